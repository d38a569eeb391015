//! What each probe kind computes from the particles gathered for it (a [`View`] sorted by id).
//!
//! Interpolated values use Shepard's normalisation over fluid particles:
//! f(x) = Σ_j f_j W(x − x_j) V_j / Σ_j W(x − x_j) V_j, V_j = m_j/ρ_j, summed in id order.

use super::bins::{around, Bins};
use super::PROBED;
use crate::particles::Fields;
use crate::physics::fluid::{pair_acceleration, PairTerms};
use crate::scene::{Direction, Probe};
use crate::sim::View;
use crate::Vector;

/// The fields probe `probe` reads. A front probe reads where the fluid is and nothing else:
/// its view, which holds every fluid particle of the run (the largest of a run's views), is
/// then 33 B a particle in 3D (id, kind, position) instead of PROBED's ~115 B. Every other
/// probe reads [`PROBED`] over its small region.
pub(super) fn fields_of(probe: &Probe) -> Fields {
    match probe {
        Probe::Front { .. } => Fields::ID.or(Fields::KIND).or(Fields::X),
        Probe::Pressure { .. }
        | Probe::VelocityLine { .. }
        | Probe::Gauge { .. }
        | Probe::Force { .. }
        | Probe::Hole { .. } => PROBED,
        #[cfg(test)]
        Probe::Toy { .. } => Fields::ID.or(Fields::KIND).or(Fields::MASS),
    }
}

/// The particles a probe kind reads, which `ProbeSet::region` turns into a box grown by the
/// interaction reach.
pub(super) enum Reach<const D: usize> {
    /// Fluid particles in the box from `lo` to `hi` (m) grown by the reach plus `margin` (m).
    Box {
        lo: Vector<D>,
        hi: Vector<D>,
        margin: f64,
    },
    /// The vertical column through a point, wall particles included (a gauge finds the bed).
    Column(Vector<D>),
    /// Every fluid particle.
    Fluid,
    /// Every solid particle.
    Solids,
    /// The probe's wall body and the fluid within reach of its current extent.
    Wall,
}

/// The particles probe `probe` reads (its [`Reach`]).
pub(super) fn reach<const D: usize>(probe: &Probe) -> Reach<D> {
    let vec_of = |x: &[f64]| Vector::<D>::from_fn(|a, _| x[a]);
    match probe {
        Probe::Pressure { point, diameter, .. } => Reach::Box {
            lo: vec_of(point),
            hi: vec_of(point),
            margin: 0.5 * diameter,
        },
        Probe::VelocityLine { from, to, .. } => {
            let (a, b) = (vec_of(from), vec_of(to));
            Reach::Box {
                lo: a.inf(&b),
                hi: b.sup(&a),
                margin: 0.0,
            }
        }
        Probe::Gauge { point, .. } => Reach::Column(vec_of(point)),
        Probe::Front { .. } => Reach::Fluid,
        Probe::Hole { .. } => Reach::Solids,
        Probe::Force { .. } => Reach::Wall,
        #[cfg(test)]
        Probe::Toy { .. } => Reach::Fluid,
    }
}

/// Sample a probe from the particles gathered for it. `wall` is the body index of a force
/// probe's wall.
pub fn sample<const D: usize>(v: &View<D>, probe: &Probe, wall: u16) -> Vec<f64> {
    let vec_of = |x: &[f64]| Vector::<D>::from_fn(|a, _| x[a]);
    match probe {
        Probe::Pressure {
            point,
            diameter,
            normal,
            ..
        } => {
            let n = normal.as_deref().map(vec_of).unwrap_or_else(Vector::zeros);
            vec![pressure(v, &vec_of(point), *diameter, &n)]
        }
        Probe::VelocityLine { from, to, points, .. } => {
            let (a, b) = (vec_of(from), vec_of(to));
            let mut out = Vec::with_capacity(points * D);
            for k in 0..*points {
                let s = k as f64 / (*points - 1) as f64;
                let u = shepard(v, &(a + (b - a) * s), &|i| v.p.v[i]).unwrap_or_else(Vector::zeros);
                out.extend(u.iter());
            }
            out
        }
        Probe::Gauge { point, .. } => vec![gauge(v, point)],
        Probe::Front {
            axis,
            direction,
            link,
            ..
        } => vec![front(v, *axis, *direction, *link * v.scene.discretisation.dx)],
        Probe::Force { about, .. } => {
            let at = about.as_deref().map(vec_of).unwrap_or_else(Vector::zeros);
            force(v, wall, &at)
        }
        Probe::Hole {
            plate, projectile, ..
        } => {
            let setup = super::hole::HoleSetup::<D>::of(v.scene, plate, projectile);
            let ids: Vec<usize> = (0..v.p.n_owned).filter(|&i| v.p.kind[i].is_solid()).collect();
            super::hole::measure(&v.p, &ids, &setup).values()
        }
        #[cfg(test)]
        Probe::Toy { .. } => {
            let fluid = (0..v.p.n_owned).filter(|&i| v.p.kind[i].is_fluid());
            vec![fluid.map(|i| v.p.mass[i]).fold(0.0, |s, m| s + m)]
        }
    }
}

