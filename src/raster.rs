//! A minimal row-major image container shared by every stage.
//!
//! Pixel (u, v) is column u, row v; the centre of the top-left pixel is (0, 0)
//! (`conventions.md`). Colour images used inside the pipeline hold linear floats in
//! 0..=1 per channel unless a function says otherwise.

use crate::error::{Error, Result};
use wide::f32x4;

/// A `width` x `height` image of `T`, stored row by row.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Image<T> {
    width: usize,
    height: usize,
    data: Vec<T>,
}

/// Three linear colour channels per pixel.
pub type Rgb = [f32; 3];

/// 8-bit camera value from which a channel counts as clipped (saturated). A little
/// below 255 because webcams' tone curves and JPEG ringing rarely reach 255 exactly.
/// The page's exposure meter (`www/camera.js`) uses the same level.
pub const SATURATED: u8 = 250;

/// `src` reduced by `factor` in each direction, each output pixel the rounded mean of a
/// `factor` x `factor` block (a box filter; the last columns and rows that do not fill a
/// block are left out), written into `dst` (resized to fit).
pub fn downsample_box_into(src: &Image<[u8; 3]>, factor: usize, dst: &mut Image<[u8; 3]>) {
    let factor = factor.max(1);
    let (w, h) = (src.width() / factor, src.height() / factor);
    if dst.size() != (w, h) {
        *dst = Image::new(w, h, [0; 3]);
    }
    let (sw, n) = (src.width(), (factor * factor) as u32);
    let pixels = src.pixels();
    for (y, row) in dst.pixels_mut().chunks_mut(w.max(1)).enumerate() {
        for (x, out) in row.iter_mut().enumerate() {
            let mut sum = [0u32; 3];
            for dy in 0..factor {
                let start = (y * factor + dy) * sw + x * factor;
                for p in &pixels[start..start + factor] {
                    for c in 0..3 {
                        sum[c] += p[c] as u32;
                    }
                }
            }
            *out = sum.map(|v| ((v + n / 2) / n) as u8);
        }
    }
}

/// The table from 8-bit camera values to linear light in 0..=1 through a power law
/// `gamma`: `linear = (value / 255)^gamma` (2.2 for the simulator's camera and most
/// webcams; 1.0 keeps values as they are).
pub fn gamma_lut(gamma: f32) -> [f32; 256] {
    let mut lut = [0f32; 256];
    for (i, l) in lut.iter_mut().enumerate() {
        *l = (i as f32 / 255.0).powf(gamma);
    }
    lut
}

