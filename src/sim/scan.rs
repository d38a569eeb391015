//! Whole-population scans of the step's checks (positions in the domain, finite state, the
//! `[limits]`, the outflow's removals): the same answer as a serial scan in index order, on
//! any number of threads, at the cost of a streaming loop.
//!
//! A check's predicate is a few comparisons per particle; rayon's `find_first` or a serial
//! `filter` spends more than that per item on its bookkeeping (the 2D profile of
//! docs/benchmark-log.md, "The step's checks and the outflow's scan in streaming chunks", put the
//! step's checks and the outflow's scan at 8–10 % of a one-thread run, and they did not scale).
//! Here each chunk of [`CHUNK`] indices is folded without an early exit, chunks run in parallel,
//! and only a chunk with a hit is searched again in order.

use rayon::prelude::*;

/// Indices per chunk: a few times the L1's worth of the fields a check reads, and enough
/// chunks (≥ 10 per thread in the 2D dam break) to balance.
pub const CHUNK: usize = 2048;

/// The indices of chunk `c` of `0..n`.
fn chunk(c: usize, n: usize) -> std::ops::Range<usize> {
    c * CHUNK..((c + 1) * CHUNK).min(n)
}

/// The smallest `i < n` with `hit(i)`, or `None`: what `(0..n).find(|&i| hit(i))` returns.
pub fn first(n: usize, hit: impl Fn(usize) -> bool + Sync) -> Option<usize> {
    let c = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .find_first(|&c| chunk(c, n).fold(false, |any, i| any | hit(i)))?;
    chunk(c, n).find(|&i| hit(i))
}

/// Every `i < n` with `hit(i)`, in increasing order: what `(0..n).filter(|&i| hit(i))`
/// collects.
pub fn all(n: usize, hit: impl Fn(usize) -> bool + Sync) -> Vec<usize> {
    let chunks: Vec<usize> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .filter(|&c| chunk(c, n).fold(false, |any, i| any | hit(i)))
        .collect();
    chunks
        .into_iter()
        .flat_map(|c| chunk(c, n).filter(|&i| hit(i)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equal to the serial search and filter for hits at chunk edges, inside chunks, nowhere
    /// and everywhere, for sizes around the chunk's, on the pool of 2 threads.
    #[test]
    fn scans_equal_the_serial_search_and_filter() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let rules: [&(dyn Fn(usize) -> bool + Sync); 5] = [
            &|_| false,
            &|_| true,
            &|i| i % CHUNK == CHUNK - 1,
            &|i| i == 3 * CHUNK || i == 3 * CHUNK + 7 || i == 5 * CHUNK - 1,
            &|i| (i * 2654435761) % 97 == 5,
        ];
        for n in [0, 1, CHUNK - 1, CHUNK, CHUNK + 1, 5 * CHUNK, 7 * CHUNK + 13] {
            for hit in rules {
                let serial_first = (0..n).find(|&i| hit(i));
                let serial_all: Vec<usize> = (0..n).filter(|&i| hit(i)).collect();
                pool.install(|| {
                    assert_eq!(first(n, hit), serial_first, "n = {n}");
                    assert_eq!(all(n, hit), serial_all, "n = {n}");
                });
            }
        }
    }
}
