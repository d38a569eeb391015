//! Placement of blocks (subdomains) on ranks, and the halo traffic it sends inside and across
//! nodes.
//!
//! A placement is fixed at start: block `b` of the [`Decomposition`] lives on rank
//! `placement[b]` for the whole run (rebalancing only moves cut planes, so a rank keeps roughly
//! its region and its node keeps its neighbours). Ranks map to nodes through a [`Topology`]
//! (consecutive ranks share a node). Methods ([`Placement`]):
//!
//! - `rank-order`: block `i` on rank `i` (blocks numbered nested x → y → z, z fastest);
//! - `centre-distance` (seed 000, `docs/methods.md` §4): nodes are filled one at a time, in node
//!   order. A node starts with the unassigned block whose centre is smallest in lexicographic
//!   `(x, y, z)` order, then repeatedly takes the unassigned block whose centre is nearest
//!   (Euclidean, m) to the centroid (unweighted mean) of the centres of the blocks it already
//!   holds, until it holds as many blocks as it has ranks. Within the node, blocks go to the
//!   node's ranks **in the order they were chosen** (first chosen → lowest rank).
//! - `node-grid`: seed 000's factorisation applied at node level. Every factorisation
//!   `mx·my(·mz) = nodes` whose factors divide the block counts `(Nx, Ny(, Nz))` gives each node a
//!   compact sub-grid of `(Nx/mx)×(Ny/my)(×(Nz/mz))` blocks (nodes numbered nested over the node
//!   grid); the one moving the fewest inter-node halo bytes (`weights`) wins, ties by eq. 5's
//!   `r_diff` of the node boxes ([`crate::decomp::r_diff`]), then lexicographically largest (as
//!   [`crate::decomp::factorise`]). Within a node, blocks go to ranks in ascending block number.
//!   When no factorisation fits (or nodes hold unequal numbers of ranks) it falls back to
//!   `centre-distance`.
//! - `min-cut`: graph partitioning of the block adjacency graph weighted by halo volume
//!   (`weights`, both directions). Each of `centre-distance`, `node-grid` and `rank-order` is
//!   refined by Kernighan–Lin passes of pairwise block swaps between nodes (see `refine`: the
//!   best swap of unlocked blocks, negative gains allowed, then the best prefix of the pass is
//!   kept; ties by smallest block pair), and the refined assignment moving the fewest
//!   inter-node bytes wins (ties in that order). Node capacities are kept by construction and
//!   refinement never increases the cut, so `min-cut` never moves more inter-node bytes than
//!   any of the three. Within a node, blocks go to ranks in ascending block number.
//!
//! Every method is deterministic: no hash-map iteration, explicit tie-breaks.
//!
//! The halo estimator ([`halo_volumes`]) needs no communication: from all particle positions
//! and the decomposition it counts the ghosts each block sends each other block. It ignores
//! periodic images (a particle near a periodic face is not counted towards the block across the
//! wrap) and mirror images (those stay on the rank).

use crate::decomp::{fold_parts, r_diff, Cloud, Decomposition};
use crate::error::{Error, Result};
use crate::topology::Topology;
use crate::Vector;
use rayon::prelude::*;
use std::fmt;
use std::str::FromStr;

/// How blocks are placed on ranks (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, clap::ValueEnum)]
pub enum Placement {
    /// Block `i` on rank `i`.
    #[default]
    RankOrder,
    /// Seed 000: fill nodes by distance between block centres.
    CentreDistance,
    /// Factorise the node count over the block grid: compact sub-grids per node.
    NodeGrid,
    /// Best of the above, refined by pairwise swaps weighted by halo volume.
    MinCut,
}

impl Placement {
    /// Every method, in a fixed order (`--placement all`).
    pub const ALL: [Placement; 4] = [
        Placement::RankOrder,
        Placement::CentreDistance,
        Placement::NodeGrid,
        Placement::MinCut,
    ];

    /// Name as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Placement::RankOrder => "rank-order",
            Placement::CentreDistance => "centre-distance",
            Placement::NodeGrid => "node-grid",
            Placement::MinCut => "min-cut",
        }
    }
}

impl fmt::Display for Placement {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Placement {
    type Err = Error;

    /// Parse a method name; an unknown name is an [`Error::Input`] on key `placement` listing
    /// the valid ones.
    fn from_str(s: &str) -> Result<Self> {
        Placement::ALL.into_iter().find(|p| p.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Placement::ALL.iter().map(|p| p.name()).collect();
            Error::input(
                "placement",
                format!("unknown placement `{s}`; valid: {} (or `all`)", names.join(", ")),
            )
        })
    }
}