impl<T: Clone> Image<T> {
    /// An image filled with `value`.
    ///
    /// ```
    /// let img = stripelight::Image::new(4, 3, 0.5f32);
    /// assert_eq!(img.get(3, 2), 0.5);
    /// ```
    pub fn new(width: usize, height: usize, value: T) -> Self {
        Image {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// Fill every pixel with `value` (no allocation).
    pub fn fill(&mut self, value: T) {
        self.data.iter_mut().for_each(|p| *p = value.clone());
    }
}

impl<T> AsRef<[T]> for Image<T> {
    fn as_ref(&self) -> &[T] {
        &self.data
    }
}

impl<T: Copy> Image<T> {
    /// The pixel at column `u`, row `v`. Panics when out of range (a programming error).
    #[inline]
    pub fn get(&self, u: usize, v: usize) -> T {
        self.data[v * self.width + u]
    }
}

impl<T> Image<T> {
    /// Wrap a row-major buffer; fails when its length is not `width * height`.
    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Result<Self> {
        if data.len() != width * height {
            return Err(Error::BufferLength { size: (width, height), per_pixel: 1, got: data.len() });
        }
        Ok(Image {
            width,
            height,
            data,
        })
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }

    /// (width, height).
    #[inline]
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Mutable access to the pixel at column `u`, row `v`.
    #[inline]
    pub fn get_mut(&mut self, u: usize, v: usize) -> &mut T {
        &mut self.data[v * self.width + u]
    }

    /// All pixels, row-major.
    #[inline]
    pub fn pixels(&self) -> &[T] {
        &self.data
    }

    /// All pixels, row-major, mutable.
    #[inline]
    pub fn pixels_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Row `v`.
    #[inline]
    pub fn row(&self, v: usize) -> &[T] {
        &self.data[v * self.width..(v + 1) * self.width]
    }

    /// The buffer, consuming the image.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }

    /// A new image of the same size with `f` applied to every pixel.
    pub fn map<U>(&self, f: impl FnMut(&T) -> U) -> Image<U> {
        Image {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(f).collect(),
        }
    }

    /// Fails with [`Error::ImageSize`] unless the image is `width` x `height`.
    pub fn expect_size(&self, width: usize, height: usize) -> Result<()> {
        if (self.width, self.height) == (width, height) {
            Ok(())
        } else {
            Err(Error::ImageSize {
                expected: (width, height),
                got: (self.width, self.height),
            })
        }
    }
}

/// 8-bit sRGB-ish camera values to linear floats in 0..=1 through a power law
/// `gamma` (2.2 for the simulator's camera and most webcams; 1.0 keeps values as they are).
pub fn rgb8_to_linear(src: &Image<[u8; 3]>, gamma: f32, dst: &mut Image<Rgb>) {
    rgb8_to_linear_lut(src, &gamma_lut(gamma), dst);
}

/// [`rgb8_to_linear`] with a table from [`gamma_lut`] made once (the per-frame form).
pub fn rgb8_to_linear_lut(src: &Image<[u8; 3]>, lut: &[f32; 256], dst: &mut Image<Rgb>) {
    debug_assert_eq!(src.size(), dst.size());
    rgb8_pixels_to_linear(src.pixels(), lut, dst.pixels_mut());
}

/// [`rgb8_to_linear_lut`] of a run of pixels (a part of a frame).
pub fn rgb8_pixels_to_linear(src: &[[u8; 3]], lut: &[f32; 256], dst: &mut [Rgb]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = [lut[s[0] as usize], lut[s[1] as usize], lut[s[2] as usize]];
    }
}

/// Linear floats to 8-bit values with the inverse of `gamma`, clamped to 0..=255.
pub fn linear_to_rgb8(src: &Image<Rgb>, gamma: f32) -> Image<[u8; 3]> {
    let inv = 1.0 / gamma;
    src.map(|p| p.map(|c| (c.clamp(0.0, 1.0).powf(inv) * 255.0).round() as u8))
}

/// Interleaved RGBA bytes (a canvas `ImageData`) to an RGB image.
pub fn from_rgba8(width: usize, height: usize, rgba: &[u8]) -> Result<Image<[u8; 3]>> {
    let mut out = Image::new(width, height, [0; 3]);
    rgba8_into(rgba, &mut out)?;
    Ok(out)
}

/// [`from_rgba8`] into an image of the right size (the per-frame form): fails when
/// `rgba` does not hold exactly 4 bytes for each of `dst`'s pixels.
pub fn rgba8_into(rgba: &[u8], dst: &mut Image<[u8; 3]>) -> Result<()> {
    let (width, height) = dst.size();
    if rgba.len() != width * height * 4 {
        return Err(Error::BufferLength { size: (width, height), per_pixel: 4, got: rgba.len() });
    }
    for (d, s) in dst.pixels_mut().iter_mut().zip(rgba.chunks_exact(4)) {
        *d = [s[0], s[1], s[2]];
    }
    Ok(())
}

/// An RGB image as interleaved RGBA bytes with alpha 255 (what a canvas shows).
pub fn to_rgba8(src: &Image<[u8; 3]>) -> Vec<u8> {
    let mut out = Vec::with_capacity(src.pixels().len() * 4);
    for p in src.pixels() {
        out.extend_from_slice(&[p[0], p[1], p[2], 255]);
    }
    out
}

/// JFIF luma of gamma-encoded R, G, B (levels in, levels out).
#[inline]
pub fn luma([r, g, b]: [f32; 3]) -> f32 {
    0.299 * r + 0.587 * g + 0.114 * b
}

/// JFIF's full-range BT.601 YCbCr (ITU-T T.871) of an 8-bit RGB pixel: the transform
/// JPEG files and most webcam streams use. Cb and Cr are centred on 128.
pub fn to_ycbcr(p: [u8; 3]) -> [f32; 3] {
    let [r, g, b] = p.map(|x| x as f32);
    [
        luma([r, g, b]),
        128.0 - 0.168_736 * r - 0.331_264 * g + 0.5 * b,
        128.0 + 0.5 * r - 0.418_688 * g - 0.081_312 * b,
    ]
}

/// The inverse of [`to_ycbcr`], rounded and clamped to 8 bits.
#[inline]
pub fn from_ycbcr(y: f32, cb: f32, cr: f32) -> [u8; 3] {
    let (cb, cr) = (cb - 128.0, cr - 128.0);
    let rgb = [y + 1.402 * cr, y - 0.344_136 * cb - 0.714_136 * cr, y + 1.772 * cb];
    // Clamped, then rounded half up by truncation: the same as rounding first (but
    // within a float's step of a half), without `round` (a library call in
    // WebAssembly).
    rgb.map(|x| (x.clamp(0.0, 255.0) + 0.5) as u8)
}

/// How a frame's colour was sampled: per axis, whether the chroma comes in pairs of
/// pixels that share one value (as a 4:2:0 or 4:2:2 stream shows it after a decoder
/// that repeats each chroma sample instead of interpolating). Pairs start at even
/// coordinates, as in every JPEG and YUV layout.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ChromaPairs {
    /// Columns 2k and 2k+1 share their chroma.
    pub horizontal: bool,
    /// Rows 2k and 2k+1 share their chroma.
    pub vertical: bool,
}

