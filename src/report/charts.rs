//! The charts of `hsph report`, each drawn once per back end: PNG (plotters' bitmap back end)
//! and SVG. Text uses DejaVu Sans compiled into the binary (see [`FONT`]).

use super::{human_bytes, CompareRow, Diagnostics, TrafficRow};
use crate::error::Result;
use crate::sim::PHASES;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Font family name the charts use; registered from the embedded DejaVu Sans.
pub const FONT: &str = "sans-serif";

pub(crate) type Res = std::result::Result<(), Box<dyn std::error::Error>>;

pub(crate) fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // DejaVu Sans is a valid TrueType font; failure here would be a broken build.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
    });
}

/// Draw one chart into `dir/<stem>.png` and `dir/<stem>.svg`.
macro_rules! both {
    ($dir:expr, $stem:expr, $size:expr, |$root:ident| $body:block) => {{
        register_font();
        let png = $dir.join(format!("{}.png", $stem));
        let svg = $dir.join(format!("{}.svg", $stem));
        $crate::output::refuse_non_regular(&png)?;
        $crate::output::refuse_non_regular(&svg)?;
        {
            let area = BitMapBackend::new(&png, $size).into_drawing_area();
            let r: Res = (|| -> Res {
                let $root = &area;
                $body
            })()
            .and_then(|_| area.present().map_err(Into::into));
            r.map_err(|e| $crate::error::Error::run(format!("{}: {e}", png.display())))?;
        }
        {
            let area = SVGBackend::new(&svg, $size).into_drawing_area();
            let r: Res = (|| -> Res {
                let $root = &area;
                $body
            })()
            .and_then(|_| area.present().map_err(Into::into));
            r.map_err(|e| $crate::error::Error::run(format!("{}: {e}", svg.display())))?;
        }
        Ok(vec![png, svg])
    }};
}
pub(crate) use both;

/// Eight distinguishable colours (Okabe–Ito, then grey).
pub(crate) const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(213, 94, 0),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(240, 228, 66),
    RGBColor(120, 120, 120),
];

/// Viridis at `x` in [0, 1] (linear between 6 stops).
pub(crate) fn viridis(x: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 6] = [
        (68.0, 1.0, 84.0),
        (65.0, 68.0, 135.0),
        (42.0, 120.0, 142.0),
        (34.0, 168.0, 132.0),
        (122.0, 209.0, 81.0),
        (253.0, 231.0, 37.0),
    ];
    let x = x.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let l = |p: f64, q: f64| (p + f * (q - p)).round() as u8;
    RGBColor(l(a.0, b.0), l(a.1, b.1), l(a.2, b.2))
}

/// Largest heat-map side in cells; more ranks are binned into groups.
const MAX_CELLS: usize = 256;

pub(crate) fn font(size: u32) -> TextStyle<'static> {
    (FONT, size).into_font().into()
}