/// A dense block × block matrix of halo volume: `get(a, b)` is what block `a` sends block `b`
/// in one exchange. Units are the producer's: particle counts from [`halo_volumes`], bytes
/// after [`PairVolumes::scaled`]. The diagonal is zero (a block sends itself nothing).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PairVolumes {
    n: usize,
    v: Vec<u64>,
}

impl PairVolumes {
    /// All-zero volumes between `n` blocks (placement then uses geometry only).
    pub fn zeros(n: usize) -> Self {
        PairVolumes { n, v: vec![0; n * n] }
    }

    /// Number of blocks.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Volume block `src` sends block `dst`.
    pub fn get(&self, src: usize, dst: usize) -> u64 {
        self.v[src * self.n + dst]
    }

    /// Add `x` to what `src` sends `dst`.
    ///
    /// # Panics
    /// If `src == dst` (a block never sends itself halo).
    pub fn add(&mut self, src: usize, dst: usize, x: u64) {
        assert_ne!(src, dst, "a block sends itself no halo");
        self.v[src * self.n + dst] += x;
    }

    /// Volume in both directions between `a` and `b` (the edge weight of the block graph).
    pub fn both_ways(&self, a: usize, b: usize) -> u64 {
        self.get(a, b) + self.get(b, a)
    }

    /// Every volume multiplied by `k`, e.g. bytes per ghost particle to turn counts into bytes.
    pub fn scaled(&self, k: u64) -> Self {
        PairVolumes {
            n: self.n,
            v: self.v.iter().map(|&x| x * k).collect(),
        }
    }

    /// Every volume, row-major (`a * n + b`), to sum over ranks.
    pub fn counts_mut(&mut self) -> &mut [u64] {
        &mut self.v
    }

    /// Sum of all volumes.
    pub fn total(&self) -> u64 {
        self.v.iter().sum()
    }
}

/// Ghost particles each block sends each other block in one halo exchange, with no
/// communication: a particle owned by block `a` ([`Decomposition::block_of`]) is sent to every
/// block `b ≠ a` whose box widened by `support` (m) on every side contains it (same rule as
/// [`Decomposition::blocks_overlapping`] on the particle's box `x ± support`). Periodic images
/// are ignored (module docs). Integer counts, so the result does not depend on thread count.
///
/// Memory: one dense `P × P` counter per rayon work item (`P` = blocks).
pub fn halo_volumes<const D: usize, C: Cloud<D>>(
    cloud: &C,
    decomp: &Decomposition<D>,
    support: f64,
) -> PairVolumes {
    assert!(
        support.is_finite() && support >= 0.0,
        "support radius must be ≥ 0 (m)"
    );
    let n = decomp.n_blocks();
    let w = Vector::<D>::repeat(support);
    let v = fold_parts(
        cloud,
        || vec![0u64; n * n],
        |acc, k| {
            cloud.visit(k, |x, id, _| {
                let a = decomp.block_of(x, id);
                for b in decomp.blocks_overlapping(&(x - w), &(x + w)) {
                    if b != a {
                        acc[a * n + b] += 1;
                    }
                }
            })
        },
        |mut a, b| {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
            a
        },
    );
    PairVolumes { n, v }
}

/// Place the blocks of `decomp` on the ranks of `topology` by `method`; returns `block →
/// rank`, a bijection. `weights` is the halo volume between blocks (e.g. [`halo_volumes`],
/// any unit); only `node-grid` and `min-cut` read it, and all-zero weights are allowed.
///
/// # Panics
/// If the decomposition's block count differs from the topology's ranks or from `weights.n()`
/// (callers check the layout first with [`Topology::check_ranks`]).
pub fn place<const D: usize>(
    decomp: &Decomposition<D>,
    topology: &Topology,
    method: Placement,
    weights: &PairVolumes,
) -> Vec<usize> {
    place_reporting(decomp, topology, method, weights).0
}

/// [`place`], also returning the method that actually placed the blocks: `node-grid` falls
/// back to `centre-distance` when no factorisation of the nodes over the block grid fits.
pub fn place_reporting<const D: usize>(
    decomp: &Decomposition<D>,
    topology: &Topology,
    method: Placement,
    weights: &PairVolumes,
) -> (Vec<usize>, Placement) {
    let p = decomp.n_blocks();
    assert_eq!(p, topology.ranks(), "one block per rank");
    assert_eq!(p, weights.n(), "one weight row per block");
    match method {
        Placement::RankOrder => ((0..p).collect(), method),
        Placement::CentreDistance => (centre_distance(decomp, topology), method),
        Placement::NodeGrid => match node_grid(decomp, topology, weights) {
            Some(b) => (b, method),
            None => (centre_distance(decomp, topology), Placement::CentreDistance),
        },
        Placement::MinCut => (min_cut(decomp, topology, weights), method),
    }
}

