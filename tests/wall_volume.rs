//! Dummy walls that keep their lattice cell's volume (`[[wall]] volume = "lattice"`,
//! docs/refinement.md §2): beside a fluid of hydrostatic mass the zeroth moment Σ_j V_j ∇W_ij
//! vanishes across the wall's face, the wall's mass follows its extrapolated density, runs give
//! the same bits on any layout, and the key is refused where it means nothing.

use crate::common;

use common::cli::assert_check_refuses;
use hsph::comm::serial::SerialComm;
use hsph::particles::Kind;
use hsph::scene::load_scene;
use hsph::sim::Simulation;
use hsph::Vector;

/// The largest h |Σ_j V_j ∇_i W_ij| (V_j = m_j/ρ_j, every neighbour by brute force) at the
/// uniform still tank's fluid particles within a support of the floor and more than a support
/// from the side walls, after the set-up's wall extrapolation, and the dummy floor's largest
/// density (kg/m³) and |m_w − ρ_w dx²| / (ρ_w dx²).
fn floor_moment(volume: &str) -> (f64, f64, f64) {
    let sets = [format!("wall.0.volume=\"{volume}\"")];
    let s = load_scene(&common::repo_path("inputs/hydrostatic_2d.toml"), &sets)
        .unwrap()
        .0;
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&s, &comm).unwrap();
    sim.compute_acceleration(&comm).unwrap();
    let (kern, dx) = (&sim.model.kernel, s.discretisation.dx);
    let p = &sim.p;
    let (mut worst, mut rho_floor, mut mass_dev) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..p.n_owned {
        let x = p.x[i];
        if p.kind[i] == Kind::Dummy && x[1] < 0.0 && x[0] > 0.0 && x[0] < 1.0 {
            rho_floor = rho_floor.max(p.rho[i]);
            let lattice = p.rho[i] * dx * dx;
            mass_dev = mass_dev.max((p.mass[i] - lattice).abs() / lattice);
        }
        let away = x[0] > kern.support && x[0] + kern.support < 1.0;
        if p.kind[i] != Kind::Fluid || x[1] > kern.support || !away {
            continue;
        }
        let mut sum = Vector::<2>::zeros();
        for j in 0..p.n_owned {
            let r = x - p.x[j];
            let d = r.norm();
            if j != i && d < kern.support {
                sum += r * (kern.dw_dr_over_r(d) * p.mass[j] / p.rho[j]);
            }
        }
        worst = worst.max(sum.norm() * kern.h);
    }
    (worst, rho_floor, mass_dev)
}

/// The still tank's fluid has hydrostatic mass, ρ(y) dx², so its volume is dx² on its lattice.
/// With `volume = "lattice"` every dummy particle of the floor weighs ρ_w dx² (to round-off) and
/// the zeroth moment beside the floor is round-off (measured 1e-15); with the default fixed
/// mass ρ0 dx² the floor's particles, compressed to ρ_w ≈ 1004 kg/m³, count 0.4 % short and the
/// moment is 2e-3 (measured), a force 2 p/ρ Σ V_j ∇W_ij of about 0.05 g that the bottom rows
/// balance with 15–20 Pa of extra pressure (docs/refinement.md §2).
#[test]
fn a_wall_of_lattice_volume_closes_the_floor_support() {
    let (lattice, rho_w, dev) = floor_moment("lattice");
    let (mass, rho_m, dev_m) = floor_moment("mass");
    eprintln!("h |Σ V ∇W| beside the floor: lattice {lattice:.2e}, mass {mass:.2e}; ρ_w {rho_w}");
    assert!(rho_w > 1003.0 && rho_m == rho_w, "floor density {rho_w} {rho_m}");
    assert!(dev < 1e-15, "lattice wall mass off ρ_w dx² by {dev:e}");
    assert!(
        dev_m > 3e-3,
        "a fixed-mass wall weighs ρ0 dx², {dev_m:e} off ρ_w dx²"
    );
    assert!(lattice < 1e-12, "lattice volume: h |Σ V ∇W| = {lattice:e}");
    assert!(mass > 1e-4, "fixed mass: h |Σ V ∇W| = {mass:e}");
}

/// The wall's mass changes every step, so ghosts kept between builds must see it refreshed:
/// the refined still tank with the key gives the bits of one rank and thread on 3 and
/// 8 ranks and on 2 threads.
#[test]
fn a_wall_of_lattice_volume_gives_the_same_bits_on_any_layout() {
    let sets = [
        "time.max_steps=60".to_string(),
        "output.format=\"none\"".to_string(),
        "wall.0.volume=\"lattice\"".to_string(),
    ];
    let s = load_scene(&common::repo_path("inputs/hydrostatic_2d_refined.toml"), &sets)
        .unwrap()
        .0;
    assert_eq!(s.walls[0].volume, hsph::scene::WallVolume::Lattice);
    let read = |d: &std::path::Path| std::fs::read(d.join("final.csv")).unwrap();
    let base = read(&common::run_layout(&s, 1, 1, "wallvol-1"));
    for (ranks, threads) in [(3, 1), (8, 1), (2, 2)] {
        let d = common::run_layout(&s, ranks, threads, &format!("wallvol-{ranks}-{threads}"));
        assert!(
            read(&d) == base,
            "final.csv differs on {ranks} ranks × {threads} threads"
        );
    }
    let mut fixed = s.clone();
    fixed.walls[0].volume = hsph::scene::WallVolume::Mass;
    assert!(read(&common::run_layout(&fixed, 1, 1, "wallvol-mass")) != base);
}

#[test]
fn a_lattice_volume_on_a_wall_that_is_not_dummy_is_exit_2_naming_the_key() {
    let dir = common::temp_dir("wallvol-bad");
    let scene = common::repo_path("inputs/hydrostatic_2d.toml");
    let refused = |sets: &[&str], needles: &[&str]| assert_check_refuses(&dir, &scene, sets, needles);
    refused(
        &["wall.0.volume=\"lattice\"", "wall.0.method=\"dynamic\""],
        &["wall[0].volume", "method = \"dummy\"", "volume = \"mass\""],
    );
    refused(
        &["wall.0.volume=\"cell\""],
        &["wall[0].volume", "lattice", "mass"],
    );
}
