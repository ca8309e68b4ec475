//! The long-lived scanner: one object per (pattern spec, calibration, image size)
//! that owns every plan and buffer the per-frame path needs, and is fed frames.
//!
//! `Scanner::scan` runs the stages in the paper's order: 8-bit frame to linear light,
//! [`crate::filter`] (log-gradient restoration per family, or none for `direct`),
//! [`crate::segment`] (stripe boundaries with transition codes, sub-pixel),
//! [`crate::decode`] (stripe identities from neighbour windows), [`crate::triangulate`]
//! (depth per family, ray-ray where two families meet) and [`crate::merge`].

use crate::calib::{crosstalk_inverse, estimate_crosstalk_from_stripes, CameraResponse, Calibration, Crosstalk, FrameMixing, IDENTITY_CROSSTALK};
use crate::cloud::Cloud;
use crate::decode::Decoder;
use crate::error::{Error, Result};
use crate::filter::{smooth_along_stripes, FamilyWindow, FilterMode, LogGradFilter, Restored, Tiling};
use crate::merge;
use crate::pattern::PatternSpec;
use crate::raster::{detect_chroma_pairs, downsample_box_into, gamma_lut, interpolate_chroma_into, rgb8_pixels_to_linear, rgba8_into, ChromaPairs, Image, Rgb, SATURATED};
use crate::segment::{clip_leak, pixel_flags_into, refine_with_luma, LumaEncoder, PixelFlags, ScanAxis, Segmentation, SUBSAMPLED_CLIP_LEVEL};
use crate::stages::{Stage, StageInputs};
use crate::triangulate::Triangulator;
use glam::DVec3;
use serde::Serialize;

/// Settings of a scanner.
#[derive(Clone, Debug)]
pub struct ScanConfig {
    /// Which restoration feeds segmentation.
    pub filter: FilterMode,
    /// The camera's encoding gamma: 8-bit value = 255 · linear^(1/gamma). 2.2 suits
    /// the simulator and most webcams.
    pub camera_gamma: f32,
    /// The camera's measured response ([`crate::calib::estimate_response`]): when
    /// given, codes are read as linear light through it instead of `camera_gamma`'s
    /// power law (a tone curve's highlight shoulder undone).
    pub response: Option<CameraResponse>,
    /// The camera's colour mixing: linear camera RGB = `crosstalk` · linear light of
    /// the projector's primaries (row = camera channel). Measured once per rig by
    /// projecting pure red, green and blue onto a white card; the identity when
    /// unknown. The scanner undoes it before anything else: on saturated surfaces a
    /// bright channel leaking into a dark one would otherwise fake transitions.
    pub crosstalk: Crosstalk,
    /// A clock in milliseconds for the per-stage timings in [`ScanStats::stage_ms`]:
    /// the operating system's natively, none in WebAssembly unless the boundary gives
    /// one (the pipeline itself knows nothing of the browser).
    pub clock: Option<fn() -> f64>,
    /// When the filter restores the frame in tiles (large frames, to bound memory).
    pub tiling: Tiling,
    /// At what scale the frame is decoded (see [`DecodeScale`]).
    pub decode_scale: DecodeScale,
}

/// At what scale a scanner decodes its frames. A camera of many megapixels with a
/// projector of few pixels sees each projector pixel over several camera pixels. Where a
/// stripe boundary falls inside a projector pixel (a stripe width that is not a whole
/// number of pixels, or boundaries offset by half a pixel), the pattern image holds that
/// pixel as a blend of the two stripes' colours, and such a camera sees a band of a
/// third colour several pixels wide at the boundary, which the decoder reads as edges
/// of their own. The frame reduced by an integer factor (each pixel the mean of a
/// block, which also averages out sensor and JPEG noise) narrows the band below a
/// pixel again, and decodes several times faster. The stripe coordinates found at the
/// reduced scale are then interpolated back to every pixel of the frame and
/// triangulated there, so the depth map, the correspondences and the cloud keep the
/// frame's size.
///
/// Measured on the simulator (`eval --hard --conditions 8mp`: 3264 x 2448, 3.5 camera
/// pixels per projector pixel, 7.5-pixel projector stripes, so every boundary is
/// blended), `Auto` decodes at a third of the scale: ColorChecker coverage 88.2 -> 95.8
/// %, sphere in 1 % dyes 89.3 -> 93.8 %, the bag 69.0 -> 75.8 %, RMSE about halved
/// (0.45 -> 0.24 mm), outliers 0.02-0.04 -> 0.05-0.12 %, the scan 4.5 times faster.
/// With a 512 x 384 projector (4 camera pixels per projector pixel) showing 5-pixel
/// stripes whose boundaries lie on pixel centres, and a 1920 x 1440 camera, the sphere
/// decodes 71.2 % (RMSE 1.1 mm) at the frame's own scale and 95.1 % (0.32 mm) at half
/// of it; the same stripes moved by half a pixel onto the pixels' edges decode 95.9 %
/// (0.20 mm) at the frame's own scale. On real photographs, where noise and blur are
/// larger, the reduced scale gains too (`docs/third-party.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DecodeScale {
    /// The frame's own scale.
    Full,
    /// Where a projector pixel covers at least [`COARSE_FROM_PROJECTOR_PIXEL`] camera
    /// pixels, reduced by the largest factor (at most [`COARSE_MAX_FACTOR`]) that
    /// leaves a projector pixel at least one camera pixel across, every family's stripes
    /// at least [`COARSE_TARGET_PERIOD`] camera pixels wide and the reduced frame at
    /// least [`COARSE_MIN_PIXELS`]; elsewhere the frame's own scale.
    #[default]
    Auto,
    /// Reduced by this factor (1: the frame's own scale).
    Factor(usize),
}

impl std::str::FromStr for DecodeScale {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "full" => Ok(DecodeScale::Full),
            "auto" => Ok(DecodeScale::Auto),
            _ => match s.parse::<usize>() {
                Ok(n @ 1..=16) => Ok(DecodeScale::Factor(n)),
                _ => Err(Error::Setting { name: "decode scale", problem: format!("{s:?} is not full, auto or a factor from 1 to 16") }),
            },
        }
    }
}

/// The camera pixels per projector pixel from which [`DecodeScale::Auto`] reduces a
/// frame. At 2 (1920 x 1440 and 1920 x 1080 cameras with the demo's 1024 x 768
/// projector) half the scale decoded more of the ColorChecker (90.2 -> 93.4 %) but less
/// of the sphere in 1 % dyes (92.1 -> 91.1 %) and of the occluders (98.9 -> 98.2 %),
/// with RMSE 0.02-0.07 mm worse on every scene.
pub const COARSE_FROM_PROJECTOR_PIXEL: f32 = 3.0;

/// The stripe width (camera pixels) that [`DecodeScale::Auto`] leaves broad stripes at
/// least: about the default pattern's at VGA (6.6), where the decoder is tuned.
pub const COARSE_TARGET_PERIOD: f32 = 6.0;

/// The largest factor [`DecodeScale::Auto`] reduces a frame by. At 8 megapixels a
/// quarter of the scale decoded a little less than a third (ColorChecker 95.1 against
/// 95.7 %, the bag 71.9 against 76.1 %).
pub const COARSE_MAX_FACTOR: usize = 4;

