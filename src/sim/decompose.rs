//! The initial decomposition: blocks balanced on particle counts (seed 000, eqs. 5–6) and
//! placed on ranks by the run layout.
//!
//! Distributed set-up (ARCHITECTURE.md, "Ranks, ghosts and determinism across ranks"): no rank
//! builds the whole lattice. Each rank streams its share of the lattice layers ([`LayerShare`]) to
//! count the load left of each candidate plane, the counts are summed over ranks (exact integer
//! all-reduce), and every rank then builds only the sites it owns. Memory per rank is O(N/P); the
//! blocks, and so the bits, are the same whatever the number of ranks, since the counts are global
//! sums.

use crate::comm::Comm;
use crate::decomp::{factorise, fold_parts, BalanceParams, Cloud, Decomposition};
use crate::error::Result;
use crate::halo::Ranks;
use crate::layout::RunLayout;
use crate::particles::Particles;
use crate::placement::{halo_volumes, place_reporting, PairVolumes, Placement};
use crate::setup::{LayerShare, SiteSource};
use crate::Vector;

/// The distributed set-up: every rank of `comm` streams its share of the scene's sites to
/// balance the blocks (counts all-reduced), places them, and builds the particles of the
/// sites it owns (sorted by id). Returns the rank map, this rank's particles and the
/// placement that ran.
pub fn decompose_sites<const D: usize>(
    src: &SiteSource<'_, D>,
    (min, max): (&Vector<D>, &Vector<D>),
    layout: &RunLayout,
    support: f64,
    comm: &dyn Comm,
) -> Result<(Ranks<D>, Particles<D>, Placement)> {
    let share = LayerShare::of_rank(src, comm.rank(), comm.size());
    let bounds = (src.id_bound(), src.count_cap());
    let (map, used) = rank_map(&share, (min, max), bounds, layout, support, comm)?;
    let rank = comm.rank();
    let (lo, hi) = map.boxes()[rank];
    // the owned sites lie in the closed box (a plane with a tie gives part of the layer on
    // the box's upper face): enumerate a spacing beyond it and keep what this rank owns
    let dx = src.dx();
    let lo: Vec<f64> = lo.iter().map(|v| v - dx).collect();
    let hi: Vec<f64> = hi.iter().map(|v| v + dx).collect();
    let built = src.build(Some((&lo, &hi)), |id, x| map.owner(x, id) == rank);
    let p = agree(built, comm)?;
    Ok((map, p, used))
}

/// One outcome for every rank: a set-up error on any rank (an overlap or an expression that
/// fails on its sites) becomes the error of the lowest failing rank everywhere, so that no
/// rank goes on to wait for the others.
pub(crate) fn agree<T>(local: Result<T>, comm: &dyn Comm) -> Result<T> {
    use crate::error::{Error, Location};
    const SEP: char = '\u{0}';
    let mine = match &local {
        Ok(_) => Vec::new(),
        Err(Error::Input { at, key, message }) => {
            let (file, line) = match at {
                Some(l) => (
                    l.file.display().to_string(),
                    l.line.map_or(String::new(), |n| n.to_string()),
                ),
                None => (String::new(), String::new()),
            };
            format!(
                "I{}{SEP}{file}{SEP}{line}{SEP}{key}{SEP}{message}",
                at.is_some() as u8
            )
            .into_bytes()
        }
        Err(e) => format!("R{}", crate::comm::error_text(e)).into_bytes(),
    };
    let all = comm.all_gather_bytes(mine)?;
    let Some(m) = all.iter().find(|m| !m.is_empty()) else {
        return local;
    };
    let text = String::from_utf8_lossy(m);
    let (kind, rest) = text.split_at(1);
    if kind != "I" {
        return Err(Error::run(rest));
    }
    let f: Vec<&str> = rest.splitn(5, SEP).collect();
    if f.len() < 5 {
        return Err(Error::run(rest));
    }
    let at = (f[0] == "1").then(|| Location {
        file: f[1].into(),
        line: f[2].parse().ok(),
    });
    Err(Error::Input {
        at,
        key: f[3].to_string(),
        message: f[4].to_string(),
    })
}