/// Shepard interpolation of `f` over the fluid particles at `at`; `None` where no fluid
/// particle is within the kernel support.
fn shepard<const D: usize>(v: &View<D>, at: &Vector<D>, f: &dyn Fn(usize) -> Vector<D>) -> Option<Vector<D>> {
    let p = &v.p;
    let (mut sw, mut s) = (0.0, Vector::<D>::zeros());
    for i in 0..p.n_owned {
        if !p.kind[i].is_fluid() {
            continue;
        }
        let r = (at - p.x[i]).norm();
        // within the largest support, each particle's own kernel (zero beyond its support)
        if r < v.model.kernel.support {
            let w = v.model.pair_kernel(p, i, i).w(r) * p.mass[i] / p.rho[i];
            sw += w;
            s += f(i) * w;
        }
    }
    (sw > 0.0).then(|| s / sw)
}

/// A pressure transducer (Pa): the Shepard average of the fluid pressure (wall particles
/// excluded, so on a wall face it averages the fluid within the support in front of the face),
/// taken at the points of its sensing face — a disc (3D) or segment (2D) of `diameter` across
/// the normal `n`, sampled every dx/4 — and averaged over them with equal weights. A point
/// with no fluid in reach reads 0 (a dry part of the face feels no gauge pressure).
fn pressure<const D: usize>(v: &View<D>, centre: &Vector<D>, diameter: f64, n: &Vector<D>) -> f64 {
    let at = |x: &Vector<D>| shepard(v, x, &|i| Vector::from_element(v.p.p[i])).map_or(0.0, |s| s[0]);
    if diameter <= 0.0 || D == 1 {
        return at(centre);
    }
    let n = n.normalize();
    // an orthonormal basis of the face: Gram–Schmidt on the coordinate axes
    let mut basis: Vec<Vector<D>> = Vec::new();
    for a in 0..D {
        let mut e = Vector::<D>::from_fn(|b, _| if a == b { 1.0 } else { 0.0 });
        e -= n * n.dot(&e);
        for b in &basis {
            e -= b * b.dot(&e);
        }
        if e.norm() > 1e-6 && basis.len() < D - 1 {
            basis.push(e.normalize());
        }
    }
    let radius = 0.5 * diameter;
    let m = (radius / (0.25 * v.scene.discretisation.dx)).ceil().max(1.0) as i64;
    let step = radius / m as f64;
    let (mut sum, mut count) = (0.0, 0usize);
    let span = -m..=m;
    let second = if D == 3 { -m..=m } else { 0..=0 };
    for a in span {
        for b in second.clone() {
            let (sa, sb) = (a as f64 * step, b as f64 * step);
            if sa * sa + sb * sb > radius * radius * (1.0 + 1e-12) {
                continue;
            }
            let mut x = centre + basis[0] * sa;
            if D == 3 {
                x += basis[1] * sb;
            }
            sum += at(&x);
            count += 1;
        }
    }
    sum / count as f64
}