/// The smallest side of a reduced frame, pixels: a factor that would leave less is
/// lowered.
const COARSE_MIN_SIDE: usize = 16;

/// The fewest pixels [`DecodeScale::Auto`] leaves a reduced frame (640 x 480, the
/// size the decoder is tuned at): with 4 camera pixels per projector pixel, a 1280 x 960
/// frame decoded a little more at half the scale (ColorChecker 88.7 -> 91.9 %, RMSE
/// 0.38 -> 0.40 mm), but the `wide` rows of `eval --hard`, VGA frames decoded at a third
/// of the scale (213 x 160), lost 4 to 27 points of coverage: too few pixels across the
/// objects.
pub const COARSE_MIN_PIXELS: usize = 640 * 480;

impl Default for ScanConfig {
    fn default() -> Self {
        ScanConfig {
            filter: FilterMode::LogGrad,
            camera_gamma: 2.2,
            response: None,
            crosstalk: IDENTITY_CROSSTALK,
            #[cfg(not(target_arch = "wasm32"))]
            clock: Some(native_clock),
            #[cfg(target_arch = "wasm32")]
            clock: None,
            tiling: Tiling::default(),
            decode_scale: DecodeScale::Auto,
        }
    }
}

/// Figures about one scan.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ScanStats {
    /// Frame width, pixels.
    pub width: usize,
    /// Frame height, pixels.
    pub height: usize,
    /// The filter used.
    pub filter: String,
    /// Pixels with a depth, per family.
    pub decoded: Vec<usize>,
    /// Points in the merged cloud.
    pub merged: usize,
    /// Pixels bright enough and not saturated.
    pub usable: usize,
    /// The frame's chroma sampling as found ([`ChromaPairs::name`]): "4:4:4", or
    /// "4:2:0" (or "4:2:2", "4:4:0") when repeated chroma was found and interpolated.
    pub chroma: &'static str,
    /// The factor the frame was reduced by before decoding (1: decoded at its own
    /// scale; see [`DecodeScale`]).
    pub decode_factor: usize,
    /// Milliseconds per stage, when the configuration has a clock.
    pub stage_ms: Vec<(&'static str, f64)>,
}

impl ScanStats {
    /// The figures of a frame's scan, written in place: the per-frame path reuses the
    /// stats' vectors and string (`stage_ms` is the caller's).
    #[allow(clippy::too_many_arguments)]
    fn fill(&mut self, (width, height): (usize, usize), family_depth: &[Image<f32>], merged: usize, usable: usize, chroma: &'static str, decode_factor: usize, filter: FilterMode) {
        self.decoded.clear();
        self.decoded.extend(family_depth.iter().map(|depth| depth.pixels().iter().filter(|z| !z.is_nan()).count()));
        (self.width, self.height, self.merged, self.usable) = (width, height, merged, usable);
        (self.chroma, self.decode_factor) = (chroma, decode_factor);
        self.filter.clear();
        use std::fmt::Write;
        let _ = write!(self.filter, "{filter}");
    }
}

/// Times the stages of one scan with the configured clock, if any.
struct StageClock {
    clock: Option<fn() -> f64>,
    last: f64,
}

impl StageClock {
    fn start(clock: Option<fn() -> f64>) -> Self {
        StageClock { clock, last: clock.map_or(0.0, |c| c()) }
    }

    /// The milliseconds since the last lap or split (0 without a clock), starting the
    /// next.
    fn split(&mut self) -> f64 {
        match self.clock {
            Some(clock) => {
                let now = clock();
                let dt = now - self.last;
                self.last = now;
                dt
            }
            None => 0.0,
        }
    }

    /// Record the time since the last lap under `name`.
    fn lap(&mut self, name: &'static str, into: &mut Vec<(&'static str, f64)>) {
        if let Some(clock) = self.clock {
            let now = clock();
            into.push((name, now - self.last));
            self.last = now;
        }
    }
}

/// Milliseconds since the first call, from the operating system's monotonic clock.
#[cfg(not(target_arch = "wasm32"))]
pub fn native_clock() -> f64 {
    static ORIGIN: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    ORIGIN.get_or_init(std::time::Instant::now).elapsed().as_secs_f64() * 1000.0
}

/// What a scan produces. The scanner writes every part in place, frame after frame,
/// into buffers it made once; nothing here is a copy of something else.
#[derive(Clone, Debug, Default)]
pub struct ScanResult {
    /// The merged cloud (family masks say which families measured each point). Each
    /// family's own cloud is made when asked ([`Scanner::layer`]).
    pub cloud: Cloud,
    /// Merged depth (Z, mm, camera frame) per camera pixel; NaN where none.
    pub depth: Image<f32>,
    /// Each family's depth map, the same way.
    pub family_depth: Vec<Image<f32>>,
    /// Each family's stripe coordinate per pixel (boundary j at q = j, between the
    /// boundaries the fraction of the way across the stripe); NaN where none.
    pub stripe_coords: Vec<Vec<f32>>,
    /// Per family, the spec's (origin, stripe width): `s = origin + q · width`.
    stripe_geometry: Vec<(f32, f32)>,
    /// Figures about the scan.
    pub stats: ScanStats,
}

impl ScanResult {
    /// Per camera pixel, channel k = family k's projector coordinate along its normal
    /// (the spec's `s`, projector pixels; see `pattern::Family`) where family k has a
    /// depth; NaN where it has none or the pattern has no family k. Made when asked
    /// (three floats a pixel that the per-frame path does not need).
    pub fn correspondence(&self) -> Image<[f32; 3]> {
        let (w, h) = self.depth.size();
        let mut out = Image::new(w, h, [f32::NAN; 3]);
        let families = self.stripe_coords.iter().zip(&self.family_depth).zip(&self.stripe_geometry);
        for (k, ((coords, depth), &(origin, width))) in families.enumerate().take(3) {
            for ((c, &q), &z) in out.pixels_mut().iter_mut().zip(coords).zip(depth.pixels()) {
                if !z.is_nan() {
                    c[k] = origin + q * width;
                }
            }
        }
        out
    }
}

