//! Patterns from elsewhere, decoded with the simulator's ground truth: one family of
//! vertical stripes that covers only the middle of the projector (black margins), in
//! the two kinds of palette other systems use: 3-colour RGB (channels at 0, so the
//! projector's black level is the floor) and the 8 corners of the RGB cube (black and
//! white stripes included), with windows of 4 and 5 stripes.

#[macro_use]
mod support;

#[cfg(target_arch = "wasm32")]
wasm_bindgen_test::wasm_bindgen_test_configure!(run_in_browser);

use stripelight::eval::measure;
use stripelight::pattern::{binary_palette, windowed_sequence_in, Family};
use stripelight::scan::{ScanConfig, Scanner};
use stripelight::sim::{render, Scene, SimConfig};
use stripelight::{Calibration, PatternSpec};

/// A single-family spec of `count` stripes `stripe_width` projector pixels wide,
/// centred on a 1024x768 projector with black on either side.
fn third_party(palette: Vec<[f64; 3]>, window: usize, count: usize, stripe_width: f64) -> PatternSpec {
    let sequence = windowed_sequence_in(&palette, count, window).expect("a sequence");
    let family = Family { angle_deg: 0.0, stripe_width, origin: -(count as f64) * stripe_width / 2.0, count };
    PatternSpec::one_family(1024, 768, palette, [0.0; 3], sequence, window, family).expect("a valid spec")
}

/// What one scan of `scene` under `spec` gives: coverage of the lit pixels
/// whose true projector column lies on the stripes (the first and last stripe left
/// out), the depth outliers, and the median correspondence error in projector pixels.
fn scan_scene(scene: &str, spec: &PatternSpec) -> (f64, f64, f32) {
    let calib = Calibration::demo();
    let cfg = SimConfig { seed: 5, projector_gamma: spec.encoding_gamma as f32, ..SimConfig::default() };
    let frame = render(&Scene::builtin(scene).unwrap(), &calib, &spec.render_rgb8(), &cfg).unwrap();
    let config = ScanConfig { crosstalk: cfg.crosstalk, ..ScanConfig::default() };
    let mut scanner = Scanner::new(spec.clone(), calib, config).unwrap();
    let result = scanner.scan(&frame.image).unwrap();
    let fam = &spec.families[0];
    let ou = (spec.width as f32 - 1.0) / 2.0;
    let (lo, hi) = (fam.origin as f32 + fam.stripe_width as f32, (fam.origin + (fam.count - 1) as f64 * fam.stripe_width) as f32);
    let (mut on_stripes, mut decoded, mut errors) = (0usize, 0usize, Vec::new());
    for (i, c) in result.correspondence().pixels().iter().enumerate() {
        let up = frame.projector.pixels()[i][0];
        if up.is_nan() || !frame.lit.pixels()[i] {
            continue;
        }
        let s = up - ou;
        if s > lo && s < hi {
            on_stripes += 1;
            decoded += !c[0].is_nan() as usize;
        }
        if !c[0].is_nan() {
            errors.push((c[0] - s).abs());
        }
    }
    errors.sort_by(f32::total_cmp);
    let median = errors.get(errors.len() / 2).copied().unwrap_or(f32::INFINITY);
    let m = measure(&result.depth, &frame);
    (decoded as f64 / on_stripes.max(1) as f64, m.outliers, median)
}

both_targets! {
/// RGB and 8-colour patterns with margins decode on the stripes, nowhere else, and
/// give the true projector coordinate: on a plain wall (the `plane` scene) nearly
/// everywhere, and on the `sphere` scene (a ball with coloured patches before a wall:
/// under a 3-colour pattern a red patch leaves two of three channels at the black
/// level) with few outliers.
fn third_party_patterns_decode_with_margins() {
    let rgb = vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let cases = [
        ("3-colour RGB, window 4", third_party(rgb.clone(), 4, 26, 20.0)),
        ("3-colour RGB, window 5", third_party(rgb, 5, 50, 16.0)),
        ("8 colours with black and white, window 4", third_party(binary_palette(0.0), 4, 125, 7.0)),
        ("8 colours with black and white, window 5", third_party(binary_palette(0.0), 5, 100, 8.0)),
    ];
    let mut figures = Vec::new();
    for (name, spec) in &cases {
        for scene in ["plane", "sphere"] {
            let (coverage, outliers, median) = scan_scene(scene, spec);
            eprintln!("{name}, {scene}: coverage {:.1} % of the lit striped pixels, outliers {:.2} %, median correspondence error {median:.3} projector px", coverage * 100.0, outliers * 100.0);
            figures.push((name, scene, coverage, outliers, median));
        }
    }
    for (name, scene, coverage, outliers, median) in figures {
        // Measured: plane 89.5-100 %, sphere 66-91 % (the two windows of 4 lowest).
        let (min_coverage, max_outliers) = if scene == "plane" { (0.85, 0.005) } else { (0.6, 0.01) };
        assert!(coverage >= min_coverage, "{name}, {scene}: coverage {coverage}");
        assert!(outliers <= max_outliers, "{name}, {scene}: outliers {outliers}");
        assert!(median <= 0.25, "{name}, {scene}: median correspondence error {median}");
    }
}
}
