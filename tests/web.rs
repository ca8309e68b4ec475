//! The worker-side API (`src/wasm.rs`) in headless Chromium, as the page's worker calls
//! it: a simulator frame of a built-in scene is scanned through the `Scanner` wrapper,
//! and bad input of every kind comes back as a JS `Error` with a clear message instead
//! of a panic.
#![cfg(target_arch = "wasm32")]

use js_sys::{Object, Reflect};
use stripelight::sim::{Scene, Scratch, SimConfig, View};
use stripelight::wasm::{
    calibration_from_rig, decode_image, default_calibration, encode_pfm_js, encode_ply_js, estimate_crosstalk,
    estimate_response, generate_pattern, parse_calibration, parse_crosstalk_js, parse_response, power_law_tolerance,
    render_scene, response_departure, response_json, scene_names, simulator_crosstalk, WasmScanner,
};
use stripelight::{Calibration, Image};
use wasm_bindgen::{JsCast, JsError, JsValue};
use wasm_bindgen_test::{wasm_bindgen_test, wasm_bindgen_test_configure};

wasm_bindgen_test_configure!(run_in_browser);

/// The message of a JS `Error` made from a `JsError`.
fn message(e: JsError) -> String {
    js_sys::Error::from(JsValue::from(e)).message().into()
}

/// Field `name` of a cloud object from `Scanner.cloud` as the typed array it is.
fn field<T: JsCast>(cloud: &Object, name: &str) -> T {
    Reflect::get(cloud, &JsValue::from_str(name)).unwrap().dyn_into::<T>().unwrap()
}

/// Scan and return the merged cloud's number of points (from the cloud itself).
fn points(scanner: &mut WasmScanner, rgba: &[u8], w: u32, h: u32) -> usize {
    scanner.scan(rgba, w, h).map_err(message).unwrap();
    field::<js_sys::Uint8Array>(&scanner.cloud(None).map_err(message).unwrap(), "families").length() as usize
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
    let mut scanner = WasmScanner::new(&spec, &calib, "loggrad", None, None).map_err(message).unwrap();
    assert_eq!((scanner.width(), scanner.height()), (640, 480));
    // Before the first frame there is nothing to show.
    assert!(scanner.stages().is_empty());
    let stats: serde_json::Value = serde_json::from_str(&scanner.scan(&rgba, w, h).map_err(message).unwrap()).unwrap();
    let merged = scanner.cloud(None).map_err(message).unwrap();
    let n = field::<js_sys::Uint8Array>(&merged, "families").length() as usize;
    // Undoing the simulator's known colour mixing, as a colour calibration would, must
    // not lose points.
    let mut unmixed = WasmScanner::new(&spec, &calib, "loggrad", Some(simulator_crosstalk()), None).map_err(message).unwrap();
    let n_unmixed = points(&mut unmixed, &rgba, w, h);
    assert!(n_unmixed * 100 >= n * 95, "{n_unmixed} points with the crosstalk undone, {n} without");
    // The sphere and the wall behind it fill most of the frame: at least a fifth of the
    // pixels must decode, and no more points than pixels can come out.
    assert!(n > 640 * 480 / 5 && n <= 640 * 480, "{n} points");
    let positions = field::<js_sys::Float32Array>(&merged, "positions");
    assert_eq!(positions.length() as usize, 3 * n);
    assert_eq!(field::<js_sys::Uint8Array>(&merged, "colors").length() as usize, 3 * n);
    assert_eq!(field::<js_sys::Float32Array>(&merged, "pixels").length() as usize, 2 * n);
    assert_eq!(scanner.family_count(), 2);
    let decoded = stats["decoded"].as_array().unwrap();
    for k in 0..2 {
        let family = scanner.cloud(Some(k)).map_err(message).unwrap();
        let m = field::<js_sys::Uint8Array>(&family, "families");
        assert_eq!(Some(m.length() as u64), decoded[k as usize].as_u64(), "family {k}");
        assert!(m.length() > 0 && m.to_vec().iter().all(|&f| f == 1 << k));
        assert_eq!(field::<js_sys::Float32Array>(&family, "positions").length(), 3 * m.length());
    }
    expect_error(scanner.cloud(Some(2)), "family 2 does not exist");
    // The depth map has a depth exactly where the merged cloud has a point.
    let depth = scanner.depth().to_vec();
    assert_eq!(depth.len(), 640 * 480);
    assert_eq!(depth.iter().filter(|z| !z.is_nan()).count(), n);
    // The scene sits around the rig's aim distance (750 mm).
    let mut z: Vec<f32> = positions.to_vec().chunks(3).map(|p| p[2]).collect();
    z.sort_by(f32::total_cmp);
    let median = z[z.len() / 2];
    assert!((400.0..1200.0).contains(&median), "median depth {median} mm");
    assert_eq!(stats["merged"].as_u64(), Some(n as u64));

    // The same scanner takes the next frame with another filter; the stages show it.
    scanner.set_filter("direct").map_err(message).unwrap();
    assert!(points(&mut scanner, &rgba, w, h) > 0);
    let stages = scanner.stages();
    assert!(stages.len() >= 4, "{} stages", stages.len());
    for s in &stages {
        assert_eq!(s.rgba().length(), s.width() * s.height() * 4, "stage {}", s.name());
        assert!(!s.caption().is_empty());
    }
    assert!(stages.iter().any(|s| s.caption().contains("(log scale, direct)")), "the stages are the direct scan's");
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
    let mut scanner = WasmScanner::new(&spec, &default_calibration(), "loggrad", None, None).map_err(message).unwrap();
    let loggrad = points(&mut scanner, &rgba, 640, 480);
    // A textured cylinder before a wall: a tenth of the pixels decode at the very least.
    assert!(loggrad > 640 * 480 / 10, "{loggrad} points");
    // Scanning is deterministic: the same frame gives the same cloud.
    assert_eq!(points(&mut scanner, &rgba, 640, 480), loggrad);
}

