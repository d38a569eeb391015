//! The engine under real MPI (issues 3 and 4): `mpirun -np 4 hsph run` writes the same
//! `timeseries.csv` and `final.csv` bits as the local back end; ranks find their node through
//! `MPI_Comm_split_type(SHARED)` — one node by default, two under OpenMPI fake hosts — and
//! `hsph plan` predicts the first step's halo bytes of those runs exactly; a failing rank
//! aborts the job with one message naming it. Spawns `mpirun` on the built binary (MPI is
//! initialised once per process, never inside a test). Compiled only with `--features mpi`.
#![cfg(feature = "mpi")]

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const HSPH: &str = env!("CARGO_BIN_EXE_hsph");

fn run_with_timeout(mut cmd: Command, secs: u64) -> Output {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot start mpirun");
    let t0 = Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            return child.wait_with_output().expect("output");
        }
        if t0.elapsed() > Duration::from_secs(secs) {
            let _ = child.kill();
            let out = child.wait_with_output().expect("output");
            panic!(
                "hang: no exit within {secs} s\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// `mpirun` with the flags these machines need as root with more ranks than cores.
fn mpirun(np: usize, extra: &[&str], hsph_args: &[&str]) -> Output {
    let mut cmd = Command::new("mpirun");
    cmd.args([
        "--allow-run-as-root",
        "--oversubscribe",
        "--bind-to",
        "none",
        "-np",
        &np.to_string(),
    ])
    .args(extra)
    .arg(HSPH)
    .args(hsph_args);
    run_with_timeout(cmd, 300)
}

fn hsph(args: &[&str]) -> Output {
    let out = Command::new(HSPH).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "hsph {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn read(dir: &Path, name: &str) -> String {
    fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{}/{name}: {e}", dir.display()))
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&read(dir, "summary.json")).unwrap()
}

/// Halo bytes (intra, inter) of step 0 in traffic.csv.
fn halo_step0(dir: &Path) -> (u64, u64) {
    let (mut a, mut b) = (0, 0);
    for l in read(dir, "traffic.csv").lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        if f[0] == "0" && f[1] == "halo" {
            let v: u64 = f[6].parse().unwrap();
            if f[4] == f[5] {
                a += v
            } else {
                b += v
            }
        }
    }
    (a, b)
}

/// `hsph plan`'s (intra, inter) halo bytes for one placement.
fn plan(scene: &str, ranks: usize, per_node: usize, placement: &str, sets: &[&str]) -> (u64, u64) {
    let dir = common::temp_dir("mpi-plan");
    let (r, k) = (ranks.to_string(), per_node.to_string());
    let mut args = vec![
        "plan",
        scene,
        "--ranks",
        &r,
        "--ranks-per-node",
        &k,
        "--placement",
        placement,
    ];
    let d = dir.to_str().unwrap().to_string();
    args.extend(["--out", &d]);
    for s in sets {
        args.extend(["--set", s]);
    }
    hsph(&args);
    let p: serde_json::Value = serde_json::from_str(&read(&dir, "plan.json")).unwrap();
    let row = &p["placements"][0];
    (
        row["halo_intra_node_bytes"].as_u64().unwrap(),
        row["halo_inter_node_bytes"].as_u64().unwrap(),
    )
}

fn out_dir(tag: &str) -> PathBuf {
    common::temp_dir(tag).join("run")
}

