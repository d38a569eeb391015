//! Neighbour search: a cell linked list built by counting sort (seed 004), and the per-particle
//! neighbour lists used by every gather pass.
//!
//! Cells are anchored to the global domain origin, with edge ≥ the kernel support radius
//! (each axis holds a whole number of cells, so periodic images land on cell boundaries), plus
//! one margin cell on each side for ghosts. A pair interacts when `r < support` (strict); the
//! brute-force oracle [`brute_force`] uses the same convention. A rank bins its particles in
//! the window of that grid they occupy ([`CellGrid::window`]): the same cells, so the same
//! order, at the cost of its occupied box rather than the whole domain.
//!
//! **Order.** Particle i visits the 3ᴰ cells around its own in a fixed order of relative
//! offsets, and within a cell its neighbours in ascending sort key (`id`, image code; by
//! sub-cell first where particles of several sizes cut the cells, [`CellList::with_sub_cells`]). The
//! order therefore depends only on global positions and ids, never on local indices, so
//! sums come out bit-identical whatever the thread or rank count.

use crate::particles::Particles;
use crate::Vector;
use rayon::prelude::*;

mod half;
mod sized;
mod verlet;
pub use half::{HalfPairs, HalfView, Stored, Window};
pub use verlet::{Kept, Near};

/// The global cell grid, or a window of it ([`CellGrid::window`]): the same cells, fewer of
/// them.
#[derive(Debug, Clone)]
pub struct CellGrid<const D: usize> {
    /// Corner of the first margin cell next to the domain (domain min − one edge) (m); a
    /// deeper margin ([`CellGrid::with_reach`]) adds `extra` cells before it.
    pub origin: Vector<D>,
    /// Index of that first margin cell along each axis: the margin cells beyond the first
    /// (0 for [`CellGrid::new`]), less the cells a window leaves out before its own first
    /// (negative when the window starts past it).
    extra: [isize; D],
    /// Cell edge per axis (m), ≥ the support radius.
    pub edge: Vector<D>,
    inv_edge: Vector<D>,
    /// Cells per axis, margins included.
    pub dims: [usize; D],
}

impl<const D: usize> CellGrid<D> {
    /// Grid over `[min, max)` with cells no smaller than `support` and one margin cell on
    /// each side.
    pub fn new(min: &Vector<D>, max: &Vector<D>, support: f64) -> Self {
        Self::with_reach(min, max, support, support)
    }

    /// Grid over `[min, max)` with cells no smaller than `support` and margins of whole cells
    /// at least `reach` (m) deep on each side, so that a ghost within `reach` of the domain
    /// has a cell (a ghost set with a skin reaches support + skin). The margins only add
    /// cells around the domain: the cells of [`CellGrid::new`] keep their order.
    pub fn with_reach(min: &Vector<D>, max: &Vector<D>, support: f64, reach: f64) -> Self {
        let mut dims = [0usize; D];
        let mut edge = Vector::zeros();
        let mut extra = [0isize; D];
        for a in 0..D {
            let len = max[a] - min[a];
            let n = ((len / support).floor() as usize).max(1);
            edge[a] = len / n as f64;
            let deeper = ((reach / edge[a]).ceil() as usize).max(1) - 1;
            extra[a] = deeper as isize;
            dims[a] = n + 2 + 2 * deeper;
        }
        CellGrid {
            origin: min - edge,
            extra,
            edge,
            inv_edge: edge.map(|e| 1.0 / e),
            dims,
        }
    }

    /// Index along axis `a` of the first margin cell next to the domain: the margin cells
    /// beyond the first on each side ([`CellGrid::with_reach`]), less a window's offset
    /// ([`CellGrid::window`]). Counting planes from it gives every grid and window the same
    /// parities.
    pub fn extra_margin(&self, a: usize) -> isize {
        self.extra[a]
    }

    /// The window of this grid that holds the particles at `x`: the cells from the lowest
    /// to the highest occupied along each axis. Its cells are this grid's, with the same
    /// bounds and the same order ([`CellGrid::coords`] puts a point in the same cell, and
    /// a stencil visits the same occupied cells in the same order), but a domain mostly
    /// empty (a debris cloud's) costs only its occupied box. Points outside the grid are
    /// left out (binning them fails as it would on the whole grid); with none inside, the
    /// window is the grid's first cell.
    pub fn window(&self, x: &[Vector<D>]) -> CellGrid<D> {
        let none = ([usize::MAX; D], [0usize; D]);
        let (lo, hi) = x
            .par_iter()
            .fold(
                || none,
                |(mut lo, mut hi), x| {
                    if let Some(c) = self.coords(x) {
                        for a in 0..D {
                            lo[a] = lo[a].min(c[a]);
                            hi[a] = hi[a].max(c[a]);
                        }
                    }
                    (lo, hi)
                },
            )
            .reduce(
                || none,
                |(l0, h0), (l1, h1)| {
                    (
                        std::array::from_fn(|a| l0[a].min(l1[a])),
                        std::array::from_fn(|a| h0[a].max(h1[a])),
                    )
                },
            );
        let (lo, hi) = if lo[0] == usize::MAX {
            ([0; D], [0; D])
        } else {
            (lo, hi)
        };
        CellGrid {
            origin: self.origin,
            extra: std::array::from_fn(|a| self.extra[a] - lo[a] as isize),
            edge: self.edge,
            inv_edge: self.inv_edge,
            dims: std::array::from_fn(|a| hi[a] - lo[a] + 1),
        }
    }

