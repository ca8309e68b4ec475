//! Projector-camera simulator with per-pixel ground truth.
//!
//! [`render`] photographs a [`Scene`] of analytic objects lit by a projector showing an
//! 8-bit image, with the geometry of a [`Calibration`], and returns the camera frame
//! together with the truth the scanner should recover: the depth and the projector
//! pixel seen at every camera pixel centre.
//!
//! # Conventions
//!
//! Everything geometric is in the **camera frame** (x right, y down, z forward,
//! millimetres; `conventions.md`). Pixel (u, v) has its centre at integer coordinates
//! on both devices. Camera rays are `calib.camera.ray(u, v)` (z = 1, lens distortion
//! undone), so the ray parameter of a hit is its depth Z. Points are mapped into the
//! projector with `calib.cam_to_proj` and onto its pixels with
//! `calib.projector.project` (its distortion applied): exactly the model that
//! [`Calibration::depth_on_stripe`] inverts, so the ground truth triangulates back to
//! itself.
//!
//! # Image formation
//!
//! For each camera pixel, `supersample`² rays on a regular grid inside the pixel (for
//! 2: at ±¼ pixel) find the nearest surface. A surface point is **lit** when it
//! projects inside the projector image (`-0.5 <= u_p <= width - 0.5`, likewise v),
//! faces the projector, and the segment to the projector's centre meets no surface
//! (shadows). Its radiance is
//!
//! ```text
//! L = albedo ⊙ (ambient + [lit] · E(u_p, v_p) · cos θ · (reference_distance / r)²)
//! ```
//!
//! with θ the angle between the normal and the direction to the projector, r the
//! distance to the projector's centre, and E the projector's emitted light: the
//! projector image sampled bilinearly in projector pixels (clamped at its border),
//! each pixel value mapped through `black + (1 - black) · (value / 255)^gamma`. Units
//! of light are fractions of full projector white arriving at normal incidence from
//! `reference_distance` away. The rays' radiances are averaged (the pixel's area),
//! then the camera mixes colours (`crosstalk`), defocus blurs the image (Gaussian),
//! the gain `exposure` scales it, Gaussian noise is added, and the result is clipped to
//! 0..=1, encoded as `x^(1 / camera_gamma)` and rounded to 8 bits.
//!
//! The ground truth ([`Frame::depth`], [`Frame::projector`], [`Frame::lit`]) is
//! computed for the single ray through each pixel centre.
//!
//! ```
//! use stripelight::{sim, Calibration, Image};
//! let calib = Calibration::demo();
//! let white = Image::new(1024, 768, [255u8; 3]);
//! let scene = sim::Scene::builtin("plane").unwrap();
//! let frame = sim::render(&scene, &calib, &white, &sim::SimConfig::default()).unwrap();
//! assert_eq!(frame.image.size(), (640, 480));
//! assert!((frame.depth.get(320, 240) - 750.0).abs() < 1.0);
//! ```

// Negated comparisons (`!(x > 0.0)`) are deliberate throughout: they also catch NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod geometry;
mod scene;
mod sensor;
mod texture;

pub use geometry::{HeightField, Shape};
pub use scene::{Hit, Object, Scene};
pub use texture::Texture;

use crate::calib::{Calibration, Intrinsics};
use crate::error::{Error, Result};
use crate::raster::{Image, Rgb};
use glam::{DMat3, DVec2, DVec3};

/// Default ambient light: a dim room, 3 % of the projector's white at the working
/// distance (a lab with the lights dimmed for scanning).
pub const DEFAULT_AMBIENT: f32 = 0.03;

/// Albedo of white office paper, used to set the default exposure.
pub const WHITE_PAPER_ALBEDO: f32 = 0.8;

/// Fraction of full scale at which white paper facing the projector at the reference
/// distance under full white reads with the default exposure: just below saturation,
/// with a little headroom for the noise and for surfaces nearer than the reference.
pub const WHITE_PAPER_LEVEL: f32 = 0.92;

/// Shadow rays ignore this much of their ends, mm, so that they do not find the
/// surface they start on.
const SHADOW_CLEARANCE_MM: f64 = 0.01;

/// Largest supersampling factor accepted (64 rays per pixel).
const MAX_SUPERSAMPLE: usize = 8;

/// Largest camera accepted, pixels (64 megapixels; a simulated frame of that size
/// already takes about a gigabyte).
const MAX_CAMERA_PIXELS: usize = 1 << 26;

