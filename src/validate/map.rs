//! The stability map of `hsph validate --map`: where each method fails. A study runs a scene
//! for every (method, parameter value) pair until it ends or fails, detects the failure
//! automatically and names it, and draws method × parameter coloured by the failure time.
//!
//! Failures: the run's own stops (exit 1: a non-finite state, a speed beyond
//! `limits.speed_over_c0` × c0, a density outside `limits.density_ratio`, a particle outside
//! the domain, which in these closed boxes went through a wall), total energy growing by more
//! than 1 % of its start (`timeseries.csv`), for the still tank the lattice rearranging (a
//! largest speed above 1 % of √(gH), the tank's `max_speed_over_sqrt_gh`), and for the solid
//! in tension clumping (two particles closer than 0.8 dx at the end). Each study also
//! records one measurement per run: pressure noise, steps, the water's closest approach to
//! the struck wall (penetration when negative), the tank's largest speed, the clumping index.

use super::sweep::run_child;
use crate::error::{Error, Result};
use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Header of `map.csv`.
pub const HEADER: &str = "study,method,parameter,value,status,reason,t_fail,t_end,metric,metric_value,wall_s";

/// One study: a scene, methods (rows), a parameter (columns), a failure judge.
pub struct Study {
    /// Name on the command line.
    pub name: &'static str,
    /// What it shows.
    pub title: &'static str,
    /// Shipped scene it runs (for messages) and its text.
    pub file: &'static str,
    scene: &'static str,
    /// Overrides of every run.
    base: &'static [&'static str],
    /// Methods: name and overrides.
    pub methods: Vec<(&'static str, Vec<String>)>,
    /// Parameter name.
    pub parameter: &'static str,
    /// Parameter values.
    pub values: Vec<f64>,
    /// Overrides of a parameter value.
    set: fn(f64) -> Vec<String>,
    /// Simulated time a run goes to when nothing fails (s), per value.
    t_end: fn(f64) -> f64,
    /// The extra measurement recorded per run (named, from the run directory).
    metric: (&'static str, fn(&Path) -> Option<f64>),
    /// Failure judged from a finished run's directory (reason, time), beyond exit statuses.
    judge: fn(&Path) -> Option<(String, f64)>,
}

/// Every study, in the order `--map` runs them.
pub fn all() -> Vec<Study> {
    vec![diffusion(), cfl(), walls(), lattice(), tensile()]
}

/// Closed-tank dam break overrides: the splash stays inside, so leaving the domain means
/// crossing a wall.
const CLOSED_DAM_BREAK: &[&str] = &[
    "wall[0].open=[]",
    "domain.min=[-0.04,-0.04]",
    "domain.max=[0.64,0.74]",
    "output.format=\"none\"",
];

fn dam_break_methods() -> Vec<(&'static str, Vec<String>)> {
    [
        ("none", "plain WCSPH"),
        ("molteni", "δ-SPH Molteni"),
        ("antuono", "δ-SPH Antuono"),
        ("fourtakas", "δ-SPH Fourtakas"),
    ]
    .into_iter()
    .map(|(d, name)| (name, vec![format!("physics.density_diffusion=\"{d}\"")]))
    // the Riemann solver's pressure and density terms (docs/pressure.md §2d)
    .chain(std::iter::once((
        "Riemann-SPH",
        vec![
            "physics.density_diffusion=\"riemann\"".to_string(),
            "physics.pressure_gradient=\"riemann\"".to_string(),
        ],
    )))
    .collect()
}

fn diffusion() -> Study {
    Study {
        name: "diffusion",
        title: "(a) dam break in a closed tank to 1 s: plain WCSPH against δ-SPH, by artificial viscosity",
        file: "inputs/dam_break_2d.toml",
        scene: include_str!("../../inputs/dam_break_2d.toml"),
        base: CLOSED_DAM_BREAK,
        methods: dam_break_methods(),
        parameter: "artificial viscosity α",
        values: vec![0.0, 0.005, 0.02, 0.1],
        set: |a| {
            vec![
                format!("physics.artificial_viscosity={a}"),
                "time.t_end=1.0".into(),
            ]
        },
        t_end: |_| 1.0,
        metric: ("pressure noise (Pa)", |d| {
            pressure_noise(&d.join("probes/p_right_wall.csv"))
        }),
        judge: energy_growth,
    }
}

fn cfl() -> Study {
    Study {
        name: "cfl",
        title: "(c) dam break in a closed tank to 1 s, α = 0.02: the largest stable CFL number",
        parameter: "CFL number",
        // beyond 1 (scenes warn there) to find where each method fails
        values: vec![0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 3.0],
        set: |c| vec![format!("time.cfl={c}"), "time.t_end=1.0".into()],
        metric: ("steps", |d| summary(d)?["steps"].as_f64()),
        ..diffusion()
    }
}

fn walls() -> Study {
    Study {
        name: "walls",
        title: "(b) a water block thrown at a wall (c0 = 50 m/s): wall methods by impact speed",
        file: "inputs/wall_impact_2d.toml",
        scene: include_str!("../../inputs/wall_impact_2d.toml"),
        base: &[],
        methods: ["dummy", "repulsive", "mirror"]
            .iter()
            .map(|m| (*m, vec![format!("wall[0].method=\"{m}\"")]))
            .collect(),
        parameter: "impact speed (m/s)",
        values: vec![1.25, 2.5, 5.0],
        set: |v| {
            vec![
                format!("fluid[0].velocity=[{v},0.0]"),
                format!("time.t_end={}", 0.6 / v),
            ]
        },
        t_end: |v| 0.6 / v,
        metric: ("closest approach (dx)", closest_approach),
        judge: energy_growth,
    }
}

/// The wall study's penetration measure: the smallest distance, over every step, between the
/// struck wall's face (`wall[0].max` along x) and the leading edge of the water's main body
/// (the scene's `front` probe), in units of dx. The lattice starts ½ off a face; 0 means the
/// water reached the face, a negative value is penetration past it (leakage through the wall
/// is a failure of its own: the particle leaves the closed box).
fn closest_approach(dir: &Path) -> Option<f64> {
    let scene: toml::Value = toml::from_str(&std::fs::read_to_string(dir.join("scene.toml")).ok()?).ok()?;
    let dx = scene.get("discretisation")?.get("dx")?.as_float()?;
    let face = scene.get("wall")?.get(0)?.get("max")?.get(0)?.as_float()?;
    let front = csv_columns(&dir.join("probes/front.csv"), "t", "front")?;
    let reach = front.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
    reach.is_finite().then(|| (face - reach) / dx)
}

fn lattice() -> Study {
    Study {
        name: "lattice",
        title: "(d) still tank to 2 s: does the square lattice hold? kernel by h/dx",
        file: "inputs/hydrostatic_2d.toml",
        scene: include_str!("../../inputs/hydrostatic_2d.toml"),
        base: &[
            "time.t_end=2.0",
            "domain.min=[-0.16,-0.16]",
            "domain.max=[1.16,0.96]",
        ],
        methods: ["wendland_c2", "cubic_spline", "quintic_spline"]
            .iter()
            .map(|k| (*k, vec![format!("discretisation.kernel=\"{k}\"")]))
            .collect(),
        parameter: "h/dx",
        values: vec![1.0, 1.2, 1.3, 1.5, 1.7, 2.0],
        set: |h| vec![format!("discretisation.h_over_dx={h}")],
        t_end: |_| 2.0,
        metric: ("max speed / √(gH)", |d| {
            summary(d)?["errors"]["max_speed_over_sqrt_gh"].as_f64()
        }),
        judge: |d| {
            let v = summary(d)?["errors"]["max_speed_over_sqrt_gh"].as_f64()?;
            // the first output step whose largest speed passed 1 % of √(gH) (g = 9.81, H = 0.5)
            let t = series(d, "max_speed")?
                .into_iter()
                .find(|&(_, s)| s > 0.01 * (9.81f64 * 0.5).sqrt())
                .map_or(2.0, |(t, _)| t);
            (v > 0.01).then(|| ("lattice rearranged".to_string(), t))
        },
    }
}

impl Study {
    /// Name of the metric recorded per run.
    pub fn metric_name(&self) -> &'static str {
        self.metric.0
    }
}

