use super::*;
use crate::decomp::{factorise, BalanceParams};
use crate::topology::Topology;
use crate::Vector;

type V3 = Vector<3>;

/// Bytes per ghost particle used by the tests (3D: position, velocity, density, mass, pressure
/// and a flag ≈ 80 B). The percentages do not depend on it.
const BYTES_PER_GHOST: u64 = 80;

/// Support radius for Wendland C2 with h = 1.3 dp (the scene defaults): 2.6 dp (m).
fn support(dp: f64) -> f64 {
    2.0 * 1.3 * dp
}

/// Cell-centred lattice points of spacing `dp` (m) in the box `[lo, hi)` kept by `keep`.
fn lattice(lo: V3, hi: V3, dp: f64, keep: impl Fn(&V3) -> bool, out: &mut Vec<V3>) {
    let n: Vec<usize> = (0..3).map(|k| ((hi[k] - lo[k]) / dp).round() as usize).collect();
    for i in 0..n[0] {
        for j in 0..n[1] {
            for k in 0..n[2] {
                let x = lo + V3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * dp;
                if keep(&x) {
                    out.push(x);
                }
            }
        }
    }
}

/// Impact-like cloud: a sphere of 4 mm diameter whose lowest point is 1 mm above a
/// 40 mm × 40 mm × 2 mm plate, spacing `dp` (m).
fn impact_cloud(dp: f64) -> Vec<V3> {
    let mut pts = Vec::new();
    lattice(
        V3::new(-0.02, -0.02, 0.0),
        V3::new(0.02, 0.02, 0.002),
        dp,
        |_| true,
        &mut pts,
    );
    let (c, r) = (V3::new(0.0, 0.0, 0.005), 0.002);
    lattice(
        c - V3::repeat(r),
        c + V3::repeat(r),
        dp,
        |x| (x - c).norm() <= r,
        &mut pts,
    );
    pts
}

/// 3D dam-break-like cloud (SPHERIC test 2 proportions): a 3.22 m × 1 m × 1 m open tank with
/// three layers of wall particles (bottom and four sides) and a water column of
/// 1.228 m × 1 m × 0.55 m against the x = 0 wall, spacing `dp` (m).
fn dam_break_cloud(dp: f64) -> Vec<V3> {
    let (l, w, h) = (3.22, 1.0, 1.0);
    let t = 3.0 * dp;
    let mut pts = Vec::new();
    lattice(
        V3::new(0.0, 0.0, 0.0),
        V3::new(1.228, w, 0.55),
        dp,
        |_| true,
        &mut pts,
    );
    let inside = |x: &V3| x[0] > 0.0 && x[0] < l && x[1] > 0.0 && x[1] < w && x[2] > 0.0;
    lattice(
        V3::new(-t, -t, -t),
        V3::new(l + t, w + t, h),
        dp,
        |x| !inside(x),
        &mut pts,
    );
    pts
}

/// Seed 000's decomposition of `pts` over `p` ranks: eq. 5 factorisation of the cloud extents,
/// then eq. 6 bisection with particle-count loads.
fn decompose(pts: &[V3], p: usize) -> Decomposition<3> {
    let mut lo = pts[0];
    let mut hi = pts[0];
    for x in pts {
        lo = lo.inf(x);
        hi = hi.sup(x);
    }
    let ext = hi - lo;
    let f = factorise(p, &[ext[0], ext[1], ext[2]]);
    let hi = hi + ext * 1e-6; // every particle inside [lo, hi)
    let (d, rep) = Decomposition::balance(lo, hi, [f[0], f[1], f[2]], &BalanceParams::default(), |s| {
        s.count_local(pts.iter().enumerate().map(|(i, x)| (*x, i as u64, 1u64)))
    });
    println!("  decomposition: max/mean load {:.3}", rep.imbalance());
    d
}

/// Check a placement: a bijection blocks → ranks, every node holding exactly its ranks' count.
fn check_placement(b2r: &[usize], topo: &Topology) {
    let r2b = invert(b2r);
    for (b, &r) in b2r.iter().enumerate() {
        assert_eq!(r2b[r], b);
    }
    let mut per_node = vec![0usize; topo.nodes()];
    for &r in b2r {
        per_node[topo.node_of(r)] += 1;
    }
    for (n, &c) in per_node.iter().enumerate() {
        assert_eq!(c, topo.node_size(n), "node {n} capacity");
    }
}

