//! Time the simulator: milliseconds per VGA frame for every built-in scene, on the
//! demo rig and on its distorted twin, under the two-direction pattern.
//!
//! ```text
//! cargo run --release --example render_bench [-- FRAMES [SCENE]]
//! ```

use std::time::Instant;
use stripelight::sim::{self, Scene, SimConfig};
use stripelight::{Calibration, PatternSpec};

fn main() -> Result<(), stripelight::Error> {
    let frames: u32 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(3).max(1);
    let spec = PatternSpec::generate(2, 1024, 768, stripelight::pattern::DEFAULT_STRIPE_WIDTH)?;
    let pattern = spec.render_rgb8();
    let cfg = SimConfig {
        projector_gamma: spec.encoding_gamma as f32,
        ..SimConfig::default()
    };
    println!("{:<10} {:>10} {:>10} {:>8}", "scene", "demo ms", "distorted", "lit %");
    let only = std::env::args().nth(2);
    for name in Scene::NAMES.iter().filter(|n| only.as_deref().is_none_or(|o| o == **n)) {
        let t0 = Instant::now();
        let scene = Scene::builtin(name)?;
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        let mut ms = [0f64; 2];
        let mut lit = 0.0;
        for (k, calib) in [Calibration::demo(), Calibration::demo_distorted()].iter().enumerate() {
            let mut frame = sim::Frame::new(0, 0);
            let t = Instant::now();
            for _ in 0..frames {
                sim::render_into(&scene, calib, &pattern, &cfg, &mut frame)?;
            }
            ms[k] = t.elapsed().as_secs_f64() * 1e3 / frames as f64;
            if k == 0 {
                let px = frame.lit.pixels();
                lit = 100.0 * px.iter().filter(|&&l| l).count() as f64 / px.len() as f64;
            }
        }
        println!(
            "{name:<10} {:>10.1} {:>10.1} {lit:>8.1}   (scene built in {build_ms:.1} ms)",
            ms[0], ms[1]
        );
    }
    Ok(())
}
