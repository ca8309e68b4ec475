//! The hard evaluation (issue 10): every scene under conditions as hard as the world's,
//! scanned as a user would (default rig, two directions, `loggrad`, the colour mixing
//! measured from white-card frames), beside the multi-shot Gray-code reference
//! ([`super::graycode`]) photographed through the same simulated view and camera.
//!
//! A [`Condition`] changes the rig (a camera of another resolution, a projector that
//! lights only part of the frame), the pattern's stripe width, the projector's focus and
//! the camera (clipping exposure, 4:2:0 chroma and JPEG); [`CONDITIONS`] lists them with their parameters
//! and where each value comes from. [`report`] writes `docs/accuracy.md`.

use super::graycode::{gray_reference, GrayReference};
use super::{evaluate_with, measure, Metrics, Row};
use crate::calib::response::{DEFAULT_GREY_LEVEL, POWER_LAW_TOLERANCE};
use crate::calib::{estimate_crosstalk_for, estimate_response, CameraResponse, Calibration, Crosstalk};
use crate::error::{Error, Result};
use crate::filter::FilterMode;
use crate::pattern::{PatternSpec, DEFAULT_STRIPE_WIDTH};
use crate::raster::Image;
use crate::calib::IDENTITY_CROSSTALK;
use crate::scan::{ScanConfig, Scanner, FRAME_MIXING_ROUNDS};
use crate::sim::{self, pigments, rig, Frame, Scene, Scratch, Shape, SimConfig, Texture, View};
use glam::DVec3;
use serde::Serialize;
use std::collections::HashMap;
use std::fmt::Write;

/// Share of the bright-stripe pixels that the `clipped` condition clips in at least
/// one channel: 20 %, the middle of the 10-30 % seen in real photographs of stripe
/// patterns exposed for a bright object (issue 10).
pub const CLIP_FRACTION: f32 = 0.2;

/// JPEG quality of the `webcam` condition: 80, a webcam's MJPEG stream (issue 10).
pub const WEBCAM_JPEG_QUALITY: u8 = 80;

/// Projector zoom of the `partial` condition: its focal length 1.15 times the demo
/// rig's (a longer-throw lens), so its image is 13 % narrower.
pub const PARTIAL_ZOOM: f64 = 1.15;

/// Where the `partial` condition's projector aims (camera frame, mm): 130 mm right of
/// and 95 mm below the camera's axis at the working distance, as a projector put
/// beside the camera and pointed at the object rather than at the frame's centre.
/// With [`PARTIAL_ZOOM`] it lights 56-63 % of the frame on the built-in scenes, set
/// for the middle of issue 10's 50-70 % (`tests/hard_sim.rs` checks that range).
pub const PARTIAL_TARGET_MM: [f64; 3] = [130.0, 95.0, 750.0];

/// Stripe width of the `narrow` condition, projector pixels: about 3 camera pixels at
/// 750 mm on the demo rig (0.65 camera pixels per projector pixel there), the
/// narrowest of the 3-25.
pub const NARROW_STRIPE_WIDTH: f64 = 4.6;

/// Stripe width of the `wide` condition, projector pixels: about 25 camera pixels at
/// 750 mm, the widest of the range.
pub const WIDE_STRIPE_WIDTH: f64 = 38.0;

/// Camera scale of the `8mp` condition: 5.1 times VGA is 3264 x 2448, 7.99 million
/// pixels, the usual 8-megapixel sensor format.
pub const EIGHT_MP_SCALE: f64 = 5.1;

/// Stripe width of the `8mp` condition, projector pixels: about 25 camera pixels at
/// 750 mm in the 8-megapixel camera (the default 10 would make 33).
pub const EIGHT_MP_STRIPE_WIDTH: f64 = 7.5;

/// Blur of the `soft` condition's projector, projector pixels (standard deviation):
/// 0.3 of the default 10-pixel stripe, so a stripe's edges rise over 2.56 σ = 7.7
/// pixels (10-90 %) and its middle reaches only 90 % of the step. That is the profile
/// of a projector out of focus or with a soft lens, and close to the lobes without a
/// flat top of a real capture (Zion1123's sphere, docs/third-party.md: lobes of
/// σ ≈ 3 projector pixels 14 apart).
pub const SOFT_PROJECTOR_BLUR: f64 = 3.0;

/// Where the `shoulder` condition's tone curve leaves the power law, as a share of the
/// code range ([`SimConfig::highlight_knee`]). Phone and many webcam pipelines roll the
/// highlights off rather than clip them at the power law's end; 0.8 (code 204) puts
/// the roll-off over the top fifth of the codes, holding 1.5 times the light (about
/// 0.6 stops) a plain power law would clip. The value is assumed, not measured from a
/// camera here: a moderate shoulder.
/// At the default exposure little reaches the shoulder (coverage stayed within half a
/// point of `default` on every scene, outliers within 0.01 point), so the condition
/// raises the exposure as `clipped` does: a user who turns it up until the object
/// looks bright puts the bright stripes on the shoulder.
pub const SHOULDER_KNEE: f32 = 0.8;

/// The scene on which the colour mixing is measured: the white plane stands in for
/// the white card a user photographs.
pub const CARD_SCENE: &str = "plane";

/// One condition of the hard evaluation.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Condition {
    /// Name, as `stripelight eval --conditions` takes it.
    pub name: &'static str,
    /// One line for the table's legend.
    pub summary: &'static str,
    /// Camera resolution as a multiple of the demo rig's VGA (same field of view).
    /// Above 1 the simulator casts one ray per pixel (the pixels are small); the
    /// defocus blur stays 0.6 of the camera's own pixels (a lens that resolves its
    /// sensor, as a phone's or a good webcam's does).
    pub camera_scale: f64,
    /// Stripe width of the one-shot pattern, projector pixels.
    pub stripe_width: f64,
    /// The projector lights only part of the frame ([`PARTIAL_ZOOM`], [`PARTIAL_TARGET_MM`]).
    pub partial_projector: bool,
    /// The projector's own blur, projector pixels ([`SimConfig::projector_blur`]).
    pub projector_blur: f64,
    /// Exposure raised until this share of the bright-stripe pixels clips.
    pub clip_fraction: Option<f32>,
    /// 4:2:0 chroma and JPEG at this quality, as a webcam delivers frames.
    pub webcam_jpeg: Option<u8>,
    /// The camera's tone curve leaves the power law here ([`SimConfig::highlight_knee`];
    /// 1, none).
    pub highlight_knee: f32,
    /// The scenes the full report runs this condition on, when not all (the
    /// 8-megapixel rows take a minute each).
    pub report_scenes: Option<&'static [&'static str]>,
}