/// A measurement as the map shows it: whole numbers (step counts) whole, others to four
/// significant figures (1027, 0.3209, 0.0009867).
pub fn show_metric(m: f64) -> String {
    if m == m.round() && m.abs() < 1e12 {
        return format!("{m:.0}");
    }
    let digits = (3 - m.abs().log10().floor() as i32).max(0) as usize;
    format!("{m:.digits$}")
}

fn tensile() -> Study {
    Study {
        name: "tensile",
        title: "(e) a solid block under uniform tension (2 × 10⁵ Pa, periodic): artificial stress by kernel",
        file: "tests/data/tension_block.toml",
        scene: include_str!("../../tests/data/tension_block.toml"),
        base: &[],
        methods: [
            ("cubic_spline", 1.3),
            ("wendland_c2", 1.3),
            ("quintic_spline", 1.0),
        ]
        .iter()
        .map(|(k, h)| {
            (
                *k,
                vec![
                    format!("discretisation.kernel=\"{k}\""),
                    format!("discretisation.h_over_dx={h}"),
                ],
            )
        })
        .collect(),
        parameter: "artificial stress ε",
        values: vec![0.0, 0.1, 0.2, 0.3],
        set: |e| vec![format!("physics.artificial_stress={e}")],
        t_end: |_| 0.05,
        metric: ("clumping index", clumping_index),
        // on the exact lattice (the test jitters it) pairs form but stop near 0.63 dx: a pair
        // closer than 0.8 dx at the end counts as clumped (the failure time is the run's end)
        judge: |d| {
            let c = clumping_index(d)?;
            (c < 0.8).then(|| ("clumped".to_string(), 0.05))
        },
    }
}

