//! Wall pressure at impact against dam-break experiments compiled into hsph
//! (`[reference] kind = "wall_pressure"`, docs/pressure.md): each compared probe's loads
//! (`crate::probes::loads`) against the experiment's sensor of the same name, over the
//! experiment's time window, by one code on both sides.

use crate::probes::loads::{loads, Loads};
use crate::scene::{ExperimentProtocol, PressureExperiment, Scene};
use std::collections::BTreeMap;

/// An experiment's protocol (declared with the scene's reference, `crate::scene`).
fn experiment(e: PressureExperiment) -> ExperimentProtocol {
    e.protocol()
}

/// Lobovsky et al. (2014), H = 300 mm: the 20 kHz run ("peak event 5"), t√(g/H) and
/// p/(ρgH) per sensor (`inputs/reference/`, with its source in the header).
const LOBOVSKY_RUN: &str = include_str!("../../inputs/reference/dambreak_lobovsky2014_H300_pressure_run.csv");
/// Buchner (2002), H = 0.6 m: digitised curves of P1 (three sources) and P2 (one).
const BUCHNER: &str = include_str!("../../inputs/reference/dambreak2d_buchner2002_wall_pressure.csv");

/// Gravity's magnitude (m/s²) the experiments' units use.
const G: f64 = 9.81;
/// Water's density (kg/m³) the experiments' units use.
const RHO: f64 = 1000.0;

/// The experiment's series of `column` as (t in s, p in Pa), sorted by time with points at an
/// equal time dropped (a digitised curve need not be monotonic). A wide table has a header
/// with `tstar` and the column; a long one (`source,sensor,tstar,pstar`) is read as
/// `source/sensor`.
fn series(e: PressureExperiment, column: &str, depth: f64) -> Vec<(f64, f64)> {
    let text = match e {
        PressureExperiment::Lobovsky2014H300 => LOBOVSKY_RUN,
        PressureExperiment::Buchner2002 => BUCHNER,
    };
    let mut lines = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let head: Vec<&str> = lines.next().unwrap_or("").split(',').map(str::trim).collect();
    let at = |name: &str| head.iter().position(|h| *h == name);
    let (ts, ps) = ((depth / G).sqrt(), RHO * G * depth);
    let mut out: Vec<(f64, f64)> = match (column.split_once('/'), at("tstar")) {
        (Some((source, sensor)), Some(it)) => {
            let (isrc, isen, ip) = (at("source"), at("sensor"), at("pstar"));
            lines
                .filter_map(|l| {
                    let f: Vec<&str> = l.split(',').map(str::trim).collect();
                    let ok = f.get(isrc?)? == &source && f.get(isen?)? == &sensor;
                    ok.then_some(())?;
                    Some((f.get(it)?.parse().ok()?, f.get(ip?)?.parse().ok()?))
                })
                .collect()
        }
        (None, Some(it)) => {
            let ic = at(column);
            lines
                .filter_map(|l| {
                    let f: Vec<&str> = l.split(',').map(str::trim).collect();
                    Some((f.get(it)?.parse().ok()?, f.get(ic?)?.parse().ok()?))
                })
                .collect()
        }
        _ => Vec::new(),
    };
    out.iter_mut().for_each(|(t, p)| {
        *t *= ts;
        *p *= ps;
    });
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out.dedup_by(|b, a| b.0 <= a.0);
    out
}

/// The loads of the (t, p) points within [from, to] (s).
fn windowed(points: &[(f64, f64)], (from, to): (f64, f64), filter: f64, span: Option<f64>) -> Option<Loads> {
    let (t, p): (Vec<f64>, Vec<f64>) = points
        .iter()
        .filter(|(t, _)| (from..=to).contains(t))
        .copied()
        .unzip();
    loads(&t, &p, filter, span)
}

/// What `hsph report` draws a compared sensor against: the experiment's depth H (m), the
/// sensor's window (s) and the experiment's points within it (s, Pa).
pub struct Trace {
    /// H (m): t√(g/H) and p/(ρgH) are the chart's units.
    pub depth: f64,
    /// The window (s).
    pub window: (f64, f64),
    /// The experiment's (t, p) within the window.
    pub points: Vec<(f64, f64)>,
}