/// (a) Rank-pair traffic heat map: bytes from source (rows) to destination (columns) over the
/// whole run, all phases, log colour scale; ranks ordered by node, node boundaries as lines.
pub fn traffic_heatmap(
    dir: &Path,
    ranks: usize,
    nodes: &[usize],
    rows: &[TrafficRow],
) -> Result<Vec<PathBuf>> {
    let p = ranks.max(1);
    // position of each rank on the axes: by (node, rank)
    let mut order: Vec<usize> = (0..p).collect();
    order.sort_by_key(|&r| (nodes.get(r).copied().unwrap_or(0), r));
    let mut pos = vec![0usize; p];
    for (i, &r) in order.iter().enumerate() {
        pos[r] = i;
    }
    let bin = p.div_ceil(MAX_CELLS).max(1);
    let mut cells: BTreeMap<(usize, usize), u64> = BTreeMap::new();
    for r in rows {
        if r.src_rank < p && r.dst_rank < p && r.bytes > 0 {
            let c = cells
                .entry((pos[r.src_rank] / bin, pos[r.dst_rank] / bin))
                .or_default();
            *c = c.saturating_add(r.bytes);
        }
    }
    // the colour range is the data's own (log10 of bytes), padded only when every cell is equal
    let lo = cells.values().copied().min().unwrap_or(1).max(1) as f64;
    let hi = cells.values().copied().max().unwrap_or(1) as f64;
    let (mut llo, mut lhi) = (lo.log10(), hi.log10());
    if lhi - llo < 1e-3 {
        llo -= 0.1;
        lhi += 0.1;
    }
    let colour = |b: u64| viridis(((b as f64).log10() - llo) / (lhi - llo));
    let boundaries: Vec<f64> = (0..p.saturating_sub(1))
        .filter(|&i| nodes.get(order[i]) != nodes.get(order[i + 1]))
        .map(|i| i as f64 + 0.5)
        .collect();
    let n = p as f64;
    let caption = if order.iter().enumerate().all(|(i, &r)| i == r) {
        "Rank-pair traffic, all phases (bytes)"
    } else {
        "Rank-pair traffic, all phases (bytes; ranks grouped by node)"
    };
    both!(dir, "traffic_heatmap", (760, 640), |root| {
        root.fill(&WHITE)?;
        let (main, bar) = root.split_horizontally(640);
        let mut ch = ChartBuilder::on(&main)
            .caption(caption, font(20))
            .margin(10)
            .x_label_area_size(45)
            .y_label_area_size(55)
            .build_cartesian_2d(-0.5..n - 0.5, -0.5..n - 0.5)?;
        let label = |v: &f64| {
            let i = v.round();
            if (v - i).abs() > 1e-6 || i < 0.0 || i >= n {
                return String::new();
            }
            order[i as usize].to_string()
        };
        ch.configure_mesh()
            .disable_mesh()
            .x_desc("destination rank")
            .y_desc("source rank")
            .x_labels(p.min(16) + 1)
            .y_labels(p.min(16) + 1)
            .x_label_formatter(&label)
            .y_label_formatter(&label)
            .label_style(font(13))
            .axis_desc_style(font(15))
            .draw()?;
        let span = |k: usize| ((k * bin) as f64 - 0.5, (((k + 1) * bin).min(p)) as f64 - 0.5);
        ch.draw_series(cells.iter().map(|(&(i, j), &b)| {
            let ((x0, x1), (y0, y1)) = (span(j), span(i));
            Rectangle::new([(x0, y0), (x1, y1)], colour(b).filled())
        }))?;
        let line = BLACK.stroke_width(2);
        for &b in &boundaries {
            ch.draw_series([
                PathElement::new(vec![(b, -0.5), (b, n - 0.5)], line),
                PathElement::new(vec![(-0.5, b), (n - 0.5, b)], line),
            ])?;
        }
        colour_bar(&bar, llo, lhi)?;
        Ok(())
    })
}

/// The heat map's colour bar on the data's range `llo..lhi` (log10 of bytes), with five labelled
/// ticks of its own: both ends and three between, so a narrow range is labelled as well as a
/// wide one.
fn colour_bar<DB: DrawingBackend>(
    bar: &DrawingArea<DB, plotters::coord::Shift>,
    llo: f64,
    lhi: f64,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let mut cb = ChartBuilder::on(bar)
        .caption("bytes", font(14))
        .margin_top(16)
        .margin_bottom(60)
        .margin_right(4)
        .build_cartesian_2d(0.0..3.2, llo..lhi)?;
    let steps = 64;
    cb.draw_series((0..steps).map(|k| {
        let a = llo + (lhi - llo) * k as f64 / steps as f64;
        let b = llo + (lhi - llo) * (k + 1) as f64 / steps as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            viridis((k as f64 + 0.5) / steps as f64).filled(),
        )
    }))?;
    let ticks: Vec<f64> = (0..5).map(|k| llo + (lhi - llo) * k as f64 / 4.0).collect();
    cb.draw_series(
        ticks
            .iter()
            .map(|&t| PathElement::new(vec![(1.0, t), (1.25, t)], BLACK.stroke_width(1))),
    )?;
    let style = font(12).pos(plotters::style::text_anchor::Pos::new(
        plotters::style::text_anchor::HPos::Left,
        plotters::style::text_anchor::VPos::Center,
    ));
    cb.draw_series(
        ticks
            .iter()
            .map(|&t| Text::new(human_bytes(10f64.powf(t)), (1.35, t), style.clone())),
    )?;
    Ok(())
}

