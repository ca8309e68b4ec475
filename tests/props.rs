//! Property tests: nothing a user can feed the parsers or the scanner makes them panic,
//! put NaN or infinity into an output, or answer with anything but a one-line error that
//! names the field or the file (`tests/support/properties.rs` says exactly what each
//! check demands).
//!
//! Every property states its number of cases and prints it when it passes (in plain
//! `cargo test` output natively; in the browser run with `-- --nocapture`). Failing inputs are shrunk and their seeds appended to
//! `proptest-regressions/NAME.txt`, which is replayed first on every run, natively and
//! (compiled in) in the browser; the raw files of the parsers' regression corpus are in
//! `tests/data/corpus/` (`tests/corpus.rs`).
//!
//! Cases per property (natively and in the browser unless said otherwise); each also
//! prints how its cases came out (accepted, refused, decoded...) and fails when an
//! outcome it exists to test never happened:
//!
//! | property | what | cases |
//! |---|---|---|
//! | `spec_text`, `calib_text`, `rig_text` | each JSON parser on arbitrary text | 512 each |
//! | `spec_mutated`, `calib_mutated`, `rig_mutated` | each on valid files with 1-4 values replaced (NaN-ish, infinite, negative, huge, wrong-typed, copied from another field), removed, added, or the text cut | 512 each |
//! | `crosstalk_text` | 9 numbers or not, typed any way | 512 |
//! | `pfm_bytes` | valid, damaged and arbitrary PFM bytes | 512 |
//! | `image_bytes` | valid, damaged (cut, flipped, absurd header sizes) and arbitrary PNG/JPEG bytes | 256 |
//! | `pattern_generate` | `PatternSpec::generate` on any arguments | 256 |
//! | `spec_mutated_scan`, `calib_mutated_scan` | accepted mutated specs and calibrations, scanned on a 40x30 camera | 256 each |
//! | `scan_tiny` | scanner, frames 1x1 to 48x48, any spec, rig, filter, colour mixing and content; each frame's colour mixing read from it too | 96 (browser: 24) |
//! | `scan_any_size` | the same, frames 8x8 to 1920x1080 (browser: 640x480) | 16 (browser: 4) |
//! | `scan_4k` | the same at 3840x2160 (native only) | 2 |
//!
//! Natively the file takes about 20 s of CPU in a debug build, plus 10 to 30 s per 4K
//! case (three families cost the most) and about 25 s for the 4K case of
//! `scanner_cases_that_once_failed`. In the browser it takes about 6 s. The scanner's
//! memory per pixel is `tests/alloc_bounds.rs`'s business.

#[macro_use]
mod support;
#[macro_use]
#[path = "support/properties.rs"]
mod properties;

#[cfg(target_arch = "wasm32")]
wasm_bindgen_test::wasm_bindgen_test_configure!(run_in_browser);

use glam::DVec3;
use properties::*;
use proptest::prelude::*;
use proptest::sample::Index;
use serde_json::Value;
use std::sync::OnceLock;
use stripelight::calib::{ApproxRig, Crosstalk, IDENTITY_CROSSTALK};
use stripelight::filter::FilterMode;
use stripelight::pattern::{binary_palette, windowed_sequence, Family, SPEC_FORMAT, SPEC_VERSION};
use stripelight::scan::{ScanConfig, Scanner};
use stripelight::sim::{self, Scene, SimConfig};
use stripelight::{io, Calibration, Error, Image, PatternSpec};

const STORED_SPEC: &str = include_str!("data/pattern2.json");
const STORED_FRAME: &[u8] = include_bytes!("data/sphere2.png");

// ---------------------------------------------------------------------------------
// Mutations of valid JSON files

/// Raw JSON text put in place of a value: NaN-ish, infinite, negative, huge, tiny,
/// wrong-typed and malformed values (JSON has no NaN: every spelling of it must be
/// refused as a syntax error that says where).
const RAW_TOKENS: &[&str] = &[
    "NaN", "-NaN", "nan", "Infinity", "-Infinity", "inf", "1e999", "-1e999", "1e-999", "-0", "-0.0", "0", "1", "2", "-1",
    "-2", "0.5", "-0.5", "1e-300", "5e-324", "1e20", "-1e20", "1e308", "-1e308", "1.7976931348623157e308", "4294967295",
    "4294967296", "65536", "16385", "18446744073709551615", "18446744073709551616", "-9223372036854775809", "0x10",
    "+1", ".5", "1.", "null", "true", "false", "\"\"", "\"mm\"", "\"NaN\"", "\"1.0\"", "[]", "{}", "[null]", "[1e999]",
    "[0,0,0]", "[1,0,0,0,1,0,0,0,1]", "[[1,1,1]]", "{\"a\":1}",
    "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[]]]",
];

/// What replaces a value.
#[derive(Clone, Debug)]
enum Replacement {
    Raw(usize),
    Float(f64),
    Int(i64),
    Text(String),
    /// A copy of another value of the same file (equal values are where geometry
    /// degenerates: a baseline along the aim, two equal angles).
    CopyOf(Index),
}

#[derive(Clone, Debug)]
enum Mutation {
    Replace(Index, Replacement),
    /// Multiply a number by a factor (no-op on other values).
    Scale(Index, f64),
    /// Remove an object member or array element.
    Remove(Index),
    /// Add a member or element (an unknown field, one element too many).
    Add(Index),
}

/// Mutations at the text level, after the value-level ones.
#[derive(Clone, Debug)]
enum TextDamage {
    None,
    Truncate(Index),
    Insert(Index, char),
    Delete(Index),
}

fn replacement() -> impl Strategy<Value = Replacement> {
    prop_oneof![
        4 => (0..RAW_TOKENS.len()).prop_map(Replacement::Raw),
        2 => any::<f64>().prop_map(Replacement::Float),
        1 => any::<i64>().prop_map(Replacement::Int),
        1 => ".{0,12}".prop_map(Replacement::Text),
        2 => any::<Index>().prop_map(Replacement::CopyOf),
    ]
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let factor = prop_oneof![
        Just(-1.0),
        Just(0.0),
        Just(1e-300),
        Just(1e300),
        Just(1e10),
        Just(-1e10),
        Just(1.0 + 1e-9),
        Just(0.5),
        Just(2.0),
        -4.0..4.0f64
    ];
    prop_oneof![
        6 => (any::<Index>(), replacement()).prop_map(|(i, r)| Mutation::Replace(i, r)),
        3 => (any::<Index>(), factor).prop_map(|(i, f)| Mutation::Scale(i, f)),
        2 => any::<Index>().prop_map(Mutation::Remove),
        1 => any::<Index>().prop_map(Mutation::Add),
    ]
}

fn text_damage() -> impl Strategy<Value = TextDamage> {
    prop_oneof![
        8 => Just(TextDamage::None),
        1 => any::<Index>().prop_map(TextDamage::Truncate),
        1 => (any::<Index>(), any::<char>()).prop_map(|(i, c)| TextDamage::Insert(i, c)),
        1 => any::<Index>().prop_map(TextDamage::Delete),
    ]
}

/// One step of a path into a JSON value.
#[derive(Clone, Debug)]
enum Step {
    Key(String),
    At(usize),
}

