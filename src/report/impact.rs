//! The impact pictures of `hsph report`, for a run whose scene has a hole probe: the plate seen
//! along its normal (particles coloured by a `final.csv` column, the hole's cells and the
//! fitted ellipse) and the debris cloud seen across the impact plane.

use super::charts::{both, font, register_font, viridis, Res};
use super::state::{read_state, scale, State};
use crate::error::Result;
use crate::probes::hole::{cell_size, in_plane_axes, measure_with_cells, HoleSetup};
use crate::scene::{load_scene, Scene};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// The run's hole probe (plate, projectile), if its scene has one.
fn hole_probe(scene: &Scene) -> Option<(String, String)> {
    scene
        .probes
        .iter()
        .find_map(|p| p.hole_bodies())
        .map(|(plate, projectile)| (plate.to_string(), projectile.to_string()))
}

/// `impact_top` and `impact_side` into `out` for the 3D run in `run` with a hole probe; no
/// files for other runs.
pub fn charts(run: &Path, out: &Path, field: &str) -> Result<Vec<PathBuf>> {
    let scene_path = run.join("scene.toml");
    let final_path = run.join("final.csv");
    if !scene_path.is_file() || !final_path.is_file() {
        return Ok(Vec::new());
    }
    let (scene, _) = load_scene(&scene_path, &[])?;
    let Some((plate, projectile)) = hole_probe(&scene) else {
        return Ok(Vec::new());
    };
    if scene.dimension != 3 {
        return Ok(Vec::new());
    }
    let fin = read_state::<3>(&[final_path], field)?;
    let setup = HoleSetup::<3>::of(&scene, &plate, &projectile);
    let ids: Vec<usize> = (0..fin.p.n_owned).filter(|&i| fin.p.kind[i].is_solid()).collect();
    let (hole, cells) = measure_with_cells(&fin.p, &ids, &setup);
    let range = scale(
        &ids.iter().map(|&i| fin.values[i]).collect::<Vec<_>>(),
        (0.05, 0.95),
    );
    let view = View {
        fin: &fin,
        ids: &ids,
        setup: &setup,
        hole: &hole,
        range,
        field,
    };
    let mut files = top_view(out, &view, &cells, scene.discretisation.dx)?;
    files.extend(side_view(out, &view)?);
    Ok(files)
}

/// What both pictures draw.
struct View<'a> {
    fin: &'a State<3>,
    ids: &'a [usize],
    setup: &'a HoleSetup<3>,
    hole: &'a crate::probes::hole::Hole,
    range: (f64, f64),
    field: &'a str,
}

impl View<'_> {
    fn colour(&self, x: f64) -> RGBColor {
        viridis((x - self.range.0) / (self.range.1 - self.range.0))
    }
}

const NAMES: [&str; 3] = ["x", "y", "z"];