/// The decomposition of the particles of `cloud` (each rank's share; loads summed over the
/// ranks of `comm`) over the layout's ranks, the blocks' ranks and the placement that ran.
/// `(id_bound, max_count)` as for [`balanced_blocks`].
pub fn rank_map<const D: usize, C: Cloud<D>>(
    cloud: &C,
    (min, max): (&Vector<D>, &Vector<D>),
    bounds: (u64, Option<f64>),
    layout: &RunLayout,
    support: f64,
    comm: &dyn Comm,
) -> Result<(Ranks<D>, Placement)> {
    let ranks = layout.ranks;
    let decomp = balanced_blocks(cloud, (min, max), ranks, bounds, comm)?;
    let (block_to_rank, used) = match layout.placement {
        Placement::RankOrder => ((0..ranks).collect(), Placement::RankOrder),
        method => {
            let t = layout.placement_topology();
            t.check_ranks(ranks)?;
            let volumes = global_halo_volumes(cloud, &decomp, support, comm)?;
            place_reporting(&decomp, &t, method, &volumes)
        }
    };
    Ok((Ranks::new(decomp, block_to_rank), used))
}

/// [`halo_volumes`] of every rank's share, summed over the ranks of `comm`.
pub fn global_halo_volumes<const D: usize, C: Cloud<D>>(
    cloud: &C,
    decomp: &Decomposition<D>,
    support: f64,
    comm: &dyn Comm,
) -> Result<PairVolumes> {
    let mut v = halo_volumes(cloud, decomp, support);
    comm.all_reduce_sum_u64(v.counts_mut())?;
    Ok(v)
}

/// Bounding box (m) and number of the particles of every rank's share.
fn extents<const D: usize, C: Cloud<D>>(cloud: &C, comm: &dyn Comm) -> Result<(Vector<D>, Vector<D>, u64)> {
    let (lo, hi, n) = fold_parts(
        cloud,
        || {
            (
                Vector::<D>::repeat(f64::INFINITY),
                Vector::<D>::repeat(f64::NEG_INFINITY),
                0u64,
            )
        },
        |a, k| {
            cloud.visit(k, |x, _, _| {
                a.0 = a.0.inf(x);
                a.1 = a.1.sup(x);
                a.2 += 1;
            })
        },
        |a, b| (a.0.inf(&b.0), a.1.sup(&b.1), a.2 + b.2),
    );
    let (mut lo, mut hi, mut n) = (lo.as_slice().to_vec(), hi.as_slice().to_vec(), [n]);
    comm.all_reduce_min_f64(&mut lo)?;
    comm.all_reduce_max_f64(&mut hi)?;
    comm.all_reduce_sum_u64(&mut n)?;
    Ok((
        Vector::<D>::from_column_slice(&lo),
        Vector::<D>::from_column_slice(&hi),
        n[0],
    ))
}

/// Blocks of the particles of `cloud` (each rank's share, counts summed over `comm`): the
/// factorisation of the cloud's extents (eq. 5 of seed 000) and cut planes balanced on
/// the particles' loads (eq. 6; counts, or with `balance.load = "pairs"` each site's
/// expected pairs, [`crate::kernel::sizes::Sizes::site_load`]), splitting layers by id below
/// `id_bound` where a layer holds more
/// than a block's share, and, when the loads are not counts, holding no block above
/// `max_count` times the mean particle count ([`BalanceParams::max_count`]). Counting is split
/// over rayon tasks and summed as integers, so the result depends on neither the thread count
/// nor the rank count.
pub fn balanced_blocks<const D: usize, C: Cloud<D>>(
    cloud: &C,
    (min, max): (&Vector<D>, &Vector<D>),
    ranks: usize,
    (id_bound, max_count): (u64, Option<f64>),
    comm: &dyn Comm,
) -> Result<Decomposition<D>> {
    let (lo, hi, n) = extents(cloud, comm)?;
    let extents: Vec<f64> = (0..D)
        .map(|a| if n > 0 { hi[a] - lo[a] } else { max[a] - min[a] })
        .collect();
    let f = factorise(ranks, &extents);
    let mut nf = [1usize; D];
    nf.copy_from_slice(&f[..D]);
    let params = BalanceParams {
        id_bound: Some(id_bound),
        max_count,
        ..BalanceParams::default()
    };
    let mut err = None;
    let (decomp, _) = Decomposition::balance(*min, *max, nf, &params, |stage| {
        let mut counts = fold_parts(
            cloud,
            || stage.counter(),
            |c, k| cloud.visit_loads(k, |x, id, w| c.add(x, id, w)),
            |a, b| a.merge(b),
        )
        .finish();
        if let Err(e) = comm.all_reduce_sum_u64(&mut counts) {
            err.get_or_insert(e);
        }
        counts
    });
    match err {
        Some(e) => Err(e),
        None => Ok(decomp),
    }
}
