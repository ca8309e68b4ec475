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
//! 0..=1, encoded as `x^(1 / camera_gamma)` and rounded to 8 bits (with
//! `highlight_knee` below 1, the top of the code range follows a tone curve's shoulder
//! instead, and the clipping is at the shoulder's end).
//!
//! The ground truth ([`Frame::depth`], [`Frame::projector`], [`Frame::lit`]) is
//! computed for the single ray through each pixel centre; [`Frame::lit_share`] is the
//! share of all the pixel's rays that are lit.
//!
//! Two optional stages model a webcam's output (both off by default): 4:2:0 chroma
//! subsampling ([`chroma_420`]: the 8-bit frame to YCbCr, each 2 x 2 block's chroma
//! averaged, back to RGB) and a JPEG round trip ([`jpeg_round_trip`]).
//!
//! # Many frames of one view
//!
//! Everything up to the projector's emission depends only on the scene, the rig and
//! the supersampling: a [`View`] traces it once (every ray's surface point, albedo,
//! shading factor and projector pixel), and [`View::photograph_into`] then makes a
//! frame for any projector image at the cost of the emission look-ups and the camera
//! stages. [`render`] is a view photographed once. Multi-shot references (a Gray-code
//! sequence, the white-card frames of a colour calibration) use one view per scene.
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
pub mod pigments;
pub mod rig;
mod scene;
mod sensor;
mod texture;

pub use geometry::{HeightField, Shape};
pub use scene::{Hit, Object, Scene};
pub use sensor::{chroma_420, jpeg_round_trip, CLIPPED};
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

/// Most rays a [`View`] keeps (2^27, 4 GiB of samples at 32 bytes each): a
/// 64-megapixel camera with one ray per pixel, or an 8-megapixel one with 4 x 4.
const MAX_SAMPLES: usize = 1 << 27;

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
    /// The projector's own blur, projector pixels (standard deviation of a Gaussian
    /// applied to the emitted image): a projector out of focus or with a soft lens,
    /// whose stripes have sloping sides and no flat top. Default 0: a sharp projector.
    pub projector_blur: f32,
    /// Sensor noise, standard deviation in linear units of full scale. Default 0.005:
    /// about 1.3 code values at mid grey after the gamma, typical of a CCD at low gain.
    pub noise_sigma: f32,
    /// Camera gain. Default: [`WHITE_PAPER_LEVEL`] / ([`WHITE_PAPER_ALBEDO`] · (1 + ambient)),
    /// so white paper facing the projector at `reference_distance` under full white
    /// is just below saturation.
    pub exposure: f32,
    /// The camera encodes linear x as x^(1 / camera_gamma). Default 2.2.
    pub camera_gamma: f32,
    /// Where the camera's tone curve leaves the power law, as a share of the code
    /// range: above it a highlight shoulder rolls the codes off smoothly to full scale,
    /// which the sensor then reaches at `(2 - knee)^camera_gamma` times the power law's
    /// clip level instead of at it (see the sensor's `untone`). Phones' and many
    /// webcams' pipelines have such a shoulder; a machine-vision camera has none.
    /// Default 1: no shoulder.
    pub highlight_knee: f32,
    /// Rays per camera pixel along each axis. Default 2 (2 x 2 rays).
    pub supersample: usize,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Distance (mm) at which the projector's irradiance at normal incidence is 1;
    /// it falls off as the inverse square of the distance to the projector's centre.
    /// 0 turns the falloff off. Default 750 mm, the demo rig's working distance.
    pub reference_distance: f32,
    /// Subsample the output frame's chroma 4:2:0 ([`chroma_420`]), as most webcams'
    /// YUV and MJPEG streams do. Default off.
    pub chroma_420: bool,
    /// Pass the output frame through a JPEG encoder of this quality (1-100) and its
    /// decoder ([`jpeg_round_trip`]), after the chroma subsampling. Default `None`.
    pub jpeg_quality: Option<u8>,
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
            projector_blur: 0.0,
            noise_sigma: 0.005,
            exposure: WHITE_PAPER_LEVEL / (WHITE_PAPER_ALBEDO * (1.0 + DEFAULT_AMBIENT)),
            camera_gamma: 2.2,
            highlight_knee: 1.0,
            supersample: 2,
            seed: 0,
            reference_distance: 750.0,
            chroma_420: false,
            jpeg_quality: None,
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
        check("highlight_knee", self.highlight_knee, 0.5..=1.0)?;
        check("blur_sigma", self.blur_sigma, 0.0..=50.0)?;
        check("projector_blur", self.projector_blur, 0.0..=50.0)?;
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
        if let Some(q) = self.jpeg_quality {
            if !(1..=100).contains(&q) {
                return Err(Error::Scene(format!("jpeg_quality must be in 1..=100, got {q}")));
            }
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
    /// The share of each pixel's rays (`supersample`² of them) whose points receive
    /// projector light: 0 where no projector light reaches any part of the pixel,
    /// between 0 and 1 on the edges of the light and of shadows.
    pub lit_share: Image<f32>,
}