    /// Total number of cells.
    pub fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// True if the grid has no cells (never, for a valid scene).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Lower corner (m) of the cell at coordinates `c`: the cell holds the points that
    /// [`CellGrid::coords`] maps to `c`, up to rounding.
    #[inline]
    pub fn cell_lo(&self, c: &[usize; D]) -> Vector<D> {
        Vector::from_fn(|a, _| self.origin[a] + (c[a] as f64 - self.extra[a] as f64) * self.edge[a])
    }

    /// Integer cell coordinates of `x`, or `None` outside the grid.
    #[inline]
    pub fn coords(&self, x: &Vector<D>) -> Option<[usize; D]> {
        let mut c = [0usize; D];
        for a in 0..D {
            // offset from the first margin cell, so a deeper margin assigns every point the
            // cell it has without one (same rounding, same order)
            let f = ((x[a] - self.origin[a]) * self.inv_edge[a]).floor() + self.extra[a] as f64;
            if !(f >= 0.0 && (f as usize) < self.dims[a]) {
                return None;
            }
            c[a] = f as usize;
        }
        Some(c)
    }

    /// The sub-cell of `x` within its cell when each cell is cut into `s` per axis: row-major,
    /// the last axis fastest (`s`ᴰ ≤ 256). It rounds as [`CellGrid::coords`] does, from the
    /// global origin, so every rank puts a particle in the same sub-cell.
    #[inline]
    pub fn sub_cell(&self, x: &Vector<D>, s: usize) -> u8 {
        let mut l = 0usize;
        for a in 0..D {
            // ⌊t⌋ as `coords` takes it (t < 0 in a deeper margin)
            let t = (x[a] - self.origin[a]) * self.inv_edge[a];
            let f = ((t - t.floor()) * s as f64) as usize;
            l = l * s + f.min(s - 1);
        }
        l as u8
    }

    /// Linear index of cell coordinates (axis 0 slowest).
    #[inline]
    pub fn linear(&self, c: &[usize; D]) -> usize {
        self.dims.iter().zip(c).fold(0, |l, (n, ca)| l * n + ca)
    }

    /// Cell coordinates of linear index `l` (the inverse of [`CellGrid::linear`]).
    #[inline]
    pub fn coords_of(&self, mut l: usize) -> [usize; D] {
        let mut c = [0usize; D];
        for a in (0..D).rev() {
            c[a] = l % self.dims[a];
            l /= self.dims[a];
        }
        c
    }

    /// Stencil row `row` (of the 3ᴰ⁻¹ offsets of the leading axes, lexicographic) around cell
    /// `c`: the linear cells `[c0, c1)`, the up to three cells along the last axis, which are
    /// contiguous; `None` where the row's leading offsets leave the grid.
    #[inline]
    pub fn stencil_run(&self, c: &[usize; D], row: usize) -> Option<(usize, usize)> {
        let last = D - 1;
        let dl = self.dims[last];
        let mut r = row;
        let mut cc = [0usize; D];
        for a in (0..last).rev() {
            let v = c[a] as isize + (r % 3) as isize - 1;
            r /= 3;
            if v < 0 || v as usize >= self.dims[a] {
                return None;
            }
            cc[a] = v as usize;
        }
        let mut base = 0usize;
        for (&ca, &da) in cc[..last].iter().zip(&self.dims[..last]) {
            base = base * da + ca;
        }
        base *= dl;
        let lo = c[last].saturating_sub(1);
        let hi = (c[last] + 1).min(dl - 1);
        Some((base + lo, base + hi + 1))
    }

    /// The 3ᴰ relative offsets in their fixed visiting order (lexicographic).
    pub fn stencil() -> Vec<[isize; D]> {
        let mut out = Vec::with_capacity(3usize.pow(D as u32));
        for k in 0..3usize.pow(D as u32) {
            let mut o = [0isize; D];
            let mut r = k;
            for a in (0..D).rev() {
                o[a] = (r % 3) as isize - 1;
                r /= 3;
            }
            out.push(o);
        }
        out
    }
}

/// Particles binned into cells: `order[start[c]..start[c+1]]` are the particles of cell `c`,
/// ascending by sort key, or with [`CellList::with_sub_cells`] ascending by (sub-cell, key).
#[derive(Debug, Clone, Default)]
pub struct CellList {
    /// Offsets into `order`, one per cell plus one.
    pub start: Vec<u32>,
    /// Particle indices grouped by cell.
    pub order: Vec<u32>,
    /// Cell of each particle.
    pub cell: Vec<u32>,
    /// Where each particle sits in `order`.
    pub slot: Vec<u32>,
    /// Sub-cells per axis of a cell (0: none): particles of several sizes.
    split: usize,
    /// Sub-cell of each particle within its cell (row-major, last axis fastest; empty without
    /// sub-cells).
    sub: Vec<u8>,
}

