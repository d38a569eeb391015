//! `hsph jobscript` (issue 10, item 5): the generated batch script, run by bash with stand-ins
//! for `mpirun` (runs the command) and `scontrol` (records the requeue), goes through Slurm's
//! stop-and-requeue cycle: USR1 to the batch shell before the limit → forwarded to the run →
//! checkpoint, exit 3 → `scontrol requeue` → the requeued script continues from the checkpoint
//! and ends with the bits of an uninterrupted run. The real-Slurm test is .ci/slurm-stage, run by CI.

use crate::common;

use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

fn write_exec(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn the_job_script_checkpoints_on_the_early_signal_and_the_requeued_job_continues() {
    let dir = common::temp_dir("jobscript");
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    // mpirun --map-by ppr:1:node:PE=1 --bind-to core HSPH ARGS... → HSPH ARGS...
    write_exec(&bin.join("mpirun"), "#!/bin/bash\nshift 4\nexec \"$@\"\n");
    let log = dir.join("scontrol.log");
    write_exec(
        &bin.join("scontrol"),
        &format!("#!/bin/bash\necho \"$@\" >> {}\n", log.display()),
    );
    let scene = common::repo_path("inputs/dam_break_2d.toml");
    let run = dir.join("run");
    let job = dir.join("job.sh");
    let (code, _, err) = common::hsph(&[
        "jobscript",
        scene.to_str().unwrap(),
        "--nodes",
        "1",
        "--ranks-per-node",
        "1",
        "--time",
        "00:10:00",
        "--launcher",
        "mpirun",
        "--out",
        run.to_str().unwrap(),
        "--script",
        job.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default());
    let batch = || {
        let mut c = Command::new("bash");
        c.arg(&job)
            .current_dir(&dir)
            .env("PATH", &path)
            .env("SLURM_JOB_ID", "42")
            .env("HSPH", env!("CARGO_BIN_EXE_hsph"));
        c
    };
    // first job: USR1 to the batch shell once the run is under way
    let mut first = batch().spawn().unwrap();
    let start = Instant::now();
    let rows = || std::fs::read_to_string(run.join("timeseries.csv")).map_or(0, |t| t.lines().count());
    while rows() < 3 {
        assert!(start.elapsed() < Duration::from_secs(60), "the run did not start");
        std::thread::sleep(Duration::from_millis(20));
    }
    let sent = Command::new("kill")
        .args(["-USR1", &first.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let status = first.wait().unwrap();
    assert_eq!(
        status.code(),
        Some(3),
        "the batch script passes on the run's exit 3"
    );
    let requeued = std::fs::read_to_string(&log).unwrap_or_default();
    assert_eq!(requeued.trim(), "requeue 42");
    let summary = std::fs::read_to_string(run.join("summary.json")).unwrap();
    assert!(summary.contains("\"stopped_by\": \"SIGUSR1\""), "{summary}");
    // the requeued job finds the checkpoint and continues
    let status = batch().status().unwrap();
    assert_eq!(status.code(), Some(0));
    let reference = dir.join("reference");
    let (code, _, err) = common::hsph(&[
        "run",
        scene.to_str().unwrap(),
        "-q",
        "--threads",
        "1",
        "--out",
        reference.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    for f in ["timeseries.csv", "final.csv", "probes/front.csv"] {
        let read = |d: &Path| std::fs::read(d.join(f)).unwrap();
        assert!(read(&run) == read(&reference), "{f} differs after the requeue");
    }
}

/// Issue 32, defect 20: nonsense layouts and times are refused with exit 2 naming the flag and
/// the limit, before any script is written.
#[test]
fn flags_beyond_their_bounds_are_refused() {
    let scene = common::repo_path("inputs/dam_break_2d.toml");
    let scene = scene.to_str().unwrap();
    let base = [
        ("--nodes", "1"),
        ("--ranks-per-node", "1"),
        ("--time", "01:00:00"),
    ];
    for (extra, needles) in [
        (
            &["--nodes", "1000000", "--ranks-per-node", "1000000"][..],
            &["--nodes", "4096"][..],
        ),
        (
            &["--nodes", "100", "--ranks-per-node", "100"],
            &["--nodes × --ranks-per-node", "10000", "4096"],
        ),
        (
            &[
                "--nodes",
                "18446744073709551615",
                "--ranks-per-node",
                "18446744073709551615",
            ],
            &["--nodes", "4096"],
        ),
        (&["--nodes", "0"], &["--nodes", "at least 1"]),
        (&["--ranks-per-node", "0"], &["--ranks-per-node", "at least 1"]),
        (
            &["--threads-per-rank", "0"],
            &["--threads-per-rank", "at least 1"],
        ),
        (&["--threads-per-rank", "1025"], &["--threads-per-rank", "1024"]),
        (&["--time", "99999999:00:00"], &["--time", "31622400"]),
        (&["--time", "99:99:99"], &["--time", "not below 60"]),
        (&["--time", "10:60"], &["--time", "not below 60"]),
        (&["--time", "0:00:00"], &["--time", "zero"]),
        (&["--time", "00:00:10"], &["--time", "no room"]),
        (&["--time", "-5"], &["--time"]),
        (&["--signal-before", "0"], &["--signal-before", "10..=65535"]),
        (&["--signal-before", "65536"], &["--signal-before", "10..=65535"]),
        (
            &["--signal-before", "3600"],
            &["--signal-before", "not before the time limit"],
        ),
    ] {
        // the extra flags replace the base ones (clap takes each flag once)
        let mut args = vec!["jobscript", scene];
        for (flag, value) in base {
            if !extra.contains(&flag) {
                args.extend([flag, value]);
            }
        }
        args.extend_from_slice(extra);
        let (code, out, err) = common::hsph(&args);
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(out.is_empty(), "{extra:?}: no script: {out}");
        assert!(!err.contains("panicked"), "{err}");
        for n in needles {
            assert!(err.contains(n), "{extra:?}: `{n}` missing from {err}");
        }
    }
    // the same duration parser bounds `run --max-wall`
    for bad in ["99:99:99", "99999999:00:00"] {
        let (code, _, err) = common::hsph(&["run", scene, "--max-wall", bad, "-q"]);
        assert_eq!(code, 2, "--max-wall {bad}: {err}");
        assert!(err.contains("--max-wall"), "{err}");
    }
}

/// The memory the script asks Slurm for per node covers the peak a rank of the scene reaches,
/// measured (`summary.json`'s `peak_rss_bytes`) on a 3D dam break of 151 000 particles whose
/// particle memory outweighs the binary's; and it is not wasteful: at most 2.5 times that peak
/// plus the 128 MB a rank is given for MPI. (The estimate is an upper bound:
/// 160 MB against the 86 MB measured when this test was written; issue 85 asks for 15 %.)
#[test]
fn the_memory_asked_per_node_covers_a_rank_s_measured_peak() {
    let dir = common::temp_dir("jobscript_mem");
    let text = std::fs::read_to_string(common::repo_path("inputs/dam_break_3d.toml")).unwrap();
    assert!(text.contains("dx = 0.025\n"));
    let scene = dir.join("dam_fine.toml");
    std::fs::write(&scene, text.replace("dx = 0.025\n", "dx = 0.0125\n")).unwrap();
    let scene = scene.to_str().unwrap();
    let (code, script, err) = common::hsph(&[
        "jobscript",
        scene,
        "--nodes",
        "1",
        "--ranks-per-node",
        "1",
        "--time",
        "01:00:00",
    ]);
    assert_eq!(code, 0, "{err}");
    let mem_mib: f64 = script
        .lines()
        .find_map(|l| l.strip_prefix("#SBATCH --mem="))
        .and_then(|m| m.strip_suffix('M'))
        .unwrap_or_else(|| panic!("no --mem line in\n{script}"))
        .parse()
        .unwrap();
    let mem = mem_mib * (1u64 << 20) as f64;
    let out = dir.join("run");
    let (code, _, err) = common::hsph(&[
        "run",
        scene,
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
        "-q",
        "--set",
        "time.t_end=2e-4",
        "--set",
        "output.format=\"none\"",
    ]);
    assert_eq!(code, 0, "{err}");
    let summary = common::summary(&out);
    let n = summary["particles"].as_u64().unwrap();
    let peak = summary["peak_rss_bytes"]
        .as_f64()
        .unwrap_or_else(|| panic!("no peak_rss_bytes in {summary}"));
    eprintln!("{n} particles: peak {:.1} MB, --mem {mem_mib} MiB", peak / 1e6);
    assert!(n > 150_000, "{n} particles");
    assert!(
        peak > 50e6,
        "the particles should outweigh the binary: peak {peak}"
    );
    assert!(mem >= peak, "--mem {mem} B below the measured peak {peak} B");
    assert!(
        mem <= 2.5 * peak + 128e6,
        "--mem {mem} B is more than 2.5 × the peak {peak} B + 128 MB"
    );
}

/// The parts `hsph check` estimates for a running rank (B per owned particle) against the
/// parts the run's structures held (`summary.json`'s `memory_parts_bytes_per_particle`, by the
/// capacities of their vectors: the same figures on any machine). The 3D dam break (fluid and
/// repulsive walls, gather lists), one rank: the table within 10 % (it is sized exactly), the
/// lists within 40 % (walls list nothing, pairs near walls and the free surface are fewer);
/// with `neighbours = "cells"` no entries are estimated, only the cell-order copies every slot
/// has (8·D + 10 B), and the run keeps only those, under a fifth of the lists' bytes.
#[test]
fn the_estimated_parts_match_what_the_run_holds() {
    let scene = common::repo_path("inputs/dam_break_3d.toml");
    let scene = scene.to_str().unwrap();
    let figure = |line: &str, name: &str| -> f64 {
        let at = line
            .find(&format!("{name} "))
            .unwrap_or_else(|| panic!("{name} in {line}"));
        let rest = &line[at + name.len() + 1..];
        rest.split([',', ';']).next().unwrap().trim().parse().unwrap()
    };
    let mut lists = Vec::new();
    for mode in ["lists", "cells"] {
        let set = format!("performance.neighbours=\"{mode}\"");
        let (code, out, err) = common::hsph(&["check", scene, "--set", &set]);
        assert_eq!(code, 0, "{err}");
        let line = out
            .lines()
            .find(|l| l.contains("in B per owned particle"))
            .expect(&out);
        let est = (figure(line, "table"), figure(line, "lists"));
        let dir = common::temp_dir(&format!("parts_{mode}"));
        let d = dir.to_str().unwrap();
        let (code, _, err) = common::hsph(&[
            "run",
            scene,
            "--out",
            d,
            "--force",
            "-q",
            "--threads",
            "1",
            "--set",
            &set,
            "--set",
            "time.max_steps=5",
            "--set",
            "output.format=\"none\"",
        ]);
        assert_eq!(code, 0, "{err}");
        let summary = common::summary(&dir);
        let per = &summary["memory_parts_bytes_per_particle"];
        let (table, listed) = (per["table"].as_f64().unwrap(), per["lists"].as_f64().unwrap());
        eprintln!(
            "{mode}: table {table} B (estimate {}), lists {listed} B (estimate {})",
            est.0, est.1
        );
        assert!(
            (table / est.0 - 1.0).abs() < 0.10,
            "table {table} against {}",
            est.0
        );
        assert!(
            (listed / est.1 - 1.0).abs() < 0.40,
            "lists {listed} against {}",
            est.1
        );
        if mode == "cells" {
            assert!(est.1 <= 34.0, "only the slots' copies in cells mode: {}", est.1);
        }
        lists.push(listed);
    }
    assert!(
        lists[1] < 0.2 * lists[0],
        "cells mode keeps {} B of the lists' {}",
        lists[1],
        lists[0]
    );
}

/// `--max-memory` below the estimate refuses the scene before anything is allocated (exit 2,
/// no output written), and the refusal names a layout that fits, which does: the 3D bench dam
/// break (gather lists) just below the list-free mode's estimate is refused without offering
/// that mode; midway between the two estimates the message offers it, and `check` accepts
/// the same limit under it.
#[test]
fn a_memory_limit_below_the_estimate_refuses_and_names_what_fits() {
    let scene = common::repo_path("inputs/dam_break_3d_bench.toml");
    let scene = scene.to_str().unwrap();
    let estimate = |sets: &[&str]| -> f64 {
        let (code, out, err) = common::hsph(&[&["check", scene], sets].concat());
        assert_eq!(code, 0, "{err}");
        let at = out.find("need about ").expect(&out) + "need about ".len();
        let mut words = out[at..].split_whitespace();
        let (x, unit) = (words.next().unwrap(), words.next().unwrap());
        x.parse::<f64>().unwrap()
            * match unit {
                "MB" => 1e6,
                "GB" => 1e9,
                u => panic!("{u}"),
            }
    };
    let est = estimate(&[]);
    let lean = estimate(&["--set", "performance.neighbours=\"cells\""]);
    assert!(
        lean < 0.9 * est,
        "the list-free mode is smaller: {lean} against {est}"
    );
    let dir = common::temp_dir("max_memory_fits");
    let run_dir = dir.join("run");
    for (limit, offers_lean) in [(0.97 * lean, false), (0.5 * (lean + est), true)] {
        let limit = format!("{limit:.0}");
        let (code, _, err) = common::hsph(&[
            "run",
            scene,
            "--max-memory",
            &limit,
            "-q",
            "--out",
            run_dir.to_str().unwrap(),
        ]);
        assert_eq!(code, 2, "{err}");
        assert!(
            err.contains("--max-memory") && err.contains("per process"),
            "{err}"
        );
        assert!(!run_dir.exists(), "nothing is written before the refusal");
        assert!(err.contains("under MPI on "), "a process count that fits: {err}");
        assert_eq!(
            err.contains("performance.neighbours=\"cells\""),
            offers_lean,
            "{err}"
        );
        if offers_lean {
            let (code, _, err) = common::hsph(&[
                "check",
                scene,
                "--max-memory",
                &limit,
                "--set",
                "performance.neighbours=\"cells\"",
            ]);
            assert_eq!(code, 0, "the offered mode fits: {err}");
        }
    }
}
