//! The camera after the lens: colour crosstalk, defocus blur, gain, sensor noise,
//! gamma encoding and 8-bit quantization. All operations before the noise are linear,
//! so their order among themselves does not matter.

use crate::raster::{Image, Rgb};

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

/// Gain, additive Gaussian noise (in units of full scale), clipping to 0..1, encoding
/// `x^(1/gamma)` and rounding to 8 bits.
pub(crate) fn quantize(
    linear: &Image<Rgb>,
    exposure: f32,
    noise_sigma: f32,
    gamma: f32,
    seed: u64,
    out: &mut Image<[u8; 3]>,
) {
    // Code c covers linear values from ((c - 0.5)/255)^gamma to ((c + 0.5)/255)^gamma;
    // the code of x is the number of upper bounds below x (exact rounding, no powf).
    let mut bounds = [0f32; 255];
    for (c, b) in bounds.iter_mut().enumerate() {
        *b = ((c as f32 + 0.5) / 255.0).powf(gamma);
    }
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
            o[c] = bounds.partition_point(|&b| b < x) as u8;
        }
    }
}
