//! Parallel bisection of cut planes (seed 000, §2.4, eq. 6) and incremental rebalance.
//!
//! # Tolerance
//! Seed 000 accepts plane `i` of an axis with `N` sub-blocks when (eq. 6)
//!
//! ```text
//! |n_l(i)(N−i−1) − n_r(i)(i+1)| / ((n_l(i)(N−i−1) + n_r(i)(i+1))/2) ≤ d_i .
//! ```
//!
//! With weights (relative speeds) the factors `i+1` and `N−i−1` become the summed weights
//! `w_l`, `w_r` of the sub-blocks left and right of the plane (the paper: "add the weights to
//! eq. 6"); unit weights give eq. 6 exactly. Write `W` for the region's load,
//! `T = W·w_l/(w_l+w_r)` for the target load left of the plane and `δ = n_l − T`. Then the
//! left-hand side equals `|δ|·w / (A + δ·B)` with `w = w_l + w_r`, `A = W·w_l·w_r/w`,
//! `B = (w_r − w_l)/2`, so eq. 6 implies `|δ| ≤ d·A/(w − d·|B|)`. We want every plane within
//! `η` of the target load of each sub-block next to it, `|δ| ≤ η·W·w_adj/w` with
//! `w_adj = min(w_i, w_{i+1})`; solving for `d` gives the per-plane tolerance
//!
//! ```text
//! d_i = η·w_adj·w / (w_l·w_r + η·w_adj·|w_r − w_l|/2)        (see `tolerance`)
//! ```
//!
//! (`d = 2η` for two equal blocks, `≈ 4η/N` for the middle plane of `N`). A fixed `d` would
//! not do: the load error of the middle plane grows like `N·d/4` block loads. With `d_i`,
//! each sub-block's load is within `2η` of its target at each level (both of its planes may
//! err by `η`), and the nesting compounds, so after all levels
//!
//! ```text
//! max_b load_b / target_b ≤ (1 + 2η)^D ,   target_b = W_total·w_b/Σw .
//! ```
//!
//! The default `η = 0.008` gives `max/mean ≤ 1.0488` in 3D (`1.032` in 2D), inside the 1.05
//! that `decomp_corner_eighth_and_spreading_3d` asks. Attainability: with distinct coordinates and
//! unit loads `δ` can be brought to `≤ 1/2`, so eq. 6 is attainable when every block holds `≥
//! 1/(2η) ≈ 63` particles (with pair loads: 63 times the largest single-particle load). The
//! adjacent windows are disjoint (`2η < 1`), so satisfied planes come out ascending.
//!
//! # Layers
//! When many particles share a coordinate (lattice rows, walls) the load left of a position
//! jumps by a whole layer. Bisection converges onto the layer (the bracket collapses to
//! adjacent floats `[a, b)`; the layer is the particles at `a`); then, when the parameters
//! give an id bound, the plane stays at `a` and bisects its id tie over `[0, id_bound]`: the
//! layer is split by global id ([`super::Decomposition`] docs) and eq. 6 becomes attainable
//! again, with unit loads to within one particle. Without an id bound, or when `max_iter`
//! calls are spent, the plane takes the best candidate seen (smallest eq. 6 residual; earliest
//! on ties): the balance is then limited by the layer granularity, not by the search.
//!
//! # Count cap (memory)
//! Loads other than counts (pairs) let a block of cheap particles (dummy walls) hold several
//! times the mean count, and memory goes with the count. With [`BalanceParams::max_count`] `= c`
//! every stage also counts particles, and each plane's count left of it must stay within a
//! window around the count-balanced prefix `T_c = C·w_l/w` (`C` the region's count): with
//! `C̄ = C/w` the region's count per unit weight, `c_k = c^{1/L}` over the `L` levels that cut,
//! and the slack `s_j = (c_k − 1)·C̄·w_j` of sub-block `j`, plane `i` may exceed `T_c` by `s_i`
//! (`s_i/2` unless sub-block `i` is the first) and fall short by `s_{i+1}` (`s_{i+1}/2` unless
//! it is the last). Each sub-block then holds at most `c_k·C̄·w_j`, so after all levels
//!
//! ```text
//! count_b ≤ c · C_total·w_b/Σw .
//! ```
//!
//! Inside the window a plane seeks its load target as above; where the window excludes it,
//! the plane goes to the window's edge (to one particle, by the same bisection of positions and
//! ids: "left heavy" becomes `count > hi ∨ (count ≥ lo ∧ load heavy)`, still monotone along
//! the axis), and the best candidate is the feasible one nearest the load target. `c = 1` is a
//! split by counts; the bound holds whenever the window is attainable (an id bound, or layers
//! no thicker than the slack).

use super::Decomposition;
use crate::Vector;