impl Frame {
    /// An empty (black, no surface) frame of `width` x `height`.
    pub fn new(width: usize, height: usize) -> Self {
        Frame {
            image: Image::new(width, height, [0; 3]),
            depth: Image::new(width, height, f32::NAN),
            projector: Image::new(width, height, [f32::NAN; 2]),
            lit: Image::new(width, height, false),
            lit_share: Image::new(width, height, 0.0),
        }
    }

    /// Bit-for-bit equality of every image (NaNs included).
    pub fn same_as(&self, other: &Frame) -> bool {
        let bits = |img: &Image<f32>| img.pixels().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let proj_bits = |img: &Image<[f32; 2]>| img.pixels().iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
        self.image == other.image
            && self.lit == other.lit
            && bits(&self.lit_share) == bits(&other.lit_share)
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
    projector_image.expect_size(calib.projector.width as usize, calib.projector.height as usize)?;
    let view = View::new(scene, calib, cfg)?;
    let (w, h) = view.size();
    let sizes = [frame.image.size(), frame.depth.size(), frame.projector.size(), frame.lit.size(), frame.lit_share.size()];
    if sizes.iter().any(|&s| s != (w, h)) {
        *frame = Frame::new(w, h);
    }
    frame.depth.pixels_mut().copy_from_slice(view.truth.depth.pixels());
    frame.projector.pixels_mut().copy_from_slice(view.truth.projector.pixels());
    frame.lit.pixels_mut().copy_from_slice(view.truth.lit.pixels());
    frame.lit_share.pixels_mut().copy_from_slice(view.truth.lit_share.pixels());
    view.photograph_into(projector_image, cfg, &mut Scratch::default(), &mut frame.image)
}

/// What one camera ray meets: the surface's albedo, the projector's shading factor
/// there and the projector pixel that lights it. A ray that meets nothing has zero
/// albedo; an unlit point has a NaN pixel.
#[derive(Clone, Copy, Debug)]
struct Sample {
    albedo: Rgb,
    /// cos θ · (reference_distance / r)², see the module documentation.
    gain: f32,
    /// Projector pixel, NaN when unlit (or nothing is hit).
    px: DVec2,
}

/// A scene seen by a rig's camera, traced once: per camera ray what it meets and how
/// the projector lights it, and the ground truth. Photographing it under a projector
/// image costs only the emission look-ups and the camera stages, so multi-shot
/// sequences (Gray codes, colour calibration frames) trace each scene once.
///
/// ```
/// use stripelight::{sim, Calibration, Image};
/// let calib = Calibration::demo();
/// let cfg = sim::SimConfig::default();
/// let view = sim::View::new(&sim::Scene::builtin("plane").unwrap(), &calib, &cfg).unwrap();
/// let mut frame = Image::new(0, 0, [0u8; 3]);
/// let mut scratch = sim::Scratch::default();
/// view.photograph_into(&Image::new(1024, 768, [255u8; 3]), &cfg, &mut scratch, &mut frame).unwrap();
/// assert_eq!(frame.size(), (640, 480));
/// ```
pub struct View {
    width: usize,
    height: usize,
    projector_size: (usize, usize),
    /// The supersampling and falloff the samples were traced with.
    supersample: usize,
    reference_distance: f32,
    /// `supersample`² samples per pixel, pixel after pixel, row by row; within a
    /// pixel rows of rays top to bottom, each left to right.
    samples: Vec<Sample>,
    /// The ground truth; its image is black.
    truth: Frame,
}

/// Reusable buffers of [`View::photograph_into`].
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    linear: Image<Rgb>,
    blur: Vec<Rgb>,
}

