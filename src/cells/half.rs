//! Pair mode's half lists, in a canonical order (`physics::pairs`).
//!
//! Every particle the rank holds (owned and ghost) has a **slot**: its place in the cell
//! order of [`CellList::order`] (cells linear with axis 0 slowest, ascending key within a
//! cell). Slot order is a global order — a function of positions and ids only — so two
//! particles compare the same way on every rank that holds both. Each pair is listed once,
//! under the particle of the lower slot (its **home**), when the pair is within the support and
//! at least one of the two is owned, and either both are solids (solids interact with solids
//! only) or neither is and at least one is fluid (walls interact with fluid only). A fluid or
//! solid slot **receives**: it has an accumulator entry ([`HalfView::entry`]).
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
const SOLID: u8 = 1;
const FLUID: u8 = 2;
const OWNED: u8 = 4;
/// The slots that receive a share of their pairs: fluid and solid.
const RECEIVES: u8 = FLUID | SOLID;

/// The canonical half lists (stored) or what a list-free scan needs (lean mode).
#[derive(Debug, Clone, Default)]
pub struct HalfPairs {
    /// Partner slots of homes k·[`CHUNK`] .. (k+1)·[`CHUNK`], one list after the other, each
    /// list delta-encoded ([`encode_run`]): about 1 B per partner instead of 4.
    chunks: Vec<Vec<u8>>,
    /// Start of slot k's partners within its chunk (in bytes).
    offset: Vec<u32>,
    /// Slots listed (owned + ghosts), 0 when not built.
    slots: usize,
    /// Flag bits per slot ([`SOLID`], [`FLUID`], [`OWNED`]).
    flags: Vec<u8>,
    /// Receiving slots before slot k (one entry per slot plus one), the accumulator entries,
    /// when the particles hold a solid; empty otherwise (the fluid counts of the
    /// [`NeighbourList`] are then the entries).
    entry_before: Vec<u32>,
    /// First slot of each row of cells (axis-0 and axis-1 coordinates), one per row plus one.
    rows: Vec<usize>,
    /// Partners listed in all.
    pairs: usize,
}

impl HalfPairs {
    /// Bytes the half lists hold, by capacity.
    pub(super) fn bytes_held(&self) -> usize {
        use super::held;
        let chunks: usize = self.chunks.iter().map(held).sum();
        chunks
            + held(&self.chunks)
            + held(&self.offset)
            + held(&self.flags)
            + held(&self.rows)
            + held(&self.entry_before)
    }

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
                    let solid = if k.is_solid() { SOLID } else { 0 };
                    let fluid = if k.is_fluid() { FLUID } else { 0 };
                    let owned = if j < n { OWNED } else { 0 };
                    *f = solid | fluid | owned;
                }
            });
        self.entry_before.clear();
        if self.flags.iter().any(|f| f & SOLID != 0) {
            self.entry_before.reserve(slots + 1);
            self.entry_before.push(0);
            let mut acc = 0u32;
            for f in &self.flags {
                acc += u32::from(f & RECEIVES != 0);
                self.entry_before.push(acc);
            }
        }
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
            self.pairs = chunks
                .par_iter_mut()
                .zip(offset.par_chunks_mut(CHUNK))
                .enumerate()
                .map(|(ci, (list, offs))| {
                    list.clear();
                    let mut pairs = 0;
                    for (k, off) in offs.iter_mut().enumerate() {
                        *off = list.len() as u32;
                        pairs += view.append(ci * CHUNK + k, list);
                    }
                    pairs
                })
                .sum();
        }
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

    /// Partners of home slot `k` (stored lists).
    #[inline]
    pub(super) fn stored(&self, k: usize) -> Stored<'_> {
        let (c, r) = (k / CHUNK, k % CHUNK);
        let list = &self.chunks[c];
        let s = self.offset[k] as usize;
        let e = if r + 1 < CHUNK && k + 1 < self.slots {
            self.offset[k + 1] as usize
        } else {
            list.len()
        };
        Stored {
            units: list[s..e].iter(),
            prev: k as u32,
        }
    }
}

