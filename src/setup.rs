//! Initial particles from a scene: every body is filled on one global lattice.
//!
//! The lattice has spacing dx and sites at `domain.min + (i + ½) dx` along each axis; a
//! particle's id is the linear index of its site (axis 0 slowest), so ids are deterministic
//! and independent of anything but the scene. Two bodies claiming one site is an input error.

use crate::boundary::wall_kind;
use crate::decomp::Cloud;
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

    /// Visit every site in the box `[min, max)`: `(site index per axis, id, centre)`.
    pub fn for_each_in(&self, min: &[f64], max: &[f64], mut f: impl FnMut(&[u64], u64, Vector<D>)) {
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
            f(&idx, id, x);
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
/// solid body, the viscous lattice moment unless the operator is renormalised (no storage,
/// no traffic; see [`Particles::dropped`]).
pub fn dropped_fields(s: &Scene) -> Fields {
    let solid = if s.solids.is_empty() {
        Fields::SOLID
    } else {
        Fields::NONE
    };
    let lap = if s.physics.viscous_operator == crate::scene::ViscousOperator::Renormalised {
        Fields::NONE
    } else {
        Fields::LAP
    };
    solid.or(lap)
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

/// Build every particle of a scene (sorted by id): [`SiteSource::build`] over the whole
/// lattice.
pub fn build_particles<const D: usize>(s: &Scene) -> Result<Particles<D>> {
    SiteSource::<D>::new(s)?.build(None, |_, _| true)
}

/// What a body does with the sites of its box.
enum Claim<const D: usize> {
    /// A fluid or solid body: the sites inside its shape, with hydrostatic density along −ĝ
    /// below `top` (m), velocity and expression fields.
    Body {
        body: usize,
        solid: bool,
        e: MaterialModel,
        v: Vector<D>,
        /// Body force (m/s²) when the density is hydrostatic (non-zero), else `None`.
        hydrostatic: Option<Vector<D>>,
        top: f64,
        fields: Box<BodyFields<D>>,
    },
    /// A dummy or repulsive wall: every site of its box, except those of `inner` (site index
    /// ranges per axis: a container's inner box).
    Wall {
        rho0: f64,
        v: Vector<D>,
        inner: Option<Vec<(u64, u64)>>,
    },
}

/// One source of particles: a body of the scene, in the order bodies are added (fluids,
/// solids, walls).
struct Source<const D: usize> {
    /// `fluid[i]`, `solid[i]` or `wall[i]`.
    key: String,
    kind: Kind,
    /// Index of the body among its kind (the particle's `body` field).
    index: u16,
    mat: u16,
    /// Box whose sites the body may claim (m).
    min: Vec<f64>,
    max: Vec<f64>,
    claim: Claim<D>,
}

/// The particles of a scene, site by site, without storing them: every rank can count, bound
/// or build exactly the sites it needs (issue 17: no rank materialises the whole lattice).
/// A site is a lattice index; its particle's fields are a function of the scene alone, so a
/// particle built on any rank is the same bits.
pub struct SiteSource<'s, const D: usize> {
    scene: &'s Scene,
    lat: Lattice<D>,
    sources: Vec<Source<D>>,
}

impl<'s, const D: usize> SiteSource<'s, D> {
    /// The sources of `s` (parses the bodies' expression fields).
    pub fn new(s: &'s Scene) -> Result<Self> {
        let lat = Lattice::<D>::new(s);
        let materials: Vec<MaterialModel> = s.materials.iter().map(MaterialModel::new).collect();
        // material indices by name, once: a scene may hold thousands of bodies and materials
        let mat_of: std::collections::HashMap<&str, u16> = (s.materials.iter().enumerate().rev())
            .map(|(i, m)| (m.name.as_str(), i as u16))
            .collect();
        let mat_index = |name: &str| mat_of.get(name).copied().unwrap_or(0);
        let g = Vector::<D>::from_fn(|a, _| s.physics.body_force[a]);
        let gmag = g.norm();
        let mut sources = Vec::new();
        let bodies = s
            .fluids
            .iter()
            .enumerate()
            .map(|(b, f)| (b, f, false))
            .chain(s.solids.iter().enumerate().map(|(b, f)| (b, f, true)));
        for (b, f, solid) in bodies {
            let key = format!("{}[{b}]", if solid { "solid" } else { "fluid" });
            let mat = mat_index(&f.material);
            // top of the block along -ĝ, for the hydrostatic profile
            let top = if gmag > 0.0 {
                (0..D)
                    .map(|a| (f.min[a] * g[a]).min(f.max[a] * g[a]))
                    .sum::<f64>()
                    / gmag
            } else {
                0.0
            };
            let kind = match (solid, f.clamped) {
                (false, _) => Kind::Fluid,
                (true, true) => Kind::Clamped,
                (true, false) => Kind::Solid,
            };
            let fields = Box::new(BodyFields::<D>::new(f, &key, s)?);
            sources.push(Source {
                key,
                kind,
                index: b as u16,
                mat,
                min: f.min.clone(),
                max: f.max.clone(),
                claim: Claim::Body {
                    body: b,
                    solid,
                    e: materials[mat as usize],
                    v: Vector::<D>::from_fn(|a, _| f.velocity[a]),
                    hydrostatic: (f.hydrostatic && gmag > 0.0).then_some(g),
                    top,
                    fields,
                },
            });
        }
        let dx = s.discretisation.dx;
        for (b, w) in s.walls.iter().enumerate() {
            let Some(kind) = wall_kind(w.method) else {
                continue;
            };
            let mat = mat_index(&w.material);
            let (min, max, inner) = match w.shape {
                WallShape::Block => (w.min.clone(), w.max.clone(), None),
                WallShape::Container => {
                    let (lo, hi) = container_outer(w, s.dimension, dx);
                    let inner = (0..D).map(|a| lat.range(a, w.min[a], w.max[a])).collect();
                    (lo, hi, Some(inner))
                }
            };
            sources.push(Source {
                key: format!("wall[{b}]"),
                kind,
                index: b as u16,
                mat,
                min,
                max,
                claim: Claim::Wall {
                    rho0: materials[mat as usize].rho0(),
                    v: Vector::<D>::from_fn(|a, _| w.velocity[a]),
                    inner,
                },
            });
        }
        Ok(SiteSource {
            scene: s,
            lat,
            sources,
        })
    }

    /// Exclusive bound of the particles' ids: the number of lattice sites.
    pub fn id_bound(&self) -> u64 {
        self.lat.n.iter().product()
    }

    /// Lattice spacing dx (m).
    pub fn dx(&self) -> f64 {
        self.lat.dx
    }

    /// Lattice layers along x (axis 0): [`SiteSource::for_each`] splits work by them.
    pub fn layers(&self) -> u64 {
        self.lat.n[0]
    }

    /// Visit every site claimed by source `j` whose centre lies in the box `[min, max)`:
    /// `(id, centre)`.
    fn each_claimed(&self, j: usize, min: &[f64], max: &[f64], mut f: impl FnMut(u64, Vector<D>)) {
        let src = &self.sources[j];
        let lo: Vec<f64> = (0..D).map(|a| src.min[a].max(min[a])).collect();
        let hi: Vec<f64> = (0..D).map(|a| src.max[a].min(max[a])).collect();
        match &src.claim {
            Claim::Body { body, solid, .. } => {
                let b = if *solid {
                    &self.scene.solids[*body]
                } else {
                    &self.scene.fluids[*body]
                };
                self.lat.for_each_in(&lo, &hi, |_, id, x| {
                    if b.contains(x.as_slice()) {
                        f(id, x)
                    }
                });
            }
            Claim::Wall { inner, .. } => self.lat.for_each_in(&lo, &hi, |idx, id, x| {
                let inside = inner
                    .as_ref()
                    .is_some_and(|r| idx.iter().zip(r).all(|(i, (l, h))| i >= l && i < h));
                if !inside {
                    f(id, x)
                }
            }),
        }
    }

    /// Visit every site of the layers `layers` along x: `(id, centre, kind)`, source by
    /// source (the order matters only to sums that are order-independent).
    pub fn for_each(&self, layers: std::ops::Range<u64>, mut f: impl FnMut(u64, &Vector<D>, Kind)) {
        let (min, max) = self.layer_box(layers);
        for (j, src) in self.sources.iter().enumerate() {
            self.each_claimed(j, &min, &max, |id, x| f(id, &x, src.kind));
        }
    }

    /// The box of the layers `layers` along x, unbounded along the other axes.
    fn layer_box(&self, layers: std::ops::Range<u64>) -> (Vec<f64>, Vec<f64>) {
        let edge = |i: u64| self.lat.origin[0] + i as f64 * self.lat.dx;
        let mut min = vec![f64::NEG_INFINITY; D];
        let mut max = vec![f64::INFINITY; D];
        min[0] = if layers.start == 0 {
            f64::NEG_INFINITY
        } else {
            edge(layers.start)
        };
        max[0] = if layers.end >= self.lat.n[0] {
            f64::INFINITY
        } else {
            edge(layers.end)
        };
        (min, max)
    }

    /// The record of the site `id` at `x` claimed by source `j`.
    fn record(&self, j: usize, id: u64, x: Vector<D>) -> Result<Record<D>> {
        let src = &self.sources[j];
        let vol = self.lat.dx.powi(D as i32);
        Ok(match &src.claim {
            Claim::Body {
                e,
                v,
                hydrostatic,
                top,
                fields,
                ..
            } => {
                let mut rho = match hydrostatic {
                    Some(g) => {
                        let gmag = g.norm();
                        let depth = x.dot(g) / gmag - top;
                        e.density(e.rho0() * gmag * depth.max(0.0))
                    }
                    None => e.rho0(),
                };
                let mut v = *v;
                fields.apply(&x, e, &mut v, &mut rho)?;
                Record::new(id, src.kind, src.index, src.mat, x, v, rho * vol, rho)
            }
            Claim::Wall { rho0, v, .. } => {
                Record::new(id, src.kind, src.index, src.mat, x, *v, rho0 * vol, *rho0)
            }
        })
    }

    /// The particles of the sites in the box `region` (`None`: everywhere) for which
    /// `keep(id, centre)` holds, sorted by id. Two bodies claiming one kept site is an input
    /// error naming both.
    pub fn build(
        &self,
        region: Option<(&[f64], &[f64])>,
        keep: impl Fn(u64, &Vector<D>) -> bool,
    ) -> Result<Particles<D>> {
        let unbounded = vec![f64::NEG_INFINITY; D];
        let above = vec![f64::INFINITY; D];
        let (min, max) = region.unwrap_or((&unbounded, &above));
        // each site goes straight into the table (a whole Record per site held beside the
        // table until it was sorted made the set-up's memory peak), then the table is sorted
        // by id in place; `label` is each particle's source, to name overlaps
        let mut p = Particles::<D>::without(dropped_fields(self.scene));
        let mut label: Vec<u32> = Vec::new();
        let mut bad = None;
        for j in 0..self.sources.len() {
            self.each_claimed(j, min, max, |id, x| {
                if !keep(id, &x) {
                    return;
                }
                match self.record(j, id, x) {
                    Ok(r) => {
                        p.push_owned(r);
                        label.push(j as u32);
                    }
                    Err(e) => {
                        bad.get_or_insert(e);
                    }
                }
            });
            if let Some(e) = bad {
                return Err(e);
            }
        }
        let mut perm: Vec<usize> = (0..p.n_owned).collect();
        // stable: of two bodies claiming one site, the one added later is named
        perm.sort_by_key(|&i| p.id[i]);
        let keys: Vec<&str> = self.sources.iter().map(|s| s.key.as_str()).collect();
        reject_overlaps(&p, &perm, &label, &keys)?;
        p.permute_owned(&perm);
        Ok(p)
    }
}

/// The lattice layers `layers` (along x) of a scene's sites as a [`Cloud`]: the share of the
/// lattice one rank streams while the ranks choose their blocks.
pub struct LayerShare<'a, 's, const D: usize> {
    /// The scene's sites.
    pub src: &'a SiteSource<'s, D>,
    /// Layers along x, `[start, end)`.
    pub layers: std::ops::Range<u64>,
}

impl<'a, 's, const D: usize> LayerShare<'a, 's, D> {
    /// Rank `rank`'s equal share of the layers of `src` among `ranks`.
    pub fn of_rank(src: &'a SiteSource<'s, D>, rank: usize, ranks: usize) -> Self {
        let n = src.layers() as u128;
        let at = |r: usize| (n * r as u128 / ranks as u128) as u64;
        LayerShare {
            src,
            layers: at(rank)..at(rank + 1),
        }
    }

    /// Layers per part: about 64 parts, for rayon.
    fn step(&self) -> u64 {
        (self.layers.end - self.layers.start).div_ceil(64).max(1)
    }
}

impl<const D: usize> Cloud<D> for LayerShare<'_, '_, D> {
    fn parts(&self) -> usize {
        (self.layers.end - self.layers.start).div_ceil(self.step()) as usize
    }

    fn visit(&self, k: usize, mut f: impl FnMut(&Vector<D>, u64, bool)) {
        let a = self.layers.start + k as u64 * self.step();
        let b = (a + self.step()).min(self.layers.end);
        self.src.for_each(a..b, |id, x, kind| f(x, id, kind.is_fluid()));
    }
}

/// Exit-2 error naming the second of two bodies that claim one lattice site (`by_id`: the
/// particles of `p` in id order; `label[i]` indexes `keys`, the bodies' names).
fn reject_overlaps<const D: usize>(
    p: &Particles<D>,
    by_id: &[usize],
    label: &[u32],
    keys: &[&str],
) -> Result<()> {
    for pair in by_id.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        if p.id[a] == p.id[b] {
            return Err(Error::input(
                keys[label[b] as usize],
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

/// Exclusive bound of the particle ids of `s`: the number of sites of its lattice.
pub fn id_bound<const D: usize>(s: &Scene) -> u64 {
    Lattice::<D>::new(s).n.iter().product()
}

/// Number of particles the scene's bodies hold, counted from the lattice ranges without
/// building them (exact unless two bodies overlap, which [`build_particles`] rejects; a
/// sphere or cylinder counts the sites of its box).
pub fn count_particles<const D: usize>(s: &Scene) -> u64 {
    body_sites::<D>(s).iter().map(|b| b.sites).sum()
}

/// The lattice sites of one body, counted without building them.
#[derive(Debug, Clone)]
pub struct BodySites {
    /// `fluid[i]`, `solid[i]` or `wall[i]`.
    pub key: String,
    /// The body's name in the scene.
    pub name: String,
    /// Sites of its box (a container: of its walls, the outer box less the inner one).
    pub sites: u64,
    /// True if the body claims at least one site: its box has sites and, for a sphere or a
    /// cylinder, the site nearest its centre lies inside it.
    pub builds: bool,
    /// Smallest extent of its box (m; a container's inner box).
    pub smallest: f64,
    /// A container with every face open (no walls at any dx).
    pub all_open: bool,
}

/// The sites of every body that has particles (fluids, solids, then dummy and repulsive walls;
/// mirror walls have none), in the order [`SiteSource`] adds them, from the lattice ranges
/// alone: O(1) per body whatever its size.
pub fn body_sites<const D: usize>(s: &Scene) -> Vec<BodySites> {
    let lat = Lattice::<D>::new(s);
    let dx = s.discretisation.dx;
    let ranges = |min: &[f64], max: &[f64]| -> Vec<(u64, u64)> {
        (0..D).map(|a| lat.range(a, min[a], max[a])).collect()
    };
    let sites = |r: &[(u64, u64)]| -> u64 { r.iter().map(|(lo, hi)| hi.saturating_sub(*lo)).product() };
    let smallest = |min: &[f64], max: &[f64]| (0..D).map(|a| max[a] - min[a]).fold(f64::INFINITY, f64::min);
    let mut out = Vec::new();
    let bodies = (s
        .fluids
        .iter()
        .enumerate()
        .map(|(i, f)| (format!("fluid[{i}]"), f)))
    .chain(
        s.solids
            .iter()
            .enumerate()
            .map(|(i, f)| (format!("solid[{i}]"), f)),
    );
    for (key, f) in bodies {
        let r = ranges(&f.min, &f.max);
        let n = sites(&r);
        // of the box's sites the one nearest the centre (per axis, so nearest overall) is
        // inside a sphere or cylinder if any is
        let builds = n > 0
            && (f.shape == crate::scene::BodyShape::Block || {
                let x: Vec<f64> = (0..D)
                    .map(|a| {
                        let i = ((f.centre[a] - lat.origin[a]) / dx - 0.5).round().max(0.0) as u64;
                        let i = i.clamp(r[a].0, r[a].1 - 1);
                        lat.origin[a] + (i as f64 + 0.5) * dx
                    })
                    .collect();
                f.contains(&x)
            });
        out.push(BodySites {
            key,
            name: f.name.clone(),
            sites: n,
            builds,
            smallest: smallest(&f.min, &f.max),
            all_open: false,
        });
    }
    for (i, w) in s.walls.iter().enumerate() {
        if wall_kind(w.method).is_none() {
            continue;
        }
        let n = match w.shape {
            WallShape::Block => sites(&ranges(&w.min, &w.max)),
            WallShape::Container => {
                let (lo, hi) = container_outer(w, D, dx);
                sites(&ranges(&lo, &hi)).saturating_sub(sites(&ranges(&w.min, &w.max)))
            }
        };
        let open = |a: usize, up: bool| {
            w.open
                .iter()
                .any(|o| crate::scene::face_of(o, D) == Some((a, up)))
        };
        out.push(BodySites {
            key: format!("wall[{i}]"),
            name: w.name.clone(),
            sites: n,
            builds: n > 0,
            smallest: smallest(&w.min, &w.max),
            all_open: w.shape == WallShape::Container && (0..D).all(|a| open(a, false) && open(a, true)),
        });
    }
    out
}

/// Every body builds at least one particle at the scene's dx: one that builds none is an
/// input error naming it and dx, with a spacing that would resolve it.
pub fn check_bodies_build<const D: usize>(s: &Scene) -> Result<()> {
    let dx = s.discretisation.dx;
    let Some(b) = body_sites::<D>(s).into_iter().find(|b| !b.builds) else {
        return Ok(());
    };
    if b.all_open {
        return Err(Error::input(
            format!("{}.open", b.key),
            format!(
                "wall `{}` is a container with every face open, which has no particle at any dx; \
                 close a face (e.g. open = [\"y+\"]) or remove the wall",
                b.name
            ),
        ));
    }
    let smallest = b.smallest;
    Err(Error::input(
        b.key.clone(),
        format!(
            "body `{}` builds no particle at dx = {dx} m: no lattice site (at domain.min + (i + ½)·dx) \
             lies inside it, its smallest extent being {smallest:.4e} m; refine discretisation.dx \
             (e.g. dx = {:.4e}, half that extent) or enlarge the body",
            b.name,
            0.5 * smallest
        ),
    ))
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

/// A scene's set-up warnings: settings outside their tested range (shifting below h/dx 1.8, a
/// CFL number above 1), fluids and solids that touch without coupling, and bodies built more
/// than 1 % off their scene size or volume (a body fills whole lattice cells of dx counted
/// from `domain.min`), with the spacing that would build them all as written, if one lies
/// within ±30 % of dx.
pub fn scene_warnings<const D: usize>(s: &Scene) -> Vec<String> {
    let mut out = sphere_warnings::<D>(s);
    out.extend(coupling_warnings(s));
    if s.time.cfl > 1.0 && s.time.dt == 0.0 {
        out.push(format!(
            "time.cfl = {} is above 1: dt = CFL·h/(c0 + |v|max) then exceeds the time sound takes \
             to cross h; in the 2D dam break every method held to 0.75, plain WCSPH and Molteni's \
             δ-SPH to 1.25, and all failed at 1.5 (docs/validation.md §5c); 0.2 is typical",
            s.time.cfl
        ));
    }
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
        lat.for_each_in(&f.min, &f.max, |_, _, x| n += f.contains(x.as_slice()) as u64);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2D scene of one fluid disc (and a 3D one of a cylinder) that the tests reshape.
    fn scene(text: &str) -> Scene {
        crate::scene::load_scene_str(text, std::path::Path::new("t.toml"), "t", &[])
            .unwrap()
            .0
    }

    const DISC: &str = r#"
dimension = 2
[domain]
min = [0.0, 0.0]
max = [1.0, 1.0]
[discretisation]
dx = 0.1
[[material]]
name = "w"
rho0 = 1000.0
c0 = 10.0
[[fluid]]
name = "disc"
material = "w"
shape = "sphere"
centre = [0.5, 0.5]
radius = 0.2
[time]
t_end = 0.01
"#;

    const CYLINDER: &str = r#"
dimension = 3
[domain]
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]
[discretisation]
dx = 0.1
[[material]]
name = "w"
rho0 = 1000.0
c0 = 10.0
[[fluid]]
name = "rod"
material = "w"
shape = "cylinder"
centre = [0.5, 0.5, 0.5]
radius = 0.2
length = 0.4
axis = 1
[time]
t_end = 0.01
"#;

    /// The a-priori answer of [`body_sites`] (does the body build a particle?) is the one
    /// building the particles gives, for discs and cylinders of every size and offset.
    #[test]
    fn bodies_that_build_no_particle_are_found_without_building() {
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut empty, mut full) = (0, 0);
        for text in [DISC, CYLINDER] {
            let base = scene(text);
            let d = base.dimension;
            for _ in 0..400 {
                let mut s = base.clone();
                let f = &mut s.fluids[0];
                f.radius = 0.01 + 0.12 * uniform();
                f.length = 0.01 + 0.2 * uniform();
                f.centre = (0..d).map(|_| 0.3 + 0.4 * uniform()).collect();
                let mut half = vec![f.radius; d];
                if f.shape == crate::scene::BodyShape::Cylinder {
                    half[1] = 0.5 * f.length;
                }
                f.min = (0..d).map(|a| f.centre[a] - half[a]).collect();
                f.max = (0..d).map(|a| f.centre[a] + half[a]).collect();
                let (builds, built) = crate::with_dim!(d, D => Ok::<_, Error>((
                    body_sites::<D>(&s)[0].builds,
                    SiteSource::<D>::new(&s).unwrap().build(None, |_, _| true).unwrap().n_owned,
                )))
                .unwrap();
                assert_eq!(
                    builds,
                    built > 0,
                    "{:?} r {} l {}",
                    s.fluids[0].centre,
                    s.fluids[0].radius,
                    s.fluids[0].length
                );
                if built == 0 {
                    empty += 1;
                } else {
                    full += 1;
                }
            }
        }
        assert!(empty > 50 && full > 50, "{empty} empty, {full} built");
    }
}
