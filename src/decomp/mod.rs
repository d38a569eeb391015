//! Dynamic domain decomposition of seed 000 (`docs/methods.md` §4): dimension-wise factorisation
//! (eq. 5), nested cut planes found by parallel bisection (eq. 6), incremental rebalance.
//!
//! Pure functions, no communication. The only collective the method needs — "load left of
//! each candidate plane, summed over all ranks" — is a closure `count(&Stage) -> Vec<u64>`
//! supplied by the caller: on one rank it is [`Stage::count_local`]; on many ranks it is
//! `count_local` followed by an integer all-reduce (sum). Loads are `u64`, so the reduction
//! is exact and independent of rank order, and every rank computes bit-identical planes.
//!
//! Geometry: the domain box `[lo, hi)` (m) is cut into `Nx` slabs along x, each slab into
//! `Ny` along y, each column into `Nz` along z. Ownership is half-open `[plane_j, plane_{j+1})`;
//! the outermost blocks also own whatever lies beyond the domain box on their side, so
//! [`Decomposition::block_of`] is total. Blocks are numbered nested x → y → z (z fastest).
//!
//! A plane can split a layer of particles that share its coordinate (a lattice row, a wall):
//! each plane carries a tie `t` besides its position `c`, and a particle `(x, id)` lies left of
//! it when `(x_k, id) < (c, t)` in lexicographic order — left of the position, or on it with a
//! smaller global id. `t = 0` is the plain half-open rule. The block boxes stay the planes'
//! boxes; a particle on a face belongs to the block its id selects, and halos, which select by
//! distance to a box, are unchanged. Without ties a layer holding more than a block's share
//! bounds the balance (docs/benchmark-log.md, "`hsph plan` at scale after the distributed set-up":
//! one x-layer of the 3D bench held twice a rank's load at 96 ranks, max/mean 1.52).
//!
//! Units: positions, planes and displacements in m; loads are dimensionless counts
//! (particles or neighbour pairs); weights are relative speeds (dimensionless).

mod balance;
mod factor;

pub use balance::{
    eq6_residual, imbalance, imbalance_weighted, rank_imbalance, tolerance, BalanceParams, Counter, Report,
    Stage,
};
pub use factor::{factorise, ordered_factorisations, r_diff, TIE_RELATIVE};

use crate::Vector;

/// A nested cut-plane decomposition of a `D`-dimensional box (seed 000, §2.3–2.4).
#[derive(Debug, Clone, PartialEq)]
pub struct Decomposition<const D: usize> {
    /// Domain box lower corner (m).
    lo: Vector<D>,
    /// Domain box upper corner (m).
    hi: Vector<D>,
    /// Blocks per axis `(Nx, Ny, Nz)`.
    n: [usize; D],
    /// Interior planes (m) per level (axis) `k`, region-major: region `r` (the index of the
    /// parent slab/column, `0..regions(k)`) holds `n[k] − 1` ascending positions.
    planes: Vec<Vec<f64>>,
    /// The id tie of every plane (same layout as `planes`; module docs).
    ties: Vec<Vec<u64>>,
}

/// Whether `(v, id)` lies right of, or on, the cut `(c, t)`: not strictly left of it.
#[inline]
pub fn at_or_right(v: f64, id: u64, c: f64, t: u64) -> bool {
    c < v || (c == v && t <= id)
}

impl<const D: usize> Decomposition<D> {
    /// Equal-width planes: the starting point before any load is known.
    ///
    /// # Panics
    /// If some `n[k]` is zero or the box is empty or not finite.
    pub fn uniform(lo: Vector<D>, hi: Vector<D>, n: [usize; D]) -> Self {
        assert!(n.iter().all(|&k| k > 0), "every axis needs at least one block");
        for k in 0..D {
            assert!(
                lo[k].is_finite() && hi[k].is_finite() && lo[k] < hi[k],
                "bad domain box on axis {k}"
            );
        }
        let mut planes = Vec::with_capacity(D);
        let mut regions = 1usize;
        for k in 0..D {
            let mut level = Vec::with_capacity(regions * (n[k] - 1));
            for _ in 0..regions {
                for i in 0..n[k] - 1 {
                    let f = (i + 1) as f64 / n[k] as f64;
                    level.push(lo[k] + (hi[k] - lo[k]) * f);
                }
            }
            planes.push(level);
            regions *= n[k];
        }
        let ties = planes.iter().map(|l| vec![0; l.len()]).collect();
        Self {
            lo,
            hi,
            n,
            planes,
            ties,
        }
    }