/// The experiment's trace of sensor `name`, if it has one.
pub fn trace(e: PressureExperiment, name: &str) -> Option<Trace> {
    let ex = experiment(e);
    let sensor = ex.sensors.iter().find(|s| s.name == name)?;
    let ts = (ex.depth / G).sqrt();
    let window = (sensor.window.0 * ts, sensor.window.1 * ts);
    let points = series(e, sensor.column, ex.depth)
        .into_iter()
        .filter(|(t, _)| (window.0..=window.1).contains(t))
        .collect();
    Some(Trace {
        depth: ex.depth,
        window,
        points,
    })
}

/// One compared sensor: the run's loads, the experiment's, both over the experiment's window.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Comparison {
    /// The experiment compared with.
    pub against: PressureExperiment,
    /// The window (s).
    pub window_s: (f64, f64),
    /// The run's loads.
    pub run: Loads,
    /// The experiment's loads.
    pub experiment: Loads,
    /// Filtered peak, run over experiment, less 1 (signed).
    pub peak_error: f64,
    /// Impulse, run over experiment, less 1 (signed), if both have one.
    pub impulse_error: Option<f64>,
}

/// Each sensor of `names` compared: the run's probe series in `dir` (`<name>.raw.csv` where
/// the run wrote one, else `<name>.csv`: `crate::probes::loads_file`; columns t and p) against
/// the experiment. A sensor whose file cannot be read or whose window holds no
/// samples is left out.
pub fn compare(
    scene: &Scene,
    e: PressureExperiment,
    names: &[String],
    dir: &std::path::Path,
) -> BTreeMap<String, Comparison> {
    let ex = experiment(e);
    let ts = (ex.depth / G).sqrt();
    let mut out = BTreeMap::new();
    for name in names {
        let Some(sensor) = ex.sensors.iter().find(|s| s.name == name) else {
            continue;
        };
        let Some(probe) = scene.probes.iter().find(|p| p.name() == name) else {
            continue;
        };
        let Some((filter, span)) = probe.load_rules() else {
            continue;
        };
        let window = (sensor.window.0 * ts, sensor.window.1 * ts);
        let (file, _) = crate::probes::loads_file(dir, probe);
        let Ok((t, p)) = crate::probes::loads::read_csv(&file, ("t", "p"), (1.0, 1.0)) else {
            continue;
        };
        let run_points: Vec<(f64, f64)> = t.into_iter().zip(p).collect();
        let exp_points = series(e, sensor.column, ex.depth);
        let (Some(run), Some(experiment)) = (
            windowed(&run_points, window, filter, span),
            windowed(&exp_points, window, ex.filter.unwrap_or(filter), span),
        ) else {
            continue;
        };
        let peak_error = run.filtered_max / experiment.filtered_max - 1.0;
        let impulse_error = match (run.impulse, experiment.impulse) {
            (Some(a), Some(b)) if b != 0.0 => Some(a / b - 1.0),
            _ => None,
        };
        out.insert(
            name.clone(),
            Comparison {
                against: e,
                window_s: window,
                run,
                experiment,
                peak_error,
                impulse_error,
            },
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The compiled-in series parse: Lobovsky's 20 kHz run through its columns, Buchner's
    /// digitised curves through `source/sensor`, in seconds and pascals, time increasing.
    #[test]
    fn the_experiments_series_parse_in_si_units() {
        for e in [
            PressureExperiment::Lobovsky2014H300,
            PressureExperiment::Buchner2002,
        ] {
            let ex = experiment(e);
            for s in ex.sensors {
                let pts = series(e, s.column, ex.depth);
                assert!(pts.len() > 40, "{e:?} {}: {} points", s.name, pts.len());
                assert!(pts.windows(2).all(|w| w[1].0 > w[0].0), "{e:?} {}", s.name);
            }
        }
        // Lobovsky's S1 peaks at 3.04 ρgH (docs/pressure.md §1), 2943 Pa per unit
        let s1 = series(PressureExperiment::Lobovsky2014H300, "p_sensor1_3mm", 0.3);
        let top = s1.iter().map(|p| p.1).fold(f64::MIN, f64::max) / (RHO * G * 0.3);
        assert!((top - 3.04).abs() < 0.01, "{top}");
        // Buchner's P2 peaks at 0.236 ρgH near t√(g/H) = 5.59
        let p2 = series(PressureExperiment::Buchner2002, "trixi/P2", 0.6);
        let (t, p) = p2
            .iter()
            .copied()
            .fold((0.0, f64::MIN), |m, x| if x.1 > m.1 { x } else { m });
        assert!((p / (RHO * G * 0.6) - 0.2357).abs() < 1e-3, "{p}");
        assert!((t / (0.6f64 / G).sqrt() - 5.591).abs() < 1e-3, "{t}");
    }
}
