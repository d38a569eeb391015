//! Initial particles from a scene: every body is filled on one global lattice.
//!
//! The lattice has spacing dx and sites at `domain.min + (i + ½) dx` along each axis; a
//! particle's id is the linear index of its site (axis 0 slowest), so ids are deterministic
//! and independent of anything but the scene. Two bodies claiming one site is an input error.

use crate::boundary::wall_kind;
use crate::error::{Error, Result};
use crate::particles::{Fields, Kind, Particles, Record};
use crate::physics::material::MaterialModel;
use crate::scene::{Scene, WallShape};
use crate::Vector;

/// The global lattice of a scene.
#[derive(Debug, Clone)]
pub struct Lattice<const D: usize> {
    /// Lower corner of the domain (m).
    pub origin: Vector<D>,
    /// Spacing dx (m).
    pub dx: f64,
    /// Sites per axis.
    pub n: [u64; D],
}

impl<const D: usize> Lattice<D> {
    /// The lattice covering the scene's domain.
    pub fn new(s: &Scene) -> Self {
        let dx = s.discretisation.dx;
        let mut n = [0u64; D];
        for (a, na) in n.iter_mut().enumerate() {
            *na = ((s.domain.max[a] - s.domain.min[a]) / dx + 1e-9).floor().max(1.0) as u64;
        }
        Lattice {
            origin: Vector::from_fn(|a, _| s.domain.min[a]),
            dx,
            n,
        }
    }

    /// Site index range `[lo, hi)` along `axis` whose centres lie in `[min, max)`.
    fn range(&self, axis: usize, min: f64, max: f64) -> (u64, u64) {
        let t = 1e-9;
        let lo = ((min - self.origin[axis]) / self.dx - 0.5 - t).ceil().max(0.0) as u64;
        let hi = ((max - self.origin[axis]) / self.dx - 0.5 - t).ceil().max(0.0) as u64;
        (lo.min(self.n[axis]), hi.min(self.n[axis]))
    }

    /// Visit every site in the box `[min, max)`: `(id, centre)`.
    pub fn for_each_in(&self, min: &[f64], max: &[f64], mut f: impl FnMut(u64, Vector<D>)) {
        let r: Vec<(u64, u64)> = (0..D).map(|a| self.range(a, min[a], max[a])).collect();
        if r.iter().any(|(lo, hi)| hi <= lo) {
            return;
        }
        let mut idx: Vec<u64> = r.iter().map(|(lo, _)| *lo).collect();
        loop {
            let mut id = 0u64;
            for (na, ia) in self.n.iter().zip(&idx) {
                id = id * na + ia;
            }
            let x = Vector::from_fn(|a, _| self.origin[a] + (idx[a] as f64 + 0.5) * self.dx);
            f(id, x);
            // odometer, last axis fastest
            let mut a = D;
            loop {
                if a == 0 {
                    return;
                }
                a -= 1;
                idx[a] += 1;
                if idx[a] < r[a].1 {
                    break;
                }
                idx[a] = r[a].0;
            }
        }
    }
}

/// A fluid body's initial fields by expression (`velocity_field`, `pressure_field`).
struct BodyFields<const D: usize> {
    velocity: Option<Vec<crate::scene::expr::FieldExpr>>,
    pressure: Option<crate::scene::expr::FieldExpr>,
}

impl<const D: usize> BodyFields<D> {
    fn new(f: &crate::scene::FluidBody, k: &str, s: &Scene) -> Result<Self> {
        use crate::scene::expr::FieldExpr;
        let velocity = match &f.velocity_field {
            Some(v) => Some(
                v.iter()
                    .enumerate()
                    .map(|(a, t)| FieldExpr::parse(&format!("{k}.velocity_field[{a}]"), t, D, &s.constants))
                    .collect::<Result<Vec<_>>>()?,
            ),
            None => None,
        };
        let pressure = match &f.pressure_field {
            Some(t) => Some(FieldExpr::parse(
                &format!("{k}.pressure_field"),
                t,
                D,
                &s.constants,
            )?),
            None => None,
        };
        Ok(BodyFields { velocity, pressure })
    }

