//! Candidates of particles of several sizes (docs/refinement.md §1): each cell of the grid, whose
//! edge is the largest support, is cut into s^D sub-cells of about the smallest support, so that a
//! fine particle tests the candidates near it, not the 3^D coarse cells around it (whose candidates
//! grow as 2^(ℓD) with the refinement level ℓ).
//!
//! **Same lists.** A pair (i, j) is a neighbour when |x_ij| < r_i + r_j, r = κh/2, and
//! r_i + r_j ≤ the support ≤ the cell edge, so every neighbour lies in i's 3^D stencil of
//! cells; the stencil's rows cover ascending linear cells, so the coarse scan lists i's
//! neighbours in ascending **slot** (position in the cell list's order). The cell list orders
//! each cell's particles by sub-cell, then by key ([`super::CellList::with_sub_cells`]; s is a
//! function of the grid and the scene, the same on every rank), so a run of sub-cells along
//! the last axis is a run of slots, the runs of one cell ascend, and so do the cells: a
//! particle's candidates come from the sub-cells that its largest possible pair support
//! reaches and its list comes out in ascending slot, with no sort — the coarse scan's list,
//! entry for entry.

use super::CellGrid;

/// Largest number of sub-cells per axis of a cell.
pub(super) const MAX_SPLIT: usize = 4;

/// Step `q` to the next index of the box `q0 ..= q1` over its first `axes` axes, the last of
/// them fastest (ascending linear order); false once the box is done.
fn advance<const D: usize>(q: &mut [usize; D], (q0, q1): (&[usize; D], &[usize; D]), axes: usize) -> bool {
    for a in (0..axes).rev() {
        if q[a] < q1[a] {
            q[a] += 1;
            return true;
        }
        q[a] = q0[a];
    }
    false
}

/// Sub-cells of the occupied cells, over the cell list's order (which lists each cell's
/// particles by sub-cell: [`super::CellList::with_sub_cells`]).
#[derive(Debug, Clone, Default)]
pub(super) struct SubCells {
    /// Sub-cells per axis of a cell (≥ 2 when built).
    s: usize,
    /// Per axis: sub-cells per metre, s / edge (1/m), and a sub-cell's edge, edge / s (m), so
    /// that the scans multiply instead of dividing (a division per axis per stencil cell was
    /// the list build's hottest instruction).
    scale: [f64; 3],
    sub: [f64; 3],
    /// Per cell: its table in `start` (`u32::MAX` for an empty cell).
    table: Vec<u32>,
    /// Per table: s^D + 1 offsets, the slots of each sub-cell (a cell's particles are listed
    /// by sub-cell, so each sub-cell is a run of slots).
    start: Vec<u32>,
    /// Per sub-cell of each table: the largest κh/2 of its particles (m).
    rmax: Vec<f64>,
    /// The largest κh/2 of all (m).
    rglob: f64,
    /// Per table: the largest κh/2 of the cell's particles (m).
    cmax: Vec<f64>,
    /// Per table: whether the cell holds a fluid particle.
    cfluid: Vec<bool>,
}

/// The cell-order copy the build made: positions (`D` per slot), fluid flags and κh/2 per slot.
pub(super) struct Copy<'a> {
    pub xs: &'a [f64],
    pub fluid: &'a [u8],
    pub reach: &'a [f64],
    /// A pair's reach is the larger of its two (`NeighbourList::with_sizes`), not their sum.
    pub larger: bool,
}

impl SubCells {
    /// Sub-cells per axis when built, 0 when the cell list has none (the coarse scan is used
    /// then).
    pub fn split(&self) -> usize {
        self.s
    }

    /// The largest κh/2 of the build (m).
    pub fn largest_reach(&self) -> f64 {
        self.rglob
    }

