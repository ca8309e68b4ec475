//! Log-gradient illumination restoration (paper section 3, eq. 5-8, and section 4).
//!
//! The captured light is `I = S · L` per channel (surface reflectance times projected
//! light, eq. 3). In the log domain the product is a sum, and a derivative across the
//! stripes sees mostly the stripes' transitions because the surface's colour changes
//! slowly (eq. 4). The restoration re-integrates only the derivative across the
//! stripes (eq. 6), so what comes back is, to a good degree, the projected light.
//!
//! Two implementations share one output type, [`Restored`]:
//!
//! - [`reference`](mod@reference): the paper to the letter. For each of 17 angles (0 to 160 degrees
//!   in 10 degree steps) rotate the image, take the log, apply the Sobel x-derivative
//!   (eq. 5), restore by FFT division (eq. 6), exponentiate and rotate back (eq. 7);
//!   per pixel pick the angle whose restored image has the largest gradient magnitude
//!   (eq. 8). Slow; kept for tests and teaching.
//! - [`LogGradFilter`]: the same restoration at a cost that does not grow with the
//!   number of angles. For an ideal derivative the directional derivative is
//!   steerable, `D_φ = cos φ·Dx + sin φ·Dy`, so the restoration filter of eq. 6,
//!   `|D_φ|² / (|Dx|² + |Dy|²)`, is `cos²φ·Hxx + sin²φ·Hyy + 2 sin φ cos φ·Hxy` with
//!   three fixed frequency responses. Because `Hxx + Hyy = 1` (except at the four
//!   frequencies where the denominator vanishes), one forward transform of each
//!   channel's log image and two inverse transforms (`Hxx` and `Hxy`) give
//!   `ĩ^φ = P + cos 2φ·Q + sin 2φ·C` at every angle as a per-pixel combination of
//!   three planes. Per pixel the angle (of the paper's 17, within half the family's
//!   window around its dominant angle: [`PER_PIXEL_FRACTION`]) maximizes the
//!   log-domain gradient energy
//!   `Σ_c |∇ĩ_c^φ|²`, a quadratic form in `(cos 2φ, sin 2φ)` whose six coefficients are
//!   box-filtered over about two stripe periods so that the choice is stable; the
//!   choice is made on a grid of every [`ANGLE_STEP`]-th pixel and shared by its cell.
//!
//! Multi-direction restoration (section 4): each family's dominant direction is
//! estimated from the frame, within [`DOMINANT_SEARCH`] of the direction the
//! calibration predicts, as the direction of most spectral power of the log image in
//! the stripe band (one histogram over the forward transforms the filter makes
//! anyway). For two families each pixel then takes the best angle near its family's
//! dominant direction. For three families 60 degrees apart eq. 8's gradient criterion
//! is the same at every angle (the three families' cos⁴ weights always sum to 9/8),
//! so a per-pixel choice would be noise: each family keeps its dominant angle, and the
//! quarter of each neighbouring family that a steered derivative lets through is
//! removed by solving a 3x3 system per frame (`decouple`).
//!
//! Where the two differ: the reference resamples the image twice (bilinear rotation
//! and back), Sobel is only approximately steerable (its responses at 0 and 90
//! degrees are exact, the steered combination at other angles is not the rotated
//! Sobel), the reference's rotated canvas has different borders, and eq. 8 is taken on
//! `exp(ĩ)` in the reference but on `ĩ` (which is independent of the surface's
//! brightness) and smoothed in the fast version. `tests/filter.rs` measures the
//! agreement.
//!
//! Numeric conventions, shared by both:
//! - **log guard**: `ln(max(I, LOG_FLOOR))` with linear `I` in 0..=1; below the floor
//!   the camera's noise dominates and ratios mean nothing.
//! - **DC and the other null frequencies**: the denominator `|Dx|² + |Dy|²` of the
//!   Sobel pair vanishes at (0, 0), (π, 0), (0, π) and (π, π); the restoration is set
//!   to 0 there. So the restored log image has zero mean: absolute brightness is lost
//!   and only ratios across the stripes survive, which is all that decoding uses.
//! - **borders**: each image is padded to an FFT-friendly size with at least
//!   [`PAD_MIN`] extra pixels; the padding blends linearly from the last row/column
//!   back to the first, so the periodic image the FFT assumes has no jump at its seams.
//! - **angles** are the direction *across* the stripes (the stripes' normal), radians,
//!   from the image's +u axis towards +v (down), taken modulo π.

pub mod fft2;
pub mod reference;

use crate::error::{Error, Result};
use crate::raster::{Image, Rgb};
use fft2::{fast_size, Fft2};
use rustfft::num_complex::Complex32;
use std::f32::consts::PI;
use std::fmt;
use std::str::FromStr;

/// How the captured colours are turned into stripe colours.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FilterMode {
    /// The captured colours as they are (the paper's "direct estimation"). With three
    /// families it decodes little (10-21 % coverage, 2-28 % outliers on the simulator's
    /// scenes): every pixel shows the product of three stripes, the others' colours
    /// follow a code sequence (no period that smoothing along a family's stripes could
    /// average away), and separating them is the directional restoration itself (the
    /// paper's decoupling), which is what `LogGrad` does.
    Direct,
    /// Log-gradient restoration with the per-pixel best angle (paper eq. 5-8, section 4).
    #[default]
    LogGrad,
    /// Log-gradient restoration at each family's dominant angle only, no per-pixel
    /// rotation (the paper's Fig. 4(b), a teaching comparison).
    LogGradNoRotation,
}

impl FromStr for FilterMode {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "direct" => Ok(FilterMode::Direct),
            "loggrad" => Ok(FilterMode::LogGrad),
            "loggrad-norot" => Ok(FilterMode::LogGradNoRotation),
            other => Err(Error::Setting {
                name: "filter",
                problem: format!("must be direct, loggrad or loggrad-norot, got {other:?}"),
            }),
        }
    }
}

impl fmt::Display for FilterMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FilterMode::Direct => "direct",
            FilterMode::LogGrad => "loggrad",
            FilterMode::LogGradNoRotation => "loggrad-norot",
        })
    }
}


/// Linear values below this are clamped before the log. 0.002 is about 8-bit code 15
/// through gamma 2.2: the level where webcam noise is as large as the signal.
pub const LOG_FLOOR: f32 = 0.002;

/// Least padding added to each dimension before the FFT, pixels: a few Sobel
/// supports, so that the seam blend is gentle.
pub const PAD_MIN: usize = 24;

/// The paper's 17 angles: 0 to 160 degrees in 10 degree steps.
pub const PAPER_ANGLES_DEG: [f32; 17] = [
    0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0, 110.0, 120.0, 130.0, 140.0, 150.0, 160.0,
];

/// The per-pixel angle is chosen on a grid of every `ANGLE_STEP`-th pixel in each
/// direction and shared by the pixels of its cell: the criterion is smoothed over more
/// than a stripe period anyway, so a finer choice only costs time (at 2, a quarter of
/// the criterion's planes, box filters and evaluations).
pub const ANGLE_STEP: usize = 2;

