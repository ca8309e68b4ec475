//! The command line: bad input gives one line on stderr and a non-zero exit, never a
//! panic; a good run writes what it says. Native only (it runs the binary).
#![cfg(not(target_arch = "wasm32"))]

use std::path::Path;
use std::process::Command;

fn run(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_stripelight")).args(args).output().unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

fn fails_with(args: &[&str], needle: &str) {
    let (code, err) = run(args);
    assert_ne!(code, 0, "{args:?} succeeded");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: not one line: {err}");
    assert!(err.contains(needle) && !err.contains("panicked"), "{args:?}: {err}");
}

#[test]
fn bad_input_is_one_line_and_a_non_zero_exit() {
    let dir = std::env::temp_dir().join(format!("stripelight-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let (spec, calib, frame) = (p("p.json"), p("c.json"), p("f.png"));
    assert_eq!(run(&["pattern", "--directions", "2", "--out", &p("p.png"), "--spec", &spec]).0, 0);
    assert_eq!(run(&["calib", "--default", "--out", &calib]).0, 0);
    assert_eq!(run(&["render", "--scene", "plane", "--spec", &spec, "--calib", &calib, "--out", &frame]).0, 0);
    std::fs::write(p("broken.json"), "{\"units\": \"mm\", ").unwrap();
    std::fs::write(p("text.png"), "hello").unwrap();
    fails_with(&["pattern", "--directions", "4", "--out", &p("x.png"), "--spec", &p("x.json")], "directions");
    fails_with(&["render", "--scene", "teapot", "--spec", &spec, "--calib", &calib, "--out", &p("x.png")], "plane");
    fails_with(&["render", "--scene", "plane", "--spec", &spec, "--calib", &p("broken.json"), "--out", &p("x.png")], "calibration");
    fails_with(&["scan", "--spec", &calib, "--calib", &calib, "--image", &frame], "pattern spec");
    fails_with(&["scan", "--spec", &spec, "--calib", &calib, "--image", &p("text.png")], "not a readable image");
    fails_with(&["scan", "--spec", &spec, "--calib", &calib, "--image", &p("p.png")], "1024x768 but 640x480");
    fails_with(&["scan", "--spec", &spec, "--calib", &calib, "--image", &frame, "--filter", "sharp"], "filter");
    fails_with(&["scan", "--spec", &spec, "--calib", &calib, "--image", &frame, "--decode-scale", "0"], "decode scale");
    fails_with(&["calib", "--default", "--out", "/nonexistent-dir/c.json"], "/nonexistent-dir/c.json");
    // A good scan writes the depth map and the cloud and says how many points.
    let (code, err) = run(&["scan", "--spec", &spec, "--calib", &calib, "--image", &frame, "--crosstalk", "sim",
        "--depth", &p("d.pfm"), "--ply", &p("c.ply")]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("points") && !err.contains("decoded at"), "{err}");
    assert!(std::fs::read(p("d.pfm")).unwrap().starts_with(b"Pf\n640 480\n-1"));
    // Reduced by a factor asked for: said on the summary line, the outputs at the
    // frame's size.
    let (code, err) = run(&["scan", "--spec", &spec, "--calib", &calib, "--image", &frame, "--crosstalk", "sim",
        "--decode-scale", "2", "--depth", &p("d2.pfm")]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("decoded at 1/2 scale (320x240)"), "{err}");
    assert!(std::fs::read(p("d2.pfm")).unwrap().starts_with(b"Pf\n640 480\n-1"));
    assert!(std::fs::read(p("c.ply")).unwrap().starts_with(b"ply\nformat binary_little_endian 1.0\n"));
    // A black frame is a result (nothing decoded), not an error.
    std::fs::write(p("black.png"), stripelight::io::encode_png(&stripelight::Image::new(640, 480, [0u8; 3])).unwrap()).unwrap();
    let (code, err) = run(&["scan", "--spec", &spec, "--calib", &calib, "--image", &p("black.png")]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("0 points") && err.contains("nothing decoded"), "{err}");
    // The colour mixing read from the frame: printed round by round in the form
    // --crosstalk takes, and more points than with none; on the black frame, the
    // problem is said and the scan still succeeds with none.
    let points = |err: &str| err.lines().find_map(|l| l.split(" points").next()?.parse::<usize>().ok()).unwrap_or(0);
    let (code, none) = run(&["scan", "--spec", &spec, "--calib", &calib, "--image", &frame]);
    assert_eq!(code, 0, "{none}");
    let (code, err) = run(&["scan", "--spec", &spec, "--calib", &calib, "--image", &frame, "--crosstalk", "frame"]);
    assert_eq!(code, 0, "{err}");
    let printed = err.lines().find(|l| l.starts_with("colour mixing from the frame, round 2: ")).unwrap_or_else(|| panic!("{err}"));
    let values = printed.split(": ").nth(1).unwrap().split(' ').next().unwrap();
    let m = stripelight::calib::parse_crosstalk(values).unwrap();
    assert!((m[0][0] - 0.86).abs() < 0.02 && (m[1][0] - 0.07).abs() < 0.02, "{printed}");
    assert!(points(&err) > points(&none), "{err} against {none}");
    let (code, err) = run(&["scan", "--spec", &spec, "--calib", &calib, "--image", &p("black.png"), "--crosstalk", "frame"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("colour mixing from the frame: only 0 regions") && err.contains("scanned with no colour mixing"), "{err}");
    let _ = std::fs::remove_dir_all(Path::new(&dir));
}

#[test]
fn a_measured_response_is_printed_and_read_back_by_scan() {
    use stripelight::sim::{Scene, SimConfig, View};
    let dir = std::env::temp_dir().join(format!("stripelight-cli-response-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = |name: &str| dir.join(name).to_string_lossy().into_owned();
    // The white card through a shoulder, at the exposure that just clips it.
    let calib = stripelight::Calibration::demo();
    let cfg = SimConfig { highlight_knee: 0.8, ..SimConfig::default() };
    let view = View::new(&Scene::builtin("plane").unwrap(), &calib, &cfg).unwrap();
    let white = stripelight::Image::new(1024, 768, [255u8; 3]);
    let cfg = SimConfig { exposure: view.exposure_for_clipping(&white, &cfg, 0.02).unwrap(), ..cfg };
    for (name, level) in [("w.png", 255u8), ("g.png", 128), ("k.png", 0)] {
        let mut shot = stripelight::Image::new(0, 0, [0u8; 3]);
        let projector = stripelight::Image::new(1024, 768, [level; 3]);
        view.photograph_into(&projector, &cfg, &mut stripelight::sim::Scratch::default(), &mut shot).unwrap();
        std::fs::write(p(name), stripelight::io::encode_png(&shot).unwrap()).unwrap();
    }
    let out = Command::new(env!("CARGO_BIN_EXE_stripelight"))
        .args(["response", "--white", &p("w.png"), "--grey", &p("g.png"), "--black", &p("k.png")])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json = String::from_utf8(out.stdout).unwrap();
    let response = stripelight::calib::CameraResponse::from_json(&json).unwrap();
    assert!(!response.is_power_law(2.2, 0.02), "no shoulder measured");
    std::fs::write(p("r.json"), &json).unwrap();
    let (spec, calib_file, frame) = (p("p.json"), p("c.json"), p("f.png"));
    assert_eq!(run(&["pattern", "--directions", "2", "--out", &p("p.png"), "--spec", &spec]).0, 0);
    assert_eq!(run(&["calib", "--default", "--out", &calib_file]).0, 0);
    assert_eq!(run(&["render", "--scene", "plane", "--spec", &spec, "--calib", &calib_file, "--out", &frame]).0, 0);
    let (code, err) = run(&["scan", "--spec", &spec, "--calib", &calib_file, "--image", &frame, "--response", &p("r.json")]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("points"), "{err}");
    let (code, err) = run(&["crosstalk", "--red", &p("w.png"), "--green", &p("w.png"), "--blue", &p("w.png"), "--black", &p("k.png"), "--response", &p("r.json")]);
    assert_eq!(code, 0, "{err}");
    std::fs::write(p("bad.json"), json.replacen('[', "[1,", 1)).unwrap();
    fails_with(&["scan", "--spec", &spec, "--calib", &calib_file, "--image", &frame, "--response", &p("bad.json")], "camera response");
    fails_with(&["response", "--white", &p("w.png"), "--grey", &p("k.png"), "--black", &p("k.png")], "grey frame");
    let _ = std::fs::remove_dir_all(Path::new(&dir));
}