    /// Set the velocity `v` (m/s) and density `rho` (kg/m³, from the pressure through the
    /// material's EOS) of the site at `x` where expressions give them.
    fn apply(&self, x: &Vector<D>, eos: &MaterialModel, v: &mut Vector<D>, rho: &mut f64) -> Result<()> {
        if let Some(vs) = &self.velocity {
            for (a, e) in vs.iter().enumerate() {
                v[a] = e.eval(x.as_slice())?;
            }
        }
        if let Some(p) = &self.pressure {
            *rho = eos.density(p.eval(x.as_slice())?);
        }
        Ok(())
    }
}

/// The shared particle fields a scene's run does not need: the solid fields when it has no
/// solid body (no storage, no traffic; see [`Particles::dropped`]).
pub fn dropped_fields(s: &Scene) -> Fields {
    if s.solids.is_empty() {
        Fields::SOLID
    } else {
        Fields::NONE
    }
}

/// A fluid body and a solid body whose boxes overlap or come within a kernel support of each
/// other: they would pass through each other, since fluids and solids do not interact yet.
pub fn coupling_warnings(s: &Scene) -> Vec<String> {
    let reach = s.discretisation.h_over_dx * s.discretisation.dx * 3.0;
    let mut out = Vec::new();
    for (i, f) in s.fluids.iter().enumerate() {
        for (j, b) in s.solids.iter().enumerate() {
            let near = (0..s.dimension).all(|a| f.min[a] - reach < b.max[a] && b.min[a] - reach < f.max[a]);
            if near {
                out.push(format!(
                    "fluid[{i}] `{}` and solid[{j}] `{}` touch or overlap, but fluids and solids do not \
                     interact yet (no coupling): each moves through the other",
                    f.name, b.name
                ));
            }
        }
    }
    out
}

/// Build the owned particles of a scene (sorted by id).
pub fn build_particles<const D: usize>(s: &Scene) -> Result<Particles<D>> {
    let lat = Lattice::<D>::new(s);
    // every site claimed by a body, with the index of the body's name in `keys` (to report
    // overlaps)
    let mut keys: Vec<String> = Vec::new();
    // each site goes straight into the table (a whole Record per site, solid fields and all,
    // held beside the table until it was sorted made the set-up's memory peak: 494 B per 3D
    // fluid particle), then the table is sorted by id in place
    let mut protos = Sites {
        p: Particles::<D>::without(dropped_fields(s)),
        label: Vec::new(),
    };
    body_sites(s, &lat, &mut keys, &mut protos)?;
    wall_sites(s, &lat, &mut keys, &mut protos);
    let Sites { mut p, label } = protos;
    let mut perm: Vec<usize> = (0..p.n_owned).collect();
    // stable: of two bodies claiming one site, the one added later is named
    perm.sort_by_key(|&i| p.id[i]);
    reject_overlaps(&p, &perm, &label, &keys)?;
    p.permute_owned(&perm);
    Ok(p)
}

/// Sites as they are generated: the table in generation order and each site's body (an
/// index into the names of the bodies).
struct Sites<const D: usize> {
    p: Particles<D>,
    label: Vec<u32>,
}

impl<const D: usize> Sites<D> {
    fn push(&mut self, r: Record<D>, label: u32) {
        self.p.push_owned(r);
        self.label.push(label);
    }
}

/// Index of material `name` in the scene (validated earlier; 0 if absent).
fn mat_index(s: &Scene, name: &str) -> u16 {
    s.materials.iter().position(|m| m.name == name).unwrap_or(0) as u16
}