    /// The sub-cells of every occupied cell of `grid` as `cells` lists them (no sub-cells,
    /// split 0, when it has none).
    pub fn build<const D: usize>(&mut self, grid: &CellGrid<D>, cells: &super::CellList, copy: &Copy<'_>) {
        let s = cells.sub_cell_split();
        self.s = s;
        if s < 2 {
            return;
        }
        let start = &cells.start;
        for a in 0..D {
            self.scale[a] = s as f64 / grid.edge[a];
            self.sub[a] = grid.edge[a] / s as f64;
        }
        self.rglob = copy.reach.iter().copied().fold(0.0, f64::max);
        let nsub = s.pow(D as u32);
        self.table.clear();
        self.table.resize(start.len() - 1, u32::MAX);
        self.start.clear();
        self.rmax.clear();
        self.cmax.clear();
        self.cfluid.clear();
        let mut count = vec![0u32; nsub + 1];
        for c in 0..start.len() - 1 {
            let (b, e) = (start[c] as usize, start[c + 1] as usize);
            if b == e {
                continue;
            }
            self.table[c] = (self.start.len() / (nsub + 1)) as u32;
            count.iter_mut().for_each(|x| *x = 0);
            let r0 = self.rmax.len();
            self.rmax.resize(r0 + nsub, 0.0);
            let rmax = &mut self.rmax[r0..];
            for k in b..e {
                let l = cells.sub[cells.order[k] as usize] as usize;
                count[l + 1] += 1;
                rmax[l] = rmax[l].max(copy.reach[k]);
            }
            self.cmax.push(rmax.iter().copied().fold(0.0, f64::max));
            self.cfluid.push(copy.fluid[b..e].iter().any(|&f| f != 0));
            for q in 0..nsub {
                count[q + 1] += count[q];
            }
            self.start.extend(count.iter().map(|&x| x + b as u32));
        }
    }

    /// Append to `list` the slots of the neighbours of the particle at slot `ki` (position
    /// `xa`, reach `ri`, in cell `c` of `grid`), fluid ones only if `fluid_only`, ascending:
    /// those with |x_ij| < r_i + r_j, the test of the coarse scan.
    #[allow(clippy::too_many_arguments)]
    pub fn list<const D: usize>(
        &self,
        list: &mut Vec<u32>,
        copy: &Copy<'_>,
        grid: &CellGrid<D>,
        c: &[usize; D],
        ki: usize,
        xa: &[f64; D],
        ri: f64,
        fluid_only: bool,
    ) {
        let s = self.s;
        let nsub = s.pow(D as u32);
        // runs of sub-cells ascend within a cell and cells ascend: the list comes out in
        // ascending slot, the coarse scan's order, with no sort
        // the cells of the 3^D stencil that i's largest pair support reaches (same margin as
        // the sub-cells'), in ascending linear order: ascending slot ranges
        let own = grid.cell_lo(c);
        let (mut c0, mut c1) = ([0usize; D], [0usize; D]);
        for a in 0..D {
            let e = grid.edge[a];
            let q = ri + self.rglob + 1e-9 * e;
            let lo = if xa[a] - q < own[a] {
                c[a].saturating_sub(1)
            } else {
                c[a]
            };
            let hi = if xa[a] + q >= own[a] + e { c[a] + 1 } else { c[a] };
            c0[a] = lo;
            c1[a] = hi.min(grid.dims[a] - 1);
        }
        let mut cc = c0;
        loop {
            let t = self.table[grid.linear(&cc)];
            // a cell without fluid lists nothing for a particle that wants only fluid
            if t != u32::MAX && (!fluid_only || self.cfluid[t as usize]) {
                let lo = grid.cell_lo(&cc);
                let base = t as usize * (nsub + 1);
                if self.covers(grid, &lo, t as usize, xa, ri) {
                    // the whole cell: its slots in cell order
                    let (b, e) = (self.start[base] as usize, self.start[base + nsub] as usize);
                    scan_slots(list, copy, (b, e), ki, xa, ri, fluid_only);
                } else {
                    self.scan_cell(list, copy, grid, (&lo, base), ki, xa, ri, fluid_only);
                }
            }
            if !advance(&mut cc, (&c0, &c1), D) {
                return;
            }
        }
    }

    /// True if i's window, ri + the cell's largest reach around `xa`, covers every sub-cell
    /// of the cell with corner `lo` and table `t` (the same test as [`SubCells::scan_cell`]'s,
    /// which would then scan them all).
    #[inline]
    fn covers<const D: usize>(
        &self,
        grid: &CellGrid<D>,
        lo: &crate::Vector<D>,
        t: usize,
        xa: &[f64; D],
        ri: f64,
    ) -> bool {
        let s = self.s as f64;
        (0..D).all(|a| {
            let q = ri + self.cmax[t] + 1e-9 * grid.edge[a];
            (xa[a] - q - lo[a]) * self.scale[a] < 1.0 && (xa[a] + q - lo[a]) * self.scale[a] >= s - 1.0
        })
    }

