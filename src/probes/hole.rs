//! The hole a projectile punches in a plate, and the debris cloud behind it (docs/impact.md,
//! "How the hole is measured"),
//! measured from the plate's particles.
//!
//! **Method** (fixed before the first oblique-impact run). The plate's particles are projected
//! along its normal onto the plate plane, but only those still in the plate: within half a
//! thickness plus a bulge allowance of 3 H of the plate's mid-plane, so that debris thrown
//! ahead or behind does not fill the hole (once it has left that band: early on, plate debris
//! still inside it hides the hole) while a bulged rim still counts. The plane is covered with
//! square cells of side 1.5 dx; a cell is material if a projected particle lies in it. The hole is
//! the connected set (4-neighbour) of empty cells that contains the projectile's aim point (the
//! centre of the empty cells within the projectile's radius of it) and does not reach the edge of
//! the grid. Its axes come from the second moments of its cells: for a uniform ellipse with
//! semi-axes a ≥ b the covariance has eigenvalues a²/4 and b²/4, so the major and minor axes are
//! 4√λ1 and 4√λ2, the orientation that of λ1's eigenvector (angle from the first in-plane axis,
//! degrees in (−90, 90]). Robust to isolated gaps elsewhere (not connected to the hole) and to the
//! bulge (the band). The debris cloud is every solid particle beyond the plate's rear face by more
//! than one thickness: its extent along the impact direction (from the rear face) and across it
//! (twice the largest distance from the impact axis through the aim point).

use crate::particles::Particles;
use crate::scene::Scene;
use crate::Vector;

/// What [`measure`] needs to know of the plate and the projectile.
#[derive(Debug, Clone)]
pub struct HoleSetup<const D: usize> {
    /// Body index of the plate (among the solids).
    pub plate: u16,
    /// Axis of the plate normal.
    pub normal: usize,
    /// Mid-plane coordinate of the plate along the normal at t = 0 (m).
    pub mid: f64,
    /// Plate thickness (m).
    pub thickness: f64,
    /// Aim point: where the projectile's centre, moving straight, crosses the mid-plane (m).
    pub aim: Vector<D>,
    /// Unit impact direction.
    pub direction: Vector<D>,
    /// Projectile radius (m): the hole seed is searched within it of the aim point.
    pub radius: f64,
    /// Spacing of the plate's finest particles (m): the scene's dx, or dx / 2^ℓ where a
    /// region of level ℓ refines the plate (`[[refine]]`), so the hole is measured at the
    /// resolution of the particles that open it.
    pub dx: f64,
    /// The scene's lattice spacing (m): a particle of level ℓ has spacing `coarse` / 2^ℓ.
    pub coarse: f64,
    /// Plate extent in the plane: lower and upper corners (m).
    pub lo: Vector<D>,
    /// Upper corner.
    pub hi: Vector<D>,
}

impl<const D: usize> HoleSetup<D> {
    /// The set-up of a validated scene's hole probe: plate and projectile are `[[solid]]`
    /// bodies by name. The plate's normal is its box's thinnest axis; the aim point is where
    /// the projectile's centre, moving straight along its initial velocity, crosses the
    /// plate's mid-plane.
    pub fn of(scene: &Scene, plate: &str, projectile: &str) -> Self {
        let index = |name: &str| scene.solids.iter().position(|b| b.name == name).unwrap_or(0);
        let pl = &scene.solids[index(plate)];
        let finest = (scene.refine.iter().filter(|r| r.applies_to(plate)))
            .map(|r| r.level)
            .max()
            .unwrap_or(0);
        let pr = &scene.solids[index(projectile)];
        let vec_of = |x: &[f64]| Vector::<D>::from_fn(|a, _| x.get(a).copied().unwrap_or(0.0));
        let (lo, hi) = (vec_of(&pl.min), vec_of(&pl.max));
        let ext = hi - lo;
        let normal = (0..D).min_by(|&a, &b| ext[a].total_cmp(&ext[b])).unwrap_or(D - 1);
        let mid = 0.5 * (lo[normal] + hi[normal]);
        let (pmin, pmax) = (vec_of(&pr.min), vec_of(&pr.max));
        let centre = if pr.centre.is_empty() {
            (pmin + pmax) * 0.5
        } else {
            vec_of(&pr.centre)
        };
        let radius = if pr.radius > 0.0 {
            pr.radius
        } else {
            0.5 * (pmax - pmin).min()
        };
        let v = vec_of(&pr.velocity);
        let direction = if v.norm() > 0.0 {
            v / v.norm()
        } else {
            Vector::zeros()
        };
        let aim = if direction[normal] != 0.0 {
            centre + direction * ((mid - centre[normal]) / direction[normal])
        } else {
            centre
        };
        HoleSetup {
            plate: index(plate) as u16,
            normal,
            mid,
            thickness: ext[normal],
            aim,
            direction,
            radius,
            dx: scene.discretisation.dx / f64::from(1u32 << finest),
            coarse: scene.discretisation.dx,
            lo,
            hi,
        }
    }
}