impl CellList {
    /// Bytes the cell list holds, by capacity (its per-cell starts span the whole grid).
    pub fn bytes_held(&self) -> usize {
        held(&self.start) + held(&self.order) + held(&self.cell) + held(&self.slot) + held(&self.sub)
    }
}

impl CellList {
    /// A cell list whose cells are cut into sub-cells about twice `smallest_reach` (m) wide,
    /// the smallest κh/2 of a scene of several sizes (at most [`sized::MAX_SPLIT`] per axis;
    /// none when that is one): each cell lists its particles by sub-cell, then by key, so a
    /// fine particle's candidates in a run of sub-cells are a run of slots (docs/benchmark-log.md,
    /// "Sized lists in the cell list's order"). The split is a function of the grid and the scene,
    /// the same on every rank, and so is the order.
    pub fn with_sub_cells<const D: usize>(grid: &CellGrid<D>, smallest_reach: f64) -> Self {
        let emin = grid.edge.iter().copied().fold(f64::INFINITY, f64::min);
        let s = if smallest_reach > 0.0 && smallest_reach.is_finite() {
            ((emin / (2.0 * smallest_reach)).floor() as usize).clamp(1, sized::MAX_SPLIT)
        } else {
            1
        };
        CellList {
            split: if s >= 2 { s } else { 0 },
            ..Default::default()
        }
    }

    /// Sub-cells per axis of a cell (0: none).
    pub fn sub_cell_split(&self) -> usize {
        self.split
    }

    /// Free every buffer, keeping the sub-cell split: the next [`CellList::build`] allocates
    /// them again.
    pub fn release(&mut self) {
        *self = CellList {
            split: self.split,
            ..Default::default()
        };
    }

    /// Bin all particles (owned and ghost). Returns the index of a particle outside the grid
    /// as an error.
    pub fn build<const D: usize>(&mut self, grid: &CellGrid<D>, p: &Particles<D>) -> Result<(), usize> {
        let n = p.len();
        self.cell.resize(n, 0);
        let bad = self
            .cell
            .par_iter_mut()
            .enumerate()
            .map(|(i, c)| match grid.coords(&p.x[i]) {
                Some(cc) => {
                    *c = grid.linear(&cc) as u32;
                    usize::MAX
                }
                None => i,
            })
            .min()
            .unwrap_or(usize::MAX);
        if bad != usize::MAX {
            return Err(bad);
        }
        let split = self.split;
        self.sub.clear();
        if split > 0 {
            self.sub
                .par_extend(p.x[..n].par_iter().map(|x| grid.sub_cell(x, split)));
        }
        // counting sort by cell
        let nc = grid.len();
        self.start.clear();
        self.start.resize(nc + 1, 0);
        for &c in &self.cell {
            self.start[c as usize + 1] += 1;
        }
        for c in 0..nc {
            self.start[c + 1] += self.start[c];
        }
        // each cell's start serves as its fill cursor and ends at the next cell's start;
        // shifting them back by one cell restores the starts (no cursor array per cell)
        self.order.resize(n, 0);
        for (i, &c) in self.cell.iter().enumerate() {
            let f = &mut self.start[c as usize];
            self.order[*f as usize] = i as u32;
            *f += 1;
        }
        self.start.copy_within(0..nc, 1);
        self.start[0] = 0;
        // ascending key (by sub-cell first, if cut) within each cell: the cells' runs of
        // `order`, found by comparing neighbours' cells (no list of slices is allocated)
        let (keys, sub, cell) = (&p.key, &self.sub, &self.cell);
        let cells = self
            .order
            .par_chunk_by_mut(|&a, &b| cell[a as usize] == cell[b as usize])
            .filter(|s| s.len() > 1);
        if split > 0 {
            cells.for_each(|s| s.sort_unstable_by_key(|&i| (sub[i as usize], keys[i as usize])));
        } else {
            cells.for_each(|s| s.sort_unstable_by_key(|&i| keys[i as usize]));
        }
        self.slot.resize(n, 0);
        for (k, &i) in self.order.iter().enumerate() {
            self.slot[i as usize] = k as u32;
        }
        Ok(())
    }
}

impl CellList {
    /// The interior of the owned particles (the first `n_owned`) into `interior`: `true` for a
    /// particle no ghost can be a neighbour of, because no cell of its 3ᴰ stencil holds a ghost
    /// (the cell edge is at least the support, so every neighbour lies in the stencil). Such a
    /// particle can be computed while the ghosts' fields are in flight. `near` is scratch, one
    /// flag per cell.
    pub fn mark_interior<const D: usize>(
        &self,
        grid: &CellGrid<D>,
        n_owned: usize,
        near: &mut Vec<bool>,
        interior: &mut Vec<bool>,
    ) {
        near.clear();
        near.resize(grid.len(), false);
        let rows = 3usize.pow(D as u32 - 1);
        let mut last = usize::MAX;
        for &c in &self.cell[n_owned..] {
            // ghosts arrive in runs from one source, often of one cell
            if c as usize == last {
                continue;
            }
            last = c as usize;
            let cc = grid.coords_of(last);
            for row in 0..rows {
                if let Some((c0, c1)) = grid.stencil_run(&cc, row) {
                    near[c0..c1].fill(true);
                }
            }
        }
        interior.clear();
        interior.extend(self.cell[..n_owned].iter().map(|&c| !near[c as usize]));
    }
}

