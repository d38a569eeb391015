//! Bitwise reproducibility across thread counts: `timeseries.csv`, `final.csv` and the probe
//! files of a run with 1 thread equal those with 2 threads, and `summary.json` records the
//! thread count actually used.

use crate::common;

use hsph::driver::{run_scene, RunOptions};
use hsph::scene::load_scene;
use std::fs;
use std::path::{Path, PathBuf};

fn run(scene_file: &Path, overrides: &[&str], threads: usize, tag: &str) -> PathBuf {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let (scene, _) = load_scene(scene_file, &overrides).unwrap();
    let out = common::temp_dir(tag).join("run");
    let outcome = run_scene(
        &scene,
        &RunOptions {
            out: Some(out.clone()),
            force: false,
            threads,
            quiet: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(outcome.dir, out);
    let summary: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(
        summary["threads"].as_u64(),
        Some(threads as u64),
        "summary.json must record the thread count used: {summary}"
    );
    assert!(summary["steps"].as_u64().unwrap() > 10, "{summary}");
    out
}

fn read(dir: &Path, name: &str) -> String {
    fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{}/{name}: {e}", dir.display()))
}

fn probe_files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir.join("probes"))
        .map(|rd| {
            rd.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

fn assert_same_runs(scene_file: &Path, overrides: &[&str], tag: &str) {
    let one = run(scene_file, overrides, 1, &format!("{tag}-t1"));
    let two = run(scene_file, overrides, 2, &format!("{tag}-t2"));
    for name in ["timeseries.csv", "final.csv"] {
        let (a, b) = (read(&one, name), read(&two, name));
        assert!(a.lines().count() > 2, "{tag}/{name} is too short:\n{a}");
        if a != b {
            let (n, (la, lb)) = a
                .lines()
                .zip(b.lines())
                .enumerate()
                .find(|(_, (x, y))| x != y)
                .unwrap_or((0, ("(length differs)", "")));
            panic!(
                "{tag}/{name} differs between 1 and 2 threads, first at line {}:\n  1: {la}\n  2: {lb}",
                n + 1
            );
        }
    }
    let probes = probe_files(&one);
    assert_eq!(probes, probe_files(&two));
    for p in &probes {
        let name = format!("probes/{p}");
        assert_eq!(read(&one, &name), read(&two, &name), "{tag}/{name} differs");
    }
    // the run must actually move: the final state differs from the initial one
    let ts = read(&one, "timeseries.csv");
    let last = ts.lines().last().unwrap();
    let ke: f64 = last.split(',').nth(3).unwrap().parse().unwrap();
    assert!(ke > 0.0, "{tag}: no motion by the end ({last})");
    let _ = fs::remove_dir_all(one.parent().unwrap());
    let _ = fs::remove_dir_all(two.parent().unwrap());
}

#[test]
fn dam_break_is_bitwise_reproducible_across_threads() {
    assert_same_runs(
        &common::repo_path("inputs/dam_break_2d.toml"),
        &[
            "time.t_end=0.04",
            "output.interval=0.005",
            "output.format=\"none\"",
        ],
        "dam",
    );
}

#[test]
fn periodic_channel_is_bitwise_reproducible_across_threads() {
    assert_same_runs(
        &common::repo_path("tests/data/periodic_channel_2d.toml"),
        &[],
        "channel",
    );
}

#[test]
fn poiseuille_is_bitwise_reproducible_across_threads() {
    // the shipped Morris et al. (1997) scene, periodic along x, over its first 0.2 s
    assert_same_runs(
        &common::repo_path("inputs/poiseuille_2d.toml"),
        &[
            "time.t_end=0.2",
            "reference.times=[0.2]",
            "output.format=\"none\"",
        ],
        "poiseuille",
    );
}
