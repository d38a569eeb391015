//! Particles of several sizes (issue 35, docs/refinement.md): refinement regions replace the
//! scene's lattice cells by their 2^D children at set-up (volume and ids exact), momentum is
//! conserved to round-off across the size interface with either smoothing length, a refined
//! run gives the same bits on any number of ranks and threads and after a restart, still water
//! stays still, and bad refinement input is exit 2 naming the key.

use crate::common;

use common::cli::{assert_check_refuses, assert_input_error, hsph_in};
use common::Rng;
use hsph::comm::serial::SerialComm;
use hsph::particles::Kind;
use hsph::scene::{load_scene, load_scene_str, Scene};
use hsph::sim::Simulation;
use hsph::Vector;
use std::collections::BTreeSet;
use std::path::Path;

/// A periodic box of fluid (no walls, no body force) with a refined region in its middle:
/// `shape` "block" or "sphere", `h` "scene" or "level".
fn box_scene(dim: usize, shape: &str, h: &str) -> String {
    let n = if dim == 2 { 24.0 } else { 16.0 };
    let dx = 1.0 / 64.0;
    let l = n * dx;
    let v = |x: f64| vec![format!("{x:?}"); dim].join(", ");
    let region = match shape {
        "block" => format!("min = [{}]\nmax = [{}]", v(0.3 * l), v(0.7 * l)),
        _ => format!(
            "shape = \"sphere\"\ncentre = [{}]\nradius = {:?}",
            v(0.5 * l),
            0.25 * l
        ),
    };
    format!(
        r#"
dimension = {dim}
[domain]
min = [{zero}]
max = [{lmax}]
periodic = [{per}]
[discretisation]
dx = {dx:?}
h_over_dx = 1.3
[[material]]
name = "water"
rho0 = 1000.0
c0 = 20.0
[physics]
density_diffusion = "antuono"
delta = 0.1
artificial_viscosity = 0.05
laminar_viscosity = 1e-3
[[fluid]]
name = "f"
material = "water"
min = [{zero}]
max = [{lmax}]
[[refine]]
{region}
level = 1
smoothing_length = "{h}"
[time]
t_end = 1.0
"#,
        zero = v(0.0),
        lmax = v(l),
        per = vec!["true"; dim].join(", "),
    )
}

fn scene_of(text: &str) -> Scene {
    load_scene_str(text, Path::new("refined.toml"), "refined", &[])
        .unwrap()
        .0
}

/// The set-up replaces every coarse cell whose centre lies in the region by its 2^D children
/// of 1/2^D of the mass: the same total volume (Σ m/ρ) as the uniform scene to round-off, ids
/// unique and below the id bound, levels and h as asked.
fn check_set_up<const D: usize>(shape: &str, h: &str) {
    let text = box_scene(D, shape, h);
    let refined = scene_of(&text);
    let cut = text.find("[[refine]]").unwrap();
    let uniform = scene_of(&(text[..cut].to_string() + "[time]\nt_end = 1.0\n"));
    let p = hsph::setup::build_particles::<D>(&refined).unwrap();
    let q = hsph::setup::build_particles::<D>(&uniform).unwrap();
    let n = p.n_owned;
    let fine = (0..n).filter(|&i| p.level[i] == 1).count();
    let coarse_left = n - fine;
    assert_eq!(fine % (1 << D), 0, "{shape}: {fine} fine particles");
    assert_eq!(
        coarse_left + fine / (1 << D),
        q.n_owned,
        "{shape}: cells replaced by children"
    );
    assert!(fine > 0 && coarse_left > 0);
    let vol = |p: &hsph::particles::Particles<D>| (0..p.n_owned).map(|i| p.mass[i] / p.rho[i]).sum::<f64>();
    let (a, b) = (vol(&p), vol(&q));
    assert!((a - b).abs() <= 1e-12 * b, "{shape}: volume {a} against {b}");
    let ids: BTreeSet<u64> = p.id[..n].iter().copied().collect();
    assert_eq!(ids.len(), n, "{shape}: ids unique");
    let bound = hsph::scene::lattice::id_bound::<D>(&refined);
    assert!(*ids.last().unwrap() < bound);
    let m0 = q.mass[0];
    let h0 = refined.discretisation.h_over_dx * refined.discretisation.dx;
    for i in 0..n {
        let (want_m, level) = if p.level[i] == 1 {
            (m0 / (1 << D) as f64, 1)
        } else {
            (m0, 0)
        };
        assert!((p.mass[i] - want_m).abs() <= 1e-12 * m0, "{shape}: mass of {i}");
        if h == "level" {
            // the level's h in the core, the scene's at the boundary, never outside [h/2, h]
            assert!(p.h[i] <= h0 && p.h[i] >= 0.5 * h0 - 1e-15, "{}", p.h[i]);
            if level == 0 {
                assert_eq!(p.h[i], h0);
            }
        }
    }
    if h == "level" {
        assert!(
            (0..n).any(|i| p.h[i] == 0.5 * h0),
            "{shape}: no particle with the level's h"
        );
        assert!(
            (0..n).any(|i| p.level[i] == 1 && p.h[i] > 0.5 * h0),
            "{shape}: no transition"
        );
    }
}

#[test]
fn set_up_replaces_coarse_cells_by_their_children() {
    for shape in ["block", "sphere"] {
        for h in ["scene", "level"] {
            check_set_up::<2>(shape, h);
            check_set_up::<3>(shape, h);
        }
    }
}

/// Random velocities and a ±1 % density perturbation; rates recomputed.
fn perturb<const D: usize>(sim: &mut Simulation<D>, seed: u64) {
    let mut rng = Rng(seed);
    for i in 0..sim.p.n_owned {
        if sim.p.kind[i] == Kind::Fluid {
            sim.p.v[i] = Vector::<D>::from_fn(|_, _| rng.range(-0.3, 0.3));
            sim.p.rho[i] *= 1.0 + rng.range(-0.01, 0.01);
        }
    }
    sim.compute_density_rate(&SerialComm::new()).unwrap();
}

