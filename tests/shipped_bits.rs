//! The bits of every shipped scene, kept: `final.csv` after 40 steps in every mode the scene
//! accepts (interactions gather or pairs × neighbours lists, cells or verlet), equal on 1 and
//! 3 ranks, and equal to the hashes recorded in `tests/data/shipped_bits.csv`. A change that
//! moves a bit of any shipped scene in any mode fails here; one that means to (a physics
//! change) records the new hashes with
//! `python3 tools/shipped_bits.py > tests/data/shipped_bits.csv` and says so in its commit.
//! Scenes above 24 000 particles run coarsened (the tool's docs); a mode a scene refuses is
//! recorded as `refused`, so a mode that starts or stops being accepted fails here too.

use crate::common;

#[test]
fn every_shipped_scene_keeps_its_bits_in_every_mode_on_1_and_3_ranks() {
    let out = std::process::Command::new("python3")
        .arg(common::repo_path("tools/shipped_bits.py"))
        .args(["--hsph", env!("CARGO_BIN_EXE_hsph")])
        .current_dir(common::repo_path("."))
        .output()
        .expect("python3 runs tools/shipped_bits.py");
    let got = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success(),
        "tools/shipped_bits.py failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let want = std::fs::read_to_string(common::repo_path("tests/data/shipped_bits.csv")).unwrap();
    let scenes = std::fs::read_dir(common::repo_path("inputs"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "toml")
        })
        .count();
    // a header, and six modes of every scene
    assert_eq!(got.lines().count(), 1 + 6 * scenes, "{got}");
    let differ: Vec<&str> = got.lines().filter(|l| l.ends_with("ranks-differ")).collect();
    assert!(differ.is_empty(), "1 and 3 ranks differ: {differ:#?}");
    let changed: Vec<String> = got
        .lines()
        .zip(want.lines())
        .filter(|(g, w)| g != w)
        .map(|(g, w)| format!("now {g}\n was {w}"))
        .collect();
    assert!(changed.is_empty(), "bits changed:\n{}", changed.join("\n"));
    assert_eq!(got.lines().count(), want.lines().count());
}