/// An axis label for `v` on an axis up to `max`: scientific from 1e5, else without trailing
/// zeros.
fn tick(v: f64, max: f64) -> String {
    if max >= 1e5 {
        return format!("{v:.1e}");
    }
    let t = format!("{v:.3}");
    t.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// A unit for `max` bytes: (divisor, name).
fn byte_unit(max: f64) -> (f64, &'static str) {
    match max {
        m if m >= 1024.0 * 1024.0 * 1024.0 => (1024.0 * 1024.0 * 1024.0, "GiB"),
        m if m >= 1024.0 * 1024.0 => (1024.0 * 1024.0, "MiB"),
        m if m >= 1024.0 => (1024.0, "KiB"),
        _ => (1.0, "B"),
    }
}

/// (b) Intra- and inter-node bytes per output interval (`(step, intra, inter)`).
pub fn traffic_time(dir: &Path, series: &[(u64, u64, u64)]) -> Result<Vec<PathBuf>> {
    let max = series.iter().map(|s| s.1.max(s.2)).max().unwrap_or(0) as f64;
    let (div, unit) = byte_unit(max);
    let x0 = series.first().map(|s| s.0).unwrap_or(0) as f64;
    let x1 = (series.last().map(|s| s.0).unwrap_or(1) as f64).max(x0 + 1.0);
    let ymax = (max / div * 1.1).max(1e-9);
    both!(dir, "traffic_time", (800, 480), |root| {
        root.fill(&WHITE)?;
        let mut ch = ChartBuilder::on(root)
            .caption("Traffic per output interval", font(20))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, 0.0..ymax)?;
        ch.configure_mesh()
            .x_desc("step (end of output interval)")
            .y_desc(format!("bytes sent ({unit})"))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .label_style(font(13))
            .axis_desc_style(font(15))
            .draw()?;
        for (k, (name, c)) in [("intra-node", PALETTE[0]), ("inter-node", PALETTE[3])]
            .into_iter()
            .enumerate()
        {
            let pts: Vec<(f64, f64)> = series
                .iter()
                .map(|s| (s.0 as f64, if k == 0 { s.1 } else { s.2 } as f64 / div))
                .collect();
            ch.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
                .label(name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
            ch.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, c.filled())))?;
        }
        ch.configure_series_labels()
            .label_font(font(13))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    })
}

/// (c) Ghost fraction and load imbalance against simulated time (two panels).
pub fn ghosts_imbalance(dir: &Path, diag: &Diagnostics) -> Result<Vec<PathBuf>> {
    let t = diag.col("t").unwrap_or_default();
    let g = diag.col("ghost_fraction").unwrap_or_default();
    let im = diag.col("imbalance").unwrap_or_default();
    let t0 = t.first().copied().unwrap_or(0.0);
    let t1 = t.last().copied().unwrap_or(1.0).max(t0 + 1e-12);
    both!(dir, "ghosts_imbalance", (800, 640), |root| {
        root.fill(&WHITE)?;
        let panels = root.split_evenly((2, 1));
        for (k, (area, (vals, name, desc))) in panels
            .iter()
            .zip([
                (&g, "Ghost fraction", "remote ghosts / particles"),
                (&im, "Load imbalance", "imbalance"),
            ])
            .enumerate()
        {
            let ymax = vals.iter().copied().fold(0.0f64, f64::max) * 1.15;
            let ymax = if ymax > 0.0 { ymax } else { 1.0 };
            let mut ch = ChartBuilder::on(area)
                .caption(name, font(18))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(t0..t1, 0.0..ymax)?;
            ch.configure_mesh()
                .x_desc("t (s)")
                .y_desc(desc)
                .label_style(font(12))
                .axis_desc_style(font(14))
                .draw()?;
            let c = PALETTE[if k == 0 { 0 } else { 3 }];
            let pts: Vec<(f64, f64)> = t.iter().copied().zip(vals.iter().copied()).collect();
            ch.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?;
            ch.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, c.filled())))?;
        }
        Ok(())
    })
}

