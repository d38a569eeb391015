//! Splitting of fluid particles that enter adaptive refinement regions (issue 36,
//! `docs/splitting.md`): a periodic box of water drifting through a region of level 1
//! (`tests/data/drift_split_2d.toml`).

use crate::common;

use common::hsph;
use std::collections::HashSet;
use std::path::{Path, PathBuf};

const SCENE: &str = "tests/data/drift_split_2d.toml";

fn run(out: &Path, ranks: usize, threads: usize, sets: &[&str]) {
    let (code, _, err) = common::run_file(SCENE, out, (ranks, threads), sets);
    assert_eq!(code, 0, "{err}");
}

fn read(dir: &Path, f: &str) -> String {
    std::fs::read_to_string(dir.join(f)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(f).display()))
}

/// (id, level, x, y, mass) of every particle in `final.csv`.
fn particles(dir: &Path) -> Vec<(u64, u16, f64, f64, f64)> {
    let text = read(dir, "final.csv");
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (id, level, x, y, m) = (col("id"), col("level"), col("x"), col("y"), col("mass"));
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[id].parse().unwrap(),
                f[level].parse().unwrap(),
                f[x].parse().unwrap(),
                f[y].parse().unwrap(),
                f[m].parse().unwrap(),
            )
        })
        .collect()
}

/// `splits` and `merges` of a run's `summary.json`, after checking its particle counts
/// against them: the end count is the start's plus 3 per split less 3 per merge, and the
/// largest is at least either.
fn resized(dir: &Path) -> (usize, usize) {
    let s: serde_json::Value = serde_json::from_str(&read(dir, "summary.json")).unwrap();
    let n = |k: &str| s[k].as_u64().unwrap_or_else(|| panic!("summary.json: no {k}")) as usize;
    let (splits, merges) = (n("splits"), n("merges"));
    let (start, end, most) = (n("particles_start"), n("particles"), n("particles_max"));
    assert_eq!(
        end + 3 * merges,
        start + 3 * splits,
        "summary.json: {start} → {end} particles"
    );
    assert!(most >= start.max(end), "summary.json: largest count {most}");
    // the mean over the steps lies between the fewest the splits and merges allow and the most
    let mean = s["particles_mean"]
        .as_f64()
        .expect("summary.json: no particles_mean");
    let fewest = start.min(end).saturating_sub(3 * merges) as f64;
    assert!(
        (fewest..=most as f64).contains(&mean),
        "summary.json: mean count {mean} outside {fewest}..={most}"
    );
    (splits, merges)
}

/// Particles split as they enter (4 children of a quarter of the mass, new ids above the
/// lattice's) and merge four by four one coarse spacing beyond the region (one particle of the
/// four's mass, a new id), mass and momentum stay what they were to round-off, no two
/// particles come closer than half the fine spacing, and the run gives the same bits on 1, 3
/// and 8 ranks and 1–2 threads.
#[test]
fn particles_split_and_merge_conserving_mass_and_momentum_on_any_layout() {
    let dir = common::temp_dir("split");
    let base: PathBuf = dir.join("r1t1");
    run(&base, 1, 1, &[]);
    let ps = particles(&base);
    let (splits, merges) = resized(&base);
    // by t = 0.06 s the water has moved 3 cm: the region's upstream columns split, and its
    // downstream fine columns have passed x = 0.31 (one coarse spacing beyond it) and merge
    assert!(splits > 0 && merges > 0, "{splits} splits, {merges} merges");
    // set-up: 700 coarse particles (40 × 20 lattice less the region's 10 × 10) and 400 fine
    let coarse = ps.iter().filter(|p| p.1 == 0).count();
    let fine = ps.iter().filter(|p| p.1 == 1).count();
    assert_eq!(coarse, 700 - splits + merges, "coarse particles");
    assert_eq!(fine, 400 + 4 * splits - 4 * merges, "fine particles");
    let ids: HashSet<u64> = ps.iter().map(|p| p.0).collect();
    assert_eq!(ids.len(), ps.len(), "ids unique");
    // new ids come from the counter, numbered from the lattice's bound: 4 per split, 1 per
    // merge; the merged particles (coarse, with a new id) are every merge's
    let bound = common::id_bound_2d(SCENE);
    let end = bound + (4 * splits + merges) as u64;
    assert!(ps.iter().all(|p| p.0 < end), "ids numbered from the bound");
    let merged = ps.iter().filter(|p| p.0 >= bound && p.1 == 0).count();
    assert_eq!(merged, merges, "merged particles");
    let children = ps.iter().filter(|p| p.0 >= bound && p.1 == 1).count();
    assert!(children <= 4 * splits, "{children} children of {splits} splits");
    for p in &ps {
        let want = if p.1 == 0 { 0.1 } else { 0.025 };
        assert_eq!(p.4, want, "particle {}: mass {}", p.0, p.4);
    }
    // Σm exactly (an exact sum of exact quarters), Σmv to round-off
    for m in common::series(&base, "mass") {
        assert_eq!(m, 80.0);
    }
    for (k, px) in common::series(&base, "momentum_x").iter().enumerate() {
        assert!((px / 40.0 - 1.0).abs() < 1e-13, "row {k}: Σm vx = {px}");
    }
    // no pair closer than half the fine spacing (periodic distances)
    let (lx, ly) = (0.4, 0.2);
    let mut closest = f64::INFINITY;
    for (a, p) in ps.iter().enumerate() {
        for q in &ps[a + 1..] {
            let dx = (p.2 - q.2).abs().min(lx - (p.2 - q.2).abs());
            let dy = (p.3 - q.3).abs().min(ly - (p.3 - q.3).abs());
            closest = closest.min(dx.hypot(dy));
        }
    }
    assert!(closest > 0.5 * 0.005, "closest pair {closest} m");
    common::assert_same_bits_on(SCENE, &dir, &base, &[], &[(3, 1), (8, 1), (3, 2)]);
}

