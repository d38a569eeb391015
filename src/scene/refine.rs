//! Refinement regions (`[[refine]]`): where bodies are built with particles of a finer spacing
//! dx / 2^level (docs/refinement.md §1).
//!
//! A lattice site of the scene's spacing (a *coarse* site) whose centre lies in a region of
//! level ℓ is not built; the 2^(ℓ·D) sites of the level-ℓ lattice that subdivide its cell are
//! built instead, each kept if it lies in the body. Regions therefore replace whole coarse
//! cells, so the fine particles tile exactly the cells the coarse ones leave, whatever the
//! region's shape.

use super::checks::err;
use super::lattice::{container_outer, Lattice};
use super::walls::WallShape;
use super::{BodyShape, FluidBody, Scene};
use crate::error::Result;
use serde::{Deserialize, Serialize};

/// Finest level a region may ask for (spacing dx / 8).
pub const MAX_LEVEL: u32 = 3;

/// The levels a region may take, as the messages that refuse another one name them.
pub const LEVELS: &str = "1, 2 or 3 (particles of spacing dx/2, dx/4 or dx/8)";

super::shape::shaped_table! {
/// One refinement region: the shape keys of a body (`block`, `sphere`, `cylinder`, `polygon`
/// or `mesh`, a mesh without a body's `fill` and `layers`), its level and the bodies it
/// refines.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Refine {
    ..shape_keys,
    /// Level ℓ ∈ 1..=3: particles of spacing dx / 2^ℓ.
    pub level: u32,
    /// Names of the fluid and solid bodies and dummy walls the region refines (empty: every
    /// one of them). A fluid refined beside a wall needs the wall refined too: a dummy wall's
    /// extrapolation mirrors the fluid's spacing (docs/refinement.md §3).
    #[serde(
        default,
        skip_serializing_if = "Vec::is_empty",
        deserialize_with = "named_bodies"
    )]
    pub bodies: Vec<String>,
    /// Width (m) of the band inside the region's boundary over which the particles' smoothing
    /// length falls from the scene's h to the level's (default: one kernel support of the
    /// scene's h, κh). h stays continuous where the spacing jumps (docs/refinement.md §1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transition: Option<f64>,
    /// The smoothing length of the region's particles: `scene` (default: the scene's h, so
    /// the region holds more, lighter particles per kernel and h never jumps) or `level` (the
    /// level's h, (h/dx)·dx/2^level, reached over `transition`: finer features resolved at a
    /// smaller time step, with the spurious currents a varying h brings where the pressure is
    /// high; docs/refinement.md §1).
    #[serde(default)]
    pub smoothing_length: RegionH,
    /// Fluid particles that enter the region during the run split to its level (2^D children
    /// on the finer lattice's pattern, `docs/splitting.md` §2) once they lie a band of their
    /// own spacing inside it. Off by default: the particles keep the size they were built with.
    #[serde(default, skip_serializing_if = "is_false")]
    pub adapt: bool,
}
}

/// `bodies` as written: a list of at least one name. An empty list would read as "every
/// body" (the default when the key is left out), the opposite of what it says.
fn named_bodies<'de, De: serde::Deserializer<'de>>(d: De) -> std::result::Result<Vec<String>, De::Error> {
    let names = Vec::<String>::deserialize(d)?;
    if names.is_empty() {
        return Err(serde::de::Error::custom(
            "an empty list names no body: leave `bodies` out to refine every fluid, solid and \
             dummy wall, or name them, e.g. bodies = [\"water\"]",
        ));
    }
    Ok(names)
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// Which smoothing length a refinement region's particles take.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum RegionH {
    /// The scene's h.
    #[default]
    Scene,
    /// The level's h.
    Level,
}

impl Refine {
    /// True if the point `x` (m) lies in the region.
    pub fn contains(&self, x: &[f64]) -> bool {
        self.keys().contains_point(x)
    }

    /// True if the region refines the body named `name`.
    pub fn applies_to(&self, name: &str) -> bool {
        self.bodies.is_empty() || self.bodies.iter().any(|b| b == name)
    }
}

/// The domain as a region sees it: its bounds (m) and the period (m) of each periodic axis.
#[derive(Debug, Clone, Copy)]
pub struct Bounds<'s> {
    /// `domain.min`.
    pub min: &'s [f64],
    /// `domain.max`.
    pub max: &'s [f64],
    /// The length of each periodic axis, `None` for a bounded one.
    pub period: [Option<f64>; 3],
}

impl<'s> Bounds<'s> {
    /// The bounds of `s`'s domain.
    pub fn of(s: &'s Scene) -> Self {
        let d = &s.domain;
        let mut period = [None; 3];
        for (a, p) in period.iter_mut().enumerate().take(d.min.len()) {
            if d.periodic.get(a).copied().unwrap_or(false) {
                *p = Some(d.max[a] - d.min[a]);
            }
        }
        Bounds {
            min: &d.min,
            max: &d.max,
            period,
        }
    }
}

/// The region refining the coarse site at `x` of body `name`, if any (validation refuses two
/// regions of different levels that could both hold a site; of several of one level the
/// first).
pub fn region_at<'s>(s: &'s Scene, name: &str, x: &[f64]) -> Option<&'s Refine> {
    s.refine.iter().find(|r| r.applies_to(name) && r.contains(x))
}

/// Per fluid body of `s` (in `s.fluids`' order): true if an adaptive region refines it, so its
/// particles split, merge and take their level's h where they are.
pub fn adaptive_bodies(s: &Scene) -> Vec<bool> {
    s.fluids
        .iter()
        .map(|f| s.refine.iter().any(|r| r.adapt && r.applies_to(&f.name)))
        .collect()
}

/// Smoothing length (m) of a particle of level `level` of body `name` at `x`, where the scene's
/// levels have smoothing lengths `h` (m; `h[0]` the scene's): that of the region of its level
/// that holds it ([`Refine::smoothing_length`]: the scene's h, or its level's ramped over the
/// transition band), else the scene's. The rule for particles that change size (children,
/// merged particles, and those of an adaptive body as they move; docs/splitting.md §2).
pub fn level_h(s: &Scene, b: &Bounds, name: &str, level: u16, x: &[f64], h: &[f64]) -> f64 {
    region_at(s, name, x)
        .filter(|g| level > 0 && g.level == u32::from(level))
        .map_or(h[0], |g| g.smoothing_length(x, b, h[0], h[level as usize]))
}