impl View {
    /// Trace `scene` through `calib`'s camera with `cfg`'s supersampling and
    /// `reference_distance`. Fails on an invalid calibration or configuration.
    pub fn new(scene: &Scene, calib: &Calibration, cfg: &SimConfig) -> Result<View> {
        calib.validate()?;
        cfg.validate()?;
        let (w, h) = (calib.camera.width as usize, calib.camera.height as usize);
        if w as u64 * h as u64 > MAX_CAMERA_PIXELS as u64 {
            return Err(Error::Scene(format!(
                "a {w}x{h} camera is more than {MAX_CAMERA_PIXELS} pixels"
            )));
        }
        let n = cfg.supersample;
        if (w * h) as u64 * (n * n) as u64 > MAX_SAMPLES as u64 {
            return Err(Error::Scene(format!(
                "a {w}x{h} camera with {n} x {n} rays per pixel is more than {MAX_SAMPLES} rays; lower supersample"
            )));
        }
        let geometry = ProjectorGeometry::new(calib, cfg);
        let rays = CameraRays::new(&calib.camera);
        let offsets: Vec<f64> = (0..n).map(|k| (k as f64 + 0.5) / n as f64 - 0.5).collect();
        let mut truth = Frame::new(w, h);
        let mut samples = Vec::with_capacity(w * h * n * n);
        let miss = Sample { albedo: [0.0; 3], gain: 0.0, px: DVec2::NAN };
        for v in 0..h {
            for u in 0..w {
                let centre = scene.cast(DVec3::ZERO, rays.centre(u, v), 0.0, f64::INFINITY);
                let centre_sample = centre.map(|hit| geometry.sample(scene, &hit));
                *truth.depth.get_mut(u, v) = centre.map_or(f32::NAN, |hit| hit.point.z as f32);
                let lit = centre_sample.filter(|s| !s.px.x.is_nan());
                *truth.projector.get_mut(u, v) = lit.map_or([f32::NAN; 2], |s| [s.px.x as f32, s.px.y as f32]);
                *truth.lit.get_mut(u, v) = lit.is_some();
                for &dv in &offsets {
                    for &du in &offsets {
                        let sample = if du == 0.0 && dv == 0.0 {
                            centre_sample
                        } else {
                            let ray = rays.at(u as f64 + du, v as f64 + dv);
                            scene.cast(DVec3::ZERO, ray, 0.0, f64::INFINITY).map(|hit| geometry.sample(scene, &hit))
                        };
                        samples.push(sample.unwrap_or(miss));
                    }
                }
                let lit_rays = samples[samples.len() - n * n..].iter().filter(|s| !s.px.x.is_nan()).count();
                *truth.lit_share.get_mut(u, v) = lit_rays as f32 / (n * n) as f32;
            }
        }
        Ok(View {
            width: w,
            height: h,
            projector_size: (calib.projector.width as usize, calib.projector.height as usize),
            supersample: n,
            reference_distance: cfg.reference_distance,
            samples,
            truth,
        })
    }

    /// The camera's (width, height).
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The ground truth (depth, projector pixel, lit) of every pixel centre; the
    /// frame's image is black.
    pub fn truth(&self) -> &Frame {
        &self.truth
    }

    /// The frame the camera takes while the projector shows `projector_image`, into
    /// `out` (resized to the camera). `cfg` gives the projector's response, ambient
    /// light and every camera stage; its `supersample` and `reference_distance` must
    /// be the ones the view was traced with ([`Error::Scene`] otherwise).
    pub fn photograph_into(
        &self,
        projector_image: &Image<[u8; 3]>,
        cfg: &SimConfig,
        scratch: &mut Scratch,
        out: &mut Image<[u8; 3]>,
    ) -> Result<()> {
        self.linear_into(projector_image, cfg, scratch)?;
        if out.size() != (self.width, self.height) {
            *out = Image::new(self.width, self.height, [0; 3]);
        }
        sensor::quantize(&scratch.linear, cfg.exposure, cfg.noise_sigma, cfg.camera_gamma, cfg.highlight_knee, cfg.seed, out);
        if cfg.chroma_420 {
            chroma_420(out);
        }
        if let Some(q) = cfg.jpeg_quality {
            *out = jpeg_round_trip(out, q)?;
        }
        Ok(())
    }