#[wasm_bindgen_test]
fn scanner_creation_errors_say_what_is_wrong() {
    let calib = default_calibration();
    let spec = generate_pattern(2, 1024, 768).map_err(message).unwrap();
    expect_error(WasmScanner::new("{", &calib, "loggrad", None, None), "pattern spec");
    expect_error(WasmScanner::new(&spec, "{}", "loggrad", None, None), "calibration");
    expect_error(WasmScanner::new(&spec, &calib, "sharpen", None, None), "filter: must be");
    expect_error(WasmScanner::new(&spec, &calib, "loggrad", Some(vec![1.0; 4]), None), "crosstalk: needs 9 numbers");
    expect_error(WasmScanner::new(&spec, &calib, "loggrad", Some(vec![0.0; 9]), None), "cannot be inverted");
    expect_error(parse_crosstalk_js("1, 0, 0"), "crosstalk: needs 9 numbers");
    assert_eq!(parse_crosstalk_js("0.9,0.1,0; 0 1 0\n0 0 1").map_err(message).unwrap()[..3], [0.9, 0.1, 0.0]);
    let small = generate_pattern(2, 800, 600).map_err(message).unwrap();
    let m = expect_error(WasmScanner::new(&small, &calib, "loggrad", None, None), "800");
    assert!(m.contains("1024"), "{m}");
    expect_error(generate_pattern(4, 1024, 768), "directions: must be 1, 2 or 3, got 4");
    expect_error(parse_calibration(&calib.replace("\"fx\": 760.0", "\"fx\": -760.0")), "camera.fx");
}

/// RGBA frames of the simulator's white card (the plane scene) under flat projector
/// colours, at the exposure that clips 2 % of the card under white, as the page's
/// guided colour calibration takes them.
fn card_frames(cfg: &SimConfig, colours: &[[u8; 3]]) -> Vec<Vec<u8>> {
    let calib = Calibration::demo();
    let view = View::new(&Scene::builtin("plane").unwrap(), &calib, cfg).unwrap();
    let flat = |rgb: [u8; 3]| Image::new(calib.projector.width as usize, calib.projector.height as usize, rgb);
    let exposure = view.exposure_for_clipping(&flat([255; 3]), cfg, 0.02).unwrap();
    let mut scratch = Scratch::default();
    let mut frame = Image::new(0, 0, [0u8; 3]);
    let mut frames = Vec::new();
    for (k, &rgb) in colours.iter().enumerate() {
        let shot = SimConfig { exposure, seed: 40 + k as u64, ..cfg.clone() };
        view.photograph_into(&flat(rgb), &shot, &mut scratch, &mut frame).unwrap();
        frames.push(stripelight::raster::to_rgba8(&frame));
    }
    frames
}

