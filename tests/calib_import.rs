//! Calibrations from other tools (`calib import`): the demo rig written as OpenCV
//! FileStorage YAML and JSON and as Bouguet's stereo text imports back to the same
//! calibration; the hand-written files of `tests/data/calib/` (one per format, in the
//! dialect the tools write) import to the demo rig; bad files give one line naming the
//! field. Each test runs natively and in the browser; the command-line test at the end
//! runs natively.

#[macro_use]
mod support;

#[cfg(target_arch = "wasm32")]
wasm_bindgen_test::wasm_bindgen_test_configure!(run_in_browser);

use glam::{DMat3, DQuat, DVec3};
use stripelight::calib::import::{from_text, rotation_from_rodrigues, Format, ImportOptions};
use stripelight::calib::Intrinsics;
use stripelight::Calibration;

/// How OpenCV (before 4.0) writes a double: whole values as `760.`, others with 17
/// significant digits and a two-digit signed exponent.
fn cv(v: f64) -> String {
    if v == v.round() && v.abs() < 1e9 {
        return format!("{}.", v as i64);
    }
    let s = format!("{v:.16e}");
    let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    format!("{mantissa}e{}{:02}", if exp < 0 { '-' } else { '+' }, exp.abs())
}

fn k_of(i: &Intrinsics) -> [f64; 9] {
    [i.fx, 0.0, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0]
}

/// The calibration's rotation as a Rodrigues vector.
fn rodrigues_of(c: &Calibration) -> DVec3 {
    let (axis, angle) = DQuat::from_mat3(&c.proj_from_cam_rotation()).to_axis_angle();
    axis * angle
}

