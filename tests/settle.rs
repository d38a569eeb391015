//! The set-up's settling (`time.settle`): the scene's own steps before t = 0 with the velocities
//! damped, then zeroed. Facts: still water set up on a lattice oscillates (its bottom pressure
//! by about 2 % of ρ0 g H, its surface corner moving at 1.5 % of √(gH)); settled, it starts in
//! its discretisation's equilibrium and stays there; the settling gives the same bits on any
//! number of ranks and threads; a scene that is not at rest is refused with exit 2 naming the
//! key.

use crate::common;
use std::fs;
use std::path::{Path, PathBuf};

/// ρ0 g H of `hydrostatic_2d.toml` (Pa) and √(gH) (m/s).
const RHO_G_H: f64 = 1000.0 * 9.81 * 0.5;
fn sqrt_gh() -> f64 {
    (9.81f64 * 0.5).sqrt()
}

fn read(dir: &Path, name: &str) -> String {
    fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{}/{name}: {e}", dir.display()))
}

/// Column `col` of the CSV file `name` in `dir`.
fn column(dir: &Path, name: &str, col: &str) -> Vec<f64> {
    let text = read(dir, name);
    let mut lines = text.lines();
    let k = lines
        .next()
        .unwrap()
        .split(',')
        .position(|h| h == col)
        .unwrap_or_else(|| panic!("{name} has no column {col}"));
    lines
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect()
}

/// Run the binary on `scene` with `sets` on (ranks, threads); the run directory.
fn run(scene: &str, sets: &[&str], layout: (usize, usize), tag: &str) -> PathBuf {
    let out = common::temp_dir(tag).join("run");
    let (code, _, err) = common::run_file(scene, &out, layout, sets);
    assert_eq!(code, 0, "{tag}: {err}");
    out
}

/// The hydrostatic tank to 0.2 s, sampled every 10 ms, with and without 0.3 s of settling:
/// the spread of the bottom probe's pressure over ρ0 g H and the largest speed over √(gH).
#[test]
fn settled_still_water_starts_and_stays_at_rest() {
    let measure = |settle: &str| {
        let sets = [
            "time.t_end=0.2",
            "output.interval=0.01",
            "output.format=\"none\"",
            settle,
        ];
        let dir = run("inputs/hydrostatic_2d.toml", &sets, (1, 2), "settle-tank");
        let t = column(&dir, "timeseries.csv", "t");
        let ke = column(&dir, "timeseries.csv", "kinetic_energy");
        assert_eq!((t[0], ke[0]), (0.0, 0.0), "the run starts at t = 0, at rest");
        let p = column(&dir, "probes/p_bottom.csv", "p");
        let spread = p.iter().cloned().fold(f64::MIN, f64::max) - p.iter().cloned().fold(f64::MAX, f64::min);
        let speed = column(&dir, "timeseries.csv", "max_speed")
            .into_iter()
            .fold(0.0, f64::max);
        (spread / RHO_G_H, speed / sqrt_gh())
    };
    // measured: 2.2 % and 1.5 % from the lattice, 0.05 % and 0.33 % settled
    let (spread, speed) = measure("time.settle=0");
    assert!(
        spread > 0.01 && speed > 0.01,
        "the lattice's transient: spread {spread}, speed {speed}"
    );
    let (spread, speed) = measure("time.settle=0.3");
    assert!(
        spread < 0.003 && speed < 0.006,
        "settled: bottom pressure spread {spread} of ρ0gH, speed {speed} of √(gH)"
    );
}

/// The settling's steps are the run's steps: the same bits on 1 and 3 ranks and 2 threads,
/// with particles of one and of two sizes.
#[test]
fn settling_gives_the_same_bits_on_any_layout() {
    for (k, scene) in ["inputs/hydrostatic_2d.toml", "inputs/hydrostatic_2d_refined.toml"]
        .iter()
        .enumerate()
    {
        let sets = [
            "time.settle=0.05",
            "time.t_end=0.01",
            "output.format=\"none\"",
            "discretisation.relax=0",
        ];
        let base = run(scene, &sets, (1, 1), &format!("settle-bits{k}-r1"));
        let fin = read(&base, "final.csv");
        for layout in [(3, 1), (2, 2)] {
            let dir = run(scene, &sets, layout, &format!("settle-bits{k}-{layout:?}"));
            assert!(
                read(&dir, "final.csv") == fin
                    && read(&dir, "timeseries.csv") == read(&base, "timeseries.csv"),
                "{scene}: settling changed the bits on {layout:?} (ranks, threads)"
            );
        }
        let unsettled = run(scene, &sets[1..], (1, 1), &format!("settle-bits{k}-none"));
        assert!(
            read(&unsettled, "final.csv") != fin,
            "{scene}: the settling moved nothing"
        );
    }
}

/// Settling damps every velocity away, so a scene that moves is refused, naming the key and
/// the body; so is a negative span.
#[test]
fn settling_refuses_a_scene_that_moves() {
    let out = common::temp_dir("settle-bad").join("run");
    let out = out.to_str().unwrap();
    let cases: [(&str, &str, &[&str]); 3] = [
        (
            "inputs/dam_break_2d.toml",
            "time.settle=-1",
            &["time.settle", "settle = 0.3"],
        ),
        (
            "inputs/hydrostatic_2d.toml",
            "fluid[0].velocity=[0.1, 0.0]",
            &["time.settle", "fluid[0]", "velocity"],
        ),
        (
            "inputs/solitary_wave.toml",
            "time.t_end=0.1",
            &["time.settle", "wall[1]", "moves"],
        ),
    ];
    for (scene, set, needles) in cases {
        let (code, _, err) = common::hsph(&[
            "run",
            scene,
            "--out",
            out,
            "--set",
            "time.settle=0.2",
            "--set",
            set,
        ]);
        assert_eq!(code, 2, "{scene} {set}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        for n in needles {
            assert!(err.contains(n), "{scene} {set}: `{n}` missing from {err}");
        }
    }
}

/// `hsph check` builds the set-up without the settling (a run's work) and counts its steps.
#[test]
fn check_counts_the_settling_without_running_it() {
    let dir = common::temp_dir("settle-check");
    let text = fs::read_to_string(common::repo_path("inputs/hydrostatic_2d.toml"))
        .unwrap()
        .replace("t_end = 0.5", "t_end = 0.5\nsettle = 0.3");
    assert!(text.contains("settle = 0.3"));
    let scene = dir.join("settled.toml");
    fs::write(&scene, text).unwrap();
    let (code, out, err) = common::hsph(&["check", scene.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let line = out.lines().find(|l| l.starts_with("time")).unwrap_or_default();
    assert!(
        line.contains("settling 0.3 s before t = 0") && line.contains("steps more"),
        "{out}"
    );
}
