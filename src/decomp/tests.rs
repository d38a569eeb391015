//! Tests of the decomposition: geometry, eq. (6) by brute force, fallback, rebalance, weights.

use super::*;
use crate::Vector;

/// SplitMix64: a tiny deterministic generator for test particle sets.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

type Pts<const D: usize> = Vec<(Vector<D>, u64)>;

fn unit<const D: usize>() -> (Vector<D>, Vector<D>) {
    (Vector::<D>::zeros(), Vector::<D>::repeat(1.0))
}

fn random<const D: usize>(n: usize, seed: u64) -> Pts<D> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| (Vector::<D>::from_fn(|_, _| rng.next()), 1))
        .collect()
}

/// `m` points per axis at cell centres of `[0, len)^D`.
fn lattice<const D: usize>(m: usize, len: f64) -> Pts<D> {
    let total = m.pow(D as u32);
    let h = len / m as f64;
    (0..total)
        .map(|mut q| {
            let mut x = Vector::<D>::zeros();
            for k in 0..D {
                x[k] = ((q % m) as f64 + 0.5) * h;
                q /= m;
            }
            (x, 1)
        })
        .collect()
}

/// `(position, id, load)` items with the index as id.
fn with_ids<const D: usize>(pts: &Pts<D>) -> impl Iterator<Item = (Vector<D>, u64, u64)> + '_ {
    pts.iter().enumerate().map(|(i, (x, l))| (*x, i as u64, *l))
}

/// The `count` closure written by brute force: every particle against every candidate.
fn brute<const D: usize>(pts: &Pts<D>) -> impl FnMut(&Stage<'_, D>) -> Vec<u64> + '_ {
    move |s: &Stage<'_, D>| {
        s.candidates()
            .iter()
            .zip(s.candidate_ties())
            .zip(s.candidate_regions())
            .map(|((&c, &t), &r)| {
                pts.iter()
                    .enumerate()
                    .filter(|(i, (x, _))| {
                        let id = *i as u64;
                        s.region_of(x, id) == r && !at_or_right(x[s.axis()], id, c, t)
                    })
                    .map(|(_, (_, l))| *l)
                    .sum()
            })
            .collect()
    }
}

fn prefix<const D: usize>(c: &[usize; D], n: &[usize; D], k: usize) -> usize {
    (0..k).fold(0, |r, a| r * n[a] + c[a])
}

