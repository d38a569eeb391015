//! Dam break against Lobovsky et al. (2014), H = 300 mm (issue 18), at CI's coarse resolution
//! dx = 1 cm (1 800 fluid particles), the whole t√(g/H) = 8. The experiment's curves ship in
//! `inputs/reference/` (their sources in the files' headers). What is scored, as
//! `tools/lobovsky_compare.py` does at the shipped 5 mm (docs/validation.md §3c): the arrival
//! of the first impact at the lowest sensor S1 (the time of its peak within [rise − 0.5,
//! rise + 1] of the experiment's first rise, in t√(g/H)), and for the gauges H2–H4 the mean
//! |h/H − experiment| over t√(g/H) ∈ [0, 8] and the surge's arrival (first h/H > 0.02). And the
//! loads of docs/pressure.md §1 at S1 (issue 82): the filtered peak and the first impact's
//! impulse over 35 ms, of the run's every-step series and of the experiment's 20 kHz run through
//! the same code (`hsph::probes::loads`), both over t√(g/H) ∈ [0, 4.5].
//! Bounds: 1.5 × the errors measured at 1 cm on the commit of this test (in docs).

use crate::common;

use common::hsph;
use std::path::Path;

const H: f64 = 0.3;
const G: f64 = 9.81;

/// Rows of a CSV file with `#` comments, as (header, rows of strings).
fn csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let head: Vec<String> = lines.next().unwrap().split(',').map(str::to_string).collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    (head, rows)
}

/// Column `col` against column `t` of a CSV, as (t, value) pairs; `t_scale` multiplies t.
fn series(path: &Path, t: &str, col: &str, t_scale: f64) -> Vec<(f64, f64)> {
    let (head, rows) = csv(path);
    let (it, ic) = (
        head.iter().position(|h| h == t).unwrap(),
        head.iter()
            .position(|h| h == col)
            .unwrap_or_else(|| panic!("{col} in {head:?}")),
    );
    rows.iter()
        .filter_map(|r| {
            Some((
                r[it].parse::<f64>().ok()? * t_scale,
                r.get(ic)?.parse::<f64>().ok()?,
            ))
        })
        .collect()
}

fn interp(pts: &[(f64, f64)], t: f64) -> Option<f64> {
    pts.windows(2)
        .find(|w| w[0].0 <= t && t <= w[1].0)
        .map(|w| w[0].1 + (w[1].1 - w[0].1) * (t - w[0].0) / (w[1].0 - w[0].0).max(1e-300))
}

fn peak(pts: &[(f64, f64)], t0: f64, t1: f64) -> (f64, f64) {
    pts.iter()
        .copied()
        .filter(|p| t0 <= p.0 && p.0 <= t1)
        .fold((f64::NAN, f64::MIN), |m, p| if p.1 > m.1 { p } else { m })
}

fn arrival(pts: &[(f64, f64)]) -> f64 {
    pts.iter().find(|p| p.1 > 0.02).map_or(f64::NAN, |p| p.0)
}

