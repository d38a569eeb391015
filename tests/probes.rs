//! Probes (issue 14): their own clock, instrument-like sensors (pressure transducer with a face
//! and a time window, front of the main body, force and moment on a wall), and the same bits
//! on any number of ranks.

use crate::common;

use std::path::{Path, PathBuf};

fn hsph(args: &[&str]) -> (i32, String) {
    let (code, _, err) = common::hsph(args);
    (code, err)
}

/// Run `scene` (text) written into a fresh directory with extra `--set`s; the run directory.
fn run(tag: &str, scene: &str, extra: &[&str]) -> PathBuf {
    let dir = common::temp_dir(tag);
    let path = dir.join(format!("{tag}.toml"));
    std::fs::write(&path, scene).unwrap();
    let out = dir.join("run");
    let mut args = vec![
        "run",
        path.to_str().unwrap(),
        "-q",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    let (code, err) = hsph(&args);
    assert_eq!(code, 0, "{err}");
    out
}

/// The rows of `probes/<name>.csv` (header dropped), as numbers.
fn rows(run: &Path, name: &str) -> Vec<Vec<f64>> {
    let t = std::fs::read_to_string(run.join("probes").join(format!("{name}.csv"))).unwrap();
    t.lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

fn shipped(name: &str) -> String {
    std::fs::read_to_string(common::repo_path(&format!("inputs/{name}"))).unwrap()
}

fn summary_steps(run: &Path) -> usize {
    let s = std::fs::read_to_string(run.join("summary.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&s).unwrap();
    v["steps"].as_u64().unwrap() as usize
}

/// `interval = 0` writes one row per step (plus t = 0), `interval = 0.005` one row at the first
/// step past each multiple, a probe without an interval one row per output step, while the
/// snapshots stay at the output interval; and the probe files have the same bytes on 1 and 3
/// ranks.
#[test]
fn probes_keep_their_own_clock_and_their_bits_across_ranks() {
    let scene = shipped("dam_break_2d.toml")
        + "\n[[probe]]\nname = \"every\"\nkind = \"pressure\"\npoint = [0.0, 0.03]\ninterval = 0.0\n"
        + "\n[[probe]]\nname = \"coarse\"\nkind = \"gauge\"\npoint = [0.1, 0.0]\ninterval = 0.005\n"
        + "\n[[probe]]\nname = \"wall\"\nkind = \"force\"\nbody = \"tank\"\nabout = [0.292, 0.0]\ninterval = 0.0\n"
        // a front every step: off the output steps it is gathered alone, with positions only,
        // and keeps its bits across ranks too
        + "\n[[probe]]\nname = \"front_every\"\nkind = \"front\"\naxis = 0\ninterval = 0.0\n";
    let sets = [
        "--set",
        "time.t_end=0.02",
        "--set",
        "output.interval=0.01",
        "--set",
        "output.format=\"vtk\"",
    ];
    let one = run("clock1", &scene, &sets);
    let steps = summary_steps(&one);
    assert!(steps > 20, "{steps} steps");
    assert_eq!(rows(&one, "every").len(), steps + 1);
    assert_eq!(rows(&one, "wall").len(), steps + 1);
    assert_eq!(rows(&one, "front_every").len(), steps + 1);
    let coarse: Vec<f64> = rows(&one, "coarse").iter().map(|r| r[0]).collect();
    assert_eq!(coarse.len(), 5, "{coarse:?}");
    for (k, t) in coarse.iter().enumerate() {
        let mark = 0.005 * k as f64;
        assert!(*t >= mark - 1e-12 && *t < mark + 0.001, "row {k} at t = {t}");
    }
    // the shipped probes have no interval: output steps, like the snapshots
    assert_eq!(rows(&one, "front").len(), 3);
    let vtu = std::fs::read_dir(one.join("snapshots"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "pvtu")
        })
        .count();
    assert_eq!(vtu, 3);
    let mut three = sets.to_vec();
    three.extend(["--ranks", "3"]);
    let three = run("clock3", &scene, &three);
    for name in ["every", "coarse", "wall", "front", "front_every", "p_right_wall"] {
        let f = |r: &Path| std::fs::read(r.join("probes").join(format!("{name}.csv"))).unwrap();
        assert!(
            f(&one) == f(&three),
            "probes/{name}.csv differs between 1 and 3 ranks"
        );
    }
}

/// A still tank (`inputs/hydrostatic_2d.toml`, H = 0.5 m, dx = 2 cm, to t = 0.2 s): pressure
/// transducers on the side wall's face read ρ0 g d within 2 % at depths 0.45, 0.35 and 0.25 m
/// (a point, a 4 cm face, a 4 cm face averaged over 0.05 s); the force the water exerts on the
/// tank is −W − dP/dt (fluid–fluid forces cancel pairwise), which the breathing of the column
/// keeps within 1.5 % of the weight W = Σ m g and, averaged over 0.12 s, within 0.3 %; the
/// tank is symmetric, so sideways force and moment about its centre line vanish.
#[test]
fn still_tank_sensors_read_hydrostatic_pressure_and_the_weight() {
    let mut scene = shipped("hydrostatic_2d.toml");
    for (name, y, extra) in [
        ("p45", 0.05, ""),
        ("p35", 0.15, "diameter = 0.04\nnormal = [1.0, 0.0]\n"),
        (
            "p25",
            0.25,
            "diameter = 0.04\nnormal = [1.0, 0.0]\nwindow = 0.05\n",
        ),
    ] {
        scene += &format!("\n[[probe]]\nname = \"{name}\"\nkind = \"pressure\"\npoint = [0.0, {y}]\n{extra}");
    }
    scene += "\n[[probe]]\nname = \"tank\"\nkind = \"force\"\nbody = \"tank\"\nabout = [0.5, 0.0]\n";
    scene += "\n[[probe]]\nname = \"tank_mean\"\nkind = \"force\"\nbody = \"tank\"\nwindow = 0.12\n";
    let out = run("still", &scene, &["--set", "time.t_end=0.2"]);
    let (rho0, g) = (1000.0, 9.81);
    for (name, depth) in [("p45", 0.45), ("p35", 0.35), ("p25", 0.25)] {
        let last = rows(&out, name).last().unwrap().clone();
        let exact = rho0 * g * depth;
        let rel = (last[1] - exact) / exact;
        eprintln!(
            "{name}: {:.1} Pa against ρ0 g d = {exact:.1} Pa ({:+.2} %)",
            last[1],
            100.0 * rel
        );
        assert!(rel.abs() <= 0.02, "{name}: {} Pa against {exact} Pa", last[1]);
    }
    let ts = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    let col = ts
        .lines()
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == "mass")
        .unwrap();
    let mass: f64 = ts
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .nth(col)
        .unwrap()
        .parse()
        .unwrap();
    let weight = mass * g;
    let f = rows(&out, "tank").last().unwrap().clone();
    let mean = rows(&out, "tank_mean").last().unwrap().clone();
    eprintln!(
        "force on the tank: fx {:.3} N/m, fy {:.3} N/m (over 0.12 s: {:.3}), mz {:.4} N; weight {weight:.3} N/m",
        f[1], f[2], mean[2], f[3]
    );
    // the water column breathes (acoustic mode, period ≈ 0.06 s, ±1 % of the weight), and the
    // instantaneous force is −W − dP/dt; over two periods it is the weight
    assert!(
        (f[2] + weight).abs() <= 0.015 * weight,
        "fy {} against −{weight}",
        f[2]
    );
    assert!(
        (mean[2] + weight).abs() <= 0.003 * weight,
        "mean fy {} against −{weight}",
        mean[2]
    );
    assert!(f[1].abs() <= 1e-6 * weight, "fx {}", f[1]);
    assert!(f[3].abs() <= 1e-6 * weight * 0.5, "mz {}", f[3]);
}

/// A front gathered with positions alone (`probes::fields_of`: no reference tracker, so no
/// view of every field) is the brute-force front of the final state: the dam break of
/// `inputs/dam_break_2d.toml` without its reference, after 0.05 s, a front probe at every step;
/// its last row against the largest group of fluid particles of `final.csv` linked within
/// 1.5 dx (union–find over every pair, ties to the group of the smallest id), its largest x.
#[test]
fn a_front_from_positions_alone_is_the_brute_force_front() {
    let shipped = shipped("dam_break_2d.toml");
    let cut = shipped.find("[reference]").expect("the scene's reference");
    let scene = shipped[..cut].to_string()
        + "\n[[probe]]\nname = \"front_every\"\nkind = \"front\"\naxis = 0\ninterval = 0.0\n";
    let sets = ["--set", "time.t_end=0.05", "--set", "output.format=\"none\""];
    let out = run("front_brute", &scene, &sets);
    let text = std::fs::read_to_string(out.join("final.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (id, kind, x, y) = (col("id"), col("kind"), col("x"), col("y"));
    // fluid particles (kind 0) in id order: (id, x, y)
    let mut fluid: Vec<(u64, f64, f64)> = lines
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|v| v[kind] == "0")
        .map(|v| {
            (
                v[id].parse().unwrap(),
                v[x].parse().unwrap(),
                v[y].parse().unwrap(),
            )
        })
        .collect();
    fluid.sort_by_key(|f| f.0);
    assert!(fluid.len() > 1000, "{} fluid particles", fluid.len());
    let link = 1.5 * 0.006;
    let mut parent: Vec<usize> = (0..fluid.len()).collect();
    fn root(parent: &[usize], mut i: usize) -> usize {
        while parent[i] != i {
            i = parent[i];
        }
        i
    }
    for i in 0..fluid.len() {
        for j in i + 1..fluid.len() {
            let (dx, dy) = (fluid[i].1 - fluid[j].1, fluid[i].2 - fluid[j].2);
            if dx * dx + dy * dy < link * link {
                let (a, b) = (root(&parent, i), root(&parent, j));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
    }
    let mut size = vec![0usize; fluid.len()];
    for i in 0..fluid.len() {
        size[root(&parent, i)] += 1;
    }
    let main = (0..fluid.len())
        .max_by_key(|&r| (size[r], std::cmp::Reverse(r)))
        .unwrap();
    let front = (0..fluid.len())
        .filter(|&i| root(&parent, i) == main)
        .map(|i| fluid[i].1)
        .fold(f64::NEG_INFINITY, f64::max);
    let last = rows(&out, "front_every").pop().unwrap();
    assert_eq!(
        last[1].to_bits(),
        front.to_bits(),
        "probe {} against {front}",
        last[1]
    );
    // the water has moved: the front is past the column's edge (0.146 m; the last lattice
    // column of particles is centred at 0.145 m)
    assert!(front > 0.146 + 0.003, "{front}");
}

/// A block of water with one drop ahead of it and one behind: the front along +x is the
/// block's leading particle and along −x its trailing one; the drops are detached and do not
/// count. Lattice: dx = 1 cm from domain.min = 0, so the block [0.2, 0.4] has particle centres
/// 0.205 … 0.395.
#[test]
fn the_front_ignores_detached_drops_and_looks_both_ways() {
    let scene = r#"
dimension = 2
[domain]
min = [0.0, 0.0]
max = [1.0, 0.5]
[discretisation]
dx = 0.01
[[material]]
name = "water"
rho0 = 1000.0
c0 = 30.0
[physics]
body_force = [0.0, -9.81]
[[fluid]]
name = "block"
material = "water"
min = [0.2, 0.0]
max = [0.4, 0.1]
[[fluid]]
name = "ahead"
material = "water"
min = [0.6, 0.2]
max = [0.62, 0.22]
[[fluid]]
name = "behind"
material = "water"
min = [0.05, 0.3]
max = [0.07, 0.32]
[time]
t_end = 1.0
max_steps = 1
[output]
format = "none"
[[probe]]
name = "plus"
kind = "front"
[[probe]]
name = "minus"
kind = "front"
direction = "-"
[[probe]]
name = "up"
kind = "front"
axis = 1
"#;
    let out = run("front", scene, &[]);
    let first = |name: &str| rows(&out, name)[0][1];
    assert!((first("plus") - 0.395).abs() < 1e-9, "{}", first("plus"));
    assert!((first("minus") - 0.205).abs() < 1e-9, "{}", first("minus"));
    assert!((first("up") - 0.095).abs() < 1e-9, "{}", first("up"));
}

/// Scene errors of the new keys name the key and a valid alternative (exit 2).
#[test]
fn probe_keys_are_checked() {
    let base = shipped("hydrostatic_2d.toml");
    for (extra, key, hint) in [
        ("kind = \"force\"\nbody = \"lid\"\n", "probe[1].body", "tank"),
        (
            "kind = \"pressure\"\npoint = [0.0, 0.1]\ndiameter = 0.04\n",
            "probe[1].normal",
            "normal = [-1.0, 0.0]",
        ),
        (
            "kind = \"pressure\"\npoint = [0.0, 0.1]\ninterval = -1.0\n",
            "probe[1].interval",
            "0 = every step",
        ),
        ("kind = \"front\"\nlink = 0.5\n", "probe[1].link", "1.5"),
        (
            "kind = \"front\"\ndirection = \"up\"\n",
            "probe[1].direction",
            "`+` or `-`",
        ),
    ] {
        let dir = common::temp_dir("probekeys");
        let path = dir.join("s.toml");
        std::fs::write(&path, format!("{base}\n[[probe]]\nname = \"x\"\n{extra}")).unwrap();
        let (code, err) = hsph(&["check", path.to_str().unwrap()]);
        assert_eq!(code, 2, "{extra}: {err}");
        assert!(err.contains(key) && err.contains(hint), "{extra}: {err}");
    }
}