#[wasm_bindgen_test]
fn the_colour_calibration_measures_a_shoulder_and_the_scanner_reads_through_it() {
    // The six frames the page's guided colour calibration takes, through a camera whose
    // tone curve rolls off the highlights: the response departs from the power law, the
    // colour mixing read through it is the simulator's, and a scanner takes it.
    let colours = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255; 3], [128; 3], [0; 3]];
    let toned = SimConfig { highlight_knee: 0.8, ..SimConfig::default() };
    let f = card_frames(&toned, &colours);
    let table = estimate_response(&f[3], &f[4], &f[5], 640, 480, 128, 2.2, 2.2).map_err(message).unwrap();
    assert_eq!(table.len(), 256);
    let departure = response_departure(&table, 2.2).map_err(message).unwrap();
    assert!(departure > 2.0 * power_law_tolerance(), "the shoulder departs by {departure}");
    let mixing = estimate_crosstalk(&f[0], &f[1], &f[2], &f[5], 640, 480, 2.2, Some(table.clone())).map_err(message).unwrap();
    for (m, truth) in mixing.iter().zip(simulator_crosstalk()) {
        assert!((m - truth).abs() < 0.02, "measured {mixing:?}, the simulator's {:?}", simulator_crosstalk());
    }
    assert_eq!(parse_response(&response_json(&table).map_err(message).unwrap()).map_err(message).unwrap(), table);
    let (spec, calib, rgba, w, h) = sample();
    let mut scanner = WasmScanner::new(&spec, &calib, "loggrad", None, Some(table.clone())).map_err(message).unwrap();
    assert!(points(&mut scanner, &rgba, w, h) > 640 * 480 / 5);
    // Without a shoulder the measurement is the power law within its noise.
    let plain = card_frames(&SimConfig::default(), &colours[3..]);
    let table = estimate_response(&plain[0], &plain[1], &plain[2], 640, 480, 128, 2.2, 2.2).map_err(message).unwrap();
    assert!(response_departure(&table, 2.2).map_err(message).unwrap() <= power_law_tolerance());
    // Broken tables and swapped frames are refused by name.
    let mut falling = table.clone();
    falling[210] = 0.0;
    expect_error(WasmScanner::new(&spec, &calib, "loggrad", None, Some(falling)), "camera response");
    expect_error(WasmScanner::new(&spec, &calib, "loggrad", None, Some(vec![0.5; 7])), "256");
    expect_error(parse_response("{\"gamma\": 2.2}"), "camera response");
    expect_error(estimate_response(&plain[1], &plain[0], &plain[2], 640, 480, 128, 2.2, 2.2), "grey frame");
}

#[wasm_bindgen_test]
fn bad_frames_are_errors_not_panics() {
    let (spec, calib, rgba, w, h) = sample();
    let mut scanner = WasmScanner::new(&spec, &calib, "loggrad", None, None).map_err(message).unwrap();
    expect_error(scanner.scan(&rgba[..rgba.len() - 4], w, h), "cannot be a 640x480 image of 4 per pixel");
    expect_error(scanner.scan(&vec![0; 320 * 240 * 4], 320, 240), "image is 320x240 but 640x480 was expected");
    expect_error(scanner.scan(&[], 0, 0), "image is 0x0 but 640x480 was expected");
    // A black frame is a result with nothing in it, not an error.
    let black = points(&mut scanner, &vec![0; rgba.len()], w, h);
    assert!(black < 1000, "{black} points from a black frame");
    // The scanner still works after all that.
    assert!(points(&mut scanner, &rgba, w, h) > 0);

    expect_error(decode_image(b"hello, not an image"), "not a readable image");
    expect_error(render_scene("teapot", &spec, &calib, 1), "teapot");
    assert!(scene_names().iter().any(|n| n == "sphere"));
    expect_error(encode_ply_js(&[0.0; 3], &[0; 3], &[0.0; 2], &[1, 1], false), "cloud: arrays disagree");
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
