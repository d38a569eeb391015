//! Bodies from STL meshes (issue 83): `shape = "mesh"` claims the lattice sites inside a closed
//! surface by the rule of `[min, max)` for blocks, so a box written by `tools/stl_shapes.py`
//! builds the block's particles bit for bit, fine spheres and cylinders build the built-in
//! shapes' up to half a spacing from the surface, the Wigley hull fills 4/9·LBT, and a bad
//! mesh is an input error, never a panic.

use crate::common;

use common::temp_dir;
use hsph::scene::{load_scene, load_scene_str, Scene};
use hsph::setup::build_particles;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A 3D scene, domain [−0.05, 0.65]³ with a floor, and one fluid body `BODY` (its shape keys).
pub(crate) fn scene(body: &str) -> String {
    format!(
        r#"name = "mesh"
dimension = 3
[domain]
min = [-0.05, -0.05, -0.05]
max = [0.65, 0.65, 0.65]
[discretisation]
dx = 0.02
h_over_dx = 1.3
[[material]]
name = "water"
rho0 = 1000.0
c0 = 40.0
eos = "tait"
gamma = 7.0
[physics]
density_diffusion = "antuono"
delta = 0.1
artificial_viscosity = 0.02
body_force = [0.0, 0.0, -9.81]
[[fluid]]
name = "body"
material = "water"
hydrostatic = true
{body}
[[wall]]
name = "floor"
shape = "block"
min = [-0.04, -0.04, -0.04]
max = [0.64, 0.64, 0.0]
method = "repulsive"
[time]
t_end = 1.0
cfl = 0.2
[output]
interval = 1.0
format = "none"
"#
    )
}

/// Run `tools/stl_shapes.py ARGS --out DIR/NAME`; the file's path.
pub(crate) fn stl(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let o = Command::new("python3")
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tools/stl_shapes.py"))
        .args(args)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

/// The scene of body `body` written to DIR/scene.toml and loaded.
fn load_in(dir: &Path, body: &str) -> Scene {
    load_with(dir, body, &[])
}

/// [`load_in`] with overrides.
fn load_with(dir: &Path, body: &str, overrides: &[&str]) -> Scene {
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene(body)).unwrap();
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    load_scene(&path, &o).unwrap().0
}

/// A lattice whose sites lie at odd multiples of 1/128 m, exact in the file's 32-bit floats
/// (dx = 1/64 m from −0.0625 m), so that a face can lie exactly on sites.
const DYADIC: [&str; 2] = [
    "discretisation.dx=0.015625",
    "domain.min=[-0.0625, -0.0625, -0.0625]",
];

/// Every built fluid particle as (x, y, z, ρ, m), bit patterns, in id order.
fn fluid(s: &Scene) -> Vec<[u64; 5]> {
    let p = build_particles::<3>(s).unwrap();
    (0..p.n_owned)
        .filter(|&i| p.kind[i] == hsph::particles::Kind::Fluid)
        .map(|i| {
            let x = p.x[i];
            [x[0], x[1], x[2], p.rho[i], p.mass[i]].map(f64::to_bits)
        })
        .collect()
}

/// On a lattice of sites at odd multiples of 1/128 m: a block with its faces on sites (13/128
/// to 51/128 m along x, …; its f32 corners are exact) and one with faces between sites, as
/// boxes written by the tool in binary and ASCII, build the block's particles to the bit,
/// hydrostatic density included; a box in mm placed by scale, a quarter turn and a
/// translation builds the block's sites; ten steps give the block's `final.csv`.
#[test]
fn a_box_as_a_mesh_builds_the_block_bit_for_bit() {
    let dir = temp_dir("mesh-box");
    let on_sites = (
        [13.0 / 128.0, 11.0 / 128.0, 1.0 / 128.0],
        [51.0 / 128.0, 39.0 / 128.0, 27.0 / 128.0],
    );
    for (lo, hi) in [on_sites, ([0.1, 0.1, 0.0], [0.4, 0.3, 0.2])] {
        let want = fluid(&load_with(&dir, &format!("min = {lo:?}\nmax = {hi:?}"), &DYADIC));
        assert!(want.len() > 3000, "{} particles", want.len());
        let bounds: Vec<String> = lo.iter().chain(&hi).map(|x| x.to_string()).collect();
        let b = &bounds;
        for ascii in [false, true] {
            let mut args = vec!["box", "--min", &b[0], &b[1], &b[2], "--max", &b[3], &b[4], &b[5]];
            if ascii {
                args.push("--ascii");
            }
            stl(&dir, "box.stl", &args);
            let got = fluid(&load_with(&dir, "shape = \"mesh\"\nfile = \"box.stl\"", &DYADIC));
            if lo == on_sites.0 {
                assert!(
                    got == want,
                    "{lo:?} {hi:?} ascii {ascii}: {} against {}",
                    got.len(),
                    want.len()
                );
            } else {
                // the top is the f32 nearest 0.2 m (3·10⁻⁹ m above): positions to the bit, the
                // hydrostatic density to within ρ0 g 3·10⁻⁹ m / K
                let xs = |p: &[[u64; 5]]| -> Vec<[u64; 3]> { p.iter().map(|p| [p[0], p[1], p[2]]).collect() };
                assert!(xs(&got) == xs(&want), "{lo:?} {hi:?} ascii {ascii}");
                let rho = |p: &[u64; 5]| f64::from_bits(p[3]);
                assert!(got
                    .iter()
                    .zip(&want)
                    .all(|(a, b)| (rho(a) / rho(b) - 1.0).abs() < 1e-9));
            }
        }
    }
    // placed: the box [0, 200] × [0, 300] × [0, 200] mm turned a quarter about z and moved
    stl(
        &dir,
        "mm.stl",
        &["box", "--min", "0", "0", "0", "--max", "200", "300", "200"],
    );
    let placed = load_with(
        &dir,
        "shape = \"mesh\"\nfile = \"mm.stl\"\nscale = 0.001\nrotate = [0.0, 0.0, 90.0]\ntranslate = [0.4, 0.1, 0.0]",
        &DYADIC,
    );
    let box_of = |s: &Scene| [s.fluids[0].min.clone(), s.fluids[0].max.clone()].concat();
    let near = box_of(&placed)
        .iter()
        .zip([0.1, 0.1, 0.0, 0.4, 0.3, 0.2])
        .all(|(a, b)| (a - b).abs() < 1e-12);
    assert!(near, "{:?}", box_of(&placed));
    let block = load_with(&dir, "min = [0.1, 0.1, 0.0]\nmax = [0.4, 0.3, 0.2]", &DYADIC);
    let xs = |s: &Scene| -> Vec<[u64; 3]> { fluid(s).iter().map(|p| [p[0], p[1], p[2]]).collect() };
    assert!(xs(&placed) == xs(&block));
    // the run
    let run = |name: &str, body: &str| {
        let path = dir.join(format!("{name}.toml"));
        std::fs::write(&path, scene(body)).unwrap();
        let out = dir.join(name);
        let o = Command::new(env!("CARGO_BIN_EXE_hsph"))
            .args(["run", path.to_str().unwrap(), "-q", "--threads", "1", "--out"])
            .arg(&out)
            .args([
                "--set",
                "time.max_steps=10",
                "--set",
                DYADIC[0],
                "--set",
                DYADIC[1],
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        out
    };
    let [l, h] = [on_sites.0, on_sites.1].map(|v| v.map(|x| x.to_string()));
    stl(
        &dir,
        "box.stl",
        &["box", "--min", &l[0], &l[1], &l[2], "--max", &h[0], &h[1], &h[2]],
    );
    let a = run(
        "block",
        &format!("min = {:?}\nmax = {:?}", on_sites.0, on_sites.1),
    );
    let b = run("meshed", "shape = \"mesh\"\nfile = \"box.stl\"");
    let read = |d: &Path| std::fs::read(d.join("final.csv")).unwrap();
    assert!(read(&a) == read(&b), "final.csv differs");
    // the mesh's hash is in the summary's provenance, and the resolved scene names the file
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("summary.json")).unwrap()).unwrap();
    let m = &summary["inputs"]["meshes"][0];
    assert_eq!(m["key"], "fluid[0]");
    assert_eq!(m["triangles"], 12);
    assert_eq!(m["sha256"].as_str().map(str::len), Some(64));
}

