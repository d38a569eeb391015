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

/// The calling thread's `Cpus_allowed_list` as the kernel reports it.
#[cfg(feature = "hwloc")]
fn kernel_affinity() -> BTreeSet<usize> {
    let status = std::fs::read_to_string("/proc/thread-self/status").unwrap();
    let list = status
        .lines()
        .find_map(|l| l.strip_prefix("Cpus_allowed_list:"))
        .unwrap()
        .trim();
    let mut set = BTreeSet::new();
    for part in list.split(',').filter(|p| !p.is_empty()) {
        match part.split_once('-') {
            Some((a, b)) => set.extend(a.parse::<usize>().unwrap()..=b.parse().unwrap()),
            None => {
                set.insert(part.parse().unwrap());
            }
        }
    }
    set
}

/// Pools built with the `--bind cores` start handler: every thread's affinity, as hwloc and
/// the kernel read it back, is the core the plan gives it.
#[cfg(feature = "hwloc")]
#[test]
fn bound_threads_run_where_the_plan_says() {
    let machine = hw::Machine::discover().unwrap();
    let cores = machine.cores().len();
    for ranks in [1, 2, 3] {
        for threads in [1, 2, 3] {
            let start = start_handler(Bind::Cores, ranks, threads).unwrap().unwrap();
            for rank in 0..ranks {
                let plan = machine.plan(threads, rank, ranks);
                assert_eq!(plan.len(), threads);
                let pool = with_start(
                    rayon::ThreadPoolBuilder::new().num_threads(threads),
                    Some(&start),
                    rank,
                )
                .build()
                .unwrap();
                let seen = pool.broadcast(|ctx| {
                    let hw: Vec<usize> = machine
                        .current_thread_binding()
                        .unwrap()
                        .iter_set()
                        .map(usize::from)
                        .collect();
                    (ctx.index(), hw, kernel_affinity())
                });
                for (i, hw, kernel) in seen {
                    let want: Vec<usize> = machine.cores()[plan[i]]
                        .cpuset
                        .iter_set()
                        .map(usize::from)
                        .collect();
                    let ctx = format!("{cores} cores, rank {rank}/{ranks}, thread {i}/{threads}");
                    assert_eq!(hw, want, "hwloc: {ctx}");
                    assert_eq!(kernel.into_iter().collect::<Vec<_>>(), want, "kernel: {ctx}");
                }
            }
        }
    }
}

#[cfg(feature = "hwloc")]
#[test]
fn topology_report_lists_the_machine_and_the_plan() {
    let text = topology_report(2, 2).unwrap();
    for want in [
        "packages:",
        "NUMA nodes:",
        "cores:",
        "PUs:",
        "process cpuset",
        "policy:",
        "rank 1:",
    ] {
        assert!(text.contains(want), "no {want:?} in\n{text}");
    }
}