/// The clumping index of a run's final state: the smallest distance between two particles
/// over dx (1 on the lattice; periodic images counted), from `final.csv` and `scene.toml`.
fn clumping_index(dir: &Path) -> Option<f64> {
    let scene: toml::Value = toml::from_str(&std::fs::read_to_string(dir.join("scene.toml")).ok()?).ok()?;
    let dx = scene["discretisation"]["dx"].as_float()?;
    let span = |k: &str| -> Option<Vec<f64>> {
        scene["domain"][k]
            .as_array()?
            .iter()
            .map(|v| v.as_float())
            .collect()
    };
    let (lo, hi) = (span("min")?, span("max")?);
    let x: Vec<(f64, f64)> = csv_columns(&dir.join("final.csv"), "x", "y")?;
    let pts: Vec<[f64; 2]> = x.iter().map(|&(a, b)| [a, b]).collect();
    let near = crate::probes::disorder::nearest_of(&pts, &[hi[0] - lo[0], hi[1] - lo[1]]);
    let best = near.into_iter().fold(f64::INFINITY, f64::min);
    Some(best / dx)
}

/// The study called `name`, or a message listing them.
pub fn find(name: &str) -> std::result::Result<Study, String> {
    let names: Vec<&str> = all().iter().map(|s| s.name).collect();
    all()
        .into_iter()
        .find(|s| s.name == name)
        .ok_or_else(|| format!("unknown study `{name}`; known studies: {}", names.join(", ")))
}

fn summary(dir: &Path) -> Option<serde_json::Value> {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).ok()?).ok()
}

/// (t, column) pairs of `timeseries.csv`.
fn series(dir: &Path, col: &str) -> Option<Vec<(f64, f64)>> {
    csv_columns(&dir.join("timeseries.csv"), "t", col)
}

fn csv_columns(path: &Path, a: &str, b: &str) -> Option<Vec<(f64, f64)>> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next()?.split(',').collect();
    let (ia, ib) = (
        head.iter().position(|c| *c == a)?,
        head.iter().position(|c| *c == b)?,
    );
    Some(
        lines
            .filter_map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                Some((f.get(ia)?.parse().ok()?, f.get(ib)?.parse().ok()?))
            })
            .collect(),
    )
}

/// Total energy above its start by more than 1 %: the first output time it did.
fn energy_growth(dir: &Path) -> Option<(String, f64)> {
    let e = series(dir, "total_energy")?;
    let e0 = e.first()?.1;
    let scale = e0
        .abs()
        .max(e.iter().map(|p| p.1.abs()).fold(0.0, f64::max) * 1e-3);
    e.iter()
        .find(|p| p.1 - e0 > 0.01 * scale)
        .map(|p| ("energy growth".to_string(), p.0))
}

/// Pressure noise of a sensor file (`t,p`): the rms deviation from the 5 ms centred moving
/// average (Pa).
pub fn pressure_noise(path: &Path) -> Option<f64> {
    let p = csv_columns(path, "t", "p")?;
    if p.len() < 3 {
        return None;
    }
    let mut sum = 0.0;
    for (k, &(t, v)) in p.iter().enumerate() {
        let near: Vec<f64> = p[k.saturating_sub(50)..(k + 50).min(p.len())]
            .iter()
            .filter(|q| (q.0 - t).abs() <= 0.0025)
            .map(|q| q.1)
            .collect();
        let mean = near.iter().sum::<f64>() / near.len() as f64;
        sum += (v - mean).powi(2);
    }
    Some((sum / p.len() as f64).sqrt())
}

