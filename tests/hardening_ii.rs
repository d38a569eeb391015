//! Issue 32 (hardening II): each class of defect, tried with the reproducer and with other
//! members of its class. Every refusal is exit 2 with one message naming the key, flag or
//! file; nothing panics; nothing is left behind. Scene-value classes (ranges, step budget,
//! expressions, names, empty bodies) are in `tests/scene_limits.rs`, job scripts in
//! `tests/injection.rs`, random mutants in `tests/fuzz.rs`.

use crate::common;

use common::cli::{assert_input_error, hsph_in, stderr};
use common::{repo_path, temp_dir};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const SCENE: &str = "inputs/dam_break_2d.toml";

fn hsph(args: &[&str]) -> Output {
    hsph_in(&repo_path(""), args)
}

fn scene() -> String {
    repo_path(SCENE).display().to_string()
}

/// Files under `dir` whose names end with `suffix` (recursively).
fn files_ending(dir: &Path, suffix: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Ok(rd) = fs::read_dir(dir) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(files_ending(&p, suffix));
            } else if p.to_string_lossy().ends_with(suffix) {
                out.push(p);
            }
        }
    }
    out
}

/// A finished short run with a checkpoint at its end, in its own directory.
fn run_with_checkpoint(tag: &str, t_end: &str) -> PathBuf {
    let out = temp_dir(tag).join("run");
    let set = format!("time.t_end={t_end}");
    let o = hsph(&[
        "run",
        SCENE,
        "-q",
        "--threads",
        "1",
        "--out",
        out.to_str().unwrap(),
        "--set",
        &set,
        "--set",
        "checkpoint.every_steps=20",
        "--set",
        "output.interval=0.005",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    out
}

#[test]
fn class_03_rank_counts_are_bounded_alike_in_every_command() {
    let s = scene();
    let t0 = Instant::now();
    for ranks in ["20000", "100000", "18446744073709551615"] {
        for cmd in [
            vec!["plan", s.as_str(), "--ranks", ranks],
            vec!["check", s.as_str(), "--ranks", ranks],
            vec![
                "run",
                s.as_str(),
                "--ranks",
                ranks,
                "-q",
                "--out",
                "/nonexistent/x",
            ],
            vec!["topology", "--ranks", ranks],
        ] {
            assert_input_error(&hsph(&cmd), &["--ranks", "4096"]);
        }
    }
    // the same limit per node layout: nodes x ranks per node
    let o = hsph(&[
        "jobscript",
        &s,
        "--nodes",
        "1000",
        "--ranks-per-node",
        "1000",
        "--time",
        "01:00:00",
    ]);
    assert_input_error(&o, &["4096"]);
    // and the particles-per-rank limit of `run`, in plan and jobscript too
    let o = hsph(&["plan", &s, "--ranks", "1000"]);
    assert_input_error(&o, &["--ranks", "at most 138 ranks"]);
    let o = hsph(&[
        "jobscript",
        &s,
        "--nodes",
        "10",
        "--ranks-per-node",
        "100",
        "--time",
        "01:00:00",
    ]);
    assert_input_error(&o, &["--nodes × --ranks-per-node", "at most 138 ranks"]);
    assert!(t0.elapsed() < Duration::from_secs(20), "{:?}", t0.elapsed());
}

#[test]
fn class_04_probe_sizes_are_bounded_before_anything_is_allocated() {
    let dir = temp_dir("points");
    let out = dir.join("run");
    for points in ["100000000000", "1000001", "0"] {
        let set = format!("probe[0].points={points}");
        // a velocity line probe replacing the scene's first probe
        let probe = format!(
            "probe=[{{kind=\"velocity_line\",name=\"line\",from=[0.1,0.05],to=[0.5,0.05],points={points}}}]"
        );
        for cmd in ["check", "run"] {
            let mut args = vec![cmd, SCENE, "--set", probe.as_str()];
            if cmd == "run" {
                args.extend(["-q", "--out", out.to_str().unwrap()]);
            }
            let o = hsph(&args);
            assert_input_error(&o, &["probe[0].points"]);
            assert!(!out.exists(), "{set}: a refused run leaves no directory");
        }
    }
}

#[test]
fn class_05_clocks_far_below_dt_advance_in_one_step_and_a_signal_acts_within_it() {
    let dir = temp_dir("clocks");
    // the default schedule, then clocks far below dt (output and probes): the same steps,
    // each step a few writes, never a loop over the missed intervals
    let base = dir.join("base");
    let steps = |d: &Path| -> u64 {
        let s: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(d.join("summary.json")).unwrap()).unwrap();
        s["steps"].as_u64().unwrap()
    };
    let o = hsph(&[
        "run",
        SCENE,
        "-q",
        "--threads",
        "1",
        "--out",
        base.to_str().unwrap(),
        "--set",
        "time.t_end=0.005",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for (k, set) in [
        "output.interval=1e-30",
        "output.interval=1e-15",
        "probe=[{kind=\"gauge\",name=\"g\",point=[0.3,0.1],interval=1e-300}]",
    ]
    .iter()
    .enumerate()
    {
        let out = dir.join(format!("r{k}"));
        let t0 = Instant::now();
        let o = hsph(&[
            "run",
            SCENE,
            "-q",
            "--threads",
            "1",
            "--out",
            out.to_str().unwrap(),
            "--set",
            "time.t_end=0.005",
            "--set",
            set,
        ]);
        assert_eq!(o.status.code(), Some(0), "{set}: {}", stderr(&o));
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "{set}: {:?}",
            t0.elapsed()
        );
        assert_eq!(steps(&out), steps(&base), "{set}");
    }
    // the check says so
    let o = hsph(&["check", SCENE, "--set", "output.interval=1e-30"]);
    assert_eq!(o.status.code(), Some(0));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("below dt₀") && text.contains("every step"),
        "{text}"
    );
}

#[test]
fn class_05_a_sigterm_is_honoured_within_one_step() {
    // steps of about 0.1 s (a 3D tank of 80 000 particles on one thread), a row every step
    // (the slowest schedule): the rows written after the signal count the steps it took
    let dir = temp_dir("sigterm");
    let out = dir.join("run");
    let mut child = Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args([
            "run",
            "inputs/dam_break_3d.toml",
            "-q",
            "--threads",
            "1",
            "--out",
            out.to_str().unwrap(),
            "--set",
            "discretisation.dx=0.017",
            "--set",
            "output.interval=1e-30",
            "--set",
            "output.format=\"none\"",
        ])
        .current_dir(repo_path(""))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // wait for the step loop: the timeseries grows
    let ts = out.join("timeseries.csv");
    let t0 = Instant::now();
    while fs::read_to_string(&ts).map_or(0, |t| t.lines().count()) < 5 {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "the run did not start stepping"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let before = fs::read_to_string(&ts).unwrap().lines().count();
    let sent = Instant::now();
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = child.wait().unwrap();
    let took = sent.elapsed();
    assert_eq!(status.code(), Some(3), "exit 3 after a signal");
    let s: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["complete"], false);
    // rows are written every step: the run took at most a couple of steps after the signal
    // (the one in progress, and the one in flight when the rows were counted)
    let after = fs::read_to_string(&ts).unwrap().lines().count();
    assert!(
        after <= before + 2,
        "{before} rows when signalled, {after} at the stop"
    );
    assert!(took < Duration::from_secs(10), "{took:?}");
}

#[test]
fn class_06_threads_are_capped_and_oversubscription_is_said() {
    let dir = temp_dir("threads");
    let out = dir.join("run");
    for t in ["100000", "1025"] {
        let o = hsph(&["run", SCENE, "-q", "--threads", t, "--out", out.to_str().unwrap()]);
        assert_input_error(&o, &["--threads", t, "1024"]);
        assert!(!out.exists(), "no run directory for a refused run");
    }
    let o = hsph(&[
        "bench",
        SCENE,
        "--threads",
        "1,5000",
        "--steps",
        "1",
        "--repeat",
        "1",
    ]);
    assert_input_error(&o, &["--threads", "5000"]);
    // above the cores: a warning, and the run runs
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let t = (cores + 1).to_string();
    let o = hsph(&[
        "run",
        SCENE,
        "-q",
        "--threads",
        &t,
        "--out",
        out.to_str().unwrap(),
        "--set",
        "time.max_steps=3",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("warning: --threads"), "{}", stderr(&o));
}

#[test]
fn class_07_force_empties_only_run_directories_and_never_leaves_old_checkpoints() {
    let run = run_with_checkpoint("force", "0.01");
    assert!(!files_ending(&run.join("checkpoints"), "manifest.json").is_empty());
    // a user's own file in the run directory survives --force; the old checkpoints do not
    fs::write(run.join("notes.txt"), "mine").unwrap();
    let o = hsph(&[
        "run",
        SCENE,
        "-q",
        "--threads",
        "1",
        "--force",
        "--out",
        run.to_str().unwrap(),
        "--set",
        "time.t_end=0.002",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(fs::read_to_string(run.join("notes.txt")).unwrap(), "mine");
    assert!(files_ending(&run.join("checkpoints"), "manifest.json").is_empty());
    // so a restart has nothing of the old run to resume
    let o = hsph(&["run", "--restart", run.to_str().unwrap(), "-q"]);
    assert_input_error(&o, &["no complete checkpoint"]);
    // a non-empty directory that is not a run directory is never emptied
    let mine = temp_dir("force-mine");
    fs::write(mine.join("thesis.tex"), "precious").unwrap();
    let o = hsph(&["run", SCENE, "-q", "--force", "--out", mine.to_str().unwrap()]);
    assert_input_error(&o, &["--out", "not a run directory"]);
    assert_eq!(fs::read_to_string(mine.join("thesis.tex")).unwrap(), "precious");
}

#[test]
fn class_07_two_runs_cannot_write_one_directory() {
    let dir = temp_dir("lock");
    let out = dir.join("run");
    let mut first = Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args([
            "run",
            SCENE,
            "-q",
            "--threads",
            "1",
            "--out",
            out.to_str().unwrap(),
            "--set",
            "time.t_end=10",
        ])
        .current_dir(repo_path(""))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !out.join("timeseries.csv").exists() {
        assert!(t0.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(20));
    }
    let o = hsph(&["run", SCENE, "-q", "--force", "--out", out.to_str().unwrap()]);
    let _ = first.kill();
    let _ = first.wait();
    assert_input_error(&o, &["--out", "in use by another hsph run"]);
}

#[test]
fn class_08_a_full_disk_during_a_checkpoint_leaves_no_temporary_file() {
    let dir = temp_dir("fulldisk");
    let out = dir.join("run");
    let o = Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args([
            "run",
            SCENE,
            "-q",
            "--threads",
            "1",
            "--out",
            out.to_str().unwrap(),
            "--set",
            "time.t_end=0.01",
            "--set",
            "checkpoint.every_steps=10",
        ])
        .env("HSPH_TEST_FULL_DISK", "part-00000.tmp")
        .current_dir(repo_path(""))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("No space left"), "{}", stderr(&o));
    assert!(
        files_ending(&out, ".tmp").is_empty(),
        "{:?}",
        files_ending(&out, ".tmp")
    );
    // and a file-size limit (a quota) in a real write, where the shell can set one
    let limited = dir.join("limited");
    let script = format!(
        "trap '' XFSZ; ulimit -f 64; exec {} run {} -q --threads 1 --out {} --set time.t_end=0.01 \
         --set checkpoint.every_steps=10 --set output.format='\"none\"'",
        env!("CARGO_BIN_EXE_hsph"),
        scene(),
        limited.display()
    );
    let o = Command::new("bash").args(["-c", &script]).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        files_ending(&limited, ".tmp").is_empty(),
        "{:?}",
        files_ending(&limited, ".tmp")
    );
}

/// A change made to a checkpoint manifest.
type Edit = Box<dyn Fn(&mut serde_json::Value)>;

#[test]
fn class_09_16_a_restart_may_not_end_before_it_starts_nor_trust_its_manifest() {
    let run = run_with_checkpoint("restart", "0.01");
    let o = hsph(&[
        "run",
        "--restart",
        run.to_str().unwrap(),
        "-q",
        "--set",
        "time.t_end=0.001",
    ]);
    assert_input_error(&o, &["time.t_end", "before the checkpoint's time"]);
    let o = hsph(&[
        "run",
        "--restart",
        run.to_str().unwrap(),
        "-q",
        "--set",
        "time.max_steps=1",
    ]);
    assert_input_error(&o, &["time.max_steps"]);
    // the newest checkpoint, which a restart reads
    let mut manifests = files_ending(&run.join("checkpoints"), "manifest.json");
    manifests.sort();
    let ck = manifests.pop().unwrap();
    let original = fs::read_to_string(&ck).unwrap();
    let m: serde_json::Value = serde_json::from_str(&original).unwrap();
    let edits: Vec<(&str, Edit)> = vec![
        (
            "part file",
            Box::new(|m| m["parts"][0]["file"] = "../../../../etc/passwd".into()),
        ),
        (
            "part file",
            Box::new(|m| m["parts"][0]["file"] = "/etc/passwd".into()),
        ),
        ("part file", Box::new(|m| m["parts"][0]["file"] = "".into())),
        ("t = -1", Box::new(|m| m["t"] = (-1e300).into())),
        ("dt", Box::new(|m| m["dt"] = 0.0.into())),
        ("parts", Box::new(|m| m["ranks"] = 100000.into())),
        (
            "particles",
            Box::new(|m| m["parts"][0]["particles"] = u64::MAX.into()),
        ),
        ("bytes", Box::new(|m| m["parts"][0]["bytes"] = 1.into())),
        (
            "series",
            Box::new(|m| m["run"]["series"]["../../victim"] = 0.into()),
        ),
        (
            "series",
            Box::new(|m| m["run"]["series"]["timeseries.csv"] = u64::MAX.into()),
        ),
    ];
    let victim = run.parent().unwrap().parent().unwrap().join("victim");
    fs::write(&victim, "keep me").unwrap();
    for (what, edit) in &edits {
        let mut bad = m.clone();
        edit(&mut bad);
        fs::write(&ck, serde_json::to_string(&bad).unwrap()).unwrap();
        let o = hsph(&[
            "run",
            "--restart",
            run.to_str().unwrap(),
            "-q",
            "--set",
            "time.t_end=0.02",
        ]);
        assert_input_error(&o, &["--restart"]);
        assert!(
            stderr(&o).contains(what) || stderr(&o).contains("manifest"),
            "{what}: {}",
            stderr(&o)
        );
        assert_eq!(fs::read_to_string(&victim).unwrap(), "keep me");
    }
    fs::write(&ck, original).unwrap();
}

#[test]
fn class_10_runs_started_together_get_directories_of_their_own() {
    let cwd = temp_dir("together");
    let children: Vec<_> = (0..3)
        .map(|_| {
            Command::new(env!("CARGO_BIN_EXE_hsph"))
                .args([
                    "run",
                    &scene(),
                    "-q",
                    "--threads",
                    "1",
                    "--set",
                    "time.max_steps=2",
                ])
                .current_dir(&cwd)
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for c in children {
        let o = c.wait_with_output().unwrap();
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let dirs: Vec<_> = fs::read_dir(cwd.join("runs")).unwrap().flatten().collect();
    assert_eq!(dirs.len(), 3);
    for d in dirs {
        assert!(d.path().join("summary.json").is_file(), "{:?}", d.path());
    }
}

#[test]
fn class_11_20_every_command_returns_2_for_bad_flags() {
    let s = scene();
    for args in [
        vec!["validate", "poiseuille", "--resolutions", "0"],
        vec!["validate", "poiseuille", "--resolutions", "1000000000"],
        vec!["validate", "poiseuille", "--set", "foo.bar=1"],
        vec!["validate", "couette", "--set", "time.t_end=-1"],
        vec!["validate", "poiseuille", "--jobs", "0"],
        vec!["validate", "poiseuille", "--threads", "100000"],
        vec!["bench", s.as_str(), "--steps", "0"],
        vec!["bench", s.as_str(), "--repeat", "0"],
        vec!["bench", s.as_str(), "--steps", "10000000000"],
        vec!["run", s.as_str(), "--max-wall", "99:99:99"],
        vec!["run", s.as_str(), "--max-wall", "99999999:00:00"],
        vec!["jobscript", s.as_str(), "--time", "99999999:00:00"],
        vec![
            "jobscript",
            s.as_str(),
            "--time",
            "01:00:00",
            "--signal-before",
            "0",
        ],
        vec![
            "jobscript",
            s.as_str(),
            "--nodes",
            "1000000",
            "--ranks-per-node",
            "1000000",
            "--time",
            "01:00:00",
        ],
    ] {
        let o = hsph(&args);
        let flag = args.iter().rev().find(|a| a.starts_with("--")).unwrap();
        let key = if *flag == "--set" { "foo" } else { flag };
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(!e.contains("panicked"), "{e}");
        assert!(
            e.contains(key) || e.contains("t_end") || e.contains("--nodes"),
            "{args:?}: {e}"
        );
    }
}

#[test]
fn class_15_inputs_are_read_with_a_bound_and_never_from_devices() {
    let s = scene();
    let t0 = Instant::now();
    let big = temp_dir("big").join("big.toml");
    fs::write(&big, "#".repeat(17 << 20)).unwrap();
    for args in [
        vec!["check", "/dev/zero"],
        vec!["check", "/dev/urandom"],
        vec!["check", big.to_str().unwrap()],
        vec!["run", "/dev/zero", "-q"],
        vec!["plan", s.as_str(), "--ranks", "2", "--topology", "/dev/zero"],
        vec!["plan", s.as_str(), "--ranks", "2", "--topology", "/"],
        vec!["run", s.as_str(), "--topology", "/dev/zero", "-q"],
    ] {
        let o = hsph(&args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(
            e.contains("not a regular file") || e.contains("limit"),
            "{args:?}: {e}"
        );
    }
    assert!(t0.elapsed() < Duration::from_secs(20), "{:?}", t0.elapsed());
}

#[test]
fn class_02_no_write_replaces_a_non_regular_file() {
    let s = scene();
    let dir = temp_dir("nonregular");
    // a plan's files, a validation's --write, a job script: never over a device or a FIFO
    let plan = dir.join("plan");
    fs::create_dir_all(&plan).unwrap();
    std::os::unix::fs::symlink("/dev/full", plan.join("plan.json")).unwrap();
    let o = hsph(&["plan", &s, "--ranks", "2", "--out", plan.to_str().unwrap()]);
    assert_input_error(&o, &["plan.json", "not a regular file"]);
    let fifo = dir.join("fifo");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let o = hsph(&[
        "jobscript",
        &s,
        "--time",
        "01:00:00",
        "--script",
        fifo.to_str().unwrap(),
    ]);
    assert_input_error(&o, &["--script"]);
    let o = hsph(&["jobscript", &s, "--time", "01:00:00", "--script", "/dev/full"]);
    assert_input_error(&o, &["--script"]);
    assert!(Path::new("/dev/full").exists());
}