/// Largest per-step |ΔP|∞ / Σ m|v| over `steps` steps of a perturbed refined box; the mass
/// is checked unchanged to the bit.
fn momentum_drift<const D: usize>(shape: &str, h: &str, steps: usize) -> f64 {
    let comm = SerialComm::new();
    let mut sim = Simulation::<D>::new(&scene_of(&box_scene(D, shape, h)), &comm).unwrap();
    perturb(&mut sim, 7 + D as u64);
    conserves(&mut sim, steps, &format!("{D}D {shape} h = {h}"))
}

/// Advance `steps` steps, asserting each conserves the momentum to 1e-12 of Σ m|v| and the
/// mass to the bit; the largest relative change.
fn conserves<const D: usize>(sim: &mut Simulation<D>, steps: usize, what: &str) -> f64 {
    let comm = SerialComm::new();
    let m0 = sim.observables(&comm).unwrap().mass;
    let mut worst = 0.0f64;
    for _ in 0..steps {
        let before = sim.observables(&comm).unwrap().momentum;
        sim.advance(&comm).unwrap();
        let obs = sim.observables(&comm).unwrap();
        let scale: f64 = (0..sim.p.n_owned)
            .map(|i| sim.p.mass[i] * sim.p.v[i].norm())
            .sum();
        let rel = (obs.momentum - before).amax() / scale;
        assert!(
            rel <= 1e-12,
            "{what}: step {} changed the momentum by {rel:e}",
            sim.step
        );
        assert_eq!(obs.mass.to_bits(), m0.to_bits(), "{what}: mass changed");
        worst = worst.max(rel);
    }
    worst
}

#[test]
fn momentum_is_conserved_across_the_size_interface() {
    for h in ["level", "scene"] {
        let w2 = momentum_drift::<2>("block", h, 40);
        let w3 = momentum_drift::<3>("sphere", h, 15);
        eprintln!("h = {h}: worst per-step |ΔP|/Σm|v| 2D {w2:.2e}, 3D {w3:.2e}");
    }
}

/// The same box as an aluminium solid (Mie–Grüneisen, Johnson–Cook, artificial viscosity and
/// stress): a refined sphere region, random velocities of ±30 m/s; every step conserves the
/// momentum to round-off and the mass to the bit, with either smoothing length (the solid
/// passes take the pair's mean-h kernel like the fluid ones).
#[test]
fn a_refined_solid_conserves_momentum_across_the_size_interface() {
    for h in ["level", "scene"] {
        let text = box_scene(2, "sphere", h)
            .replace(
                "[[material]]\nname = \"water\"\nrho0 = 1000.0\nc0 = 20.0",
                "[[material]]\nname = \"water\"\nmodel = \"solid\"\nlibrary = \"al6061-t6\"",
            )
            .replace(
                "density_diffusion = \"antuono\"\ndelta = 0.1\nartificial_viscosity = 0.05\nlaminar_viscosity = 1e-3",
                "artificial_viscosity = 1.0\nartificial_stress = 0.3",
            )
            .replace("[[fluid]]", "[[solid]]");
        let comm = SerialComm::new();
        let mut sim = Simulation::<2>::new(&scene_of(&text), &comm).unwrap();
        assert!(sim.p.kind.iter().all(|k| *k == Kind::Solid), "a solid box");
        assert!(sim.p.level.contains(&1), "refined particles");
        let mut rng = Rng(35);
        for i in 0..sim.p.n_owned {
            sim.p.v[i] = Vector::<2>::from_fn(|_, _| rng.range(-30.0, 30.0));
        }
        let v0: std::collections::BTreeMap<u64, Vector<2>> =
            (0..sim.p.n_owned).map(|i| (sim.p.id[i], sim.p.v[i])).collect();
        conserves(&mut sim, 20, &format!("solid, h = {h}"));
        // the forces were not zero: the velocities changed, particle by particle (by id)
        let dv = (0..sim.p.n_owned)
            .map(|i| (sim.p.v[i] - v0[&sim.p.id[i]]).norm())
            .fold(0.0, f64::max);
        assert!(dv > 1.0, "h = {h}: largest velocity change {dv} m/s");
    }
}

/// A small refined dam break (inputs/dam_break_2d.toml, 40 steps): walls, gravity, a refined
/// block across the lower middle of the water column and the tank's floor beneath it (the
/// dummy wall refined with the water).
fn dam(h: &str) -> Scene {
    let path = common::repo_path("inputs/dam_break_2d.toml");
    let text = std::fs::read_to_string(&path).unwrap()
        + &format!(
            "\n[[refine]]\nmin = [0.03, -0.02]\nmax = [0.11, 0.15]\nlevel = 1\nsmoothing_length = \"{h}\"\n"
        );
    let sets = [
        "time.max_steps=40".to_string(),
        "output.format=\"none\"".to_string(),
    ];
    load_scene_str(&text, &path, "dam_break_2d", &sets).unwrap().0
}