/// The sites of the fluid and solid bodies, with their initial fields (hydrostatic density
/// along −ĝ, velocity, expression fields), appended to `protos` with their body's name in
/// `keys`.
fn body_sites<const D: usize>(
    s: &Scene,
    lat: &Lattice<D>,
    keys: &mut Vec<String>,
    protos: &mut Sites<D>,
) -> Result<()> {
    let vol = s.discretisation.dx.powi(D as i32);
    let materials: Vec<MaterialModel> = s.materials.iter().map(MaterialModel::new).collect();
    let g = Vector::<D>::from_fn(|a, _| s.physics.body_force[a]);
    let gmag = g.norm();
    let solid_kind = |f: &crate::scene::FluidBody| if f.clamped { Kind::Clamped } else { Kind::Solid };
    let bodies = (s
        .fluids
        .iter()
        .enumerate()
        .map(|(b, f)| (b, f, Kind::Fluid, "fluid")))
    .chain(
        s.solids
            .iter()
            .enumerate()
            .map(|(b, f)| (b, f, solid_kind(f), "solid")),
    );
    for (b, f, kind, label) in bodies {
        let key = format!("{label}[{b}]");
        let mat = mat_index(s, &f.material);
        let e = materials[mat as usize];
        let v = Vector::<D>::from_fn(|a, _| f.velocity[a]);
        // top of the block along -ĝ, for the hydrostatic profile
        let top = if gmag > 0.0 {
            (0..D)
                .map(|a| (f.min[a] * g[a]).min(f.max[a] * g[a]))
                .sum::<f64>()
                / gmag
        } else {
            0.0
        };
        let fields = BodyFields::<D>::new(f, &key, s)?;
        let label = keys.len() as u32;
        keys.push(key);
        let mut bad = None;
        lat.for_each_in(&f.min, &f.max, |id, x| {
            if !f.contains(x.as_slice()) {
                return;
            }
            let mut rho = if f.hydrostatic && gmag > 0.0 {
                let depth = x.dot(&g) / gmag - top;
                e.density(e.rho0() * gmag * depth.max(0.0))
            } else {
                e.rho0()
            };
            let mut v = v;
            if let Err(err) = fields.apply(&x, &e, &mut v, &mut rho) {
                bad.get_or_insert(err);
            }
            let r = Record::new(id, kind, b as u16, mat, x, v, rho * vol, rho);
            protos.push(r, label);
        });
        if let Some(err) = bad {
            return Err(err);
        }
    }
    Ok(())
}

/// The sites of the dummy and repulsive walls (blocks, and containers as the shell round
/// their inner box), appended to `protos` with their wall's name in `keys`. Mirror walls are
/// images of the fluid, not particles.
fn wall_sites<const D: usize>(s: &Scene, lat: &Lattice<D>, keys: &mut Vec<String>, protos: &mut Sites<D>) {
    let dx = s.discretisation.dx;
    let vol = dx.powi(D as i32);
    for (b, w) in s.walls.iter().enumerate() {
        let Some(kind) = wall_kind(w.method) else {
            continue;
        };
        let mat = mat_index(s, &w.material);
        let rho0 = MaterialModel::new(&s.materials[mat as usize]).rho0();
        let v = Vector::<D>::from_fn(|a, _| w.velocity[a]);
        let label = keys.len() as u32;
        keys.push(format!("wall[{b}]"));
        let mut push = |id, x| {
            let r = Record::new(id, kind, b as u16, mat, x, v, rho0 * vol, rho0);
            protos.push(r, label)
        };
        match w.shape {
            WallShape::Block => lat.for_each_in(&w.min, &w.max, &mut push),
            WallShape::Container => {
                let (lo, hi) = container_outer(w, s.dimension, dx);
                let inner = lat_box_ids(lat, &w.min, &w.max);
                lat.for_each_in(&lo, &hi, |id, x| {
                    if inner.binary_search(&id).is_err() {
                        push(id, x)
                    }
                });
            }
        }
    }
}

