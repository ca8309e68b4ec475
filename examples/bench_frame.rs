//! One two-direction `loggrad` scan of the simulator's sphere (VGA), repeated `N` times
//! (default 100): milliseconds per frame and the last frame's stages. Small enough to
//! run under a profiler; under callgrind its instruction count per frame is the same
//! however loaded the machine is:
//!
//! `N=2 valgrind --tool=callgrind target/release/examples/bench_frame` (then
//! `callgrind_annotate --inclusive=yes` and `Scanner::scan_own_frame`'s count / N).

use stripelight::pattern::DEFAULT_STRIPE_WIDTH;
use stripelight::scan::{ScanConfig, Scanner};
use stripelight::sim::{self, Scene, SimConfig};
use stripelight::{Calibration, PatternSpec};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let calib = Calibration::demo();
    let spec = PatternSpec::generate(2, 1024, 768, DEFAULT_STRIPE_WIDTH)?;
    let cfg = SimConfig { seed: 1, projector_gamma: spec.encoding_gamma as f32, ..SimConfig::default() };
    let frame = sim::render(&Scene::builtin("sphere")?, &calib, &spec.render_rgb8(), &cfg)?.image;
    let mut scanner = Scanner::new(spec, calib, ScanConfig { crosstalk: cfg.crosstalk, ..ScanConfig::default() })?;
    let runs: usize = match std::env::var("N") {
        Ok(n) => n.parse().map_err(|_| format!("N must be a count, got {n:?}"))?,
        Err(_) => 100,
    };
    let start = std::time::Instant::now();
    for _ in 0..runs {
        scanner.scan(&frame)?;
    }
    println!("{:.1} ms per frame over {runs} frames", start.elapsed().as_secs_f64() * 1000.0 / runs.max(1) as f64);
    let stages: Vec<String> = scanner.result().stats.stage_ms.iter().map(|(n, ms)| format!("{n} {ms:.1}")).collect();
    println!("last frame by stage (ms): {}", stages.join(", "));
    Ok(())
}