impl Refine {
    /// Neighbour-list length of a particle of this region's level in units of a coarse
    /// particle's: 2^(ℓD) with the scene's h (its support spans 2^ℓ of its own spacings per
    /// dx along each axis), 1 with its level's h.
    pub fn list_factor(&self, d: usize) -> f64 {
        match self.smoothing_length {
            RegionH::Scene => f64::from(1u32 << (d as u32 * self.level)),
            _ => 1.0,
        }
    }

    /// True if the block's lower (`upper = false`) or upper face along axis `a` is no
    /// interface with coarser particles: on a bounded axis a face at or beyond the domain's
    /// bound (no coarse particle lies beyond it); on a periodic axis both faces of a region
    /// that spans the whole period (a band along a channel), and no face of one that does not
    /// (beyond its face at the bound the domain wraps to coarse particles).
    fn open_face(&self, a: usize, upper: bool, b: &Bounds) -> bool {
        let (at_lo, at_hi) = (self.min[a] <= b.min[a], self.max[a] >= b.max[a]);
        match b.period[a] {
            Some(_) => at_lo && at_hi,
            None if upper => at_hi,
            None => at_lo,
        }
    }

    /// Distance (m) from `x` inside the region to its boundary (≤ 0 outside); a block's faces
    /// that are no interface ([`Refine::open_face`]) are not counted.
    ///
    /// Exact below `cap` (m, ≥ 0); at or beyond it the value is some depth ≥ `cap`: a mesh
    /// region's is min(depth, cap) (outside, −min(distance, cap)), searched only within `cap`
    /// of `x` ([`Mesh::distance_capped`](super::mesh::Mesh::distance_capped)), so a site deep
    /// inside a large mesh costs a few cells. Every caller compares the depth with a band of at
    /// most `cap` (a split's own spacing, the transition; `f64::INFINITY` for the depth
    /// itself), so its comparison is exact. Every face of a mesh counts, even one on the
    /// domain's bound (as every edge of a polygon).
    pub fn depth(&self, x: &[f64], b: &Bounds, cap: f64) -> f64 {
        let d = x.len();
        let face = |a: usize| {
            let lo = if self.open_face(a, false, b) {
                f64::INFINITY
            } else {
                x[a] - self.min[a]
            };
            let hi = if self.open_face(a, true, b) {
                f64::INFINITY
            } else {
                self.max[a] - x[a]
            };
            lo.min(hi)
        };
        let to_box = (0..d).map(face).fold(f64::INFINITY, f64::min);
        match self.shape {
            BodyShape::Block => to_box,
            BodyShape::Mesh => match self.mesh.as_deref() {
                Some(m) if m.contains(x) => m.distance_capped(x, cap),
                Some(m) => -m.distance_capped(x, cap),
                // the loader reads every mesh region's file: unreachable after load
                None => to_box,
            },
            BodyShape::Sphere => {
                let r2: f64 = (0..d).map(|a| (x[a] - self.centre[a]).powi(2)).sum();
                self.radius - r2.sqrt()
            }
            BodyShape::Cylinder => {
                let axis = self.axis.unwrap_or(2);
                let r2: f64 = (0..d)
                    .filter(|&a| a != axis)
                    .map(|a| (x[a] - self.centre[a]).powi(2))
                    .sum();
                (self.radius - r2.sqrt()).min(0.5 * self.length - (x[axis] - self.centre[axis]).abs())
            }
            BodyShape::Polygon => {
                let r = super::polygon::distance(&self.vertices, x[0], x[1]);
                match super::polygon::contains(&self.vertices, x[0], x[1]) {
                    true => r,
                    false => -r,
                }
            }
        }
    }

    /// Distance (m) from `x` outside the region to it (0 inside); on a periodic axis the
    /// nearest image counts. A block's faces that are no interface ([`Refine::open_face`]) are
    /// not counted, as in [`Refine::depth`]: the region runs on past them.
    ///
    /// Exact below `cap` (m, ≥ 0), some distance ≥ `cap` beyond it (a mesh region's is
    /// min(distance, cap), searched only within `cap` of `x`), as [`Refine::depth`]: callers
    /// compare it with a band of at most `cap`. A mesh's surface, like a polygon's outline, is
    /// not wrapped round a periodic axis: its distance is to the surface as placed.
    pub fn clearance(&self, x: &[f64], b: &Bounds, cap: f64) -> f64 {
        let d = x.len();
        // the offset from `c` along axis a, to the nearest image on a periodic axis
        let off = |a: usize, c: f64| {
            let r = x[a] - c;
            match b.period[a] {
                Some(l) => r - l * (r / l).round(),
                None => r,
            }
        };
        let pos = |v: f64| v.max(0.0);
        if let (BodyShape::Mesh, Some(m)) = (self.shape, self.mesh.as_deref()) {
            // a mesh's surface is not wrapped round a periodic axis
            return match m.contains(x) {
                true => 0.0,
                false => m.distance_capped(x, cap),
            };
        }
        match self.shape {
            // a mesh region without its mesh (unreachable after load) is its box
            BodyShape::Block | BodyShape::Mesh => (0..d)
                .map(|a| {
                    let c = 0.5 * (self.min[a] + self.max[a]);
                    let half = 0.5 * (self.max[a] - self.min[a]);
                    let r = off(a, c);
                    // a face that is no interface: no distance on that side
                    let lo = if self.open_face(a, false, b) {
                        0.0
                    } else {
                        pos(-r - half)
                    };
                    let hi = if self.open_face(a, true, b) {
                        0.0
                    } else {
                        pos(r - half)
                    };
                    lo.max(hi).powi(2)
                })
                .sum::<f64>()
                .sqrt(),
            BodyShape::Sphere => {
                let r2: f64 = (0..d).map(|a| off(a, self.centre[a]).powi(2)).sum();
                pos(r2.sqrt() - self.radius)
            }
            BodyShape::Cylinder => {
                let axis = self.axis.unwrap_or(2);
                let r2: f64 = (0..d)
                    .filter(|&a| a != axis)
                    .map(|a| off(a, self.centre[a]).powi(2))
                    .sum();
                let radial = pos(r2.sqrt() - self.radius);
                let along = pos(off(axis, self.centre[axis]).abs() - 0.5 * self.length);
                radial.hypot(along)
            }
            // a polygon's outline is not wrapped round a periodic axis
            BodyShape::Polygon => match super::polygon::contains(&self.vertices, x[0], x[1]) {
                true => 0.0,
                false => super::polygon::distance(&self.vertices, x[0], x[1]),
            },
        }
    }

