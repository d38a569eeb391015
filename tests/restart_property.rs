//! The restart property (README, "Restart"): whatever stops a run — `time.max_steps`, a
//! stopping signal at a random moment, a file-size limit (`ulimit -f`) at a random size — and
//! however often, restarting it until it is complete gives a run directory whose every file
//! is byte-identical to an uninterrupted run's, with no `.tmp` file and no lock left.
//!
//! Compared: every file but the machine's own figures and the run's history — `summary.json`
//! (timers; its `complete` and `steps` are checked), `diagnostics.csv` (timers), `traffic.csv`
//! (a restart's migration is traffic of its own) and `checkpoints/` (a stop writes one of its
//! own; each is checked by the restart that reads it).
//!
//! CI runs [`CI_CASES`] random cases; more with
//! `HSPH_RESTART_CASES=2000 HSPH_RESTART_SEED=7 cargo test --release --test suite restart_property`.

use crate::common::{temp_dir, Rng};
use std::collections::BTreeMap;
use std::fs;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Cases in CI (each a reference run shared by scene, and one to five processes).
const CI_CASES: usize = 200;
/// Steps of every case's run.
const STEPS: u64 = 24;

/// A tiny dam break (about 120 fluid and 240 wall particles) with every kind of output a run
/// appends to: probes on their own clocks, snapshots (`format`), removals (`outflow`).
fn scene(format: &str, outflow: &str, interval: f64) -> String {
    format!(
        r#"name = "tiny"
dimension = 2
[domain]
min = [-0.04, -0.04]
max = [0.24, 0.2]
outflow = "{outflow}"
[discretisation]
dx = 0.01
h_over_dx = 1.3
[[material]]
name = "water"
rho0 = 1000.0
c0 = 20.0
eos = "tait"
gamma = 7.0
[physics]
density_diffusion = "antuono"
delta = 0.1
artificial_viscosity = 0.02
body_force = [0.0, -9.81]
[[fluid]]
name = "column"
material = "water"
min = [0.0, 0.0]
max = [0.08, 0.15]
hydrostatic = true
[[wall]]
name = "tank"
shape = "container"
min = [0.0, 0.0]
max = [0.2, 0.16]
open = ["y+"]
method = "dummy"
[time]
t_end = 1.0
cfl = 0.2
[output]
interval = {interval}
format = "{format}"
[[probe]]
name = "front"
kind = "front"
axis = 0
[[probe]]
name = "wall_p"
kind = "pressure"
point = [0.2, 0.01]
diameter = 0.01
normal = [-1.0, 0.0]
interval = 0.0002
"#
    )
}

/// The scene variants: (snapshot format, outflow rule, output interval (s)).
const VARIANTS: [(&str, &str, f64); 4] = [
    ("vtk", "stop", 0.0004),
    ("netcdf", "remove", 0.0007),
    ("none", "stop", 0.001),
    ("vtk", "remove", 0.0011),
];
/// Checkpoint intervals (steps; 0: only when stopped).
const EVERY: [u64; 4] = [0, 3, 5, 8];

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_hsph")
}

/// The arguments of a fresh run of `scene` into `out` to `max` steps.
fn fresh(scene: &Path, out: &Path, every: u64, max: u64) -> Vec<String> {
    let mut a: Vec<String> = ["run", scene.to_str().unwrap(), "-q", "--threads", "1", "--out"]
        .map(String::from)
        .to_vec();
    a.push(out.to_str().unwrap().into());
    a.extend(["--set".into(), format!("checkpoint.every_steps={every}")]);
    a.extend(["--set".into(), format!("time.max_steps={max}")]);
    a
}

/// The arguments of a restart of `run` to `max` steps.
fn restart(run: &Path, max: u64) -> Vec<String> {
    let mut a: Vec<String> = ["run", "--restart", run.to_str().unwrap(), "-q", "--threads", "1"]
        .map(String::from)
        .to_vec();
    a.extend(["--set".into(), format!("time.max_steps={max}")]);
    a
}

