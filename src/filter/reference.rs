//! The paper's restoration to the letter (eq. 5-8), for tests and teaching.
//!
//! For each angle φ: rotate the image by φ onto a square canvas that holds all of it
//! (bilinear, edge pixels repeated outside), take `ln(max(I, LOG_FLOOR))`, apply the
//! Sobel x-derivative in space (eq. 5), restore in the frequency domain with
//! `F(Dxʳ * i_x) / F(Dxʳ * Dx + Dyʳ * Dy)` (eq. 6; the division is done with the
//! known Sobel responses, 0 where the denominator vanishes), exponentiate and rotate
//! back (eq. 7). Per pixel the angle with the largest gradient magnitude of the
//! restored image wins (eq. 8), within each family's window (section 4). It allocates
//! freely and re-plans per call: it is the yardstick, not the product.

use super::fft2::{fast_size, Fft2};
use super::{angle_diff, log_plane_into, pad_into, FamilyWindow, Restored, MIN_SIZE, PAD_MIN, PAPER_ANGLES_DEG};
use crate::error::{Error, Result};
use crate::raster::{Image, Rgb};
use rustfft::num_complex::Complex32;

/// Bilinear sample of a `w` x `h` plane at (x, y), coordinates clamped to the image.
fn sample(plane: &[f32], w: usize, h: usize, x: f32, y: f32) -> f32 {
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let top = plane[y0 * w + x0] * (1.0 - fx) + plane[y0 * w + x1] * fx;
    let bottom = plane[y1 * w + x0] * (1.0 - fx) + plane[y1 * w + x1] * fx;
    top * (1.0 - fy) + bottom * fy
}

/// The restored image `Ĩ^φ` (eq. 7) of every channel, as the log `ln Ĩ^φ`, in the
/// original image's frame. `phi` is the normal angle across the stripes, radians.
pub fn restore_at_angle(linear: &Image<Rgb>, phi: f32) -> Result<[Vec<f32>; 3]> {
    let (w, h) = linear.size();
    if w < MIN_SIZE || h < MIN_SIZE {
        return Err(Error::ImageTooSmall { min: (MIN_SIZE, MIN_SIZE), got: (w, h) });
    }
    let side = ((w * w + h * h) as f32).sqrt().ceil() as usize + 4;
    let padded = fast_size(side + PAD_MIN);
    let (cs, sn) = (phi.cos(), phi.sin());
    let (ox, oy) = ((w as f32 - 1.0) / 2.0, (h as f32 - 1.0) / 2.0);
    let oc = (side as f32 - 1.0) / 2.0;
    let mut fft = Fft2::new(padded, padded);
    let mut spectrum = vec![Complex32::new(0.0, 0.0); fft.spectrum_len()];
    let mut out: [Vec<f32>; 3] = [vec![0.0; w * h], vec![0.0; w * h], vec![0.0; w * h]];
    let mut plane = vec![0.0; w * h];
    let mut canvas = vec![0.0; side * side];
    let mut buf = vec![0.0; padded * padded];
    let mut ix = vec![0.0; padded * padded];
    for ch in 0..3 {
        // R_φ(I): canvas axis x runs along (cos φ, sin φ) of the original image.
        for (i, p) in plane.iter_mut().zip(linear.pixels()) {
            *i = p[ch];
        }
        for yc in 0..side {
            for xc in 0..side {
                let (dx, dy) = (xc as f32 - oc, yc as f32 - oc);
                let x = ox + dx * cs - dy * sn;
                let y = oy + dx * sn + dy * cs;
                canvas[yc * side + xc] = sample(&plane, w, h, x, y);
            }
        }
        // ln, then periodic-friendly padding.
        let img = Image::from_vec(side, side, canvas.iter().map(|&v| [v, v, v]).collect())?;
        let mut logc = vec![0.0; side * side];
        log_plane_into(&img, 0, &mut logc);
        pad_into(&logc, side, side, &mut buf, padded, padded);
        // Eq. 5: i_x = Dx * ln R_φ(I), Sobel x (1/8 [-1 0 1; -2 0 2; -1 0 1]) with the
        // periodic boundary the FFT assumes.
        let n = padded;
        for y in 0..n {
            let (ym, yp) = ((y + n - 1) % n, (y + 1) % n);
            for x in 0..n {
                let (xm, xp) = ((x + n - 1) % n, (x + 1) % n);
                let d = |yy: usize| buf[yy * n + xp] - buf[yy * n + xm];
                ix[y * n + x] = (d(ym) + 2.0 * d(y) + d(yp)) / 8.0;
            }
        }
        // Eq. 6: F(Dxʳ * i_x) / F(Σ_d Ddʳ * Dd). With i_x(x) = Σ k(j) f(x + j), the
        // Sobel response is Dx = i sin ωx (1 + cos ωy)/2 and Dxʳ's is its conjugate.
        fft.forward(&ix, &mut spectrum)?;
        let scale = 1.0 / (n * n) as f64;
        for k in 0..n / 2 + 1 {
            let wx = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
            for l in 0..n {
                let wy = 2.0 * std::f64::consts::PI * l as f64 / n as f64;
                let (sx, cx) = wx.sin_cos();
                let (sy, cy) = wy.sin_cos();
                let dx_im = sx * (1.0 + cy) / 2.0;
                let dy_im = sy * (1.0 + cx) / 2.0;
                let den = dx_im * dx_im + dy_im * dy_im;
                let s = &mut spectrum[k * n + l];
                if den > 1e-12 {
                    // conj(Dx) = -i·dx_im
                    let f = Complex32::new(0.0, (-dx_im / den * scale) as f32);
                    *s *= f;
                } else {
                    *s = Complex32::new(0.0, 0.0);
                }
            }
        }
        fft.inverse(&mut spectrum, &mut buf)?;
        // Eq. 7: exp, then rotate back by -φ (sample the canvas at each original pixel).
        for y in 0..side {
            for x in 0..side {
                canvas[y * side + x] = buf[y * n + x].exp();
            }
        }
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = (x as f32 - ox, y as f32 - oy);
                let xc = oc + dx * cs + dy * sn;
                let yc = oc - dx * sn + dy * cs;
                out[ch][y * w + x] = sample(&canvas, side, side, xc, yc).ln();
            }
        }
    }
    Ok(out)
}