    /// Width (m) of the transition band over which h rises to the scene's (0 if unset).
    pub fn band(&self) -> f64 {
        self.transition.unwrap_or(0.0)
    }

    /// Smoothing length (m) of a particle of this region's level at `x`: `h_fine` at a depth
    /// of at least the transition band, rising linearly to `h_scene` at the boundary (the
    /// region's faces that are interfaces, [`Refine::depth`], capped at the band).
    pub fn smoothing_length(&self, x: &[f64], b: &Bounds, h_scene: f64, h_fine: f64) -> f64 {
        if self.smoothing_length == RegionH::Scene {
            return h_scene;
        }
        let band = self.band();
        if band <= 0.0 {
            return h_fine;
        }
        let t = (1.0 - self.depth(x, b, band) / band).clamp(0.0, 1.0);
        h_fine + (h_scene - h_fine) * t
    }
}

/// A particle that lists more neighbours than this is worth a warning (m⁰; a coarse
/// particle lists ~21 in 2D and ~74 in 3D).
const MANY_NEIGHBOURS: f64 = 1000.0;

/// Warnings for regions whose particles keep the scene's h at a level where each then lists
/// more than [`MANY_NEIGHBOURS`] neighbours (2^(ℓD) times a coarse particle's): the lists'
/// memory and the force loops' time grow as much.
pub fn list_warnings(s: &Scene) -> Vec<String> {
    let d = s.dimension;
    let base = s.discretisation.lattice_neighbours(d);
    (s.refine.iter().enumerate())
        .filter(|(_, r)| base * r.list_factor(d) > MANY_NEIGHBOURS)
        .map(|(k, r)| {
            format!(
                "refine[{k}] keeps the scene's h (smoothing_length = \"scene\") at level {}: each of its \
                 particles lists about {:.0} neighbours, {} times a coarse particle's {:.0}, and the run's \
                 memory and time per particle-step grow as much; smoothing_length = \"level\" gives them \
                 their level's h and about {:.0} neighbours (docs/refinement.md §1)",
                r.level,
                base * r.list_factor(d),
                r.list_factor(d),
                base,
                base
            )
        })
        .collect()
}

/// Warnings for regions that give dummy walls their level's h and no fluid its own: a fluid
/// particle beside them keeps the scene's h, and a pair of the mean h (the default
/// `discretisation.pair_h`) sees the wall over a support shrunk toward the wall's h, so the wall
/// holds the fluid back less (docs/pressure.md §2e: the run-up's load 14–19 % low beside the
/// Lobovsky tank's walls refined to level 2, half that at level 1).
pub fn wall_h_warnings(s: &Scene) -> Vec<String> {
    if !s.discretisation.pair_h.is_mean() {
        return Vec::new();
    }
    (s.refine.iter().enumerate())
        .filter(|(_, r)| r.smoothing_length == RegionH::Level && r.level > 0)
        .filter(|(_, r)| !s.fluids.iter().any(|f| r.applies_to(&f.name)))
        .filter_map(|(k, r)| {
            let wall = s.walls.iter().find(|w| r.applies_to(&w.name))?;
            Some(format!(
                "refine[{k}] gives wall `{}` its level's h (smoothing_length = \"level\") and no fluid \
                 its own: the fluid beside it keeps a larger h, and a pair of the mean h sees the wall \
                 over a support shrunk toward the wall's, so the wall holds the fluid back less (the \
                 run-up's load at the Lobovsky tank's walls refined to level 2 read 14-19 % low, \
                 docs/pressure.md §2e); give the walls the scene's h (smoothing_length = \"scene\", \
                 which read as unrefined at a tenth of the time) or set discretisation.pair_h = \"max\"",
                wall.name
            ))
        })
        .collect()
}

/// Transition width, in kernel supports, that kept the adaptive solitary wave's still level
/// (docs/validation.md §7); [`level_h_warnings`] advises it to narrower bands.
const STILL_BAND_SUPPORTS: f64 = 4.0;

/// Warnings for regions that give a fluid built under hydrostatic pressure (`hydrostatic =
/// true` with a body force) its level's h: where h varies across the pressure gradient, the mean-h
/// pair kernel's residual times the pressure is a force with a curl that no pressure field
/// balances, and it drives a current (docs/refinement.md §1).
pub fn level_h_warnings(s: &Scene) -> Vec<String> {
    if s.physics.body_force.iter().all(|&g| g == 0.0) {
        return Vec::new();
    }
    let support = s.discretisation.support();
    (s.refine.iter().enumerate())
        .filter(|(_, r)| r.smoothing_length == RegionH::Level)
        .filter_map(|(k, r)| {
            let fluid = s.fluids.iter().find(|f| f.hydrostatic && r.applies_to(&f.name))?;
            let (band, wide) = (r.band(), STILL_BAND_SUPPORTS * support);
            let advice = if band < wide {
                format!(
                    "for water that should stay still use smoothing_length = \"scene\" or a wider \
                     transition (four supports, {wide:.3} m, kept the still level of the adaptive \
                     solitary wave, docs/validation.md §7)"
                )
            } else {
                "a transition of four supports kept the still level of the adaptive solitary wave \
                 but left a circulation of 6-10 cm/s (4-7 % of sqrt(gH)) at its region's face that \
                 cost the crest 2.8 % half a metre from it; twelve supports cost it 1.8 % and took \
                 1.5 times as long (docs/validation.md §7)"
                    .to_string()
            };
            Some(format!(
                "refine[{k}] gives fluid `{}` its level's h (smoothing_length = \"level\") under \
                 hydrostatic pressure over a transition of {band:.3} m ({:.1} supports): where h varies \
                 across the pressure gradient a spurious current starts (measured in the reference \
                 still tank with a level-1 box, docs/refinement.md §1, not in this scene: 10 % of \
                 sqrt(gH) after 1 s with a transition of one support, 2.8 % with two, 0.15 % with the \
                 scene's h); {advice}",
                fluid.name,
                band / support,
            ))
        })
        .collect()
}

/// The most lattice sites [`region_warnings`] visits per region; a larger region is
/// assumed to hold some (no warning rather than a slow check).
const EMPTY_REGION_SITES: u64 = 1 << 24;