impl Condition {
    const BASE: Condition = Condition {
        name: "default",
        summary: "the simulator's defaults: VGA camera, whole frame lit, no clipping, lossless frames, \
                  10-pixel stripes (about 6.5 camera pixels)",
        camera_scale: 1.0,
        stripe_width: DEFAULT_STRIPE_WIDTH,
        partial_projector: false,
        projector_blur: 0.0,
        clip_fraction: None,
        webcam_jpeg: None,
        highlight_knee: 1.0,
        report_scenes: None,
    };
}

/// The scenes of the full report's `8mp` rows: every class of surface (plain, real
/// pigments, skin, 1 % dyes with and without near-black patches).
pub const EIGHT_MP_REPORT_SCENES: &[&str] = &["plane", "wall", "colorchecker", "skin", "sphere-dye", "bag"];

/// The conditions, in the table's order.
pub const CONDITIONS: &[Condition] = &[
    Condition::BASE,
    Condition {
        name: "partial",
        summary: "the projector lights about 60 % of the frame (longer throw, aimed off-centre); \
                  the rest is lit by the room only",
        partial_projector: true,
        ..Condition::BASE
    },
    Condition {
        name: "clipped",
        summary: "exposure raised until 20 % of the bright-stripe pixels clip in at least one channel",
        clip_fraction: Some(CLIP_FRACTION),
        ..Condition::BASE
    },
    Condition {
        name: "webcam",
        summary: "4:2:0 chroma (colour at half resolution) and JPEG quality 80",
        webcam_jpeg: Some(WEBCAM_JPEG_QUALITY),
        ..Condition::BASE
    },
    Condition {
        name: "narrow",
        summary: "4.6-pixel stripes: about 3 camera pixels",
        stripe_width: NARROW_STRIPE_WIDTH,
        ..Condition::BASE
    },
    Condition {
        name: "wide",
        summary: "38-pixel stripes: about 25 camera pixels",
        stripe_width: WIDE_STRIPE_WIDTH,
        ..Condition::BASE
    },
    Condition {
        name: "soft",
        summary: "a projector out of focus: its image blurred by a Gaussian of 3 projector pixels, \
                  so the stripes slope and have no flat top",
        projector_blur: SOFT_PROJECTOR_BLUR,
        ..Condition::BASE
    },
    Condition {
        name: "shoulder",
        summary: "`clipped` with a camera whose tone curve compresses the highlights: codes above 80 % \
                  of the range (204) roll off smoothly to full scale, reached at 1.5 times the light \
                  a plain power law clips at",
        clip_fraction: Some(CLIP_FRACTION),
        highlight_knee: SHOULDER_KNEE,
        ..Condition::BASE
    },
    Condition {
        name: "8mp",
        summary: "an 8-megapixel camera (3264 x 2448), 7.5-pixel stripes: about 25 camera pixels, 3.5 per projector pixel, so the scanner decodes at a third of the scale",
        camera_scale: EIGHT_MP_SCALE,
        stripe_width: EIGHT_MP_STRIPE_WIDTH,
        report_scenes: Some(EIGHT_MP_REPORT_SCENES),
        ..Condition::BASE
    },
    Condition {
        name: "world",
        summary: "partial, clipped and webcam together",
        partial_projector: true,
        clip_fraction: Some(CLIP_FRACTION),
        webcam_jpeg: Some(WEBCAM_JPEG_QUALITY),
        ..Condition::BASE
    },
];

/// The condition called `name`; fails listing the known ones.
pub fn condition(name: &str) -> Result<&'static Condition> {
    CONDITIONS.iter().find(|c| c.name == name).ok_or_else(|| Error::Setting {
        name: "condition",
        problem: format!(
            "unknown condition {name:?}; known: {}",
            CONDITIONS.iter().map(|c| c.name).collect::<Vec<_>>().join(", ")
        ),
    })
}

impl Condition {
    /// The rig: the demo rig with this condition's camera and projector.
    pub fn rig(&self) -> Result<Calibration> {
        let mut calib = Calibration::demo();
        if self.camera_scale != 1.0 {
            calib = rig::scaled_camera(&calib, self.camera_scale)?;
        }
        if self.partial_projector {
            calib = rig::partial_projector(&calib, PARTIAL_ZOOM, DVec3::from_array(PARTIAL_TARGET_MM))?;
        }
        Ok(calib)
    }

    /// The one-shot pattern (two directions) for `calib`'s projector.
    pub fn pattern(&self, calib: &Calibration) -> Result<PatternSpec> {
        PatternSpec::generate(2, calib.projector.width, calib.projector.height, self.stripe_width)
    }

    /// The camera settings before the exposure is set for clipping.
    pub fn camera(&self, seed: u64, projector_gamma: f32) -> SimConfig {
        let base = SimConfig::default();
        SimConfig {
            seed,
            projector_gamma,
            supersample: if self.camera_scale > 1.0 { 1 } else { base.supersample },
            projector_blur: self.projector_blur as f32,
            chroma_420: self.webcam_jpeg.is_some(),
            jpeg_quality: self.webcam_jpeg,
            highlight_knee: self.highlight_knee,
            ..base
        }
    }
}

/// Share of the white card's pixels that clip under full white in the frames
/// [`measured_response`] takes: the user raises the exposure until the card's
/// brightest part just clips, so that the white frame reaches the top of the codes.
pub const RESPONSE_CLIP_FRACTION: f32 = 0.02;