/// How the simulated projector and camera behave. `Default` gives a realistic
/// LCD projector and 3CCD camera in a dim room at the demo rig's working distance.
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig {
    /// Ambient light as a fraction of full projector white; see [`DEFAULT_AMBIENT`].
    pub ambient: f32,
    /// Projector black level as a fraction of white. Default 0.02: an LCD projector's
    /// 50:1 in-room contrast (its rated on/off contrast is higher, light scattered in
    /// the room lowers it).
    pub projector_black: f32,
    /// The projector's response: emitted linear light = black + (1 − black) ·
    /// (value / 255)^gamma. Default 2.2, the usual video gamma (and the pattern
    /// spec's `encoding_gamma`).
    pub projector_gamma: f32,
    /// Camera colour mixing, row = output channel, rows sum to 1. Default 0.86 on the
    /// diagonal and 0.07 off it: the overlap of projector primaries with camera
    /// filter passbands reported for LCD projectors and 3CCD/Bayer cameras (about
    /// 10-15 % of a primary leaks into each neighbouring channel).
    pub crosstalk: [[f32; 3]; 3],
    /// Defocus blur, camera pixels (standard deviation of a Gaussian). Default 0.6:
    /// a lens focused at the working distance, slightly soft over 600-950 mm.
    pub blur_sigma: f32,
    /// Sensor noise, standard deviation in linear units of full scale. Default 0.005:
    /// about 1.3 code values at mid grey after the gamma, typical of a CCD at low gain.
    pub noise_sigma: f32,
    /// Camera gain. Default: [`WHITE_PAPER_LEVEL`] / ([`WHITE_PAPER_ALBEDO`] · (1 + ambient)),
    /// so white paper facing the projector at `reference_distance` under full white
    /// is just below saturation.
    pub exposure: f32,
    /// The camera encodes linear x as x^(1 / camera_gamma). Default 2.2.
    pub camera_gamma: f32,
    /// Rays per camera pixel along each axis. Default 2 (2 x 2 rays).
    pub supersample: usize,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Distance (mm) at which the projector's irradiance at normal incidence is 1;
    /// it falls off as the inverse square of the distance to the projector's centre.
    /// 0 turns the falloff off. Default 750 mm, the demo rig's working distance.
    pub reference_distance: f32,
}

impl Default for SimConfig {
    fn default() -> Self {
        let (d, o) = (0.86, 0.07);
        SimConfig {
            ambient: DEFAULT_AMBIENT,
            projector_black: 0.02,
            projector_gamma: 2.2,
            crosstalk: [[d, o, o], [o, d, o], [o, o, d]],
            blur_sigma: 0.6,
            noise_sigma: 0.005,
            exposure: WHITE_PAPER_LEVEL / (WHITE_PAPER_ALBEDO * (1.0 + DEFAULT_AMBIENT)),
            camera_gamma: 2.2,
            supersample: 2,
            seed: 0,
            reference_distance: 750.0,
        }
    }
}

impl SimConfig {
    /// A camera with no crosstalk, blur or noise (and the other defaults): what is
    /// left is geometry, shading, the projector's response and 8-bit quantization.
    pub fn ideal() -> Self {
        SimConfig {
            crosstalk: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            blur_sigma: 0.0,
            noise_sigma: 0.0,
            ..SimConfig::default()
        }
    }

    /// Refuse values that make no physical sense, naming the field.
    pub fn validate(&self) -> Result<()> {
        let check = |field: &str, value: f32, range: std::ops::RangeInclusive<f32>| {
            if value.is_finite() && range.contains(&value) {
                Ok(())
            } else {
                Err(Error::Scene(format!(
                    "{field} must be in {}..={}, got {value}",
                    range.start(),
                    range.end()
                )))
            }
        };
        check("ambient", self.ambient, 0.0..=10.0)?;
        check("projector_black", self.projector_black, 0.0..=1.0)?;
        check("projector_gamma", self.projector_gamma, 0.1..=10.0)?;
        check("camera_gamma", self.camera_gamma, 0.1..=10.0)?;
        check("blur_sigma", self.blur_sigma, 0.0..=50.0)?;
        check("noise_sigma", self.noise_sigma, 0.0..=1.0)?;
        check("exposure", self.exposure, 1e-6..=1e6)?;
        check("reference_distance", self.reference_distance, 0.0..=1e6)?;
        for (r, row) in self.crosstalk.iter().enumerate() {
            for (c, &x) in row.iter().enumerate() {
                check(&format!("crosstalk[{r}][{c}]"), x, -10.0..=10.0)?;
            }
        }
        if !(1..=MAX_SUPERSAMPLE).contains(&self.supersample) {
            return Err(Error::Scene(format!(
                "supersample must be in 1..={MAX_SUPERSAMPLE}, got {}",
                self.supersample
            )));
        }
        Ok(())
    }
}