/// Warnings for regions that do not do what they say, so that the run is silently the uniform
/// one or slower than it needs: an adaptive region that no point lies dx deep in (nothing
/// that enters splits), a level-h region whose transition is wider than the region is deep
/// (its h never reaches the level's, which still sets dt), no site of the scene's lattice
/// ([`Lattice`]) in the region (it is smaller than a cell or between sites), or — for a region
/// that does not adapt, whose particles cannot arrive later — none of the fluids and solids it
/// refines has a site in it and no dummy wall it refines reaches it.
pub fn region_warnings<const D: usize>(s: &Scene) -> Vec<String> {
    let lat = Lattice::<D>::new(s);
    let dx = lat.dx;
    let mut out = Vec::new();
    let bounds = Bounds::of(s);
    for (k, r) in s.refine.iter().enumerate() {
        // a particle splits once it lies its own spacing inside the region (sim/adapt.rs):
        // a scene-spacing particle needs a depth of dx, which the centre has if any point has
        let centre: Vec<f64> = match r.shape {
            BodyShape::Block => (0..D).map(|a| 0.5 * (r.min[a] + r.max[a])).collect(),
            _ => r.centre.clone(),
        };
        // both warnings below compare the depth with dx or the band: exact below the larger
        let cap = dx.max(r.band());
        let deepest = deepest::<D>(r, &centre, &lat, &bounds, cap);
        if r.adapt && deepest < dx {
            out.push(format!(
                "refine[{k}] adapts, but no point of it lies deeper than {deepest:.4e} m inside its \
                 faces, and a particle of the scene's spacing splits only once it lies dx = {dx} m \
                 inside: nothing that enters it splits (what the set-up refines leaves and merges); \
                 make it at least 2·dx wide on every axis"
            ));
        }
        let band = r.band();
        if r.smoothing_length == RegionH::Scene && band != s.discretisation.support() {
            // the check fills the default (one support) whatever the mode, so only a width
            // the scene set differs from it
            out.push(format!(
                "refine[{k}].transition = {band:.4e} m has no effect: with smoothing_length = \"scene\" \
                 (the default) every particle keeps the scene's h, so there is no h to ramp; set \
                 smoothing_length = \"level\" for an h that falls to the level's over the \
                 transition, or leave `transition` out"
            ));
        }
        if r.smoothing_length == RegionH::Level && band > deepest {
            out.push(format!(
                "refine[{k}].transition = {band:.4e} m is wider than the region is deep ({deepest:.4e} m \
                 at most): its h ramps from the scene's without reaching the level's, yet the time \
                 step is the level's h's, so the run takes smaller steps than its particles need; \
                 narrow the transition below {deepest:.4e} m or widen the region"
            ));
        }
        let sites: u64 = (0..D)
            .map(|a| {
                let (lo, hi) = lat.range(a, r.min[a], r.max[a]);
                hi.saturating_sub(lo)
            })
            .product();
        if sites > EMPTY_REGION_SITES {
            continue;
        }
        let bodies: Vec<&FluidBody> = (s.fluids.iter().chain(&s.solids))
            .filter(|b| r.applies_to(&b.name))
            .collect();
        let (mut any_site, mut body_site) = (false, false);
        lat.for_each_in(&r.min, &r.max, |_, _, x| {
            if body_site || !r.contains(x.as_slice()) {
                return;
            }
            any_site = true;
            body_site = bodies
                .iter()
                .any(|b| (0..D).all(|a| x[a] >= b.min[a] && x[a] < b.max[a]) && b.contains(x.as_slice()));
        });
        // a dummy wall's sites lie in its box (a block) or between its box and the box of
        // its layers (a container)
        let on_wall = s.walls.iter().any(|w| {
            let (lo, hi) = match w.shape {
                WallShape::Block | WallShape::Polygon | WallShape::Mesh => (w.min.clone(), w.max.clone()),
                WallShape::Container => container_outer(s, w),
            };
            let meets = (0..D).all(|a| lo[a] < r.max[a] && r.min[a] < hi[a]);
            let inside = (0..D).all(|a| w.min[a] <= r.min[a] && r.max[a] <= w.max[a]);
            w.method.refinable()
                && r.applies_to(&w.name)
                && meets
                && !(w.shape == WallShape::Container && inside)
        });
        if !any_site {
            out.push(format!(
                "refine[{k}] holds no site of the scene's lattice (sites at domain.min + (i + ½)·dx, \
                 dx = {dx} m): it refines nothing and the run is the uniform one; make the region \
                 at least one dx wide on every axis"
            ));
        } else if !body_site && !on_wall && !r.adapt {
            out.push(format!(
                "refine[{k}] holds no site of the bodies it refines ({}) and does not adapt: it \
                 refines nothing and the run is the uniform one; move the region onto a body, \
                 name the bodies it should refine in `bodies`, or set adapt = true for fluid \
                 that arrives later",
                if r.bodies.is_empty() {
                    "all bodies".to_string()
                } else {
                    r.bodies.join(", ")
                }
            ));
        }
    }
    out
}

/// The finest level whose particles take their level's h (0: every particle has the scene's).
pub fn finest_h(s: &Scene) -> u32 {
    (s.refine.iter().filter(|r| r.smoothing_length == RegionH::Level))
        .map(|r| r.level)
        .max()
        .unwrap_or(0)
}

/// The particle sizes of a scene with refinement regions (`None` without).
pub fn sizes(s: &Scene) -> Option<crate::kernel::sizes::Sizes> {
    let d = &s.discretisation;
    (!s.refine.is_empty()).then(|| {
        crate::kernel::sizes::Sizes::new(d.kernel, d.dx, d.h_over_dx, finest_h(s) as u16)
            .with_pair_h(d.pair_h)
    })
}

/// The sizes the initial split weighs sites with under `balance.load = "pairs"` (a site's
/// expected pairs, [`crate::kernel::sizes::Sizes::site_load`]): the scene's levels, or its one
/// size; `None` when the split counts particles.
pub fn load_sizes(s: &Scene) -> Option<crate::kernel::sizes::Sizes> {
    let d = &s.discretisation;
    (s.balance.load == crate::scene::LoadKind::Pairs)
        .then(|| sizes(s).unwrap_or_else(|| crate::kernel::sizes::Sizes::new(d.kernel, d.dx, d.h_over_dx, 0)))
}