/// The camera's response as a user measures it: the white card ([`CARD_SCENE`]) under
/// the projector's full white, grey [`DEFAULT_GREY_LEVEL`] and black, photographed with
/// `cfg`'s camera at the exposure that clips [`RESPONSE_CLIP_FRACTION`] of the card
/// under white, then [`estimate_response`].
pub fn measured_response(calib: &Calibration, cfg: &SimConfig) -> Result<CameraResponse> {
    let view = View::new(&Scene::builtin(CARD_SCENE)?, calib, cfg)?;
    let (pw, ph) = (calib.projector.width as usize, calib.projector.height as usize);
    let exposure = view.exposure_for_clipping(&Image::new(pw, ph, [255u8; 3]), cfg, RESPONSE_CLIP_FRACTION)?;
    let cfg = SimConfig { exposure, ..cfg.clone() };
    let mut scratch = Scratch::default();
    let mut shots = Vec::with_capacity(3);
    for (k, level) in [255u8, DEFAULT_GREY_LEVEL, 0].into_iter().enumerate() {
        let mut frame = Image::new(0, 0, [0u8; 3]);
        let shot = SimConfig { seed: cfg.seed.wrapping_add(0x5E_5901).wrapping_add(k as u64), ..cfg.clone() };
        view.photograph_into(&Image::new(pw, ph, [level; 3]), &shot, &mut scratch, &mut frame)?;
        shots.push(frame);
    }
    estimate_response(&shots[0], &shots[1], &shots[2], DEFAULT_GREY_LEVEL, cfg.camera_gamma, cfg.projector_gamma)
}

/// The colour mixing as a user measures it: the white card ([`CARD_SCENE`]) under the
/// projector's full red, green, blue and black, photographed with `cfg`'s camera at
/// the default exposure (a user keeps the card below saturation, as `stripelight
/// crosstalk` asks), then [`crate::calib::estimate_crosstalk`], reading the codes
/// through `response` where one was measured.
pub fn measured_crosstalk(calib: &Calibration, cfg: &SimConfig, response: Option<&CameraResponse>) -> Result<Crosstalk> {
    let cfg = SimConfig { exposure: SimConfig::default().exposure, ..cfg.clone() };
    let view = View::new(&Scene::builtin(CARD_SCENE)?, calib, &cfg)?;
    let (pw, ph) = (calib.projector.width as usize, calib.projector.height as usize);
    let mut scratch = Scratch::default();
    let mut shots = Vec::with_capacity(4);
    for (k, rgb) in [[255u8, 0, 0], [0, 255, 0], [0, 0, 255], [0, 0, 0]].into_iter().enumerate() {
        let mut frame = Image::new(0, 0, [0u8; 3]);
        let shot = SimConfig { seed: cfg.seed.wrapping_add(0xC0_1042).wrapping_add(k as u64), ..cfg.clone() };
        view.photograph_into(&Image::new(pw, ph, rgb), &shot, &mut scratch, &mut frame)?;
        shots.push(frame);
    }
    estimate_crosstalk_for([&shots[0], &shots[1], &shots[2]], &shots[3], cfg.camera_gamma, response)
}

/// Median width of the first family's stripes (vertical stripes) in camera pixels,
/// from the ground truth's projector columns: `stripe_width / |∇u_p|` over the lit
/// pixels whose right and lower neighbours are lit.
pub fn median_stripe_px(truth: &Frame, stripe_width: f64) -> f64 {
    let (w, h) = truth.lit.size();
    let p = truth.projector.pixels();
    let lit = truth.lit.pixels();
    let mut widths = Vec::new();
    for v in 0..h.saturating_sub(1) {
        for u in 0..w.saturating_sub(1) {
            let i = v * w + u;
            if !(lit[i] && lit[i + 1] && lit[i + w]) {
                continue;
            }
            let (gx, gy) = ((p[i + 1][0] - p[i][0]) as f64, (p[i + w][0] - p[i][0]) as f64);
            let g = gx.hypot(gy);
            if g > 0.0 {
                widths.push(stripe_width / g);
            }
        }
    }
    if widths.is_empty() {
        return f64::NAN;
    }
    let k = widths.len() / 2;
    *widths.select_nth_unstable_by(k, f64::total_cmp).1
}

/// The lit pixels that see the scene's subject: an object other than a backdrop (a
/// plane facing the camera straight on, as the scenes' walls and tables). The
/// `plane` and `wall` scenes, all subject, have no backdrop.
pub fn subject_mask(scene: &Scene, calib: &Calibration, truth: &Frame) -> Vec<bool> {
    let (w, _) = truth.lit.size();
    let backdrop: Vec<bool> = scene
        .objects()
        .iter()
        .map(|o| matches!(o.shape, Shape::Plane { normal, .. } if normal.x == 0.0 && normal.y == 0.0))
        .collect();
    truth
        .lit
        .pixels()
        .iter()
        .enumerate()
        .map(|(i, &lit)| {
            lit && scene
                .cast(DVec3::ZERO, calib.camera.ray((i % w) as f64, (i / w) as f64), 0.0, f64::INFINITY)
                .is_some_and(|hit| !backdrop[hit.object])
        })
        .collect()
}

/// Decoded pixels of `depth` among `mask`'s, as a share of them (0 for an empty mask).
pub fn masked_coverage(depth: &Image<f32>, mask: &[bool]) -> f64 {
    let (mut n, mut decoded) = (0usize, 0usize);
    for (z, &m) in depth.pixels().iter().zip(mask) {
        if m {
            n += 1;
            decoded += !z.is_nan() as usize;
        }
    }
    if n == 0 {
        0.0
    } else {
        decoded as f64 / n as f64
    }
}

/// The share of `mask`'s pixels with at least one channel at [`sim::CLIPPED`].
pub fn clipped_fraction(frame: &Image<[u8; 3]>, mask: &[bool]) -> f64 {
    let (mut n, mut clipped) = (0usize, 0usize);
    for (p, &m) in frame.pixels().iter().zip(mask) {
        if m {
            n += 1;
            clipped += p.contains(&sim::CLIPPED) as usize;
        }
    }
    if n == 0 {
        0.0
    } else {
        clipped as f64 / n as f64
    }
}