/// The long-lived scanner for one (pattern, calibration, frame size). Everything the
/// per-frame path needs is made in [`Scanner::new`]; [`Scanner::scan`] reuses it.
pub struct Scanner {
    spec: PatternSpec,
    calib: Calibration,
    config: ScanConfig,
    width: usize,
    height: usize,
    lut: [f32; 256],
    /// The inverse of `lut`, for the luma refinement of frames with half-resolution
    /// chroma.
    luma_encoder: LumaEncoder,
    /// Inverse of the crosstalk matrix, `None` for the identity.
    unmix: Option<glam::Mat3>,
    /// What the unmixing is taken to overstate a channel by where another clips
    /// ([`clip_leak`]), made once with `unmix`; `None` for the identity.
    leak: Option<[[f32; 3]; 3]>,
    /// Inputs of the last frame and the stages' working buffers, kept for
    /// [`Scanner::stages`] (they are needed anyway: keeping them costs nothing).
    frame: Image<[u8; 3]>,
    /// The frame with repeated chroma interpolated (when the frame has it), and the
    /// chroma blocks' means behind it.
    interpolated: Image<[u8; 3]>,
    chroma_blocks: Vec<[f32; 2]>,
    linear: Image<Rgb>,
    flags: Vec<PixelFlags>,
    filter: LogGradFilter,
    windows: Vec<FamilyWindow>,
    predictions: Vec<FamilyPrediction>,
    /// Bit k set where family k's stripes run closer to the rows than to the columns
    /// (its scan lines are columns; see [`merge::remove_half_lit`]).
    stripes_along_rows: u8,
    /// Per family, the mean period of the other families' stripes along its own
    /// stripes, pixels (see `smooth_along_stripes`).
    other_families_period: Vec<f32>,
    restored: Vec<Restored>,
    segmentations: Vec<Segmentation>,
    decoders: Vec<Decoder>,
    triangulator: Triangulator,
    weights: Vec<Vec<f32>>,
    merged_families: Vec<u8>,
    /// The pixels [`merge::remove_disputed_extensions`], [`merge::remove_rim`] and
    /// [`merge::remove_half_lit`] remove.
    rim: Vec<u32>,
    scratch: Vec<f32>,
    /// Per family: a scratch plane and the milliseconds of its four stages.
    family_scratch: Vec<Vec<f32>>,
    family_ms: Vec<[f64; 4]>,
    result: ScanResult,
    scanned: bool,
    /// Where the frame is decoded at a reduced scale ([`DecodeScale`]): the reduced
    /// frame and its scanner. The stages above then hold nothing (size 0) but the
    /// result, the weights and the merge's buffers, at the frame's size.
    coarse: Option<Box<Coarse>>,
}

/// Decoding at a reduced scale: the factor, the reduced frame and the scanner for it.
struct Coarse {
    factor: usize,
    frame: Image<[u8; 3]>,
    scanner: Scanner,
    table: Resample,
}

/// The factor a frame of `width` x `height` is reduced by under `scale`, given the
/// families' predicted periods (camera pixels) and their stripe widths (projector
/// pixels, in the same order).
fn coarse_factor(scale: DecodeScale, predictions: &[FamilyPrediction], stripe_widths: &[f64], width: usize, height: usize) -> usize {
    let wanted = match scale {
        DecodeScale::Full => 1,
        DecodeScale::Factor(n) => n.max(1),
        DecodeScale::Auto => {
            let period = predictions.iter().map(|p| p.period).fold(f32::INFINITY, f32::min);
            // Camera pixels per projector pixel, the smallest over the families.
            let per_projector_pixel =
                predictions.iter().zip(stripe_widths).map(|(p, &w)| p.period / w as f32).fold(f32::INFINITY, f32::min);
            let by = |ratio: f32| if ratio.is_finite() && ratio >= 1.0 { (ratio.floor() as usize).min(COARSE_MAX_FACTOR) } else { 1 };
            let most = if per_projector_pixel >= COARSE_FROM_PROJECTOR_PIXEL { by(period / COARSE_TARGET_PERIOD).min(by(per_projector_pixel)) } else { 1 };
            (1..=most).rev().find(|&f| (width / f) * (height / f) >= COARSE_MIN_PIXELS).unwrap_or(1)
        }
    };
    (1..=wanted).rev().find(|&f| width / f >= COARSE_MIN_SIDE && height / f >= COARSE_MIN_SIDE).unwrap_or(1)
}

/// `calib` with its camera reduced by `factor` (the pixels of [`downsample_box_into`]:
/// pixel centre `(u + 0.5) / factor - 0.5`; the distortion, in normalized
/// coordinates, unchanged).
fn reduced_calibration(calib: &Calibration, factor: usize) -> Calibration {
    let mut c = calib.clone();
    let f = factor as f64;
    let cam = &mut c.camera;
    (cam.width, cam.height) = (cam.width / factor as u32, cam.height / factor as u32);
    (cam.fx, cam.fy) = (cam.fx / f, cam.fy / f);
    (cam.cx, cam.cy) = ((cam.cx + 0.5) / f - 0.5, (cam.cy + 0.5) / f - 0.5);
    c
}

/// Where each pixel of a frame falls among the pixels of the frame reduced by an
/// integer factor (box means: the pixel centre `(u + 0.5) / factor - 0.5`, clamped to
/// the reduced frame), per column and per row: the two reduced pixels either side and
/// the weight of the second. Made once per scanner.
struct Resample {
    /// The reduced frame's size.
    size: (usize, usize),
    cols: Vec<(u32, u32, f32)>,
    rows: Vec<(u32, u32, f32)>,
}

impl Resample {
    fn new((w, h): (usize, usize), (cw, ch): (usize, usize), factor: usize) -> Self {
        let axis = |n: usize, reduced: usize| -> Vec<(u32, u32, f32)> {
            (0..n)
                .map(|i| {
                    let t = ((i as f32 + 0.5) / factor as f32 - 0.5).clamp(0.0, reduced.saturating_sub(1) as f32);
                    let i0 = t.floor() as usize;
                    (i0 as u32, (i0 + 1).min(reduced.saturating_sub(1)) as u32, t - i0 as f32)
                })
                .collect()
        };
        Resample { size: (cw, ch), cols: axis(w, cw), rows: axis(h, ch) }
    }
}

/// Rows of the frame per chunk that [`upsample_coords`] hands to a thread.
const UPSAMPLE_ROWS: usize = 64;

/// The stripe coordinates `coarse` of the reduced frame (NaN where none) brought to
/// every pixel of the frame into `out` (`table` says where each pixel falls): where
/// the nearest reduced pixel has a coordinate and a depth that the merge kept
/// (`depth`), the bilinear mean of the four reduced pixels around, each counted where
/// it has both and lies within half a stripe of the nearest (a boundary of the
/// pattern, or a jump of depth, is not blurred across); NaN elsewhere. Chunks of rows
/// run at once with threads (`cfg(parallel)`, build.rs).
fn upsample_coords(coarse: &[f32], depth: &[f32], table: &Resample, out: &mut [f32]) {
    let (cw, w) = (table.size.0, table.cols.len());
    let at = |x: u32, y: u32| {
        let i = y as usize * cw + x as usize;
        if depth[i].is_nan() { f32::NAN } else { coarse[i] }
    };
    let rows = |(chunk, band): (usize, &mut [f32])| {
        for (dy, row) in band.chunks_mut(w).enumerate() {
            let (y0, y1, ty) = table.rows[chunk * UPSAMPLE_ROWS + dy];
            let ny = if ty < 0.5 { y0 } else { y1 };
            for (q, &(x0, x1, tx)) in row.iter_mut().zip(&table.cols) {
                let nearest = at(if tx < 0.5 { x0 } else { x1 }, ny);
                if nearest.is_nan() {
                    *q = f32::NAN;
                    continue;
                }
                let (mut sum, mut weight) = (0.0f32, 0.0f32);
                for (xx, yy, wgt) in [(x0, y0, (1.0 - tx) * (1.0 - ty)), (x1, y0, tx * (1.0 - ty)), (x0, y1, (1.0 - tx) * ty), (x1, y1, tx * ty)] {
                    let v = at(xx, yy);
                    if (v - nearest).abs() < 0.5 {
                        sum += wgt * v;
                        weight += wgt;
                    }
                }
                *q = if weight > 0.0 { sum / weight } else { nearest };
            }
        }
    };
    #[cfg(parallel)]
    {
        use rayon::prelude::*;
        out.par_chunks_mut(w * UPSAMPLE_ROWS).enumerate().for_each(rows);
    }
    #[cfg(not(parallel))]
    out.chunks_mut(w * UPSAMPLE_ROWS).enumerate().for_each(rows);
}

