//! The long-lived scanner: one object per (pattern spec, calibration, image size)
//! that owns every plan and buffer the per-frame path needs, and is fed frames.
//!
//! `Scanner::scan` runs the stages in the paper's order: 8-bit frame to linear light,
//! [`crate::filter`] (log-gradient restoration per family, or none for `direct`),
//! [`crate::segment`] (stripe boundaries with transition codes, sub-pixel),
//! [`crate::decode`] (stripe identities from neighbour windows), [`crate::triangulate`]
//! (depth per family, ray-ray where two families meet) and [`crate::merge`].

use crate::calib::Calibration;
use crate::cloud::CloudPoint;
use crate::decode::Decoder;
use crate::error::{Error, Result};
use crate::filter::{FamilyWindow, LogGradFilter, Restored};
use crate::merge;
use crate::pattern::PatternSpec;
use crate::raster::{Image, Rgb};
use crate::segment::{usable_mask_into, ScanAxis, Segmentation};
use crate::triangulate::Triangulator;
use glam::DVec3;
use serde::Serialize;
use std::fmt;
use std::str::FromStr;

/// How the captured colours are turned into stripe colours.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FilterMode {
    /// The captured colours as they are (the paper's "direct estimation").
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
            other => Err(Error::Invalid(format!(
                "filter must be direct, loggrad or loggrad-norot, got {other:?}"
            ))),
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

/// Settings of a scanner.
#[derive(Clone, Debug)]
pub struct ScanConfig {
    /// Which restoration feeds segmentation.
    pub filter: FilterMode,
    /// The camera's encoding gamma: 8-bit value = 255 · linear^(1/gamma). 2.2 suits
    /// the simulator and most webcams.
    pub camera_gamma: f32,
    /// Keep the intermediate images of the last frame for [`Scanner::stages`]
    /// (costs a little time per frame; the teaching view and `--debug` turn it on).
    pub keep_stages: bool,
    /// The camera's colour mixing: linear camera RGB = `crosstalk` · linear light of
    /// the projector's primaries (row = camera channel). Measured once per rig by
    /// projecting pure red, green and blue onto a white card; the identity when
    /// unknown. The scanner undoes it before anything else: on saturated surfaces a
    /// bright channel leaking into a dark one would otherwise fake transitions.
    pub crosstalk: [[f32; 3]; 3],
    /// A clock in milliseconds for the per-stage timings in [`ScanStats::stage_ms`]:
    /// the operating system's natively, none in WebAssembly unless the boundary gives
    /// one (the pipeline itself knows nothing of the browser).
    pub clock: Option<fn() -> f64>,
}

/// No colour mixing.
pub const IDENTITY_CROSSTALK: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

