//! `hsph report` and `hsph report --compare` on the hand-made run directory
//! `tests/data/report_run` (4 ranks on 2 nodes, 2 threads, traffic.csv and summary.json in the
//! format of issue 4).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const FIXTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/report_run");
const CHARTS: [&str; 4] = [
    "traffic_heatmap",
    "traffic_time",
    "ghosts_imbalance",
    "phase_times",
];

fn hsph(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(args)
        .output()
        .expect("hsph runs")
}

/// A fresh scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Copy the fixture run directory to `dst`.
fn copy_fixture(dst: &Path) {
    std::fs::create_dir_all(dst).unwrap();
    for f in ["summary.json", "diagnostics.csv", "traffic.csv"] {
        std::fs::copy(Path::new(FIXTURE).join(f), dst.join(f)).unwrap();
    }
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A PNG file: signature, an IHDR chunk of the expected size, an IEND chunk at the end.
fn assert_png(path: &Path) {
    let b = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(b.len() > 1000, "{}: only {} bytes", path.display(), b.len());
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "{}: PNG signature", path.display());
    assert_eq!(&b[12..16], b"IHDR", "{}", path.display());
    let w = u32::from_be_bytes(b[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(b[20..24].try_into().unwrap());
    assert!(w >= 400 && h >= 300, "{}: {w}×{h}", path.display());
    assert_eq!(&b[b.len() - 8..b.len() - 4], b"IEND", "{}", path.display());
}

/// An SVG file: well nested tags (a small XML check) and the given texts.
fn assert_svg(path: &Path, texts: &[&str]) {
    let t = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(
        t.trim_start().starts_with("<svg"),
        "{}: starts with <svg",
        path.display()
    );
    assert!(
        t.trim_end().ends_with("</svg>"),
        "{}: ends with </svg>",
        path.display()
    );
    let mut stack: Vec<String> = Vec::new();
    let mut strings: Vec<String> = Vec::new();
    let mut rest = t.as_str();
    while let Some(i) = rest.find('<') {
        let j = rest[i..].find('>').expect("tag closed") + i;
        let tag = &rest[i + 1..j];
        rest = &rest[j + 1..];
        if tag.starts_with('?') || tag.starts_with('!') || tag.ends_with('/') {
            continue;
        }
        let name: String = tag
            .trim_start_matches('/')
            .chars()
            .take_while(|c| !c.is_whitespace())
            .collect();
        if tag.starts_with('/') {
            assert_eq!(
                stack.pop().as_deref(),
                Some(name.as_str()),
                "{}: mismatched </{name}>",
                path.display()
            );
        } else {
            if name == "text" {
                strings.push(rest[..rest.find('<').unwrap_or(0)].trim().to_string());
            }
            stack.push(name);
        }
    }
    assert!(stack.is_empty(), "{}: unclosed {stack:?}", path.display());
    for x in texts {
        assert!(
            strings.iter().any(|s| s == x),
            "{}: no text `{x}` in {strings:?}",
            path.display()
        );
    }
}

fn summary() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(Path::new(FIXTURE).join("summary.json")).unwrap()).unwrap()
}