/// A simulated camera frame and its ground truth, all of camera size. (No
/// `PartialEq`: the NaNs of the ground truth never compare equal; compare
/// [`Frame::same_as`] instead.)
#[derive(Clone, Debug)]
pub struct Frame {
    /// The camera frame (8-bit, gamma-encoded RGB).
    pub image: Image<[u8; 3]>,
    /// Ground-truth depth Z (mm, camera frame) of the surface seen through each pixel
    /// centre; NaN where the ray meets nothing.
    pub depth: Image<f32>,
    /// The projector pixel (u_p, v_p) (OpenCV convention, projector distortion
    /// applied) that lights the point seen at each pixel centre; NaN where unlit.
    pub projector: Image<[f32; 2]>,
    /// Whether the point seen at each pixel centre receives projector light: inside
    /// the projector image, facing it, and not in shadow.
    pub lit: Image<bool>,
}

impl Frame {
    /// An empty (black, no surface) frame of `width` x `height`.
    pub fn new(width: usize, height: usize) -> Self {
        Frame {
            image: Image::new(width, height, [0; 3]),
            depth: Image::new(width, height, f32::NAN),
            projector: Image::new(width, height, [f32::NAN; 2]),
            lit: Image::new(width, height, false),
        }
    }

    /// Bit-for-bit equality of every image (NaNs included).
    pub fn same_as(&self, other: &Frame) -> bool {
        let bits = |img: &Image<f32>| img.pixels().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let proj_bits = |img: &Image<[f32; 2]>| img.pixels().iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
        self.image == other.image
            && self.lit == other.lit
            && self.depth.size() == other.depth.size()
            && bits(&self.depth) == bits(&other.depth)
            && proj_bits(&self.projector) == proj_bits(&other.projector)
    }
}

/// Photograph `scene` lit by a projector showing `projector_image`.
///
/// `projector_image` must be `calib.projector` width x height ([`Error::ImageSize`]
/// otherwise); the frame is `calib.camera` width x height. Fails on an invalid
/// calibration or configuration. See the module documentation for the model.
pub fn render(scene: &Scene, calib: &Calibration, projector_image: &Image<[u8; 3]>, cfg: &SimConfig) -> Result<Frame> {
    let mut frame = Frame::new(0, 0);
    render_into(scene, calib, projector_image, cfg, &mut frame)?;
    Ok(frame)
}

/// [`render`] into an existing frame, reusing its buffers when it already has the
/// camera's size.
pub fn render_into(
    scene: &Scene,
    calib: &Calibration,
    projector_image: &Image<[u8; 3]>,
    cfg: &SimConfig,
    frame: &mut Frame,
) -> Result<()> {
    calib.validate()?;
    cfg.validate()?;
    projector_image.expect_size(calib.projector.width as usize, calib.projector.height as usize)?;
    let (w, h) = (calib.camera.width as usize, calib.camera.height as usize);
    if w as u64 * h as u64 > MAX_CAMERA_PIXELS as u64 {
        return Err(Error::Scene(format!(
            "a {w}x{h} camera is more than {MAX_CAMERA_PIXELS} pixels"
        )));
    }
    let sizes = [frame.image.size(), frame.depth.size(), frame.projector.size(), frame.lit.size()];
    if sizes.iter().any(|&s| s != (w, h)) {
        *frame = Frame::new(w, h);
    }
    let light = Light::new(calib, projector_image, cfg);
    let rays = CameraRays::new(&calib.camera);
    let n = cfg.supersample;
    let offsets: Vec<f64> = (0..n).map(|k| (k as f64 + 0.5) / n as f64 - 0.5).collect();
    let weight = 1.0 / (n * n) as f32;
    let mut linear = Image::new(w, h, [0f32; 3]);
    for v in 0..h {
        for u in 0..w {
            let centre_ray = rays.centre(u, v);
            let centre = scene.cast(DVec3::ZERO, centre_ray, 0.0, f64::INFINITY);
            let centre_shade = centre.map(|hit| light.shade(scene, &hit));
            *frame.depth.get_mut(u, v) = centre.map_or(f32::NAN, |hit| hit.point.z as f32);
            let at_projector = centre_shade.and_then(|s| s.projector);
            *frame.projector.get_mut(u, v) = at_projector.map_or([f32::NAN; 2], |p| [p.x as f32, p.y as f32]);
            *frame.lit.get_mut(u, v) = at_projector.is_some();

            let mut sum = [0f32; 3];
            for &dv in &offsets {
                for &du in &offsets {
                    let radiance = if du == 0.0 && dv == 0.0 {
                        centre_shade.map(|s| s.radiance)
                    } else {
                        let ray = rays.at(u as f64 + du, v as f64 + dv);
                        scene
                            .cast(DVec3::ZERO, ray, 0.0, f64::INFINITY)
                            .map(|hit| light.shade(scene, &hit).radiance)
                    };
                    if let Some(r) = radiance {
                        for c in 0..3 {
                            sum[c] += r[c];
                        }
                    }
                }
            }
            *linear.get_mut(u, v) = sum.map(|x| x * weight);
        }
    }
    sensor::crosstalk(&mut linear, &cfg.crosstalk);
    sensor::gaussian_blur(&mut linear, cfg.blur_sigma, &mut Vec::new());
    sensor::quantize(&linear, cfg.exposure, cfg.noise_sigma, cfg.camera_gamma, cfg.seed, &mut frame.image);
    Ok(())
}

