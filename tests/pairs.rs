//! Pair mode (`[performance] interactions = "pairs"`, issue 16): each pair once, equal and
//! opposite shares. It must agree with gather mode to round-off on one step, in 2D and 3D,
//! and give the same bits on any number of ranks and threads (its own bits, not gather's).

use crate::common;

use common::hsph;
use hsph::comm::serial::SerialComm;
use hsph::scene::{load_scene, Scene};
use hsph::sim::Simulation;
use std::fs;

fn scene(rel: &str, overrides: &[&str]) -> Scene {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    load_scene(&common::repo_path(rel), &o).unwrap().0
}

/// Largest |a − b| over owned fluid particles (matched by id) relative to the largest |a|:
/// (dρ/dt, acceleration).
fn step_difference<const D: usize>(scene: &Scene) -> (f64, f64, usize) {
    let comm = SerialComm::new();
    let mut a = Simulation::<D>::new(scene, &comm).unwrap();
    let mut b = Simulation::<D>::new(scene, &comm).unwrap();
    // a few gather steps so that the fluid moves and the diffusion and viscosity act
    for _ in 0..10 {
        a.advance(&comm).unwrap();
        b.advance(&comm).unwrap();
    }
    assert_eq!(a.p.x, b.p.x, "two gather runs of one scene are identical");
    b.pair_mode = true;
    a.advance(&comm).unwrap();
    b.advance(&comm).unwrap();
    assert!(
        b.nl.entries() < a.nl.entries() * 7 / 10,
        "half lists: {} vs {}",
        b.nl.entries(),
        a.nl.entries()
    );
    let (ia, ib) = (a.by_id(), b.by_id());
    let (mut d_rho, mut s_rho, mut d_acc, mut s_acc, mut fluid) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0);
    for (&i, &j) in ia.iter().zip(&ib) {
        assert_eq!(a.p.id[i], b.p.id[j]);
        if !a.p.kind[i].is_fluid() {
            continue;
        }
        fluid += 1;
        d_rho = d_rho.max((a.p.drho[i] - b.p.drho[j]).abs());
        s_rho = s_rho.max(a.p.drho[i].abs());
        d_acc = d_acc.max((a.p.acc[i] - b.p.acc[j]).norm());
        s_acc = s_acc.max(a.p.acc[i].norm());
    }
    (d_rho / s_rho, d_acc / s_acc, fluid)
}

#[test]
fn pairs_and_gather_agree_to_round_off_on_one_step_2d_and_3d() {
    // the scene ships pair mode with Verlet lists and Fourtakas's term; this test starts both
    // runs in gather mode with lists built every step and switches one of them, first with
    // Antuono's term
    let gather = [
        "performance.interactions=\"gather\"",
        "performance.neighbours=\"lists\"",
    ];
    let s2 = scene(
        "inputs/dam_break_2d_dsph.toml",
        &[
            "output.format=\"none\"",
            "physics.density_diffusion=\"antuono\"",
            gather[0],
            gather[1],
        ],
    );
    let (rho, acc, n) = step_difference::<2>(&s2);
    eprintln!("2D, {n} fluid particles: dρ/dt {rho:.2e}, acceleration {acc:.2e} (relative to the largest)");
    assert!(n > 10_000 && rho <= 1e-12 && acc <= 1e-12, "2D: {rho:e} {acc:e}");
    // Fourtakas's hydrostatic correction, seen from either side of a pair
    let f2 = scene(
        "inputs/dam_break_2d_dsph.toml",
        &[
            "output.format=\"none\"",
            "physics.density_diffusion=\"fourtakas\"",
            gather[0],
            gather[1],
        ],
    );
    let (rho, acc, n) = step_difference::<2>(&f2);
    eprintln!("2D Fourtakas: dρ/dt {rho:.2e}, acceleration {acc:.2e}");
    assert!(
        n > 10_000 && rho <= 1e-12 && acc <= 1e-12,
        "2D Fourtakas: {rho:e} {acc:e}"
    );
    // the Riemann solver's pressure and density terms, seen from either side of a pair
    let r2 = scene(
        "inputs/dam_break_2d_dsph.toml",
        &[
            "output.format=\"none\"",
            "physics.density_diffusion=\"riemann\"",
            "physics.pressure_gradient=\"riemann\"",
            gather[0],
            gather[1],
        ],
    );
    let (rho, acc, n) = step_difference::<2>(&r2);
    eprintln!("2D Riemann: dρ/dt {rho:.2e}, acceleration {acc:.2e}");
    assert!(
        n > 10_000 && rho <= 1e-12 && acc <= 1e-12,
        "2D Riemann: {rho:e} {acc:e}"
    );
    let s3 = scene("inputs/dam_break_3d.toml", &["output.format=\"none\""]);
    let (rho, acc, n) = step_difference::<3>(&s3);
    eprintln!("3D, {n} fluid particles: dρ/dt {rho:.2e}, acceleration {acc:.2e} (relative to the largest)");
    assert!(n > 10_000 && rho <= 1e-12 && acc <= 1e-12, "3D: {rho:e} {acc:e}");
}

