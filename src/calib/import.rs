//! Calibrations made by other tools, turned into the project's [`Calibration`].
//!
//! The format is recognised from the content, never from the file name:
//! - **OpenCV `cv::FileStorage` YAML**: a `%YAML:1.0` header (or none) and
//!   `!!opencv-matrix` nodes with `rows`, `cols`, `dt`, `data`. Files written one after
//!   the other (`cat intrinsics.yml extrinsics.yml`, as OpenCV's stereo sample writes
//!   them) are read as one.
//! - **OpenCV `cv::FileStorage` JSON**: `{"type_id": "opencv-matrix", "rows": …, "cols": …,
//!   "dt": …, "data": […]}` nodes; the numbers older OpenCV writes (`760.`, `.Nan`) are
//!   accepted.
//! - **Bouguet's Camera Calibration Toolbox for MATLAB**, stereo results as text
//!   (`fc_left = [ … ];`, `cc_left`, `alpha_c_left`, `kc_left`, the same `_right`, `om`,
//!   `T`), as `Calib_Results_stereo` or Moreno and Taubin's projector-camera
//!   calibration write it; `%` comments are ignored.
//!
//! Key names accepted in the OpenCV forms, by dialect (camera matrix, camera distortion,
//! projector matrix, projector distortion): `cam_K cam_kc proj_K proj_kc` (Moreno and
//! Taubin), `cam_int cam_dist proj_int proj_dist`, `cameraMatrix1 distCoeffs1
//! cameraMatrix2 distCoeffs2` (the names of `cv::stereoCalibrate`'s arguments),
//! `camera_matrix1 dist_coeffs1 camera_matrix2 dist_coeffs2`, `M1 D1 M2 D2` (OpenCV's
//! stereo sample), `K1 D1 K2 D2`, `K1 d1 K2 d2`; rotation `R` or `rotation` (3x3, or a
//! Rodrigues vector of 3), or `om` / `rvec` (Rodrigues); translation `T`, `translation`,
//! `t` or `tvec`. Image sizes (width, height): camera `cam_size`, `imageSize`,
//! `image_size`, `imageSize1`, the pairs `cam_width`/`cam_height` and
//! `image_width`/`image_height`, or `cam_shape` as (height, width); projector
//! `proj_size`, `projector_size`, `imageSize2`, `proj_width`/`proj_height`,
//! `projector_width`/`projector_height`, or `proj_shape` as (height, width). Sizes the
//! file lacks come from [`ImportOptions`]. Bouguet's sizes are `nx_left`/`ny_left` (or
//! `nx`/`ny`) for the camera and `nx_right`/`ny_right` for the projector.
//!
//! **Convention.** The camera is the first device (OpenCV's `cameraMatrix1`, Bouguet's
//! left camera), the projector the second (right). R and T map camera coordinates to
//! projector coordinates, `X_p = R X_c + T`, as `cv::stereoCalibrate` returns them and as
//! Bouguet's `om`, `T` do (`X_right = rodrigues(om) X_left + T`); this is the project's
//! `proj_from_cam`, so they are copied, not inverted. T must be in millimetres, or
//! [`ImportOptions::unit_scale`] says how many millimetres one of its units is (1000 for
//! metres). Both tools put the centre of the top-left pixel at (0, 0), as this project
//! does, so principal points carry over unchanged.
//!
//! **Checks.** Every value must be finite; camera matrices must be 3x3 with a last row
//! `0 0 1` and no skew; distortion vectors have OpenCV's 4, 5, 8, 12 or 14 coefficients,
//! of which the project keeps `k1 k2 p1 p2 k3` and refuses non-zero higher terms it
//! cannot represent; the result then passes [`Calibration::validate`] (a rotation that
//! is not one, a focal length that is not positive, a zero baseline). Every error names
//! the field as the file names it.

use super::{Calibration, Intrinsics};
use crate::error::{Error, Result};
use glam::{DMat3, DVec3};
use std::fmt;

/// The formats [`from_text`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// OpenCV `cv::FileStorage` YAML.
    OpenCvYaml,
    /// OpenCV `cv::FileStorage` JSON.
    OpenCvJson,
    /// Bouguet's MATLAB toolbox, stereo results as text.
    Bouguet,
    /// The project's own calibration JSON (`conventions.md`), read as it is.
    Stripelight,
}

impl Format {
    /// The name errors and summaries use.
    pub fn name(self) -> &'static str {
        match self {
            Format::OpenCvYaml => "OpenCV YAML",
            Format::OpenCvJson => "OpenCV JSON",
            Format::Bouguet => "Bouguet text",
            Format::Stripelight => "stripelight JSON",
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a file may not say, given by the user.
#[derive(Clone, Debug, PartialEq)]
pub struct ImportOptions {
    /// Camera image size (width, height), used when the file gives none; when it gives
    /// one, the two must agree.
    pub camera_size: Option<(u32, u32)>,
    /// Projector size (width, height), likewise.
    pub projector_size: Option<(u32, u32)>,
    /// Millimetres per unit of the file's translation: 1 when T is in mm (the default),
    /// 1000 for metres, 25.4 for inches. Only T is scaled (the other values are pixels
    /// or have no unit).
    pub unit_scale: f64,
}

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions { camera_size: None, projector_size: None, unit_scale: 1.0 }
    }
}

/// One field of the calibration and where it came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Source {
    /// The field in the project's calibration, e.g. `camera.fx`, `rotation`.
    pub ours: &'static str,
    /// The file's name for it, e.g. `cam_K[0][0]`, `fc_left(1)`, `om (Rodrigues)`, or
    /// the option it came from, e.g. `--camera-size`.
    pub theirs: String,
}

/// An imported calibration, the format it was read as, and where each field came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Imported {
    /// The calibration, validated.
    pub calibration: Calibration,
    /// The format the file was recognised as.
    pub format: Format,
    /// Where each field of the calibration came from.
    pub sources: Vec<Source>,
}