/// A wave gauge: the elevation (m, along the last axis) of the free surface of the continuous
/// water column under `point`. The column starts on the bed — the top of the wall particles
/// under the gauge, or the domain's floor — and rises while the kernel-interpolated fraction of
/// matter φ(z) = Σ_j W(x − x_j) V_j stays at or above ½; the surface is where φ crosses ½,
/// interpolated linearly between samples dx/4 apart. φ counts the fluid particles and the wall
/// particles below z (half at z): a bed then stands in for water under the surface as it
/// should, while a vertical wall beside the gauge counts only below the surface — where the
/// fluid fills the rest of the support's lower half — so a gauge at a wall reads the run-up
/// instead of a level raised by the dry wall above the water (1.4 cm at dx = 2.5 cm). Spray above
/// the first crossing is not water under the gauge. A gauge whose first fluid row is not wet
/// (φ < ½ at dx/2 above the bed) is dry and reads 0.
fn gauge<const D: usize>(v: &View<D>, point: &[f64]) -> f64 {
    let p = &v.p;
    let dx = v.scene.discretisation.dx;
    let up = D - 1;
    // the columns within half a spacing, both of them when the gauge sits exactly between two
    // (x = 0.3 m on a lattice offset by dx/2 from it); a strict `<` found none there, took
    // the domain's floor for the bed and read a full column as dry
    // a particle's own spacing dx/2^level: refined wall columns are half as wide, so the
    // scene's spacing would take the refined side wall next to a gauge for its bed
    let spacing = |i: usize| dx / f64::from(1u32 << p.level.get(i).copied().unwrap_or(0));
    let under = |i: usize| (0..up).all(|a| (p.x[i][a] - point[a]).abs() <= 0.5 * spacing(i) * (1.0 + 1e-9));
    let bed = (0..p.n_owned)
        .filter(|&i| p.kind[i].is_wall() && under(i))
        .map(|i| p.x[i][up] + 0.5 * spacing(i))
        .fold(v.scene.domain.min[up], f64::max);
    let phi = |z: f64| {
        let at = Vector::<D>::from_fn(|a, _| if a == up { z } else { point[a] });
        let mut s = 0.0;
        for i in 0..p.n_owned {
            let r = (at - p.x[i]).norm();
            if r < v.model.kernel.support {
                let k = v.model.pair_kernel(p, i, i);
                let share = match (p.kind[i].is_fluid(), p.x[i][up].partial_cmp(&z)) {
                    (true, _) | (false, Some(std::cmp::Ordering::Less)) => 1.0,
                    (false, Some(std::cmp::Ordering::Equal)) => 0.5,
                    _ => 0.0,
                };
                s += share * k.w(r) * p.mass[i] / p.rho[i];
            }
        }
        s
    };
    let top = v.scene.domain.max[up];
    let (mut z, mut f) = (bed + 0.5 * dx, phi(bed + 0.5 * dx));
    if f < 0.5 {
        return 0.0;
    }
    let step = 0.25 * dx;
    while z + step <= top {
        let (z1, f1) = (z + step, phi(z + step));
        if f1 < 0.5 {
            return z + step * (f - 0.5) / (f - f1);
        }
        (z, f) = (z1, f1);
    }
    top
}

/// Front of the main body (m): the largest connected group of fluid particles, two particles
/// connected when closer than `link` (m) — ties to the group holding the smallest id — and
/// its largest (`+`) or smallest (`-`) coordinate along `axis`. Detached drops and spray ahead
/// of the body are separate groups and do not count. NaN when there is no fluid.
pub(crate) fn front<const D: usize>(v: &View<D>, axis: usize, dir: Direction, link: f64) -> f64 {
    // the front probe and the dam-break reference ask for the same front at an output step
    let key = [
        0,
        axis as u64,
        matches!(dir, Direction::Plus) as u64,
        link.to_bits(),
    ];
    v.memo.get_or(key, || main_body_front(v, axis, dir, link))
}

/// [`front`], computed.
fn main_body_front<const D: usize>(v: &View<D>, axis: usize, dir: Direction, link: f64) -> f64 {
    let p = &v.p;
    let bins = Bins::new(&p.x, link, (0..p.n_owned).filter(|&i| p.kind[i].is_fluid()));
    // union–find over particle indices (fluid only take part)
    let mut parent: Vec<usize> = (0..p.n_owned).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    // each pair once: a cell with itself (j > i) and with the cells around it that sort after
    // it. The groups do not depend on the order of the unions, and each group's root is its
    // smallest index (id)
    let link2 = link * link;
    for k in 0..bins.len() {
        let (cell, here) = (bins.cell(k), bins.members(k));
        for c in around(cell).filter(|c| *c >= cell) {
            for &j in bins.at(c) {
                for &i in here {
                    if (c != cell || j > i) && (p.x[i] - p.x[j]).norm_squared() < link2 {
                        let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                        if a != b {
                            parent[a.max(b)] = a.min(b);
                        }
                    }
                }
            }
        }
    }
    let mut size = vec![0usize; p.n_owned];
    for i in 0..p.n_owned {
        if p.kind[i].is_fluid() {
            let r = root(&mut parent, i);
            size[r] += 1;
        }
    }
    // largest group; among equals the one whose root (smallest member) comes first
    let Some(main) = (0..p.n_owned)
        .filter(|&r| size[r] > 0)
        .max_by_key(|&r| (size[r], std::cmp::Reverse(r)))
    else {
        return f64::NAN;
    };
    let coords = (0..p.n_owned)
        .filter(|&i| p.kind[i].is_fluid() && root(&mut parent, i) == main)
        .map(|i| p.x[i][axis]);
    match dir {
        Direction::Plus => coords.fold(f64::NEG_INFINITY, f64::max),
        Direction::Minus => coords.fold(f64::INFINITY, f64::min),
    }
}

