//! A planned 2-D real FFT of one image size, with every buffer made once.
//!
//! Layout: the spectrum of a `width` x `height` real image holds `width / 2 + 1`
//! columns of `height` complex values each, stored **column by column**
//! (`spectrum[k * height + y]` is horizontal frequency `k`, vertical frequency `y`),
//! so that the vertical transforms run on contiguous memory.
//!
//! Normalization: neither direction scales (RustFFT's convention), so
//! `inverse(forward(x)) = width · height · x`; callers fold `1 / (width · height)` into
//! their frequency-domain filters.

use crate::error::{Error, Result};
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex32;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// Forward and inverse 2-D real transforms for one size.
pub struct Fft2 {
    width: usize,
    height: usize,
    row_forward: Arc<dyn RealToComplex<f32>>,
    row_inverse: Arc<dyn ComplexToReal<f32>>,
    col_forward: Arc<dyn Fft<f32>>,
    col_inverse: Arc<dyn Fft<f32>>,
    row_real: Vec<f32>,
    /// [`BLOCK_ROWS`] rows' spectra, row after row, between the row transforms and the
    /// column-major spectrum.
    block: Vec<Complex32>,
    scratch: Vec<Complex32>,
}

/// Rows transformed before their spectra are moved into the column-major layout: each
/// column then receives this many consecutive values at once (a whole cache line at
/// 8), instead of one value per row at a stride of the whole column.
const BLOCK_ROWS: usize = 8;

impl Fft2 {
    /// Plan transforms for `width` x `height` images (both at least 1).
    pub fn new(width: usize, height: usize) -> Self {
        let mut real = RealFftPlanner::<f32>::new();
        let mut complex = FftPlanner::<f32>::new();
        let row_forward = real.plan_fft_forward(width);
        let row_inverse = real.plan_fft_inverse(width);
        let col_forward = complex.plan_fft_forward(height);
        let col_inverse = complex.plan_fft_inverse(height);
        let scratch_len = [
            row_forward.get_scratch_len(),
            row_inverse.get_scratch_len(),
            col_forward.get_inplace_scratch_len(),
            col_inverse.get_inplace_scratch_len(),
        ]
        .into_iter()
        .max()
        .unwrap_or(0);
        Fft2 {
            width,
            height,
            row_forward,
            row_inverse,
            col_forward,
            col_inverse,
            row_real: vec![0.0; width],
            block: vec![Complex32::new(0.0, 0.0); BLOCK_ROWS * (width / 2 + 1)],
            scratch: vec![Complex32::new(0.0, 0.0); scratch_len],
        }
    }

    /// The image height the transforms were planned for.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Number of complex values in a spectrum: `(width / 2 + 1) * height`.
    pub fn spectrum_len(&self) -> usize {
        (self.width / 2 + 1) * self.height
    }

    /// Forward transform of a row-major real image into a column-major spectrum.
    pub fn forward(&mut self, image: &[f32], spectrum: &mut [Complex32]) -> Result<()> {
        let (w, h) = (self.width, self.height);
        debug_assert_eq!(image.len(), w * h);
        debug_assert_eq!(spectrum.len(), self.spectrum_len());
        let nk = w / 2 + 1;
        for y0 in (0..h).step_by(BLOCK_ROWS) {
            let rows = BLOCK_ROWS.min(h - y0);
            for (r, out) in self.block.chunks_exact_mut(nk).take(rows).enumerate() {
                let y = y0 + r;
                self.row_real.copy_from_slice(&image[y * w..(y + 1) * w]);
                self.row_forward.process_with_scratch(&mut self.row_real, out, &mut self.scratch).map_err(fft_error)?;
            }
            for (k, column) in spectrum.chunks_exact_mut(h).enumerate() {
                for (r, c) in column[y0..y0 + rows].iter_mut().enumerate() {
                    *c = self.block[r * nk + k];
                }
            }
        }
        // All columns at once: RustFFT transforms each `height`-long chunk.
        self.col_forward.process_with_scratch(spectrum, &mut self.scratch);
        Ok(())
    }

    /// Inverse transform of a column-major spectrum (destroyed) into a row-major real
    /// image, unscaled.
    pub fn inverse(&mut self, spectrum: &mut [Complex32], image: &mut [f32]) -> Result<()> {
        let (w, h) = (self.width, self.height);
        debug_assert_eq!(image.len(), w * h);
        self.col_inverse.process_with_scratch(spectrum, &mut self.scratch);
        let nk = w / 2 + 1;
        for y0 in (0..h).step_by(BLOCK_ROWS) {
            let rows = BLOCK_ROWS.min(h - y0);
            for (k, column) in spectrum.chunks_exact(h).enumerate() {
                for (r, &c) in column[y0..y0 + rows].iter().enumerate() {
                    self.block[r * nk + k] = c;
                }
            }
            for (r, row) in self.block.chunks_exact_mut(nk).take(rows).enumerate() {
                // A real row's DC (and, for even widths, Nyquist) bin is real; rounding
                // leaves tiny imaginary parts there, which realfft would report.
                row[0].im = 0.0;
                if w % 2 == 0 {
                    row[w / 2].im = 0.0;
                }
                let y = y0 + r;
                self.row_inverse.process_with_scratch(row, &mut image[y * w..(y + 1) * w], &mut self.scratch).map_err(fft_error)?;
            }
        }
        Ok(())
    }
}

