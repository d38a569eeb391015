//! Solitary wave on a vertical wall (issue 18, seed 002's flume), `inputs/solitary_wave.toml`
//! at CI's coarse resolution dx = 2.5 cm (10 particles over the 0.25 m depth, h = 2 dx), the
//! whole 8 s. Measured on the commit of this test (docs/validation.md §3e): crest at the 2 m
//! gauge 0.0507 m against A = 0.05 m (1.44 %); crest at 8 m at 6.075 s against
//! (8 m + λ)/c = 6.093 s (0.30 %); run-up at the wall 0.0862 m against Su & Mirie's 0.1065 m
//! (19.0 %). Bounds: 1.5 × each.

use crate::common;

use common::hsph;

/// `hsph run inputs/solitary_wave.toml` at dx = 2.5 cm on one thread (many steps of a small
/// scene: see `common::hsph`) with the extra `--set`s: the run directory, its summary.json
/// and stderr.
fn run_coarse(tag: &str, sets: &[&str]) -> (std::path::PathBuf, serde_json::Value, String) {
    let o = common::temp_dir(tag).join("run");
    let mut args = vec!["run", "inputs/solitary_wave.toml", "--out", o.to_str().unwrap()];
    args.extend(["--threads", "1", "--set", "discretisation.dx=0.025"]);
    for s in sets {
        args.extend(["--set", s]);
    }
    let (code, _, err) = hsph(&args);
    assert_eq!(code, 0, "{err}");
    let s = serde_json::from_str(&std::fs::read_to_string(o.join("summary.json")).unwrap()).unwrap();
    (o, s, err)
}

#[test]
fn solitary_wave_crest_arrival_and_runup_within_their_committed_bounds() {
    let (o, s, _) = run_coarse("solitary", &[]);
    let e = |k: &str| s["errors"][k].as_f64().unwrap_or_else(|| panic!("{k}: {s}"));
    let m = |k: &str| s["measured"][k].as_f64().unwrap_or_else(|| panic!("{k}: {s}"));
    assert!(e("solitary_crest") <= 1.5 * 0.0144, "{}", s["measured"]);
    assert!(e("solitary_arrival") <= 1.5 * 0.0030, "{}", s["measured"]);
    assert!(e("solitary_runup") <= 1.5 * 0.190, "{}", s["measured"]);
    // the references themselves: c = √(g (h + A)), Su & Mirie's R = h (2α + α²/2 + 3α³/4)
    assert!((m("celerity_m_per_s") - (9.81f64 * 0.3).sqrt()).abs() < 1e-12);
    assert!((m("runup_su_mirie_m") - 0.25 * (0.4 + 0.02 + 0.006)).abs() < 1e-12);
    assert!((e("solitary_crest") - (m("crest_height_m") / 0.05 - 1.0).abs()).abs() < 1e-12);
    // a gauge half a spacing from the wall reads the still water's depth (the dry wall above
    // the water once raised it by 1.4 cm here)
    let z0 = common::probe_values(&o, "wall")[0];
    assert!(
        (z0 - 0.25).abs() < 0.1 * 0.025,
        "still water at the wall reads {z0}"
    );
    // the pressure sensors on the wall felt the wave above their still-water pressure ρ g d
    for (name, depth) in [("P0", 0.20), ("P1", 0.10)] {
        let p = common::probe_values(&o, name);
        let still = 1000.0 * 9.81 * depth;
        assert!((p[0] / still - 1.0).abs() < 0.02, "{name}: {} vs {still}", p[0]);
        let peak = p.iter().copied().fold(f64::MIN, f64::max);
        assert!(peak > still + 1000.0 * 9.81 * 0.05, "{name}: peak {peak}");
    }
    // a reference gauge that is not a gauge probe is exit 2 naming the key
    let (code, _, err) = hsph(&[
        "check",
        "inputs/solitary_wave.toml",
        "--set",
        "reference.runup_gauge=P0",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("reference.runup_gauge"), "{err}");
}

/// A run stopped before the wave reaches the gauges measures no crest, arrival or run-up
/// error (it said 100 %, 98 % and 100 %), and says why, naming the gauges.
#[test]
fn a_run_that_ends_before_the_wave_arrives_measures_no_error() {
    let (_, s, err) = run_coarse("solitary-short", &["time.t_end=0.2"]);
    for k in ["solitary_crest", "solitary_arrival", "solitary_runup"] {
        assert!(
            s["errors"].get(k).is_none(),
            "{k} measured before the wave arrived: {s}"
        );
    }
    for g in ["`G2`", "`G8`", "`wall`"] {
        assert!(err.contains(&format!("has not passed gauge {g}")), "{g}: {err}");
    }
}
