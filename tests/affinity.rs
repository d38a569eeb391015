//! Thread binding (`--bind cores`, `hsph topology`): without the `hwloc` feature both are input
//! errors naming it; with it, the local back end's rank pools run where the plan says and a
//! bound run completes.

mod common;

use common::{repo_path, temp_dir};
use std::process::{Command, Output};

fn hsph(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(args)
        .output()
        .expect("the hsph binary runs")
}

#[cfg(not(feature = "hwloc"))]
fn assert_needs_hwloc(o: &Output, key: &str) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "stderr:\n{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for want in [key, "`hwloc` cargo feature", "--features hwloc"] {
        assert!(stderr.contains(want), "`{want}` missing from:\n{stderr}");
    }
}

#[cfg(not(feature = "hwloc"))]
#[test]
fn topology_without_the_feature_exits_2_naming_it() {
    assert_needs_hwloc(&hsph(&["topology"]), "topology");
    assert_needs_hwloc(&hsph(&["topology", "--ranks", "2", "--threads", "2"]), "topology");
}

#[cfg(not(feature = "hwloc"))]
#[test]
fn bind_cores_without_the_feature_exits_2_naming_it() {
    let out = temp_dir("bind-nofeature").join("out");
    let scene = repo_path("inputs/dam_break_2d.toml");
    for extra in [&[][..], &["--ranks", "2"][..]] {
        let mut args = vec![
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
            "--bind",
            "cores",
        ];
        args.extend_from_slice(extra);
        assert_needs_hwloc(&hsph(&args), "--bind cores");
        assert!(!out.exists(), "no run directory");
    }
    // --bind none is the default and needs nothing
    let o = hsph(&["run", "--help"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("--bind"));
}

/// The calling thread's `Cpus_allowed_list` as the kernel reports it.
#[cfg(feature = "hwloc")]
fn kernel_affinity() -> Vec<usize> {
    let status = std::fs::read_to_string("/proc/thread-self/status").unwrap();
    let list = status
        .lines()
        .find_map(|l| l.strip_prefix("Cpus_allowed_list:"))
        .unwrap()
        .trim()
        .to_string();
    let mut set = Vec::new();
    for part in list.split(',').filter(|p| !p.is_empty()) {
        match part.split_once('-') {
            Some((a, b)) => set.extend(a.parse::<usize>().unwrap()..=b.parse().unwrap()),
            None => set.push(part.parse().unwrap()),
        }
    }
    set
}

/// The local back end with the `--bind cores` start handler: every thread of every rank's pool
/// is bound (as the kernel sees it) to the PUs of the core the plan gives it.
#[cfg(feature = "hwloc")]
#[test]
fn local_ranks_threads_are_bound_as_planned() {
    use hsph::affinity::{hw::Machine, start_handler, Bind};
    use hsph::comm::{local::run_local_with, Comm};
    let machine = Machine::discover().unwrap();
    for (ranks, threads) in [(1, 2), (2, 1), (2, 2), (3, 2)] {
        let start = start_handler(Bind::Cores, ranks, threads).unwrap();
        let per_rank = run_local_with(ranks, threads, start, |c| {
            Ok((c.rank(), rayon::broadcast(|ctx| (ctx.index(), kernel_affinity()))))
        })
        .unwrap();
        for (rank, seen) in per_rank {
            let plan = machine.plan(threads, rank, ranks);
            assert_eq!(seen.len(), threads);
            for (i, kernel) in seen {
                let want: Vec<usize> = machine.cores()[plan[i]]
                    .cpuset
                    .iter_set()
                    .map(usize::from)
                    .collect();
                assert_eq!(kernel, want, "{ranks} ranks × {threads}: rank {rank} thread {i}");
            }
        }
    }
}

/// Pools built with the `--bind cores` start handler, 1–3 ranks × 1–3 threads: every thread's
/// binding, as hwloc **and** the kernel read it back, is the PUs of the core the plan gives it.
#[cfg(feature = "hwloc")]
#[test]
fn pool_threads_read_back_the_planned_binding_through_hwloc_and_the_kernel() {
    use hsph::affinity::{hw::Machine, start_handler, with_start, Bind};
    let machine = Machine::discover().unwrap();
    let cores = machine.cores().len();
    for ranks in [1, 2, 3] {
        for threads in [1, 2, 3] {
            let start = start_handler(Bind::Cores, ranks, threads).unwrap().unwrap();
            for rank in 0..ranks {
                let plan = machine.plan(threads, rank, ranks);
                assert_eq!(plan.len(), threads);
                let builder = rayon::ThreadPoolBuilder::new().num_threads(threads);
                let pool = with_start(builder, Some(&start), rank).build().unwrap();
                let seen = pool.broadcast(|ctx| {
                    let binding = machine.current_thread_binding().unwrap();
                    let hw: Vec<usize> = binding.iter_set().map(usize::from).collect();
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
                    assert_eq!(kernel, want, "kernel: {ctx}");
                }
            }
        }
    }
}

#[cfg(feature = "hwloc")]
#[test]
fn topology_prints_the_machine_and_the_plan() {
    let o = hsph(&["topology", "--ranks", "2", "--threads", "3"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for want in [
        "packages:",
        "NUMA nodes:",
        "cores:",
        "PUs:",
        "process cpuset",
        "policy:",
        "rank 0: t0->core L#",
    ] {
        assert!(text.contains(want), "no {want:?} in\n{text}");
    }
    assert!(text.contains("rank 1: t0->core"), "{text}");
}

#[cfg(feature = "hwloc")]
#[test]
fn a_bound_run_completes() {
    let out = temp_dir("bind-run").join("out");
    let scene = repo_path("inputs/dam_break_2d.toml");
    let o = hsph(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
        "--bind",
        "cores",
        "--ranks",
        "2",
        "--threads",
        "1",
        "--set",
        "time.t_end=0.002",
        "--set",
        "output.interval=0.001",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("summary.json").exists());
    let _ = std::fs::remove_dir_all(out.parent().unwrap());
}
