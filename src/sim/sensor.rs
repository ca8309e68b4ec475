//! The camera after the lens: colour crosstalk, defocus blur, gain, sensor noise,
//! gamma encoding and 8-bit quantization. All operations before the noise are linear,
//! so their order among themselves does not matter. Then, optionally, what a webcam's
//! encoder does to the 8-bit frame: 4:2:0 chroma subsampling and JPEG.

use crate::error::{Error, Result};
use crate::raster::{from_ycbcr, to_ycbcr, Image, Rgb};

/// The 8-bit value of a clipped channel: the sensor's full scale.
pub const CLIPPED: u8 = 255;

/// The linear signal (after gain) from which a channel reads [`CLIPPED`]: the
/// rounding bound of the top code, `untone(254.5 / 255)^gamma` (see [`untone`]).
pub(crate) fn clip_level(gamma: f32, knee: f32) -> f32 {
    untone((CLIPPED as f32 - 0.5) / 255.0, knee).powf(gamma)
}

/// The camera's tone curve inverted: the power-law value `v` (`x^(1/gamma)` of the
/// linear signal `x`) that the encoded value `e` (0..=1) comes from. Up to `knee` the
/// curve is the power law itself (`e = v`). Above it, a highlight shoulder: `e = knee +
/// (1 - knee) (1 - (1 - u)²)` with `u = (v - knee) / (2 (1 - knee))`, whose slope is 1
/// at the knee and 0 at `v = 2 - knee`, where the code range ends. So the curve is
/// smooth, the top of the range holds the power law's `knee..2 - knee` squeezed into
/// `knee..1`, and the sensor clips at `(2 - knee)^gamma` instead of 1. A `knee` of 1 or
/// more is the plain power law.
pub(crate) fn untone(e: f32, knee: f32) -> f32 {
    if knee >= 1.0 || e <= knee {
        return e;
    }
    let u = 1.0 - ((1.0 - e.min(1.0)) / (1.0 - knee)).sqrt();
    knee + 2.0 * (1.0 - knee) * u
}

/// A small, seedable, platform-independent generator (SplitMix64, Steele, Lea and
/// Flood 2014): the same seed gives the same frame natively and in wasm, with no
/// entropy source.
pub(crate) struct SplitMix64(u64);