/// `impact_top`: the plate's particles near its mid-plane seen along its normal, the hole's
/// cells and the fitted ellipse.
fn top_view(out: &Path, view: &View, cells: &[[f64; 2]], dx: f64) -> Result<Vec<PathBuf>> {
    let (fin, setup, hole, field) = (view.fin, view.setup, view.hole, view.field);
    let ids = view.ids;
    let colour = |x: f64| view.colour(x);
    let names = NAMES;
    let (u, v) = in_plane_axes(3, setup.normal);
    let v = v.unwrap_or(1);
    let band = 3.5 * setup.thickness;
    let plate_ids: Vec<usize> = ids
        .iter()
        .copied()
        .filter(|&i| fin.p.body[i] == setup.plate && (fin.p.x[i][setup.normal] - setup.mid).abs() <= band)
        .collect();
    let (lo, hi) = (setup.lo, setup.hi);
    let half = cell_size(dx) / 2.0;
    let title = if hole.perforated {
        format!(
            "Plate seen along {}: hole {:.2} x {:.2} mm at {:.0} deg (ellipse), coloured by {field}",
            names[setup.normal],
            hole.major * 1e3,
            hole.minor * 1e3,
            hole.angle
        )
    } else {
        format!(
            "Plate seen along {}: not perforated, coloured by {field}",
            names[setup.normal]
        )
    };
    both!(out, "impact_top", (900, 820), |root| {
        root.fill(&WHITE)?;
        let mut ch = ChartBuilder::on(root)
            .caption(&title, font(16))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(lo[u] * 1e3..hi[u] * 1e3, lo[v] * 1e3..hi[v] * 1e3)?;
        ch.configure_mesh()
            .x_desc(format!("{} (mm)", names[u]))
            .y_desc(format!("{} (mm)", names[v]))
            .label_style(font(12))
            .axis_desc_style(font(14))
            .draw()?;
        ch.draw_series(plate_ids.iter().map(|&i| {
            let x = fin.p.x[i];
            Circle::new((x[u] * 1e3, x[v] * 1e3), 1, colour(fin.values[i]).filled())
        }))?;
        ch.draw_series(cells.iter().map(|c| {
            Rectangle::new(
                [
                    ((c[0] - half) * 1e3, (c[1] - half) * 1e3),
                    ((c[0] + half) * 1e3, (c[1] + half) * 1e3),
                ],
                RGBColor(255, 200, 200).filled(),
            )
        }))?;
        if hole.perforated {
            let (a, b, th) = (hole.major / 2.0, hole.minor / 2.0, hole.angle.to_radians());
            let pts: Vec<(f64, f64)> = (0..=180)
                .map(|k| {
                    let s = k as f64 * std::f64::consts::TAU / 180.0;
                    let (ex, ey) = (a * s.cos(), b * s.sin());
                    let x = hole.centre[0] + ex * th.cos() - ey * th.sin();
                    let y = hole.centre[1] + ex * th.sin() + ey * th.cos();
                    (x * 1e3, y * 1e3)
                })
                .collect();
            ch.draw_series(LineSeries::new(pts, RED.stroke_width(2)))?;
        }
        Ok(())
    })
}

/// `impact_side`: every solid particle seen across the plane of the impact direction and the
/// plate normal (the debris cloud).
fn side_view(out: &Path, view: &View) -> Result<Vec<PathBuf>> {
    let (fin, setup, hole, field) = (view.fin, view.setup, view.hole, view.field);
    let ids = view.ids;
    let colour = |x: f64| view.colour(x);
    let names = NAMES;
    let (u, v) = in_plane_axes(3, setup.normal);
    let v = v.unwrap_or(1);
    let side = if setup.direction[u].abs() >= setup.direction[v].abs() {
        u
    } else {
        v
    };
    let (mut a0, mut a1, mut b0, mut b1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &i in ids {
        let x = fin.p.x[i];
        a0 = a0.min(x[side]);
        a1 = a1.max(x[side]);
        b0 = b0.min(x[setup.normal]);
        b1 = b1.max(x[setup.normal]);
    }
    let caption = format!(
        "Debris cloud seen across {}-{} ({} particles beyond the rear face, {:.1} mm long, {:.1} mm wide), coloured by {field}",
        names[side],
        names[setup.normal],
        hole.debris,
        hole.debris_length * 1e3,
        hole.debris_width * 1e3
    );
    both!(out, "impact_side", (1000, 800), |root| {
        root.fill(&WHITE)?;
        let mut ch = ChartBuilder::on(root)
            .caption(&caption, font(14))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(a0 * 1e3..a1 * 1e3, b0 * 1e3..b1 * 1e3)?;
        ch.configure_mesh()
            .x_desc(format!("{} (mm)", names[side]))
            .y_desc(format!("{} (mm)", names[setup.normal]))
            .label_style(font(12))
            .axis_desc_style(font(14))
            .draw()?;
        ch.draw_series(ids.iter().map(|&i| {
            let x = fin.p.x[i];
            Circle::new(
                (x[side] * 1e3, x[setup.normal] * 1e3),
                1,
                colour(fin.values[i]).filled(),
            )
        }))?;
        Ok(())
    })
}