impl Imported {
    /// One line saying what was read: the format, the file's names, the sizes and the
    /// baseline.
    pub fn summary(&self) -> String {
        let mut names: Vec<&str> = Vec::new();
        for s in &self.sources {
            let base = s.theirs.split(['[', '(']).next().unwrap_or("").trim();
            if !base.is_empty() && !names.contains(&base) {
                names.push(base);
            }
        }
        let c = &self.calibration;
        format!(
            "{}: read {}; camera {}x{}, projector {}x{}, baseline {:.1} mm",
            self.format,
            names.join(", "),
            c.camera.width,
            c.camera.height,
            c.projector.width,
            c.projector.height,
            c.baseline_mm()
        )
    }
}

/// Largest skew accepted as none, as a fraction of fx (OpenCV's `K[0][1] / K[0][0]`,
/// Bouguet's `alpha_c`): 1e-6 moves a pixel 1000 rows from the principal point by
/// 0.001 px, far below what a calibration resolves. The project's model has no skew.
const SKEW_TOLERANCE: f64 = 1e-6;

/// Largest deviation of a camera matrix's fixed entries (`K[1][0]`, `K[2][0]`,
/// `K[2][1]` = 0, `K[2][2]` = 1) accepted, relative to fx for the first three.
const FIXED_ENTRY_TOLERANCE: f64 = 1e-9;

/// OpenCV's distortion coefficients after `k1 k2 p1 p2 k3`, which the project's lens
/// model does not have.
const HIGHER_TERMS: [&str; 9] = ["k4", "k5", "k6", "s1", "s2", "s3", "s4", "tauX", "tauY"];

/// Read a calibration in any of the module's formats. Errors name the field as the file
/// names it.
///
/// ```
/// use stripelight::calib::import::{from_text, Format, ImportOptions};
/// let text = "%YAML:1.0\n---\n\
///     cam_K: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 760., 0., 319.5, 0., 760., 239.5, 0., 0., 1. ]\n\
///     cam_kc: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n\
///     proj_K: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1150., 0., 511.5, 0., 1150., 383.5, 0., 0., 1. ]\n\
///     proj_kc: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n\
///     R: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]\n\
///     T: !!opencv-matrix\n   rows: 3\n   cols: 1\n   dt: d\n   data: [ -200., 0., 0. ]\n";
/// let options = ImportOptions { camera_size: Some((640, 480)), projector_size: Some((1024, 768)), ..Default::default() };
/// let imported = from_text(text, &options).unwrap();
/// assert_eq!(imported.format, Format::OpenCvYaml);
/// assert_eq!(imported.calibration.translation, [-200.0, 0.0, 0.0]);
/// // Without the camera's size the error names what is missing.
/// let err = from_text(text, &ImportOptions { camera_size: None, ..options }).unwrap_err().to_string();
/// assert!(err.contains("cam_size") && err.contains("--camera-size"), "{err}");
/// ```
pub fn from_text(text: &str, options: &ImportOptions) -> Result<Imported> {
    if !options.unit_scale.is_finite() || options.unit_scale <= 0.0 {
        return Err(Error::Setting {
            name: "unit-scale",
            problem: format!("must be a positive number of mm per unit of T, got {}", options.unit_scale),
        });
    }
    let body = text.trim_start_matches('\u{feff}').trim_start();
    if body.starts_with('{') {
        let root = parse_json(body)?;
        if root.iter().any(|(k, _)| k == "units") {
            let calibration = Calibration::from_json(body)?;
            let sources = vec![Source { ours: "(all)", theirs: "every field".into() }];
            return Ok(Imported { calibration, format: Format::Stripelight, sources });
        }
        return opencv(Format::OpenCvJson, &root, options);
    }
    if body.starts_with("<?xml") || body.starts_with("<opencv_storage") {
        return Err(unknown(
            "is OpenCV FileStorage XML, which is not read: save the calibration as YAML or JSON (a file name ending .yml or .json)",
        ));
    }
    if body.starts_with("%YAML") {
        return opencv(Format::OpenCvYaml, &parse_yaml(text)?, options);
    }
    let vars = matlab_vars(text);
    if vars.iter().any(|(name, _)| name == "fc_left") {
        return bouguet(&vars, options);
    }
    if vars.iter().any(|(name, _)| name == "fc") {
        return Err(Error::Import {
            format: Format::Bouguet.name(),
            field: "fc_left".into(),
            problem: "missing: this is a single-camera calibration (fc, cc, kc); a projector-camera import needs \
                      the stereo results (fc_left, cc_left, kc_left, fc_right, cc_right, kc_right, om, T)"
                .into(),
        });
    }
    // A YAML file without OpenCV's header, as people write by hand.
    if let Ok(root) = parse_yaml(text) {
        if FAMILIES.iter().any(|f| find(&root, f.camera_matrix).is_some()) {
            return opencv(Format::OpenCvYaml, &root, options);
        }
    }
    Err(unknown(
        "is not a calibration this program reads: not OpenCV FileStorage YAML (a `%YAML:1.0` header, or a \
         camera matrix such as cam_K or cameraMatrix1) or JSON (`{`), nor Bouguet stereo text (`fc_left = [ ... ];`)",
    ))
}

/// A size `WxH` as the command line gives it, e.g. `1024x768`.
///
/// ```
/// use stripelight::calib::import::parse_size;
/// assert_eq!(parse_size("projector-size", "1024x768").unwrap(), (1024, 768));
/// assert!(parse_size("projector-size", "1024").unwrap_err().to_string().contains("projector-size"));
/// ```
pub fn parse_size(name: &'static str, text: &str) -> Result<(u32, u32)> {
    let bad = || Error::Setting { name, problem: format!("{text:?} is not a size WxH such as 1024x768") };
    let (w, h) = text.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 {
        return Err(bad());
    }
    Ok((w, h))
}

