//! Loads as engineers read them: `summary.json`'s `pressure_loads` of a run's pressure probe
//! are the rules of `hsph::probes::loads` applied to the probe's own file, and `hsph loads`
//! applies the very same rules to any CSV series (an experiment's), so both sides of a
//! comparison go through one code. Bad input to `hsph loads` is exit 2 naming the file.

use crate::common;
use common::cli::{assert_input_error, hsph_out, run_args, stderr};
use common::temp_dir;

#[test]
fn summary_loads_are_the_probe_files_loads_and_hsph_loads_gives_the_same() {
    let dir = temp_dir("pressure-loads");
    let out = dir.join("run");
    let sets = [
        "probe[1].window=0.0",
        "probe[1].interval=0.0",
        "probe[1].impulse_span=0.02",
        "probe[1].filter=0.003",
    ];
    let o = hsph_out(&run_args("inputs/dam_break_2d.toml", &out, &sets));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let got = &summary["pressure_loads"]["p_right_wall"];
    assert_eq!(got["trailing_window_s"], 0.0);
    let file = out.join("probes/p_right_wall.csv");
    let (t, p) = hsph::probes::loads::read_csv(&file, ("t", "p"), (1.0, 1.0)).unwrap();
    // sampled at every step: one row per step after the start
    assert_eq!(t.len() as u64, summary["steps"].as_u64().unwrap() + 1);
    let want = hsph::probes::loads::loads(&t, &p, 0.003, Some(0.02)).unwrap();
    assert_eq!(got["loads"], serde_json::to_value(want).unwrap());
    // the water reaches the wall: a first impact with an impulse, the filter below the raw peak
    assert!(want.impulse.is_some_and(|i| i > 0.0), "{want:?}");
    assert!(
        want.filtered_max > 0.0 && want.filtered_max <= want.raw_max,
        "{want:?}"
    );
    // the command line gives the same numbers for the same file
    let f = file.to_str().unwrap();
    let o = hsph_out(&[
        "loads",
        f,
        "--column",
        "p",
        "--filter",
        "0.003",
        "--impulse-span",
        "0.02",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let cli: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(cli, serde_json::to_value(want).unwrap());
}

/// A windowed pressure probe (the 2D dam break's: 2 ms window, a row every 0.5 ms) also writes
/// its every-step samples to `probes/<name>.raw.csv`; `summary.json`'s loads come from that
/// series, and every windowed row is the trapezoid mean of the raw samples over its window.
#[test]
fn a_windowed_probe_keeps_its_every_step_series_and_the_loads_read_it() {
    let dir = temp_dir("pressure-loads-raw");
    let out = dir.join("run");
    let o = hsph_out(&run_args("inputs/dam_break_2d.toml", &out, &["time.t_end=0.3"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let got = &summary["pressure_loads"]["p_right_wall"];
    assert_eq!(got["series"], "probes/p_right_wall.raw.csv");
    assert_eq!(got["trailing_window_s"], 0.0);
    let read = |f: &str| hsph::probes::loads::read_csv(&out.join(f), ("t", "p"), (1.0, 1.0)).unwrap();
    let (t, p) = read("probes/p_right_wall.raw.csv");
    assert_eq!(t.len() as u64, summary["steps"].as_u64().unwrap() + 1);
    let want = hsph::probes::loads::loads(&t, &p, 0.002, None).unwrap();
    assert_eq!(got["loads"], serde_json::to_value(want).unwrap());
    // the rows: each the mean over the samples of [t − 2 ms, t] and the one just before
    let (rt, rp) = read("probes/p_right_wall.csv");
    assert!(
        rt.len() > 100 && rt.len() * 2 < t.len(),
        "{} rows, {} samples",
        rt.len(),
        t.len()
    );
    let mut checked = 0;
    for (&tr, &pr) in rt.iter().zip(&rp) {
        let end = t.iter().position(|&x| x == tr).expect("a row at a sample's time");
        let mut start = 0;
        while start + 1 < end && t[start + 1] <= tr - 0.002 {
            start += 1;
        }
        let w = &t[start..=end];
        let mean = if w.len() < 2 {
            p[end]
        } else {
            let area: f64 = (start..end)
                .map(|k| 0.5 * (p[k] + p[k + 1]) * (t[k + 1] - t[k]))
                .sum();
            area / (t[end] - t[start])
        };
        assert!(
            (mean - pr).abs() <= 1e-9 * pr.abs().max(1.0),
            "t = {tr}: row {pr}, samples' mean {mean}"
        );
        checked += usize::from(pr > 0.0);
    }
    assert!(
        checked > 10,
        "the water reached the sensor in {checked} rows only"
    );
    // a mean is never above the largest sample
    let row_max = rp.iter().copied().fold(f64::MIN, f64::max);
    assert!(
        want.raw_max >= row_max && want.raw_max > 0.0,
        "{} {row_max}",
        want.raw_max
    );
}

#[test]
fn bad_series_and_flags_for_hsph_loads_are_exit_2_naming_them() {
    let dir = temp_dir("pressure-loads-bad");
    let csv = dir.join("series.csv");
    std::fs::write(&csv, "t,p\n0.0,1.0\n0.001,2.0\n0.001,3.0\n").unwrap();
    let f = csv.to_str().unwrap();
    let o = hsph_out(&["loads", f, "--column", "p"]);
    assert_input_error(&o, &[f, ":4", "times must increase"]);
    let o = hsph_out(&["loads", f, "--column", "pressure"]);
    assert_input_error(&o, &[f, "no column", "pressure"]);
    std::fs::write(&csv, "t,p\n0.0,1.0\n0.001,nan\n").unwrap();
    assert_input_error(&hsph_out(&["loads", f, "--column", "p"]), &[f, ":3", "finite"]);
    std::fs::write(&csv, "t,p\n0.0,1.0\n0.001,2.0\n").unwrap();
    for (flag, value) in [("--filter", "-1"), ("--scale", "0"), ("--impulse-span", "inf")] {
        let o = hsph_out(&["loads", f, "--column", "p", &format!("{flag}={value}")]);
        assert_input_error(&o, &[flag]);
    }
    let o = hsph_out(&["loads", f, "--column", "p", "--from", "5"]);
    assert_input_error(&o, &["no row"]);
    let o = hsph_out(&[
        "loads",
        dir.join("missing.csv").to_str().unwrap(),
        "--column",
        "p",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// The probe warnings `hsph check` prints for `scene` under the `--set` overrides `sets` (the
/// check must succeed).
fn probe_warnings(scene: &str, sets: &[&str]) -> Vec<String> {
    let mut args = vec!["check", scene];
    for s in sets {
        args.extend(["--set", s]);
    }
    let o = hsph_out(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter(|l| l.contains("warning: probe["))
        .map(str::to_string)
        .collect()
}

/// `check` warns of a pressure sensor within one kernel support of a corner where two closed
/// faces meet, and of a face narrower than dx. On the Lobovsky tank (the corner at the foot of
/// the downstream wall): at dx = 5 mm (support 13 mm) S1, 3 mm up, alone; at 10 mm (26 mm) S1
/// and S2 (15 mm) but not S3 (30 mm), and S1's 6 mm face.
#[test]
fn sensors_within_a_support_of_a_corner_or_narrower_than_dx_are_warned() {
    let warned = |sets: &[&str]| probe_warnings("inputs/dam_break_lobovsky.toml", sets);
    let w = warned(&[]);
    assert_eq!(w.len(), 1, "{w:#?}");
    assert!(w[0].contains("`S1`") && w[0].contains("3.000 mm from a corner") && w[0].contains("13.000 mm"));
    let w = warned(&[
        "discretisation.dx=0.01",
        "domain.min=[-0.05,-0.05]",
        "domain.max=[1.66,0.85]",
    ]);
    assert_eq!(w.len(), 3, "{w:#?}");
    assert!(w
        .iter()
        .any(|l| l.contains("`S1`") && l.contains("face (6.000 mm) is narrower than dx (10.000 mm)")));
    assert!(w
        .iter()
        .any(|l| l.contains("`S2`") && l.contains("15.000 mm from a corner")));
    assert!(
        !w.iter().any(|l| l.contains("`S3`") || l.contains("`S4`")),
        "{w:#?}"
    );
}

/// A sensor inside a `[[refine]]` region is judged by the region's particles: the adaptive
/// Lobovsky scene (dx = 10 mm, a level-1 region with the level's h over the downstream wall)
/// warns of S1 alone, 3 mm from the corner, within the region's support of 13 mm (the uniform
/// 10 mm scene warns of S1's 6 mm face and of S2 too, within the scene's 26 mm); a region with
/// the scene's h (with global steps: local steps need particles of a smaller h) keeps the 26 mm
/// support but its 5 mm spacing, so S2 is warned again and S1's face is not.
#[test]
fn sensors_in_a_refinement_region_are_judged_by_its_particles() {
    let warned = |sets: &[&str]| probe_warnings("inputs/dam_break_lobovsky_adaptive.toml", sets);
    let w = warned(&[]);
    assert_eq!(w.len(), 1, "{w:#?}");
    assert!(
        w[0].contains("`S1`")
            && w[0].contains("3.000 mm from a corner")
            && w[0].contains("(13.000 mm in refine[0])"),
        "{w:#?}"
    );
    let w = warned(&["refine[0].smoothing_length=\"scene\"", "time.stepping=\"global\""]);
    assert_eq!(w.len(), 2, "{w:#?}");
    assert!(w.iter().all(|l| l.contains("(26.000 mm in refine[0])")), "{w:#?}");
    assert!(w
        .iter()
        .any(|l| l.contains("`S2`") && l.contains("15.000 mm from a corner")));
    // moved out of the region, S1 is judged at the scene's dx again
    let w = warned(&["refine[0].min=[1.62,-0.04]"]);
    assert!(
        w.iter()
            .any(|l| l.contains("`S1`") && l.contains("face (6.000 mm) is narrower than dx (10.000 mm)")),
        "{w:#?}"
    );
}

/// A wall-pressure reference names pressure probes that are sensors of its experiment: an
/// unknown sensor, or a sensor without its probe, is exit 2 naming the key and the choices.
#[test]
fn a_wall_pressure_reference_names_sensors_of_its_experiment() {
    let check = |sets: &[&str]| {
        let mut args = vec!["check", "inputs/dam_break_lobovsky.toml"];
        for s in sets {
            args.extend(["--set", s]);
        }
        hsph_out(&args)
    };
    assert_input_error(
        &check(&["reference.sensors=[\"S1\", \"P1\"]"]),
        &[
            "reference.sensors[1]",
            "\"P1\"",
            "[\"S1\", \"S2\", \"S3\", \"S4\"]",
        ],
    );
    assert_input_error(
        &check(&["probe[1].name=\"S2b\""]),
        &[
            "reference.sensors[1]",
            "no [[probe]] of kind = \"pressure\" is named \"S2\"",
        ],
    );
    assert_input_error(
        &check(&["reference.experiment=\"lobovsky\""]),
        &[
            "key `reference`",
            "unknown variant `lobovsky`",
            "lobovsky2014_h300",
            "buchner2002",
        ],
    );
    assert_input_error(
        &check(&["reference.sensors=[]"]),
        &["reference.sensors", "at least one"],
    );
}

/// A pressure sensor with `body` rides on its moving wall: a paddle pushes into still water at
/// 5 cm/s for 2 s (10 cm, more than the 8 cm support), and the sensor on its face reads the
/// hydrostatic pressure at its depth under the raised level (ρ g (0.4/0.7 − 0.15) m, within
/// 10 %), while the same sensor left where it started is inside the paddle, with no water in
/// reach, and reads 0. A `body` that does not move, or names no wall, is an input error.
#[test]
fn a_sensor_on_a_moving_wall_moves_with_it() {
    let dir = temp_dir("moving-sensor");
    let text = std::fs::read_to_string(common::repo_path("inputs/hydrostatic_2d.toml"))
        .unwrap()
        .replace(
            "min = [0.0, 0.0]\nmax = [1.0, 0.5]",
            "min = [0.2, 0.0]\nmax = [1.0, 0.5]",
        )
        .replace(
            "[reference]\nkind = \"hydrostatic\"\nsurface = 0.5\nbottom = 0.0\n",
            "",
        )
        + "\n[[wall]]\nname = \"paddle\"\nshape = \"block\"\nmin = [0.12, 0.0]\nmax = [0.2, 0.7]\n\
           method = \"dummy\"\nmotion = { law = \"constant_velocity\", velocity = [0.05, 0.0] }\n\
           [[probe]]\nname = \"riding\"\nkind = \"pressure\"\npoint = [0.2, 0.15]\nbody = \"paddle\"\n\
           interval = 0.01\n\
           [[probe]]\nname = \"left\"\nkind = \"pressure\"\npoint = [0.2, 0.15]\ninterval = 0.01\n";
    assert!(
        text.contains("min = [0.2, 0.0]"),
        "the fluid block moved off the paddle"
    );
    let scene = dir.join("paddle.toml");
    std::fs::write(&scene, &text).unwrap();
    let out = dir.join("run");
    let o = hsph_out(&run_args(scene.to_str().unwrap(), &out, &["time.t_end=2.0"]));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let read = |name: &str| {
        hsph::probes::loads::read_csv(&out.join(format!("probes/{name}.csv")), ("t", "p"), (1.0, 1.0))
            .unwrap()
    };
    let (t, riding) = read("riding");
    let (_, left) = read("left");
    let last = |p: &[f64]| -> f64 {
        let tail: Vec<f64> = t
            .iter()
            .zip(p)
            .filter(|(t, _)| **t >= 1.8)
            .map(|(_, p)| *p)
            .collect();
        tail.iter().sum::<f64>() / tail.len() as f64
    };
    let want = 1000.0 * 9.81 * (0.4 / 0.7 - 0.15);
    assert!(
        (last(&riding) / want - 1.0).abs() < 0.1,
        "riding {} Pa, hydrostatic {want} Pa",
        last(&riding)
    );
    assert_eq!(last(&left), 0.0, "the fixed sensor is 10 cm inside the paddle");
    // at the start both read the same water
    assert_eq!(riding[0], left[0]);
    // a body that does not move, and one that is not a wall
    for (body, needles) in [
        ("tank", &["probe[1].body", "`tank` has no motion"][..]),
        (
            "pier",
            &["probe[1].body", "no [[wall]] is named `pier`", "tank, paddle"][..],
        ),
    ] {
        let bad = text.replace("body = \"paddle\"", &format!("body = \"{body}\""));
        std::fs::write(&scene, bad).unwrap();
        assert_input_error(&hsph_out(&["check", scene.to_str().unwrap()]), needles);
    }
}
