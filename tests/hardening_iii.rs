//! Hardening III: the classes of defects 6, 8, 12, 13, 14 and 15, each tried with the
//! reproducer and with other members of its class. Every refusal is exit 2 with one message
//! naming the file (and line), key or flag; nothing panics; nothing is allocated from a number
//! a file or flag gave before it is checked.

use crate::common;

use common::cli::{assert_input_error, run_args, stderr};
use common::{repo_path, temp_dir};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const SCENE: &str = "inputs/dam_break_2d.toml";
/// A small scene of local time stepping (cycles of 2 steps).
const LOCAL: &str = "tests/data/drift_local_2d.toml";

use crate::common::cli::hsph_out as hsph;

/// `hsph ARGS` under `ulimit -v` of 2 GiB: a number read from a file or flag that sized an
/// allocation before it was checked would abort it (exit 134), not refuse it (exit 2).
fn hsph_bounded(args: &[&str]) -> Output {
    let mut cmd = Command::new("sh");
    cmd.arg("-c")
        .arg("ulimit -v 2097152; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_hsph"))
        .args(args)
        .current_dir(repo_path(""));
    cmd.output().expect("sh runs")
}

/// A short finished run of the dam break on `ranks` ranks in `dir/name`.
fn short_run(dir: &Path, name: &str, ranks: usize) -> PathBuf {
    let out = dir.join(name);
    let mut args = run_args(SCENE, &out, &["time.max_steps=12"]);
    args.extend(["--ranks".into(), ranks.to_string()]);
    let o = hsph(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    out
}

/// A copy of run directory `from` at `to` with `summary.json`'s `key` set to the JSON `value`.
fn with_summary(from: &Path, to: &Path, key: &str, value: &str) -> PathBuf {
    fs::create_dir_all(to).unwrap();
    for e in fs::read_dir(from).unwrap().flatten() {
        if e.path().is_file() {
            fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
    let p = to.join("summary.json");
    let mut s: serde_json::Value = serde_json::from_str(&fs::read_to_string(&p).unwrap()).unwrap();
    s[key] = serde_json::from_str(value).unwrap();
    fs::write(&p, serde_json::to_string_pretty(&s).unwrap()).unwrap();
    to.to_path_buf()
}

/// Defect 6: `model` and `report` read every number of `summary.json` (and of the series they
/// read) through the limits of the flags, before anything is sized by it.
#[test]
fn class_06_run_directory_numbers_are_bounded_in_model_and_report() {
    let dir = temp_dir("summary");
    let one = short_run(&dir, "r1", 1);
    let two = short_run(&dir, "r2", 2);
    let scene = repo_path(SCENE).display().to_string();
    let (one_s, two_s) = (one.to_str().unwrap(), two.to_str().unwrap());
    // the same class in every key: beyond a flag's limit, zero, negative, fractional
    let cases: [(&str, &str, &str); 9] = [
        ("ranks", "1e9", "4096"),
        ("ranks", "0", "4096"),
        ("threads", "100000000", "1024"),
        ("nodes", "1e12", "4096"),
        ("particles", "0", "2147483648"),
        ("particles", "1e300", "2147483648"),
        ("steps", "-5", "1000000000"),
        ("wall_s", "-1", "31622400"),
        ("ranks", "2.5", "4096"),
    ];
    for (k, (key, value, limit)) in cases.iter().enumerate() {
        let bad = with_summary(&one, &dir.join(format!("bad{k}")), key, value);
        let bad_s = bad.to_str().unwrap();
        let needles = ["summary.json", &format!("`{key}`"), limit];
        let o = hsph_bounded(&[
            "report",
            bad_s,
            "--out",
            dir.join(format!("rep{k}")).to_str().unwrap(),
        ]);
        assert_input_error(&o, &needles);
        let o = hsph_bounded(&["model", &scene, "--one", one_s, "--many", bad_s]);
        assert_input_error(&o, &needles);
    }
    // what the model cannot use although a run could write it: no steps, no time
    for (key, value, needle) in [
        ("steps", "0", "is 0"),
        ("wall_s", "0", "positive"),
        ("ranks", "\"two\"", "not a number"),
    ] {
        let bad = with_summary(&one, &dir.join(format!("m-{key}")), key, value);
        let o = hsph_bounded(&["model", &scene, "--one", bad.to_str().unwrap(), "--many", two_s]);
        assert_input_error(&o, &["summary.json", &format!("`{key}`"), needle]);
    }
    // nested numbers too: a timer, a traffic count beyond 64-bit sums
    let bad = with_summary(
        &one,
        &dir.join("timers"),
        "timers",
        r#"{"step_s": {"min": 0, "mean": -3, "max": 1}}"#,
    );
    assert_input_error(
        &hsph_bounded(&["report", bad.to_str().unwrap()]),
        &["summary.json", "timers.step_s.mean"],
    );
    // the series the report reads: a rank of 10^18 in traffic.csv, a step of -1 and an inf in
    // diagnostics.csv, each named with its file, line and column
    let series = with_summary(&two, &dir.join("series"), "complete", "true");
    let traffic = series.join("traffic.csv");
    let text = fs::read_to_string(&traffic).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut f: Vec<String> = lines[1].split(',').map(str::to_string).collect();
    f[2] = "1000000000000000000".into();
    lines[1] = f.join(",");
    fs::write(&traffic, lines.join("\n") + "\n").unwrap();
    assert_input_error(
        &hsph_bounded(&["report", series.to_str().unwrap()]),
        &["traffic.csv:2", "src_rank", "0 to 1"],
    );
    fs::write(&traffic, &text).unwrap();
    let diag = series.join("diagnostics.csv");
    let dtext = fs::read_to_string(&diag).unwrap();
    for (col, value) in [(0usize, "-1"), (1, "inf")] {
        let mut lines: Vec<String> = dtext.lines().map(str::to_string).collect();
        let header: Vec<String> = lines[0].split(',').map(str::to_string).collect();
        let mut f: Vec<String> = lines[1].split(',').map(str::to_string).collect();
        f[col] = value.into();
        lines[1] = f.join(",");
        fs::write(&diag, lines.join("\n") + "\n").unwrap();
        assert_input_error(
            &hsph_bounded(&["report", series.to_str().unwrap()]),
            &["diagnostics.csv:2", &format!("`{}`", header[col])],
        );
    }
    // the network flags within a physical range, named with it
    for (flag, value, range) in [
        ("--latency", "1e308", "0 to 1000000 µs"),
        ("--latency", "-1", "0 to 1000000 µs"),
        ("--bandwidth", "0", "0.001 to 10000 GB/s"),
        ("--bandwidth", "1e30", "0.001 to 10000 GB/s"),
        ("--bandwidth", "NaN", "0.001 to 10000 GB/s"),
    ] {
        let arg = format!("{flag}={value}");
        let o = hsph(&["model", &scene, "--one", one_s, "--many", two_s, &arg]);
        assert_input_error(&o, &[flag, range]);
    }
    // and the untouched runs still model and report
    let o = hsph(&["model", &scene, "--one", one_s, "--many", two_s]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = hsph(&["report", two_s, "--out", dir.join("ok").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Processes whose command line holds `needle` (Linux `/proc`).
fn processes_with(needle: &str) -> Vec<String> {
    let mut out = Vec::new();
    for e in fs::read_dir("/proc").into_iter().flatten().flatten() {
        if let Ok(c) = fs::read(e.path().join("cmdline")) {
            let c = String::from_utf8_lossy(&c).replace('\0', " ");
            if c.contains(needle) && !c.contains("hardening_iii") {
                out.push(format!("{}: {c}", e.file_name().to_string_lossy()));
            }
        }
    }
    out
}

/// Start `hsph validate poiseuille` into `out`, wait until its child run has written a row
/// of its series, then send `signal`; the validate's output.
fn validate_signalled(out: &Path, signal: &str) -> Output {
    let child = Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(["validate", "poiseuille", "--resolutions", "24", "--out"])
        .arg(out)
        .current_dir(repo_path(""))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("hsph runs");
    let series = out
        .join("runs")
        .join("poiseuille-n24-quintic_spline-h1.0-dummy-none")
        .join("timeseries.csv");
    let t0 = Instant::now();
    while fs::read_to_string(&series).map_or(true, |t| t.lines().count() < 2) {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "the child run never wrote a row"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let ok = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(ok.success());
    child.wait_with_output().unwrap()
}

/// Defect 8: a stopping signal to `hsph validate` reaches its child runs, which stop with a
/// checkpoint; validate waits for them and exits 3; no child survives; the same command
/// again resumes the sweep and finishes it.
#[test]
fn class_08_validate_forwards_stopping_signals_and_waits_for_its_runs() {
    let dir = temp_dir("validate-signal");
    let out = dir.join("v");
    let o = validate_signalled(&out, "TERM");
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{e}");
    assert!(e.contains("stopped by SIGTERM") && e.contains("resume"), "{e}");
    assert!(
        processes_with(out.to_str().unwrap()).is_empty(),
        "{:?}",
        processes_with(out.to_str().unwrap())
    );
    let run = out
        .join("runs")
        .join("poiseuille-n24-quintic_spline-h1.0-dummy-none");
    let s: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(run.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["complete"], false);
    assert_eq!(s["stopped_by"], "SIGTERM");
    assert!(run.join("checkpoints").read_dir().unwrap().count() >= 1);
    // the stopped configuration has no row: the second sweep runs it, and succeeds
    let rows = fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert_eq!(rows.lines().count(), 1, "{rows}");
    let o = hsph(&[
        "validate",
        "poiseuille",
        "--resolutions",
        "24",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let rows = fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert_eq!(rows.lines().count(), 2, "{rows}");
    assert!(rows.lines().nth(1).unwrap().ends_with(",ok"), "{rows}");
    // a closed terminal (SIGHUP) stops the sweep the same way
    let out = dir.join("hup");
    let o = validate_signalled(&out, "HUP");
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(processes_with(out.to_str().unwrap()).is_empty());
}

/// Defect 12: every output-path flag of every command is checked up front, the same way.
#[test]
fn class_12_output_paths_are_checked_before_anything_runs() {
    let dir = temp_dir("outpaths");
    let file = dir.join("a-file");
    fs::write(&file, "x").unwrap();
    let scene = repo_path(SCENE).display().to_string();
    let run = short_run(&dir, "r1", 1);
    let under_file = file.join("x").join("y");
    // the flags that name a file: jobscript's --script and validate's --write
    let v = dir.join("v");
    let file_flags = |p: &str| {
        let job = ["--nodes", "1", "--ranks-per-node", "2", "--time", "01:00:00"];
        let script: Vec<&str> = ["jobscript", &scene]
            .into_iter()
            .chain(job)
            .chain(["--script", p])
            .collect();
        let write = [
            "validate",
            "poiseuille",
            "--resolutions",
            "8",
            "--target",
            "0.5",
            "--write",
            p,
            "--out",
            v.to_str().unwrap(),
        ];
        [("--script", hsph(&script)), ("--write", hsph(&write))]
    };
    for (path, needle) in [(PathBuf::from("/dev/null"), "not a"), (under_file, "lies under")] {
        let p = path.to_str().unwrap();
        let dir_flags: Vec<Vec<&str>> = vec![
            vec!["plan", &scene, "--ranks", "2", "--out", p],
            vec!["validate", "poiseuille", "--resolutions", "8", "--out", p],
            vec!["run", &scene, "-q", "--out", p],
            vec!["report", run.to_str().unwrap(), "--out", p],
            vec![
                "jobscript",
                &scene,
                "--nodes",
                "1",
                "--ranks-per-node",
                "2",
                "--time",
                "01:00:00",
                "--out",
                p,
            ],
        ];
        for args in dir_flags {
            assert_input_error(&hsph(&args), &["--out", p, needle]);
        }
        for (flag, o) in file_flags(p) {
            assert_input_error(&o, &[flag, p, needle]);
        }
    }
    // a file's parent must exist (a directory's missing parents are made, as `run` always
    // made `runs/`)
    let missing = dir.join("no-such-dir").join("job.sh");
    let p = missing.to_str().unwrap();
    for (flag, o) in file_flags(p) {
        assert_input_error(&o, &[flag, p, "does not exist"]);
    }
    let deep = dir.join("new").join("plan");
    let o = hsph(&["plan", &scene, "--ranks", "2", "--out", deep.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(deep.join("plan.json").is_file());
    // nothing was made on the way
    assert!(!dir.join("no-such-dir").exists());
    assert!(!dir.join("v").exists());
}

/// Defect 13: an error inside an entry of an array of tables names that entry and its line,
/// or the `--set` that set it; a sphere's box outside the domain names its radius; a conflict
/// between a flag and the file names the flag.
#[test]
fn class_13_errors_name_their_own_entry_key_and_line() {
    let dir = temp_dir("locations");
    let scene = repo_path(SCENE);
    let s = scene.to_str().unwrap();
    // --set into a later probe: the key and --set, not probe[0] at the file's first probe
    for (set, key) in [
        ("probe[1].diameter=\"x\"", "probe[1].diameter"),
        ("probe[2].body=3", "probe[2].body"),
        ("probe[2].nosuch=1", "probe[2].nosuch"),
        ("probe[0].axis=-1", "probe[0].axis"),
        ("probe[1].point=7", "probe[1].point"),
    ] {
        let o = hsph(&["check", s, "--set", set]);
        assert_input_error(&o, &["--set", &format!("key `{key}`")]);
    }
    // the same in the file: the entry's own line
    let text = fs::read_to_string(&scene).unwrap();
    let line_of = |needle: &str| text.lines().position(|l| l.starts_with(needle)).unwrap() + 1;
    for (from, to, key, line) in [
        (
            "diameter = 0.01",
            "diameter = \"big\"",
            "probe[1].diameter",
            line_of("diameter = 0.01"),
        ),
        (
            "about = [0.584, 0.0]",
            "about = 3",
            "probe[2].about",
            line_of("about = "),
        ),
        (
            "window = 0.002",
            "windw = 0.002",
            "probe[1].windw",
            line_of("window = 0.002"),
        ),
    ] {
        let p = dir.join(format!("{}.toml", key.replace(['[', ']', '.'], "_")));
        fs::write(&p, text.replacen(from, to, 1)).unwrap();
        let o = hsph(&["check", p.to_str().unwrap()]);
        assert_input_error(&o, &[&format!("{}:{line}", p.display()), &format!("key `{key}`")]);
    }
    // the reference (one tagged table)
    let couette = repo_path("inputs/couette_2d.toml").display().to_string();
    let o = hsph(&["check", &couette, "--set", "reference.gap=\"x\""]);
    assert_input_error(&o, &["--set", "key `reference.gap`"]);
    // a sphere's box comes from centre and radius: a radius too large is named as such, in
    // a refinement region and in a body alike
    let refined = repo_path("inputs/hydrostatic_2d_refined.toml")
        .display()
        .to_string();
    let sphere = [
        "refine[0].shape=\"sphere\"",
        "refine[0].centre=[0.5, 0.25]",
        "refine[0].radius=5.0",
        "refine[0].min=[]",
        "refine[0].max=[]",
    ];
    let mut args = vec!["check", refined.as_str()];
    for x in &sphere {
        args.extend(["--set", x]);
    }
    assert_input_error(&hsph(&args), &["key `refine[0].radius`", "lower its radius"]);
    let sphere_fluid = [
        "fluid[0].shape=\"sphere\"",
        "fluid[0].centre=[0.1, 0.1]",
        "fluid[0].radius=3.0",
        "fluid[0].min=[]",
        "fluid[0].max=[]",
    ];
    let mut args = vec!["check", s];
    for x in &sphere_fluid {
        args.extend(["--set", x]);
    }
    assert_input_error(&hsph(&args), &["key `fluid[0].radius`"]);
    // a typed flag against the file: the flag is named, not the file
    let out = dir.join("pairs");
    let o = hsph(&[
        "run",
        LOCAL,
        "-q",
        "--interactions",
        "pairs",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "time.max_steps=2",
    ]);
    let e = stderr(&o);
    assert_input_error(&o, &["--interactions"]);
    assert!(!e.contains("drift_local_2d.toml:"), "{e}");
}

/// Defect 14: under local time stepping every key that counts steps is acted on at cycle
/// ends; an odd one is warned by `check` and `run`, naming the steps it will act on.
#[test]
fn class_14_odd_step_counts_under_local_stepping_are_warned() {
    let dir = temp_dir("cycles");
    let check = |sets: &[&str]| {
        let mut args = vec!["check", LOCAL];
        for x in sets {
            args.extend(["--set", x]);
        }
        let o = hsph(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        // `check` prints its warnings with its report, on standard output
        String::from_utf8_lossy(&o.stdout).into_owned() + &stderr(&o)
    };
    let e = check(&["checkpoint.every_steps=51"]);
    assert!(
        e.contains("checkpoint.every_steps = 51 is odd")
            && e.contains("every 102 steps")
            && e.contains("102, 204"),
        "{e}"
    );
    let e = check(&["time.max_steps=51"]);
    assert!(
        e.contains("time.max_steps = 51 is odd") && e.contains("ends at step 52"),
        "{e}"
    );
    let e = check(&["checkpoint.every_steps=52", "time.max_steps=50"]);
    assert!(!e.contains("is odd"), "{e}");
    let e = check(&["checkpoint.every_steps=51", "time.stepping=\"global\""]);
    assert!(!e.contains("is odd"), "{e}");
    // the run says it too, and writes where it said
    let out = dir.join("run");
    let sets = [
        "time.max_steps=220",
        "checkpoint.every_steps=51",
        "checkpoint.keep=10",
    ];
    let o = hsph(&run_args(LOCAL, &out, &sets));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("checkpoint.every_steps = 51 is odd"));
    let mut cks: Vec<String> = fs::read_dir(out.join("checkpoints"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    cks.sort();
    assert_eq!(cks, ["step-0000000102", "step-0000000204", "step-0000000220"]);
}

/// Defect 15: `balance.weights` of another length than the ranks is refused wherever the
/// ranks are known, naming the key, its length, the ranks and why.
#[test]
fn class_15_rank_weights_have_one_entry_per_rank() {
    let dir = temp_dir("weights");
    let s = repo_path(SCENE).display().to_string();
    let o = hsph(&[
        "check",
        &s,
        "--ranks",
        "4",
        "--set",
        "balance.weights=[1.0, 2.0, 1.0]",
    ]);
    assert_input_error(
        &o,
        &["--set", "balance.weights", "3 entries", "4 ranks", "one per rank"],
    );
    let o = hsph(&["plan", &s, "--ranks", "3", "--set", "balance.weights=[1.0, 2.0]"]);
    assert_input_error(&o, &["balance.weights", "2 entries", "3 ranks"]);
    // jobscript takes no --set: the weights come from the file
    let file = dir.join("w.toml");
    fs::write(
        &file,
        fs::read_to_string(repo_path(SCENE)).unwrap() + "\n[balance]\nweights = [1.0, 2.0, 3.0]\n",
    )
    .unwrap();
    let f = file.to_str().unwrap();
    let o = hsph(&[
        "jobscript",
        f,
        "--nodes",
        "2",
        "--ranks-per-node",
        "2",
        "--time",
        "01:00:00",
    ]);
    assert_input_error(
        &o,
        &[
            &format!("{f}:"),
            "balance.weights",
            "3 entries",
            "4 ranks",
            "--nodes 2",
        ],
    );
    let out = dir.join("run");
    let o = hsph(&["run", f, "-q", "--ranks", "2", "--out", out.to_str().unwrap()]);
    assert_input_error(&o, &["balance.weights", "3 entries", "2 ranks"]);
    assert!(!out.exists());
    // one per rank passes
    let o = hsph(&["check", f, "--ranks", "3"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}
