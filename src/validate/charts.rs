//! The charts of `hsph validate`, PNG and SVG per case: error against cost with the Pareto
//! front, and error against particle spacing with each variant's fitted convergence order.

use super::front::{convergence_order, pareto};
use super::sweep::Row;
use crate::error::Result;
use crate::report::charts::{both, font, register_font, Res, PALETTE};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Log-axis range round the positive finite values, widened by a fifth of a decade.
fn log_range(v: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = v
        .filter(|x| x.is_finite() && *x > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
    if !lo.is_finite() {
        return 1e-3..1.0;
    }
    let f = 10f64.powf(0.2);
    let hi = (hi * f).max(lo * f * f);
    // a power of ten inside, so that the log axis has labelled ticks (errors of 1.6–4.4 had
    // none)
    let decade = 10f64.powf(hi.log10().floor());
    (lo / f).min(decade)..hi
}

/// A log-axis tick: two significant figures, without float noise (0.01, not 0.0100000001).
fn tick(v: &f64) -> String {
    if !(v.is_finite() && *v > 0.0) {
        return String::new();
    }
    let e = v.log10().floor() as i32;
    let r = (v / 10f64.powi(e - 1)).round() * 10f64.powi(e - 1);
    if (-3..4).contains(&e) {
        format!("{}", (r * 1e6).round() / 1e6)
    } else {
        format!("{r:.1e}")
    }
}

/// Distinct values of `key` over `rows`, in first-seen order.
fn distinct(rows: &[&Row], key: impl Fn(&Row) -> String) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for r in rows {
        let k = key(r);
        if !out.contains(&k) {
            out.push(k);
        }
    }
    out
}

/// A variant name `kernel-hX-method…` split into the discretisation (`kernel-hX`, one colour
/// per value) and the method (walls, diffusion and the suffixes: one marker or panel per
/// value). A name without two dashes is all discretisation.
fn split_variant(name: &str) -> (String, String) {
    match name.splitn(3, '-').collect::<Vec<_>>()[..] {
        [k, h, m] => (format!("{k}-{h}"), m.to_string()),
        _ => (name.to_string(), String::new()),
    }
}

/// Marker `k` as a polygon of pixel offsets (radius `r`): circle, triangle, square, diamond,
/// inverted triangle, hexagon, then again.
fn marker_shape(k: usize, r: i32) -> Vec<(i32, i32)> {
    let ring = |n: usize, phase: f64| -> Vec<(i32, i32)> {
        (0..n)
            .map(|j| {
                let a = phase + std::f64::consts::TAU * j as f64 / n as f64;
                let rr = f64::from(r);
                ((rr * a.cos()).round() as i32, (-rr * a.sin()).round() as i32)
            })
            .collect()
    };
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    match k % 6 {
        0 => ring(16, 0.0),
        1 => ring(3, FRAC_PI_2),
        2 => ring(4, FRAC_PI_4),
        3 => ring(4, 0.0),
        4 => ring(3, -FRAC_PI_2),
        _ => ring(6, 0.0),
    }
}

