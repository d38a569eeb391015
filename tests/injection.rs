//! Issue 32, defect 1: `hsph jobscript` with a hostile value in every field it writes into the
//! batch script. Each case is either refused (exit 2, one message naming the key or flag, no
//! panic, no script written) or gives a script that `bash -n` accepts and that, run by bash
//! with stand-in `srun`, `mpirun`, `scontrol` and `hsph` that record their arguments, runs
//! nothing else (no file `PWNED` anywhere), hands the run directory and the scene path to the
//! run verbatim, each as one argument, and keeps every `#SBATCH` line in the leading comment
//! block, where Slurm reads them. Both launchers, both branches (a new run and a restart).

use crate::common;

use common::{repo_path, temp_dir};
use std::os::unix::fs::{FileTypeExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The launcher flag values.
const LAUNCHERS: [&str; 2] = ["srun", "mpirun"];

fn write_exec(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
}

/// Each stand-in writes its name and arguments, NUL-separated, to a new file in
/// `$HSPH_TEST_LOG`.
const RECORD: &str =
    "f=$(mktemp \"$HSPH_TEST_LOG/call.XXXXXX\")\nprintf '%s\\0' \"$(basename \"$0\")\" \"$@\" > \"$f\"\n";

/// The stand-in hsph: `check` passes, a run stops early with a checkpoint (exit 3), so that
/// the script goes on to `scontrol requeue`.
fn standin_hsph() -> String {
    format!("#!/bin/bash\n{RECORD}[ \"$1\" = check ] && exit 0\nexit 3\n")
}

/// Stand-in launchers and scontrol in `dir`; the launchers drop their own options (3 for
/// srun, 4 for mpirun, as the script writes them) and run the rest.
fn standins(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    write_exec(
        &dir.join("srun"),
        &format!("#!/bin/bash\n{RECORD}shift 3\nexec \"$@\"\n"),
    );
    write_exec(
        &dir.join("mpirun"),
        &format!("#!/bin/bash\n{RECORD}shift 4\nexec \"$@\"\n"),
    );
    write_exec(&dir.join("scontrol"), &format!("#!/bin/bash\n{RECORD}exit 0\n"));
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

/// The 2D dam break with `name = <name>`, written to `path` (its directory created).
fn scene_named(path: &Path, name: &str) {
    let text = std::fs::read_to_string(repo_path("inputs/dam_break_2d.toml")).unwrap();
    let old = "name = \"dam_break_2d\"\n";
    assert!(text.starts_with("#") && text.contains(old));
    let text = text.replacen(old, &format!("name = {}\n", toml_string(name)), 1);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

/// One request to `hsph jobscript`.
#[derive(Clone)]
struct Case {
    what: &'static str,
    /// Scene name (`None`: the shipped `dam_break_2d`).
    name: Option<String>,
    /// Directory of the scene file, relative to the case's directory.
    scene_dir: String,
    /// Run directory, relative to the case's directory.
    out: String,
    /// Directory the hsph binary is run from (a copy), relative to the case's directory;
    /// `None`: the built binary, and the script is run with `HSPH` set to the stand-in.
    bin_dir: Option<String>,
    partition: Option<String>,
    account: Option<String>,
    /// `None`: the script is written and run; `Some(key)`: refused naming `key`.
    refused: Option<&'static str>,
}

fn case(what: &'static str) -> Case {
    Case {
        what,
        name: None,
        scene_dir: "scenes".into(),
        out: "runs/dam".into(),
        bin_dir: None,
        partition: Some("compute,debug".into()),
        account: Some("proj-1".into()),
        refused: None,
    }
}

fn with_name(what: &'static str, name: &str) -> Case {
    Case {
        name: Some(name.into()),
        refused: Some("name"),
        ..case(what)
    }
}

/// Every hostile value: names that are refused, paths that are quoted (or refused when they
/// hold a control character).
fn cases() -> Vec<Case> {
    let names = [
        ("name with a newline and a command", "x\ntouch PWNED"),
        ("name with $(...)", "$(touch PWNED)"),
        ("name with backquotes", "`touch PWNED`"),
        ("name with double quotes", "x\"; touch PWNED; echo \""),
        ("name with a single quote", "x'; touch PWNED; echo '"),
        ("name with a space", "dam break"),
        (
            "name with a carriage return and a directive",
            "x\r#SBATCH --time=99:00:00",
        ),
        ("name with a slash", "../../x"),
    ];
    let mut all: Vec<Case> = names.iter().map(|(w, n)| with_name(w, n)).collect();
    for (what, flag, value) in [
        ("partition with a newline", "--partition", "debug\ntouch PWNED"),
        ("partition with $(...)", "--partition", "$(touch PWNED)"),
        ("partition with a space", "--partition", "debug touch"),
        (
            "partition with a directive",
            "--partition",
            "debug\n#SBATCH --time=1",
        ),
        ("account with a newline", "--account", "proj\ntouch PWNED"),
        ("account with a semicolon", "--account", "proj;touch PWNED"),
        ("account with a quote", "--account", "proj'x"),
        ("account that is empty", "--account", ""),
    ] {
        let mut c = case(what);
        if flag == "--partition" {
            c.partition = Some(value.into());
        } else {
            c.account = Some(value.into());
        }
        c.refused = Some(flag);
        all.push(c);
    }
    for (what, out) in [
        (
            "run directory with double quotes",
            "runs/x\"; touch PWNED; echo \"",
        ),
        ("run directory with a single quote", "runs/it's 'quoted'"),
        ("run directory with $(...)", "runs/$(touch PWNED)"),
        (
            "run directory with backquotes and ${...}",
            "runs/`touch PWNED` ${PWNED:-x}",
        ),
        ("run directory with spaces and a glob", "runs/a b  * c"),
        (
            "run directory with a backslash and a semicolon",
            "runs/a\\';touch PWNED;'",
        ),
    ] {
        all.push(Case {
            out: out.into(),
            ..case(what)
        });
    }
    all.push(Case {
        out: "runs/x\ntouch PWNED".into(),
        refused: Some("--out"),
        ..case("run directory with a newline")
    });
    for (what, dir) in [
        ("scene path with \"$(...)\"", "scenes/\"$(touch PWNED)\""),
        ("scene path with single quotes", "scenes/it's 'q' \\' x"),
    ] {
        all.push(Case {
            scene_dir: dir.into(),
            ..case(what)
        });
    }
    all.push(Case {
        scene_dir: "scenes/a\nb".into(),
        refused: Some("SCENE"),
        ..case("scene path with a newline")
    });
    all.push(Case {
        bin_dir: Some("bin $(touch PWNED) 'q' \"x\" `y`".into()),
        ..case("hsph binary path with quotes and $(...)")
    });
    all.push(Case {
        bin_dir: Some("bin\ntouch PWNED".into()),
        refused: Some("HSPH"),
        ..case("hsph binary path with a newline")
    });
    all.push(Case {
        out: "runs/all \"$(touch PWNED)\" 'x'".into(),
        scene_dir: "scenes/all '$(touch PWNED)'".into(),
        bin_dir: Some("bin all `touch PWNED`".into()),
        partition: Some("a.b+c_d-e,f".into()),
        account: Some("A.b+c_d-e".into()),
        ..case("every path hostile at once")
    });
    all
}

/// Any file or directory named exactly `PWNED` under `dir`.
fn pwned_under(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return found;
    };
    for e in entries.flatten() {
        let p = e.path();
        if e.file_name() == "PWNED" {
            found.push(p.clone());
        }
        if e.file_type().map(|t| t.is_dir()).unwrap_or(false) {
            found.extend(pwned_under(&p));
        }
    }
    found
}

fn assert_nothing_ran(dir: &Path, what: &str) {
    let mut found = pwned_under(dir);
    if repo_path("PWNED").exists() {
        found.push(repo_path("PWNED"));
    }
    assert!(found.is_empty(), "{what}: an injected command ran: {found:?}");
}

/// The hsph binary to generate with: the built one, or a copy in `dir` (its path is what the
/// script's HSPH_DEFAULT names).
fn binary_in(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let copy = dir.join("hsph");
    let built = Path::new(env!("CARGO_BIN_EXE_hsph"));
    if std::fs::hard_link(built, &copy).is_err() {
        std::fs::copy(built, &copy).unwrap();
    }
    copy
}

/// Every argument as recorded by the stand-ins, one Vec per call, sorted.
fn calls(log: &Path) -> Vec<Vec<String>> {
    let mut all: Vec<Vec<String>> = std::fs::read_dir(log)
        .unwrap()
        .map(|e| {
            let text = std::fs::read_to_string(e.unwrap().path()).unwrap();
            let text = text.strip_suffix('\0').expect("NUL-terminated");
            text.split('\0').map(String::from).collect()
        })
        .collect();
    all.sort();
    all
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// The `#SBATCH` lines of `script` must be these, all before the first line that is neither a
/// comment nor blank.
fn assert_directives(script: &str, expected: &[String], what: &str) {
    let lines: Vec<&str> = script.lines().collect();
    let first_command = lines
        .iter()
        .position(|l| {
            let t = l.trim();
            !t.is_empty() && !t.starts_with('#')
        })
        .expect("a command");
    let directives: Vec<&str> = lines
        .iter()
        .copied()
        .filter(|l| l.trim_start().starts_with("#SBATCH"))
        .collect();
    assert_eq!(directives, expected, "{what}: #SBATCH lines in\n{script}");
    for (i, l) in lines.iter().enumerate() {
        if l.trim_start().starts_with("#SBATCH") {
            assert!(
                i < first_command,
                "{what}: {l:?} after the first command in\n{script}"
            );
        }
    }
}

fn bash_n(script: &Path, what: &str) {
    let o = Command::new("bash").arg("-n").arg(script).output().unwrap();
    assert!(
        o.status.success(),
        "{what}: bash -n: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Generate the script for `c` with `launcher` in a fresh directory, and check what comes of it.
/// The files of one case: its directory, the scene, the run directory, the job script and
/// the hsph binary the script names.
struct Paths {
    dir: PathBuf,
    scene: PathBuf,
    run: PathBuf,
    job: PathBuf,
    bin: PathBuf,
}

fn try_case(c: &Case, launcher: &str) {
    let what = format!("{} ({launcher})", c.what);
    let dir = temp_dir("injection");
    let scene = dir.join(&c.scene_dir).join("scene.toml");
    scene_named(&scene, c.name.as_deref().unwrap_or("dam_break_2d"));
    let f = Paths {
        run: dir.join(&c.out),
        job: dir.join("job.sh"),
        bin: match &c.bin_dir {
            Some(b) => binary_in(&dir.join(b)),
            None => PathBuf::from(env!("CARGO_BIN_EXE_hsph")),
        },
        scene,
        dir,
    };
    let o = jobscript_command(c, launcher, &f).output().unwrap();
    let err = stderr(&o);
    assert!(!err.contains("panicked"), "{what}: {err}");
    if let Some(key) = c.refused {
        assert_eq!(o.status.code(), Some(2), "{what}: {err}");
        assert!(err.contains(&format!("key `{key}`")), "{what}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{what}: one line: {err}");
        if key == "name" {
            assert!(
                err.contains(f.scene.to_str().unwrap()),
                "{what}: names the scene file: {err}"
            );
        }
        assert!(!f.job.exists(), "{what}: a refused request wrote a script");
        assert_nothing_ran(&f.dir, &what);
        let _ = std::fs::remove_dir_all(&f.dir);
        return;
    }
    assert_eq!(o.status.code(), Some(0), "{what}: {err}");
    let text = std::fs::read_to_string(&f.job).unwrap();
    bash_n(&f.job, &what);
    assert_directives(&text, &expected_directives(c), &what);
    run_script(c, launcher, &f, &what);
    let _ = std::fs::remove_dir_all(&f.dir);
}

/// `hsph jobscript` for case `c`: 2 nodes of 3 ranks of 4 threads, 1 h 30 min, 4 GB a node.
fn jobscript_command(c: &Case, launcher: &str, f: &Paths) -> Command {
    let mut cmd = Command::new(&f.bin);
    cmd.arg("jobscript")
        .arg(&f.scene)
        .args(["--nodes", "2", "--ranks-per-node", "3", "--threads-per-rank", "4"])
        .args(["--time", "01:30:00", "--launcher", launcher])
        .args(["--mem", "4G"])
        .arg("--out")
        .arg(&f.run)
        .arg("--script")
        .arg(&f.job)
        .current_dir(&f.dir);
    if let Some(p) = &c.partition {
        cmd.arg(format!("--partition={p}"));
    }
    if let Some(a) = &c.account {
        cmd.arg(format!("--account={a}"));
    }
    cmd
}

/// The `#SBATCH` lines the script of case `c` must hold, in order.
fn expected_directives(c: &Case) -> Vec<String> {
    let mut expected = strings(&[
        "#SBATCH --job-name=dam_break_2d",
        "#SBATCH --nodes=2",
        "#SBATCH --ntasks-per-node=3",
        "#SBATCH --cpus-per-task=4",
        "#SBATCH --mem=3815M", // 4e9 B = 3814.7 MiB, rounded up
        "#SBATCH --time=01:30:00",
    ]);
    if let Some(p) = &c.partition {
        expected.push(format!("#SBATCH --partition={p}"));
    }
    if let Some(a) = &c.account {
        expected.push(format!("#SBATCH --account={a}"));
    }
    expected.extend(strings(&[
        "#SBATCH --signal=B:USR1@540",
        "#SBATCH --requeue",
        "#SBATCH --open-mode=append",
        "#SBATCH --output=hsph-%x-%j.out",
    ]));
    expected
}

/// Run the generated script with stand-ins for hsph, the launcher and scontrol: a new run,
/// then a restart; every command it ran is the one expected, with the hostile values quoted.
fn run_script(c: &Case, launcher: &str, f: &Paths, what: &str) {
    let (dir, scene, run, job, bin) = (&f.dir, &f.scene, &f.run, &f.job, &f.bin);
    // run it: the stand-in hsph is either $HSPH or the file the script names by default
    let standin = dir.join("standin");
    standins(&standin);
    let hsph = match &c.bin_dir {
        Some(_) => {
            std::fs::remove_file(bin).unwrap();
            write_exec(bin, &standin_hsph());
            bin.clone()
        }
        None => {
            let h = standin.join("hsph");
            write_exec(&h, &standin_hsph());
            h
        }
    };
    let work = dir.join("work");
    std::fs::create_dir_all(&work).unwrap();
    let path = format!(
        "{}:{}",
        standin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let scene_s = scene.to_str().unwrap();
    let run_s = run.to_str().unwrap();
    let hsph_s = hsph.to_str().unwrap();
    let tail = ["--threads", "4", "--placement", "centre-distance"];
    let launch: Vec<&str> = match launcher {
        "srun" => vec![
            "srun",
            "--mpi=pmix",
            "--cpus-per-task=4",
            "--cpu-bind=cores",
            hsph_s,
        ],
        _ => vec![
            "mpirun",
            "--map-by",
            "ppr:3:node:PE=4",
            "--bind-to",
            "core",
            hsph_s,
        ],
    };
    // a new run, then (with a checkpoint in the run directory) a restart
    for restart in [false, true] {
        let log = dir.join(if restart { "log-restart" } else { "log-new" });
        std::fs::create_dir_all(&log).unwrap();
        if restart {
            let ck = run.join("checkpoints").join("000001");
            std::fs::create_dir_all(&ck).unwrap();
            std::fs::write(ck.join("manifest.json"), "{}").unwrap();
        }
        let mut bash = Command::new("bash");
        bash.arg(job)
            .current_dir(&work)
            .env("PATH", &path)
            .env("SLURM_JOB_ID", "42")
            .env("HSPH_TEST_LOG", &log);
        match &c.bin_dir {
            Some(_) => bash.env_remove("HSPH"),
            None => bash.env("HSPH", &hsph),
        };
        let o = bash.output().unwrap();
        assert_nothing_ran(dir, what);
        let out = String::from_utf8_lossy(&o.stdout);
        assert_eq!(
            o.status.code(),
            Some(3),
            "{what}: the run's exit 3 passes through: {out}{}",
            stderr(&o)
        );
        assert!(out.contains("requeueing to continue"), "{what}: {out}");
        let args: Vec<&str> = if restart {
            vec!["run", "--restart", run_s]
        } else {
            vec!["run", scene_s, "--out", run_s, "--force"]
        };
        let mut want = vec![
            [launch.clone(), args.clone(), tail.to_vec()].concat(),
            [&["hsph"][..], &args, &tail].concat(),
            vec!["scontrol", "requeue", "42"],
        ];
        if !restart {
            want.push(vec!["hsph", "check", scene_s, "--ranks", "6"]);
        }
        let mut want: Vec<Vec<String>> = want.iter().map(|v| strings(v)).collect();
        want.sort();
        assert_eq!(calls(&log), want, "{what}: restart {restart}");
    }
}

#[test]
fn hostile_values_in_every_field_are_refused_or_quoted() {
    let all = cases();
    assert!(all.len() >= 25);
    for launcher in LAUNCHERS {
        for c in &all {
            try_case(c, launcher);
        }
    }
}

/// The `--script` target (issue 32, defect 2, for `jobscript`): a device, a directory, a FIFO
/// or a link to a device is refused, not replaced.
#[test]
fn the_script_is_not_written_over_what_is_not_a_regular_file() {
    let dir = temp_dir("injection-script");
    let fifo = dir.join("fifo");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let link = dir.join("link");
    std::os::unix::fs::symlink("/dev/full", &link).unwrap();
    let scene = repo_path("inputs/dam_break_2d.toml");
    for target in [Path::new("/dev/full"), Path::new("/dev/null"), &dir, &fifo, &link] {
        let (code, _, err) = common::hsph(&[
            "jobscript",
            scene.to_str().unwrap(),
            "--nodes",
            "1",
            "--ranks-per-node",
            "1",
            "--time",
            "00:10:00",
            "--out",
            dir.join("run").to_str().unwrap(),
            "--script",
            target.to_str().unwrap(),
        ]);
        assert_eq!(code, 2, "{}: {err}", target.display());
        assert!(
            err.contains("key `--script`") && !err.contains("panicked"),
            "{err}"
        );
    }
    let meta = std::fs::symlink_metadata(&fifo).unwrap();
    assert!(meta.file_type().is_fifo(), "the FIFO is still there");
    assert!(std::fs::metadata("/dev/full")
        .unwrap()
        .file_type()
        .is_char_device());
    let _ = std::fs::remove_dir_all(&dir);
}