/// Radius of the box filter over the angle criterion, in grid samples: 9x9 samples
/// [`ANGLE_STEP`] apart span 17 pixels, between two and three stripe periods on the
/// demo rig (6.5 camera pixels). The criterion is noisy on coloured surfaces (it
/// follows surface colour edges); smoothing it more helps most simulated scenes
/// (`cargo run --release -- eval --scenes ... --directions 2 --filters loggrad`, with
/// the boundary refinement; coverage / outliers, radius 3 → 4): sphere 88.8 / 0.21 % →
/// 89.2 / 0.18 %, paper 93.1 / 0.52 % → 93.4 / 0.46 %, occluders 94.6 / 0.99 % →
/// 94.9 / 0.89 %, colorchecker 78.4 / 0.90 % → 78.4 / 0.66 %, sphere-dye 77.0 / 1.04 %
/// → 77.3 / 0.97 %, bag 51.7 / 0.54 % → 51.5 / 0.27 %, paper-dye 26.2 / 6.39 % →
/// 27.8 / 6.78 %; the rest the same. Radius 6 gained more coverage but raised a
/// third-party 3-colour pattern's outliers on the sphere above 1 % (tests/third_party.rs),
/// and 12 the dye sphere's to 1.28 %. The dominant angle alone (`loggrad-norot`)
/// decodes more still on most scenes (wood 91.4 % against 87.9 %, sphere 90.4 %): the
/// per-pixel choice (eq. 8) as implemented here costs more than it gives on them. The
/// former radius of 2 grid samples (9 pixels) let paper's outliers rise to 0.74 %.
pub const ANGLE_SMOOTH_RADIUS: usize = 4;

/// Smallest image the filter accepts (a Sobel window and some stripes).
pub const MIN_SIZE: usize = 8;

/// Where to look for one stripe family's direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FamilyWindow {
    /// Expected normal angle of the family in the camera image, radians.
    pub expected: f32,
    /// Half the width of the angle window, radians: π/2 for one family, π/4 for two,
    /// π/6 for three (paper section 4).
    pub half_width: f32,
}

impl FamilyWindow {
    /// Windows for `expected` angles of 1, 2 or 3 families.
    pub fn for_families(expected: &[f32]) -> Vec<FamilyWindow> {
        let half_width = PI / (2.0 * expected.len().max(1) as f32);
        expected.iter().map(|&e| FamilyWindow { expected: e, half_width }).collect()
    }
}

/// One family's restored image.
#[derive(Clone, Debug, Default)]
pub struct Restored {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Restored log colour per channel (`ĩ`, zero mean), row-major. For the `direct`
    /// filter, the log of the captured linear colour.
    pub log: [Vec<f32>; 3],
    /// The normal angle chosen per pixel, radians in [0, π).
    pub angle: Vec<f32>,
    /// The family's dominant normal angle in this frame, radians in [0, π).
    pub dominant: f32,
}

impl Restored {
    /// An empty result for a `width` x `height` image.
    pub fn new(width: usize, height: usize) -> Self {
        let n = width * height;
        Restored { width, height, log: [vec![0.0; n], vec![0.0; n], vec![0.0; n]], angle: vec![0.0; n], dominant: 0.0 }
    }
}

/// Difference of two angles modulo π, in [-π/2, π/2).
pub fn angle_diff(a: f32, b: f32) -> f32 {
    (a - b + PI / 2.0).rem_euclid(PI) - PI / 2.0
}

/// Frequency responses of the Sobel pair on a `pw` x `ph` grid, in the column-major
/// spectrum layout of [`Fft2`], divided by the denominator and by `pw · ph` (the
/// inverse FFT's scale): `(Hxx, Hxy)` with `Hxx = |Dx|²/den`, `Hxy = Re(Dx·conj Dy)/den`.
///
/// With Sobel `Dx = [1 2 1]ᵀ/4 ⊗ [-1 0 1]/2`, `|Dx|² = sin²ωx · ((1 + cos ωy)/2)²` and
/// `Re(Dx·conj Dy) = sin ωx sin ωy (1 + cos ωx)(1 + cos ωy)/4`.
pub fn sobel_responses(pw: usize, ph: usize) -> (Vec<f32>, Vec<f32>) {
    let cols = pw / 2 + 1;
    let mut hxx = vec![0.0; cols * ph];
    let mut hxy = vec![0.0; cols * ph];
    let scale = 1.0 / (pw * ph) as f64;
    for k in 0..cols {
        let wx = 2.0 * std::f64::consts::PI * k as f64 / pw as f64;
        for l in 0..ph {
            let wy = 2.0 * std::f64::consts::PI * l as f64 / ph as f64;
            let (sx, cx) = wx.sin_cos();
            let (sy, cy) = wy.sin_cos();
            let dx2 = sx * sx * ((1.0 + cy) / 2.0).powi(2);
            let dy2 = sy * sy * ((1.0 + cx) / 2.0).powi(2);
            let dxy = sx * sy * (1.0 + cx) * (1.0 + cy) / 4.0;
            let den = dx2 + dy2;
            // The four null frequencies (and round-off around them) restore to 0.
            if den > 1e-12 {
                hxx[k * ph + l] = (dx2 / den * scale) as f32;
                hxy[k * ph + l] = (dxy / den * scale) as f32;
            }
        }
    }
    (hxx, hxy)
}

/// Copy a `w` x `h` plane into the top-left of a `pw` x `ph` buffer and fill the rest
/// so that the periodic extension is continuous: each padded run blends linearly from
/// the last value of the row (column) to its first.
pub fn pad_into(src: &[f32], w: usize, h: usize, dst: &mut [f32], pw: usize, ph: usize) {
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        let out = &mut dst[y * pw..(y + 1) * pw];
        out[..w].copy_from_slice(row);
        let (last, first) = (row[w - 1], row[0]);
        let n = (pw - w + 1) as f32;
        for (i, o) in out[w..].iter_mut().enumerate() {
            let t = (i + 1) as f32 / n;
            *o = last + (first - last) * t;
        }
    }
    let n = (ph - h + 1) as f32;
    for y in h..ph {
        let t = (y - h + 1) as f32 / n;
        for x in 0..pw {
            let (last, first) = (dst[(h - 1) * pw + x], dst[x]);
            dst[y * pw + x] = last + (first - last) * t;
        }
    }
}

/// `ln(max(x, LOG_FLOOR))` of one channel of a linear image into a plane.
pub fn log_plane_into(img: &Image<Rgb>, channel: usize, dst: &mut [f32]) {
    log_region_into(img, (0, 0), img.size(), channel, dst);
}

/// [`log_plane_into`] of the `size` region at `origin` of `img` (which holds it).
fn log_region_into(img: &Image<Rgb>, origin: (usize, usize), size: (usize, usize), channel: usize, dst: &mut [f32]) {
    let (iw, _) = img.size();
    let ((x0, y0), (w, h)) = (origin, size);
    for y in 0..h {
        let src = &img.pixels()[(y0 + y) * iw + x0..(y0 + y) * iw + x0 + w];
        // Four at a time: `wide`'s logarithm, at most one ulp from `f32::ln` over the
        // floor to 4 (checked every 37th float).
        let row = &mut dst[y * w..(y + 1) * w];
        let mut outs = row.chunks_exact_mut(4);
        let mut ins = src.chunks_exact(4);
        for (d, p) in (&mut outs).zip(&mut ins) {
            let v = wide::f32x4::new([0, 1, 2, 3].map(|k| crate::num::max_f32(p[k][channel], LOG_FLOOR)));
            d.copy_from_slice(&v.ln().to_array());
        }
        for (d, p) in outs.into_remainder().iter_mut().zip(ins.remainder()) {
            *d = crate::num::max_f32(p[channel], LOG_FLOOR).ln();
        }
    }
}

/// Longest box [`smooth_along_stripes`] takes, pixels: stripes of other families that
/// repeat more slowly than this along a family's stripes are few per box anyway, and the
/// cost grows with the length (an odd rig once asked for thousands of pixels).
pub const MAX_SMOOTH_LENGTH: f32 = 32.0;

