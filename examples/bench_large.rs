//! Milliseconds and peak memory per 8-megapixel frame (3264x2448), natively: the
//! demo rig with its camera scaled 5.1 times, the sphere scene, `loggrad`, under a
//! third-party-style pattern (one family of 125 8-colour stripes, 7 projector pixels
//! wide, black margins) and the default two-direction pattern. A benchmark, not a
//! test: run it on a quiet machine.
//!
//! `cargo run --release --example bench_large`
//!
//! It prints the median of 5 scans after a first one (which also touches the scanner's
//! buffers for the first time), on every core (`RAYON_NUM_THREADS=1` for one), for each
//! pattern decoded at the frame's own scale (`full`) and as the scanner chooses by
//! default (`auto`, see `DecodeScale`: a third of the scale for both patterns here).
//!
//! Peak memory is the process's resident high-water mark (`VmHWM`, Linux) from just
//! before the scanner is made to the end of its scans: the simulator's rendering of the
//! frame is left out (the peak is reset through `/proc/self/clear_refs`), the frame
//! itself (24 MB) is included.

use std::time::Instant;
use stripelight::calib::Intrinsics;
use stripelight::pattern::{binary_palette, windowed_sequence_in, Family};
use stripelight::scan::{DecodeScale, ScanConfig, Scanner};
use stripelight::sim::{self, Scene, SimConfig};
use stripelight::{Calibration, PatternSpec};

const SCALE: f64 = 5.1;
const RUNS: usize = 5;

/// The resident high-water mark in MB, if the system tells it.
fn peak_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn reset_peak() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

fn third_party() -> Result<PatternSpec, Box<dyn std::error::Error>> {
    let (count, width) = (125, 7.0);
    let mut palette = binary_palette(0.0);
    palette.rotate_left(3);
    let sequence = windowed_sequence_in(&palette, count, 4).ok_or("no sequence")?;
    let family = Family { angle_deg: 0.0, stripe_width: width, origin: -(count as f64) * width / 2.0, count };
    Ok(PatternSpec::one_family(1024, 768, palette, [0.0; 3], sequence, 4, family)?)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let demo = Calibration::demo();
    let c = demo.camera;
    let camera = Intrinsics {
        width: (c.width as f64 * SCALE).round() as u32,
        height: (c.height as f64 * SCALE).round() as u32,
        fx: c.fx * SCALE,
        fy: c.fy * SCALE,
        cx: (c.cx + 0.5) * SCALE - 0.5,
        cy: (c.cy + 0.5) * SCALE - 0.5,
        dist: c.dist,
    };
    let calib = Calibration { camera, ..demo };
    println!("| pattern | frame | decode scale | ms per scan | peak memory | points |");
    println!("|---|---|---|---|---|---|");
    let patterns = [("125 stripes, 8 colours, 1 direction", third_party()?), ("default, 2 directions", PatternSpec::generate(2, 1024, 768, 10.0)?)];
    for ((name, spec), (scale_name, decode_scale)) in patterns.iter().flat_map(|p| [(p, ("full", DecodeScale::Full)), (p, ("auto", DecodeScale::Auto))]) {
        let cfg = SimConfig { seed: 1, projector_gamma: spec.encoding_gamma as f32, ..SimConfig::default() };
        let frame = sim::render(&Scene::builtin("sphere")?, &calib, &spec.render_rgb8(), &cfg)?.image;
        reset_peak();
        let config = ScanConfig { crosstalk: cfg.crosstalk, decode_scale, ..ScanConfig::default() };
        let mut scanner = Scanner::new(spec.clone(), calib.clone(), config)?;
        let first = Instant::now();
        scanner.scan(&frame)?;
        let first_ms = first.elapsed().as_secs_f64() * 1000.0;
        let mut times = Vec::with_capacity(RUNS);
        for _ in 0..RUNS {
            let start = Instant::now();
            scanner.scan(&frame)?;
            times.push(start.elapsed().as_secs_f64() * 1000.0);
        }
        // The median: this machine's load comes in bursts from outside.
        times.sort_by(f64::total_cmp);
        let ms = times[RUNS / 2];
        let peak = peak_mb().map_or("unknown".into(), |mb| format!("{mb:.0} MB"));
        let (w, h) = frame.size();
        let scale = match scanner.decode_factor() {
            1 => format!("{scale_name}: 1"),
            f => format!("{scale_name}: 1/{f}"),
        };
        println!("| {name} | {w}x{h} | {scale} | {ms:.0} (first {first_ms:.0}) | {peak} | {} |", scanner.result().stats.merged);
        let stages: Vec<String> = scanner.result().stats.stage_ms.iter().map(|(n, ms)| format!("{n} {ms:.0}")).collect();
        eprintln!("  last scan by stage (ms): {}", stages.join(", "));
    }
    Ok(())
}
