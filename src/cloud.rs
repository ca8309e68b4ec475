//! Point clouds as flat arrays, and their PLY encoding (`conventions.md`):
//! `binary_little_endian 1.0` by default, ASCII on request, with `float x, y, z`
//! (mm, camera frame), `uchar red, green, blue`, the camera pixel `float u, v` the point
//! came from, and `uchar family`, a bit mask of the stripe families that measured it.
//!
//! A [`Cloud`] keeps one array per property rather than one struct per point: the
//! scanner refills the same arrays every frame (no allocation once they have grown), and
//! the web page's viewer takes each array as it is, copied once into JavaScript.

use crate::error::{Error, Result};

/// A point cloud as parallel flat arrays; point `i` is `positions[3i..3i+3]`,
/// `colors[3i..3i+3]`, `pixels[2i..2i+2]` and `families[i]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cloud {
    /// Positions `x, y, z` per point, mm, camera frame (x right, y down, z forward).
    pub positions: Vec<f32>,
    /// The captured colour at the point's pixel, `r, g, b` (8-bit, as the camera gave it).
    pub colors: Vec<u8>,
    /// The camera pixel `u, v` each point came from.
    pub pixels: Vec<f32>,
    /// Per point, bit k is set when stripe family k contributed to it.
    pub families: Vec<u8>,
}

impl Cloud {
    /// Wrap parallel arrays; fails, naming the lengths, when they disagree.
    pub fn from_parts(positions: Vec<f32>, colors: Vec<u8>, pixels: Vec<f32>, families: Vec<u8>) -> Result<Cloud> {
        let n = families.len();
        if positions.len() != 3 * n || colors.len() != 3 * n || pixels.len() != 2 * n {
            return Err(Error::Setting {
                name: "cloud",
                problem: format!(
                    "arrays disagree: {n} family masks, {} position, {} colour and {} pixel values (expected {}, {} and {})",
                    positions.len(),
                    colors.len(),
                    pixels.len(),
                    3 * n,
                    3 * n,
                    2 * n
                ),
            });
        }
        Ok(Cloud { positions, colors, pixels, families })
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.families.len()
    }

    /// True when the cloud has no points.
    pub fn is_empty(&self) -> bool {
        self.families.is_empty()
    }

    /// Remove every point, keeping the arrays' capacity.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.colors.clear();
        self.pixels.clear();
        self.families.clear();
    }

    /// Append one point.
    pub fn push(&mut self, position: [f32; 3], color: [u8; 3], pixel: [f32; 2], families: u8) {
        self.positions.extend_from_slice(&position);
        self.colors.extend_from_slice(&color);
        self.pixels.extend_from_slice(&pixel);
        self.families.push(families);
    }

    /// Point `i`'s position, mm.
    pub fn position(&self, i: usize) -> [f32; 3] {
        [self.positions[3 * i], self.positions[3 * i + 1], self.positions[3 * i + 2]]
    }
}

/// Encode a cloud as a PLY file.
///
/// ```
/// use stripelight::cloud::{encode_ply, Cloud};
/// let mut cloud = Cloud::default();
/// cloud.push([1.0, 2.0, 750.0], [255, 0, 0], [10.0, 20.0], 1);
/// let text = String::from_utf8(encode_ply(&cloud, true)).unwrap();
/// assert!(text.contains("element vertex 1"));
/// assert!(text.ends_with("1 2 750 255 0 0 10 20 1\n"));
/// ```
pub fn encode_ply(cloud: &Cloud, ascii: bool) -> Vec<u8> {
    let format = if ascii { "ascii" } else { "binary_little_endian" };
    let n = cloud.len();
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment stripelight point cloud, mm, camera frame\n\
         element vertex {n}\n\
         property float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         property float u\nproperty float v\nproperty uchar family\nend_header\n"
    )
    .into_bytes();
    let points = cloud
        .positions
        .chunks_exact(3)
        .zip(cloud.colors.chunks_exact(3))
        .zip(cloud.pixels.chunks_exact(2))
        .zip(&cloud.families);
    if ascii {
        use std::fmt::Write;
        let mut text = String::with_capacity(n * 48);
        for (((p, c), uv), fam) in points {
            // Writing to a String cannot fail.
            let _ = writeln!(text, "{} {} {} {} {} {} {} {} {fam}", p[0], p[1], p[2], c[0], c[1], c[2], uv[0], uv[1]);
        }
        out.extend_from_slice(text.as_bytes());
    } else {
        out.reserve(n * 24);
        for (((p, c), uv), &fam) in points {
            for x in p {
                out.extend_from_slice(&x.to_le_bytes());
            }
            out.extend_from_slice(c);
            for x in uv {
                out.extend_from_slice(&x.to_le_bytes());
            }
            out.push(fam);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binary_layout_is_24_bytes_a_point() {
        let mut cloud = Cloud::default();
        for _ in 0..2 {
            cloud.push([1.5, -2.0, 700.0], [1, 2, 3], [4.0, 5.0], 3);
        }
        let bytes = encode_ply(&cloud, false);
        let header_end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        assert_eq!(bytes.len() - header_end, 2 * 24);
        let body = &bytes[header_end..];
        assert_eq!(f32::from_le_bytes(body[8..12].try_into().unwrap()), 700.0);
        assert_eq!(&body[12..15], &[1, 2, 3]);
        assert_eq!(body[23], 3);
    }

    #[test]
    fn disagreeing_arrays_are_refused_with_their_lengths() {
        let e = Cloud::from_parts(vec![0.0; 3], vec![0; 3], vec![0.0; 2], vec![1, 1]).unwrap_err().to_string();
        assert!(e.contains("2 family masks") && e.contains("expected 6, 6 and 4"), "{e}");
        assert_eq!(Cloud::from_parts(vec![0.0; 6], vec![0; 6], vec![0.0; 4], vec![1, 1]).unwrap().len(), 2);
    }
}