/// A change of chroma between neighbouring pixels (|ΔCb| + |ΔCr|, 8-bit levels) at
/// least this large is a colour edge: stripe boundaries change it by 40 to 200 on the
/// simulator's scenes; JPEG's ringing at quality 80 rarely reaches it.
const EDGE_CHROMA_CHANGE: f32 = 16.0;

/// Repeated chroma counts as found along an axis when colour edges fall inside pixel
/// pairs less than this share as often as between pairs. Full-resolution colour gives
/// about 1, and 0.6 to 1 after JPEG at quality 80; repeated 4:2:0 chroma gives 0 as
/// decoded and below 0.1 after JPEG at quality 80 (measured on the simulator's scenes;
/// the tests check both sides).
const PAIR_RATIO: f32 = 0.3;

/// ... and only when at least this many colour edges were seen between pairs along
/// the axis: fewer, and the frame has too little colour detail to tell.
const PAIR_MIN_EDGES: usize = 100;

/// Rows (for the horizontal test) or columns (for the vertical one) sampled by
/// [`detect_chroma_pairs`]: one in this many.
const PAIR_SAMPLE_STEP: usize = 4;

/// JPEG's block size: a change between blocks may be the codec's own step, so pairs
/// straddling a block edge are left out of [`detect_chroma_pairs`]'s count.
const JPEG_BLOCK: usize = 8;

impl ChromaPairs {
    /// The usual name of the sampling: "4:4:4" (none), "4:2:2", "4:4:0" or "4:2:0".
    pub fn name(self) -> &'static str {
        match (self.horizontal, self.vertical) {
            (false, false) => "4:4:4",
            (true, false) => "4:2:2",
            (false, true) => "4:4:0",
            (true, true) => "4:2:0",
        }
    }
}

