//! The wall-pressure picture of `hsph report`, for a run whose scene compares its pressure
//! probes with an experiment (`[reference] kind = "wall_pressure"`): each compared sensor's
//! trace over the experiment's, in t√(g/H) and p/(ρgH), over the experiment's window — the
//! run's raw series, the same through the probe's box filter (what `summary.json`'s filtered
//! peak reads), and the experiment's (docs/pressure.md).

use super::charts::{both, font, register_font, Res, PALETTE};
use crate::error::Result;
use crate::probes::loads::{cumulative, read_csv, Series};
use crate::reference::wall_pressure::trace;
use crate::scene::PressureExperiment;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// One panel: the sensor's name, the experiment's trace (t*, p*), the run's raw and filtered
/// (t*, p*), the window in t*.
struct Panel {
    name: String,
    experiment: Vec<(f64, f64)>,
    raw: Vec<(f64, f64)>,
    filtered: Vec<(f64, f64)>,
    window: (f64, f64),
}

/// The compared sensors of `summary` (its `pressure_loads` with a `reference`), read from the
/// run directory `run`: `None` when the run compares none.
fn panels(run: &Path, summary: &serde_json::Value) -> Option<Vec<Panel>> {
    let loads = summary.get("pressure_loads")?.as_object()?;
    let mut out = Vec::new();
    for (name, entry) in loads {
        let Some(r) = entry.get("reference") else { continue };
        let Ok(e) = serde_json::from_value::<PressureExperiment>(r["against"].clone()) else {
            continue;
        };
        let (Some(tr), Some(filter)) = (trace(e, name), entry["loads"]["filter_s"].as_f64()) else {
            continue;
        };
        // the series the summary's loads were read from (a run before raw series: the rows)
        let file = entry["series"]
            .as_str()
            .map_or_else(|| format!("probes/{name}.csv"), str::to_string);
        let Ok((t, p)) = read_csv(&run.join(file), ("t", "p"), (1.0, 1.0)) else {
            continue;
        };
        let (ts, ps) = ((tr.depth / 9.81).sqrt(), 1000.0 * 9.81 * tr.depth);
        let cum = cumulative(&t, &p);
        let boxed = Series::new(&t, &p, &cum).box_filter(filter);
        let inside = |x: &f64| (tr.window.0..=tr.window.1).contains(x);
        let scaled = |v: &[f64]| -> Vec<(f64, f64)> {
            t.iter()
                .zip(v)
                .filter(|(t, _)| inside(t))
                .map(|(t, v)| (t / ts, v / ps))
                .collect()
        };
        out.push(Panel {
            name: name.clone(),
            experiment: tr.points.iter().map(|(t, p)| (t / ts, p / ps)).collect(),
            raw: scaled(&p),
            filtered: scaled(&boxed),
            window: (tr.window.0 / ts, tr.window.1 / ts),
        });
    }
    (!out.is_empty()).then_some(out)
}

/// `pressure_traces.png` and `.svg` in `dir`, one panel per compared sensor; nothing when the
/// run compares none.
pub fn traces(run: &Path, summary: &serde_json::Value, dir: &Path) -> Result<Vec<PathBuf>> {
    let Some(panels) = panels(run, summary) else {
        return Ok(Vec::new());
    };
    let rows = panels.len();
    both!(dir, "pressure_traces", (900, 260 * rows as u32 + 40), |root| {
        root.fill(&WHITE)?;
        let areas = root.split_evenly((rows, 1));
        for (area, panel) in areas.iter().zip(&panels) {
            let top = panel
                .raw
                .iter()
                .chain(&panel.experiment)
                .map(|p| p.1)
                .fold(0.0f64, f64::max);
            let low = panel
                .raw
                .iter()
                .chain(&panel.experiment)
                .map(|p| p.1)
                .fold(0.0f64, f64::min);
            let mut ch = ChartBuilder::on(area)
                .caption(
                    format!("{}: the run against the experiment", panel.name),
                    font(17),
                )
                .margin(10)
                .x_label_area_size(38)
                .y_label_area_size(60)
                .build_cartesian_2d(panel.window.0..panel.window.1, (1.1 * low)..(1.1 * top).max(1e-6))?;
            ch.configure_mesh()
                .x_desc("t √(g/H)")
                .y_desc("p / (ρ g H)")
                .label_style(font(12))
                .axis_desc_style(font(14))
                .draw()?;
            for (label, pts, c, w) in [
                ("run, raw", &panel.raw, PALETTE[0].mix(0.35), 1),
                ("run, box filter", &panel.filtered, PALETTE[0].to_rgba(), 2),
                ("experiment", &panel.experiment, BLACK.to_rgba(), 2),
            ] {
                ch.draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(w)))?
                    .label(label)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(w)));
            }
            ch.configure_series_labels()
                .label_font(font(12))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()?;
        }
        Ok(())
    })
}
