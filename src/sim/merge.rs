//! Merging of fluid particles that left adaptive refinement regions
//! (`docs/splitting.md` §3): the reverse of [`super::adapt`]'s split.
//!
//! A fluid particle of level ℓ ≥ 1 whose body some adaptive region refines is *due* when its
//! centre lies at least the coarse spacing dx/2^(ℓ−1) outside every region of level ≥ ℓ that
//! refines its body (the transition band: a split needs as much depth inside). Due particles
//! are grouped by the cell of side dx/2^(ℓ−1) that holds their centre, on the lattice anchored
//! at `domain.min`; a cell holding at least 2^D of one level merges the 2^D of smallest id into
//! one particle of level ℓ − 1 with
//!   m = Σ m_k,  x = Σ m_k x_k / m,  v = Σ m_k v_k / m,  a = Σ m_k a_k / m,
//!   ρ = m / Σ (m_k/ρ_k)  (the group's volume kept),
//! summed in id order, so Σm and Σmv are kept to round-off and every rank that holds a member
//! computes the same bits; h is that of the region of level ℓ − 1 that holds it (the scene's
//! outside every region). The other fields are the smallest-id member's. The merged particle
//! takes a new id from the run's counter, keyed (smallest member id, 0).
//!
//! In parallel: the merge runs at the end of the step, when the ghosts' positions are the
//! owners' (refreshed first if a pass moved the owners). A cell's members lie within its
//! diagonal √D·dx of each other, which the scene check keeps within the kernel support, so
//! every rank that owns a member, and the rank whose box holds the group's centroid (the
//! *leader*, which gets the merged particle), sees the whole group as owned particles or
//! ghosts and takes the same decision without a message. The members' owners then hand their
//! records and accelerations (which ghosts do not carry) over to the leader.

use super::Simulation;
use crate::comm::{Comm, Phase};
use crate::error::{Error, Result};
use crate::halo;
use crate::particles::{Fields, Record, IMAGE_BITS};
use crate::Vector;
use std::ops::Range;

/// A particle that may merge: the level it has, the cell of its group on the lattice of the
/// level below, its id and its index in the particle table (owned below `n_owned`, else a
/// ghost). Ordered by (level, cell, id).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Candidate {
    level: u16,
    cell: [i64; 3],
    id: u64,
    index: usize,
}

/// Sort `c` by (level, cell, id) and return the groups that merge, as ranges into it: in each
/// cell of one level holding at least `size` candidates, the `size` of smallest id.
fn groups(c: &mut Vec<Candidate>, size: usize) -> Vec<Range<usize>> {
    c.sort_unstable();
    // a particle is listed once (a ghost never duplicates an owned particle or another ghost
    // outside the images, which are left out); kept safe against it all the same
    c.dedup_by_key(|k| (k.level, k.cell, k.id));
    let mut out = Vec::new();
    let mut start = 0;
    while start < c.len() {
        let here = (c[start].level, c[start].cell);
        let len = c[start..]
            .iter()
            .take_while(|k| (k.level, k.cell) == here)
            .count();
        if len >= size {
            out.push(start..start + size);
        }
        start += len;
    }
    out
}

/// Σ m_k and the mass-weighted mean Σ m_k f_k / Σ m_k of `f` over `members` (in their order).
fn weighted<const D: usize>(members: &[(f64, Vector<D>)]) -> (f64, Vector<D>) {
    let m: f64 = members.iter().fold(0.0, |s, e| s + e.0);
    let sum = members.iter().fold(Vector::<D>::zeros(), |s, e| s + e.1 * e.0);
    (m, sum / m)
}

impl<const D: usize> Simulation<D> {
    /// Every fluid particle held (owned or a ghost other than an image) that is due to merge
    /// (see the module docs).
    fn merge_candidates(&self) -> Vec<Candidate> {
        let s = &self.scene;
        let dom = crate::scene::refine::Bounds::of(s);
        let adaptive = crate::scene::refine::adaptive_bodies(s);
        let p = &self.p;
        let image_mask = (1u64 << IMAGE_BITS) - 1;
        let mut out = Vec::new();
        for i in 0..p.len() {
            let l = p.level.get(i).copied().unwrap_or(0);
            let b = p.body[i] as usize;
            if l == 0 || !p.kind[i].is_fluid() || p.key[i] & image_mask != 0 || !adaptive[b] {
                continue;
            }
            let x = p.x[i].as_slice();
            let side = s.discretisation.dx / f64::from(1u32 << (l - 1));
            let name = &s.fluids[b].name;
            let clear = s
                .refine
                .iter()
                .filter(|r| r.level >= u32::from(l) && r.applies_to(name))
                .all(|r| r.clearance(x, &dom, side) >= side);
            if clear {
                let mut cell = [0i64; 3];
                for a in 0..D {
                    cell[a] = ((x[a] - dom.min[a]) / side).floor() as i64;
                }
                out.push(Candidate {
                    level: l,
                    cell,
                    id: p.id[i],
                    index: i,
                });
            }
        }
        out
    }