/// Why a run that exited 1 stopped, and when: the message's reason and its `t = … s`.
pub fn classify(stderr: &str) -> (String, f64) {
    let line = stderr
        .lines()
        .rev()
        .find(|l| l.starts_with("hsph: error"))
        .unwrap_or("");
    let reason = if line.contains("non-finite") || line.contains("blew up") {
        "NaN / blow-up"
    } else if line.contains("left the domain") {
        "through a wall"
    } else if line.contains("speed_over_c0") {
        "speed limit"
    } else if line.contains("density_ratio") || line.contains("outside") {
        "density out of band"
    } else if line.contains("max_removed_fraction") {
        "particles lost"
    } else {
        "stopped"
    };
    let t = line
        .split("t = ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.trim_end_matches(':').parse().ok())
        .unwrap_or(f64::NAN);
    (reason.to_string(), t)
}

/// One cell of the map (a row of `map.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Study.
    pub study: String,
    /// Method (row).
    pub method: String,
    /// Parameter value (column).
    pub value: f64,
    /// Failure reason, or `None` when stable.
    pub reason: Option<String>,
    /// Failure time (s; NaN when stable).
    pub t_fail: f64,
    /// Simulated time of a run that does not fail (s).
    pub t_end: f64,
    /// The study's metric (NaN where unmeasured).
    pub metric: f64,
    /// Wall time of the child process (s).
    pub wall_s: f64,
}

impl Cell {
    fn to_csv(&self, study: &Study) -> String {
        format!(
            "{},{},{},{},{},{},{:e},{:e},{},{:e},{:.3}",
            self.study,
            self.method,
            study.parameter.replace(',', ";"),
            self.value,
            if self.reason.is_some() { "failed" } else { "stable" },
            self.reason.clone().unwrap_or_default(),
            self.t_fail,
            self.t_end,
            study.metric.0.replace(',', ";"),
            self.metric,
            self.wall_s
        )
    }

    fn from_csv(line: &str) -> Option<Cell> {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 11 {
            return None;
        }
        Some(Cell {
            study: f[0].into(),
            method: f[1].into(),
            value: f[3].parse().ok()?,
            reason: (f[4] == "failed").then(|| f[5].to_string()),
            t_fail: f[6].parse().ok()?,
            t_end: f[7].parse().ok()?,
            metric: f[9].parse().ok()?,
            wall_s: f[10].parse().ok()?,
        })
    }
}

/// Read `map.csv` (empty if absent).
pub fn read_cells(path: &Path) -> Result<Vec<Cell>> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Ok(Vec::new());
    };
    text.lines()
        .enumerate()
        .skip(1)
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(k, l)| {
            Cell::from_csv(l).ok_or_else(|| {
                Error::input(
                    format!("{}:{}", path.display(), k + 1),
                    "is not a map row; delete the line to rerun that run".to_string(),
                )
            })
        })
        .collect()
}

