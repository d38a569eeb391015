//! Local time stepping (`time.stepping = "local"`, issue 36, `docs/splitting.md` §8) on
//! `tests/data/drift_local_2d.toml`: a periodic drift with a 10 % swirl through an adaptive
//! region at its level's h, so that the channel's particles take one step of 2δ while the
//! region's take two of δ.

use crate::common;

use common::hsph;
use std::path::Path;

const SCENE: &str = "tests/data/drift_local_2d.toml";
const GLOBAL: &str = "time.stepping=\"global\"";

fn run(out: &Path, ranks: usize, threads: usize, sets: &[&str]) {
    let (code, _, err) = common::run_file(SCENE, out, (ranks, threads), sets);
    assert_eq!(code, 0, "{err}");
}

fn read(dir: &Path, f: &str) -> String {
    std::fs::read_to_string(dir.join(f)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(f).display()))
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&read(dir, "summary.json")).unwrap()
}

/// With local steps every step of the swirling drift is a cycle (the channel's particles
/// have twice the region's h and the flow is slow against c0): half as many cycles as steps,
/// Σm exact through every split and merge, Σmv within 1e-6 of itself (the classes' pairs break
/// Newton's third law at the middle of a cycle only; measured 3.4e-7, the global step keeps it
/// to round-off), the particles that never split within 0.4 % of the swirl's 0.05 m/s of the
/// global run's velocities (measured 4.1e-5 m/s), and the same bits on 1, 3 and 8 ranks and
/// 1–2 threads.
#[test]
fn local_steps_cycle_and_give_the_same_bits_on_any_layout() {
    let dir = common::temp_dir("multirate");
    let global = dir.join("global");
    run(&global, 1, 1, &[GLOBAL]);
    let base = dir.join("r1t1");
    run(&base, 1, 1, &[]);
    let (g, l) = (summary(&global), summary(&base));
    let steps = l["steps"].as_u64().unwrap();
    assert_eq!(l["stepping"], "local");
    assert_eq!(l["cycles"].as_u64().unwrap() * 2, steps, "every advance a cycle");
    assert!(g.get("cycles").is_none(), "a global run reports no cycles");
    assert!(l["splits"].as_u64().unwrap() > 0 && l["merges"].as_u64().unwrap() > 0);
    for m in common::series(&base, "mass") {
        assert_eq!(m, 80.0);
    }
    let px = common::series(&base, "momentum_x");
    for (k, p) in px.iter().enumerate() {
        assert!(
            (p / px[0] - 1.0).abs() < 1e-6,
            "row {k}: Σm vx = {p}, at t = 0 {}",
            px[0]
        );
    }
    // the particles that never split (lattice ids) are the same particles in both runs
    let bound = common::id_bound_2d(SCENE);
    let (tg, tl) = (common::table(&global), common::table(&base));
    let col = |name: &str| tg.0.iter().position(|h| h == name).unwrap();
    let (vx, vy) = (col("vx"), col("vy"));
    let mut worst: f64 = 0.0;
    let mut shared = 0;
    for (id, a) in tg.1.range(..bound) {
        if let Some(b) = tl.1.get(id) {
            worst = worst.max((a[vx] - b[vx]).hypot(a[vy] - b[vy]));
            shared += 1;
        }
    }
    assert!(shared > 900, "{shared} particles never split in both runs");
    assert!(worst < 2e-4, "velocities {worst} m/s from the global run's");
    common::assert_same_bits_on(SCENE, &dir, &base, &[], &[(3, 1), (8, 1), (3, 2)]);
}

/// A run checkpointed on 2 ranks at a cycle's end and continued on 3 gives the uninterrupted
/// bits and the uninterrupted run's count of cycles.
#[test]
fn a_restart_at_a_cycle_end_gives_the_uninterrupted_bits() {
    let dir = common::temp_dir("multirate-restart");
    let whole = dir.join("whole");
    run(&whole, 2, 1, &[]);
    let cut = dir.join("cut");
    run(&cut, 2, 1, &["time.max_steps=130", "checkpoint.every_steps=130"]);
    assert!(cut.join("checkpoints/step-0000000130").is_dir());
    let (code, _, err) = common::restart_to_end(&cut, 3);
    assert_eq!(code, 0, "{err}");
    for f in ["timeseries.csv", "final.csv"] {
        assert!(read(&cut, f) == read(&whole, f), "{f} differs after the restart");
    }
    assert_eq!(summary(&cut)["cycles"], summary(&whole)["cycles"]);
}

/// Local steps need particles of several h, the CFL step, no solid and the gather kernels:
/// otherwise exit 2 naming `time.stepping` and what to change.
#[test]
fn local_steps_where_they_cannot_apply_are_refused() {
    let no_level = "refine[0].smoothing_length=\"scene\"";
    for (sets, needle) in [
        (vec![no_level], "smoothing_length = \"level\""),
        (vec!["time.dt=1e-4"], "remove time.dt"),
        (
            vec!["performance.interactions=\"pairs\""],
            "interactions = \"gather\"",
        ),
        (vec!["time.stepping=\"locall\""], "`global` or `local`"),
    ] {
        let mut args = vec!["check", SCENE];
        for s in &sets {
            args.extend(["--set", s]);
        }
        let (code, _, err) = hsph(&args);
        assert_eq!(code, 2, "{sets:?}: {err}");
        assert!(
            err.contains("time.stepping") || err.contains("stepping"),
            "{sets:?}: {err}"
        );
        assert!(err.contains(needle), "{sets:?}: {err}");
    }
}