/// Brute-force check of a balanced decomposition: block loads, and for every plane eq. (6)
/// with `d_i` — or, when `fallback` is allowed, the best residual any plane position achieves.
fn check<const D: usize>(
    dec: &Decomposition<D>,
    rep: &Report,
    pts: &Pts<D>,
    params: &BalanceParams,
    fallback: bool,
) {
    let n = dec.factors();
    let p = dec.n_blocks();
    let w = params.weights.clone().unwrap_or(vec![1.0; p]);
    let mut loads = vec![0u64; p];
    let coords: Vec<[usize; D]> = pts
        .iter()
        .enumerate()
        .map(|(i, (x, l))| {
            let b = dec.block_of(x, i as u64);
            loads[b] += l;
            dec.block_coords(b)
        })
        .collect();
    assert_eq!(loads, rep.block_loads, "block loads");
    let block_c: Vec<[usize; D]> = (0..p).map(|b| dec.block_coords(b)).collect();
    for k in 0..D {
        let m = n[k] - 1;
        for r in 0..dec.regions(k) {
            let members: Vec<usize> = (0..pts.len())
                .filter(|&q| prefix(&coords[q], &n, k) == r)
                .collect();
            let sub_w: Vec<f64> = (0..n[k])
                .map(|j| {
                    (0..p)
                        .filter(|&b| prefix(&block_c[b], &n, k + 1) == r * n[k] + j)
                        .map(|b| w[b])
                        .sum()
                })
                .collect();
            // Achievable loads left of a plane: one per distinct coordinate, plus the total.
            let mut xs: Vec<(f64, u64)> = members.iter().map(|&q| (pts[q].0[k], pts[q].1)).collect();
            xs.sort_by(|a, b| a.0.total_cmp(&b.0));
            let total: u64 = xs.iter().map(|x| x.1).sum();
            let mut achievable = vec![total];
            let mut acc = 0;
            for (j, &(v, l)) in xs.iter().enumerate() {
                if j == 0 || xs[j - 1].0 != v {
                    achievable.push(acc);
                }
                acc += l;
            }
            for i in 0..m {
                let n_l: u64 = members
                    .iter()
                    .filter(|&&q| coords[q][k] <= i)
                    .map(|&q| pts[q].1)
                    .sum();
                let n_r = total - n_l;
                let w_l: f64 = sub_w[..=i].iter().sum();
                let w_r: f64 = sub_w[i + 1..].iter().sum();
                let d = tolerance(params.eta, w_l, w_r, sub_w[i].min(sub_w[i + 1]));
                let q = r * m + i;
                assert!(
                    (rep.tolerance[k][q] - d).abs() <= 1e-12 * d,
                    "tolerance level {k} plane {q}"
                );
                assert_eq!(rep.left_load[k][q], n_l, "left load level {k} plane {q}");
                let res = eq6_residual(n_l, n_r, w_l, w_r);
                assert!((rep.residual[k][q] - res).abs() <= 1e-12 * (1.0 + res));
                if fallback {
                    let best = achievable
                        .iter()
                        .map(|&a| eq6_residual(a, total - a, w_l, w_r))
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        res <= d * (1.0 + 1e-9) || res <= best * (1.0 + 1e-9),
                        "level {k} plane {q}: residual {res} > d {d} and > best achievable {best}"
                    );
                } else {
                    assert!(
                        res <= d * (1.0 + 1e-9),
                        "eq. 6 fails at level {k} plane {q}: {res} > {d}"
                    );
                }
            }
        }
    }
}

const SIZES: [usize; 17] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 16, 24, 27, 48, 64];

fn eq6_case<const D: usize>(p: usize, pts: &Pts<D>, fallback: bool) -> Report {
    let (lo, hi) = unit::<D>();
    let f = factorise(p, &[1.0; D]);
    let n: [usize; D] = f.try_into().expect("D factors");
    let params = BalanceParams::default();
    let (dec, rep) = Decomposition::balance(lo, hi, n, &params, brute(pts));
    check(&dec, &rep, pts, &params, fallback);
    assert!(rep.calls.iter().all(|&c| c <= params.max_iter));
    if !fallback {
        assert!(rep.satisfied());
        assert!(
            rep.imbalance() <= params.bound(D),
            "P = {p}: imbalance {}",
            rep.imbalance()
        );
    }
    rep
}

#[test]
fn decomp_eq6_random_2d_3d() {
    for p in SIZES {
        let r2 = eq6_case::<2>(p, &random(150 * p, 11 + p as u64), false);
        let r3 = eq6_case::<3>(p, &random(150 * p, 7 + p as u64), false);
        assert!(r2.imbalance() <= 1.033 && r3.imbalance() <= 1.05);
    }
}

#[test]
fn decomp_eq6_lattice_2d_3d() {
    for p in SIZES {
        // About 150 particles per block, rows shared by many particles.
        let m2 = ((150 * p) as f64).sqrt().ceil() as usize;
        let m3 = ((150 * p) as f64).cbrt().ceil() as usize;
        eq6_case::<2>(p, &lattice(m2, 1.0), true);
        eq6_case::<3>(p, &lattice(m3, 1.0), true);
    }
}

#[test]
fn decomp_lattice_fallback_terminates_at_best_achievable() {
    // 7 rows of 7 into 3 slabs: loads left can only be multiples of 7, eq. 6 is unattainable.
    let pts = lattice::<2>(7, 1.0);
    let (lo, hi) = unit::<2>();
    let params = BalanceParams::default();
    let (dec, rep) = Decomposition::balance(lo, hi, [3, 1], &params, brute(&pts));
    check(&dec, &rep, &pts, &params, true);
    assert!(!rep.satisfied());
    assert!(rep.calls[0] <= params.max_iter);
    // Best achievable: 14 | 21 | 14 or 14 | 14 | 21 etc.; the largest block holds 3 rows.
    assert_eq!(*rep.block_loads.iter().max().unwrap(), 21);
    // Every particle on one coordinate: terminates, one block takes everything.
    let same: Pts<2> = (0..100).map(|_| (Vector::<2>::new(0.3, 0.6), 1)).collect();
    let (dec, rep) = Decomposition::balance(lo, hi, [2, 2], &params, brute(&same));
    check(&dec, &rep, &same, &params, true);
    assert!(rep.calls.iter().all(|&c| c <= params.max_iter));
    assert_eq!(rep.block_loads.iter().sum::<u64>(), 100);
}

