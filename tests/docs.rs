//! The docs tell the truth about the repository: every scene shipped in `inputs/` is in
//! README's scene table, every file path and every `module::item` path that README.md,
//! ARCHITECTURE.md and `docs/` cite exists, and BENCHMARKS.md is the rendering of its records
//! (`tools/bench_render.py`, BENCHMARKS.md "Commands"). Reads text only: no scene runs.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Every file under `dir` (recursively) whose name ends with `ext`, sorted.
fn files_under(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.to_string_lossy().ends_with(ext) {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The documents whose citations are checked: README.md, ARCHITECTURE.md and every page of
/// `docs/` but the benchmark log, a dated record whose entries cite the files of the commit
/// each names (some since moved or gone, and scripts that lived outside the repository).
fn documents() -> Vec<PathBuf> {
    let r = root();
    let mut docs = vec![r.join("README.md"), r.join("ARCHITECTURE.md")];
    docs.extend(
        files_under(&r.join("docs"), ".md")
            .into_iter()
            .filter(|p| !p.ends_with("benchmark-log.md")),
    );
    docs
}

/// The text of a markdown page outside its fenced code blocks, line by line (numbered from 1).
fn prose_lines(text: &str) -> Vec<(usize, &str)> {
    let mut fenced = false;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced {
            out.push((i + 1, line));
        }
    }
    out
}

/// The spans between single backticks of one line.
fn code_spans(line: &str) -> Vec<&str> {
    line.split('`').skip(1).step_by(2).collect()
}

// ---------------------------------------------------------------------------------------------
// Scenes

#[test]
fn every_shipped_scene_is_in_the_readme_scene_table() {
    let readme = read(&root().join("README.md"));
    let start = readme
        .find("## Scenes shipped")
        .expect("README has a \"Scenes shipped\" section");
    let rest = &readme[start + 3..];
    let table = &rest[..rest.find("\n## ").unwrap_or(rest.len())];
    let listed: BTreeSet<&str> = table
        .lines()
        .filter(|l| l.starts_with('|'))
        .filter_map(|l| l.split('|').nth(1))
        .flat_map(code_spans)
        .collect();
    let missing: Vec<String> = files_under(&root().join("inputs"), ".toml")
        .iter()
        .filter(|p| p.parent() == Some(&root().join("inputs")))
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .filter(|name| !listed.contains(name.as_str()))
        .collect();
    assert!(
        missing.is_empty(),
        "scenes in inputs/ missing from README's scene table (its first column): {missing:?}"
    );
}

// ---------------------------------------------------------------------------------------------
// File paths

/// Where a cited repository path may start.
const PATH_ROOTS: &[&str] = &[
    "src/",
    "docs/",
    "tools/",
    "inputs/",
    "tests/",
    "examples/",
    "jobscripts/",
    "topology/",
    ".ci/",
];

/// The repository paths cited on a line: a token starting at one of `PATH_ROOTS` (not inside
/// a longer path or word), up to the first character no path here uses; trailing punctuation
/// dropped. Paths with placeholders (`<name>`, `NNNN`, `…`) are not checked.
fn cited_paths(line: &str) -> Vec<String> {
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if !line.is_char_boundary(i) {
            i += 1;
            continue;
        }
        let boundary = i == 0 || {
            let c = b[i - 1];
            !(c.is_ascii_alphanumeric() || b"_/.-~$".contains(&c))
        };
        match PATH_ROOTS.iter().find(|r| boundary && line[i..].starts_with(*r)) {
            Some(_) => {
                let mut j = i;
                while j < b.len() && (b[j].is_ascii_alphanumeric() || b"_./*-".contains(&b[j])) {
                    j += 1;
                }
                let placeholder = j < b.len() && (b[j] == b'<' || line[j..].starts_with('…'));
                // another repository's file, named after the repository: `Owner/Name `path``
                let external = line[..i]
                    .trim_end_matches(['`', ' ', '('])
                    .rsplit(' ')
                    .next()
                    .is_some_and(|w| {
                        w.matches('/').count() == 1
                            && !PATH_ROOTS.iter().any(|r| w.starts_with(r))
                            && w.split('/').all(|p| !p.is_empty())
                    });
                let path = line[i..j].trim_end_matches(['.', ',', ':', ';', '-']);
                if !placeholder && !external && !path.contains("NNNN") && !path.contains("RRRR") {
                    out.push(path.to_string());
                }
                i = j.max(i + 1);
            }
            None => i += 1,
        }
    }
    out
}

/// Whether `pattern` (with `*` matching any run of characters) matches `name`.
fn glob_match(pattern: &str, name: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == name,
        Some((head, tail)) => {
            name.starts_with(head)
                && (0..=name.len() - head.len()).any(|k| glob_match(tail, &name[head.len() + k..]))
        }
    }
}

