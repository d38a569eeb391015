//! The impact pictures of `hsph report`, for a run whose scene has a hole probe: the plate seen
//! along its normal (particles coloured by a `final.csv` column, the hole's cells and the
//! fitted ellipse) and the debris cloud seen across the impact plane.

use super::charts::{both, font, register_font, viridis, Res};
use crate::error::{Error, Result};
use crate::particles::{Kind, Particles, Record};
use crate::probes::hole::{cell_size, in_plane_axes, measure_with_cells, HoleSetup};
use crate::scene::{load_scene, Scene};
use crate::Vector;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// The final state as the pictures need it: particles and the colouring column.
struct Final {
    p: Particles<3>,
    values: Vec<f64>,
}

/// Read `final.csv` (3D): kind, body, position and the column `field`, through the bounded
/// reader; every row has the header's fields, every number is checked where it is read (a
/// kind hsph writes, a body index, finite positions), exit 2 naming the line and column.
fn read_final(path: &Path, field: &str) -> Result<Final> {
    use crate::limits::{FileNumbers, Number};
    let mut head: Vec<String> = Vec::new();
    let mut cols: Option<[usize; 5]> = None;
    let mut failed = None;
    let mut p = Particles::<3>::default();
    let mut values = Vec::new();
    crate::limits::read_lines(path, "final.csv", |n, line| {
        if head.is_empty() {
            head = line.split(',').map(str::to_string).collect();
            let col = |name: &str| head.iter().position(|h| h == name);
            failed = col("failed");
            let (Some(id), Some(kind), Some(body), Some(x)) = (col("id"), col("kind"), col("body"), col("x"))
            else {
                return Err(Error::run(format!(
                    "{}: not a final.csv with id, kind, body, x",
                    path.display()
                )));
            };
            let Some(f) = col(field) else {
                return Err(Error::input(
                    "--field",
                    format!(
                        "`{field}` is not a column of {}; columns: {}",
                        path.display(),
                        head.join(", ")
                    ),
                ));
            };
            if x + 2 >= head.len() {
                return Err(FileNumbers::at(path, n).error("x", "needs the columns x, y, z".into()));
            }
            cols = Some([id, kind, body, x, f]);
            return Ok(());
        }
        let Some([id, kind, body, x, f]) = cols else {
            return Ok(());
        };
        let c: Vec<&str> = line.split(',').collect();
        let at = FileNumbers::at(path, n);
        if c.len() != head.len() {
            return Err(at.error("", format!("{} fields, the header has {}", c.len(), head.len())));
        }
        let num = |k: usize| Number::Text(c[k]);
        let code = at.count("kind", num(kind), (0, 255))? as u8;
        let Some(k) = Kind::from_code(code) else {
            return Err(at.error("kind", format!("{code} is not a particle kind of hsph (0 to 4)")));
        };
        let body_i = at.count("body", num(body), (0, u16::MAX as u64))? as u16;
        let any = (f64::MIN, f64::MAX);
        let pos = Vector::<3>::new(
            at.real("x", num(x), any)?,
            at.real(&head[x + 1], num(x + 1), any)?,
            at.real(&head[x + 2], num(x + 2), any)?,
        );
        let id_v = at.count("id", num(id), (0, 1u64 << 53))?;
        let mut r = Record::new(id_v, k, body_i, 0, pos, Vector::zeros(), 0.0, 0.0);
        if let Some(fl) = failed {
            r.failed = at.count("failed", num(fl), (0, u16::MAX as u64))? as u16;
        }
        p.push_owned(r);
        // the colouring column may hold a NaN; the colour scale leaves it out
        values.push(c[f].parse().unwrap_or(f64::NAN));
        Ok(())
    })?;
    if cols.is_none() {
        return Err(Error::run(format!(
            "{}: not a final.csv with id, kind, body, x",
            path.display()
        )));
    }
    Ok(Final { p, values })
}

/// The run's hole probe (plate, projectile), if its scene has one.
fn hole_probe(scene: &Scene) -> Option<(String, String)> {
    scene
        .probes
        .iter()
        .find_map(|p| p.hole_bodies())
        .map(|(plate, projectile)| (plate.to_string(), projectile.to_string()))
}

/// Colour scale of `values` (5th to 95th percentile, so that a few extreme particles do not
/// wash the picture out).
fn scale(values: &[f64]) -> (f64, f64) {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return (0.0, 1.0);
    }
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    let (lo, hi) = (at(0.05), at(0.95));
    if hi > lo {
        (lo, hi)
    } else {
        (lo, lo + 1.0)
    }
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
    let fin = read_final(&final_path, field)?;
    let setup = HoleSetup::<3>::of(&scene, &plate, &projectile);
    let ids: Vec<usize> = (0..fin.p.n_owned).filter(|&i| fin.p.kind[i].is_solid()).collect();
    let (hole, cells) = measure_with_cells(&fin.p, &ids, &setup);
    let range = scale(&ids.iter().map(|&i| fin.values[i]).collect::<Vec<_>>());
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
    fin: &'a Final,
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
