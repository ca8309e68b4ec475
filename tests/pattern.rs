//! Stripe patterns: the windowed-uniqueness property of the sequence, spec files, and
//! the same pattern from native and wasm builds. Each test runs natively and in the
//! browser.

#[cfg(target_arch = "wasm32")]
wasm_bindgen_test::wasm_bindgen_test_configure!(run_in_browser);

use std::collections::HashSet;
use stripelight::pattern::{transition, windowed_sequence, PatternSpec, Transition, DEFAULT_STRIPE_WIDTH};

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn every_window_is_unique_and_adjacent_stripes_differ() {
    for n in 1..=3 {
        let spec = PatternSpec::generate(n, 1024, 768, DEFAULT_STRIPE_WIDTH).unwrap();
        let colour = |i: usize| spec.palette[spec.sequence[i] as usize];
        for i in 1..spec.sequence.len() {
            assert_ne!(transition(colour(i - 1), colour(i)), [0; 3], "stripes {} and {i} look alike", i - 1);
        }
        let mut seen: HashSet<Vec<Transition>> = HashSet::new();
        for start in 0..=spec.sequence.len() - spec.window {
            let key = (start + 1..start + spec.window).map(|i| transition(colour(i - 1), colour(i))).collect();
            assert!(seen.insert(key), "window at {start} repeats");
        }
        // Every family has enough stripes to cover the projector without reusing a window.
        for f in &spec.families {
            assert!(f.count <= spec.sequence.len());
        }
        assert!(spec.families[0].count as f64 * DEFAULT_STRIPE_WIDTH >= 1024.0);
    }
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn narrow_stripes_get_a_longer_window() {
    // 1024 / 3 = 342 stripes: more than the 290 distinct 3-stripe windows.
    let spec = PatternSpec::generate(1, 1024, 768, 3.0).unwrap();
    assert!(spec.window >= 4, "window {}", spec.window);
    spec.validate().unwrap();
    assert_eq!(windowed_sequence(291, 3), None);
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn no_channel_is_driven_to_zero() {
    for n in 1..=3 {
        let spec = PatternSpec::generate(n, 160, 120, DEFAULT_STRIPE_WIDTH).unwrap();
        let img = spec.render_linear();
        let darkest = img.pixels().iter().flatten().fold(f32::INFINITY, |m, &x| m.min(x));
        let low = spec.palette[0][0] as f32;
        assert!(darkest >= low.powi(n as i32) * 0.999, "{n} directions: darkest {darkest}");
    }
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn generation_matches_the_stored_spec_on_every_target() {
    // tests/data/pattern2.json was written natively by `stripelight pattern --directions 2`.
    let stored = PatternSpec::from_json(include_str!("data/pattern2.json")).unwrap();
    let now = PatternSpec::generate(2, 1024, 768, DEFAULT_STRIPE_WIDTH).unwrap();
    assert_eq!(now, stored);
}

#[cfg_attr(not(target_arch = "wasm32"), test)]
#[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
fn broken_spec_files_name_the_field() {
    let good = PatternSpec::generate(2, 1024, 768, DEFAULT_STRIPE_WIDTH).unwrap();
    let mut repeated = good.clone();
    repeated.sequence[5] = repeated.sequence[4];
    let mut zero = good.clone();
    zero.palette[0][1] = 0.0;
    let mut short = good.clone();
    short.families[1].count = 10;
    let mut dup_window = good.clone();
    dup_window.sequence[10..13].copy_from_slice(&good.sequence[20..23].to_vec());
    let cases: Vec<(String, &str)> = vec![
        (repeated.to_json(), "sequence[5]"),
        (zero.to_json(), "palette[0]"),
        (short.to_json(), "families[1].count"),
        (good.to_json().replace("\"version\": 1", "\"version\": 9"), "version"),
        (good.to_json().replace("\"width\": 1024", "\"width\": \"wide\""), "width"),
        ("[]".into(), "(file)"),
    ];
    for (text, field) in cases {
        let err = PatternSpec::from_json(&text).unwrap_err().to_string();
        assert!(err.starts_with("pattern spec: ") && err.contains(field), "{field}: {err}");
    }
    let err = PatternSpec::from_json(&dup_window.to_json()).unwrap_err().to_string();
    assert!(err.contains("sequence"), "{err}");
}
