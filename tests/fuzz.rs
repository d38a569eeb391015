//! Issues 9 and 32's property test: about 3 000 mutants, seeded and reproducible, through the
//! `hsph` binary on 2 worker threads. No mutant may panic, exit with a status other than 0, 1,
//! 2 or 3, or run over 10 s (its process group is then killed and the test fails naming the
//! command). More than a fifth of all mutants are real runs of a few steps: asserted both for
//! `run` invocations and for the runs that got past their input checks (exit 0, 1 or 3).
//!
//! Families (each from its own stream of the seed [`SEED`]):
//! - `scene`: mutated scene files through `run` (bounded by `time.max_steps`) and `check`;
//! - `flags`: flag sets of `run`, `check` and `plan` (issue 9);
//! - `layout`: mutated node-layout files through `plan`;
//! - `cli`: valid, edge and nonsense values of the flags of `run`, `check`, `plan`, `model`,
//!   `bench`, `validate`, `topology` and `report` (`jobscript` has its own family), and every
//!   odd value of `run`'s flags once in an otherwise valid run; commands that could work long
//!   are bounded (`bench` at most 3 steps of one repetition, `validate` always with at least
//!   one bad argument, `run` with `time.max_steps`);
//! - `set`: `--set` values of the real keys of `inputs/dam_break_2d.toml`: half near the valid
//!   value (a user tuning the scene), half odd (0, −x, ±1e300, 1e-300, nan, inf, huge
//!   integers, strings, arrays of the wrong length) or odd `--set` syntax, through `run`,
//!   `check`, `plan`, `bench` and `model`; and every key with each of 0, −1, ±1e300, 1e-300,
//!   nan and inf through a run of 5 steps;
//! - `checkpoint`: a real run directory with checkpoints (1 and 2 ranks), copied per mutant,
//!   its newest checkpoint's `manifest.json` mutated as JSON (numbers, part names, counts and
//!   sizes, deleted keys, the embedded scene, the run state) or as text, or a part file
//!   damaged, then `run --restart` a bit beyond its end; the checkpoint files the restarts
//!   read must be unchanged at the end;
//! - `mesh` (issue 83): `check` and short runs of a 3D scene whose fluid body is an STL mesh:
//!   the hostile files of `tests/mesh.rs` (cut, NaN, open, turned, inward, empty, a 10⁹
//!   header, a lying header, self-crossing, a FIFO, /dev/zero, a directory) and byte, header
//!   and token mutants of a good binary and ASCII box, with odd placement keys;
//! - `jobscript`: hostile values in the fields of `hsph jobscript`; every script written
//!   (exit 0) must pass `bash -n` and keep every `#SBATCH` line before the first command
//!   (`tests/injection.rs` runs scripts with stand-ins; this is the property over random
//!   values).
//!
//! Every path a mutant may write is inside its own working directory under the test's temp
//! directory. Replay: the seed, and for a failure its case number, working directory and full
//! command, are printed; `HSPH_FUZZ_CASE=k` runs case `k` alone (its working directory is
//! kept), `HSPH_FUZZ_SEED=n` tries other mutants, `HSPH_FUZZ_VERBOSE=1` prints every case.

use crate::common;

use common::mutate::{mutants, mutate};
use common::{repo_path, temp_dir, Rng};
use serde_json::{json, Value};
use std::fs;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The seed every family's mutants derive from (`HSPH_FUZZ_SEED` replaces it).
const SEED: u64 = 0xf022_2026;

/// Longest a mutant may take (issue 32: each mutant bounded to 10 s).
const BOUND: Duration = Duration::from_secs(10);

/// The families of mutants, in the order they are generated.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Family {
    Scene,
    Flags,
    Layout,
    Cli,
    Set,
    Checkpoint,
    Jobscript,
    Mesh,
}

const FAMILIES: [Family; 8] = [
    Family::Scene,
    Family::Flags,
    Family::Layout,
    Family::Cli,
    Family::Set,
    Family::Checkpoint,
    Family::Jobscript,
    Family::Mesh,
];

/// What is set up in a case's working directory before its command runs.
enum Prep {
    Nothing,
    /// Copy the run directory `from` to `run/` in the working directory, then damage it.
    Checkpoint {
        from: PathBuf,
        change: CkChange,
    },
}

/// A change to the newest checkpoint (`step`) of a copied run directory.
enum CkChange {
    /// Nothing: the restart's `--set` is the mutant.
    None,
    /// `manifest.json` replaced by this text.
    Manifest { step: String, text: String },
    /// `manifest.json` removed (the checkpoint before is used).
    DropManifest { step: String },
    /// A part file damaged.
    Part { step: String, file: String, op: PartOp },
}

enum PartOp {
    /// XOR the byte at this offset with this (non-zero) mask.
    Flip(u64, u8),
    /// Cut to this length.
    Truncate(u64),
    /// Append these bytes.
    Append(Vec<u8>),
    Remove,
    /// Replace by a symbolic link to this path.
    Symlink(&'static str),
    /// Replace by an empty directory.
    Dir,
}

struct Case {
    family: Family,
    args: Vec<String>,
    prep: Prep,
    /// `jobscript` cases: where the script goes, relative to the working directory (`None`:
    /// standard output).
    script: Option<Option<String>>,
    /// What else a failure report needs (a mutated scene, the damage done to a checkpoint).
    note: String,
}

impl Case {
    fn new(family: Family, args: Vec<String>) -> Case {
        Case {
            family,
            args,
            prep: Prep::Nothing,
            script: None,
            note: String::new(),
        }
    }

    fn is_run(&self) -> bool {
        self.args.first().is_some_and(|a| a == "run")
    }
}

fn s(v: &str) -> String {
    v.to_string()
}

fn pick<'a>(rng: &mut Rng, from: &[&'a str]) -> &'a str {
    from[rng.below(from.len())]
}

fn p(path: &Path) -> String {
    path.display().to_string()
}

/// `arg` as one shell word, so that a failure's command can be pasted into bash.
fn shell_word(arg: &str) -> String {
    if !arg.is_empty()
        && arg
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"_./=:,+-@%".contains(&b))
    {
        return arg.to_string();
    }
    if arg.chars().any(|c| c.is_control()) {
        let mut o = String::from("$'");
        for c in arg.chars() {
            match c {
                '\'' => o += "\\'",
                '\\' => o += "\\\\",
                '\n' => o += "\\n",
                '\r' => o += "\\r",
                '\t' => o += "\\t",
                c if c.is_control() => o += &format!("\\x{:02x}", c as u32),
                c => o.push(c),
            }
        }
        return o + "'";
    }
    format!("'{}'", arg.replace('\'', "'\\''"))
}

fn shell_line(bin: &str, args: &[String]) -> String {
    std::iter::once(shell_word(bin))
        .chain(args.iter().map(|a| shell_word(a)))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `s` as a TOML basic string.
fn toml_string(s: &str) -> String {
    let mut o = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => o += "\\\"",
            '\\' => o += "\\\\",
            '\n' => o += "\\n",
            '\r' => o += "\\r",
            '\t' => o += "\\t",
            c if c.is_control() => o += &format!("\\u{:04X}", c as u32),
            c => o.push(c),
        }
    }
    o.push('"');
    o
}

/// Copy the tree `from` to `to`; files under a directory named `checkpoints` are hard
/// links (a restart only reads them, and writes a checkpoint of its own through a temporary
/// and a rename; the test checks at the end that the originals are unchanged).
fn copy_dir(from: &Path, to: &Path) {
    fs::create_dir_all(to).unwrap();
    let link = from.components().any(|c| c.as_os_str() == "checkpoints");
    for e in fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let t = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &t);
        } else if link {
            fs::hard_link(e.path(), &t).unwrap();
        } else {
            fs::copy(e.path(), &t).unwrap();
        }
    }
}

/// Replace the file at `path` by a new one with `bytes` (never writing through a hard link).
fn replace_file(path: &Path, bytes: &[u8]) {
    fs::remove_file(path).unwrap();
    fs::write(path, bytes).unwrap();
}

/// Every file under `dir` with its bytes' FNV-1a hash, sorted.
fn tree_hashes(dir: &Path) -> Vec<(PathBuf, u64)> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in fs::read_dir(&d).unwrap() {
            let e = e.unwrap();
            if e.file_type().unwrap().is_dir() {
                todo.push(e.path());
            } else {
                let h = fs::read(e.path())
                    .unwrap()
                    .iter()
                    .fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
                        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
                    });
                out.push((e.path(), h));
            }
        }
    }
    out.sort();
    out
}

// ---------------------------------------------------------------------------------------------
// Fixtures: finished runs, checkpoints, damaged run directories, hostile scene names
// ---------------------------------------------------------------------------------------------

/// A finished run directory with checkpoints.
struct Checkpoint {
    run: PathBuf,
    /// The newest checkpoint's directory name (`step-…`) and step.
    step: String,
    step_n: u64,
    /// The checkpoint before it.
    older: String,
    manifest: String,
    /// Part files of the newest checkpoint with their sizes.
    parts: Vec<(String, u64)>,
}

/// The run's `time.t_end`; a restart continues a bit beyond it.
const CK_T_END: f64 = 0.002;

struct Fixtures {
    dam: PathBuf,
    hydro: PathBuf,
    /// A finished 1-rank, 1-thread run and a 2-rank one (for `model` and `report`).
    r1: PathBuf,
    r2: PathBuf,
    /// Run directories with a damaged summary or series.
    damaged: Vec<PathBuf>,
    cks: Vec<Checkpoint>,
    empty: PathBuf,
    topo: Vec<PathBuf>,
    /// Scenes with a valid name in each hostile directory, then scenes with hostile names
    /// (for `jobscript`).
    js_scenes: Vec<PathBuf>,
}

fn hsph_ok(args: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "fixture {:?}: {}",
        args,
        String::from_utf8_lossy(&o.stderr)
    );
}

fn checkpoint_fixture(fx: &Path, name: &str, ranks: &str) -> Checkpoint {
    let run = fx.join(name);
    let dam = p(&repo_path("inputs/dam_break_2d.toml"));
    hsph_ok(&[
        "run",
        &dam,
        "-q",
        "--threads",
        "1",
        "--ranks",
        ranks,
        "--out",
        &p(&run),
        "--set",
        &format!("time.t_end={CK_T_END}"),
        "--set",
        "checkpoint.every_steps=5",
        "--set",
        "output.interval=0.002",
    ]);
    let mut steps: Vec<String> = fs::read_dir(run.join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    steps.sort();
    assert!(steps.len() >= 2, "{name}: checkpoints {steps:?}");
    let step = steps.last().unwrap().clone();
    let dir = run.join("checkpoints").join(&step);
    let mut parts: Vec<(String, u64)> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.file_name().to_string_lossy().starts_with("part-"))
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                e.metadata().unwrap().len(),
            )
        })
        .collect();
    parts.sort();
    Checkpoint {
        step_n: step.trim_start_matches("step-").parse().unwrap(),
        older: steps[steps.len() - 2].clone(),
        manifest: fs::read_to_string(dir.join("manifest.json")).unwrap(),
        parts,
        step,
        run,
    }
}

/// Scene names and directory names a hostile user could give `jobscript`.
const HOSTILE_NAMES: &[&str] = &[
    "dam",
    "x\ntouch PWNED",
    "$(touch PWNED)",
    "`touch PWNED`",
    "x\"; touch PWNED; echo \"",
    "x'; touch PWNED; echo '",
    "dam break",
    "x\r#SBATCH --time=99:00:00",
    "../../x",
    "",
    "a.b_c+d-e",
    "-x",
    "é∞",
    "x\\",
];
const HOSTILE_DIRS: &[&str] = &[
    "scenes",
    "sc enes",
    "sc\"$(touch PWNED)\"",
    "it's 'q' \\' x",
    "a\nb",
    "`touch PWNED`",
    "${HOME}",
    "é∞",
    "-d",
];

