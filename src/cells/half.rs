//! Pair mode's half lists, in a canonical order (`physics::pairs`).
//!
//! Every particle the rank holds (owned and ghost) has a **slot**: its place in the cell
//! order of [`CellList::order`] (cells linear with axis 0 slowest, ascending key within a
//! cell). Slot order is a global order — a function of positions and ids only — so two
//! particles compare the same way on every rank that holds both. Each pair is listed once,
//! under the particle of the lower slot (its **home**), when the pair is within the support,
//! neither is a solid, at least one is fluid and at least one is owned.
//!
//! **Schedule.** Cells are linear as (x, y, rest), so a row of cells (fixed x and y) and
//! any run of rows of one plane are contiguous slot ranges. A home in row (X, Y) lists
//! partners (higher slots) in rows Y and Y + 1 of plane X and rows Y − 1 … Y + 1 of plane
//! X + 1 only. Homes are grouped in blocks of [`BLOCK`] rows of one plane; block (X, b) writes
//! rows bB … bB + B of plane X and bB − 1 … bB + B of plane X + 1, two contiguous ranges. The
//! blocks run in four phases by the parities of X and b; within a phase the blocks' write
//! ranges are disjoint (B ≥ 2), handed to rayon as disjoint `&mut` slices (no locks, no
//! atomics, no `unsafe`), and each block's homes run one after the other in slot order. A
//! particle's contributions thus arrive in an order fixed by the global cell grid and the keys
//! alone — the same bits on any number of ranks and threads.

use super::{CellGrid, CellList, NeighbourList, CHUNK};
use crate::particles::Particles;
use rayon::prelude::*;
use std::ops::Range;

/// Rows of cells (along axis 1) per block of homes in the schedule (≥ 2, module docs).
const BLOCK: usize = 4;

/// Flag bits of a slot.
const ELIGIBLE: u8 = 1;
const FLUID: u8 = 2;
const OWNED: u8 = 4;

/// The canonical half lists (stored) or what a list-free scan needs (lean mode).
#[derive(Debug, Clone, Default)]
pub struct HalfPairs {
    /// Partner slots of homes k·[`CHUNK`] .. (k+1)·[`CHUNK`], one list after the other.
    chunks: Vec<Vec<u32>>,
    /// Start of slot k's partners within its chunk.
    offset: Vec<u32>,
    /// Slots listed (owned + ghosts), 0 when not built.
    slots: usize,
    /// Flag bits per slot ([`ELIGIBLE`], [`FLUID`], [`OWNED`]).
    flags: Vec<u8>,
    /// First slot of each row of cells (axis-0 and axis-1 coordinates), one per row plus one.
    rows: Vec<usize>,
    /// Partners listed in all.
    pairs: usize,
}

impl HalfPairs {
    /// Build the half lists over the cell list (`nl` holds the cell-order positions of this
    /// build); in lean mode only the flags and rows.
    pub(super) fn build<const D: usize>(
        &mut self,
        nl: &NeighbourList,
        grid: &CellGrid<D>,
        cells: &CellList,
        p: &Particles<D>,
        lean: bool,
    ) {
        let slots = cells.order.len();
        let n = p.n_owned;
        self.slots = slots;
        self.flags.resize(slots, 0);
        self.flags
            .par_chunks_mut(CHUNK)
            .zip(cells.order.par_chunks(CHUNK))
            .for_each(|(fl, ord)| {
                for (f, &j) in fl.iter_mut().zip(ord) {
                    let (j, k) = (j as usize, p.kind[j as usize]);
                    let eligible = if k.is_solid() { 0 } else { ELIGIBLE };
                    let fluid = if k.is_fluid() { FLUID } else { 0 };
                    let owned = if j < n { OWNED } else { 0 };
                    *f = eligible | fluid | owned;
                }
            });
        let row = grid.dims[2..].iter().product::<usize>();
        self.rows.clear();
        self.rows
            .extend((0..=grid.dims[0] * grid.dims[1]).map(|r| cells.start[r * row] as usize));
        self.pairs = 0;
        if lean {
            self.chunks.clear();
            self.offset.clear();
            return;
        }
        let nchunks = slots.div_ceil(CHUNK);
        let mut chunks = std::mem::take(&mut self.chunks);
        let mut offset = std::mem::take(&mut self.offset);
        chunks.resize_with(nchunks, Vec::new);
        offset.resize(slots, 0);
        {
            let view = HalfView {
                half: &*self,
                nl,
                grid,
                cells,
            };
            chunks
                .par_iter_mut()
                .zip(offset.par_chunks_mut(CHUNK))
                .enumerate()
                .for_each(|(ci, (list, offs))| {
                    list.clear();
                    for (k, off) in offs.iter_mut().enumerate() {
                        *off = list.len() as u32;
                        view.append(ci * CHUNK + k, list);
                    }
                });
        }
        self.pairs = chunks.iter().map(Vec::len).sum();
        self.chunks = chunks;
        self.offset = offset;
    }

