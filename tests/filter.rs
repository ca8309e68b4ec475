//! The log-gradient filter against the paper-faithful reference and against ground
//! truth, and on degenerate input. Each test runs natively and in the browser, except
//! the two that run the slow reference or render many VGA frames (native only: in a
//! debug wasm build they take minutes).

// The helpers below serve those native-only tests too.
#![cfg_attr(target_arch = "wasm32", allow(dead_code))]

#[macro_use]
mod support;

#[cfg(target_arch = "wasm32")]
wasm_bindgen_test::wasm_bindgen_test_configure!(run_in_browser);

use stripelight::filter::{reference, FamilyWindow, LogGradFilter, Restored};
use stripelight::pattern::DEFAULT_STRIPE_WIDTH;
use stripelight::raster::{rgb8_to_linear, Image, Rgb};
use stripelight::filter::FilterMode;
use stripelight::sim::{self, Frame, Scene, SimConfig};
use stripelight::{Calibration, PatternSpec};

fn simulate(scene: &str, directions: usize) -> (PatternSpec, Frame) {
    let calib = Calibration::demo();
    let spec = PatternSpec::generate(directions, 1024, 768, DEFAULT_STRIPE_WIDTH).unwrap();
    let cfg = SimConfig { seed: 7, projector_gamma: spec.encoding_gamma as f32, ..SimConfig::default() };
    let frame = sim::render(&Scene::builtin(scene).unwrap(), &calib, &spec.render_rgb8(), &cfg).unwrap();
    (spec, frame)
}

fn linear(img: &Image<[u8; 3]>) -> Image<Rgb> {
    let mut out = Image::new(img.width(), img.height(), [0.0; 3]);
    rgb8_to_linear(img, 2.2, &mut out);
    out
}

fn crop<T: Copy>(img: &Image<T>, x0: usize, y0: usize, w: usize, h: usize) -> Image<T> {
    let data = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| img.get(x0 + x, y0 + y)).collect();
    Image::from_vec(w, h, data).unwrap()
}

/// Relative RMS difference of two planes over the interior, after removing each
/// one's mean there (both restorations lose the DC term, over different canvases).
fn relative_difference(a: &[f32], b: &[f32], w: usize, h: usize, border: usize) -> f64 {
    let idx: Vec<usize> = (border..h - border).flat_map(|y| (border..w - border).map(move |x| y * w + x)).collect();
    let mean = |p: &[f32]| idx.iter().map(|&i| p[i] as f64).sum::<f64>() / idx.len() as f64;
    let (ma, mb) = (mean(a), mean(b));
    let (mut diff, mut norm) = (0.0, 0.0);
    for &i in &idx {
        let (x, y) = (a[i] as f64 - ma, b[i] as f64 - mb);
        diff += (x - y).powi(2);
        norm += y * y;
    }
    (diff / norm).sqrt()
}

/// The fast steerable restoration reproduces the paper-faithful one at single angles.
/// They differ by the reference's two bilinear resamplings (a slight blur of the
/// rotated image), Sobel's imperfect steerability at angles between the axes, and the
/// borders (excluded here). Measured on this crop: 0.06-0.22 relative RMS at 0 and 90
/// degrees, 0.19-0.39 at 30 and 60 (steerability); the tolerances 0.3 and 0.45 sit
/// above those while a wrong filter, angle or sign gives 0.8 or more.
#[cfg(not(target_arch = "wasm32"))]
#[test]
fn fast_restoration_matches_the_reference() {
    let (_, frame) = simulate("sphere", 2);
    let (w, h) = (200, 150);
    let img = linear(&crop(&frame.image, 220, 165, w, h));
    let mut fast = LogGradFilter::new(w, h).unwrap();
    let mut out: [Vec<f32>; 3] = Default::default();
    for (deg, tolerance) in [(0.0f32, 0.3), (90.0, 0.3), (30.0, 0.45), (60.0, 0.45)] {
        let phi = deg.to_radians();
        let slow = reference::restore_at_angle(&img, phi).unwrap();
        fast.restore_at_angle(&img, phi, &mut out).unwrap();
        for ch in 0..3 {
            let d = relative_difference(&out[ch], &slow[ch], w, h, 12);
            assert!(d < tolerance, "{deg} degrees, channel {ch}: relative difference {d:.3}");
        }
        // Another angle is clearly different, so the comparison can fail.
        fast.restore_at_angle(&img, phi + std::f32::consts::FRAC_PI_2, &mut out).unwrap();
        let d = relative_difference(&out[0], &slow[0], w, h, 12);
        assert!(d > 0.8, "{deg} degrees against its perpendicular: {d:.3}");
    }
}