/// Force (N; N/m in 2D) and moment about `about` (N·m; N·m/m in 2D) the fluid exerts on the
/// wall body `wall`: for every fluid particle i and wall particle j of the body within the
/// kernel support, −m_i times the acceleration j gives i in the momentum equation
/// ([`pair_acceleration`]), so the sensor reads exactly the reaction of the forces the solver
/// applies. Summed fluid particle by fluid particle in id order, each over its wall neighbours
/// in id order. Returns `fx, fy[, fz]` then `mz` (2D) or `mx, my, mz` (3D).
fn force<const D: usize>(v: &View<D>, wall: u16, about: &Vector<D>) -> Vec<f64> {
    let (p, model) = (&v.p, v.model);
    let reach = model.kernel.support.max(model.repulsive.r0);
    let walls = Bins::new(
        &p.x,
        reach,
        (0..p.n_owned).filter(|&j| p.kind[j].is_wall() && p.body[j] == wall),
    );
    let mut near = Vec::new();
    let p_rho2 = |i: usize| p.p[i] / (p.rho[i] * p.rho[i]);
    let (mut f, mut m) = (Vector::<D>::zeros(), [0.0f64; 3]);
    for i in 0..p.n_owned {
        if !p.kind[i].is_fluid() {
            continue;
        }
        near.clear();
        near.extend(walls.near(&p.x[i]).filter(|&j| (p.x[i] - p.x[j]).norm() < reach));
        if near.is_empty() {
            continue;
        }
        near.sort_unstable();
        let terms = PairTerms::of(p, model, i, p_rho2(i));
        for &j in &near {
            let fj = crate::with_pair_kernel!(model.varying(), model.kernel, D, k => {
                pair_acceleration(p, model, k, &terms, p_rho2(j), j)
            }) * -p.mass[i];
            f += fj;
            let r = p.x[j] - about;
            if D == 2 {
                m[2] += r[0] * fj[1] - r[1] * fj[0];
            } else {
                m[0] += r[1] * fj[2] - r[2] * fj[1];
                m[1] += r[2] * fj[0] - r[0] * fj[2];
                m[2] += r[0] * fj[1] - r[1] * fj[0];
            }
        }
    }
    let mut out: Vec<f64> = f.iter().copied().collect();
    if D == 3 {
        out.extend(m);
    } else {
        out.push(m[2]);
    }
    out
}

#[cfg(test)]
mod tests {
    use crate::comm::serial::SerialComm;
    use crate::probes::ProbeSet;
    use crate::scene::Probe;
    use crate::sim::Simulation;

    /// A probe kind added by its recipe's two files (`scene/probes.rs`, this file) runs from a
    /// scene file: the test-only `toy` probe of `inputs/hydrostatic_2d.toml` writes
    /// `probes/m.csv` with the header its `columns` name and, every step, the fluid mass summed
    /// in id order, to the bit of that sum over the run's particles (mass is conserved: every
    /// row is the same).
    #[test]
    fn a_probe_kind_added_in_its_files_runs_from_a_scene() {
        let text = std::fs::read_to_string("inputs/hydrostatic_2d.toml").unwrap()
            + "\n[[probe]]\nkind = \"toy\"\nname = \"m\"\ninterval = 0.0\n";
        let path = std::path::Path::new("toy_probe.toml");
        let scene = crate::scene::load_scene_str(&text, path, "toy_probe", &[])
            .unwrap()
            .0;
        assert!(matches!(scene.probes.last(), Some(Probe::Toy { .. })));
        let dir = std::env::temp_dir().join(format!("hsph-toy-probe-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let comm = SerialComm::new();
        let mut sim = Simulation::<2>::new(&scene, &comm).unwrap();
        let mut probes = ProbeSet::<2>::new(&scene, Some(&dir), false).unwrap();
        let steps = 20;
        for _ in 0..steps {
            sim.advance(&comm).unwrap();
            probes.after_step(&sim, &comm, (false, false), false).unwrap();
        }
        probes.flush().unwrap();
        let mut fluid: Vec<(u64, f64)> = (0..sim.p.n_owned)
            .filter(|&i| sim.p.kind[i].is_fluid())
            .map(|i| (sim.p.id[i] as u64, sim.p.mass[i]))
            .collect();
        fluid.sort_by_key(|f| f.0);
        let want = fluid.iter().fold(0.0, |s, f| s + f.1);
        assert!(want > 0.0);
        let csv = std::fs::read_to_string(dir.join("probes/m.csv")).unwrap();
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some("t,mass"));
        let rows: Vec<f64> = lines
            .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
            .collect();
        assert_eq!(rows.len(), steps);
        assert!(rows.iter().all(|&m| m == want), "{rows:?} against {want}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
