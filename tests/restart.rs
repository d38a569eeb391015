//! Checkpoints and restart (issue 10): a run checkpointed on P ranks and continued on Q ranks
//! writes the same bytes as a run never interrupted; a checkpoint torn by a crash is skipped; a
//! damaged part or a change to the physics is refused with exit 2.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

const SCENE: &str = "inputs/dam_break_2d.toml";
/// Files a continued run must reproduce byte for byte (`diagnostics.csv` and `traffic.csv`
/// hold timers and layout-dependent traffic).
const SAME: &[&str] = &[
    "timeseries.csv",
    "final.csv",
    "probes/front.csv",
    "probes/p_right_wall.csv",
    "probes/p_right_wall.raw.csv",
    "probes/tank.csv",
    "snapshots/series.pvd",
];

fn hsph_env(args: &[&str], env: &[(&str, &str)]) -> (i32, String) {
    let mut c = Command::new(env!("CARGO_BIN_EXE_hsph"));
    c.args(args).current_dir(common::repo_path(""));
    for (k, v) in env {
        c.env(k, v);
    }
    let o = c.output().unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// `hsph run SCENE` to t = 0.05 s (about 170 steps, rebalance checks every 20) on `ranks`.
fn run(out: &Path, ranks: &str, extra: &[&str], env: &[(&str, &str)]) -> (i32, String) {
    let mut args = vec![
        "run",
        SCENE,
        "-q",
        "--out",
        out.to_str().unwrap(),
        "--ranks",
        ranks,
        "--set",
        "time.t_end=0.05",
        "--set",
        "output.interval=0.01",
    ];
    args.extend(extra);
    hsph_env(&args, env)
}

fn restart(from: &Path, ranks: &str, extra: &[&str]) -> (i32, String) {
    let mut args = vec!["run", "--restart", from.to_str().unwrap(), "-q", "--ranks", ranks];
    args.extend(extra);
    hsph_env(&args, &[])
}

/// A 2-rank run to step 20 with a checkpoint there: (temp dir, run dir, checkpoint dir).
fn checkpointed_at_20(tag: &str) -> (PathBuf, PathBuf, PathBuf) {
    let dir = common::temp_dir(tag);
    let out = dir.join("run");
    let (code, err) = run(
        &out,
        "2",
        &["--set", "time.max_steps=20", "--set", "checkpoint.every_steps=20"],
        &[],
    );
    assert_eq!(code, 0, "{err}");
    let ck = out.join("checkpoints/step-0000000020");
    (dir, out, ck)
}

fn reference() -> PathBuf {
    let out = common::temp_dir("restart-ref").join("run");
    let (code, err) = run(&out, "1", &[], &[]);
    assert_eq!(code, 0, "{err}");
    out
}

fn assert_same(a: &Path, b: &Path, what: &str) {
    // every snapshot directory holds exactly the pieces its index lists: a restart on fewer
    // ranks leaves no stale piece of the interrupted run behind
    let snaps = b.join("snapshots");
    for e in std::fs::read_dir(&snaps).unwrap() {
        let path = e.unwrap().path();
        if path.extension().is_some_and(|x| x == "pvtu") {
            let index = std::fs::read_to_string(&path).unwrap();
            let listed = index.matches("<Piece ").count();
            let on_disk = std::fs::read_dir(path.with_extension("")).unwrap().count();
            assert_eq!(listed, on_disk, "{what}: {}", path.display());
        }
    }
    for f in SAME {
        let read =
            |d: &Path| std::fs::read(d.join(f)).unwrap_or_else(|e| panic!("{}: {e}", d.join(f).display()));
        assert!(
            read(a) == read(b),
            "{what}: {f} differs from the uninterrupted run"
        );
    }
}

/// P → Q restarts at steps inside a rebalance interval (checks every 20 steps): 1 → 3 stopped by
/// a signal at step 37, 4 → 2 and 3 → 7 from a checkpoint every 30 steps at the end of a
/// first leg cut by `time.max_steps`.
#[test]
fn a_run_continued_on_another_rank_count_has_the_same_bits() {
    let reference = reference();
    let dir = common::temp_dir("restart");
    // 1 → 3: SIGTERM at step 37 (the stop contract writes a checkpoint, exit 3)
    let a = dir.join("a");
    let (code, err) = run(&a, "1", &[], &[("HSPH_TEST_FAULT", "0:37:signal")]);
    assert_eq!(code, 3, "{err}");
    assert!(
        a.join("checkpoints/step-0000000037/manifest.json").is_file(),
        "{err}"
    );
    let (code, err) = restart(&a, "3", &[]);
    assert_eq!(code, 0, "{err}");
    assert_same(&reference, &a, "1 → 3 after a signal");
    // the summary counts both segments' wall time
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["segments"], 2);
    assert!(summary["wall_s_all_segments"].as_f64().unwrap() > summary["wall_s"].as_f64().unwrap());
    // 4 → 2 and 3 → 7: a first leg to step 45 checkpointing every 30 steps (and at its end)
    for (p, q) in [("4", "2"), ("3", "7")] {
        let b = dir.join(format!("b{p}{q}"));
        let (code, err) = run(
            &b,
            p,
            &["--set", "time.max_steps=45", "--set", "checkpoint.every_steps=30"],
            &[],
        );
        assert_eq!(code, 0, "{err}");
        let (code, err) = restart(&b, q, &["--set", "time.max_steps=0"]);
        assert_eq!(code, 0, "{err}");
        assert_same(&reference, &b, &format!("{p} → {q}"));
    }
}

