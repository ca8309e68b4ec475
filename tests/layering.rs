//! The crate's module dependency graph, drawn from the sources: every `crate::m` a
//! module names outside comments is an edge. The test prints the graph, fails on a
//! cycle, and checks that the table in `src/lib.rs` lists every module with exactly
//! the modules it uses.
#![cfg(not(target_arch = "wasm32"))]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Graph = BTreeMap<String, BTreeSet<String>>;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The names `crate::NAME` in `line`.
fn crate_paths(line: &str) -> impl Iterator<Item = &str> {
    line.match_indices("crate::").map(move |(i, _)| {
        let rest = &line[i + "crate::".len()..];
        let end = rest.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(rest.len());
        &rest[..end]
    })
}

/// Top-level module -> the other top-level modules it uses.
fn graph(src: &Path) -> Graph {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let mut g = Graph::new();
    for file in files {
        let rel = file.strip_prefix(src).unwrap();
        let first = rel.iter().next().unwrap().to_str().unwrap();
        if first == "lib.rs" || first == "main.rs" {
            continue;
        }
        let module = first.trim_end_matches(".rs").to_string();
        let uses = g.entry(module.clone()).or_default();
        for line in std::fs::read_to_string(&file).unwrap().lines() {
            if line.trim_start().starts_with("//") {
                continue;
            }
            for m in crate_paths(line) {
                if !m.is_empty() && m != module {
                    uses.insert(m.to_string());
                }
            }
        }
    }
    g
}

/// A cycle in `g`, if there is one, as the modules along it.
fn find_cycle(g: &Graph) -> Option<Vec<String>> {
    fn visit(g: &Graph, m: &str, state: &mut BTreeMap<String, u8>, stack: &mut Vec<String>) -> Option<Vec<String>> {
        match state.get(m) {
            Some(2) => return None,
            Some(1) => {
                let start = stack.iter().position(|s| s == m).unwrap();
                let mut cycle = stack[start..].to_vec();
                cycle.push(m.to_string());
                return Some(cycle);
            }
            _ => {}
        }
        state.insert(m.to_string(), 1);
        stack.push(m.to_string());
        for next in g.get(m).into_iter().flatten() {
            if let Some(c) = visit(g, next, state, stack) {
                return Some(c);
            }
        }
        stack.pop();
        state.insert(m.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    g.keys().find_map(|m| visit(g, m, &mut state, &mut Vec::new()))
}

/// The table in `src/lib.rs`: module -> its "uses" column.
fn documented(lib: &str) -> Graph {
    let mut g = Graph::new();
    for line in lib.lines().filter_map(|l| l.strip_prefix("//! |")) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 3 || cells[0] == "stage" || cells[0].starts_with("---") {
            continue;
        }
        let module = cells[1].trim_matches(|c| c == '[' || c == ']' || c == '`').to_string();
        let uses = cells[2].split(',').map(str::trim).filter(|s| !s.is_empty()).map(String::from).collect();
        g.insert(module, uses);
    }
    g
}

#[test]
fn modules_form_no_cycle_and_lib_rs_says_how_they_depend() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let g = graph(&root.join("src"));
    println!("module dependency graph (module -> modules it uses):");
    for (m, uses) in &g {
        println!("  {m:12} -> {}", uses.iter().cloned().collect::<Vec<_>>().join(", "));
    }
    assert_eq!(find_cycle(&g), None, "the modules depend on each other in a cycle");

    let lib = std::fs::read_to_string(root.join("src/lib.rs")).unwrap();
    let declared: BTreeSet<String> = lib
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod "))
        .map(|m| m.trim_end_matches(';').to_string())
        .collect();
    let table = documented(&lib);
    assert_eq!(declared, table.keys().cloned().collect::<BTreeSet<_>>(), "lib.rs's table must list every module");
    assert_eq!(declared, g.keys().cloned().collect::<BTreeSet<_>>(), "every module has a file");
    for (m, uses) in &g {
        assert_eq!(&table[m], uses, "lib.rs's table: what `{m}` uses");
    }
}

#[test]
fn the_cycle_finder_finds_cycles() {
    let edges = |pairs: &[(&str, &str)]| {
        let mut g = Graph::new();
        for (a, b) in pairs {
            g.entry(a.to_string()).or_default().insert(b.to_string());
            g.entry(b.to_string()).or_default();
        }
        g
    };
    assert_eq!(find_cycle(&edges(&[("a", "b"), ("b", "c"), ("a", "c")])), None);
    let cycle = find_cycle(&edges(&[("scan", "stages"), ("stages", "filter"), ("filter", "scan")])).unwrap();
    assert_eq!(cycle.first(), cycle.last());
    assert_eq!(cycle.len(), 4, "{cycle:?}");
    assert_eq!(crate_paths("use crate::scan::{A, B}; crate::io::x").collect::<Vec<_>>(), ["scan", "io"]);
}