/// Whether `frame`'s chroma comes in repeated pairs along each axis: counts the colour
/// edges (`EDGE_CHROMA_CHANGE`) between the two pixels of a pair and between
/// neighbouring pairs (not across JPEG blocks), on one row (column) in
/// `PAIR_SAMPLE_STEP`.
///
/// ```
/// use stripelight::raster::{detect_chroma_pairs, ChromaPairs};
/// use stripelight::Image;
/// // Colour changes every 2 columns, starting at even ones: repeated pairs across.
/// let img = Image::from_vec(128, 16, (0..2048).map(|i| if (i % 128) / 2 % 2 == 0 { [200, 40, 40] } else { [40, 40, 200] }).collect()).unwrap();
/// assert_eq!(detect_chroma_pairs(&img), ChromaPairs { horizontal: true, vertical: false });
/// ```
pub fn detect_chroma_pairs(frame: &Image<[u8; 3]>) -> ChromaPairs {
    let (w, h) = frame.size();
    let chroma = |u: usize, v: usize| {
        let c = to_ycbcr(frame.get(u, v));
        [c[1], c[2]]
    };
    let edge = |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).abs() + (a[1] - b[1]).abs() >= EDGE_CHROMA_CHANGE;
    // Along a line of `len` pixels whose chroma `at(t)` gives: colour edges inside
    // pairs, and between pairs within a JPEG block.
    let count = |len: usize, at: &dyn Fn(usize) -> [f32; 2], counts: &mut [usize; 2]| {
        if len == 0 {
            return;
        }
        let mut prev = at(0);
        for t in 1..len {
            let c = at(t);
            if t % 2 == 1 {
                counts[0] += edge(prev, c) as usize;
            } else if t % JPEG_BLOCK != 0 {
                counts[1] += edge(prev, c) as usize;
            }
            prev = c;
        }
    };
    let decide = |[inside, across]: [usize; 2]| {
        // Inside pairs there are 4 chances per JPEG block for 3 between pairs.
        across >= PAIR_MIN_EDGES && (inside as f32 * 3.0 / 4.0) < PAIR_RATIO * across as f32
    };
    let mut rows = [0; 2];
    for v in (0..h).step_by(PAIR_SAMPLE_STEP) {
        count(w, &|u| chroma(u, v), &mut rows);
    }
    let mut columns = [0; 2];
    for u in (0..w).step_by(PAIR_SAMPLE_STEP) {
        count(h, &|v| chroma(u, v), &mut columns);
    }
    ChromaPairs { horizontal: decide(rows), vertical: decide(columns) }
}