/// With `smoothing_length = "level"` a particle of level 1 has the region's h where it is, at
/// every step's end: the fine h, 0.0065 m, at a depth of one support (0.026 m, the transition
/// band) or more, rising linearly to the scene's 0.013 m at the region's faces, and the scene's
/// outside the region (children that drifted out and wait to merge); level 0 keeps the scene's.
/// Mass stays exact and the bits are the same on 1 and 3 ranks.
#[test]
fn with_the_levels_h_particles_take_the_ramp_where_they_are() {
    let dir = common::temp_dir("split-level-h");
    let level = ["refine[0].smoothing_length=\"level\""];
    let one = dir.join("r1");
    run(&one, 1, 1, &level);
    let (splits, merges) = resized(&one);
    assert!(splits > 0 && merges > 0, "{splits} splits, {merges} merges");
    let text = read(&one, "final.csv");
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (id, lv, h, x, y) = (col("id"), col("level"), col("h"), col("x"), col("y"));
    let (h_scene, h_fine, band) = (0.013, 0.0065, 0.026);
    // the region [0.2, 0.3] x [0.05, 0.15]: its depth at (x, y), ≤ 0 outside
    let depth = |x: f64, y: f64| (x - 0.2).min(0.3 - x).min(y - 0.05).min(0.15 - y);
    let (mut ramped, mut outside) = (0, 0);
    for l in text.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let (i, lvl, hh): (u64, u16, f64) = (
            f[id].parse().unwrap(),
            f[lv].parse().unwrap(),
            f[h].parse().unwrap(),
        );
        let want = if lvl == 0 {
            h_scene
        } else {
            let d = depth(f[x].parse().unwrap(), f[y].parse().unwrap());
            if d <= 0.0 {
                outside += 1;
            } else if d < band {
                ramped += 1;
            }
            h_fine + (h_scene - h_fine) * (1.0 - d / band).clamp(0.0, 1.0)
        };
        assert!(
            (hh / want - 1.0).abs() < 1e-12,
            "particle {i} (level {lvl}): h = {hh}, the region's there {want}"
        );
    }
    assert!(
        ramped > 0 && outside > 0,
        "{ramped} fine particles in the band, {outside} outside"
    );
    for m in common::series(&one, "mass") {
        assert_eq!(m, 80.0);
    }
    let three = dir.join("r3");
    run(&three, 3, 1, &level);
    for f in ["timeseries.csv", "final.csv"] {
        assert!(read(&three, f) == read(&one, f), "{f} differs on 3 ranks");
    }
}

/// A run checkpointed on 2 ranks between splits and continued on 3 gives the uninterrupted
/// bits (the counter `next_id` travels in the checkpoint) and the uninterrupted run's counts
/// of splits, merges and particles in `summary.json`.
#[test]
fn a_restart_across_splits_gives_the_uninterrupted_bits() {
    let dir = common::temp_dir("split-restart");
    let whole = dir.join("whole");
    run(&whole, 2, 1, &[]);
    let cut = dir.join("cut");
    run(&cut, 2, 1, &["time.max_steps=130", "checkpoint.every_steps=130"]);
    let m: serde_json::Value =
        serde_json::from_str(&read(&cut.join("checkpoints/step-0000000130"), "manifest.json")).unwrap();
    let bound = common::id_bound_2d(SCENE);
    assert!(
        m["next_id"].as_u64().unwrap() > bound,
        "no split before the checkpoint"
    );
    let (code, _, err) = common::restart_to_end(&cut, 3);
    assert_eq!(code, 0, "{err}");
    for f in ["timeseries.csv", "final.csv"] {
        assert!(read(&cut, f) == read(&whole, f), "{f} differs after the restart");
    }
    // the summary counts the whole run, not the last segment
    let summary = |d: &Path| -> serde_json::Value { serde_json::from_str(&read(d, "summary.json")).unwrap() };
    let (a, b) = (summary(&cut), summary(&whole));
    for k in [
        "splits",
        "merges",
        "particles_start",
        "particles_max",
        "particles",
    ] {
        assert_eq!(a[k], b[k], "summary.json `{k}` after the restart");
    }
    assert_eq!(resized(&cut), resized(&whole));
}