/// Every path in `v`, the root (empty path) first.
fn paths(v: &Value) -> Vec<Vec<Step>> {
    let mut out = vec![Vec::new()];
    let mut i = 0;
    while i < out.len() {
        let path = out[i].clone();
        match lookup(v, &path) {
            Some(Value::Object(m)) => out.extend(m.keys().map(|k| [path.clone(), vec![Step::Key(k.clone())]].concat())),
            Some(Value::Array(a)) => out.extend((0..a.len()).map(|j| [path.clone(), vec![Step::At(j)]].concat())),
            _ => {}
        }
        i += 1;
    }
    out
}

fn lookup<'a>(v: &'a Value, path: &[Step]) -> Option<&'a Value> {
    path.iter().try_fold(v, |v, s| match s {
        Step::Key(k) => v.get(k.as_str()),
        Step::At(j) => v.get(*j),
    })
}

fn lookup_mut<'a>(v: &'a mut Value, path: &[Step]) -> Option<&'a mut Value> {
    path.iter().try_fold(v, |v, s| match s {
        Step::Key(k) => v.get_mut(k.as_str()),
        Step::At(j) => v.get_mut(*j),
    })
}

/// `template` with the mutations applied, as text. Raw tokens (which a `Value` cannot
/// hold) go in as placeholders replaced in the text.
fn mutate_json(template: &Value, mutations: &[Mutation], damage: &TextDamage) -> String {
    let mut doc = template.clone();
    let mut raws: Vec<String> = Vec::new();
    let raw = |text: String, raws: &mut Vec<String>| {
        raws.push(text);
        Value::String(format!("@@RAW{}@@", raws.len() - 1))
    };
    for m in mutations {
        let all = paths(&doc);
        match m {
            Mutation::Replace(at, with) => {
                let path = &all[at.index(all.len())];
                let new = match with {
                    Replacement::Raw(k) => raw(RAW_TOKENS[*k].to_string(), &mut raws),
                    Replacement::Float(x) => raw(format!("{x:?}"), &mut raws),
                    Replacement::Int(n) => raw(n.to_string(), &mut raws),
                    Replacement::Text(s) => Value::String(s.clone()),
                    Replacement::CopyOf(from) => lookup(&doc, &all[from.index(all.len())]).cloned().unwrap_or(Value::Null),
                };
                if let Some(slot) = lookup_mut(&mut doc, path) {
                    *slot = new;
                }
            }
            Mutation::Scale(at, factor) => {
                let path = &all[at.index(all.len())];
                if let Some(x) = lookup(&doc, path).and_then(Value::as_f64) {
                    let new = raw(format!("{:?}", x * factor), &mut raws);
                    if let Some(slot) = lookup_mut(&mut doc, path) {
                        *slot = new;
                    }
                }
            }
            Mutation::Remove(at) => {
                let path = &all[at.index(all.len())];
                if let Some((last, parent)) = path.split_last() {
                    match (lookup_mut(&mut doc, parent), last) {
                        (Some(Value::Object(m)), Step::Key(k)) => {
                            m.remove(k);
                        }
                        (Some(Value::Array(a)), Step::At(j)) => {
                            a.remove(*j);
                        }
                        _ => {}
                    }
                }
            }
            Mutation::Add(at) => {
                let path = &all[at.index(all.len())];
                match lookup_mut(&mut doc, path) {
                    Some(Value::Object(m)) => {
                        m.insert("unexpected_field".into(), Value::from(1));
                    }
                    Some(Value::Array(a)) => {
                        let copy = a.last().cloned().unwrap_or(Value::from(0));
                        a.push(copy);
                    }
                    _ => {}
                }
            }
        }
    }
    let mut text = serde_json::to_string_pretty(&doc).unwrap_or_default();
    for (k, r) in raws.iter().enumerate() {
        text = text.replace(&format!("\"@@RAW{k}@@\""), r);
    }
    let at = |i: &Index, text: &str| {
        let boundaries: Vec<usize> = (0..=text.len()).filter(|&b| text.is_char_boundary(b)).collect();
        boundaries[i.index(boundaries.len())]
    };
    match damage {
        TextDamage::None => {}
        TextDamage::Truncate(i) => text.truncate(at(i, &text)),
        TextDamage::Insert(i, c) => text.insert(at(i, &text), *c),
        TextDamage::Delete(i) => {
            let b = at(i, &text);
            if b < text.len() {
                text.remove(b);
            }
        }
    }
    text
}

/// Valid files to mutate, each made once.
struct Templates {
    specs: Vec<Value>,
    calibs: Vec<Value>,
    rigs: Vec<Value>,
}

fn templates() -> &'static Templates {
    static T: OnceLock<Templates> = OnceLock::new();
    T.get_or_init(|| {
        let json = |s: String| serde_json::from_str::<Value>(&s).expect("a valid template");
        let mut specs: Vec<Value> = (1..=3).map(|n| json(PatternSpec::generate(n, 1024, 768, 10.0).unwrap().to_json())).collect();
        specs.push(json(PatternSpec::generate(2, 64, 48, 8.0).unwrap().to_json()));
        let rig = ApproxRig {
            camera_width: 640,
            camera_height: 480,
            camera_hfov_deg: 45.6,
            projector_width: 1024,
            projector_height: 768,
            projector_hfov_deg: 47.9,
            baseline_mm: [141.4, 141.4, 0.0],
            aim_distance_mm: 750.0,
        };
        let rig_flat = ApproxRig { baseline_mm: [150.0, 0.0, 0.0], aim_distance_mm: 800.0, ..rig.clone() };
        Templates {
            specs,
            calibs: vec![json(Calibration::demo().to_json()), json(Calibration::demo_distorted().to_json())],
            rigs: [rig, rig_flat].iter().map(|r| serde_json::to_value(r).unwrap()).collect(),
        }
    })
}

/// A template with 1 to `most` mutations (and maybe text damage).
fn mutated_up_to(most: usize, pick: fn(&'static Templates) -> &'static [Value]) -> impl Strategy<Value = String> {
    (any::<Index>(), prop::collection::vec(mutation(), 1..=most), text_damage()).prop_map(move |(t, ms, d)| {
        let all = pick(templates());
        mutate_json(&all[t.index(all.len())], &ms, &d)
    })
}

fn mutated(pick: fn(&'static Templates) -> &'static [Value]) -> impl Strategy<Value = String> {
    mutated_up_to(4, pick)
}

/// Text that is mostly not JSON, and text made of JSON's characters.
fn any_text() -> impl Strategy<Value = String> {
    prop_oneof![any::<String>(), "[\\[\\]{}\",:0-9.eE+\\- a-z_]{0,160}"]
}

fn expect_ok(v: Result<Verdict, String>, input: &str) -> Result<Verdict, String> {
    v.map_err(|e| format!("{e}\ninput: {input}"))
}

both_targets! {
/// Pattern specs: arbitrary text.
fn spec_parser_on_arbitrary_text() {
    check(property!("spec_text"), 512, 1024, &["refused"], any_text(), |t| expect_ok(check_spec_text(&t), &t).map(|v| v.label()));
}

/// Pattern specs: valid files with values replaced, removed, added or cut.
fn spec_parser_on_mutated_files() {
    check(property!("spec_mutated"), 512, 1024, &["accepted", "refused"], mutated(|t| &t.specs), |t| expect_ok(check_spec_text(&t), &t).map(|v| v.label()));
}

/// Calibrations: arbitrary text.
fn calib_parser_on_arbitrary_text() {
    check(property!("calib_text"), 512, 1024, &["refused"], any_text(), |t| expect_ok(check_calib_text(&t), &t).map(|v| v.label()));
}

/// Calibrations: valid files with values replaced, removed, added or cut.
fn calib_parser_on_mutated_files() {
    check(property!("calib_mutated"), 512, 1024, &["accepted", "refused"], mutated(|t| &t.calibs), |t| expect_ok(check_calib_text(&t), &t).map(|v| v.label()));
}

/// Approximate rigs: arbitrary text.
fn rig_parser_on_arbitrary_text() {
    check(property!("rig_text"), 512, 1024, &["refused"], any_text(), |t| expect_ok(check_rig_text(&t), &t).map(|v| v.label()));
}

/// Approximate rigs: valid rigs with values replaced, removed, added or cut.
fn rig_parser_on_mutated_files() {
    check(property!("rig_mutated"), 512, 1024, &["accepted", "refused"], mutated(|t| &t.rigs), |t| expect_ok(check_rig_text(&t), &t).map(|v| v.label()));
}
}

// ---------------------------------------------------------------------------------
// Crosstalk text

/// A number as a person might type it, or something that is not one.
fn crosstalk_token() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => (-2.0..2.0f32).prop_map(|x| x.to_string()),
        1 => any::<f32>().prop_map(|x| x.to_string()),
        1 => any::<f32>().prop_map(|x| format!("{x:e}")),
        2 => prop::sample::select(vec![
            "NaN", "nan", "inf", "-inf", "infinity", "1e39", "-1e39", "1e30", "-1e30", "1e20", "1e-50", "0", "-0", "1",
            "0x1", "+1", ".5", "5.", "1,5", "e", "--1", "1e", "½", "١",
        ])
        .prop_map(String::from),
    ]
}