/// The sites of `body` built in a scene in DIR, as (i, j, k) lattice indices.
fn sites(dir: &Path, body: &str) -> std::collections::BTreeSet<[i64; 3]> {
    let s = load_in(dir, body);
    let p = build_particles::<3>(&s).unwrap();
    let dx = s.discretisation.dx;
    (0..p.n_owned)
        .filter(|&i| p.kind[i] == hsph::particles::Kind::Fluid)
        .map(|i| [0, 1, 2].map(|a| ((p.x[i][a] + 0.05) / dx - 0.5).round() as i64))
        .collect()
}

/// A sphere of 48 bands (9 024 triangles) and a cylinder of 180 segments written by the tool,
/// against `shape = "sphere"` and `"cylinder"`: the sites only one of them claims lie within
/// 0.5 dx of the surface, and the counts agree within 1 %.
#[test]
fn fine_sphere_and_cylinder_meshes_build_the_shapes_up_to_half_a_spacing() {
    let dir = temp_dir("mesh-round");
    let dx = 0.02;
    let centre = [0.3, 0.31, 0.3];
    stl(
        &dir,
        "ball.stl",
        &[
            "sphere", "--centre", "0.3", "0.31", "0.3", "--radius", "0.23", "--bands", "48",
        ],
    );
    stl(
        &dir,
        "rod.stl",
        &[
            "cylinder", "--centre", "0.3", "0.31", "0.3", "--radius", "0.15", "--length", "0.45", "--axis",
            "0",
        ],
    );
    let cases = [
        (
            "ball.stl",
            "shape = \"sphere\"\ncentre = [0.3, 0.31, 0.3]\nradius = 0.23",
            None,
        ),
        (
            "rod.stl",
            "shape = \"cylinder\"\ncentre = [0.3, 0.31, 0.3]\nradius = 0.15\naxis = 0\nlength = 0.45",
            Some(0),
        ),
    ];
    for (file, exact, axis) in cases {
        let (mesh, shape) = (
            sites(&dir, &format!("shape = \"mesh\"\nfile = \"{file}\"")),
            sites(&dir, exact),
        );
        assert!(shape.len() > 3_000, "{}", shape.len());
        let rel = mesh.len() as f64 / shape.len() as f64 - 1.0;
        assert!(rel.abs() < 0.01, "{file}: {} against {}", mesh.len(), shape.len());
        for s in mesh.symmetric_difference(&shape) {
            let x = s.map(|i| -0.05 + (i as f64 + 0.5) * dx);
            // distance from the surface
            let d = match axis {
                None => ((0..3).map(|a| (x[a] - centre[a]).powi(2)).sum::<f64>().sqrt() - 0.23).abs(),
                Some(ax) => {
                    let r = (0..3)
                        .filter(|&a| a != ax)
                        .map(|a| (x[a] - centre[a]).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    (r - 0.15).abs().min((0.225 - (x[ax] - centre[ax]).abs()).abs())
                }
            };
            assert!(d < 0.5 * dx, "{file}: site {x:?} at {d} m from the surface");
        }
    }
}

/// The Wigley hull (L = 0.5 m, B = 0.1 m, T = 0.1 m, 11 756 triangles) fills its analytic
/// volume 4/9·LBT within 1 % at dx = 5 mm (100 spacings along, 20 across and down), and
/// `hsph check` reports the mesh.
#[test]
fn the_wigley_hull_fills_four_ninths_of_l_b_t() {
    let dir = temp_dir("mesh-wigley");
    stl(
        &dir,
        "hull.stl",
        &["wigley", "--length", "0.5", "--beam", "0.1", "--draft", "0.1"],
    );
    let body = "shape = \"mesh\"\nfile = \"hull.stl\"\ntranslate = [0.3, 0.3, 0.4]";
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene(body)).unwrap();
    let s = load_scene(&path, &["discretisation.dx=0.005".to_string()])
        .unwrap()
        .0;
    let p = build_particles::<3>(&s).unwrap();
    let n = (0..p.n_owned)
        .filter(|&i| p.kind[i] == hsph::particles::Kind::Fluid)
        .count();
    let exact = 4.0 / 9.0 * 0.5 * 0.1 * 0.1;
    let rel = n as f64 * 0.005f64.powi(3) / exact - 1.0;
    assert!(rel.abs() < 0.01, "{n} sites: volume {:+.3} %", 100.0 * rel);
    let o = Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(["check", path.to_str().unwrap()])
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        out.contains("mesh of 11756 triangles (binary STL") && out.contains("normals outward"),
        "{out}"
    );
}