/// Parameters of the cut-plane search.
#[derive(Debug, Clone, PartialEq)]
pub struct BalanceParams {
    /// Relative load tolerance `η` per plane and level (module docs): the bound on
    /// `max/mean` is `(1 + 2η)^D`. Default 0.008.
    pub eta: f64,
    /// Maximum number of `count` calls (all-reduces) per level. Default 60.
    pub max_iter: usize,
    /// Optional relative speed per block (= rank); target loads are proportional to them.
    pub weights: Option<Vec<f64>>,
    /// Exclusive upper bound of the particles' global ids: planes may split a layer by id
    /// (module docs). `None`: planes never split a layer (every tie 0).
    pub id_bound: Option<u64>,
    /// Largest particle count of a block over the mean (weighted) count, `≥ 1`: a memory bound
    /// when the loads are not counts (module docs: count cap). The `count` closure must then
    /// answer counts too ([`Stage::counts_particles`]). `None`: no bound.
    pub max_count: Option<f64>,
}

impl Default for BalanceParams {
    fn default() -> Self {
        Self {
            eta: 0.008,
            // ~55 calls bring a float bracket down to adjacent floats, and a layer's id
            // bisection takes log2(id_bound) more
            max_iter: 128,
            weights: None,
            id_bound: None,
            max_count: None,
        }
    }
}

impl BalanceParams {
    /// The balance this search guarantees when eq. 6 is attainable: `(1 + 2η)^dim`.
    pub fn bound(&self, dim: usize) -> f64 {
        (1.0 + 2.0 * self.eta).powi(dim as i32)
    }
}

/// Left-hand side of seed 000's eq. (6) with weights: `|n_l·w_r − n_r·w_l| /
/// ((n_l·w_r + n_r·w_l)/2)`; `w_l = i+1`, `w_r = N−i−1` gives eq. (6) itself. Zero when both
/// loads are zero.
pub fn eq6_residual(n_l: u64, n_r: u64, w_l: f64, w_r: f64) -> f64 {
    let (a, b) = (n_l as f64 * w_r, n_r as f64 * w_l);
    let den = 0.5 * (a + b);
    if den == 0.0 {
        0.0
    } else {
        (a - b).abs() / den
    }
}

/// Per-plane tolerance `d_i` of eq. (6) that keeps the plane within `η` of the target load of
/// each adjacent sub-block (derivation in the module docs). `w_l`, `w_r`: summed weights
/// left and right; `w_adj`: the smaller weight of the two sub-blocks next to the plane.
pub fn tolerance(eta: f64, w_l: f64, w_r: f64, w_adj: f64) -> f64 {
    eta * w_adj * (w_l + w_r) / (w_l * w_r + eta * w_adj * (w_r - w_l).abs() * 0.5)
}

/// `max/mean` of block loads (1 for no load).
pub fn imbalance(loads: &[u64]) -> f64 {
    let total: u128 = loads.iter().map(|&l| l as u128).sum();
    let max = loads.iter().copied().max().unwrap_or(0);
    if total == 0 {
        1.0
    } else {
        max as f64 * loads.len() as f64 / total as f64
    }
}

/// `max_b load_b / target_b` with `target_b = total·w_b/Σw` (equals [`imbalance`] for equal
/// weights). Sums run in index order.
pub fn imbalance_weighted(loads: &[u64], weights: &[f64]) -> f64 {
    assert_eq!(loads.len(), weights.len());
    let total: u128 = loads.iter().map(|&l| l as u128).sum();
    if total == 0 {
        return 1.0;
    }
    let wsum: f64 = weights.iter().sum();
    loads
        .iter()
        .zip(weights)
        .map(|(&l, &w)| l as f64 / (total as f64 * w / wsum))
        .fold(0.0, f64::max)
}

/// The load imbalance of ranks with `loads` under the scene's `balance.weights` (`weights`,
/// cycled over the ranks; empty: all equal): [`imbalance_weighted`], or [`imbalance`]. The one
/// rule `hsph plan`, the run's checks, `diagnostics.csv` and `summary.json` call "imbalance".
pub fn rank_imbalance(loads: &[u64], weights: &[f64]) -> f64 {
    if weights.is_empty() {
        return imbalance(loads);
    }
    let w: Vec<f64> = (0..loads.len()).map(|r| weights[r % weights.len()]).collect();
    imbalance_weighted(loads, &w)
}

/// One round of the search: candidate planes along one axis, each in a parent region.
/// The caller's `count` closure answers with the global load strictly left of each candidate
/// (`(x[axis], id) < (candidate, tie)`, module docs of [`super`]), among the particles of its
/// region.
pub struct Stage<'a, const D: usize> {
    decomp: &'a Decomposition<D>,
    axis: usize,
    candidates: Vec<f64>,
    ties: Vec<u64>,
    regions: Vec<usize>,
    /// Whether the answer also counts the particles (a capped search).
    counts: bool,
}

impl<'a, const D: usize> Stage<'a, D> {
    /// Whether `count` must answer, after the load left of each candidate, the number of
    /// particles left of each (`2m` numbers for `m` candidates; [`BalanceParams::max_count`]).
    /// [`Stage::count_local`] and [`Stage::counter`] do.
    pub fn counts_particles(&self) -> bool {
        self.counts
    }

    /// Axis (= level) being cut: 0 = x, 1 = y, 2 = z.
    pub fn axis(&self) -> usize {
        self.axis
    }

