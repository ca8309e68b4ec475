//! One two-direction `loggrad` scan of a simulated VGA scene (`SCENE`, default the
//! sphere; noise seed `SEED`, default 1; `WEBCAM=1` delivers it as a webcam does, 4:2:0
//! chroma and JPEG at quality 80), repeated `N` times (default 100): milliseconds per frame and each stage's fastest time over the frames. Small enough to
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
    let scene = std::env::var("SCENE").unwrap_or_else(|_| "sphere".into());
    let seed: u64 = match std::env::var("SEED") {
        Ok(s) => s.parse().map_err(|_| format!("SEED must be a number, got {s:?}"))?,
        Err(_) => 1,
    };
    let webcam = std::env::var("WEBCAM").is_ok_and(|v| v == "1");
    let cfg = SimConfig {
        seed,
        projector_gamma: spec.encoding_gamma as f32,
        chroma_420: webcam,
        jpeg_quality: webcam.then_some(80),
        ..SimConfig::default()
    };
    let frame = sim::render(&Scene::builtin(&scene)?, &calib, &spec.render_rgb8(), &cfg)?.image;
    let mut scanner = Scanner::new(spec, calib, ScanConfig { crosstalk: cfg.crosstalk, ..ScanConfig::default() })?;
    let runs: usize = match std::env::var("N") {
        Ok(n) => n.parse().map_err(|_| format!("N must be a count, got {n:?}"))?,
        Err(_) => 100,
    };
    // Per stage (in the order of the frame), the fastest of the runs: a shared
    // machine's load only ever adds time, so the minimum is the steadiest figure.
    let mut fastest: Vec<(&str, f64)> = Vec::new();
    let start = std::time::Instant::now();
    for _ in 0..runs {
        let stages = &scanner.scan(&frame)?.stats.stage_ms;
        if fastest.len() != stages.len() {
            fastest = stages.clone();
        }
        for (best, (_, ms)) in fastest.iter_mut().zip(stages) {
            best.1 = best.1.min(*ms);
        }
    }
    println!("{:.1} ms per frame over {runs} frames", start.elapsed().as_secs_f64() * 1000.0 / runs.max(1) as f64);
    let stages: Vec<String> = fastest.iter().map(|(n, ms)| format!("{n} {ms:.1}")).collect();
    println!("fastest of the frames by stage (ms): {}", stages.join(", "));
    Ok(())
}
