//! Native and WebAssembly give the same cloud for the same frame.
//!
//! The stored frame `tests/data/sphere2.png` (the simulator's sphere under
//! `tests/data/pattern2.json` on the demo rig, see `tests/scan.rs`) is scanned with the
//! default `loggrad` filter and the simulator's colour mixing, on whichever target runs
//! the test, and compared with `tests/data/sphere2-scan.pfm`: the depth map the native
//! build produced. The same test runs natively (`cargo test --test parity`) and in
//! headless Chromium (`cargo test --target wasm32-unknown-unknown --test parity`), so
//! both targets are held to the same reference.
//!
//! **Tolerance.** The two targets run the same Rust code, but not the same floating
//! point below it: `powf`, `exp`, `ln`, `atan2` and `sin_cos` come from the system libm
//! natively and from Rust's own `libm` port in WebAssembly (each within an ulp or so of
//! the true value, not always the same ulp), and RustFFT runs its AVX/SSE kernels
//! natively and its `simd128` kernels in WebAssembly, which sum in another order. Both
//! give relative differences of about 1e-7 in the restored images. Such a difference
//! can tip a threshold decision (a boundary kept or not, a window's vote) for a pixel
//! that sits right at the threshold. The filter's per-cell angle choice (one of the
//! paper's angles per 2x2 cell, `filter::ANGLE_STEP`) is such a decision too: where two
//! angles' criteria tie, a flip restores the cell's few pixels at the neighbouring
//! angle, which moves a boundary there by a fraction of a pixel. So
//! - pixels decided differently, decoded on one side only or decoded on both with depths
//!   more than [`MAX_DEPTH_DIFFERENCE_MM`] (0.01 mm) apart, may be at most
//!   [`MAX_DIFFERENT_PIXELS`] (0.1 %) of the reference's decoded pixels;
//! - even there depths differ by at most [`MAX_FLIPPED_DEPTH_MM`] (1.2 mm, half a
//!   projector pixel of stripe coordinate): a sub-pixel shift, never another stripe's
//!   identity (a whole stripe is 8 projector pixels, about 19 mm);
//! - everywhere else depths differ by at most 0.01 mm.
//!   Depth moves about 2.4 mm per projector pixel of stripe coordinate on this rig
//!   (z²/(f·b) = 750²/(1150·200)), so 0.01 mm allows a sub-pixel boundary to move by
//!   4e-3 projector pixels, far more than 1e-7 relative differences move it, and far
//!   less than a real change of the pipeline moves it. (An f32 depth near 750 mm has a
//!   resolution of 6e-5 mm.)
//!
//! Measured when the reference was first made (full-resolution angle choice): the
//! browser decoded the same 239 255 pixels as the native build, with depths at most
//! 7.9e-4 mm apart. With the per-cell angle choice: the same 241 558 pixels, 22 of them
//! (0.009 %) more than 0.01 mm apart, by up to 0.79 mm, all others within 0.01 mm.
//!
//! Every cloud point is its depth map pixel's camera ray times its depth (checked
//! below), so the clouds agree as the depth maps do: |Δx|, |Δy| ≤ 0.42 · 0.01 mm (the
//! largest |x/z| of the demo camera is 320/760).
//!
//! **Regenerating the reference** after a deliberate change to the pipeline (the
//! decoder, the filter, the merge): run
//!
//! ```text
//! STRIPELIGHT_REGENERATE=1 cargo test --test parity
//! ```
//!
//! natively; it writes `tests/data/sphere2-scan.pfm` from the native scan and says so
//! on stderr. Then run the browser test to see that WebAssembly still agrees. Without
//! the variable (and always in the browser) the test compares and fails on any
//! difference beyond the tolerance.

#[macro_use]
mod support;

#[cfg(target_arch = "wasm32")]
wasm_bindgen_test::wasm_bindgen_test_configure!(run_in_browser);

use stripelight::scan::{ScanConfig, Scanner};
use stripelight::sim::SimConfig;
use stripelight::{io, Calibration, Image, PatternSpec};

const FRAME: &[u8] = include_bytes!("data/sphere2.png");
const SPEC: &str = include_str!("data/pattern2.json");
/// The native scan of `FRAME`: depth in mm, NaN where nothing decoded.
const REFERENCE: &[u8] = include_bytes!("data/sphere2-scan.pfm");

/// Largest share of the reference's decoded pixels that may be decided differently
/// (decoded on one target only, or with depths beyond [`MAX_DEPTH_DIFFERENCE_MM`]).
const MAX_DIFFERENT_PIXELS: f64 = 0.001;
/// Largest depth difference of a pixel decided the same way on both targets, mm.
const MAX_DEPTH_DIFFERENCE_MM: f32 = 0.01;
/// Largest depth difference of any pixel both decode, mm: half a projector pixel of
/// stripe coordinate on this rig (about 2.4 mm per projector pixel).
const MAX_FLIPPED_DEPTH_MM: f32 = 1.2;
/// Least share of the frame's pixels the reference decodes: a reference that decodes
/// nothing would make any scan that decodes nothing "agree".
const MIN_REFERENCE_COVERAGE: f64 = 0.2;