/// Per-pixel stripe colour classification (the paper's hue thresholding): a channel
/// is "high" where it is at least `threshold` of the pixel's brightest channel.
fn classify(v: [f32; 3]) -> [bool; 3] {
    let m = v[0].max(v[1]).max(v[2]).max(1e-6);
    // Halfway (in log) between the palette's low level 0.25 and 1.
    v.map(|c| c / m > 0.5)
}

/// Fraction of lit pixels away from stripe edges whose projected stripe colour (known
/// from ground truth) is classified right from `colour(i)`.
fn classification_rate(spec: &PatternSpec, frame: &Frame, colour: impl Fn(usize) -> [f32; 3]) -> f64 {
    let (a, b, c) = spec.families[0].stripe_coord(spec.width, spec.height);
    let (mut right, mut total) = (0usize, 0usize);
    for (i, p) in frame.projector.pixels().iter().enumerate() {
        if !frame.lit.pixels()[i] {
            continue;
        }
        let q = a * p[0] as f64 + b * p[1] as f64 + c;
        // Away from the boundaries (a third of a stripe), where the colour is defined.
        if (q - q.round()).abs() < 0.35 {
            continue;
        }
        let truth = spec.stripe_color(0, q.floor() as i64).map(|x| x > 0.5);
        total += 1;
        right += (classify(colour(i)) == truth) as usize;
    }
    right as f64 / total as f64
}

/// The paper's claim for the filter: on coloured surfaces the restored image shows the
/// projected stripe colour more often than the captured colour does (hue thresholding
/// of each pixel, no neighbourhood). Asserted on the two scenes with large colour
/// patches; the sphere is printed but not asserted (see the figures below).
#[cfg(not(target_arch = "wasm32"))]
#[test]
fn restoration_recovers_stripe_colours_on_coloured_surfaces() {
    for scene in ["paper", "textured", "sphere"] {
        let (spec, frame) = simulate(scene, 1);
        let img = linear(&frame.image);
        let (w, h) = img.size();
        let mut filter = LogGradFilter::new(w, h).unwrap();
        let windows = FamilyWindow::for_families(&[0.0]);
        let mut restored = vec![Restored::new(w, h)];
        filter.run(&img, &windows, FilterMode::LogGrad, &mut restored).unwrap();
        let raw = classification_rate(&spec, &frame, |i| img.pixels()[i]);
        let rest = classification_rate(&spec, &frame, |i| [0, 1, 2].map(|ch| restored[0].log[ch][i].exp()));
        eprintln!("{scene}: stripe colour right at {:.1}% of pixels raw, {:.1}% restored", 100.0 * raw, 100.0 * rest);
        // Measured (seed 7): paper 32 % raw vs 47 % restored, textured 57 % vs 69 %,
        // sphere 72 % vs 69 % (its saturated squares are small and sit on a sphere
        // whose shading changes across stripes as fast as the stripes do).
        if scene != "sphere" {
            assert!(rest > raw + 0.08, "{scene}: raw {raw:.3}, restored {rest:.3}");
        }
    }
}

both_targets! {
/// Degenerate frames give defined, finite results (or a clear error), never NaN or a
/// panic.
fn degenerate_frames_give_finite_results() {
    let (w, h) = (37, 23); // odd sizes
    let mut filter = LogGradFilter::new(w, h).unwrap();
    let windows = FamilyWindow::for_families(&[0.0, std::f32::consts::FRAC_PI_2]);
    for value in [[0.0f32; 3], [1.0; 3], [0.3, 0.2, 0.1]] {
        let img = Image::new(w, h, value);
        for mode in [FilterMode::LogGrad, FilterMode::LogGradNoRotation, FilterMode::Direct] {
            let mut out = vec![Restored::new(w, h), Restored::new(w, h)];
            filter.run(&img, &windows, mode, &mut out).unwrap();
            for r in &out {
                assert!(r.log.iter().flatten().all(|v| v.is_finite()), "{value:?} {mode:?}");
                assert!(r.angle.iter().all(|v| v.is_finite()));
                if mode != FilterMode::Direct {
                    // A uniform image has no stripes: the restoration is flat.
                    assert!(r.log.iter().flatten().all(|v| v.abs() < 1e-3), "{value:?} {mode:?}");
                }
            }
        }
    }
    let err = LogGradFilter::new(4, 100).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(err.contains("too small"), "{err}");
    assert!(reference::restore_at_angle(&Image::new(3, 3, [0.5; 3]), 0.0).is_err());
    // A frame of the wrong size is refused.
    let mut out = vec![Restored::new(w, h)];
    let bad = Image::new(w + 1, h, [0.5; 3]);
    assert!(filter.run(&bad, &windows[..1], FilterMode::LogGrad, &mut out).is_err());
}
}

