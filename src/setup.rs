//! Initial particles from a scene: every body is filled on one global lattice.
//!
//! The lattice has spacing dx and sites at `domain.min + (i + ½) dx` along each axis; a
//! particle's id is the linear index of its site (axis 0 slowest), so ids are deterministic
//! and independent of anything but the scene. Two bodies claiming one site is an input error.

use crate::decomp::Cloud;
use crate::error::{Error, Result};
use crate::material::MaterialModel;
use crate::particles::{Fields, Kind, Particles, Record};
use crate::scene::lattice::{block_core, container_outer, Lattice};
use crate::scene::{Scene, WallShape};
use crate::Vector;

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
/// solid body, the viscous lattice moment unless the operator is renormalised, level and h in
/// a scene of one size, the walls' extrapolated velocity v_w unless a wall extrapolates from
/// the fluid (dummy), the renormalised density gradient unless the density diffusion is
/// Antuono's (no storage, no traffic; see [`Particles::dropped`]).
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
    let level = if s.refine.is_empty() {
        Fields::LEVEL
    } else {
        Fields::NONE
    };
    let h = if crate::scene::refine::finest_h(s) == 0 {
        Fields::H
    } else {
        Fields::NONE
    };
    // v_w is written by the walls that extrapolate from the fluid (dummy) and read only where
    // a neighbour is one of their particles
    let vw = if s.walls.iter().any(|w| crate::boundary::updates(w.method)) {
        Fields::NONE
    } else {
        Fields::VW
    };
    // ⟨∇ρ⟩^L is Antuono's δ-SPH term's alone
    let grad = if s.physics.density_diffusion.needs_gradient() {
        Fields::NONE
    } else {
        Fields::GRAD_RHO
    };
    solid.or(lap).or(level).or(h).or(vw).or(grad)
}

/// Build every particle of a scene (sorted by id): [`SiteSource::build`] over the whole
/// lattice.
pub fn build_particles<const D: usize>(s: &Scene) -> Result<Particles<D>> {
    SiteSource::<D>::new(s)?.build(None, |_, _| true)
}

/// [`crate::kernel::sizes::Sizes::site_load`] of a particle of kind `kind`: a repulsive wall
/// particle lists no neighbours (load 1), a dummy one only fluid.
pub fn particle_load<const D: usize>(z: &crate::kernel::sizes::Sizes, kind: Kind, level: u16, h: f64) -> u64 {
    match kind.is_smoothed() {
        true => z.site_load::<D>(level, h, kind.is_wall()),
        false => 1,
    }
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
        /// The other fluid bodies whose box reaches above this one's top (hydrostatic bodies
        /// only) with their ρ0 (kg/m³): the fluid that can rest on it; and the wall blocks
        /// (ρ0 `None`), which water above and around a submerged one bridges.
        over: Vec<(crate::scene::FluidBody, Option<f64>)>,
        /// Contact distance (m): half the lattice spacing.
        gap: f64,
        fields: Box<BodyFields<D>>,
    },
    /// A dummy or repulsive wall: every site of its box, except those of `inner` (site index
    /// ranges per axis: a container's inner box); a polygon wall only the sites of its
    /// `outline` within its depth (m) of it.
    Wall {
        rho0: f64,
        v: Vector<D>,
        inner: Option<Vec<(u64, u64)>>,
        outline: Option<crate::scene::lattice::Shell>,
    },
}

/// The top of a body's box along −ĝ, as the coordinate x·ĝ of its highest corner (m; smaller
/// is higher), for the hydrostatic profile; 0 without a body force.
fn top_along<const D: usize>(f: &crate::scene::FluidBody, g: &Vector<D>) -> f64 {
    let gmag = g.norm();
    if gmag > 0.0 {
        (0..D)
            .map(|a| (f.min[a] * g[a]).min(f.max[a] * g[a]))
            .sum::<f64>()
            / gmag
    } else {
        0.0
    }
}