/// The rotation matrix of a Rodrigues vector (axis times angle in radians), as OpenCV's
/// `cv::Rodrigues` and Bouguet's `rodrigues` give it.
///
/// ```
/// use stripelight::calib::import::rotation_from_rodrigues;
/// // A quarter turn about z takes x to y.
/// let r = rotation_from_rodrigues(glam::DVec3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2));
/// assert!((r * glam::DVec3::X - glam::DVec3::Y).length() < 1e-12);
/// ```
pub fn rotation_from_rodrigues(om: DVec3) -> DMat3 {
    let angle = om.length();
    if angle == 0.0 {
        return DMat3::IDENTITY;
    }
    DMat3::from_axis_angle(om / angle, angle)
}

fn unknown(problem: &str) -> Error {
    Error::Import { format: "unknown", field: "(file)".into(), problem: problem.into() }
}

fn error(format: Format, field: impl Into<String>, problem: impl Into<String>) -> Error {
    // One line, whatever a parser's message holds.
    let problem: String = problem.into();
    Error::Import { format: format.name(), field: field.into(), problem: problem.replace(['\n', '\r'], " ") }
}

// ---------------------------------------------------------------------------------------
// OpenCV FileStorage: both dialects are read into one small tree.

/// A FileStorage node, from YAML or JSON.
#[derive(Clone, Debug)]
enum Node {
    Map(Vec<(String, Node)>),
    Seq(Vec<Node>),
    Num(f64),
    Text(String),
    Null,
}

fn parse_yaml(text: &str) -> Result<Vec<(String, Node)>> {
    use yaml_rust2::{Yaml, YamlLoader};
    // OpenCV writes `%YAML:1.0`, which YAML parsers refuse (the directive is `%YAML 1.0`).
    // The line is blanked, not removed, so that error positions stay right.
    let cleaned: String = text
        .trim_start_matches('\u{feff}')
        .lines()
        .map(|line| if line.starts_with("%YAML") { "" } else { line })
        .collect::<Vec<_>>()
        .join("\n");
    let docs = YamlLoader::load_from_str(&cleaned).map_err(|e| {
        let m = e.marker();
        error(Format::OpenCvYaml, format!("line {}, column {}", m.line(), m.col() + 1), e.info())
    })?;
    fn node(y: &Yaml) -> Node {
        match y {
            Yaml::Real(_) | Yaml::Integer(_) => y.as_f64().or(y.as_i64().map(|i| i as f64)).map_or(Node::Null, Node::Num),
            Yaml::String(s) => Node::Text(s.clone()),
            Yaml::Boolean(b) => Node::Text(b.to_string()),
            Yaml::Array(items) => Node::Seq(items.iter().map(node).collect()),
            Yaml::Hash(map) => Node::Map(
                map.iter()
                    .map(|(k, v)| {
                        let key = match k {
                            Yaml::String(s) | Yaml::Real(s) => s.clone(),
                            Yaml::Integer(i) => i.to_string(),
                            _ => String::new(),
                        };
                        (key, node(v))
                    })
                    .collect(),
            ),
            Yaml::Alias(_) | Yaml::Null | Yaml::BadValue => Node::Null,
        }
    }
    // Several documents (files written one after the other) make one set of names.
    let mut root = Vec::new();
    for doc in &docs {
        match node(doc) {
            Node::Map(entries) => root.extend(entries),
            Node::Null => {}
            _ => {
                return Err(error(Format::OpenCvYaml, "(file)", "the top level must map names to matrices"));
            }
        }
    }
    if root.is_empty() {
        return Err(error(Format::OpenCvYaml, "(file)", "holds no names and matrices"));
    }
    Ok(root)
}

fn parse_json(text: &str) -> Result<Vec<(String, Node)>> {
    let value: serde_json::Value = serde_json::from_str(&repair_opencv_json(text)).map_err(|e| {
        let message = e.to_string();
        let message = message.split(" at line ").next().unwrap_or("").to_string();
        error(Format::OpenCvJson, format!("line {}, column {}", e.line(), e.column()), message)
    })?;
    fn node(v: &serde_json::Value) -> Node {
        use serde_json::Value;
        match v {
            Value::Number(n) => n.as_f64().map_or(Node::Null, Node::Num),
            Value::String(s) => Node::Text(s.clone()),
            Value::Bool(b) => Node::Text(b.to_string()),
            Value::Array(items) => Node::Seq(items.iter().map(node).collect()),
            Value::Object(map) => Node::Map(map.iter().map(|(k, v)| (k.clone(), node(v))).collect()),
            Value::Null => Node::Null,
        }
    }
    match node(&value) {
        Node::Map(root) => Ok(root),
        _ => Err(error(Format::OpenCvJson, "(file)", "the top level must be an object of names and matrices")),
    }
}

/// OpenCV before 4.0 writes whole doubles as `760.` and special values as `.Nan`,
/// `.Inf`, `-.Inf` in its JSON too, which JSON parsers refuse: outside strings, a
/// trailing point gets a `0` and the special values become strings (refused later by
/// name, as every non-finite value is).
fn repair_opencv_json(text: &str) -> String {
    const SPECIAL: [&str; 7] = ["-.Inf", "-.inf", ".Inf", ".inf", ".Nan", ".NaN", ".nan"];
    let mut out = String::with_capacity(text.len() + 16);
    let (mut in_string, mut escaped) = (false, false);
    let mut prev = ' ';
    let mut rest = text;
    while let Some(c) = rest.chars().next() {
        let next = rest[c.len_utf8()..].chars().next();
        if in_string {
            out.push(c);
            if escaped {
                escaped = false;
            } else if c == '\\' {
                escaped = true;
            } else if c == '"' {
                in_string = false;
            }
        } else if let Some(s) = SPECIAL.iter().find(|s| rest.starts_with(*s) && !prev.is_ascii_alphanumeric()) {
            out.push('"');
            out.push_str(s);
            out.push('"');
            rest = &rest[s.len()..];
            prev = '"';
            continue;
        } else if c == '.' && prev.is_ascii_digit() && !next.is_some_and(|n| n.is_ascii_digit()) {
            out.push_str(".0");
        } else {
            in_string = c == '"';
            out.push(c);
        }
        prev = c;
        rest = &rest[c.len_utf8()..];
    }
    out
}

