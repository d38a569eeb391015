//! Nothing lost on restart, `--force` or a full quota, and every stop within a step, set-up
//! included (README, "Files" and "Checkpoints and restart"): each class of defect tried with its
//! reproducer and with other members of its class. Random stops and restarts are in
//! `tests/restart_property.rs`.

use crate::common;

use common::cli::{assert_input_error, hsph_in, run_args, stderr};
use common::{repo_path, temp_dir};
use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const SCENE: &str = "inputs/dam_break_2d.toml";

use crate::common::cli::hsph_out as hsph;
use crate::common::dir_snapshot as snapshot;

/// Assert `dir` holds exactly `before`, naming the first difference.
fn assert_unchanged(dir: &Path, before: &BTreeMap<String, Vec<u8>>, what: &str) {
    let now = snapshot(dir);
    let keys = |m: &BTreeMap<String, Vec<u8>>| m.keys().cloned().collect::<Vec<_>>();
    assert_eq!(keys(&now), keys(before), "{what}: files added or removed");
    for (k, v) in &now {
        assert!(v == &before[k], "{what}: {k} changed");
    }
}

/// The reproducer: a run that ends by `time.max_steps` (with its end checkpoint), in
/// `dir/name`.
fn finished_run(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let mut args = run_args(SCENE, &out, &["time.max_steps=30", "checkpoint.every_steps=1000"]);
    args.extend(extra.iter().map(|s| s.to_string()));
    let o = hsph(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    out
}

fn restart(from: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["run", "--restart", from.to_str().unwrap(), "-q", "--threads", "1"];
    args.extend(extra);
    hsph(&args)
}

/// Defect 1: restarting a finished run with nothing left to run — with no change, or the same
/// `max_steps` — changes no byte (series, probes, snapshots, index, summary) and says how to
/// extend it (exit 0).
#[test]
fn a_restart_with_nothing_left_to_run_changes_no_byte() {
    let dir = temp_dir("noop-restart");
    let run = finished_run(&dir, "x", &[]);
    let before = snapshot(&run);
    for extra in [
        &[][..],
        &["--set", "time.max_steps=30"],
        &["--set", "output.interval=0.01"],
    ] {
        let o = restart(&run, extra);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("nothing left to run") && e.contains("time.max_steps=60"),
            "{e}"
        );
        assert_unchanged(&run, &before, &format!("restart {extra:?}"));
    }
    // from the checkpoint directory itself, too
    let ck = run.join("checkpoints/step-0000000030");
    assert_eq!(restart(&ck, &[]).status.code(), Some(0));
    assert_unchanged(&run, &before, "restart of the checkpoint");
}

