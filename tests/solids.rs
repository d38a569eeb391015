//! Elastic–plastic solids (issue 12): the oscillating plate against thin-plate theory, the
//! tensile instability with and without artificial stress.

use crate::common;

use hsph::comm::serial::SerialComm;
use hsph::scene::load_scene_str;
use hsph::sim::Simulation;
use std::path::Path;

fn sim_of<const D: usize>(text: &str, sets: &[&str]) -> Simulation<D> {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let (scene, _) = load_scene_str(text, Path::new("scene.toml"), "scene", &sets).unwrap();
    Simulation::<D>::new(&scene, &SerialComm::new()).unwrap()
}

/// Tip deflection history of the oscillating plate: (t, y of the tip particle, total energy).
fn plate_history(sets: &[&str], t_end: f64) -> Vec<(f64, f64, f64)> {
    let text = std::fs::read_to_string("inputs/oscillating_plate.toml").unwrap();
    let mut sim = sim_of::<2>(&text, sets);
    let comm = SerialComm::new();
    // the tip: the free particle of largest x closest to the mid-plane
    let tip_id = {
        let p = &sim.p;
        let i = (0..p.n_owned)
            .max_by(|&a, &b| {
                (p.x[a][0] - p.x[a][1].abs())
                    .partial_cmp(&(p.x[b][0] - p.x[b][1].abs()))
                    .unwrap()
            })
            .unwrap();
        p.id[i]
    };
    let y0 = (0..sim.p.n_owned)
        .find(|&i| sim.p.id[i] == tip_id)
        .map(|i| sim.p.x[i][1])
        .unwrap();
    let mut out = Vec::new();
    let mut energy = f64::NAN;
    // ~93 000 steps of 1 760 particles: on one thread of its own, so that no step waits for a
    // second worker that a concurrently running test keeps busy (the bits do not depend on it)
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    pool.install(|| {
        while sim.t < t_end {
            sim.advance(&comm).unwrap();
            let i = (0..sim.p.n_owned).find(|&i| sim.p.id[i] == tip_id).unwrap();
            if sim.step % 20 == 1 {
                let o = sim.observables(&comm).unwrap();
                energy = o.kinetic_energy + o.internal_energy;
            }
            out.push((sim.t, sim.p.x[i][1] - y0, energy));
        }
    });
    out
}

/// Times where the tip deflection changes sign (linear interpolation between steps).
fn zero_crossings(h: &[(f64, f64, f64)]) -> Vec<f64> {
    h.windows(2)
        .filter(|w| (w[0].1 > 0.0) != (w[1].1 > 0.0))
        .map(|w| w[0].0 - w[0].1 * (w[1].0 - w[0].0) / (w[1].1 - w[0].1))
        .collect()
}

/// Gray, Monaghan & Swift's oscillating plate at V_f = 0.01 and H/dx = 10 (the shipped
/// scene), run for 2.6 periods: over the first two the period is within 3 % of thin-plate
/// theory (T = 2π/ω, ω² = E H² k⁴ / (12 ρ (1 − ν²)), kL = 1.8751), the first amplitude within
/// 5 % of V_f c0/ω, and kinetic + internal energy (the elastic energy is part of e) drifts by
/// less than 0.7 %.
#[test]
fn oscillating_plate_period_and_energy_match_theory() {
    let (e, nu, rho, hh, l) = (2.0e6f64, 0.3975f64, 1000.0f64, 0.02f64, 0.2f64);
    let k = 1.8751040687119611 / l;
    let omega = (e * hh * hh * k.powi(4) / (12.0 * rho * (1.0 - nu * nu))).sqrt();
    let period = 2.0 * std::f64::consts::PI / omega;
    assert!((period - 0.2541).abs() < 1e-3, "theory {period}");
    // 2.6 periods (~48 000 steps) keep CI's time; the 5-period run is in docs/solids.md
    let h = plate_history(&[], 2.6 * period);
    let z = zero_crossings(&h);
    // deflection starts at 0 moving up: crossings at T/2, T, 3T/2, ...
    assert!(z.len() >= 5, "{z:?}");
    let measured = 2.0 * (z[4] - z[0]) / 4.0;
    let err = measured / period - 1.0;
    println!(
        "period {measured:.5} s, theory {period:.5} s ({:+.2} %)",
        100.0 * err
    );
    assert!(err.abs() < 0.03, "period {measured} vs {period}");
    let amp = h
        .iter()
        .take_while(|x| x.0 < 0.5 * period)
        .map(|x| x.1)
        .fold(0.0, f64::max);
    let c0 = (3.252e6f64 / rho).sqrt();
    let want = 0.01 * c0 / omega;
    assert!((amp / want - 1.0).abs() < 0.05, "amplitude {amp} vs {want}");
    let e0 = h[0].2;
    let drift = h.iter().map(|x| ((x.2 - e0) / e0).abs()).fold(0.0, f64::max);
    println!("energy drift {:.3} %", 100.0 * drift);
    // 0.452 % over 2.6 periods when this bound was set (0.67 % over 5): 1.5 × that
    assert!(drift < 0.007, "energy drift {drift}");
}