    /// The camera's linear signal before gain and noise (radiance after colour mixing
    /// and blur) into `scratch.linear`.
    fn linear_into(&self, projector_image: &Image<[u8; 3]>, cfg: &SimConfig, scratch: &mut Scratch) -> Result<()> {
        cfg.validate()?;
        projector_image.expect_size(self.projector_size.0, self.projector_size.1)?;
        if cfg.supersample != self.supersample || cfg.reference_distance.to_bits() != self.reference_distance.to_bits() {
            return Err(Error::Scene(format!(
                "the view was traced with supersample {} and reference_distance {}, not {} and {}",
                self.supersample, self.reference_distance, cfg.supersample, cfg.reference_distance
            )));
        }
        let emission = Emission::new(projector_image, cfg);
        let (w, h) = (self.width, self.height);
        if scratch.linear.size() != (w, h) {
            scratch.linear = Image::new(w, h, [0.0; 3]);
        }
        let n2 = self.supersample * self.supersample;
        let weight = 1.0 / n2 as f32;
        let ambient = cfg.ambient;
        for (out, pixel) in scratch.linear.pixels_mut().iter_mut().zip(self.samples.chunks_exact(n2)) {
            let mut sum = [0f32; 3];
            for s in pixel {
                // The same operations in the same order as a single render always did,
                // so that frames stay bit-for-bit what they were.
                let mut radiance = s.albedo.map(|a| a * ambient);
                if !s.px.x.is_nan() {
                    let e = emission.at(s.px);
                    for k in 0..3 {
                        radiance[k] += s.albedo[k] * e[k] * s.gain;
                    }
                }
                for c in 0..3 {
                    sum[c] += radiance[c];
                }
            }
            *out = sum.map(|x| x * weight);
        }
        sensor::crosstalk(&mut scratch.linear, &cfg.crosstalk);
        sensor::gaussian_blur(&mut scratch.linear, cfg.blur_sigma, &mut scratch.blur);
        Ok(())
    }

    /// The camera gain at which `fraction` of the *bright-stripe pixels* clip in at
    /// least one channel when the projector shows `projector_image` (before noise):
    /// a user who turns the exposure up until the object looks bright. Bright-stripe
    /// pixels are lit pixels where the projector emits at least
    /// [`BRIGHT_STRIPE_LEVEL`] of full white in some channel. Fails when
    /// `fraction` is not in (0, 1) or no pixel is a bright-stripe pixel.
    pub fn exposure_for_clipping(&self, projector_image: &Image<[u8; 3]>, cfg: &SimConfig, fraction: f32) -> Result<f32> {
        if !(fraction > 0.0 && fraction < 1.0) {
            return Err(Error::Scene(format!("clipped fraction must be in (0, 1), got {fraction}")));
        }
        let mut scratch = Scratch::default();
        self.linear_into(projector_image, cfg, &mut scratch)?;
        let bright = self.bright_stripe_mask(projector_image, cfg);
        let mut peaks: Vec<f32> = scratch
            .linear
            .pixels()
            .iter()
            .zip(&bright)
            .filter(|(_, &b)| b)
            .map(|(p, _)| p[0].max(p[1]).max(p[2]))
            .collect();
        if peaks.is_empty() {
            return Err(Error::Scene("no bright-stripe pixel to set the exposure on".into()));
        }
        let k = ((1.0 - fraction as f64) * peaks.len() as f64) as usize;
        let k = k.min(peaks.len() - 1);
        let (_, &mut level, _) = peaks.select_nth_unstable_by(k, f32::total_cmp);
        if !(level > 0.0) {
            return Err(Error::Scene("the bright-stripe pixels are black".into()));
        }
        Ok(sensor::clip_level(cfg.camera_gamma, cfg.highlight_knee) / level)
    }