    /// Partners listed (pairs), or 0 in lean mode.
    pub fn len(&self) -> usize {
        self.pairs
    }

    /// True if no pair is listed.
    pub fn is_empty(&self) -> bool {
        self.pairs == 0
    }

    /// Bytes held by the lists.
    pub fn bytes(&self) -> usize {
        self.chunks.iter().map(|c| c.capacity() * 4).sum::<usize>()
            + self.offset.capacity() * 4
            + self.flags.capacity()
            + self.rows.capacity() * 8
    }

    /// Partners of home slot `k` (stored lists).
    #[inline]
    pub(super) fn stored(&self, k: usize) -> &[u32] {
        let (c, r) = (k / CHUNK, k % CHUNK);
        let list = &self.chunks[c];
        let s = self.offset[k] as usize;
        let e = if r + 1 < CHUNK && k + 1 < self.slots {
            self.offset[k + 1] as usize
        } else {
            list.len()
        };
        &list[s..e]
    }
}

/// The half lists of the last build with the grid and cell list they were built on.
#[derive(Clone, Copy)]
pub struct HalfView<'a, const D: usize> {
    pub(super) half: &'a HalfPairs,
    pub(super) nl: &'a NeighbourList,
    pub(super) grid: &'a CellGrid<D>,
    pub(super) cells: &'a CellList,
}

/// The accumulator entries one block of homes may write: slots `a_base ..` (its rows of
/// plane X and the row above) and `b_base ..` (the rows of plane X + 1 beside them), `stride`
/// entries each.
pub struct Window<'w, A> {
    a_base: usize,
    a: &'w mut [A],
    b_base: usize,
    b: &'w mut [A],
    stride: usize,
}

/// The next `r` slots of `rest` (which starts at slot `at`), `stride` entries each.
fn take<'s, A>(rest: &mut &'s mut [A], at: &mut usize, r: &Range<usize>, stride: usize) -> &'s mut [A] {
    let (_, tail) = std::mem::take(rest).split_at_mut((r.start - *at) * stride);
    let (mid, tail) = tail.split_at_mut((r.end - r.start) * stride);
    *rest = tail;
    *at = r.end;
    mid
}

impl<A> Window<'_, A> {
    /// The entry of slot `s` of a one-entry-per-slot accumulator.
    #[inline(always)]
    pub fn one(&mut self, s: usize) -> &mut A {
        debug_assert_eq!(self.stride, 1);
        if s < self.b_base {
            &mut self.a[s - self.a_base]
        } else {
            &mut self.b[s - self.b_base]
        }
    }

    /// The `stride` entries of slot `s`.
    #[inline(always)]
    pub fn at(&mut self, s: usize) -> &mut [A] {
        let st = self.stride;
        if s < self.b_base {
            &mut self.a[(s - self.a_base) * st..][..st]
        } else {
            &mut self.b[(s - self.b_base) * st..][..st]
        }
    }
}

impl<'a, const D: usize> HalfView<'a, D> {
    /// Particle index at slot `s`.
    #[inline(always)]
    pub fn particle(&self, s: usize) -> usize {
        self.cells.order[s] as usize
    }