impl Default for ScanConfig {
    fn default() -> Self {
        ScanConfig {
            filter: FilterMode::LogGrad,
            camera_gamma: 2.2,
            keep_stages: false,
            crosstalk: IDENTITY_CROSSTALK,
            #[cfg(not(target_arch = "wasm32"))]
            clock: Some(native_clock),
            #[cfg(target_arch = "wasm32")]
            clock: None,
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
    /// Milliseconds per stage, when the configuration has a clock.
    pub stage_ms: Vec<(&'static str, f64)>,
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

/// What a scan produces.
#[derive(Clone, Debug, Default)]
pub struct ScanResult {
    /// The merged cloud.
    pub points: Vec<CloudPoint>,
    /// Each family's own cloud.
    pub family_points: Vec<Vec<CloudPoint>>,
    /// Merged depth (Z, mm, camera frame) per camera pixel; NaN where none.
    pub depth: Image<f32>,
    /// Each family's depth map.
    pub family_depth: Vec<Image<f32>>,
    /// Figures about the scan.
    pub stats: ScanStats,
}

/// A named intermediate image for people to look at.
#[derive(Clone, Debug)]
pub struct Stage {
    /// Short file-name-friendly name, e.g. `restored-0`.
    pub name: String,
    /// What it shows, one sentence.
    pub caption: String,
    /// The picture.
    pub image: Image<[u8; 3]>,
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
    /// Inverse of the crosstalk matrix, `None` for the identity.
    unmix: Option<glam::Mat3>,
    frame: Image<[u8; 3]>,
    linear: Image<Rgb>,
    usable: Vec<bool>,
    filter: LogGradFilter,
    windows: Vec<FamilyWindow>,
    predictions: Vec<FamilyPrediction>,
    restored: Vec<Restored>,
    segmentations: Vec<Segmentation>,
    decoders: Vec<Decoder>,
    coords: Vec<Vec<f32>>,
    triangulator: Triangulator,
    depths: Vec<Vec<f32>>,
    weights: Vec<Vec<f32>>,
    merged: Vec<f32>,
    merged_families: Vec<u8>,
    scratch: Vec<f32>,
    result: ScanResult,
    scanned: bool,
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

/// A stripe wider than this many predicted periods is not bridged (surfaces slanted
/// away from the projector stretch stripes; much wider means a missed boundary).
const MAX_STRIPE_PERIODS: f32 = 3.0;

impl Scanner {
    /// A scanner for frames of the calibration's camera size. The pattern's size must
    /// be the calibration's projector size.
    pub fn new(spec: PatternSpec, calib: Calibration, config: ScanConfig) -> Result<Scanner> {
        spec.validate()?;
        calib.validate()?;
        if (spec.width, spec.height) != (calib.projector.width, calib.projector.height) {
            return Err(Error::Invalid(format!(
                "the pattern is {}x{} but the calibration's projector is {}x{}: they must describe the same projector",
                spec.width, spec.height, calib.projector.width, calib.projector.height
            )));
        }
        if !(config.camera_gamma.is_finite() && (0.2..=5.0).contains(&config.camera_gamma)) {
            return Err(Error::Invalid(format!("camera gamma must be in 0.2..=5, got {}", config.camera_gamma)));
        }
        let (w, h) = (calib.camera.width as usize, calib.camera.height as usize);
        if config.crosstalk.iter().flatten().any(|x| !x.is_finite()) {
            return Err(Error::Invalid("crosstalk matrix has a value that is not a number".into()));
        }
        let mix = glam::Mat3::from_cols_array_2d(&config.crosstalk).transpose();
        let unmix = if config.crosstalk == IDENTITY_CROSSTALK {
            None
        } else if mix.determinant().abs() < 1e-3 {
            return Err(Error::Invalid(format!("crosstalk matrix {:?} cannot be inverted", config.crosstalk)));
        } else {
            Some(mix.inverse())
        };
        let predictions = predict_families(&spec, &calib)?;
        let windows = FamilyWindow::for_families(&predictions.iter().map(|p| p.angle).collect::<Vec<_>>());
        let n = spec.families.len();
        let mut lut = [0f32; 256];
        for (i, l) in lut.iter_mut().enumerate() {
            *l = (i as f32 / 255.0).powf(config.camera_gamma);
        }
        let decoders = predictions.iter().enumerate().map(|(k, p)| Decoder::new(&spec, k, p.increasing)).collect();
        let triangulator = Triangulator::new(&calib, &spec);
        let plane = || vec![f32::NAN; w * h];
        Ok(Scanner {
            filter: LogGradFilter::new(w, h)?,
            restored: (0..n).map(|_| Restored::new(w, h)).collect(),
            segmentations: (0..n).map(|_| Segmentation::default()).collect(),
            coords: (0..n).map(|_| plane()).collect(),
            depths: (0..n).map(|_| plane()).collect(),
            weights: (0..n).map(|_| plane()).collect(),
            merged: plane(),
            merged_families: vec![0; w * h],
            scratch: Vec::with_capacity(w * h),
            frame: Image::new(w, h, [0; 3]),
            linear: Image::new(w, h, [0.0; 3]),
            usable: vec![false; w * h],
            result: ScanResult {
                depth: Image::new(w, h, f32::NAN),
                family_depth: (0..n).map(|_| Image::new(w, h, f32::NAN)).collect(),
                family_points: vec![Vec::new(); n],
                ..Default::default()
            },
            spec,
            calib,
            config,
            width: w,
            height: h,
            lut,
            unmix,
            windows,
            predictions,
            decoders,
            triangulator,
            scanned: false,
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
    }

    /// Keep (or stop keeping) what [`Scanner::stages`] needs.
    pub fn set_keep_stages(&mut self, keep: bool) {
        self.config.keep_stages = keep;
    }

    /// Scan an interleaved RGBA frame (a canvas's `ImageData`).
    pub fn scan_rgba(&mut self, width: usize, height: usize, rgba: &[u8]) -> Result<&ScanResult> {
        if (width, height) != (self.width, self.height) {
            return Err(Error::ImageSize { expected: (self.width, self.height), got: (width, height) });
        }
        if rgba.len() != width * height * 4 {
            return Err(Error::Invalid(format!(
                "{} RGBA bytes cannot be a {width}x{height} frame (expected {})",
                rgba.len(),
                width * height * 4
            )));
        }
        for (d, s) in self.frame.pixels_mut().iter_mut().zip(rgba.chunks_exact(4)) {
            *d = [s[0], s[1], s[2]];
        }
        self.scan_own_frame()
    }

    /// Scan an 8-bit RGB frame.
    pub fn scan(&mut self, frame: &Image<[u8; 3]>) -> Result<&ScanResult> {
        frame.expect_size(self.width, self.height)?;
        self.frame.pixels_mut().copy_from_slice(frame.pixels());
        self.scan_own_frame()
    }

    fn scan_own_frame(&mut self) -> Result<&ScanResult> {
        let (w, h) = (self.width, self.height);
        let mut clock = StageClock::start(self.config.clock);
        let mut laps = std::mem::take(&mut self.result.stats.stage_ms);
        laps.clear();
        for (d, s) in self.linear.pixels_mut().iter_mut().zip(self.frame.pixels()) {
            *d = [self.lut[s[0] as usize], self.lut[s[1] as usize], self.lut[s[2] as usize]];
        }
        if let Some(m) = self.unmix {
            for p in self.linear.pixels_mut() {
                *p = (m * glam::Vec3::from_array(*p)).max(glam::Vec3::ZERO).to_array();
            }
        }
        let usable = usable_mask_into(self.frame.pixels(), self.linear.pixels(), &mut self.usable);
        clock.lap("linearize", &mut laps);
        self.filter.run(&self.linear, &self.windows, self.config.filter, &mut self.restored)?;
        clock.lap("filter", &mut laps);
        let families = self.spec.families.len();
        for k in 0..families {
            let pred = self.predictions[k];
            self.segmentations[k].run(&self.restored[k], &self.usable, pred.axis, pred.period);
            clock.lap("segment", &mut laps);
            self.decoders[k].run(&mut self.segmentations[k]);
            self.decoders[k].stripe_coords_into(&self.segmentations[k], w, MAX_STRIPE_PERIODS * pred.period, &mut self.coords[k]);
            clock.lap("decode", &mut laps);
            self.triangulator.family_depth_into(k, &self.coords[k], &mut self.depths[k], &mut self.weights[k]);
            clock.lap("triangulate", &mut laps);
            merge::remove_isolated(&mut self.depths[k], w, h, &mut self.scratch);
            clock.lap("merge", &mut laps);
        }
        merge::merge_into(&self.depths, &self.weights, &mut self.merged, &mut self.merged_families);
        merge::remove_isolated(&mut self.merged, w, h, &mut self.scratch);
        clock.lap("merge", &mut laps);

        let r = &mut self.result;
        r.depth.pixels_mut().copy_from_slice(&self.merged);
        r.points.clear();
        let frame = self.frame.pixels();
        let point = |i: usize, z: f32, families: u8| CloudPoint {
            position: self.triangulator.point(i, z),
            color: frame[i],
            pixel: [(i % w) as f32, (i / w) as f32],
            families,
        };
        for (i, &z) in self.merged.iter().enumerate() {
            if !z.is_nan() {
                r.points.push(point(i, z, self.merged_families[i]));
            }
        }
        r.stats.decoded.clear();
        for k in 0..families {
            r.family_depth[k].pixels_mut().copy_from_slice(&self.depths[k]);
            let pts = &mut r.family_points[k];
            pts.clear();
            for (i, &z) in self.depths[k].iter().enumerate() {
                if !z.is_nan() {
                    pts.push(point(i, z, 1 << k));
                }
            }
            r.stats.decoded.push(pts.len());
        }
        // Filled in place: the per-frame path reuses the stats' vectors and string.
        let stats = &mut r.stats;
        (stats.width, stats.height, stats.merged, stats.usable) = (w, h, r.points.len(), usable);
        stats.filter.clear();
        {
            use std::fmt::Write;
            let _ = write!(stats.filter, "{}", self.config.filter);
        }
        stats.stage_ms = laps;
        clock.lap("cloud", &mut r.stats.stage_ms);
        self.scanned = true;
        Ok(&self.result)
    }

    /// The result of the last scan.
    pub fn result(&self) -> &ScanResult {
        &self.result
    }

    /// Each family's restored log image from the last scan (for tests and tools).
    pub fn restored(&self) -> &[Restored] {
        &self.restored
    }

    /// Each family's boundaries from the last scan.
    pub fn segmentations(&self) -> &[Segmentation] {
        &self.segmentations
    }

    /// Each family's stripe coordinate per pixel from the last scan (NaN = none).
    pub fn stripe_coords(&self) -> &[Vec<f32>] {
        &self.coords
    }

    /// The stages of the last scan as pictures: input, per family the restored image,
    /// the chosen angle, the segmentation, the stripe identities and the depth, then
    /// the merged depth. Empty before the first scan.
    pub fn stages(&self) -> Vec<Stage> {
        if !self.scanned {
            return Vec::new();
        }
        crate::stages::render(self)
    }

    /// The 8-bit frame of the last scan.
    pub fn frame(&self) -> &Image<[u8; 3]> {
        &self.frame
    }
}
