//! Splitting of fluid particles that enter adaptive refinement regions (`[[refine]] adapt =
//! true`; `docs/splitting.md` §2). Their children merge again when they leave it
//! ([`super::merge`]).
//!
//! A fluid particle of level ℓ (spacing s = dx/2^ℓ) whose centre lies at least s inside an
//! adaptive region of a level above ℓ becomes 2^D children of level ℓ + 1 at x + (s/4)·σ,
//! σ ∈ {−1, +1}^D (the sites a set-up at level ℓ + 1 puts in the parent's cell), each of mass
//! m/2^D with the parent's velocity, density and every other field, so Σm and Σmv are kept
//! (m/2^D is exact in binary floating point). The smoothing length is the region's at the
//! child's site ([`Refine::smoothing_length`]: the scene's, or with `smoothing_length =
//! "level"` that of level ℓ + 1, ramped over the transition band). Children take new ids from the
//! run's counter ([`crate::ids`]), keyed by (parent id, child index): the same on every layout.

use super::Simulation;
use crate::comm::Comm;
use crate::error::Result;
use crate::kernel::sizes::Sizes;
use crate::scene::refine::{adaptive_bodies, level_h, Bounds, Refine};
use crate::Vector;

/// The offset σ_c (s/4)·σ of child `c` of 2^D (bit a of c: the sign along axis a).
fn child_offset<const D: usize>(c: usize, s: f64) -> Vector<D> {
    Vector::<D>::from_fn(|a, _| if c >> a & 1 == 1 { 0.25 * s } else { -0.25 * s })
}

impl<const D: usize> Simulation<D> {
    /// True if the scene has a region whose fluid particles split ([`Refine::adapt`]).
    pub fn adapts(&self) -> bool {
        self.scene.refine.iter().any(|r| r.adapt)
    }

    /// The level an owned fluid particle `i` of level `l` splits to, `l + 1`, if its centre
    /// lies at least its own spacing inside an adaptive region (of `regions`) of a higher level
    /// that refines its body, else `None`.
    fn splits_to(&self, regions: &[&Refine], i: usize, l: u16) -> Option<u16> {
        let p = &self.p;
        let name = &self.scene.fluids.get(p.body[i] as usize)?.name;
        let x = p.x[i].as_slice();
        let dom = crate::scene::refine::Bounds::of(&self.scene);
        let band = self.scene.discretisation.dx / f64::from(1u32 << l);
        let inside = |r: &&&Refine| {
            r.level > u32::from(l) && r.applies_to(name) && r.contains(x) && r.depth(x, &dom, band) >= band
        };
        regions.iter().any(|r| inside(&r)).then_some(l + 1)
    }

    /// Collective (after the drift and the outflow rule, before the balance check): split the
    /// owned fluid particles that entered an adaptive region, numbering the children on every
    /// rank together. The ghosts are dropped (the next step builds them again).
    pub(super) fn split_entering(&mut self, comm: &dyn Comm) -> Result<()> {
        let regions: Vec<&Refine> = self.scene.refine.iter().filter(|r| r.adapt).collect();
        let n = self.p.n_owned;
        let level = |i: usize| self.p.level.get(i).copied().unwrap_or(0);
        let split: Vec<(usize, u16)> = (0..n)
            .filter(|&i| self.p.kind[i].is_fluid())
            .filter_map(|i| self.splits_to(&regions, i, level(i)).map(|l| (i, l)))
            .collect();
        let children = 1usize << D;
        let id = &self.p.id;
        let keys: Vec<crate::ids::Key> = split
            .iter()
            .flat_map(|&(i, _)| (0..children as u32).map(move |c| (id[i], c)))
            .collect();
        let before = self.ids.next();
        let ids = self.ids.allocate(comm, &keys)?;
        self.resized.splits += (self.ids.next() - before) >> D;
        if split.is_empty() {
            return Ok(());
        }
        // the particles that stay, in their order, then each parent's children
        let mut parent = vec![false; n];
        split.iter().for_each(|&(i, _)| parent[i] = true);
        let mut perm: Vec<usize> = (0..n).filter(|&i| !parent[i]).collect();
        let first = perm.len();
        perm.extend(split.iter().flat_map(|&(i, _)| std::iter::repeat_n(i, children)));
        self.p.truncate_ghosts();
        self.p.permute_owned(&perm);
        let dx = self.scene.discretisation.dx;
        let share = 1.0 / children as f64;
        for (k, &(_, l)) in split.iter().enumerate() {
            let s = dx / f64::from(1u32 << (l - 1));
            for c in 0..children {
                let j = first + k * children + c;
                // a child that the pattern would put behind a wall face (a parent within a
                // quarter spacing of the face) is reflected back into the fluid
                let site = self.p.x[j];
                let x = self.faces_keep_inside(&site, site + child_offset::<D>(c, s));
                let p = &mut self.p;
                p.x[j] = x;
                let offset = p.x[j] - site;
                // the density carried to the child's site by the parent's renormalised
                // gradient, where δ-SPH computed one (a hydrostatic column keeps its profile)
                if let Some(g) = p.grad_rho.get(j) {
                    p.rho[j] += g.dot(&offset);
                }
                self.space.wrap(&mut p.x[j]);
                p.mass[j] *= share;
                p.level[j] = l;
                p.id[j] = ids[k * children + c];
                p.key[j] = p.id[j] << crate::particles::IMAGE_BITS;
                // the h of the child's level at its site (the region's ramp)
                if let Some(sz) = self.model.sizes.as_ref().filter(|_| !self.p.h.is_empty()) {
                    self.p.h[j] = self.resized_h(sz, &self.p.x[j], l, self.p.body[j]);
                }
            }
        }
        self.free_step_buffers();
        self.skin.forget();
        Ok(())
    }
}