#[test]
fn mpi_runs_give_the_local_back_ends_bits() {
    for (scene, sets) in [
        (
            "inputs/dam_break_2d.toml",
            vec![
                "time.t_end=0.05",
                "balance.check_every=5",
                "balance.threshold=1.02",
            ],
        ),
        (
            "inputs/poiseuille_2d.toml",
            vec!["time.t_end=0.05", "reference.times=[0.05]"],
        ),
        // the Riemann solver's pressure and density terms (issue 82) in pair mode
        (
            "inputs/dam_break_2d.toml",
            vec![
                "time.t_end=0.03",
                "physics.density_diffusion=\"riemann\"",
                "physics.pressure_gradient=\"riemann\"",
                "performance.interactions=\"pairs\"",
            ],
        ),
        (
            "tests/data/dam_break_3d_small.toml",
            vec!["time.t_end=0.05", "balance.check_every=5"],
        ),
        // particles of several sizes (issue 35): the level and h fields travel in halos and
        // migrations, refined plates with the level's h, and a refined box with the scene's
        (
            "inputs/poiseuille_2d_refined.toml",
            vec!["time.t_end=0.05", "reference.times=[0.05]"],
        ),
        (
            "inputs/hydrostatic_2d_refined.toml",
            vec!["time.t_end=0.05", "balance.check_every=5"],
        ),
        // splitting and merging (issue 36): children and merged particles numbered by the
        // all-gathered id counter, merges handed over to the centroid's rank, under MPI
        ("tests/data/drift_split_2d.toml", vec![]),
        // local time stepping (issue 36): cycles of two substeps, splits before them and
        // merges after, the classes' passes over fine then coarse homes, under MPI
        ("tests/data/drift_local_2d.toml", vec![]),
        // the oblique impact (issue 12), coarse: halos carry the solid fields under MPI too
        (
            "inputs/impact_oblique_45.toml",
            vec![
                "discretisation.dx=6.0e-4",
                "time.t_end=1.0e-6",
                "output.interval=5.0e-7",
            ],
        ),
    ] {
        let path = common::repo_path(scene);
        let path = path.to_str().unwrap();
        let mut args = vec!["run", path, "-q", "--threads", "1"];
        for s in &sets {
            args.extend(["--set", s]);
        }
        // the local run without overlap: MPI's overlapped refreshes change no bit (issue 34)
        let local = out_dir("mpi-local");
        let mut la = args.clone();
        let lo = local.to_str().unwrap().to_string();
        la.extend(["--ranks", "4", "--overlap", "off", "--out", &lo]);
        hsph(&la);
        let mpi = out_dir("mpi-run");
        let mo = mpi.to_str().unwrap().to_string();
        let mut ma = args.clone();
        ma.extend(["--overlap", "on", "--out", &mo]);
        let out = mpirun(4, &[], &ma);
        assert!(
            out.status.success(),
            "{scene}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let s = summary(&mpi);
        assert_eq!(s["backend"], "mpi");
        assert_eq!(s["ranks"], 4);
        assert_eq!(s["nodes"], 1, "one machine is one shared-memory node");
        assert!(
            read(&mpi, "timeseries.csv") == read(&local, "timeseries.csv"),
            "{scene}: timeseries differs"
        );
        assert!(
            read(&mpi, "final.csv") == read(&local, "final.csv"),
            "{scene}: final.csv differs"
        );
        if scene.ends_with("dam_break_3d_small.toml") {
            // without MPI_THREAD_MULTIPLE an overlapped refresh is made whole at its finish
            let funneled = out_dir("mpi-funneled");
            let fo = funneled.to_str().unwrap().to_string();
            let mut fa = args.clone();
            fa.extend(["--overlap", "on", "--out", &fo]);
            let out = mpirun(4, &["-x", "HSPH_MPI_THREADING=funneled"], &fa);
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            assert!(
                read(&funneled, "final.csv") == read(&local, "final.csv"),
                "{scene}: final.csv differs under FUNNELED"
            );
        }
    }
}

#[test]
fn plan_predicts_mpi_halo_bytes_with_virtual_and_fake_nodes() {
    let scene = common::repo_path("inputs/dam_break_2d.toml");
    let scene = scene.to_str().unwrap();
    let sets = ["time.t_end=0.005"];
    let predicted = plan(scene, 4, 2, "centre-distance", &sets);
    // 1. virtual nodes on one real node
    let dir = out_dir("mpi-virtual");
    let d = dir.to_str().unwrap();
    let args = [
        "run",
        scene,
        "-q",
        "--threads",
        "1",
        "--set",
        sets[0],
        "--ranks-per-node",
        "2",
        "--placement",
        "centre-distance",
        "--out",
        d,
    ];
    let out = mpirun(4, &[], &args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(summary(&dir)["nodes"], 2);
    assert_eq!(halo_step0(&dir), predicted, "virtual nodes: plan vs run");
    // 2. two fake hosts: one orted each, so split_shared finds two nodes by itself
    let fake = common::temp_dir("mpi-fakenodes");
    let agent = common::repo_path("tests/mpi/fakessh");
    let dir = out_dir("mpi-fake");
    let d = dir.to_str().unwrap();
    let args = [
        "run",
        scene,
        "-q",
        "--threads",
        "1",
        "--set",
        sets[0],
        "--placement",
        "centre-distance",
        "--out",
        d,
    ];
    let mut cmd_extra = vec![
        "--host",
        "nodeA:2,nodeB:2",
        "--map-by",
        "slot",
        "--mca",
        "plm_rsh_agent",
    ];
    let agent = agent.to_str().unwrap().to_string();
    cmd_extra.push(&agent);
    std::env::set_var("FAKENODE_TMP_BASE", &fake);
    let out = mpirun(4, &cmd_extra, &args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let s = summary(&dir);
    assert_eq!(s["nodes"], 2, "split_shared must find the two fake hosts");
    assert_eq!(halo_step0(&dir), predicted, "fake nodes: plan vs run");
    assert!(s["traffic"]["inter_node_bytes"].as_u64().unwrap() > 0);
}

#[test]
fn a_failing_mpi_rank_aborts_the_job_naming_it() {
    let scene = common::repo_path("inputs/dam_break_2d.toml");
    let scene = scene.to_str().unwrap();
    let dir = out_dir("mpi-fault");
    let d = dir.to_str().unwrap();
    let args = [
        "run",
        scene,
        "-q",
        "--threads",
        "1",
        "--set",
        "time.t_end=0.05",
        "--out",
        d,
    ];
    let out = mpirun(4, &["-x", "HSPH_TEST_FAULT=2:5:nan"], &args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("rank 2") && err.contains("step 5") && err.contains("particle id"),
        "{err}"
    );
    assert!(!dir.join("summary.json").exists());
}

/// Issue 9 row 6: one MPI rank (under mpirun, and a singleton `--backend mpi` without it)
/// runs and gives the serial bits.
#[test]
fn one_mpi_rank_runs_and_gives_the_serial_bits() {
    let scene = common::repo_path("inputs/dam_break_2d.toml");
    let scene = scene.to_str().unwrap();
    let args = ["run", scene, "-q", "--threads", "1", "--set", "time.t_end=0.02"];
    let serial = out_dir("mpi1-serial");
    let so = serial.to_str().unwrap().to_string();
    let mut a = args.to_vec();
    a.extend(["--out", &so]);
    hsph(&a);
    let one = out_dir("mpi1-mpirun");
    let oo = one.to_str().unwrap().to_string();
    let mut a = args.to_vec();
    a.extend(["--out", &oo]);
    let out = mpirun(1, &[], &a);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let single = out_dir("mpi1-singleton");
    let si = single.to_str().unwrap().to_string();
    let mut a = args.to_vec();
    a.extend(["--backend", "mpi", "--out", &si]);
    let out = run_with_timeout(
        {
            let mut c = Command::new(HSPH);
            c.args(&a);
            c
        },
        120,
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for dir in [&one, &single] {
        assert_eq!(summary(dir)["backend"], "mpi");
        assert!(
            read(dir, "final.csv") == read(&serial, "final.csv"),
            "{}",
            dir.display()
        );
        assert!(read(dir, "timeseries.csv") == read(&serial, "timeseries.csv"));
    }
}

/// Issue 10: a run checkpointed under `mpirun -np 4` (each rank writes its own part) and
/// continued under `mpirun -np 2` ends with the bits of an uninterrupted local run.
#[test]
fn an_mpi_checkpoint_restarts_on_fewer_ranks_with_the_same_bits() {
    let path = common::repo_path("inputs/dam_break_2d.toml");
    let path = path.to_str().unwrap();
    let base = ["run", path, "-q", "--threads", "1", "--set", "time.t_end=0.05"];
    let local = out_dir("mpi-restart-ref");
    let lo = local.to_str().unwrap().to_string();
    let mut la = base.to_vec();
    la.extend(["--out", &lo]);
    hsph(&la);
    let cut = out_dir("mpi-restart");
    let co = cut.to_str().unwrap().to_string();
    let mut ca = base.to_vec();
    ca.extend([
        "--out",
        &co,
        "--set",
        "time.max_steps=70",
        "--set",
        "checkpoint.every_steps=35",
    ]);
    let out = mpirun(4, &[], &ca);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let parts = fs::read_dir(cut.join("checkpoints/step-0000000070"))
        .unwrap()
        .count();
    assert_eq!(parts, 5, "four parts and the manifest");
    let out = mpirun(
        2,
        &[],
        &[
            "run",
            "--restart",
            &co,
            "-q",
            "--threads",
            "1",
            "--set",
            "time.max_steps=0",
        ],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in ["timeseries.csv", "final.csv"] {
        assert!(
            read(&cut, f) == read(&local, f),
            "{f} differs after the 4 → 2 restart"
        );
    }
}

/// Issue 17: with the distributed set-up each of 4 MPI processes holds its block, not the
/// whole lattice: every process's peak RSS is at most 0.40 × that of one process running the
/// whole 3D dam break (911 k particles; set-up and 2 steps; final.csv written per rank, so
/// no rank gathers the state). Before, every process built all N particles first (0.49 at
/// 1.15 M particles, docs/benchmark-log.md, "Memory per MPI process with the distributed set-up").
#[test]
fn four_mpi_processes_each_peak_under_0_4_of_one() {
    let scene = common::repo_path("inputs/dam_break_3d_bench.toml");
    let scene = scene.to_str().unwrap();
    let base = [
        "run",
        scene,
        "-q",
        "--threads",
        "1",
        "--set",
        "time.max_steps=2",
        "--set",
        "discretisation.dx=0.0065",
        "--set",
        "output.gather_limit=0",
    ];
    let one = out_dir("mpi-mem-1");
    let o1 = one.to_str().unwrap().to_string();
    let mut a1 = base.to_vec();
    a1.extend(["--out", &o1]);
    hsph(&a1);
    let four = out_dir("mpi-mem-4");
    let o4 = four.to_str().unwrap().to_string();
    let mut a4 = base.to_vec();
    a4.extend(["--out", &o4]);
    let out = mpirun(4, &[], &a4);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let peaks = |dir: &Path| -> Vec<u64> {
        summary(dir)["peak_rss_bytes_per_rank"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect()
    };
    let (p1, p4) = (peaks(&one), peaks(&four));
    assert_eq!(summary(&one)["particles"], 911_094);
    assert_eq!(p4.len(), 4);
    for (r, p) in p4.iter().enumerate() {
        let ratio = *p as f64 / p1[0] as f64;
        eprintln!("rank {r}: {p} B, {ratio:.3} of one process's {} B", p1[0]);
        assert!(
            ratio <= 0.40,
            "rank {r}: peak {p} B is {ratio:.3} of one process's"
        );
    }
}