/// Average each channel of `restored` along its family's stripes (perpendicular to
/// `restored.dominant`) over `length` pixels, through `tmp`.
///
/// Without restoration (`direct`) a family's log image also holds the other families'
/// stripes, which cross its own: along this family's stripes they repeat every
/// `P_m / |sin(θ_m − θ_k)|` pixels (their period over the sine of the angle between the
/// normals), so a box of that length cancels them, while this family's boundaries, which
/// run along the box, stay sharp; after restoration it also averages the noise.
///
/// Samples are taken one pixel apart along the stripes' main image axis (v for stripes
/// nearer vertical) and interpolated linearly across it, so that the box follows the
/// stripe exactly (rounding the path to whole pixels shifts boundaries by up to half a
/// pixel, which three families then disagree about); the box's two end samples take
/// fractional weights so that its length is exact; samples beyond the image are clamped
/// to its border.
pub fn smooth_along_stripes(restored: &mut Restored, length: f32, tmp: &mut Vec<f32>) {
    let (w, h) = (restored.width, restored.height);
    if w == 0 || h == 0 || !length.is_finite() {
        return;
    }
    let length = length.min(MAX_SMOOTH_LENGTH);
    let (sin, cos) = restored.dominant.sin_cos();
    let (dx, dy) = (-sin, cos);
    let along_v = dy.abs() >= dx.abs();
    let (slope, main) = if along_v { (dx / dy, dy.abs()) } else { (dy / dx, dx.abs()) };
    // The box spans `length` pixels along the stripe: length·main steps of the main axis.
    let steps = (length * main).max(1.0);
    let inner = ((steps - 1.0) / 2.0).floor().max(0.0) as isize;
    let end_weight = ((steps - (2 * inner + 1) as f32) / 2.0).clamp(0.0, 1.0);
    let total = (2 * inner + 1) as f32 + 2.0 * end_weight;
    // In the frame (a, b): b runs along the main axis (`nb` long), a across (`na`).
    // The sample of row offset t lies `slope·t` across: whole pixels `shift` plus a
    // fraction `frac` to interpolate, the same for every pixel, so each row offset adds
    // a shifted, interpolated copy of one source line to the output line.
    let (na, nb) = if along_v { (w, h) } else { (h, w) };
    let taps: Vec<(isize, isize, f32, f32)> = (-(inner + 1)..=inner + 1)
        .filter_map(|t| {
            let weight = if t.unsigned_abs() as isize <= inner { 1.0 } else { end_weight };
            let offset = slope * t as f32;
            let shift = offset.floor();
            (weight > 0.0).then_some((t, shift as isize, offset - shift, weight / total))
        })
        .collect();
    tmp.resize(w * h + 2 * na, 0.0);
    let (src, lines) = tmp.split_at_mut(w * h);
    let (line, acc) = lines.split_at_mut(na);
    for plane in restored.log.iter_mut() {
        src.copy_from_slice(plane);
        for b in 0..nb {
            acc.iter_mut().for_each(|x| *x = 0.0);
            for &(t, shift, frac, weight) in &taps {
                let bb = (b as isize + t).clamp(0, nb as isize - 1) as usize;
                for (a, x) in line.iter_mut().enumerate() {
                    *x = if along_v { src[bb * w + a] } else { src[a * w + bb] };
                }
                // Interior: both interpolation taps inside the line; edges: clamped.
                let lo = (-shift).clamp(0, na as isize) as usize;
                let hi = (na as isize - 1 - shift).clamp(lo as isize, na as isize) as usize;
                let (w0, w1) = (weight * (1.0 - frac), weight * frac);
                for a in lo..hi {
                    let j = (a as isize + shift) as usize;
                    acc[a] += w0 * line[j] + w1 * line[j + 1];
                }
                for a in (0..lo).chain(hi..na) {
                    let j = |k: isize| line[(a as isize + shift + k).clamp(0, na as isize - 1) as usize];
                    acc[a] += w0 * j(0) + w1 * j(1);
                }
            }
            for (a, &x) in acc.iter().enumerate() {
                let i = if along_v { b * w + a } else { a * w + b };
                plane[i] = x;
            }
        }
    }
}

/// Box filter of radius `r` (clamped at the borders) of a `w` x `h` plane, separable,
/// through `tmp`.
pub fn box_filter_into(src: &[f32], dst: &mut [f32], tmp: &mut [f32], w: usize, h: usize, r: usize) {
    let norm = 1.0 / (2 * r + 1) as f32;
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        let out = &mut tmp[y * w..(y + 1) * w];
        let at = |i: isize| row[i.clamp(0, w as isize - 1) as usize];
        let mut sum: f32 = (-(r as isize)..=r as isize).map(at).sum();
        for (x, o) in out.iter_mut().enumerate() {
            *o = sum * norm;
            sum += at(x as isize + r as isize + 1) - at(x as isize - r as isize);
        }
    }
    // Down the columns, a whole row at a time: the running sums of every column sit in
    // the output's next row until it is written.
    let row = |y: isize| y.clamp(0, h as isize - 1) as usize * w;
    if h == 0 {
        return;
    }
    let (first, rest) = dst.split_at_mut(w);
    first.iter_mut().for_each(|s| *s = 0.0);
    for i in -(r as isize)..=r as isize {
        first.iter_mut().zip(&tmp[row(i)..row(i) + w]).for_each(|(s, t)| *s += t);
    }
    let mut sums = first;
    for (y, next) in (0..h).zip(rest.chunks_exact_mut(w).map(Some).chain(std::iter::once(None))) {
        let (add, sub) = (row(y as isize + r as isize + 1), row(y as isize - r as isize));
        match next {
            Some(next) => {
                for (((n, s), a), b) in next.iter_mut().zip(sums.iter_mut()).zip(&tmp[add..add + w]).zip(&tmp[sub..sub + w]) {
                    *n = *s + (a - b);
                    *s *= norm;
                }
                sums = next;
            }
            None => sums.iter_mut().for_each(|s| *s *= norm),
        }
    }
}

/// The fast steerable log-gradient restoration for one frame size. Owns the FFT plans,
/// the frequency responses and every buffer; [`LogGradFilter::run`] allocates nothing.
pub struct LogGradFilter {
    /// The frame size.
    frame_width: usize,
    frame_height: usize,
    /// Overlapping tiles for large frames (see [`TileGrid`]); `None`: the whole frame
    /// at once.
    tiles: Option<TileGrid>,
    /// The workspaces: one for the whole frame; for tiles, one per tile restored at
    /// once (two with threads, one without).
    regions: Vec<Region>,
    /// Spectral power of the frame's log image per direction (degrees, 0..180),
    /// summed over the tiles.
    direction_power: Vec<f64>,
}

/// The planes and plans that restore one region of the frame (the whole frame, or a
/// tile's region).
struct Region {
    /// The region's size.
    width: usize,
    height: usize,
    pw: usize,
    ph: usize,
    fft: Fft2,
    hxx: Vec<f32>,
    hxy: Vec<f32>,
    padded: Vec<f32>,
    /// Two spectra: with threads, one channel's inverse transforms read one while the
    /// next channel's forward transform writes the other.
    spectra: [Vec<Complex32>; 2],
    /// The two inverse transforms' workspaces (`Hxx` and `Hxy`), which with threads
    /// run at once.
    inverse: [InverseLane; 2],
    /// Per channel: `P = l̃/2`, `Q = A - l̃/2`, `C`, so `ĩ^φ = P + cos2φ·Q + sin2φ·C`.
    p: [Vec<f32>; 3],
    q: [Vec<f32>; 3],
    c: [Vec<f32>; 3],
    /// The six coefficients of the angle criterion on the grid of every
    /// [`ANGLE_STEP`]-th pixel (`gw` x `gh`), then smoothed.
    m: [Vec<f32>; 6],
    gw: usize,
    gh: usize,
    /// Per family, the workspace of `compose`, made at the first frame.
    compose: Vec<ComposeScratch>,
    tmp: Vec<f32>,
    tmp2: Vec<f32>,
    /// Per spectrum bin: its 1-degree direction bin, or `u16::MAX` outside the band
    /// of stripe frequencies.
    direction_bin: Vec<u16>,
    /// Spectral power of the region's log image per direction (degrees, 0..180).
    direction_power: Vec<f64>,
    /// A tile's restored families before they are blended into the frame's (made at
    /// the first tiled frame).
    tile_out: Vec<Restored>,
}