/// The names one tool uses for the four per-device matrices.
struct Family {
    camera_matrix: &'static str,
    camera_dist: &'static str,
    projector_matrix: &'static str,
    projector_dist: &'static str,
}

const FAMILIES: &[Family] = &[
    // Moreno and Taubin's projector-camera calibration.
    Family { camera_matrix: "cam_K", camera_dist: "cam_kc", projector_matrix: "proj_K", projector_dist: "proj_kc" },
    // Its JSON export.
    Family { camera_matrix: "cam_int", camera_dist: "cam_dist", projector_matrix: "proj_int", projector_dist: "proj_dist" },
    // cv::stereoCalibrate's argument names.
    Family {
        camera_matrix: "cameraMatrix1",
        camera_dist: "distCoeffs1",
        projector_matrix: "cameraMatrix2",
        projector_dist: "distCoeffs2",
    },
    Family {
        camera_matrix: "camera_matrix1",
        camera_dist: "dist_coeffs1",
        projector_matrix: "camera_matrix2",
        projector_dist: "dist_coeffs2",
    },
    // OpenCV's stereo_calib sample.
    Family { camera_matrix: "M1", camera_dist: "D1", projector_matrix: "M2", projector_dist: "D2" },
    Family { camera_matrix: "K1", camera_dist: "D1", projector_matrix: "K2", projector_dist: "D2" },
    Family { camera_matrix: "K1", camera_dist: "d1", projector_matrix: "K2", projector_dist: "d2" },
];

const ROTATION_MATRIX: &[&str] = &["R", "rotation"];
const ROTATION_VECTOR: &[&str] = &["om", "rvec"];
const TRANSLATION: &[&str] = &["T", "translation", "t", "tvec"];

/// Where one device's image size may be.
struct SizeNames {
    /// (width, height) as a list, an opencv-matrix or a map with `width` and `height`.
    size: &'static [&'static str],
    /// (height, width), as numpy's shape.
    shape: &'static [&'static str],
    /// Separate width and height.
    pairs: &'static [(&'static str, &'static str)],
}

const CAMERA_SIZE: SizeNames = SizeNames {
    size: &["cam_size", "imageSize", "image_size", "imageSize1"],
    shape: &["cam_shape"],
    pairs: &[("cam_width", "cam_height"), ("image_width", "image_height")],
};

const PROJECTOR_SIZE: SizeNames = SizeNames {
    size: &["proj_size", "projector_size", "imageSize2"],
    shape: &["proj_shape"],
    pairs: &[("proj_width", "proj_height"), ("projector_width", "projector_height")],
};

fn find<'a>(entries: &'a [(String, Node)], name: &str) -> Option<&'a Node> {
    // The last one wins, as when FileStorage reads a repeated name.
    entries.iter().rev().find(|(k, _)| k == name).map(|(_, v)| v)
}

fn find_any<'a>(entries: &'a [(String, Node)], names: &[&'static str]) -> Option<(&'static str, &'a Node)> {
    names.iter().find_map(|n| find(entries, n).map(|v| (*n, v)))
}

/// A matrix as read, its values row by row.
struct Matrix {
    rows: usize,
    cols: usize,
    values: Vec<f64>,
}

fn number(format: Format, field: &str, node: &Node) -> Result<f64> {
    let value = match node {
        Node::Num(v) => *v,
        Node::Text(s) => match s.to_ascii_lowercase().as_str() {
            ".nan" | "nan" => f64::NAN,
            ".inf" | "+.inf" | "inf" => f64::INFINITY,
            "-.inf" | "-inf" => f64::NEG_INFINITY,
            _ => return Err(error(format, field, format!("{s:?} is not a number"))),
        },
        _ => return Err(error(format, field, "must be a number")),
    };
    if !value.is_finite() {
        return Err(error(format, field, format!("is {value}; every value must be finite")));
    }
    Ok(value)
}

/// An `opencv-matrix` node, a list of numbers (one row), a list of lists (rows), or a
/// single number.
fn matrix(format: Format, key: &str, node: &Node) -> Result<Matrix> {
    match node {
        Node::Map(entries) => {
            if let Some(Node::Text(kind)) = find(entries, "type_id") {
                if kind != "opencv-matrix" {
                    return Err(error(format, key, format!("is an {kind}, not an opencv-matrix")));
                }
            }
            let Some(data) = find(entries, "data") else {
                return Err(error(format, key, "has no data: an opencv-matrix has rows, cols, dt and data"));
            };
            let dim = |name: &str| -> Result<usize> {
                let field = format!("{key}.{name}");
                let Some(node) = find(entries, name) else {
                    return Err(error(format, &field, "missing: an opencv-matrix has rows, cols, dt and data"));
                };
                let v = number(format, &field, node)?;
                if v < 0.0 || v.fract() != 0.0 || v > 1e6 {
                    return Err(error(format, &field, format!("must be a whole number, got {v}")));
                }
                Ok(v as usize)
            };
            let (rows, cols) = (dim("rows")?, dim("cols")?);
            // dt is an element type such as `d` or `f`, with a channel count before it
            // for multi-channel matrices (`3d`).
            let channels = match find(entries, "dt") {
                Some(Node::Text(dt)) => {
                    let digits: String = dt.chars().take_while(|c| c.is_ascii_digit()).collect();
                    let kind: String = dt.chars().skip(digits.len()).collect();
                    if !["u", "c", "w", "s", "i", "f", "d", "h"].contains(&kind.as_str()) {
                        return Err(error(format, format!("{key}.dt"), format!("{dt:?} is not a numeric element type")));
                    }
                    digits.parse::<usize>().unwrap_or(1).max(1)
                }
                _ => 1,
            };
            let Node::Seq(items) = data else {
                return Err(error(format, format!("{key}.data"), "must be a list of numbers"));
            };
            let values = items
                .iter()
                .enumerate()
                .map(|(i, v)| number(format, &format!("{key}.data[{i}]"), v))
                .collect::<Result<Vec<f64>>>()?;
            if values.len() != rows * cols * channels {
                return Err(error(
                    format,
                    format!("{key}.data"),
                    format!("has {} values but the matrix is {rows}x{cols} of {channels} channel(s)", values.len()),
                ));
            }
            Ok(Matrix { rows, cols: cols * channels, values })
        }
        Node::Seq(items) if !items.is_empty() && items.iter().all(|i| matches!(i, Node::Seq(_))) => {
            let mut values = Vec::new();
            let mut cols = None;
            for (r, row) in items.iter().enumerate() {
                let Node::Seq(row) = row else { continue };
                if *cols.get_or_insert(row.len()) != row.len() {
                    return Err(error(format, format!("{key}[{r}]"), "rows of different lengths"));
                }
                for (c, v) in row.iter().enumerate() {
                    values.push(number(format, &format!("{key}[{r}][{c}]"), v)?);
                }
            }
            Ok(Matrix { rows: items.len(), cols: cols.unwrap_or(0), values })
        }
        Node::Seq(items) => {
            let values =
                items.iter().enumerate().map(|(i, v)| number(format, &format!("{key}[{i}]"), v)).collect::<Result<Vec<f64>>>()?;
            Ok(Matrix { rows: 1, cols: values.len(), values })
        }
        Node::Num(_) | Node::Text(_) => Ok(Matrix { rows: 1, cols: 1, values: vec![number(format, key, node)?] }),
        Node::Null => Err(error(format, key, "is empty")),
    }
}

