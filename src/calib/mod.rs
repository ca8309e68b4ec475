//! Projector-camera calibration: the JSON file of `conventions.md`, its validation,
//! the default demo rig, and the rays and light planes that triangulation needs.
//!
//! Conventions (OpenCV): pixel (u, v) with the top-left pixel centre at (0, 0);
//! normalized coordinates x = (u - cx) / fx; camera frame x right, y down, z forward;
//! a point `X_c` in camera coordinates is `X_p = R X_c + t` in projector coordinates
//! (`proj_from_cam`). Lengths are millimetres. Distortion is OpenCV's
//! `[k1, k2, p1, p2, k3]`, applied to normalized coordinates.
//!
//! [`import`] reads calibrations made by other tools (OpenCV, Bouguet's toolbox).

pub mod frame_mixing;
pub mod import;
pub mod response;

pub use frame_mixing::{estimate_crosstalk_from_stripes, FrameMixing};
pub use response::{estimate_response, CameraResponse};

use crate::error::{Error, Result};
use glam::{DMat3, DVec2, DVec3};
use serde::{Deserialize, Serialize};

/// Intrinsics of one device (camera, or projector seen as an inverse camera).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Intrinsics {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length along u, pixels.
    pub fx: f64,
    /// Focal length along v, pixels.
    pub fy: f64,
    /// Principal point u, pixels.
    pub cx: f64,
    /// Principal point v, pixels.
    pub cy: f64,
    /// OpenCV distortion `[k1, k2, p1, p2, k3]`; zeros when omitted.
    #[serde(default)]
    pub dist: [f64; 5],
}

/// An approximate rig described the way a person measures one with a tape and the
/// devices' data sheets, for [`Calibration::from_approx_rig`]. Square pixels, the
/// principal point at the image centre, no lens distortion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ApproxRig {
    /// Camera image width, pixels.
    pub camera_width: u32,
    /// Camera image height, pixels.
    pub camera_height: u32,
    /// Camera horizontal field of view, degrees (edge to edge of the image).
    pub camera_hfov_deg: f64,
    /// Projector width, pixels.
    pub projector_width: u32,
    /// Projector height, pixels.
    pub projector_height: u32,
    /// Projector horizontal field of view, degrees (a throw ratio r gives
    /// `2·atan(1 / (2r))`).
    pub projector_hfov_deg: f64,
    /// The projector's centre of projection in camera coordinates (x right, y down,
    /// z forward), mm.
    pub baseline_mm: [f64; 3],
    /// Distance along the camera's optical axis of the point both devices aim at, mm.
    pub aim_distance_mm: f64,
}

/// A calibrated projector-camera pair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// Always `"mm"`.
    pub units: String,
    /// The camera.
    pub camera: Intrinsics,
    /// The projector.
    pub projector: Intrinsics,
    /// R of `X_p = R X_c + t`, row-major.
    pub rotation: [f64; 9],
    /// t of `X_p = R X_c + t`, mm.
    pub translation: [f64; 3],
}

/// Largest deviation of `R Rᵀ` from identity accepted as orthonormal. Calibration
/// tools print 6 to 8 significant digits, which keeps real files far below this.
const ORTHONORMAL_TOLERANCE: f64 = 1e-4;

/// Iterations of the fixed-point undistortion; OpenCV's default is 5, more costs
/// little and brings strong distortion below 1e-9 in normalized units.
const UNDISTORT_ITERATIONS: usize = 20;

impl Intrinsics {
    /// Normalized coordinates of a pixel, lens distortion undone.
    pub fn undistort(&self, u: f64, v: f64) -> DVec2 {
        let xd = DVec2::new((u - self.cx) / self.fx, (v - self.cy) / self.fy);
        if self.dist == [0.0; 5] {
            return xd;
        }
        let mut x = xd;
        for _ in 0..UNDISTORT_ITERATIONS {
            let [k1, k2, p1, p2, k3] = self.dist;
            let r2 = x.length_squared();
            let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
            let dx = 2.0 * p1 * x.x * x.y + p2 * (r2 + 2.0 * x.x * x.x);
            let dy = p1 * (r2 + 2.0 * x.y * x.y) + 2.0 * p2 * x.x * x.y;
            x = DVec2::new((xd.x - dx) / radial, (xd.y - dy) / radial);
        }
        x
    }