/// The binary STL of `files`' triangles in order (each a binary STL; the first one's header).
fn joined(files: &[&[u8]]) -> Vec<u8> {
    let mut out = files[0][..80].to_vec();
    let n: usize = files.iter().map(|b| (b.len() - 84) / 50).sum();
    out.extend_from_slice(&(n as u32).to_le_bytes());
    for b in files {
        out.extend_from_slice(&b[84..]);
    }
    out
}

/// [`scene`]'s text made 2D: its vectors lose their y component (the floor is then a plate
/// under [−0.04, 0.64] in x).
fn to_2d(text: &str) -> String {
    text.replace("dimension = 3", "dimension = 2")
        .replace("[-0.05, -0.05, -0.05]", "[-0.05, -0.05]")
        .replace("[0.65, 0.65, 0.65]", "[0.65, 0.65]")
        .replace("[0.0, 0.0, -9.81]", "[0.0, -9.81]")
        .replace("[-0.04, -0.04, -0.04]", "[-0.04, -0.04]")
        .replace("[0.64, 0.64, 0.0]", "[0.64, 0.0]")
}

/// A 2D scene cuts a 3D mesh by `slice = { axis, at }`, the other two axes in order: a box
/// (faces on sites) cut across y builds the 2D block of its (x, z) section bit for bit,
/// hydrostatic density included; a fine sphere cut through its centre across x builds the
/// disc's sites up to half a spacing from the circle, counts within 1 %.
#[test]
fn a_slice_of_a_mesh_builds_its_section_in_2d() {
    let dir = temp_dir("mesh-slice");
    let load2 = |body: &str, overrides: &[&str]| {
        let path = dir.join("scene.toml");
        std::fs::write(&path, to_2d(&scene(body))).unwrap();
        let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        load_scene(&path, &o)
    };
    let fluid2 = |s: &Scene| -> Vec<[u64; 4]> {
        let p = build_particles::<2>(s).unwrap();
        (0..p.n_owned)
            .filter(|&i| p.kind[i] == hsph::particles::Kind::Fluid)
            .map(|i| [p.x[i][0], p.x[i][1], p.rho[i], p.mass[i]].map(f64::to_bits))
            .collect()
    };
    let dyadic = ["discretisation.dx=0.015625", "domain.min=[-0.0625, -0.0625]"];
    let (lo, hi) = (
        [13.0 / 128.0, 11.0 / 128.0, 1.0 / 128.0],
        [51.0 / 128.0, 39.0 / 128.0, 27.0 / 128.0],
    );
    let b: Vec<String> = lo.iter().chain(&hi).map(|x| x.to_string()).collect();
    stl(
        &dir,
        "box.stl",
        &["box", "--min", &b[0], &b[1], &b[2], "--max", &b[3], &b[4], &b[5]],
    );
    let block = load2(
        &format!("min = [{}, {}]\nmax = [{}, {}]", b[0], b[2], b[3], b[5]),
        &dyadic,
    )
    .unwrap()
    .0;
    let want = fluid2(&block);
    assert_eq!(want.len(), 19 * 13);
    let cut = load2(
        "shape = \"mesh\"\nfile = \"box.stl\"\nslice = { axis = 1, at = 0.2 }",
        &dyadic,
    )
    .unwrap()
    .0;
    assert_eq!(cut.fluids[0].min, block.fluids[0].min);
    assert_eq!(cut.fluids[0].max, block.fluids[0].max);
    assert!(
        fluid2(&cut) == want,
        "{} against {}",
        fluid2(&cut).len(),
        want.len()
    );
    // the sphere's section against the disc
    stl(
        &dir,
        "ball.stl",
        &[
            "sphere", "--centre", "0.3", "0.3", "0.3", "--radius", "0.143", "--bands", "200",
        ],
    );
    let sites = |s: &Scene| -> std::collections::BTreeSet<[i64; 2]> {
        fluid2(s)
            .iter()
            .map(|p| [0, 1].map(|a| ((f64::from_bits(p[a]) + 0.05) / 0.02 - 0.5).round() as i64))
            .collect()
    };
    let disc = sites(
        &load2("shape = \"sphere\"\ncentre = [0.3, 0.3]\nradius = 0.143", &[])
            .unwrap()
            .0,
    );
    let section = sites(
        &load2(
            "shape = \"mesh\"\nfile = \"ball.stl\"\nslice = { axis = 0, at = 0.3 }",
            &[],
        )
        .unwrap()
        .0,
    );
    let (n_disc, n_cut) = (disc.len() as f64, section.len() as f64);
    assert!((n_cut / n_disc - 1.0).abs() < 0.01, "{n_cut} against {n_disc}");
    for s in disc.symmetric_difference(&section) {
        let x = s.map(|i| -0.05 + (i as f64 + 0.5) * 0.02);
        let r = (x[0] - 0.3).hypot(x[1] - 0.3);
        assert!((r - 0.143).abs() < 0.01, "site {x:?} at r = {r}");
    }
}

/// A plane beside the mesh, a bad axis, `slice` on a block, and `slice` in a 3D scene are
/// refused by key.
#[test]
fn a_bad_slice_is_refused_by_key() {
    let dir = temp_dir("mesh-slice-bad");
    stl(
        &dir,
        "box.stl",
        &["box", "--min", "0.1", "0.1", "0", "--max", "0.4", "0.3", "0.2"],
    );
    let load2 = |body: &str| {
        let path = dir.join("scene.toml");
        std::fs::write(&path, to_2d(&scene(body))).unwrap();
        load_scene(&path, &[])
    };
    let m = "shape = \"mesh\"\nfile = \"box.stl\"\n";
    for (body, key, needle) in [
        (
            format!("{m}slice = {{ axis = 1, at = 0.9 }}"),
            "fluid[0].slice",
            "misses the mesh",
        ),
        (
            format!("{m}slice = {{ axis = 3, at = 0.1 }}"),
            "fluid[0].slice",
            "an axis of 0, 1 or 2",
        ),
        (
            "min = [0.1, 0.0]\nmax = [0.3, 0.1]\nslice = { axis = 1, at = 0.2 }".into(),
            "fluid[0].slice",
            "belongs to `shape = \"mesh\"`",
        ),
    ] {
        let e = load2(&body).expect_err(&body).to_string();
        assert!(e.contains(key) && e.contains(needle), "{e}");
    }
    let path = dir.join("three.toml");
    std::fs::write(&path, scene(&format!("{m}slice = {{ axis = 1, at = 0.2 }}"))).unwrap();
    let e = load_scene(&path, &[]).expect_err("3D slice").to_string();
    assert!(
        e.contains("fluid[0].slice") && e.contains("this scene is 3D"),
        "{e}"
    );
}