/// Which neighbours a particle's list holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wants {
    /// No list (a particle no pass gathers for).
    Nothing,
    /// Every particle within the support.
    All,
    /// A fluid particle in pair mode (`physics::pairs`): no list of its own; its pairs are in
    /// the canonical half lists ([`HalfPairs`]), built over every particle held when any
    /// owned particle wants them.
    Half,
    /// Fluid particles only: a dummy wall particle, whose only pass (the extrapolation of
    /// `boundary::dummy`) reads fluid neighbours. Its list is a fraction of a full one, and
    /// a wall particle with no fluid in its stencil cells tests no candidate at all.
    Fluid,
}

/// Neighbour lists of the owned particles: for particle i, the indices j (owned or ghost) with
/// `|x_i − x_j| < support`, j ≠ i (fluid j only where i [`Wants::Fluid`]), in the fixed order
/// described in the module docs.
#[derive(Debug, Clone, Default)]
pub struct NeighbourList {
    /// The lists of owned particles k·[`CHUNK`] .. (k+1)·[`CHUNK`], one after the other, as
    /// the build task of that block wrote them (no copy into one array).
    chunks: Vec<Vec<u32>>,
    /// Start of particle i's list within its block's chunk.
    offset: Vec<u32>,
    /// List entries in the blocks before block k (one entry per block plus one).
    before: Vec<usize>,
    /// Owned particles listed.
    n: usize,
    /// Positions in cell order (`xs[k·D + a]` = axis a of particle `order[k]`): the candidates
    /// of one stencil row are contiguous here.
    xs: Vec<f64>,
    /// 1 for a fluid particle, in cell order like `xs`.
    fluid: Vec<u8>,
    /// Fluid particles in the slots before slot k (one entry per slot plus one): the fluid in
    /// a run of cells, `fluid_before[start[c1]] − fluid_before[start[c0]]`, without looking at
    /// it. Per slot rather than per cell, so that a domain mostly empty (a debris cloud's)
    /// costs nothing per empty cell.
    fluid_before: Vec<u32>,
    /// Lean mode (`[performance] neighbours = "cells"`): no lists are stored; a pass scans
    /// the stencil cells of each particle as it goes ([`CellScan`]), in the same order.
    lean: bool,
    /// What each owned particle wants (lean mode), as a scan mode.
    wants: Vec<u8>,
    /// Support radius squared (m²) of the last build.
    r2max: f64,
    /// Particles of several smoothing lengths: half the kernel support per unit h (κ/2), 0 in
    /// a scene of one h (κ with the larger h of a pair). A pair of several sizes is listed only
    /// within its own support ([`pair_reach`]): |x_ij| < r_i + r_j = κ (h_i + h_j)/2 for the
    /// mean h, |x_ij| < max(r_i, r_j) = κ max(h_i, h_j) for the larger, so a fine particle's
    /// list does not hold the coarse support's candidates (docs/refinement.md §1).
    reach_per_h: f64,
    /// True if a pair's reach is the larger of its two reaches (`with_sizes`), not their sum.
    reach_larger: bool,
    /// κ h_i / 2 of every particle in cell order (like `xs`; empty in a scene of one h).
    reach: Vec<f64>,
    /// Sub-cells of the occupied cells (particles of several sizes, stored lists): a fine
    /// particle's candidates come from near it (`sized`; the same lists).
    sub: sized::SubCells,
    /// False to list particles of several sizes by the coarse scan (tests compare the two).
    no_sub_cells: bool,
    /// Pair mode's half lists (built when some owned particle wants [`Wants::Half`]).
    half: HalfPairs,
    /// True if the last build made half lists.
    has_half: bool,
    /// Verlet lists (`verlet`): the support squared (m²) within which a pass keeps a listed
    /// pair of the current positions; 0 for lists built every step.
    within2: f64,
}

/// Particles per block of the parallel neighbour-list build.
const CHUNK: usize = 512;

/// [`Wants`] as a const parameter of the candidate scan, so that each kind of list gets a
/// loop with only its own test.
const ALL: u8 = 0;
const FLUID: u8 = 1;
const NOTHING: u8 = 3;

impl Wants {
    /// The scan mode of this kind of list.
    fn mode(self) -> u8 {
        match self {
            Wants::All => ALL,
            Wants::Fluid => FLUID,
            Wants::Half | Wants::Nothing => NOTHING,
        }
    }
}

/// What a pass asks of the neighbour search: particle i's neighbours in the fixed order of
/// the module docs, and a measure of the work before particle i (to split the particles
/// into tasks of equal work). Stored lists ([`NeighbourList`]) and the list-free scan
/// ([`CellScan`]) give the same neighbours in the same order, so the same bits.
pub trait Neighbours: Sync {
    /// The iterator over one particle's neighbours (indices, owned or ghost).
    type Iter<'a>: Iterator<Item = u32>
    where
        Self: 'a;
    /// Neighbours of owned particle `i`.
    fn iter(&self, i: usize) -> Self::Iter<'_>;
    /// Work of the owned particles before `i`: list entries, or particles without lists.
    fn work_before(&self, i: usize) -> usize;
    /// True if a pass computes owned particle `i` now: every particle, unless the source is a
    /// [`Subset`] (the interior while ghosts are in flight, then the rest). A kernel leaves a
    /// particle it does not visit as it was.
    #[inline(always)]
    fn visits(&self, _i: usize) -> bool {
        true
    }
}