#[test]
fn decomp_block_of_agrees_with_boxes_and_overlap_queries() {
    fn case<const D: usize>(n: [usize; D], seed: u64) {
        let mut rng = Rng(seed);
        let (lo, hi) = unit::<D>();
        let mut regions = 1;
        let mut planes = Vec::new();
        for &nk in &n {
            let mut level = Vec::new();
            for _ in 0..regions {
                let mut v: Vec<f64> = (0..nk - 1).map(|_| rng.next()).collect();
                v.sort_by(f64::total_cmp);
                level.extend(v);
            }
            planes.push(level);
            regions *= nk;
        }
        let dec = Decomposition::from_planes(lo, hi, n, planes);
        let boxes: Vec<_> = (0..dec.n_blocks()).map(|b| dec.block_box(b)).collect();
        let inside = |b: usize, x: &Vector<D>| (0..D).all(|k| boxes[b].0[k] <= x[k] && x[k] < boxes[b].1[k]);
        for (x, _) in random::<D>(5000, seed + 1) {
            let owners: Vec<usize> = (0..dec.n_blocks()).filter(|&b| inside(b, &x)).collect();
            assert_eq!(owners, vec![dec.block_of(&x, 0)], "x = {x:?}");
        }
        // Outside the box: the outermost block on that side.
        let far = Vector::<D>::repeat(7.0);
        assert_eq!(dec.block_coords(dec.block_of(&far, 0))[0], n[0] - 1);
        assert_eq!(dec.block_coords(dec.block_of(&-far, 0))[0], 0);
        // Overlap queries: every point of the query box is in a returned block, and every
        // returned block owns a point of it (checked on its clipped box, widened to ±∞ outside).
        for _ in 0..200 {
            let c = Vector::<D>::from_fn(|_, _| rng.next() * 1.4 - 0.2);
            let r = rng.next() * 0.2;
            let (qmin, qmax) = (c.add_scalar(-r), c.add_scalar(r));
            let got = dec.blocks_overlapping(&qmin, &qmax);
            let expect: Vec<usize> = (0..dec.n_blocks())
                .filter(|&b| {
                    let cb = dec.block_coords(b);
                    (0..D).all(|k| {
                        let l = if cb[k] == 0 {
                            f64::NEG_INFINITY
                        } else {
                            boxes[b].0[k]
                        };
                        let h = if cb[k] + 1 == n[k] {
                            f64::INFINITY
                        } else {
                            boxes[b].1[k]
                        };
                        l < h && l <= qmax[k] && qmin[k] < h
                    })
                })
                .collect();
            assert_eq!(got, expect);
            for _ in 0..20 {
                let x = Vector::<D>::from_fn(|k, _| qmin[k] + (qmax[k] - qmin[k]) * rng.next());
                assert!(got.contains(&dec.block_of(&x, 0)));
            }
        }
        let near = dec.blocks_near(0, 0.05);
        assert!(!near.contains(&0));
    }
    case::<2>([4, 3], 1);
    case::<2>([5, 1], 2);
    case::<3>([2, 3, 2], 3);
    case::<3>([3, 1, 4], 4);
}

