//! Verlet lists (`[performance] neighbours = "verlet"`): the lists of a build reach the
//! support + skin w and are kept, with the cell list and the slots they index, until the
//! ghosts are built again (`sim/skin.rs`: no particle has moved w/2 since the build, so every
//! pair within the support now was within support + w then). Each step copies the current
//! positions into the build's cell order ([`NeighbourList::follow`]). A gather pass takes a
//! listed partner only while it lies within the support of those positions ([`Near`]): the
//! pair set of a fresh build, in the order of the last one. Pair mode's passes read the half
//! lists unfiltered: their kernels are multiples of W′(r), exactly 0 beyond the support
//! (`physics::pairs`). The build steps are decided on all-reduced displacements and the lists
//! are canonical (global cell and key order of the build's positions), so the bits do not
//! depend on ranks or threads.

use super::{NeighbourList, Neighbours, CHUNK};
use crate::particles::Particles;
use rayon::prelude::*;

/// The listed partners of one particle that lie within the support now.
#[derive(Clone)]
pub struct Near<'a, I, const D: usize> {
    /// The listed partners (particle indices).
    inner: I,
    /// Current positions in cell order (`xs[k·D + a]`).
    xs: &'a [f64],
    /// Slot of each particle index.
    slot: &'a [u32],
    /// The particle's own position.
    xa: [f64; D],
    /// Support squared (m²).
    r2: f64,
}

impl<I: Iterator<Item = u32>, const D: usize> Iterator for Near<'_, I, D> {
    type Item = u32;

    #[inline(always)]
    fn next(&mut self) -> Option<u32> {
        loop {
            let j = self.inner.next()?;
            let k = self.slot[j as usize] as usize;
            let xb = &self.xs[k * D..k * D + D];
            let mut d2 = 0.0;
            for (a, b) in self.xa.iter().zip(xb) {
                let d = a - b;
                d2 += d * d;
            }
            if d2 < self.r2 {
                return Some(j);
            }
        }
    }
}

impl NeighbourList {
    /// Verlet lists (module docs) for a kernel of radius `support` (m): what a pass keeps of
    /// the lists built to a wider reach.
    pub fn verlet(support: f64) -> Self {
        NeighbourList {
            within2: support * support,
            ..Default::default()
        }
    }

    /// True for Verlet lists.
    pub fn is_verlet(&self) -> bool {
        self.within2 > 0.0
    }

    /// Copy the current positions of `p` into the cell order of the last build (`cells`, the
    /// build's cell list): a kept step's [`Near`] measures with them.
    pub fn follow<const D: usize>(&mut self, cells: &super::CellList, p: &Particles<D>) {
        self.xs
            .par_chunks_mut(D * CHUNK)
            .zip(cells.order.par_chunks(CHUNK))
            .for_each(|(xs, ord)| {
                for (x, &j) in xs.chunks_exact_mut(D).zip(ord) {
                    x.copy_from_slice(p.x[j as usize].as_slice());
                }
            });
    }

    /// The partners `inner` (particle indices; `slot` the slot of each) of the particle at
    /// slot `k` that lie within the support now.
    #[inline]
    fn near<'a, I, const D: usize>(&'a self, k: usize, inner: I, slot: &'a [u32]) -> Near<'a, I, D> {
        let mut xa = [0.0; D];
        xa.copy_from_slice(&self.xs[k * D..k * D + D]);
        Near {
            inner,
            xs: &self.xs,
            slot,
            xa,
            r2: self.within2,
        }
    }

    /// The gather lists of the last build, each partner kept while within the support now.
    pub fn kept<'a, const D: usize>(&'a self, cells: &'a super::CellList) -> Kept<'a, D> {
        Kept { nl: self, cells }
    }
}

/// The gather lists of a Verlet build as a neighbour source ([`NeighbourList::kept`]).
pub struct Kept<'a, const D: usize> {
    nl: &'a NeighbourList,
    cells: &'a super::CellList,
}

impl<const D: usize> Neighbours for Kept<'_, D> {
    type Iter<'b>
        = Near<'b, std::iter::Copied<std::slice::Iter<'b, u32>>, D>
    where
        Self: 'b;

    #[inline]
    fn iter(&self, i: usize) -> Self::Iter<'_> {
        let slot = &self.cells.slot[..];
        self.nl
            .near(slot[i] as usize, self.nl.of(i).iter().copied(), slot)
    }

    fn work_before(&self, i: usize) -> usize {
        self.nl.entries_before(i)
    }
}