/// The most particles the adaptive regions of `s` (`[[refine]] adapt`) can add to its set-up,
/// for the memory estimate: each region's box, widened by the merge band dx/2^(ℓ−1) on every
/// side (fine particles wait there to merge) and cut to the domain, filled with fluid of its
/// level ℓ where the set-up put the scene's spacing, that is 2^(Dℓ) − 1 more particles per
/// volume dx^D, over at most the volume of the boxes of the fluids it refines. An upper bound:
/// the set-up's own fine particles in the region are counted again.
pub fn adaptive_growth(s: &Scene) -> u64 {
    let d = s.dimension;
    let dx = s.discretisation.dx;
    let dom = &s.domain;
    let volume = |min: &[f64], max: &[f64]| (0..d).map(|a| (max[a] - min[a]).max(0.0)).product::<f64>();
    let mut extra = 0.0;
    for r in s.refine.iter().filter(|r| r.adapt) {
        let band = dx / f64::from(1u32 << (r.level - 1));
        let lo: Vec<f64> = (0..d).map(|a| (r.min[a] - band).max(dom.min[a])).collect();
        let hi: Vec<f64> = (0..d).map(|a| (r.max[a] + band).min(dom.max[a])).collect();
        let fluid: f64 = s
            .fluids
            .iter()
            .filter(|f| r.applies_to(&f.name))
            .map(|f| volume(&f.min, &f.max))
            .sum();
        let per_cell = f64::from((1u32 << (d as u32 * r.level)) - 1);
        extra += volume(&lo, &hi).min(fluid) / dx.powi(d as i32) * per_cell;
    }
    // a whole number of cells stays whole despite the rounding of the volumes
    (extra * (1.0 - 1e-12)).ceil() as u64
}

/// Check every region: its level, shape keys and box, inside the domain, the bodies it names
/// (fluids or solids of the scene), and no two regions of different levels for one body that
/// overlap.
pub fn validate_refine(s: &mut Scene) -> Result<()> {
    let d = s.dimension;
    let bodies = refinable(s);
    let walls: Vec<&str> = s.walls.iter().map(|w| w.name.as_str()).collect();
    for (i, r) in s.refine.iter_mut().enumerate() {
        let k = format!("refine[{i}]");
        if !(1..=MAX_LEVEL).contains(&r.level) {
            return err(
                format!("{k}.level"),
                format!("must be {LEVELS}, got {}; e.g. level = 1", r.level),
            );
        }
        super::checks::sphere_box(r.keys_mut(), &k, d)?;
        super::checks::check_vec(&mut r.min, d, &format!("{k}.min"), false)?;
        super::checks::check_vec(&mut r.max, d, &format!("{k}.max"), false)?;
        super::checks::check_box(&r.min, &r.max, &k)?;
        super::checks::body_in_domain(r.keys(), &k, &s.domain)?;
        let support = s.discretisation.support();
        match r.transition {
            None => r.transition = Some(support),
            Some(w) if !(w >= 0.0 && w.is_finite()) => {
                return err(
                    format!("{k}.transition"),
                    format!("must be a width ≥ 0 (m), got {w}; e.g. transition = {support:.4e} (one kernel support, the default)"),
                )
            }
            Some(_) => {}
        }
        for (j, b) in r.bodies.iter().enumerate() {
            if let Some(first) = r.bodies[..j].iter().position(|o| o == b) {
                return err(
                    format!("{k}.bodies[{j}]"),
                    format!("names `{b}` a second time (bodies[{first}] is `{b}`): name each body once"),
                );
            }
            if bodies.contains(b) {
                continue;
            }
            let what = if walls.contains(&b.as_str()) {
                format!(
                    "`{b}` is a wall without dummy particles (repulsive walls keep the scene's \
                     spacing, their force has the range dx; mirror walls have no particles);"
                )
            } else {
                format!("no fluid, solid or dummy wall is named `{b}`;")
            };
            return err(
                format!("{k}.bodies[{j}]"),
                format!(
                    "{what} name fluids, solids or dummy walls ({}), or leave out `bodies` for \
                     all of them",
                    bodies.join(", ")
                ),
            );
        }
        no_polygon_wall(&s.walls, r, &k, &bodies)?;
        let diagonal = (d as f64).sqrt() * s.discretisation.dx;
        if r.adapt && support < diagonal {
            return err(
                format!("{k}.adapt"),
                format!(
                    "merges particles within a cell of side dx, whose diagonal √D·dx = {diagonal:.4e} m \
                     must lie within the kernel support ({support:.4e} m): raise \
                     discretisation.h_over_dx to at least {:.3}",
                    diagonal / (s.discretisation.kernel.support_factor() * s.discretisation.dx)
                ),
            );
        }
        if r.adapt
            && !s
                .fluids
                .iter()
                .any(|f| r.bodies.is_empty() || r.bodies.contains(&f.name))
        {
            return err(
                format!("{k}.adapt"),
                "splits fluid particles, and the region refines no fluid: name a fluid in `bodies` \
                 or set adapt = false",
            );
        }
    }
    check_overlaps(s)
}

/// How deep (m) the deepest point of region `r` lies, exact below `cap` (m; [`Refine::depth`]):
/// at `centre` for a block, sphere or cylinder; for a polygon or mesh, where no point is known
/// to be the deepest, its deepest site of the scene's lattice `lat` (once a site reaches `cap`
/// the rest are not measured).
fn deepest<const D: usize>(r: &Refine, centre: &[f64], lat: &Lattice<D>, bounds: &Bounds, cap: f64) -> f64 {
    if !matches!(r.shape, BodyShape::Polygon | BodyShape::Mesh) {
        return r.depth(centre, bounds, cap);
    }
    let mut m = f64::NEG_INFINITY;
    lat.for_each_in(&r.min, &r.max, |_, _, x| {
        if m < cap {
            m = m.max(r.depth(x.as_slice(), bounds, cap));
        }
    });
    m
}

/// Region `r` (key `k`) may not reach a polygon wall it would refine: polygon walls are built at
/// the scene's spacing only (their outline is not refined). `bodies` are the refinable names.
fn no_polygon_wall(walls: &[super::WallBody], r: &Refine, k: &str, bodies: &[String]) -> Result<()> {
    let d = r.min.len();
    let polygon = walls.iter().find(|w| {
        w.shape.outlined()
            && w.method.refinable()
            && r.applies_to(&w.name)
            && (0..d).all(|a| w.min[a] < r.max[a] && r.min[a] < w.max[a])
    });
    let Some(w) = polygon else {
        return Ok(());
    };
    let others: Vec<String> = (bodies.iter())
        .filter(|b| **b != w.name)
        .map(|b| format!("\"{b}\""))
        .collect();
    err(
        format!("{k}.bodies"),
        format!(
            "the region reaches the {} wall `{}`, and polygon and mesh walls are built at the \
             scene's spacing only: list the bodies it refines without it, e.g. bodies = [{}]",
            if w.shape == WallShape::Mesh {
                "mesh"
            } else {
                "polygon"
            },
            w.name,
            others.join(", ")
        ),
    )
}

