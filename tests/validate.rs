//! `hsph validate` (issue 19): a 2 × 2 sweep of the Poiseuille start-up (n = 10, 20; the
//! shipped quintic spline at h = dx and the cubic spline at h = 1.2 dx) to t = 0.6 s. Asserts
//! the CSV, the chart files, that the Pareto front holds the cheapest run, that the error falls
//! with resolution for each variant, that a second call reruns nothing, and that `--target`
//! names a run that met it and `--write` gives a scene `hsph check` accepts.

use crate::common;

use std::path::Path;
use std::process::Command;

fn hsph(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(args)
        .output()
        .unwrap()
}

const VARIANTS: &str = "quintic_spline-h1.0-dummy-none,cubic_spline-h1.2-dummy-none";

fn sweep(out: &Path, extra: &[&str]) -> std::process::Output {
    let o = out.to_str().unwrap();
    let mut args = vec![
        "validate",
        "poiseuille",
        "--resolutions",
        "10,20",
        "--variants",
        VARIANTS,
        "--set",
        "time.t_end=0.6",
        "--set",
        "reference.times=[0.6]",
        "--out",
        o,
    ];
    args.extend(extra);
    hsph(&args)
}

#[test]
fn a_small_poiseuille_sweep_charts_its_front_and_names_the_cheapest_run() {
    let out = common::temp_dir("validate_sweep");
    let r = sweep(&out, &[]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(0), "{err}");
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 4, "{csv}");
    let col = |name: &str| {
        csv.lines()
            .next()
            .unwrap()
            .split(',')
            .position(|c| c == name)
            .unwrap()
    };
    let (n, var, error, wall, status) = (
        col("resolution"),
        col("variant"),
        col("error"),
        col("wall_s"),
        col("status"),
    );
    for row in &rows {
        assert_eq!(row[status], "ok", "{csv}");
        let e: f64 = row[error].parse().unwrap();
        assert!(e > 0.0 && e < 0.5, "{csv}");
    }
    // the error falls with resolution for each variant
    for v in VARIANTS.split(',') {
        let e = |res: &str| -> f64 {
            rows.iter().find(|r| r[var] == v && r[n] == res).unwrap()[error]
                .parse()
                .unwrap()
        };
        assert!(e("20") < e("10"), "{v}: n = 20 {} vs n = 10 {}", e("20"), e("10"));
    }
    // the charts, both formats
    for stem in ["poiseuille_cost_error", "poiseuille_convergence"] {
        for ext in ["png", "svg"] {
            let f = out.join(format!("{stem}.{ext}"));
            assert!(
                std::fs::metadata(&f).map(|m| m.len() > 1000).unwrap_or(false),
                "{}",
                f.display()
            );
        }
    }
    // the front (marked ● in validate.md) holds the cheapest run
    let md = std::fs::read_to_string(out.join("validate.md")).unwrap();
    let cheapest = rows
        .iter()
        .min_by(|a, b| {
            a[wall]
                .parse::<f64>()
                .unwrap()
                .total_cmp(&b[wall].parse::<f64>().unwrap())
        })
        .unwrap();
    let line = md
        .lines()
        .find(|l| l.starts_with(&format!("| {} | {} |", cheapest[var], cheapest[n])))
        .unwrap_or_else(|| panic!("{md}"));
    assert!(line.contains('●'), "{line}");
    assert!(md.contains("order"), "{md}");
    // run again: nothing is rerun, the rows stay
    let again = sweep(&out, &[]);
    assert_eq!(again.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&again.stderr).contains("4 configuration(s) already in"));
    assert_eq!(std::fs::read_to_string(out.join("sweep.csv")).unwrap(), csv);
    target_names_a_run_that_met_it(&out, &rows, (n, var, error));
    bad_requests_are_refused(&out);
}