/// The scene's wall blocks as block bodies, for the overburden's rays (a container holds the
/// water from outside and is never above it).
fn wall_blocks(s: &Scene) -> Vec<crate::scene::FluidBody> {
    (s.walls.iter())
        .filter(|w| w.shape == WallShape::Block)
        .map(|w| crate::scene::FluidBody {
            name: w.name.clone(),
            material: String::new(),
            shape: crate::scene::BodyShape::Block,
            min: w.min.clone(),
            max: w.max.clone(),
            centre: Vec::new(),
            radius: 0.0,
            axis: None,
            length: 0.0,
            vertices: Vec::new(),
            file: None,
            scale: None,
            rotate: Vec::new(),
            translate: Vec::new(),
            flip: None,
            slice: None,
            fill: None,
            layers: None,
            sha256: None,
            mesh: None,
            velocity: Vec::new(),
            hydrostatic: false,
            velocity_field: None,
            pressure_field: None,
            clamped: false,
        })
        .collect()
}

/// Σ ρ0_k L_k (kg/m²) of the fluid bodies `over` stacked on a body above the site `x`: along
/// the ray x + s·`up` from the body's top (s = `top`), each body whose column starts within
/// `gap` of where the last one ended adds its length L_k there, until a gap (a body that
/// does not touch the stack, e.g. a drop above a pool, weighs nothing on it). A wall block on
/// the ray (ρ0 `None`) is bridged: if fluid rests on it, its length counts at that fluid's
/// ρ0, the pressure of the water beside a submerged body at its depth; with nothing on it, it
/// ends the stack. Zero without.
fn overburden<const D: usize>(
    x: &Vector<D>,
    up: &Vector<D>,
    top: f64,
    over: &[(crate::scene::FluidBody, Option<f64>)],
    gap: f64,
) -> f64 {
    if over.is_empty() {
        return 0.0;
    }
    let mut cols: Vec<(f64, f64, Option<f64>)> = over
        .iter()
        .filter_map(|(o, rho0)| {
            o.chord(x.as_slice(), up.as_slice())
                .map(|(s0, s1)| (s0, s1, *rho0))
        })
        .collect();
    cols.sort_by(|a, b| a.0.total_cmp(&b.0));
    // `bridged`: the length of wall crossed since the last fluid (m)
    let (mut reach, mut load, mut bridged) = (top, 0.0, 0.0);
    for (s0, s1, rho0) in cols {
        if s0 > reach + gap {
            break;
        }
        if s1 > reach {
            let length = s1 - s0.max(reach);
            match rho0 {
                Some(rho0) => {
                    load += rho0 * (length + bridged);
                    bridged = 0.0;
                }
                None => bridged += length,
            }
            reach = s1;
        }
    }
    load
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
/// or build exactly the sites it needs (no rank materialises the whole lattice: ARCHITECTURE.md,
/// "Ranks, ghosts and determinism across ranks").
/// A site is a lattice index; its particle's fields are a function of the scene alone, so a
/// particle built on any rank is the same bits.
pub struct SiteSource<'s, const D: usize> {
    scene: &'s Scene,
    lat: Lattice<D>,
    /// The lattice of each refinement level 1..=finest (`[[refine]]`; empty without).
    fine: Vec<Lattice<D>>,
    /// Spacings and smoothing lengths of the levels (a refined scene only).
    sizes: Option<crate::kernel::sizes::Sizes>,
    /// The sizes the initial split weighs sites with (`balance.load = "pairs"`; else none).
    load_sizes: Option<crate::kernel::sizes::Sizes>,
    sources: Vec<Source<D>>,
}