    /// Candidate plane positions (m). May include `+∞` (asks for a region's total load).
    pub fn candidates(&self) -> &[f64] {
        &self.candidates
    }

    /// Parent region of each candidate.
    pub fn candidate_regions(&self) -> &[usize] {
        &self.regions
    }

    /// Id tie of each candidate (0 unless a layer is being split).
    pub fn candidate_ties(&self) -> &[u64] {
        &self.ties
    }

    /// Parent region of the particle `id` at `x` at this level (planes of earlier levels
    /// are final).
    pub fn region_of(&self, x: &Vector<D>, id: u64) -> usize {
        self.decomp.region_of(self.axis, x, id)
    }

    /// Load left of each candidate among the given `(position, id, load)` items, then, when
    /// the stage [counts particles](Stage::counts_particles), their number left of each — the
    /// local half of `count`; sum the result over ranks (integer all-reduce) for the global
    /// answer.
    /// `O((n + m)·log m)` for `n` items and `m` candidates; integer sums, order-independent.
    pub fn count_local<I: IntoIterator<Item = (Vector<D>, u64, u64)>>(&self, items: I) -> Vec<u64> {
        let mut counter = self.counter();
        for (x, id, load) in items {
            counter.add(&x, id, load);
        }
        counter.finish()
    }

    /// An accumulator of [`Stage::count_local`] to feed item by item (for sites streamed
    /// without being stored), or to merge over threads with [`Counter::merge`].
    pub fn counter(&self) -> Counter<'_, 'a, D> {
        let nreg = self.decomp.regions(self.axis);
        // Candidates sorted by (region, position, tie); `start[r]..start[r+1]` is region r.
        let mut order: Vec<usize> = (0..self.candidates.len()).collect();
        order.sort_by(|&i, &j| {
            self.regions[i]
                .cmp(&self.regions[j])
                .then(self.candidates[i].total_cmp(&self.candidates[j]))
                .then(self.ties[i].cmp(&self.ties[j]))
        });
        let mut start = vec![0usize; nreg + 1];
        for &r in &self.regions {
            start[r + 1] += 1;
        }
        for r in 0..nreg {
            start[r + 1] += start[r];
        }
        let sorted: Vec<(f64, u64)> = order
            .iter()
            .map(|&i| (self.candidates[i], self.ties[i]))
            .collect();
        let hist = vec![0u64; sorted.len() * (1 + self.counts as usize)];
        Counter {
            stage: self,
            order,
            start,
            sorted,
            hist,
        }
    }
}

/// Loads left of a stage's candidates, accumulated item by item ([`Stage::counter`]).
#[derive(Clone)]
pub struct Counter<'s, 'a, const D: usize> {
    stage: &'s Stage<'a, D>,
    order: Vec<usize>,
    start: Vec<usize>,
    sorted: Vec<(f64, u64)>,
    hist: Vec<u64>,
}

impl<const D: usize> Counter<'_, '_, D> {
    /// Count `load` for the particle `id` at `x`.
    #[inline]
    pub fn add(&mut self, x: &Vector<D>, id: u64, load: u64) {
        let r = self.stage.region_of(x, id);
        let s = &self.sorted[self.start[r]..self.start[r + 1]];
        let v = x[self.stage.axis];
        let p = s.partition_point(|&(c, t)| super::at_or_right(v, id, c, t));
        if p < s.len() {
            let q = self.start[r] + p;
            self.hist[q] += load;
            if self.stage.counts {
                self.hist[self.sorted.len() + q] += 1;
            }
        }
    }

    /// Add another counter's items (of the same stage).
    pub fn merge(mut self, other: Self) -> Self {
        self.hist.iter_mut().zip(other.hist).for_each(|(a, b)| *a += b);
        self
    }

    /// Load left of each candidate in the stage's candidate order (then the counts, when the
    /// stage counts particles).
    pub fn finish(self) -> Vec<u64> {
        let nreg = self.start.len() - 1;
        let m = self.sorted.len();
        let mut out = vec![0u64; self.hist.len()];
        for (half, hist) in self.hist.chunks(m.max(1)).enumerate() {
            for r in 0..nreg {
                let mut acc = 0u64;
                for q in self.start[r]..self.start[r + 1] {
                    acc += hist[q];
                    out[half * m + self.order[q]] = acc;
                }
            }
        }
        out
    }
}

#[cfg(test)]
impl<'a, const D: usize> Stage<'a, D> {
    pub(crate) fn new_for_tests(
        decomp: &'a Decomposition<D>,
        axis: usize,
        candidates: Vec<f64>,
        regions: Vec<usize>,
    ) -> Self {
        Self {
            decomp,
            axis,
            ties: vec![0; candidates.len()],
            candidates,
            regions,
            counts: false,
        }
    }
}