fn fixtures(dir: &Path, rng: &mut Rng) -> Fixtures {
    let fx = dir.join("fixtures");
    fs::create_dir_all(&fx).unwrap();
    let dam = repo_path("inputs/dam_break_2d.toml");
    let (r1, r2) = (fx.join("r1"), fx.join("r2"));
    for (out, ranks) in [(&r1, "1"), (&r2, "2")] {
        hsph_ok(&[
            "run",
            &p(&dam),
            "-q",
            "--threads",
            "1",
            "--ranks",
            ranks,
            "--out",
            &p(out),
            "--set",
            "time.max_steps=5",
        ]);
    }
    let cks = vec![
        checkpoint_fixture(&fx, "ck1", "1"),
        checkpoint_fixture(&fx, "ck2", "2"),
    ];
    let damaged = damaged_runs(&fx, &r2, rng);
    let empty = fx.join("empty");
    fs::create_dir_all(&empty).unwrap();
    // layout files: the shipped one, mutants of it, and one that does not exist
    let shipped_topo = fs::read_to_string(repo_path("topology/four_nodes_24.toml")).unwrap();
    let mut topo = vec![repo_path("topology/four_nodes_24.toml"), dir.join("missing.toml")];
    for (k, t) in mutants(&shipped_topo, 60, 0x7090).iter().enumerate() {
        let p = dir.join(format!("topo-{k}.toml"));
        fs::write(&p, t).unwrap();
        topo.push(p);
    }
    let js_scenes = hostile_scenes(&fx, &dam);
    Fixtures {
        hydro: repo_path("inputs/hydrostatic_2d.toml"),
        dam,
        r1,
        r2,
        damaged,
        cks,
        empty,
        topo,
        js_scenes,
    }
}

/// Damaged copies of the run `r2` under `fx`: summaries cut, mutated or a link to
/// /dev/zero, final rows cut, garbage series.
fn damaged_runs(fx: &Path, r2: &Path, rng: &mut Rng) -> Vec<PathBuf> {
    let mut damaged = Vec::new();
    let summary = fs::read_to_string(r2.join("summary.json")).unwrap();
    for k in 0..8 {
        let d = fx.join(format!("damaged-{k}"));
        copy_dir(r2, &d);
        match k {
            0 => fs::write(d.join("summary.json"), &summary[..summary.len() / 2]).unwrap(),
            1..=3 => {
                let mut v: Value = serde_json::from_str(&summary).unwrap();
                let ptr = random_pointer(&v, rng);
                mutate_json_at(&mut v, &ptr, rng);
                fs::write(d.join("summary.json"), raw_json(&v)).unwrap();
            }
            4 => {
                let t = fs::read_to_string(d.join("final.csv")).unwrap();
                fs::write(d.join("final.csv"), &t[..t.len() / 3]).unwrap();
            }
            5 => fs::write(d.join("traffic.csv"), "x,y\n1,2,3\nnan,\n").unwrap(),
            6 => fs::write(d.join("diagnostics.csv"), "").unwrap(),
            _ => {
                fs::remove_file(d.join("summary.json")).unwrap();
                std::os::unix::fs::symlink("/dev/zero", d.join("summary.json")).unwrap();
            }
        }
        damaged.push(d);
    }
    damaged
}

/// Scenes for `hsph jobscript` under `fx`: the dam break (`dam`) with a valid name in each
/// hostile directory, and with hostile names in hostile directories.
fn hostile_scenes(fx: &Path, dam: &Path) -> Vec<PathBuf> {
    let text = fs::read_to_string(dam).unwrap();
    let old = "name = \"dam_break_2d\"\n";
    assert!(text.contains(old));
    let mut js_scenes = Vec::new();
    let valid = HOSTILE_DIRS.iter().map(|d| ("dam", *d));
    let hostile = (0..24).map(|j| {
        (
            HOSTILE_NAMES[j % HOSTILE_NAMES.len()],
            HOSTILE_DIRS[(j * 5 + j / HOSTILE_NAMES.len()) % HOSTILE_DIRS.len()],
        )
    });
    for (k, (name, sub)) in valid.chain(hostile).enumerate() {
        let d = fx.join(format!("js-{k}")).join(sub);
        fs::create_dir_all(&d).unwrap();
        let file = d.join(if k % 3 == 2 {
            "sc ene '$(x)'.toml"
        } else {
            "scene.toml"
        });
        fs::write(
            &file,
            text.replacen(old, &format!("name = {}\n", toml_string(name)), 1),
        )
        .unwrap();
        js_scenes.push(file);
    }
    js_scenes
}

// ---------------------------------------------------------------------------------------------
// Family `scene`, `flags` and `layout` (issue 9)
// ---------------------------------------------------------------------------------------------

/// Flags and the values tried for each (valid ones, edge values and nonsense).
const FLAGS: &[(&str, &[&str])] = &[
    ("--ranks", &["0", "1", "2", "3", "8", "-1", "x", "100000"]),
    ("--threads", &["0", "1", "2", "x", "-3"]),
    ("--ranks-per-node", &["0", "1", "2", "5", "x"]),
    (
        "--placement",
        &[
            "rank-order",
            "centre-distance",
            "node-grid",
            "min-cut",
            "all",
            "bogus",
        ],
    ),
    ("--backend", &["auto", "serial", "local", "mpi", "x"]),
    ("--max-memory", &["1", "1G", "x", "0"]),
    ("--min-particles-per-rank", &["0", "1", "100000"]),
    ("--bind", &["none", "cores", "x"]),
    ("--set", CLI_SETS),
];

/// `--set` values for flag mixes: none of them makes a run long (no `time.*` but a shorter
/// end, no finer dx).
const CLI_SETS: &[&str] = &[
    "time.t_end=0.001",
    "time.cfl=5",
    "discretisation.dx=0.5",
    "discretisation.dx=0.02",
    "nosuch=1",
    "fluid[9].min=[0,0]",
    "output.format=\"netcdf\"",
    "balance.check_every=1",
    "physics.delta=-1",
    "dimension=3",
    "probe[0].axis=7",
    "limits.speed_over_c0=0.001",
    "name=\"../x\"",
    "=",
    "time",
];

fn flag_case(rng: &mut Rng, scene: &Path, dir: &Path, topo: &[PathBuf], n: usize) -> Case {
    let cmd = ["run", "check", "plan"][rng.below(3)];
    let mut args: Vec<String> = vec![cmd.into(), p(scene)];
    if cmd == "run" {
        let out = dir.join(format!("flags-{n}"));
        args.extend(["-q", "--force", "--out"].map(String::from));
        args.push(p(&out));
        args.extend(["--set", "time.max_steps=5", "--set", "output.format=\"none\""].map(String::from));
    }
    if cmd == "plan" {
        args.extend(["--ranks".into(), ["1", "4", "6", "0"][rng.below(4)].into()]);
    }
    // mostly flags the command takes (so that cases get past the parser), now and then any
    let takes = |f: &str| match cmd {
        "check" => ["--set", "--ranks", "--max-memory"].contains(&f),
        "plan" => ["--set", "--ranks-per-node", "--placement"].contains(&f),
        _ => true,
    };
    let mut used: Vec<&str> = Vec::new();
    for _ in 0..1 + rng.below(4) {
        if cmd != "check" && rng.below(8) == 0 && !used.contains(&"--topology") {
            used.push("--topology");
            args.extend(["--topology".into(), p(&topo[rng.below(topo.len())])]);
            continue;
        }
        let (flag, values) = FLAGS[rng.below(FLAGS.len())];
        let any = rng.below(10) == 0;
        if !any && (!takes(flag) || (flag != "--set" && used.contains(&flag))) {
            continue;
        }
        used.push(flag);
        args.extend([flag.to_string(), values[rng.below(values.len())].to_string()]);
    }
    Case::new(Family::Flags, args)
}

fn scene_case(rng: &mut Rng, text: &str, dir: &Path, n: usize, run: bool) -> Case {
    let path = dir.join(format!("mutant-{n}.toml"));
    fs::write(&path, text).unwrap();
    let mut args: Vec<String> = if run {
        let out = dir.join(format!("scene-{n}"));
        vec![s("run"), p(&path), s("-q"), s("--force"), s("--out"), p(&out)]
    } else {
        vec![s("check"), p(&path)]
    };
    args.extend(["--max-memory", "2G"].map(String::from));
    if run {
        args.extend(["--set", "time.max_steps=5", "--set", "output.interval=0"].map(String::from));
        if rng.below(3) == 0 {
            args.extend(["--ranks", "3", "--threads", "1"].map(String::from));
        }
    }
    Case {
        note: format!("scene {}:\n{text}", path.display()),
        ..Case::new(Family::Scene, args)
    }
}

fn layout_case(fx: &Fixtures, k: usize) -> Case {
    let t = &fx.topo[2 + k % (fx.topo.len() - 2)];
    let args = vec![
        s("plan"),
        p(&fx.dam),
        s("--ranks"),
        s(["96", "4", "24"][k % 3]),
        s("--topology"),
        p(t),
    ];
    Case::new(Family::Layout, args)
}

// ---------------------------------------------------------------------------------------------
// Family `cli`: every subcommand's flags with valid, edge and nonsense values
// ---------------------------------------------------------------------------------------------

const COUNTS: &[&str] = &[
    "0",
    "1",
    "2",
    "3",
    "-1",
    "4096",
    "4097",
    "100000",
    "18446744073709551616",
    "1e300",
    "nan",
    "",
    "x",
    "1.5",
    " 2",
    "+2",
    "0x2",
    "2\n",
];
const REALS: &[&str] = &[
    "0",
    "-0",
    "-1",
    "1",
    "12.5",
    "1e300",
    "-1e300",
    "1e-300",
    "nan",
    "inf",
    "-inf",
    "",
    "x",
    "1,5",
    "$(echo 1)",
];
const TIMES: &[&str] = &[
    "00:10:00",
    "00:02:00",
    "10:00",
    "600",
    "0",
    "-1",
    "00:00:01",
    "99999999:00:00",
    "99:99:99",
    "8784:00:00",
    "8785:00:00",
    "1:2:3:4",
    "00:-1:00",
    "1e300",
    "nan",
    "",
    "x",
    "$(date)",
    "12:00:00\n#SBATCH --time=1",
];
const SIZES: &[&str] = &[
    "1",
    "1K",
    "512MiB",
    "2G",
    "64G",
    "0",
    "-1",
    "1e300",
    "18446744073709551616",
    "1P",
    "1 G",
    "",
    "x",
    "2GG",
];
/// `run`'s flags: (flag, valid values, odd values).
const RUN_FLAGS: &[(&str, &[&str], &[&str])] = &[
    (
        "--threads",
        &["1", "2"],
        &["0", "3", "1024", "1025", "100000", "-1", "x", ""],
    ),
    ("--ranks", &["1", "2", "3"], &["8", "100", "0", "-1", "4097", "x"]),
    ("--ranks-per-node", &["0", "1", "2"], &["5", "100000", "-1", "x"]),
    (
        "--placement",
        &["rank-order", "centre-distance", "node-grid", "min-cut"],
        &["all", "x", ""],
    ),
    ("--backend", &["auto", "serial", "local"], &["mpi", "x", ""]),
    ("--bind", &["none"], &["cores", "x"]),
    ("--max-memory", &["2G", "512MiB"], SIZES),
    (
        "--min-particles-per-rank",
        &["16", "1"],
        &["0", "100000", "-1", "18446744073709551616"],
    ),
    ("--max-wall", &["00:10:00", "600"], TIMES),
    (
        "--checkpoint-every-minutes",
        &["0.0001", "10"],
        &["0", "-1", "nan", "inf", "1e300", "1e-300", "x", ""],
    ),
    ("--interactions", &["gather", "pairs"], &["x", ""]),
    ("--neighbours", &["lists", "cells"], &["x", ""]),
    ("--restart", &[], &[]),
    ("--topology", &[], &[]),
    (
        "--set",
        &[
            "time.t_end=0.001",
            "physics.delta=0.2",
            "output.format=\"none\"",
            "balance.check_every=1",
            "discretisation.dx=0.008",
            "checkpoint.every_steps=2",
        ],
        CLI_SETS,
    ),
    (
        "--set",
        &["output.interval=0.0001", "probe[1].interval=0"],
        CLI_SETS,
    ),
];

