//! Issue 9's property test: at least 1 000 mutated scenes, flag sets and layout files through
//! the `hsph` binary (`run` with `--set time.max_steps=5` for more than a fifth of them, `check`
//! and `plan` for the rest) never panic and never exit with a status other than 0, 1 or 2.

mod common;

use common::mutate::mutants;
use common::{repo_path, temp_dir, Rng};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

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
    (
        "--set",
        &[
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
        ],
    ),
];

/// Every flag may be given to `run`.
fn rng_free(_flag: &str) -> bool {
    true
}

struct Case {
    args: Vec<String>,
    what: String,
}

fn flag_case(rng: &mut Rng, scene: &Path, dir: &Path, topo: &[PathBuf], n: usize) -> Case {
    let cmd = ["run", "check", "plan"][rng.below(3)];
    let mut args: Vec<String> = vec![cmd.into(), scene.display().to_string()];
    if cmd == "run" {
        let out = dir.join(format!("flags-{n}"));
        args.extend(["-q", "--force", "--out"].map(String::from));
        args.push(out.display().to_string());
        args.extend(["--set", "time.max_steps=5", "--set", "output.format=\"none\""].map(String::from));
    }
    if cmd == "plan" {
        args.extend(["--ranks".into(), ["1", "4", "6", "0"][rng.below(4)].into()]);
    }
    // mostly flags the command takes (so that cases get past the parser), now and then any
    let takes = |f: &str| match cmd {
        "check" => ["--set", "--ranks", "--max-memory"].contains(&f),
        "plan" => ["--set", "--ranks-per-node", "--placement"].contains(&f),
        _ => f != "--ranks" || rng_free(f),
    };
    let mut used: Vec<&str> = Vec::new();
    for _ in 0..1 + rng.below(4) {
        if cmd != "check" && rng.below(8) == 0 && !used.contains(&"--topology") {
            used.push("--topology");
            args.extend([
                "--topology".into(),
                topo[rng.below(topo.len())].display().to_string(),
            ]);
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
    Case {
        what: format!("flags {args:?}"),
        args,
    }
}

fn scene_case(rng: &mut Rng, text: &str, dir: &Path, n: usize, run: bool) -> Case {
    let path = dir.join(format!("mutant-{n}.toml"));
    fs::write(&path, text).unwrap();
    let mut args: Vec<String> = if run {
        let out = dir.join(format!("scene-{n}"));
        vec![
            "run".into(),
            path.display().to_string(),
            "-q".into(),
            "--force".into(),
            "--out".into(),
            out.display().to_string(),
        ]
    } else {
        vec!["check".into(), path.display().to_string()]
    };
    args.extend(["--max-memory", "2G"].map(String::from));
    if run {
        args.extend(["--set", "time.max_steps=5", "--set", "output.interval=0"].map(String::from));
        if rng.below(3) == 0 {
            args.extend(["--ranks", "3", "--threads", "1"].map(String::from));
        }
    }
    Case {
        what: format!("scene mutant {n}: {args:?}\n{text}"),
        args,
    }
}

/// Run case `k` (at most 120 s) and check it neither panicked nor exited outside 0–2; its code.
fn run_case(bin: &str, dir: &Path, k: usize, case: &Case) -> usize {
    let mut child = Command::new(bin)
        .args(&case.args)
        .current_dir(dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if t0.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("case {k} ran over 120 s: {}", case.what);
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let mut err = String::new();
    use std::io::Read;
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert!(
        !err.contains("panicked"),
        "case {k} panicked: {}\n{err}",
        case.what
    );
    let code = status.code().unwrap_or(-1);
    assert!(
        (0..=2).contains(&code),
        "case {k}: exit {code}: {}\n{err}",
        case.what
    );
    if std::env::var("HSPH_FUZZ_VERBOSE").is_ok() {
        eprintln!("case {k} exit {code}: {:?}\n  {}", case.args, err.trim());
    }
    code as usize
}

#[test]
fn a_thousand_mutated_scenes_flags_and_layouts_never_panic() {
    let dir = temp_dir("fuzz");
    let mut rng = Rng(0xf022_2026);
    // layout files: the shipped one, mutants of it, and one that does not exist
    let shipped_topo = fs::read_to_string(repo_path("topology/four_nodes_24.toml")).unwrap();
    let mut topo = vec![repo_path("topology/four_nodes_24.toml"), dir.join("missing.toml")];
    for (k, t) in mutants(&shipped_topo, 60, 0x7090).iter().enumerate() {
        let p = dir.join(format!("topo-{k}.toml"));
        fs::write(&p, t).unwrap();
        topo.push(p);
    }
    let mut cases = Vec::new();
    let dam = fs::read_to_string(repo_path("inputs/dam_break_2d.toml")).unwrap();
    let poi = fs::read_to_string(repo_path("inputs/poiseuille_2d.toml")).unwrap();
    for (k, text) in mutants(&dam, 300, 0x5ce0e)
        .iter()
        .chain(&mutants(&poi, 150, 0x901))
        .enumerate()
    {
        cases.push(scene_case(&mut rng, text, &dir, k, k % 2 == 0));
    }
    for k in 0..480 {
        let scene = repo_path(["inputs/dam_break_2d.toml", "inputs/hydrostatic_2d.toml"][k % 2]);
        cases.push(flag_case(&mut rng, &scene, &dir, &topo, k));
    }
    // layout mutants through plan and run
    for k in 0..80 {
        let t = &topo[2 + k % (topo.len() - 2)];
        let mut args: Vec<String> = vec![
            "plan".into(),
            repo_path("inputs/dam_break_2d.toml").display().to_string(),
        ];
        args.extend([
            "--ranks".into(),
            ["96", "4", "24"][k % 3].into(),
            "--topology".into(),
            t.display().to_string(),
        ]);
        cases.push(Case {
            what: format!("layout mutant {}", t.display()),
            args,
        });
    }
    let runs = cases.iter().filter(|c| c.args[0] == "run").count();
    assert!(
        cases.len() >= 1000 && runs * 5 >= cases.len(),
        "{} cases, {runs} runs",
        cases.len()
    );

    let next = AtomicUsize::new(0);
    let counts = Mutex::new([0usize; 3]);
    let bin = env!("CARGO_BIN_EXE_hsph");
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(case) = cases.get(k) else { break };
                let code = run_case(bin, &dir, k, case);
                counts.lock().unwrap()[code] += 1;
            });
        }
    });
    let c = counts.into_inner().unwrap();
    eprintln!(
        "{} cases ({runs} runs): {} exit 0, {} exit 1, {} exit 2",
        cases.len(),
        c[0],
        c[1],
        c[2]
    );
    assert!(c[0] > 100 && c[2] > 100, "both outcomes must be exercised: {c:?}");
    let _ = fs::remove_dir_all(&dir);
}