/// The neighbours of a part of the owned particles: those whose `mask` entry equals `part`.
/// Running a pass over `Subset { part: true, .. }` then `Subset { part: false, .. }` gives the
/// bits of one run over every particle when the pass reads no field it writes
/// (`physics::passes::Pass::splits`): each particle's sum is its own, in the same order.
pub struct Subset<'a, N> {
    /// The neighbour source of every particle.
    pub all: &'a N,
    /// Per owned particle: which part it belongs to.
    pub mask: &'a [bool],
    /// The part visited.
    pub part: bool,
}

impl<N: Neighbours> Neighbours for Subset<'_, N> {
    type Iter<'b>
        = N::Iter<'b>
    where
        Self: 'b;
    #[inline(always)]
    fn iter(&self, i: usize) -> Self::Iter<'_> {
        self.all.iter(i)
    }
    fn work_before(&self, i: usize) -> usize {
        self.all.work_before(i)
    }
    #[inline(always)]
    fn visits(&self, i: usize) -> bool {
        self.mask[i] == self.part
    }
}

impl Neighbours for NeighbourList {
    type Iter<'a> = std::iter::Copied<std::slice::Iter<'a, u32>>;
    #[inline]
    fn iter(&self, i: usize) -> Self::Iter<'_> {
        self.of(i).iter().copied()
    }
    fn work_before(&self, i: usize) -> usize {
        self.entries_before(i)
    }
}

/// Bytes a vector holds by its capacity.
pub(crate) fn held<T>(v: &Vec<T>) -> usize {
    v.capacity() * std::mem::size_of::<T>()
}

/// Make room for `need` entries in a list chunk, growing its capacity by an eighth rather
/// than doubling it: chunks keep their capacity from one build to the next and the scan writes
/// ahead of the hits, so a doubled chunk stays resident at up to twice its entries (the 3D
/// dam break of 275 k particles held 93 MB of lists for 63 MB of entries; issue 85).
#[inline]
pub(crate) fn grow_list(list: &mut Vec<u32>, need: usize) {
    if list.capacity() < need {
        let target = need.max(list.capacity() + list.capacity() / 8).max(4096);
        list.reserve_exact(target - list.len());
    }
}

/// Append to `list` the candidates of one stencil row (`ord`, positions `xr`, fluid flags
/// `fr`) that are neighbours of particle `i` at `xa` for a list of kind `MODE`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn scan_row<const D: usize, const MODE: u8, const SIZED: bool>(
    list: &mut Vec<u32>,
    xa: &[f64; D],
    i: usize,
    r2max: f64,
    ord: &[u32],
    xr: &[f64],
    fr: &[u8],
    (ri, rr, larger): (f64, &[f64], bool),
) {
    // branch-free append: write every candidate, advance on a hit
    let w = list.len();
    grow_list(list, w + ord.len());
    list.resize(w + ord.len(), 0);
    let out = &mut list[w..];
    let mut m = 0usize;
    for (k, (xj, &j)) in xr.chunks_exact(D).zip(ord).enumerate() {
        let mut d2 = 0.0;
        for a in 0..D {
            let d = xa[a] - xj[a];
            d2 += d * d;
        }
        let ju = j as usize;
        let near = if SIZED {
            let s = pair_reach(ri, rr[k], larger);
            d2 < s * s
        } else {
            d2 < r2max
        };
        let keep = match MODE {
            ALL => near & (ju != i),
            _ => near & (ju != i) & (fr[k] != 0),
        };
        out[m] = j;
        m += keep as usize;
    }
    list.truncate(w + m);
}

/// The reach (m) within which a pair of particles of reaches `ri`, `rj` (m) is listed: their
/// sum, or with `larger` the larger of the two.
#[inline(always)]
pub(crate) fn pair_reach(ri: f64, rj: f64, larger: bool) -> f64 {
    if larger {
        ri.max(rj)
    } else {
        ri + rj
    }
}

/// Append particle i's neighbours (fluid ones only with `fluid_only`) through the sub-cells
/// `sub` of `cells`, as particle indices (`copy`: the build's cell-order copy).
fn list_by_sub_cells<const D: usize>(
    list: &mut Vec<u32>,
    sub: &sized::SubCells,
    copy: &sized::Copy,
    grid: &CellGrid<D>,
    cells: &CellList,
    i: usize,
    fluid_only: bool,
) {
    let k = cells.slot[i] as usize;
    let mut xa = [0.0f64; D];
    xa.copy_from_slice(&copy.xs[k * D..k * D + D]);
    let c = grid.coords_of(cells.cell[i] as usize);
    let w = list.len();
    sub.list(list, copy, grid, &c, k, &xa, copy.reach[k], fluid_only);
    list[w..].iter_mut().for_each(|s| *s = cells.order[*s as usize]);
}

