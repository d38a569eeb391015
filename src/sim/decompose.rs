//! The initial decomposition: blocks balanced on particle counts (seed 000, eqs. 5–6) and
//! placed on ranks by the run layout.

use crate::decomp::{factorise, BalanceParams, Decomposition};
use crate::error::Result;
use crate::halo::Ranks;
use crate::layout::RunLayout;
use crate::particles::Particles;
use crate::placement::{halo_volumes, place_reporting, Placement};
use crate::Vector;
use rayon::prelude::*;

/// Split the whole lattice over `layout.ranks` blocks, place the blocks on ranks and keep rank
/// `rank`'s particles. Every rank computes the same result from the same particles. Returns
/// the rank map, this rank's particles and the placement that ran.
pub fn decompose<const D: usize>(
    mut all: Particles<D>,
    min: &Vector<D>,
    max: &Vector<D>,
    rank: usize,
    layout: &RunLayout,
    support: f64,
) -> Result<(Ranks<D>, Particles<D>, Placement)> {
    let (map, used) = rank_map(&all.x[..all.n_owned], min, max, layout, support)?;
    if layout.ranks > 1 {
        let keep: Vec<usize> = (0..all.n_owned)
            .filter(|&i| map.owner(&all.x[i]) == rank)
            .collect();
        all.permute_owned(&keep);
    }
    Ok((map, all, used))
}

/// The decomposition of particles at `x` over the layout's ranks, the blocks' ranks and the
/// placement that ran.
pub fn rank_map<const D: usize>(
    x: &[Vector<D>],
    min: &Vector<D>,
    max: &Vector<D>,
    layout: &RunLayout,
    support: f64,
) -> Result<(Ranks<D>, Placement)> {
    let ranks = layout.ranks;
    let decomp = balanced_blocks(x, min, max, ranks);
    let (block_to_rank, used) = match layout.placement {
        Placement::RankOrder => ((0..ranks).collect(), Placement::RankOrder),
        method => {
            let t = layout.placement_topology();
            t.check_ranks(ranks)?;
            let volumes = halo_volumes(x, &decomp, support);
            place_reporting(&decomp, &t, method, &volumes)
        }
    };
    Ok((Ranks::new(decomp, block_to_rank), used))
}

/// Blocks of particles at `x`: the factorisation of the cloud's extents (eq. 5 of seed 000)
/// and cut planes balanced on particle counts (eq. 6). Counting is split over rayon tasks
/// and summed as integers, so the result does not depend on the thread count.
pub fn balanced_blocks<const D: usize>(
    x: &[Vector<D>],
    min: &Vector<D>,
    max: &Vector<D>,
    ranks: usize,
) -> Decomposition<D> {
    let n = x.len();
    let mut lo = Vector::<D>::repeat(f64::INFINITY);
    let mut hi = Vector::<D>::repeat(f64::NEG_INFINITY);
    for x in x {
        lo = lo.inf(x);
        hi = hi.sup(x);
    }
    let extents: Vec<f64> = (0..D)
        .map(|a| if n > 0 { hi[a] - lo[a] } else { max[a] - min[a] })
        .collect();
    let f = factorise(ranks, &extents);
    let mut nf = [1usize; D];
    nf.copy_from_slice(&f[..D]);
    let (decomp, _) = Decomposition::balance(*min, *max, nf, &BalanceParams::default(), |stage| {
        let k = stage.candidates().len();
        x.par_chunks(1 << 15)
            .map(|c| stage.count_local(c.iter().map(|x| (*x, 1u64))))
            .reduce(
                || vec![0u64; k],
                |mut a, b| {
                    a.iter_mut().zip(b).for_each(|(p, q)| *p += q);
                    a
                },
            )
    });
    decomp
}
