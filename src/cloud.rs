//! Point clouds and their PLY encoding (`conventions.md`): `binary_little_endian 1.0`
//! by default, ASCII on request, with `float x, y, z` (mm, camera frame),
//! `uchar red, green, blue`, the camera pixel `float u, v` the point came from, and
//! `uchar family`, a bit mask of the stripe families that measured the point.

/// One measured surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudPoint {
    /// Position in the camera frame, mm (x right, y down, z forward).
    pub position: [f32; 3],
    /// The captured colour at the pixel (8-bit, as the camera gave it).
    pub color: [u8; 3],
    /// The camera pixel (u, v) the point came from.
    pub pixel: [f32; 2],
    /// Bit k is set when stripe family k contributed to the point.
    pub families: u8,
}

/// Encode points as a PLY file.
///
/// ```
/// use stripelight::cloud::{encode_ply, CloudPoint};
/// let p = CloudPoint { position: [1.0, 2.0, 750.0], color: [255, 0, 0], pixel: [10.0, 20.0], families: 1 };
/// let text = String::from_utf8(encode_ply(&[p], true)).unwrap();
/// assert!(text.contains("element vertex 1"));
/// assert!(text.ends_with("1 2 750 255 0 0 10 20 1\n"));
/// ```
pub fn encode_ply(points: &[CloudPoint], ascii: bool) -> Vec<u8> {
    let format = if ascii { "ascii" } else { "binary_little_endian" };
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment stripelight point cloud, mm, camera frame\n\
         element vertex {}\n\
         property float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         property float u\nproperty float v\nproperty uchar family\nend_header\n",
        points.len()
    )
    .into_bytes();
    if ascii {
        use std::fmt::Write;
        let mut text = String::with_capacity(points.len() * 48);
        for p in points {
            let [x, y, z] = p.position;
            let [r, g, b] = p.color;
            let [u, v] = p.pixel;
            // Writing to a String cannot fail.
            let _ = writeln!(text, "{x} {y} {z} {r} {g} {b} {u} {v} {}", p.families);
        }
        out.extend_from_slice(text.as_bytes());
    } else {
        out.reserve(points.len() * 24);
        for p in points {
            for c in p.position {
                out.extend_from_slice(&c.to_le_bytes());
            }
            out.extend_from_slice(&p.color);
            for c in p.pixel {
                out.extend_from_slice(&c.to_le_bytes());
            }
            out.push(p.families);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binary_layout_is_24_bytes_a_point() {
        let p = CloudPoint { position: [1.5, -2.0, 700.0], color: [1, 2, 3], pixel: [4.0, 5.0], families: 3 };
        let bytes = encode_ply(&[p, p], false);
        let header_end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        assert_eq!(bytes.len() - header_end, 2 * 24);
        let body = &bytes[header_end..];
        assert_eq!(f32::from_le_bytes(body[8..12].try_into().unwrap()), 700.0);
        assert_eq!(&body[12..15], &[1, 2, 3]);
        assert_eq!(body[23], 3);
    }
}