/// Append particle i's neighbours (`want`: all, or fluid only) to `list`, scanning its
/// stencil rows; `view` is the build's cell-order copy (positions, fluid flags, fluid counts
/// per cell, κh per particle when h varies).
#[allow(clippy::too_many_arguments)]
fn list_particle<const D: usize>(
    list: &mut Vec<u32>,
    grid: &CellGrid<D>,
    cells: &CellList,
    p: &Particles<D>,
    i: usize,
    want: Wants,
    (xs, fluid, fluid_before, reach, larger): (&[f64], &[u8], &[u32], &[f64], bool),
    r2max: f64,
) {
    let sized = !reach.is_empty();
    // row offsets: 3^(D-1) offsets of the leading axes, lexicographic
    let rows = 3usize.pow(D as u32 - 1);
    let mut xa = [0.0f64; D];
    xa.copy_from_slice(p.x[i].as_slice());
    let c = grid.coords_of(cells.cell[i] as usize);
    for row in 0..rows {
        let Some((c0, c1)) = grid.stencil_run(&c, row) else {
            continue;
        };
        let s = cells.start[c0] as usize;
        let e = cells.start[c1] as usize;
        if want == Wants::Fluid && fluid_before[e] == fluid_before[s] {
            continue;
        }
        let (ord, xr, fr) = (&cells.order[s..e], &xs[s * D..e * D], &fluid[s..e]);
        let r = match sized {
            true => (reach[cells.slot[i] as usize], &reach[s..e], larger),
            false => (0.0, reach, larger),
        };
        match (want, sized) {
            (Wants::All, false) => scan_row::<D, ALL, false>(list, &xa, i, r2max, ord, xr, fr, r),
            (Wants::All, true) => scan_row::<D, ALL, true>(list, &xa, i, r2max, ord, xr, fr, r),
            (Wants::Fluid, false) => scan_row::<D, FLUID, false>(list, &xa, i, r2max, ord, xr, fr, r),
            (Wants::Fluid, true) => scan_row::<D, FLUID, true>(list, &xa, i, r2max, ord, xr, fr, r),
            (Wants::Half | Wants::Nothing, _) => {}
        }
    }
}

impl NeighbourList {
    /// Build the list of each owned particle i with the neighbours `wants(i)` asks for.
    ///
    /// Cells are linear with the last axis fastest, so for each of the 3ᴰ⁻¹ offsets of the
    /// leading axes the three stencil cells along the last axis are one contiguous run of
    /// `cells.order`, already in stencil order (offset −1, 0, +1, each ascending by key).
    pub fn build<const D: usize>(
        &mut self,
        grid: &CellGrid<D>,
        cells: &CellList,
        p: &Particles<D>,
        support: f64,
        wants: impl Fn(usize) -> Wants + Sync,
    ) {
        let n = p.n_owned;
        let r2max = support * support;
        self.copy_cell_order(cells, p);
        self.r2max = r2max;
        if self.lean {
            // no lists: remember what each particle wants; passes scan as they go
            self.wants.clear();
            let mut any_half = false;
            self.wants.extend((0..n).map(|i| {
                let w = wants(i);
                any_half |= w == Wants::Half;
                w.mode()
            }));
            self.n = n;
            self.chunks.clear();
            self.offset.clear();
            self.before.clear();
            self.build_half(any_half, grid, cells, p);
            return;
        }
        let (xs, fluid, fluid_before, reach, larger) = (
            &self.xs[..],
            &self.fluid[..],
            &self.fluid_before[..],
            &self.reach[..],
            self.reach_larger,
        );
        let copy = sized::Copy {
            xs,
            fluid,
            reach,
            larger,
        };
        if reach.is_empty() || self.no_sub_cells {
            self.sub = Default::default();
        } else {
            self.sub.build(grid, cells, &copy);
        }
        let sub = &self.sub;
        let nchunks = n.div_ceil(CHUNK);
        self.chunks.resize_with(nchunks, Vec::new);
        self.offset.resize(n, 0);
        self.n = n;
        let any_half = self
            .chunks
            .par_iter_mut()
            .zip(self.offset.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(ci, (list, offsets))| {
                list.clear();
                let mut any_half = false;
                for (k, off) in offsets.iter_mut().enumerate() {
                    let i = ci * CHUNK + k;
                    *off = list.len() as u32;
                    let want = wants(i);
                    if want == Wants::Half {
                        any_half = true;
                        continue;
                    }
                    if want == Wants::Nothing {
                        continue;
                    }
                    // a particle of the largest reach reaches the whole stencil: the row scan
                    // lists the same neighbours with less overhead per cell
                    if sub.split() > 0 && reach[cells.slot[i] as usize] < sub.largest_reach() {
                        list_by_sub_cells(list, sub, &copy, grid, cells, i, want == Wants::Fluid);
                        continue;
                    }
                    list_particle(
                        list,
                        grid,
                        cells,
                        p,
                        i,
                        want,
                        (xs, fluid, fluid_before, reach, larger),
                        r2max,
                    );
                }
                any_half
            })
            .reduce(|| false, |a, b| a | b);
        self.before.clear();
        self.before.push(0);
        let mut total = 0usize;
        for list in &self.chunks {
            total += list.len();
            self.before.push(total);
        }
        self.build_half(any_half, grid, cells, p);
    }