/// Exit-2 error naming the second of two bodies that claim one lattice site (`by_id`: the
/// particles of `p` in id order; `label[i]` indexes `keys`, the bodies' names).
fn reject_overlaps<const D: usize>(
    p: &Particles<D>,
    by_id: &[usize],
    label: &[u32],
    keys: &[String],
) -> Result<()> {
    for pair in by_id.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        if p.id[a] == p.id[b] {
            return Err(Error::input(
                keys[label[b] as usize].clone(),
                format!(
                    "overlaps {} at the lattice site {:?}: bodies must not share particles; \
                     shrink one of them",
                    keys[label[a] as usize],
                    p.x[a].as_slice()
                ),
            ));
        }
    }
    Ok(())
}

/// Number of particles the scene's bodies hold, counted from the lattice ranges without
/// building them (exact unless two bodies overlap, which [`build_particles`] rejects).
pub fn count_particles<const D: usize>(s: &Scene) -> u64 {
    let lat = Lattice::<D>::new(s);
    let dx = s.discretisation.dx;
    let sites = |min: &[f64], max: &[f64]| -> u64 {
        (0..D)
            .map(|a| {
                let (lo, hi) = lat.range(a, min[a], max[a]);
                hi.saturating_sub(lo)
            })
            .product()
    };
    let mut n: u64 = s
        .fluids
        .iter()
        .chain(&s.solids)
        .map(|f| sites(&f.min, &f.max))
        .sum();
    for w in &s.walls {
        if wall_kind(w.method).is_none() {
            continue;
        }
        n += match w.shape {
            WallShape::Block => sites(&w.min, &w.max),
            WallShape::Container => {
                let (lo, hi) = container_outer(w, D, dx);
                sites(&lo, &hi).saturating_sub(sites(&w.min, &w.max))
            }
        };
    }
    n
}

/// A body as the lattice builds it: every lattice site whose centre lies in the scene's box
/// `[min, max)` becomes a particle standing for a cell of side dx, so the body as built spans
/// `[origin + lo·dx, origin + hi·dx)` along each axis.
#[derive(Debug, Clone)]
pub struct BuiltBody {
    /// `fluid[i]`, `wall[i]` (a block) or `wall[i] inner` (a container's inner box).
    pub key: String,
    /// The body's name in the scene.
    pub name: String,
    /// Box in the scene (m).
    pub scene: (Vec<f64>, Vec<f64>),
    /// Box as built (m).
    pub built: (Vec<f64>, Vec<f64>),
    /// Sites per axis.
    pub sites: Vec<u64>,
}

/// Largest relative difference between built and scene sizes (per axis, and of the volume).
const EXTENT_TOLERANCE: f64 = 0.01;

impl BuiltBody {
    /// Relative size differences per axis and of the volume, (built − scene) / scene.
    pub fn differences(&self) -> (Vec<f64>, f64) {
        let len = |b: &(Vec<f64>, Vec<f64>), a: usize| b.1[a] - b.0[a];
        let d = self.scene.0.len();
        let per_axis: Vec<f64> = (0..d)
            .map(|a| len(&self.built, a) / len(&self.scene, a) - 1.0)
            .collect();
        let vol = |b: &(Vec<f64>, Vec<f64>)| (0..d).map(|a| len(b, a)).product::<f64>();
        (per_axis, vol(&self.built) / vol(&self.scene) - 1.0)
    }

    /// True if the body as built differs from the scene's by more than 1 % in size or volume.
    pub fn off(&self) -> bool {
        let (axes, vol) = self.differences();
        vol.abs() > EXTENT_TOLERANCE || axes.iter().any(|x| x.abs() > EXTENT_TOLERANCE)
    }
}