/// A frame restored in overlapping tiles (as large frames are) matches the frame
/// restored whole: the restored log gradients (what segmentation reads) differ little,
/// seams included, and the per-pixel angles agree almost everywhere. Small tiles on a
/// VGA frame, so that many seams cross the sphere. Measured: 0.07 relative RMS
/// difference (0.11 within 8 pixels of a seam, 0.05 further), the same angle at 99.9 %
/// of the pixels; tiles blended without their overlap, or restored without context,
/// differ far more at their seams.
#[cfg(not(target_arch = "wasm32"))]
#[test]
fn tiled_restoration_matches_the_whole_frame() {
    let (_, frame) = simulate("sphere", 2);
    let img = linear(&frame.image);
    let (w, h) = img.size();
    let windows = FamilyWindow::for_families(&[0.0, std::f32::consts::FRAC_PI_2]);
    let restore = |mut filter: LogGradFilter| {
        let mut out = vec![Restored::new(w, h), Restored::new(w, h)];
        filter.run(&img, &windows, FilterMode::LogGrad, &mut out).unwrap();
        out
    };
    let whole = restore(LogGradFilter::new(w, h).unwrap());
    let tiled_filter = LogGradFilter::tiled(w, h, 6.5, 260).unwrap();
    assert!(tiled_filter.tile_count() >= 12, "{} tiles", tiled_filter.tile_count());
    let tiled = restore(tiled_filter);
    let border = 8;
    for (k, (a, b)) in tiled.iter().zip(&whole).enumerate() {
        assert!((a.dominant - b.dominant).abs() < 0.02, "family {k}: dominant {} vs {}", a.dominant, b.dominant);
        let (mut diff, mut norm) = (0.0f64, 0.0f64);
        for ch in 0..3 {
            let (pa, pb) = (&a.log[ch], &b.log[ch]);
            for y in border..h - border {
                for x in border..w - border {
                    let i = y * w + x;
                    for step in [1, w] {
                        let (ga, gb) = (pa[i + step] - pa[i - step], pb[i + step] - pb[i - step]);
                        diff += ((ga - gb) as f64).powi(2);
                        norm += (gb as f64).powi(2);
                    }
                }
            }
        }
        let rel = (diff / norm).sqrt();
        let same = a.angle.iter().zip(&b.angle).filter(|(x, y)| (*x - *y).abs() < 0.02).count() as f64 / (w * h) as f64;
        eprintln!("family {k}: relative RMS gradient difference {rel:.4}, same angle at {:.1} % of pixels", 100.0 * same);
        assert!(rel < 0.1, "family {k}: relative gradient difference {rel:.4}");
        assert!(same > 0.95, "family {k}: same angle at {same:.3}");
    }
}

both_targets! {
/// The box filter (the per-pixel angle criterion's smoothing) equals the mean over the
/// window with clamped borders, on planes narrower, shorter and larger than the window.
fn box_filter_matches_a_clamped_window_mean() {
    use stripelight::filter::box_filter_into;
    for (w, h, r) in [(1, 1, 2), (5, 3, 4), (17, 11, 3), (40, 29, 6)] {
        let src: Vec<f32> = (0..w * h).map(|i| ((i * 7919 % 101) as f32 - 50.0) * 0.37).collect();
        let (mut dst, mut tmp) = (vec![f32::NAN; w * h], vec![0.0; w * h]);
        box_filter_into(&src, &mut dst, &mut tmp, w, h, r);
        let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
        for y in 0..h {
            for x in 0..w {
                let mut sum = 0.0f64;
                for dy in -(r as isize)..=r as isize {
                    for dx in -(r as isize)..=r as isize {
                        sum += src[clamp(y as isize + dy, h) * w + clamp(x as isize + dx, w)] as f64;
                    }
                }
                let want = sum / ((2 * r + 1) * (2 * r + 1)) as f64;
                let got = dst[y * w + x] as f64;
                assert!((got - want).abs() < 1e-3, "{w}x{h} r={r} at ({x}, {y}): {got} vs {want}");
            }
        }
    }
}
}