#[test]
fn decomp_count_local_matches_brute_force() {
    let pts = random::<3>(3000, 99);
    let (lo, hi) = unit::<3>();
    let dec = Decomposition::uniform(lo, hi, [3, 2, 2]);
    let mut rng = Rng(5);
    for axis in 0..3 {
        let nreg = dec.regions(axis);
        let mut cands = Vec::new();
        let mut regs = Vec::new();
        for r in 0..nreg {
            for _ in 0..4 {
                cands.push(rng.next());
                regs.push(r);
            }
        }
        cands.push(f64::INFINITY);
        regs.push(0);
        let stage = Stage::new_for_tests(&dec, axis, cands, regs);
        let loads: Pts<3> = pts
            .iter()
            .enumerate()
            .map(|(i, (x, _))| (*x, 1 + (i % 5) as u64))
            .collect();
        assert_eq!(stage.count_local(with_ids(&loads)), brute(&loads)(&stage));
    }
}

/// Smooth displacement field of amplitude ≤ `s` per component, zero normal motion at the
/// walls; the x component compresses towards x = 1 so the x planes must move.
fn displace<const D: usize>(pts: &Pts<D>, s: f64) -> Pts<D> {
    use std::f64::consts::PI;
    pts.iter()
        .map(|(x, l)| {
            let y = Vector::<D>::from_fn(|k, _| {
                let other = x[(k + 1) % D];
                let shape = if k == 0 {
                    1.0
                } else {
                    (2.0 * PI * other + k as f64).cos()
                };
                x[k] + s * (PI * x[k]).sin() * shape
            });
            (y, *l)
        })
        .collect()
}

#[test]
fn decomp_rebalance_moves_planes_little() {
    fn case<const D: usize>(p: usize, count: usize, seed: u64) {
        let (lo, hi) = unit::<D>();
        let n: [usize; D] = factorise(p, &[1.0; D]).try_into().unwrap();
        let params = BalanceParams::default();
        let pts = random::<D>(count, seed);
        let dx = (count as f64).powf(-1.0 / D as f64);
        let (dec, rep) = Decomposition::balance(lo, hi, n, &params, brute(&pts));
        assert!(rep.satisfied());
        // Nothing moved: one call per level with planes, no displacement.
        let (same, rep0) = dec.rebalance(&params, 0.5 * dx, brute(&pts));
        assert_eq!(same, dec);
        assert_eq!(rep0.max_displacement(), 0.0);
        assert!(rep0.calls.iter().all(|&c| c <= 1));
        // Every particle moved by ≤ s = 0.5 dx per component (≤ 0.5·√D dx in norm).
        let s = 0.5 * dx;
        let moved = displace(&pts, s);
        let (new, rep1) = dec.rebalance(&params, s, brute(&moved));
        check(&new, &rep1, &moved, &params, false);
        assert!(rep1.satisfied());
        let x_max = rep1.displacement[0].iter().copied().fold(0.0, f64::max);
        assert!(x_max <= 2.0 * s, "x planes moved {x_max} > 2s = {}", 2.0 * s);
        assert!(
            rep1.max_displacement() <= 3.0 * dx,
            "planes moved {} > 3 dx",
            rep1.max_displacement()
        );
        eprintln!(
            "rebalance D={D} P={p} N={count}: max plane move {:.3} dx (x: {:.3} dx), calls {:?} vs {:?} from scratch",
            rep1.max_displacement() / dx,
            x_max / dx,
            rep1.calls,
            rep.calls
        );
    }
    case::<2>(12, 40_000, 21);
    case::<2>(7, 20_000, 22);
    case::<3>(8, 40_000, 23);
    case::<3>(12, 40_000, 24);
}

#[test]
fn decomp_weights_give_proportional_shares() {
    let pts = random::<2>(30_000, 31);
    let (lo, hi) = unit::<2>();
    let weights = vec![1.0, 2.0, 3.0, 1.5, 0.5, 2.5];
    let params = BalanceParams {
        weights: Some(weights.clone()),
        ..Default::default()
    };
    let (dec, rep) = Decomposition::balance(lo, hi, [3, 2], &params, brute(&pts));
    check(&dec, &rep, &pts, &params, false);
    let wi = imbalance_weighted(&rep.block_loads, &weights);
    assert!(wi <= params.bound(2), "weighted imbalance {wi}");
    let wsum: f64 = weights.iter().sum();
    for (b, &l) in rep.block_loads.iter().enumerate() {
        let share = l as f64 / 30_000.0;
        let target = weights[b] / wsum;
        assert!(
            (share / target - 1.0).abs() <= params.bound(2) - 1.0,
            "block {b}: {share} vs {target}"
        );
    }
}