/// The points of `depth` (NaN: none) into `cloud`, coloured from `frame`, with the
/// family mask `families(i)` of pixel i.
fn fill_cloud(triangulator: &Triangulator, frame: &Image<[u8; 3]>, depth: &Image<f32>, families: &dyn Fn(usize) -> u8, cloud: &mut Cloud) {
    let w = depth.width();
    let frame = frame.pixels();
    cloud.clear();
    for (v, row) in depth.pixels().chunks(w).enumerate() {
        for (u, &z) in row.iter().enumerate() {
            if !z.is_nan() {
                let i = v * w + u;
                cloud.push(triangulator.point_at(i, (u, v), z), frame[i], [u as f32, v as f32], families(i));
            }
        }
    }
}

/// What the calibration predicts about a family's stripes in the camera image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FamilyPrediction {
    /// Normal angle across the stripes in the camera image, radians in [0, π).
    pub angle: f32,
    /// Stripe period in camera pixels.
    pub period: f32,
    /// The axis the scan lines follow.
    pub axis: ScanAxis,
    /// Stripe indices grow along the scan direction.
    pub increasing: bool,
}

impl FamilyPrediction {
    /// The stripe period along the family's scan lines, pixels: the period across the
    /// stripes over the cosine of the angle between the lines and the stripes' normal
    /// (at most 45 degrees, see [`ScanAxis::for_normal`]).
    pub fn line_period(&self) -> f32 {
        let along = match self.axis {
            ScanAxis::Rows => self.angle.cos(),
            ScanAxis::Columns => self.angle.sin(),
        };
        self.period / along.abs().max(std::f32::consts::FRAC_1_SQRT_2)
    }
}

/// Predict each family's appearance in the camera at the rig's working distance: the
/// depth where the projector's optical axis passes closest to the camera's.
pub fn predict_families(spec: &PatternSpec, calib: &Calibration) -> Result<Vec<FamilyPrediction>> {
    let c = calib.projector_center_cam();
    let d = calib.proj_from_cam_rotation().transpose() * DVec3::Z;
    // Closest points of the lines s·Z (camera axis) and c + t·d (projector axis).
    let b = DVec3::Z.dot(d);
    let denom = 1.0 - b * b;
    let z_ref = if denom > 1e-9 {
        let (e, f) = (DVec3::Z.dot(c), d.dot(c));
        ((e - b * f) / denom).clamp(200.0, 5000.0)
    } else {
        750.0
    };
    let (cu, cv) = ((calib.camera.width as f64 - 1.0) / 2.0, (calib.camera.height as f64 - 1.0) / 2.0);
    let mut out = Vec::new();
    for (k, fam) in spec.families.iter().enumerate() {
        let (a, bb, cc) = fam.stripe_coord(spec.width, spec.height);
        let q = |u: f64, v: f64| -> Option<f64> {
            let x = calib.camera.ray(u, v) * z_ref;
            let p = calib.projector.project(calib.cam_to_proj(x))?;
            Some(a * p.x + bb * p.y + cc)
        };
        let fail = || Error::Calib {
            field: "rotation".into(),
            problem: format!("the projector does not see the camera's view at {z_ref:.0} mm, so family {k} cannot be predicted"),
        };
        let q0 = q(cu, cv).ok_or_else(fail)?;
        let gu = q(cu + 1.0, cv).ok_or_else(fail)? - q0;
        let gv = q(cu, cv + 1.0).ok_or_else(fail)? - q0;
        let norm = gu.hypot(gv);
        if !(norm > 1e-9) {
            return Err(fail());
        }
        let angle = (gv.atan2(gu) as f32).rem_euclid(std::f32::consts::PI);
        let axis = ScanAxis::for_normal(angle);
        let increasing = match axis {
            ScanAxis::Rows => gu > 0.0,
            ScanAxis::Columns => gv > 0.0,
        };
        out.push(FamilyPrediction { angle, period: (1.0 / norm) as f32, axis, increasing });
    }
    Ok(out)
}

/// From this many families on, each family's log image is averaged along its stripes
/// (`filter::smooth_along_stripes`) before segmentation. Measured on the simulator's
/// scenes (`stripelight eval`): with three families it lifts coverage and cuts outliers
/// in both modes (crumpled paper, `loggrad`: 76.8 -> 90.2 % coverage, 2.91 -> 0.98 %
/// outliers; `direct`: 0.1 -> 16 %); with two perpendicular families, which barely leak
/// into each other, the gain on coloured scenes (paper 91.6 -> 93.8 %) costs coverage near
/// depth edges, where the box reaches across the occlusion (occluders 94.5 -> 92.5 %).
pub const SMOOTH_MIN_FAMILIES: usize = 3;

/// How many chunks of the frame linearization splits it into (with threads they run at
/// once).
const LINEARIZE_CHUNKS: usize = 8;

/// A stripe wider than this many predicted periods is not bridged (surfaces slanted
/// away from the projector stretch stripes; much wider means a missed boundary).
const MAX_STRIPE_PERIODS: f32 = 3.0;

/// The side of a tile in [`Scanner::estimate_crosstalk`], in stripe periods: enough
/// stripes (of each family) for a tile to show several of the pattern's colours.
const FRAME_MIXING_TILE_PERIODS: f32 = 4.0;

/// Rounds of [`Scanner::scan_estimating_crosstalk`] that `scan --crosstalk frame` and
/// the page run: on `eval --hard`'s scenes the second round's estimate is as close to
/// the card's as the first or closer (crumpled paper in 1 % dyes through a webcam's
/// chroma and JPEG: 0.052 -> 0.023 at most), and a third moved no row's coverage by
/// more than 0.3 point (paper, paper-dye, colorchecker, bag, textured under default,
/// webcam and wide).
pub const FRAME_MIXING_ROUNDS: usize = 2;

/// The tiles a frame is at least cut into by [`Scanner::estimate_crosstalk`] (fewer
/// stripe periods a tile where the stripes are broad): on the `wide` rows of `eval
/// --hard`, four periods a tile left 20-25 tiles and crumpled paper in 1 % dyes too
/// few to estimate from.
const FRAME_MIXING_MIN_TILES: f32 = 150.0;

