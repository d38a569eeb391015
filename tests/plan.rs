//! Node-aware layouts (issue 4): `hsph plan` predicts the halo bytes of a real run's first step
//! exactly, the placements order as the issue expects on the 3D dam break with 96 ranks on 4
//! nodes, every placement keeps the engine's bits, and bad layouts are input errors.

use crate::common;

use hsph::driver::{run_scene, Backend, RunOptions};
use hsph::placement::Placement;
use hsph::plan::{plan, PlanRow};
use hsph::scene::{load_scene, Scene};
use hsph::topology::Topology;
use std::fs;
use std::path::PathBuf;
use std::process::Command;

fn scene(rel: &str, overrides: &[&str]) -> Scene {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    load_scene(&common::repo_path(rel), &o).unwrap().0
}

fn run(s: &Scene, ranks: usize, per_node: usize, placement: Placement, tag: &str) -> PathBuf {
    let out = common::temp_dir(tag).join("run");
    let opts = RunOptions {
        out: Some(out.clone()),
        threads: 1,
        quiet: true,
        ranks,
        backend: Backend::Local,
        ranks_per_node: per_node,
        placement,
        ..Default::default()
    };
    run_scene(s, &opts).unwrap_or_else(|e| panic!("{tag}: {e}"));
    out
}

/// (intra-node bytes, inter-node bytes, messages) of the halo phase at `step` of traffic.csv.
fn halo_of_step(dir: &std::path::Path, step: u64) -> (u64, u64, u64) {
    let text = fs::read_to_string(dir.join("traffic.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("step,phase,src_rank,dst_rank,src_node,dst_node,bytes,messages")
    );
    let (mut intra, mut inter, mut msgs) = (0, 0, 0);
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        if f[0].parse::<u64>().unwrap() != step || f[1] != "halo" {
            continue;
        }
        let b: u64 = f[6].parse().unwrap();
        if f[4] == f[5] {
            intra += b;
        } else {
            inter += b;
        }
        msgs += f[7].parse::<u64>().unwrap();
    }
    (intra, inter, msgs)
}

#[test]
fn plan_predicts_the_first_step_halo_bytes_of_a_run_exactly() {
    let cases = [
        (
            "inputs/dam_break_2d.toml",
            vec!["time.t_end=0.002"],
            4,
            2,
            Placement::CentreDistance,
        ),
        // periodic: images sent to the rank itself count as intra-node traffic
        (
            "inputs/poiseuille_2d.toml",
            vec!["time.t_end=0.001", "reference.times=[0.001]"],
            3,
            1,
            Placement::RankOrder,
        ),
        (
            "tests/data/dam_break_3d_small.toml",
            vec!["time.t_end=0.002"],
            6,
            3,
            Placement::MinCut,
        ),
        (
            "tests/data/dam_break_3d_small.toml",
            vec!["time.t_end=0.002"],
            8,
            4,
            Placement::NodeGrid,
        ),
    ];
    for (file, o, ranks, per_node, method) in cases {
        let s = scene(file, &o);
        let topo = Topology::from_ranks_per_node(ranks, per_node).unwrap();
        let rows = plan(&s, ranks, &topo, &[method]).unwrap();
        let dir = run(&s, ranks, per_node, method, "plan-exact");
        let (intra, inter, msgs) = halo_of_step(&dir, 0);
        let r = &rows[0];
        assert!(intra + inter > 0, "{file}: no halo traffic recorded");
        assert_eq!(
            (r.intra_node_bytes, r.inter_node_bytes, r.messages),
            (intra, inter, msgs),
            "{file} on {ranks} ranks, {per_node} per node, {}: plan vs run",
            method.name()
        );
    }
}

#[test]
fn placements_cut_inter_node_halo_bytes_on_the_3d_dam_break() {
    // 96 ranks on 4 virtual nodes of 24 (seed 000's process count), the 275 k-particle scene
    let s = scene("inputs/dam_break_3d_bench.toml", &[]);
    let topo = Topology::from_ranks_per_node(96, 24).unwrap();
    let rows = plan(&s, 96, &topo, &Placement::ALL).unwrap();
    let by = |m: Placement| -> &PlanRow { rows.iter().find(|r| r.placement == m).unwrap() };
    let (ro, cd, mc) = (
        by(Placement::RankOrder),
        by(Placement::CentreDistance),
        by(Placement::MinCut),
    );
    for r in &rows {
        // every placement moves the same total: only the split between nodes changes
        assert_eq!(
            r.intra_node_bytes + r.inter_node_bytes,
            ro.intra_node_bytes + ro.inter_node_bytes
        );
    }
    assert!(
        cd.inter_node_bytes < ro.inter_node_bytes,
        "centre-distance {} vs rank-order {}",
        cd.inter_node_bytes,
        ro.inter_node_bytes
    );
    assert!(mc.inter_node_bytes <= cd.inter_node_bytes);
    assert!(
        mc.inter_node_bytes < cd.inter_node_bytes,
        "min-cut must beat centre-distance here"
    );
}