/// `<case>_cost_error.{png,svg}`: the error of every successful run against its wall time
/// (log–log); colour = kernel and h/dx, marker = method; the Pareto front joined in black.
pub fn cost_error(dir: &Path, case: &str, rows: &[&Row]) -> Result<Vec<PathBuf>> {
    let ok: Vec<&Row> = rows.iter().copied().filter(|r| r.ok()).collect();
    let xr = log_range(ok.iter().map(|r| r.wall_s));
    let yr = log_range(ok.iter().map(|r| r.error));
    let bases = distinct(&ok, |r| split_variant(&r.variant).0);
    let methods = distinct(&ok, |r| split_variant(&r.variant).1);
    let pts: Vec<(f64, f64)> = ok.iter().map(|r| (r.wall_s, r.error)).collect();
    let front: Vec<(f64, f64)> = pareto(&pts).into_iter().map(|i| pts[i]).collect();
    let untimed = ok.iter().any(|r| !r.timed);
    let no_points = Vec::<(f64, f64)>::new;
    both!(dir, format!("{case}_cost_error"), (1000, 600), |root| {
        root.fill(&WHITE)?;
        let title = if untimed {
            format!("{case}: error against cost (some runs untimed: --jobs > 1)")
        } else {
            format!("{case}: error against cost")
        };
        let (plot, side) = root.split_horizontally(720);
        let mut ch = ChartBuilder::on(&plot)
            .caption(title, font(20))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(xr.clone().log_scale(), yr.clone().log_scale())?;
        ch.configure_mesh()
            .x_desc("wall time of the run (s)")
            .y_desc("error (fraction)")
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .light_line_style(RGBColor(238, 238, 238))
            .label_style(font(13))
            .axis_desc_style(font(15))
            .draw()?;
        ch.draw_series(LineSeries::new(front.clone(), BLACK.stroke_width(2)))?;
        for r in &ok {
            let (base, method) = split_variant(&r.variant);
            let c = PALETTE[bases.iter().position(|b| *b == base).unwrap_or(0) % PALETTE.len()];
            let m = methods.iter().position(|x| *x == method).unwrap_or(0);
            ch.draw_series(std::iter::once(
                EmptyElement::at((r.wall_s, r.error)) + Polygon::new(marker_shape(m, 5), c.filled()),
            ))?;
        }
        // the legend beside the plot: the front, the colours, then the markers
        let mut lg = ChartBuilder::on(&side)
            .margin_top(40)
            .build_cartesian_2d(0.0..1.0, 0.0..1.0)?;
        lg.draw_series(LineSeries::new(no_points(), BLACK.stroke_width(2)))?
            .label("Pareto front")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        for (k, b) in bases.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            lg.draw_series(LineSeries::new(no_points(), c))?
                .label(b.as_str())
                .legend(move |(x, y)| {
                    EmptyElement::at((x + 10, y)) + Polygon::new(marker_shape(0, 5), c.filled())
                });
        }
        for (k, m) in methods.iter().enumerate() {
            let grey = RGBColor(90, 90, 90);
            lg.draw_series(LineSeries::new(no_points(), grey))?
                .label(m.as_str())
                .legend(move |(x, y)| {
                    EmptyElement::at((x + 10, y)) + Polygon::new(marker_shape(k, 5), grey.filled())
                });
        }
        lg.configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(font(12))
            .background_style(WHITE)
            .border_style(WHITE)
            .draw()?;
        Ok(())
    })
}

/// `<case>_convergence.{png,svg}`: error against resolution n = L/dx (log–log), one panel
/// per method and one colour per kernel and h/dx, with the fitted order p of error ≈ c dxᵖ in
/// the legend and the fit drawn dashed. Every panel has the same axes.
pub fn convergence(dir: &Path, case: &str, rows: &[&Row]) -> Result<Vec<PathBuf>> {
    let ok: Vec<&Row> = rows.iter().copied().filter(|r| r.ok()).collect();
    let xr = log_range(ok.iter().map(|r| r.resolution as f64));
    let yr = log_range(ok.iter().map(|r| r.error));
    let bases = distinct(&ok, |r| split_variant(&r.variant).0);
    let methods = distinct(&ok, |r| split_variant(&r.variant).1);
    let cols = methods.len().clamp(1, 3);
    let grid = (methods.len().max(1).div_ceil(cols), cols);
    let size = if methods.len() <= 1 {
        (900, 560)
    } else {
        (480 * cols as u32, 430 * grid.0 as u32 + 40)
    };
    both!(dir, format!("{case}_convergence"), size, |root| {
        root.fill(&WHITE)?;
        let root = root.titled(&format!("{case}: error against resolution"), font(20))?;
        for (panel, method) in root.split_evenly(grid).iter().zip(&methods) {
            let mut ch = ChartBuilder::on(panel)
                .caption(method.as_str(), font(15))
                .margin(8)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(xr.clone().log_scale(), yr.clone().log_scale())?;
            ch.configure_mesh()
                .x_desc("n = L/dx")
                .y_desc("error (fraction)")
                .x_label_formatter(&tick)
                .y_label_formatter(&tick)
                .light_line_style(RGBColor(238, 238, 238))
                .label_style(font(12))
                .axis_desc_style(font(13))
                .draw()?;
            for (k, base) in bases.iter().enumerate() {
                let c = PALETTE[k % PALETTE.len()];
                let mine_rows: Vec<&&Row> = ok
                    .iter()
                    .filter(|r| {
                        let (b, m) = split_variant(&r.variant);
                        b == *base && m == *method
                    })
                    .collect();
                if mine_rows.is_empty() {
                    continue;
                }
                let mine_dx: Vec<(f64, f64)> = mine_rows.iter().map(|r| (r.dx, r.error)).collect();
                // n = L/dx
                let len = mine_rows[0].dx * mine_rows[0].resolution as f64;
                let mut mine: Vec<(f64, f64)> = mine_dx.iter().map(|&(d, e)| (len / d, e)).collect();
                mine.sort_by(|a, b| a.0.total_cmp(&b.0));
                let label = match convergence_order(&mine_dx) {
                    Some((p, cst)) => {
                        let (a, b) = (mine[0].0, mine[mine.len() - 1].0);
                        let fit = [(a, cst * (len / a).powf(p)), (b, cst * (len / b).powf(p))];
                        ch.draw_series(DashedLineSeries::new(fit, 6, 4, c.stroke_width(1)))?;
                        format!("{base} (order {p:.2})")
                    }
                    None => base.clone(),
                };
                ch.draw_series(LineSeries::new(mine.clone(), c.stroke_width(2)))?
                    .label(label)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
                ch.draw_series(mine.into_iter().map(|p| Circle::new(p, 4, c.filled())))?;
            }
            ch.configure_series_labels()
                .position(SeriesLabelPosition::LowerLeft)
                .label_font(font(11))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()?;
        }
        Ok(())
    })
}