#[test]
fn lobovsky_dam_break_at_1cm_within_its_committed_bounds() {
    let out = common::temp_dir("lobovsky").join("run");
    let (code, _, err) = hsph(&[
        "run",
        "inputs/dam_break_lobovsky.toml",
        "--out",
        out.to_str().unwrap(),
        "-q",
        "--set",
        "discretisation.dx=0.01",
    ]);
    assert_eq!(code, 0, "{err}");
    let refs = common::repo_path("inputs/reference");
    let ts = (G / H).sqrt();
    let probes = out.join("probes");
    // S1: the first impact's arrival
    let exp_p = refs.join("dambreak_lobovsky2014_H300_pressure_digitized.csv");
    let (_, rows) = csv(&exp_p);
    let e1: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r[0] == "S1")
        .map(|r| (r[2].parse().unwrap(), r[3].parse().unwrap()))
        .collect();
    let rise = e1.iter().find(|p| p.1 > 0.1).unwrap().0;
    let sim1: Vec<(f64, f64)> = series(&probes.join("S1.csv"), "t", "p", ts)
        .into_iter()
        .map(|(t, p)| (t, p / (1000.0 * G * H)))
        .collect();
    let (te, pe) = peak(&e1, rise - 0.5, rise + 1.0);
    let (tsim, psim) = peak(&sim1, rise - 0.5, rise + 1.0);
    let s1_arrival = (tsim - te).abs();
    eprintln!("S1: peak {psim:.3} at {tsim:.3}, experiment {pe:.3} at {te:.3}: |Δt*| = {s1_arrival:.3}");
    // the gauges
    let lv = refs.join("dambreak_lobovsky2014_H300_water_level.csv");
    let mut level = Vec::new();
    for (g, col) in [("H2", "h_H2_3"), ("H3", "h_H3_3"), ("H4", "h_H4_4")] {
        let e = series(&lv, "tstar", col, 1.0);
        let sim: Vec<(f64, f64)> = series(&probes.join(format!("{g}.csv")), "t", "eta", ts)
            .into_iter()
            .map(|(t, h)| (t, h / H))
            .collect();
        let d: Vec<f64> = e
            .iter()
            .filter(|p| (0.0..=8.0).contains(&p.0))
            .filter_map(|p| Some((interp(&sim, p.0)? - p.1).abs()))
            .collect();
        let mean = d.iter().sum::<f64>() / d.len().max(1) as f64;
        let (a_sim, a_exp) = (arrival(&sim), arrival(&e));
        let a_err = (a_sim / a_exp - 1.0).abs();
        eprintln!(
            "{g}: mean |h/H − exp| {mean:.4}, arrival {a_sim:.3} / {a_exp:.3} ({:.1} %)",
            100.0 * a_err
        );
        assert!(d.len() > 100, "{g}: {} points compared", d.len());
        level.push((g, mean, a_err));
    }
    // S1's loads, the run's against the experiment's run through the same rules
    let ps = 1000.0 * G * H;
    let window = |(t, p): (Vec<f64>, Vec<f64>)| -> (Vec<f64>, Vec<f64>) {
        t.into_iter().zip(p).filter(|(t, _)| *t * ts <= 4.5).unzip()
    };
    let loads =
        |(t, p): (Vec<f64>, Vec<f64>)| hsph::probes::loads::loads(&t, &p, 0.002, Some(0.035)).unwrap();
    let sim = loads(window(
        hsph::probes::loads::read_csv(&probes.join("S1.csv"), ("t", "p"), (1.0, 1.0)).unwrap(),
    ));
    let run = refs.join("dambreak_lobovsky2014_H300_pressure_run.csv");
    let exp = loads(window(
        hsph::probes::loads::read_csv(&run, ("tstar", "p_sensor1_3mm"), (1.0 / ts, ps)).unwrap(),
    ));
    let peak_err = sim.filtered_max / exp.filtered_max - 1.0;
    let impulse_err = sim.impulse.unwrap() / exp.impulse.unwrap() - 1.0;
    eprintln!(
        "S1 loads: filtered peak {:.3} against {:.3} ({:+.1} %), impulse {:.1} against {:.1} Pa s ({:+.1} %)",
        sim.filtered_max / ps,
        exp.filtered_max / ps,
        100.0 * peak_err,
        sim.impulse.unwrap(),
        exp.impulse.unwrap(),
        100.0 * impulse_err
    );
    // the scene's wall-pressure reference gives summary.json the same errors by the same code
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["errors"]["S1_peak"].as_f64(), Some(peak_err.abs()));
    assert_eq!(summary["errors"]["S1_impulse"].as_f64(), Some(impulse_err.abs()));
    // hsph report draws the compared sensors over the experiment, first
    let rep = common::temp_dir("lobovsky").join("report");
    let (code, _, err) = hsph(&["report", out.to_str().unwrap(), "--out", rep.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let md = std::fs::read_to_string(rep.join("report.md")).unwrap();
    let first_chart = md.find("![").unwrap();
    assert!(
        md[first_chart..].starts_with("![Wall pressure at each compared sensor"),
        "{md}"
    );
    assert!(std::fs::metadata(rep.join("pressure_traces.png")).unwrap().len() > 10_000);
    // committed at 1 cm (docs/validation.md §3c, docs/pressure.md); bounds 1.5 ×
    assert!(s1_arrival <= 1.5 * S1_ARRIVAL, "S1 arrival off by {s1_arrival}");
    assert!(
        peak_err.abs() <= 1.5 * S1_PEAK,
        "S1 filtered peak error {peak_err} (committed {S1_PEAK})"
    );
    assert!(
        impulse_err.abs() <= 1.5 * S1_IMPULSE,
        "S1 impulse error {impulse_err} (committed {S1_IMPULSE})"
    );
    for ((g, mean, a_err), (m0, a0)) in level.iter().zip(LEVELS) {
        assert!(*mean <= 1.5 * m0, "{g}: mean level error {mean} (committed {m0})");
        assert!(*a_err <= 1.5 * a0, "{g}: arrival error {a_err} (committed {a0})");
    }
}

/// |Δt√(g/H)| of S1's first-impact peak measured at 1 cm with the Riemann solver's terms (0.124
/// with δ-SPH, whose 15.5 peak was a coarse particle's spike); 0.02 keeps the bound meaningful.
const S1_ARRIVAL: f64 = 0.02;
/// (mean |h/H − experiment|, relative arrival error) of H2, H3, H4 measured at 1 cm.
const LEVELS: [(f64, f64); 3] = [(0.0472, 0.028), (0.0302, 0.069), (0.1234, 0.079)];
/// |relative error| of S1's filtered peak and of its first impact's impulse measured at 1 cm
/// (+169.6 % and +17.7 %; docs/pressure.md §2d).
const S1_PEAK: f64 = 1.696;
const S1_IMPULSE: f64 = 0.177;