/// Frames of more pixels than this are restored in overlapping tiles
/// ([`LogGradFilter::for_frame`]): whole, the filter's planes (about 45 floats per
/// pixel, 1.4 GB at 8 megapixels) and its column transforms' cache misses grow with the
/// frame. Up to this (1920x1080 and below) the frame is restored whole, as before.
pub const TILED_ABOVE_PIXELS: usize = 2_100_000;

/// A tile's region (core, blend overlap and context on each side), pixels along each
/// axis, before the FFT's padding: about 4 MB per plane.
pub const TILE_SIZE: usize = 800;

/// When and how a frame is restored in tiles ([`LogGradFilter::for_frame`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tiling {
    /// Frames of more pixels than this are restored in tiles.
    pub above_pixels: usize,
    /// A tile's region, pixels along each axis.
    pub size: usize,
}

impl Default for Tiling {
    fn default() -> Self {
        Tiling { above_pixels: TILED_ABOVE_PIXELS, size: TILE_SIZE }
    }
}

/// Overlapping tiles along one axis: tile `i` owns the core `[bounds[i], bounds[i+1])`,
/// blends with its neighbours over `overlap` pixels either side of each inner core
/// boundary (weights that ramp linearly and sum to 1), and is restored from the region
/// `[start[i], start[i] + size)`, which holds the core, the blend zone and at least
/// `context` pixels more on each inner side.
#[derive(Clone, Debug, PartialEq)]
struct TileAxis {
    bounds: Vec<usize>,
    start: Vec<usize>,
    size: usize,
    overlap: usize,
}

impl TileAxis {
    /// Tiles for a frame `len` pixels long with regions of at most `tile` pixels
    /// (fewer tiles where the blend zone and context leave no core).
    fn new(len: usize, tile: usize, overlap: usize, context: usize) -> TileAxis {
        let extra = 2 * (overlap + context);
        let whole = TileAxis { bounds: vec![0, len], start: vec![0], size: len, overlap };
        if len <= tile || tile < extra + 2 * overlap.max(1) {
            return whole;
        }
        let n = len.div_ceil(tile - extra);
        let bounds: Vec<usize> = (0..=n).map(|i| i * len / n).collect();
        let core = bounds.windows(2).map(|b| b[1] - b[0]).max().unwrap_or(len);
        if n < 2 || core < 2 * overlap {
            return whole;
        }
        let size = (core + extra).min(len);
        let start = (0..n).map(|i| bounds[i].saturating_sub(overlap + context).min(len - size)).collect();
        TileAxis { bounds, start, size, overlap }
    }

    fn count(&self) -> usize {
        self.start.len()
    }

    /// Tile `i`'s blend weight at frame position `x`.
    fn weight(&self, i: usize, x: usize) -> f32 {
        let o = self.overlap as f32;
        let ramp = |b: usize| ((x as f32 + 0.5 - (b as f32 - o)) / (2.0 * o)).clamp(0.0, 1.0);
        let mut w = 1.0f32;
        if i > 0 {
            w = w.min(ramp(self.bounds[i]));
        }
        if i + 1 < self.count() {
            w = w.min(1.0 - ramp(self.bounds[i + 1]));
        }
        w
    }
}

/// The tiles of a frame: rows of tiles (`y`) times columns of tiles (`x`).
#[derive(Clone, Debug, PartialEq)]
struct TileGrid {
    x: TileAxis,
    y: TileAxis,
    /// Every tile's (column, row), row after row.
    order: Vec<(usize, usize)>,
}

impl TileGrid {
    fn new(x: TileAxis, y: TileAxis) -> Self {
        let order = (0..y.count()).flat_map(|ty| (0..x.count()).map(move |tx| (tx, ty))).collect();
        TileGrid { x, y, order }
    }
}

/// Band of spatial frequencies (cycles per pixel) that carries the stripes: from
/// stripes 12 pixels wide to 2 pixels wide (the demo rig's are about 7). Lower
/// frequencies belong mostly to objects' outlines, whose edges would pull the
/// direction estimate.
pub const STRIPE_BAND: (f64, f64) = (0.04, 0.25);

/// How far (radians) a family's dominant direction in the frame is searched from the
/// calibration's prediction: 15 degrees, more than surfaces at the working distance
/// turn the stripes as a whole, less than the 30 degrees to a neighbouring family's
/// window edge.
pub const DOMINANT_SEARCH: f32 = 15.0 * PI / 180.0;

impl LogGradFilter {
    /// Plan for `width` x `height` frames, restored whole.
    pub fn new(width: usize, height: usize) -> Result<Self> {
        check_size(width, height)?;
        Ok(LogGradFilter {
            frame_width: width,
            frame_height: height,
            tiles: None,
            regions: vec![Region::new(width, height, STRIPE_BAND)],
            direction_power: vec![0.0; 180],
        })
    }

    /// Plan for `width` x `height` frames whose stripes are about `period` pixels
    /// apart, restored whole or in tiles as `tiling` says.
    pub fn for_frame(width: usize, height: usize, period: f32, tiling: Tiling) -> Result<Self> {
        if width * height > tiling.above_pixels {
            Self::tiled(width, height, period, tiling.size)
        } else {
            Self::new(width, height)
        }
    }

    /// Plan for `width` x `height` frames restored in overlapping tiles whose regions
    /// are at most `tile` pixels along each axis. Each tile is restored with a stripe
    /// period of the frame around its core as context (the restoration's kernel falls
    /// off with distance; what lies further changes the restored log image only
    /// slowly, which decoding does not see) and blended into its neighbours over a
    /// period either side of each seam; the dominant directions are taken from the
    /// spectra of all tiles, and the stripe band of that estimate reaches down to half
    /// the stripes' frequency when their period is over 12.5 pixels.
    pub fn tiled(width: usize, height: usize, period: f32, tile: usize) -> Result<Self> {
        check_size(width, height)?;
        if !(period.is_finite() && period > 0.0) {
            return Err(Error::Internal(format!("stripe period must be positive, got {period}")));
        }
        let overlap = (period.ceil() as usize).clamp(8, 64);
        let context = (period.ceil() as usize).clamp(16, 128);
        let grid = TileGrid::new(TileAxis::new(width, tile, overlap, context), TileAxis::new(height, tile, overlap, context));
        let band = (STRIPE_BAND.0.min(0.5 / period as f64), STRIPE_BAND.1);
        #[cfg(parallel)]
        let workers = rayon::current_num_threads().clamp(1, TILE_WORKERS);
        #[cfg(not(parallel))]
        let workers = 1;
        let workers = workers.min(grid.x.count() * grid.y.count());
        Ok(LogGradFilter {
            frame_width: width,
            frame_height: height,
            regions: (0..workers).map(|_| Region::new(grid.x.size, grid.y.size, band)).collect(),
            tiles: Some(grid),
            direction_power: vec![0.0; 180],
        })
    }

    /// Number of tiles the frame is restored in (1 when whole).
    pub fn tile_count(&self) -> usize {
        self.tiles.as_ref().map_or(1, |t| t.x.count() * t.y.count())
    }

    /// The padded FFT size of the frame, or of a tile's region when tiled, (width,
    /// height).
    pub fn padded_size(&self) -> (usize, usize) {
        (self.regions[0].pw, self.regions[0].ph)
    }