fn crosstalk_text() -> impl Strategy<Value = String> {
    let sep = prop::sample::select(vec![",", ";", " ", "\t", "\n", ", ", "; ", ",,", " ,", "\r\n", "\u{a0}", ""]);
    let near_identity = (0..9usize, crosstalk_token()).prop_map(|(k, t)| {
        let mut v: Vec<String> = IDENTITY_CROSSTALK.iter().flatten().map(|x| x.to_string()).collect();
        v[k] = t;
        v.join(",")
    });
    prop_oneof![
        2 => prop::collection::vec((crosstalk_token(), sep), 0..=12)
            .prop_map(|v| v.into_iter().map(|(t, s)| t + s).collect::<String>()),
        2 => near_identity,
        1 => prop::collection::vec(prop::sample::select(vec!["1e30", "-1e30", "1e20", "3e19", "1", "0"]), 9)
            .prop_map(|v| v.join(" ")),
        1 => any_text(),
    ]
}

both_targets! {
/// Crosstalk text: 9 numbers or not, typed any way.
fn crosstalk_parser_on_any_text() {
    check(property!("crosstalk_text"), 512, 1024, &["accepted", "refused"], crosstalk_text(), |t| expect_ok(check_crosstalk_text(&t), &t).map(|v| v.label()));
}
}

// ---------------------------------------------------------------------------------
// PFM

/// A header number: the true one, junk, or one near a power of two (where sizes
/// overflow when multiplied by each other and by 4 bytes a pixel, on 32 and 64 bits).
fn pfm_token(valid: usize) -> impl Strategy<Value = String> {
    prop_oneof![
        3 => Just(valid.to_string()),
        1 => prop::sample::select(vec!["0", "-1", "+2", "1e3", "abc", "", "18446744073709551616", "99999999999999999999"])
            .prop_map(String::from),
        2 => (1..=64u32, 0..=9u64).prop_map(|(k, d)| ((1u128 << k) as u64).wrapping_sub(d).to_string()),
    ]
}

/// A PFM: a valid one whose header and body are then damaged.
fn pfm_bytes() -> impl Strategy<Value = Vec<u8>> {
    let header = (prop_oneof![Just(1usize), 1..6usize], prop_oneof![Just(1usize), 1..6usize]).prop_flat_map(|(w, h)| {
        (
            prop::sample::select(vec!["Pf", "Pf", "Pf", "PF", "P6", "pf", ""]),
            pfm_token(w),
            pfm_token(h),
            prop::sample::select(vec!["-1.0", "-1.0", "1.0", "-1", "0", "-0", "NaN", "inf", "-inf", "1e39", "abc", "-1e-45"]),
            prop::sample::select(vec!["\n", " ", "\t", "\r\n", "  ", "\n\n"]),
            prop::collection::vec(any::<u32>().prop_map(f32::from_bits), w * h),
            -8..8isize,
        )
    });
    let structured = header.prop_map(|(magic, w, h, scale, sep, pixels, extra)| {
        let mut out = format!("{magic}{sep}{w}{sep}{h}{sep}{scale}{sep}").into_bytes();
        let little = scale.starts_with('-');
        for x in pixels {
            out.extend_from_slice(&if little { x.to_le_bytes() } else { x.to_be_bytes() });
        }
        if extra < 0 {
            out.truncate(out.len().saturating_sub((-extra) as usize));
        } else {
            out.extend(std::iter::repeat_n(0x7f, extra as usize));
        }
        out
    });
    // Valid files of any values, white space and byte order, for the round trip.
    let valid = (1..6usize, 1..6usize, prop::sample::select(vec![" ", "\n", "\t", "\r\n"]), prop_oneof![-1e6..-1e-6f32, 1e-6..1e6f32])
        .prop_flat_map(|(w, h, sep, scale)| {
            prop::collection::vec(any::<u32>().prop_map(f32::from_bits), w * h).prop_map(move |pixels| {
                let mut out = format!("Pf{sep}{w}{sep}{h}{sep}{scale}\n").into_bytes();
                for x in pixels {
                    out.extend_from_slice(&if scale < 0.0 { x.to_le_bytes() } else { x.to_be_bytes() });
                }
                out
            })
        });
    prop_oneof![
        3 => structured,
        2 => valid,
        1 => prop::collection::vec(any::<u8>(), 0..80),
        1 => prop::collection::vec(any::<u8>(), 0..80).prop_map(|b| [b"Pf\n".as_slice(), &b].concat()),
    ]
}

both_targets! {
/// PFM bytes, arbitrary and damaged.
fn pfm_decoder_on_any_bytes() {
    check(property!("pfm_bytes"), 512, 1024, &["accepted", "refused"], pfm_bytes(), |b| {
        expect_ok(check_pfm_bytes(&b), &format!("{:?}", String::from_utf8_lossy(&b))).map(|v| v.label())
    });
}
}

// ---------------------------------------------------------------------------------
// PNG and JPEG

/// CRC-32 (ISO 3309, as PNG chunks use it), bit by bit.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xedb8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

#[derive(Clone, Debug)]
enum ImageDamage {
    None,
    Truncate(Index),
    Flip(Index, u8),
    /// New IHDR width and height with a correct CRC (so the header is believed).
    Header(u32, u32),
    Append(Vec<u8>),
}