/// Colour of a failure at fraction `f` of the run's end time: dark red early, light orange
/// late.
fn failure_colour(f: f64) -> RGBColor {
    let f = if f.is_finite() { f.clamp(0.0, 1.0) } else { 0.0 };
    let l = |a: f64, b: f64| (a + f * (b - a)).round() as u8;
    RGBColor(l(140.0, 250.0), l(20.0, 190.0), l(20.0, 110.0))
}

/// `map_<study>.{png,svg}`: method (rows) × parameter value (columns); a stable run pale
/// green, a failed one red to orange by its failure time over the run's end time (dark =
/// early), labelled with the reason and time; the study's metric below.
pub fn stability_map(
    dir: &Path,
    study: &super::map::Study,
    cells: &[super::map::Cell],
) -> Result<Vec<PathBuf>> {
    let (nm, nv) = (study.methods.len(), study.values.len());
    let (left, top, cw, chh) = (150i32, 50i32, 190i32, 64i32);
    let w = (left + cw * nv as i32 + 20) as u32;
    let h = (top + chh * nm as i32 + 70) as u32;
    both!(dir, format!("map_{}", study.name), (w.max(620), h), |root| {
        root.fill(&WHITE)?;
        root.draw(&Text::new(study.title, (10, 12), font(15)))?;
        for (vi, v) in study.values.iter().enumerate() {
            let x = left + cw * vi as i32 + cw / 2 - 12;
            root.draw(&Text::new(
                format!("{v}"),
                (x, top + chh * nm as i32 + 8),
                font(13),
            ))?;
        }
        root.draw(&Text::new(
            study.parameter,
            (left + cw * nv as i32 / 2 - 60, top + chh * nm as i32 + 32),
            font(14),
        ))?;
        for (mi, (method, _)) in study.methods.iter().enumerate() {
            let y = top + chh * mi as i32;
            root.draw(&Text::new(method.to_string(), (8, y + chh / 2 - 7), font(13)))?;
            for (vi, v) in study.values.iter().enumerate() {
                let x = left + cw * vi as i32;
                let cell = cells.iter().find(|c| c.method == *method && c.value == *v);
                let (colour, text, ink) = match cell {
                    None => (RGBColor(245, 245, 245), "not run".to_string(), BLACK),
                    Some(c) => match &c.reason {
                        None => (RGBColor(200, 235, 200), "stable".to_string(), BLACK),
                        Some(r) => (
                            failure_colour(c.t_fail / c.t_end),
                            format!("{r} @ {:.3} s", c.t_fail),
                            WHITE,
                        ),
                    },
                };
                root.draw(&Rectangle::new(
                    [(x + 2, y + 2), (x + cw - 2, y + chh - 2)],
                    colour.filled(),
                ))?;
                root.draw(&Text::new(text, (x + 8, y + 12), font(12).color(&ink)))?;
                if let Some(m) = cell.map(|c| c.metric).filter(|m| m.is_finite()) {
                    root.draw(&Text::new(
                        format!("{}: {}", study.metric_name(), super::map::show_metric(m)),
                        (x + 8, y + 36),
                        font(11).color(&ink),
                    ))?;
                }
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_variant_splits_into_its_discretisation_and_its_method() {
        assert_eq!(
            split_variant("quintic_spline-h1.0-dummy-none-renorm-morriswall"),
            (
                "quintic_spline-h1.0".into(),
                "dummy-none-renorm-morriswall".into()
            )
        );
        assert_eq!(
            split_variant("wendland_c2-h2.0-mirror-none"),
            ("wendland_c2-h2.0".into(), "mirror-none".into())
        );
        assert_eq!(split_variant("odd"), ("odd".into(), String::new()));
    }

    #[test]
    fn six_methods_get_six_different_markers_inside_their_radius() {
        let shapes: Vec<Vec<(i32, i32)>> = (0..6).map(|k| marker_shape(k, 5)).collect();
        for (a, sa) in shapes.iter().enumerate() {
            assert!(sa.iter().all(|&(x, y)| x * x + y * y <= 36), "{sa:?}");
            for sb in &shapes[a + 1..] {
                assert_ne!(sa, sb);
            }
        }
        assert_eq!(marker_shape(6, 5), shapes[0]);
    }
}
