//! Accuracy against the simulator's ground truth: the figures of `stripelight eval`
//! and of the accuracy tests.
//!
//! - **coverage**: decoded lit pixels / lit pixels;
//! - **outliers**: decoded pixels whose depth is off the true depth by more than
//!   [`outlier_threshold`] (max(2 mm, 0.5 % of depth)), or where no projector light
//!   reaches any part of the pixel ([`Frame::lit_share`] 0: no surface, outside the
//!   projector's image, facing away or in shadow; any depth there is invented), as a
//!   fraction of decoded pixels. A pixel lit over part of its area (on the edge of the
//!   light or of a shadow) is judged by its depth like a lit one;
//! - **RMSE** of the other decoded pixels, mm;
//! - **edge coverage**: coverage among lit pixels within [`EDGE_BAND`] pixels of a true
//!   depth discontinuity (neighbouring pixels more than [`DISCONTINUITY_MM`] apart).
//!
//! [`hard`] runs the hard evaluation of issue 10 (real pigments, saturated dyes,
//! partial projector light, clipping, webcam compression, stripe widths and frame
//! sizes), each scan beside a multi-shot Gray-code reference ([`graycode`]) rendered
//! through the same simulator.

pub mod graycode;
pub mod hard;

use crate::calib::{Calibration, Crosstalk};
use crate::error::Result;
use crate::pattern::{PatternSpec, DEFAULT_STRIPE_WIDTH};
use crate::raster::Image;
use crate::filter::FilterMode;
use crate::scan::{ScanConfig, Scanner};
use crate::sim::{self, Frame, Scene, SimConfig};
use serde::Serialize;

/// Half-width of the band around depth discontinuities, pixels.
pub const EDGE_BAND: usize = 8;

/// Neighbouring ground-truth depths further apart than this (mm) make a discontinuity.
pub const DISCONTINUITY_MM: f32 = 20.0;

/// A decoded depth is an outlier when it is off by more than max(2 mm, 0.5 % of depth).
pub fn outlier_threshold(true_depth: f32) -> f32 {
    (0.005 * true_depth).max(2.0)
}

/// Figures of one depth map against ground truth.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Metrics {
    /// Lit pixels.
    pub lit: usize,
    /// Decoded lit pixels / lit pixels.
    pub coverage: f64,
    /// Outliers / decoded pixels.
    pub outliers: f64,
    /// Number of decoded pixels that are not outliers.
    pub correct: usize,
    /// RMSE of the non-outliers, mm.
    pub rmse_mm: f64,
    /// Lit pixels in the edge band.
    pub edge_lit: usize,
    /// Decoded / lit pixels in the edge band.
    pub edge_coverage: f64,
}

/// The lit pixels within [`EDGE_BAND`] of a depth discontinuity.
pub fn edge_band(truth: &Frame) -> Vec<bool> {
    let (w, h) = truth.depth.size();
    let d = truth.depth.pixels();
    let mut edge = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let z = d[y * w + x];
            let jump = |o: f32| z.is_nan() != o.is_nan() || (z - o).abs() > DISCONTINUITY_MM;
            if (x + 1 < w && jump(d[y * w + x + 1])) || (y + 1 < h && jump(d[(y + 1) * w + x])) {
                edge[y * w + x] = true;
            }
        }
    }
    // Dilate by EDGE_BAND (square), separably.
    let r = EDGE_BAND as isize;
    let mut rows = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            rows[y * w + x] = (-r..=r).any(|k| {
                let xx = x as isize + k;
                xx >= 0 && (xx as usize) < w && edge[y * w + xx as usize]
            });
        }
    }
    let lit = truth.lit.pixels();
    let mut band = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            band[y * w + x] = lit[y * w + x]
                && (-r..=r).any(|k| {
                    let yy = y as isize + k;
                    yy >= 0 && (yy as usize) < h && rows[yy as usize * w + x]
                });
        }
    }
    band
}