fn image_bytes() -> impl Strategy<Value = Vec<u8>> {
    let kind = prop::sample::select(vec!["rgb8", "rgba8", "l8", "la8", "rgb16", "jpeg"]);
    let huge = prop::sample::select(vec![0u32, 1, 2, 17, 65535, 100_000, 0x7fff_ffff, 0xffff_ffff]);
    let damage = prop_oneof![
        2 => Just(ImageDamage::None),
        2 => any::<Index>().prop_map(ImageDamage::Truncate),
        2 => (any::<Index>(), 1..=255u8).prop_map(|(i, x)| ImageDamage::Flip(i, x)),
        2 => (huge.clone(), huge).prop_map(|(w, h)| ImageDamage::Header(w, h)),
        1 => prop::collection::vec(any::<u8>(), 1..32).prop_map(ImageDamage::Append),
    ];
    let structured = (kind, 1..12u32, 1..12u32, any::<u64>(), 1..=100u8, damage).prop_map(|(kind, w, h, seed, quality, damage)| {
        let mut rng = SplitMix(seed);
        let mut bytes = Vec::new();
        let cursor = &mut std::io::Cursor::new(&mut bytes);
        let n = (w * h) as usize;
        let mut data = |per_pixel: usize| (0..n * per_pixel).map(|_| rng.next() as u8).collect::<Vec<u8>>();
        use image::ExtendedColorType as T;
        let written = match kind {
            "jpeg" => image::codecs::jpeg::JpegEncoder::new_with_quality(cursor, quality).encode(&data(3), w, h, T::Rgb8),
            k => {
                let (t, per) = match k {
                    "rgb8" => (T::Rgb8, 3),
                    "rgba8" => (T::Rgba8, 4),
                    "l8" => (T::L8, 1),
                    "la8" => (T::La8, 2),
                    _ => (T::Rgb16, 6),
                };
                image::write_buffer_with_format(cursor, &data(per), w, h, t, image::ImageFormat::Png)
            }
        };
        written.expect("a small image encodes");
        match damage {
            ImageDamage::None => {}
            ImageDamage::Truncate(i) => bytes.truncate(i.index(bytes.len() + 1)),
            ImageDamage::Flip(i, x) => {
                let k = i.index(bytes.len());
                bytes[k] ^= x;
            }
            ImageDamage::Header(w, h) if kind != "jpeg" => {
                // Signature (8), length (4), "IHDR" (4), then width and height.
                bytes[16..20].copy_from_slice(&w.to_be_bytes());
                bytes[20..24].copy_from_slice(&h.to_be_bytes());
                let crc = crc32(&bytes[12..29]);
                bytes[29..33].copy_from_slice(&crc.to_be_bytes());
            }
            ImageDamage::Header(..) => {}
            ImageDamage::Append(tail) => bytes.extend(tail),
        }
        bytes
    });
    prop_oneof![
        3 => structured,
        1 => prop::collection::vec(any::<u8>(), 0..120),
        1 => prop::collection::vec(any::<u8>(), 0..120).prop_map(|b| [b"\x89PNG\r\n\x1a\n".as_slice(), &b].concat()),
        1 => prop::collection::vec(any::<u8>(), 0..120).prop_map(|b| [b"\xff\xd8\xff".as_slice(), &b].concat()),
    ]
}

both_targets! {
/// PNG and JPEG bytes, arbitrary and damaged (cut, flipped, with absurd sizes in the
/// header, with junk after the end).
fn image_decoder_on_any_bytes() {
    check(property!("image_bytes"), 256, 256, &["accepted", "refused"], image_bytes(), |b| {
        expect_ok(check_image_bytes(&b), &format!("{} bytes starting {:02x?}", b.len(), &b[..b.len().min(40)])).map(|v| v.label())
    });
}
}

// ---------------------------------------------------------------------------------
// The scanner

/// A small deterministic generator for frame content (the strategies shrink its seed,
/// not millions of pixels).
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Which pattern.
#[derive(Clone, Debug)]
enum SpecChoice {
    /// `tests/data/pattern2.json` (with the demo rig only: it is for a 1024x768 projector).
    Stored,
    /// `PatternSpec::generate` for the rig's projector.
    Generated { directions: usize, stripe_width: f64 },
    /// Families at any angles and widths, any palette low level and gamma: anything
    /// `PatternSpec::validate` accepts.
    Custom { families: Vec<(f64, f64)>, low: f64, gamma: f64 },
}

/// Which projector-camera rig.
#[derive(Clone, Debug)]
enum RigChoice {
    /// The demo rig with its camera scaled to the frame (same field of view).
    DemoScaled { distorted: bool },
    /// Any rig an approximate description gives, with or without lens distortion.
    Random {
        camera_hfov: f64,
        projector: (u32, u32),
        projector_hfov: f64,
        azimuth: f64,
        elevation: f64,
        baseline: f64,
        aim: f64,
        distortion: Option<([f64; 5], [f64; 5])>,
    },
}

#[derive(Clone, Debug)]
enum Content {
    Noise,
    Constant([u8; 3]),
    /// The pattern's own colours along one or two directions in the frame.
    Stripes { angle: f64, period: f64, second: Option<(f64, f64)>, albedo: f64 },
    /// Nearly all channels at 255.
    Saturated,
    /// Nearly all black.
    Dark,
    /// The simulator's picture of a built-in scene under the pattern (small frames).
    Simulated { scene: usize },
    /// The stored sphere frame resampled to the frame size.
    Sphere,
}

#[derive(Clone, Debug)]
struct FrameRecipe {
    content: Content,
    seed: u64,
    /// Rectangles overwritten with noise, black or white.
    damage: u8,
}

#[derive(Clone, Debug)]
struct ScanCase {
    width: u32,
    height: u32,
    spec: SpecChoice,
    rig: RigChoice,
    filter: FilterMode,
    crosstalk: Option<Crosstalk>,
    gamma: f32,
    frames: Vec<FrameRecipe>,
}

fn spec_choice() -> impl Strategy<Value = SpecChoice> {
    let family = (-180.0..180.0f64, prop_oneof![2.0..8.0f64, 8.0..60.0f64]);
    prop_oneof![
        1 => Just(SpecChoice::Stored),
        2 => (1..=3usize, prop_oneof![Just(10.0), 6.0..40.0f64])
            .prop_map(|(directions, stripe_width)| SpecChoice::Generated { directions, stripe_width }),
        2 => (prop::collection::vec(family, 1..=3), 0.05..0.8f64, 0.2..=5.0f64)
            .prop_map(|(families, low, gamma)| SpecChoice::Custom { families, low, gamma }),
    ]
}

fn rig_choice() -> impl Strategy<Value = RigChoice> {
    let dist = || (-0.3..0.3f64, -0.1..0.1f64, -0.003..0.003f64, -0.003..0.003f64, -0.05..0.05f64).prop_map(|(a, b, c, d, e)| [a, b, c, d, e]);
    let random = (
        (20.0..100.0f64, (32..=1920u32, 32..=1200u32), 10.0..80.0f64),
        (0.0..std::f64::consts::TAU, -0.6..0.6f64, 20.0..600.0f64, 300.0..3000.0f64),
        prop::option::weighted(0.3, (dist(), dist())),
    )
        .prop_map(|((camera_hfov, projector, projector_hfov), (azimuth, elevation, baseline, aim), distortion)| RigChoice::Random {
            camera_hfov,
            projector,
            projector_hfov,
            azimuth,
            elevation,
            baseline,
            aim,
            distortion,
        });
    prop_oneof![3 => any::<bool>().prop_map(|d| RigChoice::DemoScaled { distorted: d }), 2 => random]
}

fn content() -> impl Strategy<Value = Content> {
    prop_oneof![
        2 => Just(Content::Noise),
        1 => prop_oneof![Just([0u8; 3]), Just([255u8; 3]), any::<[u8; 3]>()].prop_map(Content::Constant),
        2 => (0.0..180.0f64, 2.0..80.0f64, prop::option::of((0.0..180.0f64, 2.0..80.0f64)), 0.05..1.0f64)
            .prop_map(|(angle, period, second, albedo)| Content::Stripes { angle, period, second, albedo }),
        1 => Just(Content::Saturated),
        1 => Just(Content::Dark),
        3 => (0..SCENES.len()).prop_map(|scene| Content::Simulated { scene }),
        3 => Just(Content::Sphere),
    ]
}

