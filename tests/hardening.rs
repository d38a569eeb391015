//! Issue 9's table of edge cases, one test per row (the row number in the test name): each
//! reproduces what a user tried and checks what happens now.

use crate::common;

use common::cli::{assert_input_error, hsph_in, stderr};
use common::{repo_path, temp_dir};
use std::fs;
use std::path::Path;
use std::process::{Command, Output};

fn hsph(args: &[&str]) -> Output {
    hsph_in(&repo_path(""), args)
}

const SCENE: &str = "inputs/dam_break_2d.toml";

#[test]
fn row_01_scene_names_never_escape_runs() {
    let cwd = temp_dir("names");
    let scene = repo_path(SCENE);
    let long = "x".repeat(5000);
    for name in [
        "../../evil",
        "a/../../b",
        "ｅｖｉｌ／..／..／x",
        "..",
        "/etc/evil",
        long.as_str(),
    ] {
        let set = format!("name=\"{name}\"");
        let o = hsph_in(
            &cwd,
            &[
                "run",
                scene.to_str().unwrap(),
                "-q",
                "--set",
                &set,
                "--set",
                "time.max_steps=2",
                "--set",
                "output.format=\"none\"",
            ],
        );
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
        // exactly one new directory, directly under runs/, holding the run
        let runs: Vec<_> = fs::read_dir(cwd.join("runs"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        assert_eq!(runs.len(), 1, "{name}: {runs:?}");
        let dir = &runs[0];
        assert!(dir.join("summary.json").exists(), "{name}");
        let leaf = dir.file_name().unwrap().to_str().unwrap();
        assert!(
            leaf.len() <= 64 + 16 && !leaf.contains("..") && !leaf.starts_with('.'),
            "{leaf}"
        );
        fs::remove_dir_all(dir).unwrap();
    }
    // nothing was created beside or above the working directory
    assert_eq!(fs::read_dir(&cwd).unwrap().count(), 1);
    assert!(!cwd.parent().unwrap().join("evil").exists());
}

#[test]
fn row_07_a_probe_outside_the_domain_is_an_input_error() {
    let o = hsph(&["check", SCENE, "--set", "probe[1].point=[5.0, 5.0]"]);
    assert_input_error(&o, &["probe[1].point", "outside the domain", "move it inside"]);
}

#[test]
fn row_08_a_container_closed_across_a_periodic_axis_is_an_input_error() {
    let o = hsph(&[
        "check",
        "inputs/hydrostatic_2d.toml",
        "--set",
        "domain.periodic=[false, true]",
    ]);
    assert_input_error(&o, &["wall[0].open", "periodic axis y", "\"y-\", \"y+\""]);
}

#[test]
fn row_09_output_directory_problems_are_input_errors_naming_it() {
    let dir = temp_dir("out");
    let file = dir.join("a-file");
    fs::write(&file, "x").unwrap();
    let under = file.join("run");
    let long = dir.join("d".repeat(5000));
    for out in [
        file.as_path(),
        under.as_path(),
        Path::new("/proc/hsph-run"),
        long.as_path(),
    ] {
        let o = hsph(&["run", SCENE, "-q", "--out", out.to_str().unwrap()]);
        assert_input_error(&o, &["--out", "run directory"]);
    }
}

#[test]
fn row_10_set_errors_are_blamed_on_the_flag() {
    let o = hsph(&["check", SCENE, "--set", "nosuch.x=1"]);
    assert_input_error(&o, &["error: --set: key `nosuch`"]);
    let dir = temp_dir("empty");
    let empty = dir.join("empty.toml");
    fs::write(&empty, "").unwrap();
    let o = hsph(&["check", empty.to_str().unwrap(), "--set", "time.t_end=1"]);
    assert_input_error(&o, &["key `dimension`: missing field `dimension`"]);
    assert!(!stderr(&o).contains("time.dimension"));
}

#[test]
fn row_11_conflicting_layout_flags_say_so() {
    for cmd in ["run", "plan"] {
        let o = hsph(&[
            cmd,
            SCENE,
            "--ranks",
            "4",
            "--ranks-per-node",
            "2",
            "--topology",
            "topology/four_nodes_24.toml",
        ]);
        assert_input_error(&o, &["--ranks-per-node", "cannot be used with", "--topology"]);
    }
}

#[test]
fn row_12_failures_leave_no_empty_directory_and_no_truncated_file() {
    // a wall overlap is found while filling the lattice, after the directory was made
    let dir = temp_dir("overlap");
    let out = dir.join("run");
    let o = hsph(&[
        "run",
        SCENE,
        "-q",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "fluid[0].max=[0.5, 0.5]",
        "--set",
        "wall[0].min=[0.1, 0.1]",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!out.exists(), "an empty run directory was left behind");
    // a full disk while writing the fourth snapshot (test-only switch: that file goes to
    // /dev/full): exit 1 naming it, no partial file, everything written before kept
    let out = dir.join("full");
    let o = Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args([
            "run",
            SCENE,
            "-q",
            "--out",
            out.to_str().unwrap(),
            "--set",
            "time.t_end=0.1",
        ])
        .current_dir(repo_path(""))
        .env("HSPH_TEST_FULL_DISK", "snapshot_00003/rank_0000.vtu.tmp")
        .output()
        .unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("snapshot_00003/rank_0000.vtu") && e.contains("No space left on device"),
        "{e}"
    );
    assert!(!e.contains("panicked"), "{e}");
    let snaps: Vec<String> = fs::read_dir(out.join("snapshots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(snaps.iter().all(|n| !n.ends_with(".tmp")), "{snaps:?}");
    assert!(!snaps.contains(&"snapshot_00003.pvtu".to_string()), "{snaps:?}");
    let piece = out.join("snapshots/snapshot_00003/rank_0000.vtu");
    assert!(!piece.exists() && !piece.with_extension("vtu.tmp").exists());
    for k in 0..3 {
        for f in [
            format!("snapshot_{k:05}.pvtu"),
            format!("snapshot_{k:05}/rank_0000.vtu"),
        ] {
            let v = fs::read_to_string(out.join("snapshots").join(f)).unwrap();
            assert!(v.trim_end().ends_with("</VTKFile>"));
        }
    }
    assert!(!out.join("summary.json").exists() && !out.join("summary.json.tmp").exists());
    let ts = fs::read_to_string(out.join("timeseries.csv")).unwrap();
    // the rows of the four output steps, the last one written before its snapshot failed
    assert_eq!(ts.lines().count(), 1 + 4, "{ts}");
}

#[test]
fn row_02_03_rank_counts_beyond_the_particles_are_refused_before_any_rank_starts() {
    let dir = temp_dir("ranks");
    let out = dir.join("run");
    let t0 = std::time::Instant::now();
    let beyond_particles: &[&str] = &[
        "--ranks",
        "2221 particles",
        "at most 138 ranks",
        "--min-particles-per-rank",
    ];
    let beyond_limit: &[&str] = &["--ranks", "100000", "limit of 4096"];
    for (ranks, needles) in [("100000", beyond_limit), ("1000", beyond_particles)] {
        let o = hsph(&[
            "run",
            SCENE,
            "--ranks",
            ranks,
            "--threads",
            "1",
            "-q",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_input_error(&o, needles);
        assert!(!out.exists());
    }
    // with the minimum lowered, the memory the 1000 set-ups would take is what refuses it
    let o = hsph(&[
        "run",
        SCENE,
        "--ranks",
        "1000",
        "--threads",
        "1",
        "-q",
        "--min-particles-per-rank",
        "1",
        "--max-memory",
        "2G",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_input_error(
        &o,
        &["--ranks", "per process", "more than the 2.0 GB of --max-memory"],
    );
    assert!(!out.exists());
    assert!(t0.elapsed().as_secs() < 30, "refusals must be immediate");
}

#[test]
fn row_04_a_scene_too_large_for_the_memory_is_refused_with_its_estimate() {
    let dir = temp_dir("memory");
    let out = dir.join("run");
    let bin = env!("CARGO_BIN_EXE_hsph");
    for cmd in ["check", "run"] {
        // under a 4 GB address-space limit, as on a login node
        let script = format!(
            "ulimit -v 4000000; exec {bin} {cmd} {SCENE} --set discretisation.dx=0.00003 {}",
            if cmd == "run" {
                format!("--out {}", out.display())
            } else {
                String::new()
            }
        );
        let o = Command::new("sh")
            .args(["-c", &script])
            .current_dir(repo_path(""))
            .output()
            .unwrap();
        assert_input_error(
            &o,
            &[
                "discretisation.dx",
                "47555190 particles",
                "GB per process",
                "ulimit -v",
            ],
        );
        assert!(!out.exists());
    }
    // check prints the estimate of a scene that fits
    let o = hsph(&["check", SCENE]);
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(text.starts_with("estimate    2221 particles;"), "{text}");
}

#[test]
fn row_13_a_blow_up_is_caught_while_the_state_is_still_physical() {
    // no viscosity, no density diffusion, CFL 1: once caught only at a negative density with
    // velocities of 14 km/s; it blows up near t = 0.39 s
    let inviscid = |extra: &str| {
        let out = temp_dir("blowup").join("run");
        let mut args = vec!["run", SCENE, "-q", "--out", out.to_str().unwrap()];
        for set in [
            "time.cfl=1",
            "time.t_end=0.6",
            "physics.artificial_viscosity=0",
            "physics.density_diffusion=\"none\"",
            extra,
        ] {
            args.extend(["--set", set]);
        }
        (hsph(&args), out)
    };
    let (o, _) = inviscid("domain.outflow=\"stop\"");
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("limits.density_ratio") || e.contains("limits.speed_over_c0"),
        "{e}"
    );
    assert!(
        e.contains("step ") && e.contains("particle id") && e.contains("at position"),
        "{e}"
    );
    let speed: f64 = e
        .split("speed ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or(0.0);
    assert!(speed < 100.0, "caught at {speed} m/s: {e}");
    // the default outflow = "remove" takes out the particles leaving the density band (and the
    // domain) and stops once more than 1 % of the fluid is gone
    let (o, out) = inviscid("domain.outflow=\"remove\"");
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("more than domain.max_removed_fraction = 0.01"), "{e}");
    let removed = fs::read_to_string(out.join("removed.csv")).unwrap();
    assert!(removed.contains(",density out of band,"), "{removed}");
    assert!(removed.lines().count() > 1 + 12, "{removed}");
    // the limits are scene keys, validated
    let o = hsph(&["check", SCENE, "--set", "limits.density_ratio=[1.5, 2.0]"]);
    assert_input_error(&o, &["limits.density_ratio", "0 < low < 1 < high"]);
}

#[test]
fn row_14_the_heat_map_is_left_out_for_one_rank_and_labelled_on_the_data_range() {
    let dir = temp_dir("heat");
    for ranks in ["1", "4"] {
        let run = dir.join(format!("r{ranks}"));
        let o = hsph(&[
            "run",
            SCENE,
            "-q",
            "--threads",
            "1",
            "--ranks",
            ranks,
            "--out",
            run.to_str().unwrap(),
            "--set",
            "time.t_end=0.02",
            "--set",
            "output.format=\"none\"",
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let rep = run.join("report");
        let o = hsph(&["report", run.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let md = fs::read_to_string(rep.join("report.md")).unwrap();
        if ranks == "1" {
            assert!(!rep.join("traffic_heatmap.png").exists());
            assert!(md.contains("No rank-pair heat map"), "{md}");
            continue;
        }
        // the colour bar's end labels are the smallest and largest rank-pair totals
        let traffic = fs::read_to_string(run.join("traffic.csv")).unwrap();
        let mut pairs = std::collections::BTreeMap::new();
        for l in traffic.lines().skip(1) {
            let f: Vec<&str> = l.split(',').collect();
            *pairs.entry((f[2].to_string(), f[3].to_string())).or_insert(0u64) +=
                f[6].parse::<u64>().unwrap();
        }
        let nonzero: Vec<u64> = pairs.values().copied().filter(|&b| b > 0).collect();
        let (lo, hi) = (*nonzero.iter().min().unwrap(), *nonzero.iter().max().unwrap());
        let svg = fs::read_to_string(rep.join("traffic_heatmap.svg")).unwrap();
        for b in [lo, hi] {
            let label = hsph::report::human_bytes(b as f64);
            assert!(svg.contains(&label), "colour bar lacks {label}");
        }
        assert!(md.contains("traffic_heatmap.png"));
    }
}