    /// Positions and fluid flags in cell order, and the fluid before each slot.
    fn copy_cell_order<const D: usize>(&mut self, cells: &CellList, p: &Particles<D>) {
        // positions and fluid flags in cell order
        self.xs.resize(cells.order.len() * D, 0.0);
        self.fluid.resize(cells.order.len(), 0);
        self.xs
            .par_chunks_mut(D * CHUNK)
            .zip(self.fluid.par_chunks_mut(CHUNK))
            .zip(cells.order.par_chunks(CHUNK))
            .for_each(|((xs, fl), ord)| {
                for ((x, f), &j) in xs.chunks_exact_mut(D).zip(fl.iter_mut()).zip(ord) {
                    x.copy_from_slice(p.x[j as usize].as_slice());
                    *f = p.kind[j as usize].is_fluid() as u8;
                }
            });
        self.reach.clear();
        if self.reach_per_h > 0.0 {
            let k = self.reach_per_h;
            self.reach
                .extend(cells.order.iter().map(|&j| k * p.h[j as usize]));
        }
        self.fluid_before.clear();
        self.fluid_before.reserve(self.fluid.len() + 1);
        self.fluid_before.push(0);
        let mut acc = 0u32;
        for &f in &self.fluid {
            acc += u32::from(f);
            self.fluid_before.push(acc);
        }
    }

    /// Build (or drop) the half lists of pair mode.
    fn build_half<const D: usize>(
        &mut self,
        any: bool,
        grid: &CellGrid<D>,
        cells: &CellList,
        p: &Particles<D>,
    ) {
        self.has_half = any;
        let mut half = std::mem::take(&mut self.half);
        if any {
            half.build(self, grid, cells, p, self.lean);
        }
        self.half = half;
    }

    /// Pair mode's half lists of the last build with the grid and cell list it used, if it
    /// made them.
    pub fn half<'a, const D: usize>(
        &'a self,
        grid: &'a CellGrid<D>,
        cells: &'a CellList,
    ) -> Option<HalfView<'a, D>> {
        self.has_half.then_some(HalfView {
            half: &self.half,
            nl: self,
            grid,
            cells,
        })
    }

    /// Load of owned particle `i` for the balance: its list entries, plus its half-list
    /// partners in pair mode (`cells` the build's cell list).
    pub fn load(&self, i: usize, cells: &CellList) -> usize {
        let own = self.of(i).len();
        if self.has_half && !self.lean {
            own + self.half.stored(cells.slot[i] as usize).count()
        } else {
            own
        }
    }

    /// Free every buffer (lists, cell-order copies, half lists), keeping the configuration
    /// (lean mode, several sizes): the next [`NeighbourList::build`] allocates them again.
    pub fn release(&mut self) {
        *self = NeighbourList {
            lean: self.lean,
            within2: self.within2,
            reach_per_h: self.reach_per_h,
            reach_larger: self.reach_larger,
            no_sub_cells: self.no_sub_cells,
            ..Default::default()
        };
    }

    /// An empty list set that stores no lists ([`NeighbourList::lean`]): passes reach the
    /// neighbours through [`NeighbourList::scan`].
    pub fn lean() -> Self {
        NeighbourList {
            lean: true,
            ..Default::default()
        }
    }

    /// Lists for particles of several smoothing lengths (`Particles::h`): a pair is kept
    /// within [`pair_reach`] of r_i = `reach_per_h` h_i and r_j, the sum (`larger` false) or
    /// the larger: κ/2 and the sum for the support κ (h_i + h_j)/2 of the mean h, κ and the
    /// larger for κ max(h_i, h_j) ([`crate::kernel::sizes::PairH`]).
    pub fn with_sizes(mut self, reach_per_h: f64, larger: bool) -> Self {
        self.reach_per_h = reach_per_h;
        self.reach_larger = larger;
        self
    }

    /// Lists of particles of several sizes built by the coarse scan of the 3^D cells, not
    /// through sub-cells: the same lists, slower (for tests that compare the two).
    pub fn without_sub_cells(mut self) -> Self {
        self.no_sub_cells = true;
        self
    }

    /// Sub-cells per axis of a cell in the last build (0: the coarse scan listed).
    pub fn sub_cell_split(&self) -> usize {
        self.sub.split()
    }

    /// True in lean mode (no stored lists).
    pub fn is_lean(&self) -> bool {
        self.lean
    }

    /// The list-free neighbours of the last build (lean mode), scanning `cells` of `grid`
    /// (the ones the build used).
    pub fn scan<'a, const D: usize>(&'a self, grid: &'a CellGrid<D>, cells: &'a CellList) -> CellScan<'a, D> {
        CellScan {
            nl: self,
            grid,
            cells,
        }
    }

    /// Neighbours of owned particle `i` (empty in lean mode: use [`NeighbourList::scan`]).
    #[inline]
    pub fn of(&self, i: usize) -> &[u32] {
        if self.lean {
            return &[];
        }
        let (c, k) = (i / CHUNK, i % CHUNK);
        let list = &self.chunks[c];
        let s = self.offset[i] as usize;
        let e = if k + 1 < CHUNK && i + 1 < self.n {
            self.offset[i + 1] as usize
        } else {
            list.len()
        };
        &list[s..e]
    }

    /// List entries of the owned particles before `i` (`i` up to the owned count).
    pub fn entries_before(&self, i: usize) -> usize {
        if self.lean {
            return 0;
        }
        if i >= self.n {
            return self.before.last().copied().unwrap_or(0);
        }
        self.before[i / CHUNK] + self.offset[i] as usize
    }

    /// Bytes the lists, their cell-order copies and the half lists hold, by capacity.
    pub fn bytes_held(&self) -> usize {
        let chunks: usize = self.chunks.iter().map(held).sum();
        chunks
            + held(&self.chunks)
            + held(&self.offset)
            + held(&self.before)
            + held(&self.xs)
            + held(&self.fluid)
            + held(&self.fluid_before)
            + held(&self.wants)
            + held(&self.reach)
            + self.half.bytes_held()
    }

    /// Owned particles the lists were built for.
    pub fn listed(&self) -> usize {
        self.n
    }

    /// Total number of list entries: directed pairs of the gather lists plus, in pair mode,
    /// the pairs of the half lists.
    pub fn entries(&self) -> usize {
        self.before.last().copied().unwrap_or(0) + if self.has_half { self.half.len() } else { 0 }
    }
}

