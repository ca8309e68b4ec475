//! The scanner's memory for a W x H frame is bounded by a fixed number of bytes per
//! pixel, measured with a counting global allocator (this file is its own test binary,
//! so nothing else allocates meanwhile; it has one test, so no other test thread does).
//!
//! Measured natively (x86_64) by this test: the peak of the bytes held while
//! `Scanner::new` runs and then scans (twice for the smaller frames, so that what the
//! second frame reuses or grows counts too), above what was held before, per frame
//! pixel (the test prints the figures):
//!
//! | frame | 1 family | 2 families | 3 families |
//! |---|---|---|---|
//! | 640x480 | 235 | 293 | 301 |
//! | 1280x720 | | | 290 |
//! | 3840x2160 | | 93 (0.77 GB) at a third of the scale, 151 (1.25 GB) at its own | |
//!
//! The scanner decodes the 3840x2160 frame at a third of the scale (`DecodeScale`: a
//! projector pixel covers 3 to 4 of its pixels), so only the frame, the depth maps,
//! the stripe coordinates and the cloud are at its size; the frame's own scale is
//! measured too.
//!
//! About 70 bytes are the log-gradient filter's 17 float planes, 30 its padded FFT
//! buffers, 20 the triangulator's per-pixel rays, 16 per family the restored images,
//! 24 per decoded point and cloud (merged and per family); the rest is the frame in its
//! three forms, the segmentation, the decoders and the depth maps.
//!
//! The bound [`MAX_BYTES_PER_PIXEL`] is the largest measured value (301) with a margin
//! of about 25 % for changes to the stages (the decoder is being rewritten); a change
//! that needs more should raise it knowingly. The frames decode (the stored sphere,
//! resampled) so the clouds, which grow with the decoded points, are part of the peak.
//!
//! Native only: the browser's wasm memory holds the same data with 32-bit pointers and
//! `usize`, a little less per pixel.
#![cfg(not(target_arch = "wasm32"))]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use stripelight::scan::{DecodeScale, ScanConfig, Scanner};
use stripelight::sim::SimConfig;
use stripelight::{io, Calibration, Image, PatternSpec};

/// Bytes currently allocated, and the most ever since the last reset.
static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

/// The system allocator, counting. (`unsafe` because `GlobalAlloc` is an unsafe trait:
/// every call is passed on to `System` unchanged.)
struct Counting;

fn grew(n: usize) {
    let now = CURRENT.fetch_add(n, Ordering::Relaxed) + n;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

fn shrank(n: usize) {
    CURRENT.fetch_sub(n, Ordering::Relaxed);
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        shrank(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            // The old block counts until the new one exists: a moving realloc holds both.
            grew(new_size);
            shrank(layout.size());
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Largest peak the scanner may hold per frame pixel, bytes (see the module docs).
const MAX_BYTES_PER_PIXEL: f64 = 380.0;

/// The demo rig with its camera scaled to `w` x `h` (same field of view).
fn demo_rig(w: u32, h: u32) -> Calibration {
    let mut c = Calibration::demo();
    let (sx, sy) = (w as f64 / 640.0, h as f64 / 480.0);
    let cam = &mut c.camera;
    (cam.width, cam.height, cam.fx, cam.fy) = (w, h, cam.fx * sx, cam.fy * sy);
    (cam.cx, cam.cy) = ((cam.cx + 0.5) * sx - 0.5, (cam.cy + 0.5) * sy - 0.5);
    c
}

/// The stored sphere frame resampled (nearest neighbour) to `w` x `h`.
fn sphere_frame(w: usize, h: usize) -> Image<[u8; 3]> {
    let src = io::decode_rgb8(include_bytes!("data/sphere2.png")).unwrap();
    let (sw, sh) = src.size();
    let mut img = Image::new(w, h, [0u8; 3]);
    for v in 0..h {
        for u in 0..w {
            *img.get_mut(u, v) = src.get(u * sw / w, v * sh / h);
        }
    }
    img
}

/// Peak bytes above the starting level while a scanner is made for `spec` and the demo
/// rig at `w` x `h` and scans `frame` `scans` times; and the points of the merged cloud.
fn peak_of_scanning(spec: &PatternSpec, w: usize, h: usize, frame: &Image<[u8; 3]>, scans: usize, decode_scale: DecodeScale) -> (usize, usize, usize) {
    let calib = demo_rig(w as u32, h as u32);
    let config = ScanConfig { crosstalk: SimConfig::default().crosstalk, decode_scale, ..ScanConfig::default() };
    let spec = spec.clone();
    let before = CURRENT.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    let (points, factor) = {
        let mut scanner = Scanner::new(spec, calib, config).unwrap();
        for _ in 1..scans {
            scanner.scan(frame).unwrap();
        }
        (scanner.scan(frame).unwrap().cloud.len(), scanner.decode_factor())
    };
    (PEAK.load(Ordering::Relaxed) - before, points, factor)
}

#[test]
fn scanner_memory_is_bounded_per_pixel() {
    let stored = PatternSpec::from_json(include_str!("data/pattern2.json")).unwrap();
    let specs = [PatternSpec::generate(1, 1024, 768, 10.0).unwrap(), stored, PatternSpec::generate(3, 1024, 768, 10.0).unwrap()];
    // Every family count at VGA, three at 720p, and 4K once with the pattern the frame
    // shows (so that most of it decodes), at the reduced scale the scanner chooses and
    // at the frame's own. (About 10 s in a debug build, mostly 4K.)
    let (auto, full) = (DecodeScale::Auto, DecodeScale::Full);
    let cases = [(640, 480, 0, 2, auto), (640, 480, 1, 2, auto), (640, 480, 2, 2, auto), (1280, 720, 2, 2, auto), (3840, 2160, 1, 1, auto), (3840, 2160, 1, 1, full)];
    let mut worst = 0f64;
    for (w, h, k, scans, decode_scale) in cases {
        let frame = sphere_frame(w, h);
        let (peak, points, factor) = peak_of_scanning(&specs[k], w, h, &frame, scans, decode_scale);
        let per_pixel = peak as f64 / (w * h) as f64;
        worst = worst.max(per_pixel);
        let line = format!("alloc: {w}x{h}, {} families: peak {:.1} MB, {per_pixel:.1} bytes per pixel ({points} points, decoded at 1/{factor} scale)", k + 1, peak as f64 / 1e6);
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "{line}");
        assert!(per_pixel <= MAX_BYTES_PER_PIXEL, "{line}: more than {MAX_BYTES_PER_PIXEL} bytes per pixel");
    }
    // The measurement measures: a scanner holds at least its frame in three forms.
    assert!(worst > 16.0, "{worst} bytes per pixel cannot hold a frame");
}
