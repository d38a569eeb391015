//! Scene values that `hsph check` must refuse with exit 2, one located message naming the key
//! and no panic (issue 32, defects 12–14 and 17–19, and the step budget), each tried as a class:
//! every constant that enters the time step at absurd, non-finite and merely too large values;
//! runs over the step budget; expressions too long or too deep in every key that takes one;
//! constants named like a built-in in any letter case; body names used twice across kinds;
//! bodies that build no particle. Ordinary values pass (the positive controls). Every case is
//! a `check`, never a run, so that the whole file takes seconds.

use crate::common;

use common::{hsph, temp_dir};
use std::time::Instant;

const DAM: &str = "inputs/dam_break_2d.toml";
const TG: &str = "inputs/taylor_green.toml";
const IMPACT: &str = "inputs/impact_oblique_45.toml";

/// `hsph check scene --set s...` for each of `sets`; returns (status, stderr).
fn check(scene: &str, sets: &[&str]) -> (i32, String) {
    let mut args = vec!["check", scene];
    for s in sets {
        args.extend(["--set", s]);
    }
    let (code, _, stderr) = hsph(&args);
    (code, stderr)
}

/// Exit 2 within two seconds (milliseconds in fact), one message naming `key` and every needle, no panic.
fn refused(scene: &str, sets: &[&str], key: &str, needles: &[&str]) {
    let t = Instant::now();
    let (code, stderr) = check(scene, sets);
    let took = t.elapsed().as_secs_f64();
    let case = format!("{scene} {sets:?}");
    assert_eq!(code, 2, "{case}: exit status; stderr:\n{stderr}");
    assert!(!stderr.contains("panicked"), "{case}: panic:\n{stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{case}: one message expected, got:\n{stderr}");
    assert!(
        stderr.contains(&format!("key `{key}`")),
        "{case}: key `{key}` not named:\n{stderr}"
    );
    for n in needles {
        assert!(stderr.contains(n), "{case}: `{n}` missing from:\n{stderr}");
    }
    assert!(took < 2.0, "{case}: refused after {took:.2} s");
}

/// Exit 0.
fn accepted(scene: &str, sets: &[&str]) {
    let (code, stderr) = check(scene, sets);
    assert_eq!(code, 0, "{scene} {sets:?}: exit status; stderr:\n{stderr}");
}