    /// Build from explicit planes (layout as [`Decomposition::planes`]), every tie 0.
    ///
    /// # Panics
    /// If a level has the wrong length or its planes are not ascending within a region.
    pub fn from_planes(lo: Vector<D>, hi: Vector<D>, n: [usize; D], planes: Vec<Vec<f64>>) -> Self {
        let mut d = Self::uniform(lo, hi, n);
        assert_eq!(planes.len(), D, "one plane list per axis");
        for (k, level) in planes.iter().enumerate() {
            assert_eq!(
                level.len(),
                d.planes[k].len(),
                "level {k}: wrong number of planes"
            );
            let m = n[k] - 1;
            for r in 0..d.regions(k) {
                let s = &level[r * m..(r + 1) * m];
                assert!(
                    s.windows(2).all(|w| w[0] <= w[1]),
                    "level {k} region {r}: planes not ascending"
                );
            }
        }
        d.planes = planes;
        d
    }

    /// Blocks per axis `(Nx, Ny(, Nz))`.
    pub fn factors(&self) -> [usize; D] {
        self.n
    }

    /// Number of blocks `P = Nx·Ny(·Nz)`.
    pub fn n_blocks(&self) -> usize {
        self.n.iter().product()
    }

    /// Domain box `(lo, hi)` (m).
    pub fn domain(&self) -> (Vector<D>, Vector<D>) {
        (self.lo, self.hi)
    }

    /// Number of parent regions at level `k`: `1` for x, `Nx` for y, `Nx·Ny` for z.
    pub fn regions(&self, k: usize) -> usize {
        self.n[..k].iter().product()
    }

    /// Interior planes (m) of level `k`, region-major (`n[k] − 1` per region).
    pub fn planes(&self, k: usize) -> &[f64] {
        &self.planes[k]
    }

    /// Interior planes (m) of level `k` inside parent region `r`, ascending.
    pub fn region_planes(&self, k: usize, r: usize) -> &[f64] {
        let m = self.n[k] - 1;
        &self.planes[k][r * m..(r + 1) * m]
    }

    /// Id ties of level `k`, as [`Decomposition::planes`] (module docs).
    pub fn ties(&self, k: usize) -> &[u64] {
        &self.ties[k]
    }

    /// Whether some plane splits a layer (a tie other than 0).
    pub fn splits_layers(&self) -> bool {
        self.ties.iter().flatten().any(|&t| t != 0)
    }

    pub(crate) fn set_level(&mut self, k: usize, level: Vec<f64>, ties: Vec<u64>) {
        debug_assert_eq!(level.len(), self.planes[k].len());
        debug_assert_eq!(ties.len(), self.planes[k].len());
        self.planes[k] = level;
        self.ties[k] = ties;
    }

