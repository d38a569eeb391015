use super::*;
use std::collections::BTreeSet;

#[test]
fn distinct_cores_while_they_last() {
    let cores = [10, 11, 12, 13, 14, 15, 16, 17];
    for threads in 1..=cores.len() {
        let got = thread_cores(&cores, threads, 0, 1);
        assert_eq!(got, cores[..threads].to_vec(), "{threads} threads");
    }
}

#[test]
fn round_robin_when_threads_outnumber_cores() {
    let cores = [4, 5, 6];
    assert_eq!(thread_cores(&cores, 7, 0, 1), vec![4, 5, 6, 4, 5, 6, 4]);
    // every core carries ⌊T/C⌋ or ⌈T/C⌉ threads
    for threads in 1..20 {
        let got = thread_cores(&cores, threads, 0, 1);
        for c in cores {
            let n = got.iter().filter(|&&x| x == c).count();
            assert!(n == threads / 3 || n == threads.div_ceil(3), "{threads}: {got:?}");
        }
    }
}

#[test]
fn ranks_sharing_a_cpuset_get_disjoint_cores_when_enough() {
    let cores: Vec<usize> = (0..12).collect();
    for ranks in 1..=12 {
        for threads in 1..=12 / ranks {
            let all: Vec<usize> = (0..ranks)
                .flat_map(|r| thread_cores(&cores, threads, r, ranks))
                .collect();
            let distinct: BTreeSet<_> = all.iter().collect();
            assert_eq!(distinct.len(), ranks * threads, "{ranks}×{threads}: {all:?}");
        }
    }
}

#[test]
fn oversubscribed_ranks_stay_on_their_own_block() {
    // 8 cores, 2 ranks × 6 threads: each rank wraps over its own 4 cores
    let cores: Vec<usize> = (0..8).collect();
    assert_eq!(thread_cores(&cores, 6, 0, 2), vec![0, 1, 2, 3, 0, 1]);
    assert_eq!(thread_cores(&cores, 6, 1, 2), vec![4, 5, 6, 7, 4, 5]);
    // uneven blocks: 5 cores, 2 ranks → 2 + 3
    assert_eq!(rank_block(5, 0, 2), 0..2);
    assert_eq!(rank_block(5, 1, 2), 2..5);
    for ranks in 1..=5 {
        let blocks: Vec<_> = (0..ranks).map(|r| rank_block(5, r, ranks)).collect();
        assert_eq!(blocks.first().unwrap().start, 0);
        assert_eq!(blocks.last().unwrap().end, 5);
        assert!(blocks.windows(2).all(|w| w[0].end == w[1].start), "{blocks:?}");
    }
}

#[test]
fn more_ranks_than_cores_share_cores_consecutively() {
    let cores = [0, 1];
    let firsts: Vec<usize> = (0..4).map(|r| thread_cores(&cores, 2, r, 4)[0]).collect();
    assert_eq!(firsts, vec![0, 0, 1, 1]);
    assert_eq!(thread_cores(&cores, 2, 3, 4), vec![1, 1]);
    assert!(thread_cores::<usize>(&[], 3, 0, 1).is_empty());
}

#[test]
fn bind_none_needs_nothing() {
    assert!(start_handler(Bind::None, 2, 2).unwrap().is_none());
    assert!(mpi_start_handler(Bind::None, 2).unwrap().is_none());
}

#[cfg(not(feature = "hwloc"))]
#[test]
fn bind_cores_without_the_feature_is_an_input_error() {
    let e = start_handler(Bind::Cores, 1, 1).err().expect("an error");
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().contains("hwloc"), "{e}");
    let e = topology_report(1, 1).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().contains("hwloc"), "{e}");
}

// The tests that need the `hwloc` feature are in `tests/affinity.rs`: CI builds that crate with
// the feature and the library it already built for MPI, not the library's unit tests again.