fn require<'a>(format: Format, entries: &'a [(String, Node)], name: &'static str, what: &str) -> Result<&'a Node> {
    find(entries, name).ok_or_else(|| error(format, name, format!("missing: the file has no {what}")))
}

/// `[fx, fy, cx, cy]` of a camera matrix `[fx s cx; 0 fy cy; 0 0 1]` whose skew `s` is
/// (nearly) 0.
fn camera_matrix(format: Format, key: &str, m: &Matrix) -> Result<[f64; 4]> {
    if (m.rows, m.cols) != (3, 3) {
        return Err(error(format, key, format!("must be a 3x3 camera matrix, got {}x{}", m.rows, m.cols)));
    }
    let k = |r: usize, c: usize| m.values[r * 3 + c];
    let fx = k(0, 0);
    let scale = fx.abs().max(1.0);
    for (r, c) in [(1, 0), (2, 0), (2, 1)] {
        if k(r, c).abs() > FIXED_ENTRY_TOLERANCE * scale {
            return Err(error(format, format!("{key}[{r}][{c}]"), format!("must be 0 in a camera matrix, got {}", k(r, c))));
        }
    }
    if (k(2, 2) - 1.0).abs() > FIXED_ENTRY_TOLERANCE {
        return Err(error(format, format!("{key}[2][2]"), format!("must be 1 in a camera matrix, got {}", k(2, 2))));
    }
    if k(0, 1).abs() > SKEW_TOLERANCE * scale {
        return Err(error(
            format,
            format!("{key}[0][1]"),
            format!("is a skew of {}: the project's camera model has none; calibrate with skew fixed at 0", k(0, 1)),
        ));
    }
    Ok([fx, k(1, 1), k(0, 2), k(1, 2)])
}

/// OpenCV's 4, 5, 8, 12 or 14 coefficients `k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [τx
/// τy]]]]` as the project's five; `name(i)` names coefficient `i` in errors.
fn distortion(format: Format, key: &str, values: &[f64], name: impl Fn(usize) -> String) -> Result<[f64; 5]> {
    if !matches!(values.len(), 0 | 4 | 5 | 8 | 12 | 14) {
        return Err(error(
            format,
            key,
            format!("has {} coefficients; OpenCV's distortion vectors have 4, 5, 8, 12 or 14", values.len()),
        ));
    }
    for (i, &v) in values.iter().enumerate().skip(5) {
        if v != 0.0 {
            return Err(error(
                format,
                name(i),
                format!(
                    "{} = {v}, which the project's lens model (OpenCV's k1 k2 p1 p2 k3) cannot represent; \
                     calibrate without the rational, thin-prism and tilted models",
                    HIGHER_TERMS[i - 5]
                ),
            ));
        }
    }
    let mut dist = [0.0; 5];
    for (d, v) in dist.iter_mut().zip(values) {
        *d = *v;
    }
    Ok(dist)
}

/// A whole positive number of pixels.
fn pixels(format: Format, field: &str, node: &Node) -> Result<u32> {
    let v = number(format, field, node)?;
    if v < 1.0 || v.fract() != 0.0 || v > u32::MAX as f64 {
        return Err(error(format, field, format!("must be a whole positive number of pixels, got {v}")));
    }
    Ok(v as u32)
}

/// One device's image size from the file, with the name it had there.
fn file_size(format: Format, entries: &[(String, Node)], names: &SizeNames) -> Result<Option<((u32, u32), String)>> {
    let pair = |key: &'static str, node: &Node, swap: bool| -> Result<Option<((u32, u32), String)>> {
        if let Node::Map(m) = node {
            if let (Some(w), Some(h)) = (find(m, "width"), find(m, "height")) {
                let size = (pixels(format, &format!("{key}.width"), w)?, pixels(format, &format!("{key}.height"), h)?);
                return Ok(Some((size, key.to_string())));
            }
        }
        let m = matrix(format, key, node)?;
        if m.values.len() != 2 {
            let order = if swap { "height, width" } else { "width, height" };
            return Err(error(format, key, format!("must hold 2 values ({order}), got {}", m.values.len())));
        }
        let a = pixels(format, &format!("{key}[0]"), &Node::Num(m.values[0]))?;
        let b = pixels(format, &format!("{key}[1]"), &Node::Num(m.values[1]))?;
        Ok(Some((if swap { (b, a) } else { (a, b) }, key.to_string())))
    };
    if let Some((key, node)) = find_any(entries, names.size) {
        return pair(key, node, false);
    }
    if let Some((key, node)) = find_any(entries, names.shape) {
        return pair(key, node, true);
    }
    for &(w, h) in names.pairs {
        if let (Some(wn), Some(hn)) = (find(entries, w), find(entries, h)) {
            return Ok(Some(((pixels(format, w, wn)?, pixels(format, h, hn)?), format!("{w}/{h}"))));
        }
    }
    Ok(None)
}