/// Every fluid block, wall block and container inner box as built on the scene's lattice.
pub fn built_extents<const D: usize>(s: &Scene) -> Vec<BuiltBody> {
    let lat = Lattice::<D>::new(s);
    let body = |key: String, name: &str, min: &[f64], max: &[f64]| {
        let r: Vec<(u64, u64)> = (0..D).map(|a| lat.range(a, min[a], max[a])).collect();
        let edge = |i: u64, a: usize| lat.origin[a] + i as f64 * lat.dx;
        BuiltBody {
            key,
            name: name.to_string(),
            scene: (min.to_vec(), max.to_vec()),
            built: (
                (0..D).map(|a| edge(r[a].0, a)).collect(),
                (0..D).map(|a| edge(r[a].1, a)).collect(),
            ),
            sites: r.iter().map(|(lo, hi)| hi.saturating_sub(*lo)).collect(),
        }
    };
    let mut out: Vec<BuiltBody> = s
        .fluids
        .iter()
        .enumerate()
        .filter(|(_, f)| f.shape == crate::scene::BodyShape::Block)
        .map(|(i, f)| body(format!("fluid[{i}]"), &f.name, &f.min, &f.max))
        .collect();
    for (i, w) in s.walls.iter().enumerate() {
        match (w.shape, wall_kind(w.method)) {
            (WallShape::Block, Some(_)) => out.push(body(format!("wall[{i}]"), &w.name, &w.min, &w.max)),
            (WallShape::Container, Some(_)) => {
                out.push(body(format!("wall[{i}] inner"), &w.name, &w.min, &w.max))
            }
            _ => {}
        }
    }
    out
}

/// The spacing nearest to the scene's dx (within ±30 %) on whose lattice every body is built
/// exactly as written (every extent and offset from the domain's corner a whole number of
/// spacings), if there is one.
pub fn fitting_dx<const D: usize>(s: &Scene) -> Option<f64> {
    let dx = s.discretisation.dx;
    let origin = &s.domain.min;
    let mut lengths = Vec::new();
    for b in built_extents::<D>(s) {
        for (a, o) in origin.iter().enumerate().take(D) {
            lengths.push(b.scene.0[a] - o);
            lengths.push(b.scene.1[a] - o);
        }
    }
    let reference = lengths
        .iter()
        .copied()
        .filter(|l| *l > 0.0)
        .fold(f64::INFINITY, f64::min);
    if !reference.is_finite() {
        return None;
    }
    let whole = |l: f64, h: f64| ((l / h) - (l / h).round()).abs() < 1e-6 * (l / h).abs().max(1.0);
    let n0 = (reference / dx).round().max(1.0) as u64;
    // candidates reference / n near n0, nearest first
    (0..n0.max(8))
        .flat_map(|k| [n0 + k, n0.saturating_sub(k)])
        .filter(|&n| n > 0)
        .map(|n| reference / n as f64)
        .filter(|h| (h / dx - 1.0).abs() <= 0.3)
        .find(|&h| lengths.iter().all(|&l| whole(l, h)))
}

/// Sizes "a × b (× c)" in metres with 4 significant digits.
fn sizes(b: &(Vec<f64>, Vec<f64>)) -> String {
    let v: Vec<String> =
        b.0.iter()
            .zip(&b.1)
            .map(|(lo, hi)| format!("{:.4}", hi - lo))
            .collect();
    v.join(" × ")
}

/// One line per body: its size in the scene and as built, its particles per axis and the
/// volume difference.
pub fn extent_lines<const D: usize>(s: &Scene) -> Vec<String> {
    built_extents::<D>(s)
        .iter()
        .map(|b| {
            let (_, vol) = b.differences();
            let n: Vec<String> = b.sites.iter().map(|k| k.to_string()).collect();
            format!(
                "{} `{}`: scene {} m, built {} m ({} sites), volume {:+.2} %",
                b.key,
                b.name,
                sizes(&b.scene),
                sizes(&b.built),
                n.join(" × "),
                100.0 * vol
            )
        })
        .collect()
}