impl<'s, const D: usize> SiteSource<'s, D> {
    /// The sources of `s` (parses the bodies' expression fields).
    pub fn new(s: &'s Scene) -> Result<Self> {
        let lat = Lattice::<D>::new(s);
        let materials: Vec<MaterialModel> = s.materials.iter().map(|m| m.model()).collect();
        // material indices by name, once: a scene may hold thousands of bodies and materials
        let mat_of: std::collections::HashMap<&str, u16> = (s.materials.iter().enumerate().rev())
            .map(|(i, m)| (m.name.as_str(), i as u16))
            .collect();
        let mat_index = |name: &str| mat_of.get(name).copied().unwrap_or(0);
        let g = Vector::<D>::from_fn(|a, _| s.physics.body_force[a]);
        let gmag = g.norm();
        let mut sources = Vec::new();
        let wall_blocks = wall_blocks(s);
        let bodies = s
            .fluids
            .iter()
            .enumerate()
            .map(|(b, f)| (b, f, false))
            .chain(s.solids.iter().enumerate().map(|(b, f)| (b, f, true)));
        for (b, f, solid) in bodies {
            let key = format!("{}[{b}]", if solid { "solid" } else { "fluid" });
            let mat = mat_index(&f.material);
            let top = top_along(f, &g);
            let kind = match (solid, f.clamped) {
                (false, _) => Kind::Fluid,
                (true, true) => Kind::Clamped,
                (true, false) => Kind::Solid,
            };
            let fields = Box::new(BodyFields::<D>::new(f, &key, s)?);
            // fluid bodies whose box reaches above this one's top: what may rest on it
            let over = match !solid && f.hydrostatic && gmag > 0.0 {
                true => (s.fluids.iter().enumerate())
                    .filter(|&(k, o)| k != b && top_along(o, &g) < top)
                    .map(|(_, o)| (o.clone(), Some(materials[mat_index(&o.material) as usize].rho0())))
                    .chain(wall_blocks.iter().map(|w| (w.clone(), None)))
                    .collect(),
                false => Vec::new(),
            };
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
                    over,
                    gap: 0.5 * lat.dx,
                    fields,
                },
            });
        }
        for (b, w) in s.walls.iter().enumerate() {
            let Some(kind) = w.method.particle_kind() else {
                continue;
            };
            let mat = mat_index(&w.material);
            let (min, max, inner) = match w.shape {
                // a dummy block is its shell: its core reaches no fluid
                WallShape::Block => (w.min.clone(), w.max.clone(), block_core(s, w, &lat)),
                WallShape::Polygon | WallShape::Mesh => (w.min.clone(), w.max.clone(), None),
                WallShape::Container => {
                    let (lo, hi) = container_outer(s, w);
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
                    outline: crate::scene::lattice::wall_shell(s, w),
                },
            });
        }
        let fine = (1..=s.finest_level())
            .map(|l| Lattice::<D>::at_level(s, l))
            .collect();
        Ok(SiteSource {
            scene: s,
            lat,
            fine,
            sizes: crate::scene::refine::sizes(s),
            load_sizes: crate::scene::refine::load_sizes(s),
            sources,
        })
    }

    /// Exclusive bound of the particles' ids: the number of sites of every level's lattice.
    pub fn id_bound(&self) -> u64 {
        let last = self.fine.last().unwrap_or(&self.lat);
        last.offset + last.sites()
    }

    /// The count cap of the initial split ([`crate::scene::Balance::count_cap`]).
    pub fn count_cap(&self) -> Option<f64> {
        self.scene.balance.count_cap()
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
    /// `(id, centre, level, h)` (h: the smoothing length, set only in a refined scene). A
    /// body's coarse sites come first, then those of each refinement
    /// level (`crate::scene::refine`: the fine sites subdivide the cells of the coarse sites
    /// whose centres lie in a region of their level).
    fn each_claimed(&self, j: usize, min: &[f64], max: &[f64], mut f: impl FnMut(u64, Vector<D>, u16, f64)) {
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
                if self.fine.is_empty() {
                    self.lat.for_each_in(&lo, &hi, |_, id, x| {
                        if b.contains(x.as_slice()) {
                            f(id, x, 0, 0.0)
                        }
                    });
                    return;
                }
                let region_at = |x: &[f64]| crate::scene::refine::region_at(self.scene, &b.name, x);
                let h0 = self.sizes.as_ref().expect("a refined scene has sizes").h[0];
                self.lat.for_each_in(&lo, &hi, |_, id, x| {
                    if b.contains(x.as_slice()) && region_at(x.as_slice()).is_none() {
                        f(id, x, 0, h0)
                    }
                });
                self.each_fine(&b.name, &lo, &hi, None, |_, x| b.contains(x.as_slice()), &mut f);
            }
            Claim::Wall { inner, outline, .. } => {
                let h_scene = self.sizes.as_ref().map_or(0.0, |z| z.h[0]);
                // only dummy walls are refined (a repulsive wall's force has the range dx), and
                // not polygons (a region that would is refused)
                let refined = !self.fine.is_empty() && src.kind == Kind::Dummy && outline.is_none();
                let in_outline = |x: &[f64]| outline.as_ref().is_none_or(|shell| shell.claims(x));
                let name = &self.scene.walls[src.index as usize].name;
                let outer: Vec<(u64, u64)> = (0..D)
                    .map(|a| self.lat.range(a, src.min[a], src.max[a]))
                    .collect();
                // the wall claims the coarse site of lattice index `idx`
                let claims = |idx: &[u64]| {
                    idx.iter().zip(&outer).all(|(i, (l, h))| i >= l && i < h)
                        && !inner
                            .as_ref()
                            .is_some_and(|r| idx.iter().zip(r).all(|(i, (l, h))| i >= l && i < h))
                };
                let region_at = |x: &[f64]| {
                    refined
                        .then(|| crate::scene::refine::region_at(self.scene, name, x))
                        .flatten()
                };
                // the inner box's rows are jumped over, not visited
                let hole = inner.as_deref();
                self.lat.for_each_in_except(&lo, &hi, hole, |idx, id, x| {
                    if claims(idx) && in_outline(x.as_slice()) && region_at(x.as_slice()).is_none() {
                        f(id, x, 0, h_scene)
                    }
                });
                if refined {
                    self.each_fine(name, &lo, &hi, hole, |parent, _| claims(parent), &mut f);
                }
            }
        }
    }

    /// Visit the sites of the refinement levels of body `name` whose centres lie in
    /// `[lo, hi)`: a site of level ℓ is visited if the coarse site whose cell it subdivides
    /// (lattice index `parent`) lies in a region of level ℓ refining the body and `keep(parent,
    /// centre)` holds. Sites whose parent lies in `hole` (coarse index ranges) are not visited.
    fn each_fine(
        &self,
        name: &str,
        lo: &[f64],
        hi: &[f64],
        hole: Option<&[(u64, u64)]>,
        keep: impl Fn(&[u64], &Vector<D>) -> bool,
        f: &mut impl FnMut(u64, Vector<D>, u16, f64),
    ) {
        let sizes = self.sizes.as_ref().expect("a refined scene has sizes");
        for (lat, level) in self.fine.iter().zip(1u32..) {
            // a fine site's parent is idx >> level: the hole at this level
            let fine_hole: Option<Vec<(u64, u64)>> =
                hole.map(|r| r.iter().map(|(l, h)| (l << level, h << level)).collect());
            lat.for_each_in_except(lo, hi, fine_hole.as_deref(), |idx, id, x| {
                let parent: [u64; D] = std::array::from_fn(|a| idx[a] >> level);
                let centre: [f64; D] =
                    std::array::from_fn(|a| self.lat.origin[a] + (parent[a] as f64 + 0.5) * self.lat.dx);
                let Some(r) =
                    crate::scene::refine::region_at(self.scene, name, &centre).filter(|r| r.level == level)
                else {
                    return;
                };
                if keep(&parent, &x) {
                    let dom = crate::scene::refine::Bounds::of(self.scene);
                    let h = r.smoothing_length(x.as_slice(), &dom, sizes.h[0], sizes.h[level as usize]);
                    f(id, x, level as u16, h)
                }
            });
        }
    }

    /// Visit every site of the layers `layers` along x: `(id, centre, kind)`, source by
    /// source (the order matters only to sums that are order-independent).
    pub fn for_each(&self, layers: std::ops::Range<u64>, mut f: impl FnMut(u64, &Vector<D>, Kind)) {
        let (min, max) = self.layer_box(layers);
        for (j, src) in self.sources.iter().enumerate() {
            self.each_claimed(j, &min, &max, |id, x, _, _| f(id, &x, src.kind));
        }
    }

    /// Visit every site of the layers `layers` along x with its load in the initial split:
    /// `(id, centre, load)`: with `balance.load = "pairs"` the site's expected pairs
    /// ([`crate::kernel::sizes::Sizes::site_load`]), else 1.
    pub fn for_each_load(&self, layers: std::ops::Range<u64>, mut f: impl FnMut(u64, &Vector<D>, u64)) {
        let sizes = self.load_sizes.as_ref();
        let (min, max) = self.layer_box(layers);
        for (j, src) in self.sources.iter().enumerate() {
            self.each_claimed(j, &min, &max, |id, x, level, h| {
                f(
                    id,
                    &x,
                    // a site of a scene of one size has no h of its own: the scene's
                    sizes.map_or(1, |z| {
                        particle_load::<D>(z, src.kind, level, if h > 0.0 { h } else { z.h[0] })
                    }),
                )
            });
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

    /// The record of the site `id` at `x` of refinement level `level` and smoothing length `h`
    /// claimed by source `j`.
    fn record(&self, j: usize, id: u64, x: Vector<D>, (level, h): (u16, f64)) -> Result<Record<D>> {
        let src = &self.sources[j];
        let dx = match level {
            0 => self.lat.dx,
            l => self.fine[l as usize - 1].dx,
        };
        let vol = dx.powi(D as i32);
        let mut r = match &src.claim {
            Claim::Body {
                e,
                v,
                hydrostatic,
                top,
                over,
                gap,
                fields,
                ..
            } => {
                let mut rho = match hydrostatic {
                    Some(g) => {
                        let gmag = g.norm();
                        let depth = x.dot(g) / gmag - top;
                        let load = overburden(&x, &(-g / gmag), depth.max(0.0), over, *gap);
                        e.density(e.rho0() * gmag * depth.max(0.0) + gmag * load)
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
        };
        r.level = level;
        r.h = h;
        Ok(r)
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
            self.each_claimed(j, min, max, |id, x, level, h| {
                if !keep(id, &x) {
                    return;
                }
                match self.record(j, id, x, (level, h)) {
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

    /// The layers of part `k`.
    fn part(&self, k: usize) -> std::ops::Range<u64> {
        let a = self.layers.start + k as u64 * self.step();
        a..(a + self.step()).min(self.layers.end)
    }
}

impl<const D: usize> Cloud<D> for LayerShare<'_, '_, D> {
    fn parts(&self) -> usize {
        (self.layers.end - self.layers.start).div_ceil(self.step()) as usize
    }

    fn visit(&self, k: usize, mut f: impl FnMut(&Vector<D>, u64, bool)) {
        self.src
            .for_each(self.part(k), |id, x, kind| f(x, id, kind.is_fluid()));
    }

    fn visit_loads(&self, k: usize, mut f: impl FnMut(&Vector<D>, u64, u64)) {
        self.src.for_each_load(self.part(k), |id, x, w| f(x, id, w));
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
                    crate::scene::lattice::body_sites::<D>(&s)[0].builds,
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

    /// A tank (a dummy container asking 6 layers) with a dummy block in the water, in 2D and
    /// 3D, for kernels whose support is 2.4, 2.6, 3 and 3.46 spacings.
    fn tank(d: usize, kernel: &str, h_over_dx: f64) -> Scene {
        let v = |x: f64| {
            vec![x; d]
                .iter()
                .map(f64::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        };
        let (blo, bhi) = (vec!["0.5"; d].join(", "), vec!["0.95"; d].join(", "));
        scene(&format!(
            r#"
dimension = {d}
[domain]
min = [{dmin}]
max = [{dmax}]
[discretisation]
dx = 0.05
h_over_dx = {h_over_dx}
kernel = "{kernel}"
[[material]]
name = "w"
rho0 = 1000.0
c0 = 10.0
[[fluid]]
name = "water"
material = "w"
min = [{fmin}]
max = [{water}]
[[wall]]
name = "tank"
shape = "container"
min = [{fmin}]
max = [{fmax}]
layers = 6
[[wall]]
name = "pillar"
shape = "block"
min = [{blo}]
max = [{bhi}]
[time]
t_end = 0.01
"#,
            dmin = v(-0.5),
            dmax = v(2.0),
            fmin = v(0.0),
            fmax = v(1.5),
            water = v(0.4),
        ))
    }

    /// Dummy walls are built where fluid can reach them and nowhere else: against a brute-force
    /// walk over every site of the walls' boxes, no site within the support κh of the water's
    /// side is missing (the container's inner box, the pillar's outside), no built site lies
    /// more than κh + dx/2 beyond it along an axis, and `hsph check`'s count equals the build.
    #[test]
    fn dummy_walls_are_built_within_reach_of_the_fluid_only() {
        for d in [2, 3] {
            for (kernel, h_over_dx) in [
                ("cubic_spline", 1.2),
                ("wendland_c2", 1.3),
                ("quintic_spline", 1.0),
                ("cubic_spline", 3f64.sqrt()),
            ] {
                let s = tank(d, kernel, h_over_dx);
                crate::with_dim!(d, D => {
                    walls_against_oracle::<D>(&s);
                    Ok::<_, Error>(())
                })
                .unwrap();
            }
        }
    }

    /// A wall site's (Euclidean distance to the water's side, largest distance along an axis)
    /// in m, or `None` for a site on the water's side.
    type Side<'a> = &'a dyn Fn(&[f64]) -> Option<(f64, f64)>;

    fn walls_against_oracle<const D: usize>(s: &Scene) {
        let (dx, support) = (s.discretisation.dx, s.discretisation.support());
        let p = SiteSource::<D>::new(s).unwrap().build(None, |_, _| true).unwrap();
        let built: std::collections::HashSet<u64> = p.id[..p.n_owned].iter().copied().collect();
        assert_eq!(
            crate::scene::lattice::count_particles::<D>(s),
            p.n_owned as u64,
            "count against build"
        );
        let lat = Lattice::<D>::new(s);
        let (tank, pillar) = (&s.walls[0], &s.walls[1]);
        let asked = tank.layers as f64 * dx;
        let outer_lo: Vec<f64> = tank.min.iter().map(|x| x - asked).collect();
        let outer_hi: Vec<f64> = tank.max.iter().map(|x| x + asked).collect();
        let rows = crate::scene::rows_reaching(support, dx);
        assert!(
            rows < tank.layers && (rows as f64 - 0.5) * dx < support && (rows as f64 + 0.5) * dx >= support
        );
        let (mut kept, mut dropped) = (0, 0);
        let mut walk = |lo: &[f64], hi: &[f64], side: Side| {
            lat.for_each_in(lo, hi, |_, id, x| {
                // (Euclidean distance to the water's side, largest distance along an axis)
                let Some((dist, axis)) = side(x.as_slice()) else {
                    return;
                };
                if dist < support {
                    assert!(
                        built.contains(&id),
                        "a site {dist} m from the water is missing at {x:?}"
                    );
                }
                if built.contains(&id) {
                    assert!(
                        axis < support + 0.5 * dx + 1e-12,
                        "a site {axis} m deep is built at {x:?}"
                    );
                    kept += 1;
                } else {
                    dropped += 1;
                }
            })
        };
        // the container's sites: outside the inner box, inside the asked outer box
        walk(&outer_lo, &outer_hi, &|x| {
            let out: Vec<f64> = (0..D)
                .map(|a| (tank.min[a] - x[a]).max(x[a] - tank.max[a]).max(0.0))
                .collect();
            let axis = out.iter().copied().fold(0.0, f64::max);
            (axis > 0.0).then(|| (out.iter().map(|o| o * o).sum::<f64>().sqrt(), axis))
        });
        // the pillar's sites: depth below its nearest face
        walk(&pillar.min, &pillar.max, &|x| {
            let depth = (0..D)
                .map(|a| (x[a] - pillar.min[a]).min(pillar.max[a] - x[a]))
                .fold(f64::INFINITY, f64::min);
            Some((depth, depth))
        });
        assert!(kept > 0 && dropped > 0, "{kept} kept, {dropped} dropped");
    }
}