    /// Restore `linear` (linear RGB in 0..=1) for the families whose direction windows
    /// are given, writing one [`Restored`] per window into `out`. `mode` chooses
    /// log-gradient with per-pixel angles, log-gradient at each family's dominant
    /// angle only, or no filtering at all.
    pub fn run(&mut self, linear: &Image<Rgb>, windows: &[FamilyWindow], mode: FilterMode, out: &mut [Restored]) -> Result<()> {
        linear.expect_size(self.frame_width, self.frame_height)?;
        if out.len() != windows.len() || out.iter().any(|r| r.width != self.frame_width || r.height != self.frame_height) {
            return Err(Error::Internal("filter output does not match the families or the image size".into()));
        }
        if mode == FilterMode::Direct {
            // One log image, copied to every family.
            if let Some((first, rest)) = out.split_first_mut() {
                for ch in 0..3 {
                    log_plane_into(linear, ch, &mut first.log[ch]);
                    for r in rest.iter_mut() {
                        r.log[ch].copy_from_slice(&first.log[ch]);
                    }
                }
            }
            for (r, w) in out.iter_mut().zip(windows) {
                r.dominant = w.expected.rem_euclid(PI);
                r.angle.iter_mut().for_each(|a| *a = r.dominant);
            }
            return Ok(());
        }
        // With three families 60 degrees apart eq. 8's criterion is flat in the angle
        // (see `dominant_angle`), so each family keeps its dominant angle.
        let per_pixel = mode == FilterMode::LogGrad && windows.len() < 3;
        match self.tiles.take() {
            None => {
                let region = &mut self.regions[0];
                region.steerable_planes(linear, (0, 0), true)?;
                for (r, w) in out.iter_mut().zip(windows) {
                    r.dominant = dominant_angle(&region.direction_power, w);
                }
                region.compose_families(windows, per_pixel, out);
            }
            Some(grid) => {
                let done = self.run_tiled(&grid, linear, windows, per_pixel, out);
                self.tiles = Some(grid);
                done?;
            }
        }
        if out.len() == 3 {
            decouple(out);
        }
        Ok(())
    }

    /// [`LogGradFilter::run`] tile by tile: first the dominant directions from the
    /// spectra of every tile, then each tile's restoration blended into `out`; as many
    /// tiles at once as there are workspaces. Each tile's forward transforms are made
    /// twice (once for the directions, once for the restoration): keeping every tile's
    /// spectra would cost as much memory as restoring the frame whole.
    fn run_tiled(&mut self, grid: &TileGrid, linear: &Image<Rgb>, windows: &[FamilyWindow], per_pixel: bool, out: &mut [Restored]) -> Result<()> {
        let tiles = &grid.order;
        let origin = |&(tx, ty): &(usize, usize)| (grid.x.start[tx], grid.y.start[ty]);
        for region in self.regions.iter_mut() {
            region.direction_power.iter_mut().for_each(|p| *p = 0.0);
        }
        for batch in tiles.chunks(self.regions.len()) {
            each_region(&mut self.regions, batch, |region, tile| region.accumulate_power(linear, origin(tile)))?;
        }
        for (d, bin) in self.direction_power.iter_mut().enumerate() {
            *bin = self.regions.iter().map(|r| r.direction_power[d]).sum();
        }
        for (r, w) in out.iter_mut().zip(windows) {
            r.dominant = dominant_angle(&self.direction_power, w);
            for plane in r.log.iter_mut() {
                plane.iter_mut().for_each(|x| *x = 0.0);
            }
        }
        for batch in tiles.chunks(self.regions.len()) {
            each_region(&mut self.regions, batch, |region, tile| {
                region.steerable_planes(linear, origin(tile), false)?;
                let (w, h) = (region.width, region.height);
                let mut tile_out = std::mem::take(&mut region.tile_out);
                tile_out.resize_with(windows.len(), || Restored::new(w, h));
                for (t, r) in tile_out.iter_mut().zip(out.iter()) {
                    t.dominant = r.dominant;
                }
                region.compose_families(windows, per_pixel, &mut tile_out);
                weigh_tile(grid, *tile, &mut tile_out, &mut region.tmp);
                region.tile_out = tile_out;
                Ok(())
            })?;
            for (region, &tile) in self.regions.iter().zip(batch) {
                blend_tile(grid, tile, &region.tile_out, out);
            }
        }
        Ok(())
    }

    /// The restored log image `ĩ^φ` of every channel at one angle `phi` (radians),
    /// for comparison with [`reference::restore_at_angle`] and for teaching. Needs a
    /// filter that restores the frame whole.
    pub fn restore_at_angle(&mut self, linear: &Image<Rgb>, phi: f32, out: &mut [Vec<f32>; 3]) -> Result<()> {
        linear.expect_size(self.frame_width, self.frame_height)?;
        if self.tiles.is_some() {
            return Err(Error::Internal("restore_at_angle needs a filter that restores the frame whole".into()));
        }
        let region = &mut self.regions[0];
        region.steerable_planes(linear, (0, 0), true)?;
        let (al, be) = ((2.0 * phi).cos(), (2.0 * phi).sin());
        for ch in 0..3 {
            out[ch].resize(region.width * region.height, 0.0);
            for (i, o) in out[ch].iter_mut().enumerate() {
                *o = region.p[ch][i] + al * region.q[ch][i] + be * region.c[ch][i];
            }
        }
        Ok(())
    }
}

/// The frame is large enough for the filter.
fn check_size(width: usize, height: usize) -> Result<()> {
    if width < MIN_SIZE || height < MIN_SIZE {
        return Err(Error::ImageTooSmall { min: (MIN_SIZE, MIN_SIZE), got: (width, height) });
    }
    Ok(())
}

/// How many tiles are restored at once with threads, at most (each with its own workspace,
/// about 27 floats per pixel of a tile's region), and no more than rayon has threads.
pub const TILE_WORKERS: usize = 2;

/// Run `f` on each region with its tile of `batch` (as many tiles as regions, or
/// fewer): at once with threads, one after the other without.
fn each_region<T: Sync>(regions: &mut [Region], batch: &[T], f: impl Fn(&mut Region, &T) -> Result<()> + Sync + Send) -> Result<()> {
    #[cfg(parallel)]
    {
        use rayon::prelude::*;
        regions.par_iter_mut().zip(batch.par_iter()).try_for_each(|(r, t)| f(r, t))
    }
    #[cfg(not(parallel))]
    regions.iter_mut().zip(batch).try_for_each(|(r, t)| f(r, t))
}

/// Multiply tile `(tx, ty)`'s restored families by its blend weights (done for each
/// tile at once, so that adding them into the frame, one after the other, is a plain
/// sum); `wx` takes the weights along x.
fn weigh_tile(grid: &TileGrid, (tx, ty): (usize, usize), tile_out: &mut [Restored], wx: &mut [f32]) {
    let (x0, y0, tw) = (grid.x.start[tx], grid.y.start[ty], grid.x.size);
    for (x, w) in (x0..x0 + tw).zip(wx.iter_mut()) {
        *w = grid.x.weight(tx, x);
    }
    for t in tile_out.iter_mut() {
        for plane in t.log.iter_mut() {
            for (row, y) in plane.chunks_exact_mut(tw).zip(y0..) {
                let wy = grid.y.weight(ty, y);
                for (v, w) in row.iter_mut().zip(&wx[..tw]) {
                    *v *= wy * w;
                }
            }
        }
    }
}