/// One row of the hard table.
#[derive(Clone, Debug, Serialize)]
pub struct HardRow {
    /// Scene name.
    pub scene: String,
    /// Condition name.
    pub condition: String,
    /// Camera (width, height).
    pub camera: (usize, usize),
    /// Median stripe width in camera pixels ([`median_stripe_px`]).
    pub stripe_px: f64,
    /// Lit pixels / all pixels.
    pub lit_fraction: f64,
    /// Bright-stripe pixels of the one-shot frame clipped in at least one channel.
    pub clipped: f64,
    /// The colour mixing the scanner was told (measured).
    pub crosstalk: Crosstalk,
    /// The one-shot scan (merged depth).
    pub one_shot: Metrics,
    /// The Gray-code reference.
    pub gray: Metrics,
    /// Coverage of the lit pixels on the scene's objects other than a flat backdrop
    /// ([`subject_mask`]): one-shot, then Gray code.
    pub subject_coverage: (f64, f64),
}

impl HardRow {
    /// One-shot coverage / Gray-code coverage (0 when the reference decodes nothing).
    pub fn coverage_ratio(&self) -> f64 {
        if self.gray.coverage > 0.0 {
            self.one_shot.coverage / self.gray.coverage
        } else {
            0.0
        }
    }
}

/// A row and the depth maps behind it.
pub struct HardRun {
    /// The figures.
    pub row: HardRow,
    /// The one-shot scan's merged depth.
    pub one_shot_depth: Image<f32>,
    /// The Gray-code reference's depth.
    pub gray_depth: Image<f32>,
    /// The ground truth.
    pub truth: Frame,
}

/// Runs rows of the hard table, measuring each condition's colour mixing once and
/// reusing a scene's Gray-code reference across conditions that share its rig and
/// camera (`default`, `narrow` and `wide`).
pub struct HardEval {
    seed: u64,
    crosstalk: HashMap<&'static str, Crosstalk>,
    /// Each condition's measured camera response, where it is not the power law.
    responses: HashMap<&'static str, Option<CameraResponse>>,
    gray: HashMap<String, GrayReference>,
    /// Each condition's rig, pattern spec and pattern image.
    setups: HashMap<&'static str, (Calibration, PatternSpec, Image<[u8; 3]>)>,
}

impl HardEval {
    /// A runner whose simulated frames use noise seed `seed`.
    pub fn new(seed: u64) -> Self {
        HardEval { seed, crosstalk: HashMap::new(), responses: HashMap::new(), gray: HashMap::new(), setups: HashMap::new() }
    }

    /// The camera response measured for `cond`'s camera ([`measured_response`]), or
    /// None where it is the power law within [`POWER_LAW_TOLERANCE`].
    pub fn response(&mut self, cond: &'static Condition) -> Result<Option<CameraResponse>> {
        if let Some(r) = self.responses.get(cond.name) {
            return Ok(r.clone());
        }
        let cfg = cond.camera(self.seed, 2.2);
        let measured = measured_response(&cond.rig()?, &cfg)?;
        let r = (!measured.is_power_law(cfg.camera_gamma, POWER_LAW_TOLERANCE)).then_some(measured);
        self.responses.insert(cond.name, r.clone());
        Ok(r)
    }

    /// The colour mixing measured for `cond`'s rig and camera.
    pub fn crosstalk(&mut self, cond: &'static Condition) -> Result<Crosstalk> {
        if let Some(m) = self.crosstalk.get(cond.name) {
            return Ok(*m);
        }
        let response = self.response(cond)?;
        let calib = cond.rig()?;
        let m = measured_crosstalk(&calib, &cond.camera(self.seed, 2.2), response.as_ref())?;
        self.crosstalk.insert(cond.name, m);
        Ok(m)
    }

    /// Render and scan `scene` under `cond` (no reference): what the one-shot scanner
    /// decodes, measured against the ground truth.
    pub fn one_shot(&mut self, scene_name: &str, cond: &'static Condition) -> Result<OneShot> {
        Ok(self.render_and_scan(scene_name, cond)?.0)
    }

    /// `cond`'s rig, pattern spec and pattern image, made at the first call.
    fn setup(&mut self, cond: &'static Condition) -> Result<&(Calibration, PatternSpec, Image<[u8; 3]>)> {
        if !self.setups.contains_key(cond.name) {
            let calib = cond.rig()?;
            let spec = cond.pattern(&calib)?;
            let pattern = spec.render_rgb8();
            self.setups.insert(cond.name, (calib, spec, pattern));
        }
        Ok(&self.setups[cond.name])
    }

    /// The frame a row's one-shot scan decodes: `scene` photographed under `cond`'s
    /// pattern and camera (its exposure set to clip as the condition says), with the
    /// view (whose [`View::truth`] measures a scan of it) and the camera.
    pub fn photograph(&mut self, scene: &Scene, cond: &'static Condition) -> Result<(Image<[u8; 3]>, View, SimConfig)> {
        let seed = self.seed;
        let (calib, spec, pattern) = self.setup(cond)?;
        let mut cfg = cond.camera(seed, spec.encoding_gamma as f32);
        let view = View::new(scene, calib, &cfg)?;
        if let Some(f) = cond.clip_fraction {
            cfg.exposure = view.exposure_for_clipping(pattern, &cfg, f)?;
        }
        let mut frame = Image::new(0, 0, [0u8; 3]);
        view.photograph_into(pattern, &cfg, &mut Scratch::default(), &mut frame)?;
        Ok((frame, view, cfg))
    }

