//! Initial fields by expression (issue 18, item 4): every particle of a body starts with the
//! velocity and pressure its expressions give at its position; bad expressions are exit 2
//! naming the key.

use crate::common;

use std::f64::consts::PI;

const SCENE: &str = "tests/data/taylor_green_fields.toml";

#[test]
fn every_particle_starts_with_the_expressions_values() {
    let out = common::temp_dir("fields").join("run");
    let (code, _, err) = common::hsph(&[
        "run",
        SCENE,
        "-q",
        "--out",
        out.to_str().unwrap(),
        "--ranks",
        "2",
        "--set",
        "time.max_steps=1",
    ]);
    assert_eq!(code, 0, "{err}");
    let (u0, l, p0, rho0, c0) = (0.05, 0.1, 50.0, 1000.0, 1.0);
    let mut n = 0;
    for r in 0..2 {
        let text =
            std::fs::read_to_string(out.join(format!("snapshots/snapshot_00000/rank_{r:04}.vtu"))).unwrap();
        let num = |v: Vec<String>| -> Vec<f64> { v.iter().map(|s| s.parse().unwrap()).collect() };
        let x = num(common::vtu_points(&text));
        let v = num(common::vtu_array(&text, "velocity"));
        let rho = num(common::vtu_array(&text, "density"));
        for k in 0..rho.len() {
            let (px, py) = (x[3 * k], x[3 * k + 1]);
            let (s, c) = ((2.0 * PI * px / l).sin_cos(), (2.0 * PI * py / l).sin_cos());
            let (u, w) = (u0 * s.0 * c.1, -u0 * s.1 * c.0);
            assert!(
                (v[3 * k] - u).abs() < 1e-15 && (v[3 * k + 1] - w).abs() < 1e-15,
                "u at ({px}, {py})"
            );
            let p = p0 * ((4.0 * PI * px / l).cos() + (4.0 * PI * py / l).cos());
            assert!(
                (rho[k] - (rho0 + p / (c0 * c0))).abs() < 1e-10,
                "ρ at ({px}, {py})"
            );
            n += 1;
        }
    }
    assert_eq!(n, 400, "the 20 × 20 body");
}