impl Scanner {
    /// A scanner for frames of the calibration's camera size. The pattern's size must
    /// be the calibration's projector size.
    pub fn new(spec: PatternSpec, calib: Calibration, config: ScanConfig) -> Result<Scanner> {
        spec.validate()?;
        calib.validate()?;
        let projector = (calib.projector.width, calib.projector.height);
        if (spec.width, spec.height) != projector {
            return Err(Error::ProjectorMismatch { pattern: (spec.width, spec.height), calibration: projector });
        }
        if !(config.camera_gamma.is_finite() && (0.2..=5.0).contains(&config.camera_gamma)) {
            return Err(Error::Setting { name: "camera gamma", problem: format!("must be in 0.2..=5, got {}", config.camera_gamma) });
        }
        let (w, h) = (calib.camera.width as usize, calib.camera.height as usize);
        let unmix = crosstalk_inverse(&config.crosstalk)?;
        let predictions = predict_families(&spec, &calib)?;
        let windows = FamilyWindow::for_families(&predictions.iter().map(|p| p.angle).collect::<Vec<_>>());
        let other_families_period = predictions
            .iter()
            .enumerate()
            .map(|(k, pk)| {
                let others: Vec<f32> = predictions
                    .iter()
                    .enumerate()
                    .filter(|&(m, _)| m != k)
                    .map(|(_, pm)| pm.period / (pm.angle - pk.angle).sin().abs().max(0.5))
                    .collect();
                if others.is_empty() { 0.0 } else { others.iter().sum::<f32>() / others.len() as f32 }
            })
            .collect();
        let n = spec.families.len();
        let (lut, luma_encoder) = match &config.response {
            Some(r) => (*r.linear(), LumaEncoder::from_table(r.linear())),
            None => (gamma_lut(config.camera_gamma), LumaEncoder::new(config.camera_gamma)),
        };
        let decoders = predictions.iter().enumerate().map(|(k, p)| Decoder::new(&spec, k, p.increasing)).collect();
        let triangulator = Triangulator::new(&calib, &spec);
        let plane = || vec![f32::NAN; w * h];
        let period = predictions.iter().map(|p| p.period).fold(0.0f32, f32::max);
        // Decoded at a reduced scale: by a scanner of its own, this one's stages empty.
        let stripe_widths: Vec<f64> = spec.families.iter().map(|f| f.stripe_width).collect();
        let factor = coarse_factor(config.decode_scale, &predictions, &stripe_widths, w, h);
        let coarse = if factor > 1 {
            let config = ScanConfig { decode_scale: DecodeScale::Full, ..config.clone() };
            let scanner = Scanner::new(spec.clone(), reduced_calibration(&calib, factor), config)?;
            let (cw, ch) = scanner.size();
            let table = Resample::new((w, h), (cw, ch), factor);
            // The reduced frame at its size from the start: the first frame allocates nothing.
            Some(Box::new(Coarse { factor, frame: Image::new(cw, ch, [0; 3]), scanner, table }))
        } else {
            None
        };
        let (sw, sh) = if coarse.is_some() { (0, 0) } else { (w, h) };
        // The reduced-scale scanner filters; this one's filter is never run (a token 8 x 8).
        let (fw, fh) = if coarse.is_some() { (8, 8) } else { (w, h) };
        Ok(Scanner {
            filter: LogGradFilter::for_frame(fw, fh, period, config.tiling)?,
            restored: (0..n).map(|_| Restored::new(sw, sh)).collect(),
            segmentations: (0..n).map(|_| Segmentation::for_pattern(spec.unlit_channels())).collect(),
            // A single family is not merged: it needs no weights.
            weights: (0..n).map(|_| if n > 1 { plane() } else { Vec::new() }).collect(),
            merged_families: vec![0; w * h],
            rim: Vec::new(),
            scratch: Vec::new(),
            family_scratch: (0..n).map(|_| Vec::new()).collect(),
            family_ms: vec![[0.0; 4]; n],
            frame: Image::new(w, h, [0; 3]),
            interpolated: Image::new(sw, sh, [0; 3]),
            chroma_blocks: Vec::with_capacity(sw * sh),
            linear: Image::new(sw, sh, [0.0; 3]),
            flags: vec![0; sw * sh],
            result: ScanResult {
                depth: Image::new(w, h, f32::NAN),
                family_depth: (0..n).map(|_| Image::new(w, h, f32::NAN)).collect(),
                stripe_coords: (0..n).map(|_| plane()).collect(),
                stripe_geometry: spec.families.iter().map(|f| (f.origin as f32, f.stripe_width as f32)).collect(),
                ..Default::default()
            },
            spec,
            calib,
            config,
            width: w,
            height: h,
            lut,
            luma_encoder,
            unmix,
            leak: unmix.as_ref().map(clip_leak),
            windows,
            stripes_along_rows: predictions.iter().enumerate().fold(0u8, |m, (k, p)| if p.axis == ScanAxis::Columns { m | 1 << k } else { m }),
            predictions,
            other_families_period,
            decoders,
            triangulator,
            scanned: false,
            coarse,
        })
    }

    /// The frame size this scanner takes, (width, height).
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The settings.
    pub fn config(&self) -> &ScanConfig {
        &self.config
    }

    /// The pattern spec.
    pub fn spec(&self) -> &PatternSpec {
        &self.spec
    }

    /// The calibration.
    pub fn calibration(&self) -> &Calibration {
        &self.calib
    }

    /// What the calibration predicts for each family.
    pub fn predictions(&self) -> &[FamilyPrediction] {
        &self.predictions
    }

    /// Change the filter for the next frames.
    pub fn set_filter(&mut self, filter: FilterMode) {
        self.config.filter = filter;
        if let Some(c) = self.coarse.as_deref_mut() {
            c.scanner.set_filter(filter);
        }
    }

    /// Change the colour mixing for the next frames (refused, and the old one kept,
    /// when it cannot be inverted).
    pub fn set_crosstalk(&mut self, crosstalk: Crosstalk) -> Result<()> {
        let unmix = crosstalk_inverse(&crosstalk)?;
        if let Some(c) = self.coarse.as_deref_mut() {
            c.scanner.set_crosstalk(crosstalk)?;
        }
        (self.config.crosstalk, self.unmix, self.leak) = (crosstalk, unmix, unmix.as_ref().map(clip_leak));
        Ok(())
    }

    /// Scan `frame`, then estimate the colour mixing from it
    /// ([`Scanner::estimate_crosstalk`]) and scan it again with the estimate, `rounds`
    /// times: each round identifies more stripes, which the next estimate reads. Stops
    /// early, keeping the mixing it has, where an estimate cannot be made; returns the
    /// estimates made, and the scanner keeps the last for the next frames.
    pub fn scan_estimating_crosstalk(&mut self, frame: &Image<[u8; 3]>, rounds: usize) -> Result<(Vec<FrameMixing>, Option<Error>)> {
        self.scan(frame)?;
        let mut estimates = Vec::new();
        for _ in 0..rounds {
            match self.estimate_crosstalk().and_then(|m| self.set_crosstalk(m.crosstalk).map(|()| m)) {
                Ok(m) => estimates.push(m),
                Err(e) => return Ok((estimates, Some(e))),
            }
            self.scan_own_frame()?;
        }
        Ok((estimates, None))
    }

    /// Scan an interleaved RGBA frame (a canvas's `ImageData`).
    pub fn scan_rgba(&mut self, width: usize, height: usize, rgba: &[u8]) -> Result<&ScanResult> {
        if (width, height) != (self.width, self.height) {
            return Err(Error::ImageSize { expected: (self.width, self.height), got: (width, height) });
        }
        rgba8_into(rgba, &mut self.frame)?;
        self.scan_own_frame()
    }

    /// Scan an 8-bit RGB frame.
    pub fn scan(&mut self, frame: &Image<[u8; 3]>) -> Result<&ScanResult> {
        frame.expect_size(self.width, self.height)?;
        self.frame.pixels_mut().copy_from_slice(frame.pixels());
        self.scan_own_frame()
    }

