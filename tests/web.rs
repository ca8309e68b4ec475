//! The worker-side API (`src/wasm.rs`) in headless Chromium, as the page's worker calls
//! it: a simulator frame of a built-in scene is scanned through the `Scanner` wrapper,
//! and bad input of every kind comes back as a JS `Error` with a clear message instead
//! of a panic.
#![cfg(target_arch = "wasm32")]

use stripelight::wasm::{
    calibration_from_rig, decode_image, simulator_crosstalk, default_calibration, encode_pfm_js, encode_ply_js, generate_pattern,
    parse_calibration, render_scene, scene_names, WasmScanner,
};
use wasm_bindgen::{JsError, JsValue};
use wasm_bindgen_test::{wasm_bindgen_test, wasm_bindgen_test_configure};

wasm_bindgen_test_configure!(run_in_browser);

/// The message of a JS `Error` made from a `JsError`.
fn message(e: JsError) -> String {
    js_sys::Error::from(JsValue::from(e)).message().into()
}

fn expect_error<T>(result: Result<T, JsError>, contains: &str) -> String {
    match result {
        Ok(_) => panic!("expected an error containing {contains:?}, got Ok"),
        Err(e) => {
            let m = message(e);
            assert!(m.contains(contains), "error {m:?} does not mention {contains:?}");
            m
        }
    }
}

/// A two-direction pattern for the demo rig and the simulator's sphere frame, as the
/// page's built-in sample makes them.
fn sample() -> (String, String, Vec<u8>, u32, u32) {
    let calib = default_calibration();
    let spec = generate_pattern(2, 1024, 768).map_err(message).unwrap();
    let frame = render_scene("sphere", &spec, &calib, 1).map_err(message).unwrap();
    let rgba = frame.rgba().to_vec();
    (spec, calib, rgba, frame.width(), frame.height())
}

#[wasm_bindgen_test]
fn a_simulated_frame_gives_a_plausible_cloud() {
    let (spec, calib, rgba, w, h) = sample();
    assert_eq!((w, h), (640, 480));
    assert_eq!(rgba.len(), 640 * 480 * 4);
    let mut scanner = WasmScanner::new(&spec, &calib, "loggrad", None).map_err(message).unwrap();
    assert_eq!((scanner.width(), scanner.height()), (640, 480));
    let out = scanner.scan(&rgba, w, h).map_err(message).unwrap();
    let n = out.point_count() as usize;
    // Undoing the simulator's known colour mixing, as a colour calibration would, must
    // not lose points.
    let mut unmixed = WasmScanner::new(&spec, &calib, "loggrad", Some(simulator_crosstalk())).map_err(message).unwrap();
    let n_unmixed = unmixed.scan(&rgba, w, h).map_err(message).unwrap().point_count() as usize;
    assert!(n_unmixed * 100 >= n * 95, "{n_unmixed} points with the crosstalk undone, {n} without");
    // The sphere and the wall behind it fill most of the frame: at least a fifth of the
    // pixels must decode, and no more points than pixels can come out.
    assert!(n > 640 * 480 / 5 && n <= 640 * 480, "{n} points");
    assert_eq!(out.positions().length() as usize, 3 * n);
    assert_eq!(out.colors().length() as usize, 3 * n);
    assert_eq!(out.pixels().length() as usize, 2 * n);
    assert_eq!(out.families().length() as usize, n);
    assert_eq!(out.family_count(), 2);
    for k in 0..2 {
        let m = out.family_positions(k).map_err(message).unwrap().length();
        assert!(m > 0 && m.is_multiple_of(3));
    }
    expect_error(out.family_positions(2), "family 2 does not exist");
    assert_eq!(out.depth().length(), 640 * 480);
    // The scene sits around the rig's aim distance (750 mm).
    let mut z: Vec<f32> = out.positions().to_vec().chunks(3).map(|p| p[2]).collect();
    z.sort_by(f32::total_cmp);
    let median = z[z.len() / 2];
    assert!((400.0..1200.0).contains(&median), "median depth {median} mm");
    let stats: serde_json::Value = serde_json::from_str(&out.stats_json()).unwrap();
    assert_eq!(stats["merged"].as_u64(), Some(n as u64));

    // The same scanner takes the next frame with another filter, and keeps stages on request.
    scanner.set_filter("direct").map_err(message).unwrap();
    scanner.set_keep_stages(true);
    let direct = scanner.scan(&rgba, w, h).map_err(message).unwrap();
    assert!(direct.point_count() > 0);
    let stages = scanner.stages();
    assert!(stages.len() >= 4, "{} stages", stages.len());
    for s in &stages {
        assert_eq!(s.rgba().length(), s.width() * s.height() * 4, "stage {}", s.name());
        assert!(!s.caption().is_empty());
    }
}

/// The stored frame the end-to-end test also uses: the simulator's `textured` scene lit
/// by the default two-direction pattern on the demo rig (regenerate with
/// `node tests/e2e/run.mjs --write-fixture`).
const STORED_FRAME: &[u8] = include_bytes!("e2e/fixtures/textured-2dir.png");