#[test]
fn bad_expressions_are_input_errors_naming_the_key() {
    let text = std::fs::read_to_string(common::repo_path(SCENE)).unwrap();
    let dir = common::temp_dir("fields-bad");
    for (from, to, key, says) in [
        (
            "U*sin(2*PI*x/L)",
            "Q*sin(x)",
            "fluid[0].velocity_field[0]",
            "unknown name `Q`",
        ),
        (
            "P0*(cos(4*PI*x/L)",
            "P0*(cos(4*PI*x/L",
            "fluid[0].pressure_field",
            "cannot parse",
        ),
        (
            "-U*cos(2*PI*x/L)*sin(2*PI*y/L)",
            "z",
            "fluid[0].velocity_field[1]",
            "unknown name `z`",
        ),
        (
            "P0*(cos(4*PI*x/L)",
            "ln(x - 1)*(cos(4*PI*x/L)",
            "fluid[0].pressure_field",
            "finite",
        ),
        (
            "name = \"vortices\"",
            "name = \"vortices\"\nvelocity = [1.0, 0.0]",
            "fluid[0].velocity_field",
            "not both",
        ),
    ] {
        assert!(text.contains(from), "{from}");
        let scene = dir.join("bad.toml");
        std::fs::write(&scene, text.replacen(from, to, 1)).unwrap();
        let (code, _, err) = common::hsph(&["check", scene.to_str().unwrap()]);
        assert_eq!(code, 2, "{to}: {err}");
        assert!(err.contains(key) && err.contains(says), "{to}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// A sphere body (a disc in 2D) holds exactly the lattice sites closer than its radius to its
/// centre (brute-force count over the lattice), carries its expression fields, and its keys
/// are checked.
#[test]
fn a_sphere_holds_exactly_the_sites_inside_it() {
    let text = std::fs::read_to_string(common::repo_path(SCENE)).unwrap();
    let block = "material = \"water\"\nmin = [0.0, 0.0]\nmax = [0.1, 0.1]\n";
    assert!(text.contains(block));
    let (c, r) = ([0.05, 0.045], 0.033);
    let disc = text.replacen(
        block,
        &format!(
            "material = \"water\"\nshape = \"sphere\"\ncentre = [{}, {}]\nradius = {r}\n",
            c[0], c[1]
        ),
        1,
    );
    let dir = common::temp_dir("sphere");
    let scene = dir.join("disc.toml");
    std::fs::write(&scene, &disc).unwrap();
    let out = dir.join("run");
    let (code, _, err) = common::hsph(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--set",
        "time.max_steps=1",
    ]);
    assert_eq!(code, 0, "{err}");
    // 13.2 spacings across: the lattice disc (140 sites) is 2.3 % larger than the true one
    assert!(
        err.contains("a sphere of radius 0.033 m") && err.contains("an area +2.3 %"),
        "{err}"
    );
    let t = std::fs::read_to_string(out.join("snapshots/snapshot_00000/rank_0000.vtu")).unwrap();
    let x: Vec<f64> = common::vtu_points(&t)
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();
    let mut got: Vec<(i64, i64)> = x
        .chunks(3)
        .map(|p| {
            (
                ((p[0] / 0.005) - 0.5).round() as i64,
                ((p[1] / 0.005) - 0.5).round() as i64,
            )
        })
        .collect();
    got.sort_unstable();
    let mut want = Vec::new();
    for i in 0..20 {
        for j in 0..20 {
            let (px, py) = ((i as f64 + 0.5) * 0.005, (j as f64 + 0.5) * 0.005);
            if (px - c[0]).powi(2) + (py - c[1]).powi(2) < r * r {
                want.push((i, j));
            }
        }
    }
    assert_eq!(got, want, "the disc's sites");
    assert!(want.len() > 100);
    // sphere keys are checked: no radius, sphere keys on a block, a box given as well
    for (from, to, says) in [
        (format!("radius = {r}\n"), String::new(), "fluid[0].radius"),
        (
            "shape = \"sphere\"\n".to_string(),
            String::new(),
            "fluid[0].shape",
        ),
        (
            format!("radius = {r}\n"),
            format!("radius = {r}\nmin = [0.0, 0.0]\n"),
            "fluid[0].min",
        ),
    ] {
        let bad = dir.join("bad.toml");
        std::fs::write(&bad, disc.replacen(&from, &to, 1)).unwrap();
        let (code, _, err) = common::hsph(&["check", bad.to_str().unwrap()]);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains(says), "{says}: {err}");
    }
}

/// A cylinder (3D) along x holds exactly the lattice sites within its radius of the axis and
/// within half its length of the centre (brute-force count); a cylinder in 2D is exit 2.
#[test]
fn a_cylinder_holds_exactly_the_sites_inside_it() {
    let text = std::fs::read_to_string(common::repo_path("tests/data/dam_break_3d_small.toml")).unwrap();
    let block = "min = [0.0, 0.0, 0.0]\nmax = [0.2, 0.2, 0.3]\nhydrostatic = true\n";
    assert!(text.contains(block));
    let (c, r, len) = ([0.3, 0.1, 0.15], 0.09, 0.4);
    let cyl = text.replacen(
        block,
        &format!(
            "shape = \"cylinder\"\ncentre = [{}, {}, {}]\nradius = {r}\naxis = 0\nlength = {len}\n",
            c[0], c[1], c[2]
        ),
        1,
    );
    let dir = common::temp_dir("cylinder");
    let scene = dir.join("cyl.toml");
    std::fs::write(&scene, &cyl).unwrap();
    let out = dir.join("run");
    let (code, _, err) = common::hsph(&[
        "run",
        scene.to_str().unwrap(),
        "-q",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "time.max_steps=1",
        "--set",
        "output.format=\"vtk\"",
    ]);
    assert_eq!(code, 0, "{err}");
    let t = std::fs::read_to_string(out.join("snapshots/snapshot_00000/rank_0000.vtu")).unwrap();
    let x: Vec<f64> = common::vtu_points(&t)
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();
    let kind = common::vtu_array(&t, "kind");
    let (o, dx) = (-0.08, 0.025);
    let site = |v: f64| ((v - o) / dx - 0.5).round() as i64;
    let mut got: Vec<[i64; 3]> = x
        .chunks(3)
        .zip(&kind)
        .filter(|(_, k)| *k == "0")
        .map(|(p, _)| [site(p[0]), site(p[1]), site(p[2])])
        .collect();
    got.sort_unstable();
    let mut want = Vec::new();
    for i in 0..31 {
        for j in 0..15 {
            for k in 0..23 {
                let p = [i, j, k].map(|n| o + (n as f64 + 0.5) * dx);
                let inside = p[0] >= c[0] - len / 2.0
                    && p[0] < c[0] + len / 2.0
                    && (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2) < r * r;
                if inside {
                    want.push([i, j, k]);
                }
            }
        }
    }
    assert_eq!(got, want, "the cylinder's sites");
    assert!(want.len() > 300, "{}", want.len());
    // a cylinder needs 3D
    let disc = std::fs::read_to_string(common::repo_path(SCENE))
        .unwrap()
        .replacen(
            "min = [0.0, 0.0]\nmax = [0.1, 0.1]\nvelocity_field",
            "shape = \"cylinder\"\ncentre = [0.05, 0.05]\nradius = 0.02\nlength = 0.1\nvelocity_field",
            1,
        );
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, disc).unwrap();
    let (code, _, err) = common::hsph(&["check", bad.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("fluid[0].shape") && err.contains("needs a 3D scene"),
        "{err}"
    );
}

/// `hydrostatic = true` under other fluid bodies: a body's pressure starts from the weight of
/// the fluid that rests on it (directly or through others), not from zero at its own top. The
/// tank of `hydrostatic_2d.toml` built as two stacked blocks starts with the densities of the
/// one block (to round-off); under oil (ρ0 = 800) the water's densities are those of the exact
/// pressure field 7848·0.24 + 9810·(0.26 − y) Pa; a drop above the pool, not touching it,
/// weighs nothing on it (the pool's bits are those of the pool alone).
#[test]
fn hydrostatic_bodies_carry_the_fluid_stacked_on_them() {
    use hsph::comm::serial::SerialComm;
    use hsph::scene::load_scene_str;
    use hsph::sim::Simulation;
    use std::collections::HashMap;
    use std::path::Path;
    let base = std::fs::read_to_string(common::repo_path("inputs/hydrostatic_2d.toml")).unwrap();
    let one_block = "[[fluid]]\nname = \"water\"\nmaterial = \"water\"\nmin = [0.0, 0.0]\nmax = [1.0, 0.5]\nhydrostatic = true\n";
    assert!(
        base.contains(one_block),
        "hydrostatic_2d.toml's fluid block moved"
    );
    let densities = |text: &str| -> HashMap<u64, f64> {
        let (scene, _) = load_scene_str(text, Path::new("t.toml"), "t", &[]).unwrap();
        let sim = Simulation::<2>::new(&scene, &SerialComm::new()).unwrap();
        (0..sim.p.n_owned)
            .filter(|&i| sim.p.kind[i].is_fluid())
            .map(|i| (sim.p.id[i], sim.p.rho[i]))
            .collect()
    };
    let block = |name: &str, mat: &str, y0: f64, y1: f64, how: &str| {
        format!("[[fluid]]\nname = \"{name}\"\nmaterial = \"{mat}\"\nmin = [0.0, {y0:?}]\nmax = [1.0, {y1:?}]\n{how}\n")
    };
    let one = densities(&base);
    // the same water in two blocks, the upper one listed first
    let two = base.replace(
        one_block,
        &(block("upper", "water", 0.26, 0.5, "hydrostatic = true")
            + &block("lower", "water", 0.0, 0.26, "hydrostatic = true")),
    );
    let two = densities(&two);
    assert_eq!(one.len(), two.len());
    for (id, r) in &one {
        let s = two[id];
        assert!(
            (s - r).abs() <= 1e-12 * r,
            "particle {id}: {s} kg/m³ stacked, {r} in one block"
        );
    }
    // water under oil against the exact pressure field
    let oil = "[[material]]\nname = \"oil\"\nrho0 = 800.0\nc0 = 40.0\n";
    let with_oil = |lower: &str| {
        base.replace(
            one_block,
            &(block("oil", "oil", 0.26, 0.5, "hydrostatic = true") + lower),
        )
        .replace("[physics]", &format!("{oil}\n[physics]"))
    };
    let stacked = densities(&with_oil(&block(
        "water",
        "water",
        0.0,
        0.26,
        "hydrostatic = true",
    )));
    let exact = densities(&with_oil(&block(
        "water",
        "water",
        0.0,
        0.26,
        "pressure_field = \"800.0*9.81*0.24 + 1000.0*9.81*(0.26 - y)\"",
    )));
    assert_eq!(stacked.len(), exact.len());
    for (id, r) in &exact {
        let s = stacked[id];
        assert!(
            (s - r).abs() <= 1e-12 * r,
            "particle {id}: {s} kg/m³ under oil, {r} exact"
        );
    }
    // a drop above the pool, a gap of 0.05 m between them
    let pool = "[[fluid]]\nname = \"water\"\nmaterial = \"water\"\nmin = [0.0, 0.0]\nmax = [1.0, 0.5]\nhydrostatic = true\n";
    let with_drop = base.replace(one_block, &(block("drop", "water", 0.55, 0.6, "") + pool));
    let with_drop = densities(&with_drop);
    for (id, r) in &one {
        assert_eq!(
            with_drop[id].to_bits(),
            r.to_bits(),
            "particle {id} of the pool under a drop"
        );
    }
}

/// `hydrostatic = true` round a submerged wall block: the water under the block starts with
/// the pressure of its depth below the free surface, as the water beside it does, not of its
/// depth below the block (an outside user's tank: 1 864 Pa under the block where 4 807 Pa was
/// due, and the force on the block pointed down at t = 0). The tank of `hydrostatic_2d.toml`
/// with a dummy block at 0.4–0.6 × 0.2–0.3 m and the water as four blocks round it: every
/// fluid particle's pressure within 1e-9 of ρ0 g (0.5 m − y).
#[test]
fn water_under_a_submerged_wall_starts_from_its_depth_below_the_surface() {
    use hsph::comm::serial::SerialComm;
    use hsph::scene::load_scene_str;
    use hsph::sim::Simulation;
    use std::path::Path;
    let base = std::fs::read_to_string(common::repo_path("inputs/hydrostatic_2d.toml")).unwrap();
    let one_block = "[[fluid]]\nname = \"water\"\nmaterial = \"water\"\nmin = [0.0, 0.0]\nmax = [1.0, 0.5]\nhydrostatic = true\n";
    assert!(
        base.contains(one_block),
        "hydrostatic_2d.toml's fluid block moved"
    );
    let block = |name: &str, (x0, y0): (f64, f64), (x1, y1): (f64, f64)| {
        format!("[[fluid]]\nname = \"{name}\"\nmaterial = \"water\"\nmin = [{x0:?}, {y0:?}]\nmax = [{x1:?}, {y1:?}]\nhydrostatic = true\n")
    };
    let around = block("bottom", (0.0, 0.0), (1.0, 0.2))
        + &block("left", (0.0, 0.2), (0.4, 0.3))
        + &block("right", (0.6, 0.2), (1.0, 0.3))
        + &block("top", (0.0, 0.3), (1.0, 0.5));
    let text = base.replace(one_block, &around)
        + "\n[[wall]]\nname = \"obstacle\"\nshape = \"block\"\nmin = [0.4, 0.2]\nmax = [0.6, 0.3]\n";
    let (scene, _) = load_scene_str(&text, Path::new("t.toml"), "t", &[]).unwrap();
    let sim = Simulation::<2>::new(&scene, &SerialComm::new()).unwrap();
    let mut under = 0;
    for i in (0..sim.p.n_owned).filter(|&i| sim.p.kind[i].is_fluid()) {
        let (x, y) = (sim.p.x[i][0], sim.p.x[i][1]);
        let exact = 1000.0 * 9.81 * (0.5 - y);
        assert!(
            (sim.p.p[i] - exact).abs() <= 1e-9 * 4905.0,
            "particle at ({x}, {y}): {} Pa, {exact} Pa due",
            sim.p.p[i]
        );
        under += usize::from((0.4..0.6).contains(&x) && y < 0.2);
    }
    assert!(under > 50, "only {under} particles under the block");
}