/// A refined dam break gives the same bits on any layout, with stored lists, the list-free scan
/// and pair mode, for the scene's h, the level's h and the level's h with pairs of the larger h
/// (`pair_h = "max"`, whose lists keep a pair within κ max(h_i, h_j); its bits differ from the
/// mean h's, so the key is read).
#[test]
fn a_refined_run_gives_the_same_bits_on_any_layout() {
    let mut finals = Vec::new();
    for (h, larger) in [("level", false), ("scene", false), ("level", true)] {
        let mut s = dam(h);
        let h = if larger {
            s.discretisation.pair_h = hsph::kernel::sizes::PairH::Max;
            "level-max"
        } else {
            h
        };
        let base = common::run_layout(&s, 1, 1, &format!("refined-{h}-1"));
        let read = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap();
        let fin = read(&base, "final.csv");
        finals.push(fin.clone());
        // columns id,kind,body,level: a fluid and a wall particle of level 1
        let text = String::from_utf8_lossy(&fin);
        for kind in ["0", "1"] {
            assert!(
                text.lines()
                    .any(|l| l.split(',').skip(1).take(3).eq([kind, "0", "1"])),
                "no level-1 particle of kind {kind}"
            );
        }
        for (ranks, threads) in [(1, 2), (3, 1), (8, 1), (3, 2)] {
            let d = common::run_layout(&s, ranks, threads, &format!("refined-{h}-{ranks}-{threads}"));
            for f in ["final.csv", "timeseries.csv"] {
                assert!(
                    read(&d, f) == read(&base, f),
                    "h = {h}: {f} differs on {ranks} ranks × {threads} threads"
                );
            }
        }
        // lists kept within each pair's own support: the list-free scan finds the same pairs
        // (same bits), and pair mode keeps its own bits on any layout
        let mut lean = s.clone();
        lean.performance.neighbours = hsph::scene::NeighbourMode::Cells;
        let d = common::run_layout(&lean, 3, 2, &format!("refined-{h}-lean"));
        assert!(
            read(&d, "final.csv") == fin,
            "h = {h}: the list-free scan differs"
        );
        let mut pairs = s.clone();
        pairs.performance.interactions = hsph::scene::Interactions::Pairs;
        let one = common::run_layout(&pairs, 1, 1, &format!("refined-{h}-pairs-1"));
        for (lean, ranks, threads) in [(false, 3, 2), (true, 8, 1)] {
            let mut q = pairs.clone();
            if lean {
                q.performance.neighbours = hsph::scene::NeighbourMode::Cells;
            }
            let d = common::run_layout(&q, ranks, threads, &format!("refined-{h}-pairs-{ranks}-{lean}"));
            assert!(
                read(&d, "final.csv") == read(&one, "final.csv"),
                "h = {h}: pair mode differs on {ranks} × {threads} (lean {lean})"
            );
        }
    }
    assert!(finals[0] != finals[2], "pair_h = \"max\" gave the mean h's bits");
}

/// The same fact in 3D, without walls or gravity: the periodic box with a sphere of the level's
/// h, densities set so that the pressure is linear, p = p0 + G·x; at the particles a support or
/// more from the box's faces (the periodic seam breaks the linear field) that have a neighbour
/// of another h, the difference form gives dv/dt = −G/ρ_i to round-off, the symmetric form not.
#[test]
fn the_difference_form_is_exact_for_a_linear_pressure_in_3d() {
    let (p0, grad) = (2000.0, Vector::<3>::new(300.0, -500.0, 800.0));
    let residuals = |form: &str| -> Vec<f64> {
        let sets = [format!("physics.pressure_gradient=\"{form}\"")];
        let text = box_scene(3, "sphere", "level");
        let s = load_scene_str(&text, Path::new("refined.toml"), "refined", &sets)
            .unwrap()
            .0;
        let l = s.domain.max[0];
        let comm = SerialComm::new();
        let mut sim = Simulation::<3>::new(&s, &comm).unwrap();
        let eos = sim.model.materials[0];
        for i in 0..sim.p.n_owned {
            let p = p0 + grad.dot(&sim.p.x[i]);
            sim.p.rho[i] = eos.density(p);
        }
        sim.compute_acceleration(&comm).unwrap();
        let support = sim.model.kernel.support;
        let inside = |x: &Vector<3>| (0..3).all(|a| x[a] >= support && x[a] <= l - support);
        mixed_residuals(&sim, inside, |i| -grad / sim.p.rho[i], None)
    };
    the_difference_form_is_exact("3D", &residuals("difference"), &residuals("symmetric"));
}

/// |dv/dt − exact| / scale (`None`: relative to |exact|) at the owned fluid particles for
/// which `inside` holds and that have a neighbour of another h within their pair's support
/// (found by brute force).
fn mixed_residuals<const D: usize>(
    sim: &Simulation<D>,
    inside: impl Fn(&Vector<D>) -> bool,
    exact: impl Fn(usize) -> Vector<D>,
    scale: Option<f64>,
) -> Vec<f64> {
    let p = &sim.p;
    let kappa = sim.model.kernel.support / sim.model.kernel.h;
    (0..p.n_owned)
        .filter(|&i| p.kind[i] == Kind::Fluid && inside(&p.x[i]))
        .filter(|&i| {
            (0..p.n_owned)
                .any(|j| p.h[j] != p.h[i] && (p.x[i] - p.x[j]).norm() < 0.5 * kappa * (p.h[i] + p.h[j]))
        })
        .map(|i| {
            let e = exact(i);
            (p.acc[i] - e).norm() / scale.unwrap_or_else(|| e.norm())
        })
        .collect()
}

/// The difference form's residuals are round-off at more than 100 particles of mixed supports,
/// and the symmetric form's are not (so the check can fail).
fn the_difference_form_is_exact(what: &str, difference: &[f64], symmetric: &[f64]) {
    let worst = |r: &[f64]| r.iter().fold(0.0f64, |m, &e| m.max(e));
    assert!(
        difference.len() > 100,
        "{what}: {} particles of mixed supports",
        difference.len()
    );
    eprintln!(
        "{what}, {} particles: largest residual {:.2e} (difference), {:.2e} (symmetric)",
        difference.len(),
        worst(difference),
        worst(symmetric)
    );
    assert!(
        worst(difference) < 1e-10,
        "{what}, difference form: {:e}",
        worst(difference)
    );
    assert!(
        worst(symmetric) > 0.05,
        "{what}, symmetric form: {:e}",
        worst(symmetric)
    );
}