    /// The neighbours of one cell (corner `lo`, table at `base`) among the sub-cells that
    /// i's largest pair support reaches, as slots.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn scan_cell<const D: usize>(
        &self,
        list: &mut Vec<u32>,
        copy: &Copy<'_>,
        grid: &CellGrid<D>,
        (lo, base): (&crate::Vector<D>, usize),
        ki: usize,
        xa: &[f64; D],
        ri: f64,
        fluid_only: bool,
    ) {
        let s = self.s;
        let nsub = s.pow(D as u32);
        let t = base / (nsub + 1);
        let tb = t * nsub;
        // the sub-cells within ri + (the cell's largest reach) of x_i per axis, with a margin
        // of 1e-9 edges for a particle binned across a rounding of its position
        let (mut q0, mut q1) = ([0usize; D], [0usize; D]);
        for a in 0..D {
            let e = grid.edge[a];
            let q = ri + self.cmax[t] + 1e-9 * e;
            // sub-cell coordinates; ⌊g⌋ < 0 iff g < 0 and ⌊g⌋ ≥ s iff g ≥ s, and truncation
            // is ⌊g⌋ for g ≥ 0, so no floor is needed
            let g0 = (xa[a] - q - lo[a]) * self.scale[a];
            let g1 = (xa[a] + q - lo[a]) * self.scale[a];
            if g1 < 0.0 || g0 >= s as f64 {
                return;
            }
            q0[a] = if g0 > 0.0 { g0 as usize } else { 0 };
            q1[a] = (g1 as usize).min(s - 1);
        }
        // runs of sub-cells along the last axis are contiguous in the sub-cell order
        let last = D - 1;
        let mut q = q0;
        loop {
            let l = q.iter().fold(0usize, |l, &qa| l * s + qa);
            let run = l + q1[last] - q0[last];
            let (b, e) = (self.start[base + l] as usize, self.start[base + run + 1] as usize);
            if b < e {
                let rmax = self.rmax[tb + l..=tb + run].iter().copied().fold(0.0, f64::max);
                self.scan_run(
                    list,
                    copy,
                    grid,
                    (lo, &q, q1[last], rmax),
                    (b, e),
                    ki,
                    xa,
                    ri,
                    fluid_only,
                );
            }
            // next run of the box
            if !advance(&mut q, (&q0, &q1), last) {
                return;
            }
        }
    }

    /// The neighbours in a run of sub-cells along the last axis (from local coordinates `q`
    /// to `q_end` on that axis; slots `b..e`; their largest reach `rmax`), unless the run's
    /// box lies beyond ri + that reach.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn scan_run<const D: usize>(
        &self,
        list: &mut Vec<u32>,
        copy: &Copy<'_>,
        grid: &CellGrid<D>,
        (lo, q, q_end, rmax): (&crate::Vector<D>, &[usize; D], usize, f64),
        (b, e): (usize, usize),
        ki: usize,
        xa: &[f64; D],
        ri: f64,
        fluid_only: bool,
    ) {
        let reach = ri + rmax;
        let mut d2 = 0.0;
        for a in 0..D {
            let sub = self.sub[a];
            let b0 = lo[a] + q[a] as f64 * sub;
            let b1 = lo[a] + (if a == D - 1 { q_end } else { q[a] } + 1) as f64 * sub;
            let d = (b0 - xa[a]).max(xa[a] - b1).max(0.0) - 1e-9 * grid.edge[a];
            if d > 0.0 {
                d2 += d * d;
            }
        }
        if d2 >= reach * reach {
            return;
        }
        scan_slots(list, copy, (b, e), ki, xa, ri, fluid_only);
    }
}

/// The neighbours among the slots `b..e` of the cell-order copy `copy`: those with |x_ij| < r_i +
/// r_j (fluid ones only if `fluid_only`), in entry order.
#[allow(clippy::too_many_arguments)]
#[inline]
fn scan_slots<const D: usize>(
    list: &mut Vec<u32>,
    copy: &Copy<'_>,
    (b, e): (usize, usize),
    ki: usize,
    xa: &[f64; D],
    ri: f64,
    fluid_only: bool,
) {
    // branch-free append: write every candidate, advance on a hit
    let w = list.len();
    super::grow_list(list, w + (e - b));
    list.resize(w + (e - b), 0);
    let out = &mut list[w..];
    let mut m = 0usize;
    for q in b..e {
        let xj = &copy.xs[q * D..q * D + D];
        let mut d2 = 0.0;
        for a in 0..D {
            let d = xa[a] - xj[a];
            d2 += d * d;
        }
        let k = q as u32;
        let sum = super::pair_reach(ri, copy.reach[q], copy.larger);
        let keep = (d2 < sum * sum) & (k as usize != ki) & (!fluid_only | (copy.fluid[q] != 0));
        out[m] = k;
        m += keep as usize;
    }
    list.truncate(w + m);
}