    /// Particle index of every slot (the cell list's order).
    #[inline(always)]
    pub fn order(&self) -> &'a [u32] {
        &self.cells.order
    }

    /// Slot of particle `i`.
    #[inline(always)]
    pub fn slot(&self, i: usize) -> usize {
        self.cells.slot[i] as usize
    }

    /// Slots held (owned + ghosts).
    pub fn slots(&self) -> usize {
        self.half.slots
    }

    /// The stored partner slots of home slot `k`, ascending; `None` in lean mode (use
    /// [`HalfView::scan`]).
    #[inline]
    pub fn stored(&self, k: usize) -> Option<&'a [u32]> {
        (!self.nl.lean).then(|| self.half.stored(k))
    }

    /// The partners of home slot `k` by scanning its stencil rows from slot k + 1 on (what
    /// the stored lists hold, in the same order).
    pub fn scan(&self, k: usize) -> HalfScan<'a, D> {
        let mut it = HalfScan {
            view: *self,
            xa: [0.0; D],
            ra: self.nl.reach.get(k).copied().unwrap_or(0.0),
            fa: self.half.flags[k],
            k,
            c: [0; D],
            row: 0,
            rows: 0,
            t: 0,
            e: 0,
        };
        if it.fa & ELIGIBLE != 0 {
            let xs = &self.nl.xs;
            it.xa.copy_from_slice(&xs[k * D..k * D + D]);
            it.c = self
                .grid
                .coords_of(self.cells.cell[self.cells.order[k] as usize] as usize);
            it.rows = 3usize.pow(D as u32 - 1);
        }
        it
    }

    /// True if cells `c0 .. c1` can hold no partner of a home with flags `fa`: a home that is
    /// not fluid pairs with fluid only (most wall particles lie far from the water).
    #[inline]
    fn no_partner_in(&self, fa: u8, c0: usize, c1: usize) -> bool {
        fa & FLUID == 0 && self.nl.fluid_start[c1] == self.nl.fluid_start[c0]
    }

    /// Append home slot `k`'s partners to `list` (the list build: what [`HalfView::scan`]
    /// finds, with a branch-free append per stencil row).
    fn append(&self, k: usize, list: &mut Vec<u32>) {
        let it = self.scan(k);
        if it.rows == 0 {
            return;
        }
        let (fl, xs, r2max, cells) = (&self.half.flags, &self.nl.xs, self.nl.r2max, self.cells);
        let reach = &self.nl.reach;
        for row in 0..it.rows {
            let Some((c0, c1)) = self.grid.stencil_run(&it.c, row) else {
                continue;
            };
            let e = cells.start[c1] as usize;
            if e <= k + 1 || self.no_partner_in(it.fa, c0, c1) {
                continue;
            }
            let s = (cells.start[c0] as usize).max(k + 1);
            // write every candidate, advance on a hit
            let w = list.len();
            list.resize(w + (e - s), 0);
            let out = &mut list[w..];
            let mut m = 0usize;
            for (t, (xb, &fb)) in (s..e).zip(xs[s * D..e * D].chunks_exact(D).zip(&fl[s..e])) {
                let mut d2 = 0.0;
                for (xa, xb) in it.xa.iter().zip(xb) {
                    let d = xa - xb;
                    d2 += d * d;
                }
                let both = it.fa | fb;
                let near = match reach.get(t) {
                    Some(r) => d2 < (it.ra + r) * (it.ra + r),
                    None => d2 < r2max,
                };
                let keep = near & (fb & ELIGIBLE != 0) & (both & FLUID != 0) & (both & OWNED != 0);
                out[m] = t as u32;
                m += keep as usize;
            }
            list.truncate(w + m);
        }
    }

    /// Run `home(k, window)` for every slot k, in four phases (module docs); `acc` is reset
    /// to `stride` entries of `zero` per slot first. A home may write the entries of its own
    /// slot and of its partners'.
    pub fn run<A: Copy + Send + Sync>(
        &self,
        acc: &mut Vec<A>,
        stride: usize,
        zero: A,
        home: impl Fn(usize, &mut Window<'_, A>) + Sync,
    ) {
        let slots = self.half.slots;
        acc.clear();
        acc.resize(slots * stride, zero);
        let (nx, ny) = (self.grid.dims[0], self.grid.dims[1]);
        // first slot of row (x, y); y = ny is the next plane's first row
        let row = |x: usize, y: usize| self.half.rows[x * ny + y];
        // planes and blocks are counted from the first margin cell, so a deeper margin
        // (`CellGrid::with_reach`) runs every pair in the same phase: the same bits
        let [ex, ey] = [0, 1].map(|a| self.grid.extra_margin(a));
        // blocks b = first..last cover rows ey + b·B … ey + (b+1)·B − 1, clipped to the grid
        let first = -(ey.div_ceil(BLOCK) as i64);
        let last = ((ny - 1 - ey) / BLOCK) as i64;
        let mut spans = Vec::new();
        for phase in 0..4 {
            let (px, py) = (phase & 1, phase >> 1);
            let mut windows = Vec::new();
            let mut rest: &mut [A] = acc;
            let mut at = 0usize;
            for x in (0..nx).filter(|x| (x + ex) % 2 == px) {
                // (homes, rows written in plane x, rows written in plane x + 1)
                spans.clear();
                for b in (first..=last).filter(|b| b.rem_euclid(2) as usize == py) {
                    let start = ey as i64 + b * BLOCK as i64;
                    let y0 = start.max(0) as usize;
                    let y1 = ((start + BLOCK as i64) as usize).min(ny);
                    let homes = row(x, y0)..row(x, y1);
                    if homes.is_empty() {
                        continue;
                    }
                    let top = (y1 + 1).min(ny);
                    let next = if x + 1 < nx {
                        row(x + 1, y0.saturating_sub(1))..row(x + 1, top)
                    } else {
                        usize::MAX..usize::MAX
                    };
                    spans.push((homes.clone(), homes.start..row(x, top), next));
                }
                // the windows' pieces in memory order: plane x's, then plane x + 1's
                let mut own = Vec::with_capacity(spans.len());
                for (_, r, _) in &spans {
                    own.push(take(&mut rest, &mut at, r, stride));
                }
                for ((homes, r, n), a) in spans.iter().zip(own) {
                    let b = if n.start == usize::MAX {
                        &mut [][..]
                    } else {
                        take(&mut rest, &mut at, n, stride)
                    };
                    windows.push((
                        homes.clone(),
                        Window {
                            a_base: r.start,
                            a,
                            b_base: n.start,
                            b,
                            stride,
                        },
                    ));
                }
            }
            // one task per block: the work sits in a few blocks (the water), which rayon's
            // default split into halves would hand to one thread
            windows.par_iter_mut().with_max_len(1).for_each(|(homes, w)| {
                for k in homes.clone() {
                    home(k, w);
                }
            });
        }
    }

    /// True if slot `s` is an owned particle.
    #[inline(always)]
    pub fn owned(&self, s: usize) -> bool {
        self.half.flags[s] & OWNED != 0
    }
}