/// Inverse of a placement: `rank → block`.
///
/// # Panics
/// If `block_to_rank` is not a permutation of `0..len`.
pub fn invert(block_to_rank: &[usize]) -> Vec<usize> {
    let mut out = vec![usize::MAX; block_to_rank.len()];
    for (b, &r) in block_to_rank.iter().enumerate() {
        assert!(
            r < out.len() && out[r] == usize::MAX,
            "not a permutation: rank {r}"
        );
        out[r] = b;
    }
    out
}

/// Centre (m) of block `b`'s box.
fn centre<const D: usize>(decomp: &Decomposition<D>, b: usize) -> Vector<D> {
    let (lo, hi) = decomp.block_box(b);
    (lo + hi) * 0.5
}

/// Lexicographic order of two points, coordinate by coordinate (`total_cmp`).
fn lex<const D: usize>(a: &Vector<D>, b: &Vector<D>) -> std::cmp::Ordering {
    (0..D)
        .map(|k| a[k].total_cmp(&b[k]))
        .find(|o| o.is_ne())
        .unwrap_or(std::cmp::Ordering::Equal)
}

/// Seed 000's assignment (module docs).
fn centre_distance<const D: usize>(decomp: &Decomposition<D>, topology: &Topology) -> Vec<usize> {
    let p = decomp.n_blocks();
    let centres: Vec<Vector<D>> = (0..p).map(|b| centre(decomp, b)).collect();
    let mut out = vec![usize::MAX; p];
    let mut free = vec![true; p];
    for node in 0..topology.nodes() {
        let ranks = topology.ranks_of(node);
        // Seed: smallest centre in (x, y, z) order; ties by block number (the first found).
        let mut seed = None::<usize>;
        for b in (0..p).filter(|&b| free[b]) {
            if seed.is_none_or(|s| lex(&centres[b], &centres[s]).is_lt()) {
                seed = Some(b);
            }
        }
        let Some(seed) = seed else { break };
        let mut chosen = vec![seed];
        free[seed] = false;
        let mut sum = centres[seed];
        while chosen.len() < ranks.len() {
            let c = sum / chosen.len() as f64;
            // Nearest to the centroid; ties: smaller centre (lexicographic), then block number.
            let mut best = None::<(f64, usize)>;
            for b in (0..p).filter(|&b| free[b]) {
                let d = (centres[b] - c).norm_squared();
                let better = match best {
                    None => true,
                    Some((bd, bb)) => d < bd || (d == bd && lex(&centres[b], &centres[bb]).is_lt()),
                };
                if better {
                    best = Some((d, b));
                }
            }
            let (_, b) = best.expect("enough free blocks for every rank");
            free[b] = false;
            sum += centres[b];
            chosen.push(b);
        }
        for (b, r) in chosen.into_iter().zip(ranks) {
            out[b] = r;
        }
    }
    out
}

/// Block → node for a placement.
fn nodes_of(block_to_rank: &[usize], topology: &Topology) -> Vec<usize> {
    block_to_rank.iter().map(|&r| topology.node_of(r)).collect()
}

/// Inter-node volume of a block → node assignment (both directions counted once each).
fn cut(node: &[usize], w: &PairVolumes) -> u64 {
    let p = node.len();
    let mut s = 0;
    for a in 0..p {
        for b in 0..p {
            if node[a] != node[b] {
                s += w.get(a, b);
            }
        }
    }
    s
}

/// Ranks from a block → node assignment: within each node, blocks in ascending number take the
/// node's ranks in ascending order.
fn ranks_from_nodes(node: &[usize], topology: &Topology) -> Vec<usize> {
    let mut next: Vec<usize> = (0..topology.nodes())
        .map(|n| topology.ranks_of(n).start)
        .collect();
    node.iter()
        .map(|&n| {
            let r = next[n];
            next[n] += 1;
            r
        })
        .collect()
}