/// Run every (method, value) of `study` not yet in `<out>/map.csv`, one at a time, and return
/// the study's cells; `None` if a stopping signal arrived (forwarded to the run going, which
/// gets no row and runs again when the map resumes).
pub fn run(study: &Study, out: &Path, exe: &Path) -> Result<Option<Vec<Cell>>> {
    super::stop::install()?;
    for d in ["runs", "scenes"] {
        std::fs::create_dir_all(out.join(d)).map_err(|e| Error::io(out, e))?;
    }
    let csv = out.join("map.csv");
    if !csv.exists() {
        crate::output::write_file(&csv, format!("{HEADER}\n").as_bytes())?;
    }
    let done: BTreeSet<(String, String, u64)> = read_cells(&csv)?
        .iter()
        .map(|c| (c.study.clone(), c.method.clone(), c.value.to_bits()))
        .collect();
    let scene = out.join("scenes").join(format!("{}.toml", study.name));
    crate::output::write_file(&scene, study.scene.as_bytes())?;
    let mut file = std::fs::OpenOptions::new()
        .append(true)
        .open(&csv)
        .map_err(|e| Error::io(&csv, e))?;
    for (method, sets) in &study.methods {
        for &v in &study.values {
            if done.contains(&(study.name.to_string(), method.to_string(), v.to_bits())) {
                continue;
            }
            let dir: PathBuf =
                out.join("runs")
                    .join(format!("{}-{}-{v}", study.name, method.replace([' ', '/'], "_")));
            let all: Vec<String> = study
                .base
                .iter()
                .map(|s| s.to_string())
                .chain(sets.iter().cloned())
                .chain((study.set)(v))
                .collect();
            let t0 = std::time::Instant::now();
            if super::stop::stopping() {
                return Ok(None);
            }
            let Some(o) = run_child(exe, &scene, &dir, 1, &all)? else {
                return Ok(None);
            };
            let wall_s = t0.elapsed().as_secs_f64();
            let failure = match o.status.code() {
                Some(0) => (study.judge)(&dir),
                Some(1) => Some(classify(&String::from_utf8_lossy(&o.stderr))),
                code => {
                    let err = String::from_utf8_lossy(&o.stderr);
                    return Err(Error::run(format!(
                        "validate --map {}: {method} at {} = {v}: exit {code:?}: {}",
                        study.name,
                        study.parameter,
                        err.lines().rev().find(|l| l.starts_with("hsph:")).unwrap_or("")
                    )));
                }
            };
            let cell = Cell {
                study: study.name.into(),
                method: method.to_string(),
                value: v,
                t_fail: failure.as_ref().map_or(f64::NAN, |f| f.1),
                reason: failure.map(|f| f.0),
                t_end: (study.t_end)(v),
                metric: (study.metric.1)(&dir).unwrap_or(f64::NAN),
                wall_s,
            };
            eprintln!(
                "hsph validate --map {}: {method}, {} = {v}: {}",
                study.name,
                study.parameter,
                cell.reason.as_ref().map_or("stable".to_string(), |r| format!(
                    "{r} at t = {:.4} s",
                    cell.t_fail
                ))
            );
            writeln!(file, "{}", cell.to_csv(study)).map_err(|e| Error::io(&csv, e))?;
        }
    }
    Ok(Some(
        read_cells(&csv)?
            .into_iter()
            .filter(|c| c.study == study.name)
            .collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stops_are_named_with_their_time() {
        let e = "hsph: warning: x\nhsph: error: rank 0, step 1875, t = 8.452431e-2 s: particle id 5555 left the domain (enlarge) at position [0.8, -0.1]";
        assert_eq!(classify(e), ("through a wall".to_string(), 8.452431e-2));
        let e = "hsph: error: step 2276, t = 5.292906e-1 s: 13 of 1225 moving particles removed, more than domain.max_removed_fraction = 0.01";
        assert_eq!(classify(e).0, "particles lost");
        let e = "hsph: error: rank 1, step 9, t = 1e-3 s: particle id 4 has a non-finite position (the run blew up)";
        assert_eq!(classify(e).0, "NaN / blow-up");
    }

    #[test]
    fn measurements_show_four_significant_figures_and_counts_whole() {
        assert_eq!(show_metric(14319.0), "14319");
        assert_eq!(show_metric(1026.53), "1027");
        assert_eq!(show_metric(0.320949), "0.3209");
        assert_eq!(show_metric(9.867062e-4), "0.0009867");
        assert_eq!(show_metric(0.0), "0");
    }

    #[test]
    fn cells_survive_the_csv() {
        let s = diffusion();
        let c = Cell {
            study: "diffusion".into(),
            method: "plain WCSPH".into(),
            value: 0.005,
            reason: Some("energy growth".into()),
            t_fail: 0.25,
            t_end: 1.0,
            metric: 123.5,
            wall_s: 2.0,
        };
        assert_eq!(Cell::from_csv(&c.to_csv(&s)).unwrap(), c);
    }

    #[test]
    fn noise_is_zero_for_a_steady_signal_and_the_deviation_for_a_zigzag() {
        let dir = std::env::temp_dir().join(format!("hsph-noise-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("p.csv");
        let rows: String = (0..200)
            .map(|k| format!("{},{}\n", k as f64 * 5e-4, 1.0e4))
            .collect();
        std::fs::write(&f, format!("t,p\n{rows}")).unwrap();
        assert!(pressure_noise(&f).unwrap() < 1e-9);
        let rows: String = (0..200)
            .map(|k| format!("{},{}\n", k as f64 * 5e-4, if k % 2 == 0 { 1.0 } else { -1.0 }))
            .collect();
        std::fs::write(&f, format!("t,p\n{rows}")).unwrap();
        let n = pressure_noise(&f).unwrap();
        // a window of an odd number of ±1 samples averages to ±1/(its length), so the
        // deviation is a little below 1
        assert!(n > 0.85 && n < 1.0, "{n}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