#[test]
fn report_writes_valid_charts_and_markdown() {
    let out = scratch("single");
    let o = hsph(&["report", FIXTURE, "--out", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for c in CHARTS {
        assert_png(&out.join(format!("{c}.png")));
    }
    assert_svg(
        &out.join("traffic_heatmap.svg"),
        &[
            "destination rank",
            "source rank",
            "bytes",
            "Rank-pair traffic, all phases (bytes)",
            "0",
            "3",
        ],
    );
    assert_svg(
        &out.join("traffic_time.svg"),
        &[
            "step (end of output interval)",
            "bytes sent (KiB)",
            "intra-node",
            "inter-node",
        ],
    );
    assert_svg(
        &out.join("ghosts_imbalance.svg"),
        &[
            "t (s)",
            "Ghost fraction",
            "Load imbalance",
            "remote ghosts / particles",
        ],
    );
    assert_svg(
        &out.join("phase_times.svg"),
        &[
            "wall seconds",
            "phase",
            "neighbours",
            "forces",
            "halo",
            "output",
            "40",
        ],
    );
    // every file written is listed on stdout
    let listed = String::from_utf8_lossy(&o.stdout);
    assert_eq!(listed.lines().count(), 2 * CHARTS.len() + 1, "{listed}");
}

#[test]
fn report_markdown_has_the_summary_figures() {
    let out = scratch("markdown");
    let o = hsph(&["report", FIXTURE, "--out", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let j = summary();
    let f = |k: &str| j[k].as_f64().unwrap();
    let tr = &j["traffic"];
    let (intra, inter) = (
        tr["intra_node_bytes"].as_u64().unwrap(),
        tr["inter_node_bytes"].as_u64().unwrap(),
    );
    let expect = [
        j["scene"].as_str().unwrap().to_string(),
        format!("| ranks | {} |", j["ranks"]),
        format!("| nodes | {} |", j["nodes"]),
        format!("| threads per rank | {} |", j["threads"]),
        format!("{:.3e}", f("particle_steps_per_s")),
        hsph::report::percent(f("ghost_fraction")),
        format!("{:.4}", f("imbalance")),
        hsph::report::percent(f("communication_fraction")),
        hsph::report::percent(f("balance_fraction")),
        format!("| traffic, intra-node | {intra} B"),
        format!("| traffic, inter-node | {inter} B"),
        hsph::report::percent(inter as f64 / (intra + inter) as f64),
        format!(
            "| halo | {} | {} | {} |",
            tr["phases"]["halo"]["intra_node_bytes"],
            tr["phases"]["halo"]["inter_node_bytes"],
            tr["phases"]["halo"]["messages"]
        ),
    ];
    for e in &expect {
        assert!(md.contains(e.as_str()), "report.md lacks `{e}`:\n{md}");
    }
    // the fixture's own numbers, so a formatting change is seen
    for e in [
        "6.000e5", "12.62 %", "1.0498", "14.00 %", "1.00 %", "757280 B", "638560 B", "45.75 %",
    ] {
        assert!(md.contains(e), "report.md lacks `{e}`:\n{md}");
    }
    for c in CHARTS {
        assert!(
            md.contains(&format!("]({c}.png)")) && md.contains(&format!("]({c}.svg)")),
            "{c}"
        );
    }
}

#[test]
fn report_defaults_to_rundir_report_and_works_without_traffic() {
    let run = scratch("no_traffic").join("run");
    copy_fixture(&run);
    std::fs::remove_file(run.join("traffic.csv")).unwrap();
    let mut j = summary();
    j.as_object_mut().unwrap().remove("traffic");
    std::fs::write(run.join("summary.json"), j.to_string()).unwrap();
    let o = hsph(&["report", s(&run)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = run.join("report");
    assert!(!out.join("traffic_heatmap.png").exists());
    assert_png(&out.join("ghosts_imbalance.png"));
    assert_png(&out.join("phase_times.png"));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("No `traffic.csv`"), "{md}");
    assert!(!md.contains("traffic_heatmap.png"), "{md}");
}

#[test]
fn report_compare_two_runs() {
    let dir = scratch("compare");
    let (a, b) = (dir.join("layout_a"), dir.join("layout_b"));
    copy_fixture(&a);
    copy_fixture(&b);
    let mut j = summary();
    j["particle_steps_per_s"] = serde_json::json!(1.5e6);
    j["placement"] = serde_json::json!("centre-distance");
    std::fs::write(b.join("summary.json"), j.to_string()).unwrap();
    let out = dir.join("out");
    let o = hsph(&["report", "--compare", s(&a), s(&b), "--out", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(out.join("compare.md")).unwrap();
    assert!(
        md.contains("| # | run | scene | layout | placement | particle-steps/s |"),
        "{md}"
    );
    let rows: Vec<&str> = md
        .lines()
        .filter(|l| l.starts_with("| 1 |") || l.starts_with("| 2 |"))
        .collect();
    assert_eq!(rows.len(), 2, "{md}");
    assert!(
        rows[0].contains("layout_a") && rows[0].contains("6.000e5") && rows[0].contains("638560"),
        "{}",
        rows[0]
    );
    assert!(
        rows[1].contains("layout_b") && rows[1].contains("1.500e6") && rows[1].contains("centre-distance"),
        "{}",
        rows[1]
    );
    assert!(
        rows[1].contains("12.62 %") && rows[1].contains("14.00 %") && rows[1].contains("45.75 %"),
        "{}",
        rows[1]
    );
    assert_png(&out.join("compare.png"));
    assert_svg(
        &out.join("compare.svg"),
        &[
            "Particle-steps/s",
            "Inter-node bytes",
            "Ghost fraction",
            "Communication fraction",
            "#1",
            "#2",
        ],
    );
}

fn assert_input_error(args: &[&str], needles: &[&str]) {
    let o = hsph(args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: stderr lacks `{n}`: {err}");
    }
}

#[test]
fn report_bad_run_dir_exits_2() {
    let dir = scratch("bad");
    // a directory that is not a finished run
    let unfinished = dir.join("unfinished");
    copy_fixture(&unfinished);
    std::fs::remove_file(unfinished.join("summary.json")).unwrap();
    let want = unfinished.join("summary.json");
    assert_input_error(
        &["report", s(&unfinished)],
        &[s(&want), "missing", "not a finished"],
    );
    // no such directory
    let nowhere = dir.join("nowhere");
    assert_input_error(&["report", s(&nowhere)], &[s(&nowhere), "no such run directory"]);
    // in a comparison too
    assert_input_error(&["report", "--compare", FIXTURE, s(&unfinished)], &[s(&want)]);
    // incomplete: no diagnostics.csv
    let nodiag = dir.join("nodiag");
    copy_fixture(&nodiag);
    std::fs::remove_file(nodiag.join("diagnostics.csv")).unwrap();
    assert_input_error(&["report", s(&nodiag)], &["diagnostics.csv", "missing"]);
    // a malformed traffic.csv names its line
    let badcsv = dir.join("badcsv");
    copy_fixture(&badcsv);
    let t = std::fs::read_to_string(badcsv.join("traffic.csv")).unwrap();
    std::fs::write(
        badcsv.join("traffic.csv"),
        t.replacen("0,other,0,1,0,0,256,1", "0,other,0,1,0,0,lots,1", 1),
    )
    .unwrap();
    assert_input_error(&["report", s(&badcsv)], &["traffic.csv:2", "bytes"]);
    // --compare needs two runs; several runs need --compare
    assert_input_error(&["report", "--compare", FIXTURE], &["--compare"]);
    assert_input_error(&["report", FIXTURE, FIXTURE], &["--compare"]);
}
