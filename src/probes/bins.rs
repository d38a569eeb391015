//! Particles binned in square (cubic) cells for the sensors that look for close pairs (the
//! front's connected groups, the force on a wall body).
//!
//! The cells are a sorted list, not a hash map: building is one sort of (cell, index) pairs,
//! a lookup one binary search, and every walk visits cells and, inside a cell, particles in a
//! fixed order (cell coordinates, then index — the gathered view's id order). At an output
//! every step (an `output.interval` below dt) the hashed cells of earlier versions cost more
//! than the step itself.

use crate::Vector;

/// The cell of side `size` (m) holding `x`.
pub(crate) fn cell_of<const D: usize>(x: &Vector<D>, size: f64) -> [i64; D] {
    std::array::from_fn(|a| (x[a] / size).floor() as i64)
}

/// The 3^D cell offsets around a cell (itself included).
pub(crate) fn around<const D: usize>(c: [i64; D]) -> impl Iterator<Item = [i64; D]> {
    (0..3i64.pow(D as u32)).map(move |k| {
        let mut k = k;
        std::array::from_fn(|a| {
            let o = k % 3 - 1;
            k /= 3;
            c[a] + o
        })
    })
}

/// The chosen particles in cells of side `size` (m): occupied cells in sorted order, each
/// holding its particles in index order.
pub(crate) struct Bins<const D: usize> {
    size: f64,
    cells: Vec<[i64; D]>,
    /// `items[start[k]..start[k + 1]]` are cell k's particles
    start: Vec<usize>,
    items: Vec<usize>,
    /// a direct table from cell to occupied cell when the occupied cells' bounding box is
    /// small (at most [`DENSE_PER_ITEM`] cells per particle), else lookups search `cells`
    dense: Option<Dense<D>>,
}

/// Cells of the bounding box per binned particle up to which lookups use a direct table.
const DENSE_PER_ITEM: usize = 16;

/// A direct table over the occupied cells' bounding box: `slot[linear(c)]` is the occupied
/// cell's index, or `u32::MAX`.
struct Dense<const D: usize> {
    lo: [i64; D],
    dims: [i64; D],
    slot: Vec<u32>,
}

impl<const D: usize> Dense<D> {
    /// The table's box over `cells` (lowest corner, extent per axis), or `None` when it would
    /// hold more than [`DENSE_PER_ITEM`] cells per particle of `items`.
    fn bounds(cells: impl Iterator<Item = [i64; D]>, items: usize) -> Option<([i64; D], [i64; D])> {
        let mut cells = cells.peekable();
        let first = *cells.peek()?;
        let (mut lo, mut hi) = (first, first);
        for c in cells {
            for a in 0..D {
                lo[a] = lo[a].min(c[a]);
                hi[a] = hi[a].max(c[a]);
            }
        }
        let dims: [i64; D] = std::array::from_fn(|a| hi[a].saturating_sub(lo[a]).saturating_add(1));
        let budget = (DENSE_PER_ITEM * items + 1024) as i64;
        dims.iter()
            .try_fold(1i64, |n, &d| n.checked_mul(d).filter(|&n| n <= budget))?;
        Some((lo, dims))
    }

    fn linear(&self, c: [i64; D]) -> Option<usize> {
        let mut at = 0i64;
        for ((c, lo), n) in c.iter().zip(&self.lo).zip(&self.dims) {
            let o = c.checked_sub(*lo)?;
            if o < 0 || o >= *n {
                return None;
            }
            at = at * n + o;
        }
        Some(at as usize)
    }

    /// The cell at linear index `l` (the inverse of [`Dense::linear`]).
    fn cell(&self, mut l: usize) -> [i64; D] {
        let mut c = [0i64; D];
        for a in (0..D).rev() {
            let n = self.dims[a] as usize;
            c[a] = self.lo[a] + (l % n) as i64;
            l /= n;
        }
        c
    }

    fn find(&self, c: [i64; D]) -> Option<usize> {
        let k = self.slot[self.linear(c)?];
        (k != u32::MAX).then_some(k as usize)
    }
}

impl<const D: usize> Bins<D> {
    /// Bin the particles `members` (indices into `x`) in cells of side `size` (m).
    ///
    /// When the occupied cells' box is small (the usual case) this is a counting sort over the
    /// box, O(n), that walks `members` again instead of storing their cells; otherwise one
    /// sort of (cell, index) pairs and lookups by binary search.
    pub fn new(x: &[Vector<D>], size: f64, members: impl Iterator<Item = usize> + Clone) -> Self {
        let cells = members.clone().map(|i| cell_of(&x[i], size));
        let in_order = members.clone().zip(members.clone().skip(1)).all(|(a, b)| a < b);
        match Dense::bounds(cells, members.clone().count()) {
            Some((lo, dims)) if in_order => Self::counted(size, x, members, lo, dims),
            _ => {
                let mut keyed: Vec<([i64; D], usize)> = members.map(|i| (cell_of(&x[i], size), i)).collect();
                keyed.sort_unstable();
                Self::sorted(size, keyed)
            }
        }
    }