    /// The scanner of a row's one-shot scan: `cond`'s rig and pattern, `loggrad`, the
    /// colour mixing measured for the condition.
    pub fn scanner(&mut self, cond: &'static Condition) -> Result<Scanner> {
        let crosstalk = self.crosstalk(cond)?;
        let response = self.response(cond)?;
        let (calib, spec, _) = self.setup(cond)?;
        let config = ScanConfig { filter: FilterMode::LogGrad, crosstalk, response, ..ScanConfig::default() };
        Scanner::new(spec.clone(), calib.clone(), config)
    }

    fn render_and_scan(&mut self, scene_name: &str, cond: &'static Condition) -> Result<(OneShot, View, SimConfig)> {
        let crosstalk = self.crosstalk(cond)?;
        let scene = Scene::builtin(scene_name)?;
        let (frame, view, cfg) = self.photograph(&scene, cond)?;
        let mut scanner = self.scanner(cond)?;
        let (calib, _, pattern) = &self.setups[cond.name];
        let clipped = clipped_fraction(&frame, &view.bright_stripe_mask(pattern, &cfg));
        let depth = scanner.scan(&frame)?.depth.clone();
        let truth = view.truth();
        let one_shot = OneShot {
            metrics: measure(&depth, truth),
            subject_coverage: masked_coverage(&depth, &subject_mask(&scene, calib, truth)),
            clipped,
            crosstalk,
            depth,
        };
        Ok((one_shot, view, cfg))
    }

    /// `scene` under `cond` scanned with no colour mixing, and with the mixing estimated
    /// from the frame itself (`scan --crosstalk frame`), beside the card's; `card` is the
    /// row's scan with the mixing measured from the card (the hard table's).
    pub fn frame_mixing(&mut self, scene_name: &str, cond: &'static Condition, card: Metrics) -> Result<FrameMixingRow> {
        let card_crosstalk = self.crosstalk(cond)?;
        let scene = Scene::builtin(scene_name)?;
        let (frame, view, _) = self.photograph(&scene, cond)?;
        let mut scanner = self.scanner(cond)?;
        scanner.set_crosstalk(IDENTITY_CROSSTALK)?;
        let none = measure(&scanner.scan(&frame)?.depth, view.truth());
        let (estimates, stopped) = scanner.scan_estimating_crosstalk(&frame, FRAME_MIXING_ROUNDS)?;
        let from_frame = measure(&scanner.result().depth, view.truth());
        // The card's matrix with its columns scaled as the frame's estimate is.
        let mut card_columns = card_crosstalk;
        for k in 0..3 {
            let sum: f32 = (0..3).map(|c| card_crosstalk[c][k]).sum();
            for row in card_columns.iter_mut() {
                row[k] /= sum;
            }
        }
        let difference = estimates.last().map(|m| {
            m.crosstalk.iter().flatten().zip(card_columns.iter().flatten()).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max)
        });
        Ok(FrameMixingRow {
            scene: scene_name.to_string(),
            condition: cond.name,
            none,
            card,
            from_frame,
            rounds: estimates.len(),
            difference,
            problem: stopped.map(|e| e.to_string()),
        })
    }

    /// Render, scan and measure `scene` under `cond`, with its Gray-code reference.
    pub fn run(&mut self, scene_name: &str, cond: &'static Condition) -> Result<HardRun> {
        let (one_shot, view, cfg) = self.render_and_scan(scene_name, cond)?;
        let (calib, spec, _) = &self.setups[cond.name];
        let (calib, stripe_width) = (calib.clone(), spec.families[0].stripe_width);
        let scene = Scene::builtin(scene_name)?;
        let truth = view.truth().clone();

        // The reference depends on the rig, the camera and (through the clipping
        // exposure) the one-shot pattern, not on the stripes otherwise, nor on the
        // projector's blur (below).
        let key = format!(
            "{scene_name}/{}/{}/{:?}/{}/{}",
            cond.camera_scale,
            cond.partial_projector,
            cond.webcam_jpeg,
            cond.highlight_knee,
            cond.clip_fraction.map_or(String::new(), |f| format!("{f}@{}", cond.stripe_width))
        );
        if !self.gray.contains_key(&key) {
            // Keep only the current scene's references.
            self.gray.retain(|k, _| k.starts_with(&format!("{scene_name}/")));
            // With a sharp projector: the reference stands for what of the scene is
            // decodable at all, and a soft projector would blur its finest codes (a
            // limit of the reference's patterns, not of the scene).
            let reference = gray_reference(&view, &calib, &SimConfig { projector_blur: 0.0, ..cfg.clone() })?;
            self.gray.insert(key.clone(), reference);
        }
        let gray_depth = self.gray[&key].depth.clone();
        let (w, h) = view.size();
        let lit = truth.lit.pixels().iter().filter(|&&l| l).count();
        let subject = subject_mask(&scene, &calib, &truth);
        let row = HardRow {
            scene: scene_name.to_string(),
            condition: cond.name.to_string(),
            camera: (w, h),
            stripe_px: median_stripe_px(&truth, stripe_width),
            lit_fraction: lit as f64 / (w * h).max(1) as f64,
            clipped: one_shot.clipped,
            crosstalk: one_shot.crosstalk,
            one_shot: one_shot.metrics,
            gray: measure(&gray_depth, &truth),
            subject_coverage: (one_shot.subject_coverage, masked_coverage(&gray_depth, &subject)),
        };
        Ok(HardRun { row, one_shot_depth: one_shot.depth, gray_depth, truth })
    }
}

/// A one-shot scan of a scene under a condition ([`HardEval::one_shot`]).
pub struct OneShot {
    /// The merged depth against the ground truth.
    pub metrics: Metrics,
    /// Coverage of the lit pixels on the scene's objects ([`subject_mask`]).
    pub subject_coverage: f64,
    /// Bright-stripe pixels clipped in at least one channel ([`clipped_fraction`]).
    pub clipped: f64,
    /// The colour mixing the scanner was told (measured).
    pub crosstalk: Crosstalk,
    /// The merged depth.
    pub depth: Image<f32>,
}