/// What a (re)balance did, per level (axis) and plane (region-major, as
/// [`Decomposition::planes`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Report {
    /// `count` calls (all-reduces) per level.
    pub calls: Vec<usize>,
    /// Global load left of each final plane, within its region.
    pub left_load: Vec<Vec<u64>>,
    /// Eq. (6) left-hand side of each final plane.
    pub residual: Vec<Vec<f64>>,
    /// Tolerance `d_i` of each plane.
    pub tolerance: Vec<Vec<f64>>,
    /// `|new − previous|` (m) of each plane; empty after a from-scratch balance.
    pub displacement: Vec<Vec<f64>>,
    /// Global load of every block (known from the last level's counts, no extra reduction).
    pub block_loads: Vec<u64>,
    /// Particles of every block, when the search was capped ([`BalanceParams::max_count`]);
    /// else empty.
    pub block_counts: Vec<u64>,
}

impl Report {
    /// Whether every plane satisfies eq. (6) with its `d_i`.
    pub fn satisfied(&self) -> bool {
        self.residual
            .iter()
            .flatten()
            .zip(self.tolerance.iter().flatten())
            .all(|(r, d)| r <= d)
    }

    /// Total `count` calls.
    pub fn total_calls(&self) -> usize {
        self.calls.iter().sum()
    }

    /// Largest plane displacement (m), 0 after a from-scratch balance.
    pub fn max_displacement(&self) -> f64 {
        self.displacement.iter().flatten().copied().fold(0.0, f64::max)
    }

    /// `max/mean` block load.
    pub fn imbalance(&self) -> f64 {
        imbalance(&self.block_loads)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Rebalance: evaluate the previous plane first.
    Probe,
    /// Rebalance: stepping away from `origin` by `step`, doubling, in direction `dir`.
    Expand {
        origin: f64,
        step: f64,
        dir: f64,
    },
    /// Bisection of `[a, b]`.
    Bisect,
    /// The bracket collapsed onto adjacent floats `a < b` whose ends both carry ties: is the
    /// target in the layer at `a` or in the one at `b`? (evaluates `(b, 0)`)
    TieProbe,
    /// Bisection of the id tie of a plane at `row` over `(lo, hi)` (module docs: layers).
    Tie {
        row: f64,
        lo: u64,
        hi: u64,
    },
    Done,
}

/// Search state of one plane. The bracket's ends are keys `(a, ta)` (load left below the
/// target) and `(b, tb)` (above it).
#[derive(Debug, Clone)]
struct Plane {
    w_l: f64,
    w_r: f64,
    d: f64,
    /// Initial half-width of a rebalance bracket (m).
    h: f64,
    a: f64,
    ta: u64,
    b: f64,
    tb: u64,
    cand: f64,
    tie: u64,
    phase: Phase,
    /// Exclusive bound of the ids, when layers may be split.
    id_bound: Option<u64>,
    /// Count window of a capped search (module docs: count cap); `None`: uncapped.
    window: Option<CountWindow>,
    /// Best candidate seen: (residual, position, tie, load left, count left).
    best: Option<(f64, f64, u64, u64, u64)>,
}

/// The particles left of a plane of a capped search lie within `[lo, hi]` of the region's
/// `total` (module docs: count cap).
#[derive(Debug, Clone, Copy, Default)]
struct CountWindow {
    /// Slack below and above the count-balanced prefix, in units of weight.
    below: f64,
    above: f64,
    /// The region's particle count and the window, once that is known.
    total: u64,
    lo: u64,
    hi: u64,
}

/// A candidate's residual when its count lies outside the window, `out` particles away: more
/// than any feasible one's (eq. 6's left-hand side is at most 2).
fn infeasible(out: u64, total: u64) -> f64 {
    1.0e9 + out as f64 / total.max(1) as f64
}

impl Plane {
    /// Fix the count window once the region's particle count `total` is known.
    fn set_count_total(&mut self, total: u64) {
        let (w_l, w_r) = (self.w_l, self.w_r);
        if let Some(w) = &mut self.window {
            let per = total as f64 / (w_l + w_r);
            let target = per * w_l;
            w.total = total;
            w.lo = (target - w.below * per).ceil().max(0.0) as u64;
            w.hi = ((target + w.above * per).floor().max(0.0) as u64).min(total);
            if w.lo > w.hi {
                (w.lo, w.hi) = (w.hi, w.hi);
            }
        }
    }

    /// The region's particle count (0 uncapped).
    fn count_total(&self) -> u64 {
        self.window.map_or(0, |w| w.total)
    }

    /// How far `cnt` particles left of the plane lie outside its window (0 inside or uncapped).
    fn outside(&self, cnt: u64) -> u64 {
        match self.window {
            Some(w) if cnt < w.lo => w.lo - cnt,
            Some(w) if cnt > w.hi => cnt - w.hi,
            _ => 0,
        }
    }

    /// Whether the plane must move left: its left side is heavier than its target, or, capped,
    /// holds more particles than the window allows (a predicate monotone along the axis).
    fn left_heavy(&self, left: u64, cnt: u64, total: u64) -> bool {
        let load_heavy = left as f64 * self.w_r > (total - left) as f64 * self.w_l;
        match self.window {
            Some(w) => cnt > w.hi || (cnt >= w.lo && load_heavy),
            None => load_heavy,
        }
    }