/// Warnings for bodies built more than 1 % off their scene size or volume (a body fills whole
/// lattice cells of dx counted from `domain.min`), with the spacing that would build them all
/// as written, if one lies within ±30 % of dx.
pub fn extent_warnings<const D: usize>(s: &Scene) -> Vec<String> {
    let mut out = sphere_warnings::<D>(s);
    out.extend(coupling_warnings(s));
    if s.physics.shifting == crate::scene::ShiftingKind::DeltaPlus && s.discretisation.h_over_dx < 1.8 {
        out.push(format!(
            "physics.shifting = \"delta_plus\" with discretisation.h_over_dx = {}: shifting is made \
             for h/dx = 2 (Sun et al. 2017); at 1.3 it raised the 40 × 40 cavity's error from 3.2 % \
             to 17.6 % (docs/validation.md §3d); use h_over_dx = 2.0",
            s.discretisation.h_over_dx
        ));
    }
    let off: Vec<BuiltBody> = built_extents::<D>(s).into_iter().filter(|b| b.off()).collect();
    if off.is_empty() {
        return out;
    }
    let fit = match fitting_dx::<D>(s) {
        Some(h) => format!("discretisation.dx = {h:.6e} m would build every body as written"),
        None => "no spacing within ±30 % of dx builds every body as written; align the bodies with \
                 domain.min + k·dx"
            .to_string(),
    };
    out.extend(off.iter().map(|b| {
        let (axes, vol) = b.differences();
        let a: Vec<String> = axes.iter().map(|x| format!("{:+.1} %", 100.0 * x)).collect();
        format!(
            "{} `{}` is built {} m where the scene says {} m ({}; volume {:+.1} %): bodies fill \
                 whole cells of dx = {} m counted from domain.min; {fit}",
            b.key,
            b.name,
            sizes(&b.built),
            sizes(&b.scene),
            a.join(", "),
            100.0 * vol,
            s.discretisation.dx
        )
    }));
    out
}

/// Spheres (discs in 2D) whose lattice volume (sites × dx^D) differs from the true volume by
/// more than 1 %: a sphere is resolved by its diameter in spacings.
fn sphere_warnings<const D: usize>(s: &Scene) -> Vec<String> {
    let lat = Lattice::<D>::new(s);
    let dx = s.discretisation.dx;
    let mut out = Vec::new();
    for (i, f) in s.fluids.iter().enumerate() {
        if f.shape == crate::scene::BodyShape::Block {
            continue;
        }
        let mut n = 0u64;
        lat.for_each_in(&f.min, &f.max, |_, x| n += f.contains(x.as_slice()) as u64);
        let pi = std::f64::consts::PI;
        let exact = match (f.shape, D) {
            (crate::scene::BodyShape::Cylinder, _) => pi * f.radius.powi(2) * f.length,
            (_, 2) => pi * f.radius.powi(2),
            _ => 4.0 / 3.0 * pi * f.radius.powi(3),
        };
        let rel = n as f64 * dx.powi(D as i32) / exact - 1.0;
        if rel.abs() > 0.01 {
            out.push(format!(
                "fluid[{i}] `{}` (a {} of radius {} m, {:.1} spacings across) is built with a \
                 volume {:+.1} % off the true one; a finer dx resolves it better",
                f.name,
                if f.shape == crate::scene::BodyShape::Cylinder {
                    "cylinder"
                } else {
                    "sphere"
                },
                f.radius,
                2.0 * f.radius / dx,
                100.0 * rel
            ));
        }
    }
    out
}

/// The outer box of a container wall: its inner box grown by `layers` spacings on every closed
/// face (open faces stay at the inner box).
fn container_outer(w: &crate::scene::WallBody, d: usize, dx: f64) -> (Vec<f64>, Vec<f64>) {
    let mut lo = w.min.clone();
    let mut hi = w.max.clone();
    for a in 0..d {
        let open = |up| {
            w.open
                .iter()
                .any(|o| crate::scene::face_of(o, d) == Some((a, up)))
        };
        if !open(false) {
            lo[a] -= w.layers as f64 * dx;
        }
        if !open(true) {
            hi[a] += w.layers as f64 * dx;
        }
    }
    (lo, hi)
}

/// Sorted ids of the sites inside a box.
fn lat_box_ids<const D: usize>(lat: &Lattice<D>, min: &[f64], max: &[f64]) -> Vec<u64> {
    let mut ids = Vec::new();
    lat.for_each_in(min, max, |id, _| ids.push(id));
    ids.sort_unstable();
    ids
}