/// `adapt` needs a region that refines a fluid and a kernel support that holds a merge's cell
/// (√D·dx): otherwise exit 2 naming the key.
#[test]
fn adapt_without_a_fluid_or_with_a_short_support_is_refused() {
    for (scene, set, needle) in [
        (DRIFT, "refine[0].bodies=[\"bottom\"]", "refine[0].adapt"),
        (DRIFT, "refine[0].bodies=[\"bottom\"]", "refines no fluid"),
        // a misspelt name is named as such, not as a region without fluid
        (SCENE, "refine[0].bodies=[\"watr\"]", "refine[0].bodies[0]"),
        (
            SCENE,
            "refine[0].bodies=[\"watr\"]",
            "no fluid, solid or dummy wall is named `watr`",
        ),
        (
            SCENE,
            "discretisation.h_over_dx=0.6",
            "h_over_dx to at least 0.707",
        ),
    ] {
        let (code, _, err) = hsph(&["check", scene, "--set", set]);
        assert_eq!(code, 2, "{set}: {err}");
        assert!(err.contains("refine[0]") && err.contains(needle), "{set}: {err}");
    }
}

const DRIFT: &str = "inputs/hydrostatic_2d_drift_adaptive.toml";

/// Still water drifting at U = 0.1 m/s through an adaptive box (issue 36's acceptance, the
/// scene's header): over 1 s, at every output, no fluid particle deviates from the drift by
/// 1 % of √(gH) (measured 0.0208 of 0.0221 m/s; 0.0032 with the box's particles keeping
/// their size); the mass stays what it was through every split and merge; no two fluid
/// particles end closer than half the fine spacing.
#[test]
fn still_water_drifting_through_an_adaptive_box_stays_still() {
    let out = common::temp_dir("drift-still").join("run");
    let (code, _, err) = common::run_file(DRIFT, &out, (2, 1), &["output.format=\"vtk\""]);
    assert_eq!(code, 0, "{err}");
    let (splits, merges) = resized(&out);
    assert!(splits > 50 && merges > 50, "{splits} splits, {merges} merges");
    let limit = 0.01 * (9.81f64 * 0.5).sqrt();
    let mut snaps: Vec<PathBuf> = std::fs::read_dir(out.join("snapshots"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    snaps.sort();
    assert_eq!(snaps.len(), 21, "outputs every 0.05 s");
    let mut worst: f64 = 0.0;
    for snap in &snaps {
        for piece in std::fs::read_dir(snap).unwrap() {
            let text = std::fs::read_to_string(piece.unwrap().path()).unwrap();
            let v = common::vtu_array(&text, "velocity");
            let kind = common::vtu_array(&text, "kind");
            for (k, c) in kind.iter().zip(v.chunks(3)) {
                if k == "0" {
                    let (vx, vy): (f64, f64) = (c[0].parse().unwrap(), c[1].parse().unwrap());
                    worst = worst.max((vx - 0.1).hypot(vy));
                }
            }
        }
    }
    assert!(
        worst < limit,
        "largest deviation from the drift {worst} m/s (limit {limit})"
    );
    let mass = common::series(&out, "mass");
    for (k, m) in mass.iter().enumerate() {
        assert!(
            (m / mass[0] - 1.0).abs() < 1e-14,
            "row {k}: Σm = {m}, at t = 0 {}",
            mass[0]
        );
    }
    let fluid: Vec<(f64, f64)> = particles_of_kind(&out, "0");
    let mut closest = f64::INFINITY;
    for (a, p) in fluid.iter().enumerate() {
        for q in &fluid[a + 1..] {
            let dx = (p.0 - q.0).abs().min(1.0 - (p.0 - q.0).abs());
            closest = closest.min(dx.hypot(p.1 - q.1));
        }
    }
    assert!(closest > 0.5 * 0.01, "closest pair {closest} m");
}

/// (x, y) of the particles of kind `kind` in `final.csv`.
fn particles_of_kind(dir: &Path, kind: &str) -> Vec<(f64, f64)> {
    let text = read(dir, "final.csv");
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (k, x, y) = (col("kind"), col("x"), col("y"));
    text.lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[k] == kind)
        .map(|f| (f[x].parse().unwrap(), f[y].parse().unwrap()))
        .collect()
}

/// A gauge half a fine spacing in front of a refined side wall reads the still water, not the
/// wall: columns are taken within half of each wall particle's own spacing (a window of the
/// scene's spacing took the 1 cm wall column beside it, 0.7 m high, for the bed and read 0).
#[test]
fn a_gauge_beside_a_refined_wall_reads_the_still_water() {
    let out = common::temp_dir("gauge-refined").join("run");
    let scene = "inputs/solitary_wave_adaptive.toml";
    let (code, _, err) = common::run_file(scene, &out, (1, 1), &["time.t_end=0.005"]);
    assert_eq!(code, 0, "{err}");
    let first = common::probe_values(&out, "wall")[0];
    assert!(
        (first - 0.24).abs() < 1e-3,
        "the wall gauge reads {first} m at t = 0"
    );
}