/// Write `text` as a scene file in a fresh temp dir; its path.
fn scene_file(tag: &str, text: &str) -> String {
    let p = temp_dir(tag).join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// A small 2D scene: a fluid block `water` in an open container `tank`, then `extra` (TOML
/// appended: more bodies, constants, probes).
fn small(extra: &str) -> String {
    format!(
        r#"
dimension = 2
[domain]
min = [-0.1, -0.1]
max = [1.1, 1.1]
[discretisation]
dx = 0.02
[[material]]
name = "water"
rho0 = 1000.0
c0 = 40.0
[physics]
body_force = [0.0, -9.81]
[[fluid]]
name = "column"
material = "water"
min = [0.0, 0.0]
max = [0.4, 0.4]
[[wall]]
name = "tank"
shape = "container"
min = [0.0, 0.0]
max = [1.0, 1.0]
open = ["y+"]
[time]
t_end = 0.1
{extra}
"#
    )
}

#[test]
fn fluid_constants_that_enter_dt_are_finite_and_in_range() {
    for (set, key) in [
        ("material.0.c0=1e300", "material[0].c0"),
        ("material.0.c0=2e5", "material[0].c0"),
        ("material.0.c0=1e-9", "material[0].c0"),
        ("material.0.c0=-20.0", "material[0].c0"),
        ("material.0.c0=nan", "material[0].c0"),
        ("material.0.c0=inf", "material[0].c0"),
        ("material.0.rho0=1e300", "material[0].rho0"),
        ("material.0.rho0=2e5", "material[0].rho0"),
        ("material.0.rho0=1e-300", "material[0].rho0"),
        ("material.0.rho0=nan", "material[0].rho0"),
        ("material.0.gamma=1e300", "material[0].gamma"),
        ("material.0.gamma=-inf", "material[0].gamma"),
        ("time.t_end=1e300", "time.t_end"),
        ("time.t_end=2e9", "time.t_end"),
        ("time.t_end=inf", "time.t_end"),
        ("time.t_end=nan", "time.t_end"),
        ("time.dt=1e300", "time.dt"),
        ("time.dt=nan", "time.dt"),
        ("time.dt=-1e-4", "time.dt"),
        ("physics.laminar_viscosity=1e300", "physics.laminar_viscosity"),
        ("physics.laminar_viscosity=nan", "physics.laminar_viscosity"),
        (
            "physics.artificial_viscosity=1e300",
            "physics.artificial_viscosity",
        ),
        ("physics.artificial_viscosity=1e3", "physics.artificial_viscosity"),
        (
            "physics.artificial_viscosity_beta=1e300",
            "physics.artificial_viscosity_beta",
        ),
        ("physics.artificial_stress=inf", "physics.artificial_stress"),
        ("physics.delta=1e300", "physics.delta"),
        ("discretisation.h_over_dx=1e300", "discretisation.h_over_dx"),
        ("discretisation.h_over_dx=nan", "discretisation.h_over_dx"),
        ("fluid.0.velocity=[1e300, 0.0]", "fluid[0].velocity"),
        ("fluid.0.velocity=[2e5, 0.0]", "fluid[0].velocity"),
    ] {
        refused(DAM, &[set], key, &[]);
    }
    // the message names the value, the range and a valid alternative
    refused(
        DAM,
        &["material.0.c0=1e300"],
        "material[0].c0",
        &["1e300", "1e5", "e.g. c0 = "],
    );
}

#[test]
fn solid_constants_that_enter_dt_are_finite_and_in_range() {
    for (set, key) in [
        ("material.0.shear_modulus=1e300", "material[0].shear_modulus"),
        ("material.0.shear_modulus=1e14", "material[0].shear_modulus"),
        ("material.0.shear_modulus=nan", "material[0].shear_modulus"),
        ("material.0.c0=1e300", "material[0].c0"),
        ("material.0.rho0=1e300", "material[0].rho0"),
        ("material.0.hugoniot_slope=1e300", "material[0].hugoniot_slope"),
        ("material.0.gruneisen=1e3", "material[0].gruneisen"),
        ("material.0.jc_a=1e300", "material[0].jc_a"),
        ("material.0.jc_b=inf", "material[0].jc_b"),
        ("material.0.spall_pressure=1e300", "material[0].spall_pressure"),
        ("solid.1.velocity=[1e300, 0.0, 0.0]", "solid[1].velocity"),
    ] {
        refused(IMPACT, &[set], key, &[]);
    }
    // each constant in range, but together a wave speed no material has
    refused(
        IMPACT,
        &["material.0.rho0=1e-5"],
        "material[0].shear_modulus",
        &["longitudinal wave speed"],
    );
}

#[test]
fn huge_body_forces_are_refused_and_large_ones_still_meet_the_sound_speed_check() {
    for bf in [
        "[0.0, -1e200]",
        "[0.0, -1e308]",
        "[1e155, 1e155]",
        "[0.0, -2e6]",
        "[8e5, -8e5]",
    ] {
        refused(
            DAM,
            &[&format!("physics.body_force={bf}")],
            "physics.body_force",
            &["1e6"],
        );
    }
    for bf in ["[0.0, nan]", "[inf, 0.0]"] {
        refused(
            DAM,
            &[&format!("physics.body_force={bf}")],
            "physics.body_force",
            &[],
        );
    }
    // within range, the expected speed √(2 g H) stays finite and c0 = 25 m/s falls short of it
    refused(
        DAM,
        &["physics.body_force=[0.0, -1e6]"],
        "material[0].c0",
        &["expected speed"],
    );
    // and a wall moving at 1e300 m/s is refused on its velocity, not passed as speed 0
    refused(DAM, &["wall.0.velocity=[1e300, 0.0]"], "wall[0].velocity", &[]);
}

#[test]
fn runs_over_the_step_budget_are_refused_unless_max_steps_is_set() {
    // a fixed step: t_end / dt
    refused(DAM, &["time.dt=1e-300"], "time.dt", &["time.max_steps", "1e9"]);
    refused(DAM, &["time.dt=1e-12"], "time.dt", &["time.max_steps"]);
    // the adaptive step: t_end over the CFL bound, from t_end, CFL or the viscous bound
    refused(
        DAM,
        &["time.t_end=1e7"],
        "time.t_end",
        &["time.max_steps", "steps"],
    );
    refused(DAM, &["time.cfl=1e-12"], "time.t_end", &["time.max_steps"]);
    refused(DAM, &["physics.laminar_viscosity=1e5"], "time.t_end", &["ν"]);
    // solids: their longitudinal wave speed sets the bound
    refused(IMPACT, &["time.t_end=100"], "time.t_end", &["time.max_steps"]);
    // max_steps lifts the budget: the user asked for it
    accepted(DAM, &["time.t_end=1e7", "time.max_steps=10"]);
    accepted(DAM, &["time.dt=1e-12", "time.max_steps=10"]);
    // and an ordinary fixed step passes
    accepted(DAM, &["time.dt=1e-4"]);
}

#[test]
fn long_or_deep_expressions_are_refused_in_milliseconds_in_every_key() {
    let nested = format!("{}x{}", "sin(".repeat(200_000), ")".repeat(200_000));
    let sum = vec!["x"; 100_000].join("+");
    let deep = format!("{}x{}", "(".repeat(65), ")".repeat(65));
    let deep_calls = format!("{}x{}", "exp(".repeat(100), ")".repeat(100));
    let keys = [
        ("velocity_field", 0usize),
        ("velocity_field", 1),
        ("pressure_field", 0),
    ];
    for (i, text) in [&nested, &sum, &deep, &deep_calls].into_iter().enumerate() {
        for (j, (field, axis)) in keys.iter().enumerate() {
            let mut tg = std::fs::read_to_string(common::repo_path(TG)).unwrap();
            let (key, line) = if *field == "pressure_field" {
                (
                    "fluid[0].pressure_field".to_string(),
                    "pressure_field = \"-RHO*U^2/4*(cos(4*PI*x/L)+cos(4*PI*y/L))\"".to_string(),
                )
            } else {
                let v = ["-U*cos(2*PI*x/L)*sin(2*PI*y/L)", "U*sin(2*PI*x/L)*cos(2*PI*y/L)"];
                (
                    format!("fluid[0].velocity_field[{axis}]"),
                    format!("velocity_field = [\"{}\", \"{}\"]", v[0], v[1]),
                )
            };
            assert!(tg.contains(&line), "{line}");
            let new = if *field == "pressure_field" {
                format!("pressure_field = \"{text}\"")
            } else if *axis == 0 {
                line.replace("-U*cos(2*PI*x/L)*sin(2*PI*y/L)", text)
            } else {
                line.replace("U*sin(2*PI*x/L)*cos(2*PI*y/L)", text)
            };
            tg = tg.replace(&line, &new);
            let path = scene_file(&format!("expr-{i}-{j}"), &tg);
            let why = if i < 2 {
                "characters long"
            } else {
                "nests brackets"
            };
            refused(&path, &[], &key, &[why]);
        }
    }
    // many bodies, each within the bound, together above the scene's
    let e = vec!["1e-9*x"; 580].join("+");
    assert!(e.len() <= 4096);
    let bodies: String = (0..20)
        .map(|i| {
            let x = 0.02 * i as f64;
            format!(
                "[[fluid]]\nname = \"b{i}\"\nmaterial = \"water\"\nmin = [{x}, 0.6]\nmax = [{}, 0.62]\n\
                 velocity_field = [\"{e}\", \"{e}\"]\n",
                x + 0.02
            )
        })
        .collect();
    let path = scene_file("expr-total", &small(&bodies));
    // the first body over the total, counting the small scene's own fluid[0]
    let over = 1 + hsph::limits::MAX_EXPR_TOTAL_CHARS / (2 * e.len());
    refused(
        &path,
        &[],
        &format!("fluid[{over}].velocity_field"),
        &["MAX_EXPR_TOTAL_CHARS"],
    );
}

#[test]
fn constants_may_not_shadow_built_in_names_in_any_case() {
    for (name, builtin) in [
        ("PI", "PI"),
        ("pi", "PI"),
        ("Pi", "PI"),
        ("E", "E"),
        ("e", "e"),
        ("TAU", "TAU"),
        ("tau", "TAU"),
        ("sin", "sin"),
        ("COS", "cos"),
        ("exp", "exp"),
        ("sqrt", "sqrt"),
        ("ln", "ln"),
        ("log", "log"),
        ("atan2", "atan2"),
        ("min", "min"),
        ("max_u", "max"),
        ("signum", "signum"),
    ] {
        refused(
            TG,
            &[&format!("constants.{name}=3.0")],
            &format!("constants.{name}"),
            &[&format!("`{builtin}`")],
        );
    }
    for name in ["x", "y", "z", "X"] {
        refused(
            TG,
            &[&format!("constants.{name}=1.0")],
            &format!("constants.{name}"),
            &["coordinate"],
        );
    }
    // names expressions could not write, and values that are not finite
    refused(TG, &["constants.2U=1.0"], "constants.2U", &["not a name"]);
    refused(TG, &["constants.U=nan"], "constants.U", &["finite"]);
    refused(TG, &["constants.U=inf"], "constants.U", &["finite"]);
    // Greek π is exmex's too
    let tg = std::fs::read_to_string(common::repo_path(TG))
        .unwrap()
        .replace("RHO = 1.0", "RHO = 1.0\n\"π\" = 3.0");
    refused(&scene_file("pi-greek", &tg), &[], "constants.π", &["`π`"]);
    // ordinary names pass
    accepted(
        TG,
        &["constants.U_0=1.0", "constants.Maxim=2.0", "constants.t=0.0"],
    );
}

#[test]
fn body_names_are_unique_across_kinds() {
    // wall after fluid, solid after solid
    refused(
        DAM,
        &["wall.0.name=\"column\""],
        "wall[0].name",
        &["fluid[0]", "column"],
    );
    refused(
        IMPACT,
        &["solid.1.name=\"plate\""],
        "solid[1].name",
        &["solid[0]"],
    );
    // fluid after fluid, wall after wall, solid after fluid
    let two_fluids =
        small("[[fluid]]\nname = \"column\"\nmaterial = \"water\"\nmin = [0.6, 0.0]\nmax = [0.8, 0.2]\n");
    refused(
        &scene_file("dup-fluid", &two_fluids),
        &[],
        "fluid[1].name",
        &["fluid[0]"],
    );
    let two_walls =
        small("[[wall]]\nname = \"tank\"\nshape = \"block\"\nmin = [0.5, 0.0]\nmax = [0.6, 0.2]\n");
    refused(
        &scene_file("dup-wall", &two_walls),
        &[],
        "wall[1].name",
        &["wall[0]"],
    );
    let solid = "[[material]]\nname = \"al\"\nmodel = \"solid\"\nlibrary = \"al6061-t6\"\n\
                 [[solid]]\nname = \"NAME\"\nmaterial = \"al\"\nmin = [0.6, 0.6]\nmax = [0.7, 0.7]\n\
                 [time]\nt_end = 1e-5\n";
    for (name, first) in [("column", "fluid[0]"), ("tank", "wall[0]")] {
        let text = small(&solid.replace("NAME", name)).replace("[time]\nt_end = 0.1\n", "");
        refused(&scene_file("dup-solid", &text), &[], "solid[0].name", &[first]);
    }
    // distinct names pass
    let text = small(&solid.replace("NAME", "cube")).replace("[time]\nt_end = 0.1\n", "");
    accepted(&scene_file("solid-ok", &text), &[]);
}

#[test]
fn bodies_that_build_no_particle_are_refused_naming_the_body_and_dx() {
    // a fluid block thinner than a spacing between two site centres
    refused(
        DAM,
        &["fluid.0.max=[0.001, 0.001]"],
        "fluid[0]",
        &["`column`", "dx = 0.006"],
    );
    // a sphere whose box holds sites but none inside it, and one far below a spacing
    for r in ["1.6e-4", "1e-5"] {
        refused(
            IMPACT,
            &[&format!("solid.1.radius={r}")],
            "solid[1]",
            &["`sphere`", "dx = 0.00024"],
        );
    }
    // a wall block between two rows of sites, and a container open on every face
    let thin =
        small("[[wall]]\nname = \"sill\"\nshape = \"block\"\nmin = [0.5, 0.001]\nmax = [0.6, 0.005]\n");
    refused(
        &scene_file("thin-wall", &thin),
        &[],
        "wall[1]",
        &["`sill`", "dx = 0.02"],
    );
    refused(
        DAM,
        &["wall.0.open=[\"x-\", \"x+\", \"y-\", \"y+\"]"],
        "wall[0].open",
        &["every face open"],
    );
    // run refuses it too, before making a run directory
    let out = temp_dir("empty-run").join("run");
    let (code, _, stderr) = hsph(&[
        "run",
        DAM,
        "--set",
        "fluid.0.max=[0.001, 0.001]",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("builds no particle"), "{stderr}");
    assert!(!out.join("summary.json").exists());
    // the same block one spacing thick builds a row
    accepted(DAM, &["fluid.0.max=[0.006, 0.006]"]);
}

#[test]
fn a_line_probe_of_too_many_points_is_refused() {
    let probe = "[[probe]]\nname = \"line\"\nkind = \"velocity_line\"\nfrom = [0.1, 0.1]\nto = [0.9, 0.1]\npoints = 100000000000\n";
    refused(
        &scene_file("probe-points", &small(probe)),
        &[],
        "probe[0].points",
        &["limit"],
    );
}

#[test]
fn every_shipped_scene_still_passes() {
    for entry in std::fs::read_dir(common::repo_path("inputs")).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "toml") {
            accepted(p.to_str().unwrap(), &[]);
        }
    }
    accepted(&scene_file("small", &small("")), &[]);
}