/// Output paths, relative to the case's working directory so that nothing is written
/// outside it (`..` is the case's own directory).
const OUT_PATHS: &[&str] = &[
    "out",
    "out/sub/dir",
    "o u t",
    "out\nx",
    "out'q'\"",
    "$(touch PWNED)",
    "`touch PWNED`",
    "-out",
    "",
    ".",
    "..",
    "out/../out2",
    "é∞",
    "out/",
    "a*b?[c]",
];
/// Hostile strings for names, partitions, accounts, fields.
const HOSTILE: &[&str] = &[
    "",
    " ",
    "x",
    "a b",
    "a\nb",
    "debug\ntouch PWNED",
    "$(touch PWNED)",
    "`touch PWNED`",
    "x\"; touch PWNED; echo \"",
    "x'; touch PWNED; echo '",
    "../../x",
    "a,b",
    ",",
    "-",
    "--help",
    "#SBATCH --time=1",
    "x\r#SBATCH --time=1",
    "é∞",
    "${HOME}",
    "*",
    "debug\t",
    "LONG",
    "VERYLONG",
];

/// A hostile string (`LONG`: 129 characters, one over the Slurm name limit; `VERYLONG`: 5000).
fn hostile(rng: &mut Rng) -> String {
    match pick(rng, HOSTILE) {
        "LONG" => "a".repeat(129),
        "VERYLONG" => "x,".repeat(2500),
        v => s(v),
    }
}

/// A path that is read, never written (absolute ones allowed).
fn input_path(rng: &mut Rng, fx: &Fixtures) -> String {
    match rng.below(12) {
        0 => s("nosuch.toml"),
        1 => s("/dev/zero"),
        2 => s("/dev/null"),
        3 => s("/etc/passwd"),
        4 => s("/"),
        5 => s("."),
        6 => s(""),
        7 => s("-"),
        8 => s("/proc/self/status"),
        9 => p(&fx.empty),
        10 => p(&fx.r1.join("summary.json")),
        _ => p(&fx.topo[rng.below(fx.topo.len())]),
    }
}

/// A run directory for `model` and `report` (read only).
fn run_dir(rng: &mut Rng, fx: &Fixtures) -> String {
    match rng.below(10) {
        0..=2 => p(&fx.r1),
        3..=5 => p(&fx.r2),
        6 | 7 => p(&fx.damaged[rng.below(fx.damaged.len())]),
        _ => input_path(rng, fx),
    }
}

fn scene_arg(rng: &mut Rng, fx: &Fixtures) -> String {
    match rng.below(10) {
        0..=6 => p(&fx.dam),
        7 | 8 => p(&fx.hydro),
        _ => input_path(rng, fx),
    }
}

/// Add `flag value` (`value` drawn from `values`).
fn flag(args: &mut Vec<String>, rng: &mut Rng, flag: &str, values: &[&str]) {
    args.push(s(flag));
    args.push(s(pick(rng, values)));
}

/// Now and then something no command takes: an unknown flag, a flag without its value, a
/// stray word.
fn junk(args: &mut Vec<String>, rng: &mut Rng) {
    match rng.below(24) {
        0 => args.push(s("--nosuch")),
        1 => args.push(s("--")),
        2 => args.push(hostile(rng)),
        _ => {}
    }
}

fn cli_case(rng: &mut Rng, fx: &Fixtures) -> Case {
    let cmd = pick(
        rng,
        &[
            "run", "run", "run", "run", "run", "run", "check", "check", "plan", "plan", "model", "model",
            "bench", "bench", "validate", "validate", "topology", "report", "report",
        ],
    );
    let mut a: Vec<String> = vec![s(cmd)];
    match cmd {
        "run" => run_args(&mut a, rng, fx),
        "check" => check_args(&mut a, rng, fx),
        "plan" => plan_args(&mut a, rng, fx),
        "model" => model_args(&mut a, rng, fx),
        "bench" => bench_args(&mut a, rng, fx),
        "validate" => validate_args(&mut a, rng),
        "topology" => topology_args(&mut a, rng),
        _ => report_args(&mut a, rng, fx),
    }
    Case::new(Family::Cli, a)
}

/// Arguments of a fuzzed `hsph run` after the command: a scene, output flags, up to four run
/// flags (each odd one time in three) and junk.
fn run_args(a: &mut Vec<String>, rng: &mut Rng, fx: &Fixtures) {
    // each flag odd one time in three, so that most runs get to their steps
    a.push(if rng.below(12) == 0 {
        input_path(rng, fx)
    } else {
        p(&fx.dam)
    });
    if rng.below(2) == 0 {
        a.push(s("-q"));
    }
    if rng.below(4) != 0 {
        a.push(s("--force"));
    }
    a.extend([
        s("--out"),
        s(if rng.below(6) == 0 {
            pick(rng, OUT_PATHS)
        } else {
            "out"
        }),
    ]);
    for _ in 0..rng.below(5) {
        let (f, good, bad) = RUN_FLAGS[rng.below(RUN_FLAGS.len())];
        let odd = rng.below(3) == 0;
        match f {
            "--restart" if odd => {
                let r = match rng.below(5) {
                    0 => s("nosuch"),
                    1 => p(&fx.dam),
                    2 => s("."),
                    3 => s(".."),
                    _ => s("/dev/null"),
                };
                a.extend([s(f), r]);
            }
            "--topology" => {
                let t = if odd { 1 + rng.below(fx.topo.len() - 1) } else { 0 };
                a.extend([s(f), p(&fx.topo[t])]);
            }
            "--restart" => {}
            _ => a.extend([s(f), s(pick(rng, if odd { bad } else { good }))]),
        }
    }
    junk(a, rng);
    a.extend([s("--set"), s("time.max_steps=5")]);
}

/// Arguments of a fuzzed `hsph check`.
fn check_args(a: &mut Vec<String>, rng: &mut Rng, fx: &Fixtures) {
    a.push(scene_arg(rng, fx));
    for _ in 0..rng.below(4) {
        match rng.below(3) {
            0 => flag(a, rng, "--ranks", COUNTS),
            1 => flag(a, rng, "--max-memory", SIZES),
            _ => flag(a, rng, "--set", CLI_SETS),
        }
    }
    junk(a, rng);
}

/// Arguments of a fuzzed `hsph plan`.
fn plan_args(a: &mut Vec<String>, rng: &mut Rng, fx: &Fixtures) {
    a.push(scene_arg(rng, fx));
    if rng.below(8) != 0 {
        flag(a, rng, "--ranks", COUNTS);
    }
    for _ in 0..rng.below(4) {
        match rng.below(5) {
            0 => flag(a, rng, "--ranks-per-node", COUNTS),
            1 => a.extend([s("--topology"), input_path(rng, fx)]),
            2 => flag(
                a,
                rng,
                "--placement",
                &[
                    "all",
                    "rank-order",
                    "centre-distance",
                    "node-grid",
                    "min-cut",
                    "x",
                ],
            ),
            3 => flag(a, rng, "--out", OUT_PATHS),
            _ => flag(a, rng, "--set", CLI_SETS),
        }
    }
    junk(a, rng);
}

/// Arguments of a fuzzed `hsph model`.
fn model_args(a: &mut Vec<String>, rng: &mut Rng, fx: &Fixtures) {
    if rng.below(4) != 0 {
        a.push(scene_arg(rng, fx));
    }
    if rng.below(8) != 0 {
        a.extend([s("--one"), run_dir(rng, fx)]);
    }
    if rng.below(8) != 0 {
        a.push(s("--many"));
        for _ in 0..1 + rng.below(2) {
            a.push(run_dir(rng, fx));
        }
    }
    for _ in 0..rng.below(5) {
        match rng.below(7) {
            0 => flag(a, rng, "--ranks", COUNTS),
            1 => flag(a, rng, "--ranks-per-node", COUNTS),
            2 => flag(a, rng, "--cores", COUNTS),
            3 => flag(a, rng, "--bandwidth", REALS),
            4 => flag(a, rng, "--latency", REALS),
            5 => a.extend([s("--check"), run_dir(rng, fx)]),
            _ => flag(a, rng, "--set", CLI_SETS),
        }
    }
    junk(a, rng);
}

/// Arguments of a fuzzed `hsph bench`: at most 3 timed steps of one repetition, or values
/// that are refused.
fn bench_args(a: &mut Vec<String>, rng: &mut Rng, fx: &Fixtures) {
    // at most 3 timed steps of one repetition, or values that are refused
    a.push(if rng.below(6) == 0 {
        input_path(rng, fx)
    } else {
        p(&fx.dam)
    });
    flag(
        a,
        rng,
        "--steps",
        &["1", "2", "3", "0", "-1", "x", "1000001", "1e300", ""],
    );
    flag(a, rng, "--repeat", &["1", "1", "0", "-1", "1001", "x", ""]);
    if rng.below(2) == 0 {
        flag(
            a,
            rng,
            "--threads",
            &[
                "1", "2", "1,2", "0", "1,,2", "", "1025", "x", "100000", ",", "2,1", "-1",
            ],
        );
    }
    for _ in 0..rng.below(3) {
        match rng.below(3) {
            0 => flag(a, rng, "--interactions", &["gather", "pairs", "x"]),
            1 => flag(a, rng, "--neighbours", &["lists", "cells", "x"]),
            _ => flag(a, rng, "--set", CLI_SETS),
        }
    }
    junk(a, rng);
}

/// Arguments of a fuzzed `hsph topology`.
fn topology_args(a: &mut Vec<String>, rng: &mut Rng) {
    for _ in 0..rng.below(3) {
        let f = pick(rng, &["--ranks", "--threads"]);
        flag(a, rng, f, COUNTS);
    }
    junk(a, rng);
}

/// Arguments of a fuzzed `hsph report`: always an output directory of the case's own.
fn report_args(a: &mut Vec<String>, rng: &mut Rng, fx: &Fixtures) {
    // report: always an output directory of the case's own
    for _ in 0..1 + rng.below(3) {
        a.push(run_dir(rng, fx));
    }
    if rng.below(3) == 0 {
        a.push(s("--compare"));
    }
    let out = loop {
        let o = pick(rng, OUT_PATHS);
        if !o.is_empty() {
            break o;
        }
    };
    a.extend([s("--out"), s(out)]);
    if rng.below(2) == 0 {
        a.push(s("--field"));
        a.push(match rng.below(3) {
            0 => s(pick(rng, &["eps_p", "p", "rho", "vx", "id", "e"])),
            _ => hostile(rng),
        });
    }
    junk(a, rng);
}

/// Every odd value of [`RUN_FLAGS`] once in an otherwise valid run, and thread and rank
/// counts that are each within their limit but large together.
fn run_flag_sweep(fx: &Fixtures) -> Vec<Case> {
    let base = |extra: &[&str]| {
        let mut a = vec![s("run"), p(&fx.dam)];
        a.extend(["-q", "--force", "--out", "out", "--set", "output.format=\"none\""].map(String::from));
        a.extend(extra.iter().map(|e| s(e)));
        a.extend(["--set", "time.max_steps=5"].map(String::from));
        Case::new(Family::Cli, a)
    };
    let mut out = Vec::new();
    for (f, _, bad) in RUN_FLAGS {
        for v in *bad {
            out.push(base(&[f, v]));
        }
    }
    for pair in [["2", "1024"], ["8", "1000"], ["100", "80"]] {
        out.push(base(&["--ranks", pair[0], "--threads", pair[1]]));
    }
    out
}