/// Whether `run` holds a complete checkpoint (one with a manifest).
fn has_checkpoint(run: &Path) -> bool {
    fs::read_dir(run.join("checkpoints"))
        .map(|rd| rd.flatten().any(|e| e.path().join("manifest.json").is_file()))
        .unwrap_or(false)
}

/// Every file under `dir`, relative, with its bytes.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut all = crate::common::dir_snapshot(dir);
    all.retain(|k, _| !k.ends_with('/') && !k.ends_with(" (special)"));
    all
}

/// The files compared with the uninterrupted run (see the module's doc).
fn compared(all: &BTreeMap<String, Vec<u8>>) -> BTreeMap<String, Vec<u8>> {
    all.iter()
        .filter(|(k, _)| {
            !["summary.json", "diagnostics.csv", "traffic.csv"].contains(&k.as_str())
                && !k.starts_with("checkpoints/")
        })
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect()
}

/// How one segment is stopped.
#[derive(Debug, Clone, Copy)]
enum Stop {
    /// `time.max_steps` below the end.
    Steps(u64),
    /// A stopping signal after this many milliseconds.
    Signal(&'static str, u64),
    /// `ulimit -f` of this many 512-byte blocks.
    FileSize(u64),
    /// None: to the end.
    End,
}

/// Run one segment of `args` stopped by `stop`: its exit status (None: killed by a signal).
fn segment(mut args: Vec<String>, stop: Stop) -> (Option<i32>, String) {
    if let Stop::Steps(k) = stop {
        args.extend(["--set".into(), format!("time.max_steps={k}")]);
    }
    let mut cmd = match stop {
        Stop::FileSize(blocks) => {
            let mut c = Command::new("sh");
            c.arg("-c")
                .arg(format!("ulimit -f {blocks} && exec \"$0\" \"$@\""))
                .arg(bin())
                .args(&args);
            c
        }
        _ => {
            let mut c = Command::new(bin());
            c.args(&args);
            c
        }
    };
    let child = cmd.stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    if let Stop::Signal(sig, ms) = stop {
        std::thread::sleep(Duration::from_millis(ms));
        let _ = Command::new("kill")
            .args([format!("-{sig}"), child.id().to_string()])
            .stderr(Stdio::null())
            .status();
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_run_stopped_and_restarted_anyhow_ends_with_the_uninterrupted_files() {
    let cases: usize = std::env::var("HSPH_RESTART_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(CI_CASES);
    let seed: u64 = std::env::var("HSPH_RESTART_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(81);
    let root = temp_dir("restart-property");
    let mut rng = Rng(seed);
    // the uninterrupted runs, one per scene variant and checkpoint interval
    let mut references: BTreeMap<(usize, u64), BTreeMap<String, Vec<u8>>> = BTreeMap::new();
    let mut scenes = Vec::new();
    for (v, (format, outflow, interval)) in VARIANTS.iter().enumerate() {
        let path = root.join(format!("tiny_{v}.toml"));
        fs::write(&path, scene(format, outflow, *interval)).unwrap();
        scenes.push(path);
    }
    let mut tally = BTreeMap::<String, usize>::new();
    for case in 0..cases {
        let v = rng.below(VARIANTS.len());
        let every = EVERY[rng.below(EVERY.len())];
        let scene = &scenes[v];
        let reference = references.entry((v, every)).or_insert_with(|| {
            let out = root.join(format!("ref_{v}_{every}"));
            let (code, err) = segment(fresh(scene, &out, every, STEPS), Stop::End);
            assert_eq!(code, Some(0), "{err}");
            compared(&files(&out))
        });
        let run = root.join(format!("case_{case}"));
        let mut history = Vec::new();
        let stops = 1 + rng.below(4);
        for _ in 0..=stops {
            let last = history.len() == stops;
            let stop = if last {
                Stop::End
            } else {
                match rng.below(3) {
                    0 => Stop::Steps(1 + rng.below(STEPS as usize - 1) as u64),
                    1 => {
                        let sig = ["TERM", "INT", "USR1", "HUP"][rng.below(4)];
                        Stop::Signal(sig, rng.below(120) as u64)
                    }
                    _ => Stop::FileSize(1 + rng.below(400) as u64),
                }
            };
            let args = if has_checkpoint(&run) {
                restart(&run, STEPS)
            } else {
                let mut a = fresh(scene, &run, every, STEPS);
                if run.exists() {
                    a.push("--force".into());
                }
                a
            };
            let fresh_start = !has_checkpoint(&run);
            let (code, err) = segment(args, stop);
            history.push(format!("{stop:?} → {code:?}"));
            let ok = match stop {
                Stop::End => code == Some(0),
                // a restart to steps below its checkpoint's is refused (exit 2)
                Stop::Steps(_) => code == Some(0) || (code == Some(2) && !fresh_start),
                Stop::Signal(..) => matches!(code, Some(0) | Some(3) | None),
                Stop::FileSize(_) => matches!(code, Some(0) | Some(1)),
            };
            assert!(ok, "case {case} (variant {v}, every {every}): {history:?}\n{err}");
            assert!(!err.contains("panicked"), "case {case}: {history:?}\n{err}");
            *tally
                .entry(format!("{stop:?}").split('(').next().unwrap().to_string())
                .or_default() += 1;
        }
        let all = files(&run);
        let left: Vec<&String> = all
            .keys()
            .filter(|k| k.ends_with(".tmp") || k.ends_with(".hsph.lock"))
            .collect();
        assert!(left.is_empty(), "case {case}: {left:?} left; {history:?}");
        let summary: serde_json::Value = serde_json::from_slice(&all["summary.json"]).unwrap();
        assert_eq!(summary["complete"], true, "case {case}: {history:?}");
        assert_eq!(summary["steps"], STEPS, "case {case}: {history:?}");
        let got = compared(&all);
        let names = |m: &BTreeMap<String, Vec<u8>>| m.keys().cloned().collect::<Vec<_>>();
        assert_eq!(names(&got), names(reference), "case {case}: {history:?}");
        for (name, bytes) in &got {
            assert!(
                bytes == &reference[name],
                "case {case} (variant {v}, every {every}): {name} differs from the uninterrupted \
                 run's after {history:?} (in {})",
                run.display()
            );
        }
        // a passing case leaves no directory behind
        let _ = fs::remove_dir_all(&run);
    }
    eprintln!("restart property: {cases} cases, segments by stop: {tally:?}");
}

/// A restarted segment that writes no output step before a signal stops it at the run's last
/// step: its checkpoint precedes the last state's row, so the restart that finishes the run
/// writes that row again (the restart property's seed 81, case 180, found the lost snapshot).
#[test]
fn a_signal_at_the_last_step_of_a_restarted_segment_loses_no_output() {
    let root = temp_dir("restart-last-step");
    let path = root.join("tiny.toml");
    fs::write(&path, scene("vtk", "stop", 0.0004)).unwrap();
    let go = |args: Vec<String>, fault: Option<&str>| {
        let mut c = Command::new(bin());
        c.args(&args).stdout(Stdio::null());
        if let Some(f) = fault {
            c.env("HSPH_TEST_FAULT", f);
        }
        let out = c.output().unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (reference, run) = (root.join("reference"), root.join("run"));
    let (code, err) = go(fresh(&path, &reference, 5, STEPS), None);
    assert_eq!(code, Some(0), "{err}");
    // a first leg to two steps short of the end, then a restart stopped at the last step
    let (code, err) = go(fresh(&path, &run, 5, STEPS - 2), None);
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = go(restart(&run, STEPS), Some(&format!("0:{STEPS}:signal")));
    assert_eq!(code, Some(3), "{err}");
    let (code, err) = go(restart(&run, STEPS), None);
    assert_eq!(code, Some(0), "{err}");
    let (got, want) = (compared(&files(&run)), compared(&files(&reference)));
    let names = |m: &BTreeMap<String, Vec<u8>>| m.keys().cloned().collect::<Vec<_>>();
    assert_eq!(names(&got), names(&want));
    for (name, bytes) in &got {
        assert!(
            bytes == &want[name],
            "{name} differs from the uninterrupted run's"
        );
    }
}
