// The largest frame the page decodes, and the size of a PNG or JPEG read from its header
// alone, so that a frame too large is refused before any of it is decoded.
//
// Why a limit: a decoding worker's WebAssembly memory (at most 4 GiB, and never given
// back) holds the frame and the scanner's per-pixel buffers, many times the frame's size.
// Measured in Chromium with `loggrad`: a 4096x3072 frame scans in about 2.5 GB (16 s on
// the 2-core machine), an 8000x6000 one runs out of memory. The command line has no such
// limit.

/** 12 megapixels as camera makers count them: 4000x3000 and 4032x3024 both fit. */
export const MAX_FRAME_PIXELS = 4096 * 3072;

/** Why a `width` x `height` frame is refused, or '' when it is not. */
export function frameSizeProblem(width, height) {
  const pixels = width * height;
  if (pixels <= MAX_FRAME_PIXELS) return '';
  return (
    `the image is ${width}x${height} = ${pixels.toLocaleString('en')} pixels, more than the 12 megapixels ` +
    `(4096x3072 = ${MAX_FRAME_PIXELS.toLocaleString('en')} pixels) the page decodes: scale it down, ` +
    'or scan it with the command line (stripelight scan), which has no such limit'
  );
}

/**
 * `{width, height}` from a PNG's IHDR or a JPEG's start-of-frame segment, or null when the
 * bytes are neither (the decoder then says what they are).
 * @param {Uint8Array} bytes
 */
export function imageSize(bytes) {
  return pngSize(bytes) ?? jpegSize(bytes);
}

const PNG_SIGNATURE = [0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a];

function pngSize(b) {
  // Signature, then the first chunk, which must be IHDR: length (4), type (4), width, height.
  if (b.length < 24 || PNG_SIGNATURE.some((v, i) => b[i] !== v)) return null;
  if (String.fromCharCode(b[12], b[13], b[14], b[15]) !== 'IHDR') return null;
  return { width: u32be(b, 16), height: u32be(b, 20) };
}

function jpegSize(b) {
  if (b.length < 4 || b[0] !== 0xff || b[1] !== 0xd8) return null;
  let i = 2;
  while (i + 3 < b.length) {
    if (b[i] !== 0xff) return null; // not at a marker: malformed
    const marker = b[i + 1];
    if (marker === 0xff) {
      i++; // fill byte
      continue;
    }
    // Markers without a length: TEM, RST0-7, SOI, EOI.
    if (marker === 0x01 || (marker >= 0xd0 && marker <= 0xd9)) {
      i += 2;
      continue;
    }
    const length = (b[i + 2] << 8) | b[i + 3];
    // Start of frame, any coding (C0-CF except DHT C4, JPG C8, DAC CC): precision (1),
    // height (2), width (2). A height of 0 (set later by a DNL segment) is left to the decoder.
    if (marker >= 0xc0 && marker <= 0xcf && marker !== 0xc4 && marker !== 0xc8 && marker !== 0xcc) {
      if (i + 8 >= b.length) return null;
      const height = (b[i + 5] << 8) | b[i + 6];
      const width = (b[i + 7] << 8) | b[i + 8];
      return height ? { width, height } : null;
    }
    if (marker === 0xda) return null; // scan data before any frame header
    i += 2 + length;
  }
  return null;
}

function u32be(b, i) {
  return ((b[i] << 24) >>> 0) + (b[i + 1] << 16) + (b[i + 2] << 8) + b[i + 3];
}