    /// Which pixels are bright-stripe pixels under `projector_image` (see
    /// [`View::exposure_for_clipping`]): lit, with the emission at the pixel centre's
    /// projector pixel at least [`BRIGHT_STRIPE_LEVEL`] in some channel.
    pub fn bright_stripe_mask(&self, projector_image: &Image<[u8; 3]>, cfg: &SimConfig) -> Vec<bool> {
        let emission = Emission::new(projector_image, cfg);
        self.truth
            .projector
            .pixels()
            .iter()
            .map(|p| {
                !p[0].is_nan() && {
                    let e = emission.at(DVec2::new(p[0] as f64, p[1] as f64));
                    e.iter().any(|&x| x >= BRIGHT_STRIPE_LEVEL)
                }
            })
            .collect()
    }
}

/// Emitted light (fraction of full white) from which a projector pixel counts as a
/// bright stripe in one channel: half of full white, between the patterns' high level
/// (1) and their highest low level (0.45 for three directions, 0.46 after the
/// projector's black level).
pub const BRIGHT_STRIPE_LEVEL: f32 = 0.5;

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

/// Where the projector is and which of its pixels reach a point: the geometric part
/// of the projector as a light source.
struct ProjectorGeometry<'a> {
    proj_from_cam: DMat3,
    proj_from_cam_t: DVec3,
    /// Projector centre in the camera frame, mm.
    centre: DVec3,
    intrinsics: &'a Intrinsics,
    /// Undistorted normalized coordinates that can reach the image (with a margin):
    /// guards against distortion polynomials folding far-off points back inside.
    normalized_bounds: (DVec2, DVec2),
    /// reference_distance², or 0 for no falloff.
    reference2: f64,
}

impl<'a> ProjectorGeometry<'a> {
    fn new(calib: &'a Calibration, cfg: &SimConfig) -> Self {
        let p = &calib.projector;
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
        ProjectorGeometry {
            proj_from_cam: calib.proj_from_cam_rotation(),
            proj_from_cam_t: calib.proj_from_cam_translation(),
            centre: calib.projector_center_cam(),
            intrinsics: p,
            normalized_bounds: (lo - margin, hi + margin),
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

    /// What the camera ray that met `hit` needs to know about the projector: lit (in
    /// the image, facing the projector, not in shadow) or not, and the shading factor.
    fn sample(&self, scene: &Scene, hit: &Hit) -> Sample {
        let unlit = Sample { albedo: hit.albedo, gain: 0.0, px: DVec2::NAN };
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
        Sample { albedo: hit.albedo, gain: (cos * falloff) as f32, px }
    }
}

/// The projector image as emitted light: every pixel's linear emission looked up
/// once per frame (and blurred by [`SimConfig::projector_blur`]), so that each ray's
/// bilinear sample reads four floats per channel.
struct Emission {
    width: usize,
    height: usize,
    /// Emitted linear light per projector pixel, row by row.
    light: Vec<Rgb>,
}

impl Emission {
    fn new(image: &Image<[u8; 3]>, cfg: &SimConfig) -> Self {
        let mut lut = [0f32; 256];
        for (i, l) in lut.iter_mut().enumerate() {
            *l = cfg.projector_black + (1.0 - cfg.projector_black) * (i as f32 / 255.0).powf(cfg.projector_gamma);
        }
        let (width, height) = image.size();
        let mut light = image.map(|p| p.map(|v| lut[v as usize]));
        sensor::gaussian_blur(&mut light, cfg.projector_blur, &mut Vec::new());
        Emission { width, height, light: light.into_vec() }
    }

    /// Emitted linear light at projector pixel `px` (bilinear, clamped at the border).
    #[inline]
    fn at(&self, px: DVec2) -> Rgb {
        let (w, h) = (self.width, self.height);
        let x = px.x.max(0.0).min((w - 1) as f64);
        let y = px.y.max(0.0).min((h - 1) as f64);
        // Truncation is the floor here (x, y >= 0); i64 casts are cheaper than usize ones.
        let (i0, j0) = (x as i64, y as i64);
        let (fx, fy) = ((x - i0 as f64) as f32, (y - j0 as f64) as f32);
        let (i0, j0) = (i0 as usize, j0 as usize);
        let (i1, j1) = ((i0 + 1).min(w - 1), (j0 + 1).min(h - 1));
        let (a, b) = (self.light[j0 * w + i0], self.light[j0 * w + i1]);
        let (c, d) = (self.light[j1 * w + i0], self.light[j1 * w + i1]);
        let mut out = [0f32; 3];
        for k in 0..3 {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            out[k] = top + (bottom - top) * fy;
        }
        out
    }
}