/// (d) Time per phase: stacked bars of the mean seconds (over ranks) of each phase per output
/// interval, and the whole run's seconds per phase (mean bar, min–max whisker over ranks).
pub fn phase_times(dir: &Path, diag: &Diagnostics, totals: &[(String, [f64; 3])]) -> Result<Vec<PathBuf>> {
    let steps = diag.col("step").unwrap_or_default();
    // per interval k (ending at row k+1): per phase the increase of the cumulative mean
    let means: Vec<Vec<f64>> = PHASES
        .iter()
        .map(|p| {
            let c = diag.col(&format!("{p}_s_mean")).unwrap_or_default();
            c.windows(2).map(|w| (w[1] - w[0]).max(0.0)).collect()
        })
        .collect();
    let intervals = steps.len().saturating_sub(1);
    let stack_max = (0..intervals)
        .map(|k| means.iter().filter_map(|m| m.get(k)).sum::<f64>())
        .fold(0.0f64, f64::max);
    let total_max = totals.iter().map(|t| t.1[2]).fold(0.0f64, f64::max);
    both!(dir, "phase_times", (1000, 520), |root| {
        root.fill(&WHITE)?;
        let (left, right) = root.split_horizontally(560);
        let ni = intervals.max(1) as f64;
        let mut ch = ChartBuilder::on(&left)
            .caption("Seconds per output interval (mean over ranks)", font(17))
            .margin(10)
            .x_label_area_size(45)
            .y_label_area_size(65)
            // headroom above the bars for the legend
            .build_cartesian_2d(-0.5..ni - 0.5, 0.0..(stack_max * 1.6).max(1e-9))?;
        let step_label = |v: &f64| {
            let i = v.round();
            if (v - i).abs() > 1e-6 || i < 0.0 || i as usize >= intervals {
                return String::new();
            }
            format!("{:.0}", steps[i as usize + 1])
        };
        ch.configure_mesh()
            .disable_x_mesh()
            .x_desc("step (end of output interval)")
            .y_desc("wall seconds")
            .x_labels(intervals.min(12) + 1)
            .x_label_formatter(&step_label)
            .label_style(font(12))
            .axis_desc_style(font(14))
            .draw()?;
        for (pi, name) in PHASES.iter().enumerate() {
            let c = PALETTE[pi % PALETTE.len()];
            let bars: Vec<Rectangle<(f64, f64)>> = (0..intervals)
                .map(|k| {
                    let below: f64 = means[..pi].iter().filter_map(|m| m.get(k)).sum();
                    let h = means[pi].get(k).copied().unwrap_or(0.0);
                    let x = k as f64;
                    Rectangle::new([(x - 0.4, below), (x + 0.4, below + h)], c.filled())
                })
                .collect();
            ch.draw_series(bars)?
                .label(*name)
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], c.filled()));
        }
        ch.configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(font(12))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
        whole_run_panel(&right, totals, total_max)?;
        Ok(())
    })
}