#[test]
fn every_placement_keeps_the_bits() {
    let s = scene(
        "inputs/dam_break_2d.toml",
        &["time.t_end=0.03", "output.format=\"none\""],
    );
    let serial = {
        let out = common::temp_dir("plan-bits-serial").join("run");
        run_scene(
            &s,
            &RunOptions {
                out: Some(out.clone()),
                threads: 1,
                quiet: true,
                ..Default::default()
            },
        )
        .unwrap();
        fs::read_to_string(out.join("final.csv")).unwrap()
    };
    for m in Placement::ALL {
        let dir = run(&s, 6, 3, m, "plan-bits");
        assert!(
            fs::read_to_string(dir.join("final.csv")).unwrap() == serial,
            "{} changes the bits",
            m.name()
        );
    }
}

/// A placement the nodes cannot honour is recorded as what ran, with a warning (the other
/// half, a layout that cannot hold the ranks at all, exits 2: `bad_layouts_are_input_errors`).
#[test]
fn a_placement_the_nodes_cannot_honour_is_recorded_as_what_ran() {
    // 6 ranks on nodes of 4 hold 4 and 2 ranks: node-grid finds no sub-grid per node
    let s = scene(
        "inputs/dam_break_2d.toml",
        &["time.max_steps=3", "output.format=\"none\""],
    );
    let dir = run(&s, 6, 4, Placement::NodeGrid, "plan-fallback");
    let summary: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["placement_requested"], "node-grid");
    assert_eq!(summary["placement"], "centre-distance");
    let warning = summary["layout_warnings"][0].as_str().unwrap();
    assert!(
        warning.contains("node-grid") && warning.contains("centre-distance"),
        "{warning}"
    );
    // plan says the same
    let topo = Topology::from_ranks_per_node(6, 4).unwrap();
    let rows = plan(&s, 6, &topo, &[Placement::NodeGrid]).unwrap();
    assert_eq!(rows[0].ran, Placement::CentreDistance);
    // an honoured placement records itself and no warning
    let dir = run(&s, 6, 3, Placement::NodeGrid, "plan-honoured");
    let summary: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["placement"], "node-grid");
    assert_eq!(summary["layout_warnings"].as_array().unwrap().len(), 0);
}

fn hsph(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn bad_layouts_are_input_errors() {
    let scene = common::repo_path("inputs/dam_break_2d.toml");
    let scene = scene.to_str().unwrap();
    let dir = common::temp_dir("plan-bad");
    let bad = dir.join("typo.toml");
    fs::write(&bad, "[node]\ncount = 2\nranks = 2\nnuma_domain = 1\n").unwrap();
    let zero = dir.join("zero.toml");
    let valid = fs::read_to_string(common::repo_path("topology/four_nodes_24.toml")).unwrap();
    fs::write(&zero, valid.replace("count = 4", "count = 0")).unwrap();
    let out = dir.join("run");
    let out = out.to_str().unwrap();
    for (args, needle) in [
        (
            vec!["plan", scene, "--ranks", "4", "--ranks-per-node", "8"],
            "ranks-per-node",
        ),
        (
            vec![
                "run",
                scene,
                "--ranks",
                "4",
                "--ranks-per-node",
                "8",
                "--out",
                out,
            ],
            "ranks-per-node",
        ),
        (
            vec!["plan", scene, "--ranks", "4", "--topology", bad.to_str().unwrap()],
            "numa_domain",
        ),
        (
            vec![
                "plan",
                scene,
                "--ranks",
                "4",
                "--topology",
                zero.to_str().unwrap(),
            ],
            "node.count",
        ),
        (
            vec![
                "run",
                scene,
                "--ranks",
                "4",
                "--placement",
                "nearest",
                "--out",
                out,
            ],
            "placement",
        ),
    ] {
        let (code, err) = hsph(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(!dir.join("run").join("summary.json").exists());
    }
}

/// The model's compute term weighs each rank's particles by their cost: under
/// `balance.load = "pairs"` the set-up split balances that work, not the counts (a rank of
/// cheap dummy-wall particles owns more of them), and the work sums to the particles; split
/// by counts, the work is the count.
#[test]
fn plan_weighs_each_ranks_particles_by_their_cost() {
    // 2 ranks: below the count cap (at 3 it binds on this scene)
    let topo = Topology::from_ranks_per_node(2, 2).unwrap();
    for (load, by_pairs) in [("pairs", true), ("particles", false)] {
        let s = scene("inputs/dam_break_3d.toml", &[&format!("balance.load=\"{load}\"")]);
        let row = plan(&s, 2, &topo, &[Placement::RankOrder]).unwrap().remove(0);
        let n: u64 = row.owned.iter().sum();
        let w: f64 = row.work.iter().sum();
        assert!(
            (w - n as f64).abs() < 1e-6 * n as f64,
            "{load}: work {w} for {n} particles"
        );
        let spread = |v: &[f64]| {
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            v.iter().fold(0.0f64, |m, x| m.max(*x)) / mean
        };
        let owned: Vec<f64> = row.owned.iter().map(|&c| c as f64).collect();
        if by_pairs {
            assert!(
                spread(&row.work) < 1.05 && spread(&owned) > 1.2,
                "{load}: work {:?}, owned {:?}",
                row.work,
                row.owned
            );
        } else {
            assert_eq!(row.work, owned, "{load}");
        }
    }
}
