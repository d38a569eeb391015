//! `hsph jobscript`: an sbatch script for a scene, with the stop-and-requeue cycle built in.
//!
//! Slurm's `--signal=B:USR1@S` reaches the batch shell only, S seconds before the time limit.
//! The script traps it and forwards it to the launcher (srun or mpirun pass it on to every
//! rank); the ranks agree on a step, write a checkpoint and exit 3; the script then requeues
//! the job (`scontrol requeue`, which needs `JobRequeue=1` or `--requeue`), and the requeued job
//! finds the checkpoint and continues with `hsph run --restart`. Threads: one rayon thread per
//! CPU of the task (`--cpus-per-task`), cores bound by the launcher.
//!
//! Nothing taken from input reaches the script unchecked: the job name (the scene's `name`),
//! `--partition` and `--account` must be Slurm names ([`slurm_name`]), written only on
//! `#SBATCH` lines; paths (the scene, the run directory, the hsph binary) are refused if they
//! hold a control character and written only as single-quoted shell words ([`shell_quote`]);
//! everything else is a number checked against [`crate::limits`].

use crate::error::{Error, Location, Result};
use crate::limits::{
    MAX_NODE_MEMORY_MIB, MAX_RANKS, MAX_SLURM_NAME, MAX_THREADS, MAX_WALL_SECONDS, SIGNAL_BEFORE_RANGE,
};
use clap::ValueEnum;
use std::path::{Path, PathBuf};

/// How the ranks are started inside the allocation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Launcher {
    /// `srun --mpi=pmix` (Open MPI built with PMIx support).
    Srun,
    /// `mpirun` inside the allocation (Open MPI starts its daemons through Slurm).
    Mpirun,
}

/// What the script asks for. [`JobSpec::validate`] checks every field; [`JobSpec::script`]
/// assumes it has.
#[derive(Debug, Clone)]
pub struct JobSpec {
    /// Scene file, as the job should see it (absolute; no control character).
    pub scene: String,
    /// Run directory (absolute; no control character).
    pub run: String,
    /// The hsph binary (built with the `mpi` feature; no control character).
    pub hsph: String,
    /// Job name: the scene's `name`, a Slurm name ([`slurm_name`]).
    pub name: String,
    /// Nodes.
    pub nodes: usize,
    /// Ranks per node.
    pub ranks_per_node: usize,
    /// Rayon threads per rank (= CPUs per task).
    pub threads_per_rank: usize,
    /// Time limit (s).
    pub time_s: u64,
    /// Seconds before the limit at which Slurm sends USR1.
    pub signal_s: u64,
    /// Partition, or a comma-separated list of partitions, if any (Slurm names).
    pub partition: Option<String>,
    /// Account, if any (a Slurm name).
    pub account: Option<String>,
    /// Placement of subdomains (`hsph run --placement`).
    pub placement: String,
    /// srun or mpirun.
    pub launcher: Launcher,
    /// Memory per node (MiB), Slurm's `--mem`.
    pub mem_mib: u64,
    /// Where [`JobSpec::mem_mib`] came from: the estimate of one rank's peak (bytes), or `None`
    /// when `--mem` gave it.
    pub mem_estimate: Option<f64>,
}

/// Headroom on the estimate of a rank's peak memory in the request: the estimate is meant to
/// be within 15 % of the measured peak (issue 85), so 25 % covers it with room for the
/// allocator.
pub const MEM_HEADROOM: f64 = 1.25;

/// Bytes a rank needs beyond the estimate of its process (which counts the binary's pages,
/// [`crate::memory::PROCESS_BASE`]): the MPI library and its shared-memory and network
/// buffers (Open MPI: 30–100 MB a process).
pub const MEM_PER_RANK_BASE: f64 = 128e6;

/// Memory per node (MiB, rounded up) for `ranks_per_node` ranks that each peak at about
/// `rank_peak` bytes: (rank_peak × [`MEM_HEADROOM`] + [`MEM_PER_RANK_BASE`]) × ranks_per_node.
pub fn mem_per_node_mib(rank_peak: f64, ranks_per_node: usize) -> u64 {
    mib((rank_peak.max(0.0) * MEM_HEADROOM + MEM_PER_RANK_BASE) * ranks_per_node as f64)
}

/// `bytes` in whole MiB, rounded up (Slurm's `--mem` unit `M`).
pub fn mib(bytes: f64) -> u64 {
    (bytes / (1u64 << 20) as f64).ceil() as u64
}