/// [`halo_volumes`] of stored points (ids their indices).
fn volumes_of(pts: &[V3], d: &Decomposition<3>, support: f64) -> PairVolumes {
    let id: Vec<u64> = (0..pts.len() as u64).collect();
    let cloud = crate::decomp::Points {
        x: pts,
        id: &id,
        fluid: None,
        load: None,
    };
    halo_volumes(&cloud, d, support)
}

/// Place with every method; print a table; return the splits in [`Placement::ALL`] order.
fn compare(label: &str, pts: &[V3], dp: f64, topo: &Topology) -> Vec<TrafficSplit> {
    let d = decompose(pts, topo.ranks());
    let counts = volumes_of(pts, &d, support(dp));
    let bytes = counts.scaled(BYTES_PER_GHOST);
    let f = d.factors();
    println!(
        "{label}: {} particles, dp = {} mm, blocks {}×{}×{}, {} nodes × {} ranks, ghosts {:.2} % of particles",
        pts.len(),
        dp * 1e3,
        f[0],
        f[1],
        f[2],
        topo.nodes(),
        topo.ranks_per_node(),
        100.0 * counts.total() as f64 / pts.len() as f64
    );
    println!(
        "  {:<16} {:>14} {:>14} {:>8} {:>10} {:>11} {:>14}",
        "placement", "intra B", "inter B", "inter %", "vs rank-o", "node pairs", "max node B"
    );
    let mut out = Vec::new();
    for m in Placement::ALL {
        let b2r = place(&d, topo, m, &counts);
        check_placement(&b2r, topo);
        assert_eq!(b2r, place(&d, topo, m, &counts), "{m} is deterministic");
        let s = traffic_split(&bytes, &b2r, topo);
        assert_eq!(s.intra_node_bytes + s.inter_node_bytes, bytes.total());
        out.push(s);
    }
    for (m, s) in Placement::ALL.iter().zip(&out) {
        println!(
            "  {:<16} {:>14} {:>14} {:>7.2}% {:>+9.1}% {:>11} {:>14}",
            m.name(),
            s.intra_node_bytes,
            s.inter_node_bytes,
            100.0 * s.inter_fraction(),
            100.0 * (s.inter_node_bytes as f64 / out[0].inter_node_bytes as f64 - 1.0),
            s.node_pairs_talking,
            s.max_node_inter_bytes
        );
    }
    out
}

/// The placements of docs/benchmark-log.md, "Placement: inter-node halo bytes with 96 ranks on 4
/// nodes of 24", on the impact-like cloud (dp = 0.2 mm, ≈ 404 k particles) and a 3D dam-break-like
/// cloud (dp = 25 mm, ≈ 104 k particles), 96 ranks on 4 nodes of 24. Run with `--nocapture` for the
/// table (that section of docs/benchmark-log.md).
///
/// What holds and is asserted: on the impact cloud `centre-distance` moves fewer inter-node
/// bytes than `rank-order`; `min-cut` moves no more than `centre-distance` (nor `rank-order`,
/// nor `node-grid`) on both clouds, and strictly fewer than `centre-distance` on at least one.
///
/// What does NOT hold, contrary to the expectation: on the dam break `centre-distance`
/// moves *more* than `rank-order` (+60 % here; +70 % at dp = 20 mm, +55 % at 16.7 mm). The
/// blocks are 8×4×3 along a long tank, so rank-order gives each node two whole x-slabs (three
/// flat cuts), while the greedy blob of node 0 leaves fragments to nodes 1 and 2. The test pins
/// that finding (so a change to it is noticed) instead of asserting the opposite.
#[test]
fn placement_acceptance_96_ranks_on_4_nodes() {
    let topo = Topology::from_ranks_per_node(96, 24).unwrap();
    let file =
        Topology::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("topology/four_nodes_24.toml"))
            .unwrap();
    assert!((0..96).all(|r| topo.node_of(r) == file.node_of(r)));
    let dp_impact = 0.2e-3;
    let impact = compare("impact", &impact_cloud(dp_impact), dp_impact, &topo);
    let dp_dam = 0.025;
    let dam = compare("dam break 3D", &dam_break_cloud(dp_dam), dp_dam, &topo);
    let (ro, cd, ng, mc) = (0, 1, 2, 3);
    let inter = |s: &[TrafficSplit], m: usize| s[m].inter_node_bytes;
    assert!(
        inter(&impact, cd) < inter(&impact, ro),
        "impact: centre-distance vs rank-order"
    );
    assert!(
        inter(&dam, cd) > inter(&dam, ro),
        "dam break: the finding documented above changed"
    );
    for (label, s) in [("impact", &impact), ("dam break", &dam)] {
        for other in [ro, cd, ng] {
            assert!(
                inter(s, mc) <= inter(s, other),
                "{label}: min-cut vs {}",
                Placement::ALL[other]
            );
        }
    }
    assert!(
        inter(&impact, mc) < inter(&impact, cd) || inter(&dam, mc) < inter(&dam, cd),
        "min-cut must beat centre-distance on at least one cloud"
    );
}