/// Whether a cited path exists: a file or directory, a module path without `.rs`, or a glob
/// whose last component matches at least one file.
fn path_exists(path: &str) -> bool {
    let r = root();
    if path.contains('*') {
        let (dir, pat) = path.rsplit_once('/').unwrap_or(("", path));
        return std::fs::read_dir(r.join(dir)).is_ok_and(|entries| {
            entries
                .flatten()
                .any(|e| glob_match(pat, &e.file_name().to_string_lossy()))
        });
    }
    r.join(path).exists() || r.join(format!("{path}.rs")).exists()
}

#[test]
fn every_cited_file_path_exists() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for doc in documents() {
        let text = read(&doc);
        for (n, line) in text.lines().enumerate() {
            for path in cited_paths(line) {
                checked += 1;
                if !path_exists(&path) {
                    broken.push(format!(
                        "{}:{}: {path}",
                        doc.strip_prefix(root()).unwrap().display(),
                        n + 1
                    ));
                }
            }
        }
    }
    assert!(
        checked > 100,
        "only {checked} cited paths found: the scan is broken"
    );
    assert!(
        broken.is_empty(),
        "cited paths that do not exist:\n{}",
        broken.join("\n")
    );
}

#[test]
fn the_path_scan_finds_paths_and_refuses_bogus_ones() {
    let line = "see `src/sim/skin.rs`, docs/refinement.md §2 and inputs/*.toml; not /work/x/src/y.rs \
                nor runs/<name>/ nor final/rank_NNNN.csv nor pypr/pysph `tests/test_x.py`";
    assert_eq!(
        cited_paths(line),
        ["src/sim/skin.rs", "docs/refinement.md", "inputs/*.toml"]
    );
    assert!(path_exists("src/sim/skin.rs") && path_exists("inputs/*.toml"));
    assert!(path_exists("src/cells/half") && path_exists("tests/"));
    assert!(!path_exists("src/sim/no_such_file.rs"));
    assert!(!path_exists("docs/no_such_page.md"));
    assert!(!path_exists("inputs/no_such_*.toml"));
}

// ---------------------------------------------------------------------------------------------
// Rust paths

/// First segments that name another crate or a primitive, not this one.
const FOREIGN: &[&str] = &[
    "std", "core", "alloc", "rayon", "serde", "clap", "mpi", "nalgebra", "exmex", "toml", "hwloc2", "netcdf",
    "plotters", "f32", "f64", "u8", "u32", "u64", "usize", "i32", "i64", "Vec", "Option", "Result", "Self",
    "Box", "Ordering",
];

/// Every `.rs` file of the module at `file` (`src/a.rs` or `src/a/mod.rs`) and of its
/// directory's submodules.
fn module_files(file: &Path) -> Vec<PathBuf> {
    let mut out = vec![file.to_path_buf()];
    let dir = if file.ends_with("mod.rs") || file.ends_with("lib.rs") {
        file.parent().unwrap().to_path_buf()
    } else {
        file.with_extension("")
    };
    if dir != root().join("src") {
        out.extend(files_under(&dir, ".rs").into_iter().filter(|p| p != file));
    }
    out
}

/// The file of the module `segments` name below `src/`, if they all are modules.
fn module_file(segments: &[&str]) -> Option<PathBuf> {
    let mut file = root().join("src/lib.rs");
    let mut dir = root().join("src");
    for s in segments {
        let (a, b) = (dir.join(format!("{s}.rs")), dir.join(s).join("mod.rs"));
        file = if a.is_file() {
            a
        } else if b.is_file() {
            b
        } else {
            return None;
        };
        dir = dir.join(s);
    }
    Some(file)
}

/// Whether `text` defines `name`: an item (`fn`, `struct`, `enum`, `trait`, `const`,
/// `static`, `type`, `mod`, `macro_rules!`), an enum variant (a line that starts with the
/// name and goes on with `,`, `(`, `{` or nothing), a field `name:` of a struct, or a `use`
/// that brings the name in.
fn defines(text: &str, name: &str) -> bool {
    let word_at = |s: &str, k: usize| {
        s[k..].starts_with(name)
            && !s[k + name.len()..]
                .chars()
                .next()
                .is_some_and(|c| c.is_alphanumeric() || c == '_')
    };
    text.lines().any(|line| {
        let mut t = line.trim_start();
        for p in [
            "pub(crate) ",
            "pub(super) ",
            "pub ",
            "unsafe ",
            "async ",
            "const fn ",
            "extern \"C\" ",
        ] {
            t = t.strip_prefix(p).unwrap_or(t);
        }
        let items = [
            "fn ",
            "struct ",
            "enum ",
            "trait ",
            "const ",
            "static ",
            "type ",
            "mod ",
            "macro_rules! ",
            "union ",
        ];
        items.iter().any(|k| t.starts_with(k) && word_at(t, k.len()))
            || (word_at(t, 0)
                && matches!(
                    t[name.len()..].trim_start().chars().next(),
                    None | Some(',' | '(' | '{' | ':' | '=')
                ))
            || (t.starts_with("use ") && t.contains(name) && {
                let k = t.find(name).unwrap();
                word_at(t, k)
            })
    })
}

