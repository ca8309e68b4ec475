//! The regression corpus: every file in `tests/data/corpus/KIND/` goes to its parser
//! and must pass the parser's check in `tests/support/properties.rs` (no panic; a
//! one-line error that names the field or the format, or an accepted value that is
//! finite and round-trips). `tests/data/corpus/expected.txt` further says, for the
//! files it lists, whether the parser accepts or refuses them and what the refusal
//! must name. The hand-picked bad inputs are here, and every input that once broke a
//! parser, found by the properties of `tests/props.rs` or by hand (the file list in
//! `expected.txt` says which).
//!
//! To add a case, drop the raw file into the folder of its kind; list it in
//! `expected.txt` to pin down the verdict. Native only: it reads the folders.
#![cfg(not(target_arch = "wasm32"))]

#[path = "support/properties.rs"]
mod properties;

use properties::*;
use std::collections::BTreeMap;
use std::path::Path;

/// The parser's check for each folder of the corpus.
fn checker(kind: &str) -> Option<fn(&[u8]) -> Result<Verdict, String>> {
    fn text(bytes: &[u8], check: fn(&str) -> Result<Verdict, String>) -> Result<Verdict, String> {
        // The parsers take text: bytes that are not UTF-8 never reach them (the CLI and
        // the page refuse them when reading the file).
        match std::str::from_utf8(bytes) {
            Ok(t) => check(t),
            Err(_) => Ok(Verdict::Refused("not UTF-8".into())),
        }
    }
    Some(match kind {
        "spec" => |b| text(b, check_spec_text),
        "calib" => |b| text(b, check_calib_text),
        "rig" => |b| text(b, check_rig_text),
        "crosstalk" => |b| text(b, check_crosstalk_text),
        "pfm" => check_pfm_bytes,
        "image" => check_image_bytes,
        _ => return None,
    })
}

/// `expected.txt`: `KIND/FILE  accept` or `KIND/FILE  refuse  TEXT THE MESSAGE CONTAINS`
/// per line, `#` comments.
fn expectations(dir: &Path) -> BTreeMap<String, (bool, String)> {
    let text = std::fs::read_to_string(dir.join("expected.txt")).expect("tests/data/corpus/expected.txt");
    let mut out = BTreeMap::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.split(" #").next().unwrap_or("").trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let path = line.split_whitespace().next().unwrap_or("");
        let rest = line[path.len()..].trim_start();
        let verdict = rest.split_whitespace().next().unwrap_or("");
        let needle = rest[verdict.len()..].trim();
        let accept = match verdict {
            "accept" => true,
            "refuse" => false,
            v => panic!("expected.txt line {}: verdict {v:?} is neither accept nor refuse", n + 1),
        };
        assert!(accept || !needle.is_empty(), "expected.txt line {}: a refusal needs the text it must contain", n + 1);
        assert!(out.insert(path.to_string(), (accept, needle.to_string())).is_none(), "expected.txt lists {path} twice");
    }
    out
}

#[test]
fn every_corpus_file_is_parsed_or_refused_clearly() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/corpus");
    let mut expected = expectations(&dir);
    let mut failures = Vec::new();
    let mut counts: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    let mut kinds: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.is_dir()).collect();
    kinds.sort();
    for kind_dir in kinds {
        let kind = kind_dir.file_name().unwrap().to_string_lossy().into_owned();
        let check = checker(&kind).unwrap_or_else(|| panic!("tests/data/corpus/{kind}: no parser for this folder"));
        let mut files: Vec<_> = std::fs::read_dir(&kind_dir).unwrap().map(|e| e.unwrap().path()).collect();
        files.sort();
        for file in files {
            let name = format!("{kind}/{}", file.file_name().unwrap().to_string_lossy());
            let bytes = std::fs::read(&file).unwrap();
            let verdict = match check(&bytes) {
                Ok(v) => v,
                Err(why) => {
                    failures.push(format!("{name}: {why}"));
                    continue;
                }
            };
            let c = counts.entry(kind.clone()).or_default();
            match &verdict {
                Verdict::Accepted => c.0 += 1,
                Verdict::Refused(_) => c.1 += 1,
            }
            match (expected.remove(&name), &verdict) {
                (None, _) | (Some((true, _)), Verdict::Accepted) => {}
                (Some((false, needle)), Verdict::Refused(m)) if m.contains(&needle) => {}
                (Some((false, needle)), Verdict::Refused(m)) => failures.push(format!("{name}: refused without naming {needle:?}: {m}")),
                (Some((false, _)), Verdict::Accepted) => failures.push(format!("{name}: accepted, but expected.txt says refuse")),
                (Some((true, _)), Verdict::Refused(m)) => failures.push(format!("{name}: refused, but expected.txt says accept: {m}")),
            }
        }
    }
    for name in expected.keys() {
        failures.push(format!("{name}: listed in expected.txt but not in the corpus"));
    }
    let summary: Vec<String> = counts.iter().map(|(k, (a, r))| format!("{k} {} ({a} accepted, {r} refused)", a + r)).collect();
    report(&format!("corpus: {}", summary.join(", ")));
    assert!(failures.is_empty(), "{} corpus files break their parser's promises:\n{}", failures.len(), failures.join("\n"));
}

/// Arguments of `PatternSpec::generate` that once gave a spec its own validation refuses
/// (found by the property `pattern_generate`): projectors narrower than three stripes,
/// and stripes so wide that the pattern's extent overflows.
#[test]
fn generator_arguments_that_once_failed() {
    for (directions, width, height, stripe_width) in [(1, 1, 1, 10.0), (2, 3, 2, 2.0), (3, 1, 5000, 40.0)] {
        let spec = stripelight::PatternSpec::generate(directions, width, height, stripe_width).unwrap();
        spec.validate().unwrap();
    }
    let e = stripelight::PatternSpec::generate(2, 1024, 768, 1e308).unwrap_err().to_string();
    assert!(e.starts_with("stripe width: "), "{e}");
}
