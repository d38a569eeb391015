//! The module layers of `src/` (ARCHITECTURE.md, "Layers"): every `crate::` path of every
//! source file — `use` lines and inline paths alike, comments and unit-test modules left out —
//! must point to a module of a lower layer, and no files of one module may depend on each
//! other in a cycle. A new upward path or cycle fails here with the file that makes it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Top-level modules, lowest layer first. A module may use the modules of the layers below
/// its own, never one of its own layer or above.
const LAYERS: &[&[&str]] = &[
    // values, errors, numbers with no knowledge of the simulation
    &[
        "error",
        "kernel",
        "exact",
        "stokes_cavity",
        "progress",
        "joblayout",
        "with_dim",
        // the pair-kernel dispatcher of kernel::sizes (macro_export puts it at the crate root)
        "with_pair_kernel",
    ],
    &["limits", "particles", "decomp", "affinity", "material"],
    // input: what a run is asked to do, and files
    &["scene", "comm", "jobscript", "files"],
    &["topology", "signals", "cells", "ids"],
    // methods
    &["boundary", "placement"],
    &["physics", "halo", "layout", "checkpoint"],
    &["setup"],
    // the engine
    &["sim", "memory"],
    // what a run writes and measures
    &["output"],
    &["probes", "plan"],
    &["reference", "model"],
    // commands
    &["driver", "report"],
    &["bench", "validate"],
    &["cli"],
];

/// The crate-level names that are not modules (types re-exported by `lib.rs`).
const NOT_MODULES: &[&str] = &["Vector", "Tensor", "Matrix"];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

/// Source text without comments, string literals and `#[cfg(test)] mod tests` blocks.
pub(crate) fn code_of(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(k) => &text[..k],
        None => text,
    };
    let mut out = String::with_capacity(text.len());
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            i += 2;
            while i + 1 < b.len() && !(b[i] == b'*' && b[i + 1] == b'/') {
                i += 1;
            }
            i += 2;
        } else if b[i] == b'"' && (i == 0 || (b[i - 1] != b'\'' && b[i - 1] != b'r' && b[i - 1] != b'#')) {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    out
}

/// Every path that starts with `prefix` (`crate::` or `super::`) in `code`, as its segments;
/// a group `prefix{a::b, c}` gives one path per member.
fn paths(code: &str, prefix: &str) -> Vec<Vec<String>> {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(k) = rest.find(prefix) {
        let before = rest[..k].chars().next_back();
        rest = &rest[k + prefix.len()..];
        if before.is_some_and(ident) {
            continue;
        }
        let mut segs = Vec::new();
        let mut s = rest;
        loop {
            let n = s.find(|c: char| !ident(c)).unwrap_or(s.len());
            if n == 0 {
                break;
            }
            segs.push(s[..n].to_string());
            s = &s[n..];
            match s.strip_prefix("::") {
                Some(t) => s = t,
                None => break,
            }
        }
        if segs.is_empty() && s.starts_with('{') {
            let end = s.find('}').unwrap_or(s.len());
            for member in s[1..end].split(',') {
                let m: Vec<String> = member
                    .trim()
                    .split("::")
                    .map(|p| p.trim().to_string())
                    .filter(|p| !p.is_empty() && p.chars().all(ident))
                    .collect();
                if !m.is_empty() {
                    out.push(m);
                }
            }
        } else if !segs.is_empty() {
            out.push(segs);
        }
    }
    out
}

/// Source files of `src/` with their module paths (`a/b.rs` and `a/b/mod.rs` are `a::b`).
fn sources() -> Vec<(PathBuf, Vec<String>)> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    walk(&root, &mut files);
    files.sort();
    files
        .into_iter()
        .filter_map(|f| {
            let rel = f.strip_prefix(&root).unwrap().with_extension("");
            let mut m: Vec<String> = rel.iter().map(|s| s.to_string_lossy().into_owned()).collect();
            if m.last().is_some_and(|s| s == "mod") {
                m.pop();
            }
            // the crate root and the binary; unit tests kept in their own files
            let skip = m == ["lib"] || m == ["main"] || m.last().is_some_and(|s| s == "tests");
            (!skip).then_some((f, m))
        })
        .collect()
}

