//! Running the `hsph` binary and reading its refusals, for the tests of bad input.

use std::ffi::OsStr;
use std::path::Path;
use std::process::{Command, Output};

/// `hsph ARGS` run from the crate root, its whole output kept.
pub fn hsph_out<S: AsRef<OsStr>>(args: &[S]) -> Output {
    hsph_in(&super::repo_path(""), args)
}

/// The arguments of a quiet one-thread run of `scene` into `out`, with `--set S` for each of
/// `sets`: `run SCENE -q --threads 1 --out OUT --set S…` (append more flags to the vector).
pub fn run_args(scene: &str, out: &Path, sets: &[&str]) -> Vec<String> {
    let mut a: Vec<String> = ["run", scene, "-q", "--threads", "1", "--out"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    a.push(out.to_str().unwrap().to_string());
    for s in sets {
        a.extend(["--set".to_string(), s.to_string()]);
    }
    a
}

/// Run `hsph ARGS` in `cwd` and keep its whole output.
pub fn hsph_in<S: AsRef<OsStr>>(cwd: &Path, args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the hsph binary runs")
}

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit 2, no panic, every needle in the message.
pub fn assert_input_error(o: &Output, needles: &[&str]) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    for n in needles {
        assert!(e.contains(n), "`{n}` missing from:\n{e}");
    }
}

/// `hsph check SCENE --set S…` (run in `cwd`) is exit 2 with every needle in its message.
pub fn assert_check_refuses(cwd: &Path, scene: &Path, sets: &[&str], needles: &[&str]) {
    let mut args = vec!["check", scene.to_str().unwrap()];
    for x in sets {
        args.extend(["--set", x]);
    }
    assert_input_error(&hsph_in(cwd, &args), needles);
}