/// A hole and debris measurement; lengths in m.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Hole {
    /// A hole exists through the plate.
    pub perforated: bool,
    /// Major axis (m).
    pub major: f64,
    /// Minor axis (m).
    pub minor: f64,
    /// Orientation of the major axis from the first in-plane axis (degrees).
    pub angle: f64,
    /// Hole area (m²).
    pub area: f64,
    /// Hole centre, the two in-plane coordinates (m).
    pub centre: [f64; 2],
    /// Solid particles in the debris cloud.
    pub debris: f64,
    /// Debris extent along the impact direction beyond the rear face (m).
    pub debris_length: f64,
    /// Debris extent across the impact direction (m).
    pub debris_width: f64,
}

impl Hole {
    /// Column names in the probe file.
    pub const COLUMNS: [&'static str; 10] = crate::scene::HOLE_COLUMNS;

    /// The values in column order.
    pub fn values(&self) -> Vec<f64> {
        vec![
            f64::from(u8::from(self.perforated)),
            self.major,
            self.minor,
            self.angle,
            self.area,
            self.centre[0],
            self.centre[1],
            self.debris,
            self.debris_length,
            self.debris_width,
        ]
    }
}

/// How long the axes must stay within [`SETTLE_CHANGE`] for the hole to count as settled (s).
pub const SETTLE_WINDOW: f64 = 5e-6;
/// The largest relative change of either axis over [`SETTLE_WINDOW`] of a settled hole.
pub const SETTLE_CHANGE: f64 = 0.02;

/// `summary.json`'s `hole` from a hole probe's file (`t` then [`Hole::COLUMNS`]): the first
/// time t_s from which both axes stay within 2 % of their values at t_s for 5 µs, and the axes
/// at t_s + 5 µs; `"settled": false` with the last row's axes if no such time lies in the run.
/// With a `reference` (major, minor in m, source) the signed relative differences.
pub fn settled(text: &str, reference: Option<(f64, f64, &str)>) -> serde_json::Value {
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .filter_map(|l| l.split(',').map(|c| c.parse().ok()).collect::<Option<Vec<f64>>>())
        .filter(|r| r.len() == 1 + Hole::COLUMNS.len())
        .collect();
    let Some(last) = rows.last() else {
        return serde_json::Value::Null;
    };
    let (major, minor) = (2, 3); // column indices after t
    let close = |a: f64, b: f64| b > 0.0 && ((a - b) / b).abs() < SETTLE_CHANGE;
    let mut at = None;
    for (k, r) in rows.iter().enumerate() {
        if r[1] == 0.0 {
            continue;
        }
        let window: Vec<&Vec<f64>> = rows[k..]
            .iter()
            .take_while(|s| s[0] <= r[0] + SETTLE_WINDOW * (1.0 + 1e-9))
            .collect();
        // rows come at the first step past each sampling time: allow 5 % of the window of jitter
        let spans = window.last().is_some_and(|s| s[0] >= r[0] + 0.95 * SETTLE_WINDOW);
        if spans
            && window
                .iter()
                .all(|s| s[1] != 0.0 && close(s[major], r[major]) && close(s[minor], r[minor]))
        {
            at = Some((r[0], *window.last().unwrap()));
            break;
        }
    }
    let (settled, row) = match at {
        Some((_, row)) => (true, row.clone()),
        None => (false, last.clone()),
    };
    let history: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| serde_json::json!([r[0], r[major], r[minor]]))
        .collect();
    let mut v = serde_json::json!({
        "method": "plate particles within 3.5 thicknesses of the mid-plane projected on cells of 1.5 dx; the empty 4-connected region around the aim point; axes 4 sqrt(eigenvalues of its second moments) (src/probes/hole.rs)",
        "perforated": row[1] != 0.0,
        "settled": settled,
        "settled_from_s": at.map(|a| a.0),
        "settle_rule": "both axes within 2 % of their values for 5 us",
        "t_s": row[0],
        "major_m": row[major],
        "minor_m": row[minor],
        "angle_deg": row[4],
        "area_m2": row[5],
        "centre_m": [row[6], row[7]],
        "debris_particles": row[8],
        "debris_length_m": row[9],
        "debris_width_m": row[10],
        "history_t_major_minor": history,
    });
    if let Some((ma, mi, source)) = reference {
        v["reference"] = serde_json::json!({
            "major_m": ma,
            "minor_m": mi,
            "source": source,
            "major_difference": row[major] / ma - 1.0,
            "minor_difference": row[minor] / mi - 1.0,
        });
    }
    v
}

