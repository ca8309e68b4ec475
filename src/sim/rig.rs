//! Variations of a projector-camera rig for the simulator's harder conditions: a
//! camera of another resolution with the same view, and a projector that lights only
//! part of the camera's frame. Both return new calibrations; the scanner is given the
//! same one, as it would be by a calibration of that rig.

use crate::calib::{Calibration, Intrinsics};
use crate::error::{Error, Result};
use glam::DVec3;

/// Largest camera side accepted by [`scaled_camera`], pixels.
const MAX_CAMERA_SIDE: f64 = 16384.0;

/// `calib` with its camera resampled by `factor` (same field of view, same lens
/// distortion in normalized coordinates): `factor` 2 doubles the width and height.
/// The image edge stays the image edge (pixel centres at integers, so the edge at
/// −0.5 stays at −0.5). Fails when the factor is not positive and finite or the
/// camera would be empty or wider than 16384 pixels.
///
/// ```
/// let c = stripelight::sim::rig::scaled_camera(&stripelight::Calibration::demo(), 5.1).unwrap();
/// assert_eq!((c.camera.width, c.camera.height), (3264, 2448));
/// ```
pub fn scaled_camera(calib: &Calibration, factor: f64) -> Result<Calibration> {
    let c = &calib.camera;
    let (w, h) = ((c.width as f64 * factor).round(), (c.height as f64 * factor).round());
    if !(factor.is_finite() && factor > 0.0 && w >= 1.0 && h >= 1.0 && w <= MAX_CAMERA_SIDE && h <= MAX_CAMERA_SIDE) {
        return Err(Error::Scene(format!(
            "camera scale factor {factor} makes a {w}x{h} camera (1..={MAX_CAMERA_SIDE} per side)"
        )));
    }
    // Scale per axis by the ratio of the rounded sizes so that the edges map exactly.
    let (sx, sy) = (w / c.width as f64, h / c.height as f64);
    let mut out = calib.clone();
    out.camera = Intrinsics {
        width: w as u32,
        height: h as u32,
        fx: c.fx * sx,
        fy: c.fy * sy,
        cx: (c.cx + 0.5) * sx - 0.5,
        cy: (c.cy + 0.5) * sy - 0.5,
        dist: c.dist,
    };
    out.validate()?;
    Ok(out)
}

/// `calib` with its projector given `zoom` times its focal length (a longer throw:
/// its image is `1 / zoom` as wide) and turned, about its own centre, to aim at
/// `target` (camera frame, mm) instead of where it aimed. The projector's centre,
/// resolution, principal point and distortion are kept.
///
/// With the demo rig, `zoom` 1.15 and a target 130 mm right of and 95 mm below the
/// camera's axis at 750 mm light about 60 % of the camera's frame (the `partial`
/// condition of `eval::hard`).
pub fn partial_projector(calib: &Calibration, zoom: f64, target: DVec3) -> Result<Calibration> {
    if !(zoom.is_finite() && zoom > 0.0 && target.is_finite()) {
        return Err(Error::Scene(format!("projector zoom {zoom} and target {target} must be finite, zoom positive")));
    }
    let mut projector = calib.projector.clone();
    projector.fx *= zoom;
    projector.fy *= zoom;
    let centre = calib.projector_center_cam();
    if (target - centre).length() < 1.0 {
        return Err(Error::Scene(format!("projector target {target} is at the projector itself")));
    }
    let out = Calibration::aimed(calib.camera.clone(), projector, centre, target);
    out.validate()?;
    Ok(out)
}
