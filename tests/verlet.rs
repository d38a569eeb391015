//! Verlet lists (`performance.neighbours = "verlet"`, issue 33): lists built with the ghosts to
//! the support + skin and kept until the next build. Facts: the same bits on any number of
//! ranks and threads (builds fall on the same steps, decided on the particles' motion), the
//! results of lists built every step to round-off (only the order of the sums differs), far
//! fewer builds than steps, a restart continues the uninterrupted bits, and the mode's bad
//! input is exit 2 naming the key.

use crate::common;
use std::fs;
use std::path::{Path, PathBuf};

/// Run the binary on `scene` with `sets` on (ranks, threads): the run directory and its
/// summary. (A process of its own was once needed because the signal test's injected stop sat in
/// the test process's signal flag; the injected stop is now the run's own.)
fn run(
    scene: &str,
    sets: &[String],
    (ranks, threads): (usize, usize),
    tag: &str,
) -> (PathBuf, serde_json::Value) {
    let out = common::temp_dir(tag).join("run");
    let sets: Vec<&str> = sets.iter().map(String::as_str).collect();
    let (code, _, err) = common::run_file(scene, &out, (ranks, threads), &sets);
    assert_eq!(code, 0, "{tag}: {err}");
    let summary: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["complete"], true, "{tag}");
    (out, summary)
}

fn read(dir: &Path, name: &str) -> String {
    fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{}/{name}: {e}", dir.display()))
}

/// Each case: fluids in gather and pair mode, a periodic channel with shifting and the
/// renormalised viscous operator (particles wrap), mirror walls, the 3D dam break in pair
/// mode, an elastic solid, and a refined tank (particles of two masses, the scene's h). With
/// Verlet lists every layout gives the bits of one rank and one thread, builds far fewer times
/// than it steps, and ends within round-off of lists built every step.
#[test]
fn verlet_lists_give_the_same_bits_on_any_layout_and_the_fresh_lists_results() {
    let cases: [(&str, &[&str]); 7] = [
        ("inputs/dam_break_2d.toml", &["time.t_end=0.05"]),
        (
            "inputs/dam_break_2d.toml",
            &["time.t_end=0.05", "performance.interactions=\"pairs\""],
        ),
        (
            "inputs/poiseuille_2d.toml",
            &[
                "time.t_end=0.04",
                "reference.times=[0.04]",
                "physics.viscous_operator=\"renormalised\"",
                "physics.shifting=\"delta_plus\"",
            ],
        ),
        (
            "inputs/couette_2d_mirror.toml",
            &["time.t_end=0.04", "reference.times=[0.04]"],
        ),
        (
            "tests/data/dam_break_3d_small.toml",
            &["time.t_end=0.03", "performance.interactions=\"pairs\""],
        ),
        ("inputs/oscillating_plate.toml", &["time.t_end=0.02"]),
        ("inputs/hydrostatic_2d_refined.toml", &["time.t_end=0.04"]),
    ];
    for (k, (path, sets)) in cases.iter().enumerate() {
        let with = |mode: &str| {
            let mut s: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            s.push("output.format=\"none\"".into());
            s.push(format!("performance.neighbours=\"{mode}\""));
            s
        };
        let verlet = with("verlet");
        let (base, s0) = run(path, &verlet, (1, 1), &format!("vl{k}-r1"));
        let steps = s0["steps"].as_u64().unwrap();
        let builds = s0["ghost_builds"].as_u64().unwrap();
        assert!(
            builds < steps / 4,
            "{path} {sets:?}: {builds} builds in {steps} steps with Verlet lists"
        );
        let (ts, fin) = (read(&base, "timeseries.csv"), read(&base, "final.csv"));
        for layout in [(3, 1), (8, 1), (2, 2)] {
            if layout == (2, 2) && k > 1 {
                continue;
            }
            let (dir, s) = run(
                path,
                &verlet,
                layout,
                &format!("vl{k}-r{}t{}", layout.0, layout.1),
            );
            assert!(
                read(&dir, "timeseries.csv") == ts && read(&dir, "final.csv") == fin,
                "{path} {sets:?}: Verlet lists changed the bits on {layout:?} (ranks, threads)"
            );
            assert_eq!(
                s["ghost_builds"], s0["ghost_builds"],
                "{path}: builds on {layout:?}"
            );
        }
        // lists built every step: the same pairs, summed in another order
        let (fresh, _) = run(path, &with("lists"), (1, 1), &format!("vl{k}-lists"));
        let (dx, drho) = common::position_and_density_gap(&base, &fresh);
        assert!(
            dx < 1e-9 && drho < 1e-5,
            "{path} {sets:?}: Verlet lists end {dx:e} m and {drho:e} kg/m³ from fresh lists"
        );
    }
}

/// A run checkpointed between two builds on 2 ranks and continued on 3 writes the bytes of the
/// run never interrupted: the checkpoint holds the positions of the last build, and the restart
/// lists the pairs from them (without them it would build at its first step, in another order
/// of the sums).
#[test]
fn a_restart_between_builds_continues_the_uninterrupted_bits() {
    let dir = common::temp_dir("verlet-restart");
    let sets = [
        "time.t_end=0.05",
        "performance.interactions=\"pairs\"",
        "performance.neighbours=\"verlet\"",
        "output.interval=0.01",
    ];
    let (reference, cut, ck) = common::reference_and_cut(&dir, "inputs/dam_break_2d.toml", &sets, 90);
    let manifest = read(&ck, "manifest.json");
    assert!(manifest.contains("\"build_positions\": true"), "{manifest}");
    let summary: serde_json::Value = serde_json::from_str(&read(&cut, "summary.json")).unwrap();
    let builds = summary["ghost_builds"].as_u64().unwrap();
    assert!(
        builds < 30,
        "{builds} builds in 90 steps: the checkpoint is not between builds"
    );
    let (code, _, err) = common::restart_to_end(&ck, 3);
    assert_eq!(code, 0, "{err}");
    common::assert_same_files(
        &reference,
        &cut,
        &["timeseries.csv", "final.csv", "probes/front.csv"],
    );
}

/// Verlet lists without a skin, or with a region that gives its particles the level's h, are
/// refused with exit 2 naming the key and what to use instead.
#[test]
fn verlet_lists_refuse_no_skin_and_the_levels_h() {
    let out = common::temp_dir("verlet-bad").join("run");
    let out = out.to_str().unwrap();
    let (code, _, err) = common::hsph(&[
        "run",
        "inputs/dam_break_2d.toml",
        "--out",
        out,
        "--neighbours",
        "verlet",
        "--set",
        "performance.skin=0",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("performance.skin") && err.contains("skin = 0.1"),
        "{err}"
    );
    let (code, _, err) = common::hsph(&[
        "run",
        "inputs/hydrostatic_2d_refined.toml",
        "--out",
        out,
        "--neighbours",
        "verlet",
        "--set",
        "refine.0.smoothing_length=\"level\"",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("performance.neighbours") && err.contains("smoothing_length = \"scene\""),
        "{err}"
    );
    assert!(!Path::new(out).exists(), "a refused run writes nothing");
}