    /// Bins from `keyed` sorted by (cell, index), looked up by binary search.
    fn sorted(size: f64, keyed: Vec<([i64; D], usize)>) -> Self {
        let (mut cells, mut start) = (Vec::new(), Vec::new());
        for (k, (c, _)) in keyed.iter().enumerate() {
            if cells.last() != Some(c) {
                cells.push(*c);
                start.push(k);
            }
        }
        start.push(keyed.len());
        let items: Vec<usize> = keyed.into_iter().map(|(_, i)| i).collect();
        Bins {
            size,
            cells,
            start,
            items,
            dense: None,
        }
    }

    /// Bins of `members` (in index order) by a stable counting sort over the box (`lo`,
    /// `dims`): the box's linear order is the cells' lexicographic order, so cells and members
    /// come out as [`Bins::sorted`] would give them.
    fn counted(
        size: f64,
        x: &[Vector<D>],
        members: impl Iterator<Item = usize> + Clone,
        lo: [i64; D],
        dims: [i64; D],
    ) -> Self {
        let total = dims.iter().product::<i64>() as usize;
        let mut dense = Dense {
            lo,
            dims,
            slot: vec![0u32; total],
        };
        let linear = |d: &Dense<D>, i: usize| d.linear(cell_of(&x[i], size)).expect("inside the box");
        let mut n = 0;
        for i in members.clone() {
            let l = linear(&dense, i);
            dense.slot[l] += 1;
            n += 1;
        }
        let (mut cells, mut start) = (Vec::new(), Vec::new());
        let mut at = 0usize;
        for l in 0..total {
            let count = dense.slot[l] as usize;
            if count == 0 {
                dense.slot[l] = u32::MAX;
                continue;
            }
            dense.slot[l] = cells.len() as u32;
            cells.push(dense.cell(l));
            start.push(at);
            at += count;
        }
        start.push(at);
        let mut next = start.clone();
        let mut items = vec![0usize; n];
        for i in members {
            let k = dense.slot[linear(&dense, i)] as usize;
            items[next[k]] = i;
            next[k] += 1;
        }
        Bins {
            size,
            cells,
            start,
            items,
            dense: Some(dense),
        }
    }

    /// Number of occupied cells.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Occupied cell `k`'s coordinates.
    pub fn cell(&self, k: usize) -> [i64; D] {
        self.cells[k]
    }

    /// Occupied cell `k`'s particles, in index order.
    pub fn members(&self, k: usize) -> &[usize] {
        &self.items[self.start[k]..self.start[k + 1]]
    }

    /// The particles of cell `c` (none if it is empty).
    pub fn at(&self, c: [i64; D]) -> &[usize] {
        let k = match &self.dense {
            Some(d) => d.find(c),
            None => self.cells.binary_search(&c).ok(),
        };
        k.map_or(&[], |k| self.members(k))
    }

    /// The particles of the 3^D cells around the one holding `x`, cell by cell.
    pub fn near(&self, x: &Vector<D>) -> impl Iterator<Item = usize> + '_ {
        around(cell_of(x, self.size)).flat_map(|c| self.at(c).iter().copied())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pair within `size` is found by `near`, and nothing else beyond the 3^D cells:
    /// against a brute-force oracle over a scattered cloud.
    #[test]
    fn near_finds_every_close_pair() {
        check_near(false);
        // one particle far away: the bounding box is too large for the direct table
        check_near(true);
    }

    fn check_near(outlier: bool) {
        let mut s = 12345u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut x: Vec<Vector<2>> = (0..400)
            .map(|_| Vector::<2>::new(rnd() - 0.5, rnd() - 0.5))
            .collect();
        if outlier {
            x[1] = Vector::<2>::new(1e6, -1e6);
        }
        let size = 0.07;
        let bins = Bins::new(&x, size, (0..x.len()).filter(|i| i % 3 != 0));
        assert_eq!(bins.dense.is_none(), outlier);
        for (i, xi) in x.iter().enumerate() {
            let mut got: Vec<usize> = bins.near(xi).filter(|&j| (xi - x[j]).norm() < size).collect();
            got.sort_unstable();
            let want: Vec<usize> = (0..x.len())
                .filter(|&j| j % 3 != 0 && (xi - x[j]).norm() < size)
                .collect();
            assert_eq!(got, want, "particle {i}");
        }
        assert!((0..bins.len().saturating_sub(1)).all(|k| bins.cell(k) < bins.cell(k + 1)));
        let total: usize = (0..bins.len()).map(|k| bins.members(k).len()).sum();
        assert_eq!(total, x.len() - x.len().div_ceil(3));
        for k in 0..bins.len() {
            assert!(bins.members(k).windows(2).all(|w| w[0] < w[1]));
            assert!(bins
                .members(k)
                .iter()
                .all(|&i| cell_of(&x[i], size) == bins.cell(k)));
        }
    }
}
