//! A multi-shot Gray-code reference: what a careful multi-frame scanner decodes from
//! the same scene, rig and camera, as the yardstick beside every one-shot figure.
//!
//! # Frames
//!
//! The projector shows full white, black, then for the columns and for the rows each
//! bit of the binary-reflected Gray code of the pixel's index (most significant
//! first) and its inverse: 2 + 2·(10 + 10) = 42 frames on a 1024 x 768 projector.
//! Each frame is photographed through the same [`View`] and camera settings as the
//! one-shot frame, with its own sensor noise.
//!
//! # Decoding
//!
//! Per pixel and bit, `D` = (pattern − inverse), summed over the three channels in
//! linear light (the 8-bit values through the camera's gamma). A bit is *clear* when
//! `|D|` is at least [`MIN_DIFFERENCE`]; a pixel is *lit* when white − black is.
//!
//! Bits whose stripes are narrower than [`MIN_STRIPE_CAMERA_PX`] camera pixels are
//! below the camera's resolution and are not used: the finest used level `L` follows
//! from the ratio of the focal lengths (camera pixels per projector pixel at equal
//! distances). The bits above `L`, all clear, give a pixel's *coarse index* `c`
//! (`2^(L+1)` projector pixels wide); the level-`L` bit changes once in the middle of
//! every coarse interval, at projector coordinate `c·2^(L+1) + 2^L − ½` (pixel centres
//! at integers, so the edge between pixels k − 1 and k is at k − ½). Along each camera
//! line across the stripes (rows for the columns' code, columns for the rows'), a
//! sign change of the level-`L` difference between two neighbours of the same coarse
//! index is such an edge, placed where `D` crosses zero by linear interpolation. The
//! pixels between two consecutive edges of neighbouring coarse intervals, of one of the
//! two coarse indices (but for at most one lit pixel with unclear coarse bits: the
//! coarse edge between them), get their projector coordinate by linear interpolation
//! between the edges: sub-pixel, as the one-shot scanner's boundaries are.
//!
//! Column and row coordinates triangulate with the project's [`Triangulator`] (a
//! one-pixel "stripe" family per axis). Where both decode, they must agree within
//! [`outlier_threshold`] (else the pixel is dropped) and are averaged with the
//! scanner's merge weights, 1 / (dz/dq)²; where one decodes, it stands alone.

// Negated comparisons (`!(x >= t)`) are deliberate: they also catch NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::outlier_threshold;
use crate::calib::Calibration;
use crate::error::{Error, Result};
use crate::pattern::{binary_palette, Family, PatternSpec, SPEC_FORMAT, SPEC_VERSION};
use crate::raster::{gamma_lut, Image};
use crate::sim::{Scratch, SimConfig, View};
use crate::triangulate::Triangulator;

/// Least pattern-minus-inverse difference of a clear bit, in linear units of full
/// scale summed over the three channels: 4 standard deviations of that difference
/// under the simulator's default sensor noise (σ = 0.005 per channel and frame, so
/// √6 · 0.005 = 0.012 for the sum of three channel differences). A pixel whose true
/// difference is zero passes by chance with probability 6e-5 per bit.
pub const MIN_DIFFERENCE: f32 = 0.05;

/// Narrowest Gray-code stripe used, camera pixels. At the demo rig's default blur
/// (σ 0.6 px) and a pixel's own width, 1.15-pixel stripes keep about 20 % of their
/// contrast and 0.66-pixel stripes (the XGA projector's single pixels in the VGA
/// camera) under 2 %: the finest bit is noise there.
pub const MIN_STRIPE_CAMERA_PX: f64 = 1.0;

/// Offset added to the one-shot frame's noise seed for the Gray-code frames (each
/// frame then adds its index), so that no two frames share their noise.
const SEED_OFFSET: u64 = 0x6A7C_0DE0_0000;

