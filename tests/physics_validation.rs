//! Physics acceptance tests: the shipped validation scenes run through the library and their
//! errors against analytic solutions (written by `reference.rs` into `summary.json`) must
//! meet the acceptance figures of docs/validation.md.
//!
//! Each scene runs at its shipped resolution (the thresholds must hold there); the whole
//! file takes about a minute in release mode on 2 cores.

use crate::common;
use hsph::driver::{run_scene, RunOptions, RunOutcome};
use hsph::scene::{load_scene, Scene};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn scene(file: &str, overrides: &[&str]) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("inputs").join(file);
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    load_scene(&path, &overrides)
        .unwrap_or_else(|e| panic!("{file}: {e}"))
        .0
}

fn run(s: &Scene, tag: &str) -> RunOutcome {
    let out: PathBuf = common::temp_dir(&format!("physics-validation-{tag}")).join("run");
    let opts = RunOptions {
        out: Some(out.clone()),
        force: true,
        threads: 0,
        quiet: true,
        ..Default::default()
    };
    let outcome = run_scene(s, &opts).unwrap_or_else(|e| panic!("{tag}: {e}"));
    let _ = std::fs::remove_dir_all(&out);
    outcome
}

fn error(errors: &BTreeMap<String, f64>, key: &str) -> f64 {
    let e = *errors
        .get(key)
        .unwrap_or_else(|| panic!("summary.json has no error `{key}`: {errors:?}"));
    assert!(e.is_finite(), "{key} = {e}");
    e
}

/// Max over all fluid particles of |u − u_exact|/u_max ≤ 0.5 % at t = 0.6 s and 2 s.
fn channel(file: &str, tag: &str) {
    let s = scene(file, &[]);
    assert_eq!(s.time.t_end, 2.0);
    let out = run(&s, tag);
    for key in ["velocity_linf_t0.6", "velocity_linf_t2"] {
        let e = error(&out.errors, key);
        eprintln!("{tag}: {key} = {:.4} %", 100.0 * e);
        assert!(e <= 0.005, "{tag}: {key} = {:.4} % > 0.5 %", 100.0 * e);
    }
}

#[test]
fn poiseuille_matches_morris_series_within_half_a_percent() {
    channel("poiseuille_2d.toml", "poiseuille");
}

#[test]
fn couette_matches_morris_series_within_half_a_percent() {
    channel("couette_2d.toml", "couette");
}

/// The same start-ups between mirror walls (the plates are faces of containers open along
/// the periodic axis; no wall particles): the shipped quintic spline at h = dx, n = 25.
#[test]
fn poiseuille_and_couette_between_mirror_walls_match_morris_within_half_a_percent() {
    channel("poiseuille_2d_mirror.toml", "poiseuille-mirror");
    channel("couette_2d_mirror.toml", "couette-mirror");
}

/// Issue 19: the channel at n = 25 with the renormalised viscous operator and Morris's
/// no-slip stays within 0.5 % (t = 0.6 s and 2 s), between dummy plates and between mirror
/// plates, for the two worst settings of the sweep's kernels and h/dx 1.2–2.0: Wendland C2
/// at h = 1.2 dx, whose lattice moment (0.964) held the plain operator at 3.7 %, and the
/// cubic spline at h = 2 dx, whose Adami walls gave 1.1 % and whose reflected mirror
/// velocity 0.59 %. The plain Wendland run is checked to fail, so the test sees the
/// correction. The runs use the sweep's own scenes and overrides (`hsph validate`'s `cases`).
#[test]
fn renormalised_operator_and_morris_walls_bring_the_channel_within_half_a_percent() {
    use hsph::kernel::KernelKind;
    use hsph::validate::cases;
    let errors = |case: &cases::Case, v: &cases::Variant| {
        let sets = case.sets(25, v);
        let sets: Vec<&str> = sets.iter().map(String::as_str).collect();
        let s = scene(case.scene_for(v).0.trim_start_matches("inputs/"), &sets);
        let out = run(&s, &format!("{}-{}", case.name, v.name()));
        ["velocity_linf_t0.6", "velocity_linf_t2"].map(|k| error(&out.errors, k))
    };
    for name in ["poiseuille", "couette"] {
        let case = cases::find(name).unwrap();
        let sweep = (case.sweep)();
        for (kernel, h) in [(KernelKind::WendlandC2, 1.2), (KernelKind::CubicSpline, 2.0)] {
            for walls in ["dummy", "mirror"] {
                let v = sweep
                    .iter()
                    .find(|v| {
                        v.kernel == kernel
                            && v.h_over_dx == h
                            && v.walls == walls
                            && v.viscous == "renormalised"
                            && v.no_slip == "morris"
                    })
                    .unwrap_or_else(|| panic!("{name}: no corrected {walls} {kernel:?} h = {h} dx variant"));
                let e = errors(&case, v);
                eprintln!(
                    "{name} {}: {:.3} % at 0.6 s, {:.3} % at 2 s",
                    v.name(),
                    100.0 * e[0],
                    100.0 * e[1]
                );
                assert!(e.iter().all(|&e| e <= 0.005), "{name} {}: {e:?}", v.name());
            }
        }
    }
    let case = cases::find("poiseuille").unwrap();
    let plain = (case.sweep)()
        .into_iter()
        .find(|v| v.kernel == KernelKind::WendlandC2 && v.h_over_dx == 1.2 && v.viscous == "morris")
        .unwrap();
    let e = errors(&case, &plain);
    assert!(
        e[1] > 0.03,
        "plain Wendland h = 1.2 dx: {e:?} (the lattice-moment floor is 3.6 %)"
    );
}

