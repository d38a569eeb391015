//! The lean-memory mode (`[performance] neighbours = "cells"`, issue 16): no stored neighbour
//! lists; each pass scans the stencil cells again in the order the lists hold. Gather and
//! pair mode must give the same bits as with lists, in 2D and 3D, on one rank and several,
//! with walls (fluid-only wall lists), mirror walls and periodic images.

use crate::common;

use common::hsph;
use hsph::scene::{load_scene, Scene};
use std::fs;

fn scene(rel: &str, overrides: &[&str]) -> Scene {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    load_scene(&common::repo_path(rel), &o).unwrap().0
}

fn run(scene: &Scene, ranks: usize, tag: &str) -> (String, String) {
    let out = common::run_layout(scene, ranks, 2, tag);
    let read = |f: &str| fs::read_to_string(out.join(f)).unwrap();
    (read("final.csv"), read("timeseries.csv"))
}

#[test]
fn cells_mode_gives_the_bits_of_stored_lists() {
    for (file, over, ranks) in [
        ("inputs/dam_break_2d.toml", vec!["time.t_end=0.05"], 1),
        ("inputs/dam_break_2d.toml", vec!["time.t_end=0.05"], 3),
        (
            "inputs/dam_break_3d.toml",
            vec!["time.max_steps=20", "output.format=\"none\""],
            1,
        ),
        ("inputs/wall_impact_2d.toml", vec!["time.max_steps=100"], 2),
        (
            "inputs/wall_impact_2d.toml",
            vec!["time.max_steps=100", "wall[0].method=\"mirror\""],
            1,
        ),
        ("inputs/poiseuille_2d.toml", vec!["time.max_steps=200"], 1),
        // pair mode's half lists against its list-free scan: periodic, mirror, repulsive
        (
            "inputs/poiseuille_2d.toml",
            vec!["time.max_steps=200", "performance.interactions=\"pairs\""],
            3,
        ),
        (
            "inputs/wall_impact_2d.toml",
            vec![
                "time.max_steps=150",
                "fluid[0].min=[0.79, 0.15]",
                "fluid[0].max=[0.99, 0.35]",
                "wall[0].method=\"mirror\"",
                "performance.interactions=\"pairs\"",
            ],
            2,
        ),
        (
            "inputs/wall_impact_2d.toml",
            vec![
                "time.max_steps=150",
                "fluid[0].min=[0.79, 0.15]",
                "fluid[0].max=[0.99, 0.35]",
                "wall[0].method=\"repulsive\"",
                "performance.interactions=\"pairs\"",
            ],
            1,
        ),
        // 3D rows of cells hold more candidates than one batch of the scan (64)
        (
            "inputs/dam_break_3d.toml",
            vec![
                "time.max_steps=10",
                "output.format=\"none\"",
                "performance.interactions=\"pairs\"",
            ],
            2,
        ),
        // particles of several sizes: each pair within its own support, the cells in their
        // sub-cell order in both modes (gather with the set-up relaxation, then pairs)
        (
            "inputs/hydrostatic_2d_refined.toml",
            vec!["time.max_steps=60", "refine.0.smoothing_length=\"level\""],
            1,
        ),
        (
            "inputs/hydrostatic_2d_refined.toml",
            vec![
                "time.max_steps=60",
                "refine.0.smoothing_length=\"level\"",
                "discretisation.relax=0",
                "performance.interactions=\"pairs\"",
            ],
            2,
        ),
    ] {
        let tag = format!(
            "{}-{}-r{ranks}",
            file.trim_start_matches("inputs/").trim_end_matches(".toml"),
            over.len()
        );
        let lists = scene(file, &over);
        let mut over_cells = over.clone();
        over_cells.push("performance.neighbours=\"cells\"");
        let cells = scene(file, &over_cells);
        let a = run(&lists, ranks, &format!("{tag}-lists"));
        let b = run(&cells, ranks, &format!("{tag}-cells"));
        assert!(a.0 == b.0, "{tag}: final.csv differs between lists and cells");
        assert!(
            a.1 == b.1,
            "{tag}: timeseries.csv differs between lists and cells"
        );
    }
}

#[test]
fn cells_mode_runs_pairs_and_names_it_in_the_cli() {
    let out = common::temp_dir("lean-cli").join("run");
    let (code, _, err) = hsph(&[
        "run",
        "inputs/dam_break_2d.toml",
        "--neighbours",
        "cells",
        "--interactions",
        "pairs",
        "--set",
        "time.max_steps=20",
        "-q",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let scene = fs::read_to_string(out.join("scene.toml")).unwrap();
    assert!(
        scene.contains("neighbours = \"cells\"") && scene.contains("interactions = \"pairs\""),
        "{scene}"
    );
    let (code, _, err) = hsph(&[
        "check",
        "inputs/dam_break_2d.toml",
        "--set",
        "performance.neighbours=\"none\"",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("performance.neighbours"), "{err}");
}