    /// Distorted normalized coordinates of undistorted ones (OpenCV's forward model).
    pub fn distort(&self, x: DVec2) -> DVec2 {
        let [k1, k2, p1, p2, k3] = self.dist;
        let r2 = x.length_squared();
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        DVec2::new(
            x.x * radial + 2.0 * p1 * x.x * x.y + p2 * (r2 + 2.0 * x.x * x.x),
            x.y * radial + p1 * (r2 + 2.0 * x.y * x.y) + 2.0 * p2 * x.x * x.y,
        )
    }

    /// Pixel of a point in this device's frame; `None` behind the device.
    pub fn project(&self, p: DVec3) -> Option<DVec2> {
        if p.z <= 0.0 {
            return None;
        }
        let xd = self.distort(DVec2::new(p.x / p.z, p.y / p.z));
        Some(DVec2::new(self.fx * xd.x + self.cx, self.fy * xd.y + self.cy))
    }

    /// Direction (z = 1) of the ray through pixel (u, v), in this device's frame.
    pub fn ray(&self, u: f64, v: f64) -> DVec3 {
        self.undistort(u, v).extend(1.0)
    }

    fn validate(&self, name: &str) -> Result<()> {
        let err = |field: &str, problem: String| Error::Calib {
            field: format!("{name}.{field}"),
            problem,
        };
        if self.width == 0 || self.height == 0 {
            return Err(err("width", format!("size {}x{} is empty", self.width, self.height)));
        }
        for (field, value) in [("fx", self.fx), ("fy", self.fy)] {
            if !value.is_finite() || value <= 0.0 {
                return Err(err(field, format!("must be a positive focal length, got {value}")));
            }
        }
        for (field, value) in [("cx", self.cx), ("cy", self.cy)] {
            if !value.is_finite() {
                return Err(err(field, format!("must be finite, got {value}")));
            }
        }
        if let Some(k) = self.dist.iter().position(|d| !d.is_finite()) {
            return Err(err(&format!("dist[{k}]"), "must be finite".into()));
        }
        Ok(())
    }
}