/// Add tile `(tx, ty)`'s weighted restored families ([`weigh_tile`]) into the frame's
/// `out`; each pixel's angle is the one of the tile whose core holds it.
fn blend_tile(grid: &TileGrid, (tx, ty): (usize, usize), tile_out: &[Restored], out: &mut [Restored]) {
    let (x0, y0) = (grid.x.start[tx], grid.y.start[ty]);
    let (tw, th) = (grid.x.size, grid.y.size);
    let (cx0, cx1) = (grid.x.bounds[tx], grid.x.bounds[tx + 1]);
    let (cy0, cy1) = (grid.y.bounds[ty], grid.y.bounds[ty + 1]);
    // Where the tile's weight is not 0: its core and the blend zones beside it.
    let o = grid.x.overlap;
    let (xa, xb) = (cx0.saturating_sub(o).max(x0), (cx1 + o).min(x0 + tw));
    let (ya, yb) = (cy0.saturating_sub(grid.y.overlap).max(y0), (cy1 + grid.y.overlap).min(y0 + th));
    for (t, r) in tile_out.iter().zip(out.iter_mut()) {
        let fw = r.width;
        for y in ya..yb {
            let (src, dst) = ((y - y0) * tw, y * fw);
            for ch in 0..3 {
                let (s, d) = (&t.log[ch][src + xa - x0..src + xb - x0], &mut r.log[ch][dst + xa..dst + xb]);
                for (d, s) in d.iter_mut().zip(s) {
                    *d += s;
                }
            }
            if (cy0..cy1).contains(&y) {
                r.angle[dst + cx0..dst + cx1].copy_from_slice(&t.angle[src + cx0 - x0..src + cx1 - x0]);
            }
        }
    }
}

/// A family's dominant angle from the frame's spectral power per direction
/// (`power`): the direction, within its window, in which the frame's log image has
/// the most spectral power in the stripe band (smoothed over 5 degrees, refined by a
/// parabola). Eq. 8's gradient criterion cannot serve here: summed over a frame with
/// three families 60 degrees apart it is the same at every angle (cos⁴ of three such
/// angles always sums to 9/8).
fn dominant_angle(power: &[f64], win: &FamilyWindow) -> f32 {
    let p = power;
    let smooth = |d: i32| -> f64 { (-2..=2).map(|k| p[(d + k).rem_euclid(180) as usize]).sum() };
    let centre = win.expected.to_degrees().round() as i32;
    let steps = (win.half_width.min(DOMINANT_SEARCH).to_degrees().round() as i32).max(1);
    let mut best = (f64::NEG_INFINITY, centre);
    for d in centre - steps..=centre + steps {
        let e = smooth(d);
        if e > best.0 {
            best = (e, d);
        }
    }
    let (a, b, c) = (smooth(best.1 - 1), best.0, smooth(best.1 + 1));
    let den = a - 2.0 * b + c;
    let offset = if den < 0.0 { (0.5 * (a - c) / den).clamp(-0.5, 0.5) } else { 0.0 };
    // Bin d holds directions [d, d + 1) degrees.
    ((best.1 as f64 + 0.5 + offset) as f32).to_radians().rem_euclid(PI)
}

impl Region {
    /// Plans and buffers for a `width` x `height` region; `band` is the stripe band of
    /// the direction estimate (cycles per pixel).
    fn new(width: usize, height: usize, band: (f64, f64)) -> Self {
        let (pw, ph) = (fast_size(width + PAD_MIN), fast_size(height + PAD_MIN));
        let fft = Fft2::new(pw, ph);
        let (hxx, hxy) = sobel_responses(pw, ph);
        let n = width * height;
        let plane = || vec![0.0f32; n];
        let (gw, gh) = (width.div_ceil(ANGLE_STEP), height.div_ceil(ANGLE_STEP));
        let grid = || vec![0.0f32; gw * gh];
        let spectrum_len = fft.spectrum_len();
        Region {
            width,
            height,
            pw,
            ph,
            fft,
            hxx,
            hxy,
            padded: vec![0.0; pw * ph],
            spectra: [vec![Complex32::new(0.0, 0.0); spectrum_len], vec![Complex32::new(0.0, 0.0); spectrum_len]],
            inverse: [InverseLane::new(pw, ph), InverseLane::new(pw, ph)],
            p: [plane(), plane(), plane()],
            q: [plane(), plane(), plane()],
            c: [plane(), plane(), plane()],
            m: [grid(), grid(), grid(), grid(), grid(), grid()],
            gw,
            gh,
            compose: Vec::new(),
            tmp: plane(),
            tmp2: plane(),
            direction_bin: direction_bins(pw, ph, band),
            direction_power: vec![0.0; 180],
            tile_out: Vec::new(),
        }
    }

    /// Compose every family (whose `dominant` is set) from the planes of the image or
    /// tile last given to `steerable_planes`, with the per-pixel angle choice or not.
    fn compose_families(&mut self, windows: &[FamilyWindow], per_pixel: bool, out: &mut [Restored]) {
        if per_pixel {
            self.criterion_planes();
            let g = self.gw * self.gh;
            for k in 0..6 {
                box_filter_into(&self.m[k], &mut self.tmp2[..g], &mut self.tmp[..g], self.gw, self.gh, ANGLE_SMOOTH_RADIUS);
                self.m[k].copy_from_slice(&self.tmp2[..g]);
            }
        }
        // Made once: the families' workspaces (the count only changes with the spec).
        let (g, w) = (self.gw * self.gh, self.width);
        self.compose.resize_with(windows.len(), || ComposeScratch { choice: vec![0; g], alpha: vec![0.0; w], beta: vec![0.0; w] });
        let planes = Planes { p: &self.p, q: &self.q, c: &self.c, m: &self.m, width: self.width, height: self.height, gw: self.gw };
        let compose = |((r, w), scratch): ((&mut Restored, &FamilyWindow), &mut ComposeScratch)| planes.compose(scratch, r, w, per_pixel);
        #[cfg(parallel)]
        {
            use rayon::prelude::*;
            out.par_iter_mut().zip(windows.par_iter()).zip(self.compose.par_iter_mut()).for_each(compose);
        }
        #[cfg(not(parallel))]
        out.iter_mut().zip(windows.iter()).zip(self.compose.iter_mut()).for_each(compose);
    }

    /// Add the stripe-band power of every channel of the region at `origin` to the
    /// region's `direction_power`.
    fn accumulate_power(&mut self, linear: &Image<Rgb>, origin: (usize, usize)) -> Result<()> {
        let size = (self.width, self.height, self.pw, self.ph);
        let Region { fft, tmp, padded, spectra, direction_bin, direction_power, .. } = self;
        let mut forward = Forward { linear, origin, size, fft, log: tmp, padded };
        for ch in 0..3 {
            forward.transform(ch, &mut spectra[0])?;
            add_band_power(direction_bin, &spectra[0], direction_power);
        }
        Ok(())
    }

    /// The planes P, Q, C of every channel (eq. 5-6 for all angles at once) of the
    /// region of `linear` at `origin`; with `power`, `direction_power` is the region's.
    ///
    /// Each channel's forward transform (with P) and its two inverse transforms (Q and
    /// C); with threads, the next channel's forward transform runs while this one's
    /// inverse transforms do, through a second spectrum.
    fn steerable_planes(&mut self, linear: &Image<Rgb>, origin: (usize, usize), power: bool) -> Result<()> {
        let (w, h) = (self.width, self.height);
        if power {
            self.direction_power.iter_mut().for_each(|p| *p = 0.0);
        }
        let size = (w, h, self.pw, self.ph);
        let Region { fft, tmp, padded, spectra, direction_bin, direction_power, p, q, c, hxx, hxy, inverse, .. } = self;
        let mut forward = Forward { linear, origin, size, fft, log: tmp, padded };
        // The forward half of channel `ch`: its spectrum, its band power, and P.
        let mut forward_half = |ch: usize, spectrum: &mut [Complex32], p: &mut [f32]| -> Result<()> {
            forward.transform(ch, spectrum)?;
            if power {
                add_band_power(direction_bin, spectrum, direction_power);
            }
            forward.half_log_without_null_modes(spectrum, p);
            Ok(())
        };
        forward_half(0, &mut spectra[0], &mut p[0])?;
        for ch in 0..3 {
            let (first, second) = spectra.split_at_mut(1);
            let (spectrum, next) = if ch % 2 == 0 { (&first[0], &mut second[0]) } else { (&second[0], &mut first[0]) };
            let (done, rest) = p.split_at_mut(ch + 1);
            let [lane_xx, lane_xy] = &mut *inverse;
            let (q, c, p) = (&mut q[ch], &mut c[ch], &done[ch]);
            // The two inverse transforms, `Hxx` into Q = A - l̃/2 = A - P and `Hxy`
            // into C.
            let (ahead, (rxx, rxy)) = join(
                || rest.first_mut().map_or(Ok(()), |p_next| forward_half(ch + 1, next, p_next)),
                || join(|| lane_xx.restore(spectrum, hxx, Some(p), q, w, h), || lane_xy.restore(spectrum, hxy, None, c, w, h)),
            );
            ahead?;
            rxx?;
            rxy?;
        }
        Ok(())
    }