/// A good box in DIR/box.stl and, beside it, the bad files of [`a_bad_mesh_is_an_input_error`]:
/// cut short, a NaN, a missing triangle (3 open edges), a turned triangle, no triangle, every
/// triangle turned (normals inward), a header counting 10⁹ triangles, a header counting one
/// fewer than the file holds, a FIFO, a link to /dev/zero; and `crossing.stl`, the box and a
/// second box through it.
pub(crate) fn write_bad_files(dir: &Path) {
    let good = stl(
        dir,
        "box.stl",
        &["box", "--min", "0.1", "0.1", "0", "--max", "0.4", "0.3", "0.2"],
    );
    let bytes = std::fs::read(&good).unwrap();
    let mut nan = bytes.clone();
    nan[84 + 12..84 + 16].copy_from_slice(&f32::NAN.to_le_bytes());
    let mut open = bytes.clone();
    open.truncate(84 + 50 * 11);
    open[80..84].copy_from_slice(&11u32.to_le_bytes());
    let mut turned = bytes.clone();
    // swap the second and third corners of triangle 4
    let t = 84 + 50 * 3 + 12;
    let (b, c) = (turned[t + 12..t + 24].to_vec(), turned[t + 24..t + 36].to_vec());
    turned[t + 12..t + 24].copy_from_slice(&c);
    turned[t + 24..t + 36].copy_from_slice(&b);
    let mut inward = bytes.clone();
    for k in 0..12 {
        let t = 84 + 50 * k + 12;
        let (b, c) = (inward[t + 12..t + 24].to_vec(), inward[t + 24..t + 36].to_vec());
        inward[t + 12..t + 24].copy_from_slice(&c);
        inward[t + 24..t + 36].copy_from_slice(&b);
    }
    let mut huge = bytes.clone();
    huge[80..84].copy_from_slice(&1_000_000_000u32.to_le_bytes());
    let mut lying = bytes.clone();
    lying[80..84].copy_from_slice(&11u32.to_le_bytes());
    let other = std::fs::read(stl(
        dir,
        "other.stl",
        &[
            "box", "--min", "0.2", "0.15", "0.05", "--max", "0.5", "0.25", "0.15",
        ],
    ))
    .unwrap();
    let files: [(&str, Vec<u8>); 9] = [
        ("cut.stl", bytes[..bytes.len() - 7].to_vec()),
        ("nan.stl", nan),
        ("open.stl", open),
        ("turned.stl", turned),
        ("empty.stl", b"solid x\nendsolid x\n".to_vec()),
        ("inward.stl", inward),
        ("huge.stl", huge),
        ("lying.stl", lying),
        ("crossing.stl", joined(&[&bytes, &other])),
    ];
    for (name, b) in &files {
        std::fs::write(dir.join(name), b).unwrap();
    }
    let fifo = dir.join("fifo.stl");
    let _ = std::fs::remove_file(&fifo);
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let zero = dir.join("zero.stl");
    let _ = std::fs::remove_file(&zero);
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
}