/// Defect 2: a refused restart changes no byte, whichever file is the bad one (the last
/// series checked, a probe, a snapshot index path), and never touches another run: a
/// checkpoint is continued only from its own run's `checkpoints/`, and one anywhere else is
/// refused before anything is locked.
#[test]
fn a_refused_restart_changes_no_byte_of_any_run() {
    let dir = temp_dir("refused-restart");
    let run = finished_run(&dir, "x", &[]);
    let more = ["--set", "time.max_steps=60"];
    let before = snapshot(&run);
    for (file, cut) in [("traffic.csv", 3), ("probes/tank.csv", 1), ("timeseries.csv", 10)] {
        let path = run.join(file);
        let good = fs::read(&path).unwrap();
        // shorter than the checkpoint says: the series was damaged after it
        let len = fs::metadata(run.join("checkpoints/step-0000000030/manifest.json")).unwrap();
        assert!(len.len() > 0);
        let m: serde_json::Value =
            serde_json::from_slice(&fs::read(run.join("checkpoints/step-0000000030/manifest.json")).unwrap())
                .unwrap();
        let at = m["run"]["series"][file].as_u64().unwrap() as usize;
        fs::write(&path, &good[..at - cut]).unwrap();
        let mut damaged = before.clone();
        damaged.insert(file.to_string(), good[..at - cut].to_vec());
        assert_input_error(&restart(&run, &more), &[file, "shorter than the checkpoint"]);
        assert_unchanged(&run, &damaged, &format!("damaged {file}"));
        fs::write(&path, &good).unwrap();
    }
    // a checkpoint copied into another finished run, beside its own checkpoints
    let other = finished_run(&dir, "other", &["--set", "output.interval=0.01"]);
    let copy = other.join("saved/step-0000000030");
    fs::create_dir_all(&copy).unwrap();
    for e in fs::read_dir(run.join("checkpoints/step-0000000030"))
        .unwrap()
        .flatten()
    {
        fs::copy(e.path(), copy.join(e.file_name())).unwrap();
    }
    let theirs = snapshot(&other);
    assert_input_error(
        &restart(&copy, &more),
        &["not inside a run directory", "checkpoints/step-"],
    );
    assert_unchanged(&other, &theirs, "another run's");
    // a checkpoint outside any run directory: refused, and no lock anywhere
    let alone = dir.join("loose/step-0000000030");
    fs::create_dir_all(&alone).unwrap();
    for e in fs::read_dir(&copy).unwrap().flatten() {
        fs::copy(e.path(), alone.join(e.file_name())).unwrap();
    }
    let o = hsph_in(&dir, &["run", "--restart", "loose/step-0000000030", "-q"]);
    assert_input_error(&o, &["not inside a run directory"]);
    assert!(!dir.join(".hsph.lock").exists() && !dir.join("loose/.hsph.lock").exists());
    // the original run is still as it was, and continues
    assert_unchanged(&run, &before, "the run after the refusals");
    let o = restart(&run, &more);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Defect 4: an output path that is there as something else than a regular file (a FIFO named
/// `final.csv`, a directory named `summary.json`, a probe file or snapshot index that is a
/// directory) refuses the restart before a step is taken: exit 2 naming it, nothing changed.
#[test]
fn a_restart_whose_output_is_not_a_regular_file_is_refused_before_it_runs() {
    let dir = temp_dir("restart-targets");
    let run = finished_run(&dir, "x", &[]);
    let more = ["--set", "time.max_steps=300"];
    for target in [
        "final.csv",
        "summary.json",
        "probes/front.csv",
        "snapshots/series.pvd",
    ] {
        let path = run.join(target);
        let kept = fs::read(&path).unwrap();
        fs::remove_file(&path).unwrap();
        if target == "final.csv" {
            let ok = Command::new("mkfifo").arg(&path).status().unwrap().success();
            assert!(ok, "mkfifo");
        } else {
            fs::create_dir(&path).unwrap();
        }
        let before = snapshot(&run);
        let t0 = Instant::now();
        let o = restart(&run, &more);
        assert_input_error(&o, &[target, "regular file"]);
        assert!(!stderr(&o).contains("continuing from"), "{}", stderr(&o));
        assert_unchanged(&run, &before, target);
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "{target}: refused only after running"
        );
        if target == "final.csv" {
            fs::remove_file(&path).unwrap();
        } else {
            fs::remove_dir(&path).unwrap();
        }
        fs::write(&path, kept).unwrap();
    }
}

/// Defect 3: `--force` removes only the files a run wrote, by name, and keeps a user's files
/// in every folder of the run directory (and the folders that hold them); the other form of
/// the final state left by a run with another `output.gather_limit` goes.
#[test]
fn force_removes_only_what_a_run_wrote() {
    let dir = temp_dir("force-by-name");
    let run = finished_run(&dir, "x", &["--set", "output.gather_limit=10"]);
    assert!(run.join("final/rank_0000.csv").is_file() && !run.join("final.csv").exists());
    let mine = [
        "notes.txt",
        "probes/calibration.csv",
        "snapshots/view.pvsm",
        "snapshots/snapshot_00001/annotations.txt",
        "checkpoints/README",
        "checkpoints/step-0000000030/why.txt",
        "final/plot.py",
        "report/figure.png",
    ];
    for f in mine {
        let p = run.join(f);
        fs::create_dir_all(p.parent().unwrap()).unwrap();
        fs::write(&p, f).unwrap();
    }
    let mut args = run_args(SCENE, &run, &["checkpoint.every_steps=1000", "time.max_steps=10"]);
    args.push("--force".into());
    let o = hsph(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for f in mine {
        assert_eq!(fs::read_to_string(run.join(f)).unwrap(), f, "{f} lost to --force");
    }
    // what the old run wrote is gone: its checkpoint, its last snapshot and its final pieces
    assert!(!run.join("checkpoints/step-0000000030/manifest.json").exists());
    assert!(!run.join("checkpoints/step-0000000030/part-00000.bin").exists());
    assert!(
        !run.join("final/rank_0000.csv").exists(),
        "the stale final/ piece stayed"
    );
    assert!(run.join("final.csv").is_file());
    let summary: serde_json::Value =
        serde_json::from_slice(&fs::read(run.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["steps"], 10);
    // and the other way round: final/ written removes a final.csv
    let o = restart(
        &run,
        &["--set", "time.max_steps=12", "--set", "output.gather_limit=10"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(run.join("final/rank_0000.csv").is_file() && !run.join("final.csv").exists());
    assert_eq!(
        fs::read_to_string(run.join("final/plot.py")).unwrap(),
        "final/plot.py"
    );
}

/// Defect 5: under a file-size limit SIGXFSZ does not kill hsph: the write fails, exit 1 with
/// a message naming the file, no `.tmp` left, and the directory can be restarted.
#[test]
fn a_file_size_limit_is_an_ordinary_write_error() {
    let dir = temp_dir("ulimit");
    let out = dir.join("x");
    for blocks in [40, 300] {
        let o = Command::new("sh")
            .arg("-c")
            .arg(format!("ulimit -f {blocks} && exec \"$0\" \"$@\""))
            .arg(env!("CARGO_BIN_EXE_hsph"))
            .args(["run", SCENE, "-q", "--threads", "1", "--force", "--out"])
            .arg(&out)
            .args(["--set", "time.max_steps=30", "--set", "checkpoint.every_steps=10"])
            .current_dir(repo_path(""))
            .stdin(Stdio::null())
            .output()
            .unwrap();
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "ulimit -f {blocks}: {e}");
        assert!(e.contains("File too large") || e.contains("too large"), "{e}");
        let left: Vec<String> = snapshot(&out)
            .into_keys()
            .filter(|k| k.ends_with(".tmp"))
            .collect();
        assert!(left.is_empty(), "ulimit -f {blocks}: {left:?} left");
    }
}

/// Defects 10 and 11: a manifest that lists a part twice, or whose parts hold ids of split
/// particles but no `next_id`, is refused (exit 2 naming the manifest).
#[test]
fn a_tampered_manifest_is_refused_whatever_it_would_duplicate() {
    let dir = temp_dir("manifest-parts");
    let out = dir.join("x");
    let (code, _, err) = common::run_file(
        SCENE,
        &out,
        (2, 1),
        &["time.max_steps=10", "checkpoint.every_steps=10"],
    );
    assert_eq!(code, 0, "{err}");
    let ck = out.join("checkpoints/step-0000000010");
    let path = ck.join("manifest.json");
    let good = fs::read_to_string(&path).unwrap();
    let more = ["--set", "time.max_steps=20"];
    let mut v: serde_json::Value = serde_json::from_str(&good).unwrap();
    v["parts"][1] = v["parts"][0].clone();
    fs::write(&path, v.to_string()).unwrap();
    assert_input_error(&restart(&ck, &more), &["manifest.json", "listed once"]);
    // the parts swapped: each is still listed once, but not by its rank
    let mut v: serde_json::Value = serde_json::from_str(&good).unwrap();
    let p0 = v["parts"][0].clone();
    v["parts"][0] = v["parts"][1].clone();
    v["parts"][1] = p0;
    fs::write(&path, v.to_string()).unwrap();
    assert_input_error(&restart(&ck, &more), &["manifest.json", "rank 0 writes"]);
    fs::write(&path, &good).unwrap();

    // a run that split particles before its checkpoint, its counter removed
    let split = dir.join("split");
    let scene = "tests/data/drift_split_2d.toml";
    let sets = ["time.max_steps=130", "checkpoint.every_steps=130"];
    let (code, _, err) = common::run_file(scene, &split, (1, 1), &sets);
    assert_eq!(code, 0, "{err}");
    let ck = split.join("checkpoints/step-0000000130");
    let mut v: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(ck.join("manifest.json")).unwrap()).unwrap();
    v.as_object_mut().unwrap().remove("next_id");
    fs::write(ck.join("manifest.json"), v.to_string()).unwrap();
    let o = restart(&ck, &["--set", "time.max_steps=140"]);
    assert_input_error(&o, &["manifest.json", "no next_id"]);
}

/// Spawn `hsph ARGS` (from the crate root), send `signals` (names, at once) after `after`, and
/// return its output and how long it took to end after them.
fn signalled(args: &[String], after: Duration, signals: &[&str]) -> (Output, Duration) {
    let child = Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(args)
        .current_dir(repo_path(""))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(after);
    let t0 = Instant::now();
    for s in signals {
        let _ = Command::new("kill")
            .args([format!("-{s}"), child.id().to_string()])
            .status();
    }
    let o = child.wait_with_output().unwrap();
    (o, t0.elapsed())
}

/// Defects 7 and 16: the set-up's relaxation and settling stop on a signal within one
/// iteration (exit 3, nothing left behind); SIGHUP stops a run like SIGTERM (exit 3 with a
/// checkpoint); two signals at once are one stop (its checkpoint written); `time.max_steps`
/// bounds the settling's steps.
#[test]
fn every_phase_stops_within_an_iteration_and_sighup_is_a_stop() {
    let dir = temp_dir("stop-phases");
    // the 3D dam break's relaxation takes a minute; the 2D one's settling as long
    for (phase, scene, set) in [
        ("settling", SCENE, "time.settle=50"),
        (
            "relaxation",
            "inputs/dam_break_3d.toml",
            "discretisation.relax=1000",
        ),
    ] {
        let out = dir.join(phase);
        let args = run_args(scene, &out, &[set]);
        let (o, took) = signalled(&args, Duration::from_millis(1500), &["TERM"]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(3), "{phase}: {e}");
        assert!(e.contains(phase) && e.contains("SIGTERM"), "{e}");
        assert!(
            took < Duration::from_secs(10),
            "{phase}: stopped {took:?} after the signal"
        );
        assert!(
            !out.exists(),
            "{phase}: the stopped set-up left {}",
            out.display()
        );
    }
    for signals in [&["HUP"][..], &["TERM", "TERM"], &["INT", "TERM"]] {
        let out = dir.join(format!("run-{}", signals.join("-")));
        let args = run_args(SCENE, &out, &["time.t_end=10", "output.interval=0.5"]);
        let (o, _) = signalled(&args, Duration::from_millis(1500), signals);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(3), "{signals:?}: {e}");
        let summary: serde_json::Value =
            serde_json::from_slice(&fs::read(out.join("summary.json")).unwrap()).unwrap();
        assert_eq!(summary["complete"], false);
        let sig = format!("SIG{}", signals[0]);
        assert_eq!(summary["stopped_by"], sig.as_str(), "{e}");
        let n = fs::read_dir(out.join("checkpoints")).unwrap().count();
        assert_eq!(n, 1, "{signals:?}: no checkpoint");
    }
    // settling to 50 s of a dam break is millions of steps: max_steps = 5 bounds them
    let out = dir.join("bounded");
    let o = hsph(&run_args(SCENE, &out, &["time.settle=50", "time.max_steps=5"]));
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{e}");
    assert!(e.contains("cut short after 5 steps"), "{e}");
}

/// Defect 9: `hsph check` runs no relaxation and no settling (a run's work, not a check's).
#[test]
fn check_runs_no_set_up_iterations() {
    // a thousand relaxation iterations and 50 s of settling take minutes in a run
    let t0 = Instant::now();
    let o = hsph(&[
        "check",
        SCENE,
        "--set",
        "discretisation.relax=1000",
        "--set",
        "time.settle=50",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        t0.elapsed() < Duration::from_secs(30),
        "check took {:?}",
        t0.elapsed()
    );
}