    fn consider(&mut self, pos: f64, tie: u64, (left, cnt): (u64, u64), total: u64) -> f64 {
        let res = match self.outside(cnt) {
            0 => eq6_residual(left, total - left, self.w_l, self.w_r),
            out => infeasible(out, self.count_total()),
        };
        let better = match self.best {
            None => true,
            Some((r, ..)) => res < r,
        };
        if better {
            self.best = Some((res, pos, tie, left, cnt));
        }
        res
    }

    fn settle_if_satisfied(&mut self, res: f64) -> bool {
        if res <= self.d {
            self.phase = Phase::Done;
        }
        self.phase == Phase::Done
    }

    /// Next bisection candidate; once the bracket has collapsed to adjacent floats, split the
    /// layer it holds (or stop).
    fn bisect_next(&mut self) {
        let m = self.a + 0.5 * (self.b - self.a);
        if self.a < m && m < self.b {
            self.cand = m;
            self.tie = 0;
            self.phase = Phase::Bisect;
        } else {
            self.split_layer();
        }
    }

    /// The target lies between `(a, ta)` and `(b, tb)` with no float strictly between `a` and
    /// `b`: bisect the ties of the layer at `a` (whose last id is equivalent to `(b, 0)`), or
    /// of the layer at `b` when `tb > 0` and `(b, 0)` is still light.
    fn split_layer(&mut self) {
        let Some(bound) = self.id_bound else {
            self.phase = Phase::Done;
            return;
        };
        if self.a == self.b {
            self.tie_next(self.a, self.ta, self.tb);
        } else if self.tb == 0 {
            self.tie_next(self.a, self.ta, bound);
        } else {
            self.cand = self.b;
            self.tie = 0;
            self.phase = Phase::TieProbe;
        }
    }

    fn tie_next(&mut self, row: f64, lo: u64, hi: u64) {
        if hi > lo + 1 {
            self.cand = row;
            self.tie = lo + (hi - lo) / 2;
            self.phase = Phase::Tie { row, lo, hi };
        } else {
            self.phase = Phase::Done;
        }
    }

    /// Record the global load `left` (and particle count `cnt`, capped) at the current
    /// candidate and choose the next one.
    fn observe(&mut self, (left, cnt): (u64, u64), total: u64, lo: f64, hi: f64) {
        let (c, t) = (self.cand, self.tie);
        let res = self.consider(c, t, (left, cnt), total);
        if self.settle_if_satisfied(res) {
            return;
        }
        let left_heavy = self.left_heavy(left, cnt, total);
        match self.phase {
            Phase::Probe => {
                let (origin, step) = (c, self.h);
                if left_heavy {
                    (self.b, self.tb) = (c, t);
                    self.expand(origin, step, -1.0, total, lo, hi);
                } else {
                    (self.a, self.ta) = (c, t);
                    self.expand(origin, step, 1.0, total, lo, hi);
                }
            }
            Phase::Expand { origin, step, dir } => {
                let away = (dir < 0.0) == left_heavy; // target still further out
                if away {
                    if dir < 0.0 {
                        (self.b, self.tb) = (c, t);
                    } else {
                        (self.a, self.ta) = (c, t);
                    }
                    self.expand(origin, 2.0 * step, dir, total, lo, hi);
                } else {
                    if dir < 0.0 {
                        (self.a, self.ta) = (c, t);
                    } else {
                        (self.b, self.tb) = (c, t);
                    }
                    self.bisect_next();
                }
            }
            Phase::Bisect => {
                if left_heavy {
                    (self.b, self.tb) = (c, t);
                } else {
                    (self.a, self.ta) = (c, t);
                }
                self.bisect_next();
            }
            Phase::TieProbe => {
                let bound = self.id_bound.expect("layers are split only with an id bound");
                if left_heavy {
                    self.tie_next(self.a, self.ta, bound);
                } else {
                    self.tie_next(self.b, 0, self.tb);
                }
            }
            Phase::Tie { row, lo, hi } => {
                if left_heavy {
                    self.tie_next(row, lo, t);
                } else {
                    self.tie_next(row, t, hi);
                }
            }
            Phase::Done => {}
        }
    }