#[test]
fn every_crate_path_points_down_the_layers() {
    let mut bad = Vec::new();
    let mut unknown = BTreeSet::new();
    for (file, module) in sources() {
        let top = module[0].as_str();
        let Some(mine) = layer_of(top) else {
            unknown.insert(top.to_string());
            continue;
        };
        let code = code_of(&std::fs::read_to_string(&file).unwrap());
        for p in paths(&code, "crate::") {
            let to = p[0].as_str();
            if to == top || NOT_MODULES.contains(&to) {
                continue;
            }
            match layer_of(to) {
                None => {
                    unknown.insert(to.to_string());
                }
                Some(theirs) if theirs >= mine => bad.push(format!(
                    "{}: `crate::{}` — `{top}` (layer {mine}) may not use `{to}` (layer {theirs})",
                    file.display(),
                    p.join("::")
                )),
                Some(_) => {}
            }
        }
    }
    assert!(
        unknown.is_empty(),
        "modules missing from LAYERS in tests/layers.rs (place each in the layer its uses allow): {unknown:?}"
    );
    assert!(bad.is_empty(), "upward paths:\n{}", bad.join("\n"));
}

/// Files of one top-level module: the graph of which uses which (`super::` and `crate::`
/// paths resolved to the longest known module; a module and its own ancestors or
/// descendants do not count, a parent declares its children and they use its items) has no
/// cycle.
#[test]
fn no_cycle_between_the_files_of_a_module() {
    let files = sources();
    let known: BTreeSet<Vec<String>> = files.iter().map(|(_, m)| m.clone()).collect();
    let resolve = |p: &[String]| -> Option<Vec<String>> {
        (1..=p.len())
            .rev()
            .map(|n| p[..n].to_vec())
            .find(|m| known.contains(m))
    };
    let related = |a: &[String], b: &[String]| a.starts_with(b) || b.starts_with(a);
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for (file, module) in &files {
        let code = code_of(&std::fs::read_to_string(file).unwrap());
        let mut targets: Vec<Vec<String>> = paths(&code, "crate::");
        // super:: from a file module is its parent module
        let parent = &module[..module.len() - 1];
        for p in paths(&code, "super::") {
            let mut full = parent.to_vec();
            full.extend(p.into_iter().filter(|s| s != "super"));
            targets.push(full);
        }
        for t in targets {
            if let Some(to) = resolve(&t) {
                if to[0] == module[0] && !related(&to, module) {
                    edges.entry(module.clone()).or_default().insert(to);
                }
            }
        }
    }
    // a cycle exists iff some module reaches itself
    let mut cycles = Vec::new();
    for start in edges.keys() {
        let mut seen = BTreeSet::new();
        let mut stack: Vec<Vec<String>> = edges[start].iter().cloned().collect();
        while let Some(m) = stack.pop() {
            if &m == start {
                cycles.push(start.join("::"));
                break;
            }
            if seen.insert(m.clone()) {
                stack.extend(edges.get(&m).into_iter().flatten().cloned());
            }
        }
    }
    assert!(
        cycles.is_empty(),
        "files on a cycle with their siblings: {cycles:?}"
    );
}

/// The scanner itself: inline paths, groups and comments.
#[test]
fn the_scanner_reads_inline_paths_and_groups_and_skips_comments() {
    let code = code_of(
        "use crate::{a::B, c};\n// crate::hidden\nlet x = crate::d::e(\"crate::s\");\nmy_crate::f;\n/* crate::g */",
    );
    let got: Vec<String> = paths(&code, "crate::").iter().map(|p| p.join("::")).collect();
    assert_eq!(got, ["a::B", "c", "d::e"]);
}
