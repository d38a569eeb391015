//! The stop contract: a SIGINT/SIGTERM (or Slurm's SIGUSR1) stops every rank after the same
//! step, flushes every CSV, writes final.csv and a summary.json with "complete": false, and
//! exits with status 3; the CSV series are exactly the complete run's up to the last output
//! step before the stop.

use crate::common;

use hsph::driver::{run_scene, Backend, Fault, FaultKind, RunOptions};
use hsph::scene::load_scene;
use std::fs;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const OVERRIDES: [&str; 3] = [
    "time.t_end=0.12",
    "output.interval=0.005",
    "output.format=\"none\"",
];

fn complete_run(tag: &str) -> std::path::PathBuf {
    let o: Vec<String> = OVERRIDES.iter().map(|s| s.to_string()).collect();
    let (scene, _) = load_scene(&common::repo_path("inputs/dam_break_2d.toml"), &o).unwrap();
    let out = common::temp_dir(tag).join("run");
    let outcome = run_scene(
        &scene,
        &RunOptions {
            out: Some(out.clone()),
            threads: 1,
            quiet: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(outcome.stopped_by, None);
    out
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// The stopped run's series are the complete run's rows up to its stop step, every one of them.
fn assert_prefix(stopped: &Path, complete: &Path, stop_step: u64) {
    for file in ["timeseries.csv", "probes/front.csv"] {
        let part = fs::read_to_string(stopped.join(file)).unwrap();
        let full = fs::read_to_string(complete.join(file)).unwrap();
        let full_lines: Vec<&str> = full.lines().collect();
        let part_lines: Vec<&str> = part.lines().collect();
        assert!(part.ends_with('\n'), "{file}: a whole last line");
        assert_eq!(
            part_lines[..],
            full_lines[..part_lines.len()],
            "{file}: a prefix of the complete run"
        );
        if file == "timeseries.csv" {
            // rows parse, and no output step at or before the stop is missing
            let step = |l: &str| l.split(',').next().unwrap().parse::<u64>().unwrap();
            let want = full_lines[1..].iter().filter(|l| step(l) <= stop_step).count();
            assert_eq!(
                part_lines.len() - 1,
                want,
                "{file}: ends at the last output step before the stop"
            );
            for l in &part_lines[1..] {
                assert!(l.split(',').skip(1).all(|c| c.parse::<f64>().is_ok()), "{l}");
            }
        }
    }
}

#[test]
fn a_signal_stops_every_rank_after_the_same_step_and_keeps_what_was_written() {
    let complete = complete_run("sig-complete");
    // in-process, deterministic: rank 1 of 3 records a SIGTERM before step 9
    let o: Vec<String> = OVERRIDES.iter().map(|s| s.to_string()).collect();
    let (scene, _) = load_scene(&common::repo_path("inputs/dam_break_2d.toml"), &o).unwrap();
    let out = common::temp_dir("sig-fault").join("run");
    let outcome = run_scene(
        &scene,
        &RunOptions {
            out: Some(out.clone()),
            threads: 1,
            quiet: true,
            ranks: 3,
            backend: Backend::Local,
            fault: Some(Fault {
                rank: 1,
                step: 9,
                kind: FaultKind::Signal,
            }),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(outcome.stopped_by, Some("SIGTERM"));
    let s = summary(&out);
    assert_eq!(s["complete"], false);
    assert_eq!(s["stopped_by"], "SIGTERM");
    assert_eq!(s["steps"], 9);
    // build provenance
    assert_eq!(s["build"]["version"], env!("CARGO_PKG_VERSION"));
    assert!(!s["build"]["git_commit"].as_str().unwrap().is_empty());
    assert_prefix(&out, &complete, 9);
    let final_rows = fs::read_to_string(out.join("final.csv")).unwrap().lines().count();
    assert_eq!(final_rows, 1 + s["particles"].as_u64().unwrap() as usize);
    // hsph report draws the partial run and says so
    let rep = out.parent().unwrap().join("report");
    hsph::report::command(std::slice::from_ref(&out), false, Some(&rep), "eps_p").unwrap();
    let md = fs::read_to_string(rep.join("report.md")).unwrap();
    assert!(
        md.contains("**Partial run**: stopped by SIGTERM after step 9"),
        "{md}"
    );

    // a real signal at a random moment, to the binary: SIGTERM on 1 rank, SIGINT on 3 ranks
    let mut rng = common::Rng(0x5eed ^ std::process::id() as u64);
    let mut checked = 0;
    for (sig, ranks) in [("TERM", "1"), ("INT", "3")] {
        let dir = common::temp_dir("sig-kill").join("run");
        let mut args: Vec<String> = [
            "run",
            "inputs/dam_break_2d.toml",
            "-q",
            "--threads",
            "1",
            "--ranks",
            ranks,
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        args.extend(["--out".into(), dir.to_str().unwrap().into()]);
        for o in OVERRIDES {
            args.extend(["--set".into(), o.to_string()]);
        }
        let mut child = Command::new(env!("CARGO_BIN_EXE_hsph"))
            .args(&args)
            .current_dir(common::repo_path(""))
            .spawn()
            .unwrap();
        // wait until 2–6 output rows are on disk, then signal
        let rows = 3 + rng.below(5);
        let t0 = Instant::now();
        while fs::read_to_string(dir.join("timeseries.csv")).map_or(0, |t| t.lines().count()) < rows {
            assert!(
                t0.elapsed() < Duration::from_secs(120),
                "the run never wrote {rows} rows"
            );
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        let killed = Command::new("kill")
            .args([&format!("-{sig}"), &child.id().to_string()])
            .status();
        let status = child.wait().unwrap();
        if killed.map(|k| !k.success()).unwrap_or(true) || status.code() == Some(0) {
            // the run finished before the signal arrived: nothing to check this round
            continue;
        }
        assert_eq!(status.code(), Some(3), "SIG{sig}");
        let s = summary(&dir);
        assert_eq!(s["complete"], false);
        assert_eq!(s["stopped_by"], format!("SIG{sig}"));
        assert_prefix(&dir, &complete, s["steps"].as_u64().unwrap());
        checked += 1;
    }
    // the runs take seconds and the signal comes after a few of 25 output rows
    assert!(checked >= 1, "no signal arrived before the end of a run");
}