/// The two in-plane axes of a plate with normal `normal` in D dimensions (in 2D the "plate"
/// is a line: one in-plane axis, the second coordinate is 0).
fn plane_axes(d: usize, normal: usize) -> (usize, Option<usize>) {
    let mut it = (0..d).filter(|&a| a != normal);
    let u = it.next().unwrap_or(0);
    (u, it.next())
}

/// Measure the hole and the debris cloud from the particles `ids` of `p` (every solid particle,
/// in id order).
pub fn measure<const D: usize>(p: &Particles<D>, ids: &[usize], s: &HoleSetup<D>) -> Hole {
    measure_with_cells(p, ids, s).0
}

/// [`measure`], with the centres of the hole's cells (in-plane coordinates, m; side
/// [`cell_size`]) for pictures.
pub fn measure_with_cells<const D: usize>(
    p: &Particles<D>,
    ids: &[usize],
    s: &HoleSetup<D>,
) -> (Hole, Vec<[f64; 2]>) {
    let grid = Grid::over(s, D);
    let mut hole = debris_cloud(p, ids, s);
    let full = occupancy(p, ids, s, &grid);
    let Some(mut cells) = flood(&grid, &full, s) else {
        return (hole, Vec::new());
    };
    cells.sort_unstable();
    fit_ellipse(&grid, &cells, &mut hole);
    let centres = cells
        .iter()
        .map(|&c| {
            let (x, y) = grid.centre(c);
            [x, y]
        })
        .collect();
    (hole, centres)
}

/// The cells of the plate plane: `nu` × `nv` squares of side `cell` from (`u0`, `v0`) along the
/// in-plane axes `u`, `v` (a single row in 2D).
struct Grid {
    u: usize,
    v: Option<usize>,
    u0: f64,
    v0: f64,
    cell: f64,
    nu: usize,
    nv: usize,
}

impl Grid {
    /// The plate's in-plane extent with a margin of 4 cells.
    fn over<const D: usize>(s: &HoleSetup<D>, d: usize) -> Self {
        let (u, v) = plane_axes(d, s.normal);
        let cell = cell_size(s.dx);
        let margin = 4.0 * cell;
        let (u0, v0) = (s.lo[u] - margin, v.map_or(0.0, |v| s.lo[v] - margin));
        let nu = (((s.hi[u] - s.lo[u]) + 2.0 * margin) / cell).ceil() as usize + 1;
        let nv = v.map_or(1, |v| {
            (((s.hi[v] - s.lo[v]) + 2.0 * margin) / cell).ceil() as usize + 1
        });
        Grid {
            u,
            v,
            u0,
            v0,
            cell,
            nu,
            nv,
        }
    }