/// HH:MM:SS of `s` seconds (Slurm's `--time`).
pub fn hms(s: u64) -> String {
    format!("{:02}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

/// The default warning before the limit: a tenth of the time, at least 60 s and at most 15 min
/// (a checkpoint of millions of particles takes seconds; a step can take as long).
pub fn default_signal(time_s: u64) -> u64 {
    (time_s / 10).clamp(60, 900)
}

/// `s` as one POSIX shell word: in single quotes, each `'` written `'\''`. Inside single quotes
/// the shell expands nothing (`$`, backquotes, `\`, `"`, newlines are all literal).
pub fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// A character Slurm takes in a name without quoting, and a shell line without meaning:
/// ASCII letters, digits, `.`, `_`, `+`, `-`.
fn slurm_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '+' | '-')
}

/// Check `value` of `key` as a Slurm name (job name, account; with `list`, a comma-separated
/// list of them, as `--partition` takes): 1 to [`MAX_SLURM_NAME`] characters, each a letter,
/// digit, `.`, `_`, `+` or `-` (or `,` between names of a list). Anything else, a newline, a
/// quote, `$`, a space, could end an `#SBATCH` line or start a command, and is refused with
/// exit 2 naming `key`, the value and an example like `example`.
pub fn slurm_name(key: &str, value: &str, list: bool, example: &str) -> Result<()> {
    let what = if list {
        "a Slurm name or a comma-separated list of names"
    } else {
        "a Slurm name"
    };
    let chars = value.chars().count();
    let bad = if value.is_empty() {
        Some("is empty".to_string())
    } else if chars > MAX_SLURM_NAME {
        Some(format!(
            "is {chars} characters, above the limit of {MAX_SLURM_NAME}"
        ))
    } else if list && value.split(',').any(str::is_empty) {
        Some("has an empty name in its list".to_string())
    } else {
        value
            .chars()
            .find(|&c| !(slurm_char(c) || (list && c == ',')))
            .map(|c| format!("contains {c:?}"))
    };
    match bad {
        None => Ok(()),
        Some(why) => Err(Error::input(
            key,
            format!(
                "{value:?} {why}: it must be {what} of letters, digits and . _ + -{}, at most \
                 {MAX_SLURM_NAME} characters; e.g. {example}",
                if list { " (and , between names)" } else { "" }
            ),
        )),
    }
}

/// Check a path written into the script, given by `key`: refused (exit 2, with `advice`) if it
/// holds a control character (a newline, a carriage return, a tab, ...), which could end a line
/// of the script or of its log.
pub fn plain_path(key: &str, path: &str, advice: &str) -> Result<()> {
    match path.chars().find(|c| c.is_control()) {
        None => Ok(()),
        Some(c) => Err(Error::input(
            key,
            format!("{path:?} contains the control character {c:?}, which a batch script cannot hold safely; {advice}"),
        )),
    }
}

/// `path` (given by `key`) as UTF-8 text for the script, else exit 2 naming `key` (with
/// `advice`): the script must name the very file, not a lossy rendering of it.
pub fn path_text(key: &str, path: &Path, advice: &str) -> Result<String> {
    let text = path.to_str().ok_or_else(|| {
        Error::input(
            key,
            format!("{path:?} is not valid UTF-8, so a batch script cannot name it exactly; {advice}"),
        )
    })?;
    plain_path(key, text, advice)?;
    Ok(text.to_string())
}

/// What to do about an unusable scene path, run directory or hsph binary.
pub const SCENE_ADVICE: &str = "rename it, e.g. inputs/dam_break_2d.toml";
/// See [`SCENE_ADVICE`].
pub const OUT_ADVICE: &str = "choose another, e.g. --out runs/dam_break";
/// See [`SCENE_ADVICE`].
pub const HSPH_ADVICE: &str = "install hsph under a path of printable characters, e.g. /opt/hsph/bin/hsph";