/// The names of the bodies a region may refine: fluids, solids and dummy and dynamic walls
/// (particles of the dummy kind, which the set-up refines).
fn refinable(s: &Scene) -> Vec<String> {
    let dummy = s.walls.iter().filter(|w| w.method.refinable());
    (s.fluids.iter().chain(&s.solids).map(|b| b.name.clone()))
        .chain(dummy.map(|w| w.name.clone()))
        .collect()
}

/// Two regions of different levels that refine one body may not overlap: the level of a site
/// would be ambiguous. Blocks and spheres are tested exactly; a cylinder by its box.
fn check_overlaps(s: &Scene) -> Result<()> {
    for (j, b) in s.refine.iter().enumerate() {
        for (i, a) in s.refine[..j].iter().enumerate() {
            if a.level == b.level || !overlap(a, b) {
                continue;
            }
            let shared = refinable(s)
                .into_iter()
                .find(|f| a.applies_to(f) && b.applies_to(f));
            if let Some(f) = shared {
                return err(
                    format!("refine[{j}]"),
                    format!(
                        "overlaps refine[{i}] (level {} against {}) on body `{}`: a site's level \
                         would be ambiguous; separate the regions, give them one level, or list \
                         different `bodies`",
                        b.level, a.level, f
                    ),
                );
            }
        }
    }
    Ok(())
}

/// True if two validated regions may share a point.
fn overlap(a: &Refine, b: &Refine) -> bool {
    let d = a.min.len();
    let boxes = (0..d).all(|k| a.min[k] < b.max[k] && b.min[k] < a.max[k]);
    if !boxes {
        return false;
    }
    let dist2 = |c: &[f64], r: &Refine| -> f64 {
        (0..d)
            .map(|k| (c[k] - c[k].clamp(r.min[k], r.max[k])).powi(2))
            .sum()
    };
    match (a.shape, b.shape) {
        (BodyShape::Sphere, BodyShape::Sphere) => {
            let c2: f64 = (0..d).map(|k| (a.centre[k] - b.centre[k]).powi(2)).sum();
            c2 < (a.radius + b.radius).powi(2)
        }
        (BodyShape::Sphere, BodyShape::Block) => dist2(&a.centre, b) < a.radius * a.radius,
        (BodyShape::Block, BodyShape::Sphere) => dist2(&b.centre, a) < b.radius * b.radius,
        _ => true,
    }
}

#[cfg(test)]
mod tests {
    use super::{Bounds, Refine};

    fn region(text: &str) -> Refine {
        toml::from_str(text).unwrap()
    }

    /// The drifting box of `tests/data/drift_split_2d.toml`: its 0.1 × 0.1 m region of level 1
    /// widened by the band 0.01 m on each side is 0.0144 m², 144 cells of dx² that can each
    /// hold 3 more particles; without `adapt`, none.
    #[test]
    fn the_adaptive_growth_fills_the_widened_region_at_its_level() {
        let text = include_str!("../../tests/data/drift_split_2d.toml");
        let path = std::path::Path::new("drift_split_2d.toml");
        let (s, _) = crate::scene::load_scene_str(text, path, "scene", &[]).unwrap();
        assert_eq!(super::adaptive_growth(&s), 432);
        let off = ["refine[0].adapt=false".to_string()];
        let (s, _) = crate::scene::load_scene_str(text, path, "scene", &off).unwrap();
        assert_eq!(super::adaptive_growth(&s), 0);
    }

    /// The shipped refined still tank with `sets` applied (`--set` syntax).
    fn refined_tank(sets: &[&str]) -> crate::scene::Scene {
        let text = include_str!("../../inputs/hydrostatic_2d_refined.toml");
        let path = std::path::Path::new("hydrostatic_2d_refined.toml");
        let sets: Vec<String> = sets.iter().map(|x| x.to_string()).collect();
        crate::scene::load_scene_str(text, path, "scene", &sets)
            .unwrap()
            .0
    }

    /// A region that refines nothing at set-up is named, with the reason; a region on the
    /// water, one on the tank's wall layers only, and one that adapts (water may arrive) are
    /// not.
    #[test]
    fn a_region_that_refines_nothing_is_named() {
        let warn = |sets: &[&str]| super::region_warnings::<2>(&refined_tank(sets));
        assert!(warn(&[]).is_empty());
        // 0.1 mm wide about (0.5, 0.2): the sites of dx = 2 cm lie at 0.49 and 0.51 m
        let tiny = warn(&["refine[0].min=[0.5, 0.2]", "refine[0].max=[0.5001, 0.2001]"]);
        assert_eq!(tiny.len(), 1);
        assert!(
            tiny[0].contains("refine[0] holds no site of the scene's lattice"),
            "{tiny:?}"
        );
        let above = ["refine[0].min=[0.3, 0.6]", "refine[0].max=[0.7, 0.7]"];
        let dry = warn(&above);
        assert_eq!(dry.len(), 1);
        assert!(dry[0].contains("no site of the bodies it refines"), "{dry:?}");
        assert!(warn(&[above[0], above[1], "refine[0].adapt=true"]).is_empty());
        // an adaptive region 1.9 dx wide: nothing of the scene's spacing lies dx inside it
        let narrow = [
            "refine[0].min=[0.3, 0.1]",
            "refine[0].max=[0.338, 0.4]",
            "refine[0].adapt=true",
        ];
        let thin = warn(&narrow);
        assert_eq!(thin.len(), 1, "{thin:?}");
        assert!(
            thin[0].contains("refine[0] adapts") && thin[0].contains("1.9000e-2 m"),
            "{thin:?}"
        );
        assert!(warn(&[narrow[0], "refine[0].max=[0.342, 0.4]", narrow[2]]).is_empty());
        // the shipped box is 0.3 m tall (0.15 m deep at most): a ramp of 0.2 m never ends
        let level = "refine[0].smoothing_length=\"level\"";
        let wide = warn(&[level, "refine[0].transition=0.2"]);
        assert_eq!(wide.len(), 1, "{wide:?}");
        assert!(wide[0].contains("refine[0].transition = 2.0000e-1 m"), "{wide:?}");
        assert!(warn(&[level, "refine[0].transition=0.1"]).is_empty());
        // with the scene's h a transition does nothing; the default (one support, κh = 0.08 m)
        // is filled in whatever the mode and is not warned about
        let idle = warn(&["refine[0].transition=0.1"]);
        assert_eq!(idle.len(), 1, "{idle:?}");
        assert!(
            idle[0].contains("refine[0].transition = 1.0000e-1 m has no effect"),
            "{idle:?}"
        );
        assert!(warn(&["refine[0].transition=0.08"]).is_empty());
        // the tank's left wall layers (x < 0) above the water
        assert!(warn(&["refine[0].min=[-0.1, 0.6]", "refine[0].max=[0.05, 0.7]"]).is_empty());
        // the same band within the tank but only for the water
        let water = warn(&[
            "refine[0].min=[0.01, 0.6]",
            "refine[0].max=[0.05, 0.7]",
            "refine[0].bodies=[\"water\"]",
        ]);
        assert!(water[0].contains("(water)"), "{water:?}");
    }