/// Smallest distance between two particles of the block over dx (the clumping index; 1 on the
/// initial lattice, below ½ once pairs clump).
fn min_pair_distance_over_dx(sim: &Simulation<2>) -> f64 {
    let p = &sim.p;
    let mut best = f64::INFINITY;
    for i in 0..p.n_owned {
        for &j in sim.nl.of(i) {
            let j = j as usize;
            if j != i {
                best = best.min((p.x[i] - p.x[j]).norm());
            }
        }
    }
    best / sim.scene.discretisation.dx
}

/// The tensile instability (Swegle et al. 1995; Gray, Monaghan & Swift 2001): a periodic block
/// in uniform tension, its lattice jittered by 1 % of dx, clumps without artificial stress —
/// the clumping index, the smallest pair distance over dx, falls below 0.5 — and stays above
/// 0.8 with ε = 0.3.
#[test]
fn tension_clumps_without_artificial_stress_and_not_with_it() {
    let text = std::fs::read_to_string("tests/data/tension_block.toml").unwrap();
    let index = |eps: &str| {
        let set = format!("physics.artificial_stress={eps}");
        let mut sim = sim_of::<2>(&text, &[set.as_str()]);
        let comm = SerialComm::new();
        // a 1 % jitter of the lattice (a fixed seed): the perturbation the instability grows from
        let mut rng = common::Rng(7);
        let dx = sim.scene.discretisation.dx;
        for i in 0..sim.p.n_owned {
            for a in 0..2 {
                sim.p.x[i][a] += rng.range(-0.01, 0.01) * dx;
            }
        }
        let mut worst = f64::INFINITY;
        while sim.t < sim.scene.time.t_end {
            sim.advance(&comm).unwrap();
            if sim.step.is_multiple_of(10) {
                worst = worst.min(min_pair_distance_over_dx(&sim));
            }
        }
        worst
    };
    let (without, with) = (index("0.0"), index("0.3"));
    println!("clumping index: {without:.3} without artificial stress, {with:.3} with");
    assert!(without < 0.5, "no clumping without artificial stress: {without}");
    assert!(with > 0.8, "clumping with artificial stress: {with}");
}