/// The Gray-code sequence of a projector.
#[derive(Clone, Debug, PartialEq)]
pub struct GrayCode {
    width: usize,
    height: usize,
    /// Bits of the column and of the row index.
    bits: [u32; 2],
}

/// What one projector frame of the sequence shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GrayFrame {
    /// Full white.
    White,
    /// Black.
    Black,
    /// Bit `level` (0 = finest) of the Gray code of the column (`axis` 0) or row
    /// (`axis` 1) index, or its inverse.
    Bit {
        /// 0 for columns, 1 for rows.
        axis: usize,
        /// Bit level, 0 for the least significant.
        level: u32,
        /// The inverse pattern (white where the bit is 0).
        inverse: bool,
    },
}

/// Binary-reflected Gray code of `n`.
pub fn gray(n: u32) -> u32 {
    n ^ (n >> 1)
}

/// The index whose Gray code is `g`.
pub fn gray_inverse(mut g: u32) -> u32 {
    let mut n = g;
    while g > 1 {
        g >>= 1;
        n ^= g;
    }
    n
}

/// Bits needed to number `n` items.
fn bits_for(n: usize) -> u32 {
    usize::BITS - (n.max(2) - 1).leading_zeros()
}

impl GrayCode {
    /// The sequence for a `width` x `height` projector; fails on an empty projector.
    pub fn new(width: u32, height: u32) -> Result<Self> {
        if width == 0 || height == 0 || width > 1 << 15 || height > 1 << 15 {
            return Err(Error::Setting {
                name: "projector size",
                problem: format!("{width}x{height} is not in 1..=32768 on each side"),
            });
        }
        let (width, height) = (width as usize, height as usize);
        Ok(GrayCode { width, height, bits: [bits_for(width), bits_for(height)] })
    }

    /// The frames in the order they are shown: white, black, then per axis (columns,
    /// rows) each bit from the most significant, pattern then inverse.
    pub fn frames(&self) -> Vec<GrayFrame> {
        let mut out = vec![GrayFrame::White, GrayFrame::Black];
        for axis in 0..2 {
            for level in (0..self.bits[axis]).rev() {
                for inverse in [false, true] {
                    out.push(GrayFrame::Bit { axis, level, inverse });
                }
            }
        }
        out
    }

    /// The projector image of `frame` into `out` (resized to the projector).
    pub fn render_into(&self, frame: GrayFrame, out: &mut Image<[u8; 3]>) {
        if out.size() != (self.width, self.height) {
            *out = Image::new(self.width, self.height, [0; 3]);
        }
        let w = self.width;
        for (i, p) in out.pixels_mut().iter_mut().enumerate() {
            let on = match frame {
                GrayFrame::White => true,
                GrayFrame::Black => false,
                GrayFrame::Bit { axis, level, inverse } => {
                    let index = if axis == 0 { i % w } else { i / w };
                    (gray(index as u32) >> level & 1 == 1) != inverse
                }
            };
            *p = [if on { 255 } else { 0 }; 3];
        }
    }

    /// A pattern spec whose two families are the projector's columns and rows, one
    /// pixel per stripe, with the family coordinate equal to the pixel coordinate
    /// (u_p, then v_p): what [`Triangulator`] needs to triangulate decoded coordinates.
    pub fn coordinate_spec(&self) -> PatternSpec {
        let (ou, ov) = ((self.width as f64 - 1.0) / 2.0, (self.height as f64 - 1.0) / 2.0);
        let family = |angle_deg: f64, origin: f64, count: usize| Family { angle_deg, stripe_width: 1.0, origin, count };
        PatternSpec {
            format: SPEC_FORMAT.into(),
            version: SPEC_VERSION,
            width: self.width as u32,
            height: self.height as u32,
            encoding_gamma: 1.0,
            palette: binary_palette(0.25),
            background: [0.0; 3],
            sequence: Vec::new(),
            window: 1,
            families: vec![family(0.0, -ou, self.width), family(90.0, -ov, self.height)],
        }
    }
}