/// Append to `out` the candidates of slots `s ..` (one item of `cand` each) for which
/// `keep(t, item)` holds, each as its distance from the previous partner (`prev`, the home's
/// slot before its first partner) in one byte — or, for a distance of 256 or more (the first
/// partner of a stencil row, a jump within a long row), an escape ([`encoded`]). Distances are
/// at least 1, so 0 is free to mark the escape. Returns how many were kept.
///
/// Branch-free for a row of fewer than 256 candidates: every candidate is written at the end,
/// counted from the slot before the row (or the last kept one), and the end advances on a
/// keep, so no distance within the row overflows; only the row's first partner is then
/// re-measured from `prev`. A longer row (dense cells of a refined region) takes a branch per
/// kept partner.
#[inline(always)]
fn encode_run<I: ExactSizeIterator>(
    prev: &mut u32,
    s: usize,
    out: &mut Vec<u8>,
    cand: I,
    keep: impl Fn(usize, I::Item) -> bool,
) -> usize {
    let n = cand.len();
    let w = out.len();
    if n > usize::from(u8::MAX) {
        let mut m = 0;
        for (t, item) in (s..s + n).zip(cand) {
            if keep(t, item) {
                let t = t as u32;
                let (e, len) = encoded(t - *prev, t);
                out.extend_from_slice(&e[..len]);
                *prev = t;
                m += 1;
            }
        }
        return m;
    }
    out.resize(w + n, 0);
    let body = &mut out[w..];
    let (mut m, mut last) = (0usize, s as u32 - 1);
    for (t, item) in (s..s + n).zip(cand) {
        let hit = keep(t, item);
        body[m] = (t as u32 - last) as u8;
        last = if hit { t as u32 } else { last };
        m += usize::from(hit);
    }
    out.truncate(w + m);
    if m > 0 {
        let first = s as u32 - 1 + u32::from(out[w]);
        match encoded(first - *prev, first) {
            (e, 1) => out[w] = e[0],
            (e, len) => {
                out.splice(w..w + 1, e[..len].iter().copied());
            }
        }
        *prev = last;
    }
    m
}

/// The units of a partner at slot `t`, `d` ≥ 1 slots after the previous one: `d` in one byte
/// if it fits; else an escape, a 0 and then `d` in two bytes (low first) if it fits, or two
/// 0 bytes and the slot `t` itself in four bytes (low first). Returns the bytes and how many
/// of them to write (1, 3 or 7).
#[inline]
fn encoded(d: u32, t: u32) -> ([u8; 7], usize) {
    if let Ok(d) = u8::try_from(d) {
        return ([d, 0, 0, 0, 0, 0, 0], 1);
    }
    match u16::try_from(d) {
        Ok(d) => {
            let [a, b] = d.to_le_bytes();
            ([0, a, b, 0, 0, 0, 0], 3)
        }
        Err(_) => {
            let [a, b, c, e] = t.to_le_bytes();
            ([0, 0, 0, a, b, c, e], 7)
        }
    }
}

/// One home's stored partner slots, decoded ([`encode_run`]), ascending.
#[derive(Clone)]
pub struct Stored<'a> {
    units: std::slice::Iter<'a, u8>,
    prev: u32,
}

impl Stored<'_> {
    /// The slot an escape ([`encoded`]) after its 0 byte names.
    #[inline]
    fn escaped(&mut self) -> u32 {
        let mut byte = |shift: u32| u32::from(self.units.next().copied().unwrap_or(0)) << shift;
        let d = byte(0) | byte(8);
        if d != 0 {
            self.prev + d
        } else {
            byte(0) | byte(8) | byte(16) | byte(24)
        }
    }
}

impl Iterator for Stored<'_> {
    type Item = u32;

    #[inline(always)]
    fn next(&mut self) -> Option<u32> {
        let d = *self.units.next()?;
        self.prev = if d != 0 {
            self.prev + u32::from(d)
        } else {
            self.escaped()
        };
        Some(self.prev)
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

/// The accumulator entries one block of homes may write: entries `a_base ..` (the receiving slots
/// of its rows of plane X and the row above) and `b_base ..` (those of the rows of plane X + 1
/// beside them), `stride` values each. Only receiving (fluid and solid) slots have an entry.
pub struct Window<'w, A> {
    a_base: usize,
    a: &'w mut [A],
    b_base: usize,
    b: &'w mut [A],
    stride: usize,
    /// Entry of each slot, one per slot plus one: the receiving slots before it. Only fluid
    /// and solid slots receive in the pair passes, so [`HalfView::run`]'s accumulators hold
    /// one entry per such slot (half the slots or fewer in a walled tank); the count rises
    /// with the slot, so the blocks' disjoint slot ranges stay disjoint entry ranges.
    entry: &'w [u32],
}