/// The size from the file or the option; both must agree when both are given.
fn device_size(
    format: Format,
    from_file: Option<((u32, u32), String)>,
    option: Option<(u32, u32)>,
    option_name: &'static str,
    device: &str,
    looked_for: &str,
) -> Result<((u32, u32), String)> {
    match (from_file, option) {
        (Some((size, key)), Some(given)) if size != given => Err(error(
            format,
            key,
            format!("says {}x{} but {option_name} says {}x{}", size.0, size.1, given.0, given.1),
        )),
        (Some(found), _) => Ok(found),
        (None, Some(given)) => Ok((given, option_name.to_string())),
        (None, None) => Err(error(
            format,
            looked_for.split(',').next().unwrap_or(looked_for).trim(),
            format!("missing: the file gives no {device} image size (looked for {looked_for}); give it with {option_name} WxH"),
        )),
    }
}

fn size_names_list(names: &SizeNames) -> String {
    let mut all: Vec<String> = names.size.iter().map(|s| s.to_string()).collect();
    all.extend(names.pairs.iter().map(|(w, h)| format!("{w}/{h}")));
    all.extend(names.shape.iter().map(|s| s.to_string()));
    all.join(", ")
}

fn opencv(format: Format, root: &[(String, Node)], options: &ImportOptions) -> Result<Imported> {
    // The dialect is the first whose camera matrix is there, preferring one whose
    // distortion is there too (K1 goes with D1 or d1).
    let has = |name: &str| find(root, name).is_some();
    let family = FAMILIES
        .iter()
        .find(|f| has(f.camera_matrix) && has(f.camera_dist))
        .or_else(|| FAMILIES.iter().find(|f| has(f.camera_matrix)))
        .ok_or_else(|| {
            let mut names: Vec<&str> = FAMILIES.iter().map(|f| f.camera_matrix).collect();
            names.dedup();
            error(format, FAMILIES[0].camera_matrix, format!("missing: the file has no camera matrix (looked for {})", names.join(", ")))
        })?;
    let mut sources = Vec::new();
    let mut device = |matrix_key: &'static str,
                      dist_key: &'static str,
                      what: &str,
                      size: ((u32, u32), String),
                      prefix: &'static [&'static str; 7]|
     -> Result<Intrinsics> {
        let k = matrix(format, matrix_key, require(format, root, matrix_key, &format!("{what} matrix"))?)?;
        let [fx, fy, cx, cy] = camera_matrix(format, matrix_key, &k)?;
        let d = matrix(format, dist_key, require(format, root, dist_key, &format!("{what} distortion"))?)?;
        let data_name = |i: usize| match find(root, dist_key) {
            Some(Node::Map(_)) => format!("{dist_key}.data[{i}]"),
            _ => format!("{dist_key}[{i}]"),
        };
        let dist = distortion(format, dist_key, &d.values, data_name)?;
        for (ours, theirs) in prefix.iter().zip([
            format!("{matrix_key}[0][0]"),
            format!("{matrix_key}[1][1]"),
            format!("{matrix_key}[0][2]"),
            format!("{matrix_key}[1][2]"),
            dist_key.to_string(),
            size.1.clone(),
            size.1.clone(),
        ]) {
            sources.push(Source { ours, theirs });
        }
        Ok(Intrinsics { width: size.0 .0, height: size.0 .1, fx, fy, cx, cy, dist })
    };
    let camera_size = device_size(
        format,
        file_size(format, root, &CAMERA_SIZE)?,
        options.camera_size,
        "--camera-size",
        "camera",
        &size_names_list(&CAMERA_SIZE),
    )?;
    let projector_size = device_size(
        format,
        file_size(format, root, &PROJECTOR_SIZE)?,
        options.projector_size,
        "--projector-size",
        "projector",
        &size_names_list(&PROJECTOR_SIZE),
    )?;
    let camera = device(family.camera_matrix, family.camera_dist, "camera", camera_size, &CAMERA_FIELDS)?;
    let projector =
        device(family.projector_matrix, family.projector_dist, "projector", projector_size, &PROJECTOR_FIELDS)?;

    let (rotation, rotation_source) = if let Some((key, node)) = find_any(root, ROTATION_MATRIX) {
        let m = matrix(format, key, node)?;
        match m.values.len() {
            // Row by row, whatever the shape it was written in.
            9 => (DMat3::from_cols_slice(&m.values).transpose(), key.to_string()),
            3 => (rotation_from_rodrigues(DVec3::from_slice(&m.values)), format!("{key} (Rodrigues)")),
            _ => {
                return Err(error(
                    format,
                    key,
                    format!("must be a 3x3 rotation or a Rodrigues vector of 3, got {}x{}", m.rows, m.cols),
                ))
            }
        }
    } else if let Some((key, node)) = find_any(root, ROTATION_VECTOR) {
        let m = matrix(format, key, node)?;
        if m.values.len() != 3 {
            return Err(error(format, key, format!("must be a Rodrigues vector of 3, got {}x{}", m.rows, m.cols)));
        }
        (rotation_from_rodrigues(DVec3::from_slice(&m.values)), format!("{key} (Rodrigues)"))
    } else {
        return Err(error(
            format,
            ROTATION_MATRIX[0],
            "missing: the file has no rotation from camera to projector (looked for R, rotation, om, rvec)",
        ));
    };
    let Some((t_key, t_node)) = find_any(root, TRANSLATION) else {
        return Err(error(
            format,
            TRANSLATION[0],
            "missing: the file has no translation from camera to projector (looked for T, translation, t, tvec)",
        ));
    };
    let t = matrix(format, t_key, t_node)?;
    if t.values.len() != 3 {
        return Err(error(format, t_key, format!("must be a vector of 3, got {}x{}", t.rows, t.cols)));
    }
    let translation = DVec3::from_slice(&t.values) * options.unit_scale;
    sources.push(Source { ours: "rotation", theirs: rotation_source });
    sources.push(Source { ours: "translation", theirs: scaled(t_key, options.unit_scale) });
    finish(format, camera, projector, rotation, translation, sources)
}