/// `node-grid` (module docs); `None` when no node factorisation fits the block grid.
fn node_grid<const D: usize>(
    decomp: &Decomposition<D>,
    topology: &Topology,
    w: &PairVolumes,
) -> Option<Vec<usize>> {
    let nodes = topology.nodes();
    if !topology.ranks().is_multiple_of(topology.ranks_per_node()) {
        return None;
    }
    let n = decomp.factors();
    let (lo, hi) = decomp.domain();
    let extents: Vec<f64> = (0..D).map(|k| hi[k] - lo[k]).collect();
    let assign = |m: &[usize]| -> Vec<usize> {
        (0..decomp.n_blocks())
            .map(|b| {
                let c = decomp.block_coords(b);
                (0..D).fold(0, |id, k| id * m[k] + c[k] / (n[k] / m[k]))
            })
            .collect()
    };
    // Candidates in ascending lexicographic order; keep the last of the best (largest on ties).
    let mut best: Option<(u64, f64, Vec<usize>)> = None;
    for m in crate::decomp::ordered_factorisations(nodes, D) {
        if (0..D).any(|k| !n[k].is_multiple_of(m[k])) {
            continue;
        }
        let node = assign(&m);
        let key = (cut(&node, w), r_diff(&m, &extents));
        let better = match &best {
            None => true,
            Some((c, r, _)) => key.0 < *c || (key.0 == *c && key.1 <= *r),
        };
        if better {
            best = Some((key.0, key.1, node));
        }
    }
    best.map(|(_, _, node)| ranks_from_nodes(&node, topology))
}

/// `min-cut` (module docs): refine every start, keep the cheapest result.
fn min_cut<const D: usize>(decomp: &Decomposition<D>, topology: &Topology, w: &PairVolumes) -> Vec<usize> {
    let p = decomp.n_blocks();
    let mut starts = vec![centre_distance(decomp, topology)];
    starts.extend(node_grid(decomp, topology, w));
    starts.push((0..p).collect());
    let mut best: Option<(u64, Vec<usize>)> = None;
    for s in &starts {
        let node = refine(nodes_of(s, topology), topology.nodes(), w);
        let c = cut(&node, w);
        // Strictly better only: ties keep the earlier start (centre-distance, node-grid, rank-order).
        if best.as_ref().is_none_or(|(bc, _)| c < *bc) {
            best = Some((c, node));
        }
    }
    let (_, node) = best.expect("at least one start");
    ranks_from_nodes(&node, topology)
}

/// Longest sequence of tentative swaps in one Kernighan–Lin pass.
const KL_MAX_MOVES: usize = 128;
/// Most passes of [`refine`] (each pass that is kept lowers the cut, so this is a safety cap).
const KL_MAX_PASSES: usize = 100;

/// Kernighan–Lin refinement of a block → node assignment with edge weights
/// `w.both_ways(a, b)`: each pass swaps, one pair at a time, the unlocked pair of blocks on
/// different nodes with the largest gain (reduction of inter-node volume; negative gains
/// allowed, ties: smallest `(a, b)`, `a < b`), locks both, and at the end of the pass keeps the
/// prefix of swaps with the largest cumulative gain. Passes repeat while that gain is positive.
/// Only pairs where one block talks to the other's node are candidates (others cannot gain).
/// Node sizes never change; the cut never increases.
fn refine(mut node: Vec<usize>, nodes: usize, w: &PairVolumes) -> Vec<usize> {
    let p = node.len();
    let edge = |a: usize, b: usize| w.both_ways(a, b) as i128;
    // ext[b * nodes + x]: volume between block b and the blocks on node x (both directions).
    let mut ext = vec![0i128; p * nodes];
    for a in 0..p {
        for b in 0..p {
            if a != b {
                ext[a * nodes + node[b]] += edge(a, b);
            }
        }
    }
    let swap = |node: &mut Vec<usize>, ext: &mut Vec<i128>, a: usize, b: usize| {
        let (na, nb) = (node[a], node[b]);
        for c in 0..p {
            if c != a {
                let e = edge(c, a);
                ext[c * nodes + na] -= e;
                ext[c * nodes + nb] += e;
            }
            if c != b {
                let e = edge(c, b);
                ext[c * nodes + nb] -= e;
                ext[c * nodes + na] += e;
            }
        }
        node[a] = nb;
        node[b] = na;
    };
    for _ in 0..KL_MAX_PASSES {
        let mut locked = vec![false; p];
        let mut moves = Vec::new();
        let (mut sum, mut best_sum, mut best_len) = (0i128, 0i128, 0usize);
        while moves.len() < KL_MAX_MOVES.min(p / 2) {
            // the best swap: largest gain, then smallest (a, b) — the same pair a sequential
            // scan in (a, b) order keeps, found in parallel over a (integer gains: exact)
            let better = |x: Option<(i128, usize, usize)>, y: Option<(i128, usize, usize)>| match (x, y) {
                (Some(u), Some(v)) => Some(if v.0 > u.0 || (v.0 == u.0 && (v.1, v.2) < (u.1, u.2)) {
                    v
                } else {
                    u
                }),
                (u, None) => u,
                (None, v) => v,
            };
            let (node_r, ext_r, locked_r) = (&node, &ext, &locked);
            let best = (0..p)
                .into_par_iter()
                .filter(|&a| !locked_r[a])
                .map(|a| {
                    let na = node_r[a];
                    let mut best: Option<(i128, usize, usize)> = None;
                    for b in (a + 1..p).filter(|&b| !locked_r[b] && node_r[b] != na) {
                        let nb = node_r[b];
                        if ext_r[a * nodes + nb] == 0 && ext_r[b * nodes + na] == 0 {
                            continue;
                        }
                        let gain = ext_r[a * nodes + nb] - ext_r[a * nodes + na] + ext_r[b * nodes + na]
                            - ext_r[b * nodes + nb]
                            - 2 * edge(a, b);
                        if best.is_none_or(|(g, _, _)| gain > g) {
                            best = Some((gain, a, b));
                        }
                    }
                    best
                })
                .reduce(|| None, better);
            let Some((gain, a, b)) = best else { break };
            swap(&mut node, &mut ext, a, b);
            locked[a] = true;
            locked[b] = true;
            moves.push((a, b));
            sum += gain;
            if sum > best_sum {
                (best_sum, best_len) = (sum, moves.len());
            }
        }
        for &(a, b) in moves[best_len..].iter().rev() {
            swap(&mut node, &mut ext, a, b);
        }
        if best_sum <= 0 {
            break;
        }
    }
    node
}

