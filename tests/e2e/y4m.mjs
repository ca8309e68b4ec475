// Writes an RGBA frame as a YUV4MPEG2 (4:2:0) file for Chromium's fake camera
// (--use-file-for-fake-video-capture). RGB to YCbCr with BT.601 coefficients in the
// limited ("video") range, which is how Chromium interprets I420 frames from a y4m file.

/** BT.601 luma weights. */
const KR = 0.299, KB = 0.114, KG = 1 - KR - KB;

function clampByte(v) {
  return Math.max(0, Math.min(255, Math.round(v)));
}

/**
 * @param {{width: number, height: number, rgba: Uint8Array}} frame even width and height
 * @param {number} frames how many copies of the frame the file holds (Chromium loops it)
 * @returns {Buffer}
 */
export function encodeY4m({ width, height, rgba }, frames = 1) {
  if (width % 2 || height % 2) throw new Error(`4:2:0 needs an even size, got ${width}x${height}`);
  const y = new Uint8Array(width * height);
  const cw = width / 2, ch = height / 2;
  const cb = new Uint8Array(cw * ch);
  const cr = new Uint8Array(cw * ch);
  const cbSum = new Float64Array(cw * ch);
  const crSum = new Float64Array(cw * ch);
  for (let v = 0; v < height; v++) {
    for (let u = 0; u < width; u++) {
      const i = v * width + u;
      const r = rgba[4 * i] / 255, g = rgba[4 * i + 1] / 255, b = rgba[4 * i + 2] / 255;
      const luma = KR * r + KG * g + KB * b;
      y[i] = clampByte(16 + 219 * luma);
      // Chroma of each 2x2 block is the mean of its four pixels' chroma.
      const c = (v >> 1) * cw + (u >> 1);
      cbSum[c] += (b - luma) / (2 * (1 - KB));
      crSum[c] += (r - luma) / (2 * (1 - KR));
    }
  }
  for (let c = 0; c < cw * ch; c++) {
    cb[c] = clampByte(128 + 224 * (cbSum[c] / 4));
    cr[c] = clampByte(128 + 224 * (crSum[c] / 4));
  }
  const header = Buffer.from(`YUV4MPEG2 W${width} H${height} F30:1 Ip A1:1 C420jpeg\n`, 'latin1');
  const frameHeader = Buffer.from('FRAME\n', 'latin1');
  const parts = [header];
  for (let k = 0; k < frames; k++) parts.push(frameHeader, y, cb, cr);
  return Buffer.concat(parts);
}

/**
 * The first frame of a y4m file written by encodeY4m back to RGBA, the way a 4:2:0
 * camera frame reaches the page (each chroma sample shared by its 2x2 block). Scanning
 * this shows what the chroma subsampling alone does to a frame.
 */
export function decodeY4m(buffer) {
  const header = buffer.toString('latin1', 0, buffer.indexOf(0x0a));
  const width = Number(/ W(\d+)/.exec(header)?.[1]);
  const height = Number(/ H(\d+)/.exec(header)?.[1]);
  if (!width || !height || !/C420/.test(header)) throw new Error(`not a 4:2:0 y4m header: ${header}`);
  const start = buffer.indexOf('FRAME\n', header.length) + 6;
  const cw = width / 2;
  const y = buffer.subarray(start, start + width * height);
  const cb = buffer.subarray(start + width * height, start + (width * height * 5) / 4);
  const cr = buffer.subarray(start + (width * height * 5) / 4, start + (width * height * 3) / 2);
  const rgba = new Uint8Array(width * height * 4);
  for (let v = 0; v < height; v++) {
    for (let u = 0; u < width; u++) {
      const i = v * width + u;
      const c = (v >> 1) * cw + (u >> 1);
      const luma = (y[i] - 16) / 219;
      const pb = (cb[c] - 128) / 224;
      const pr = (cr[c] - 128) / 224;
      const r = luma + 2 * (1 - KR) * pr;
      const b = luma + 2 * (1 - KB) * pb;
      const g = (luma - KR * r - KB * b) / KG;
      rgba.set([clampByte(255 * r), clampByte(255 * g), clampByte(255 * b), 255], 4 * i);
    }
  }
  return { width, height, rgba };
}