const CAMERA_FIELDS: [&str; 7] =
    ["camera.fx", "camera.fy", "camera.cx", "camera.cy", "camera.dist", "camera.width", "camera.height"];
const PROJECTOR_FIELDS: [&str; 7] = [
    "projector.fx",
    "projector.fy",
    "projector.cx",
    "projector.cy",
    "projector.dist",
    "projector.width",
    "projector.height",
];

fn scaled(key: &str, unit_scale: f64) -> String {
    if unit_scale == 1.0 {
        key.to_string()
    } else {
        format!("{key} (x {unit_scale} mm per unit)")
    }
}

/// The calibration, checked by [`Calibration::validate`] with errors renamed to the
/// file's fields.
fn finish(
    format: Format,
    camera: Intrinsics,
    projector: Intrinsics,
    rotation: DMat3,
    translation: DVec3,
    sources: Vec<Source>,
) -> Result<Imported> {
    let calibration = Calibration {
        units: "mm".into(),
        camera,
        projector,
        // glam is column-major; the file is row-major.
        rotation: rotation.transpose().to_cols_array(),
        translation: translation.to_array(),
    };
    if let Err(e) = calibration.validate() {
        return Err(match e {
            Error::Calib { field, problem } => {
                // `camera.dist[2]` is found under `camera.dist`, `rotation` under itself.
                let theirs = sources
                    .iter()
                    .filter(|s| field.starts_with(s.ours))
                    .max_by_key(|s| s.ours.len())
                    .map_or_else(|| field.clone(), |s| format!("{} ({field})", s.theirs));
                error(format, theirs, problem)
            }
            other => other,
        });
    }
    Ok(Imported { calibration, format, sources })
}

// ---------------------------------------------------------------------------------------
// Bouguet's toolbox: MATLAB assignments `name = [ ... ];` or `name = value;`.

/// A numeric MATLAB value: its rows, and its values row by row (or why it is not one).
#[derive(Clone, Debug)]
struct MatlabValue {
    rows: usize,
    values: std::result::Result<Vec<f64>, String>,
}

/// Every `name = value` in the text, `%` comments and `...` continuations removed. A
/// value is a bracketed matrix (rows split by `;` or line ends, values by spaces or
/// commas) or a single number; anything else (strings, expressions) is kept as not a
/// number. Text after a value (`± [ ... ]` in the toolbox's printed results) is skipped.
fn matlab_vars(text: &str) -> Vec<(String, MatlabValue)> {
    let cleaned: String = text
        .lines()
        .map(|line| {
            let line = line.split('%').next().unwrap_or("");
            match line.find("...") {
                Some(i) => format!("{} ", &line[..i]),
                None => format!("{line}\n"),
            }
        })
        .collect();
    let chars: Vec<char> = cleaned.chars().collect();
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut vars = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let starts_name = (chars[i].is_ascii_alphabetic() || chars[i] == '_') && (i == 0 || !(ident(chars[i - 1]) || chars[i - 1] == '.'));
        if !starts_name {
            i += 1;
            continue;
        }
        let start = i;
        while i < chars.len() && ident(chars[i]) {
            i += 1;
        }
        let name: String = chars[start..i].iter().collect();
        let mut j = i;
        while j < chars.len() && (chars[j] == ' ' || chars[j] == '\t') {
            j += 1;
        }
        if chars.get(j) != Some(&'=') || chars.get(j + 1) == Some(&'=') {
            continue;
        }
        j += 1;
        while j < chars.len() && (chars[j] == ' ' || chars[j] == '\t') {
            j += 1;
        }
        if chars.get(j) == Some(&'[') {
            let close = chars[j..].iter().position(|&c| c == ']').map(|p| j + p);
            let end = close.unwrap_or(chars.len());
            let inner: String = chars[j + 1..end].iter().collect();
            let value = match close {
                Some(_) => matlab_matrix(&inner),
                None => MatlabValue { rows: 0, values: Err("has no closing ]".into()) },
            };
            vars.push((name, value));
            i = (end + 1).min(chars.len());
        } else {
            let end = chars[j..].iter().position(|&c| c == ';' || c == '\n' || c == ',').map_or(chars.len(), |p| j + p);
            let token: String = chars[j..end].iter().collect();
            let token = token.trim();
            let values = token.parse::<f64>().map(|v| vec![v]).map_err(|_| format!("{token:?} is not a number"));
            vars.push((name, MatlabValue { rows: 1, values }));
            i = end;
        }
    }
    vars
}

fn matlab_matrix(inner: &str) -> MatlabValue {
    let mut rows = 0;
    let mut values = Vec::new();
    for row in inner.split([';', '\n']) {
        let items: Vec<&str> = row.split(|c: char| c == ',' || c.is_whitespace()).filter(|s| !s.is_empty()).collect();
        if items.is_empty() {
            continue;
        }
        rows += 1;
        for item in items {
            match item.parse::<f64>() {
                Ok(v) => values.push(v),
                Err(_) => return MatlabValue { rows, values: Err(format!("{item:?} is not a number")) },
            }
        }
    }
    MatlabValue { rows, values: Ok(values) }
}

