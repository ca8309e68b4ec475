//! Render a built-in scene with the simulator, scan it and compare with the ground
//! truth; write every stage as a PNG.
//!
//! `cargo run --release --example scan_scene -- SCENE DIRECTIONS FILTER OUT_DIR`
//! e.g. `cargo run --release --example scan_scene -- sphere 2 loggrad /tmp/sphere`

use stripelight::pattern::DEFAULT_STRIPE_WIDTH;
use stripelight::scan::{ScanConfig, Scanner};
use stripelight::sim::{self, Scene, SimConfig};
use stripelight::{eval, io, Calibration, PatternSpec};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.to_string());
    let (scene_name, directions, filter, out) = (arg(0, "sphere"), arg(1, "2").parse()?, arg(2, "loggrad").parse()?, arg(3, "scan_scene_out"));
    let calib = Calibration::demo();
    let spec = PatternSpec::generate(directions, calib.projector.width, calib.projector.height, DEFAULT_STRIPE_WIDTH)?;
    let cfg = SimConfig { seed: 1, projector_gamma: spec.encoding_gamma as f32, ..SimConfig::default() };
    let truth = sim::render(&Scene::builtin(&scene_name)?, &calib, &spec.render_rgb8(), &cfg)?;
    let mut scanner = Scanner::new(spec, calib, ScanConfig { filter, crosstalk: cfg.crosstalk, ..ScanConfig::default() })?;
    scanner.scan(&truth.image)?;
    let result = scanner.result().clone();
    let m = eval::measure(&result.depth, &truth);
    println!("{scene_name}, {directions} directions, {filter}: {m:?}");
    for (k, d) in result.family_depth.iter().enumerate() {
        println!("family {k}: {:?}", eval::measure(d, &truth));
    }
    for (k, seg) in scanner.segmentations().iter().enumerate() {
        let edges: Vec<_> = seg.lines.iter().flatten().collect();
        let read = edges.iter().filter(|e| e.code != stripelight::segment::NO_CODE).count();
        let named = edges.iter().filter(|e| e.id >= 0).count();
        println!("dominant {:.1} deg", scanner.restored()[k].dominant.to_degrees());
        println!("family {k}: {} boundaries, {read} read, {named} identified; {:?}", edges.len(), scanner.predictions()[k]);
    }
    std::fs::create_dir_all(&out)?;
    // Error map: green correct, red outlier, blue lit but not decoded.
    let err = truth.depth.pixels().iter().zip(result.depth.pixels()).zip(truth.lit.pixels()).map(|((&t, &z), &lit)| {
        if !z.is_nan() {
            if (z - t).abs() > eval::outlier_threshold(t) { [255, 0, 0] } else { [0, 160, 0] }
        } else if lit { [0, 0, 200] } else { [0, 0, 0] }
    }).collect();
    let (w, h) = truth.depth.size();
    io::write_file(&std::path::Path::new(&out).join("errors.png"), &io::encode_png(&stripelight::Image::from_vec(w, h, err)?)?)?;
    for stage in scanner.stages() {
        io::write_file(&std::path::Path::new(&out).join(format!("{}.png", stage.name)), &io::encode_png(&stage.image)?)?;
    }
    Ok(())
}