/// Plane shock of a symmetric flyer-plate impact against the Rankine–Hugoniot jump of the
/// material's linear Us–up Hugoniot: at 1 km/s the target behind the shock moves at up = 500
/// m/s and the shock runs at Us = c0 + s·up = 5940 m/s; both within 3 %.
#[test]
fn flyer_plate_shock_matches_the_hugoniot() {
    let text = std::fs::read_to_string("tests/data/flyer_plate.toml").unwrap();
    let mut sim = sim_of::<2>(&text, &[]);
    let comm = SerialComm::new();
    let target = 1u16;
    // the shock front: the largest x of a target particle moving faster than up/2
    let front = |sim: &Simulation<2>| {
        let p = &sim.p;
        (0..p.n_owned)
            .filter(|&i| p.body[i] == target && p.v[i][0] > 250.0)
            .map(|i| p.x[i][0])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let mut marks = Vec::new();
    for t_mark in [0.6e-6, 1.4e-6] {
        while sim.t < t_mark {
            sim.advance(&comm).unwrap();
        }
        marks.push((sim.t, front(&sim)));
    }
    let us = (marks[1].1 - marks[0].1) / (marks[1].0 - marks[0].0);
    // particle velocity: target particles well behind the front and ahead of the contact
    let p = &sim.p;
    let contact = (0..p.n_owned)
        .filter(|&i| p.body[i] == target)
        .map(|i| p.x[i][0])
        .fold(f64::INFINITY, f64::min);
    let (lo, hi) = (contact + 1.0e-3, marks[1].1 - 1.0e-3);
    let behind: Vec<f64> = (0..p.n_owned)
        .filter(|&i| p.body[i] == target && p.x[i][0] > lo && p.x[i][0] < hi)
        .map(|i| p.v[i][0])
        .collect();
    let up = behind.iter().sum::<f64>() / behind.len() as f64;
    println!(
        "Us = {us:.1} m/s (Hugoniot 5940), up = {up:.1} m/s (500), {} particles",
        behind.len()
    );
    assert!(behind.len() > 100);
    assert!((us / 5940.0 - 1.0).abs() < 0.03, "shock speed {us}");
    assert!((up / 500.0 - 1.0).abs() < 0.03, "particle velocity {up}");
}

/// The oblique impact coarsened to dx = 0.6 mm for CI, to t = 1.5 µs (the sphere inside the
/// plate: shocks, plasticity, failure, debris).
fn impact_run(out: &std::path::Path, ranks: &str, threads: &str, extra: &[&str]) -> (i32, String) {
    let mut args = vec![
        "run",
        "inputs/impact_oblique_45.toml",
        "-q",
        "--out",
        out.to_str().unwrap(),
        "--ranks",
        ranks,
        "--threads",
        threads,
        "--set",
        "discretisation.dx=6.0e-4",
        "--set",
        "time.t_end=1.5e-6",
        "--set",
        "output.interval=5.0e-7",
    ];
    args.extend(extra);
    let (code, _, err) = common::hsph(&args);
    (code, err)
}

const SAME: [&str; 3] = ["timeseries.csv", "final.csv", "probes/hole.csv"];

fn assert_same(a: &std::path::Path, b: &std::path::Path, what: &str) {
    for f in SAME {
        let read = |d: &std::path::Path| {
            std::fs::read(d.join(f)).unwrap_or_else(|e| panic!("{}: {e}", d.join(f).display()))
        };
        assert!(read(a) == read(b), "{what}: {f} differs");
    }
}

/// The impact gives the same bits on 1 rank, 4 ranks and 2 ranks × 2 threads (halos carry the
/// stress, energy, plastic strain, failure flag and gradient correction: a missing one shows
/// at subdomain boundaries only), and a run stopped on 4 ranks and continued on 3 from its
/// checkpoint ends with the same bits (checkpoints carry the solid fields).
#[test]
fn impact_same_bits_on_any_rank_count_and_across_a_restart() {
    let dir = common::temp_dir("impact");
    let one = dir.join("r1");
    let (code, err) = impact_run(&one, "1", "1", &[]);
    assert_eq!(code, 0, "{err}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(one.join("summary.json")).unwrap()).unwrap();
    assert!(summary["solid_particles"].as_u64().unwrap() > 4000, "{summary}");
    // the run did something a solid does: plastic flow and failed particles
    let fin = std::fs::read_to_string(one.join("final.csv")).unwrap();
    let head: Vec<&str> = fin.lines().next().unwrap().split(',').collect();
    let (eps, failed) = (
        head.iter().position(|h| *h == "eps_p").unwrap(),
        head.iter().position(|h| *h == "failed").unwrap(),
    );
    let rows: Vec<Vec<f64>> = fin
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    assert!(rows.iter().any(|r| r[eps] > 0.1), "no plastic flow");
    assert!(rows.iter().any(|r| r[failed] == 1.0), "no failure");
    for (ranks, threads) in [("4", "1"), ("2", "2")] {
        let d = dir.join(format!("r{ranks}t{threads}"));
        let (code, err) = impact_run(&d, ranks, threads, &[]);
        assert_eq!(code, 0, "{err}");
        assert_same(&one, &d, &format!("{ranks} ranks x {threads} threads"));
    }
    let b = dir.join("restart");
    let (code, err) = impact_run(
        &b,
        "4",
        "1",
        &["--set", "time.max_steps=25", "--set", "checkpoint.every_steps=25"],
    );
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = common::restart_to_end(&b, 3);
    assert_eq!(code, 0, "{err}");
    assert_same(&one, &b, "4 -> 3 restart");
}

/// Pair mode for solids (issue 85, `--interactions pairs`, the impact's own mode): each pair
/// of solid particles is visited once over the half lists and both get their share. The impact
/// then gives its own bits on 1, 3 and 8 ranks and on 2 ranks × 2 threads, conserves momentum
/// to round-off (no gravity, no wall: every pair term is equal and opposite), holds less than
/// a third of gather mode's lists, and stays within round-off grown over the run of gather
/// mode.
#[test]
fn impact_in_pair_mode_gives_the_same_bits_on_any_layout_and_stays_near_gather() {
    let dir = common::temp_dir("impact-pairs");
    let pairs = ["--interactions", "pairs"];
    let one = dir.join("r1");
    let (code, err) = impact_run(&one, "1", "1", &pairs);
    assert_eq!(code, 0, "{err}");
    for (ranks, threads) in [("3", "1"), ("8", "1"), ("2", "2")] {
        let d = dir.join(format!("r{ranks}t{threads}"));
        let (code, err) = impact_run(&d, ranks, threads, &pairs);
        assert_eq!(code, 0, "{err}");
        assert_same(&one, &d, &format!("pairs, {ranks} ranks x {threads} threads"));
    }
    // momentum Σ m v of every row of the time series against the first (kg m/s)
    let series = std::fs::read_to_string(one.join("timeseries.csv")).unwrap();
    let head: Vec<&str> = series.lines().next().unwrap().split(',').collect();
    let cols: Vec<usize> = ["momentum_x", "momentum_y", "momentum_z"]
        .iter()
        .map(|c| head.iter().position(|h| h == c).unwrap())
        .collect();
    let rows: Vec<Vec<f64>> = series
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    assert!(rows.len() >= 4, "{series}");
    let p0: Vec<f64> = cols.iter().map(|&c| rows[0][c]).collect();
    let size = p0.iter().map(|x| x.abs()).fold(0.0, f64::max);
    assert!(size > 0.1, "the sphere carries momentum: {p0:?}");
    for r in &rows {
        for (k, &c) in cols.iter().enumerate() {
            let drift = (r[c] - p0[k]).abs() / size;
            assert!(drift < 1e-13, "momentum component {k} drifts by {drift:e} of |p|");
        }
    }
    let gather = dir.join("gather");
    let (code, err) = impact_run(&gather, "1", "1", &["--interactions", "gather"]);
    assert_eq!(code, 0, "{err}");
    let lists = |d: &std::path::Path| {
        let s = common::summary(d);
        s["memory_parts_bytes"]["lists"].as_f64().unwrap()
    };
    let (lp, lg) = (lists(&one), lists(&gather));
    assert!(lp < lg / 3.0, "pair mode's lists {lp} B against gather's {lg} B");
    // every number of final.csv (positions in m, speeds in m/s, densities, pressures and
    // stresses in Pa, energies), relative to the larger of 1 and its size
    let read = |d: &std::path::Path| std::fs::read_to_string(d.join("final.csv")).unwrap();
    let (a, b) = (read(&one), read(&gather));
    assert!(a != b, "pair mode ran as gather mode");
    let mut worst = 0.0f64;
    for (la, lb) in a.lines().skip(1).zip(b.lines().skip(1)) {
        for (x, y) in la.split(',').zip(lb.split(',')) {
            let (x, y): (f64, f64) = (x.parse().unwrap(), y.parse().unwrap());
            worst = worst.max((x - y).abs() / x.abs().max(1.0));
        }
    }
    eprintln!("impact, pairs against gather: largest relative difference {worst:.2e}");
    assert!(worst < 1e-8, "pair mode differs from gather by {worst:e}");
}