fn frame_recipe() -> impl Strategy<Value = FrameRecipe> {
    (content(), any::<u64>(), prop_oneof![3 => Just(0u8), 1 => 1..6u8]).prop_map(|(content, seed, damage)| FrameRecipe { content, seed, damage })
}

/// A scan case: half of them anything (any pattern, rig, filter, colour mixing, gamma,
/// content) of a size from `size`; half the stored pattern on the demo rig seeing the
/// stored sphere or a simulated scene, of a size from `sample_size` (the frames the
/// scanner is made for, so that there are clouds to check).
fn scan_case(
    size: impl Strategy<Value = (u32, u32)>,
    sample_size: impl Strategy<Value = (u32, u32)>,
    frames: std::ops::RangeInclusive<usize>,
) -> impl Strategy<Value = ScanCase> {
    let mixing = prop_oneof![
        2 => Just(None),
        1 => Just(Some(SimConfig::default().crosstalk)),
        1 => (prop::array::uniform3(0.6..1.0f32), prop::array::uniform6(-0.1..0.3f32)).prop_map(|(d, o)| {
            Some([[d[0], o[0], o[1]], [o[2], d[1], o[3]], [o[4], o[5], d[2]]])
        }),
    ];
    let filter = prop::sample::select(vec![FilterMode::LogGrad, FilterMode::Direct, FilterMode::LogGradNoRotation]);
    let gamma = prop_oneof![3 => Just(2.2f32), 1 => 0.2..=5.0f32];
    let anything = (size, spec_choice(), rig_choice(), filter.clone(), mixing, gamma, prop::collection::vec(frame_recipe(), frames.clone()))
        .prop_map(|((width, height), spec, rig, filter, crosstalk, gamma, frames)| ScanCase { width, height, spec, rig, filter, crosstalk, gamma, frames });
    let scene = prop_oneof![Just(Content::Sphere), (0..SCENES.len()).prop_map(|scene| Content::Simulated { scene })];
    let sample_frame = (scene, any::<u64>()).prop_map(|(content, seed)| FrameRecipe { content, seed, damage: 0 });
    let sample = (sample_size, filter, prop::collection::vec(sample_frame, frames)).prop_map(|((width, height), filter, frames)| ScanCase {
        width,
        height,
        spec: SpecChoice::Stored,
        rig: RigChoice::DemoScaled { distorted: false },
        filter,
        crosstalk: Some(SimConfig::default().crosstalk),
        gamma: 2.2,
        frames,
    });
    prop_oneof![anything, sample]
}

/// The camera of `calib` given the size `w` x `h` with the same field of view.
fn scale_camera(calib: &mut Calibration, w: u32, h: u32) {
    let (sx, sy) = (w as f64 / calib.camera.width as f64, h as f64 / calib.camera.height as f64);
    let c = &mut calib.camera;
    (c.width, c.height) = (w, h);
    (c.fx, c.fy) = (c.fx * sx, c.fy * sy);
    (c.cx, c.cy) = ((c.cx + 0.5) * sx - 0.5, (c.cy + 0.5) * sy - 0.5);
}

/// The calibration of a case, or the (clear) error that building it gave.
fn build_rig(case: &ScanCase) -> Result<Calibration, Error> {
    match &case.rig {
        RigChoice::DemoScaled { distorted } => {
            let mut c = if *distorted { Calibration::demo_distorted() } else { Calibration::demo() };
            scale_camera(&mut c, case.width, case.height);
            Ok(c)
        }
        RigChoice::Random { camera_hfov, projector, projector_hfov, azimuth, elevation, baseline, aim, distortion } => {
            let dir = DVec3::new(elevation.cos() * azimuth.cos(), elevation.cos() * azimuth.sin(), elevation.sin());
            let mut c = Calibration::from_approx_rig(&ApproxRig {
                camera_width: case.width,
                camera_height: case.height,
                camera_hfov_deg: *camera_hfov,
                projector_width: projector.0,
                projector_height: projector.1,
                projector_hfov_deg: *projector_hfov,
                baseline_mm: (dir * *baseline).to_array(),
                aim_distance_mm: *aim,
            })?;
            if let Some((cam, proj)) = distortion {
                (c.camera.dist, c.projector.dist) = (*cam, *proj);
            }
            Ok(c)
        }
    }
}

/// A custom spec: families at `(angle, stripe width)`, sized to cover the projector.
fn custom_spec(families: &[(f64, f64)], low: f64, gamma: f64, width: u32, height: u32) -> PatternSpec {
    // At most this many stripes a family, so that the sequence search stays fast.
    const MAX_STRIPES: f64 = 300.0;
    let families: Vec<Family> = families
        .iter()
        .map(|&(angle_deg, w)| {
            let (s, c) = angle_deg.to_radians().sin_cos();
            let reach = width as f64 / 2.0 * c.abs() + height as f64 / 2.0 * s.abs();
            let stripe_width = w.max(2.0 * reach / MAX_STRIPES);
            let count = ((2.0 * reach / stripe_width).ceil() as usize).max(2);
            Family { angle_deg, stripe_width, origin: -(count as f64) * stripe_width / 2.0, count }
        })
        .collect();
    let needed = families.iter().map(|f| f.count).max().unwrap_or(2);
    let (window, sequence) = (3..=8).find_map(|w| windowed_sequence(needed, w).map(|s| (w, s))).expect("a sequence of at most 300 stripes");
    PatternSpec {
        format: SPEC_FORMAT.into(),
        version: SPEC_VERSION,
        width,
        height,
        encoding_gamma: gamma,
        palette: binary_palette(low),
        background: [0.0; 3],
        sequence,
        window,
        families,
    }
}

fn build_spec(case: &ScanCase, calib: &Calibration) -> PatternSpec {
    let (pw, ph) = (calib.projector.width, calib.projector.height);
    match &case.spec {
        SpecChoice::Stored if (pw, ph) == (1024, 768) => stored_pattern().0.clone(),
        SpecChoice::Stored => PatternSpec::generate(2, pw, ph, 10.0).unwrap(),
        SpecChoice::Generated { directions, stripe_width } => {
            // Keep within 300 stripes (see `custom_spec`).
            let reach = (pw as f64).hypot(ph as f64);
            PatternSpec::generate(*directions, pw, ph, stripe_width.max(reach / 300.0)).unwrap()
        }
        SpecChoice::Custom { families, low, gamma } => custom_spec(families, *low, *gamma, pw, ph),
    }
}

/// The stored pattern and its picture (made once: rendering a pattern takes a while).
fn stored_pattern() -> &'static (PatternSpec, Image<[u8; 3]>) {
    static P: OnceLock<(PatternSpec, Image<[u8; 3]>)> = OnceLock::new();
    P.get_or_init(|| {
        let spec = PatternSpec::from_json(STORED_SPEC).unwrap();
        let image = spec.render_rgb8();
        (spec, image)
    })
}

fn stored_frame() -> &'static Image<[u8; 3]> {
    static F: OnceLock<Image<[u8; 3]>> = OnceLock::new();
    F.get_or_init(|| io::decode_rgb8(STORED_FRAME).unwrap())
}

