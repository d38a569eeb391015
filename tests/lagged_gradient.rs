//! The lagged density gradient (`physics.density_gradient = "lagged"`, issue 33): Antuono's
//! ⟨∇ρ⟩^L computed with the momentum pass and read by the next step's continuity. Facts: the
//! same bits on any number of ranks and threads in pair and gather mode (the gradient travels
//! with migrating particles and to ghosts built or kept), a restart continues the uninterrupted
//! bits (checkpoints carry the gradient), the flow stays within round-off-amplified distance of
//! the gradient of each step, and the key's bad input is exit 2 naming it.

use crate::common;
use std::fs;
use std::path::Path;

fn read(dir: &Path, name: &str) -> String {
    fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{}/{name}: {e}", dir.display()))
}

/// Run `inputs/dam_break_2d.toml` with `sets` on (ranks, threads); the run directory.
fn run(sets: &[&str], layout: (usize, usize), tag: &str) -> std::path::PathBuf {
    let out = common::temp_dir(tag).join("run");
    let (code, _, err) = common::run_file("inputs/dam_break_2d.toml", &out, layout, sets);
    assert_eq!(code, 0, "{tag}: {err}");
    out
}

/// Pair mode with Verlet lists (the 3D DualSPHysics scene's mode) and gather mode with lists
/// built every step: every layout gives the bits of one rank and one thread; the run differs
/// from the gradient of each step, but by little over 0.05 s of the dam break (positions within
/// 1e-5 m, densities within 0.05 kg/m³ of a flow whose densities vary by ~50 kg/m³).
#[test]
fn the_lagged_gradient_gives_the_same_bits_on_any_layout() {
    for (k, mode) in [
        &[
            "performance.interactions=\"pairs\"",
            "performance.neighbours=\"verlet\"",
        ][..],
        &[][..],
    ]
    .iter()
    .enumerate()
    {
        let mut sets = vec!["time.t_end=0.05", "output.format=\"none\""];
        sets.extend_from_slice(mode);
        let mut lagged = sets.clone();
        lagged.push("physics.density_gradient=\"lagged\"");
        let base = run(&lagged, (1, 1), &format!("lag{k}-r1"));
        let (ts, fin) = (read(&base, "timeseries.csv"), read(&base, "final.csv"));
        for layout in [(3, 1), (2, 2), (8, 1)] {
            let dir = run(&lagged, layout, &format!("lag{k}-r{}t{}", layout.0, layout.1));
            assert!(
                read(&dir, "timeseries.csv") == ts && read(&dir, "final.csv") == fin,
                "{mode:?}: the lagged gradient changed the bits on {layout:?} (ranks, threads)"
            );
        }
        let step = run(&sets, (1, 1), &format!("lag{k}-step"));
        assert!(
            read(&step, "final.csv") != fin,
            "{mode:?}: the key changed nothing"
        );
        let (dx, drho) = common::position_and_density_gap(&step, &base);
        assert!(
            dx < 1e-5 && drho < 0.05,
            "{mode:?}: the lagged gradient ends {dx:e} m and {drho:e} kg/m³ from the step's"
        );
    }
}

/// A run checkpointed on 2 ranks and continued on 3 writes the bytes of the run never
/// interrupted: the checkpoint carries each particle's gradient, which the first step after
/// the restart reads (recomputing it there would take x^{n+1} instead of x^n).
#[test]
fn a_restart_continues_the_lagged_gradients_bits() {
    let dir = common::temp_dir("lagged-restart");
    let sets = [
        "time.t_end=0.04",
        "performance.interactions=\"pairs\"",
        "physics.density_gradient=\"lagged\"",
        "output.interval=0.01",
    ];
    let (reference, cut, ck) = common::reference_and_cut(&dir, "inputs/dam_break_2d.toml", &sets, 70);
    let (code, _, err) = common::restart_to_end(&ck, 3);
    assert_eq!(code, 0, "{err}");
    common::assert_same_files(
        &reference,
        &cut,
        &["timeseries.csv", "final.csv", "probes/front.csv"],
    );
}

/// An unknown value, and `lagged` without Antuono's term (which alone has the gradient), are
/// exit 2 naming the key and what to write instead.
#[test]
fn the_lagged_gradients_bad_input_is_exit_2_naming_the_key() {
    let out = common::temp_dir("lagged-bad").join("run");
    let out = out.to_str().unwrap();
    for (set, says) in [
        ("physics.density_gradient=\"late\"", "lagged"),
        (
            "physics.density_diffusion=\"fourtakas\"",
            "density_diffusion = \"antuono\"",
        ),
    ] {
        let (code, _, err) = common::hsph(&[
            "run",
            "inputs/dam_break_2d.toml",
            "--out",
            out,
            "--set",
            "physics.density_gradient=\"lagged\"",
            "--set",
            set,
        ]);
        assert_eq!(code, 2, "{set}: {err}");
        assert!(
            err.contains("density_gradient") && err.contains(says),
            "{set}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
}