/// `validate` always with at least one bad argument, so that no mix starts its (long) runs.
fn validate_args(a: &mut Vec<String>, rng: &mut Rng) {
    let mut bad = false;
    for _ in 0..rng.below(3) {
        let c = pick(
            rng,
            &["poiseuille", "couette", "hydrostatic", "cavity", "nosuch", ""],
        );
        bad |= c == "nosuch" || c.is_empty();
        a.push(s(c));
    }
    // each flag: (name, good values, bad values)
    let flags: &[(&str, &[&str], &[&str])] = &[
        (
            "--resolutions",
            &["10", "10,20", "8"],
            &["0", "1000000000", "x", "", "-1", "1,,2", "4097"],
        ),
        (
            "--variants",
            &["cubic_spline-h1.2-dummy-none"],
            &["nosuch", "", ","],
        ),
        ("--jobs", &["1", "2"], &["0", "-1", "100000", "257", "x"]),
        ("--threads", &["1"], &["0", "100000", "1025", "x"]),
        (
            "--set",
            &["time.t_end=0.1"],
            &[
                "nosuch=1",
                "time.t_end=-1",
                "=",
                "discretisation.dx=nan",
                "time.t_end=\"x\"",
                "physics.delta=1e300",
            ],
        ),
        ("--target", &["0.005"], &["-1", "nan", "x", "inf"]),
        ("--map", &["walls", "cfl,lattice"], &["nosuch", "", ","]),
    ];
    let mut used = Vec::new();
    for _ in 0..rng.below(4) {
        let (f, good, wrong) = flags[rng.below(flags.len())];
        if rng.below(3) == 0 {
            a.extend([s(f), s(pick(rng, wrong))]);
            bad = true;
        } else {
            a.extend([s(f), s(pick(rng, good))]);
        }
        used.push(f);
    }
    match rng.below(4) {
        0 => a.push(s("--sweep")),
        1 => a.push(s("--map")),
        2 => a.extend([
            s("--write"),
            s(pick(rng, &["best.toml", "", "$(touch PWNED).toml", "a\nb.toml"])),
        ]),
        _ => {}
    }
    if !bad {
        let (f, _, wrong) = flags[rng.below(flags.len())];
        a.extend([s(f), s(pick(rng, wrong))]);
    }
    a.extend([s("--out"), s(pick(rng, &["v", "v w", "$(touch PWNED)", ""]))]);
}

// ---------------------------------------------------------------------------------------------
// Family `set`: odd values of the real keys of inputs/dam_break_2d.toml
// ---------------------------------------------------------------------------------------------

/// The scene's keys with a valid value.
const SET_KEYS: &[(&str, &str)] = &[
    ("time.t_end", "0.3"),
    ("time.cfl", "0.2"),
    ("time.dt", "0.0001"),
    ("time.max_steps", "5"),
    ("output.interval", "0.02"),
    ("output.format", "\"vtk\""),
    ("output.fields", "[\"velocity\", \"density\"]"),
    ("output.gather_limit", "2000000"),
    ("probe[1].interval", "0.0005"),
    ("probe[1].window", "0.002"),
    ("probe[1].diameter", "0.01"),
    ("probe[1].point", "[0.584, 0.01]"),
    ("probe[1].normal", "[-1.0, 0.0]"),
    ("probe[0].axis", "0"),
    ("probe[0].link", "1.5"),
    ("probe[2].about", "[0.584, 0.0]"),
    ("probe[2].window", "0.001"),
    ("physics.body_force", "[0.0, -9.81]"),
    ("physics.delta", "0.1"),
    ("physics.artificial_viscosity", "0.02"),
    ("physics.laminar_viscosity", "0.000001"),
    ("material[0].c0", "25.0"),
    ("material[0].rho0", "1000.0"),
    ("material[0].gamma", "7.0"),
    ("discretisation.dx", "0.006"),
    ("discretisation.h_over_dx", "1.3"),
    ("domain.min", "[-0.02, -0.02]"),
    ("domain.max", "[0.604, 0.7]"),
    ("domain.max_removed_fraction", "0.01"),
    ("fluid[0].min", "[0.0, 0.0]"),
    ("fluid[0].max", "[0.146, 0.292]"),
    ("fluid[0].velocity", "[0.0, 0.0]"),
    ("wall[0].layers", "3"),
    ("wall[0].max", "[0.584, 0.68]"),
    ("checkpoint.every_steps", "5"),
    ("checkpoint.every", "0.001"),
    ("checkpoint.keep", "2"),
    ("limits.density_ratio", "[0.5, 2.0]"),
    ("limits.speed_over_c0", "1.0"),
    ("balance.check_every", "20"),
    ("balance.threshold", "1.1"),
    ("balance.max_count", "1.25"),
];

/// Values of another type than a number, for any key.
const OTHER_TYPES: &[&str] = &[
    "\"abc\"",
    "\"\"",
    "true",
    "[]",
    "[1.0]",
    "[1.0, 2.0, 3.0]",
    "[nan, nan]",
    "[1e300, -1e300]",
    "[0.0, -1e308]",
    "{ a = 1 }",
    "",
    "x",
    "\"a\\nb\"",
    "\"$(touch PWNED)\"",
    "1\n2",
    "[[1.0, 2.0]]",
];

/// An odd number in place of `v` (integers stay integers when `v` is one).
fn number_mutant(rng: &mut Rng, v: &str) -> String {
    let fixed = [
        "0",
        "-0.0",
        "-1",
        "1e300",
        "-1e300",
        "1e-300",
        "nan",
        "inf",
        "-inf",
        "18446744073709551616",
        "9223372036854775807",
        "-9223372036854775808",
        "1e-9",
        "0.5",
    ];
    if rng.below(3) == 0 {
        if let Ok(i) = v.parse::<i64>() {
            return [-i, i.saturating_mul(1_000_000), i + 1][rng.below(3)].to_string();
        }
        if let Ok(x) = v.parse::<f64>() {
            let r = [-x, 2.0 * x, 0.5 * x, x * 1e6, x * 1e-6, x + 1.0][rng.below(6)];
            return format!("{r:?}");
        }
    }
    s(pick(rng, &fixed))
}

/// A value near `valid` (numbers scaled by 0.5 to 2, one element of an array so), as a user
/// tuning the scene would give: these mostly run.
fn plausible(rng: &mut Rng, key: &str, valid: &str) -> String {
    // keys whose valid range starts at their value (or a body must stay inside): grown only
    let grow = [
        "domain.",
        "balance.threshold",
        "balance.max_count",
        "probe[0].link",
        "limits.",
        "material[0].c0",
    ]
    .iter()
    .any(|g| key.starts_with(g));
    let f = if grow {
        [1.25, 2.0][rng.below(2)]
    } else {
        [0.5, 0.8, 1.25, 2.0][rng.below(4)]
    };
    let scale = |x: &str| -> String {
        if let Ok(i) = x.parse::<i64>() {
            ((i as f64 * f).round() as i64).max(1).to_string()
        } else if let Ok(v) = x.parse::<f64>() {
            format!("{:?}", v * f)
        } else {
            x.to_string()
        }
    };
    if valid.starts_with('[') {
        let mut items: Vec<String> = valid
            .trim_matches(|c| c == '[' || c == ']')
            .split(',')
            .map(|i| i.trim().to_string())
            .collect();
        let k = rng.below(items.len());
        items[k] = scale(&items[k]);
        return format!("[{}]", items.join(", "));
    }
    scale(valid)
}

fn set_value(rng: &mut Rng, key: &str, valid: &str) -> String {
    if rng.below(2) == 0 {
        return plausible(rng, key, valid);
    }
    if valid.starts_with('[') && rng.below(2) == 0 {
        let items: Vec<String> = valid
            .trim_matches(|c| c == '[' || c == ']')
            .split(',')
            .map(|i| i.trim().to_string())
            .collect();
        return match rng.below(4) {
            0 => format!("[{}]", items[..items.len() - 1].join(", ")),
            1 => format!("[{}, {}]", items.join(", "), items[0]),
            _ => {
                let mut it = items.clone();
                let k = rng.below(it.len());
                it[k] = number_mutant(rng, &items[k]);
                format!("[{}]", it.join(", "))
            }
        };
    }
    if rng.below(5) == 0 {
        return s(pick(rng, OTHER_TYPES));
    }
    number_mutant(rng, valid)
}

/// `--set` syntax itself.
const SET_SYNTAX: &[&str] = &[
    "time.t_end",
    "=1",
    "time..t_end=1",
    "probe[99999999999].interval=1",
    "probe[1000000].interval=1",
    "probe[-1].interval=1",
    "fluid[18446744073709551616].min=[0,0]",
    "a.b.c.d.e=1",
    "time.t_end=1=2",
    " time.t_end = 0.001 ",
    "time.t_end==0.001",
    "[time]\nt_end=1",
    "time.t_end=0.001\nmax_steps=0",
    "time=1",
    "time={t_end=0.001}",
    "probe=[]",
    "fluid=[]",
    "material[0]={}",
    "discretisation.dx.x=1",
    "time.t_end[0]=1",
];

/// The extreme values every key of [`SET_KEYS`] gets once, through a run of 5 steps (an
/// array gets the value in each component).
const SWEEP: &[&str] = &["0", "-1", "1e300", "-1e300", "1e-300", "nan", "inf"];

/// `run` with `key` set to an extreme `value` (the sweep over keys × [`SWEEP`]).
fn sweep_case(fx: &Fixtures, key: &str, valid: &str, value: &str) -> Case {
    let v = if valid.starts_with('[') {
        let n = valid.split(',').count();
        format!("[{}]", vec![value; n].join(", "))
    } else {
        s(value)
    };
    let mut a = vec![s("run"), p(&fx.dam)];
    a.extend(
        [
            "-q",
            "--force",
            "--out",
            "out",
            "--max-memory",
            "2G",
            "--set",
            "output.format=\"none\"",
        ]
        .map(String::from),
    );
    if key == "time.max_steps" {
        a.extend(["--set", "time.t_end=0.003"].map(String::from));
        a.extend([s("--set"), format!("{key}={v}")]);
    } else {
        a.extend([s("--set"), format!("{key}={v}")]);
        a.extend(["--set", "time.max_steps=5"].map(String::from));
    }
    Case::new(Family::Set, a)
}

fn set_case(rng: &mut Rng, fx: &Fixtures) -> Case {
    let mut sets: Vec<String> = Vec::new();
    let mut bounds_own_steps = false;
    // half the cases as a user tuning the scene (values near the valid ones, which mostly
    // run), half hostile (odd values and syntax)
    let mild = rng.below(2) == 0;
    for _ in 0..1 + rng.below(3) {
        if !mild && rng.below(10) == 0 {
            sets.push(s(pick(rng, SET_SYNTAX)));
            continue;
        }
        let (key, valid) = SET_KEYS[rng.below(SET_KEYS.len())];
        if key == "time.max_steps" {
            // alone: the run is then bounded by a short end instead
            sets.clear();
            sets.push(format!("{key}={}", set_value(rng, key, valid)));
            bounds_own_steps = true;
            break;
        }
        let v = if mild {
            plausible(rng, key, valid)
        } else {
            set_value(rng, key, valid)
        };
        sets.push(format!("{key}={v}"));
    }
    let dam = p(&fx.dam);
    // mild values through runs; hostile ones through every command that reads a scene
    let cmd = if mild {
        "run"
    } else {
        pick(
            rng,
            &[
                "run", "run", "run", "run", "check", "check", "check", "plan", "bench", "model",
            ],
        )
    };
    let mut a: Vec<String> = vec![s(cmd), dam];
    match cmd {
        "run" => {
            a.extend(["-q", "--force", "--out", "out", "--max-memory", "2G"].map(String::from));
            if rng.below(2) == 0 {
                a.extend(["--set", "output.format=\"none\""].map(String::from));
            }
            if rng.below(6) == 0 {
                a.extend(["--ranks", "2", "--threads", "1"].map(String::from));
            }
        }
        "plan" => a.extend(["--ranks", "2"].map(String::from)),
        "bench" => a.extend(["--steps", "1", "--repeat", "1", "--threads", "1"].map(String::from)),
        "model" => {
            a.extend([
                s("--one"),
                p(&fx.r1),
                s("--many"),
                p(&fx.r2),
                s("--ranks"),
                s("4"),
            ]);
        }
        _ => {}
    }
    if cmd == "run" && bounds_own_steps {
        a.extend(["--set", "time.t_end=0.003"].map(String::from));
    }
    for v in sets {
        a.extend([s("--set"), v]);
    }
    if cmd == "run" && !bounds_own_steps {
        a.extend(["--set", "time.max_steps=5"].map(String::from));
    }
    Case::new(Family::Set, a)
}

// ---------------------------------------------------------------------------------------------
// Family `checkpoint`: damaged manifests and parts through `run --restart`
// ---------------------------------------------------------------------------------------------

