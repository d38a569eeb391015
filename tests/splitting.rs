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

/// A column of `timeseries.csv`.
fn series(dir: &Path, name: &str) -> Vec<f64> {
    let text = read(dir, "timeseries.csv");
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let k = head.iter().position(|h| *h == name).unwrap();
    text.lines()
        .skip(1)
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect()
}

/// Particles split as they enter (4 children of a quarter of the mass, new ids above the
/// lattice's), mass and momentum stay what they were to round-off, no two particles come
/// closer than half the fine spacing, and the run gives the same bits on 1, 3 and 8 ranks and
/// 1–2 threads.
#[test]
fn entering_particles_split_conserving_mass_and_momentum_on_any_layout() {
    let dir = common::temp_dir("split");
    let base: PathBuf = dir.join("r1t1");
    run(&base, 1, 1, &[]);
    let ps = particles(&base);
    // set-up: 700 coarse particles (40 × 20 lattice less the region's 10 × 10) and 400 fine
    let coarse = ps.iter().filter(|p| p.1 == 0).count();
    let fine = ps.iter().filter(|p| p.1 == 1).count();
    assert_eq!(
        coarse + fine / 4,
        800,
        "{coarse} coarse, {fine} fine: a split lost mass"
    );
    assert!(
        coarse < 700 && coarse > 600,
        "{coarse} coarse left: splits expected"
    );
    let split = 700 - coarse;
    let ids: HashSet<u64> = ps.iter().map(|p| p.0).collect();
    assert_eq!(ids.len(), ps.len(), "ids unique");
    let bound = common::id_bound_2d(SCENE);
    let born: Vec<u64> = ps.iter().filter(|p| p.0 >= bound).map(|p| p.0).collect();
    assert_eq!(born.len(), 4 * split, "children take ids from the counter");
    assert!(
        born.iter().all(|&i| i < bound + 4 * split as u64),
        "ids numbered from the bound"
    );
    for p in &ps {
        let want = if p.1 == 0 { 0.1 } else { 0.025 };
        assert_eq!(p.4, want, "particle {}: mass {}", p.0, p.4);
    }
    // Σm exactly (an exact sum of exact quarters), Σmv to round-off
    for m in series(&base, "mass") {
        assert_eq!(m, 80.0);
    }
    for (k, px) in series(&base, "momentum_x").iter().enumerate() {
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
    for (ranks, threads) in [(3, 1), (8, 1), (3, 2)] {
        let d = dir.join(format!("r{ranks}t{threads}"));
        run(&d, ranks, threads, &[]);
        for f in ["timeseries.csv", "final.csv"] {
            assert!(
                read(&d, f) == read(&base, f),
                "{f} differs on {ranks} ranks × {threads} threads"
            );
        }
    }
}

/// A run checkpointed on 2 ranks between splits and continued on 3 gives the uninterrupted
/// bits: the counter `next_id` travels in the checkpoint.
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
    let (code, _, err) = hsph(&[
        "run",
        "--restart",
        cut.to_str().unwrap(),
        "-q",
        "--ranks",
        "3",
        "--set",
        "time.max_steps=0",
    ]);
    assert_eq!(code, 0, "{err}");
    for f in ["timeseries.csv", "final.csv"] {
        assert!(read(&cut, f) == read(&whole, f), "{f} differs after the restart");
    }
}

/// `adapt` needs a region that refines a fluid, with the scene's h: otherwise exit 2 naming
/// the key.
#[test]
fn adapt_without_a_fluid_or_with_the_levels_h_is_refused() {
    for (set, needle) in [
        (
            "refine[0].smoothing_length=\"level\"",
            "smoothing_length = \"scene\"",
        ),
        ("refine[0].bodies=[\"nothing\"]", "refines no fluid"),
    ] {
        let (code, _, err) = hsph(&["check", SCENE, "--set", set]);
        assert_eq!(code, 2, "{set}: {err}");
        assert!(err.contains("refine[0]") && err.contains(needle), "{set}: {err}");
    }
}
