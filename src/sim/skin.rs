//! The ghost set kept between builds: a Verlet skin (ARCHITECTURE.md, "Ghosts kept with a skin").
//!
//! A build sends every rank the ghosts within `support + w` of its box (`w` the skin width,
//! `performance.skin` × the support). Between builds the same ghosts, from the same owners, in
//! the same order, get the fields a build sends refreshed (`Fields::CONSTANT` stays); no
//! particle migrates. That set still holds every neighbour within the support as long as no
//! particle has moved more than `w/2` since the build: two particles within `support` now were
//! within `support + w` of each other then, and the one owned here was in this rank's box.
//! The rule is checked every step on the all-reduced largest displacement; a wrap across a
//! periodic face counts as a move of a whole period; a removed particle or cut planes that
//! moved force a build. Neighbour lists are still built every step from the cells, taking a
//! neighbour only within the support in global cell and key order, so the extra ghosts change
//! no sum: **the bits do not depend on the skin** (`tests/parallel.rs`), and a restart, which
//! builds at its first step, continues the uninterrupted bits. One rank without periodic axes
//! or mirror planes has no ghost: it gets no skin (and stores no build positions).

use crate::comm::{Comm, Phase};
use crate::error::Result;
use crate::particles::Particles;
use crate::Vector;
use rayon::prelude::*;

/// The skin and what the last ghost build left to compare with.
#[derive(Debug, Clone, Default)]
pub struct Skin<const D: usize> {
    /// Skin width w (m): ghosts reach the support + w; 0 builds every step.
    pub width: f64,
    /// Owned positions (m) at the last build, in storage order (empty with no skin).
    built: Vec<Vector<D>>,
    /// Particles held right after the last build (owned, owned + ghosts).
    held: (usize, usize),
    /// Ghost builds so far (set-up included).
    pub builds: u64,
}

impl<const D: usize> Skin<D> {
    /// A skin of width `width` (m), with no build yet.
    pub fn new(width: f64) -> Self {
        Skin {
            width,
            ..Default::default()
        }
    }

    /// Note a ghost build of `p` (owned particles and their ghosts, just made).
    pub fn built(&mut self, p: &Particles<D>) {
        self.builds += 1;
        self.held = (p.n_owned, p.len());
        if self.width > 0.0 {
            self.built.clear();
            self.built.extend_from_slice(&p.x[..p.n_owned]);
        }
    }

    /// The owned positions at the last build, in storage order, if they still describe the
    /// owned particles (none added, removed or reordered since; else empty: the next step
    /// builds anyway).
    pub fn positions(&self, p: &Particles<D>) -> &[Vector<D>] {
        if self.held == (p.n_owned, p.len()) && self.built.len() == p.n_owned {
            &self.built
        } else {
            &[]
        }
    }

    /// Forget the last build: the ghosts are built again at the next check (particles were
    /// created, so the owned set no longer matches the one the ghosts were built from).
    pub fn forget(&mut self) {
        self.built.clear();
        self.held = (usize::MAX, usize::MAX);
    }

    /// True if the ghosts must be built again this step, the same answer on every rank: no
    /// skin, a forced build (`force`: the cut planes moved), particles added,
    /// removed or reordered since the build, or some particle moved farther than w/2 (the
    /// largest displacement, exact, max all-reduced).
    pub fn expired(&self, p: &Particles<D>, force: bool, comm: &dyn Comm) -> Result<bool> {
        if self.width <= 0.0 {
            return Ok(true);
        }
        let n = p.n_owned;
        let local = if force || self.held != (n, p.len()) || self.built.len() != n {
            f64::INFINITY
        } else {
            let (x, b) = (&p.x[..n], &self.built[..]);
            x.par_iter()
                .zip(b.par_iter())
                .map(|(x, b)| (x - b).norm())
                .reduce(|| 0.0, f64::max)
        };
        let mut m = [local];
        let prev = comm.set_phase(Phase::Other);
        let r = comm.all_reduce_max_f64(&mut m);
        comm.set_phase(prev);
        r?;
        // NaN (a particle no longer finite) also builds
        Ok(m[0].is_nan() || m[0] > 0.5 * self.width)
    }
}
