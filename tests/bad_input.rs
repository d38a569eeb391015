//! Bad input: every mistake exits with status 2 and one located message on stderr, never a
//! panic and never a `summary.json`; randomly mutated scenes never panic the loader.

use crate::common;

use common::{repo_path, temp_dir};
use hsph::error::Error;
use hsph::scene::load_scene_str;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn shipped() -> String {
    fs::read_to_string(repo_path("inputs/dam_break_2d.toml")).unwrap()
}

fn hsph(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(args)
        .output()
        .expect("the hsph binary runs")
}

/// 1-based line of the first line of `text` containing `pat`.
fn line_of(text: &str, pat: &str) -> usize {
    text.lines()
        .position(|l| l.contains(pat))
        .unwrap_or_else(|| panic!("`{pat}` not in the scene"))
        + 1
}

/// Write `text` as a scene file in a fresh temp dir; returns (scene path, an unused --out).
fn write_scene(tag: &str, text: &str) -> (PathBuf, PathBuf) {
    let dir = temp_dir(tag);
    let scene = dir.join("scene.toml");
    fs::write(&scene, text).unwrap();
    (scene, dir.join("out"))
}

/// Exit status 2, exactly one non-empty line on stderr containing every needle, no panic.
fn assert_input_error(out: &Output, needles: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "exit status; stderr:\n{stderr}");
    assert!(!stderr.contains("panicked"), "panic:\n{stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one message expected, got:\n{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "`{n}` missing from:\n{stderr}");
    }
    stderr
}

