//! Pair mode (`[performance] interactions = "pairs"`, issue 16): each owned fluid pair once,
//! equal and opposite shares. It must agree with gather mode to round-off on one step, in 2D
//! and 3D, and give the same bits run after run for a fixed layout and thread count.

mod common;

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
    b.model.pairs = true;
    a.advance(&comm).unwrap();
    b.advance(&comm).unwrap();
    assert!(
        b.nl.pairs() < a.nl.pairs() * 7 / 10,
        "half lists: {} vs {}",
        b.nl.pairs(),
        a.nl.pairs()
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
    let s2 = scene("inputs/dam_break_2d_dsph.toml", &["output.format=\"none\""]);
    let (rho, acc, n) = step_difference::<2>(&s2);
    eprintln!("2D, {n} fluid particles: dρ/dt {rho:.2e}, acceleration {acc:.2e} (relative to the largest)");
    assert!(n > 10_000 && rho <= 1e-12 && acc <= 1e-12, "2D: {rho:e} {acc:e}");
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

#[test]
fn pairs_mode_repeats_its_bits_for_a_fixed_layout_and_stays_near_gather() {
    let pairs = scene(
        "inputs/dam_break_2d.toml",
        &["time.t_end=0.05", "performance.interactions=\"pairs\""],
    );
    let gather = scene("inputs/dam_break_2d.toml", &["time.t_end=0.05"]);
    for (ranks, threads) in [(1, 2), (3, 1)] {
        let tag = format!("pairs-r{ranks}t{threads}");
        let first = run(&pairs, ranks, threads, &format!("{tag}-a"));
        let again = run(&pairs, ranks, threads, &format!("{tag}-b"));
        assert!(first == again, "{tag}: two runs differ");
        // the same flow as gather mode after 0.05 s of a dam break (positions in m, speeds in
        // m/s, densities, pressures): round-off grown over 80 steps, not a different flow
        let g = run(&gather, ranks, threads, &format!("{tag}-gather"));
        let d = max_difference(&first, &g);
        eprintln!("{tag}: largest relative difference from gather {d:.2e}");
        assert!(d < 1e-8, "{tag}: differs from gather by {d}");
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
        err.contains("performance.interactions") && err.contains("gather"),
        "{err}"
    );
    let (code, _, err) = hsph(&[
        "run",
        "inputs/impact_oblique_45.toml",
        "--interactions",
        "pairs",
        "--set",
        "time.max_steps=1",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("solid"), "{err}");
}
