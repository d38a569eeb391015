//! A method enum's variants are named in two files only (ARCHITECTURE.md, "Method enums and
//! their dispatch sites"): the enum's own, where its exhaustive property functions are, and
//! one dispatch site in the kernel's layer. Everywhere else the code asks a property. A path
//! `Enum::Variant` (so any `match`, `matches!`, `==` or `!=` on a variant), an import
//! `Enum::{…}` or `Enum::*`, or an alias `Enum as …` elsewhere fails here with its file.
//! Comments, string literals and unit-test modules are left out, as in `tests/layers.rs`.

use std::path::{Path, PathBuf};

/// Each enum: its name, its own file and its one dispatch site (paths under `src/`).
const ENUMS: &[(&str, &str, &str)] = &[
    ("WallMethod", "scene/walls.rs", "boundary/mod.rs"),
    ("DensityDiffusion", "scene/mod.rs", "physics/fluid.rs"),
    ("PressureGradient", "scene/mod.rs", "physics/fluid.rs"),
    ("Probe", "scene/probes.rs", "probes/sensors.rs"),
];

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The variants of `pub enum name { … }` in `code`: the identifiers at depth 1.
fn variants(code: &str, name: &str) -> Vec<String> {
    let head = format!("pub enum {name} {{");
    let start = code.find(&head).unwrap_or_else(|| panic!("no `{head}`")) + head.len();
    let mut depth = 1;
    let mut out = Vec::new();
    let mut word = String::new();
    let mut attr = 0;
    for c in code[start..].chars() {
        if c.is_ascii_alphanumeric() || c == '_' {
            word.push(c);
            continue;
        }
        if depth == 1 && attr == 0 && word.starts_with(|c: char| c.is_ascii_uppercase()) {
            out.push(std::mem::take(&mut word));
        }
        word.clear();
        match c {
            '#' if depth == 1 => attr = 1,
            '[' if attr > 0 => attr += 1,
            ']' if attr > 0 => attr = if attr == 2 { 0 } else { attr - 1 },
            '{' | '(' => depth += 1,
            '}' | ')' => {
                depth -= 1;
                if depth == 0 {
                    break;
                }
            }
            _ => {}
        }
    }
    out
}

/// Where `code` names a variant of `name` (`name::Variant`), imports from it
/// (`name::{`, `name::*`) or renames it (`name as`), as the text found.
fn namings(code: &str, name: &str, vs: &[String]) -> Vec<String> {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(k) = code[from..].find(name) {
        let at = from + k;
        from = at + name.len();
        if code[..at].chars().next_back().is_some_and(ident) {
            continue;
        }
        let rest = code[from..].trim_start();
        if let Some(r) = rest.strip_prefix("::") {
            let r = r.trim_start();
            let n = r.find(|c: char| !ident(c)).unwrap_or(r.len());
            if r.starts_with('{') || r.starts_with('*') || vs.iter().any(|v| *v == r[..n]) {
                out.push(format!("{name}::{}", &r[..n.max(1)]));
            }
        } else if rest.starts_with("as ") {
            out.push(format!("{name} as"));
        }
    }
    out
}

#[test]
fn method_variants_are_named_in_their_enums_file_and_one_dispatch_site() {
    let root = src();
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    files.sort();
    let arch = std::fs::read_to_string(root.join("../ARCHITECTURE.md")).unwrap();
    let mut bad = Vec::new();
    for &(name, own, site) in ENUMS {
        let own_code = super::layers::code_of(&std::fs::read_to_string(root.join(own)).unwrap());
        let vs = variants(&own_code, name);
        assert!(vs.len() >= 2, "{name}: variants {vs:?} read from {own}");
        for f in [own, site] {
            assert!(
                arch.contains(&format!("`{f}`")),
                "ARCHITECTURE.md does not name `{f}`, {name}'s file or dispatch site"
            );
        }
        for f in &files {
            let rel = f
                .strip_prefix(&root)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            if rel == own || rel == site || rel.ends_with("/tests.rs") {
                continue;
            }
            let code = super::layers::code_of(&std::fs::read_to_string(f).unwrap());
            for n in namings(&code, name, &vs) {
                bad.push(format!("src/{rel}: {n}"));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "method variants named outside their enum's file and dispatch site (ask a property \
         next to the enum instead):\n{}",
        bad.join("\n")
    );
}

/// The scan itself: it reads variants past attributes and struct-like fields, and finds a
/// path, a group import, a glob and an alias, but not a property call.
#[test]
fn the_scan_finds_paths_imports_and_aliases() {
    let code = "pub enum E { #[default] A, B { x: Vec<f64> }, #[cfg(test)] C(u8) }";
    assert_eq!(variants(code, "E"), ["A", "B", "C"]);
    let vs: Vec<String> = ["A", "B"].iter().map(|s| s.to_string()).collect();
    let found = namings(
        "if m == E::A {} matches!(m, E :: B); use x::E::{A, B}; use E::*; use E as F; E::prop(m); NE::A",
        "E",
        &vs,
    );
    assert_eq!(found, ["E::A", "E::B", "E::{", "E::*", "E as"]);
}