/// The simulator's scenes that frames are made of. (Not `Scene::NAMES`: its newer
/// scenes' chart texture panics with "attempt to multiply with overflow" at
/// `src/sim/texture.rs` on some views, a simulator bug outside what this file tests.)
const SCENES: &[&str] = &["plane", "sphere", "paper", "textured", "occluders"];

/// Largest frame (pixels) the simulator renders for a case; larger ones get stripes.
const MAX_SIMULATED_PIXELS: usize = 320 * 240;

fn build_frame(r: &FrameRecipe, w: usize, h: usize, spec: &PatternSpec, calib: &Calibration) -> Result<Image<[u8; 3]>, String> {
    let mut rng = SplitMix(r.seed);
    let encode = |lin: f64| (lin.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8;
    let stripes = |angle: f64, period: f64, second: Option<(f64, f64)>, albedo: f64| {
        let colour = |u: usize, v: usize, angle: f64, period: f64| {
            let (s, c) = angle.to_radians().sin_cos();
            let q = ((u as f64 * c + v as f64 * s) / period).floor() as i64;
            let j = q.rem_euclid(spec.sequence.len() as i64) as usize;
            spec.palette[spec.sequence[j] as usize]
        };
        let mut img = Image::new(w, h, [0u8; 3]);
        for v in 0..h {
            for u in 0..w {
                let a = colour(u, v, angle, period);
                let b = second.map_or([1.0; 3], |(angle, period)| colour(u, v, angle, period));
                *img.get_mut(u, v) = [0, 1, 2].map(|k| encode(a[k] * b[k] * albedo));
            }
        }
        img
    };
    let mut img = match &r.content {
        Content::Noise => Image::from_vec(w, h, (0..w * h).map(|_| rng.next().to_le_bytes()[..3].try_into().unwrap()).collect()).unwrap(),
        Content::Constant(c) => Image::new(w, h, *c),
        Content::Stripes { angle, period, second, albedo } => stripes(*angle, *period, *second, *albedo),
        Content::Saturated => {
            let mut img = Image::new(w, h, [255u8; 3]);
            for p in img.pixels_mut() {
                if rng.below(20) == 0 {
                    p[rng.below(3)] = rng.next() as u8;
                }
            }
            img
        }
        Content::Dark => Image::from_vec(w, h, (0..w * h).map(|_| [0, 1, 2].map(|_| rng.below(4) as u8)).collect()).unwrap(),
        Content::Simulated { scene } if w * h <= MAX_SIMULATED_PIXELS && spec.width * spec.height <= 1024 * 768 => {
            let cfg = SimConfig { seed: r.seed, projector_gamma: spec.encoding_gamma as f32, ..SimConfig::default() };
            let scene = Scene::builtin(SCENES[*scene]).unwrap();
            let shown = if *spec == stored_pattern().0 { std::borrow::Cow::Borrowed(&stored_pattern().1) } else { std::borrow::Cow::Owned(spec.render_rgb8()) };
            sim::render(&scene, calib, &shown, &cfg).map_err(|e| format!("the simulator refuses the case: {e}"))?.image
        }
        Content::Simulated { .. } => stripes(0.0, 6.5, Some((90.0, 6.5)), 0.8),
        Content::Sphere => {
            let src = stored_frame();
            let (sw, sh) = src.size();
            let mut img = Image::new(w, h, [0u8; 3]);
            for v in 0..h {
                for u in 0..w {
                    *img.get_mut(u, v) = src.get(u * sw / w, v * sh / h);
                }
            }
            img
        }
    };
    for _ in 0..r.damage {
        let (u0, v0) = (rng.below(w), rng.below(h));
        let (u1, v1) = ((u0 + 1 + rng.below(w / 3 + 1)).min(w), (v0 + 1 + rng.below(h / 3 + 1)).min(h));
        let kind = rng.below(3);
        for v in v0..v1 {
            for u in u0..u1 {
                *img.get_mut(u, v) = match kind {
                    0 => [0; 3],
                    1 => [255; 3],
                    _ => [rng.next() as u8, rng.next() as u8, rng.next() as u8],
                };
            }
        }
    }
    Ok(img)
}

/// Everything a scan gives is consistent and finite: depth maps hold positive finite
/// depths or NaN ("no depth"), every cloud point is finite and is the depth map's pixel
/// it claims to come from, with that pixel's colour, and the correspondences are finite
/// where (and only where) their family has a depth.
fn check_result(scanner: &Scanner, frame: &Image<[u8; 3]>, families: usize) -> Result<(), String> {
    let r = scanner.result();
    let (w, h) = frame.size();
    if r.depth.size() != (w, h) || r.family_depth.len() != families {
        return Err(format!("result shapes: depth {:?}, {} family depths for a {w}x{h} frame and {families} families", r.depth.size(), r.family_depth.len()));
    }
    let family_clouds = (0..families).map(|k| scanner.layer(Some(k)).map(|c| c.into_owned())).collect::<Result<Vec<_>, _>>().map_err(|e| format!("family cloud: {e}"))?;
    if scanner.layer(Some(families)).is_ok() {
        return Err(format!("a cloud of family {families} of {families}"));
    }
    let layers = std::iter::once((&r.depth, &r.cloud, None)).chain(r.family_depth.iter().zip(&family_clouds).enumerate().map(|(k, (d, c))| (d, c, Some(k))));
    for (depth, cloud, family) in layers {
        let name = family.map_or("merged".to_string(), |k| format!("family {k}"));
        if depth.size() != (w, h) {
            return Err(format!("{name} depth is {:?}", depth.size()));
        }
        if let Some((i, z)) = depth.pixels().iter().enumerate().find(|(_, z)| !(z.is_nan() || (z.is_finite() && **z > 0.0))) {
            return Err(format!("{name} depth at pixel {i} is {z}"));
        }
        let decoded = depth.pixels().iter().filter(|z| !z.is_nan()).count();
        let n = cloud.len();
        if n != decoded || cloud.positions.len() != 3 * n || cloud.colors.len() != 3 * n || cloud.pixels.len() != 2 * n {
            return Err(format!("{name} cloud has {n} points (arrays {}, {}, {}) for {decoded} depths", cloud.positions.len(), cloud.colors.len(), cloud.pixels.len()));
        }
        for i in 0..n {
            let p = cloud.position(i);
            let (u, v) = (cloud.pixels[2 * i], cloud.pixels[2 * i + 1]);
            if p.iter().any(|x| !x.is_finite()) {
                return Err(format!("{name} point {i} at ({u}, {v}) is {p:?}"));
            }
            if !(u >= 0.0 && v >= 0.0 && u.fract() == 0.0 && v.fract() == 0.0 && (u as usize) < w && (v as usize) < h) {
                return Err(format!("{name} point {i} comes from pixel ({u}, {v}) of a {w}x{h} frame"));
            }
            let (u, v) = (u as usize, v as usize);
            if p[2] != depth.get(u, v) || cloud.colors[3 * i..3 * i + 3] != frame.get(u, v) {
                return Err(format!("{name} point {i} {p:?} is not the depth {} or colour of its pixel ({u}, {v})", depth.get(u, v)));
            }
            let mask = cloud.families[i];
            let right = match family {
                None => mask != 0 && (mask as usize) < 1 << families,
                Some(k) => mask == 1 << k,
            };
            if !right {
                return Err(format!("{name} point {i} has family mask {mask:#b} ({families} families)"));
            }
        }
    }
    // Channel k: family k's projector coordinate exactly where it has a depth.
    let correspondence = r.correspondence();
    if correspondence.size() != (w, h) {
        return Err(format!("correspondence is {:?}", correspondence.size()));
    }
    for (i, c) in correspondence.pixels().iter().enumerate() {
        for (k, &s) in c.iter().enumerate() {
            let has_depth = k < families && !r.family_depth[k].pixels()[i].is_nan();
            if s.is_nan() == has_depth || s.is_infinite() {
                return Err(format!("correspondence at pixel {i} is {c:?} ({families} families, family {k} depth: {has_depth})"));
            }
        }
    }
    let s = &r.stats;
    let decoded: Vec<usize> = family_clouds.iter().map(|c| c.len()).collect();
    if (s.width, s.height, s.merged) != (w, h, r.cloud.len()) || s.decoded != decoded {
        return Err(format!("stats {s:?} disagree with the result ({w}x{h}, {} merged, {decoded:?})", r.cloud.len()));
    }
    if s.stage_ms.iter().any(|(_, ms)| !ms.is_finite()) {
        return Err(format!("stage timings {:?}", s.stage_ms));
    }
    Ok(())
}

/// Debug-build time allowed per pixel for making a scanner and scanning its frames
/// (measured: about 1 µs at 3840x2160 on the 2-core machine; 10x for a loaded machine),
/// and at least [`MIN_TIME`] for any case.
#[cfg(not(target_arch = "wasm32"))]
const TIME_PER_PIXEL: std::time::Duration = std::time::Duration::from_micros(10);
#[cfg(not(target_arch = "wasm32"))]
const MIN_TIME: std::time::Duration = std::time::Duration::from_secs(5);

/// Make the case's scanner and scan its frames; every outcome must be a clear error or
/// a result that passes [`check_result`], within bounded time. The outcome says whether
/// the rig, the scanner or a scan came out, and whether anything decoded.
fn run_scan_case(case: ScanCase) -> Result<&'static str, String> {
    let calib = match build_rig(&case) {
        Ok(c) => c,
        Err(e) => return one_line(&e).map(|_| "rig refused"),
    };
    calib.validate().map_err(|e| format!("the case's calibration is invalid: {e}"))?;
    let spec = build_spec(&case, &calib);
    spec.validate().map_err(|e| format!("the case's spec is invalid: {e}"))?;
    let (w, h) = (case.width as usize, case.height as usize);
    let frames = case.frames.iter().map(|r| build_frame(r, w, h, &spec, &calib)).collect::<Result<Vec<_>, _>>()?;
    let config = ScanConfig {
        filter: case.filter,
        camera_gamma: case.gamma,
        crosstalk: case.crosstalk.unwrap_or(IDENTITY_CROSSTALK),
        ..ScanConfig::default()
    };
    let families = spec.families.len();
    #[cfg(not(target_arch = "wasm32"))]
    let start = std::time::Instant::now();
    let mut scanner = match Scanner::new(spec, calib, config) {
        Ok(s) => s,
        Err(e) => return one_line(&e).map(|_| "scanner refused"),
    };
    #[cfg(not(target_arch = "wasm32"))]
    let made = start.elapsed();
    let mut decoded = false;
    if scanner.size() != (w, h) {
        return Err(format!("a scanner for a {w}x{h} camera takes {:?} frames", scanner.size()));
    }
    for (k, frame) in frames.iter().enumerate() {
        // A frame of the right size is always a result, however little decodes.
        scanner.scan(frame).map_err(|e| format!("frame {k} of the right size is refused: {e}"))?;
        check_result(&scanner, frame, families).map_err(|e| format!("frame {k}: {e}"))?;
        check_frame_mixing(&scanner).map_err(|e| format!("frame {k}: {e}"))?;
        let result = scanner.result();
        decoded |= !result.cloud.is_empty() || result.stats.decoded.iter().any(|&n| n > 0);
        if w * h <= 64 * 64 {
            // The teaching view's pictures of every stage.
            let stages = scanner.stages();
            if let Some(s) = stages.iter().find(|s| s.image.size() != (w, h) || s.name.is_empty() || s.caption.contains('\n')) {
                return Err(format!("stage {:?} is {:?}", s.name, s.image.size()));
            }
        }
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let elapsed = start.elapsed();
        let allowed = MIN_TIME.max(TIME_PER_PIXEL * (w * h * frames.len()) as u32);
        if elapsed > allowed {
            return Err(format!(
                "{w}x{h}, {} frames took {elapsed:?}, more than {allowed:?} (making the scanner {made:?}; last frame's stages, ms: {:?})",
                frames.len(),
                scanner.result().stats.stage_ms
            ));
        }
    }
    Ok(if decoded { "decoded" } else { "nothing decoded" })
}

