//! How often the segmentation reads a boundary's transition wrong, against the ground
//! truth: a row of the hard evaluation is rendered and scanned as `stripelight eval
//! --hard` does, and each boundary found is compared with the pattern's transition at
//! the projector coordinate the simulator says lights it.
//!
//! `cargo run --release --example boundary_codes -- SCENE CONDITION [X0 Y0 X1 Y1]`
//! e.g. `cargo run --release --example boundary_codes -- bag default 140 100 500 420`
//! (the bag itself, not the wall around it).
//!
//! Per family it prints the real boundaries found in the window (those within a
//! quarter of a stripe of a stripe boundary of the pattern), by how many codes their
//! mask allows (one, 2 to 6, more), and how many of those masks leave out the true
//! transition; the edges that lie inside a stripe (the surface's own edges, noise);
//! and how many identities the decoder gave and how many of them are wrong.

use stripelight::eval::hard;
use stripelight::segment::{pack, ScanAxis};
use stripelight::sim::Scene;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(scene_name), Some(condition)) = (args.first(), args.get(1)) else {
        return Err("usage: boundary_codes SCENE CONDITION [X0 Y0 X1 Y1]".into());
    };
    let window: Vec<usize> = args[2..].iter().map(|a| a.parse()).collect::<Result<_, _>>()?;
    let cond = hard::condition(condition)?;
    let mut rows = hard::HardEval::new(1);
    let (frame, view, _) = rows.photograph(&Scene::builtin(scene_name)?, cond)?;
    let mut scanner = rows.scanner(cond)?;
    scanner.scan(&frame)?;
    let spec = scanner.spec().clone();
    let truth = view.truth();
    let (w, h) = truth.depth.size();
    let (x0, y0, x1, y1) = match window[..] {
        [] => (0, 0, w, h),
        [a, b, c, d] => (a, b, c.min(w), d.min(h)),
        _ => return Err("the window is four numbers: X0 Y0 X1 Y1".into()),
    };
    println!("{scene_name} / {condition}, pixels x {x0}..{x1}, y {y0}..{y1}");
    for (k, seg) in scanner.segmentations().iter().enumerate() {
        let family = &spec.families[k];
        let (a, b, c) = family.stripe_coord(spec.width, spec.height);
        // [mask of one code, 2 to 6, more] x [true transition left out, kept].
        let mut real = [[0usize; 2]; 3];
        let (mut inside, mut named, mut named_wrong) = (0, 0, 0);
        for (line, edges) in seg.lines.iter().enumerate() {
            for e in edges {
                let s = e.pos.round().max(0.0) as usize;
                let (x, y) = match seg.axis {
                    Some(ScanAxis::Columns) => (line, s),
                    _ => (s, line),
                };
                if x < x0 || x >= x1 || y < y0 || y >= y1 {
                    continue;
                }
                let [u, v] = truth.projector.pixels()[y * w + x];
                let q = (a * u as f64 + b * v as f64 + c) as f32;
                let j = q.round();
                if !(j >= 0.0 && j <= family.count as f32) {
                    continue;
                }
                if e.id >= 0 {
                    named += 1;
                    named_wrong += usize::from(e.id as f32 != j);
                }
                if (q - j).abs() > 0.25 {
                    inside += 1;
                    continue;
                }
                let code = pack(spec.boundary_transition(k, j as usize));
                let kept = usize::from(e.mask >> code & 1 != 0);
                let size = match e.mask.count_ones() {
                    1 => 0,
                    2..=6 => 1,
                    _ => 2,
                };
                real[size][kept] += 1;
            }
        }
        println!("family {k}:");
        for (name, [out, kept]) in ["one code", "2 to 6 codes", "7 or more"].iter().zip(real) {
            let share = 100.0 * out as f64 / (out + kept).max(1) as f64;
            println!("  real boundaries read as {name}: {} ({out} leave out the true transition, {share:.1} %)", out + kept);
        }
        println!("  edges inside a stripe: {inside}");
        println!("  identified: {named}, of which wrong: {named_wrong}");
    }
    Ok(())
}