    /// The six coefficients of `E(φ) = Σ_c |∇P + α∇Q + β∇C|²` with `α = cos 2φ`,
    /// `β = sin 2φ`, `E = m0 + 2α·m1 + 2β·m2 + α²·m3 + β²·m4 + 2αβ·m5`, at every
    /// [`ANGLE_STEP`]-th pixel (central differences at full resolution).
    fn criterion_planes(&mut self) {
        let (w, h, gw) = (self.width, self.height, self.gw);
        let (p, q, c) = (&self.p, &self.q, &self.c);
        for (gy, y) in (0..h).step_by(ANGLE_STEP).enumerate() {
            let (ym, yp) = (y.saturating_sub(1), (y + 1).min(h - 1));
            for (gx, x) in (0..w).step_by(ANGLE_STEP).enumerate() {
                let (xm, xp) = (x.saturating_sub(1), (x + 1).min(w - 1));
                let grad = |f: &[f32]| [f[y * w + xp] - f[y * w + xm], f[yp * w + x] - f[ym * w + x]];
                let dot = |a: [f32; 2], b: [f32; 2]| a[0] * b[0] + a[1] * b[1];
                // The three channels' sums, in channel order.
                let mut sum = [0.0f32; 6];
                for ch in 0..3 {
                    let (gp, gq, gc) = (grad(&p[ch]), grad(&q[ch]), grad(&c[ch]));
                    sum[0] += dot(gp, gp);
                    sum[1] += dot(gp, gq);
                    sum[2] += dot(gp, gc);
                    sum[3] += dot(gq, gq);
                    sum[4] += dot(gc, gc);
                    sum[5] += dot(gq, gc);
                }
                let i = gy * gw + gx;
                for (m, s) in self.m.iter_mut().zip(sum) {
                    m[i] = s;
                }
            }
        }
    }
}

/// One family's workspace for [`Planes::compose`].
struct ComposeScratch {
    /// Per grid sample, the index of the chosen candidate angle.
    choice: Vec<u8>,
    /// One row's `cos 2φ` and `sin 2φ` of the chosen angles.
    alpha: Vec<f32>,
    beta: Vec<f32>,
}

/// The planes [`LogGradFilter::run`] composes the families from, borrowed so that the
/// families can be composed at once.
struct Planes<'a> {
    p: &'a [Vec<f32>; 3],
    q: &'a [Vec<f32>; 3],
    c: &'a [Vec<f32>; 3],
    m: &'a [Vec<f32>; 6],
    width: usize,
    height: usize,
    gw: usize,
}

impl Planes<'_> {
    /// Write one family's restored image: per pixel the paper's angle (within the
    /// window around the dominant angle) with the largest criterion at its grid
    /// sample, where it beats the dominant angle's criterion by
    /// [`DOMINANT_PREFERENCE`]; or the dominant angle everywhere.
    fn compose(&self, scratch: &mut ComposeScratch, r: &mut Restored, win: &FamilyWindow, per_pixel: bool) {
        // The candidate angles with cos 2φ and sin 2φ, in a fixed array (no allocation);
        // without a per-pixel choice the one candidate is the dominant angle.
        let mut buffer = [(0f32, 0f32, 0f32); PAPER_ANGLES_DEG.len() + 1];
        let mut count = 0;
        if per_pixel {
            for a in PAPER_ANGLES_DEG.iter().map(|d| d.to_radians()) {
                if angle_diff(a, r.dominant).abs() <= win.half_width * PER_PIXEL_FRACTION + 1e-4 {
                    buffer[count] = (a, (2.0 * a).cos(), (2.0 * a).sin());
                    count += 1;
                }
            }
        }
        if count == 0 {
            buffer[0] = (r.dominant, (2.0 * r.dominant).cos(), (2.0 * r.dominant).sin());
            count = 1;
        }
        if count > 1 {
            // The dominant angle itself, the choice unless another is clearly better.
            buffer[count] = (r.dominant, (2.0 * r.dominant).cos(), (2.0 * r.dominant).sin());
            count += 1;
        }
        let candidates = &buffer[..count];
        if count > 1 {
            for (g, choice) in scratch.choice.iter_mut().enumerate() {
                let m = [self.m[0][g], self.m[1][g], self.m[2][g], self.m[3][g], self.m[4][g], self.m[5][g]];
                let criterion = |al: f32, be: f32| m[0] + 2.0 * al * m[1] + 2.0 * be * m[2] + al * al * m[3] + be * be * m[4] + 2.0 * al * be * m[5];
                let (_, al, be) = candidates[count - 1];
                let (mut best, mut index) = (criterion(al, be) * DOMINANT_PREFERENCE, (count - 1) as u8);
                for (k, &(_, al, be)) in candidates[..count - 1].iter().enumerate() {
                    let e = criterion(al, be);
                    if e > best {
                        best = e;
                        index = k as u8;
                    }
                }
                *choice = index;
            }
        }
        // Row by row: the chosen angles' coefficients into a row, then each channel in
        // one pass over the row (which vectorizes).
        let (w, gw) = (self.width, self.gw);
        let (alpha, beta) = (&mut scratch.alpha[..w], &mut scratch.beta[..w]);
        if count == 1 {
            let (a, al, be) = candidates[0];
            alpha.iter_mut().for_each(|x| *x = al);
            beta.iter_mut().for_each(|x| *x = be);
            r.angle.iter_mut().for_each(|x| *x = a);
        }
        for y in 0..self.height {
            let row = y * w..(y + 1) * w;
            if count > 1 {
                let grid_row = &scratch.choice[(y / ANGLE_STEP) * gw..(y / ANGLE_STEP + 1) * gw];
                for (x, ((angle, al), be)) in r.angle[row.clone()].iter_mut().zip(alpha.iter_mut()).zip(beta.iter_mut()).enumerate() {
                    (*angle, *al, *be) = candidates[grid_row[x / ANGLE_STEP] as usize];
                }
            }
            for ch in 0..3 {
                let (p, q, c) = (&self.p[ch][row.clone()], &self.q[ch][row.clone()], &self.c[ch][row.clone()]);
                for ((((o, p), q), c), (al, be)) in r.log[ch][row.clone()].iter_mut().zip(p).zip(q).zip(c).zip(alpha.iter().zip(beta.iter())) {
                    *o = p + al * q + be * c;
                }
            }
        }
    }
}

/// One inverse transform's plan and buffers.
/// The forward transform of a region's channels: the plan and the buffers it borrows
/// from its [`Region`], which it leaves free for the inverse transforms.
struct Forward<'a> {
    linear: &'a Image<Rgb>,
    origin: (usize, usize),
    /// The region's size and its padded size.
    size: (usize, usize, usize, usize),
    fft: &'a mut Fft2,
    /// The last channel's log region.
    log: &'a mut [f32],
    padded: &'a mut [f32],
}

