//! Milliseconds per VGA frame, natively, for the log-gradient filter (the paper-faithful
//! reference and the fast steerable version) and for the whole scan, with 1, 2 and 3
//! stripe directions. A benchmark, not a test: run it on a quiet machine.
//!
//! `cargo run --release --example bench` uses every core (the families of a frame, the
//! filter's two inverse transforms and its per-family composition run at once);
//! `RAYON_NUM_THREADS=1 cargo run --release --example bench` uses one.

use std::time::Instant;
use stripelight::filter::{reference, FamilyWindow, FilterMode, LogGradFilter, Restored};
use stripelight::pattern::DEFAULT_STRIPE_WIDTH;
use stripelight::raster::{rgb8_to_linear, Image};
use stripelight::scan::{ScanConfig, Scanner};
use stripelight::sim::{self, Scene, SimConfig};
use stripelight::{Calibration, PatternSpec};

/// The median of `runs` timed calls, milliseconds: a shared machine's load comes in
/// bursts, which a mean would carry.
fn ms_per_run(runs: usize, mut f: impl FnMut()) -> f64 {
    f(); // warm up: first-touch of buffers, caches
    let mut times: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1000.0
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let calib = Calibration::demo();
    println!("threads: {}", rayon::current_num_threads());
    println!("| directions | reference filter | fast filter | scan, direct | scan, loggrad |");
    println!("|---|---|---|---|---|");
    for directions in 1..=3 {
        let spec = PatternSpec::generate(directions, 1024, 768, DEFAULT_STRIPE_WIDTH)?;
        let cfg = SimConfig { seed: 1, projector_gamma: spec.encoding_gamma as f32, ..SimConfig::default() };
        let frame = sim::render(&Scene::builtin("sphere")?, &calib, &spec.render_rgb8(), &cfg)?.image;
        let (w, h) = frame.size();
        let mut linear = Image::new(w, h, [0.0; 3]);
        rgb8_to_linear(&frame, 2.2, &mut linear);
        let mut scanner = Scanner::new(spec, calib.clone(), ScanConfig { crosstalk: cfg.crosstalk, ..ScanConfig::default() })?;
        let windows = FamilyWindow::for_families(&scanner.predictions().iter().map(|p| p.angle).collect::<Vec<_>>());
        let mut filter = LogGradFilter::new(w, h)?;
        let mut out: Vec<Restored> = windows.iter().map(|_| Restored::new(w, h)).collect();
        let fast = ms_per_run(21, || {
            let _ = filter.run(&linear, &windows, FilterMode::LogGrad, &mut out);
        });
        let start = Instant::now();
        reference::restore(&linear, &windows, true)?;
        let slow = start.elapsed().as_secs_f64() * 1000.0;
        scanner.set_filter(FilterMode::Direct);
        let direct = ms_per_run(21, || {
            let _ = scanner.scan(&frame);
        });
        let stages = |scanner: &Scanner| -> String {
            let parts: Vec<String> = scanner.result().stats.stage_ms.iter().map(|(n, ms)| format!("{n} {ms:.1}")).collect();
            parts.join(", ")
        };
        let direct_stages = stages(&scanner);
        scanner.set_filter(FilterMode::LogGrad);
        let loggrad = ms_per_run(21, || {
            let _ = scanner.scan(&frame);
        });
        println!("| {directions} | {slow:.0} ms | {fast:.1} ms | {direct:.1} ms | {loggrad:.1} ms |");
        eprintln!("  last direct scan by stage (ms): {direct_stages}");
        eprintln!("  last loggrad scan by stage (ms): {}", stages(&scanner));
    }
    Ok(())
}