/// The colour mixing read from the scanned frame ([`Scanner::estimate_crosstalk`]):
/// either a matrix the scanner can use (finite, not negative, each column summing to
/// 1, invertible) or a one-line refusal that names it.
fn check_frame_mixing(scanner: &Scanner) -> Result<(), String> {
    match scanner.estimate_crosstalk() {
        Ok(m) => {
            let columns_sum_to_one = (0..3).all(|k| ((0..3).map(|c| m.crosstalk[c][k]).sum::<f32>() - 1.0).abs() < 1e-4);
            if !(m.crosstalk.iter().flatten().all(|x| x.is_finite() && *x >= 0.0) && columns_sum_to_one) {
                return Err(format!("the colour mixing read from the frame is {:?}", m.crosstalk));
            }
            stripelight::calib::crosstalk_inverse(&m.crosstalk).map_err(|e| format!("the colour mixing read from the frame cannot be used: {e}"))?;
            Ok(())
        }
        Err(e) => {
            let m = one_line(&e)?;
            if m.starts_with("colour mixing from the frame: ") { Ok(()) } else { Err(format!("the colour mixing's refusal does not name it: {m}")) }
        }
    }
}

/// Sizes from 8x8 to `max`, most of them small (cubed uniform fractions).
fn skewed_size(max: (u32, u32)) -> impl Strategy<Value = (u32, u32)> {
    let side = |m: u32| (0.0..=1.0f64).prop_map(move |x| 8 + ((m - 8) as f64 * x * x * x).round() as u32);
    (side(max.0), side(max.1))
}

/// Largest frame and cases of the scanner properties, and the outcomes the "any size"
/// one must see. The browser's test runner gives a whole test file 20 s
/// (`WASM_BINDGEN_TEST_TIMEOUT`), and a debug wasm build scans about half as fast as a
/// native one: fewer and smaller frames there, too few to be sure one decodes (the
/// browser's decoding is `tests/parity.rs`'s business).
#[cfg(not(target_arch = "wasm32"))]
const SCAN_CASES: (u32, (u32, u32), u32, &[&str]) = (96, (1920, 1080), 16, &["decoded"]);
#[cfg(target_arch = "wasm32")]
const SCAN_CASES: (u32, (u32, u32), u32, &[&str]) = (24, (640, 480), 4, &[]);