/// The difference form of the pressure term (gather mode) on the refined dam break with the
/// level's h: the bits of one rank and thread on 3 ranks × 2 threads and 8 ranks, and not the
/// symmetric form's bits (the form applies somewhere).
#[test]
fn the_difference_form_gives_the_same_bits_on_any_layout() {
    let mut s = dam("level");
    s.physics.pressure_gradient = hsph::scene::PressureGradient::Difference;
    let read = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap();
    let base = common::run_layout(&s, 1, 1, "refined-difference-1");
    for (ranks, threads) in [(3, 2), (8, 1)] {
        let d = common::run_layout(
            &s,
            ranks,
            threads,
            &format!("refined-difference-{ranks}-{threads}"),
        );
        for f in ["final.csv", "timeseries.csv"] {
            assert!(
                read(&d, f) == read(&base, f),
                "{f} differs on {ranks} ranks × {threads} threads"
            );
        }
    }
    let symmetric = common::run_layout(&dam("level"), 1, 1, "refined-symmetric-1");
    assert!(read(&symmetric, "final.csv") != read(&base, "final.csv"));
}

#[test]
fn a_refined_run_restarts_to_the_uninterrupted_bits() {
    let dir = common::temp_dir("refined-restart");
    let scene = dir.join("scene.toml");
    let text = std::fs::read_to_string(common::repo_path("inputs/hydrostatic_2d_refined.toml")).unwrap();
    // balanced on pairs: the set-up weighs the sites, the resumed run the checkpoint's
    // particles (checks every 10 steps)
    let text = format!("{text}\n[balance]\nload = \"pairs\"\ncheck_every = 10\n");
    std::fs::write(&scene, text).unwrap();
    let s = scene.to_str().unwrap();
    let run = |out: &str, extra: &[&str]| {
        let mut args = vec!["run", s, "-q", "--out", out, "--set", "time.max_steps=60"];
        args.extend(extra);
        let o = hsph_in(&dir, &args);
        assert_eq!(o.status.code(), Some(0), "{}", common::cli::stderr(&o));
    };
    run("whole", &[]);
    run("legs", &["--ranks", "3", "--set", "checkpoint.every_steps=25"]);
    // continue from step 50 (the checkpoints kept: 50 and 60) on 2 ranks, over the files the
    // first leg wrote beyond it
    let cp = dir.join("legs/checkpoints/step-0000000050");
    assert!(cp.join("manifest.json").is_file());
    let o = hsph_in(
        &dir,
        &["run", "--restart", cp.to_str().unwrap(), "-q", "--ranks", "2"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", common::cli::stderr(&o));
    for f in ["final.csv", "timeseries.csv"] {
        let a = std::fs::read(dir.join("whole").join(f)).unwrap();
        let b = std::fs::read(dir.join("legs").join(f)).unwrap();
        assert!(a == b, "{f} of the restarted run differs");
    }
}

/// The issue's still water: the shipped scene with a refined box, its set-up relaxation, dummy
/// walls of lattice volume and Fourtakas's density diffusion, settled for 0.3 s before t = 0
/// (`time.settle`: without it the lattice's acoustic transient decides which run reads best at
/// any instant; docs/refinement.md §2), then 1 s (70 acoustic periods). Facts: the largest speed
/// over the whole second below 1 % of sqrt(gH) (measured 0.32 %, at the surface's corners; 1.51 %
/// unsettled), no fluid pair closer than half the fine spacing, no particle in a wall, and the
/// pressure error of docs/validation.md §2 at t = 1 s within the issue's 1.1 × the settled
/// uniform dx/2 tank of the same physics (`hydrostatic_2d.toml` with dx = 0.01 m, the same
/// wall volume and diffusion: 0.2795 %; measured 0.2943 % = 1.05 ×, at the bottom row under the
/// box's lower corners) and within 1.1 × its 0.2123 % around the box (measured 0.2188 %).
#[test]
fn still_water_with_a_refined_box_stays_still() {
    let s = load_scene(
        &common::repo_path("inputs/hydrostatic_2d_refined.toml"),
        &["time.settle=0.3".to_string(), "output.interval=0.01".to_string()],
    )
    .unwrap()
    .0;
    let out = common::run_layout(&s, 1, 2, "refined-still");
    // the largest speed over the second (every 10 ms), not only at its end
    let series = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    let mut rows = series.lines();
    let k = rows
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == "max_speed")
        .unwrap();
    let fastest = rows
        .map(|l| l.split(',').nth(k).unwrap().parse::<f64>().unwrap())
        .fold(0.0, f64::max);
    let over = fastest / (9.81f64 * 0.5).sqrt();
    assert!(
        over < 0.01,
        "largest speed over 1 s {:.3} % of sqrt(gH)",
        100.0 * over
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let e = |k: &str| summary["errors"][k].as_f64().unwrap();
    let (ev, ep) = (e("max_speed_over_sqrt_gh"), e("pressure_linf_below_mid_depth"));
    eprintln!(
        "refined still water: speed {:.3} %, pressure {:.3} %",
        100.0 * ev,
        100.0 * ep
    );
    assert!(ev < 0.005, "max speed {:.3} % of sqrt(gH)", 100.0 * ev);
    // the settled uniform dx/2 tank's errors at t = 1 s, over the tank and around the box
    let (fine_tank, fine_box) = (0.002795, 0.002123);
    assert!(ep <= 1.1 * fine_tank, "pressure error {:.3} %", 100.0 * ep);
    assert_eq!(e("fluid_in_walls_fraction"), 0.0);
    // closest pair of fluid particles, by brute force over final.csv
    let text = std::fs::read_to_string(out.join("final.csv")).unwrap();
    let mut lines = text.lines();
    let cols: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| cols.iter().position(|c| *c == name).unwrap();
    let (kx, ky, kk, kl, kp) = (at("x"), at("y"), at("kind"), at("level"), at("p"));
    let mut pts = Vec::new();
    let mut fine = 0;
    // the pressure error below mid-depth within a coarse spacing of the box (0.3–0.7 × 0.1–0.4
    // m): H = 0.5 m, ρ0 = 1000 kg/m³, g = 9.81 m/s² as in the scene
    let (h, rho_g) = (0.5, 1000.0 * 9.81);
    let mut box_error = 0.0f64;
    for l in lines {
        let v: Vec<&str> = l.split(',').collect();
        if v[kk] == "0" {
            let (x, y) = (v[kx].parse::<f64>().unwrap(), v[ky].parse::<f64>().unwrap());
            pts.push((x, y));
            fine += usize::from(v[kl] == "1");
            if y < 0.5 * h && (0.28..0.72).contains(&x) && (0.08..0.42).contains(&y) {
                let p: f64 = v[kp].parse().unwrap();
                box_error = box_error.max((p - rho_g * (h - y)).abs() / (rho_g * h));
            }
        }
    }
    assert_eq!(fine, 1200, "the box holds 20 × 15 cells of four particles");
    eprintln!("around the box: pressure {:.3} %", 100.0 * box_error);
    assert!(
        box_error <= 1.1 * fine_box,
        "pressure error around the box {:.3} %",
        100.0 * box_error
    );
    let mut closest = f64::INFINITY;
    for (i, a) in pts.iter().enumerate() {
        for b in &pts[i + 1..] {
            closest = closest.min(((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt());
        }
    }
    let half_fine = 0.25 * s.discretisation.dx;
    assert!(
        closest > half_fine,
        "closest fluid pair {closest} m ≤ half the fine spacing {half_fine} m"
    );
}

/// The uniform still tank's lattice is the set-up relaxation's fixed point: in a full support
/// Σ V_j ∇W_ij vanishes by symmetry, walls count as filled space, and the rows whose support the
/// free surface cuts are held (`shifting::RELAX_NEAR`). 50 iterations move no fluid particle
/// by more than 1e-9 dx (measured 4e-15 dx). Under δ⁺ shifting's 0.9 D rule (the rule
/// before 2026-11-29) the row 2 dx below the top row (∇·r = 0.969 D) climbed into the surface
/// rows and the column below followed: this test read a particle moved by 7.8 mm = 0.39 dx,
/// and the refined tank took a 20 Pa step from it (docs/refinement.md §2).
#[test]
fn relaxing_a_uniform_tank_leaves_its_lattice() {
    let dir = common::temp_dir("relax-uniform");
    let final_positions = |relax: u32| {
        let out = dir.join(format!("relax{relax}"));
        let set = format!("discretisation.relax={relax}");
        let (code, _, err) = common::run_file(
            "inputs/hydrostatic_2d.toml",
            &out,
            (1, 1),
            &[&set, "time.t_end=1e-9"],
        );
        assert_eq!(code, 0, "{err}");
        let text = std::fs::read_to_string(out.join("final.csv")).unwrap();
        let mut lines = text.lines();
        let cols: Vec<&str> = lines.next().unwrap().split(',').collect();
        let at = |name: &str| cols.iter().position(|c| *c == name).unwrap();
        let (ki, kk, kx, ky) = (at("id"), at("kind"), at("x"), at("y"));
        lines
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|v| v[kk] == "0")
            .map(|v| {
                let f = |k: usize| v[k].parse::<f64>().unwrap();
                (v[ki].parse::<u64>().unwrap(), (f(kx), f(ky)))
            })
            .collect::<std::collections::BTreeMap<_, _>>()
    };
    let (lattice, relaxed) = (final_positions(0), final_positions(50));
    assert_eq!(lattice.len(), 1250);
    assert_eq!(lattice.len(), relaxed.len());
    let dx = 0.02;
    let moved = lattice
        .iter()
        .map(|(id, a)| {
            let b = relaxed[id];
            (a.0 - b.0).hypot(a.1 - b.1)
        })
        .fold(0.0f64, f64::max);
    assert!(moved < 1e-9 * dx, "a fluid particle moved {moved} m");
}

/// A dummy wall keeps the water in where the smoothing length varies beside it. The refined
/// tank with the box taken down through the floor and the level's h: the spurious force of
/// the h ramp at the floor (`docs/refinement.md` §1) carried two fluid particles 3.8 mm
/// through the floor by t = 0.1 s before dummy walls bounced fluid that crosses their face
/// (`WallSurface::bounce`; 8 particles lost by t = 1 s). Now, at t = 0.15 s, every fluid
/// particle is inside the tank, none was removed, and the bits are the same on 1 and 3 ranks.
#[test]
fn a_dummy_floor_keeps_the_water_beside_a_ramp_of_h() {
    let sets: Vec<String> = [
        "refine.0.min=[0.3,-0.1]",
        "refine.0.smoothing_length=\"level\"",
        "time.t_end=0.15",
    ]
    .map(String::from)
    .to_vec();
    let s = load_scene(&common::repo_path("inputs/hydrostatic_2d_refined.toml"), &sets)
        .unwrap()
        .0;
    let run = |ranks: usize| {
        let out = common::run_layout(&s, ranks, 1, &format!("dummy-bounce-{ranks}"));
        let removed = std::fs::read_to_string(out.join("removed.csv")).unwrap();
        assert_eq!(removed.lines().count(), 1, "removed: {removed}");
        std::fs::read_to_string(out.join("final.csv")).unwrap()
    };
    let one = run(1);
    let mut lines = one.lines();
    let cols: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| cols.iter().position(|c| *c == name).unwrap();
    let (kx, ky, kk) = (at("x"), at("y"), at("kind"));
    let mut fluid = 0;
    for l in lines {
        let v: Vec<&str> = l.split(',').collect();
        if v[kk] == "0" {
            fluid += 1;
            let (x, y) = (v[kx].parse::<f64>().unwrap(), v[ky].parse::<f64>().unwrap());
            assert!(
                (0.0..=1.0).contains(&x) && y >= 0.0,
                "fluid outside the tank: {l}"
            );
        }
    }
    // 50 × 25 cells of the tank, the box's 20 × 20 of them in four particles each
    assert_eq!(fluid, 1250 + 3 * 400);
    assert!(one == run(3), "final.csv differs on 3 ranks");
}

/// Under the set-up's linear pressure p = ρ0 g (H − y) the renormalised difference form
/// (`physics.pressure_gradient = "difference"`) gives every particle it applies to its exact
/// acceleration −∇p/ρ_i + g to round-off, where the symmetric form leaves the mean-h kernel's
/// residual −2 (p_i/ρ_i) Σ_j V_j ∇_i W_ij (docs/refinement.md §1). The still tank with the
/// level's h at t = 0, without relaxation: the fluid particles a support or more from the walls
/// and the surface that have a neighbour of another h (found here by brute force).
#[test]
fn the_difference_form_balances_a_linear_pressure_where_h_varies() {
    let residuals = |form: &str| -> Vec<f64> {
        let sets: Vec<String> = [
            "refine.0.smoothing_length=\"level\"".to_string(),
            "discretisation.relax=0".to_string(),
            format!("physics.pressure_gradient=\"{form}\""),
        ]
        .to_vec();
        let s = load_scene(&common::repo_path("inputs/hydrostatic_2d_refined.toml"), &sets)
            .unwrap()
            .0;
        let comm = SerialComm::new();
        let mut sim = Simulation::<2>::new(&s, &comm).unwrap();
        sim.compute_acceleration(&comm).unwrap();
        let (g, support) = (sim.model.g, sim.model.kernel.support);
        let (rho0, depth) = (1000.0, 0.5);
        // a support or more from the side walls, the floor and the surface
        let inside = |x: &Vector<2>| {
            x[0] >= support && x[0] + support <= 1.0 && x[1] >= support && x[1] + support <= depth
        };
        let exact = |i: usize| Vector::<2>::new(0.0, rho0 * g.norm() / sim.p.rho[i]) + g;
        // in units of g: the residual the difference form removes is of order g here
        mixed_residuals(&sim, inside, exact, Some(g.norm()))
    };
    the_difference_form_is_exact("2D tank", &residuals("difference"), &residuals("symmetric"));
}

/// `hsph check` warns of the level's h only where it drives a current: a fluid under
/// hydrostatic pressure (the adaptive solitary wave), not the scene's h (the refined tank) nor a
/// fluid without a hydrostatic column (the refined Poiseuille channel, driven by a body force).
#[test]
fn the_level_h_warning_names_the_region_under_hydrostatic_pressure() {
    let warn = |f: &str, sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let s = load_scene(&common::repo_path(f), &sets).unwrap().0;
        hsph::scene::refine::level_h_warnings(&s)
    };
    let w = warn("inputs/solitary_wave_adaptive.toml", &[]);
    assert!(
        w.len() == 1 && w[0].starts_with("refine[0] gives fluid `water`"),
        "{w:?}"
    );
    // the shipped band (0.32 m, four supports of 0.08 m) is named and not told to widen
    assert!(w[0].contains("transition of 0.320 m (4.0 supports)"), "{w:?}");
    assert!(!w[0].contains("a wider transition"), "{w:?}");
    // and told what a wider one costs (docs/validation.md §7: 0.96 m, 715.9 s against 472.0 s)
    assert!(
        w[0].contains("twelve supports cost it 1.8 % and took 1.5 times as long"),
        "{w:?}"
    );
    assert!(warn("inputs/hydrostatic_2d_refined.toml", &[]).is_empty());
    let tank = warn(
        "inputs/hydrostatic_2d_refined.toml",
        &["refine.0.smoothing_length=\"level\""],
    );
    // the default band, one support, is told the width that kept the solitary wave's level
    assert!(
        tank.len() == 1 && tank[0].contains("(1.0 supports)") && tank[0].contains("a wider transition"),
        "{tank:?}"
    );
    assert!(warn("inputs/poiseuille_2d_refined.toml", &[]).is_empty());
}

/// `hsph check` warns of walls refined with their level's h and no fluid with them (the
/// Lobovsky tank's walls refined alone read the run-up's load 14–19 % low, docs/pressure.md
/// §2e), and not when the walls keep the scene's h, the fluid is refined with them, or pairs
/// take the larger h.
#[test]
fn the_wall_h_warning_names_walls_refined_finer_than_the_fluid() {
    let path = common::repo_path("inputs/dam_break_lobovsky.toml");
    let base = std::fs::read_to_string(&path).unwrap();
    let warn = |bodies: &str, h: &str, sets: &[&str]| {
        let text = format!(
            "{base}\n[[refine]]\nmin = [1.46, -0.05]\nmax = [1.66, 0.2]\nlevel = 2\nbodies = {bodies}\n\
             smoothing_length = \"{h}\"\n"
        );
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let s = load_scene_str(&text, &path, "scene", &sets).unwrap().0;
        hsph::scene::refine::wall_h_warnings(&s)
    };
    let w = warn("[\"tank\"]", "level", &[]);
    assert!(
        w.len() == 1 && w[0].starts_with("refine[0] gives wall `tank` its level's h"),
        "{w:?}"
    );
    assert!(
        w[0].contains("pair_h = \"max\"") && w[0].contains("14-19 % low"),
        "{w:?}"
    );
    assert!(warn("[\"tank\"]", "scene", &[]).is_empty());
    assert!(warn("[\"column\", \"tank\"]", "level", &[]).is_empty());
    assert!(warn("[\"tank\"]", "level", &["discretisation.pair_h=\"max\""]).is_empty());
}

/// Poiseuille start-up with refined bands along both plates (`inputs/poiseuille_2d_refined.toml`,
/// cut to t = 0.6 s): the velocity error against Morris et al.'s series is within the issue's
/// max(0.5 %, 1.1 × the uniform L/50 run's 0.09 %) = 0.5 % (measured 0.46 %; 0.47 % at t = 2 s)
/// with at most 0.6 × the particles of the uniform run at the fine spacing (measured 1 065 against 1 908, 0.56 ×);
/// refined plates carry fine particles (without them the fluid slips: 1.7 %).
#[test]
fn poiseuille_with_refined_bands_is_as_accurate_as_the_target() {
    let path = common::repo_path("inputs/poiseuille_2d_refined.toml");
    let sets = ["time.t_end=0.6".to_string(), "reference.times=[0.6]".to_string()];
    let s = load_scene(&path, &sets).unwrap().0;
    let uniform = load_scene(
        &common::repo_path("inputs/poiseuille_2d.toml"),
        &["discretisation.dx=2e-5".to_string()],
    )
    .unwrap()
    .0;
    let out = common::run_layout(&s, 1, 2, "refined-poiseuille");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let e = summary["errors"]["velocity_linf_t0.6"].as_f64().unwrap();
    let n = summary["particles"].as_u64().unwrap();
    let n_fine = hsph::scene::lattice::count_particles::<2>(&uniform);
    eprintln!(
        "refined Poiseuille: error {:.3} %, {n} particles against {n_fine}",
        100.0 * e
    );
    assert!(e <= 0.005, "velocity error {:.3} % > 0.5 %", 100.0 * e);
    assert!(
        (n as f64) <= 0.6 * n_fine as f64,
        "{n} particles > 0.6 × {n_fine}"
    );
    // fine particles in both plates: the walls were refined with the fluid
    let text = std::fs::read_to_string(out.join("final.csv")).unwrap();
    let mut lines = text.lines();
    let cols: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| cols.iter().position(|c| *c == name).unwrap();
    let fine_walls = lines
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|v| v[at("kind")] != "0" && v[at("level")] == "1")
        .count();
    assert_eq!(
        fine_walls,
        2 * 2 * 15 * 4,
        "two coarse rows of 15 cells per plate, 4 each"
    );
}

#[test]
fn bad_refinement_input_is_exit_2_naming_the_key() {
    let dir = common::temp_dir("refine-bad");
    let scene = common::repo_path("inputs/hydrostatic_2d_refined.toml");
    let refused = |sets: &[&str], needles: &[&str]| assert_check_refuses(&dir, &scene, sets, needles);
    refused(&["refine.0.level=0"], &["--set", "refine[0].level", "1, 2 or 3"]);
    refused(&["refine.0.level=4"], &["refine[0].level", "got 4"]);
    refused(
        &["discretisation.relax=5000"],
        &["discretisation.relax", "got 5000", "at most 1000"],
    );
    refused(&["discretisation.relax=-1"], &["discretisation.relax"]);
    // the relaxation's shifting row gathers over full lists: no pair mode
    refused(
        &["performance.interactions=\"pairs\""],
        &["performance.interactions", "discretisation.relax", "shift"],
    );
    refused(
        &["refine.0.max=[0.7, 2.0]"],
        &["refine[0].max", "outside the domain"],
    );
    refused(
        &["refine.0.min=[-5.0, 0.1]"],
        &["refine[0].min", "outside the domain"],
    );
    // a dummy wall may be refined (the tank), a repulsive one not
    refused(
        &[
            "refine.0.bodies=[\"tank\"]",
            "wall.0.method=\"repulsive\"",
            "wall.0.volume=\"mass\"",
        ],
        &["refine[0].bodies[0]", "without dummy particles", "water"],
    );
    refused(
        &["refine.0.bodies=[\"sea\"]"],
        &[
            "refine[0].bodies[0]",
            "no fluid, solid or dummy wall",
            "water, tank",
        ],
    );
    refused(&["refine.0.transition=-1.0"], &["refine[0].transition", "≥ 0"]);
    // an empty list would read as every body; a name given twice is a slip
    refused(
        &["refine.0.bodies=[]"],
        &["refine[0].bodies", "names no body", "leave `bodies` out"],
    );
    refused(
        &["refine.0.bodies=[\"water\", \"tank\", \"water\"]"],
        &["refine[0].bodies[2]", "names `water` a second time", "bodies[0]"],
    );
    // a negative or fractional level gets the level's range, not its integer type's
    refused(&["refine.0.level=-1"], &["refine[0].level", "expected 1, 2 or 3"]);
    refused(
        &["refine.0.level=1.5"],
        &["refine[0].level", "expected 1, 2 or 3"],
    );
    refused(
        &["refine.0.smoothing_length=\"half\""],
        &["smoothing_length", "scene", "level"],
    );
    // a second region of another level overlapping the first, for the same body
    let text = std::fs::read_to_string(&scene).unwrap()
        + "\n[[refine]]\nshape = \"sphere\"\ncentre = [0.7, 0.4]\nradius = 0.05\nlevel = 2\n";
    let two = dir.join("two.toml");
    std::fs::write(&two, &text).unwrap();
    let o = hsph_in(&dir, &["check", two.to_str().unwrap()]);
    assert_input_error(
        &o,
        &[
            "refine[1]",
            "overlaps refine[0]",
            "level 2 against 1",
            "water",
            "two.toml",
        ],
    );
    // the same sphere moved away is accepted; of one level, overlapping is accepted too
    let apart = text.replace("centre = [0.7, 0.4]", "centre = [0.85, 0.3]");
    std::fs::write(&two, apart).unwrap();
    assert_eq!(
        hsph_in(&dir, &["check", two.to_str().unwrap()]).status.code(),
        Some(0)
    );
    let same = text.replace("level = 2", "level = 1");
    std::fs::write(&two, same).unwrap();
    assert_eq!(
        hsph_in(&dir, &["check", two.to_str().unwrap()]).status.code(),
        Some(0)
    );
}

/// `physics.pressure_gradient = "difference"` needs supports of several h (a region with the
/// level's h) and whole supports in one visit (gather mode); a misspelt value names both forms.
#[test]
fn bad_pressure_gradient_input_is_exit_2_naming_the_key() {
    let dir = common::temp_dir("pressure-bad");
    let scene = common::repo_path("inputs/hydrostatic_2d_refined.toml");
    let refused = |sets: &[&str], needles: &[&str]| assert_check_refuses(&dir, &scene, sets, needles);
    let difference = "physics.pressure_gradient=\"difference\"";
    refused(
        &[difference],
        &["physics.pressure_gradient", "smoothing_length = \"level\""],
    );
    refused(
        &[
            difference,
            "refine.0.smoothing_length=\"level\"",
            "discretisation.relax=0",
            "performance.interactions=\"pairs\"",
        ],
        &["physics.pressure_gradient", "interactions = \"gather\""],
    );
    refused(
        &["physics.pressure_gradient=\"differences\""],
        &["physics.pressure_gradient", "symmetric", "difference"],
    );
}

/// Load balance by cost: with `balance.load = "pairs"` a refined particle weighs its
/// neighbours. The refined tank on 3 ranks along x (the middle one holding most of the refined
/// box), with either smoothing length: the initial split, which weighs each site by its
/// expected list length, is already within 1.1 in pairs at every check (the count split was
/// 1.60 with the scene's h, 1.21 with the level's), so no rebalance is needed at threshold
/// 1.1; at threshold 1.01 the checks rebalance and stay within 1.1. The bits stay those of one
/// rank.
#[test]
fn pairs_load_balances_a_refined_tank() {
    for (h, threshold) in [("scene", 1.1), ("level", 1.1), ("scene", 1.01)] {
        let overrides: Vec<String> = [
            "time.max_steps=30".to_string(),
            "balance.load=\"pairs\"".to_string(),
            "balance.check_every=5".to_string(),
            format!("balance.threshold={threshold}"),
            format!("refine.0.smoothing_length=\"{h}\""),
        ]
        .to_vec();
        let s = load_scene(
            &common::repo_path("inputs/hydrostatic_2d_refined.toml"),
            &overrides,
        )
        .unwrap()
        .0;
        let tag = format!("refined-balance-{h}-{threshold}");
        let one = common::run_layout(&s, 1, 1, &format!("{tag}-1"));
        let three = common::run_layout(&s, 3, 1, &format!("{tag}-3"));
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(three.join("summary.json")).unwrap()).unwrap();
        let imbalance = summary["imbalance"].as_f64().unwrap();
        let rebalances = summary["rebalances"].as_u64().unwrap();
        if threshold > 1.05 {
            assert_eq!(
                rebalances, 0,
                "h {h}: the weighed initial split needed rebalancing: {summary}"
            );
        } else {
            assert!(rebalances >= 1, "h {h}: {summary}");
        }
        assert!(imbalance <= 1.1, "h {h}: pair imbalance {imbalance}");
        eprintln!("pairs-balanced refined tank, h {h}, threshold {threshold}: imbalance {imbalance:.3}, {rebalances} rebalances");
        let read = |d: &Path| std::fs::read(d.join("final.csv")).unwrap();
        assert!(read(&one) == read(&three), "h {h}: final.csv differs on 3 ranks");
    }
}