/// The finest Gray-code level whose stripes (`2^level` projector pixels) are at least
/// [`MIN_STRIPE_CAMERA_PX`] wide in a camera that sees `camera_per_projector` camera
/// pixels per projector pixel.
pub fn finest_level(camera_per_projector: f64, bits: u32) -> u32 {
    (0..bits)
        .find(|&l| (1u64 << l) as f64 * camera_per_projector >= MIN_STRIPE_CAMERA_PX)
        .unwrap_or(bits.saturating_sub(1))
}

/// The reference's output.
#[derive(Clone, Debug)]
pub struct GrayReference {
    /// Depth (Z, mm) per camera pixel, NaN where nothing decoded.
    pub depth: Image<f32>,
    /// Decoded projector column (u_p) and row (v_p) per camera pixel, NaN where none.
    pub coords: [Vec<f32>; 2],
    /// The finest bit level used for the columns and for the rows.
    pub finest_level: [u32; 2],
    /// Frames of the sequence (those of bits below the finest used level are not
    /// photographed: they would be ignored).
    pub frames: usize,
}

/// Per axis, the state of the decoding while frames arrive.
struct AxisState {
    /// Gray bits above the finest level.
    code: Vec<u32>,
    /// Whether any of those bits was unclear.
    unclear: Vec<bool>,
    /// The finest level's difference.
    fine: Vec<f32>,
    finest: u32,
}

