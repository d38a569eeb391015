//! Scale-out (issue 17): the distributed set-up holds O(N/P) particles per rank (at most
//! `balance.max_count` times the mean count when balanced on pairs) and keeps the bits of one
//! rank; planes that split lattice layers by id balance `hsph plan` to 1.10 at
//! 96 ranks and 1.20 at 1 024 ranks on 10 M particles; a set-up error found by one rank is
//! every rank's input error.

use crate::common;

use hsph::placement::Placement;
use hsph::plan::plan;
use hsph::scene::{load_scene, Scene};
use hsph::topology::Topology;
use std::fs;

fn scene(rel: &str, overrides: &[&str]) -> Scene {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    load_scene(&common::repo_path(rel), &o).unwrap().0
}

fn summary(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

fn per_rank(s: &serde_json::Value, key: &str) -> Vec<u64> {
    s[key]
        .as_array()
        .unwrap_or_else(|| panic!("summary.json lacks {key}"))
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect()
}

#[test]
fn distributed_setup_holds_n_over_p_per_rank_and_keeps_the_bits() {
    // the 3D dam break at 2.5 cm (~23 k particles), the set-up and one step on 8 local ranks
    let s = scene(
        "inputs/dam_break_3d.toml",
        &["discretisation.dx=0.025", "time.max_steps=1"],
    );
    let one = common::run_layout(&s, 1, 1, "so-r1");
    let eight = common::run_layout(&s, 8, 1, "so-r8");
    assert!(
        fs::read_to_string(one.join("final.csv")).unwrap()
            == fs::read_to_string(eight.join("final.csv")).unwrap(),
        "final.csv differs between 1 and 8 ranks"
    );
    let (s1, s8) = (summary(&one), summary(&eight));
    let n = s8["particles"].as_u64().unwrap();
    assert!(n > 20_000, "{n} particles");
    // one rank holds everything (the instrument counts what the set-up materialises)
    assert!(per_rank(&s1, "particle_high_water")[0] >= n);
    let held = per_rank(&s8, "particle_high_water");
    let ghosts = per_rank(&s8, "ghost_high_water");
    assert_eq!(held.len(), 8);
    // balanced on pairs, a rank owns at most `balance.max_count` times the mean count (1.83
    // uncapped here); the set-up materialises a spacing around its box besides
    let cap = s.balance.max_count;
    for (r, (h, g)) in held.iter().zip(&ghosts).enumerate() {
        let bound = cap * n as f64 / 8.0 + *g as f64;
        assert!(
            (*h as f64) <= bound,
            "rank {r} held {h} particles, above {cap} N/P + its {g} ghosts = {bound:.0} (N = {n})"
        );
        assert!(*h < n / 2, "rank {r} held {h} of {n} particles");
    }
}

/// `hsph plan`'s (rank order) max/mean owned particles for `ranks` ranks, `per_node` a node:
/// its count imbalance.
fn plan_imbalance(s: &Scene, ranks: usize, per_node: usize) -> f64 {
    plan_row(s, ranks, per_node).count_imbalance
}

/// `hsph plan`'s row (rank order) for `ranks` ranks, `per_node` a node.
fn plan_row(s: &Scene, ranks: usize, per_node: usize) -> hsph::plan::PlanRow {
    let topo = Topology::from_ranks_per_node(ranks, per_node).unwrap();
    plan(s, ranks, &topo, &[Placement::RankOrder]).unwrap().remove(0)
}

#[test]
fn plans_balance_at_96_and_1024_ranks() {
    // issue 17: 1.52 at 96 ranks and 4.1 at 1 024 before planes could split a layer; split by
    // counts (balanced on pairs, the count cap bounds the counts instead: below)
    let counts = ["balance.load=\"particles\""];
    let bench = scene("inputs/dam_break_3d_bench.toml", &counts);
    let i96 = plan_imbalance(&bench, 96, 24);
    assert!(i96 <= 1.10, "96 ranks: max/mean {i96}");
    // balanced on expected pairs, a block of dummy wall holds more particles than the mean,
    // up to `balance.max_count` (uncapped: 4.4 at 96 ranks)
    let pairs = scene("inputs/dam_break_3d_bench.toml", &[]);
    let cap = pairs.balance.max_count;
    let p96 = plan_imbalance(&pairs, 96, 24);
    assert!(
        p96 > i96 && p96 <= cap * 1.001,
        "96 ranks on pairs: max/mean count {p96}, cap {cap}"
    );
    // what plan calls "imbalance" is the balanced load's, as a run's: on counts the two are
    // one figure; on pairs without the count cap the pairs are balanced (4.4 in counts) and
    // with it (the default, 1.5) the cap costs pair balance (1.31 measured)
    let counted = plan_row(&bench, 96, 24);
    assert_eq!(counted.imbalance, counted.count_imbalance);
    let uncapped = scene("inputs/dam_break_3d_bench.toml", &["balance.max_count=100"]);
    let free = plan_row(&uncapped, 96, 24);
    assert!(
        free.imbalance <= 1.05 && free.count_imbalance > 2.0,
        "96 ranks on pairs, uncapped: load imbalance {}, count imbalance {}",
        free.imbalance,
        free.count_imbalance
    );
    let capped = plan_row(&pairs, 96, 24).imbalance;
    assert!(capped > free.imbalance, "the cap costs pair balance: {capped}");
    let big = scene(
        "inputs/dam_break_3d.toml",
        &["discretisation.dx=0.0028", counts[0]],
    );
    let t0 = std::time::Instant::now();
    let i1024 = plan_imbalance(&big, 1024, 32);
    eprintln!(
        "plan: 96 ranks {i96:.4}, 1 024 ranks on 10 M particles {i1024:.4} ({:.1} s)",
        t0.elapsed().as_secs_f64()
    );
    assert!(i1024 <= 1.20, "1 024 ranks: max/mean {i1024}");
}

#[test]
fn an_overlap_found_by_one_rank_is_every_ranks_input_error() {
    // a second fluid block overlapping the dam-break column: the sites in common belong to
    // one or two ranks of four, and the run must still exit 2 naming both bodies
    let text = fs::read_to_string(common::repo_path("inputs/dam_break_2d.toml")).unwrap();
    let extra = "\n[[fluid]]\nname = \"spill\"\nmaterial = \"water\"\nmin = [0.05, 0.05]\nmax = [0.2, 0.2]\n";
    let dir = common::temp_dir("so-overlap");
    let path = dir.join("overlap.toml");
    fs::write(&path, text + extra).unwrap();
    let out = dir.join("run");
    let (code, _, err) = common::hsph(&[
        "run",
        path.to_str().unwrap(),
        "--ranks",
        "4",
        "-q",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("fluid[1]") && err.contains("overlaps fluid[0]"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn the_model_reproduces_its_calibration_and_refuses_bad_runs() {
    // three short runs of the 2D dam break: 1, 2 and 4 ranks of 1 thread
    let dir = common::temp_dir("so-model");
    let run_at = |ranks: &str, threads: &str| {
        let out = dir.join(format!("r{ranks}t{threads}"));
        let path = common::repo_path("inputs/dam_break_2d.toml");
        let (code, _, err) = common::hsph(&[
            "run",
            path.to_str().unwrap(),
            "-q",
            "--threads",
            threads,
            "--ranks",
            ranks,
            "--set",
            "time.max_steps=20",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        out.to_str().unwrap().to_string()
    };
    let run = |ranks: &str| run_at(ranks, "1");
    let (r1, r2, r4) = (run("1"), run("2"), run("4"));
    let (code, out, err) = common::hsph(&["model", "--one", &r1, "--many", &r2, &r4, "--check", &r1, &r4]);
    assert_eq!(code, 0, "{err}");
    // a = wall / particle-steps of the one-rank run: the model gives that run's step exactly
    let line = out.lines().find(|l| l.starts_with(&format!("| {r1} "))).unwrap();
    assert!(line.ends_with("| +0.0 % |"), "{out}");
    let rows = out
        .lines()
        .filter(|l| l.starts_with("| ") && l.ends_with(" % |"))
        .count();
    assert_eq!(rows, 2, "{out}");
    // the one-rank calibration must be a one-rank run
    let (code, _, err) = common::hsph(&["model", "--one", &r2, "--many", &r4, "--check", &r1]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--one") && err.contains("1 rank"), "{err}");
    // threads: a run with two threads is checked once e(2) is measured, and reproduced when
    // it is the run that measured it; a layout ranking names the fastest of a node's layouts
    let t2 = run_at("1", "2");
    let (code, _, err) = common::hsph(&["model", "--one", &r1, "--many", &r2, "--check", &t2]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--two"), "{err}");
    let (code, out, err) =
        common::hsph(&["model", "--one", &r1, "--many", &r2, "--two", &t2, "--check", &t2]);
    assert_eq!(code, 0, "{err}");
    let line = out.lines().find(|l| l.starts_with(&format!("| {t2} "))).unwrap();
    assert!(line.ends_with("| +0.0 % |"), "{out}");
    let scene = common::repo_path("inputs/dam_break_2d.toml");
    let args = ["model", scene.to_str().unwrap(), "--one", &r1, "--many", &r2];
    let (code, _, err) = common::hsph(&[&args[..], &["--layouts", "4"]].concat());
    assert_eq!(code, 2, "{err}");
    let (code, out, err) =
        common::hsph(&[&args[..], &["--two", &t2, "--layouts", "4", "--nodes", "2"]].concat());
    assert_eq!(code, 0, "{err}");
    for layout in ["| 8 × 1 |", "| 4 × 2 |", "| 2 × 4 |"] {
        assert!(out.contains(layout), "{layout}: {out}");
    }
    assert!(out.contains("fastest on nodes of 4 cores"), "{out}");
}

#[test]
fn a_restart_reads_its_share_of_the_checkpoint_not_the_whole() {
    // checkpoint the 3D dam break at step 2 on 4 ranks, continue on 4: each rank reads one
    // part and receives what it owns, so it never holds the whole checkpoint; the continued
    // run ends with the bits of an uninterrupted one
    let s = |steps: &str| {
        vec![
            "--set".to_string(),
            "discretisation.dx=0.025".to_string(),
            "--set".to_string(),
            format!("time.max_steps={steps}"),
            "--set".to_string(),
            "checkpoint.every_steps=2".to_string(),
        ]
    };
    let dir = common::temp_dir("so-restart");
    let scene = common::repo_path("inputs/dam_break_3d.toml");
    let run = |out: &std::path::Path, steps: &str, restart: bool| {
        let out_s = out.to_str().unwrap().to_string();
        let mut args: Vec<String> = if restart {
            vec!["run".into(), "--restart".into(), out_s.clone()]
        } else {
            vec![
                "run".into(),
                scene.to_str().unwrap().into(),
                "--out".into(),
                out_s,
            ]
        };
        args.extend([
            "-q".into(),
            "--ranks".into(),
            "4".into(),
            "--threads".into(),
            "1".into(),
        ]);
        args.extend(s(steps));
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, _, err) = common::hsph(&a);
        assert_eq!(code, 0, "{err}");
    };
    let whole = dir.join("whole");
    run(&whole, "4", false);
    let cut = dir.join("cut");
    run(&cut, "2", false);
    run(&cut, "4", true);
    assert!(
        fs::read_to_string(whole.join("final.csv")).unwrap()
            == fs::read_to_string(cut.join("final.csv")).unwrap(),
        "the continued run's final.csv differs from the uninterrupted one's"
    );
    let sm = summary(&cut);
    let n = sm["particles"].as_u64().unwrap();
    for (r, (h, g)) in per_rank(&sm, "particle_high_water")
        .iter()
        .zip(per_rank(&sm, "ghost_high_water"))
        .enumerate()
    {
        // the high water of held particles is the whole run's, the ghosts' that of the
        // continued part
        let bound = hsph::scene::Balance::default().max_count * n as f64 / 4.0 + g as f64;
        assert!(
            (*h as f64) <= bound,
            "rank {r} held {h} of {n} particles after the restart (bound {bound:.0})"
        );
    }
}