    /// The distance from points around a block and a disc to the nearest of ~10⁵ sample points
    /// inside them (a brute-force oracle, to within the sampling step), on a domain periodic
    /// along x: the nearest image counts, and a block face on the domain's bound does not.
    #[test]
    fn clearance_is_the_distance_to_the_nearest_point_of_the_region() {
        let b = Bounds {
            min: &[0.0, 0.0],
            max: &[1.0, 1.0],
            period: [Some(1.0), None, None],
        };
        let block = region("min = [0.6, 0.0]\nmax = [0.9, 0.5]\nlevel = 1");
        let mut disc = region("shape = \"sphere\"\ncentre = [0.2, 0.7]\nradius = 0.15\nlevel = 1");
        (disc.min, disc.max) = (vec![0.05, 0.55], vec![0.35, 0.85]);
        let step = 0.002;
        for r in [&block, &disc] {
            let inside: Vec<[f64; 2]> = (0..500)
                .flat_map(|i| (0..500).map(move |j| [(i as f64 + 0.5) * step, (j as f64 + 0.5) * step]))
                .filter(|x| r.contains(x))
                .collect();
            for x in [
                [0.5, 0.3],
                [0.95, 0.8],
                [0.02, 0.2],
                [0.7, 0.6],
                [0.2, 0.3],
                [0.7, 0.2],
            ] {
                let oracle = inside
                    .iter()
                    .map(|y| {
                        let dx = (x[0] - y[0]).abs();
                        // the nearest periodic image along x; the block's lower face at
                        // y = 0 lies on the domain's bound and is not a face
                        dx.min(1.0 - dx).hypot(x[1] - y[1])
                    })
                    .fold(f64::INFINITY, f64::min);
                let got = r.clearance(&x, &b, f64::INFINITY);
                let inside_x = r.contains(&x);
                assert_eq!(got == 0.0, inside_x, "{x:?}: {got}");
                if !inside_x {
                    assert!((got - oracle).abs() < 2.0 * step, "{x:?}: {got}, oracle {oracle}");
                }
            }
        }
    }

    /// On a periodic axis a block's face at the domain's bound is an interface (the domain
    /// wraps to coarse particles beyond it) unless the block spans the whole period; on a
    /// bounded axis it is not (no coarse particle lies beyond it).
    #[test]
    fn a_face_on_a_periodic_bound_is_an_interface_unless_the_region_spans_the_period() {
        let periodic = Bounds {
            min: &[0.0, 0.0],
            max: &[0.4, 0.2],
            period: [Some(0.4), None, None],
        };
        let bounded = Bounds {
            period: [None; 3],
            ..periodic
        };
        let edge = region("min = [0.3, 0.05]\nmax = [0.4, 0.15]\nlevel = 1");
        // 5 cm past the face at x = 0.4, wrapped to x = 0.05
        assert!((edge.clearance(&[0.05, 0.1], &periodic, f64::INFINITY) - 0.05).abs() < 1e-12);
        assert!((edge.clearance(&[0.05, 0.1], &bounded, f64::INFINITY) - 0.25).abs() < 1e-12);
        assert!((edge.depth(&[0.39, 0.1], &periodic, f64::INFINITY) - 0.01).abs() < 1e-12);
        assert!((edge.depth(&[0.39, 0.1], &bounded, f64::INFINITY) - 0.05).abs() < 1e-12);
        // a band along the whole periodic channel: interfaces only across it
        let band = region("min = [0.0, 0.0]\nmax = [0.4, 0.05]\nlevel = 1");
        assert!((band.depth(&[0.001, 0.01], &periodic, f64::INFINITY) - 0.04).abs() < 1e-12);
        assert_eq!(band.clearance(&[0.2, 0.04], &periodic, f64::INFINITY), 0.0);
        assert!((band.clearance(&[0.399, 0.08], &periodic, f64::INFINITY) - 0.03).abs() < 1e-12);
    }

    /// A region of `mesh`, its box the mesh's (as the loader sets it).
    fn mesh_region(mesh: crate::scene::mesh::Mesh) -> Refine {
        let mut r = region("shape = \"mesh\"\nlevel = 1");
        (r.min, r.max) = mesh.bounds();
        r.mesh = Some(std::sync::Arc::new(mesh));
        r
    }

    /// Points of [0, 1]^d at odd multiples of 1/64 (on no face of the boxes below, which lie
    /// on multiples of 1/8), and points on each plane of `faces` and 10⁻⁹ m to either side.
    fn samples(d: usize, faces: &[f64]) -> Vec<Vec<f64>> {
        let n: usize = 32;
        let c = |i: usize| (2 * i + 1) as f64 / 64.0;
        let mut out: Vec<Vec<f64>> = (0..n.pow(d as u32))
            .map(|k| (0..d).map(|a| c(k / n.pow(a as u32) % n)).collect())
            .collect();
        for (a, f) in (0..d).flat_map(|a| faces.iter().map(move |&f| (a, f))) {
            for off in [-1e-9, 0.0, 1e-9] {
                let mut x = vec![0.40625; d];
                x[a] = f + off;
                out.push(x);
            }
        }
        out
    }