impl Forward<'_> {
    /// The log image of channel `ch` of the region (kept in `log`), padded and
    /// transformed into `spectrum`.
    fn transform(&mut self, ch: usize, spectrum: &mut [Complex32]) -> Result<()> {
        let (w, h, pw, ph) = self.size;
        log_region_into(self.linear, self.origin, (w, h), ch, self.log);
        pad_into(self.log, w, h, self.padded, pw, ph);
        self.fft.forward(self.padded, spectrum)
    }

    /// `P = l̃/2` of the channel last transformed (its `spectrum`) into `p`: l̃ is the log
    /// image minus its components at the four null frequencies (real for a real image):
    /// DC, (π,0), (0,π), (π,π).
    fn half_log_without_null_modes(&self, spectrum: &[Complex32], p: &mut [f32]) {
        let (w, h, pw, ph) = self.size;
        let n = (pw * ph) as f32;
        let mode = |k: usize, l: usize| spectrum[k * ph + l].re / n;
        let (m00, m10, m01, m11) = (mode(0, 0), mode(pw / 2, 0), mode(0, ph / 2), mode(pw / 2, ph / 2));
        for y in 0..h {
            let sy = if y % 2 == 0 { 1.0 } else { -1.0 };
            // The modes' sum at even and at odd columns of this row.
            let modes = [1.0f32, -1.0].map(|sx| m00 + sx * m10 + sy * m01 + sx * sy * m11);
            let row = y * w..(y + 1) * w;
            for (x, (p, t)) in p[row.clone()].iter_mut().zip(&self.log[row]).enumerate() {
                *p = 0.5 * (t - modes[x % 2]);
            }
        }
    }
}

/// Add the power of `spectrum` in the stripe band to `power` (per direction bin).
fn add_band_power(bins: &[u16], spectrum: &[Complex32], power: &mut [f64]) {
    for (bin, s) in bins.iter().zip(spectrum) {
        if *bin != u16::MAX {
            power[*bin as usize] += s.norm_sqr() as f64;
        }
    }
}

struct InverseLane {
    fft: Fft2,
    work: Vec<Complex32>,
    out: Vec<f32>,
}

impl InverseLane {
    fn new(pw: usize, ph: usize) -> Self {
        let fft = Fft2::new(pw, ph);
        InverseLane { work: vec![Complex32::new(0.0, 0.0); fft.spectrum_len()], out: vec![0.0; pw * ph], fft, }
    }

    /// The inverse transform of `spectrum · response` cropped to `w` x `h` into `dst`,
    /// minus `minus` (a `w` x `h` plane) when given.
    fn restore(&mut self, spectrum: &[Complex32], response: &[f32], minus: Option<&[f32]>, dst: &mut [f32], w: usize, h: usize) -> Result<()> {
        for ((o, s), f) in self.work.iter_mut().zip(spectrum).zip(response) {
            *o = s * *f;
        }
        self.fft.inverse(&mut self.work, &mut self.out)?;
        let pw = self.out.len() / self.fft.height();
        for y in 0..h {
            let (d, src) = (&mut dst[y * w..(y + 1) * w], &self.out[y * pw..y * pw + w]);
            match minus {
                Some(m) => d.iter_mut().zip(src).zip(&m[y * w..(y + 1) * w]).for_each(|((d, s), m)| *d = s - m),
                None => d.copy_from_slice(src),
            }
        }
        Ok(())
    }
}

/// Run `a` and `b`, at once with threads (rayon's pool: natively, and in WebAssembly
/// built with `threads`; `cfg(parallel)`, build.rs), one after the other without.
fn join<A: Send, B: Send>(a: impl FnOnce() -> A + Send, b: impl FnOnce() -> B + Send) -> (A, B) {
    #[cfg(parallel)]
    return rayon::join(a, b);
    #[cfg(not(parallel))]
    return (a(), b());
}

/// The 1-degree direction bin of every spectrum entry (column-major layout of
/// [`Fft2`]) whose frequency lies in `band` (cycles per pixel, [`STRIPE_BAND`] unless
/// the stripes are wider); `u16::MAX` elsewhere.
fn direction_bins(pw: usize, ph: usize, band: (f64, f64)) -> Vec<u16> {
    let mut bins = vec![u16::MAX; (pw / 2 + 1) * ph];
    for k in 0..pw / 2 + 1 {
        let fx = k as f64 / pw as f64;
        for l in 0..ph {
            let fy = if l > ph / 2 { l as f64 - ph as f64 } else { l as f64 } / ph as f64;
            let f = fx.hypot(fy);
            if f >= band.0 && f <= band.1 {
                let deg = fy.atan2(fx).to_degrees().rem_euclid(180.0);
                bins[k * ph + l] = (deg as u16).min(179);
            }
        }
    }
    bins
}

/// Separate three families that leak into each other's restorations.
///
/// With a steerable derivative, the restoration at angle φ passes a family whose
/// stripes have normal θ with weight cos²(θ − φ): 1 for its own family and 0.25 for
/// the others at 60 degrees (measured on the pattern itself: 0.26), so in each of
/// three families' restorations the other two families' boundaries would stay visible
/// at a quarter of their contrast. In the log domain the families add, so per pixel
/// the three restorations are `R_k = Σ_j cos²(θ_j − θ_k)·S_j` in the three pure family
/// signals `S_j`; one 3x3 inverse per frame decouples them. Two families 90 degrees
/// apart do not need it (their weight is 0).
fn decouple(out: &mut [Restored]) {
    let theta = [out[0].dominant, out[1].dominant, out[2].dominant];
    let c = |k: usize, j: usize| (theta[j] - theta[k]).cos().powi(2);
    let m = glam::Mat3::from_cols(
        glam::Vec3::new(c(0, 0), c(1, 0), c(2, 0)),
        glam::Vec3::new(c(0, 1), c(1, 1), c(2, 1)),
        glam::Vec3::new(c(0, 2), c(1, 2), c(2, 2)),
    );
    // Nearly collinear families (a degenerate rig) are left as they are.
    if m.determinant().abs() < 0.05 {
        return;
    }
    let inv = m.inverse();
    for ch in 0..3 {
        for i in 0..out[0].log[ch].len() {
            let r = glam::Vec3::new(out[0].log[ch][i], out[1].log[ch][i], out[2].log[ch][i]);
            let sep = inv * r;
            out[0].log[ch][i] = sep.x;
            out[1].log[ch][i] = sep.y;
            out[2].log[ch][i] = sep.z;
        }
    }
}

/// How much larger than the dominant angle's a paper angle's criterion (eq. 8) must be
/// for a pixel to take it. The criterion follows the surface's own colour edges as well
/// as the stripes, so on coloured surfaces an equal choice often picks a mixture of
/// the families. Measured with the line alignment (`eval --scenes ... --directions 2
/// --filters loggrad`, coverage / outliers; 1.0 → 1.3 → dominant angle only): wood
/// 88.3 / 0.83 % → 90.4 / 0.56 % → 91.2 / 0.51 %, colorchecker 79.9 / 0.67 % →
/// 81.8 / 0.55 % → 82.1 / 0.54 %, paper-dye 29.7 / 3.12 % → 34.9 / 3.49 % → the same,
/// sphere 90.4 / 0.38 % → 91.0 / 0.37 % → 91.3 / 0.36 %, but occluders 95.2 / 0.71 %
/// → 95.5 / 0.88 % → 94.7 / 0.93 % (the choice helps beside its depth edges). 1.3
/// keeps the choice where a stripe clearly turns.
pub const DOMINANT_PREFERENCE: f32 = 1.3;

/// Fraction of the family window (around the frame's dominant angle) searched per
/// pixel by the fast filter. The paper searches the whole window (π/2 for two
/// families); at its edge the restoration already passes the neighbouring family at
/// half strength, and the gradient criterion then often prefers the mixture. Half the
/// window measured better on every simulated scene (two directions, plane: coverage
/// 93.2 % → 95.8 %, outliers 1.06 % → 0.05 %). The reference keeps the paper's window.
pub const PER_PIXEL_FRACTION: f32 = 0.5;