/// A scene under a condition scanned with no colour mixing, with the card's, and with
/// the mixing estimated from the frame itself ([`HardEval::frame_mixing`]).
#[derive(Clone, Debug)]
pub struct FrameMixingRow {
    /// Scene name.
    pub scene: String,
    /// Condition name.
    pub condition: &'static str,
    /// The scan with no colour mixing (where the estimate starts).
    pub none: Metrics,
    /// The scan with the mixing measured from the white card.
    pub card: Metrics,
    /// The scan with the mixing estimated from the frame.
    pub from_frame: Metrics,
    /// Rounds of the estimate that ran (of [`FRAME_MIXING_ROUNDS`]).
    pub rounds: usize,
    /// The last estimate's largest difference from the card's matrix (its columns
    /// scaled to sum to 1, as the estimate's are); `None` without an estimate.
    pub difference: Option<f32>,
    /// Why an estimate stopped, if one did.
    pub problem: Option<String>,
}

/// The conditions of the report's table of colour mixing read from the frame: the
/// ones a user without a white card meets (a webcam's chroma and JPEG, partial light),
/// and broad stripes, where a tile of a frame shows the fewest colours.
pub const FRAME_MIXING_CONDITIONS: &[&str] = &["default", "webcam", "world", "wide"];

/// The coverage goal of issue 10 for a scene, as a share of the Gray-code reference's
/// coverage, with its class: real pigments 95 %, saturated dyes 85 %, dyes with 1 %
/// off-channel reflectance 70 %.
pub fn coverage_goal(scene: &str) -> (&'static str, f64) {
    match scene {
        "sphere-dye" | "paper-dye" | "bag" => ("1 % dye", 0.70),
        "sphere" | "paper" | "textured" => ("saturated", 0.85),
        _ => ("pigment", 0.95),
    }
}

/// Outliers allowed by issue 10 on every scene.
pub const OUTLIER_GOAL: f64 = 0.005;

/// Per ColorChecker patch (and the card around them, index 24): lit pixels and the
/// coverage of the one-shot scan and of the Gray-code reference. A pixel's patch is
/// the chart's own layout read at the surface coordinates of the point its centre ray
/// meets on the chart (object 0 of the `colorchecker` scene).
pub fn patch_coverage(run: &HardRun, calib: &Calibration) -> Result<Vec<(usize, f64, f64)>> {
    let scene = Scene::builtin("colorchecker")?;
    let chart = &scene.objects()[0];
    let Texture::Chart { colours, columns, patch, gap, .. } = &chart.texture else {
        return Err(Error::Scene("the colorchecker scene's first object is not a chart".into()));
    };
    // The same layout with each patch's index as its "colour" and -1 for the card.
    let labels = Texture::Chart {
        colours: (0..colours.len()).map(|k| [k as f32, 0.0, 0.0]).collect(),
        columns: *columns,
        patch: *patch,
        gap: *gap,
        background: [-1.0; 3],
    };
    let card = colours.len();
    let mut counts = vec![(0usize, 0usize, 0usize); card + 1];
    let (w, _) = run.truth.lit.size();
    for (i, &lit) in run.truth.lit.pixels().iter().enumerate() {
        if !lit {
            continue;
        }
        let ray = calib.camera.ray((i % w) as f64, (i / w) as f64);
        let Some(hit) = scene.cast(DVec3::ZERO, ray, 0.0, f64::INFINITY) else { continue };
        if hit.object != 0 {
            continue;
        }
        let label = labels.albedo(chart.shape.surface(hit.point).1)[0];
        let c = &mut counts[if label < 0.0 { card } else { label as usize }];
        c.0 += 1;
        c.1 += !run.one_shot_depth.pixels()[i].is_nan() as usize;
        c.2 += !run.gray_depth.pixels()[i].is_nan() as usize;
    }
    let ratio = |a: usize, b: usize| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    Ok(counts.iter().map(|&(n, a, b)| (n, ratio(a, n), ratio(b, n))).collect())
}

fn pct(x: f64) -> String {
    format!("{:.1}%", 100.0 * x)
}

/// The hard table as Markdown.
pub fn hard_markdown(rows: &[HardRow]) -> String {
    let mut s = String::from(
        "| scene | condition | stripe px | lit | clipped | coverage | object cov. | outliers | RMSE mm | edge cov. \
         | Gray coverage | Gray object cov. | Gray outliers | Gray RMSE mm | ratio | goal |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let (class, goal) = coverage_goal(&r.scene);
        let ratio = r.coverage_ratio();
        let met = ratio >= goal && r.one_shot.outliers <= OUTLIER_GOAL;
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} | {} | {} | {} | {} | {:.2}% | {:.3} | {} | {} | {} | {:.2}% | {:.3} | {:.0}% | {} {:.0}% {} |",
            r.scene,
            r.condition,
            r.stripe_px,
            pct(r.lit_fraction),
            pct(r.clipped),
            pct(r.one_shot.coverage),
            pct(r.subject_coverage.0),
            100.0 * r.one_shot.outliers,
            r.one_shot.rmse_mm,
            if r.one_shot.edge_lit == 0 { "–".to_string() } else { pct(r.one_shot.edge_coverage) },
            pct(r.gray.coverage),
            pct(r.subject_coverage.1),
            100.0 * r.gray.outliers,
            r.gray.rmse_mm,
            100.0 * ratio,
            class,
            100.0 * goal,
            if met { "met" } else { "**missed**" },
        );
    }
    s
}

/// What [`report`] covers.
#[derive(Clone, Debug)]
pub struct ReportOptions {
    /// Scenes, in order.
    pub scenes: Vec<String>,
    /// Conditions, in order.
    pub conditions: Vec<&'static Condition>,
    /// Noise seed.
    pub seed: u64,
    /// Also the table of 1, 2 and 3 directions with `direct` and `loggrad` (default
    /// condition, measured colour mixing).
    pub directions_table: bool,
    /// Run a condition only on its [`Condition::report_scenes`], when it has them.
    pub restrict_heavy: bool,
    /// Also the table of colour mixing estimated from the frame itself, for the
    /// chosen conditions among [`FRAME_MIXING_CONDITIONS`].
    pub frame_mixing_table: bool,
}

