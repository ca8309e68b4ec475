//! Reading and writing files: PNG/JPEG frames and patterns, PFM depth maps
//! (`conventions.md`: grayscale `Pf`, little-endian, rows bottom-to-top, NaN where
//! there is no depth).

use crate::error::{Error, Result};
use crate::raster::Image;
use std::io::Cursor;

/// Decode PNG or JPEG bytes (any bit depth, with or without alpha) to 8-bit RGB.
/// Anything else is refused with [`Error::ImageDecode`] naming the problem.
pub fn decode_rgb8(bytes: &[u8]) -> Result<Image<[u8; 3]>> {
    let reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| Error::ImageDecode(e.to_string()))?;
    if reader.format().is_none() {
        return Err(Error::ImageDecode(
            "unknown format (PNG and JPEG are supported)".into(),
        ));
    }
    let img = reader
        .decode()
        .map_err(|e| Error::ImageDecode(e.to_string()))?
        .into_rgb8();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let data = img.pixels().map(|p| p.0).collect();
    Image::from_vec(w, h, data)
}

/// Read a PNG or JPEG file to 8-bit RGB.
pub fn read_rgb8(path: &std::path::Path) -> Result<Image<[u8; 3]>> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode_rgb8(&bytes).map_err(|e| match e {
        Error::ImageDecode(m) => Error::ImageDecode(format!("{}: {m}", path.display())),
        other => other,
    })
}

/// Encode an 8-bit RGB image as PNG bytes.
pub fn encode_png(img: &Image<[u8; 3]>) -> Result<Vec<u8>> {
    let flat: Vec<u8> = img.pixels().iter().flatten().copied().collect();
    let mut out = Vec::new();
    image::write_buffer_with_format(
        &mut Cursor::new(&mut out),
        &flat,
        img.width() as u32,
        img.height() as u32,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| Error::ImageDecode(format!("PNG encoding failed: {e}")))?;
    Ok(out)
}

/// Write bytes to `path`, with an error that names the path.
pub fn write_file(path: &std::path::Path, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).map_err(|e| Error::io(path, e))
}

/// Encode a single-channel float image as little-endian grayscale PFM
/// (`Pf`, scale -1.0, rows stored bottom-to-top as the format requires).
pub fn encode_pfm(img: &Image<f32>) -> Vec<u8> {
    let (w, h) = img.size();
    let mut out = format!("Pf\n{w} {h}\n-1.0\n").into_bytes();
    out.reserve(w * h * 4);
    for v in (0..h).rev() {
        for &x in img.row(v) {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out
}

/// Decode a grayscale PFM (`Pf`) of either byte order into top-to-bottom rows.
pub fn decode_pfm(bytes: &[u8]) -> Result<Image<f32>> {
    let bad = |m: &str| Error::ImageDecode(format!("PFM: {m}"));
    // Header: three whitespace-separated tokens after the magic, then one whitespace byte.
    let mut pos = 0;
    let mut tokens = Vec::new();
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos {
            return Err(bad("header is incomplete"));
        }
        tokens.push(std::str::from_utf8(&bytes[start..pos]).map_err(|_| bad("header is not text"))?);
    }
    pos += 1; // the single whitespace byte that ends the header
    if tokens[0] != "Pf" {
        return Err(bad(&format!("magic is {:?}, expected \"Pf\" (grayscale)", tokens[0])));
    }
    let w: usize = tokens[1].parse().map_err(|_| bad("width is not a number"))?;
    let h: usize = tokens[2].parse().map_err(|_| bad("height is not a number"))?;
    let scale: f32 = tokens[3].parse().map_err(|_| bad("scale is not a number"))?;
    if w == 0 || h == 0 || scale == 0.0 || !scale.is_finite() {
        return Err(bad("size or scale is zero"));
    }
    let need = w.checked_mul(h).and_then(|n| n.checked_mul(4)).ok_or_else(|| bad("size overflows"))?;
    let body = bytes.get(pos..pos + need).ok_or_else(|| bad("data is shorter than the header says"))?;
    let little = scale < 0.0;
    let mut img = Image::new(w, h, 0f32);
    for (i, c) in body.chunks_exact(4).enumerate() {
        let b = [c[0], c[1], c[2], c[3]];
        let x = if little { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) };
        let (u, v_file) = (i % w, i / w);
        *img.get_mut(u, h - 1 - v_file) = x;
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pfm_round_trip_keeps_nan_and_row_order() {
        let mut img = Image::new(3, 2, 0f32);
        *img.get_mut(0, 0) = 1.5;
        *img.get_mut(2, 1) = f32::NAN;
        let bytes = encode_pfm(&img);
        assert!(bytes.starts_with(b"Pf\n3 2\n-1.0\n"));
        // The first stored row is the bottom one.
        let first = f32::from_le_bytes(bytes[12..16].try_into().unwrap());
        assert_eq!(first, 0.0);
        let back = decode_pfm(&bytes).unwrap();
        assert_eq!(back.get(0, 0), 1.5);
        assert!(back.get(2, 1).is_nan());
    }

    #[test]
    fn garbage_is_not_an_image() {
        assert!(matches!(decode_rgb8(b"hello"), Err(Error::ImageDecode(_))));
        assert!(decode_pfm(b"P6\n1 1\n255\n").is_err());
        assert!(decode_pfm(b"Pf\n2 2\n-1.0\n\0\0").is_err());
    }
}