    fn scan_own_frame(&mut self) -> Result<&ScanResult> {
        if self.coarse.is_some() {
            return self.scan_coarse();
        }
        let (w, h) = (self.width, self.height);
        let mut clock = StageClock::start(self.config.clock);
        let mut laps = std::mem::take(&mut self.result.stats.stage_ms);
        laps.clear();
        // A webcam's 4:2:0 (or 4:2:2) chroma, repeated over pixel pairs by the decoder,
        // would put every colour edge on an even pixel boundary: interpolate it first.
        let pairs = detect_chroma_pairs(&self.frame);
        let colour = if pairs == ChromaPairs::default() {
            &self.frame
        } else {
            interpolate_chroma_into(&self.frame, pairs, &mut self.chroma_blocks, &mut self.interpolated);
            &self.interpolated
        };
        // Gamma and the colour mixing undone, and the pixel flags, in chunks of the
        // frame that run at once with threads.
        let (lut, unmix) = (&self.lut, self.unmix);
        let level = if pairs == ChromaPairs::default() { SATURATED } else { SUBSAMPLED_CLIP_LEVEL };
        let leak = self.leak.as_ref().map(|l| (l, level));
        let chunk = (w * h).div_ceil(LINEARIZE_CHUNKS).max(1);
        let linearize = |((colour, frame), (linear, flags)): ((&[[u8; 3]], &[[u8; 3]]), (&mut [Rgb], &mut [PixelFlags]))| {
            rgb8_pixels_to_linear(colour, lut, linear);
            if let Some(m) = unmix {
                for p in linear.iter_mut() {
                    *p = (m * glam::Vec3::from_array(*p)).max(glam::Vec3::ZERO).to_array();
                }
            }
            pixel_flags_into(frame, linear, leak, flags)
        };
        #[cfg(parallel)]
        let usable: usize = {
            use rayon::prelude::*;
            let inputs = colour.pixels().par_chunks(chunk).zip(self.frame.pixels().par_chunks(chunk));
            inputs.zip(self.linear.pixels_mut().par_chunks_mut(chunk).zip(self.flags.par_chunks_mut(chunk))).map(linearize).sum()
        };
        #[cfg(not(parallel))]
        let usable: usize = {
            let inputs = colour.pixels().chunks(chunk).zip(self.frame.pixels().chunks(chunk));
            inputs.zip(self.linear.pixels_mut().chunks_mut(chunk).zip(self.flags.chunks_mut(chunk))).map(linearize).sum()
        };
        clock.lap("linearize", &mut laps);
        self.filter.run(&self.linear, &self.windows, self.config.filter, &mut self.restored)?;
        clock.lap("filter", &mut laps);
        let families = self.spec.families.len();
        let clock_fn = self.config.clock;
        let smooth = families >= SMOOTH_MIN_FAMILIES;
        let (predictions, periods) = (&self.predictions, &self.other_families_period);
        let (linear, flags, triangulator) = (self.linear.pixels(), &self.flags[..], &self.triangulator);
        // One family's stages, from its restored image to its depth map with isolated
        // points removed; the families are independent, so with threads they run at once.
        type FamilyParts<'a> = (
            &'a mut Restored,
            (&'a mut Segmentation, (&'a mut Decoder, (&'a mut Vec<f32>, (&'a mut Vec<f32>, (&'a mut Image<f32>, (&'a mut Vec<f32>, &'a mut [f64; 4])))))),
        );
        // Half-resolution chroma: the boundaries are refined with the frame's own luma.
        let luma_refine = pairs != ChromaPairs::default();
        let luma_encoder = &self.luma_encoder;
        let family = |(k, (restored, (seg, (decoder, (coords, (weights, (depth, (scratch, ms)))))))): (usize, FamilyParts)| {
            let mut clock = StageClock::start(clock_fn);
            let pred = predictions[k];
            // Three families: each family's restored (or raw, for `direct`) log image
            // still holds much of the others' stripes, 60 degrees away; averaging along
            // the family's own stripes removes them and keeps its boundaries.
            if smooth {
                smooth_along_stripes(restored, periods[k], scratch);
            }
            seg.run(restored, linear, flags, pred.axis, pred.period, pairs);
            if luma_refine {
                refine_with_luma(seg, colour.pixels(), w, lut, luma_encoder, pred.period);
            }
            ms[0] = clock.split();
            decoder.run(seg, pred.line_period());
            decoder.smooth_positions(seg);
            decoder.stripe_coords_into(seg, linear, w, MAX_STRIPE_PERIODS * pred.period, coords);
            ms[1] = clock.split();
            triangulator.family_depth_into(k, coords, depth.pixels_mut(), weights);
            ms[2] = clock.split();
            merge::remove_isolated(depth.pixels_mut(), w, h, scratch);
            ms[3] = clock.split();
        };
        let r = &mut self.result;
        // The same zip of every family's parts: in parallel with threads, in order
        // without (`cfg(parallel)`, build.rs).
        macro_rules! each_family {
            ($s:ident, $iter:ident) => {
                $s.restored
                    .$iter()
                    .zip($s.segmentations.$iter().zip($s.decoders.$iter().zip(r.stripe_coords.$iter().zip(
                        $s.weights.$iter().zip(r.family_depth.$iter().zip($s.family_scratch.$iter().zip($s.family_ms.$iter()))),
                    ))))
                    .enumerate()
                    .for_each(family)
            };
        }
        #[cfg(parallel)]
        {
            use rayon::prelude::*;
            each_family!(self, par_iter_mut);
        }
        #[cfg(not(parallel))]
        each_family!(self, iter_mut);
        // Each family's own stage times (overlapping when the families ran at once;
        // `segment` includes the smoothing along the stripes of three families), then
        // the wall time of all of them.
        if clock_fn.is_some() {
            for ms in &self.family_ms {
                for (name, t) in ["segment", "decode", "triangulate", "isolated"].into_iter().zip(ms) {
                    laps.push((name, *t));
                }
            }
        }
        clock.lap("families", &mut laps);
        merge::merge_into(&r.family_depth, &self.weights, r.depth.pixels_mut(), &mut self.merged_families);
        let mut extended: [&[u32]; 3] = [&[]; 3];
        for (e, decoder) in extended.iter_mut().zip(&self.decoders) {
            *e = decoder.extended();
        }
        let extended = &extended[..self.decoders.len().min(3)];
        let mut weak: [&[u32]; 3] = [&[]; 3];
        for (e, decoder) in weak.iter_mut().zip(&self.decoders) {
            *e = decoder.weak();
        }
        merge::remove_unconfirmed(r.depth.pixels_mut(), &mut self.merged_families, &weak[..self.decoders.len().min(3)], &r.family_depth, w, h);
        // One family has no other to contradict it: skip the look around every pixel.
        if families > 1 {
            merge::remove_contradicted(r.depth.pixels_mut(), &mut self.merged_families, w, h, &mut self.rim);
        }
        merge::resolve_disputes(&r.family_depth, r.depth.pixels_mut(), &mut self.merged_families, w, h, &mut self.rim);
        merge::remove_disputed_extensions(r.depth.pixels_mut(), &mut self.merged_families, extended, w, h, &mut self.rim);
        merge::remove_rim(r.depth.pixels_mut(), &mut self.merged_families, self.linear.pixels(), w, h, &mut self.rim);
        merge::remove_half_lit(r.depth.pixels_mut(), &mut self.merged_families, self.linear.pixels(), w, h, self.stripes_along_rows, &mut self.rim);
        merge::remove_isolated(r.depth.pixels_mut(), w, h, &mut self.scratch);
        clock.lap("merge", &mut laps);

        fill_cloud(&self.triangulator, &self.frame, &r.depth, &|i| self.merged_families[i], &mut r.cloud);
        r.stats.fill((w, h), &r.family_depth, r.cloud.len(), usable, pairs.name(), 1, self.config.filter);
        r.stats.stage_ms = laps;
        clock.lap("cloud", &mut r.stats.stage_ms);
        self.scanned = true;
        Ok(&self.result)
    }

    /// [`Scanner::scan_own_frame`] at a reduced scale ([`DecodeScale`]): the frame
    /// reduced, decoded by the coarse scanner, its stripe coordinates brought back to
    /// every pixel ([`upsample_coords`]) and triangulated and merged at the frame's size.
    /// The coarse scan's rim, contradiction and isolated-point removals stand: a pixel
    /// gets a coordinate only beside a reduced pixel whose depth the merge kept.
    fn scan_coarse(&mut self) -> Result<&ScanResult> {
        let (w, h) = (self.width, self.height);
        let mut clock = StageClock::start(self.config.clock);
        let coarse = self.coarse.as_deref_mut().ok_or_else(|| Error::Internal("no coarse scanner".into()))?;
        downsample_box_into(&self.frame, coarse.factor, &mut coarse.frame);
        let mut laps = std::mem::take(&mut self.result.stats.stage_ms);
        laps.clear();
        clock.lap("reduce", &mut laps);
        let inner = coarse.scanner.scan(&coarse.frame)?;
        laps.extend(inner.stats.stage_ms.iter().copied());
        clock.split();
        let r = &mut self.result;
        for (out, coords) in r.stripe_coords.iter_mut().zip(&inner.stripe_coords) {
            upsample_coords(coords, inner.depth.pixels(), &coarse.table, out);
        }
        clock.lap("upsample", &mut laps);
        // Each family's depth at the frame's scale, in bands of rows: at once with
        // threads, in order without (`cfg(parallel)`, build.rs).
        let triangulator = &self.triangulator;
        let band = w * UPSAMPLE_ROWS;
        for (k, (coords, (depth, weights))) in r.stripe_coords.iter().zip(r.family_depth.iter_mut().zip(self.weights.iter_mut())).enumerate() {
            let rows = |b: usize, q: &[f32], d: &mut [f32], wt: &mut [f32]| triangulator.family_depth_rows_into(k, b * UPSAMPLE_ROWS, q, d, wt);
            // A single family has no weights (empty): each band gets none.
            macro_rules! bands {
                ($chunks:ident, $chunks_mut:ident) => {
                    if weights.is_empty() {
                        coords.$chunks(band).zip(depth.pixels_mut().$chunks_mut(band)).enumerate().for_each(|(b, (q, d))| rows(b, q, d, &mut []));
                    } else {
                        coords.$chunks(band).zip(depth.pixels_mut().$chunks_mut(band).zip(weights.$chunks_mut(band))).enumerate().for_each(|(b, (q, (d, wt)))| rows(b, q, d, wt));
                    }
                };
            }
            #[cfg(parallel)]
            {
                use rayon::prelude::*;
                bands!(par_chunks, par_chunks_mut);
            }
            #[cfg(not(parallel))]
            bands!(chunks, chunks_mut);
        }
        merge::merge_into(&r.family_depth, &self.weights, r.depth.pixels_mut(), &mut self.merged_families);
        clock.lap("full-scale depth", &mut laps);
        fill_cloud(&self.triangulator, &self.frame, &r.depth, &|i| self.merged_families[i], &mut r.cloud);
        let f2 = coarse.factor * coarse.factor;
        r.stats.fill((w, h), &r.family_depth, r.cloud.len(), inner.stats.usable * f2, inner.stats.chroma, coarse.factor, self.config.filter);
        r.stats.stage_ms = laps;
        clock.lap("full-scale cloud", &mut r.stats.stage_ms);
        self.scanned = true;
        Ok(&self.result)
    }

    /// The factor the frame is reduced by before decoding (1: decoded at its own
    /// scale; see [`DecodeScale`]).
    pub fn decode_factor(&self) -> usize {
        self.coarse.as_ref().map_or(1, |c| c.factor)
    }

    /// The result of the last scan.
    pub fn result(&self) -> &ScanResult {
        &self.result
    }

    /// The cloud of a layer of the last scan: `None` for the merged cloud (the
    /// result's), `Some(k)` for family k's own (family mask `1 << k`), made from its
    /// depth map when asked: live frames show the merged cloud only, and three clouds
    /// of a large frame would cost hundreds of megabytes.
    pub fn layer(&self, family: Option<usize>) -> Result<std::borrow::Cow<'_, Cloud>> {
        let r = &self.result;
        match family {
            None => Ok(std::borrow::Cow::Borrowed(&r.cloud)),
            Some(k) => {
                let depth = r.family_depth.get(k).ok_or_else(|| Error::Setting {
                    name: "layer",
                    problem: format!("family {k} does not exist (the pattern has {})", r.family_depth.len()),
                })?;
                let mut cloud = Cloud::default();
                fill_cloud(&self.triangulator, &self.frame, depth, &|_| 1 << k, &mut cloud);
                Ok(std::borrow::Cow::Owned(cloud))
            }
        }
    }

    /// Each family's restored log image from the last scan (for tests and tools).
    pub fn restored(&self) -> &[Restored] {
        if let Some(c) = self.coarse.as_deref() {
            return c.scanner.restored();
        }
        &self.restored
    }

    /// Each family's boundaries from the last scan.
    pub fn segmentations(&self) -> &[Segmentation] {
        if let Some(c) = self.coarse.as_deref() {
            return c.scanner.segmentations();
        }
        &self.segmentations
    }

    /// Each family's stripe coordinate per pixel from the last scan (NaN = none).
    pub fn stripe_coords(&self) -> &[Vec<f32>] {
        &self.result.stripe_coords
    }

    /// The stages of the last scan as pictures: input, per family the restored image,
    /// the chosen angle, the segmentation, the stripe identities and the depth, then
    /// the merged depth. Empty before the first scan.
    pub fn stages(&self) -> Vec<Stage> {
        if !self.scanned {
            return Vec::new();
        }
        if let Some(c) = self.coarse.as_deref() {
            // The stages the decoder saw, at the reduced scale: each caption says so.
            let (w, h) = c.scanner.size();
            let mut stages = c.scanner.stages();
            for stage in &mut stages {
                stage.caption = format!("{} (Decoded at 1/{} scale, {w}x{h}.)", stage.caption, c.factor);
            }
            return stages;
        }
        crate::stages::render(&StageInputs {
            frame: &self.frame,
            filter: self.config.filter,
            restored: &self.restored,
            segmentations: &self.segmentations,
            stripe_coords: &self.result.stripe_coords,
            family_depth: &self.result.family_depth,
            depth: &self.result.depth,
        })
    }

    /// The camera's colour mixing estimated from the last scan's own frame and the
    /// stripes it identified ([`crate::calib::estimate_crosstalk_from_stripes`]), for a
    /// rig whose white-card frames were never taken. The estimate does not depend on
    /// the mixing this scanner decodes with; a scanner made with it identifies more.
    pub fn estimate_crosstalk(&self) -> Result<FrameMixing> {
        if !self.scanned {
            return Err(Error::FrameMixing("nothing has been scanned yet".into()));
        }
        if let Some(c) = self.coarse.as_deref() {
            return c.scanner.estimate_crosstalk();
        }
        let colour = if detect_chroma_pairs(&self.frame) == ChromaPairs::default() { &self.frame } else { &self.interpolated };
        let period = self.predictions.iter().map(|p| p.period).fold(0.0f32, f32::max);
        // Small enough that a frame of broad stripes still has some hundred tiles.
        let most = ((self.width * self.height) as f32 / FRAME_MIXING_MIN_TILES).sqrt();
        let tile = (FRAME_MIXING_TILE_PERIODS * period).min(most).max(16.0).round() as usize;
        let r = &self.result;
        let estimate = |tile| estimate_crosstalk_from_stripes(&self.spec, colour.pixels(), self.width, &self.lut, &r.stripe_coords, r.depth.pixels(), tile);
        // Where too few small tiles show enough colours, larger ones may.
        estimate(tile).or_else(|_| estimate(2 * tile))
    }

    /// The 8-bit frame of the last scan.
    pub fn frame(&self) -> &Image<[u8; 3]> {
        &self.frame
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A field of stripe coordinates that is a plane over the reduced pixels comes back
    /// as the same plane over the frame's pixels; a jump of more than half a stripe is
    /// not blurred across, and reduced pixels without a kept depth give nothing.
    #[test]
    fn coordinates_found_at_a_reduced_scale_come_back_to_every_pixel() {
        // 90 rows: more than one chunk of [`UPSAMPLE_ROWS`].
        let (cw, ch, factor) = (8usize, 30usize, 3usize);
        let plane = |x: f32, y: f32| 10.0 + 0.25 * x + 0.05 * y;
        let mut coarse: Vec<f32> = (0..cw * ch).map(|i| plane((i % cw) as f32, (i / cw) as f32)).collect();
        let mut depth = vec![700.0f32; cw * ch];
        let (w, h) = (cw * factor, ch * factor);
        let table = Resample::new((w, h), (cw, ch), factor);
        let mut out = vec![0.0; w * h];
        upsample_coords(&coarse, &depth, &table, &mut out);
        for y in 0..h {
            for x in 0..w {
                // The frame's pixel centre in reduced pixels, inside the reduced frame.
                let fx = ((x as f32 + 0.5) / factor as f32 - 0.5).clamp(0.0, (cw - 1) as f32);
                let fy = ((y as f32 + 0.5) / factor as f32 - 0.5).clamp(0.0, (ch - 1) as f32);
                assert!((out[y * w + x] - plane(fx, fy)).abs() < 1e-4, "({x}, {y}): {} vs {}", out[y * w + x], plane(fx, fy));
            }
        }
        // A jump of 3 stripes between reduced columns 3 and 4, and no depth at (6, 2).
        for (i, q) in coarse.iter_mut().enumerate() {
            if i % cw >= 4 {
                *q += 3.0;
            }
        }
        depth[2 * cw + 6] = f32::NAN;
        upsample_coords(&coarse, &depth, &table, &mut out);
        for y in 0..h {
            for x in 0..w {
                let (nx, ny) = (((x as f32 + 0.5) / factor as f32 - 0.5).round() as usize, ((y as f32 + 0.5) / factor as f32 - 0.5).round() as usize);
                let (nx, ny) = (nx.min(cw - 1), ny.min(ch - 1));
                let q = out[y * w + x];
                if (nx, ny) == (6, 2) {
                    assert!(q.is_nan(), "({x}, {y}) took {q} beside a pixel without depth");
                } else {
                    let nearest = coarse[ny * cw + nx];
                    assert!((q - nearest).abs() < 0.3, "({x}, {y}): {q} blurred across the jump from {nearest}");
                }
            }
        }
    }

    /// `auto` reduces by the period over the target and by the camera pixels per
    /// projector pixel, never below the fewest pixels or the smallest side; a factor
    /// given is kept where the frame allows it.
    #[test]
    fn the_decode_factor_follows_the_stripes_and_the_frame() {
        let prediction = |period| FamilyPrediction { angle: 0.0, period, axis: ScanAxis::Rows, increasing: true };
        let eight_mp = [prediction(26.6), prediction(26.6)];
        let widths = [7.5, 7.5];
        assert_eq!(coarse_factor(DecodeScale::Full, &eight_mp, &widths, 3264, 2448), 1);
        // 3.5 camera pixels per projector pixel: 3; 1088 x 816 is above the fewest pixels.
        assert_eq!(coarse_factor(DecodeScale::Auto, &eight_mp, &widths, 3264, 2448), 3);
        assert_eq!(coarse_factor(DecodeScale::Auto, &eight_mp, &widths, 1920, 1440), 3);
        // A third of 1600 x 1200 is too small: a half.
        assert_eq!(coarse_factor(DecodeScale::Auto, &eight_mp, &widths, 1600, 1200), 2);
        // 15.6-pixel stripes, 4 camera pixels per projector pixel: the stripes allow 2.
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(15.6)], &[3.9], 3264, 2448), 2);
        // 2 camera pixels per projector pixel: the frame's own scale, however broad.
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(19.9)], &[10.0], 1920, 1080), 1);
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(40.0)], &[20.0], 4096, 3072), 1);
        // 3-pixel projector stripes 23 camera pixels wide: the stripes decide.
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(23.0)], &[3.0], 3264, 2448), 3);
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(6.5)], &[10.0], 640, 480), 1);
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(400.0)], &[10.0], 640, 480), 1);
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(400.0)], &[10.0], 1280, 960), 2);
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(400.0)], &[10.0], 1200, 900), 1);
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(400.0)], &[10.0], 4096, 3072), COARSE_MAX_FACTOR);
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(400.0)], &[10.0], 1920, 1080), 2);
        assert_eq!(coarse_factor(DecodeScale::Auto, &[prediction(f32::NAN)], &[10.0], 4096, 3072), 1);
        assert_eq!(coarse_factor(DecodeScale::Factor(3), &eight_mp, &widths, 640, 480), 3);
        assert_eq!(coarse_factor(DecodeScale::Factor(16), &eight_mp, &widths, 40, 30), 1);
        assert_eq!(coarse_factor(DecodeScale::Factor(16), &eight_mp, &widths, 64, 48), 3);
        assert!("0".parse::<DecodeScale>().unwrap_err().to_string().contains("decode scale"));
        assert_eq!("auto".parse::<DecodeScale>().unwrap(), DecodeScale::Auto);
        assert_eq!("4".parse::<DecodeScale>().unwrap(), DecodeScale::Factor(4));
    }
}