impl Default for ReportOptions {
    fn default() -> Self {
        ReportOptions {
            scenes: Scene::NAMES.iter().map(|s| s.to_string()).collect(),
            conditions: CONDITIONS.iter().collect(),
            seed: 1,
            directions_table: true,
            restrict_heavy: true,
            frame_mixing_table: true,
        }
    }
}

const REPORT_HEAD: &str = "\
# Accuracy against the simulator's ground truth

Regenerate with `cargo run --release -- eval --hard > docs/accuracy.md` (this whole
file; about a quarter of an hour on two cores, a third of it the 8-megapixel rows, which
run on six of the scenes). Every scan is what a user gets: the demo rig (`stripelight calib --default`, or the condition's variant
of it), the two-direction pattern, `loggrad`, and the colour mixing *measured* from
simulated frames of a white card under full red, green, blue and black
(`calib::estimate_crosstalk`, as `stripelight crosstalk` does), not the simulator's
known matrix. The camera's response is measured too, from the card under full white,
grey 128 and black at an exposure that just clips it (`calib::estimate_response`, as
`stripelight response` does); the scanner reads codes through it where it is not the
power law within 2 % (the `shoulder` rows), and through the power law elsewhere. Beside every scan, a 42-frame Gray-code reference (columns and rows, each
bit and its inverse, white and black; `src/eval/graycode.rs`) photographed through the
same simulated view and camera and triangulated with the same code: what is decodable
at all.

- **coverage**: decoded lit pixels / lit pixels (lit = the projector's light reaches
  the surface seen at the pixel centre: inside its image, facing it, not in shadow);
- **outliers**: decoded pixels off by more than max(2 mm, 0.5 % of depth), *or decoded
  where no projector light reaches any part of the pixel* (a depth there is invented),
  as a share of the decoded pixels; a pixel lit over part of its area (on the edge of
  the light or of a shadow) is judged by its depth;
- **RMSE**: of the decoded pixels that are not outliers, mm;
- **edge cov.**: coverage of lit pixels within 8 px of a true depth discontinuity
  (neighbours more than 20 mm apart; – where the scene has none);
- **stripe px**: median width of the vertical stripes in camera pixels (from the ground
  truth); **lit**: lit pixels / all pixels; **clipped**: bright-stripe pixels (where the
  projector emits at least half of full white in some channel) that read 255 in at least
  one channel;
- **object cov.**: coverage of the lit pixels on the scene's objects, leaving out a
  backdrop (a wall or table facing the camera straight on);
- **ratio**: one-shot coverage / Gray-code coverage; **goal**: issue 10's target for the
  scene's class (real pigments 95 %, saturated dyes 85 %, dyes with 1 % off-channel
  reflectance 70 %) together with at most 0.5 % outliers.

The reference has limits of its own, which the ratios inherit: a bit counts only where
pattern minus inverse is 4 noise deviations clear (0.05 of full scale over the three
channels), so near-black surfaces far from the projector stay partly empty; Gray-code
stripes narrower than one camera pixel are not used (their contrast is gone), so the
coordinate is interpolated between the edges of the finest usable bit; a pixel counts
as lit (for coverage) when its centre is, so the partly lit pixels on the edges of the
light and of shadows, when decoded, add to the decoded pixels and not to the lit ones;
and the lens blur (σ 0.6 px) carries the stripes about a pixel into shadows, where no
projector light falls: the reference reads them there and they count as its outliers
(most of its outliers on `occluders` and `wood`, whose shadows are long). Under the
`soft` condition the reference is photographed with a sharp projector: it stands for
what of the scene is decodable, and a blurred projector would wash out its own finest
bits, a limit of those patterns and not of the scene.
";

const FRAME_MIXING_HEAD: &str = "
## Colour mixing read from the frame itself