impl JobSpec {
    /// Check the request: every count, time and name within its bound, every path printable
    /// (exit 2 naming the flag, or the scene file and its `name`).
    pub fn validate(&self) -> Result<()> {
        let max_ranks = MAX_RANKS as u64;
        crate::limits::count("--nodes", self.nodes as u64, max_ranks)?;
        crate::limits::count("--ranks-per-node", self.ranks_per_node as u64, max_ranks)?;
        crate::limits::ranks(
            "--nodes × --ranks-per-node",
            self.nodes.saturating_mul(self.ranks_per_node),
        )?;
        crate::limits::count(
            "--threads-per-rank",
            self.threads_per_rank as u64,
            MAX_THREADS as u64,
        )?;
        if self.mem_mib > MAX_NODE_MEMORY_MIB {
            let key = match self.mem_estimate {
                Some(_) => "--nodes × --ranks-per-node",
                None => "--mem",
            };
            return Err(Error::input(
                key,
                format!(
                    "asks for {} MiB per node, above the limit of {MAX_NODE_MEMORY_MIB} MiB (64 TiB); \
                     e.g. --mem 256G, or more nodes",
                    self.mem_mib
                ),
            ));
        }
        if self.mem_mib == 0 {
            return Err(Error::input("--mem", "is below 1 MiB; e.g. --mem 4G"));
        }
        let (lo, hi) = SIGNAL_BEFORE_RANGE;
        if self.time_s as f64 > MAX_WALL_SECONDS {
            return Err(Error::input(
                "--time",
                format!(
                    "{} is above the limit of {} ({MAX_WALL_SECONDS} s); e.g. 23:50:00",
                    hms(self.time_s),
                    hms(MAX_WALL_SECONDS as u64)
                ),
            ));
        }
        if self.time_s <= lo {
            return Err(Error::input(
                "--time",
                format!(
                    "{} leaves no room for the warning before the limit (at least {lo} s); e.g. 00:10:00",
                    hms(self.time_s)
                ),
            ));
        }
        if !(lo..=hi).contains(&self.signal_s) {
            return Err(Error::input(
                "--signal-before",
                format!(
                    "{} s is outside {lo}..={hi} s (Slurm may send the signal up to a minute early, and \
                     takes at most {hi} s); e.g. {}",
                    self.signal_s,
                    self.example_signal()
                ),
            ));
        }
        if self.signal_s >= self.time_s {
            return Err(Error::input(
                "--signal-before",
                format!(
                    "{} s is not before the time limit {}: the run would never get its warning; e.g. {}",
                    self.signal_s,
                    hms(self.time_s),
                    self.example_signal()
                ),
            ));
        }
        plain_path("SCENE", &self.scene, SCENE_ADVICE)?;
        plain_path("--out", &self.run, OUT_ADVICE)?;
        plain_path("HSPH", &self.hsph, HSPH_ADVICE)?;
        slurm_name("name", &self.name, false, "name = \"dam_break\"").map_err(|e| match e {
            Error::Input { key, message, .. } => Error::Input {
                at: Some(Location {
                    file: PathBuf::from(&self.scene),
                    line: None,
                }),
                key,
                message: format!("{message} (the scene's name is the job's name)"),
            },
            other => other,
        })?;
        if let Some(p) = &self.partition {
            slurm_name(
                "--partition",
                p,
                true,
                "--partition compute or --partition compute,debug",
            )?;
        }
        if let Some(a) = &self.account {
            slurm_name("--account", a, false, "--account proj-123")?;
        }
        Ok(())
    }

    /// A warning that fits the time limit, for messages: the default, within
    /// [`SIGNAL_BEFORE_RANGE`] and below the limit where the limit allows.
    fn example_signal(&self) -> u64 {
        let (lo, hi) = SIGNAL_BEFORE_RANGE;
        default_signal(self.time_s).min(self.time_s / 2).clamp(lo, hi)
    }

    /// The layout the script asks for, as `HSPH_JOB_PLAN`
    /// (`nodes=N,ranks_per_node=K,threads_per_rank=T`).
    pub fn plan(&self) -> String {
        format!(
            "nodes={},ranks_per_node={},threads_per_rank={}",
            self.nodes, self.ranks_per_node, self.threads_per_rank
        )
    }