    /// The cell holding position `x`, if on the grid.
    fn cell_of<const D: usize>(&self, x: &Vector<D>) -> Option<usize> {
        let a = ((x[self.u] - self.u0) / self.cell).floor();
        let b = self.v.map_or(0.0, |v| ((x[v] - self.v0) / self.cell).floor());
        (a >= 0.0 && b >= 0.0 && (a as usize) < self.nu && (b as usize) < self.nv)
            .then(|| b as usize * self.nu + a as usize)
    }

    /// Mark every cell the in-plane square of half-side `half` centred at `x` overlaps.
    fn fill_square<const D: usize>(&self, x: &Vector<D>, half: f64, full: &mut [bool]) {
        let range = |a: usize, o: f64, n: usize| {
            let lo = ((x[a] - half - o) / self.cell).floor().max(0.0) as usize;
            let hi = ((x[a] + half - o) / self.cell).ceil().min(n as f64).max(0.0) as usize;
            lo..hi
        };
        let rv = self.v.map_or(0..1, |v| range(v, self.v0, self.nv));
        for b in rv {
            for a in range(self.u, self.u0, self.nu) {
                full[b * self.nu + a] = true;
            }
        }
    }

    /// In-plane centre of cell `c` (m).
    fn centre(&self, c: usize) -> (f64, f64) {
        let (a, b) = (c % self.nu, c / self.nu);
        (
            self.u0 + (a as f64 + 0.5) * self.cell,
            self.v0 + (b as f64 + 0.5) * self.cell,
        )
    }
}

/// Distance of `x` behind the plate's rear face, the face the projectile leaves by (m).
fn behind<const D: usize>(x: &Vector<D>, s: &HoleSetup<D>) -> f64 {
    let sign = if s.direction[s.normal] < 0.0 { -1.0 } else { 1.0 };
    let rear = s.mid + 0.5 * s.thickness * sign;
    (x[s.normal] - rear) * sign
}

/// A measurement holding only the debris cloud: every solid particle more than a thickness
/// behind the rear face, its length along the impact direction and its width across.
fn debris_cloud<const D: usize>(p: &Particles<D>, ids: &[usize], s: &HoleSetup<D>) -> Hole {
    let mut hole = Hole::default();
    for &i in ids {
        if !p.kind[i].is_solid() || behind(&p.x[i], s) <= s.thickness {
            continue;
        }
        hole.debris += 1.0;
        let r = p.x[i] - s.aim;
        let along = r.dot(&s.direction);
        let across = (r - s.direction * along).norm();
        hole.debris_length = hole.debris_length.max(behind(&p.x[i], s));
        hole.debris_width = hole.debris_width.max(2.0 * across);
    }
    hole
}

/// Cells covered by a plate particle within the band (half a thickness plus 3 H) of the
/// mid-plane.
fn occupancy<const D: usize>(p: &Particles<D>, ids: &[usize], s: &HoleSetup<D>, grid: &Grid) -> Vec<bool> {
    let band = 0.5 * s.thickness + 3.0 * s.thickness;
    let mut full = vec![false; grid.nu * grid.nv];
    for &i in ids {
        let x = &p.x[i];
        if !(p.kind[i].is_solid() && p.body[i] == s.plate && (x[s.normal] - s.mid).abs() <= band) {
            continue;
        }
        // a particle coarser than the plate's finest (a refined plate) fills the cells its
        // own square of side `spacing` overlaps, so the cells, sized for the finest, see no
        // gap between coarse particles
        let spacing = s.coarse / f64::from(1u32 << p.level.get(i).copied().unwrap_or(0));
        if spacing > 1.01 * s.dx {
            grid.fill_square(x, 0.5 * spacing, &mut full);
        } else if let Some(c) = grid.cell_of(x) {
            full[c] = true;
        }
    }
    full
}