both_targets! {
/// The scanner on frames from 1x1 to 48x48: anything from "too small" to a few stripes.
fn scanner_on_tiny_frames() {
    let tiny = || (1..=48u32, 1..=48u32);
    check(property!("scan_tiny"), SCAN_CASES.0, 64, &["scanner refused", "nothing decoded"], scan_case(tiny(), tiny(), 1..=2), run_scan_case);
}

/// The scanner on frames of any size up to full HD (the browser: 640x480).
fn scanner_on_frames_of_any_size() {
    let (_, max, cases, must_see) = SCAN_CASES;
    // Sample frames from a quarter of the largest size up, where the stripes are wide
    // enough to decode.
    let sample = (max.0 / 4..=max.0, max.1 / 4..=max.1);
    check(property!("scan_any_size"), cases, 16, must_see, scan_case(skewed_size(max), sample, 1..=2), run_scan_case);
}

/// Accepted mutated pattern specs (odd angles, origins, palettes, gammas) scanned on a
/// small camera of the demo rig.
fn mutated_specs_that_parse_also_scan() {
    check(property!("spec_mutated_scan"), 256, 256, &["scanned"], (mutated_up_to(1, |t| &t.specs), any::<u64>()), |(text, seed)| {
        let Ok(spec) = PatternSpec::from_json(&text) else { return Ok("not parsed") };
        let mut calib = Calibration::demo();
        (calib.projector.width, calib.projector.height) = (spec.width, spec.height);
        scale_camera(&mut calib, 40, 30);
        scan_small(spec, calib, seed).map_err(|e| format!("{e}\nspec: {text}"))
    });
}

/// Accepted mutated calibrations (odd focal lengths, distortion, rotations, baselines)
/// scanned with a two-direction pattern for their projector, their camera shrunk to
/// 40x30 (same field of view) when it is larger than 64x64.
fn mutated_calibrations_that_parse_also_scan() {
    check(property!("calib_mutated_scan"), 256, 256, &["scanned"], (mutated_up_to(1, |t| &t.calibs), any::<u64>()), |(text, seed)| {
        let Ok(mut calib) = Calibration::from_json(&text) else { return Ok("not parsed") };
        if calib.camera.width as u64 * calib.camera.height as u64 > 64 * 64 {
            // Large frames are the other properties' business: keep the field of view.
            scale_camera(&mut calib, 40, 30);
        }
        let spec = PatternSpec::generate(2, calib.projector.width.min(4096), calib.projector.height.min(4096), 40.0).unwrap();
        scan_small(spec, calib, seed).map_err(|e| format!("{e}\ncalibration: {text}"))
    });
}
}

/// Generated patterns: any number of directions, projector size and stripe width gives
/// a one-line error or a spec that validates.
fn generator_case((directions, width, height, stripe_width): (usize, u32, u32, f64)) -> Result<&'static str, String> {
    if stripe_width > 0.0 && (width as f64).hypot(height as f64) / stripe_width > 400.0 {
        return Ok("skipped"); // long sequences take the search a while: see `tests/pattern.rs`
    }
    match PatternSpec::generate(directions, width, height, stripe_width) {
        // The arguments are settings: the error names the one that is wrong.
        Err(e @ Error::Setting { .. }) => one_line(&e).map(|_| "refused"),
        Err(e) => Err(format!("an error that does not name the argument: {e}")),
        Ok(spec) => spec.validate().map(|_| "generated").map_err(|e| format!("generated spec is invalid: {e}")),
    }
}

both_targets! {
/// `PatternSpec::generate` on any arguments (what `stripelight pattern` and the page's
/// pattern panel pass on).
fn pattern_generator_on_any_arguments() {
    let size = prop_oneof![3 => 1..64u32, 2 => 64..2048u32, 1 => any::<u32>()];
    let stripe_width = prop_oneof![3 => 1.0..60.0f64, 1 => any::<f64>(), 1 => Just(2.0)];
    check(property!("pattern_generate"), 256, 256, &["generated", "refused"], (0..=4usize, size.clone(), size, stripe_width), generator_case);
}
}

/// Make a scanner (a clear error is fine) and scan a noise frame and a stripe frame.
fn scan_small(spec: PatternSpec, calib: Calibration, seed: u64) -> Result<&'static str, String> {
    let (w, h) = (calib.camera.width as usize, calib.camera.height as usize);
    let recipes = [
        FrameRecipe { content: Content::Noise, seed, damage: 0 },
        FrameRecipe { content: Content::Stripes { angle: (seed % 180) as f64, period: 5.0, second: None, albedo: 0.9 }, seed, damage: 0 },
    ];
    let frames = recipes.iter().map(|r| build_frame(r, w, h, &spec, &calib)).collect::<Result<Vec<_>, _>>()?;
    let families = spec.families.len();
    let mut scanner = match Scanner::new(spec, calib, ScanConfig::default()) {
        Ok(s) => s,
        Err(e) => return one_line(&e).map(|_| "scanner refused"),
    };
    for frame in &frames {
        scanner.scan(frame).map_err(|e| format!("a frame of the right size is refused: {e}"))?;
        check_result(&scanner, frame, families)?;
    }
    Ok("scanned")
}

/// The scanner at 4K (3840x2160): any pattern, rig, filter and content. Native only:
/// each case takes 10 to 30 s in a debug build, and about 2 GB.
#[cfg(not(target_arch = "wasm32"))]
#[test]
fn scanner_on_4k_frames() {
    check(property!("scan_4k"), 2, 0, &[], scan_case(Just((3840u32, 2160u32)), Just((3840u32, 2160u32)), 1..=1), run_scan_case);
}

/// Scanner cases that once failed, written out (a proptest seed stops meaning the same
/// input when a strategy changes; these do not). Native only, for the time bound.
///
/// - A 4K frame, three families at odd angles, a narrow camera (26 degrees) on a
///   projector with distortion: the filter stage took 250-350 s (the bound is 83 s).
///   `filter::smooth_along_stripes` (three families) costs the frame's pixels times the
///   box length, which is the other families' predicted period in camera pixels
///   (`other_families_period` in `src/scan.rs`): 630, 239 and 242 pixels here, so
///   about 3e10 samples.
#[cfg(not(target_arch = "wasm32"))]
#[test]
fn scanner_cases_that_once_failed() {
    let slow_smoothing = ScanCase {
        width: 3840,
        height: 2160,
        spec: SpecChoice::Custom {
            families: vec![(-43.34703907648782, 4.9853773351300665), (158.94801675695538, 54.0212290035445), (-122.98061524064843, 48.6926914390276)],
            low: 0.6173477299804074,
            gamma: 2.590081026785048,
        },
        rig: RigChoice::Random {
            camera_hfov: 26.00357781772649,
            projector: (1291, 325),
            projector_hfov: 61.64639105509714,
            azimuth: 2.105856675259756,
            elevation: -0.1150638366818211,
            baseline: 364.30491893586736,
            aim: 2112.1781814076917,
            distortion: Some((
                [-0.25700152547392197, -0.09302683708564811, -0.0006478400022956148, 0.0012062657031729645, 0.02656893308835979],
                [-0.006611004444311091, 0.02476730478968482, 0.0014701547737459542, -0.0015411759518729042, 0.047596616382451176],
            )),
        },
        filter: FilterMode::Direct,
        crosstalk: Some([[0.87762207, -0.09073592, 0.022875084], [0.10107239, 0.8246321, 0.29985768], [-0.06426958, 0.19419236, 0.92235947]]),
        gamma: 4.07492,
        frames: vec![FrameRecipe { content: Content::Stripes { angle: 0.0, period: 6.5, second: Some((90.0, 6.5)), albedo: 0.8 }, seed: 2145904408841516856, damage: 0 }],
    };
    for case in [slow_smoothing] {
        let shown = format!("{case:?}");
        if let Err(e) = run_scan_case(case) {
            panic!("{e}\ncase: {shown}");
        }
    }
}