/// A JSON value written verbatim (numbers serde_json cannot hold: NaN, 1e999, …).
fn raw(text: &str) -> Value {
    Value::String(format!("@@RAW@@{text}@@"))
}

/// `v` as pretty JSON with the [`raw`] values put in verbatim.
fn raw_json(v: &Value) -> String {
    let mut t = serde_json::to_string_pretty(v).unwrap();
    while let Some(at) = t.find("\"@@RAW@@") {
        let end = at + t[at..].find("@@\"").unwrap() + 3;
        let inner = t[at + 8..end - 3].to_string();
        t.replace_range(at..end, &inner);
    }
    t
}

/// A JSON pointer reached by a random walk from the root.
fn random_pointer(v: &Value, rng: &mut Rng) -> String {
    let mut ptr = String::new();
    let mut node = v;
    loop {
        let children: Vec<(String, &Value)> = match node {
            Value::Object(m) => m
                .iter()
                .map(|(k, c)| (k.replace('~', "~0").replace('/', "~1"), c))
                .collect(),
            Value::Array(a) => a.iter().enumerate().map(|(i, c)| (i.to_string(), c)).collect(),
            _ => break,
        };
        if children.is_empty() || (!ptr.is_empty() && rng.below(4) == 0) {
            break;
        }
        let (k, c) = &children[rng.below(children.len())];
        ptr = format!("{ptr}/{k}");
        node = c;
    }
    ptr
}

/// Pointers into a manifest that matter most: numbers the restart trusts, part names,
/// counts, sizes, the scene.
const MANIFEST_TARGETS: &[&str] = &[
    "/t",
    "/dt",
    "/step",
    "/ranks",
    "/dimension",
    "/format",
    "/parts",
    "/parts/0",
    "/parts/0/file",
    "/parts/0/file",
    "/parts/0/particles",
    "/parts/0/bytes",
    "/parts/0/fnv1a64",
    "/parts/1/file",
    "/parts/1/particles",
    "/parts/1/bytes",
    "/scene",
    "/scene",
    "/scene",
    "/run/n_fluid",
    "/run/next_out",
    "/run/next_checkpoint",
    "/run/series",
    "/run/snapshots",
    "/run/segments",
    "/run/removed",
    "/run/probes/clocks/1/Every/interval",
    "/run/probes/clocks/1/Every/next",
    "/run/probes/windows",
    "/run/tracker",
    "/run/wall_s",
    "/hsph_version",
];

const PART_NAMES: &[&str] = &[
    "../../etc/passwd",
    "/etc/passwd",
    "../../../../../../../../etc/passwd",
    "part-00000.bin/..",
    "",
    "part-00001.bin",
    "part-00002.bin",
    "part-99999.bin",
    "part-0.bin",
    "part-00000.bin ",
    ".",
    "..",
    "part-00000.bin\u{0}",
    "manifest.json",
    "part-00000.tmp",
    "PART-00000.BIN",
    "part-12345678901.bin",
    "../step-0000000030/part-00000.bin",
    "/dev/zero",
];

/// Replace the node at `ptr` (or delete it); a description of the change.
fn mutate_json_at(root: &mut Value, ptr: &str, rng: &mut Rng) -> String {
    if !ptr.is_empty() && rng.below(7) == 0 {
        let (parent, last) = ptr.rsplit_once('/').unwrap();
        match root.pointer_mut(parent) {
            Some(Value::Object(m)) => {
                m.remove(&last.replace("~1", "/").replace("~0", "~"));
            }
            Some(Value::Array(a)) => {
                a.remove(last.parse::<usize>().unwrap());
            }
            _ => {}
        }
        return format!("{ptr}: deleted");
    }
    let Some(node) = root.pointer_mut(ptr) else {
        return format!("{ptr}: absent, unchanged");
    };
    let new: Value = match &*node {
        Value::Number(n) => number_node(n, rng),
        Value::String(t) => string_node(t, ptr, rng),
        Value::Array(a) => array_node(a, rng),
        Value::Object(m) => object_node(m, rng),
        Value::Bool(_) | Value::Null => json!(pick(rng, &["1", "x"])),
    };
    set_node(node, ptr, new)
}

/// A mutant of a JSON number `n`: extremes, non-numbers, neighbours.
fn number_node(n: &serde_json::Number, rng: &mut Rng) -> Value {
    let x = n.as_f64().unwrap();
    match rng.below(22) {
        0 => json!(-1e300),
        1 => json!(1e300),
        2 => json!("NaN"),
        3 => raw("NaN"),
        4 => raw("1e999"),
        5 => raw("-1e999"),
        6 => json!(0),
        7 => json!(-1),
        8 => json!(u64::MAX),
        9 => raw("18446744073709551616"),
        10 => json!(1e19),
        11 => json!(0.5),
        12 => Value::Null,
        13 => json!("x"),
        14 => json!(true),
        15 => json!([]),
        16 => json!(x + 1.0),
        17 => json!(x - 1.0),
        18 => n.as_u64().map_or(json!(x * 2.0), |u| json!(u.wrapping_add(1))),
        19 => n.as_u64().map_or(json!(-x), |u| json!(u.wrapping_sub(1))),
        20 => json!(x * 1e6),
        _ => json!(1e-300),
    }
}

/// A mutant of the string `t` at `ptr`: a part name for a part's file, a mutated scene text,
/// a damaged checksum, else an odd word.
fn string_node(t: &str, ptr: &str, rng: &mut Rng) -> Value {
    if ptr.ends_with("/file") {
        json!(pick(rng, PART_NAMES))
    } else if ptr == "/scene" {
        if rng.below(5) == 0 {
            json!("")
        } else {
            let mut m = t.to_string();
            for _ in 0..1 + rng.below(2) {
                m = mutate(&m, rng);
            }
            json!(m)
        }
    } else if ptr.ends_with("fnv1a64") {
        let mut c: Vec<char> = t.chars().collect();
        match rng.below(4) {
            0 if !c.is_empty() => {
                let k = rng.below(c.len());
                c[k] = if c[k] == '0' { '1' } else { '0' };
                json!(c.into_iter().collect::<String>())
            }
            1 => json!(""),
            2 => json!("zz"),
            _ => json!("0".repeat(100)),
        }
    } else {
        json!(pick(rng, &["", "x", "../x", "Every", "Output", "\u{0}", "NaN"]))
    }
}

/// A mutant of the array `a`: emptied, an element doubled, popped, pushed, 100 000 copies.
fn array_node(a: &[Value], rng: &mut Rng) -> Value {
    let mut a = a.to_vec();
    match rng.below(6) {
        0 => a.clear(),
        1 if !a.is_empty() => {
            let k = rng.below(a.len());
            let e = a[k].clone();
            a.insert(k, e);
        }
        2 => {
            a.pop();
        }
        3 => a.push(json!("x")),
        4 if !a.is_empty() => {
            let e = a[0].clone();
            a = vec![e; 100_000];
        }
        _ => a.reverse(),
    }
    Value::Array(a)
}

/// A mutant of the object `m`: a key removed, an unknown key added, or an array or null
/// in its place.
fn object_node(m: &serde_json::Map<String, Value>, rng: &mut Rng) -> Value {
    let mut m = m.clone();
    match rng.below(4) {
        0 if !m.is_empty() => {
            let k = m.keys().nth(rng.below(m.len())).unwrap().clone();
            m.remove(&k);
        }
        1 => {
            m.insert(s("nosuch"), json!(1));
        }
        2 => return json!([]),
        _ => return Value::Null,
    }
    Value::Object(m)
}

fn set_node(node: &mut Value, ptr: &str, new: Value) -> String {
    let mut shown = new.to_string();
    if shown.len() > 160 {
        let mut cut = 160;
        while !shown.is_char_boundary(cut) {
            cut -= 1;
        }
        shown = format!("{}… ({} chars)", &shown[..cut], shown.len());
    }
    *node = new;
    format!("{ptr} = {shown}")
}

/// Restart-time `--set` values: the keys a restart may change, with odd values, and one it
/// may not.
const RESTART_SETS: &[&str] = &[
    "output.interval=1e-300",
    "output.interval=0",
    "output.interval=-1",
    "output.format=\"x\"",
    "output.format=\"none\"",
    "checkpoint.every_steps=0",
    "checkpoint.every_steps=1",
    "checkpoint.every_steps=18446744073709551616",
    "checkpoint.keep=0",
    "checkpoint.keep=-1",
    "checkpoint.keep=1e300",
    "checkpoint.every=1e-300",
    "checkpoint.every=nan",
    "time.t_end=nan",
    "time.t_end=-1",
    "time.t_end=0.001",
    "time.max_steps=1",
    "physics.delta=0.2",
    "discretisation.dx=0.005",
    "probe[1].interval=1e-300",
];

/// Restart-time `--set` values a user would give.
const RESTART_MILD: &[&str] = &[
    "output.interval=0.0005",
    "output.format=\"none\"",
    "output.format=\"vtk\"",
    "checkpoint.every_steps=2",
    "checkpoint.keep=1",
    "checkpoint.every=0.0001",
    "time.t_end=0.0021",
];

fn checkpoint_case(rng: &mut Rng, fx: &Fixtures) -> Case {
    let ck = &fx.cks[if rng.below(10) < 7 { 0 } else { 1 }];
    let step = ck.step.clone();
    let mut extra: Vec<String> = Vec::new();
    let (change, note) = match rng.below(100) {
        // mild: the run state nudged, or a restart with allowed changes and another layout
        0..=44 => mild_change(rng, ck, step, &mut extra),
        45..=69 => {
            let mut v: Value = serde_json::from_str(&ck.manifest).unwrap();
            let mut notes = Vec::new();
            for _ in 0..1 + rng.below(2) {
                let ptr = if rng.below(2) == 0 {
                    s(pick(rng, MANIFEST_TARGETS))
                } else {
                    random_pointer(&v, rng)
                };
                notes.push(mutate_json_at(&mut v, &ptr, rng));
            }
            let text = raw_json(&v);
            (CkChange::Manifest { step, text }, notes.join("; "))
        }
        d @ 70..=77 => broken_manifest(rng, ck, step, d >= 76),
        78 => (
            CkChange::DropManifest { step },
            format!("newest manifest removed ({} used)", ck.older),
        ),
        79..=94 => part_change(rng, ck, step),
        _ => {
            extra.extend([s("--set"), s(pick(rng, RESTART_SETS))]);
            (CkChange::None, s("checkpoint unchanged"))
        }
    };
    let a = restart_args(rng, ck, extra);
    Case {
        prep: Prep::Checkpoint {
            from: ck.run.clone(),
            change,
        },
        note: format!("restart of a copy of {} ({}): {note}", ck.run.display(), ck.step),
        ..Case::new(Family::Checkpoint, a)
    }
}

/// A mild change: an allowed `--set` on an unchanged checkpoint, or one number of the
/// manifest's run state nudged (anything else there mutated).
fn mild_change(rng: &mut Rng, ck: &Checkpoint, step: String, extra: &mut Vec<String>) -> (CkChange, String) {
    if rng.below(2) == 0 {
        extra.extend([s("--set"), s(pick(rng, RESTART_MILD))]);
        return (CkChange::None, s("checkpoint unchanged"));
    }
    let mut v: Value = serde_json::from_str(&ck.manifest).unwrap();
    let run = v.pointer("/run").unwrap().clone();
    let ptr = format!("/run{}", random_pointer(&run, rng));
    let note = match v.pointer_mut(&ptr) {
        Some(n @ Value::Number(_)) => {
            let x = n.as_f64().unwrap();
            let new = if n.is_u64() {
                json!(n.as_u64().unwrap().saturating_sub(rng.below(2) as u64))
            } else {
                json!(x * (1.0 + 1e-3 * rng.range(-1.0, 1.0)))
            };
            set_node(n, &ptr, new)
        }
        _ => mutate_json_at(&mut v, &ptr, rng),
    };
    let text = raw_json(&v);
    (CkChange::Manifest { step, text }, note)
}

