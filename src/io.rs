//! Reading and writing files: PNG/JPEG frames and patterns, PFM depth maps
//! (`conventions.md`: grayscale `Pf`, little-endian, rows bottom-to-top, NaN where
//! there is no depth).

use crate::error::{Error, Result};
use crate::raster::Image;
use std::ffi::OsString;
use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

/// Decode PNG or JPEG bytes (any bit depth, with or without alpha) to 8-bit RGB.
/// Anything else is refused with [`Error::ImageDecode`] naming the problem.
pub fn decode_rgb8(bytes: &[u8]) -> Result<Image<[u8; 3]>> {
    let reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| Error::ImageDecode(one_line(e)))?;
    if reader.format().is_none() {
        return Err(Error::ImageDecode(
            "unknown format (PNG and JPEG are supported)".into(),
        ));
    }
    let img = reader
        .decode()
        .map_err(|e| Error::ImageDecode(one_line(e)))?
        .into_rgb8();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let data = img.pixels().map(|p| p.0).collect();
    Image::from_vec(w, h, data)
}

/// A decoder's message as one line: some end in a newline or hold several lines.
fn one_line(message: impl std::fmt::Display) -> String {
    message.to_string().split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Read a PNG or JPEG file to 8-bit RGB.
pub fn read_rgb8(path: &Path) -> Result<Image<[u8; 3]>> {
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

/// Write bytes to `path` whole or not at all, with an error that names the path.
///
/// The bytes go to a temporary file beside `path` (`.NAME.tmp-PID`: the same directory,
/// so that the rename stays on one file system), which is synced to disk and only then
/// renamed over `path`. If any step fails the temporary file is removed and whatever
/// was at `path` stays as it was: an interrupted run never leaves a truncated output.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = temp_path(path).map_err(|e| Error::io(path, e))?;
    let written = write_synced(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    written.map_err(|e| {
        // Fails harmlessly when the temporary file was never created.
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

/// Where [`write_file`] puts the bytes for `path` before the rename.
fn temp_path(path: &Path) -> std::io::Result<PathBuf> {
    let Some(name) = path.file_name() else {
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"));
    };
    let mut tmp = OsString::from(".");
    tmp.push(name);
    tmp.push(format!(".tmp-{}", process_id()));
    Ok(path.with_file_name(tmp))
}

/// Create (or truncate) `path`, write `bytes` and wait until they are on disk.
fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut file = std::fs::File::create(path)?;
    file.write_all(bytes)?;
    file.sync_all()
}

/// This process's id. wasm32 has neither processes (`std::process::id` panics there)
/// nor files (the write then fails with an error naming the path).
fn process_id() -> u32 {
    if cfg!(target_arch = "wasm32") {
        0
    } else {
        std::process::id()
    }
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

/// Encode a three-channel float image as little-endian colour PFM (`PF`, scale -1.0,
/// rows bottom-to-top, channels interleaved per pixel).
pub fn encode_pfm_rgb(img: &Image<[f32; 3]>) -> Vec<u8> {
    let (w, h) = img.size();
    let mut out = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    out.reserve(w * h * 12);
    for v in (0..h).rev() {
        for px in img.row(v) {
            for x in px {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    out
}

/// Decode a grayscale PFM (`Pf`) of either byte order into top-to-bottom rows.
pub fn decode_pfm(bytes: &[u8]) -> Result<Image<f32>> {
    let (w, h, values) = decode_pfm_values(bytes, "Pf", 1)?;
    Image::from_vec(w, h, values)
}

/// Decode a colour PFM (`PF`, such as the correspondences `encode_pfm_rgb` writes) of
/// either byte order into top-to-bottom rows.
pub fn decode_pfm_rgb(bytes: &[u8]) -> Result<Image<[f32; 3]>> {
    let (w, h, values) = decode_pfm_values(bytes, "PF", 3)?;
    Image::from_vec(w, h, values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

/// The size and the values (interleaved, `channels` per pixel, top-to-bottom rows) of a
/// PFM whose magic must be `magic`.
fn decode_pfm_values(bytes: &[u8], magic: &str, channels: usize) -> Result<(usize, usize, Vec<f32>)> {
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
    if tokens[0] != magic {
        let kind = if channels == 1 { "grayscale" } else { "colour" };
        return Err(bad(&format!("magic is {:?}, expected {magic:?} ({kind})", tokens[0])));
    }
    let w: usize = tokens[1].parse().map_err(|_| bad("width is not a number"))?;
    let h: usize = tokens[2].parse().map_err(|_| bad("height is not a number"))?;
    let scale: f32 = tokens[3].parse().map_err(|_| bad("scale is not a number"))?;
    if w == 0 || h == 0 {
        return Err(bad(&format!("size {w}x{h} is empty")));
    }
    if scale == 0.0 || !scale.is_finite() {
        return Err(bad(&format!("scale {scale} is not a finite non-zero number")));
    }
    let row = w.checked_mul(channels).ok_or_else(|| bad("size overflows"))?;
    let need = row.checked_mul(h).and_then(|n| n.checked_mul(4)).ok_or_else(|| bad("size overflows"))?;
    let body = pos
        .checked_add(need)
        .and_then(|end| bytes.get(pos..end))
        .ok_or_else(|| bad("data is shorter than the header says"))?;
    let little = scale < 0.0;
    let mut values = vec![0f32; row * h];
    // The file's rows run bottom to top.
    for (file_row, data) in body.chunks_exact(row * 4).enumerate() {
        let out = &mut values[(h - 1 - file_row) * row..][..row];
        for (x, c) in out.iter_mut().zip(data.chunks_exact(4)) {
            let b = [c[0], c[1], c[2], c[3]];
            *x = if little { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) };
        }
    }
    Ok((w, h, values))
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
    fn colour_pfm_round_trip_keeps_channels_and_row_order() {
        let mut img = Image::new(3, 2, [0f32; 3]);
        *img.get_mut(0, 0) = [1.5, -2.0, f32::NAN];
        *img.get_mut(2, 1) = [7.0, 8.0, 9.0];
        let back = decode_pfm_rgb(&encode_pfm_rgb(&img)).unwrap();
        assert_eq!(back.size(), (3, 2));
        assert_eq!(back.get(0, 0)[..2], [1.5, -2.0]);
        assert!(back.get(0, 0)[2].is_nan());
        assert_eq!(back.get(2, 1), [7.0, 8.0, 9.0]);
        assert_eq!(back.get(1, 0), [0.0; 3]);
        // The one decoder does not take the other's files.
        assert!(decode_pfm(&encode_pfm_rgb(&img)).is_err());
        assert!(decode_pfm_rgb(&encode_pfm(&Image::new(3, 2, 0f32))).is_err());
    }

    /// A fresh, empty directory for one test, removed by the test when it passes.
    #[cfg(not(target_arch = "wasm32"))]
    fn scratch_dir(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("stripelight-io-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// The names in `dir`, sorted.
    #[cfg(not(target_arch = "wasm32"))]
    fn names_in(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[cfg(not(target_arch = "wasm32"))]
    #[test]
    fn write_file_leaves_exactly_the_new_bytes() {
        let dir = scratch_dir("replace");
        let out = dir.join("cloud.ply");
        write_file(&out, b"a first, longer content").unwrap();
        write_file(&out, b"second").unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), b"second");
        assert_eq!(names_in(&dir), ["cloud.ply"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(not(target_arch = "wasm32"))]
    #[test]
    fn write_file_into_a_missing_directory_names_the_path_and_leaves_nothing() {
        let dir = scratch_dir("missing");
        let out = dir.join("missing").join("depth.pfm");
        match write_file(&out, b"Pf") {
            Err(Error::Io { path, .. }) => assert_eq!(path, out.display().to_string()),
            other => panic!("expected an I/O error naming {}, got {other:?}", out.display()),
        }
        assert!(names_in(&dir).is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(not(target_arch = "wasm32"))]
    #[test]
    fn a_failed_write_keeps_what_was_there() {
        let dir = scratch_dir("failed");
        // The destination is a directory: the rename fails, the directory is untouched.
        let taken = dir.join("stages");
        std::fs::create_dir(&taken).unwrap();
        std::fs::write(taken.join("merged.png"), b"old").unwrap();
        assert!(matches!(write_file(&taken, b"new"), Err(Error::Io { .. })));
        assert_eq!(std::fs::read(taken.join("merged.png")).unwrap(), b"old");
        assert_eq!(names_in(&dir), ["stages"]);
        // An existing file whose temporary file cannot be created (a directory is in the
        // way): the old content stays.
        let out = dir.join("calib.json");
        std::fs::write(&out, b"old").unwrap();
        let blocker = temp_path(&out).unwrap();
        std::fs::create_dir(&blocker).unwrap();
        assert!(matches!(write_file(&out, b"new"), Err(Error::Io { .. })));
        assert_eq!(std::fs::read(&out).unwrap(), b"old");
        std::fs::remove_dir(&blocker).unwrap();
        assert_eq!(names_in(&dir), ["calib.json", "stages"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn garbage_is_not_an_image() {
        assert!(matches!(decode_rgb8(b"hello"), Err(Error::ImageDecode(_))));
        assert!(decode_pfm(b"P6\n1 1\n255\n").is_err());
        assert!(decode_pfm(b"Pf\n2 2\n-1.0\n\0\0").is_err());
    }
}