impl SplitMix64 {
    pub(crate) fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1].
    fn uniform_open0(&mut self) -> f64 {
        ((self.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64
    }

    /// Two independent standard normal variates (Box-Muller).
    pub(crate) fn normal_pair(&mut self) -> (f64, f64) {
        let r = (-2.0 * self.uniform_open0().ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * self.uniform_open0()).sin_cos();
        (r * c, r * s)
    }
}

/// `out_c = Σ_k m[c][k] · in_k` at every pixel.
pub(crate) fn crosstalk(img: &mut Image<Rgb>, m: &[[f32; 3]; 3]) {
    if *m == [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
        return;
    }
    for p in img.pixels_mut() {
        let x = *p;
        for c in 0..3 {
            p[c] = m[c][0] * x[0] + m[c][1] * x[1] + m[c][2] * x[2];
        }
    }
}

/// Normalized Gaussian kernel of standard deviation `sigma`, radius ⌈3σ⌉.
fn gaussian_kernel(sigma: f32) -> Vec<f32> {
    let radius = (3.0 * sigma).ceil() as usize;
    let mut k: Vec<f32> = (0..=2 * radius)
        .map(|i| {
            let x = i as f32 - radius as f32;
            (-0.5 * x * x / (sigma * sigma)).exp()
        })
        .collect();
    let sum: f32 = k.iter().sum();
    k.iter_mut().for_each(|w| *w /= sum);
    k
}

/// Separable Gaussian blur of standard deviation `sigma` pixels, edges clamped;
/// nothing happens below 0.05 px. `scratch` is resized as needed.
pub(crate) fn gaussian_blur(img: &mut Image<Rgb>, sigma: f32, scratch: &mut Vec<Rgb>) {
    if !(sigma >= 0.05) {
        return;
    }
    let kernel = gaussian_kernel(sigma);
    let radius = kernel.len() / 2;
    let (w, h) = img.size();
    scratch.clear();
    scratch.resize(w * h, [0.0; 3]);
    // Rows into scratch.
    for v in 0..h {
        let row = img.row(v);
        for u in 0..w {
            let mut acc = [0f32; 3];
            for (i, &k) in kernel.iter().enumerate() {
                let x = (u + i).saturating_sub(radius).min(w - 1);
                let p = row[x];
                for c in 0..3 {
                    acc[c] += k * p[c];
                }
            }
            scratch[v * w + u] = acc;
        }
    }
    // Columns back into the image.
    let out = img.pixels_mut();
    for v in 0..h {
        for u in 0..w {
            let mut acc = [0f32; 3];
            for (i, &k) in kernel.iter().enumerate() {
                let y = (v + i).saturating_sub(radius).min(h - 1);
                let p = scratch[y * w + u];
                for c in 0..3 {
                    acc[c] += k * p[c];
                }
            }
            out[v * w + u] = acc;
        }
    }
}

/// Steps of the quantizer's look-up from linear value to the first candidate code.
const QUANTIZE_BUCKETS: usize = 4096;

/// Gain, additive Gaussian noise (in units of full scale), clipping, encoding
/// `x^(1/gamma)` through the tone curve of `knee` ([`untone`]; 1 for none) and rounding
/// to 8 bits.
pub(crate) fn quantize(
    linear: &Image<Rgb>,
    exposure: f32,
    noise_sigma: f32,
    gamma: f32,
    knee: f32,
    seed: u64,
    out: &mut Image<[u8; 3]>,
) {
    // Code c covers the linear values whose encoding is from (c - 0.5)/255 to
    // (c + 0.5)/255; the code of x is the number of upper bounds below x (exact
    // rounding, no powf).
    let mut bounds = [0f32; 255];
    for (c, b) in bounds.iter_mut().enumerate() {
        *b = untone((c as f32 + 0.5) / 255.0, knee).powf(gamma);
    }
    // The linear signal at which the code range ends (1 without a shoulder).
    let full = untone(1.0, knee).powf(gamma);
    // The count of bounds below each of QUANTIZE_BUCKETS equal steps of 0..full, so
    // that a value's count starts from its step's and walks the few bounds inside the
    // step (the same codes as a search over all bounds, in a fraction of the time).
    let mut start = [0u8; QUANTIZE_BUCKETS + 1];
    for (k, s) in start.iter_mut().enumerate() {
        let x = full * (k as f32 / QUANTIZE_BUCKETS as f32);
        *s = bounds.partition_point(|&b| b < x) as u8;
    }
    let bucket = QUANTIZE_BUCKETS as f32 / full;
    let code = |x: f32| -> u8 {
        if !(x > 0.0) {
            // Negative, zero (no bound is below) or NaN (no bound compares below it).
            return 0;
        }
        if x >= full {
            return 255;
        }
        // Truncation is the floor for 0 < x < full. Without a shoulder `full` is 1 and
        // the bucket's start is exact; with one, rounding can put the start a hair
        // above `x`, so the walk also steps back over a bound that is not below it.
        let mut c = start[((x * bucket) as usize).min(QUANTIZE_BUCKETS)] as usize;
        while c > 0 && !(bounds[c - 1] < x) {
            c -= 1;
        }
        while c < bounds.len() && bounds[c] < x {
            c += 1;
        }
        c as u8
    };
    let mut rng = SplitMix64::new(seed);
    let mut spare: Option<f64> = None;
    let mut noise = || -> f32 {
        if noise_sigma <= 0.0 {
            return 0.0;
        }
        let z = match spare.take() {
            Some(z) => z,
            None => {
                let (a, b) = rng.normal_pair();
                spare = Some(b);
                a
            }
        };
        noise_sigma * z as f32
    };
    for (o, p) in out.pixels_mut().iter_mut().zip(linear.pixels()) {
        for c in 0..3 {
            let x = exposure * p[c] + noise();
            o[c] = code(x);
        }
    }
}

/// 4:2:0 chroma subsampling of an 8-bit (gamma-encoded) frame, in place: every pixel
/// keeps its own luma (JFIF YCbCr), and the chroma of each 2 x 2 block (a 2 x 1, 1 x 2
/// or single pixel at an odd border) is replaced by the block's mean, as a webcam's
/// YUV 4:2:0 or MJPEG stream carries it, then converted back to RGB (chroma
/// replicated over the block, no interpolation). Colour detail finer than two pixels
/// is lost; a one-pixel colour line spreads over its block.
///
/// ```
/// use stripelight::{sim, Image};
/// let mut img = Image::new(4, 2, [128u8, 128, 128]);
/// *img.get_mut(1, 0) = [255, 0, 0];
/// sim::chroma_420(&mut img);
/// let (left, right) = (img.get(0, 0), img.get(1, 0));
/// assert!(left[0] > left[1] + 20);   // the red reached its neighbour
/// assert!(right[0] < 255);           // and is diluted where it was
/// assert_eq!(img.get(2, 0), [128, 128, 128]);
/// ```
pub fn chroma_420(img: &mut Image<[u8; 3]>) {
    let (w, h) = img.size();
    for by in (0..h).step_by(2) {
        for bx in (0..w).step_by(2) {
            let (x1, y1) = ((bx + 2).min(w), (by + 2).min(h));
            let (mut cb, mut cr, mut n) = (0f32, 0f32, 0f32);
            for y in by..y1 {
                for x in bx..x1 {
                    let [_, b, r] = to_ycbcr(img.get(x, y));
                    cb += b;
                    cr += r;
                    n += 1.0;
                }
            }
            let (cb, cr) = (cb / n, cr / n);
            for y in by..y1 {
                for x in bx..x1 {
                    let luma = to_ycbcr(img.get(x, y))[0];
                    *img.get_mut(x, y) = from_ycbcr(luma, cb, cr);
                }
            }
        }
    }
}

/// The frame after a JPEG encoder of `quality` (1-100, libjpeg's scaling of the
/// standard quantization tables; the `image` crate's baseline encoder, which keeps
/// chroma at full resolution: subsample with [`chroma_420`] first for a webcam's
/// 4:2:0) and a decoder. Fails with [`Error::Scene`] when the codec does.
pub fn jpeg_round_trip(img: &Image<[u8; 3]>, quality: u8) -> Result<Image<[u8; 3]>> {
    let (w, h) = img.size();
    let flat: Vec<u8> = img.pixels().iter().flatten().copied().collect();
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, quality.clamp(1, 100))
        .encode(&flat, w as u32, h as u32, image::ExtendedColorType::Rgb8)
        .map_err(|e| Error::Scene(format!("JPEG encoding of a {w}x{h} frame failed: {e}")))?;
    let decoded = image::load_from_memory_with_format(&bytes, image::ImageFormat::Jpeg)
        .map_err(|e| Error::Scene(format!("JPEG decoding failed: {e}")))?
        .into_rgb8();
    if (decoded.width() as usize, decoded.height() as usize) != (w, h) {
        return Err(Error::Scene(format!(
            "JPEG round trip changed the size from {w}x{h} to {}x{}",
            decoded.width(),
            decoded.height()
        )));
    }
    Image::from_vec(w, h, decoded.pixels().map(|p| p.0).collect())
}