/// The manifest's text broken: cut or one byte replaced, or (`whole`) replaced by something
/// that is not a manifest (empty, `{}`, `null`, deep nesting, 17 MiB of spaces).
fn broken_manifest(rng: &mut Rng, ck: &Checkpoint, step: String, whole: bool) -> (CkChange, String) {
    if whole {
        let (text, note) = match rng.below(5) {
            0 => (s(""), "manifest empty"),
            1 => (s("{}"), "manifest {}"),
            2 => (s("null"), "manifest null"),
            3 => ("[".repeat(100_000), "manifest 100 000 nested ["),
            _ => (" ".repeat(17 << 20), "manifest of 17 MiB of spaces"),
        };
        return (CkChange::Manifest { step, text }, s(note));
    }
    let mut text = ck.manifest.clone();
    let note = if rng.below(2) == 0 {
        let mut cut = rng.below(text.len());
        while !text.is_char_boundary(cut) {
            cut -= 1;
        }
        text.truncate(cut);
        format!("manifest cut to {cut} bytes")
    } else {
        let k = rng.below(text.len());
        let mut b = text.into_bytes();
        b[k] = b"{}[]\",:0-e\\ \n9x"[rng.below(15)];
        text = String::from_utf8_lossy(&b).into_owned();
        format!("manifest byte {k} replaced")
    };
    (CkChange::Manifest { step, text }, note)
}

/// One part file of the checkpoint damaged: a byte flipped, cut, grown, removed, a link or a
/// directory in its place.
fn part_change(rng: &mut Rng, ck: &Checkpoint, step: String) -> (CkChange, String) {
    let (file, len) = ck.parts[rng.below(ck.parts.len())].clone();
    let op = match rng.below(9) {
        0..=2 => PartOp::Flip(rng.below(len as usize) as u64, 1 + rng.below(255) as u8),
        3 | 4 => PartOp::Truncate(rng.below(len as usize) as u64),
        5 => PartOp::Append(vec![0xab; 1 + rng.below(64)]),
        6 => PartOp::Remove,
        7 => PartOp::Symlink(pick(rng, &["/dev/zero", "/etc/passwd", "/dev/null"])),
        _ => PartOp::Dir,
    };
    let note = match &op {
        PartOp::Flip(at, m) => format!("{file}: byte {at} xor {m:#04x}"),
        PartOp::Truncate(n) => format!("{file}: cut to {n} bytes"),
        PartOp::Append(b) => format!("{file}: {} bytes appended", b.len()),
        PartOp::Remove => format!("{file}: removed"),
        PartOp::Symlink(t) => format!("{file}: a link to {t}"),
        PartOp::Dir => format!("{file}: a directory"),
    };
    (CkChange::Part { step, file, op }, note)
}

/// The restart's command line: past the checkpoint's end, sometimes a step cap, one of four
/// layouts, then the case's `extra` flags.
fn restart_args(rng: &mut Rng, ck: &Checkpoint, extra: Vec<String>) -> Vec<String> {
    let t_end = CK_T_END + 0.0005;
    let mut a: Vec<String> = vec![
        s("run"),
        s("--restart"),
        s("run"),
        s("-q"),
        s("--set"),
        format!("time.t_end={t_end}"),
    ];
    if rng.below(2) == 0 {
        a.extend([s("--set"), format!("time.max_steps={}", ck.step_n + 5)]);
    }
    match rng.below(6) {
        0 => a.extend(["--ranks", "2", "--threads", "1"].map(String::from)),
        1 => a.extend(["--ranks", "3", "--threads", "1"].map(String::from)),
        2 => a.extend(["--threads", "1"].map(String::from)),
        _ => {}
    }
    a.extend(extra);
    a
}