/// Photograph the Gray-code sequence of `calib`'s projector through `view` with the
/// camera settings `cfg` (its seed moved per frame) and decode it.
pub fn gray_reference(view: &View, calib: &Calibration, cfg: &SimConfig) -> Result<GrayReference> {
    let code = GrayCode::new(calib.projector.width, calib.projector.height)?;
    let (w, h) = view.size();
    let n = w * h;
    let ratios = [calib.camera.fx / calib.projector.fx, calib.camera.fy / calib.projector.fy];
    let mut axes: Vec<AxisState> = (0..2)
        .map(|a| AxisState {
            code: vec![0; n],
            unclear: vec![false; n],
            fine: vec![0.0; n],
            finest: finest_level(ratios[a], code.bits[a]),
        })
        .collect();
    let lut = gamma_lut(cfg.camera_gamma);
    let sum = |p: &[u8; 3]| lut[p[0] as usize] + lut[p[1] as usize] + lut[p[2] as usize];
    let (mut projector, mut photo, mut scratch) = (Image::new(0, 0, [0u8; 3]), Image::new(0, 0, [0u8; 3]), Scratch::default());
    let mut first = vec![0f32; n];
    let mut white = vec![0f32; n];
    let frames = code.frames();
    for (k, &frame) in frames.iter().enumerate() {
        // Bits below the finest used level would be photographed and ignored.
        if matches!(frame, GrayFrame::Bit { axis, level, .. } if level < axes[axis].finest) {
            continue;
        }
        code.render_into(frame, &mut projector);
        let shot_cfg = SimConfig { seed: cfg.seed.wrapping_add(SEED_OFFSET).wrapping_add(k as u64), ..cfg.clone() };
        view.photograph_into(&projector, &shot_cfg, &mut scratch, &mut photo)?;
        let px = photo.pixels();
        match frame {
            GrayFrame::White => white.iter_mut().zip(px).for_each(|(x, p)| *x = sum(p)),
            GrayFrame::Black => white.iter_mut().zip(px).for_each(|(x, p)| *x -= sum(p)),
            GrayFrame::Bit { inverse: false, .. } => first.iter_mut().zip(px).for_each(|(x, p)| *x = sum(p)),
            GrayFrame::Bit { axis, level, inverse: true } => {
                let s = &mut axes[axis];
                for (i, p) in px.iter().enumerate() {
                    let d = first[i] - sum(p);
                    if level == s.finest {
                        s.fine[i] = d;
                    } else {
                        s.code[i] |= ((d > 0.0) as u32) << (level - s.finest - 1);
                        s.unclear[i] |= !(d.abs() >= MIN_DIFFERENCE);
                    }
                }
            }
        }
    }
    let lit: Vec<bool> = white.iter().map(|&x| x >= MIN_DIFFERENCE).collect();
    let mut coords = [vec![f32::NAN; n], vec![f32::NAN; n]];
    for (a, s) in axes.iter().enumerate() {
        // Columns change along camera rows, rows along camera columns.
        let (lines, len, index): (usize, usize, &dyn Fn(usize, usize) -> usize) =
            if a == 0 { (h, w, &|line, k| line * w + k) } else { (w, h, &|line, k| k * w + line) };
        let mut edges: Vec<(f64, u32)> = Vec::new();
        for line in 0..lines {
            edges.clear();
            let coarse = |i: usize| (lit[i] && !s.unclear[i]).then(|| gray_inverse(s.code[i]));
            for k in 0..len.saturating_sub(1) {
                let (i, j) = (index(line, k), index(line, k + 1));
                let (Some(ci), Some(cj)) = (coarse(i), coarse(j)) else { continue };
                let (di, dj) = (s.fine[i], s.fine[j]);
                if ci != cj || (di >= 0.0) == (dj >= 0.0) || !((di - dj).abs() >= MIN_DIFFERENCE) {
                    continue;
                }
                edges.push((k as f64 + (di / (di - dj)) as f64, ci));
            }
            let step = 2u64 << s.finest;
            let edge_q = |c: u32| (c as u64 * step + step / 2) as f64 - 0.5;
            for pair in edges.windows(2) {
                let ((xa, ca), (xb, cb)) = (pair[0], pair[1]);
                if ca.abs_diff(cb) != 1 || !(xb > xa) {
                    continue;
                }
                let (k0, k1) = (xa.ceil() as usize, (xb.floor() as usize).min(len - 1));
                // Every pixel lit, of one of the two coarse indices, except at most one
                // whose coarse bits are unclear: the coarse edge between the two.
                let mut unclear = 0;
                let consistent = (k0..=k1).all(|k| {
                    let i = index(line, k);
                    match coarse(i) {
                        Some(c) => c == ca || c == cb,
                        None => {
                            unclear += 1;
                            lit[i] && unclear <= 1
                        }
                    }
                });
                if !consistent {
                    continue;
                }
                let (qa, qb) = (edge_q(ca), edge_q(cb));
                for k in k0..=k1 {
                    let q = qa + (k as f64 - xa) * (qb - qa) / (xb - xa);
                    coords[a][index(line, k)] = q as f32;
                }
            }
        }
    }
    let triangulator = Triangulator::new(calib, &code.coordinate_spec());
    let mut depth = Image::new(w, h, f32::NAN);
    for (i, z) in depth.pixels_mut().iter_mut().enumerate() {
        let per_axis: Vec<(f64, f64)> = (0..2)
            .filter(|&a| !coords[a][i].is_nan())
            .filter_map(|a| triangulator.depth(a, i, coords[a][i] as f64))
            .collect();
        *z = match per_axis[..] {
            [] => f32::NAN,
            [(z, _)] => z as f32,
            [(z0, d0), (z1, d1), ..] => {
                if (z0 - z1).abs() > outlier_threshold(((z0 + z1) / 2.0) as f32) as f64 {
                    f32::NAN
                } else {
                    let (w0, w1) = (1.0 / (d0 * d0).max(1e-12), 1.0 / (d1 * d1).max(1e-12));
                    ((z0 * w0 + z1 * w1) / (w0 + w1)) as f32
                }
            }
        };
    }
    Ok(GrayReference { depth, coords, finest_level: [axes[0].finest, axes[1].finest], frames: frames.len() })
}