/// A wall on a motion law (a paddle oscillating in the tank, x(t) = x0 + A sin 2πt/T) continues
/// from where it was: checkpointed on 2 ranks at step 125, continued on 3.
#[test]
fn a_moving_wall_restarts_where_it_was() {
    let dir = common::temp_dir("restart-paddle");
    let text = std::fs::read_to_string(common::repo_path(SCENE)).unwrap()
        + "\n[[wall]]\nname = \"paddle\"\nshape = \"block\"\nmin = [0.45, 0.0]\nmax = [0.468, 0.12]\n\
           method = \"dummy\"\nmotion = { law = \"sine\", amplitude = [0.01, 0.0], period = 0.04 }\n";
    let scene = dir.join("paddle.toml");
    std::fs::write(&scene, text).unwrap();
    let go = |out: &str, extra: &[&str]| {
        let out = dir.join(out);
        let mut a = vec![
            "run",
            scene.to_str().unwrap(),
            "-q",
            "--out",
            out.to_str().unwrap(),
        ];
        a.extend(["--set", "time.t_end=0.03", "--set", "output.interval=0.01"]);
        a.extend(extra);
        let (code, err) = hsph_env(&a, &[]);
        assert_eq!(code, 0, "{err}");
    };
    go("ref", &[]);
    go(
        "cut",
        &[
            "--set",
            "checkpoint.every_steps=125",
            "--set",
            "checkpoint.keep=10",
            "--ranks",
            "2",
        ],
    );
    // the newest checkpoint is the one at the end: take the first explicitly
    let first = std::fs::read_dir(dir.join("cut/checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .min()
        .unwrap();
    assert!(first.ends_with("step-0000000125"), "{}", first.display());
    let (code, err) = restart(&first, "3", &[]);
    assert_eq!(code, 0, "{err}");
    assert_same(&dir.join("ref"), &dir.join("cut"), "paddle 2 → 3");
}

/// Dynamic walls carry their integrated density in the checkpoint: checkpointed on 2 ranks at
/// step 60, continued on 3, the run writes the uninterrupted run's bytes.
#[test]
fn dynamic_walls_restart_with_their_density() {
    let dir = common::temp_dir("restart-dynamic");
    let dynamic = [
        "--set",
        "wall[0].method=\"dynamic\"",
        "--set",
        "wall[0].slip=\"no_slip\"",
    ];
    let reference = dir.join("ref");
    let (code, err) = run(&reference, "1", &dynamic, &[]);
    assert_eq!(code, 0, "{err}");
    let cut = dir.join("cut");
    let mut first_leg = dynamic.to_vec();
    first_leg.extend(["--set", "time.max_steps=60", "--set", "checkpoint.every_steps=60"]);
    let (code, err) = run(&cut, "2", &first_leg, &[]);
    assert_eq!(code, 0, "{err}");
    let (code, err) = restart(&cut, "3", &["--set", "time.max_steps=0"]);
    assert_eq!(code, 0, "{err}");
    assert_same(&reference, &cut, "dynamic walls 2 → 3");
}

/// kill -9 while a checkpoint is written (after the parts, before the manifest): the torn
/// checkpoint is skipped and the run continues from the previous one with the same bits.
#[test]
fn a_checkpoint_torn_by_a_crash_is_skipped() {
    let reference = reference();
    let out = common::temp_dir("restart-torn").join("run");
    let (code, _) = run(
        &out,
        "2",
        &["--set", "checkpoint.every_steps=30"],
        &[("HSPH_TEST_ABORT_IN_CHECKPOINT", "60")],
    );
    assert_ne!(code, 0);
    assert!(out.join("checkpoints/step-0000000060/part-00000.bin").is_file());
    assert!(!out.join("checkpoints/step-0000000060/manifest.json").exists());
    let (code, err) = restart(&out, "1", &[]);
    assert_eq!(code, 0, "{err}");
    assert_same(&reference, &out, "after a torn checkpoint");
}

/// A flipped byte and a truncated part each give exit 2 naming the part; so does a change to
/// the physics, naming the key; a later t_end is accepted.
#[test]
fn damaged_checkpoints_and_physics_changes_are_refused() {
    let (dir, out, ck) = checkpointed_at_20("restart-bad");
    let part = ck.join("part-00001.bin");
    let good = std::fs::read(&part).unwrap();
    let (code, err) = restart(&out, "1", &["--set", "physics.artificial_viscosity=0.1"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("physics.artificial_viscosity") && err.contains("start a new run"),
        "{err}"
    );
    // the run is complete at step 20: a restart with steps to run reads the checkpoint
    let more = ["--set", "time.max_steps=40"];
    let mut flipped = good.clone();
    flipped[good.len() / 2] ^= 0x10;
    std::fs::write(&part, &flipped).unwrap();
    let (code, err) = restart(&out, "1", &more);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("part-00001.bin") && err.contains("corrupt"), "{err}");
    std::fs::write(&part, &good[..good.len() - 8]).unwrap();
    let (code, err) = restart(&ck, "1", &more);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("part-00001.bin") && err.contains("truncated"),
        "{err}"
    );
    std::fs::write(&part, &good).unwrap();
    let (code, err) = restart(
        &out,
        "1",
        &["--set", "time.t_end=0.06", "--set", "time.max_steps=0"],
    );
    assert_eq!(code, 0, "{err}");
    let (code, err) = restart(&dir.join("nowhere"), "1", &[]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("no such checkpoint"), "{err}");
}

/// `--max-wall`: a limit already reached after the first step stops the run there with a
/// checkpoint and exit 3 (the signal contract), and the run continues to the same bits.
#[test]
fn a_wall_clock_limit_stops_with_a_checkpoint() {
    let reference = reference();
    let out = common::temp_dir("restart-wall").join("run");
    let (code, err) = run(&out, "2", &["--max-wall", "0.001"], &[]);
    assert_eq!(code, 3, "{err}");
    assert!(err.contains("stopped by max-wall after step 1 "), "{err}");
    assert!(out.join("checkpoints/step-0000000001/manifest.json").is_file());
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(
        summary.contains("\"complete\": false") && summary.contains("\"stopped_by\": \"max-wall\""),
        "{summary}"
    );
    let (code, err) = restart(&out, "1", &[]);
    assert_eq!(code, 0, "{err}");
    assert_same(&reference, &out, "after --max-wall");
}

/// The id counter of created particles (issue 36, `hsph::ids`): a checkpoint records it (the
/// lattice's id bound while nothing is created); a manifest without it (hsph before the
/// counter) restarts to the same bits; a counter below the lattice's ids, below an id the
/// parts hold or above the id limit is refused with exit 2 naming the manifest.
#[test]
fn the_id_counter_is_checkpointed_and_checked() {
    let (_, out, ck) = checkpointed_at_20("restart-ids");
    let path = ck.join("manifest.json");
    let good = std::fs::read_to_string(&path).unwrap();
    let m: hsph::checkpoint::Manifest = serde_json::from_str(&good).unwrap();
    let bound = common::id_bound_2d(SCENE);
    assert_eq!(m.next_id, Some(bound));
    let (p, _, _) = hsph::checkpoint::particles::<2>(&ck, &m).unwrap();
    let largest = *p.id.iter().max().unwrap();
    assert!(largest + 1 < bound, "the lattice has sites beyond the bodies");
    // the continued runs write no checkpoint: the one read stays as it is
    let to_end = ["--set", "time.max_steps=40", "--set", "checkpoint.every_steps=0"];
    let (code, err) = restart(&ck, "1", &to_end);
    assert_eq!(code, 0, "{err}");
    let reference = std::fs::read(out.join("final.csv")).unwrap();
    let with = |next: Option<u64>| {
        let mut v: serde_json::Value = serde_json::from_str(&good).unwrap();
        match next {
            Some(n) => v["next_id"] = n.into(),
            None => drop(v.as_object_mut().unwrap().remove("next_id")),
        }
        std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    };
    with(None);
    let (code, err) = restart(&ck, "1", &to_end);
    assert_eq!(code, 0, "{err}");
    assert!(std::fs::read(out.join("final.csv")).unwrap() == reference);
    for (next, needle) in [
        (largest, "below the scene's lattice ids"),
        (largest + 1, "below the scene's lattice ids"),
        (1 << 60, "above the id limit 2^54"),
    ] {
        with(Some(next));
        let (code, err) = restart(&ck, "1", &to_end);
        assert_eq!(code, 2, "next_id = {next}: {err}");
        assert!(err.contains("manifest.json") && err.contains(needle), "{err}");
    }
}