/// One home's partners found by scanning (lean mode, and the list build).
pub struct HalfScan<'a, const D: usize> {
    view: HalfView<'a, D>,
    xa: [f64; D],
    /// κ h / 2 of the home (particles of several sizes; 0 otherwise).
    ra: f64,
    fa: u8,
    k: usize,
    c: [usize; D],
    row: usize,
    rows: usize,
    t: usize,
    e: usize,
}

impl<const D: usize> HalfScan<'_, D> {
    /// Move to the next stencil row with slots above the home's; false when there is none.
    fn next_row(&mut self) -> bool {
        let cells = self.view.cells;
        while self.row < self.rows {
            let row = self.row;
            self.row += 1;
            let Some((c0, c1)) = self.view.grid.stencil_run(&self.c, row) else {
                continue;
            };
            let e = cells.start[c1] as usize;
            if e <= self.k + 1 || self.view.no_partner_in(self.fa, c0, c1) {
                continue;
            }
            self.t = (cells.start[c0] as usize).max(self.k + 1);
            self.e = e;
            return true;
        }
        false
    }
}

impl<const D: usize> Iterator for HalfScan<'_, D> {
    type Item = u32;

    #[inline]
    fn next(&mut self) -> Option<u32> {
        let fl = &self.view.half.flags;
        let xs = &self.view.nl.xs;
        let r2max = self.view.nl.r2max;
        let reach = &self.view.nl.reach;
        loop {
            while self.t < self.e {
                let t = self.t;
                self.t += 1;
                let fb = fl[t];
                let mut d2 = 0.0;
                for a in 0..D {
                    let d = self.xa[a] - xs[t * D + a];
                    d2 += d * d;
                }
                let both = self.fa | fb;
                let near = match reach.get(t) {
                    Some(r) => d2 < (self.ra + r) * (self.ra + r),
                    None => d2 < r2max,
                };
                if near & (fb & ELIGIBLE != 0) & (both & FLUID != 0) & (both & OWNED != 0) {
                    return Some(t as u32);
                }
            }
            if !self.next_row() {
                return None;
            }
        }
    }
}