/// The 4-connected empty cells reached from those within the projectile's radius of the aim
/// point; `None` when there are none or they reach the grid's edge (no hole, open ground).
fn flood<const D: usize>(grid: &Grid, full: &[bool], s: &HoleSetup<D>) -> Option<Vec<usize>> {
    let (nu, nv) = (grid.nu, grid.nv);
    let aim = (s.aim[grid.u], grid.v.map_or(0.0, |v| s.aim[v]));
    let mut label = vec![false; nu * nv];
    let mut stack: Vec<usize> = (0..nu * nv)
        .filter(|&c| {
            let (x, y) = grid.centre(c);
            !full[c] && (x - aim.0).hypot(y - aim.1) <= s.radius
        })
        .collect();
    stack.iter().for_each(|&c| label[c] = true);
    let mut cells = Vec::new();
    let mut open = false;
    while let Some(c) = stack.pop() {
        cells.push(c);
        let (a, b) = (c % nu, c / nu);
        if a == 0 || a + 1 == nu || (nv > 1 && (b == 0 || b + 1 == nv)) {
            open = true;
        }
        let neighbours = [
            (a > 0).then(|| c - 1),
            (a + 1 < nu).then(|| c + 1),
            (b > 0).then(|| c - nu),
            (b + 1 < nv).then(|| c + nu),
        ];
        for n in neighbours.into_iter().flatten() {
            if !full[n] && !label[n] {
                label[n] = true;
                stack.push(n);
            }
        }
    }
    (!cells.is_empty() && !open).then_some(cells)
}

/// Axes, orientation, area and centre of the hole's cells (sorted) from their second moments,
/// each cell a uniform square (variance cell²/12 per axis): a uniform ellipse with semi-axes
/// a ≥ b has eigenvalues a²/4 and b²/4.
fn fit_ellipse(grid: &Grid, cells: &[usize], hole: &mut Hole) {
    let cell = grid.cell;
    let n = cells.len() as f64;
    let (mut mx, mut my) = (0.0, 0.0);
    for &c in cells {
        let (x, y) = grid.centre(c);
        mx += x;
        my += y;
    }
    let (mx, my) = (mx / n, my / n);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for &c in cells {
        let (x, y) = grid.centre(c);
        sxx += (x - mx) * (x - mx);
        syy += (y - my) * (y - my);
        sxy += (x - mx) * (y - my);
    }
    let add = cell * cell / 12.0;
    let (sxx, syy, sxy) = (
        sxx / n + add,
        if grid.nv > 1 { syy / n + add } else { 0.0 },
        sxy / n,
    );
    let tr = 0.5 * (sxx + syy);
    let det = (0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy).sqrt();
    let (l1, l2) = (tr + det, (tr - det).max(0.0));
    hole.perforated = true;
    hole.major = 4.0 * l1.sqrt();
    hole.minor = 4.0 * l2.sqrt();
    let mut angle = 0.5 * (2.0 * sxy).atan2(sxx - syy).to_degrees();
    if angle <= -90.0 {
        angle += 180.0;
    }
    hole.angle = angle;
    hole.area = n * cell * cell;
    hole.centre = [mx, my];
}

/// Side of the cells the plate is projected on (m): 1.5 dx, so that a plate stretched to 1.5×
/// its lattice spacing still covers every cell.
pub fn cell_size(dx: f64) -> f64 {
    1.5 * dx
}