/// `hsph run` on a mutated scene: located error, no run directory, no summary.json.
pub(crate) fn run_bad_scene(tag: &str, text: &str, key: &str, line_pat: &str, valid: &[&str]) {
    let (scene, out) = write_scene(tag, text);
    let o = hsph(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let loc = format!("{}:{}:", scene.display(), line_of(text, line_pat));
    let key = format!("key `{key}`");
    let mut needles = vec![loc.as_str(), key.as_str()];
    needles.extend_from_slice(valid);
    assert_input_error(&o, &needles);
    assert!(!out.join("summary.json").exists());
    assert!(!out.exists(), "no run directory for a bad scene");
    // `hsph check` reports the same error
    let o = hsph(&["check", scene.to_str().unwrap()]);
    assert_input_error(&o, &needles);
    let _ = fs::remove_dir_all(scene.parent().unwrap());
}

#[test]
fn unknown_key() {
    let text = shipped().replace("delta = 0.1\n", "delta = 0.1\nviscosity = 0.1\n");
    run_bad_scene(
        "unknown",
        &text,
        "physics.viscosity",
        "viscosity = 0.1",
        &[
            "unknown field `viscosity`",
            "expected one of",
            "laminar_viscosity",
        ],
    );
}

#[test]
fn missing_key() {
    let text = shipped().replace("dx = 0.006\n", "");
    run_bad_scene(
        "missing",
        &text,
        "discretisation.dx",
        "[discretisation]",
        &["missing field `dx`", "README"],
    );
}

#[test]
fn wrong_type() {
    let text = shipped().replace("dx = 0.006", "dx = \"6 mm\"");
    run_bad_scene(
        "wrongtype",
        &text,
        "discretisation.dx",
        "dx = \"6 mm\"",
        &["invalid type", "expected a number"],
    );
}

/// A count given a negative or fractional value is named with the range it takes, not Rust's
/// type name.
#[test]
fn a_count_out_of_its_type() {
    for (bad, what) in [("-3", "integer `-3`"), ("2.5", "floating point `2.5`")] {
        let text = shipped().replace("dx = 0.006\n", &format!("dx = 0.006\nrelax = {bad}\n"));
        run_bad_scene(
            "count",
            &text,
            "discretisation.relax",
            &format!("relax = {bad}"),
            &[what, "expected a whole number from 0 to 4294967295"],
        );
    }
}

#[test]
fn negative_spacing() {
    let text = shipped().replace("dx = 0.006", "dx = -0.006");
    run_bad_scene(
        "negdx",
        &text,
        "discretisation.dx",
        "dx = -0.006",
        &["must be a positive number", "-0.006", "e.g. dx ="],
    );
}

/// A CFL number above the accepted range is an input error naming the range; one above 1
/// but inside it is accepted with a warning (the stability map goes there).
#[test]
fn cfl_beyond_the_range_is_refused_and_above_one_warned() {
    let text = shipped().replace("cfl = 0.2", "cfl = 4.0");
    run_bad_scene(
        "cfl4",
        &text,
        "time.cfl",
        "cfl = 4.0",
        &["must lie in (0, 3]", "0.2 is typical"],
    );
    let (scene, _) = write_scene("cfl15", &shipped().replace("cfl = 0.2", "cfl = 1.5"));
    let o = hsph(&["check", scene.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    let all = format!("{stderr}{}", String::from_utf8_lossy(&o.stdout));
    assert!(all.contains("time.cfl = 1.5 is above 1"), "{all}");
    let _ = fs::remove_dir_all(scene.parent().unwrap());
}

#[test]
fn body_outside_domain() {
    let text = shipped().replace("max = [0.146, 0.292]", "max = [0.146, 0.9]");
    run_bad_scene(
        "outside",
        &text,
        "fluid[0].max",
        "max = [0.146, 0.9]",
        &["outside the domain", "axis 1", "enlarge domain"],
    );
}

#[test]
fn sound_speed_too_low() {
    let text = shipped().replace("c0 = 25.0", "c0 = 5.0");
    run_bad_scene(
        "c0",
        &text,
        "material[0].c0",
        "c0 = 5.0",
        &["below 10 × the expected speed", "c0 ≥"],
    );
}

#[test]
fn overlapping_bodies_are_located() {
    // found only while filling the lattice, after validation
    let text = format!(
        "{}\n[[fluid]]\nname = \"drop\"\nmaterial = \"water\"\nmin = [0.05, 0.05]\nmax = [0.1, 0.1]\n",
        shipped()
    );
    // the second [[fluid]] table is fluid[1]
    let at = text.rfind("[[fluid]]").unwrap();
    let line = text[..at].lines().count() + 1;
    let (scene, out) = write_scene("overlap", &text);
    let o = hsph(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
    ]);
    let loc = format!("{}:{line}:", scene.display());
    assert_input_error(&o, &[&loc, "key `fluid[1]`", "overlaps fluid[0]", "shrink"]);
    assert!(!out.join("summary.json").exists());
}

#[test]
fn non_ascii_face_name() {
    let text = shipped().replace("open = [\"y+\"]", "open = [\"é\"]");
    run_bad_scene(
        "face",
        &text,
        "wall[0].open[0]",
        "open = [\"é\"]",
        &["unknown face `é`", "valid faces: x-, x+, y-, y+"],
    );
}

#[test]
fn bad_set() {
    let scene = repo_path("inputs/dam_break_2d.toml");
    let s = scene.to_str().unwrap();
    let dir = temp_dir("badset");
    let out = dir.join("out");
    let o_s = out.to_str().unwrap();
    let cases: [(&str, &[&str]); 5] = [
        (
            "time.t_end",
            &[
                "key `time.t_end`",
                "not key.path=value",
                "e.g. --set time.t_end=0.5",
            ],
        ),
        (
            "time.t_end=soon",
            &["key `time.t_end`", "invalid type", "expected a number"],
        ),
        ("time.t_edn=1", &["key `time.t_edn`", "unknown field", "t_end"]),
        (
            "fluid[3].min=[0,0]",
            &["key `fluid[3].min`", "past the end", "length 1"],
        ),
        (
            "discretisation.dx=-1",
            &["key `discretisation.dx`", "positive", "e.g. dx ="],
        ),
    ];
    for (set, needles) in cases {
        let o = hsph(&["run", s, "--out", o_s, "-q", "--set", set]);
        let msg = assert_input_error(&o, needles);
        // the mistake is on the command line, not in the file
        assert!(msg.contains("--set"), "{set}: {msg}");
        assert!(
            !msg.contains("dam_break_2d.toml"),
            "{set}: blames the file: {msg}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn non_empty_out_without_force() {
    let dir = temp_dir("nonempty");
    let out = dir.join("out");
    fs::create_dir_all(out.join("mine")).unwrap();
    fs::write(out.join("keep.txt"), "precious").unwrap();
    fs::write(out.join("timeseries.csv"), "not from hsph").unwrap();
    let scene = repo_path("inputs/dam_break_2d.toml");
    let o = hsph(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "-q",
        "--set",
        "time.t_end=0.001",
    ]);
    let o_disp = out.display().to_string();
    assert_input_error(&o, &["key `--out`", &o_disp, "not empty", "--force"]);
    assert_eq!(fs::read_to_string(out.join("keep.txt")).unwrap(), "precious");
    assert_eq!(
        fs::read_to_string(out.join("timeseries.csv")).unwrap(),
        "not from hsph"
    );
    let mut names: Vec<String> = fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["keep.txt", "mine", "timeseries.csv"]);
    let _ = fs::remove_dir_all(&dir);
}

#[cfg(not(feature = "mpi"))]
#[test]
fn mpi_backend_without_feature() {
    let dir = temp_dir("mpi");
    let out = dir.join("out");
    let scene = repo_path("inputs/dam_break_2d.toml");
    let o = hsph(&[
        "run",
        scene.to_str().unwrap(),
        "--backend",
        "mpi",
        "--out",
        out.to_str().unwrap(),
        "-q",
    ]);
    assert_input_error(&o, &["key `--backend`", "`mpi` cargo feature", "--features mpi"]);
    assert!(!out.exists());
}

// ---------------------------------------------------------------------------------------
// Property test: mutated scene text never panics the loader.

/// Mutants of the shipped scene (1–3 mutations each), deterministic.
fn mutants(count: usize, seed: u64) -> Vec<String> {
    common::mutate::mutants(&shipped(), count, seed)
}

#[test]
fn mutated_scenes_never_panic() {
    let file = Path::new("mutant.toml");
    let (mut ok, mut errs, mut built) = (0, 0, 0);
    for (n, text) in mutants(600, 0xbad_5eed).iter().enumerate() {
        let r = std::panic::catch_unwind(|| load_scene_str(text, file, "mutant", &[]));
        let r = r.unwrap_or_else(|_| panic!("mutant {n} panicked the loader:\n{text}"));
        match r {
            Ok((scene, _)) => {
                ok += 1;
                // a scene that loads must also build (what `hsph check` does) without panic
                let c = std::panic::catch_unwind(|| hsph::cli::check_report(&scene));
                match c.unwrap_or_else(|_| panic!("mutant {n} panicked `check`:\n{text}")) {
                    Ok(_) => built += 1,
                    Err(Error::Input { key, .. }) => assert!(!key.is_empty(), "mutant {n}"),
                    Err(e) => panic!("mutant {n}: check gave a non-input error {e}:\n{text}"),
                }
            }
            Err(Error::Input { at, key, message }) => {
                errs += 1;
                let at = at.unwrap_or_else(|| panic!("mutant {n}: no location for `{key}`: {message}"));
                assert_eq!(at.file, file, "mutant {n}: {message}");
                assert!(
                    !key.is_empty() || at.line.is_some(),
                    "mutant {n}: neither key nor line: {message}\n{text}"
                );
                assert!(!message.is_empty());
            }
            Err(e) => panic!("mutant {n}: not an input error: {e}"),
        }
    }
    eprintln!("{ok} mutants loaded ({built} built), {errs} rejected with located errors");
    assert!(errs > 300 && ok > 20, "the mutations must exercise both outcomes");
}

#[test]
fn mutated_files_through_hsph_check() {
    let dir = temp_dir("mutants");
    let (mut zero, mut two) = (0, 0);
    for (n, text) in mutants(12, 0xc4ec_4000).iter().enumerate() {
        let path = dir.join(format!("mutant_{n}.toml"));
        fs::write(&path, text).unwrap();
        let o = hsph(&["check", path.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!stderr.contains("panicked"), "mutant {n}:\n{stderr}\n{text}");
        match o.status.code() {
            Some(0) => zero += 1,
            Some(2) => {
                two += 1;
                eprint!("mutant {n}: {stderr}");
                assert_eq!(stderr.lines().count(), 1, "{stderr}");
                assert!(stderr.contains(&path.display().to_string()), "{stderr}");
            }
            c => panic!("mutant {n}: exit status {c:?}\n{stderr}\n{text}"),
        }
    }
    eprintln!("hsph check on 12 mutants: {zero} ok, {two} rejected");
    assert!(two > 0);
    let _ = fs::remove_dir_all(&dir);
}

fn impact() -> String {
    fs::read_to_string(repo_path("inputs/impact_oblique_45.toml")).unwrap()
}

/// Bad solid materials (issue 12): each names its key, line and what would be valid.
#[test]
fn bad_solid_materials_name_their_key() {
    let with = |extra: &str| {
        impact().replace(
            "failure_strain = 0.5\n",
            &format!("failure_strain = 0.5\n{extra}\n"),
        )
    };
    run_bad_scene(
        "negshear",
        &with("shear_modulus = -27.6e9"),
        "material[0].shear_modulus",
        "shear_modulus = -27.6e9",
        &["must be a number > 0", "e.g. shear_modulus ="],
    );
    run_bad_scene(
        "melt",
        &with("t_melt = 250.0"),
        "material[0].t_melt",
        "t_melt = 250.0",
        &["melt temperature 250 K is not above the room temperature 294 K"],
    );
    run_bad_scene(
        "model",
        &impact().replace("model = \"solid\"", "model = \"plastic\""),
        "material[0].model",
        "model = \"plastic\"",
        &["unknown variant `plastic`", "fluid", "solid"],
    );
    run_bad_scene(
        "library",
        &impact().replace("library = \"al6061-t6\"", "library = \"al2024-t3\""),
        "material[0].library",
        "library = \"al2024-t3\"",
        &["unknown library material `al2024-t3`", "al6061-t6"],
    );
    // a solid material on a fluid body, a fluid key on a solid
    let fluid_body = impact().replacen("[[solid]]\nname = \"plate\"", "[[fluid]]\nname = \"plate\"", 1);
    run_bad_scene(
        "solid-on-fluid",
        &fluid_body,
        "fluid[0].material",
        "material = \"al6061\"",
        &["is a solid", "[[solid]]"],
    );
    let hydro = impact().replace("name = \"plate\"\n", "name = \"plate\"\nhydrostatic = true\n");
    run_bad_scene(
        "hydro",
        &hydro,
        "solid[0].hydrostatic",
        "hydrostatic = true",
        &["fluid bodies only"],
    );
}

#[test]
fn morris_no_slip_needs_a_no_slip_dummy_or_mirror_wall() {
    // the shipped dam break's tank is free-slip
    let text = shipped().replace(
        "slip = \"free_slip\"",
        "slip = \"free_slip\"\nno_slip = \"morris\"",
    );
    run_bad_scene(
        "morris-free-slip",
        &text,
        "wall[0].no_slip",
        "no_slip = \"morris\"",
        &[
            "method = \"dummy\" or \"mirror\"",
            "slip = \"no_slip\"",
            "no_slip = \"adami\"",
        ],
    );
}

#[test]
fn renormalised_viscous_operator_needs_a_laminar_viscosity() {
    let text = shipped().replace(
        "artificial_viscosity = 0.02",
        "artificial_viscosity = 0.02\nviscous_operator = \"renormalised\"",
    );
    run_bad_scene(
        "renorm-no-nu",
        &text,
        "physics.viscous_operator",
        "viscous_operator",
        &["laminar_viscosity", "remove viscous_operator"],
    );
}

/// A ghost skin outside 0–1 of the support is an input error naming the key, its line and a
/// valid value.
#[test]
fn skin_beyond_the_support_is_refused() {
    let text = format!("{}\n[performance]\nskin = 1.5\n", shipped());
    run_bad_scene(
        "skin",
        &text,
        "performance.skin",
        "skin = 1.5",
        &["fraction of the kernel support", "got 1.5", "e.g. skin ="],
    );
}

#[test]
fn a_count_cap_below_one_is_refused() {
    let text = format!("{}\n[balance]\nmax_count = 0.8\n", shipped());
    run_bad_scene(
        "max-count",
        &text,
        "balance.max_count",
        "max_count = 0.8",
        &["most particles a rank may own", "got 0.8", "1 splits by counts"],
    );
}

/// A number where a name is due (an enum's value) lists the names the key takes, read from
/// the parser's own refusal of an unknown name (`SceneSource::variants_at`).
#[test]
fn a_number_for_a_name_lists_the_names() {
    let text = shipped().replace("density_diffusion = \"antuono\"", "density_diffusion = 1");
    run_bad_scene(
        "enum-number",
        &text,
        "physics.density_diffusion",
        "density_diffusion = 1",
        &["`molteni`", "`antuono`", "`fourtakas`", "in quotes"],
    );
    let text = shipped().replace("kernel = \"wendland_c2\"", "kernel = 2");
    run_bad_scene(
        "enum-kernel",
        &text,
        "discretisation.kernel",
        "kernel = 2",
        &["`wendland_c2`", "`cubic_spline`", "in quotes"],
    );
}

/// A sphere region without its centre or radius says which is missing (not "got 0").
#[test]
fn a_sphere_without_centre_or_radius_names_the_missing_key() {
    let sphere = "\n[[refine]]\nshape = \"sphere\"\nmin = [0.2, 0.1]\nmax = [0.4, 0.3]\nlevel = 1\n";
    let text = shipped() + sphere;
    run_bad_scene(
        "sphere-centre",
        &text,
        "refine[0].centre",
        "[[refine]]",
        &["is missing", "centre = [", "min and max are a block's keys"],
    );
    let text = shipped() + &sphere.replace("min = [0.2, 0.1]\nmax = [0.4, 0.3]\n", "centre = [0.3, 0.2]\n");
    run_bad_scene(
        "sphere-radius",
        &text,
        "refine[0].radius",
        "[[refine]]",
        &["is missing", "radius = 0.05"],
    );
}

/// A moving wall whose particles the motion law would carry out of the domain before
/// `time.t_end` is refused before the run starts (it used to stop the run mid-way), naming the
/// motion's key and the bound that would hold it. The tank's outer box ends at x = 0.602 m;
/// a sine of amplitude 0.05 m and period 1 s reaches its crest at t = 0.25 s < t_end = 0.3 s.
#[test]
fn a_wall_moved_out_of_the_domain_is_refused_before_the_run() {
    let text = shipped().replace(
        "slip = \"free_slip\"",
        "slip = \"free_slip\"\nmotion = { law = \"sine\", amplitude = [0.05, 0.0], period = 1.0 }",
    );
    run_bad_scene(
        "wall-sweep",
        &text,
        "wall[0].motion",
        "motion = {",
        &[
            "wall `tank`",
            "x = 0.652 m",
            "domain.max[0] ≥ 0.652",
            "shorten the motion",
        ],
    );
}
