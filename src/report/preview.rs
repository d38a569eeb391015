//! `hsph check SCENE --preview DIR`: the particles a run's set-up builds
//! ([`crate::setup::build_particles`], the code a run calls), written before any step: the
//! whole set as `particles.vtu` and `particles.nc` (kind, body, level, mass, density, pressure;
//! the netCDF in the snapshots' CF point layout) and pictures of
//! them coloured by body, drawn as `hsph report` draws. A 2D scene gives one picture; a 3D scene
//! one per axis, each a section one spacing thick (a projection would hide a baffle behind a
//! wall): the lattice layer that cuts the most bodies, the one nearest the domain's middle
//! among those, so that a hull beside a water column is cut even where the middle misses it.

use super::charts::{both, font, register_font, Res, PALETTE};
use crate::error::{Error, Result};
use crate::particles::Particles;
use crate::scene::Scene;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// The snapshot fields `particles.vtu` carries, of those the scene's particles hold.
const FIELDS: [&str; 6] = ["kind", "body", "level", "mass", "density", "pressure"];

/// Write the preview of `scene` into `dir` (created if missing); returns the files written.
pub fn write(dir: &Path, scene: &Scene) -> Result<Vec<PathBuf>> {
    crate::with_dim!(scene.dimension, D => write_dim::<D>(dir, scene))
}

fn write_dim<const D: usize>(dir: &Path, scene: &Scene) -> Result<Vec<PathBuf>> {
    let p = crate::setup::build_particles::<D>(scene)?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut order: Vec<usize> = (0..p.n_owned).collect();
    order.sort_unstable_by_key(|&i| p.id[i]);
    let vtu = dir.join("particles.vtu");
    crate::output::refuse_non_regular(&vtu)?;
    // those the scene's table holds (a level only where regions refine)
    let table = Particles::<D>::field_table();
    let fields: Vec<String> = (FIELDS.iter())
        .filter(|f| {
            table
                .iter()
                .any(|m| m.snapshot == Some(**f) && p.column(m.name).is_some())
        })
        .map(|s| s.to_string())
        .collect();
    crate::output::vtk::write_vtu(&vtu, &p, &order, &fields)?;
    // the same particles in the snapshots' netCDF point layout, at t = 0 before step 1
    let nc = dir.join("particles.nc");
    crate::output::refuse_non_regular(&nc)?;
    let piece = crate::output::snapshot::Piece::new(&p, (0.0, 0), (0, 1), scene);
    crate::output::netcdf::write_piece(&nc, &piece, &fields)?;
    let mut files = vec![vtu, nc];
    let (names, body_of) = bodies(scene, &p);
    if D == 2 {
        files.extend(section(dir, scene, &p, (&names, &body_of), None)?);
    } else {
        for normal in 0..D {
            files.extend(section(dir, scene, &p, (&names, &body_of), Some(normal))?);
        }
    }
    Ok(files)
}

/// The bodies' labels (`fluid column`, `wall tank`, …) and each particle's index into them.
fn bodies<const D: usize>(scene: &Scene, p: &Particles<D>) -> (Vec<String>, Vec<usize>) {
    let mut names: Vec<String> = Vec::new();
    let mut keys: Vec<(u8, u16)> = Vec::new();
    let of = (0..p.n_owned)
        .map(|i| {
            let (class, label) = match p.kind[i] {
                k if k.is_fluid() => (0, "fluid"),
                k if k.is_solid() => (1, "solid"),
                _ => (2, "wall"),
            };
            let key = (class, p.body[i]);
            match keys.iter().position(|k| *k == key) {
                Some(j) => j,
                None => {
                    let b = p.body[i] as usize;
                    let name = match class {
                        0 => scene.fluids.get(b).map(|f| f.name.as_str()),
                        1 => scene.solids.get(b).map(|f| f.name.as_str()),
                        _ => scene.walls.get(b).map(|w| w.name.as_str()),
                    };
                    names.push(format!("{label} {}", name.unwrap_or("?")));
                    keys.push(key);
                    keys.len() - 1
                }
            }
        })
        .collect();
    (names, of)
}

/// The coordinate (m) along axis `n` of the layer of lattice sites (lo + (i + ½) dx) that the
/// most bodies (`body_of`, `bodies` of them) have particles in; among those, the one nearest
/// the middle of [lo, hi].
fn busiest_layer<const D: usize>(
    p: &Particles<D>,
    body_of: &[usize],
    bodies: usize,
    n: usize,
    lo: f64,
    hi: f64,
    dx: f64,
) -> f64 {
    let layers = (((hi - lo) / dx).ceil() as usize).max(1);
    let mut seen = vec![false; layers * bodies];
    for i in 0..p.n_owned {
        let l = (((p.x[i][n] - lo) / dx).floor().max(0.0) as usize).min(layers - 1);
        seen[l * bodies + body_of[i]] = true;
    }
    let middle = ((0.5 * (hi - lo)) / dx - 0.5).round().max(0.0) as usize;
    let best = (0..layers)
        .max_by_key(|&l| {
            let count = seen[l * bodies..(l + 1) * bodies].iter().filter(|&&b| b).count();
            (count, std::cmp::Reverse(l.abs_diff(middle)), std::cmp::Reverse(l))
        })
        .unwrap_or(middle);
    lo + (best as f64 + 0.5) * dx
}