/// Camera rays (z = 1) through any point of the image. Pixel centres use
/// `Intrinsics::ray` exactly; other points interpolate the centres' rays bilinearly
/// when the lens is distorted (the undistortion is iterative and costly; the map is
/// so smooth that the interpolation error is below 1e-5 pixel), and use the exact
/// linear map when it is not.
struct CameraRays<'a> {
    camera: &'a Intrinsics,
    width: usize,
    height: usize,
    /// Normalized (x, y) of every pixel centre, when the lens is distorted.
    centres: Vec<DVec2>,
}

impl<'a> CameraRays<'a> {
    fn new(camera: &'a Intrinsics) -> Self {
        let (width, height) = (camera.width as usize, camera.height as usize);
        let mut centres = Vec::new();
        if camera.dist != [0.0; 5] {
            centres.reserve(width * height);
            for v in 0..height {
                for u in 0..width {
                    centres.push(camera.undistort(u as f64, v as f64));
                }
            }
        }
        CameraRays {
            camera,
            width,
            height,
            centres,
        }
    }

    fn centre(&self, u: usize, v: usize) -> DVec3 {
        if self.centres.is_empty() {
            self.camera.ray(u as f64, v as f64)
        } else {
            self.centres[v * self.width + u].extend(1.0)
        }
    }

    fn at(&self, u: f64, v: f64) -> DVec3 {
        if self.centres.is_empty() || self.width < 2 || self.height < 2 {
            return self.camera.ray(u, v);
        }
        // Bilinear (extrapolating by half a pixel at the border) from the nearest cell.
        // Truncation is the floor for the non-negative values kept.
        let i = (u.max(0.0) as i64).min(self.width as i64 - 2);
        let j = (v.max(0.0) as i64).min(self.height as i64 - 2);
        let (fx, fy) = (u - i as f64, v - j as f64);
        let (i, j) = (i as usize, j as usize);
        let k = j * self.width + i;
        let c = &self.centres;
        let top = c[k] + (c[k + 1] - c[k]) * fx;
        let bottom = c[k + self.width] + (c[k + self.width + 1] - c[k + self.width]) * fx;
        (top + (bottom - top) * fy).extend(1.0)
    }
}

/// What a surface point sends to the camera.
#[derive(Clone, Copy, Debug)]
struct Shade {
    /// Linear radiance, units of full projector white.
    radiance: Rgb,
    /// The projector pixel lighting it, when lit.
    projector: Option<DVec2>,
}

/// The projector as a light source.
struct Light<'a> {
    proj_from_cam: DMat3,
    proj_from_cam_t: DVec3,
    /// Projector centre in the camera frame, mm.
    centre: DVec3,
    intrinsics: &'a Intrinsics,
    image: &'a Image<[u8; 3]>,
    /// Emitted linear light of each 8-bit value.
    lut: [f32; 256],
    /// Undistorted normalized coordinates that can reach the image (with a margin):
    /// guards against distortion polynomials folding far-off points back inside.
    normalized_bounds: (DVec2, DVec2),
    ambient: f32,
    /// reference_distance², or 0 for no falloff.
    reference2: f64,
}