fn run(scene: &Scene, ranks: usize, threads: usize, tag: &str) -> String {
    fs::read_to_string(common::run_layout(scene, ranks, threads, tag).join("final.csv")).unwrap()
}

/// Largest difference of any number in two `final.csv` texts of the same particles, relative
/// to the larger of 1 and its size.
fn max_difference(a: &str, b: &str) -> f64 {
    let mut m = 0.0f64;
    for (la, lb) in a.lines().skip(1).zip(b.lines().skip(1)) {
        for (x, y) in la.split(',').zip(lb.split(',')) {
            if let (Ok(x), Ok(y)) = (x.parse::<f64>(), y.parse::<f64>()) {
                m = m.max((x - y).abs() / x.abs().max(1.0));
            }
        }
    }
    m
}

/// A scene file, its `--set` overrides and the layouts (ranks, threads) it runs on.
type Case = (&'static str, &'static [&'static str], &'static [(usize, usize)]);

/// The scenes pair mode is checked on: 2D dam break (walls, free surface, δ-SPH) and 3D dam
/// break, each long enough that the ranks rebalance and particles migrate, and the methods
/// below; each with the `--set` overrides and the layouts (ranks, threads) it runs on, the
/// first the reference.
const PAIR_CASES: [Case; 8] = [
    (
        "inputs/dam_break_2d.toml",
        &["time.t_end=0.05"],
        &[(1, 1), (1, 2), (3, 1), (3, 2), (4, 2)],
    ),
    // Fourtakas's density diffusion (no gradient pass, no ⟨∇ρ⟩ field)
    (
        "inputs/dam_break_2d.toml",
        &["time.t_end=0.05", "physics.density_diffusion=\"fourtakas\""],
        &[(1, 1), (3, 2)],
    ),
    // the Riemann solver's pressure and density terms (docs/pressure.md), on 1, 3 and 8
    // ranks
    (
        "inputs/dam_break_2d.toml",
        &[
            "time.t_end=0.05",
            "physics.density_diffusion=\"riemann\"",
            "physics.pressure_gradient=\"riemann\"",
        ],
        &[(1, 1), (3, 2), (8, 1)],
    ),
    (
        "inputs/dam_break_3d.toml",
        &["time.max_steps=40", "balance.check_every=5"],
        &[(1, 2), (3, 1), (4, 2)],
    ),
    // periodic images and laminar viscosity; mirror images
    (
        "inputs/poiseuille_2d.toml",
        &["time.max_steps=200"],
        &[(1, 1), (3, 2)],
    ),
    // the renormalised viscous operator (its lattice-moment pass and ghost refresh) and
    // Morris's no-slip walls
    (
        "inputs/poiseuille_2d.toml",
        &[
            "time.max_steps=200",
            "physics.viscous_operator=\"renormalised\"",
            "wall[0].no_slip=\"morris\"",
            "wall[1].no_slip=\"morris\"",
            "discretisation.kernel=\"wendland_c2\"",
            "discretisation.h_over_dx=1.2",
        ],
        &[(1, 1), (3, 2)],
    ),
    // Morris's no-slip between mirror plates: images across two planes, one of them
    // moving (the Couette lid), seen from either side of a pair
    (
        "inputs/couette_2d_mirror.toml",
        &[
            "time.max_steps=200",
            "physics.viscous_operator=\"renormalised\"",
            "wall[0].no_slip=\"morris\"",
            "wall[1].no_slip=\"morris\"",
        ],
        &[(1, 1), (3, 2)],
    ),
    (
        "inputs/wall_impact_2d.toml",
        // the block starts 1 cm from the mirror wall, so that it hits it
        &[
            "time.max_steps=150",
            "fluid[0].min=[0.79, 0.15]",
            "fluid[0].max=[0.99, 0.35]",
            "wall[0].method=\"mirror\"",
        ],
        &[(1, 2), (2, 1)],
    ),
];

/// Pair mode on `file` with `extra`: the same `final.csv` on every layout, and the flow of
/// gather mode to round-off.
fn check_pair_case(k: usize, (file, extra, layouts): Case) {
    let mut with_pairs: Vec<&str> = extra.to_vec();
    with_pairs.push("performance.interactions=\"pairs\"");
    let pairs = scene(file, &with_pairs);
    let gather = scene(file, extra);
    let name = format!(
        "{}{k}",
        file.trim_start_matches("inputs/").trim_end_matches(".toml")
    );
    let reference = run(&pairs, layouts[0].0, layouts[0].1, &format!("pairs-{name}-ref"));
    for &(ranks, threads) in &layouts[1..] {
        let tag = format!("pairs-{name}-r{ranks}t{threads}");
        let other = run(&pairs, ranks, threads, &tag);
        assert!(
            other == reference,
            "{tag}: final.csv differs from {} rank(s) × {} thread(s)",
            layouts[0].0,
            layouts[0].1
        );
    }
    // the same flow as gather mode (positions in m, speeds in m/s, densities, pressures):
    // round-off grown over the run, not a different flow
    let g = run(&gather, 1, 2, &format!("pairs-{name}-gather"));
    let d = max_difference(&reference, &g);
    eprintln!("{name}: largest relative difference from gather {d:.2e}");
    assert!(d < 1e-8, "{name}: differs from gather by {d}");
    assert!(reference != g, "{name}: pair mode ran as gather mode");
}

#[test]
fn pairs_mode_gives_the_same_bits_on_any_ranks_and_threads_and_stays_near_gather() {
    for (k, case) in PAIR_CASES.into_iter().enumerate() {
        check_pair_case(k, case);
    }
}

#[test]
fn pairs_mode_refuses_passes_it_does_not_cover() {
    let (code, _, err) = hsph(&[
        "check",
        "inputs/taylor_green.toml",
        "--set",
        "physics.shifting=\"delta_plus\"",
        "--set",
        "performance.interactions=\"pairs\"",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("performance.interactions") && err.contains("gather") && err.contains("shift"),
        "{err}"
    );
    let (code, _, err) = hsph(&[
        "run",
        "inputs/taylor_green.toml",
        "--set",
        "physics.shifting=\"delta_plus\"",
        "--interactions",
        "pairs",
        "--set",
        "time.max_steps=1",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("shift"), "{err}");
    // the typed flag, not `--set`, is named as the source of the key
    assert!(
        err.contains("--interactions: key `performance.interactions`"),
        "{err}"
    );
}

/// Typed flags reach the scene as values and its written text: `--interactions pairs
/// --neighbours cells` runs in those modes and the run directory's `scene.toml` (what a restart
/// reads) says so.
#[test]
fn typed_flags_reach_the_scene_and_its_written_text() {
    let dir = common::temp_dir("typed-flags").join("run");
    let out = dir.to_str().unwrap();
    let (code, _, err) = hsph(&[
        "run",
        "inputs/hydrostatic_2d.toml",
        "--interactions",
        "pairs",
        "--neighbours",
        "cells",
        "--set",
        "time.max_steps=2",
        "--out",
        out,
        "--force",
        "-q",
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(dir.join("scene.toml")).unwrap();
    let (scene, _) = hsph::scene::load_scene_str(&text, &dir.join("scene.toml"), "x", &[]).unwrap();
    assert_eq!(scene.performance.interactions, hsph::scene::Interactions::Pairs);
    assert_eq!(scene.performance.neighbours, hsph::scene::NeighbourMode::Cells);
    std::fs::remove_dir_all(&dir).ok();
}

/// The renormalised viscous operator's lattice moment L_i = −(1/D) Σ_j V_j r W′ at the
/// set-up of the channel (Wendland C2, h = 1.2 dx): every fluid particle (the plates fill the
/// support next to the walls) carries the square lattice's sum, taken here by brute
/// force over the lattice offsets (0.9638, docs/validation.md), in gather and pair mode alike.
#[test]
fn lattice_moment_equals_the_square_lattice_sum_in_gather_and_pair_mode() {
    use hsph::kernel::{Kernel, KernelKind};
    let sets = [
        "physics.viscous_operator=\"renormalised\"",
        "discretisation.kernel=\"wendland_c2\"",
        "discretisation.h_over_dx=1.2",
    ];
    let s = scene("inputs/poiseuille_2d.toml", &sets);
    let dx = s.discretisation.dx;
    let k = Kernel::new(KernelKind::WendlandC2, 1.2 * dx, 2);
    let mut oracle = 0.0;
    for a in -5i32..=5 {
        for b in -5i32..=5 {
            let r = dx * f64::from(a * a + b * b).sqrt();
            if r > 0.0 {
                oracle -= dx * dx * r * r * k.dw_dr_over_r(r) / 2.0;
            }
        }
    }
    assert!((oracle - 0.9638).abs() < 5e-5, "{oracle}");
    let comm = SerialComm::new();
    let gather = Simulation::<2>::new(&s, &comm).unwrap();
    let mut with_pairs = sets.to_vec();
    with_pairs.push("performance.interactions=\"pairs\"");
    let pairs = Simulation::<2>::new(&scene("inputs/poiseuille_2d.toml", &with_pairs), &comm).unwrap();
    let (ia, ib) = (gather.by_id(), pairs.by_id());
    let mut checked = 0;
    for (&i, &j) in ia.iter().zip(&ib) {
        if !gather.p.kind[i].is_fluid() {
            assert_eq!(gather.p.lap[i], 1.0);
            continue;
        }
        // the ρ of the fluid is ρ0 at the set-up (linear EOS, no hydrostatic start), and the
        // plates' extrapolated ρ differs from it by round-off only
        let (l, m) = (gather.p.lap[i], pairs.p.lap[j]);
        assert!((l - m).abs() < 1e-13, "gather {l} pairs {m}");
        assert!(
            (l - oracle).abs() < 1e-9,
            "id {}: {l} against {oracle}",
            gather.p.id[i]
        );
        checked += 1;
    }
    assert_eq!(checked, 25 * 15, "25 rows of 15 fluid particles");
}
