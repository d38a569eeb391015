//! Running the `hsph` binary and reading its refusals, for the tests of bad input.

use std::path::Path;
use std::process::{Command, Output};

/// Run `hsph ARGS` in `cwd` and keep its whole output.
/// `hsph ARGS` run from the crate root.
pub fn hsph_out(args: &[&str]) -> Output {
    hsph_in(&super::repo_path(""), args)
}

pub fn hsph_in(cwd: &Path, args: &[&str]) -> Output {
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