    /// The sbatch script.
    pub fn script(&self) -> String {
        let ranks = self.nodes.saturating_mul(self.ranks_per_node);
        let t = self.threads_per_rank;
        let mut s = String::new();
        s += "#!/bin/bash\n";
        s += &format!(
            "# Generated by hsph {} ({}): {} ranks on {} node(s) x {} per node, {} thread(s) per rank.\n",
            env!("CARGO_PKG_VERSION"),
            env!("HSPH_GIT_COMMIT"),
            ranks,
            self.nodes,
            self.ranks_per_node,
            t
        );
        s += "# Stop-and-requeue: USR1 before the limit -> checkpoint, exit 3 -> requeue -> restart.\n";
        s += &match self.mem_estimate {
            Some(b) => format!(
                "# Memory per node: {} ranks x ({:.1} MB, hsph check's estimate of a rank's peak, x {MEM_HEADROOM} \
                 + {:.0} MB for MPI).\n",
                self.ranks_per_node,
                b / 1e6,
                MEM_PER_RANK_BASE / 1e6
            ),
            None => "# Memory per node: given with --mem.\n".to_string(),
        };
        s += &format!("#SBATCH --job-name={}\n", self.name);
        s += &format!("#SBATCH --nodes={}\n", self.nodes);
        s += &format!("#SBATCH --ntasks-per-node={}\n", self.ranks_per_node);
        s += &format!("#SBATCH --cpus-per-task={t}\n");
        s += &format!("#SBATCH --mem={}M\n", self.mem_mib);
        s += &format!("#SBATCH --time={}\n", hms(self.time_s));
        if let Some(p) = &self.partition {
            s += &format!("#SBATCH --partition={p}\n");
        }
        if let Some(a) = &self.account {
            s += &format!("#SBATCH --account={a}\n");
        }
        s += &format!("#SBATCH --signal=B:USR1@{}\n", self.signal_s);
        s += "#SBATCH --requeue\n";
        s += "#SBATCH --open-mode=append\n";
        s += "#SBATCH --output=hsph-%x-%j.out\n\n";
        s += "set -u\n";
        // paths as single-quoted words; the default binary through a variable, so that it is
        // not expanded inside ${HSPH:-...}
        s += &format!("HSPH_DEFAULT={}\n", shell_quote(&self.hsph));
        s += "HSPH=\"${HSPH:-$HSPH_DEFAULT}\"\n";
        s += &format!(
            "SCENE={}\nRUN={}\n",
            shell_quote(&self.scene),
            shell_quote(&self.run)
        );
        s += &format!("export RAYON_NUM_THREADS={t}\n");
        s += "# the layout asked for here; the run compares it with the one it gets and warns\n";
        s += &format!("export HSPH_JOB_PLAN=\"{}\"\n\n", self.plan());
        s += "if ls \"$RUN\"/checkpoints/*/manifest.json >/dev/null 2>&1; then\n";
        s += "    ARGS=(run --restart \"$RUN\")\n";
        s += "else\n";
        s += &format!("    \"$HSPH\" check \"$SCENE\" --ranks {ranks} >/dev/null || exit 2\n");
        s += "    ARGS=(run \"$SCENE\" --out \"$RUN\" --force)\n";
        s += "fi\n";
        s += &format!("ARGS+=(--threads {t} --placement {})\n\n", self.placement);
        s += "# USR1 reaches this shell only: pass it on to the launcher, which passes it to the ranks\n";
        s += "# (Slurm may send it up to a minute early: if it comes before the launch, it is passed on\n";
        s += "# right after the launch)\n";
        s += "pid=\nearly=0\n";
        s += "forward() {\n";
        s += "    echo \"hsph job: USR1 before the time limit, asking the run to checkpoint\"\n";
        s += "    if [ -n \"$pid\" ]; then kill -USR1 \"$pid\" 2>/dev/null; else early=1; fi\n";
        s += "}\n";
        s += "trap forward USR1\n";
        match self.launcher {
            Launcher::Srun => {
                s += &format!(
                    "srun --mpi=pmix --cpus-per-task={t} --cpu-bind=cores \"$HSPH\" \"${{ARGS[@]}}\" &\n"
                );
            }
            Launcher::Mpirun => {
                s += "unset OMPI_MCA_btl_vader_backing_directory OMPI_MCA_orte_tmpdir_base\n";
                s += &format!(
                    "mpirun --map-by ppr:{}:node:PE={t} --bind-to core \"$HSPH\" \"${{ARGS[@]}}\" &\n",
                    self.ranks_per_node
                );
            }
        }
        s += "pid=$!\n";
        s += "if [ \"$early\" = 1 ]; then kill -USR1 \"$pid\" 2>/dev/null; fi\n";
        s += "# a trapped signal interrupts wait: wait again until the run has finished its checkpoint\n";
        s += "wait \"$pid\"; rc=$?\n";
        s += "while kill -0 \"$pid\" 2>/dev/null; do wait \"$pid\"; rc=$?; done\n";
        s += "if [ \"$rc\" -eq 3 ]; then\n";
        s += "    echo \"hsph job: stopped early with a checkpoint; requeueing to continue\"\n";
        s += "    # (this ends the job: Slurm cancels it and queues it again)\n";
        s += "    scontrol requeue \"$SLURM_JOB_ID\" ||\n";
        s += "        echo \"hsph job: scontrol requeue failed (JobRequeue?): submit this script again to continue\"\n";
        s += "fi\n";
        s += "exit \"$rc\"\n";
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(launcher: Launcher) -> JobSpec {
        JobSpec {
            scene: "/data/dam.toml".into(),
            run: "/scratch/runs/dam".into(),
            hsph: "/opt/hsph/bin/hsph".into(),
            name: "dam".into(),
            nodes: 2,
            ranks_per_node: 4,
            threads_per_rank: 6,
            time_s: 2 * 3600 + 30 * 60,
            signal_s: default_signal(9000),
            partition: Some("compute".into()),
            account: None,
            placement: "centre-distance".into(),
            launcher,
            mem_mib: mem_per_node_mib(50e6, 4),
            mem_estimate: Some(50e6),
        }
    }

    #[test]
    fn the_script_asks_for_the_layout_and_the_early_signal() {
        let s = spec(Launcher::Srun).script();
        for line in [
            "#SBATCH --nodes=2\n",
            "#SBATCH --ntasks-per-node=4\n",
            "#SBATCH --cpus-per-task=6\n",
            // 4 × (50 MB × 1.25 + 128 MB) = 762 MB = 726.7 MiB
            "#SBATCH --mem=727M\n",
            "# Memory per node: 4 ranks x (50.0 MB,",
            "#SBATCH --time=02:30:00\n",
            "#SBATCH --partition=compute\n",
            "#SBATCH --signal=B:USR1@900\n",
            "#SBATCH --requeue\n",
            "export RAYON_NUM_THREADS=6\n",
            "trap forward USR1\n",
            "srun --mpi=pmix --cpus-per-task=6 --cpu-bind=cores",
            "ARGS=(run --restart \"$RUN\")",
            "--ranks 8",
            "--placement centre-distance",
            "scontrol requeue \"$SLURM_JOB_ID\"",
            "export HSPH_JOB_PLAN=\"nodes=2,ranks_per_node=4,threads_per_rank=6\"\n",
        ] {
            assert!(s.contains(line), "missing {line:?} in\n{s}");
        }
        assert!(!s.contains("--account"));
        let m = spec(Launcher::Mpirun).script();
        assert!(
            m.contains("mpirun --map-by ppr:4:node:PE=6 --bind-to core"),
            "{m}"
        );
    }

    #[test]
    fn an_early_signal_waits_for_the_launch_and_the_plan_is_exported_before_it() {
        for launcher in [Launcher::Srun, Launcher::Mpirun] {
            let s = spec(launcher).script();
            let at = |needle: &str| s.find(needle).unwrap_or_else(|| panic!("{needle:?} in\n{s}"));
            // `set -u` and a USR1 before the launch: the trap must not read an unset $pid
            assert!(at("pid=\nearly=0\n") < at("trap forward USR1"), "{s}");
            assert!(s.contains("else early=1; fi"), "{s}");
            let launch = at(" \"$HSPH\" \"${ARGS[@]}\" &\n");
            assert!(at("export HSPH_JOB_PLAN=") < launch);
            assert!(at("if [ \"$early\" = 1 ]; then kill -USR1 \"$pid\"") > launch);
            assert!(s.contains("scontrol requeue failed"), "{s}");
        }
        assert_eq!(
            spec(Launcher::Srun).plan(),
            "nodes=2,ranks_per_node=4,threads_per_rank=6"
        );
    }

    #[test]
    fn the_script_is_valid_bash() {
        for launcher in [Launcher::Srun, Launcher::Mpirun] {
            let mut sp = spec(launcher);
            sp.account = Some("proj-1".into());
            let out = std::process::Command::new("bash")
                .args(["-n", "-c", &sp.script()])
                .output()
                .expect("bash");
            assert!(
                out.status.success(),
                "{launcher:?}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
    }

    #[test]
    fn times_and_warnings() {
        assert_eq!(hms(59), "00:00:59");
        assert_eq!(hms(3 * 3600 + 7 * 60 + 5), "03:07:05");
        assert_eq!(default_signal(120), 60);
        assert_eq!(default_signal(86_400), 900);
        let mut s = spec(Launcher::Srun);
        s.signal_s = s.time_s;
        assert_eq!(s.validate().unwrap_err().exit_code(), 2);
        s.signal_s = 60;
        s.nodes = 0;
        assert_eq!(s.validate().unwrap_err().exit_code(), 2);
    }

    /// The message of `sp`'s refusal, which must be exit 2 naming `key`.
    fn refused(sp: &JobSpec, key: &str) -> String {
        let e = sp.validate().expect_err(key);
        assert_eq!(e.exit_code(), 2, "{e}");
        let m = e.to_string();
        assert!(m.contains(&format!("key `{key}`")), "{key}: {m}");
        m
    }

    #[test]
    fn counts_and_times_are_bounded() {
        assert!(spec(Launcher::Srun).validate().is_ok());
        let with = |f: &dyn Fn(&mut JobSpec)| {
            let mut sp = spec(Launcher::Srun);
            f(&mut sp);
            sp
        };
        refused(&with(&|s| s.ranks_per_node = 0), "--ranks-per-node");
        refused(&with(&|s| s.nodes = MAX_RANKS + 1), "--nodes");
        // each below the limit, the product above it (and no overflow at the extremes)
        let m = refused(
            &with(&|s| {
                s.nodes = 1000;
                s.ranks_per_node = 1000
            }),
            "--nodes × --ranks-per-node",
        );
        assert!(m.contains("1000000") && m.contains("4096"), "{m}");
        assert!(with(&|s| {
            s.nodes = 64;
            s.ranks_per_node = 64
        })
        .validate()
        .is_ok());
        refused(&with(&|s| s.threads_per_rank = 0), "--threads-per-rank");
        refused(
            &with(&|s| s.threads_per_rank = MAX_THREADS + 1),
            "--threads-per-rank",
        );
        refused(&with(&|s| s.time_s = MAX_WALL_SECONDS as u64 + 1), "--time");
        refused(&with(&|s| s.time_s = 10), "--time");
        for signal in [0, 9, 65_536, u64::MAX] {
            refused(&with(&|s| s.signal_s = signal), "--signal-before");
        }
        // the suggestion fits: within the range and below the limit
        let m = refused(
            &with(&|s| {
                s.time_s = 15;
                s.signal_s = 60
            }),
            "--signal-before",
        );
        assert!(m.ends_with("e.g. 10"), "{m}");
        assert!(with(&|s| {
            s.time_s = 15;
            s.signal_s = 10
        })
        .validate()
        .is_ok());
    }

    #[test]
    fn names_must_be_slurm_names() {
        for ok in ["dam_break_2d", "a.b+c-d", "X1"] {
            assert!(slurm_name("--account", ok, false, "x").is_ok(), "{ok}");
        }
        assert!(slurm_name("--partition", "compute,debug", true, "x").is_ok());
        let long = "a".repeat(MAX_SLURM_NAME + 1);
        for (bad, list) in [
            ("", false),
            ("a,b", false),
            (",a", true),
            ("a,", true),
            ("a,,b", true),
            ("x\ntouch PWNED", false),
            ("x\rb", false),
            ("a b", false),
            ("$(id)", false),
            ("`id`", false),
            ("a'b", false),
            ("a\"b", false),
            ("a;b", false),
            ("a#b", false),
            ("a/b", false),
            ("é", false),
            (long.as_str(), true),
        ] {
            let e = slurm_name("--partition", bad, list, "--partition compute").unwrap_err();
            assert_eq!(e.exit_code(), 2);
            let m = e.to_string();
            assert!(
                m.contains("--partition") && m.contains("e.g. --partition compute"),
                "{m}"
            );
            assert!(!m.contains('\n'), "the value is escaped: {m}");
        }
        let mut sp = spec(Launcher::Srun);
        sp.name = "x\ntouch PWNED".into();
        let m = refused(&sp, "name");
        assert!(
            m.contains("/data/dam.toml") && m.contains(r#""x\ntouch PWNED""#),
            "{m}"
        );
        let mut sp = spec(Launcher::Srun);
        sp.account = Some("p\n#SBATCH --x".into());
        refused(&sp, "--account");
    }

    #[test]
    fn paths_with_control_characters_are_refused() {
        for (key, set) in [
            (
                "SCENE",
                (|s: &mut JobSpec, v: String| s.scene = v) as fn(&mut JobSpec, String),
            ),
            ("--out", |s, v| s.run = v),
            ("HSPH", |s, v| s.hsph = v),
        ] {
            for bad in ["/a\nb", "/a\rb", "/a\tb", "/a\u{7f}b", "/a\u{85}b"] {
                let mut sp = spec(Launcher::Srun);
                set(&mut sp, bad.into());
                refused(&sp, key);
            }
            let mut sp = spec(Launcher::Srun);
            set(&mut sp, "/a b/'c'/\"$(touch PWNED)\"/`x`;\\".into());
            assert!(
                sp.validate().is_ok(),
                "{key}: printable paths are quoted, not refused"
            );
        }
        #[cfg(unix)]
        {
            use std::os::unix::ffi::OsStrExt;
            let p = Path::new(std::ffi::OsStr::from_bytes(b"/a\xffb"));
            let e = path_text("--out", p, OUT_ADVICE).unwrap_err();
            assert!(
                e.to_string().contains("--out") && e.to_string().contains("UTF-8"),
                "{e}"
            );
        }
    }

    /// What bash makes of `word` as the argument of printf.
    fn through_bash(word: &str) -> String {
        let out = std::process::Command::new("bash")
            .args(["-c", &format!("printf %s {word}")])
            .output()
            .expect("bash");
        assert!(
            out.status.success(),
            "{word}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    }

    #[test]
    fn quoted_words_come_back_from_the_shell_unchanged() {
        for s in [
            "",
            "plain",
            "a b  c",
            "'",
            "''",
            "it's",
            "'\\''",
            "\"",
            "\\",
            "\\'",
            "$HOME",
            "${HOME:-x}",
            "$(touch PWNED)",
            "`touch PWNED`",
            "\"; touch PWNED; echo \"",
            "'; touch PWNED; echo '",
            "a\nb\ttouch PWNED",
            "*",
            "~",
            "!x",
            "#x",
            "a;b|c&d<e>f",
            "é ✓",
        ] {
            assert_eq!(through_bash(&shell_quote(s)), s, "{s:?}");
        }
        assert_eq!(shell_quote("it's"), r"'it'\''s'");
    }

    #[test]
    fn paths_are_single_quoted_and_the_default_binary_is_not_expanded() {
        let mut sp = spec(Launcher::Mpirun);
        sp.scene = "/d/it's \"$(x)\".toml".into();
        sp.run = "/r/`y` $z".into();
        sp.hsph = "/o/$(w)/hsph".into();
        let s = sp.script();
        for line in [
            "SCENE='/d/it'\\''s \"$(x)\".toml'\n",
            "RUN='/r/`y` $z'\n",
            "HSPH_DEFAULT='/o/$(w)/hsph'\nHSPH=\"${HSPH:-$HSPH_DEFAULT}\"\n",
        ] {
            assert!(s.contains(line), "missing {line:?} in\n{s}");
        }
        let out = std::process::Command::new("bash")
            .args(["-n", "-c", &s])
            .output()
            .expect("bash");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }

    #[test]
    fn memory_per_node_is_bounded_and_rounded_up() {
        assert_eq!(mem_per_node_mib(0.0, 1), 123); // 128 MB = 122.07 MiB, rounded up
        assert_eq!(mem_per_node_mib(1e9, 2), 2629); // 2 × 1.378 GB = 2628.3 MiB
        let mut sp = spec(Launcher::Srun);
        sp.mem_mib = MAX_NODE_MEMORY_MIB + 1;
        sp.mem_estimate = None;
        assert!(refused(&sp, "--mem").contains("64 TiB"));
        sp.mem_estimate = Some(1e18);
        assert!(refused(&sp, "--nodes × --ranks-per-node").contains("more nodes"));
        sp.mem_mib = 0;
        sp.mem_estimate = None;
        assert!(refused(&sp, "--mem").contains("1 MiB"));
        sp.mem_mib = 4096;
        let s = sp.script();
        assert!(s.contains("#SBATCH --mem=4096M\n"), "{s}");
        assert!(s.contains("# Memory per node: given with --mem.\n"), "{s}");
    }
}