    /// Step to `origin + dir·step`; at a domain face, bracket with the face (known load).
    fn expand(&mut self, origin: f64, step: f64, dir: f64, total: u64, lo: f64, hi: f64) {
        let next = origin + dir * step;
        if dir < 0.0 && next <= lo {
            (self.a, self.ta) = (lo, 0);
            let res = self.consider(lo, 0, (0, 0), total);
            if !self.settle_if_satisfied(res) {
                self.bisect_next();
            }
        } else if dir > 0.0 && next >= hi {
            (self.b, self.tb) = (hi, 0);
            let res = self.consider(hi, 0, (total, self.count_total()), total);
            if !self.settle_if_satisfied(res) {
                self.bisect_next();
            }
        } else {
            self.cand = next;
            self.tie = 0;
            self.phase = Phase::Expand { origin, step, dir };
        }
    }
}

/// Sub-block weights per level: `w[k][q]` for the `regions(k+1)` sub-blocks of level `k`,
/// summed bottom-up in index order.
fn level_weights<const D: usize>(n: &[usize; D], weights: Option<&[f64]>) -> Vec<Vec<f64>> {
    let p: usize = n.iter().product();
    let blocks = match weights {
        Some(w) => {
            assert_eq!(w.len(), p, "one weight per block");
            assert!(
                w.iter().all(|x| x.is_finite() && *x > 0.0),
                "weights must be positive and finite"
            );
            w.to_vec()
        }
        None => vec![1.0; p],
    };
    let mut out = vec![Vec::new(); D];
    out[D - 1] = blocks;
    for k in (0..D - 1).rev() {
        let nk = n[k + 1];
        out[k] = out[k + 1].chunks(nk).map(|c| c.iter().sum()).collect();
    }
    out
}

impl<const D: usize> Decomposition<D> {
    /// Balance from scratch (seed 000, §2.4): the factorisation `n` (see
    /// [`super::factorise`]) is cut level by level; every plane of a level, in every parent
    /// region, starts with the bracket `[lo_k, hi_k]` and its midpoint and is bisected
    /// simultaneously, one `count` call per iteration, until eq. (6) holds with `d_i` or the
    /// fallback applies (module docs).
    ///
    /// Precondition: every particle lies in `[lo, hi)` (the loads at the domain faces are
    /// taken as 0 and the total). `count` must return one load per candidate.
    pub fn balance<F>(
        lo: Vector<D>,
        hi: Vector<D>,
        n: [usize; D],
        params: &BalanceParams,
        count: F,
    ) -> (Self, Report)
    where
        F: FnMut(&Stage<'_, D>) -> Vec<u64>,
    {
        let start = Self::uniform(lo, hi, n);
        search(start, None, params, count)
    }

    /// Incremental rebalance from these planes (docs/methods.md §4). Each plane is first
    /// evaluated where it is (it stays when eq. 6 still holds); otherwise the bracket is
    /// widened geometrically from it, by `bracket`, `2·bracket`, `4·bracket`, … (m) towards the
    /// target, then bisected. Suggested `bracket`: the largest particle displacement since the
    /// last balance, or the particle spacing.
    ///
    /// Bound: if the previous x planes satisfied eq. (6) and no particle moved by more than `s`
    /// since, every x plane moves by at most `max(bracket, 2s)`: the load left of `p ∓ s` is
    /// bracketed by the old load left of `p`, so the widening stops by `p ∓ 2s`. Planes of
    /// later levels also see their parent region change (particles crossing moved planes);
    /// for smooth densities their displacement is of the same order (asserted in the tests).
    pub fn rebalance<F>(&self, params: &BalanceParams, bracket: f64, count: F) -> (Self, Report)
    where
        F: FnMut(&Stage<'_, D>) -> Vec<u64>,
    {
        assert!(
            bracket.is_finite() && bracket > 0.0,
            "bracket must be a positive length"
        );
        search(self.clone(), Some(bracket), params, count)
    }
}

/// The level-by-level search. `bracket`: `None` from scratch, `Some(h)` to rebalance from the
/// planes already in `decomp`.
fn search<const D: usize, F>(
    mut decomp: Decomposition<D>,
    bracket: Option<f64>,
    params: &BalanceParams,
    mut count: F,
) -> (Decomposition<D>, Report)
where
    F: FnMut(&Stage<'_, D>) -> Vec<u64>,
{
    assert!(params.eta > 0.0 && params.eta < 0.5, "eta must lie in (0, 0.5)");
    assert!(params.max_iter >= 1, "max_iter must be at least 1");
    let capped = params.max_count.is_some();
    if let Some(c) = params.max_count {
        assert!(c >= 1.0 && c.is_finite(), "max_count must be at least 1");
    }
    let n = decomp.n;
    let wl = level_weights(&n, params.weights.as_deref());
    // the cap per level that cuts (module docs: count cap)
    let cutting = n.iter().filter(|&&m| m > 1).count().max(1);
    let cap_k = params.max_count.map(|c| c.powf(1.0 / cutting as f64));
    let previous = decomp.clone();
    let mut report = Report::default();
    // Region totals of the current level (loads; particle counts when capped); level 0's come
    // from a `+∞` candidate.
    let mut totals: Option<Vec<u64>> = None;
    let mut ctotals: Vec<u64> = Vec::new();
    for k in 0..D {
        let nk = n[k];
        let m = nk - 1;
        let nreg = decomp.regions(k);
        let (lo, hi) = (decomp.lo[k], decomp.hi[k]);
        let old: Vec<f64> = decomp.planes[k].clone();
        let old_ties: Vec<u64> = decomp.ties[k].clone();
        let planes0 = LevelPlanes {
            weights: &wl[k],
            nk,
            lo,
            hi,
            cap: cap_k,
            bracket,
            old: (&old, &old_ties),
        };
        let mut planes = planes0.build(nreg, params);
        let level = Level {
            m,
            lo,
            hi,
            rebalance: bracket.is_some(),
        };
        if let Some(t) = &totals {
            init_level(&mut planes, (t, &ctotals), &level, (&old, &old_ties));
        }
        let mut calls = 0;
        loop {
            let first = totals.is_none();
            if !first && (calls == params.max_iter || planes.iter().all(|p| p.phase == Phase::Done)) {
                break;
            }
            let (idx, mut loads, mut counts) = ask(&decomp, k, &planes, first, capped, &mut count);
            calls += 1;
            if first {
                totals = Some(vec![loads.pop().expect("the total")]);
                ctotals = if capped {
                    counts.pop().into_iter().collect()
                } else {
                    Vec::new()
                };
                let t = totals.as_ref().expect("just set");
                init_level(&mut planes, (t, &ctotals), &level, (&old, &old_ties));
            }
            let t = totals.as_ref().expect("known after the first call");
            for (j, (&q, &left)) in idx.iter().zip(&loads).enumerate() {
                if planes[q].phase != Phase::Done {
                    let tot = t[q / m];
                    assert!(left <= tot, "load left of a plane exceeds its region's total");
                    let cnt = counts.get(j).copied().unwrap_or(0);
                    planes[q].observe((left, cnt), tot, lo, hi);
                }
            }
        }
        let t = totals.take().expect("totals known");
        let fin = finish_level(&planes, (&t, &ctotals), m);
        let moved = bracket.map(|_| previous.planes(k));
        let (positions, ties) = report.record(fin, moved, calls, &planes);
        decomp.set_level(k, positions, ties);
        totals = Some(std::mem::take(&mut report.block_loads));
        ctotals = std::mem::take(&mut report.block_counts);
    }
    report.block_loads = totals.expect("loads of the last level");
    report.block_counts = ctotals;
    (decomp, report)
}

/// The planes of one level before its search, region-major: each with its weights left and
/// right, eq. (6)'s tolerance, its start (the middle from scratch, where it was on rebalance)
/// and, capped, its count window (module docs: count cap).
struct LevelPlanes<'w> {
    /// Sub-block weights of the level, `nk` per region.
    weights: &'w [f64],
    nk: usize,
    lo: f64,
    hi: f64,
    /// The cap per level (`c^(1/L)`), when capped.
    cap: Option<f64>,
    bracket: Option<f64>,
    /// The level's previous planes and ties, region-major.
    old: (&'w [f64], &'w [u64]),
}

impl LevelPlanes<'_> {
    fn build(&self, nreg: usize, params: &BalanceParams) -> Vec<Plane> {
        let (nk, lo, hi) = (self.nk, self.lo, self.hi);
        let m = nk - 1;
        let (old, old_ties) = self.old;
        let mut planes = Vec::with_capacity(nreg * m);
        for r in 0..nreg {
            let w = &self.weights[r * nk..(r + 1) * nk];
            let wsum: f64 = w.iter().sum();
            let mut w_l = 0.0;
            for i in 0..m {
                w_l += w[i];
                let w_r = wsum - w_l;
                let d = tolerance(params.eta, w_l, w_r, w[i].min(w[i + 1]));
                let (cand, tie, phase) = match self.bracket {
                    None => (lo + 0.5 * (hi - lo), 0, Phase::Bisect),
                    Some(_) => {
                        let q = r * m + i;
                        let c = old[q].clamp(lo, hi);
                        (c, if c == old[q] { old_ties[q] } else { 0 }, Phase::Probe)
                    }
                };
                // a sub-block's slack goes whole to its one plane, or half to each of two
                let share = |j: usize| if j == 0 || j == nk - 1 { 1.0 } else { 0.5 };
                let window = self.cap.map(|c| CountWindow {
                    above: (c - 1.0) * w[i] * share(i),
                    below: (c - 1.0) * w[i + 1] * share(i + 1),
                    ..CountWindow::default()
                });
                planes.push(Plane {
                    w_l,
                    w_r,
                    d,
                    h: self.bracket.unwrap_or(0.0),
                    a: lo,
                    ta: 0,
                    b: hi,
                    tb: 0,
                    cand,
                    tie,
                    phase,
                    id_bound: params.id_bound,
                    window,
                    best: None,
                });
            }
        }
        planes
    }
}

/// One counting round of level `k`: the candidate of every plane still searching (of every
/// plane, and `+∞` for the total, on level 0's `first` call) is answered by `count`. Returns
/// the planes asked and the loads and, `capped`, particle counts left of each candidate (the
/// total last on the first call).
fn ask<const D: usize, F>(
    decomp: &Decomposition<D>,
    k: usize,
    planes: &[Plane],
    first: bool,
    capped: bool,
    count: &mut F,
) -> (Vec<usize>, Vec<u64>, Vec<u64>)
where
    F: FnMut(&Stage<'_, D>) -> Vec<u64>,
{
    let m = decomp.n[k] - 1;
    let mut cands = Vec::new();
    let mut ties = Vec::new();
    let mut regs = Vec::new();
    let mut idx = Vec::new();
    for (q, p) in planes.iter().enumerate() {
        if first || p.phase != Phase::Done {
            cands.push(p.cand);
            ties.push(p.tie);
            regs.push(q / m);
            idx.push(q);
        }
    }
    if first {
        cands.push(f64::INFINITY);
        ties.push(0);
        regs.push(0);
    }
    let ncand = cands.len();
    let stage = Stage {
        decomp,
        axis: k,
        candidates: cands,
        ties,
        regions: regs,
        counts: capped,
    };
    let mut loads = count(&stage);
    assert_eq!(
        loads.len(),
        ncand * (1 + capped as usize),
        "count must answer every candidate"
    );
    let counts = loads.split_off(ncand);
    (idx, loads, counts)
}

impl Report {
    /// Keep a finished level's calls, loads, residuals, tolerances and (rebalancing from
    /// `previous` planes) displacements; its sub-blocks' loads and counts are left in
    /// `block_loads` and `block_counts`. Returns the planes and ties.
    fn record(
        &mut self,
        fin: LevelResult,
        previous: Option<&[f64]>,
        calls: usize,
        planes: &[Plane],
    ) -> (Vec<f64>, Vec<u64>) {
        if let Some(prev) = previous {
            let moved = fin.positions.iter().zip(prev).map(|(a, b)| (a - b).abs());
            self.displacement.push(moved.collect());
        }
        self.calls.push(calls);
        self.left_load.push(fin.left_load);
        self.residual.push(fin.residual);
        self.tolerance.push(planes.iter().map(|p| p.d).collect());
        self.block_loads = fin.sub_loads;
        self.block_counts = fin.sub_counts;
        (fin.positions, fin.ties)
    }
}

/// The planes of a finished level, region-major, with what the report keeps of them.
struct LevelResult {
    positions: Vec<f64>,
    ties: Vec<u64>,
    left_load: Vec<u64>,
    residual: Vec<f64>,
    /// Load of every sub-block: the next level's region totals.
    sub_loads: Vec<u64>,
    /// Particles of every sub-block (capped; else empty).
    sub_counts: Vec<u64>,
}

/// Each plane takes the best candidate it saw, made ascending in (position, tie) within its
/// region; `t`: the regions' total loads (and particle counts, capped), `m` planes per region.
fn finish_level(planes: &[Plane], (t, ct): (&[u64], &[u64]), m: usize) -> LevelResult {
    let mut out = LevelResult {
        positions: Vec::with_capacity(planes.len()),
        ties: Vec::with_capacity(planes.len()),
        left_load: Vec::with_capacity(planes.len()),
        residual: Vec::with_capacity(planes.len()),
        sub_loads: Vec::with_capacity(t.len() * (m + 1)),
        sub_counts: Vec::with_capacity(ct.len() * (m + 1)),
    };
    for (r, &total) in t.iter().enumerate() {
        let mut prev: Option<(f64, u64, u64, u64)> = None;
        let (mut last_left, mut last_cnt) = (0u64, 0u64);
        for p in &planes[r * m..(r + 1) * m] {
            let (_, mut pos, mut tie, mut left, mut cnt) = p.best.expect("every plane has a candidate");
            if let Some((pp, pt, pl, pc)) = prev {
                if pos < pp || (pos == pp && tie < pt) {
                    (pos, tie, left, cnt) = (pp, pt, pl, pc);
                }
            }
            prev = Some((pos, tie, left, cnt));
            out.positions.push(pos);
            out.ties.push(tie);
            out.left_load.push(left);
            out.residual.push(eq6_residual(left, total - left, p.w_l, p.w_r));
            let ascending = "ascending planes have ascending loads";
            out.sub_loads.push(left.checked_sub(last_left).expect(ascending));
            if !ct.is_empty() {
                out.sub_counts.push(cnt.checked_sub(last_cnt).expect(ascending));
            }
            (last_left, last_cnt) = (left, cnt);
        }
        out.sub_loads.push(total - last_left);
        if let Some(&c) = ct.get(r) {
            out.sub_counts.push(c - last_cnt);
        }
    }
    out
}

/// What [`init_level`] needs of a level: `m` planes per region, the axis's extent, and
/// whether planes start where they were.
struct Level {
    m: usize,
    lo: f64,
    hi: f64,
    rebalance: bool,
}

/// Once the region totals are known: empty regions are settled (uniform shares from
/// scratch, previous planes on rebalance); from scratch the domain faces enter as bracket
/// ends with known loads.
fn init_level(
    planes: &mut [Plane],
    (totals, counts): (&[u64], &[u64]),
    level: &Level,
    (old, old_ties): (&[f64], &[u64]),
) {
    let Level { m, lo, hi, rebalance } = *level;
    for (q, p) in planes.iter_mut().enumerate() {
        let tot = totals[q / m];
        let cnt = counts.get(q / m).copied().unwrap_or(0);
        p.set_count_total(cnt);
        if tot == 0 {
            let (pos, tie) = if rebalance {
                (old[q], old_ties[q])
            } else {
                (lo + (hi - lo) * p.w_l / (p.w_l + p.w_r), 0)
            };
            p.best = Some((0.0, pos, tie, 0, 0));
            p.phase = Phase::Done;
        } else if !rebalance {
            for (pos, left) in [(lo, (0, 0)), (hi, (tot, cnt))] {
                let res = p.consider(pos, 0, left, tot);
                p.settle_if_satisfied(res);
            }
        }
    }
}
