//! A particle's neighbours in batches of [`BATCH`], with the kernel factor (1/r) dW/dr of
//! the whole batch evaluated at once ([`PairKernel::dw_dr_over_r_batch`]): the square roots
//! and divisions of several pairs go through one vector instruction, and no branch on q is
//! mispredicted. Each pair's factor has the bits it has one by one, and the pairs run in the
//! neighbours' order, so every sum keeps its bits. Used by the pair passes of both modes.

use crate::kernel::sizes::PairKernel;
use crate::kernel::BATCH;

/// Walk particle a's `neighbours` (list entries: slots in pair mode, particles in gather
/// mode; `particle` maps an entry to its particle) in batches: `r2_of(b)` is the squared
/// separation (m²) at which the pair (a, b) takes its kernel, and `pair(e, b, f)` runs for
/// each neighbour in order with its entry e, particle b and (1/r) dW/dr `f` (m⁻ᴰ⁻²). Pairs
/// that a pass skips still have their factor evaluated (finite, not read). `pair` may compute
/// the separation again from the particles: the same operations give the same bits, and two
/// subtractions per pair cost less than storing the batch's vectors.
#[inline(always)]
pub fn batched<K: PairKernel, I: Iterator<Item = u32>>(
    kern: &K,
    h: &[f64],
    a: usize,
    mut neighbours: I,
    particle: impl Fn(u32) -> usize,
    r2_of: impl Fn(usize) -> f64,
    mut pair: impl FnMut(usize, usize, f64),
) {
    // entries past a short batch's end keep earlier pairs (or a itself): valid, never read
    let (mut es, mut bs) = ([0u32; BATCH], [a; BATCH]);
    let (mut r2, mut f) = ([0.0; BATCH], [0.0; BATCH]);
    loop {
        let mut n = 0;
        for e in neighbours.by_ref() {
            es[n] = e;
            n += 1;
            if n == BATCH {
                break;
            }
        }
        if n == 0 {
            return;
        }
        for j in 0..n {
            let b = particle(es[j]);
            bs[j] = b;
            r2[j] = r2_of(b);
        }
        kern.dw_dr_over_r_batch(h, a, &bs, &r2, &mut f);
        for j in 0..n {
            pair(es[j] as usize, bs[j], f[j]);
        }
        if n < BATCH {
            return;
        }
    }
}

/// The particle of a pair-mode list entry (a slot of the half view's `order`).
#[inline(always)]
pub fn slot_of(order: &[u32]) -> impl Fn(u32) -> usize + '_ {
    move |t| order[t as usize] as usize
}

/// The particle of a gather-mode list entry (the particle itself).
#[inline(always)]
pub fn itself(j: u32) -> usize {
    j as usize
}