fn bouguet(vars: &[(String, MatlabValue)], options: &ImportOptions) -> Result<Imported> {
    let format = Format::Bouguet;
    // MATLAB runs the file top to bottom: the last assignment wins.
    let get = |name: &str| vars.iter().rev().find(|(n, _)| n == name).map(|(_, v)| v);
    let read = |name: &str, counts: &[usize]| -> Result<Option<Vec<f64>>> {
        let Some(v) = get(name) else { return Ok(None) };
        let values = v.values.clone().map_err(|problem| error(format, name, problem))?;
        if !counts.contains(&values.len()) {
            let want: Vec<String> = counts.iter().map(|c| c.to_string()).collect();
            return Err(error(format, name, format!("must hold {} values, got {}", want.join(" or "), values.len())));
        }
        // MATLAB counts from 1.
        if let Some(k) = values.iter().position(|x| !x.is_finite()) {
            return Err(error(format, format!("{name}({})", k + 1), format!("is {}; every value must be finite", values[k])));
        }
        Ok(Some(values))
    };
    let need = |name: &str, counts: &[usize]| -> Result<Vec<f64>> {
        read(name, counts)?.ok_or_else(|| error(format, name, "missing: the file does not assign it"))
    };
    let mut sources = Vec::new();
    let mut device = |side: &str, fields: &'static [&'static str; 7], size: ((u32, u32), String)| -> Result<Intrinsics> {
        let (fc_name, cc_name, kc_name, alpha_name) =
            (format!("fc_{side}"), format!("cc_{side}"), format!("kc_{side}"), format!("alpha_c_{side}"));
        let fc = need(&fc_name, &[2])?;
        let cc = need(&cc_name, &[2])?;
        let kc = need(&kc_name, &[4, 5])?;
        let alpha = read(&alpha_name, &[1])?.map_or(0.0, |a| a[0]);
        if alpha.abs() > SKEW_TOLERANCE {
            return Err(error(
                format,
                alpha_name,
                format!("is a skew of {alpha}: the project's camera model has none; calibrate with est_alpha = 0"),
            ));
        }
        let dist = distortion(format, &kc_name, &kc, |i| format!("{kc_name}({})", i + 1))?;
        for (ours, theirs) in fields.iter().zip([
            format!("{fc_name}(1)"),
            format!("{fc_name}(2)"),
            format!("{cc_name}(1)"),
            format!("{cc_name}(2)"),
            kc_name.clone(),
            size.1.clone(),
            size.1.clone(),
        ]) {
            sources.push(Source { ours, theirs });
        }
        Ok(Intrinsics { width: size.0 .0, height: size.0 .1, fx: fc[0], fy: fc[1], cx: cc[0], cy: cc[1], dist })
    };
    let size_of = |nx: &str, ny: &str| -> Result<Option<((u32, u32), String)>> {
        match (read(nx, &[1])?, read(ny, &[1])?) {
            (Some(w), Some(h)) => {
                Ok(Some(((pixels(format, nx, &Node::Num(w[0]))?, pixels(format, ny, &Node::Num(h[0]))?), format!("{nx}/{ny}"))))
            }
            _ => Ok(None),
        }
    };
    let camera_file = match size_of("nx_left", "ny_left")? {
        Some(s) => Some(s),
        None => size_of("nx", "ny")?,
    };
    let camera_size =
        device_size(format, camera_file, options.camera_size, "--camera-size", "camera", "nx_left/ny_left, nx/ny")?;
    let projector_size = device_size(
        format,
        size_of("nx_right", "ny_right")?,
        options.projector_size,
        "--projector-size",
        "projector",
        "nx_right/ny_right",
    )?;
    let camera = device("left", &CAMERA_FIELDS, camera_size)?;
    let projector = device("right", &PROJECTOR_FIELDS, projector_size)?;
    let (rotation, rotation_source) = match read("om", &[3])? {
        Some(om) => (rotation_from_rodrigues(DVec3::from_slice(&om)), "om (Rodrigues)".to_string()),
        None => match read("R", &[9])? {
            // MATLAB's [a b c; d e f; g h i] is row by row.
            Some(r) if get("R").is_some_and(|v| v.rows == 3) => {
                (DMat3::from_cols_slice(&r).transpose(), "R".to_string())
            }
            Some(_) => return Err(error(format, "R", "must be a 3x3 matrix written row by row")),
            None => return Err(error(format, "om", "missing: the file assigns neither om nor R")),
        },
    };
    let t = need("T", &[3])?;
    let translation = DVec3::from_slice(&t) * options.unit_scale;
    sources.push(Source { ours: "rotation", theirs: rotation_source });
    sources.push(Source { ours: "translation", theirs: scaled("T", options.unit_scale) });
    finish(format, camera, projector, rotation, translation, sources)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opencv_json_from_before_4_0_is_repaired() {
        let text = r#"{"a": [760., 0., 1.5e+02, -3., ".Nan"], "s": "1. .Nan", "b": .Nan, "c": -.Inf}"#;
        let fixed = repair_opencv_json(text);
        assert_eq!(fixed, r#"{"a": [760.0, 0.0, 1.5e+02, -3.0, ".Nan"], "s": "1. .Nan", "b": ".Nan", "c": "-.Inf"}"#);
    }

    #[test]
    fn matlab_assignments_are_read_with_their_shapes() {
        let vars = matlab_vars(
            "% comment fc_left = [ 9 9 ];\nfc_left = [ 1000.5 ; 1001 ]; % Focal\nalpha_c_left = 0.000000000000000;\n\
             R = [ 1 0 0; 0 1 0;\n 0 0 1 ];\nname = 'bmp';\nT = [ 1, 2, ...\n 3 ];\nFocal Length: fc_right = [ 7 8 ] ± [ 0.1 0.2 ]\n",
        );
        let get = |n: &str| vars.iter().rev().find(|(k, _)| k == n).map(|(_, v)| v.clone()).unwrap();
        assert_eq!(get("fc_left").values.unwrap(), vec![1000.5, 1001.0]);
        assert_eq!(get("alpha_c_left").values.unwrap(), vec![0.0]);
        assert_eq!(get("R").rows, 3);
        assert_eq!(get("T").values.unwrap(), vec![1.0, 2.0, 3.0]);
        assert_eq!(get("fc_right").values.unwrap(), vec![7.0, 8.0]);
        assert!(get("name").values.is_err());
        assert_eq!(vars.iter().filter(|(k, _)| k == "fc_left").count(), 1);
    }

    #[test]
    fn sizes_parse_and_refuse() {
        assert_eq!(parse_size("camera-size", " 640 x 480 ").unwrap(), (640, 480));
        for bad in ["640", "0x480", "axb", "640x-1", ""] {
            assert!(parse_size("camera-size", bad).is_err(), "{bad}");
        }
    }
}