/// Halo traffic of one exchange split by node (see [`traffic_split`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TrafficSplit {
    /// Bytes between distinct ranks of one node.
    pub intra_node_bytes: u64,
    /// Bytes between ranks of different nodes.
    pub inter_node_bytes: u64,
    /// Unordered node pairs `{m, n}`, `m ≠ n`, with any bytes in either direction.
    pub node_pairs_talking: usize,
    /// Largest inter-node volume of any node: bytes it sends to plus receives from other nodes.
    pub max_node_inter_bytes: u64,
}

impl TrafficSplit {
    /// Inter-node share of all bytes between distinct ranks (0 when there is no traffic).
    pub fn inter_fraction(&self) -> f64 {
        let total = self.intra_node_bytes + self.inter_node_bytes;
        if total == 0 {
            0.0
        } else {
            self.inter_node_bytes as f64 / total as f64
        }
    }

    /// Split `(src rank, dst rank, bytes)` triples by node; self-sends are left out.
    pub fn from_rank_pairs<I: IntoIterator<Item = (usize, usize, u64)>>(
        pairs: I,
        topology: &Topology,
    ) -> Self {
        let nodes = topology.nodes();
        let mut between = vec![0u64; nodes * nodes];
        let mut s = TrafficSplit::default();
        for (src, dst, bytes) in pairs {
            if src == dst || bytes == 0 {
                continue;
            }
            let (m, n) = (topology.node_of(src), topology.node_of(dst));
            if m == n {
                s.intra_node_bytes += bytes;
            } else {
                s.inter_node_bytes += bytes;
                between[m * nodes + n] += bytes;
            }
        }
        for m in 0..nodes {
            let mut own = 0;
            for n in 0..nodes {
                own += between[m * nodes + n] + between[n * nodes + m];
                if m < n && between[m * nodes + n] + between[n * nodes + m] > 0 {
                    s.node_pairs_talking += 1;
                }
            }
            s.max_node_inter_bytes = s.max_node_inter_bytes.max(own);
        }
        s
    }
}

/// Split the halo volume `bytes` (block × block, bytes, e.g. `halo_volumes(..).scaled(b)`) of a
/// placement `block_to_rank` into intra- and inter-node traffic of `topology`.
pub fn traffic_split(bytes: &PairVolumes, block_to_rank: &[usize], topology: &Topology) -> TrafficSplit {
    let p = bytes.n();
    assert_eq!(p, block_to_rank.len(), "one rank per block");
    let pairs =
        (0..p).flat_map(|a| (0..p).map(move |b| (block_to_rank[a], block_to_rank[b], bytes.get(a, b))));
    TrafficSplit::from_rank_pairs(pairs, topology)
}

/// Split measured traffic-log entries (any phases the caller selects) by node.
pub fn split_entries(entries: &[crate::comm::TrafficEntry], topology: &Topology) -> TrafficSplit {
    TrafficSplit::from_rank_pairs(entries.iter().map(|e| (e.src, e.dst, e.bytes)), topology)
}

#[cfg(test)]
mod tests;