#[test]
fn decomp_corner_eighth_and_spreading_3d() {
    // The cut planes of docs/methods.md §4 on a hard cloud: ~100 000 particles on a lattice
    // filling the corner eighth of a unit cube, 8 ranks; max/mean ≤ 1.05 after the decomposition
    // and after each rebalance while the cloud spreads to the whole cube.
    let m = 46; // 46³ = 97 336
    let base = lattice::<3>(m, 0.5);
    let (lo, hi) = unit::<3>();
    let params = BalanceParams::default();
    let n: [usize; 3] = factorise(8, &[1.0; 3]).try_into().unwrap();
    let local = |pts: &Pts<3>| {
        let pts = pts.clone();
        move |s: &Stage<'_, 3>| s.count_local(with_ids(&pts))
    };
    let (mut dec, rep) = Decomposition::balance(lo, hi, n, &params, local(&base));
    assert!(rep.imbalance() <= 1.05, "initial imbalance {}", rep.imbalance());
    eprintln!(
        "corner eighth: imbalance {:.4}, calls {:?}",
        rep.imbalance(),
        rep.calls
    );
    let mut prev_scale = 1.0;
    for step in 1..=10 {
        let scale = 1.0 + step as f64 * 0.1;
        let pts: Pts<3> = base.iter().map(|(x, l)| (x * scale, *l)).collect();
        let s = 0.5 * (scale - prev_scale); // largest particle displacement per axis
        prev_scale = scale;
        let (next, r) = dec.rebalance(&params, s.max(1e-3), local(&pts));
        assert!(r.imbalance() <= 1.05, "step {step}: imbalance {}", r.imbalance());
        let sum: u64 = r.block_loads.iter().sum();
        assert_eq!(sum, (m * m * m) as u64);
        eprintln!(
            "  scale {scale:.1}: imbalance {:.4}, max move {:.4} m, calls {:?}",
            r.imbalance(),
            r.max_displacement(),
            r.calls
        );
        dec = next;
    }
}