/// Each bad mesh or bad mesh key is refused by `hsph check` with exit status 2, the key, the
/// file where the file is at fault, and the reason.
#[test]
fn a_bad_mesh_is_an_input_error() {
    let dir = temp_dir("mesh-bad");
    write_bad_files(&dir);
    std::fs::create_dir_all(dir.join("folder.stl")).unwrap();
    let cases = bad_cases();
    assert!(cases.len() >= 20, "{} cases", cases.len());
    let path = dir.join("scene.toml");
    for (body, key, needle) in &cases {
        std::fs::write(&path, scene(body)).unwrap();
        let (code, _, err) = common::hsph(&["check", path.to_str().unwrap()]);
        assert_eq!(code, 2, "{body}: {err}");
        assert!(
            err.contains(&format!("key `{key}`")) && err.contains(needle),
            "{body}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    // a mesh in 2D
    let two_d = to_2d(&scene("shape = \"mesh\"\nfile = \"box.stl\""));
    let err = match load_scene_str(&two_d, &dir.join("x.toml"), "x", &[]) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("fluid[0].slice accepted"),
    };
    assert!(
        err.contains("fluid[0].slice") && err.contains("a mesh in a 2D scene is cut by a plane"),
        "{err}"
    );
    // a mesh refinement region, once refused ("cannot be a mesh yet"), loads with the box of
    // its mesh (the file's 32-bit corners) and the mesh kept for its depths
    let region = format!(
        "{}\n[[refine]]\nshape = \"mesh\"\nfile = \"box.stl\"\nlevel = 1\n",
        scene("min = [0.1, 0.1, 0.0]\nmax = [0.4, 0.3, 0.2]")
    );
    let s = load_scene_str(&region, &dir.join("x.toml"), "x", &[]).unwrap().0;
    let f32s = |v: [f32; 3]| v.map(f64::from).to_vec();
    assert_eq!(s.refine[0].min, f32s([0.1, 0.1, 0.0]));
    assert_eq!(s.refine[0].max, f32s([0.4, 0.3, 0.2]));
    assert_eq!(s.refine[0].mesh.as_ref().map(|m| m.triangles()), Some(12));
}

/// A mesh refinement region refuses, by key with exit status 2, what only a body takes
/// (`fill`, `layers`: a region holds every point inside its surface), a placement that takes
/// it out of the domain (as a body's), and the placement keys on a region of another shape.
#[test]
fn a_mesh_region_refuses_a_fill_and_the_outside_by_key() {
    let dir = temp_dir("mesh-region-bad");
    stl(
        &dir,
        "box.stl",
        &["box", "--min", "0.1", "0.1", "0", "--max", "0.4", "0.3", "0.2"],
    );
    let path = dir.join("scene.toml");
    let region = |keys: &str| {
        format!(
            "{}\n[[refine]]\n{keys}\nlevel = 1\n",
            scene("min = [0.1, 0.1, 0.0]\nmax = [0.4, 0.3, 0.2]")
        )
    };
    let mesh = "shape = \"mesh\"\nfile = \"box.stl\"";
    for (keys, key, needle) in [
        (
            format!("{mesh}\nfill = \"shell\""),
            "refine[0].fill",
            "refines every point inside it",
        ),
        (
            format!("{mesh}\nlayers = 2"),
            "refine[0].layers",
            "refines every point inside it",
        ),
        (
            format!("{mesh}\nfill = \"inside\""),
            "refine[0].fill",
            "belongs to a mesh body",
        ),
        (
            format!("{mesh}\ntranslate = [0.5, 0.0, 0.0]"),
            "refine[0].translate",
            "on axis 0, outside the domain [-0.05, 0.65]",
        ),
        (
            "min = [0.1, 0.1, 0.0]\nmax = [0.4, 0.3, 0.2]\nscale = 2.0".to_string(),
            "refine[0].scale",
            "belongs to `shape = \"mesh\"`; this body is a block",
        ),
    ] {
        std::fs::write(&path, region(&keys)).unwrap();
        let (code, _, err) = common::hsph(&["check", path.to_str().unwrap()]);
        assert_eq!(code, 2, "{keys}: {err}");
        assert!(
            err.contains(&format!("key `{key}`")) && err.contains(needle),
            "{keys}: {err}"
        );
    }
    // the region as written is accepted, and `check` reports its mesh
    std::fs::write(&path, region(mesh)).unwrap();
    let (code, out, err) = common::hsph(&["check", path.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("refine[0] (level 1): mesh of 12 triangles (binary STL"),
        "{out}"
    );
}

/// A refinement region given as a box mesh cut across y (`slice`) is the block region of its
/// section: the drifting periodic water of `tests/data/drift_split_2d.toml` through an
/// adaptive level-1 region with the level's h (its ramp over the transition band is the
/// region's depth; splitting on entry needs a depth of the particle's spacing, merging on exit
/// a clearance of it) runs to t = 0.1 s with the same `final.csv` bits as through the block,
/// particles having split and merged; and to the same bits on 3 ranks.
#[test]
fn a_box_mesh_region_runs_the_block_region_bit_for_bit() {
    let dir = temp_dir("mesh-region-run");
    // corners exact in the file's 32-bit floats; 1 m across the cut plane
    stl(
        &dir,
        "region.stl",
        &[
            "box", "--min", "0.1875", "-0.5", "0.0625", "--max", "0.3125", "0.5", "0.15625",
        ],
    );
    let text = std::fs::read_to_string(common::repo_path("tests/data/drift_split_2d.toml")).unwrap();
    let shipped = "min = [0.2, 0.05]\nmax = [0.3, 0.15]\nlevel = 1\nadapt = true";
    assert!(text.contains(shipped));
    let with = |region: &str| {
        text.replace(
            shipped,
            &format!("{region}\nlevel = 1\nadapt = true\nsmoothing_length = \"level\""),
        )
    };
    let run = |name: &str, region: &str, ranks: &str| {
        let path = dir.join(format!("{name}.toml"));
        std::fs::write(&path, with(region)).unwrap();
        let out = dir.join(format!("{name}-{ranks}"));
        let (code, _, err) = common::hsph(&[
            "run",
            path.to_str().unwrap(),
            "-q",
            "--force",
            "--threads",
            "1",
            "--ranks",
            ranks,
            "--set",
            "time.t_end=0.1",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        (std::fs::read(out.join("final.csv")).unwrap(), summary)
    };
    let (block, _) = run("block", "min = [0.1875, 0.0625]\nmax = [0.3125, 0.15625]", "1");
    let meshed = "shape = \"mesh\"\nfile = \"region.stl\"\nslice = { axis = 1, at = 0.0 }";
    let (mesh, summary) = run("mesh", meshed, "1");
    for what in ["splits", "merges"] {
        assert!(summary[what].as_u64().unwrap() > 0, "no {what}: {summary}");
    }
    assert_eq!(summary["inputs"]["meshes"][0]["key"], "refine[0]");
    assert!(
        block == mesh,
        "the mesh region's run differs from the block region's"
    );
    let (three, _) = run("mesh", meshed, "3");
    assert!(three == mesh, "the mesh region's run differs on 3 ranks");
}

/// The bodies of [`a_bad_mesh_is_an_input_error`]'s scenes, each with the key its refusal
/// names and a phrase of the reason (the files are [`write_bad_files`]'s).
fn bad_cases() -> Vec<(String, &'static str, &'static str)> {
    let m = |extra: &str| format!("shape = \"mesh\"\nfile = \"box.stl\"\n{extra}");
    vec![
        (
            "shape = \"mesh\"\nfile = \"cut.stl\"".into(),
            "fluid[0].file",
            "truncated, or not an STL",
        ),
        (
            "shape = \"mesh\"\nfile = \"nan.stl\"".into(),
            "fluid[0].file",
            "triangle 1 has a coordinate that is not finite",
        ),
        (
            "shape = \"mesh\"\nfile = \"open.stl\"".into(),
            "fluid[0].file",
            "not closed: 3 open edge(s)",
        ),
        (
            "shape = \"mesh\"\nfile = \"turned.stl\"".into(),
            "fluid[0].file",
            "normals are inconsistent",
        ),
        (
            "shape = \"mesh\"\nfile = \"empty.stl\"".into(),
            "fluid[0].file",
            "holds no triangle",
        ),
        (
            "shape = \"mesh\"\nfile = \"folder.stl\"".into(),
            "fluid[0].file",
            "not a regular file",
        ),
        (
            "shape = \"mesh\"\nfile = \"fifo.stl\"".into(),
            "fluid[0].file",
            "not a regular file",
        ),
        (
            "shape = \"mesh\"\nfile = \"zero.stl\"".into(),
            "fluid[0].file",
            "not a regular file",
        ),
        (
            "shape = \"mesh\"\nfile = \"huge.stl\"".into(),
            "fluid[0].file",
            "header counts 1000000000 triangles",
        ),
        (
            "shape = \"mesh\"\nfile = \"lying.stl\"".into(),
            "fluid[0].file",
            "header counts 11 triangles, 84 + 50·11 = 634 bytes, but the file has 684",
        ),
        (
            "shape = \"mesh\"\nfile = \"inward.stl\"".into(),
            "fluid[0].file",
            "normals point inward (signed volume -1.2000e-2 m³",
        ),
        (
            m("flip = true"),
            "fluid[0].file",
            "the file's own normals point outward already; remove `fluid[0].flip`",
        ),
        (
            "shape = \"mesh\"\nfile = \"none.stl\"".into(),
            "fluid[0].file",
            "relative to the scene file",
        ),
        ("shape = \"mesh\"".into(), "fluid[0].file", "a mesh needs `file"),
        (m("scale = -1.0"), "fluid[0].scale", "positive factor"),
        (
            m("rotate = [0.0, 90.0]"),
            "fluid[0].rotate",
            "three finite numbers",
        ),
        (
            m("translate = [1.0, 0.0, 0.0]"),
            "fluid[0].translate",
            "outside the domain",
        ),
        (
            m("radius = 0.1"),
            "fluid[0].shape",
            "a mesh takes file, scale, rotate and translate",
        ),
        (
            m("min = [0.0, 0.0, 0.0]"),
            "fluid[0].min",
            "the box of a mesh comes from its file",
        ),
        (
            m("sha256 = \"00\""),
            "fluid[0].sha256",
            "has changed since the scene was resolved",
        ),
        (
            "min = [0.1, 0.1, 0.0]\nmax = [0.4, 0.3, 0.2]\nscale = 2.0".into(),
            "fluid[0].scale",
            "belongs to `shape = \"mesh\"`",
        ),
        (
            "min = [0.1, 0.1, 0.0]\nmax = [0.4, 0.3, 0.2]\nflip = false".into(),
            "fluid[0].flip",
            "belongs to `shape = \"mesh\"`",
        ),
    ]
}

/// An inward box with `flip = true` builds the box's particles, and a box with a second box
/// through it is built with a warning naming a crossing pair, one triangle of each box.
#[test]
fn a_flipped_mesh_is_the_box_and_a_crossing_mesh_warns() {
    let dir = temp_dir("mesh-flip-cross");
    write_bad_files(&dir);
    let path = dir.join("scene.toml");
    // the inward box with `flip = true` is the box
    let sites_of = |file: &str, extra: &str| {
        let s = load_in(&dir, &format!("shape = \"mesh\"\nfile = \"{file}\"\n{extra}"));
        fluid(&s)
    };
    assert_eq!(sites_of("inward.stl", "flip = true"), sites_of("box.stl", ""));
    // a box with a second one through it is built, with a warning naming a crossing pair
    std::fs::write(&path, scene("shape = \"mesh\"\nfile = \"crossing.stl\"")).unwrap();
    let (code, out, err) = common::hsph(&["check", path.to_str().unwrap()]);
    let all = out + &err;
    assert_eq!(code, 0, "{all}");
    let warning = all
        .lines()
        .find(|l| l.contains("cross each other"))
        .unwrap_or_else(|| panic!("{all}"));
    let pair: Vec<usize> = warning
        .split("triangles ")
        .nth(1)
        .unwrap()
        .split(" cross")
        .next()
        .unwrap()
        .split(" and ")
        .map(|t| t.parse().unwrap())
        .collect();
    assert!(
        warning.contains("fluid[0].file") && pair[0] <= 12 && pair[1] > 12,
        "{warning}"
    );
}

/// Random bytes, random cuts of a good file and random triangle soups are refused as input
/// errors or built, never a panic; and boxes turned by random angles claim exactly the sites
/// inside the turned box (sites within 10⁻⁹ m of a face are left out of the comparison).
#[test]
fn random_meshes_are_refused_or_built_never_a_panic() {
    let dir = temp_dir("mesh-fuzz");
    let good = std::fs::read(stl(
        &dir,
        "box.stl",
        &["box", "--min", "0.1", "0.1", "0", "--max", "0.4", "0.3", "0.2"],
    ))
    .unwrap();
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene("shape = \"mesh\"\nfile = \"f.stl\"")).unwrap();
    let (mut built, mut refused) = (0, 0);
    for case in 0..300 {
        let bytes: Vec<u8> = match case % 3 {
            0 => {
                let n = (next() % 400) as usize;
                let mut b: Vec<u8> = (0..n).map(|_| next() as u8).collect();
                if case % 2 == 0 && n > 6 {
                    b[..6].copy_from_slice(b"solid ");
                }
                b
            }
            1 if case % 2 == 0 => good.clone(),
            1 => good[..(next() as usize % (good.len() + 1))].to_vec(),
            _ => {
                let n = 1 + next() % 20;
                let mut b = vec![b' '; 80];
                b.extend_from_slice(&(n as u32).to_le_bytes());
                for _ in 0..n {
                    b.extend_from_slice(&[0u8; 12]);
                    for _ in 0..9 {
                        b.extend_from_slice(&(0.05 + 0.5 * (next() % 1000) as f32 / 1000.0).to_le_bytes());
                    }
                    b.extend_from_slice(&[0, 0]);
                }
                b
            }
        };
        std::fs::write(dir.join("f.stl"), &bytes).unwrap();
        match load_scene(&path, &[]) {
            Ok((s, _)) => {
                build_particles::<3>(&s).unwrap();
                built += 1;
            }
            Err(e) => {
                assert!(matches!(e, hsph::error::Error::Input { .. }), "case {case}: {e}");
                refused += 1;
            }
        }
    }
    assert!(built > 0 && refused > 200, "{built} built, {refused} refused");
    // turned boxes against the analytic inside
    for case in 0..8 {
        let ang = [0, 1, 2].map(|_| (next() % 36_000) as f64 / 100.0);
        let body =
            format!("shape = \"mesh\"\nfile = \"box.stl\"\nrotate = {ang:?}\ntranslate = [0.3, 0.3, 0.3]");
        std::fs::write(
            dir.join("box.stl"),
            std::fs::read(stl(
                &dir,
                "c.stl",
                &[
                    "box", "--min", "-0.1", "-0.12", "-0.08", "--max", "0.1", "0.12", "0.08",
                ],
            ))
            .unwrap(),
        )
        .unwrap();
        let got = sites(&dir, &body);
        // the inverse turn: about z, then y, then x, each by −angle
        let inside = |x: [f64; 3]| {
            let mut p = [x[0] - 0.3, x[1] - 0.3, x[2] - 0.3];
            for axis in [2usize, 1, 0] {
                let (s, c) = (-ang[axis]).to_radians().sin_cos();
                let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
                let (a, b) = (p[i], p[j]);
                p[i] = c * a - s * b;
                p[j] = s * a + c * b;
            }
            let half = [0.1, 0.12, 0.08];
            let margin = (0..3).map(|a| half[a] - p[a].abs()).fold(f64::INFINITY, f64::min);
            (margin.abs() > 1e-9).then_some(margin > 0.0)
        };
        let dx = 0.02;
        for k in 0..35i64.pow(3) {
            let s = [k % 35, k / 35 % 35, k / 1225];
            let x = s.map(|i| -0.05 + (i as f64 + 0.5) * dx);
            if let Some(want) = inside(x) {
                assert_eq!(got.contains(&s), want, "case {case} angles {ang:?} site {x:?}");
            }
        }
    }
}

/// A 3D tank (inner box [0, 0.6] × [0, 0.2] × [0, 0.4], dummy walls, open top) with a water
/// column [0, 0.2) × [0, 0.2) × [0, 0.3) and a second wall `OBSTACLE` (its shape keys).
fn tank(obstacle: &str) -> String {
    format!(
        r#"name = "mesh_tank"
dimension = 3
[domain]
min = [-0.07, -0.07, -0.07]
max = [0.67, 0.27, 0.55]
[discretisation]
dx = 0.02
h_over_dx = 1.3
[[material]]
name = "water"
rho0 = 1000.0
c0 = 25.0
eos = "tait"
gamma = 7.0
[physics]
density_diffusion = "antuono"
delta = 0.1
artificial_viscosity = 0.02
body_force = [0.0, 0.0, -9.81]
[[fluid]]
name = "column"
material = "water"
min = [0.0, 0.0, 0.0]
max = [0.2, 0.2, 0.3]
hydrostatic = true
[[wall]]
name = "tank"
shape = "container"
min = [0.0, 0.0, 0.0]
max = [0.6, 0.2, 0.4]
open = ["z+"]
method = "dummy"
[[wall]]
name = "obstacle"
method = "dummy"
{obstacle}
[time]
t_end = 0.25
cfl = 0.2
[output]
interval = 1.0
format = "none"
"#
    )
}

/// Run the scene `text` (written to DIR/NAME.toml) on `ranks` ranks; its `final.csv`.
fn run_tank(dir: &Path, name: &str, text: &str, ranks: &str) -> String {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    let out = dir.join(format!("{name}-{ranks}"));
    let o = Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args([
            "run",
            path.to_str().unwrap(),
            "-q",
            "--threads",
            "1",
            "--ranks",
            ranks,
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::read_to_string(out.join("final.csv")).unwrap()
}

/// A block on the tank's floor as a mesh wall builds the block wall's particles (its shell
/// rows included) bit for bit, and the surge against it runs to the same bits (t = 0.25 s).
#[test]
fn a_box_as_a_mesh_wall_builds_the_block_wall_bit_for_bit() {
    let dir = temp_dir("mesh-wall-box");
    // faces between the sites (at −0.06 + 0.02 k) but the floor's, z = 0, all exact in f32:
    // the bounce reflects across the face's own coordinate
    stl(
        &dir,
        "step.stl",
        &[
            "box", "--min", "0.375", "0.0625", "0", "--max", "0.46875", "0.15625", "0.109375",
        ],
    );
    let block = tank("shape = \"block\"\nmin = [0.375, 0.0625, 0.0]\nmax = [0.46875, 0.15625, 0.109375]");
    let meshed = tank("shape = \"mesh\"\nfile = \"step.stl\"");
    let build = |text: &str| {
        let path = dir.join("b.toml");
        std::fs::write(&path, text).unwrap();
        let s = load_scene(&path, &[]).unwrap().0;
        let p = build_particles::<3>(&s).unwrap();
        (0..p.n_owned)
            .map(|i| [p.x[i][0], p.x[i][1], p.x[i][2], p.rho[i], p.mass[i]].map(f64::to_bits))
            .collect::<Vec<_>>()
    };
    let want = build(&block);
    assert!(build(&meshed) == want);
    assert!(run_tank(&dir, "block", &block, "1") == run_tank(&dir, "meshed", &meshed, "1"));
}

/// A sphere of 24 bands hung in the surge's path as a mesh wall: no fluid particle ends
/// inside it, fluid reaches it, and the run gives the same bits on 1 and 3 ranks.
#[test]
fn a_surge_past_a_mesh_sphere_stays_out_of_it_on_any_layout() {
    let dir = temp_dir("mesh-wall-ball");
    let (c, r) = ([0.4, 0.1, 0.09], 0.07);
    stl(
        &dir,
        "ball.stl",
        &[
            "sphere", "--centre", "0.4", "0.1", "0.09", "--radius", "0.07", "--bands", "24",
        ],
    );
    let text = tank("shape = \"mesh\"\nfile = \"ball.stl\"");
    let one = run_tank(&dir, "ball", &text, "1");
    assert_eq!(one, run_tank(&dir, "ball", &text, "3"), "1 and 3 ranks differ");
    let mut near = 0;
    for row in one.lines().skip(1) {
        let f: Vec<&str> = row.split(',').collect();
        if f[1] != "0" {
            continue;
        }
        let x: Vec<f64> = (3..6).map(|k| f[k].parse().unwrap()).collect();
        let d = ((0..3).map(|a| (x[a] - c[a]).powi(2)).sum::<f64>()).sqrt();
        // the facets lie inside the sphere by up to r (1 − cos(π/24)) = 6e-4 m
        assert!(
            d > r - 1e-3,
            "fluid at {x:?}, {d} m from the centre, inside the ball"
        );
        near += (d < r + 0.03) as usize;
    }
    assert!(near > 20, "{near} fluid particles came near the ball");
}

/// A mesh wall refuses what needs a box (mirror images, open faces, Morris's distances) and a
/// refinement region over it, each as a located input error.
#[test]
fn a_mesh_wall_refuses_what_needs_a_box() {
    let dir = temp_dir("mesh-wall-bad");
    stl(
        &dir,
        "step.stl",
        &[
            "box", "--min", "0.35", "0.05", "0", "--max", "0.45", "0.15", "0.11",
        ],
    );
    let path = dir.join("scene.toml");
    let mesh = "shape = \"mesh\"\nfile = \"step.stl\"";
    let region = "[[refine]]\nmin = [0.3, 0.0, 0.0]\nmax = [0.5, 0.2, 0.2]\nlevel = 1\n";
    for (text, key, needle) in [
        (tank(mesh).replace("name = \"obstacle\"\nmethod = \"dummy\"", "name = \"obstacle\"\nmethod = \"mirror\""), "wall[1].method", "mirror walls"),
        (tank(&format!("{mesh}\nopen = [\"x-\"]")), "wall[1].open", "only a container"),
        (tank(&format!("{mesh}\nno_slip = \"morris\"")), "wall[1].no_slip", "polygon or mesh wall"),
        (tank(&format!("{mesh}\nscale = 0.0")), "wall[1].scale", "positive factor"),
        (tank("min = [0.35, 0.05, 0.0]\nmax = [0.45, 0.15, 0.11]\nshape = \"block\"\nrotate = [0.0, 0.0, 1.0]"), "wall[1].rotate", "belongs to `shape = \"mesh\"`"),
        (format!("{}{region}", tank(mesh)), "refine[0].bodies", "polygon and mesh walls are built"),
    ] {
        std::fs::write(&path, &text).unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_hsph"))
            .args(["check", path.to_str().unwrap()])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{key}: {err}");
        assert!(err.contains(&format!("key `{key}`")) && err.contains(needle), "{key}: {err}");
    }
}

/// In 2D, a box mesh wall cut across y (`slice`) is the block wall of its section: a surge
/// from a water column runs over it to t = 0.3 s with the same `final.csv` as over the block
/// (the wall sites, their shell and the bounce off its faces are the block's).
#[test]
fn a_slice_of_a_box_mesh_wall_is_the_block_wall_in_2d() {
    let dir = temp_dir("mesh-slice-wall");
    stl(
        &dir,
        "box.stl",
        &[
            "box", "--min", "0.5", "-0.5", "0", "--max", "0.75", "0.5", "0.125",
        ],
    );
    let base = r#"name = "slice"
dimension = 2
[domain]
min = [-0.1, -0.1]
max = [1.1, 0.6]
[discretisation]
dx = 0.015625
[[material]]
name = "water"
rho0 = 1000.0
c0 = 30.0
[physics]
density_diffusion = "fourtakas"
artificial_viscosity = 0.02
body_force = [0.0, -9.81]
[[fluid]]
name = "column"
material = "water"
min = [0.0, 0.0]
max = [0.25, 0.375]
hydrostatic = true
[[wall]]
name = "tank"
shape = "container"
min = [0.0, 0.0]
max = [1.0, 0.5]
open = ["y+"]
[[wall]]
name = "obstacle"
OBSTACLE
[time]
t_end = 0.3
[output]
interval = 1.0
format = "none"
"#;
    let run = |name: &str, obstacle: &str| {
        let path = dir.join(format!("{name}.toml"));
        std::fs::write(&path, base.replace("OBSTACLE", obstacle)).unwrap();
        let out = dir.join(name);
        let (code, _, err) = common::hsph(&[
            "run",
            path.to_str().unwrap(),
            "-q",
            "--force",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        std::fs::read(out.join("final.csv")).unwrap()
    };
    let block = run(
        "block",
        "shape = \"block\"\nmin = [0.5, 0.0]\nmax = [0.75, 0.125]",
    );
    let mesh = run(
        "mesh",
        "shape = \"mesh\"\nfile = \"box.stl\"\nslice = { axis = 1, at = 0.0 }",
    );
    assert!(
        block == mesh,
        "the sliced mesh wall's run differs from the block wall's"
    );
}

/// `fill = "shell"` keeps the sites inside a closed mesh within `layers` × dx of its surface:
/// a box mesh as a 2-row shell builds the block's sites less those of the block 2 dx inside
/// it, and `check` says so; `layers` without the shell fill, a shell of 0 rows, and `fill` on
/// a block are refused by key.
#[test]
fn a_shell_fill_keeps_the_rows_inside_the_surface() {
    let dir = temp_dir("mesh-shell-fill");
    stl(
        &dir,
        "box.stl",
        &[
            "box", "--min", "0.09", "0.09", "0.01", "--max", "0.39", "0.29", "0.21",
        ],
    );
    let outer = sites(&dir, "min = [0.09, 0.09, 0.01]\nmax = [0.39, 0.29, 0.21]");
    let inner = sites(&dir, "min = [0.13, 0.13, 0.05]\nmax = [0.35, 0.25, 0.17]");
    let want: std::collections::BTreeSet<_> = outer.difference(&inner).copied().collect();
    assert_eq!(outer.len(), 15 * 10 * 10);
    assert_eq!(want.len(), 15 * 10 * 10 - 11 * 6 * 6);
    let m = "shape = \"mesh\"\nfile = \"box.stl\"\n";
    assert_eq!(sites(&dir, &format!("{m}fill = \"shell\"\nlayers = 2")), want);
    assert_eq!(sites(&dir, &format!("{m}fill = \"inside\"")), outer);
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene(&format!("{m}fill = \"shell\"\nlayers = 2"))).unwrap();
    let (code, out, err) = common::hsph(&["check", path.to_str().unwrap()]);
    let shell = format!("built {} sites, a shell 4.0000e-2 m deep", want.len());
    assert!(code == 0 && out.contains(&shell), "{out}{err}");
    for (body, key, needle) in [
        (
            format!("{m}layers = 2"),
            "fluid[0].layers",
            "set fill = \"shell\"",
        ),
        (
            format!("{m}fill = \"shell\"\nlayers = 0"),
            "fluid[0].layers",
            "1 to 1000 rows",
        ),
        (
            "min = [0.1, 0.1, 0.0]\nmax = [0.4, 0.3, 0.2]\nfill = \"shell\"".into(),
            "fluid[0].fill",
            "belongs to `shape = \"mesh\"`",
        ),
    ] {
        std::fs::write(&path, scene(&body)).unwrap();
        let e = load_scene(&path, &[]).expect_err(&body).to_string();
        assert!(e.contains(key) && e.contains(needle), "{e}");
    }
}