    /// Index along axis `k` of the sub-block of region `r` holding coordinate `v` (m) of the
    /// particle `id`: the number of interior planes it lies at or right of.
    fn slot(&self, k: usize, r: usize, v: f64, id: u64) -> usize {
        let m = self.n[k] - 1;
        let (c, t) = (
            &self.planes[k][r * m..(r + 1) * m],
            &self.ties[k][r * m..(r + 1) * m],
        );
        // planes ascend in (c, t), so the predicate is a prefix
        let mut lo = 0;
        let mut hi = m;
        while lo < hi {
            let mid = (lo + hi) / 2;
            if at_or_right(v, id, c[mid], t[mid]) {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// Parent region at level `k` of the particle `id` at `x` (uses the planes of levels
    /// `< k` only).
    pub fn region_of(&self, k: usize, x: &Vector<D>, id: u64) -> usize {
        let mut r = 0;
        for a in 0..k {
            r = r * self.n[a] + self.slot(a, r, x[a], id);
        }
        r
    }

    /// Block owning the particle `id` at position `x` (m). Total: points outside the domain
    /// box go to the outermost block on their side.
    pub fn block_of(&self, x: &Vector<D>, id: u64) -> usize {
        self.region_of(D, x, id)
    }

    /// Per-axis indices `(i, j(, k))` of block `b` (nested numbering, last axis fastest).
    pub fn block_coords(&self, b: usize) -> [usize; D] {
        assert!(b < self.n_blocks(), "block {b} out of range");
        let mut c = [0; D];
        let mut rest = b;
        for k in (0..D).rev() {
            c[k] = rest % self.n[k];
            rest /= self.n[k];
        }
        c
    }

    /// Lower and upper bound (m) of sub-block `j` of region `r` along axis `k`
    /// (domain faces for the outermost ones).
    fn bounds(&self, k: usize, r: usize, j: usize) -> (f64, f64) {
        let p = self.region_planes(k, r);
        let lo = if j == 0 { self.lo[k] } else { p[j - 1] };
        let hi = if j == p.len() { self.hi[k] } else { p[j] };
        (lo, hi)
    }

    /// Box `(min, max)` (m) of block `b`, clipped to the domain. Ownership is
    /// `min ≤ x < max` on every axis (plus the beyond-the-domain rule of [`Self::block_of`]).
    pub fn block_box(&self, b: usize) -> (Vector<D>, Vector<D>) {
        let c = self.block_coords(b);
        let (mut min, mut max) = (self.lo, self.hi);
        let mut r = 0;
        for k in 0..D {
            let (l, h) = self.bounds(k, r, c[k]);
            min[k] = l;
            max[k] = h;
            r = r * self.n[k] + c[k];
        }
        (min, max)
    }

    /// Blocks (ascending) whose ownership set meets the closed box `[min, max]` (m): block
    /// `[l, h)` is kept on axis `k` when `l ≤ max_k` and `min_k < h` (`≤ h` when its upper
    /// plane has a tie: part of that layer is the block's), with the outermost
    /// blocks extended to ±∞ as in [`Self::block_of`]. Hence every point of `[min, max]`
    /// lies in one of the returned blocks. For ghost search pass a box widened by the
    /// kernel support radius.
    pub fn blocks_overlapping(&self, min: &Vector<D>, max: &Vector<D>) -> Vec<usize> {
        let mut out = Vec::new();
        self.overlap_rec(0, 0, min, max, &mut out);
        out
    }

    fn overlap_rec(&self, k: usize, r: usize, min: &Vector<D>, max: &Vector<D>, out: &mut Vec<usize>) {
        if k == D {
            out.push(r);
            return;
        }
        let nk = self.n[k];
        for j in 0..nk {
            let (l, h) = self.bounds(k, r, j);
            let l = if j == 0 { f64::NEG_INFINITY } else { l };
            let h = if j + 1 == nk { f64::INFINITY } else { h };
            // a tie on the upper plane gives the block part of the layer on its face
            let face = j + 1 < nk && self.ties[k][r * (nk - 1) + j] > 0;
            let below_top = min[k] < h || (face && min[k] == h);
            if l <= max[k] && below_top && (l < h || face) {
                self.overlap_rec(k + 1, r * nk + j, min, max, out);
            }
        }
    }

    /// Blocks other than `b` within distance `radius` (m, per axis) of block `b`'s box:
    /// the ranks `b` may need ghosts from (non-periodic).
    pub fn blocks_near(&self, b: usize, radius: f64) -> Vec<usize> {
        let (min, max) = self.block_box(b);
        let w = Vector::<D>::repeat(radius);
        let mut v = self.blocks_overlapping(&(min - w), &(max + w));
        v.retain(|&o| o != b);
        v
    }
}

#[cfg(test)]
mod tests;

/// Particles whose blocks are being chosen, visited in parts (one rayon task each) without
/// necessarily being stored: a slice of particles, or the lattice sites a rank streams
/// ([`crate::setup::SiteSource`]). Each particle is `(position (m), global id, fluid)`.
pub trait Cloud<const D: usize>: Sync {
    /// Number of parts.
    fn parts(&self) -> usize;
    /// Visit the particles of part `k`.
    fn visit(&self, k: usize, f: impl FnMut(&Vector<D>, u64, bool));
    /// Visit the particles of part `k` with the load each adds to the initial split
    /// (`(position, id, load)`; 1 unless the cloud knows better).
    fn visit_loads(&self, k: usize, mut f: impl FnMut(&Vector<D>, u64, u64)) {
        self.visit(k, |x, id, _| f(x, id, 1));
    }
}

/// Stored particles as a [`Cloud`]: positions, ids and whether each is fluid.
pub struct Points<'a, const D: usize> {
    /// Positions (m).
    pub x: &'a [Vector<D>],
    /// Global ids.
    pub id: &'a [u64],
    /// Fluid flags (`None`: none is fluid).
    pub fluid: Option<&'a [bool]>,
    /// Load of each particle in the initial split (`None`: 1 each).
    pub load: Option<&'a [u64]>,
}

/// Particles per part of [`Points`].
const POINTS_PART: usize = 1 << 15;

impl<const D: usize> Cloud<D> for Points<'_, D> {
    fn parts(&self) -> usize {
        self.x.len().div_ceil(POINTS_PART)
    }

    fn visit(&self, k: usize, mut f: impl FnMut(&Vector<D>, u64, bool)) {
        let r = k * POINTS_PART..((k + 1) * POINTS_PART).min(self.x.len());
        for i in r {
            f(&self.x[i], self.id[i], self.fluid.is_some_and(|fl| fl[i]));
        }
    }

    fn visit_loads(&self, k: usize, mut f: impl FnMut(&Vector<D>, u64, u64)) {
        let r = k * POINTS_PART..((k + 1) * POINTS_PART).min(self.x.len());
        for i in r {
            f(&self.x[i], self.id[i], self.load.map_or(1, |l| l[i]));
        }
    }
}

/// A sum over a cloud's parts on rayon tasks: `init` a fresh accumulator per task, `add` one
/// part to it, `merge` two. Integer accumulators make the result independent of the split.
pub fn fold_parts<const D: usize, C, A>(
    cloud: &C,
    init: impl Fn() -> A + Sync + Send,
    add: impl Fn(&mut A, usize) + Sync + Send,
    merge: impl Fn(A, A) -> A + Sync + Send,
) -> A
where
    C: Cloud<D>,
    A: Send,
{
    use rayon::prelude::*;
    (0..cloud.parts())
        .into_par_iter()
        .fold(&init, |mut a, k| {
            add(&mut a, k);
            a
        })
        .reduce(&init, merge)
}