/// Names one tool writes (camera matrix, camera distortion, projector matrix,
/// projector distortion, camera size, projector size; `None` for a size it does not
/// write).
struct Dialect {
    names: [&'static str; 4],
    camera_size: Option<&'static str>,
    projector_size: Option<&'static str>,
    /// Rotation as a Rodrigues vector under this name instead of `R`.
    rodrigues: Option<&'static str>,
}

const DIALECTS: [Dialect; 3] = [
    Dialect {
        names: ["cam_K", "cam_kc", "proj_K", "proj_kc"],
        camera_size: Some("cam_size"),
        projector_size: Some("proj_size"),
        rodrigues: None,
    },
    Dialect {
        names: ["cameraMatrix1", "distCoeffs1", "cameraMatrix2", "distCoeffs2"],
        camera_size: Some("imageSize"),
        projector_size: None,
        rodrigues: None,
    },
    Dialect { names: ["M1", "D1", "M2", "D2"], camera_size: None, projector_size: None, rodrigues: Some("om") },
];

/// OpenCV FileStorage YAML as `cv::FileStorage` writes it.
fn opencv_yaml(c: &Calibration, d: &Dialect) -> String {
    let matrix = |name: &str, rows: usize, cols: usize, values: &[f64]| {
        let data: Vec<String> = values.iter().map(|&v| cv(v)).collect();
        format!("{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n", data.join(", "))
    };
    let mut text = String::from("%YAML:1.0\n---\n");
    text += &matrix(d.names[0], 3, 3, &k_of(&c.camera));
    text += &matrix(d.names[1], 1, 5, &c.camera.dist);
    text += &matrix(d.names[2], 3, 3, &k_of(&c.projector));
    text += &matrix(d.names[3], 1, 5, &c.projector.dist);
    match d.rodrigues {
        Some(name) => text += &matrix(name, 3, 1, &rodrigues_of(c).to_array()),
        None => text += &matrix("R", 3, 3, &c.rotation),
    }
    text += &matrix("T", 3, 1, &c.translation);
    if let Some(name) = d.camera_size {
        text += &format!("{name}: [ {}, {} ]\n", c.camera.width, c.camera.height);
    }
    if let Some(name) = d.projector_size {
        text += &format!("{name}: [ {}, {} ]\n", c.projector.width, c.projector.height);
    }
    text += "rms: 2.4417301852013116e-01\n";
    text
}

/// OpenCV FileStorage JSON, with the `760.` numbers OpenCV before 4.0 writes there too.
fn opencv_json(c: &Calibration, d: &Dialect) -> String {
    let matrix = |name: &str, rows: usize, cols: usize, values: &[f64]| {
        let data: Vec<String> = values.iter().map(|&v| cv(v)).collect();
        format!(
            "    \"{name}\": {{\n        \"type_id\": \"opencv-matrix\",\n        \"rows\": {rows},\n        \"cols\": {cols},\n        \"dt\": \"d\",\n        \"data\": [ {} ]\n    }}",
            data.join(", ")
        )
    };
    let mut parts = vec![
        matrix(d.names[0], 3, 3, &k_of(&c.camera)),
        matrix(d.names[1], 1, 5, &c.camera.dist),
        matrix(d.names[2], 3, 3, &k_of(&c.projector)),
        matrix(d.names[3], 1, 5, &c.projector.dist),
    ];
    match d.rodrigues {
        Some(name) => parts.push(matrix(name, 3, 1, &rodrigues_of(c).to_array())),
        None => parts.push(matrix("R", 3, 3, &c.rotation)),
    }
    parts.push(matrix("T", 3, 1, &c.translation));
    if let Some(name) = d.camera_size {
        parts.push(format!("    \"{name}\": [ {}, {} ]", c.camera.width, c.camera.height));
    }
    if let Some(name) = d.projector_size {
        parts.push(format!("    \"{name}\": [ {}, {} ]", c.projector.width, c.projector.height));
    }
    format!("{{\n{}\n}}\n", parts.join(",\n"))
}

/// Bouguet's stereo results as text, the rotation as the Rodrigues vector `om`.
fn bouguet_text(c: &Calibration) -> String {
    let v = |values: &[f64]| {
        let items: Vec<String> = values.iter().map(|x| format!("{x:?}")).collect();
        format!("[ {} ]", items.join(" ; "))
    };
    let device = |side: &str, i: &Intrinsics| {
        format!(
            "%-- Focal length:\nfc_{side} = {};\n%-- Principal point:\ncc_{side} = {};\n%-- Skew coefficient:\nalpha_c_{side} = 0.000000000000000;\n%-- Distortion coefficients:\nkc_{side} = {};\n\n",
            v(&[i.fx, i.fy]),
            v(&[i.cx, i.cy]),
            v(&i.dist)
        )
    };
    format!(
        "% Intrinsic and Extrinsic Camera Parameters\n\n{}nx = {};\nny = {};\n\n{}%-- Rotation vector:\nom = {};\n%-- Translation vector:\nT = {};\n",
        device("left", &c.camera),
        c.camera.width,
        c.camera.height,
        device("right", &c.projector),
        v(&rodrigues_of(c).to_array()),
        v(&c.translation)
    )
}

/// Equal to `tol` relative (absolute below magnitude 1).
fn assert_close(a: &Calibration, b: &Calibration, tol: f64, what: &str) {
    let values = |c: &Calibration| -> Vec<f64> {
        let mut v = Vec::new();
        for i in [&c.camera, &c.projector] {
            v.extend([i.width as f64, i.height as f64, i.fx, i.fy, i.cx, i.cy]);
            v.extend(i.dist);
        }
        v.extend(c.rotation);
        v.extend(c.translation);
        v
    };
    assert_eq!(a.units, b.units);
    for (k, (x, y)) in values(a).iter().zip(values(b)).enumerate() {
        assert!((x - y).abs() <= tol * x.abs().max(y.abs()).max(1.0), "{what}: value {k}: {x} vs {y}");
    }
}

fn options_for(c: &Calibration, d: &Dialect) -> ImportOptions {
    ImportOptions {
        camera_size: d.camera_size.is_none().then_some((c.camera.width, c.camera.height)),
        projector_size: d.projector_size.is_none().then_some((c.projector.width, c.projector.height)),
        ..ImportOptions::default()
    }
}

/// The error's text, checked to be one line in the import's form.
fn one_line_error(text: &str, options: &ImportOptions) -> String {
    let err = from_text(text, options).expect_err("the import should fail").to_string();
    assert!(!err.contains('\n'), "not one line: {err}");
    assert!(err.starts_with("calibration import ("), "{err}");
    err
}

fn demo_options() -> ImportOptions {
    ImportOptions { camera_size: Some((640, 480)), projector_size: Some((1024, 768)), ..ImportOptions::default() }
}

both_targets! {
/// The simulator's rigs, written by each tool's dialect, import back to themselves.
fn the_demo_rigs_round_trip_through_every_format() {
    for rig in [Calibration::demo(), Calibration::demo_distorted()] {
        for d in &DIALECTS {
            let options = options_for(&rig, d);
            let yaml = from_text(&opencv_yaml(&rig, d), &options).unwrap();
            assert_eq!(yaml.format, Format::OpenCvYaml);
            assert_close(&yaml.calibration, &rig, 1e-9, &format!("YAML {}", d.names[0]));
            let json = from_text(&opencv_json(&rig, d), &options).unwrap();
            assert_eq!(json.format, Format::OpenCvJson);
            assert_close(&json.calibration, &rig, 1e-9, &format!("JSON {}", d.names[0]));
        }
        let options = ImportOptions { projector_size: Some((1024, 768)), ..ImportOptions::default() };
        let bouguet = from_text(&bouguet_text(&rig), &options).unwrap();
        assert_eq!(bouguet.format, Format::Bouguet);
        assert_close(&bouguet.calibration, &rig, 1e-9, "Bouguet");
        // And the project's own file goes through unchanged.
        let own = from_text(&rig.to_json(), &ImportOptions::default()).unwrap();
        assert_eq!((own.format, &own.calibration), (Format::Stripelight, &rig));
    }
}

/// The stored files, in the dialects the tools write (OpenCV 3's YAML as Moreno and
/// Taubin's calibration saves it, OpenCV 4's JSON with 8 coefficients, the toolbox's
/// text with 15 decimals), import to the distorted demo rig.
fn stored_files_of_each_format_import_to_the_demo_rig() {
    let rig = Calibration::demo_distorted();
    let yaml = from_text(include_str!("data/calib/moreno-taubin.yml"), &demo_options()).unwrap();
    assert_eq!(yaml.format, Format::OpenCvYaml);
    assert_close(&yaml.calibration, &rig, 1e-12, "moreno-taubin.yml");
    let json_options = ImportOptions { projector_size: Some((1024, 768)), ..ImportOptions::default() };
    let json = from_text(include_str!("data/calib/stereo-opencv4.json"), &json_options).unwrap();
    assert_eq!(json.format, Format::OpenCvJson);
    assert_close(&json.calibration, &rig, 1e-12, "stereo-opencv4.json");
    let m = from_text(include_str!("data/calib/Calib_Results_stereo.m"), &json_options).unwrap();
    assert_eq!(m.format, Format::Bouguet);
    // 15 decimals of om and T.
    assert_close(&m.calibration, &rig, 1e-12, "Calib_Results_stereo.m");
    let summary = yaml.summary();
    assert!(summary.starts_with("OpenCV YAML: read cam_K, cam_kc, --camera-size, proj_K"), "{summary}");
    assert!(summary.contains("baseline 200.0 mm"), "{summary}");
}

/// A rotation given as a Rodrigues vector is the matrix it stands for.
fn a_rodrigues_vector_matches_its_matrix() {
    let quarter = rotation_from_rodrigues(DVec3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2));
    let expected = DMat3::from_cols(DVec3::Y, -DVec3::X, DVec3::Z);
    assert!(quarter.abs_diff_eq(expected, 1e-15), "{quarter}");
    assert_eq!(rotation_from_rodrigues(DVec3::ZERO), DMat3::IDENTITY);
    let rig = Calibration::demo();
    let with_matrix = from_text(&opencv_yaml(&rig, &DIALECTS[0]), &ImportOptions::default()).unwrap();
    let as_vector = Dialect { rodrigues: Some("om"), ..DIALECTS[0] };
    let with_vector = from_text(&opencv_yaml(&rig, &as_vector), &ImportOptions::default()).unwrap();
    for (a, b) in with_matrix.calibration.rotation.iter().zip(&with_vector.calibration.rotation) {
        assert!((a - b).abs() < 1e-12, "{a} vs {b}");
    }
    // R written as a 3x1 matrix is a Rodrigues vector too.
    let r_as_vector = Dialect { rodrigues: Some("R"), ..DIALECTS[0] };
    let imported = from_text(&opencv_yaml(&rig, &r_as_vector), &ImportOptions::default()).unwrap();
    assert_close(&imported.calibration, &rig, 1e-9, "R as a vector");
    assert!(imported.sources.iter().any(|s| s.theirs == "R (Rodrigues)"));
}

/// Sizes come from the file or the options, and must agree; T may be in other units.
fn sizes_and_units_come_from_the_options_where_the_file_is_silent() {
    let rig = Calibration::demo();
    let text = opencv_yaml(&rig, &DIALECTS[2]);
    let err = one_line_error(&text, &ImportOptions { camera_size: Some((640, 480)), ..ImportOptions::default() });
    assert!(err.contains("proj_size") && err.contains("--projector-size") && err.contains("missing"), "{err}");
    let with_size = opencv_yaml(&rig, &DIALECTS[0]);
    let clash = ImportOptions { camera_size: Some((1280, 960)), ..ImportOptions::default() };
    let err = one_line_error(&with_size, &clash);
    assert!(err.contains("cam_size") && err.contains("640x480") && err.contains("1280x960"), "{err}");
    // T in metres.
    let mut metres = rig.clone();
    metres.translation = rig.translation.map(|t| t / 1000.0);
    let imported =
        from_text(&opencv_yaml(&metres, &DIALECTS[0]), &ImportOptions { unit_scale: 1000.0, ..ImportOptions::default() })
            .unwrap();
    assert_close(&imported.calibration, &rig, 1e-9, "T in metres");
    assert!(from_text(&with_size, &ImportOptions { unit_scale: 0.0, ..ImportOptions::default() })
        .unwrap_err()
        .to_string()
        .contains("unit-scale"));
}

/// Bad files give one line that names the field.
fn bad_imports_name_the_field() {
    let rig = Calibration::demo();
    let good = opencv_yaml(&rig, &DIALECTS[0]);
    let k = "cam_K: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 760., 0., 3.1950000000000000e+02, 0., 760., 2.3950000000000000e+02, 0., 0., 1. ]\n";
    assert!(good.contains(k), "the writer changed: {good}");
    let mut stretched = rig.clone();
    stretched.rotation[0] *= 2.0;
    let cases: Vec<(String, &str, &[&str])> = vec![
        // Malformed YAML: the position of the fault.
        (good.replace("   cols: 3\n   dt: d\n   data: [ 760.", "  cols: [3\n   dt: d\n   data: [ 760."), "OpenCV YAML", &["line 5"]),
        // A missing matrix, named in the file's dialect.
        (good.replace("proj_K:", "projK:"), "OpenCV YAML", &["proj_K", "missing"]),
        (opencv_yaml(&rig, &DIALECTS[1]).replace("distCoeffs2", "dist2"), "OpenCV YAML", &["distCoeffs2", "missing"]),
        (good.replace("\nT:", "\nTranslation:"), "OpenCV YAML", &["): T: missing"]),
        // A 2x3 camera matrix.
        (
            good.replace(k, "cam_K: !!opencv-matrix\n   rows: 2\n   cols: 3\n   dt: d\n   data: [ 760., 0., 319.5, 0., 760., 239.5 ]\n"),
            "OpenCV YAML",
            &["cam_K", "3x3", "2x3"],
        ),
        // Data that does not fill the matrix.
        (good.replace("0., 0., 1. ]\ncam_kc", "0., 0. ]\ncam_kc"), "OpenCV YAML", &["cam_K.data", "8 values"]),
        // A rotation that is not one.
        (opencv_yaml(&stretched, &DIALECTS[0]), "OpenCV YAML", &["R (rotation)", "not a rotation"]),
        // NaN, as OpenCV writes it.
        (good.replace("data: [ 760., 0., 3.195", "data: [ .Nan, 0., 3.195"), "OpenCV YAML", &["cam_K.data[0]", "NaN"]),
        // Skew and higher distortion terms the model cannot represent.
        (good.replace("data: [ 760., 0., 3.195", "data: [ 760., 2.5, 3.195"), "OpenCV YAML", &["cam_K[0][1]", "skew"]),
        (
            good.replace("cam_kc: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]", "cam_kc: !!opencv-matrix\n   rows: 1\n   cols: 8\n   dt: d\n   data: [ 0., 0., 0., 0., 0., 0.25, 0., 0. ]"),
            "OpenCV YAML",
            &["cam_kc.data[5]", "k4"],
        ),
        (
            good.replace("cam_kc: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]", "cam_kc: [ 0., 0., 0. ]"),
            "OpenCV YAML",
            &["cam_kc", "4, 5, 8, 12 or 14"],
        ),
        // A zero focal length, caught by Calibration::validate and named as the file names it.
        (good.replace("data: [ 1150., 0., 5.115", "data: [ 0., 0., 5.115"), "OpenCV YAML", &["proj_K[0][0] (projector.fx)", "positive"]),
        // Malformed JSON, and NaN in JSON.
        (opencv_json(&rig, &DIALECTS[0]).replace("\"rows\": 3,", "\"rows\": 3"), "OpenCV JSON", &["line 5, column 9"]),
        (opencv_json(&rig, &DIALECTS[0]).replace("\"data\": [ 760.", "\"data\": [ .Nan"), "OpenCV JSON", &["cam_K.data[0]", "NaN"]),
        // Bouguet: a missing variable, NaN, skew, a rotation vector of 2.
        (bouguet_text(&rig).replace("fc_right", "fc_r"), "Bouguet text", &["fc_right", "missing"]),
        (bouguet_text(&rig).replace("fc_left = [ 760.0", "fc_left = [ NaN"), "Bouguet text", &["fc_left(1)", "NaN"]),
        (bouguet_text(&rig).replace("alpha_c_left = 0.000000000000000", "alpha_c_left = 0.002"), "Bouguet text", &["alpha_c_left", "skew"]),
        (bouguet_text(&rig).replace("om = [ ", "om = [ 0.1 ; "), "Bouguet text", &["om", "3 values"]),
        // Nothing any tool writes.
        ("hello, calibration\n".to_string(), "unknown", &["(file)", "not a calibration"]),
        ("<?xml version=\"1.0\"?>\n<opencv_storage>\n".to_string(), "unknown", &["XML"]),
        ("fc = [ 1 ; 2 ];\ncc = [ 3 ; 4 ];\n".to_string(), "Bouguet text", &["fc_left", "single-camera"]),
    ];
    for (text, format, needles) in cases {
        let err = one_line_error(&text, &demo_options());
        assert!(err.starts_with(&format!("calibration import ({format}): ")), "{err}");
        for needle in needles {
            assert!(err.contains(needle), "{needle:?} not in: {err}");
        }
    }
}
}