/// Gradient magnitude of the linear restored image `exp(log)` summed over channels
/// (eq. 8's criterion), central differences, clamped borders.
fn gradient_magnitude(log: &[Vec<f32>; 3], w: usize, h: usize) -> Vec<f32> {
    let mut g = vec![0.0; w * h];
    for plane in log {
        let lin: Vec<f32> = plane.iter().map(|v| v.exp()).collect();
        for y in 0..h {
            let (ym, yp) = (y.saturating_sub(1), (y + 1).min(h - 1));
            for x in 0..w {
                let (xm, xp) = (x.saturating_sub(1), (x + 1).min(w - 1));
                let gx = (lin[y * w + xp] - lin[y * w + xm]) / 2.0;
                let gy = (lin[yp * w + x] - lin[ym * w + x]) / 2.0;
                g[y * w + x] += gx * gx + gy * gy;
            }
        }
    }
    g.iter_mut().for_each(|v| *v = v.sqrt());
    g
}

/// The reference restoration of every family: the 17 paper angles, the dominant angle
/// of each family (the paper angle in its window with the largest total gradient
/// magnitude) and per pixel the best angle within the window around it (eq. 8).
/// With `per_pixel == false` every pixel takes the dominant angle (Fig. 4(b) style).
pub fn restore(linear: &Image<Rgb>, windows: &[FamilyWindow], per_pixel: bool) -> Result<Vec<Restored>> {
    let (w, h) = linear.size();
    let angles: Vec<f32> = PAPER_ANGLES_DEG.iter().map(|d| d.to_radians()).collect();
    let mut logs = Vec::with_capacity(angles.len());
    let mut mags = Vec::with_capacity(angles.len());
    for &a in &angles {
        let log = restore_at_angle(linear, a)?;
        mags.push(gradient_magnitude(&log, w, h));
        logs.push(log);
    }
    let totals: Vec<f64> = mags.iter().map(|m| m.iter().map(|&v| v as f64).sum()).collect();
    let mut out = Vec::with_capacity(windows.len());
    for win in windows {
        let in_window = |a: f32, centre: f32| angle_diff(a, centre).abs() <= win.half_width + 1e-4;
        let dominant_idx = (0..angles.len())
            .filter(|&k| in_window(angles[k], win.expected))
            .max_by(|&a, &b| totals[a].total_cmp(&totals[b]))
            .unwrap_or(0);
        let dominant = angles[dominant_idx];
        let candidates: Vec<usize> = (0..angles.len()).filter(|&k| in_window(angles[k], dominant)).collect();
        let mut r = Restored::new(w, h);
        r.dominant = dominant;
        for i in 0..w * h {
            let k = if per_pixel {
                candidates.iter().copied().max_by(|&a, &b| mags[a][i].total_cmp(&mags[b][i])).unwrap_or(dominant_idx)
            } else {
                dominant_idx
            };
            r.angle[i] = angles[k];
            for ch in 0..3 {
                r.log[ch][i] = logs[k][ch][i];
            }
        }
        out.push(r);
    }
    Ok(out)
}