/// The still tank of `hydrostatic_2d.toml` with `sets`, after ≥ 20 acoustic periods H/c0:
/// pressure below mid-depth within `pressure` of ρ0 g H, speeds below 1 % of sqrt(gH), no fluid
/// particle in or beyond a wall.
fn still_tank(sets: &[&str], tag: &str, pressure: f64) {
    let s = scene("hydrostatic_2d.toml", sets);
    let Some(hsph::scene::Reference::Hydrostatic { surface, bottom }) = s.reference.clone() else {
        panic!("hydrostatic_2d.toml needs a hydrostatic reference");
    };
    let periods = s.time.t_end / ((surface - bottom) / s.materials[0].c0);
    assert!(periods >= 20.0, "only {periods:.1} acoustic periods");
    let out = run(&s, tag);
    let ep = error(&out.errors, "pressure_linf_below_mid_depth");
    let ev = error(&out.errors, "max_speed_over_sqrt_gh");
    let ew = error(&out.errors, "fluid_in_walls_fraction");
    eprintln!(
        "{tag}: {periods:.0} periods, pressure {:.3} %, speed {:.3} %, in walls {ew}",
        100.0 * ep,
        100.0 * ev
    );
    assert!(
        ep <= pressure,
        "{tag}: pressure error {:.3} % of ρ0 g H",
        100.0 * ep
    );
    assert!(
        ev < 0.01,
        "{tag}: max speed {:.3} % of sqrt(gH) ≥ 1 %",
        100.0 * ev
    );
    assert_eq!(ew, 0.0, "{tag}: fluid particles inside or beyond a wall");
}

/// The shipped still tank (dummy walls): pressure within 2 %.
#[test]
fn hydrostatic_tank_stays_at_rest_with_hydrostatic_pressure() {
    still_tank(&[], "hydrostatic", 0.02);
}

/// The still tank (free-slip) on dynamic walls (DualSPHysics's boundary: wall density by
/// continuity, no pressure extrapolation) over the scene's 0.5 s, in the default layers (the
/// rows in the support's reach): pressure within 1 % (measured 0.37 % and 0.08 % of sqrt(gH)
/// at 1 s; one layer reads 85 %, docs/methods.md).
#[test]
fn a_tank_on_dynamic_walls_holds_still_water() {
    still_tank(&["wall[0].method=\"dynamic\""], "hydrostatic-dynamic", 0.01);
}

/// A material listed before the water (air) changes neither the tank's walls (they take the
/// fluid's material) nor the hydrostatic reference (it reads each fluid particle's ρ0): the
/// errors equal the plain tank's, where air's ρ0 once gave 1000/1.2 × the error.
#[test]
fn a_material_listed_first_changes_neither_walls_nor_reference() {
    let sets = ["time.t_end=0.05".to_string()];
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("inputs/hydrostatic_2d.toml"))
            .unwrap();
    let air = "[[material]]\nname = \"air\"\nrho0 = 1.2\nc0 = 35.0\neos = \"tait\"\ngamma = 7.0\n\n";
    let with_air = text.replacen("[[material]]", &format!("{air}[[material]]"), 1);
    let load = |t: &str| {
        hsph::scene::load_scene_str(t, Path::new("t.toml"), "t", &sets)
            .unwrap()
            .0
    };
    let plain = run(&load(&text), "first-material-plain");
    let aired = run(&load(&with_air), "first-material-air");
    assert!(
        plain.errors["pressure_linf_below_mid_depth"] < 0.05,
        "{:?}",
        plain.errors
    );
    assert_eq!(plain.errors, aired.errors);
}

/// The benchmark and 3D scenes load and have the particle counts their comments state.
#[test]
fn dam_break_scenes_have_the_documented_particle_counts() {
    fn counts<const D: usize>(s: &Scene) -> (usize, usize) {
        let p = hsph::setup::build_particles::<D>(s).expect("particles");
        let n = p.n_owned;
        let fluid = p.kind[..n]
            .iter()
            .filter(|k| **k == hsph::particles::Kind::Fluid)
            .count();
        (fluid, n - fluid)
    }
    // seed 004: 25 057 particles, 12 083 wall
    let (f, w) = counts::<3>(&scene("dam_break_3d.toml", &[]));
    assert_eq!((f, w), (12_992, 12_070));
    assert!((f + w).abs_diff(25_057) <= 25 && w.abs_diff(12_083) <= 25);
    let (f, _) = counts::<2>(&scene("dam_break_2d_dsph.toml", &[]));
    assert_eq!(f, 20_000);
    let (f, w) = counts::<3>(&scene("dam_break_3d_bench.toml", &[]));
    assert!(f + w >= 200_000, "{} particles", f + w);
}

/// The 3D dam break runs (here its first 0.02 s, ≈ 125 steps; `hsph run inputs/dam_break_3d.toml` runs
/// the whole 1 s) without a particle leaving the domain or blowing up.
#[test]
fn dam_break_3d_starts_cleanly() {
    let s = scene(
        "dam_break_3d.toml",
        &["time.t_end=0.02", "output.format=\"none\""],
    );
    let out = run(&s, "dam_break_3d");
    let t = out.summary["t"].as_f64().unwrap();
    assert!((t - 0.02).abs() < 1e-9, "stopped at t = {t}");
}