/// Interpolate repeated chroma back to one value per pixel, keeping every pixel's own
/// luma: each pair's (block's) mean Cb and Cr is taken to sit at its centre, and a
/// pixel gets 3/4 of its own block's value and 1/4 of the neighbouring block's on its
/// side, along each axis in `pairs` (bilinear interpolation between block centres, the
/// "fancy upsampling" of JPEG decoders; the frame's edges repeat their last block).
///
/// Why: a decoder that repeats each chroma sample moves every colour edge to an even
/// pixel boundary, up to a pixel from where the stripe edge is; the stripe boundaries
/// found from such colour wander by that much (on the simulator's plane, 4 % of one
/// family's depths were more than 2 mm off). Interpolated chroma puts the edge back
/// within a fifth of a pixel on average. `blocks` is scratch space, resized here.
pub fn interpolate_chroma_into(
    frame: &Image<[u8; 3]>,
    pairs: ChromaPairs,
    blocks: &mut Vec<[f32; 2]>,
    out: &mut Image<[u8; 3]>,
) {
    let (w, h) = frame.size();
    debug_assert_eq!(out.size(), (w, h));
    if w == 0 || h == 0 {
        return;
    }
    let (sx, sy) = (1 + pairs.horizontal as usize, 1 + pairs.vertical as usize);
    let (bw, bh) = (w.div_ceil(sx), h.div_ceil(sy));
    blocks.clear();
    // The blocks, then one row of them mixed down the columns, then one row of pixels'
    // chroma mixed across too.
    blocks.resize(bw * bh + bw + w, [0.0; 2]);
    let (blocks, rest) = blocks.split_at_mut(bw * bh);
    let (column_mix, mixed) = rest.split_at_mut(bw);
    // Each block's sum, a row of pixels at a time into the row of blocks (a block adds
    // its pixels in the same order as one by one: down its rows, along each row), then
    // its mean.
    let pixels = frame.pixels();
    for (by, block_row) in blocks.chunks_exact_mut(bw).enumerate() {
        let rows = by * sy..((by + 1) * sy).min(h);
        let n_rows = rows.len();
        for v in rows {
            for (sum, run) in block_row.iter_mut().zip(pixels[v * w..][..w].chunks(sx)) {
                for &p in run {
                    let c = to_ycbcr(p);
                    sum[0] += c[1];
                    sum[1] += c[2];
                }
            }
        }
        for (bx, sum) in block_row.iter_mut().enumerate() {
            let n = (n_rows * (((bx + 1) * sx).min(w) - bx * sx)) as f32;
            *sum = [sum[0] / n, sum[1] / n];
        }
    }
    // The neighbouring block along an axis of block size `s`, for a pixel at `p` in
    // block `b` of `count`: on the side of the pixel, clamped to the frame.
    let neighbour = |p: usize, b: usize, s: usize, count: usize| {
        if s == 1 {
            b
        } else if p % 2 == 0 {
            b.saturating_sub(1)
        } else {
            (b + 1).min(count - 1)
        }
    };
    // Weights of the own and the neighbouring block along an axis.
    let weights = |s: usize| if s == 1 { (1.0, 0.0) } else { (0.75f32, 0.25f32) };
    let ((ox, nx), (oy, ny)) = (weights(sx), weights(sy));
    // Each row: the blocks' chroma mixed down the columns once (after the blocks, in
    // the same scratch), then across for each pixel (after that): with pairs across, a
    // pair's left pixel takes the block on its left and its right pixel the block on
    // its right.
    for ((v, row), out_row) in pixels.chunks_exact(w).enumerate().zip(out.pixels_mut().chunks_exact_mut(w)) {
        let (own, next) = (&blocks[v / sy * bw..][..bw], &blocks[neighbour(v, v / sy, sy, bh) * bw..][..bw]);
        for ((m, a), c) in column_mix.iter_mut().zip(own).zip(next) {
            *m = [oy * a[0] + ny * c[0], oy * a[1] + ny * c[1]];
        }
        let across = |a: [f32; 2], b: [f32; 2]| [ox * a[0] + nx * b[0], ox * a[1] + nx * b[1]];
        if sx == 1 {
            for (m, &a) in mixed.iter_mut().zip(column_mix.iter()) {
                *m = across(a, a);
            }
        } else {
            for (bx, pair) in mixed.chunks_mut(2).enumerate() {
                let a = column_mix[bx];
                let sides = [column_mix[bx.saturating_sub(1)], column_mix[(bx + 1).min(bw - 1)]];
                for (m, b) in pair.iter_mut().zip(sides) {
                    *m = across(a, b);
                }
            }
        }
        // Four pixels at a time: the arithmetic of `luma` and `from_ycbcr`, operation
        // for operation (the same results), with the clamped values converted by
        // truncation (in 0.5..=255.5, as `as u8` does).
        let quads = row.chunks_exact(4).zip(out_row.chunks_exact_mut(4)).zip(mixed.chunks_exact(4));
        for ((p, o), m) in quads {
            let channel = |k: usize| f32x4::new([p[0][k], p[1][k], p[2][k], p[3][k]].map(f32::from));
            let (r, g, b) = (channel(0), channel(1), channel(2));
            let y = f32x4::splat(0.299) * r + f32x4::splat(0.587) * g + f32x4::splat(0.114) * b;
            let cb = f32x4::new([m[0][0], m[1][0], m[2][0], m[3][0]]) - f32x4::splat(128.0);
            let cr = f32x4::new([m[0][1], m[1][1], m[2][1], m[3][1]]) - f32x4::splat(128.0);
            let rgb = [
                y + f32x4::splat(1.402) * cr,
                y - f32x4::splat(0.344_136) * cb - f32x4::splat(0.714_136) * cr,
                y + f32x4::splat(1.772) * cb,
            ]
            .map(|x| (x.fast_max(f32x4::splat(0.0)).fast_min(f32x4::splat(255.0)) + f32x4::splat(0.5)).fast_trunc_int().to_array());
            for (j, o) in o.iter_mut().enumerate() {
                *o = [rgb[0][j] as u8, rgb[1][j] as u8, rgb[2][j] as u8];
            }
        }
        let done = w / 4 * 4;
        for ((&p, o), m) in row[done..].iter().zip(out_row[done..].iter_mut()).zip(&mixed[done..]) {
            *o = from_ycbcr(luma(p.map(f32::from)), m[0], m[1]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 4:2:0 chroma (one value per 2 x 2 block) is interpolated bilinearly between
    /// block centres, each pixel keeping its own luma, and the frame's edges repeat
    /// their last block.
    #[test]
    fn repeated_chroma_is_interpolated_between_block_centres() {
        // 6 x 4 pixels: 3 x 2 blocks, each its own colour, luma varying per pixel.
        let block_colour = |bx: usize, by: usize| [[200u8, 60, 40], [40, 180, 60], [60, 40, 200]][(bx + by) % 3];
        let (w, h) = (6, 4);
        let mut frame = Image::new(w, h, [0u8; 3]);
        for v in 0..h {
            for u in 0..w {
                let c = to_ycbcr(block_colour(u / 2, v / 2));
                let luma = c[0] + (u as f32 - 2.5) * 3.0 + (v as f32 - 1.5) * 2.0;
                *frame.get_mut(u, v) = from_ycbcr(luma, c[1], c[2]);
            }
        }
        let pairs = ChromaPairs { horizontal: true, vertical: true };
        let (mut blocks, mut out) = (Vec::new(), Image::new(w, h, [0u8; 3]));
        interpolate_chroma_into(&frame, pairs, &mut blocks, &mut out);
        let chroma = |p: [u8; 3]| {
            let c = to_ycbcr(p);
            [c[1], c[2]]
        };
        let block = |bx: usize, by: usize| {
            let mut sum = [0f32; 2];
            for (u, v) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let c = chroma(frame.get(2 * bx + u, 2 * by + v));
                sum = [sum[0] + c[0] / 4.0, sum[1] + c[1] / 4.0];
            }
            sum
        };
        // Pixel (3, 1): block (1, 0), right half and lower half, so its neighbours are
        // block (2, 0) across and block (1, 1) down.
        let (a, b, c, d) = (block(1, 0), block(2, 0), block(1, 1), block(2, 1));
        let expected = [0, 1].map(|k| 0.75 * (0.75 * a[k] + 0.25 * b[k]) + 0.25 * (0.75 * c[k] + 0.25 * d[k]));
        let got = chroma(out.get(3, 1));
        for k in 0..2 {
            assert!((got[k] - expected[k]).abs() < 1.5, "pixel (3, 1) chroma {got:?}, expected {expected:?}");
        }
        // Pixel (0, 0): the frame's corner, its own block on both sides.
        let (got, own) = (chroma(out.get(0, 0)), block(0, 0));
        for k in 0..2 {
            assert!((got[k] - own[k]).abs() < 1.5, "corner chroma {got:?}, its block's {own:?}");
        }
        // Every pixel keeps its luma (within the 8-bit rounding of the three channels).
        for (p, q) in frame.pixels().iter().zip(out.pixels()) {
            assert!((to_ycbcr(*p)[0] - to_ycbcr(*q)[0]).abs() < 1.0, "luma of {p:?} became that of {q:?}");
        }
    }
}