fn prepare(prep: &Prep, cwd: &Path) {
    let Prep::Checkpoint { from, change } = prep else {
        return;
    };
    let run = cwd.join("run");
    copy_dir(from, &run);
    let ck = |step: &str| run.join("checkpoints").join(step);
    match change {
        CkChange::None => {}
        CkChange::Manifest { step, text } => replace_file(&ck(step).join("manifest.json"), text.as_bytes()),
        CkChange::DropManifest { step } => fs::remove_file(ck(step).join("manifest.json")).unwrap(),
        CkChange::Part { step, file, op } => {
            let path = ck(step).join(file);
            match op {
                PartOp::Flip(at, mask) => {
                    let mut b = fs::read(&path).unwrap();
                    b[*at as usize] ^= mask;
                    replace_file(&path, &b);
                }
                PartOp::Truncate(n) => {
                    let b = fs::read(&path).unwrap();
                    replace_file(&path, &b[..*n as usize]);
                }
                PartOp::Append(extra) => {
                    let mut b = fs::read(&path).unwrap();
                    b.extend_from_slice(extra);
                    replace_file(&path, &b);
                }
                PartOp::Remove => fs::remove_file(&path).unwrap(),
                PartOp::Symlink(target) => {
                    fs::remove_file(&path).unwrap();
                    std::os::unix::fs::symlink(target, &path).unwrap();
                }
                PartOp::Dir => {
                    fs::remove_file(&path).unwrap();
                    fs::create_dir(&path).unwrap();
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Family `jobscript`: hostile values in every field; scripts written must parse and keep
// every #SBATCH line where Slurm reads them
// ---------------------------------------------------------------------------------------------

fn jobscript_case(rng: &mut Rng, fx: &Fixtures) -> Case {
    // up to two fields of each case get an odd value (hostile, edge or nonsense), the others
    // a valid one, so that both refusals and written scripts are common
    let odd_fields: Vec<usize> = (0..rng.below(3)).map(|_| rng.below(13)).collect();
    let odd = |k: usize| odd_fields.contains(&k);
    let scene = jobscript_scene(rng, fx, odd(0));
    let mut a = vec![s("jobscript"), scene];
    jobscript_flags(&mut a, rng, &odd);
    jobscript_account_out(&mut a, rng, &odd);
    let script = jobscript_script(&mut a, rng, odd(11));
    junk(&mut a, rng);
    Case {
        script: Some(script),
        ..Case::new(Family::Jobscript, a)
    }
}

/// The scene argument of a `jobscript` case: an odd path (`odd`), a valid scene in a hostile
/// directory, or the dam break.
fn jobscript_scene(rng: &mut Rng, fx: &Fixtures, odd: bool) -> String {
    if odd {
        match rng.below(3) {
            0 => input_path(rng, fx),
            _ => p(&fx.js_scenes[HOSTILE_DIRS.len() + rng.below(fx.js_scenes.len() - HOSTILE_DIRS.len())]),
        }
    } else if rng.below(4) == 0 {
        // hostile directories, valid names
        p(&fx.js_scenes[rng.below(HOSTILE_DIRS.len())])
    } else {
        p(&fx.dam)
    }
}

/// The flags with a valid and an odd value each (`odd(k)` for flag k; `--mem` is 12, after
/// the fields of the other helpers); the required ones (k ≤ 3) are present unless left out as
/// the odd case, the others a third of the time.
fn jobscript_flags(a: &mut Vec<String>, rng: &mut Rng, odd: &dyn Fn(usize) -> bool) {
    let pairs: [(usize, &str, &[&str], &[&str]); 9] = [
        (1, "--nodes", &["1", "2", "4"], COUNTS),
        (2, "--ranks-per-node", &["1", "2", "24"], COUNTS),
        (
            3,
            "--time",
            &["00:10:00", "12:00:00", "10:00", "3600", "00:02:00"],
            TIMES,
        ),
        (
            4,
            "--threads-per-rank",
            &["1", "2"],
            &["1024", "1025", "0", "x", "-1", ""],
        ),
        (
            5,
            "--signal-before",
            &["60", "10", "120"],
            &["9", "0", "65535", "65536", "-1", "x", "599", "600", "1e300"],
        ),
        (
            6,
            "--placement",
            &["rank-order", "centre-distance", "node-grid", "min-cut"],
            &["all", "x", ""],
        ),
        (7, "--launcher", &["srun", "mpirun"], &["x", "", "srun\nid"]),
        (
            8,
            "--partition",
            &["compute", "compute,debug", "gpu_a100", "a.b+c"],
            &[],
        ),
        (
            12,
            "--mem",
            &["4G", "512M", "2.5GB", "1000000000", "64GiB"],
            &["0", "x", "-1G", "1e300", "100P", "65TiB", "", "4G\nid", "nan"],
        ),
    ];
    for (k, f, good, bad) in pairs {
        let required = k <= 3;
        if odd(k) {
            if required && rng.below(4) == 0 {
                continue; // a required flag left out
            }
            let v = if bad.is_empty() {
                hostile(rng)
            } else {
                s(pick(rng, bad))
            };
            a.extend([s(f), v]);
        } else if required || rng.below(3) == 0 {
            a.extend([s(f), s(pick(rng, good))]);
        }
    }
}

/// `--account` and `--out`, odd (`odd(9)`, `odd(10)`) or valid, each sometimes.
fn jobscript_account_out(a: &mut Vec<String>, rng: &mut Rng, odd: &dyn Fn(usize) -> bool) {
    if odd(9) {
        a.extend([s("--account"), hostile(rng)]);
    } else if rng.below(3) == 0 {
        a.extend([s("--account"), s(pick(rng, &["proj-1", "a_b.c+d", "x"]))]);
    }
    if odd(10) || rng.below(4) == 0 {
        // run directories are quoted, not refused (but for a control character)
        let v = match rng.below(3) {
            0 => hostile(rng),
            1 => s(pick(rng, OUT_PATHS)),
            _ => s(pick(
                rng,
                &[
                    "/tmp/x y",
                    "runs/x\"; touch PWNED; echo \"",
                    "runs/it's 'q'",
                    "runs/`id` ${X:-y} *",
                ],
            )),
        };
        a.extend([s("--out"), v]);
    }
}

/// `--script` (four cases in five): an odd name (`odd`) or `job.sh`; the name given, if any.
fn jobscript_script(a: &mut Vec<String>, rng: &mut Rng, odd: bool) -> Option<String> {
    if rng.below(5) == 0 {
        None
    } else {
        let v = if odd {
            pick(
                rng,
                &[
                    "job $(touch PWNED).sh",
                    "j'o\"b.sh",
                    "sub/job.sh",
                    ".",
                    "",
                    "job\n.sh",
                    "-job.sh",
                    "..",
                ],
            )
        } else {
            "job.sh"
        };
        a.extend([s("--script"), s(v)]);
        Some(s(v))
    }
}

/// The property of a generated script: `bash -n` accepts it and no `#SBATCH` line comes
/// after its first command (Slurm stops reading directives there). `Err` says what failed.
fn check_script(path: &Path, cwd: &Path) -> Result<(), String> {
    let text =
        fs::read_to_string(path).map_err(|e| format!("exit 0 but no script at {}: {e}", path.display()))?;
    let mut first_command = None;
    for (k, line) in text.lines().enumerate() {
        let t = line.trim_start();
        if first_command.is_none() && !t.is_empty() && !t.starts_with('#') {
            first_command = Some(k + 1);
        }
        if t.starts_with("#SBATCH") {
            if let Some(c) = first_command {
                return Err(format!(
                    "line {}: `{line}` comes after the first command (line {c}); Slurm ignores it",
                    k + 1
                ));
            }
            if line != t {
                return Err(format!("line {}: `{line}` is indented; Slurm ignores it", k + 1));
            }
        }
    }
    if !text.lines().any(|l| l.starts_with("#SBATCH --time=")) {
        return Err(s("no #SBATCH --time line"));
    }
    let mut bash = Command::new("bash");
    bash.arg("-n").arg(path);
    let (status, _) = run_bounded(bash, cwd, &cwd.join("../bash.out"), &cwd.join("../bash.err"));
    match status {
        Some(st) if st.success() => Ok(()),
        Some(st) => Err(format!(
            "bash -n {}: {st}: {}",
            path.display(),
            fs::read_to_string(cwd.join("../bash.err")).unwrap_or_default()
        )),
        None => Err(format!("bash -n {} ran over {BOUND:?}", path.display())),
    }
}

// ---------------------------------------------------------------------------------------------
// Running a case
// ---------------------------------------------------------------------------------------------

/// Run `cmd` in `cwd` in a process group of its own, standard output and error to files;
/// its status, or `None` when it ran over [`BOUND`] (the whole group is then killed, so that
/// children of `validate` do not outlive it).
fn run_bounded(mut cmd: Command, cwd: &Path, out: &Path, err: &Path) -> (Option<ExitStatus>, Duration) {
    let mut child = cmd
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(fs::File::create(out).unwrap())
        .stderr(fs::File::create(err).unwrap())
        .process_group(0)
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            return (Some(st), t0.elapsed());
        }
        if t0.elapsed() > BOUND {
            let _ = Command::new("kill")
                .args(["-KILL", "--", &format!("-{}", child.id())])
                .status();
            let _ = child.kill();
            let _ = child.wait();
            return (None, t0.elapsed());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Time spent setting up and removing working directories (ns), for the summary.
static PREP_NS: AtomicUsize = AtomicUsize::new(0);

struct Outcome {
    /// Exit status 0–3, or `None` for a failure.
    code: Option<usize>,
    elapsed: Duration,
    /// A script passed its checks.
    script_checked: bool,
}

/// Run case `k`; a failure is pushed to `failures` with everything needed to replay it.
fn run_case(bin: &str, dir: &Path, k: usize, case: &Case, failures: &Mutex<Vec<String>>) -> Outcome {
    let base = dir.join(format!("c{k}"));
    let cwd = base.join("w");
    let _ = fs::remove_dir_all(&base);
    fs::create_dir_all(&cwd).unwrap();
    let tp = Instant::now();
    prepare(&case.prep, &cwd);
    PREP_NS.fetch_add(tp.elapsed().as_nanos() as usize, Ordering::Relaxed);
    let (out, err) = (base.join("stdout"), base.join("stderr"));
    let mut cmd = Command::new(bin);
    cmd.args(&case.args);
    let (status, elapsed) = run_bounded(cmd, &cwd, &out, &err);
    let stderr = fs::read(&err)
        .map(|b| String::from_utf8_lossy(&b).into_owned())
        .unwrap_or_default();
    let code = status.map(|st| st.code().unwrap_or(-1));
    let mut problem = match code {
        None => Some(format!("ran over {BOUND:?} (killed)")),
        Some(_) if stderr.contains("panicked") => Some(s("panicked")),
        Some(c) if !(0..=3).contains(&c) => Some(format!("exit {c} ({:?})", status.unwrap())),
        Some(_) => None,
    };
    let mut script_checked = false;
    if let (None, Some(0), Some(script)) = (&problem, code, &case.script) {
        let path = script.as_ref().map_or(out.clone(), |f| cwd.join(f));
        match check_script(&path, &cwd) {
            Ok(()) => script_checked = true,
            Err(e) => problem = Some(format!("script: {e}")),
        }
    }
    let line = shell_line(bin, &case.args);
    if std::env::var("HSPH_FUZZ_VERBOSE").is_ok() {
        eprintln!(
            "case {k} [{:?}] exit {code:?} {:.2} s: {line}\n  {}",
            case.family,
            elapsed.as_secs_f64(),
            stderr.trim()
        );
    }
    if let Some(problem) = problem {
        // the head of standard error: the error or panic message comes before any backtrace
        let mut tail = stderr.clone();
        if tail.len() > 2000 {
            let mut cut = 2000;
            while !tail.is_char_boundary(cut) {
                cut -= 1;
            }
            tail = format!("{}…", &tail[..cut]);
        }
        failures.lock().unwrap().push(format!(
            "case {k} [{:?}] {problem} after {:.1} s\n  replay: HSPH_FUZZ_CASE={k} cargo test --release --test suite fuzz::\n  \
             cd {} && {line}\n  {}\n  stderr: {}",
            case.family,
            elapsed.as_secs_f64(),
            shell_word(&p(&cwd)),
            case.note.replace('\n', "\n  "),
            tail.trim().replace('\n', "\n    ")
        ));
        return Outcome {
            code: None,
            elapsed,
            script_checked,
        };
    }
    // keep the working directory of a replayed case; free the disk of the others
    if std::env::var("HSPH_FUZZ_CASE").is_err() {
        let tc = Instant::now();
        let _ = fs::remove_dir_all(&base);
        PREP_NS.fetch_add(tc.elapsed().as_nanos() as usize, Ordering::Relaxed);
    }
    Outcome {
        code: code.map(|c| c as usize),
        elapsed,
        script_checked,
    }
}

/// Every case of the run, each family from its stream of `seed` (the scene mutants from
/// theirs), in a fixed order: case k is the same case for one seed.
fn all_cases(seed: u64, fx: &Fixtures, dir: &Path) -> Vec<Case> {
    let stream = |k: u64| seed ^ k.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    let mut cases = Vec::new();
    let mut rng = Rng(seed);
    let dam = fs::read_to_string(&fx.dam).unwrap();
    let poi = fs::read_to_string(repo_path("inputs/poiseuille_2d.toml")).unwrap();
    for (k, text) in mutants(&dam, 300, 0x5ce0e ^ seed ^ SEED)
        .iter()
        .chain(&mutants(&poi, 150, 0x901 ^ seed ^ SEED))
        .enumerate()
    {
        cases.push(scene_case(&mut rng, text, dir, k, k % 2 == 0));
    }
    for k in 0..480 {
        let scene = if k % 2 == 0 { &fx.dam } else { &fx.hydro };
        cases.push(flag_case(&mut rng, scene, dir, &fx.topo, k));
    }
    for k in 0..80 {
        cases.push(layout_case(fx, k));
    }
    let mut rng = Rng(stream(2));
    for _ in 0..560 {
        cases.push(cli_case(&mut rng, fx));
    }
    cases.extend(run_flag_sweep(fx));
    let mut rng = Rng(stream(3));
    for _ in 0..500 {
        cases.push(set_case(&mut rng, fx));
    }
    for (key, valid) in SET_KEYS {
        for value in SWEEP {
            cases.push(sweep_case(fx, key, valid, value));
        }
    }
    let mut rng = Rng(stream(4));
    for _ in 0..450 {
        cases.push(checkpoint_case(&mut rng, fx));
    }
    let mut rng = Rng(stream(5));
    for _ in 0..260 {
        cases.push(jobscript_case(&mut rng, fx));
    }
    cases.extend(mesh_cases(&mut Rng(stream(6)), dir));
    cases
}

// ---------------------------------------------------------------------------------------------
// Family `mesh` (issue 83)
// ---------------------------------------------------------------------------------------------

/// Placement keys a mesh body may carry, valid and odd.
const MESH_KEYS: &[&str] = &[
    "",
    "scale = 0.001",
    "scale = 1e-300",
    "scale = 1e300",
    "scale = nan",
    "rotate = [0.0, 0.0, 90.0]",
    "rotate = [1e300, 0.0, 0.0]",
    "rotate = [33.0, 12.5, -7.0]",
    "translate = [0.01, 0.0, 0.02]",
    "translate = [inf, 0.0, 0.0]",
    "flip = true",
    "sha256 = \"deadbeef\"",
];

/// The mesh family's cases under `dir/meshes`: each hostile file of `tests/mesh.rs` through
/// `check` and a run, then 150 mutants of a good binary or ASCII box (bytes flipped, cut,
/// the header's count replaced, a triangle repeated, ASCII tokens replaced), each with a
/// placement key from [`MESH_KEYS`]; a third of the mutants run 3 steps.
fn mesh_cases(rng: &mut Rng, dir: &Path) -> Vec<Case> {
    let md = dir.join("meshes");
    fs::create_dir_all(md.join("folder.stl")).unwrap();
    crate::mesh::write_bad_files(&md);
    let binary = fs::read(md.join("box.stl")).unwrap();
    let ascii = fs::read(crate::mesh::stl(
        &md,
        "ascii.stl",
        &[
            "box", "--min", "0.1", "0.1", "0", "--max", "0.4", "0.3", "0.2", "--ascii",
        ],
    ))
    .unwrap();
    let mut cases = Vec::new();
    let mut case = |name: &str, extra: &str, run: bool, note: String| {
        let k = cases.len();
        let scene = md.join(format!("m{k}.toml"));
        fs::write(
            &scene,
            crate::mesh::scene(&format!("shape = \"mesh\"\nfile = \"{name}\"\n{extra}")),
        )
        .unwrap();
        let mut args = if run {
            vec![s("run"), p(&scene), s("-q"), s("--force"), s("--out"), s("run")]
        } else {
            vec![s("check"), p(&scene)]
        };
        args.extend(["--max-memory", "2G"].map(String::from));
        if run {
            args.extend(["--set", "time.max_steps=3", "--threads", "1"].map(String::from));
        }
        cases.push(Case {
            note: format!("{note}; {extra}"),
            ..Case::new(Family::Mesh, args)
        });
    };
    let hostile = [
        "cut.stl",
        "nan.stl",
        "open.stl",
        "turned.stl",
        "empty.stl",
        "inward.stl",
        "huge.stl",
        "lying.stl",
        "crossing.stl",
        "fifo.stl",
        "zero.stl",
        "folder.stl",
        "none.stl",
        "box.stl",
    ];
    for name in hostile {
        case(name, "", false, format!("hostile {name}"));
        case(name, "", true, format!("hostile {name}"));
    }
    for k in 0..150 {
        let (b, what) = if rng.below(2) == 0 {
            mesh_mutant(rng, &binary, false)
        } else {
            mesh_mutant(rng, &ascii, true)
        };
        let name = format!("mutant-{k}.stl");
        fs::write(md.join(&name), &b).unwrap();
        let extra = if rng.below(2) == 0 {
            ""
        } else {
            MESH_KEYS[rng.below(MESH_KEYS.len())]
        };
        case(&name, extra, k % 3 == 0, format!("{name}: {what}"));
    }
    cases
}

/// A mutant of the good STL `base` (`text` for ASCII) and what was done to it: bytes the
/// reader ignores flipped (binary), bits flipped anywhere, a cut, the header's count replaced
/// or a triangle repeated (binary), or one word replaced in place.
fn mesh_mutant(rng: &mut Rng, base: &[u8], text: bool) -> (Vec<u8>, String) {
    let mut b = base.to_vec();
    let what = match rng.below(6) {
        5 if !text => {
            // bytes the reader ignores: the header's text and a facet's normal
            let i = if rng.below(2) == 0 {
                rng.below(80)
            } else {
                84 + 50 * rng.below(12) + rng.below(12)
            };
            b[i] ^= 1 << rng.below(8);
            format!("byte {i} (header or normal) flipped")
        }
        0 => {
            let n = 1 + rng.below(8);
            for _ in 0..n {
                let i = rng.below(b.len());
                b[i] ^= 1 << rng.below(8);
            }
            format!("{n} bits flipped")
        }
        1 => {
            b.truncate(rng.below(b.len() + 1));
            format!("cut to {} bytes", b.len())
        }
        2 if !text => {
            let n = rng.next_u64() as u32;
            b[80..84].copy_from_slice(&n.to_le_bytes());
            format!("header counts {n}")
        }
        3 if !text => {
            let t = 84 + 50 * rng.below(12);
            let tri = b[t..t + 50].to_vec();
            b.extend_from_slice(&tri);
            let n = u32::from_le_bytes([b[80], b[81], b[82], b[83]]) + 1;
            b[80..84].copy_from_slice(&n.to_le_bytes());
            s("a triangle repeated")
        }
        _ => {
            let t = String::from_utf8_lossy(&b).into_owned();
            // the byte ranges of the words, so that one is replaced in place (lines kept)
            let mut words = Vec::new();
            let mut start = None;
            for (at, c) in t.char_indices().chain([(t.len(), ' ')]) {
                match (c.is_whitespace(), start) {
                    (false, None) => start = Some(at),
                    (true, Some(a)) => {
                        words.push(a..at);
                        start = None;
                    }
                    _ => {}
                }
            }
            let w = words[rng.below(words.len())].clone();
            let odd = [
                "nan", "inf", "-1e39", "1e309", "", "facet", "vertex", "endsolid", "0x1p3", "1e-320",
            ];
            let new = odd[rng.below(odd.len())];
            b = format!("{}{new}{}", &t[..w.start], &t[w.end..]).into_bytes();
            format!("word `{}` at byte {} replaced by `{new}`", &t[w.clone()], w.start)
        }
    };
    (b, what)
}

/// Print what the run did, per family and in all (exit codes, runs that ran, scripts checked,
/// the slowest cases); returns the count of each exit code, the runs that ran and the
/// scripts checked.
fn report(
    cases: &[Case],
    outcomes: &[(usize, Outcome)],
    wall: Duration,
    seed: u64,
) -> ([usize; 4], usize, usize) {
    let runs = cases.iter().filter(|c| c.is_run()).count();
    // per family: cases, runs, exit 0/1/2/3, failures, scripts checked, seconds
    eprintln!(
        "{} mutants ({runs} runs, {:.0} %) in {:.1} s on 2 workers, seed {seed:#x}",
        outcomes.len(),
        100.0 * runs as f64 / cases.len() as f64,
        wall.as_secs_f64()
    );
    let mut total = [0usize; 4];
    let mut ran = 0;
    let mut scripts = 0;
    for f in FAMILIES {
        let mine: Vec<&(usize, Outcome)> = outcomes.iter().filter(|(k, _)| cases[*k].family == f).collect();
        let mut c = [0usize; 4];
        let mut failed = 0;
        for (k, o) in &mine {
            match o.code {
                Some(code) => {
                    c[code] += 1;
                    total[code] += 1;
                    if cases[*k].is_run() && code != 2 {
                        ran += 1;
                    }
                }
                None => failed += 1,
            }
            scripts += o.script_checked as usize;
        }
        let secs = mine.iter().map(|(_, o)| o.elapsed.as_secs_f64()).sum::<f64>() + 0.0;
        eprintln!(
            "  {f:?}: {} mutants, {} runs; exit 0: {}, 1: {}, 2: {}, 3: {}; {failed} failed; {secs:.1} s",
            mine.len(),
            mine.iter().filter(|(k, _)| cases[*k].is_run()).count(),
            c[0],
            c[1],
            c[2],
            c[3]
        );
    }
    eprintln!(
        "  runs that ran (exit 0, 1 or 3): {ran}; job scripts checked: {scripts}; {:.1} s setting up and removing working directories",
        PREP_NS.load(Ordering::Relaxed) as f64 * 1e-9
    );
    let mut slow: Vec<&(usize, Outcome)> = outcomes.iter().collect();
    slow.sort_by_key(|o| std::cmp::Reverse(o.1.elapsed));
    for (k, o) in slow.iter().take(5) {
        eprintln!(
            "  slow: case {k} {:.2} s: {}",
            o.elapsed.as_secs_f64(),
            shell_line("hsph", &cases[*k].args)
        );
    }
    (total, ran, scripts)
}

#[test]
fn two_thousand_mutants_of_scenes_flags_sets_checkpoints_and_job_scripts_never_panic_hang_or_exit_outside_0_to_3(
) {
    let seed = std::env::var("HSPH_FUZZ_SEED").ok().map_or(SEED, |v| {
        v.parse()
            .unwrap_or_else(|_| u64::from_str_radix(v.trim_start_matches("0x"), 16).unwrap())
    });
    // each family from its own stream, so that changing one leaves the others' mutants alone
    let stream = |k: u64| seed ^ k.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    eprintln!("fuzz seed {seed:#x} (HSPH_FUZZ_SEED)");
    let dir = temp_dir("fuzz");
    let t_fx = Instant::now();
    let fx = fixtures(&dir, &mut Rng(stream(1)));
    let ck_hashes: Vec<_> = fx
        .cks
        .iter()
        .map(|c| tree_hashes(&c.run.join("checkpoints")))
        .collect();

    let cases = all_cases(seed, &fx, &dir);
    let runs = cases.iter().filter(|c| c.is_run()).count();
    assert!(
        cases.len() >= 2000 && runs * 5 >= cases.len(),
        "{} cases, {runs} runs",
        cases.len()
    );

    let only: Option<usize> = std::env::var("HSPH_FUZZ_CASE").ok().map(|v| v.parse().unwrap());
    let order: Vec<usize> = match only {
        Some(k) => vec![k],
        None => (0..cases.len()).collect(),
    };
    let next = AtomicUsize::new(0);
    let outcomes: Mutex<Vec<(usize, Outcome)>> = Mutex::new(Vec::new());
    let failures = Mutex::new(Vec::new());
    let bin = env!("CARGO_BIN_EXE_hsph");
    eprintln!("fixtures ready after {:.1} s", t_fx.elapsed().as_secs_f64());
    let t0 = Instant::now();
    std::thread::scope(|sc| {
        for _ in 0..2 {
            sc.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                let Some(&k) = order.get(i) else { break };
                let o = run_case(bin, &dir, k, &cases[k], &failures);
                outcomes.lock().unwrap().push((k, o));
            });
        }
    });
    let wall = t0.elapsed();
    let outcomes = outcomes.into_inner().unwrap();
    let failures = failures.into_inner().unwrap();

    let (total, ran, scripts) = report(&cases, &outcomes, wall, seed);
    for (c, h) in fx.cks.iter().zip(&ck_hashes) {
        assert_eq!(
            &tree_hashes(&c.run.join("checkpoints")),
            h,
            "a restart changed the checkpoint files it read (hard links of {})",
            c.run.display()
        );
    }
    assert!(
        failures.is_empty(),
        "{} of {} mutants failed (seed {seed:#x}; working directories kept under {}):\n\n{}",
        failures.len(),
        outcomes.len(),
        dir.display(),
        failures.join("\n\n")
    );
    if only.is_none() {
        assert!(
            total[0] > 100 && total[2] > 100 && ran * 5 >= cases.len() && scripts >= 50,
            "every outcome must be exercised: exit codes {total:?}, {ran} runs ran, {scripts} scripts checked"
        );
        let _ = fs::remove_dir_all(&dir);
    }
}

/// Manifests through the library, in process (Hardening III: manifests join the corpus): a
/// real two-rank checkpoint's `manifest.json`, mutated as JSON at the pointers a restart trusts
/// and at random ones, or as text, is read, checked and its parts loaded as a restart reads
/// them (each rank's share, the ids checked against the counter). No mutant panics; a refusal
/// is always an input error (exit 2) naming the manifest or a part.
#[test]
fn manifests_in_process_are_read_or_refused_as_input() {
    const MUTANTS: usize = 1600;
    let dir = temp_dir("fuzz-manifests");
    let run = dir.join("run");
    let (code, _, err) = common::run_file(
        "inputs/dam_break_2d.toml",
        &run,
        (2, 1),
        &["time.max_steps=10", "checkpoint.every_steps=10"],
    );
    assert_eq!(code, 0, "{err}");
    let ck = run.join("checkpoints/step-0000000010");
    let good = fs::read_to_string(ck.join("manifest.json")).unwrap();
    let bound = common::id_bound_2d("inputs/dam_break_2d.toml");
    let seed = std::env::var("HSPH_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(SEED);
    let mut rng = Rng(seed ^ 0x3a41_f357);
    let (mut read, mut refused) = (0usize, 0usize);
    for k in 0..MUTANTS {
        let (text, note) = match rng.below(10) {
            0..=6 => {
                let mut v: Value = serde_json::from_str(&good).unwrap();
                let mut notes = Vec::new();
                for _ in 0..1 + rng.below(3) {
                    let ptr = if rng.below(2) == 0 {
                        s(pick(&mut rng, MANIFEST_TARGETS))
                    } else {
                        random_pointer(&v, &mut rng)
                    };
                    notes.push(mutate_json_at(&mut v, &ptr, &mut rng));
                }
                (raw_json(&v), notes.join("; "))
            }
            _ => {
                let mut t = good.clone();
                for _ in 0..1 + rng.below(3) {
                    t = mutate(&t, &mut rng);
                }
                (t, s("text mutated"))
            }
        };
        fs::write(ck.join("manifest.json"), &text).unwrap();
        let outcome = std::panic::catch_unwind(|| -> hsph::error::Result<()> {
            let m = hsph::checkpoint::manifest(&ck)?;
            let next = hsph::checkpoint::next_id(&ck, &m, bound)?;
            for rank in 0..2 {
                let (p, _, _) = hsph::checkpoint::share::<2>(&ck, &m, rank, 2)?;
                hsph::checkpoint::check_ids(&ck, &m, &p.id[..p.n_owned], next)?;
            }
            Ok(())
        });
        match outcome {
            Err(_) => panic!("manifest mutant {k} panicked ({note}):\n{text}"),
            Ok(Ok(())) => read += 1,
            Ok(Err(e @ hsph::error::Error::Input { .. })) => {
                let msg = e.to_string();
                assert!(
                    msg.contains("manifest.json") || msg.contains("part-"),
                    "mutant {k} ({note}): the refusal names no file: {msg}"
                );
                refused += 1;
            }
            Ok(Err(e)) => panic!("manifest mutant {k} ({note}) is not an input error: {e}\n{text}"),
        }
    }
    fs::write(ck.join("manifest.json"), &good).unwrap();
    eprintln!("manifests in process: {MUTANTS} mutants, {read} read, {refused} refused");
    assert!(
        refused > MUTANTS / 2 && read > 0,
        "{read} read, {refused} refused"
    );
}

/// `summary.json` through the library, in process (Hardening III: summaries join the corpus):
/// a real two-rank run's summary, mutated as JSON at random pointers (ranks, threads, counts,
/// timers, traffic, the decomposition: extremes, non-numbers, deletions) or as text, read as
/// `hsph report` and `hsph validate` read it ([`hsph::limits::read_summary`]) and as `hsph model`
/// does ([`hsph::model::Measured::read`]). No mutant panics or sizes anything by a number
/// out of range; a refusal is an input error naming `summary.json`.
#[test]
fn summaries_in_process_are_read_or_refused_as_input() {
    const MUTANTS: usize = 1000;
    let dir = temp_dir("fuzz-summaries");
    let run = dir.join("run");
    let (code, _, err) = common::run_file("inputs/dam_break_2d.toml", &run, (2, 1), &["time.max_steps=5"]);
    assert_eq!(code, 0, "{err}");
    let path = run.join("summary.json");
    let good = fs::read_to_string(&path).unwrap();
    let seed = std::env::var("HSPH_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(SEED);
    let mut rng = Rng(seed ^ 0x05e3_3a11);
    let targets = [
        "/ranks",
        "/threads",
        "/nodes",
        "/particles",
        "/steps",
        "/wall_s",
        "/t",
    ];
    let (mut read, mut refused) = (0usize, 0usize);
    for k in 0..MUTANTS {
        let (text, note) = if rng.below(8) < 7 {
            let mut v: Value = serde_json::from_str(&good).unwrap();
            let mut notes = Vec::new();
            for _ in 0..1 + rng.below(3) {
                let ptr = if rng.below(3) == 0 {
                    s(pick(&mut rng, &targets))
                } else {
                    random_pointer(&v, &mut rng)
                };
                notes.push(mutate_json_at(&mut v, &ptr, &mut rng));
            }
            (raw_json(&v), notes.join("; "))
        } else {
            let mut t = good.clone();
            for _ in 0..1 + rng.below(3) {
                t = mutate(&t, &mut rng);
            }
            (t, s("text mutated"))
        };
        fs::write(&path, &text).unwrap();
        let outcome = std::panic::catch_unwind(|| -> hsph::error::Result<()> {
            hsph::limits::read_summary(&path)?;
            hsph::model::Measured::read(&run)?;
            Ok(())
        });
        match outcome {
            Err(_) => panic!("summary mutant {k} panicked ({note}):\n{text}"),
            Ok(Ok(())) => read += 1,
            Ok(Err(e @ hsph::error::Error::Input { .. })) => {
                let msg = e.to_string();
                assert!(msg.contains("summary.json"), "mutant {k} ({note}): {msg}");
                refused += 1;
            }
            Ok(Err(e)) => panic!("summary mutant {k} ({note}) is not an input error: {e}"),
        }
    }
    fs::write(&path, &good).unwrap();
    eprintln!("summaries in process: {MUTANTS} mutants, {read} read, {refused} refused");
    assert!(
        refused > MUTANTS / 4 && read > 0,
        "{read} read, {refused} refused"
    );
}
