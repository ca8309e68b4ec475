//! `pattern import`: a projector image read back into the spec that made it, and
//! images that are no usable pattern refused with a message naming what is wrong.

#[macro_use]
mod support;

#[cfg(target_arch = "wasm32")]
wasm_bindgen_test::wasm_bindgen_test_configure!(run_in_browser);

use stripelight::pattern::import::{import_image, Placement, StripeAxis};
use stripelight::pattern::{binary_palette, windowed_sequence_in, Family};
use stripelight::{Image, PatternSpec};

/// One family of `count` stripes, `width` projector pixels wide, starting at projector
/// pixel edge `start` along the axis (margins of `background` elsewhere).
fn striped(palette: Vec<[f64; 3]>, window: usize, count: usize, width: f64, start: f64, rows: bool, background: [f64; 3]) -> PatternSpec {
    let (pw, ph) = (1024u32, 768u32);
    let mut sequence = windowed_sequence_in(&palette, count, window).expect("a sequence");
    // A stripe the colour of the margin beside it would be part of the margin.
    assert_ne!(palette[sequence[0] as usize], background, "the first stripe is the margin's colour");
    if palette[sequence[count - 1] as usize] == background {
        sequence.pop();
    }
    let count = sequence.len();
    let centre = if rows { (ph as f64 - 1.0) / 2.0 } else { (pw as f64 - 1.0) / 2.0 };
    let family = Family { angle_deg: if rows { 90.0 } else { 0.0 }, stripe_width: width, origin: start - 0.5 - centre, count };
    canonical(PatternSpec::one_family(pw, ph, palette, background, sequence, window, family).expect("a valid spec"))
}

/// The same pattern with its palette in order of first appearance (how an import
/// numbers colours it has never seen named).
fn canonical(mut spec: PatternSpec) -> PatternSpec {
    let mut order: Vec<u8> = Vec::new();
    for &s in &spec.sequence {
        if !order.contains(&s) {
            order.push(s);
        }
    }
    spec.palette = order.iter().map(|&i| spec.palette[i as usize]).collect();
    spec.sequence = spec.sequence.iter().map(|s| order.iter().position(|o| o == s).unwrap() as u8).collect();
    spec
}

/// The 8 corners of the RGB cube, black and white included, starting at corner `k`
/// (a sequence starts with its palette's first colour).
fn rotated(k: usize) -> Vec<[f64; 3]> {
    let mut p = binary_palette(0.0);
    p.rotate_left(k);
    p
}

fn import(image: &Image<[u8; 3]>, axis: StripeAxis) -> Result<PatternSpec, String> {
    let place = Placement { axis, projector: Some((1024, 768)), ..Placement::default() };
    import_image(image, &place).map(|(spec, _)| spec).map_err(|e| e.to_string())
}

both_targets! {
/// Third-party-style patterns (margins, black stripes, 3-colour RGB and 8-colour
/// palettes, windows 4 and 5, columns and rows, a margin on one side only) come back
/// exactly.
fn imported_images_reproduce_their_specs() {
    let rgb = vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let cases = [
        striped(rgb.clone(), 4, 26, 20.0, 252.0, false, [0.0; 3]),
        striped(rgb, 5, 50, 12.0, 100.0, true, [0.0; 3]),
        striped(rotated(3), 5, 125, 7.0, 74.0, false, [0.0; 3]),
        striped(rotated(1), 4, 60, 8.0, 30.0, false, [1.0, 1.0, 1.0]),
        // No margin before the stripes.
        striped(rotated(5), 4, 100, 6.0, 0.0, false, [0.0; 3]),
    ];
    for spec in cases {
        let axis = if spec.families[0].angle_deg == 0.0 { StripeAxis::Columns } else { StripeAxis::Rows };
        let got = import(&spec.render_rgb8(), axis).unwrap();
        assert_eq!(got, spec);
    }
}
}

both_targets! {
/// A generated pattern of one direction covers the whole projector, its end stripes
/// cut by the image's edges: the import finds the same stripes, sequence and window;
/// the palette comes back within its 8-bit quantization.
fn generated_patterns_import_back() {
    let spec = canonical(PatternSpec::generate(1, 1024, 768, 10.0).unwrap());
    let got = import(&spec.render_rgb8(), StripeAxis::Columns).unwrap();
    assert_eq!((got.sequence.clone(), got.window, got.families.clone()), (spec.sequence.clone(), spec.window, spec.families.clone()));
    for (a, b) in got.palette.iter().zip(&spec.palette) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() < 0.003, "{a:?} against {b:?}");
        }
    }
}
}

both_targets! {
/// Images that hold no usable pattern: one line of error naming the part.
fn bad_pattern_images_are_refused_by_name() {
    let flat = Image::new(64, 8, [90u8, 90, 90]);
    let stripes = |cols: &[[u8; 3]], width: usize| {
        let mut img = Image::new(cols.len() * width, 4, [0u8; 3]);
        for y in 0..4 {
            for (k, &c) in cols.iter().enumerate() {
                for x in 0..width {
                    *img.get_mut(k * width + x, y) = c;
                }
            }
        }
        img
    };
    let (r, g, b) = ([255u8, 0, 0], [0u8, 255, 0], [0u8, 0, 255]);
    // A repeated sequence: no window makes it unique.
    let repeated: Vec<[u8; 3]> = (0..40).map(|k| [r, g, b][k % 3]).collect();
    let nine: Vec<[u8; 3]> = (0..10u8).map(|k| [k * 25, 255 - k * 25, (k % 2) * 255]).collect();
    let mut uneven = stripes(&[r, g, b, r, b, g, r], 6);
    for y in 0..4 {
        for x in 18..21 {
            *uneven.get_mut(x, y) = b; // the third stripe grows into the fourth
        }
    }
    let mut skewed = stripes(&[r, g, b, r, b, g], 6);
    *skewed.get_mut(3, 2) = g;
    let cases: Vec<(Image<[u8; 3]>, StripeAxis, &str)> = vec![
        (flat, StripeAxis::Columns, "pattern import: stripes: "),
        (stripes(&repeated, 6), StripeAxis::Columns, "pattern import: sequence: "),
        (stripes(&nine, 6), StripeAxis::Columns, "pattern import: palette: "),
        (uneven, StripeAxis::Columns, "pattern import: stripes: not of one width"),
        (skewed.clone(), StripeAxis::Columns, "pattern import: image: pixel (3, 2)"),
        (skewed, StripeAxis::Rows, "pattern import: image: "),
    ];
    for (image, axis, start) in cases {
        let err = import(&image, axis).map(|_| ()).expect_err(start);
        assert!(err.starts_with(start) && !err.contains('\n'), "{start}: {err}");
    }
    let place = Placement { scale: 0.0, ..Placement::default() };
    let err = import_image(&stripes(&[r, g, b], 6), &place).unwrap_err().to_string();
    assert!(err.starts_with("pattern import: scale: "), "{err}");
}
}