fn fft_error(e: realfft::FftError) -> Error {
    Error::Internal(format!("FFT: {e}"))
}

/// The transform length of at least `min` (even, with no prime factor above 7: RustFFT
/// has butterflies for 2, 3, 5 and 7) that is cheapest by a simple cost model, the
/// length times `1 + ODD_FACTOR_COST` per odd prime factor (with multiplicity), among
/// the lengths at most `MAX_SIZE_GROWTH` above the smallest such length (the planes
/// and the memory grow with the length).
///
/// The smallest such length is not always the fastest: in WebAssembly, one forward and
/// one inverse transform of 672 x 504 took 2.4-2.5 ms, of 672 x 512 2.0-2.2 ms
/// (504 = 2³·3²·7, 512 = 2⁹), while 700, 750 and 756 wide (two or three odd factors,
/// few twos) took 3-3.9 ms against about 2 ms for 672 and 768 (fastest of 80 each, the
/// 2-D transform of [`Fft2`]).
pub fn fast_size(min: usize) -> usize {
    let odd_factors = |n: usize| -> Option<usize> {
        if n % 2 != 0 {
            return None;
        }
        let (mut m, mut odd) = (n, 0);
        while m % 2 == 0 {
            m /= 2;
        }
        for p in [3, 5, 7] {
            while m % p == 0 {
                m /= p;
                odd += 1;
            }
        }
        (m == 1).then_some(odd)
    };
    // A power of two at least `min` always qualifies and bounds the search.
    let min = min.max(2);
    let smallest = (min..=min.next_power_of_two()).find(|&n| odd_factors(n).is_some()).unwrap_or(min.next_power_of_two());
    let limit = (smallest as f64 * (1.0 + MAX_SIZE_GROWTH)) as usize;
    let cost = |n: usize| Some((n, n as f64 * (1.0 + ODD_FACTOR_COST * odd_factors(n)? as f64)));
    // The first of equally cheap lengths, so the shorter.
    (smallest..=limit).filter_map(cost).min_by(|a, b| a.1.total_cmp(&b.1)).map_or(smallest, |(n, _)| n)
}

/// How much longer than the smallest fast length [`fast_size`] may choose, as a
/// fraction: enough for 504 -> 512 (VGA's height), not for 840 -> 1024 (the tiles of
/// large frames, whose memory counts).
const MAX_SIZE_GROWTH: f64 = 0.05;

/// The extra cost of a transform length per odd prime factor, relative to a power of
/// two (see [`fast_size`]).
const ODD_FACTOR_COST: f64 = 0.15;

#[cfg(test)]
mod tests {
    use super::*;

    /// The forward transform equals a naive 2-D DFT, and inverse(forward(x)) = N x.
    #[test]
    fn matches_a_naive_dft() {
        for (w, h) in [(6, 5), (8, 4), (7, 9)] {
            let img: Vec<f32> = (0..w * h).map(|i| ((i * 37 % 11) as f32 - 5.0) * 0.3 + (i as f32 * 0.7).sin()).collect();
            let mut fft = Fft2::new(w, h);
            let mut spec = vec![Complex32::new(0.0, 0.0); fft.spectrum_len()];
            fft.forward(&img, &mut spec).unwrap();
            for k in 0..w / 2 + 1 {
                for l in 0..h {
                    let mut sum = (0.0f64, 0.0f64);
                    for y in 0..h {
                        for x in 0..w {
                            let ang = -2.0 * std::f64::consts::PI * (k as f64 * x as f64 / w as f64 + l as f64 * y as f64 / h as f64);
                            let v = img[y * w + x] as f64;
                            sum.0 += v * ang.cos();
                            sum.1 += v * ang.sin();
                        }
                    }
                    let got = spec[k * h + l];
                    assert!((got.re as f64 - sum.0).abs() < 1e-3 && (got.im as f64 - sum.1).abs() < 1e-3, "{w}x{h} ({k},{l}): {got} vs {sum:?}");
                }
            }
            let mut back = vec![0.0; w * h];
            fft.inverse(&mut spec, &mut back).unwrap();
            for (a, b) in img.iter().zip(&back) {
                assert!((a * (w * h) as f32 - b).abs() < 1e-3);
            }
        }
    }

    #[test]
    fn fast_sizes_are_even_and_smooth() {
        // VGA with the filter's padding: 664 x 504 becomes 672 x 512 (504 = 2³·3²·7
        // costs more than 512).
        assert_eq!(fast_size(664), 672);
        assert_eq!(fast_size(504), 512);
        assert_eq!(fast_size(511), 512);
        assert_eq!(fast_size(1), 2);
        // A large frame's tile (800 + 24) keeps 840 rather than 1024.
        assert_eq!(fast_size(824), 840);
        for min in 1..3000 {
            let n = fast_size(min);
            let mut m = n;
            for p in [2, 3, 5, 7] {
                while m % p == 0 {
                    m /= p;
                }
            }
            assert!(n >= min && n % 2 == 0 && m == 1 && n <= min.next_power_of_two().max(2), "{min} -> {n}");
            assert!(n as f64 <= 1.05 * (min..).find(|&k| k % 2 == 0 && { let mut m = k; for p in [2, 3, 5, 7] { while m % p == 0 { m /= p; } } m == 1 }).unwrap() as f64, "{min} -> {n}");
        }
    }
}