/// One line to the test output, past the native harness's capture.
fn report(line: &str) {
    #[cfg(not(target_arch = "wasm32"))]
    {
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "{line}");
    }
    #[cfg(target_arch = "wasm32")]
    wasm_bindgen_test::console_log!("{}", line);
}

/// The reference, or on request (natively) the scan written as the new reference.
fn reference(depth: &Image<f32>) -> Image<f32> {
    #[cfg(not(target_arch = "wasm32"))]
    if std::env::var_os("STRIPELIGHT_REGENERATE").is_some() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/sphere2-scan.pfm");
        io::write_file(&path, &io::encode_pfm(depth)).unwrap();
        report(&format!("STRIPELIGHT_REGENERATE: wrote {}", path.display()));
        return io::decode_pfm(&std::fs::read(&path).unwrap()).unwrap();
    }
    let _ = depth;
    io::decode_pfm(REFERENCE).expect("tests/data/sphere2-scan.pfm is a PFM")
}

both_targets! {
/// The stored frame's depth and cloud on this target agree with the native reference
/// within the tolerance of the module docs.
fn this_target_scans_the_stored_frame_as_the_native_build_did() {
    let spec = PatternSpec::from_json(SPEC).unwrap();
    let calib = Calibration::demo();
    let frame = io::decode_rgb8(FRAME).unwrap();
    let config = ScanConfig { crosstalk: SimConfig::default().crosstalk, ..ScanConfig::default() };
    let mut scanner = Scanner::new(spec, calib.clone(), config).unwrap();
    let result = scanner.scan(&frame).unwrap();
    let depth = &result.depth;
    let reference = reference(depth);
    assert_eq!(reference.size(), depth.size(), "the reference is not of the frame's size");

    let (mut decoded_ref, mut decoded, mut only_one, mut max_dz, mut beyond) = (0usize, 0usize, 0usize, 0f32, 0usize);
    let mut worst = None;
    for (i, (&z, &r)) in depth.pixels().iter().zip(reference.pixels()).enumerate() {
        decoded_ref += !r.is_nan() as usize;
        decoded += !z.is_nan() as usize;
        match (z.is_nan(), r.is_nan()) {
            (true, true) => {}
            (false, false) => {
                let dz = (z - r).abs();
                beyond += !(dz <= MAX_DEPTH_DIFFERENCE_MM) as usize;
                if !(dz <= max_dz) {
                    (max_dz, worst) = (dz, Some(i));
                }
            }
            _ => only_one += 1,
        }
    }
    let (w, _) = depth.size();
    report(&format!(
        "parity: {decoded} pixels decoded here, {decoded_ref} in the native reference, {only_one} in one only, \
         largest depth difference {max_dz:.2e} mm (at pixel {:?}), {beyond} pixels beyond the tolerance",
        worst.map(|i| (i % w, i / w))
    ));
    let pixels = depth.pixels().len() as f64;
    assert!(decoded_ref as f64 >= MIN_REFERENCE_COVERAGE * pixels, "the reference decodes only {decoded_ref} pixels");
    assert!(
        (only_one + beyond) as f64 <= MAX_DIFFERENT_PIXELS * decoded_ref as f64,
        "{only_one} pixels decode on one side only and {beyond} differ by more than {MAX_DEPTH_DIFFERENCE_MM} mm \
         (at most {:.0} in all allowed)",
        MAX_DIFFERENT_PIXELS * decoded_ref as f64
    );
    assert!(max_dz <= MAX_FLIPPED_DEPTH_MM, "depths differ by up to {max_dz} mm at pixel {:?}", worst.map(|i| (i % w, i / w)));

    // The cloud is the depth map: each point is its pixel's ray times its depth, with its
    // pixel's colour, and every decoded pixel has its point.
    let cloud = &result.cloud;
    assert_eq!(cloud.len(), decoded);
    for i in 0..cloud.len() {
        let (u, v) = (cloud.pixels[2 * i] as usize, cloud.pixels[2 * i + 1] as usize);
        let z = depth.get(u, v);
        let ray = calib.camera.ray(u as f64, v as f64);
        let expected = [ray.x as f32 * z, ray.y as f32 * z, z];
        assert_eq!(cloud.position(i), expected, "point {i} at ({u}, {v})");
        assert_eq!(cloud.colors[3 * i..3 * i + 3], frame.get(u, v), "colour of point {i}");
    }
}
}