impl Calibration {
    /// Parse and validate a calibration JSON. Errors name the offending field.
    pub fn from_json(text: &str) -> Result<Self> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let calib: Calibration = serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            Error::Calib {
                field: if path == "." { "(file)".into() } else { path },
                problem: e.into_inner().to_string(),
            }
        })?;
        calib.validate()?;
        Ok(calib)
    }

    /// Serialize as pretty JSON in the schema of `conventions.md`.
    pub fn to_json(&self) -> String {
        // Serializing plain numbers and strings cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Check every field for finite, possible values.
    pub fn validate(&self) -> Result<()> {
        if self.units != "mm" {
            return Err(Error::Calib {
                field: "units".into(),
                problem: format!("must be \"mm\", got {:?}", self.units),
            });
        }
        self.camera.validate("camera")?;
        self.projector.validate("projector")?;
        if let Some(k) = self.rotation.iter().position(|r| !r.is_finite()) {
            return Err(Error::Calib {
                field: format!("rotation[{k}]"),
                problem: "must be finite".into(),
            });
        }
        let r = self.proj_from_cam_rotation();
        let dev = (r * r.transpose() - DMat3::IDENTITY).to_cols_array().iter().fold(0f64, |m, x| m.max(x.abs()));
        if dev > ORTHONORMAL_TOLERANCE || (r.determinant() - 1.0).abs() > ORTHONORMAL_TOLERANCE {
            return Err(Error::Calib {
                field: "rotation".into(),
                problem: format!(
                    "is not a rotation (R Rᵀ deviates from I by {dev:.2e}, det R = {:.6})",
                    r.determinant()
                ),
            });
        }
        if let Some(k) = self.translation.iter().position(|r| !r.is_finite()) {
            return Err(Error::Calib {
                field: format!("translation[{k}]"),
                problem: "must be finite".into(),
            });
        }
        if self.baseline_mm() < 1e-6 {
            return Err(Error::Calib {
                field: "translation".into(),
                problem: "is zero: without a baseline nothing can be triangulated".into(),
            });
        }
        Ok(())
    }

    /// R of `X_p = R X_c + t`.
    pub fn proj_from_cam_rotation(&self) -> DMat3 {
        // glam is column-major; the file is row-major.
        DMat3::from_cols_array(&self.rotation).transpose()
    }

    /// t of `X_p = R X_c + t`, mm.
    pub fn proj_from_cam_translation(&self) -> DVec3 {
        DVec3::from_array(self.translation)
    }

    /// A camera-frame point in projector coordinates.
    pub fn cam_to_proj(&self, p_cam: DVec3) -> DVec3 {
        self.proj_from_cam_rotation() * p_cam + self.proj_from_cam_translation()
    }

    /// A projector-frame point in camera coordinates.
    pub fn proj_to_cam(&self, p_proj: DVec3) -> DVec3 {
        self.proj_from_cam_rotation().transpose() * (p_proj - self.proj_from_cam_translation())
    }

    /// The projector's centre of projection in camera coordinates, mm.
    pub fn projector_center_cam(&self) -> DVec3 {
        self.proj_to_cam(DVec3::ZERO)
    }

    /// Distance between the two centres of projection, mm.
    pub fn baseline_mm(&self) -> f64 {
        self.proj_from_cam_translation().length()
    }

    /// The default demo rig: a VGA camera and an XGA projector whose centre sits
    /// 200 mm from the camera's along the image diagonal (right and down, so vertical,
    /// horizontal and 60-degree stripe families all triangulate), both aimed at a
    /// point 750 mm in front of the camera. No lens distortion.
    pub fn demo() -> Self {
        let camera = Intrinsics {
            width: 640,
            height: 480,
            fx: 760.0,
            fy: 760.0,
            cx: 319.5,
            cy: 239.5,
            dist: [0.0; 5],
        };
        let projector = Intrinsics {
            width: 1024,
            height: 768,
            fx: 1150.0,
            fy: 1150.0,
            cx: 511.5,
            cy: 383.5,
            dist: [0.0; 5],
        };
        let half = 200.0 / std::f64::consts::SQRT_2;
        Self::aimed(camera, projector, DVec3::new(half, half, 0.0), DVec3::new(0.0, 0.0, 750.0))
    }

    /// A usable calibration from an approximate rig: focal lengths from the fields of
    /// view (`f = (w / 2) / tan(hfov / 2)`, square pixels), principal points at the
    /// image centres, the projector at `baseline_mm` and aimed at the point
    /// `aim_distance_mm` along the camera's axis (see [`Calibration::aimed`]).
    /// Errors name the offending field of [`ApproxRig`].
    ///
    /// ```
    /// use stripelight::calib::{ApproxRig, Calibration};
    /// let rig = ApproxRig {
    ///     camera_width: 640, camera_height: 480, camera_hfov_deg: 60.0,
    ///     projector_width: 1024, projector_height: 768, projector_hfov_deg: 40.0,
    ///     baseline_mm: [150.0, 0.0, 0.0], aim_distance_mm: 800.0,
    /// };
    /// let calib = Calibration::from_approx_rig(&rig).unwrap();
    /// assert!((calib.baseline_mm() - 150.0).abs() < 1e-9);
    /// ```
    pub fn from_approx_rig(rig: &ApproxRig) -> Result<Self> {
        let err = |field: &str, problem: String| Error::Calib { field: field.into(), problem };
        let device = |prefix: &str, width: u32, height: u32, hfov_deg: f64| -> Result<Intrinsics> {
            if width == 0 || height == 0 {
                return Err(err(&format!("{prefix}_width"), format!("size {width}x{height} is empty")));
            }
            // Below 1 degree or near 180 degrees the pinhole model says nothing useful.
            if !(1.0..=170.0).contains(&hfov_deg) {
                return Err(err(
                    &format!("{prefix}_hfov_deg"),
                    format!("must be between 1 and 170 degrees, got {hfov_deg}"),
                ));
            }
            let f = (width as f64 / 2.0) / (hfov_deg.to_radians() / 2.0).tan();
            Ok(Intrinsics {
                width,
                height,
                fx: f,
                fy: f,
                cx: (width as f64 - 1.0) / 2.0,
                cy: (height as f64 - 1.0) / 2.0,
                dist: [0.0; 5],
            })
        };
        let camera = device("camera", rig.camera_width, rig.camera_height, rig.camera_hfov_deg)?;
        let projector = device("projector", rig.projector_width, rig.projector_height, rig.projector_hfov_deg)?;
        let center = DVec3::from_array(rig.baseline_mm);
        // Past a kilometre it is a typing error (and the squares of such lengths overflow).
        if !center.is_finite() || !(1.0..=1e6).contains(&center.length()) {
            return Err(err("baseline_mm", format!("must be a finite vector of 1 mm to 1 km, got {:?}", rig.baseline_mm)));
        }
        if !rig.aim_distance_mm.is_finite() || rig.aim_distance_mm <= 0.0 {
            return Err(err("aim_distance_mm", format!("must be a positive distance, got {}", rig.aim_distance_mm)));
        }
        let target = DVec3::new(0.0, 0.0, rig.aim_distance_mm);
        if (target - center).length() < 1.0 {
            return Err(err("aim_distance_mm", "puts the aim point at the projector itself".into()));
        }
        // `aimed` takes the projector's x axis as close to the camera's as the aim
        // allows: aiming along the camera's x axis leaves it undefined (NaN).
        if (target - center).normalize().cross(DVec3::X).length() < 1e-6 {
            return Err(err(
                "aim_distance_mm",
                format!("with baseline_mm {center} aims the projector along the camera's x axis, which leaves its orientation undefined"),
            ));
        }
        let calib = Self::aimed(camera, projector, center, target);
        calib.validate()?;
        Ok(calib)
    }

    /// The demo rig with moderate lens distortion on both devices, for tests that the
    /// distortion model is applied everywhere.
    pub fn demo_distorted() -> Self {
        let mut c = Self::demo();
        c.camera.dist = [-0.12, 0.05, 0.001, -0.0008, 0.0];
        c.projector.dist = [0.06, -0.02, -0.0005, 0.0004, 0.0];
        c
    }

    /// A rig with the projector's centre at `projector_center` (camera frame, mm),
    /// its optical axis through `target` and its x axis as close to the camera's as
    /// the aim allows.
    pub fn aimed(camera: Intrinsics, projector: Intrinsics, projector_center: DVec3, target: DVec3) -> Self {
        let z = (target - projector_center).normalize();
        let x = (DVec3::X - z * z.dot(DVec3::X)).normalize();
        let y = z.cross(x);
        // Rows of R are the projector's axes in camera coordinates.
        let r = DMat3::from_cols(x, y, z).transpose();
        let t = -(r * projector_center);
        Calibration {
            units: "mm".into(),
            camera,
            projector,
            rotation: r.transpose().to_cols_array(),
            translation: t.to_array(),
        }
    }

    /// Depth along the camera ray of pixel (u, v) where it meets the projector's
    /// light surface `coord(projector pixel) = target`, for a `coord` that is an affine
    /// function `a·u_p + b·v_p + c` of the projector pixel (a stripe family's
    /// coordinate). Lens distortion of both devices is honoured: the first guess is the
    /// exact answer for the undistorted projector and Newton steps on the true
    /// projection refine it. `None` when the ray is (nearly) parallel to the surface or
    /// meets it behind either device.
    pub fn depth_on_stripe(&self, u: f64, v: f64, a: f64, b: f64, c: f64, target: f64) -> Option<f64> {
        let ray = self.camera.ray(u, v);
        let p = &self.projector;
        // Undistorted light plane through the projector centre: in normalized
        // projector coordinates a(fx x + cx) + b(fy y + cy) + c = target.
        let n_proj = DVec3::new(a * p.fx, b * p.fy, a * p.cx + b * p.cy + c - target);
        let r = self.proj_from_cam_rotation();
        let t = self.proj_from_cam_translation();
        let denom = (r.transpose() * n_proj).dot(ray);
        if denom.abs() < 1e-12 * n_proj.length() {
            return None;
        }
        let mut z = -n_proj.dot(t) / denom;
        if p.dist != [0.0; 5] {
            let f = |z: f64| -> Option<f64> {
                let px = p.project(r * (ray * z) + t)?;
                Some(a * px.x + b * px.y + c - target)
            };
            for _ in 0..8 {
                let h = 1e-3 * z.abs().max(1.0);
                let f0 = f(z)?;
                let slope = (f(z + h)? - f0) / h;
                if slope.abs() < 1e-12 {
                    return None;
                }
                let step = f0 / slope;
                z -= step;
                if step.abs() < 1e-9 {
                    break;
                }
            }
        }
        let in_front = z > 0.0 && (r * (ray * z) + t).z > 0.0;
        (in_front && z.is_finite()).then_some(z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn demo_rig_round_trips_and_is_valid() {
        let c = Calibration::demo();
        c.validate().unwrap();
        let back = Calibration::from_json(&c.to_json()).unwrap();
        assert_eq!(back, c);
        assert!((c.baseline_mm() - 200.0).abs() < 1e-9);
        // The projector's optical axis passes through the target point.
        let target_p = c.cam_to_proj(DVec3::new(0.0, 0.0, 750.0));
        assert!(target_p.x.abs() < 1e-9 && target_p.y.abs() < 1e-9);
    }

    #[test]
    fn approx_rig_reproduces_the_demo_rig() {
        let demo = Calibration::demo();
        let hfov = |i: &Intrinsics| 2.0 * (i.width as f64 / 2.0 / i.fx).atan().to_degrees();
        let half = 200.0 / std::f64::consts::SQRT_2;
        let rig = ApproxRig {
            camera_width: 640,
            camera_height: 480,
            camera_hfov_deg: hfov(&demo.camera),
            projector_width: 1024,
            projector_height: 768,
            projector_hfov_deg: hfov(&demo.projector),
            baseline_mm: [half, half, 0.0],
            aim_distance_mm: 750.0,
        };
        let c = Calibration::from_approx_rig(&rig).unwrap();
        assert!((c.camera.fx - 760.0).abs() < 1e-9 && (c.projector.fy - 1150.0).abs() < 1e-9);
        assert_eq!((c.camera.cx, c.projector.cy), (319.5, 383.5));
        for (a, b) in c.rotation.iter().chain(&c.translation).zip(demo.rotation.iter().chain(&demo.translation)) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
        let bad = [
            (ApproxRig { camera_hfov_deg: 0.0, ..rig.clone() }, "camera_hfov_deg"),
            (ApproxRig { projector_width: 0, ..rig.clone() }, "projector_width"),
            (ApproxRig { baseline_mm: [0.0; 3], ..rig.clone() }, "baseline_mm"),
            (ApproxRig { aim_distance_mm: f64::NAN, ..rig.clone() }, "aim_distance_mm"),
        ];
        for (r, field) in bad {
            let e = Calibration::from_approx_rig(&r).unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        }
    }

    #[test]
    fn undistort_inverts_distort() {
        let c = Calibration::demo_distorted();
        for &(u, v) in &[(0.0, 0.0), (639.0, 479.0), (320.0, 17.0), (5.0, 400.0)] {
            let x = c.camera.undistort(u, v);
            let xd = c.camera.distort(x);
            let back = DVec2::new(xd.x * c.camera.fx + c.camera.cx, xd.y * c.camera.fy + c.camera.cy);
            assert!((back - DVec2::new(u, v)).length() < 1e-7, "{u},{v} -> {back}");
        }
    }

    #[test]
    fn stripe_depth_recovers_a_known_point() {
        for calib in [Calibration::demo(), Calibration::demo_distorted()] {
            let p_cam = DVec3::new(40.0, -25.0, 700.0);
            let pix = calib.camera.project(p_cam).unwrap();
            let proj = calib.projector.project(calib.cam_to_proj(p_cam)).unwrap();
            // A 60-degree family: coord = cos·u + sin·v.
            let (s, co) = (60f64.to_radians().sin(), 60f64.to_radians().cos());
            let target = co * proj.x + s * proj.y;
            let z = calib.depth_on_stripe(pix.x, pix.y, co, s, 0.0, target).unwrap();
            assert!((z - 700.0).abs() < 1e-6, "{z}");
        }
    }

    #[test]
    fn broken_files_name_the_field() {
        let good = Calibration::demo().to_json();
        let cases = [
            (good.replace("\"fx\": 760.0", "\"fx\": -1.0"), "camera.fx"),
            (good.replace("\"fx\": 760.0", "\"fx\": \"a\""), "camera.fx"),
            (good.replace("\"units\": \"mm\"", "\"units\": \"in\""), "units"),
            (good.replace("\"width\": 640", "\"width\": 0"), "camera.width"),
            ("{".to_string(), ""),
        ];
        for (text, field) in cases {
            let err = Calibration::from_json(&text).unwrap_err().to_string();
            assert!(err.starts_with("calibration: ") && err.contains(field), "{err}");
        }
        let mut c = Calibration::demo();
        c.rotation[0] = 2.0;
        assert!(c.validate().unwrap_err().to_string().contains("rotation"));
        let no_dist = good.replace("\"dist\": [\n      0.0,\n      0.0,\n      0.0,\n      0.0,\n      0.0\n    ]", "\"dist\": [0,0,0,0,0]");
        assert!(Calibration::from_json(&no_dist).is_ok());
    }
}

/// A camera's colour mixing: linear camera RGB = `M` · linear light of the projector's
/// primaries; row = camera channel, column = projector primary.
pub type Crosstalk = [[f32; 3]; 3];

/// No colour mixing.
pub const IDENTITY_CROSSTALK: Crosstalk = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Least |determinant| of a colour-mixing matrix that the scanner inverts: below it the
/// three primaries are not told apart (a real camera's is 0.3 to 1 after row scaling).
pub const CROSSTALK_MIN_DETERMINANT: f32 = 1e-3;

/// A colour-mixing matrix from 9 numbers, row by row (what `stripelight crosstalk`
/// prints and the page's worker receives).
pub fn crosstalk_from_values(values: &[f32]) -> Result<Crosstalk> {
    let v: &[f32; 9] = values.try_into().map_err(|_| Error::Setting {
        name: "crosstalk",
        problem: format!("needs 9 numbers (3x3, row by row), got {}", values.len()),
    })?;
    let m = [[v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]]];
    crosstalk_inverse(&m)?;
    Ok(m)
}

/// A colour-mixing matrix from text: 9 numbers, row by row, separated by commas,
/// semicolons or white space.
///
/// ```
/// let m = stripelight::calib::parse_crosstalk("0.9,0.1,0; 0.05 0.9 0.05, 0 0.1 0.9").unwrap();
/// assert_eq!(m[1], [0.05, 0.9, 0.05]);
/// assert!(stripelight::calib::parse_crosstalk("1,0,0").unwrap_err().to_string().contains("9 numbers"));
/// ```
pub fn parse_crosstalk(text: &str) -> Result<Crosstalk> {
    let values = text
        .split(|c: char| c == ',' || c == ';' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| {
            t.parse::<f32>().map_err(|_| Error::Setting { name: "crosstalk", problem: format!("{t:?} is not a number") })
        })
        .collect::<Result<Vec<f32>>>()?;
    crosstalk_from_values(&values)
}

/// The inverse of a colour-mixing matrix (what the scanner applies to each pixel),
/// `None` for the identity; fails when a value is not finite or the matrix cannot be
/// inverted.
pub fn crosstalk_inverse(m: &Crosstalk) -> Result<Option<glam::Mat3>> {
    if m.iter().flatten().any(|x| !x.is_finite()) {
        return Err(Error::Setting { name: "crosstalk", problem: format!("{m:?} has a value that is not a number") });
    }
    if *m == IDENTITY_CROSSTALK {
        return Ok(None);
    }
    let mix = glam::Mat3::from_cols_array_2d(m).transpose();
    // Huge values overflow the determinant to infinity or NaN (which no comparison
    // refuses) and the inverse to NaN, which would reach every pixel: refused alike.
    let inverse = mix.inverse();
    if !(mix.determinant().abs() >= CROSSTALK_MIN_DETERMINANT && mix.determinant().is_finite() && inverse.is_finite()) {
        return Err(Error::Setting { name: "crosstalk", problem: format!("{m:?} cannot be inverted") });
    }
    Ok(Some(inverse))
}

/// Least fraction of a primary's frame that must be well exposed (neither dark nor
/// saturated in any channel) for [`estimate_crosstalk`].
const CROSSTALK_MIN_COVERAGE: f64 = 0.01;

/// Estimate the camera's colour mixing (`ScanConfig::crosstalk`) from four frames of a
/// white card: the projector showing full red, full green, full blue and black. Per
/// camera channel c and primary k, `M[c][k]` is the mean linear response of c to k
/// (black frame subtracted, which removes ambient light and the projector's black
/// level), over the pixels well exposed in all four frames; each row is scaled to sum
/// to 1 (a camera channel's gain does not matter to decoding, which works on ratios).
/// `gamma` is the camera's encoding gamma.
pub fn estimate_crosstalk(
    primaries: [&crate::raster::Image<[u8; 3]>; 3],
    black: &crate::raster::Image<[u8; 3]>,
    gamma: f32,
) -> Result<Crosstalk> {
    let linear: [f64; 256] = std::array::from_fn(|v| (v as f64 / 255.0).powf(gamma as f64));
    estimate_crosstalk_through(primaries, black, &linear)
}

/// [`estimate_crosstalk`] with the camera's codes read through `response` where one was
/// measured, through the power law of `camera_gamma` otherwise (what `stripelight
/// crosstalk`, the page and the evaluation do).
pub fn estimate_crosstalk_for(
    primaries: [&crate::raster::Image<[u8; 3]>; 3],
    black: &crate::raster::Image<[u8; 3]>,
    camera_gamma: f32,
    response: Option<&CameraResponse>,
) -> Result<Crosstalk> {
    match response {
        Some(r) => estimate_crosstalk_through(primaries, black, &r.linear_f64()),
        None => estimate_crosstalk(primaries, black, camera_gamma),
    }
}

/// [`estimate_crosstalk`] with the camera's codes read through `linear` (light per
/// 8-bit code: a power law's, or a measured [`CameraResponse`]'s, see
/// [`CameraResponse::linear_f64`]).
pub fn estimate_crosstalk_through(
    primaries: [&crate::raster::Image<[u8; 3]>; 3],
    black: &crate::raster::Image<[u8; 3]>,
    linear: &[f64; 256],
) -> Result<Crosstalk> {
    let size = black.size();
    for p in primaries {
        p.expect_size(size.0, size.1)?;
    }
    let lin = |v: u8| linear[v as usize];
    let mut sum = [[0f64; 3]; 3];
    let mut count = 0usize;
    for i in 0..size.0 * size.1 {
        let frames = [primaries[0].pixels()[i], primaries[1].pixels()[i], primaries[2].pixels()[i]];
        let usable = frames.iter().all(|p| p.iter().all(|&c| c < crate::raster::SATURATED)) && frames.iter().all(|p| p.iter().any(|&c| c > 40));
        if !usable {
            continue;
        }
        count += 1;
        let k0 = black.pixels()[i];
        for (k, p) in frames.iter().enumerate() {
            for c in 0..3 {
                sum[c][k] += (lin(p[c]) - lin(k0[c])).max(0.0);
            }
        }
    }
    if (count as f64) < CROSSTALK_MIN_COVERAGE * (size.0 * size.1) as f64 {
        return Err(Error::ColourFrames(format!(
            "only {count} pixels are well exposed under all three primaries; \
             point the camera at a white card lit by the projector and avoid saturation"
        )));
    }
    let mut m = [[0f32; 3]; 3];
    for c in 0..3 {
        let row: f64 = sum[c].iter().sum();
        if row <= 0.0 {
            return Err(Error::ColourFrames(format!("camera channel {c} saw no projector light")));
        }
        for k in 0..3 {
            m[c][k] = (sum[c][k] / row) as f32;
        }
    }
    Ok(m)
}