/// The next entries `r` of `rest` (which starts at entry `at`), `stride` values each.
fn take<'s, A>(rest: &mut &'s mut [A], at: &mut usize, r: &Range<usize>, stride: usize) -> &'s mut [A] {
    let (_, tail) = std::mem::take(rest).split_at_mut((r.start - *at) * stride);
    let (mid, tail) = tail.split_at_mut((r.end - r.start) * stride);
    *rest = tail;
    *at = r.end;
    mid
}

impl<A> Window<'_, A> {
    /// Entry of receiving slot `s` (a wall slot has none).
    #[inline(always)]
    fn entry_of(&self, s: usize) -> usize {
        debug_assert!(self.entry[s + 1] > self.entry[s], "slot {s} receives nothing");
        self.entry[s] as usize
    }

    /// The value of receiving slot `s` of a one-value-per-entry accumulator.
    #[inline(always)]
    pub fn one(&mut self, s: usize) -> &mut A {
        debug_assert_eq!(self.stride, 1);
        let e = self.entry_of(s);
        if e < self.b_base {
            &mut self.a[e - self.a_base]
        } else {
            &mut self.b[e - self.b_base]
        }
    }

    /// The `stride` values of receiving slot `s`.
    #[inline(always)]
    pub fn at(&mut self, s: usize) -> &mut [A] {
        let (st, e) = (self.stride, self.entry_of(s));
        if e < self.b_base {
            &mut self.a[(e - self.a_base) * st..][..st]
        } else {
            &mut self.b[(e - self.b_base) * st..][..st]
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

    /// Accumulator entry of fluid or solid particle `i` (where [`HalfView::run`] left its
    /// sums).
    #[inline(always)]
    pub fn entry(&self, i: usize) -> usize {
        self.entries()[self.slot(i)] as usize
    }

    /// Receiving slots before each slot: the entries of [`HalfView::run`]'s accumulator.
    #[inline(always)]
    fn entries(&self) -> &'a [u32] {
        if self.half.entry_before.is_empty() {
            &self.nl.fluid_before
        } else {
            &self.half.entry_before
        }
    }

    /// True if slot `s` holds a solid particle (its pairs are with solids only).
    #[inline(always)]
    pub fn solid(&self, s: usize) -> bool {
        self.half.flags[s] & SOLID != 0
    }

    /// The stored partner slots of home slot `k`, ascending; `None` in lean mode (use
    /// [`HalfView::scan`]).
    #[inline]
    pub fn stored(&self, k: usize) -> Option<Stored<'a>> {
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
            buf: [0; BATCH],
            i: 0,
            n: 0,
        };
        // every slot may be a home: a fluid or solid one, or a wall with fluid partners
        let xs = &self.nl.xs;
        it.xa.copy_from_slice(&xs[k * D..k * D + D]);
        it.c = self
            .grid
            .coords_of(self.cells.cell[self.cells.order[k] as usize] as usize);
        it.rows = 3usize.pow(D as u32 - 1);
        it
    }

    /// True if cells `c0 .. c1` can hold no partner of a home with flags `fa`: a wall home
    /// pairs with fluid only (most wall particles lie far from the water).
    #[inline]
    fn no_partner_in(&self, fa: u8, c0: usize, c1: usize) -> bool {
        let (st, fb) = (&self.cells.start, &self.nl.fluid_before);
        fa & RECEIVES == 0 && fb[st[c1] as usize] == fb[st[c0] as usize]
    }

    /// True if slot `t` (position `xb`, flags `fb`) is a partner of a home with flags `fa`,
    /// reach `ra` and position `xa`: within the support, both solid or neither, one of the two
    /// receiving and one owned (the rule of the module docs). No branch on the outcome.
    #[inline(always)]
    fn keeps(&self, fa: u8, ra: f64, xa: &[f64; D], t: usize, xb: &[f64], fb: u8) -> bool {
        let mut d2 = 0.0;
        for (xa, xb) in xa.iter().zip(xb) {
            let d = xa - xb;
            d2 += d * d;
        }
        let both = fa | fb;
        let near = match self.nl.reach.get(t) {
            Some(&r) => {
                let s = super::pair_reach(ra, r, self.nl.reach_larger);
                d2 < s * s
            }
            None => d2 < self.nl.r2max,
        };
        near & ((fa ^ fb) & SOLID == 0) & (both & RECEIVES != 0) & (both & OWNED != 0)
    }

    /// Append home slot `k`'s partners to `list`, delta-encoded ([`encode_run`]), and return
    /// how many (the list build: what [`HalfView::scan`] finds, with a branch-free append per
    /// stencil row).
    fn append(&self, k: usize, list: &mut Vec<u8>) -> usize {
        let it = self.scan(k);
        if it.rows == 0 {
            return 0;
        }
        let (fl, xs, cells) = (&self.half.flags, &self.nl.xs, self.cells);
        let (mut prev, mut pairs) = (k as u32, 0);
        for row in 0..it.rows {
            let Some((c0, c1)) = self.grid.stencil_run(&it.c, row) else {
                continue;
            };
            let e = cells.start[c1] as usize;
            if e <= k + 1 || self.no_partner_in(it.fa, c0, c1) {
                continue;
            }
            let s = (cells.start[c0] as usize).max(k + 1);
            let cand = xs[s * D..e * D].chunks_exact(D).zip(&fl[s..e]);
            pairs += encode_run(&mut prev, s, list, cand, |t, (xb, &fb)| {
                self.keeps(it.fa, it.ra, &it.xa, t, xb, fb)
            });
        }
        pairs
    }

    /// Run `home(k, window)` for every slot k, in four phases (module docs); `acc` is reset
    /// to `stride` values of `zero` per receiving slot first ([`HalfView::entry`] finds them).
    /// A home may write the values of its own slot and of its partners', receiving slots only.
    pub fn run<A: Copy + Send + Sync>(
        &self,
        acc: &mut Vec<A>,
        stride: usize,
        zero: A,
        home: impl Fn(usize, &mut Window<'_, A>) + Sync,
    ) {
        let entry = self.entries();
        let len = entry[self.half.slots] as usize * stride;
        acc.clear();
        // exactly what the largest pass needs: passes of several strides share the buffer, and
        // growth by doubling would hold up to twice the largest
        acc.reserve_exact(len);
        acc.resize(len, zero);
        // the entries of a range of slots
        let entries = |r: Range<usize>| entry[r.start] as usize..entry[r.end] as usize;
        let (nx, ny) = (self.grid.dims[0], self.grid.dims[1]);
        // first slot of row (x, y); y = ny is the next plane's first row
        let row = |x: usize, y: usize| self.half.rows[x * ny + y];
        // planes and blocks are counted from the first margin cell, so a deeper margin
        // (`CellGrid::with_reach`) or a window (`CellGrid::window`, which may start past that
        // cell: ey < 0) runs every pair in the same phase: the same bits
        let [ex, ey] = [0, 1].map(|a| self.grid.extra_margin(a) as i64);
        // blocks b = first..last cover rows ey + b·B … ey + (b+1)·B − 1, clipped to the grid:
        // the blocks of rows 0 and ny − 1
        let first = (-ey).div_euclid(BLOCK as i64);
        let last = (ny as i64 - 1 - ey).div_euclid(BLOCK as i64);
        let mut spans = Vec::new();
        for phase in 0..4 {
            let (px, py) = (phase & 1, phase >> 1);
            let mut windows = Vec::new();
            let mut rest: &mut [A] = acc;
            let mut at = 0usize;
            for x in (0..nx).filter(|&x| (x as i64 + ex).rem_euclid(2) as usize == px) {
                // (homes, rows written in plane x, rows written in plane x + 1)
                spans.clear();
                for b in (first..=last).filter(|b| b.rem_euclid(2) as usize == py) {
                    let start = ey + b * BLOCK as i64;
                    let y0 = start.max(0) as usize;
                    let y1 = ((start + BLOCK as i64) as usize).min(ny);
                    let homes = row(x, y0)..row(x, y1);
                    if homes.is_empty() {
                        continue;
                    }
                    let top = (y1 + 1).min(ny);
                    let next = if x + 1 < nx {
                        entries(row(x + 1, y0.saturating_sub(1))..row(x + 1, top))
                    } else {
                        usize::MAX..usize::MAX
                    };
                    spans.push((homes.clone(), entries(homes.start..row(x, top)), next));
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
                            entry,
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

/// Candidates a lean scan tests per refill of its buffer (a power of two).
const BATCH: usize = 64;

/// One home's partners found by scanning (lean mode, and the list build).
///
/// The candidates of a stencil row are tested [`BATCH`] at a time without a branch on the
/// outcome (each is written to the buffer, the end advances on a keep), then yielded from the
/// buffer: a kept pair is a coin toss in a row of cells, which a branch per candidate
/// mispredicts.
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
    /// Next candidate slot of the current row, and the row's end.
    t: usize,
    e: usize,
    /// Partners of the last refill: `buf[i..n]` are still to be yielded.
    buf: [u32; BATCH],
    i: usize,
    n: usize,
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

    /// Test the next [`BATCH`] candidates of the current row into the buffer.
    #[inline(always)]
    fn refill(&mut self) {
        let v = self.view;
        let end = self.e.min(self.t + BATCH);
        let mut m = 0;
        for t in self.t..end {
            let xb = &v.nl.xs[t * D..t * D + D];
            let hit = v.keeps(self.fa, self.ra, &self.xa, t, xb, v.half.flags[t]);
            self.buf[m & (BATCH - 1)] = t as u32;
            m += usize::from(hit);
        }
        (self.t, self.i, self.n) = (end, 0, m);
    }
}

impl<const D: usize> Iterator for HalfScan<'_, D> {
    type Item = u32;

    #[inline]
    fn next(&mut self) -> Option<u32> {
        loop {
            if self.i < self.n {
                let t = self.buf[self.i];
                self.i += 1;
                return Some(t);
            }
            if self.t >= self.e && !self.next_row() {
                return None;
            }
            self.refill();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{encode_run, Stored};

    /// Rows of candidates encoded one after the other decode to exactly the kept slots:
    /// distances of one and of 255 (the largest in one byte) within a row, of 256 (the first
    /// two-byte escape) across rows, of 2¹⁶ − 1 and 2¹⁶ (the slot escape), a jump up to the top
    /// of the slot range, an empty row, and rows of more than 255 candidates (the branchy path:
    /// partners 1, 255, 256 and 2¹⁶ apart within the row).
    #[test]
    fn delta_lists_decode_to_the_slots_kept() {
        let k = 5u32;
        let top = u32::MAX as usize;
        let rows = [
            (6, 10),
            (10, 266),
            (521, 530),
            (66_000, 66_010),
            (131_535, 131_600),
            (200_000, 200_100),
            (300_000, 400_000),
            (top - 3, top),
            (top, top + 1),
        ];
        let picked = [
            6, 7, 10, 265, 521, 66_000, 131_535, 131_536, 200_050, 300_000, 300_001, 300_256, 300_512,
            366_048,
        ];
        let kept = |t: usize| picked.contains(&t) || t >= top - 1;
        let (mut units, mut prev, mut pairs, mut want) = (Vec::new(), k, 0, Vec::new());
        for (s, e) in rows {
            pairs += encode_run(&mut prev, s, &mut units, s..e, |t, _| kept(t));
            want.extend((s..e).filter(|&t| kept(t)).map(|t| t as u32));
        }
        assert_eq!(pairs, want.len());
        let got: Vec<u32> = Stored {
            units: units.iter(),
            prev: k,
        }
        .collect();
        assert_eq!(got, want);
        // one byte each: 6, 7, 10, 265 (255 after 10), 131 536, 300 001, 300 256 (255 after
        // 300 001) and the top; three: 521 (256 after 265), 66 000, 131 535 (2^16 − 1 after
        // 66 000) and 300 512 (256 after 300 256); seven: 200 050, 300 000, 366 048 (2^16 after
        // 300 512) and top − 1
        assert_eq!(units.len(), 8 + 3 * 4 + 7 * 4);
    }
}