/// The command line: `calib import` writes the project's JSON and says what it read;
/// a bad file is one line on stderr and a non-zero exit; the old form still works.
#[cfg(not(target_arch = "wasm32"))]
#[test]
fn calib_import_on_the_command_line() {
    use std::process::Command;
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_stripelight")).args(args).output().unwrap();
        (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let dir = std::env::temp_dir().join(format!("stripelight-calib-import-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/calib/");
    let (code, err) = run(&[
        "calib", "import", "--from", &format!("{data}moreno-taubin.yml"), "--out", &p("c.json"),
        "--camera-size", "640x480", "--projector-size", "1024x768",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("OpenCV YAML") && err.contains("baseline 200.0 mm"), "{err}");
    let written = Calibration::from_json(&std::fs::read_to_string(p("c.json")).unwrap()).unwrap();
    assert_close(&written, &Calibration::demo_distorted(), 1e-12, "written by the CLI");
    // Metres and a Bouguet file.
    let (code, err) = run(&[
        "calib", "import", "--from", &format!("{data}Calib_Results_stereo.m"), "--out", &p("b.json"),
        "--projector-size", "1024x768",
    ]);
    assert_eq!(code, 0, "{err}");
    // Failures: one line, non-zero, naming the field or the option.
    let fails = |args: &[&str], needle: &str| {
        let (code, err) = run(args);
        assert_ne!(code, 0, "{args:?} succeeded");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: not one line: {err}");
        assert!(err.contains(needle) && !err.contains("panicked"), "{args:?}: {err}");
    };
    let moreno = format!("{data}moreno-taubin.yml");
    fails(&["calib", "import", "--from", &moreno, "--out", &p("x.json"), "--projector-size", "1024x768"], "--camera-size");
    fails(&["calib", "import", "--from", &moreno, "--out", &p("x.json"), "--camera-size", "640"], "camera-size");
    std::fs::write(p("bad.yml"), "%YAML:1.0\ncam_K: [ 1, 2\n").unwrap();
    fails(&["calib", "import", "--from", &p("bad.yml"), "--out", &p("x.json")], "bad.yml: calibration import (OpenCV YAML): line");
    fails(&["calib", "import", "--from", &p("missing.yml"), "--out", &p("x.json")], "missing.yml");
    fails(&["calib", "import", "--out", &p("x.json")], "required");
    assert!(!Path::new(&p("x.json")).exists());
    // The old form keeps its meaning.
    assert_eq!(run(&["calib", "--default", "--out", &p("d.json")]).0, 0);
    fails(&["calib", "--default"], "required");
    let _ = std::fs::remove_dir_all(&dir);
}

#[cfg(not(target_arch = "wasm32"))]
use std::path::Path;
