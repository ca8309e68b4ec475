//! Decoding a large frame of broad stripes at a reduced scale
//! (`ScanConfig::decode_scale`): the outputs keep the frame's size, and where each
//! projector pixel covers several camera pixels the reduced scale decodes more, as
//! accurately.

#[macro_use]
mod support;

#[cfg(target_arch = "wasm32")]
wasm_bindgen_test::wasm_bindgen_test_configure!(run_in_dedicated_worker);

use stripelight::calib::Calibration;
use stripelight::eval::measure;
use stripelight::pattern::PatternSpec;
use stripelight::scan::{DecodeScale, ScanConfig, Scanner};
use stripelight::sim::{Scene, Scratch, SimConfig, View};
use stripelight::Image;

/// The demo rig with its camera at three times VGA's size (1920 x 1440) and its
/// projector at half the demo's (512 x 384), the same fields of view: each projector
/// pixel covers about 4 camera pixels.
fn large_camera_small_projector() -> Calibration {
    let mut calib = Calibration::demo();
    let c = &mut calib.camera;
    (c.width, c.height, c.fx, c.fy) = (c.width * 3, c.height * 3, c.fx * 3.0, c.fy * 3.0);
    (c.cx, c.cy) = ((c.cx + 0.5) * 3.0 - 0.5, (c.cy + 0.5) * 3.0 - 0.5);
    let p = &mut calib.projector;
    (p.width, p.height, p.fx, p.fy) = (p.width / 2, p.height / 2, p.fx / 2.0, p.fy / 2.0);
    (p.cx, p.cy) = ((p.cx + 0.5) / 2.0 - 0.5, (p.cy + 0.5) / 2.0 - 0.5);
    calib
}

both_targets! {
/// The ColorChecker seen by a 1920 x 1440 camera, 4 camera pixels per projector pixel,
/// 5-pixel projector stripes (about 21 camera pixels) whose boundaries lie on pixel
/// centres (so the pattern image blends the two colours there, as a pattern of
/// fractional width or someone else's may): `auto` decodes at a third of the scale,
/// fills the frame's depth map, correspondences and cloud, and decodes far more than
/// the frame's own scale, as accurately.
fn a_large_frame_of_blended_boundaries_decodes_at_a_reduced_scale() {
    let calib = large_camera_small_projector();
    let mut spec = PatternSpec::generate(2, calib.projector.width, calib.projector.height, 5.0).unwrap();
    // `generate` puts whole-pixel stripes' boundaries on pixel edges: half a pixel off.
    for family in &mut spec.families {
        family.origin += 0.5;
    }
    let pattern = spec.render_rgb8();
    // One ray a pixel, as the evaluation's 8-megapixel condition renders.
    let cfg = SimConfig { supersample: 1, ..SimConfig::default() };
    let view = View::new(&Scene::builtin("colorchecker").unwrap(), &calib, &cfg).unwrap();
    let mut frame = Image::new(0, 0, [0u8; 3]);
    view.photograph_into(&pattern, &cfg, &mut Scratch::default(), &mut frame).unwrap();
    let scan = |decode_scale| {
        let config = ScanConfig { crosstalk: cfg.crosstalk, decode_scale, ..ScanConfig::default() };
        let mut s = Scanner::new(spec.clone(), calib.clone(), config).unwrap();
        s.scan(&frame).unwrap();
        let r = s.result();
        assert_eq!(r.depth.size(), frame.size());
        assert_eq!(r.cloud.len(), r.depth.pixels().iter().filter(|z| !z.is_nan()).count());
        assert!(r.correspondence().pixels().iter().all(|c| c[0].is_nan() || (-600.0..600.0).contains(&c[0])));
        let metrics = measure(&r.depth, view.truth());
        // The teaching stages are the decoder's, at the reduced scale, and say so.
        let f = s.decode_factor();
        let stages = s.stages();
        assert!(!stages.is_empty());
        for stage in &stages {
            assert_eq!(stage.image.size(), (1920 / f, 1440 / f), "{}", stage.name);
            assert_eq!(stage.caption.contains(&format!("1/{f} scale")), f > 1, "{}", stage.caption);
        }
        (f, metrics)
    };
    let ((full_factor, full), (factor, reduced)) = (scan(DecodeScale::Full), scan(DecodeScale::Auto));
    eprintln!(
        "full scale coverage {:.4} outliers {:.4} RMSE {:.3}; 1/{factor} scale coverage {:.4} outliers {:.4} RMSE {:.3}",
        full.coverage, full.outliers, full.rmse_mm, reduced.coverage, reduced.outliers, reduced.rmse_mm
    );
    assert_eq!((full_factor, factor), (1, 3));
    assert!(reduced.coverage > full.coverage + 0.1, "{} against {}", reduced.coverage, full.coverage);
    assert!(reduced.outliers < full.outliers + 0.002, "{} against {}", reduced.outliers, full.outliers);
    assert!(reduced.rmse_mm < full.rmse_mm + 0.05, "{} mm against {} mm", reduced.rmse_mm, full.rmse_mm);
    // The blend is the cause: the pattern as generated, its boundaries on pixel edges,
    // decodes at the frame's own scale (measured 90.0 %).
    let aligned = PatternSpec::generate(2, calib.projector.width, calib.projector.height, 5.0).unwrap();
    view.photograph_into(&aligned.render_rgb8(), &cfg, &mut Scratch::default(), &mut frame).unwrap();
    let config = ScanConfig { crosstalk: cfg.crosstalk, decode_scale: DecodeScale::Full, ..ScanConfig::default() };
    let mut s = Scanner::new(aligned, calib.clone(), config).unwrap();
    let edges = measure(&s.scan(&frame).unwrap().depth, view.truth());
    eprintln!("boundaries on pixel edges, full scale: coverage {:.4} outliers {:.4} RMSE {:.3}", edges.coverage, edges.outliers, edges.rmse_mm);
    assert!(edges.coverage > full.coverage + 0.1, "{} against {}", edges.coverage, full.coverage);
}

/// A VGA frame is decoded at its own scale under `auto`, bit for bit as under `full`.
fn a_vga_frame_is_decoded_at_its_own_scale() {
    let calib = Calibration::demo();
    let spec = PatternSpec::generate(2, calib.projector.width, calib.projector.height, 38.0).unwrap();
    let cfg = SimConfig::default();
    let view = View::new(&Scene::builtin("sphere").unwrap(), &calib, &cfg).unwrap();
    let mut frame = Image::new(0, 0, [0u8; 3]);
    view.photograph_into(&spec.render_rgb8(), &cfg, &mut Scratch::default(), &mut frame).unwrap();
    let depth = |decode_scale| {
        let mut s = Scanner::new(spec.clone(), calib.clone(), ScanConfig { crosstalk: cfg.crosstalk, decode_scale, ..ScanConfig::default() }).unwrap();
        assert_eq!(s.decode_factor(), 1);
        s.scan(&frame).unwrap().depth.pixels().iter().map(|z| z.to_bits()).collect::<Vec<_>>()
    };
    assert_eq!(depth(DecodeScale::Auto), depth(DecodeScale::Full));
}
}
