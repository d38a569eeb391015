//! MPI back end under a real launcher: spawns `mpirun` on the built example
//! `examples/comm_selftest.rs` (MPI can be initialised only once per process, so never inside
//! a test itself). Compiled only with `--features mpi`; needs `mpirun` (apt: openmpi-bin).
//!
//! Build the example with the same profile and features first:
//! `cargo build --release --features mpi --examples && cargo test --release --features mpi
//! --test comm_mpi` (a plain `cargo test --release --features mpi` builds examples too, but
//! `--test NAME` alone does not, and a build without the feature overwrites the binary). A generous timeout turns a hang into a failure; there
//! is no timing assertion.
#![cfg(feature = "mpi")]

use std::path::PathBuf;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The example binary of the same profile as this test (target/<profile>/examples/).
fn selftest_exe() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    let profile_dir = exe
        .parent()
        .and_then(|deps| deps.parent())
        .expect("target/<profile>/deps/<test>");
    let p = profile_dir.join("examples").join("comm_selftest");
    assert!(
        p.exists(),
        "{} missing: build it first with `cargo build --release --features mpi --examples` \
         (`cargo test --test comm_mpi` alone does not build examples)",
        p.display()
    );
    p
}

/// Run `cmd`, killing it and failing if it takes more than `secs` seconds.
fn run_with_timeout(mut cmd: Command, secs: u64) -> Output {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot start mpirun: install openmpi-bin (see .ci/mpi-notes.md)");
    let t0 = Instant::now();
    loop {
        if child.try_wait().expect("wait for mpirun").is_some() {
            return child.wait_with_output().expect("mpirun output");
        }
        if t0.elapsed() > Duration::from_secs(secs) {
            let _ = child.kill();
            let out = child.wait_with_output().expect("mpirun output");
            panic!(
                "hang: no exit within {secs} s\nstdout:\n{}\nstderr:\n{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn mpirun(np: usize, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new("mpirun");
    cmd.args(["--allow-run-as-root", "--oversubscribe", "--bind-to", "none"])
        .args(["-np", &np.to_string()]);
    for (k, v) in env {
        cmd.args(["-x", &format!("{k}={v}")]);
    }
    cmd.arg(selftest_exe()).args(args);
    run_with_timeout(cmd, 180)
}

fn text(out: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn selftest_passes_under_mpirun_on_1_2_3_4_and_8_ranks() {
    for np in [1, 2, 3, 4, 8] {
        let out = mpirun(np, &[], &[]);
        let (so, se) = text(&out);
        assert!(out.status.success(), "np {np}: {so}\n{se}");
        assert!(
            so.contains(&format!("comm selftest ok: backend mpi, {np} ranks")),
            "np {np}: {so}\n{se}"
        );
    }
}

#[test]
fn selftest_passes_with_the_funneled_fallback() {
    let out = mpirun(4, &[], &[("HSPH_MPI_THREADING", "funneled")]);
    let (so, se) = text(&out);
    assert!(out.status.success(), "{so}\n{se}");
    assert!(so.contains("4 ranks, thread multiple false"), "{so}\n{se}");
}

#[test]
fn a_failing_rank_stops_the_mpi_run_with_a_message_naming_it() {
    let out = mpirun(4, &["--fail-rank", "2"], &[]);
    let (so, se) = text(&out);
    assert!(!out.status.success(), "{so}\n{se}");
    assert!(se.contains("rank 2 failed: injected failure"), "{so}\n{se}");
}

#[test]
fn same_selftest_passes_on_the_local_back_end() {
    for (ranks, threads) in [("4", "2"), ("8", "1")] {
        let mut cmd = Command::new(selftest_exe());
        cmd.args(["--backend", "local", "--ranks", ranks, "--threads", threads]);
        let out = run_with_timeout(cmd, 120);
        let (so, se) = text(&out);
        assert!(out.status.success(), "{so}\n{se}");
        assert!(so.contains("backend local"), "{so}");
    }
    let mut cmd = Command::new(selftest_exe());
    cmd.args(["--backend", "local", "--ranks", "4", "--fail-rank", "3"]);
    let out = run_with_timeout(cmd, 120);
    let (_, se) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{se}");
    assert!(se.contains("rank 3 failed: injected failure"), "{se}");
}