    /// A box given as a closed mesh measures what the block region does: in 3D, and in 2D as
    /// the section of a box only 2 cm thick across the plane (the faces parallel to the plane
    /// do not count: the depth at the section's middle is 0.125 m, not 0.01 m), on a grid of
    /// points and on each face's plane and 1 nm to either side of it: the same membership, the
    /// same depth inside to the bit (the distance across a face is the block's subtraction) and
    /// the clearance outside to 1e-15 m (a corner's is a sum of squares in another order);
    /// with a cap c, min(value, c) exactly, beyond the cap the cap itself, and outside a depth
    /// of −min(clearance, c).
    #[test]
    fn a_box_mesh_region_measures_the_block_region_depths() {
        use crate::scene::mesh::{shapes::cuboid, Mesh, Slice};
        let (lo, hi) = ([0.25, 0.125, 0.375], [0.75, 0.5, 0.625]);
        let faces = [0.125, 0.25, 0.375, 0.5, 0.625, 0.75];
        let mesh = |lo, hi| Mesh::new(cuboid(lo, hi), String::new(), "binary");
        let (min3, max3) = ([0.0; 3], [1.0; 3]);
        let three = (
            region("min = [0.25, 0.125, 0.375]\nmax = [0.75, 0.5, 0.625]\nlevel = 1"),
            mesh_region(mesh(lo, hi)),
            Bounds {
                min: &min3,
                max: &max3,
                period: [None; 3],
            },
        );
        // (x, z) of the 3D box, y ∈ [−0.01, 0.01] cut at y = 0
        let cut = Slice { axis: 1, at: 0.0 };
        let thin = mesh([0.25, -0.01, 0.375], [0.75, 0.01, 0.625])
            .sliced(cut)
            .unwrap();
        let (min2, max2) = ([0.0; 2], [1.0; 2]);
        let two = (
            region("min = [0.25, 0.375]\nmax = [0.75, 0.625]\nlevel = 1"),
            mesh_region(thin),
            Bounds {
                min: &min2,
                max: &max2,
                period: [None; 3],
            },
        );
        assert_eq!(
            (two.1.min.clone(), two.1.max.clone()),
            (vec![0.25, 0.375], vec![0.75, 0.625])
        );
        let middle = [0.5, 0.5];
        assert_eq!(two.1.depth(&middle, &two.2, f64::INFINITY), 0.125);
        let (mut inside, mut outside) = (0, 0);
        for (d, (block, meshed, b)) in [(3, &three), (2, &two)] {
            for x in samples(d, &faces) {
                let x = x.as_slice();
                assert_eq!(meshed.contains(x), block.contains(x), "{x:?}");
                let (depth, clear) = (
                    block.depth(x, b, f64::INFINITY),
                    block.clearance(x, b, f64::INFINITY),
                );
                if block.contains(x) {
                    inside += 1;
                    assert_eq!(meshed.depth(x, b, f64::INFINITY), depth, "{x:?}");
                    assert_eq!(meshed.clearance(x, b, 0.01), 0.0, "{x:?}");
                    for cap in [0.01, 0.05] {
                        assert_eq!(meshed.depth(x, b, cap), depth.min(cap), "{x:?} cap {cap}");
                    }
                } else {
                    outside += 1;
                    let got = meshed.clearance(x, b, f64::INFINITY);
                    assert!((got - clear).abs() <= 1e-15, "{x:?}: {got} against {clear}");
                    for cap in [0.01, 0.05] {
                        let (c, dep) = (meshed.clearance(x, b, cap), meshed.depth(x, b, cap));
                        match clear < cap - 1e-15 {
                            true => assert!((c - clear).abs() <= 1e-15 && dep == -c, "{x:?} cap {cap}"),
                            false => assert!(c >= cap - 1e-15 && dep == -c, "{x:?} cap {cap}"),
                        }
                    }
                }
            }
        }
        assert!(
            inside > 1000 && outside > 10000,
            "{inside} inside, {outside} outside"
        );
        // deep inside, past the cap: the cap itself, not the depth
        let (centre3, centre2) = ([0.5, 0.3125, 0.5], [0.5, 0.5]);
        assert_eq!(three.1.depth(&centre3, &three.2, 0.02), 0.02);
        assert_eq!(three.1.depth(&centre3, &three.2, f64::INFINITY), 0.125);
        assert_eq!(two.1.depth(&centre2, &two.2, 0.02), 0.02);
        assert_eq!(three.1.clearance(&[0.0625; 3], &three.2, 0.03), 0.03);
    }

    /// A sphere of 24 bands as a mesh region measures the sphere region's depth and clearance
    /// to within the facets' sagitta, r(1 − cos(π/24)) = 2.6 mm, and with a cap of 5 cm the
    /// same value clamped to ±5 cm, to the bit.
    #[test]
    fn a_sphere_mesh_region_measures_the_sphere_to_its_facets() {
        use crate::scene::mesh::{shapes::sphere, Mesh};
        let (min, max) = ([0.0; 3], [1.0; 3]);
        let b = Bounds {
            min: &min,
            max: &max,
            period: [None; 3],
        };
        let meshed = mesh_region(Mesh::new(sphere([0.5; 3], 0.3, 24), String::new(), "binary"));
        let mut ball = region("shape = \"sphere\"\ncentre = [0.5, 0.5, 0.5]\nradius = 0.3\nlevel = 1");
        (ball.min, ball.max) = (vec![0.2; 3], vec![0.8; 3]);
        let sagitta = 0.3 * (1.0 - (std::f64::consts::PI / 24.0).cos());
        let mut worst = 0.0f64;
        for x in samples(3, &[]) {
            let x = x.as_slice();
            let (depth, clear) = (
                ball.depth(x, &b, f64::INFINITY),
                ball.clearance(x, &b, f64::INFINITY),
            );
            let got = match meshed.contains(x) {
                true => meshed.depth(x, &b, f64::INFINITY),
                false => -meshed.clearance(x, &b, f64::INFINITY),
            };
            let want = if depth > 0.0 { depth } else { -clear };
            worst = worst.max((got - want).abs());
            // with a cap: the value, or the cap (outside, its negative)
            assert_eq!(meshed.depth(x, &b, 0.05), got.clamp(-0.05, 0.05), "{x:?}");
        }
        assert!(worst <= sagitta, "{worst} against the sagitta {sagitta}");
        assert!(worst > 0.1 * sagitta, "{worst}: the facets show");
    }

    /// A region that keeps the scene's h at a level where each particle lists thousands of
    /// neighbours is named, with the level's h as the way out.
    #[test]
    fn a_region_whose_particles_list_thousands_of_neighbours_is_named() {
        let warn = |sets: &[&str]| super::list_warnings(&refined_tank(sets));
        // h = 2 dx, Wendland C2: 50 neighbours; ×16 at level 2 (804), ×64 at level 3
        assert!(warn(&["refine[0].level=2"]).is_empty());
        let many = warn(&["refine[0].level=3"]);
        assert_eq!(many.len(), 1, "{many:?}");
        assert!(
            many[0].contains("refine[0]") && many[0].contains("about 3217 neighbours"),
            "{many:?}"
        );
        assert!(warn(&["refine[0].level=3", "refine[0].smoothing_length=\"level\""]).is_empty());
    }
}