/// Kernighan–Lin passes improve a poor start: on a 4×4 grid, alternating columns (12 cut
/// edges) are refined to 6 cut edges (a local optimum of pairwise swaps: the straight cut has
/// 4, so KL is a heuristic, not an exact partitioner).
#[test]
fn placement_refine_reaches_straight_cut() {
    let d = Decomposition::<3>::uniform(V3::zeros(), V3::new(4.0, 4.0, 1.0), [4, 4, 1]);
    let mut w = PairVolumes::zeros(16);
    for a in 0..16 {
        for b in 0..16 {
            let (ca, cb) = (d.block_coords(a), d.block_coords(b));
            if ca[0].abs_diff(cb[0]) + ca[1].abs_diff(cb[1]) == 1 {
                w.add(a, b, 1);
            }
        }
    }
    let start: Vec<usize> = (0..16).map(|b| d.block_coords(b)[0] % 2).collect();
    assert_eq!(cut(&start, &w), 2 * 12);
    let node = refine(start, 2, &w);
    assert_eq!(cut(&node, &w), 2 * 6);
    assert_eq!(node.iter().filter(|&&n| n == 0).count(), 8, "sizes kept");
}

/// A uniform 4×4×1 grid of unit blocks on 2 nodes of 8: hand-checked answers.
#[test]
fn placement_small_grid_by_hand() {
    let d = Decomposition::<3>::uniform(V3::zeros(), V3::new(4.0, 4.0, 1.0), [4, 4, 1]);
    let topo = Topology::from_ranks_per_node(16, 8).unwrap();
    let zero = PairVolumes::zeros(16);
    assert_eq!(
        place(&d, &topo, Placement::RankOrder, &zero),
        (0..16).collect::<Vec<_>>()
    );
    // Centre-distance: node 0 starts at block 0 (centre (0.5, 0.5)), then grows around the
    // centroid; the first node ends up with a compact 8-block region at small x.
    let cd = place(&d, &topo, Placement::CentreDistance, &zero);
    check_placement(&cd, &topo);
    assert_eq!(
        cd[0], 0,
        "the lexicographically smallest centre seeds node 0 on its first rank"
    );
    // Within the node, ranks follow the order of choice: the second pick is a face neighbour
    // of block 0 at distance 1 — (1.5, 0.5) or (0.5, 1.5); ties go to the smaller centre,
    // block 1 = (0.5, 1.5).
    assert_eq!(cd[1], 1);
    // Node-grid: 2 nodes over [4, 4, 1] → [2, 1, 1] (lexicographically largest on the tie with
    // [1, 2, 1]): x < 2 on node 0.
    let ng = place(&d, &topo, Placement::NodeGrid, &zero);
    for (b, &r) in ng.iter().enumerate() {
        assert_eq!(topo.node_of(r), d.block_coords(b)[0] / 2, "block {b}");
    }
    // With halo weights between face neighbours, min-cut finds a straight cut (4 edges).
    let mut w = PairVolumes::zeros(16);
    for a in 0..16 {
        for b in 0..16 {
            let (ca, cb) = (d.block_coords(a), d.block_coords(b));
            if ca[0].abs_diff(cb[0]) + ca[1].abs_diff(cb[1]) == 1 {
                w.add(a, b, 10);
            }
        }
    }
    let mc = place(&d, &topo, Placement::MinCut, &w);
    check_placement(&mc, &topo);
    let s = traffic_split(&w, &mc, &topo);
    assert_eq!(s.inter_node_bytes, 4 * 2 * 10);
    assert_eq!(s.node_pairs_talking, 1);
    assert_eq!(s.max_node_inter_bytes, 80);
    // Centre-distance's greedy blob is not a straight cut here: block 0, its two face
    // neighbours, (1.5, 1.5), then ties broken towards small centres give a 3×3-minus-one
    // corner region, cut 6 edges.
    assert_eq!(traffic_split(&w, &cd, &topo).inter_node_bytes, 120);
    // Rank-order on 4×4: blocks 0..7 are x ∈ {0, 1}: also a straight cut.
    assert_eq!(
        traffic_split(&w, &(0..16).collect::<Vec<_>>(), &topo).inter_node_bytes,
        80
    );
}