/// One picture: every particle (2D), or those of the lattice layer of [`busiest_layer`] along
/// `normal` (3D), on the other two axes in order, coloured by body.
fn section<const D: usize>(
    dir: &Path,
    scene: &Scene,
    p: &Particles<D>,
    (names, body_of): (&[String], &[usize]),
    normal: Option<usize>,
) -> Result<Vec<PathBuf>> {
    const AXES: [&str; 3] = ["x", "y", "z"];
    let (lo, hi, dx) = (&scene.domain.min, &scene.domain.max, scene.discretisation.dx);
    let (u, v) = match normal {
        None => (0, 1),
        Some(n) => {
            let others: Vec<usize> = (0..D).filter(|&a| a != n).collect();
            (others[0], others[1])
        }
    };
    let at = normal.map(|n| (n, busiest_layer(p, body_of, names.len(), n, lo[n], hi[n], dx)));
    let shown: Vec<usize> = (0..p.n_owned)
        .filter(|&i| at.is_none_or(|(n, c)| (p.x[i][n] - c).abs() < 0.5 * dx))
        .collect();
    let plane = Plane::of(scene, (u, v));
    let radius = plane.radius;
    let (stem, caption) = match at {
        None => (
            "preview".to_string(),
            format!(
                "{}: {} particles as built, coloured by body",
                scene.name,
                shown.len()
            ),
        ),
        Some((n, c)) => (
            format!("preview_{}", AXES[n]),
            format!(
                "{}: the section {} = {c:.4} m ({} particles), coloured by body",
                scene.name,
                AXES[n],
                shown.len()
            ),
        ),
    };
    let colour = |k: usize| PALETTE[k % PALETTE.len()];
    both!(dir, stem, plane.size, |root| {
        let mut ch = plane.chart(root, &caption)?;
        for (k, name) in names.iter().enumerate() {
            let c = colour(k);
            ch.draw_series(
                shown
                    .iter()
                    .filter(|&&i| body_of[i] == k)
                    .map(|&i| Circle::new((p.x[i][u], p.x[i][v]), radius, c.filled())),
            )?
            .label(name.as_str())
            .legend(move |(x, y)| Circle::new((x, y), 4, c.filled()));
        }
        legend(&mut ch)
    })
}

/// A particle picture's coordinates: metres on both axes.
type XY = Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>;

/// The plane a particle picture draws (the preview's sections, the report's flow pictures):
/// the domain on axes `u` (across) and `v` (up), the picture's size in pixels and the radius
/// of a particle's disc.
pub(super) struct Plane {
    u: usize,
    v: usize,
    lo: [f64; 2],
    hi: [f64; 2],
    /// Pixels (width, height).
    pub size: (u32, u32),
    /// A particle's disc, about a spacing across and at least a pixel (pixels).
    pub radius: i32,
}

impl Plane {
    /// The domain of `scene` on axes (`u`, `v`).
    pub(super) fn of(scene: &Scene, (u, v): (usize, usize)) -> Plane {
        let (lo, hi, dx) = (&scene.domain.min, &scene.domain.max, scene.discretisation.dx);
        let size = picture_size(hi[u] - lo[u], hi[v] - lo[v]);
        let radius = ((dx / (hi[u] - lo[u]) * f64::from(size.0) * 0.45).round() as i32).clamp(1, 12);
        Plane {
            u,
            v,
            lo: [lo[u], lo[v]],
            hi: [hi[u], hi[v]],
            size,
            radius,
        }
    }

    /// The chart on `root` (filled white): `caption` above, the axes named with their unit.
    pub(super) fn chart<'a, DB>(
        &self,
        root: &'a DrawingArea<DB, plotters::coord::Shift>,
        caption: &str,
    ) -> std::result::Result<ChartContext<'a, DB, XY>, Box<dyn std::error::Error>>
    where
        DB: DrawingBackend + 'a,
        DB::ErrorType: 'static,
    {
        const AXES: [&str; 3] = ["x", "y", "z"];
        root.fill(&WHITE)?;
        let mut ch = ChartBuilder::on(root)
            .caption(caption, font(14))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(self.lo[0]..self.hi[0], self.lo[1]..self.hi[1])?;
        ch.configure_mesh()
            .x_desc(format!("{} (m)", AXES[self.u]))
            .y_desc(format!("{} (m)", AXES[self.v]))
            .label_style(font(12))
            .axis_desc_style(font(14))
            .draw()?;
        Ok(ch)
    }
}

/// A particle picture's legend box, drawn over the chart.
pub(super) fn legend<'a, DB>(ch: &mut ChartContext<'a, DB, XY>) -> Res
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
{
    ch.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(font(12))
        .draw()?;
    Ok(())
}

/// Pixels for a picture of the extents `a` × `b` (m): 1000 wide, the height in proportion
/// within 300..1000, plus room for the caption and axes.
fn picture_size(a: f64, b: f64) -> (u32, u32) {
    let h = (1000.0 * b / a).clamp(300.0, 1000.0);
    (1000, h as u32 + 90)
}