/// `--target` on the sweep of `out` (rows of `sweep.csv`; columns resolution, variant, error)
/// names the run that met it, and `--write` gives a scene that `hsph check` accepts.
fn target_names_a_run_that_met_it(out: &Path, rows: &[Vec<&str>], cols: (usize, usize, usize)) {
    let (n, var, error) = cols;
    let errors: Vec<f64> = rows.iter().map(|r| r[error].parse().unwrap()).collect();
    let target = errors.iter().cloned().fold(f64::INFINITY, f64::min) * 1.0001;
    let scene = out.join("cheapest.toml");
    let t = sweep(
        out,
        &[
            "--target",
            &target.to_string(),
            "--write",
            scene.to_str().unwrap(),
        ],
    );
    let said = String::from_utf8_lossy(&t.stdout);
    assert_eq!(
        t.status.code(),
        Some(0),
        "{said}{}",
        String::from_utf8_lossy(&t.stderr)
    );
    let best = rows
        .iter()
        .find(|r| r[error].parse::<f64>().unwrap() <= target)
        .unwrap();
    assert!(
        said.contains(&format!("variant {} at n = {}", best[var], best[n])),
        "{said}"
    );
    let check = hsph(&["check", scene.to_str().unwrap()]);
    assert_eq!(
        check.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );
}

/// An unmet target is exit 1; bad requests are exit 2 naming the flag or the known names.
fn bad_requests_are_refused(out: &Path) {
    let none = sweep(out, &["--target", "1e-9"]);
    assert_eq!(none.status.code(), Some(1));
    let bad = sweep(out, &["--variants", "nonsense"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("quintic_spline-h1.0-dummy-none"));
    let other = hsph(&[
        "validate",
        "poiseuille",
        "--out",
        out.to_str().unwrap(),
        "--resolutions",
        "10",
    ]);
    assert_eq!(other.status.code(), Some(2), "other overrides in the same --out");
    let unknown = hsph(&["validate", "nonsense", "--out", out.to_str().unwrap()]);
    assert_eq!(unknown.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&unknown.stderr).contains("known cases: poiseuille"));
}

/// The stability map's wall study (9 runs, about 15 s): every run stable now that mirror walls
/// bounce particles that a drift carries through them (before, the mirror row failed "through
/// a wall" at every speed), and every run's closest approach to the wall measured;
/// `map.csv`, the chart and `map.md` are written, and an unknown study is exit 2 naming the
/// known ones.
#[test]
fn the_wall_study_maps_every_method_and_speed() {
    let out = common::temp_dir("validate_map");
    let o = out.to_str().unwrap();
    let r = hsph(&["validate", "--map", "walls", "--out", o]);
    assert_eq!(r.status.code(), Some(0), "{}", String::from_utf8_lossy(&r.stderr));
    let csv = std::fs::read_to_string(out.join("map.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 9, "{csv}");
    for method in ["dummy", "repulsive", "mirror"] {
        assert_eq!(
            rows.iter()
                .filter(|l| l.split(',').nth(1) == Some(method))
                .count(),
            3
        );
    }
    for l in &rows {
        assert_eq!(l.split(',').nth(4), Some("stable"), "{l}");
        // penetration: the water's closest approach to the struck wall's face, in dx, over
        // every step (the front probe of the scene); no method lets the main body past the
        // face, and the repulsive force holds it a fifth of a spacing off (measured 0.21-0.32)
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f[8], "closest approach (dx)", "{l}");
        let approach: f64 = f[9].parse().unwrap();
        assert!((0.0..0.5).contains(&approach), "{l}");
        if f[1] == "repulsive" {
            assert!(approach > 0.15, "{l}");
        }
    }
    for ext in ["png", "svg"] {
        assert!(out.join(format!("map_walls.{ext}")).exists());
    }
    assert!(std::fs::read_to_string(out.join("map.md"))
        .unwrap()
        .contains("| mirror |"));
    let bad = hsph(&["validate", "--map", "nonsense", "--out", o]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("known studies: diffusion"));
}