#[test]
fn placement_halo_volumes_by_hand() {
    // Two blocks split at x = 1; support 0.1.
    let d = Decomposition::<3>::uniform(V3::zeros(), V3::new(2.0, 1.0, 1.0), [2, 1, 1]);
    let pts = [
        V3::new(0.5, 0.5, 0.5),  // deep in block 0
        V3::new(0.95, 0.5, 0.5), // within 0.1 of block 1
        V3::new(0.9, 0.5, 0.5),  // exactly 0.1 away: closed widened box, sent
        V3::new(1.05, 0.2, 0.2), // block 1, near block 0
        V3::new(1.5, 0.5, 0.5),
    ];
    let v = volumes_of(&pts, &d, 0.1);
    assert_eq!((v.get(0, 1), v.get(1, 0), v.get(0, 0), v.get(1, 1)), (2, 1, 0, 0));
    assert_eq!(v.scaled(80).both_ways(0, 1), 240);
    // Traffic split on 2 nodes of 1 rank vs 1 node of 2.
    let two = Topology::from_ranks_per_node(2, 1).unwrap();
    let one = Topology::from_ranks_per_node(2, 2).unwrap();
    let s = traffic_split(&v, &[1, 0], &two);
    assert_eq!(
        (s.intra_node_bytes, s.inter_node_bytes, s.node_pairs_talking),
        (0, 3, 1)
    );
    assert_eq!(s.max_node_inter_bytes, 3);
    let s = traffic_split(&v, &[0, 1], &one);
    assert_eq!(
        (s.intra_node_bytes, s.inter_node_bytes, s.node_pairs_talking),
        (3, 0, 0)
    );
}

#[test]
fn placement_names_round_trip() {
    for m in Placement::ALL {
        assert_eq!(m.name().parse::<Placement>().unwrap(), m);
        assert_eq!(m.to_string(), m.name());
    }
    let e = "centre_distance".parse::<Placement>().unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().contains("centre-distance"), "{e}");
}

#[test]
fn placement_uneven_nodes_and_fallback() {
    // 10 blocks on nodes of 4, 4, 2: node-grid cannot fit and falls back to centre-distance.
    let d = Decomposition::<3>::uniform(V3::zeros(), V3::new(10.0, 1.0, 1.0), [10, 1, 1]);
    let topo = Topology::from_ranks_per_node(10, 4).unwrap();
    let zero = PairVolumes::zeros(10);
    for m in Placement::ALL {
        check_placement(&place(&d, &topo, m, &zero), &topo);
    }
    assert_eq!(
        place(&d, &topo, Placement::NodeGrid, &zero),
        place(&d, &topo, Placement::CentreDistance, &zero)
    );
    // On a row of slabs, centre-distance fills nodes left to right.
    assert_eq!(
        place(&d, &topo, Placement::CentreDistance, &zero),
        (0..10).collect::<Vec<_>>()
    );
}

/// Measured traffic-log entries split the same way as estimated volumes.
#[test]
fn placement_split_entries_matches_traffic_split() {
    use crate::comm::{Phase, TrafficEntry};
    let topo = Topology::from_ranks_per_node(4, 2).unwrap();
    let mut v = PairVolumes::zeros(4);
    v.add(0, 1, 5);
    v.add(1, 2, 7);
    v.add(3, 0, 11);
    let b2r = [0, 1, 2, 3];
    let entries: Vec<TrafficEntry> = (0..4)
        .flat_map(|a| (0..4).map(move |b| (a, b)))
        .filter(|&(a, b)| a != b && v.get(a, b) > 0)
        .map(|(a, b)| TrafficEntry {
            phase: Phase::Halo,
            src: a,
            dst: b,
            bytes: v.get(a, b),
            messages: 1,
        })
        .chain([TrafficEntry {
            phase: Phase::Halo,
            src: 2,
            dst: 2,
            bytes: 99,
            messages: 1,
        }])
        .collect();
    let s = split_entries(&entries, &topo);
    assert_eq!(s, traffic_split(&v, &b2r, &topo));
    assert_eq!((s.intra_node_bytes, s.inter_node_bytes), (5, 18));
    assert_eq!((s.node_pairs_talking, s.max_node_inter_bytes), (1, 18));
}