For a rig whose white-card frames were never taken (a third party's capture, or a page
where the guided measurement was skipped), `stripelight scan --crosstalk frame` (and the
page's \"Estimate from the shown frame\") scans the frame with no colour mixing, reads the
mixing from the stripes it identified (`calib::estimate_crosstalk_from_stripes`: per
tile of a few stripe periods, the camera's channels fitted as straight lines of the
projector's primaries, which the surface's colour scales column by column; the median
over the tiles), and scans again with it, twice over. Below, the same frames scanned
with no mixing, with the card's (the table above) and with the frame's own; the last
column is the estimate's largest difference from the card's matrix once both have their
columns scaled to sum to 1 (a frame cannot tell a primary's strength from a surface's
colour, and decoding does not need it).

| scene | condition | no mixing: coverage / outliers | card's | the frame's own | estimate against the card's |
|---|---|---|---|---|---|
";

/// The whole of `docs/accuracy.md`: the conditions, the hard table, the ColorChecker's
/// patches, and (optionally) the directions and filters table. `progress` is told each
/// finished row.
pub fn report(options: &ReportOptions, progress: &mut dyn FnMut(&str)) -> Result<String> {
    let mut eval = HardEval::new(options.seed);
    let mut out = String::from(REPORT_HEAD);
    let _ = writeln!(out, "\nNoise seed {}.\n\n## Conditions\n", options.seed);
    out.push_str("| condition | what changes | camera | colour mixing measured (rows: camera R, G, B) |\n|---|---|---|---|\n");
    for cond in &options.conditions {
        let m = eval.crosstalk(cond)?;
        let calib = cond.rig()?;
        let rows: Vec<String> = m.iter().map(|r| format!("{:.3} {:.3} {:.3}", r[0], r[1], r[2])).collect();
        let _ = writeln!(
            out,
            "| {} | {} | {} x {} | {} |",
            cond.name,
            cond.summary,
            calib.camera.width,
            calib.camera.height,
            rows.join(" / ")
        );
    }
    let sim_xt = SimConfig::default().crosstalk;
    let _ = writeln!(
        out,
        "\nThe simulated camera's true mixing is {:.2} on the diagonal and {:.2} off it.\n",
        sim_xt[0][0], sim_xt[0][1]
    );
    out.push_str(
        "Scenes: `Scene::builtin` in `src/sim/scene.rs` describes each; the hard ones are \
         `colorchecker` (the 24 ColorChecker Classic pigments, bent and tilted), `sphere-dye`, \
         `paper-dye` and `bag` (dyes with 1 % off-channel reflectance, the bag with near-black \
         patches), `skin`, `wood` and `wall` (white and grey).\n\n\
         ## One-shot scan and Gray-code reference\n\n",
    );

    let mut rows = Vec::new();
    let mut patches = None;
    for scene in &options.scenes {
        for cond in &options.conditions {
            let skip = options.restrict_heavy && cond.report_scenes.is_some_and(|only| !only.contains(&scene.as_str()));
            if skip {
                continue;
            }
            let run = eval.run(scene, cond)?;
            if scene == "colorchecker" && cond.name == "default" {
                patches = Some(patch_coverage(&run, &cond.rig()?)?);
            }
            progress(&format!(
                "{} / {}: coverage {:.1}% (Gray {:.1}%), outliers {:.2}%",
                scene,
                cond.name,
                100.0 * run.row.one_shot.coverage,
                100.0 * run.row.gray.coverage,
                100.0 * run.row.one_shot.outliers
            ));
            rows.push(run.row);
        }
    }
    out.push_str(&hard_markdown(&rows));

    let missed: Vec<String> = rows
        .iter()
        .filter(|r| r.coverage_ratio() < coverage_goal(&r.scene).1 || r.one_shot.outliers > OUTLIER_GOAL)
        .map(|r| format!("{} / {}", r.scene, r.condition))
        .collect();
    let met_rows = rows.len() - missed.len();
    let _ = writeln!(out, "\n{met_rows} of {} rows meet issue 10's coverage and outlier goals (the last column).", rows.len());
    out.push_str(
        "\n| condition | goals met | one-shot coverage / Gray's, median | outliers, median | RMSE over 0.5 mm |\n\
         |---|---|---|---|---|\n",
    );
    for cond in &options.conditions {
        let of: Vec<&HardRow> = rows.iter().filter(|r| r.condition == cond.name).collect();
        if of.is_empty() {
            continue;
        }
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let met = of.len() - of.iter().filter(|r| missed.contains(&format!("{} / {}", r.scene, r.condition))).count();
        let _ = writeln!(
            out,
            "| {} | {} of {} | {:.0}% | {:.2}% | {} of {} |",
            cond.name,
            met,
            of.len(),
            100.0 * median(of.iter().map(|r| r.coverage_ratio()).collect()),
            100.0 * median(of.iter().map(|r| r.one_shot.outliers).collect()),
            of.iter().filter(|r| r.one_shot.rmse_mm > 0.5).count(),
            of.len()
        );
    }

    if options.frame_mixing_table {
        let mut table = Vec::new();
        for row in rows.iter().filter(|r| FRAME_MIXING_CONDITIONS.contains(&r.condition.as_str())) {
            let cond = condition(&row.condition)?;
            let m = eval.frame_mixing(&row.scene, cond, row.one_shot.clone())?;
            progress(&format!(
                "{} / {}: colour mixing from the frame, coverage {:.1}% (card {:.1}%)",
                m.scene,
                m.condition,
                100.0 * m.from_frame.coverage,
                100.0 * m.card.coverage
            ));
            table.push(m);
        }
        if !table.is_empty() {
            out.push_str(FRAME_MIXING_HEAD);
            for m in &table {
                let estimate = match (&m.difference, &m.problem) {
                    (Some(d), None) => format!("{d:.3}"),
                    (Some(d), Some(_)) => format!("{d:.3} (round {} of {FRAME_MIXING_ROUNDS})", m.rounds),
                    (None, _) => "none".to_string(),
                };
                let _ = writeln!(
                    out,
                    "| {} | {} | {} / {:.2}% | {} / {:.2}% | {} / {:.2}% | {} |",
                    m.scene,
                    m.condition,
                    pct(m.none.coverage),
                    100.0 * m.none.outliers,
                    pct(m.card.coverage),
                    100.0 * m.card.outliers,
                    pct(m.from_frame.coverage),
                    100.0 * m.from_frame.outliers,
                    estimate
                );
            }
        }
    }

    if let Some(p) = patches {
        out.push_str(
            "\n## ColorChecker, patch by patch (default condition)\n\n\
             | patch | lit px | coverage | Gray coverage |\n|---|---|---|---|\n",
        );
        for (k, (n, a, b)) in p.iter().enumerate() {
            let name = match pigments::COLORCHECKER_SRGB.get(k) {
                Some((patch, _)) => format!("{} {patch}", k + 1),
                None => "the black card around the patches".to_string(),
            };
            let _ = writeln!(out, "| {name} | {n} | {} | {} |", pct(*a), pct(*b));
        }
    }

    if options.directions_table {
        let base = condition("default")?;
        let crosstalk = eval.crosstalk(base)?;
        let calib = base.rig()?;
        out.push_str(
            "\n## Directions and filters (default condition, measured colour mixing)\n\n\
             Three directions with `direct` decode little: every pixel shows the product of \
             three stripes, which only the directional restoration (`loggrad`, the paper's \
             decoupling) separates.\n\n\
             | scene | dirs | filter | coverage | outliers | RMSE mm | edge coverage | per family coverage |\n\
             |---|---|---|---|---|---|---|---|\n",
        );
        let mut table: Vec<Row> = Vec::new();
        for scene in &options.scenes {
            for dirs in 1..=3 {
                for filter in [FilterMode::Direct, FilterMode::LogGrad] {
                    table.push(evaluate_with(scene, dirs, filter, &calib, options.seed, crosstalk)?);
                }
            }
            progress(&format!("{scene}: directions and filters"));
        }
        let md = super::markdown(&table);
        // Skip the header `markdown` writes: this one is already out.
        out.extend(md.lines().skip(2).map(|l| format!("{l}\n")));
    }
    Ok(out)
}