/// The in-plane axes of the plate (the second is absent in 2D).
pub fn in_plane_axes(d: usize, normal: usize) -> (usize, Option<usize>) {
    plane_axes(d, normal)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::particles::{Kind, Record};

    #[test]
    fn the_hole_settles_at_the_first_time_both_axes_hold_for_5_us() {
        let head = format!("t,{}", Hole::COLUMNS.join(","));
        let row = |t: f64, major: f64, minor: f64| format!("{t},1,{major},{minor},10,0,0,0,0,0,0");
        // growing until 4 µs, then within 1 % from 4 µs to 10 µs
        let mut text = vec![head.clone(), "0,0,0,0,0,0,0,0,0,0,0".to_string()];
        for k in 1..=20 {
            let t = k as f64 * 0.5e-6;
            let g = if t < 4e-6 {
                t / 4e-6
            } else {
                1.0 + 0.005 * (t - 4e-6) / 6e-6
            };
            text.push(row(t, 0.01 * g, 0.008 * g));
        }
        let v = settled(&text.join("\n"), Some((0.0106, 0.0085, "exp")));
        assert_eq!(v["settled"], true);
        assert!(
            (v["settled_from_s"].as_f64().unwrap() - 4e-6).abs() < 1e-12,
            "{v}"
        );
        assert!((v["t_s"].as_f64().unwrap() - 9e-6).abs() < 1e-12);
        let d = v["reference"]["major_difference"].as_f64().unwrap();
        assert!((d - (v["major_m"].as_f64().unwrap() / 0.0106 - 1.0)).abs() < 1e-15);
        // still growing by 3 % per µs at the end: not settled, the last row reported
        let growing: Vec<String> = std::iter::once(head)
            .chain((1..=20).map(|k| {
                let t = k as f64 * 0.5e-6;
                row(t, 0.01 * (1.0 + 0.03e6 * t), 0.008)
            }))
            .collect();
        let v = settled(&growing.join("\n"), None);
        assert_eq!(v["settled"], false);
        assert!((v["t_s"].as_f64().unwrap() - 10e-6).abs() < 1e-12);
    }

    /// The set-up of a 0.4 mm plate (body 1) in z ∈ [0, 0.4 mm], ±15 mm across, hit along
    /// −z at its centre; `dx` its finest spacing, `coarse` the scene's.
    fn plate_setup(dx: f64, coarse: f64) -> HoleSetup<3> {
        HoleSetup::<3> {
            plate: 1,
            normal: 2,
            mid: 0.2e-3,
            thickness: 0.4e-3,
            aim: Vector::<3>::new(0.0, 0.0, 0.2e-3),
            direction: Vector::<3>::new(0.0, 0.0, -1.0),
            radius: 1e-3,
            dx,
            coarse,
            lo: Vector::<3>::new(-15e-3, -15e-3, 0.0),
            hi: Vector::<3>::new(15e-3, 15e-3, 0.4e-3),
        }
    }

    /// A plate of lattice particles with an elliptical hole (semi-axes a, b, rotated by θ),
    /// plus debris behind it: the measured axes are those of the ellipse within a cell.
    #[test]
    fn an_elliptical_hole_in_a_lattice_plate_is_measured_within_a_cell() {
        let dx = 0.1e-3;
        let (a, b, th) = (5.0e-3, 3.5e-3, 30f64.to_radians());
        let mut p = Particles::<3>::default();
        let mut id = 0;
        for i in -150..150 {
            for j in -150..150 {
                for k in 0..4 {
                    let x = Vector::<3>::new(
                        (i as f64 + 0.5) * dx,
                        (j as f64 + 0.5) * dx,
                        (k as f64 + 0.5) * dx,
                    );
                    let (c, s) = (th.cos(), th.sin());
                    let (xu, yv) = (c * x[0] + s * x[1], -s * x[0] + c * x[1]);
                    if (xu / a).powi(2) + (yv / b).powi(2) < 1.0 {
                        continue;
                    }
                    p.push_owned(Record::new(id, Kind::Solid, 1, 0, x, Vector::zeros(), 1.0, 1.0));
                    id += 1;
                }
            }
        }
        // debris well behind the plate (−z), and a loose fragment inside the hole's shadow
        for k in 0..10 {
            let x = Vector::<3>::new(1e-3, 0.0, -3e-3 - k as f64 * 1e-3);
            p.push_owned(Record::new(id, Kind::Solid, 0, 0, x, Vector::zeros(), 1.0, 1.0));
            id += 1;
        }
        let ids: Vec<usize> = (0..p.n_owned).collect();
        let s = plate_setup(dx, dx);
        let h = measure(&p, &ids, &s);
        assert!(h.perforated);
        let cell = 1.5 * dx;
        assert!((h.major - 2.0 * a).abs() < 2.0 * cell, "{h:?}");
        assert!((h.minor - 2.0 * b).abs() < 2.0 * cell, "{h:?}");
        assert!((h.angle - 30.0).abs() < 2.0, "{h:?}");
        assert_eq!(h.debris, 10.0);
        // the last fragment is 12 mm behind the rear face (z = 0), 1 mm off the axis
        assert!((h.debris_length - 12e-3).abs() < 1e-9, "{h:?}");
        assert!((h.debris_width - 2e-3).abs() < 1e-9, "{h:?}");
        // an intact plate has no hole
        let mut filled = Particles::<3>::default();
        for i in -150..150 {
            for j in -150..150 {
                let x = Vector::<3>::new((i as f64 + 0.5) * dx, (j as f64 + 0.5) * dx, 0.5 * dx);
                let id = ((i + 150) * 300 + (j + 150)) as u64;
                filled.push_owned(Record::new(id, Kind::Solid, 1, 0, x, Vector::zeros(), 1.0, 1.0));
            }
        }
        let all: Vec<usize> = (0..filled.n_owned).collect();
        assert!(!measure(&filled, &all, &s).perforated);
    }

    /// A refined plate (`[[refine]]`): fine particles (spacing dx, level 1) in a disc of
    /// radius 3 mm, coarse ones (2 dx, level 0) beyond, and a circular hole of radius 4 mm
    /// opened into the coarse part. Measured at the fine spacing (cells of 1.5 dx), the coarse
    /// particles fill the cells their squares cover: the hole's axes are the circle's within
    /// two cells.
    #[test]
    fn a_hole_in_a_refined_plate_is_measured_at_the_fine_spacing() {
        let dx = 0.1e-3;
        let (r_hole, r_disc) = (4.0e-3, 3.0e-3);
        let mut p = Particles::<3>::default();
        let mut id = 0;
        let mut put = |x: Vector<3>, level: u16, p: &mut Particles<3>| {
            let mut r = Record::new(id, Kind::Solid, 1, 0, x, Vector::zeros(), 1.0, 1.0);
            r.level = level;
            p.push_owned(r);
            id += 1;
        };
        // coarse lattice (2 dx): sites outside the disc; fine (dx): sites of the disc's cells
        for i in -75..75 {
            for j in -75..75 {
                for k in 0..2 {
                    let c = Vector::<3>::new(
                        (i as f64 + 0.5) * 2.0 * dx,
                        (j as f64 + 0.5) * 2.0 * dx,
                        (k as f64 + 0.5) * 2.0 * dx,
                    );
                    if c[0].hypot(c[1]) >= r_disc {
                        if c[0].hypot(c[1]) >= r_hole {
                            put(c, 0, &mut p);
                        }
                        continue;
                    }
                    for o in 0..8 {
                        let off = |b: usize| if o >> b & 1 == 1 { 0.5 } else { -0.5 } * dx;
                        let x = c + Vector::<3>::new(off(0), off(1), off(2));
                        if x[0].hypot(x[1]) >= r_hole {
                            put(x, 1, &mut p);
                        }
                    }
                }
            }
        }
        let ids: Vec<usize> = (0..p.n_owned).collect();
        let s = plate_setup(dx, 2.0 * dx);
        let h = measure(&p, &ids, &s);
        assert!(h.perforated, "{h:?}");
        let cell = 1.5 * dx;
        assert!((h.major - 2.0 * r_hole).abs() < 2.0 * cell, "{h:?}");
        assert!((h.minor - 2.0 * r_hole).abs() < 2.0 * cell, "{h:?}");
        // the same particles counted as fine (each filling its own cell only): the gaps
        // between the coarse particles join the hole to the grid's edge, no hole is found
        let mut flat = p.clone();
        flat.level.iter_mut().for_each(|l| *l = 1);
        assert!(!measure(&flat, &ids, &s).perforated);
    }
}