/// The right panel of [`phase_times`]: per phase the whole run's mean seconds (bar) and the
/// min–max over ranks (whisker), on a scale up to `total_max` (s).
fn whole_run_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    totals: &[(String, [f64; 3])],
    total_max: f64,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let np = totals.len().max(1) as f64;
    let mut tc = ChartBuilder::on(area)
        .caption("Whole run: mean, min–max over ranks", font(17))
        .margin(10)
        .x_label_area_size(70)
        .y_label_area_size(65)
        .build_cartesian_2d(-0.5..np - 0.5, 0.0..(total_max * 1.1).max(1e-9))?;
    let phase_label = |v: &f64| {
        let i = v.round();
        if (v - i).abs() > 1e-6 || i < 0.0 || i as usize >= totals.len() {
            return String::new();
        }
        totals[i as usize].0.clone()
    };
    tc.configure_mesh()
        .disable_x_mesh()
        .x_desc("phase")
        .y_desc("wall seconds")
        .x_labels(totals.len() + 1)
        .x_label_formatter(&phase_label)
        .x_label_style(font(11).transform(FontTransform::Rotate90))
        .label_style(font(12))
        .axis_desc_style(font(14))
        .draw()?;
    for (k, (name, [lo, mean, hi])) in totals.iter().enumerate() {
        let pi = PHASES.iter().position(|p| p == name).unwrap_or(k);
        let c = PALETTE[pi % PALETTE.len()];
        let x = k as f64;
        tc.draw_series(std::iter::once(Rectangle::new(
            [(x - 0.35, 0.0), (x + 0.35, *mean)],
            c.filled(),
        )))?;
        let w = BLACK.stroke_width(1);
        tc.draw_series([
            PathElement::new(vec![(x, *lo), (x, *hi)], w),
            PathElement::new(vec![(x - 0.15, *lo), (x + 0.15, *lo)], w),
            PathElement::new(vec![(x - 0.15, *hi), (x + 0.15, *hi)], w),
        ])?;
    }
    Ok(())
}

/// `--compare`: bars per run of particle-steps/s, inter-node bytes, ghost fraction and
/// communication fraction (2 × 2 panels), runs numbered as in `compare.md`.
pub fn compare(dir: &Path, rows: &[CompareRow]) -> Result<Vec<PathBuf>> {
    let inter_max = rows
        .iter()
        .filter_map(|r| r.traffic)
        .map(|t| t.1)
        .max()
        .unwrap_or(0) as f64;
    let (div, unit) = byte_unit(inter_max);
    let inter_desc = format!("inter-node bytes ({unit})");
    let panels: Vec<(&str, &str, Vec<Option<f64>>)> = vec![
        (
            "Particle-steps/s",
            "particle-steps/s",
            rows.iter().map(|r| r.rate).collect(),
        ),
        (
            "Inter-node bytes",
            inter_desc.as_str(),
            rows.iter().map(|r| r.traffic.map(|t| t.1 as f64 / div)).collect(),
        ),
        (
            "Ghost fraction",
            "ghost fraction (%)",
            rows.iter().map(|r| r.ghost_fraction.map(|x| 100.0 * x)).collect(),
        ),
        (
            "Communication fraction",
            "communication / wall (%)",
            rows.iter().map(|r| r.comm_fraction.map(|x| 100.0 * x)).collect(),
        ),
    ];
    let n = rows.len().max(1) as f64;
    both!(dir, "compare", (1000, 760), |root| {
        root.fill(&WHITE)?;
        let areas = root.split_evenly((2, 2));
        for (area, (title, desc, vals)) in areas.iter().zip(&panels) {
            let ymax = vals.iter().flatten().copied().fold(0.0f64, f64::max) * 1.15;
            let ymax = if ymax > 0.0 { ymax } else { 1.0 };
            let mut ch = ChartBuilder::on(area)
                .caption(*title, font(17))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(75)
                .build_cartesian_2d(-0.5..n - 0.5, 0.0..ymax)?;
            let run_label = |v: &f64| {
                let i = v.round();
                if (v - i).abs() > 1e-6 || i < 0.0 || i >= n {
                    return String::new();
                }
                format!("#{}", i as usize + 1)
            };
            ch.configure_mesh()
                .disable_x_mesh()
                .x_desc("run (see compare.md)")
                .y_desc(*desc)
                .x_labels(rows.len().min(24) + 1)
                .x_label_formatter(&run_label)
                .y_label_formatter(&|v| tick(*v, ymax))
                .label_style(font(12))
                .axis_desc_style(font(13))
                .draw()?;
            ch.draw_series(vals.iter().enumerate().filter_map(|(k, v)| {
                let x = k as f64;
                v.map(|v| {
                    Rectangle::new(
                        [(x - 0.35, 0.0), (x + 0.35, v)],
                        PALETTE[k % PALETTE.len()].filled(),
                    )
                })
            }))?;
        }
        Ok(())
    })
}