/// Compare a decoded depth map with the ground truth.
pub fn measure(depth: &Image<f32>, truth: &Frame) -> Metrics {
    let band = edge_band(truth);
    let (mut lit, mut decoded_lit, mut decoded, mut outliers, mut sq) = (0usize, 0usize, 0usize, 0usize, 0f64);
    let (mut edge_lit, mut edge_decoded) = (0usize, 0usize);
    for (i, (&z, &t)) in depth.pixels().iter().zip(truth.depth.pixels()).enumerate() {
        let is_lit = truth.lit.pixels()[i];
        lit += is_lit as usize;
        edge_lit += band[i] as usize;
        if z.is_nan() {
            continue;
        }
        decoded += 1;
        decoded_lit += is_lit as usize;
        edge_decoded += band[i] as usize;
        let err = z - t;
        // A depth where no projector light falls is invented, however close it is.
        let dark = !is_lit && truth.lit_share.pixels()[i] == 0.0;
        if dark || t.is_nan() || err.abs() > outlier_threshold(t) {
            outliers += 1;
        } else {
            sq += (err as f64).powi(2);
        }
    }
    let ratio = |a: usize, b: usize| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    let correct = decoded - outliers;
    Metrics {
        lit,
        coverage: ratio(decoded_lit, lit),
        outliers: ratio(outliers, decoded),
        correct,
        rmse_mm: if correct == 0 { 0.0 } else { (sq / correct as f64).sqrt() },
        edge_lit,
        edge_coverage: ratio(edge_decoded, edge_lit),
    }
}

/// One row of the accuracy table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Scene name.
    pub scene: String,
    /// Number of stripe directions.
    pub directions: usize,
    /// Filter used.
    pub filter: String,
    /// Figures of the merged depth.
    pub merged: Metrics,
    /// Figures of each family's own depth.
    pub families: Vec<Metrics>,
}

/// Render `scene` with a `directions` pattern on `calib` and scan it with `filter`,
/// telling the scanner the simulator's own colour mixing.
pub fn evaluate(scene_name: &str, directions: usize, filter: FilterMode, calib: &Calibration, seed: u64) -> Result<Row> {
    evaluate_with(scene_name, directions, filter, calib, seed, SimConfig::default().crosstalk)
}

/// [`evaluate`] with the colour mixing the scanner is told (measured, for instance,
/// with [`hard::measured_crosstalk`]).
pub fn evaluate_with(
    scene_name: &str,
    directions: usize,
    filter: FilterMode,
    calib: &Calibration,
    seed: u64,
    crosstalk: Crosstalk,
) -> Result<Row> {
    let spec = PatternSpec::generate(directions, calib.projector.width, calib.projector.height, DEFAULT_STRIPE_WIDTH)?;
    let scene = Scene::builtin(scene_name)?;
    let cfg = SimConfig { seed, projector_gamma: spec.encoding_gamma as f32, ..SimConfig::default() };
    let truth = sim::render(&scene, calib, &spec.render_rgb8(), &cfg)?;
    let mut scanner = Scanner::new(spec, calib.clone(), ScanConfig { filter, crosstalk, ..ScanConfig::default() })?;
    let result = scanner.scan(&truth.image)?;
    Ok(Row {
        scene: scene_name.to_string(),
        directions,
        filter: filter.to_string(),
        merged: measure(&result.depth, &truth),
        families: result.family_depth.iter().map(|d| measure(d, &truth)).collect(),
    })
}

/// The table as Markdown.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from(
        "| scene | dirs | filter | coverage | outliers | RMSE mm | edge coverage | per family coverage |\n|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let fam: Vec<String> = r.families.iter().map(|m| format!("{:.1}%", 100.0 * m.coverage)).collect();
        s.push_str(&format!(
            "| {} | {} | {} | {:.1}% | {:.2}% | {:.3} | {:.1}% | {} |\n",
            r.scene,
            r.directions,
            r.filter,
            100.0 * r.merged.coverage,
            100.0 * r.merged.outliers,
            r.merged.rmse_mm,
            100.0 * r.merged.edge_coverage,
            fam.join(" / ")
        ));
    }
    s
}