#[test]
fn decomp_imbalance_and_tolerance_facts() {
    assert_eq!(imbalance(&[10, 10, 10]), 1.0);
    assert_eq!(imbalance(&[5, 10, 15]), 1.5);
    assert_eq!(imbalance(&[0, 0]), 1.0);
    // Two equal blocks: d = 2η; eq. 6 with d_i bounds |δ| by η·(block target).
    let eta = 0.008;
    assert!((tolerance(eta, 1.0, 1.0, 1.0) - 2.0 * eta).abs() < 1e-15);
    for nn in 2..40usize {
        for i in 0..nn - 1 {
            let (w_l, w_r) = ((i + 1) as f64, (nn - i - 1) as f64);
            let d = tolerance(eta, w_l, w_r, 1.0);
            let total = 1_000_000u64 * nn as u64;
            let target = total as f64 * w_l / nn as f64;
            let block = total as f64 / nn as f64;
            // Largest admissible deviation either way is within η·block.
            for sign in [-1.0, 1.0] {
                let mut lo = 0.0;
                let mut hi = block;
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    let n_l = (target + sign * mid).round() as u64;
                    if eq6_residual(n_l, total - n_l, w_l, w_r) <= d {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                assert!(
                    lo <= eta * block + 1.0,
                    "N = {nn}, i = {i}: deviation {lo} > {}",
                    eta * block
                );
                assert!(lo >= 0.9 * eta * block, "N = {nn}, i = {i}: d too strict");
            }
        }
    }
}

/// Block loads by brute force, with the index as id.
fn loads_by_brute<const D: usize>(dec: &Decomposition<D>, pts: &Pts<D>) -> Vec<u64> {
    let mut loads = vec![0u64; dec.n_blocks()];
    for (i, (x, l)) in pts.iter().enumerate() {
        loads[dec.block_of(x, i as u64)] += l;
    }
    loads
}

#[test]
fn decomp_layers_split_by_id_reach_the_bound() {
    // the same 7 × 7 lattice that the fallback cannot balance (21 of 49 in one slab), and
    // every particle on one point: with an id bound the planes split layers by id and eq. 6
    // holds
    let (lo, hi) = unit::<2>();
    let params = BalanceParams {
        id_bound: Some(1 << 20),
        ..BalanceParams::default()
    };
    let pts = lattice::<2>(7, 1.0);
    let (dec, rep) = Decomposition::balance(lo, hi, [3, 1], &params, brute(&pts));
    assert!(dec.splits_layers());
    assert_eq!(rep.block_loads, loads_by_brute(&dec, &pts));
    assert!(
        rep.block_loads.iter().all(|&l| (16..=17).contains(&l)),
        "{:?}",
        rep.block_loads
    );
    let same: Pts<2> = (0..1000).map(|_| (Vector::<2>::new(0.3, 0.6), 1)).collect();
    let (dec, rep) = Decomposition::balance(lo, hi, [2, 2], &params, brute(&same));
    assert_eq!(rep.block_loads, loads_by_brute(&dec, &same));
    // eq. 6 stops each plane within its tolerance of the target, not at it
    assert_eq!(rep.block_loads.iter().sum::<u64>(), 1000);
    assert!(rep.satisfied(), "{rep:?}");
    assert!(rep.imbalance() <= params.bound(2), "{:?}", rep.block_loads);
    assert!(rep.calls.iter().all(|&c| c <= params.max_iter));
}

#[test]
fn decomp_layer_splitting_balances_lattices_at_many_ranks() {
    // lattices with ~150 particles per block, every row shared: the fallback is bounded by
    // the row granularity, the id split by eq. 6's (1 + 2η)^D
    let params = BalanceParams {
        id_bound: Some(1 << 30),
        ..BalanceParams::default()
    };
    for p in [5, 7, 24, 48, 96] {
        let m = ((150 * p) as f64).cbrt().ceil() as usize;
        let pts = lattice::<3>(m, 1.0);
        let (lo, hi) = unit::<3>();
        let n: [usize; 3] = factorise(p, &[1.0; 3]).try_into().unwrap();
        let (dec, rep) = Decomposition::balance(lo, hi, n, &params, brute(&pts));
        assert_eq!(rep.block_loads, loads_by_brute(&dec, &pts), "P = {p}");
        assert!(
            rep.calls.iter().all(|&c| c <= params.max_iter),
            "P = {p}: {:?}",
            rep.calls
        );
        assert!(
            rep.imbalance() <= params.bound(3),
            "P = {p}: imbalance {} (calls {:?})",
            rep.imbalance(),
            rep.calls
        );
    }
}

#[test]
fn decomp_rebalance_keeps_and_moves_split_layers() {
    // a wall-like layer (many particles at x = 0.25) plus a moving cloud: planes that split
    // the layer survive a rebalance where nothing moved, and a rebalance after the cloud
    // moved still balances within the bound
    let params = BalanceParams {
        id_bound: Some(1 << 20),
        ..BalanceParams::default()
    };
    let mut rng = Rng(3);
    let mut pts: Pts<2> = (0..3000)
        .map(|_| (Vector::<2>::new(0.25, rng.next()), 1))
        .collect();
    pts.extend((0..2000).map(|_| (Vector::<2>::new(0.3 + 0.6 * rng.next(), rng.next()), 1)));
    let (lo, hi) = unit::<2>();
    let (dec, rep) = Decomposition::balance(lo, hi, [4, 2], &params, brute(&pts));
    assert!(dec.splits_layers());
    assert!(rep.imbalance() <= params.bound(2), "{}", rep.imbalance());
    let (same, rep2) = dec.rebalance(&params, 0.01, brute(&pts));
    assert_eq!(same, dec, "a satisfied decomposition stays");
    assert_eq!(rep2.block_loads, rep.block_loads);
    let moved = displace(&pts, 0.05);
    let (next, rep3) = dec.rebalance(&params, 0.01, brute(&moved));
    assert_eq!(rep3.block_loads, loads_by_brute(&next, &moved));
    assert!(rep3.imbalance() <= params.bound(2), "{}", rep3.imbalance());
}

/// Points whose load is 30 in the lower half of y (fluid) and 2 above (walls): balanced on
/// loads, the light blocks hold several times the mean count.
fn fluid_and_walls<const D: usize>(pts: &Pts<D>) -> Pts<D> {
    pts.iter()
        .map(|(x, _)| (*x, if x[1] < 0.5 { 30 } else { 2 }))
        .collect()
}

/// Counts and loads of every block, by brute force.
fn block_totals<const D: usize>(dec: &Decomposition<D>, pts: &Pts<D>) -> (Vec<u64>, Vec<u64>) {
    let mut counts = vec![0u64; dec.n_blocks()];
    let mut loads = vec![0u64; dec.n_blocks()];
    for (i, (x, l)) in pts.iter().enumerate() {
        let b = dec.block_of(x, i as u64);
        counts[b] += 1;
        loads[b] += l;
    }
    (counts, loads)
}

#[test]
fn decomp_count_cap_bounds_every_blocks_particles() {
    fn case<const D: usize>(pts: &Pts<D>, n: [usize; D], weights: Option<Vec<f64>>) {
        let (lo, hi) = unit::<D>();
        let pts = fluid_and_walls(pts);
        let local = |s: &Stage<'_, D>| s.count_local(with_ids(&pts));
        let run = |max_count: Option<f64>| {
            let params = BalanceParams {
                id_bound: Some(pts.len() as u64),
                max_count,
                weights: weights.clone(),
                ..BalanceParams::default()
            };
            Decomposition::balance(lo, hi, n, &params, local)
        };
        let w = weights.clone().unwrap_or(vec![1.0; n.iter().product()]);
        let (free, _) = run(None);
        let (fc, fl) = block_totals(&free, &pts);
        let free_count = imbalance_weighted(&fc, &w);
        assert!(
            free_count > 1.4,
            "{n:?}: uncapped counts {free_count} (the case must bind)"
        );
        // a cap that does not bind changes no plane
        assert_eq!(run(Some(1.0e3)).0, free, "{n:?}: a loose cap moved planes");
        for cap in [1.0, 1.25, 1.5] {
            let (dec, rep) = run(Some(cap));
            let (c, l) = block_totals(&dec, &pts);
            assert_eq!(rep.block_counts, c, "{n:?} cap {cap}: reported counts");
            assert_eq!(rep.block_loads, l, "{n:?} cap {cap}: reported loads");
            // to a particle per block and level of rounding
            let mean = pts.len() as f64 / w.iter().sum::<f64>();
            for (b, (&cb, wb)) in c.iter().zip(&w).enumerate() {
                let bound = cap * mean * wb + D as f64;
                assert!(
                    cb as f64 <= bound,
                    "{n:?} cap {cap}: block {b} holds {cb} > {bound}"
                );
            }
            assert!(imbalance_weighted(&l, &w) >= imbalance_weighted(&fl, &w) - 1e-12);
            if cap == 1.0 {
                assert!(imbalance_weighted(&c, &w) < 1.01, "{n:?}: cap 1 counts {c:?}");
            }
        }
        let loads = |cap| imbalance_weighted(&block_totals(&run(Some(cap)).0, &pts).1, &w);
        // one plane: the nearer its load target, the better the loads (with several planes a
        // block between a clamped plane and a free one need not gain)
        assert!(
            n.iter().product::<usize>() > 2 || loads(1.5) < loads(1.0),
            "{n:?}: a looser cap balances the loads better ({} vs {})",
            loads(1.5),
            loads(1.0)
        );
    }
    case(&random::<2>(4000, 11), [1, 2], None);
    case(&random::<2>(4000, 12), [2, 3], None);
    case(&random::<2>(4000, 13), [1, 4], Some(vec![1.0, 2.0, 1.0, 1.5]));
    case(&lattice::<3>(16, 1.0), [2, 2, 2], None);
    case(&random::<3>(6000, 14), [1, 3, 2], None);
}