/// `hsph check`'s count (`count_particles`, from the lattice ranges alone) is the number of
/// particles the set-up builds for block regions over the fluid, over the tank's corner
/// (its dummy wall refined too), over the fluid only and over one coarse site; and the memory
/// estimate's list entries per particle (the lattice's neighbours times
/// [`hsph::scene::lattice::list_weight`]) lie between 0.95 and 2 times those the set-up lists
/// (they were 1.01–1.6 ×), with the scene's h at levels 1 and 2 (a fine particle then lists
/// 2^(ℓD) times a coarse one's neighbours) and with the level's h.
#[test]
fn the_check_counts_the_particles_and_lists_that_the_set_up_builds() {
    let text = include_str!("../inputs/hydrostatic_2d_refined.toml");
    let path = Path::new("hydrostatic_2d_refined.toml");
    let variants: [&[&str]; 6] = [
        &[],
        &["refine[0].min=[-0.1, -0.1]", "refine[0].max=[0.3, 0.3]"],
        &[
            "refine[0].bodies=[\"water\"]",
            "refine[0].min=[-0.1, -0.1]",
            "refine[0].max=[0.3, 0.3]",
        ],
        &["refine[0].min=[0.509, 0.249]", "refine[0].max=[0.511, 0.251]"],
        &["refine[0].level=2"],
        &["refine[0].smoothing_length=\"level\""],
    ];
    let comm = SerialComm::new();
    for sets in variants {
        let sets: Vec<String> = sets.iter().map(|x| x.to_string()).collect();
        let (s, _) = load_scene_str(text, path, "scene", &sets).unwrap();
        let sim = Simulation::<2>::new(&s, &comm).unwrap();
        let built = sim.p.n_owned;
        assert_eq!(
            hsph::scene::lattice::count_particles::<2>(&s),
            built as u64,
            "{sets:?}"
        );
        // the set-up's lists (both directions) against the estimate's per particle
        let listed = sim.nl.entries() as f64 / built as f64;
        let full = if sim.pair_mode { 2.0 * listed } else { listed };
        let estimate = s.discretisation.lattice_neighbours(2)
            * hsph::scene::lattice::list_weight(&hsph::scene::lattice::body_sites::<2>(&s));
        assert!(
            estimate >= 0.95 * full && estimate <= 2.0 * full,
            "{sets:?}: estimate {estimate:.1}, built {full:.1}"
        );
    }
}

/// `hsph check` on a sphere region: the estimate counts the region's box before building; when
/// the built count differs, a note says so and which way the memory estimate errs.
#[test]
fn the_check_notes_an_estimate_counted_on_boxes() {
    let text = include_str!("../inputs/hydrostatic_2d_refined.toml").replace(
        "min = [0.3, 0.1]\nmax = [0.7, 0.4]\nlevel = 1",
        "shape = \"sphere\"\ncentre = [0.5, 0.25]\nradius = 0.1\nlevel = 1",
    );
    let dir = common::temp_dir("check-note");
    let scene = dir.join("sphere.toml");
    std::fs::write(&scene, &text).unwrap();
    let (code, out, err) = common::hsph(&["check", scene.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let number = |prefix: &str| -> u64 {
        let line = out.lines().find_map(|l| l.strip_prefix(prefix)).expect(prefix);
        line.split_whitespace().next().unwrap().parse().unwrap()
    };
    let (estimated, built) = (number("estimate    "), number("particles   "));
    assert!(
        estimated > built,
        "a sphere fills part of its box: {estimated} against {built}"
    );
    assert!(
        out.contains(&format!("{built} are built")) && out.contains("upper bound"),
        "{out}"
    );
}
