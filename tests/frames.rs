//! Flow frames (`output.frames`, issue 82's "the flow itself"): every rank writes its
//! particles at the first step at or past each asked time, without a gather; `hsph report`
//! draws each frame and the final state coloured by pressure.

use crate::common;

use std::path::Path;

const SCENE: &str = "tests/data/drift_local_2d.toml";
/// The drift runs to 0.06 s; the last frame is asked at its end.
const FRAMES: &str = "output.frames=[0.0451, 0.02, 0.06]";

fn run(out: &Path, ranks: usize, sets: &[&str]) {
    let (code, _, err) = common::run_file(SCENE, out, (ranks, 1), sets);
    assert_eq!(code, 0, "{err}");
}

/// Frame `k`'s rows of every piece, by id (the header first).
fn frame_rows(run: &Path, k: usize) -> (String, Vec<String>) {
    let index: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(run.join(format!("frames/frame_{k:02}.json"))).unwrap(),
    )
    .unwrap();
    let pieces = index["pieces"].as_u64().unwrap();
    let mut head = String::new();
    let mut rows = Vec::new();
    for r in 0..pieces {
        let text = std::fs::read_to_string(run.join(format!("frames/frame_{k:02}/rank_{r:04}.csv"))).unwrap();
        let mut lines = text.lines();
        head = lines.next().unwrap().to_string();
        rows.extend(lines.map(String::from));
    }
    let id = |l: &String| l.split(',').next().unwrap().parse::<u64>().unwrap();
    rows.sort_by_key(id);
    (head, rows)
}

fn index(run: &Path, k: usize) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(run.join(format!("frames/frame_{k:02}.json"))).unwrap())
        .unwrap()
}

/// Frames asked out of order are written in time order, each at the first step at or past
/// its time (the step's time less the step lies before it); the frame at t_end holds
/// `final.csv`'s rows to the byte; 1 and 3 ranks write the same rows (merged by id); a run
/// continued from a checkpoint between frames writes the later ones again with the same
/// bytes; `hsph report` draws `flow_00`–`flow_02` and `flow_final`.
#[test]
fn frames_are_the_state_at_their_times_on_any_layout_and_after_a_restart() {
    let dir = common::temp_dir("frames");
    let one = dir.join("one");
    run(&one, 1, &[FRAMES]);
    for (k, asked) in [0.02, 0.0451, 0.06].into_iter().enumerate() {
        let e = index(&one, k);
        assert_eq!(e["requested_t"].as_f64().unwrap(), asked);
        let t = e["t"].as_f64().unwrap();
        assert!(t >= asked * (1.0 - 1e-12), "frame {k} at {t} before {asked}");
        // the drift's cycles are 3.1e-4 s long
        assert!(
            t - 4e-4 < asked,
            "frame {k} at {t}, more than a cycle past {asked}"
        );
        assert_eq!(e["pieces"], 1);
    }
    let (head, rows) = frame_rows(&one, 2);
    let fin = std::fs::read_to_string(one.join("final.csv")).unwrap();
    let mut lines = fin.lines();
    assert_eq!(lines.next().unwrap(), head);
    assert_eq!(
        rows,
        lines.map(String::from).collect::<Vec<_>>(),
        "the frame at t_end is final.csv"
    );
    let three = dir.join("three");
    run(&three, 3, &[FRAMES]);
    for k in 0..3 {
        assert_eq!(index(&three, k)["pieces"], 3);
        assert_eq!(frame_rows(&one, k), frame_rows(&three, k), "frame {k} on 3 ranks");
        assert_eq!(index(&one, k)["t"], index(&three, k)["t"]);
    }
    // cut between the first and second frames, continued on 3 ranks
    let cut = dir.join("cut");
    let step = |k: usize| index(&one, k)["step"].as_u64().unwrap();
    // an even step (a cycle's end) between them
    let at = (step(0) + step(1)) / 4 * 2;
    assert!(step(0) < at && at < step(1));
    let (max, ck) = (
        format!("time.max_steps={at}"),
        format!("checkpoint.every_steps={at}"),
    );
    run(&cut, 2, &[FRAMES, &max, &ck]);
    assert!(
        !cut.join("frames/frame_01.json").exists(),
        "frame 1 lies after the cut"
    );
    let (code, _, err) = common::restart_to_end(&cut, 3);
    assert_eq!(code, 0, "{err}");
    for k in 0..3 {
        assert_eq!(
            frame_rows(&one, k),
            frame_rows(&cut, k),
            "frame {k} after the restart"
        );
    }
    let out = dir.join("report");
    let (code, _, err) = common::hsph(&["report", one.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    for stem in ["flow_00", "flow_01", "flow_02", "flow_final"] {
        let png = std::fs::read(out.join(format!("{stem}.png"))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{stem}.png");
        assert!(out.join(format!("{stem}.svg")).is_file());
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("(flow_00.png)") && md.contains("(flow_final.png)"),
        "{md}"
    );
}

/// A scene with fluid writes frames at ¼, ½ and ¾ of t_end unless told otherwise, `[]`
/// writes none, and a time that is not a positive number exits 2 naming the key.
#[test]
fn frames_default_to_quarters_and_bad_times_are_refused() {
    let dir = common::temp_dir("frames-default");
    let auto = dir.join("auto");
    run(&auto, 1, &[]);
    for (k, q) in [0.25, 0.5, 0.75].into_iter().enumerate() {
        assert_eq!(index(&auto, k)["requested_t"].as_f64().unwrap(), q * 0.06);
    }
    assert!(!auto.join("frames/frame_03.json").exists());
    let none = dir.join("none");
    run(&none, 1, &["output.frames=[]"]);
    assert!(!none.join("frames").exists());
    for (set, key) in [
        ("output.frames=[0.01, -0.02]", "output.frames[1]"),
        ("output.frames=[0.0]", "output.frames[0]"),
        ("output.frames=[nan]", "output.frames[0]"),
    ] {
        let (code, _, err) = common::hsph(&["check", SCENE, "--set", set]);
        assert_eq!(code, 2, "{set}: {err}");
        assert!(err.contains(key), "{set}: {err}");
    }
    let (code, out, err) = common::hsph(&["check", SCENE, "--set", "output.frames=[0.01, 0.5]"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("output.frames[1] = 0.5 s lies past time.t_end"),
        "{out}"
    );
}