    /// Collective (at the end of the step, after the passes): merge the groups of fluid
    /// particles that left the adaptive regions (see the module docs). The ghosts are dropped
    /// when anything merged anywhere on this rank (the next step builds them again).
    pub(super) fn merge_leaving(&mut self, comm: &dyn Comm) -> Result<()> {
        let need = self.fresh.needs(Fields::X);
        if !need.0.is_empty() {
            self.refresh(need, comm)?;
        }
        let mut cands = self.merge_candidates();
        let size = 1usize << D;
        let n = self.p.n_owned;
        let me = comm.rank();
        let mut led: Vec<Range<usize>> = Vec::new();
        let mut hand: Vec<(usize, usize)> = Vec::new();
        let mut gone: Vec<usize> = Vec::new();
        for g in groups(&mut cands, size) {
            let members = &cands[g.clone()];
            let xs: Vec<(f64, Vector<D>)> = members
                .iter()
                .map(|c| (self.p.mass[c.index], self.p.x[c.index]))
                .collect();
            let (_, centroid) = weighted(&xs);
            let leader = self.map.owner(&centroid, members[0].id);
            if leader == me {
                led.push(g);
            }
            for c in members.iter().filter(|c| c.index < n) {
                gone.push(c.index);
                if leader != me {
                    hand.push((c.index, leader));
                }
            }
        }
        // one integer all-reduce spares the steps without a merge anywhere the hand-over's
        // and the id allocator's collectives
        let mut any = [(led.len() + hand.len()) as u64];
        let prev = comm.set_phase(Phase::Other);
        comm.all_reduce_sum_u64(&mut any)?;
        comm.set_phase(prev);
        if any[0] == 0 {
            return Ok(());
        }
        let got = halo::hand_over(&self.p, &hand, comm)?;
        let keys: Vec<crate::ids::Key> = led.iter().map(|g| (cands[g.start].id, 0)).collect();
        let before = self.ids.next();
        let ids = self.ids.allocate(comm, &keys)?;
        self.resized.merges += self.ids.next() - before;
        if led.is_empty() && gone.is_empty() {
            return Ok(());
        }
        let mut merged: Vec<(Record<D>, Vector<D>)> = Vec::with_capacity(led.len());
        for (g, &id) in led.iter().zip(&ids) {
            let mut members: Vec<(Record<D>, Vector<D>)> = Vec::with_capacity(size);
            for c in &cands[g.clone()] {
                if c.index < n {
                    members.push((self.p.record(c.index), self.p.acc[c.index]));
                } else {
                    let k = got
                        .binary_search_by_key(&c.id, |e| e.0.id)
                        .map_err(|_| Error::run(format!("merging: particle {} was not handed over", c.id)))?;
                    members.push(got[k]);
                }
            }
            merged.push(self.merged(&members, id));
        }
        let mut leaving = vec![false; n];
        gone.iter().for_each(|&i| leaving[i] = true);
        let keep: Vec<usize> = (0..n).filter(|&i| !leaving[i]).collect();
        self.p.truncate_ghosts();
        self.p.permute_owned(&keep);
        for (r, a) in merged {
            self.p.push_owned(r);
            let j = self.p.n_owned - 1;
            self.p.acc[j] = a;
        }
        self.free_step_buffers();
        self.skin.forget();
        Ok(())
    }

    /// The particle a group `members` (records and accelerations, in id order) merges into,
    /// with id `id` (see the module docs).
    fn merged(&self, members: &[(Record<D>, Vector<D>)], id: u64) -> (Record<D>, Vector<D>) {
        let with = |f: &dyn Fn(&(Record<D>, Vector<D>)) -> Vector<D>| -> Vec<(f64, Vector<D>)> {
            members.iter().map(|e| (e.0.mass, f(e))).collect()
        };
        let (m, x) = weighted(&with(&|e| e.0.x));
        let (_, v) = weighted(&with(&|e| e.0.v));
        let (_, a) = weighted(&with(&|e| e.1));
        let volume = members.iter().fold(0.0, |s, e| s + e.0.mass / e.0.rho);
        let mut r = members[0].0;
        r.mass = m;
        r.x = x;
        r.v = v;
        r.rho = m / volume;
        r.level -= 1;
        r.id = id;
        if let Some(sz) = self.model.sizes.as_ref() {
            r.h = self.resized_h(sz, &r.x, r.level, r.body);
        }
        (r, a)
    }
}

#[cfg(test)]
mod tests {
    use super::{groups, Candidate};

    fn cand(level: u16, cell: [i64; 3], id: u64) -> Candidate {
        Candidate {
            level,
            cell,
            id,
            index: id as usize,
        }
    }

    /// Against a brute-force oracle over a scrambled list: every (level, cell) with at least 4
    /// candidates gives one group, its 4 smallest ids; a cell with 3, or 4 split over two
    /// levels, gives none; a listed duplicate counts once.
    #[test]
    fn a_cell_merges_its_four_smallest_ids_when_it_holds_four() {
        let mut c = Vec::new();
        // cell A (level 1): 5 candidates; cell B: 3; cell C: 2 of level 1 and 2 of level 2;
        // cell D (level 2): exactly 4, one listed twice
        for id in [50, 10, 40, 30, 20] {
            c.push(cand(1, [0, 0, 0], id));
        }
        for id in [7, 8, 9] {
            c.push(cand(1, [1, 0, 0], id));
        }
        for (l, id) in [(1, 60), (2, 61), (1, 62), (2, 63)] {
            c.push(cand(l, [2, 0, 0], id));
        }
        for id in [70, 71, 72, 73, 72] {
            c.push(cand(2, [0, 5, 0], id));
        }
        c.reverse();
        let g = groups(&mut c, 4);
        let ids: Vec<Vec<u64>> = g
            .iter()
            .map(|r| c[r.clone()].iter().map(|k| k.id).collect())
            .collect();
        assert_eq!(ids, vec![vec![10, 20, 30, 40], vec![70, 71, 72, 73]]);
        // the oracle: count per (level, cell) by brute force
        for r in &g {
            let k = c[r.start];
            let all = c
                .iter()
                .filter(|o| (o.level, o.cell) == (k.level, k.cell))
                .count();
            assert!(all >= 4);
        }
    }
}