/// List-free neighbours (lean mode): each query scans the particle's stencil rows in the
/// order the lists would hold them, testing distances again — less memory (no 4 B per pair),
/// more work per pass.
pub struct CellScan<'a, const D: usize> {
    nl: &'a NeighbourList,
    grid: &'a CellGrid<D>,
    cells: &'a CellList,
}

impl<const D: usize> Neighbours for CellScan<'_, D> {
    type Iter<'b>
        = ScanIter<'b, D>
    where
        Self: 'b;

    fn iter(&self, i: usize) -> ScanIter<'_, D> {
        let nl = self.nl;
        let mode = nl.wants[i];
        let c = self.grid.coords_of(self.cells.cell[i] as usize);
        // i's own position from the build's cell-order copy (positions do not change between
        // the build and the passes)
        let mut xa = [0.0f64; D];
        let k = self.cells.slot[i] as usize;
        xa.copy_from_slice(&nl.xs[k * D..k * D + D]);
        let rows = if mode == NOTHING {
            0
        } else {
            3usize.pow(D as u32 - 1)
        };
        ScanIter {
            scan: self,
            xa,
            ri: nl.reach.get(k).copied().unwrap_or(0.0),
            i,
            mode,
            c,
            row: 0,
            rows,
            k: 0,
            e: 0,
        }
    }

    fn work_before(&self, i: usize) -> usize {
        i
    }
}

/// One particle's list-free neighbours ([`CellScan`]).
pub struct ScanIter<'b, const D: usize> {
    scan: &'b CellScan<'b, D>,
    xa: [f64; D],
    /// κ h_i / 2 (particles of several sizes; 0 otherwise).
    ri: f64,
    i: usize,
    mode: u8,
    c: [usize; D],
    row: usize,
    rows: usize,
    k: usize,
    e: usize,
}

impl<const D: usize> ScanIter<'_, D> {
    /// Move to the next stencil row with candidates; false when there is none.
    fn next_row(&mut self) -> bool {
        while self.row < self.rows {
            let row = self.row;
            self.row += 1;
            let Some((c0, c1)) = self.scan.grid.stencil_run(&self.c, row) else {
                continue;
            };
            let (k, e) = (
                self.scan.cells.start[c0] as usize,
                self.scan.cells.start[c1] as usize,
            );
            let fb = &self.scan.nl.fluid_before;
            if self.mode == FLUID && fb[e] == fb[k] {
                continue;
            }
            (self.k, self.e) = (k, e);
            return true;
        }
        false
    }
}

impl<const D: usize> Iterator for ScanIter<'_, D> {
    type Item = u32;

    #[inline]
    fn next(&mut self) -> Option<u32> {
        let nl = self.scan.nl;
        let order = &self.scan.cells.order;
        loop {
            while self.k < self.e {
                let k = self.k;
                self.k += 1;
                let xj = &nl.xs[k * D..k * D + D];
                let mut d2 = 0.0;
                for (xa, xb) in self.xa.iter().zip(xj) {
                    let d = xa - xb;
                    d2 += d * d;
                }
                let j = order[k];
                let ju = j as usize;
                let near = match nl.reach.get(k) {
                    Some(&r) => {
                        let s = pair_reach(self.ri, r, nl.reach_larger);
                        d2 < s * s
                    }
                    None => d2 < nl.r2max,
                };
                let keep = match self.mode {
                    ALL => near & (ju != self.i),
                    _ => near & (ju != self.i) & (nl.fluid[k] != 0),
                };
                if keep {
                    return Some(j);
                }
            }
            if !self.next_row() {
                return None;
            }
        }
    }
}

/// Brute-force neighbour oracle over all particles: sorted `j` for each owned `i` with
/// `|x_i − x_j| < support`, j ≠ i (the same convention as [`NeighbourList`]).
pub fn brute_force<const D: usize>(p: &Particles<D>, support: f64) -> Vec<Vec<u32>> {
    let r2 = support * support;
    (0..p.n_owned)
        .map(|i| {
            (0..p.len())
                .filter(|&j| j != i && (p.x[i] - p.x[j]).norm_squared() < r2)
                .map(|j| j as u32)
                .collect()
        })
        .collect()
}