fn any_defines(files: &[PathBuf], name: &str) -> bool {
    files.iter().any(|f| defines(&read(f), name))
}

/// Why a cited `a::b::c` does not resolve, if it does not: the longest prefix of modules
/// below `src/`, then the first item in that module (its file or its directory's files), then
/// any further segments (a method, variant or associated item) defined anywhere in `src/`.
/// A path whose first segment is no module is a type's: the type and its items are looked up
/// anywhere in `src/`.
fn unresolved(path: &str, all: &[PathBuf]) -> Option<String> {
    let path = path.trim_end_matches("()").trim_end_matches('!');
    let path = path.strip_prefix("crate::").unwrap_or(path);
    let path = path.strip_prefix("hsph::").unwrap_or(path);
    let segs: Vec<&str> = path.split("::").collect();
    if FOREIGN.contains(&segs[0]) {
        return None;
    }
    let mut k = 0;
    while k < segs.len() && module_file(&segs[..=k]).is_some() {
        k += 1;
    }
    let test_file = root().join("tests").join(format!("{}.rs", segs[0]));
    if k == 0 && segs.len() > 1 && test_file.is_file() {
        // an integration test, `file::name` as `cargo test --test suite` names it
        let text = read(&test_file);
        if segs[1..].iter().all(|m| defines(&text, m)) {
            return None;
        }
    }
    let (first, rest) = if k == 0 {
        (None, &segs[..])
    } else {
        (module_file(&segs[..k]), &segs[k..])
    };
    let Some((item, members)) = rest.split_first() else {
        return None; // a module path, and it exists
    };
    let in_module = match &first {
        Some(file) => any_defines(&module_files(file), item),
        None => any_defines(all, item),
    };
    if !in_module {
        let place = segs[..k].join("::");
        return Some(format!(
            "`{item}` is not defined in `{}`",
            if k == 0 { "src/" } else { &place }
        ));
    }
    members
        .iter()
        .find(|m| !any_defines(all, m))
        .map(|m| format!("`{m}` is not defined anywhere in src/"))
}

/// Whether a code span is a Rust path `a::b` (optionally a call `a::b()` or a macro `a!`).
fn is_rust_path(span: &str) -> bool {
    let s = span.trim_end_matches("()").trim_end_matches('!');
    s.contains("::")
        && s.split("::").all(|seg| {
            seg.chars()
                .next()
                .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                && seg.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        })
}

#[test]
fn every_cited_rust_path_exists() {
    let all = files_under(&root().join("src"), ".rs");
    let mut broken = Vec::new();
    let mut checked = 0;
    for doc in documents() {
        let text = read(&doc);
        for (n, line) in prose_lines(&text) {
            for span in code_spans(line).into_iter().filter(|s| is_rust_path(s)) {
                checked += 1;
                if let Some(why) = unresolved(span, &all) {
                    broken.push(format!(
                        "{}:{n}: `{span}`: {why}",
                        doc.strip_prefix(root()).unwrap().display()
                    ));
                }
            }
        }
    }
    assert!(
        checked > 20,
        "only {checked} cited Rust paths found: the scan is broken"
    );
    assert!(
        broken.is_empty(),
        "cited Rust paths that do not resolve:\n{}",
        broken.join("\n")
    );
}

#[test]
fn the_rust_path_check_refuses_bogus_paths() {
    let all = files_under(&root().join("src"), ".rs");
    for good in [
        "scene::refine::level_h",
        "physics::passes::Freshness",
        "cells::verlet",
        "Simulation::advance",
        "crate::ids",
        "restart::the_id_counter_is_checkpointed_and_checked",
        "shifting::lattice_divergence",
    ] {
        assert_eq!(unresolved(good, &all), None, "{good}");
    }
    for bogus in [
        "scene::refine::no_such_fn",
        "physics::passes::NoSuchType",
        "scene::no_such_module::level_h",
        "NoSuchType::advance",
        "Simulation::no_such_method",
        "restart::no_such_test",
        "shifting::no_such_fn",
    ] {
        assert!(unresolved(bogus, &all).is_some(), "{bogus} resolved");
    }
}

// ---------------------------------------------------------------------------------------------
// BENCHMARKS.md

#[test]
fn benchmarks_page_is_the_rendering_of_its_records() {
    let page = read(&root().join("BENCHMARKS.md"));
    let lines = page.lines().count();
    assert!(lines <= 300, "BENCHMARKS.md has {lines} lines, more than 300");
    let out = std::process::Command::new("python3")
        .arg(root().join("tools/bench_render.py"))
        .arg("--check")
        .output()
        .expect("python3 runs tools/bench_render.py");
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