impl<'a> Light<'a> {
    fn new(calib: &'a Calibration, image: &'a Image<[u8; 3]>, cfg: &SimConfig) -> Self {
        let p = &calib.projector;
        let mut lut = [0f32; 256];
        for (i, l) in lut.iter_mut().enumerate() {
            *l = cfg.projector_black + (1.0 - cfg.projector_black) * (i as f32 / 255.0).powf(cfg.projector_gamma);
        }
        // Undistort the image border to find the normalized region it covers.
        let (w, h) = (p.width as f64, p.height as f64);
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        const SAMPLES: usize = 64;
        for k in 0..=SAMPLES {
            let f = k as f64 / SAMPLES as f64;
            let (x, y) = (-0.5 + f * w, -0.5 + f * h);
            for (u, v) in [(x, -0.5), (x, h - 0.5), (-0.5, y), (w - 0.5, y)] {
                let q = p.undistort(u, v);
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
        let margin = (hi - lo) * 0.1;
        Light {
            proj_from_cam: calib.proj_from_cam_rotation(),
            proj_from_cam_t: calib.proj_from_cam_translation(),
            centre: calib.projector_center_cam(),
            intrinsics: p,
            image,
            lut,
            normalized_bounds: (lo - margin, hi + margin),
            ambient: cfg.ambient,
            reference2: (cfg.reference_distance as f64).powi(2),
        }
    }

    /// The projector pixel that lights camera-frame point `p`, if `p` is inside the
    /// projector's image.
    fn pixel_of(&self, p: DVec3) -> Option<DVec2> {
        let q = self.proj_from_cam * p + self.proj_from_cam_t;
        if !(q.z > 0.0) {
            return None;
        }
        let n = DVec2::new(q.x / q.z, q.y / q.z);
        let (lo, hi) = self.normalized_bounds;
        if n.cmplt(lo).any() || n.cmpgt(hi).any() {
            return None;
        }
        let px = self.intrinsics.project(q)?;
        let (w, h) = (self.intrinsics.width as f64, self.intrinsics.height as f64);
        let inside = px.x >= -0.5 && px.x <= w - 0.5 && px.y >= -0.5 && px.y <= h - 0.5;
        inside.then_some(px)
    }

    /// Emitted linear light at projector pixel `px` (bilinear, clamped at the border).
    fn emission(&self, px: DVec2) -> Rgb {
        let (w, h) = self.image.size();
        let x = px.x.max(0.0).min((w - 1) as f64);
        let y = px.y.max(0.0).min((h - 1) as f64);
        // Truncation is the floor here (x, y >= 0); i64 casts are cheaper than usize ones.
        let (i0, j0) = (x as i64, y as i64);
        let (fx, fy) = ((x - i0 as f64) as f32, (y - j0 as f64) as f32);
        let (i0, j0) = (i0 as usize, j0 as usize);
        let (i1, j1) = ((i0 + 1).min(w - 1), (j0 + 1).min(h - 1));
        let (a, b) = (self.image.get(i0, j0), self.image.get(i1, j0));
        let (c, d) = (self.image.get(i0, j1), self.image.get(i1, j1));
        let mut out = [0f32; 3];
        for k in 0..3 {
            let l = |p: [u8; 3]| self.lut[p[k] as usize];
            let top = l(a) + (l(b) - l(a)) * fx;
            let bottom = l(c) + (l(d) - l(c)) * fx;
            out[k] = top + (bottom - top) * fy;
        }
        out
    }

    fn shade(&self, scene: &Scene, hit: &Hit) -> Shade {
        let ambient = hit.albedo.map(|a| a * self.ambient);
        let unlit = Shade {
            radiance: ambient,
            projector: None,
        };
        let Some(px) = self.pixel_of(hit.point) else {
            return unlit;
        };
        let to_light = self.centre - hit.point;
        let r2 = to_light.length_squared();
        let cos = hit.normal.dot(to_light) / r2.sqrt();
        if !(cos > 0.0) || scene.blocked(hit.point, self.centre, SHADOW_CLEARANCE_MM) {
            return unlit;
        }
        let falloff = if self.reference2 > 0.0 { self.reference2 / r2 } else { 1.0 };
        let gain = (cos * falloff) as f32;
        let e = self.emission(px);
        let mut radiance = ambient;
        for k in 0..3 {
            radiance[k] += hit.albedo[k] * e[k] * gain;
        }
        Shade {
            radiance,
            projector: Some(px),
        }
    }
}