#[wasm_bindgen_test]
fn a_stored_frame_decodes_and_scans() {
    let frame = decode_image(STORED_FRAME).map_err(message).unwrap();
    assert_eq!((frame.width(), frame.height()), (640, 480));
    let rgba = frame.rgba().to_vec();
    assert!(rgba.chunks(4).all(|p| p[3] == 255));
    let spec = generate_pattern(2, 1024, 768).map_err(message).unwrap();
    let mut scanner = WasmScanner::new(&spec, &default_calibration(), "loggrad", None).map_err(message).unwrap();
    let loggrad = scanner.scan(&rgba, 640, 480).map_err(message).unwrap().point_count();
    // A textured cylinder before a wall: a tenth of the pixels decode at the very least.
    assert!(loggrad as usize > 640 * 480 / 10, "{loggrad} points");
    // Scanning is deterministic: the same frame gives the same cloud.
    assert_eq!(scanner.scan(&rgba, 640, 480).map_err(message).unwrap().point_count(), loggrad);
}

#[wasm_bindgen_test]
fn scanner_creation_errors_say_what_is_wrong() {
    let calib = default_calibration();
    let spec = generate_pattern(2, 1024, 768).map_err(message).unwrap();
    expect_error(WasmScanner::new("{", &calib, "loggrad", None), "pattern spec");
    expect_error(WasmScanner::new(&spec, "{}", "loggrad", None), "calibration");
    expect_error(WasmScanner::new(&spec, &calib, "sharpen", None), "filter must be");
    expect_error(WasmScanner::new(&spec, &calib, "loggrad", Some(vec![1.0; 4])), "crosstalk must be 9 numbers");
    expect_error(WasmScanner::new(&spec, &calib, "loggrad", Some(vec![0.0; 9])), "crosstalk");
    let small = generate_pattern(2, 800, 600).map_err(message).unwrap();
    let m = expect_error(WasmScanner::new(&small, &calib, "loggrad", None), "800");
    assert!(m.contains("1024"), "{m}");
    expect_error(generate_pattern(4, 1024, 768), "");
    expect_error(parse_calibration(&calib.replace("\"fx\": 760.0", "\"fx\": -760.0")), "camera.fx");
}

#[wasm_bindgen_test]
fn bad_frames_are_errors_not_panics() {
    let (spec, calib, rgba, w, h) = sample();
    let mut scanner = WasmScanner::new(&spec, &calib, "loggrad", None).map_err(message).unwrap();
    expect_error(scanner.scan(&rgba[..rgba.len() - 4], w, h), "RGBA bytes");
    expect_error(scanner.scan(&vec![0; 320 * 240 * 4], 320, 240), "320x240");
    expect_error(scanner.scan(&[], 0, 0), "");
    // A black frame is a result with nothing in it, not an error.
    let black = scanner.scan(&vec![0; rgba.len()], w, h).map_err(message).unwrap();
    assert!(black.point_count() < 1000, "{} points from a black frame", black.point_count());
    // The scanner still works after all that.
    assert!(scanner.scan(&rgba, w, h).map_err(message).unwrap().point_count() > 0);

    expect_error(decode_image(b"hello, not an image"), "not a readable image");
    expect_error(render_scene("teapot", &spec, &calib, 1), "teapot");
    assert!(scene_names().iter().any(|n| n == "sphere"));
    expect_error(encode_ply_js(&[0.0; 3], &[0; 3], &[0.0; 2], &[1, 1], false), "cloud arrays disagree");
    expect_error(encode_pfm_js(&[0.0; 5], 2, 2), "2x2");
    expect_error(calibration_from_rig("{\"camera_width\": 640}"), "calibration");
    expect_error(
        calibration_from_rig(
            r#"{"camera_width": 640, "camera_height": 480, "camera_hfov_deg": 0,
                "projector_width": 1024, "projector_height": 768, "projector_hfov_deg": 48,
                "baseline_mm": [141, 141, 0], "aim_distance_mm": 750}"#,
        ),
        "camera_hfov_deg",
    );
}

#[wasm_bindgen_test]
fn exports_follow_the_conventions() {
    let ply = encode_ply_js(&[1.0, 2.0, 750.0], &[10, 20, 30], &[5.0, 6.0], &[1], false).map_err(message).unwrap();
    let text = String::from_utf8_lossy(&ply);
    assert!(text.starts_with("ply\nformat binary_little_endian 1.0\n"));
    assert!(text.contains("element vertex 1\n") && text.contains("property float u\n"));
    let pfm = encode_pfm_js(&[1.0, f32::NAN, 3.0, 4.0], 2, 2).map_err(message).unwrap();
    assert!(pfm.starts_with(b"Pf\n2 2\n-1.0\n"));
    // Rows bottom to top: the first stored value is the bottom-left pixel.
    assert_eq!(f32::from_le_bytes(pfm[12..16].try_into().unwrap()), 3.0);
    let rig = calibration_from_rig(
        r#"{"camera_width": 640, "camera_height": 480, "camera_hfov_deg": 45.67,
            "projector_width": 1024, "projector_height": 768, "projector_hfov_deg": 48.0,
            "baseline_mm": [141.4, 141.4, 0], "aim_distance_mm": 750}"#,
    )
    .map_err(message)
    .unwrap();
    parse_calibration(&rig).map_err(message).unwrap();
}