impl<const D: usize> Simulation<D> {
    /// The smoothing length (m) that a fluid particle of body `body` and level `level` at `x`
    /// takes when it changes size or moves in an adaptive body
    /// ([`crate::scene::refine::level_h`]).
    pub(super) fn resized_h(&self, sz: &Sizes, x: &Vector<D>, level: u16, body: u16) -> f64 {
        let s = &self.scene;
        let dom = Bounds::of(s);
        level_h(s, &dom, &s.fluids[body as usize].name, level, x.as_slice(), &sz.h)
    }

    /// At the end of each step or cycle (after the merges, before the next span is planned):
    /// every owned fluid particle of level ≥ 1 in a body that an adaptive region refines takes
    /// the h of its level where it now is ([`Simulation::resized_h`]; docs/splitting.md §2),
    /// so that the particles a surge carries deep into a region have the level's h there, not
    /// the ramp's at the site where they split. A function of the particle's state alone (the
    /// same on every layout); h changes only between steps, so a particle keeps its class
    /// through a cycle of local time stepping, and the next span is planned on the new classes.
    /// When some h changed, the ghosts (which carry h) are built again.
    pub(super) fn follow_ramps(&mut self) {
        let Some(sz) = self.model.sizes.as_ref().filter(|z| z.varies_h) else {
            return;
        };
        if self.p.h.is_empty() || self.p.level.is_empty() {
            return;
        }
        let s = &self.scene;
        let dom = Bounds::of(s);
        let adaptive = adaptive_bodies(s);
        let n = self.p.n_owned;
        let (kind, body, level, x) = (&self.p.kind, &self.p.body, &self.p.level, &self.p.x);
        let mut changed = false;
        for (i, h) in self.p.h[..n].iter_mut().enumerate() {
            let b = body[i] as usize;
            if !kind[i].is_fluid() || level[i] == 0 || !adaptive[b] {
                continue;
            }
            let new = level_h(s, &dom, &s.fluids[b].name, level[i], x[i].as_slice(), &sz.h);
            if new != *h {
                *h = new;
                changed = true;
            }
        }
        if changed {
            self.skin.forget();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::child_offset;

    #[test]
    fn the_children_sit_on_the_finer_lattice_and_average_to_the_parent() {
        // a power of two: the offsets ±s/4 and their sums are exact
        let s = 0.5;
        let offsets: Vec<_> = (0..8).map(|c| child_offset::<3>(c, s)).collect();
        let mean = offsets.iter().fold(crate::Vector::<3>::zeros(), |a, o| a + o) / 8.0;
        assert_eq!(mean, crate::Vector::<3>::zeros());
        for (a, oa) in offsets.iter().enumerate() {
            assert!(oa.iter().all(|&v| v.abs() == 0.25 * s));
            for ob in &offsets[a + 1..] {
                // distinct sites, at least the finer spacing s/2 apart
                assert!((oa - ob).norm() >= 0.5 * s - 1e-15);
            }
        }
    }
}
