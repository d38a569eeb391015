//! Running a sweep: one `hsph run` child process per configuration (so that its wall time and
//! peak memory are its own), one CSV row per run, finished rows never rerun.

use super::cases::{Case, Variant};
use crate::error::{Error, Result};
use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Header of `sweep.csv`.
pub const HEADER: &str = "case,resolution,variant,dx,particles,steps,error,wall_s,\
particle_steps_per_s,peak_rss_bytes,threads,timed,status";

/// One run of a sweep (a row of `sweep.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Case name.
    pub case: String,
    /// Cells across the case's length scale.
    pub resolution: u32,
    /// Variant name ([`Variant::name`]).
    pub variant: String,
    /// Particle spacing (m).
    pub dx: f64,
    /// Particles of the run.
    pub particles: u64,
    /// Steps taken.
    pub steps: u64,
    /// The case's error (a fraction; NaN when the run failed or measured none).
    pub error: f64,
    /// Wall time of the steps (s).
    pub wall_s: f64,
    /// Particle-steps per second.
    pub particle_steps_per_s: f64,
    /// Peak resident memory of the run's process (bytes; 0 where unknown).
    pub peak_rss_bytes: u64,
    /// Rayon threads of the run.
    pub threads: usize,
    /// True when the run had the machine to itself (`--jobs 1`): its cost is a measurement.
    pub timed: bool,
    /// `ok`, or why the run has no error (`failed (exit 1): ...`).
    pub status: String,
}

impl Row {
    /// The run finished and measured its error.
    pub fn ok(&self) -> bool {
        self.status == "ok"
    }

    /// Identifies the configuration: what resumption compares.
    pub fn key(&self) -> (String, u32, String) {
        (self.case.clone(), self.resolution, self.variant.clone())
    }

    /// The CSV line (no newline); commas and quotes in the status become `;` and `'`.
    pub fn to_csv(&self) -> String {
        let status = self.status.replace(',', ";").replace('"', "'").replace('\n', " ");
        format!(
            "{},{},{},{:e},{},{},{:e},{:.6},{:.1},{},{},{},{}",
            self.case,
            self.resolution,
            self.variant,
            self.dx,
            self.particles,
            self.steps,
            self.error,
            self.wall_s,
            self.particle_steps_per_s,
            self.peak_rss_bytes,
            self.threads,
            self.timed,
            status
        )
    }

    /// Parse a CSV line of [`Row::to_csv`].
    pub fn from_csv(line: &str) -> Option<Row> {
        let f: Vec<&str> = line.splitn(13, ',').collect();
        if f.len() != 13 {
            return None;
        }
        Some(Row {
            case: f[0].to_string(),
            resolution: f[1].parse().ok()?,
            variant: f[2].to_string(),
            dx: f[3].parse().ok()?,
            particles: f[4].parse().ok()?,
            steps: f[5].parse().ok()?,
            error: f[6].parse().ok()?,
            wall_s: f[7].parse().ok()?,
            particle_steps_per_s: f[8].parse().ok()?,
            peak_rss_bytes: f[9].parse().ok()?,
            threads: f[10].parse().ok()?,
            timed: f[11].parse().ok()?,
            status: f[12].to_string(),
        })
    }
}

/// The rows of `path` (none if it does not exist); a malformed line is exit 2 naming it.
pub fn read_rows(path: &Path) -> Result<Vec<Row>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::io(path, e)),
    };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h == HEADER => {}
        _ => {
            return Err(Error::input(
                path.display().to_string(),
                format!(
                    "is not a sweep of this hsph (its first line should be `{HEADER}`); choose another --out"
                ),
            ))
        }
    }
    lines
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(k, l)| {
            Row::from_csv(l).ok_or_else(|| {
                Error::input(
                    format!("{}:{}", path.display(), k + 1),
                    "is not a sweep row; delete the line to rerun that configuration".to_string(),
                )
            })
        })
        .collect()
}

/// Where and how the runs of a sweep go.
pub struct Runner {
    /// Output directory (`sweep.csv`, `runs/`, `scenes/`).
    pub out: PathBuf,
    /// Rayon threads per run.
    pub threads: usize,
    /// Runs at once; above 1 the costs are marked untimed.
    pub jobs: usize,
    /// Extra `--set` overrides for every run.
    pub set: Vec<String>,
    /// The hsph binary to run (this one).
    pub exe: PathBuf,
}

/// One configuration to run.
#[derive(Debug, Clone)]
pub struct Job {
    /// The case.
    pub case: Case,
    /// Resolution.
    pub n: u32,
    /// Variant.
    pub variant: Variant,
}

impl Job {
    /// Run directory name: `<case>-n<n>-<variant>`.
    pub fn dir_name(&self) -> String {
        format!("{}-n{}-{}", self.case.name, self.n, self.variant.name())
    }
}

impl Runner {
    /// Run every job whose configuration has no row in `sweep.csv` yet, appending rows as runs
    /// finish, then return all rows of the file. Progress goes to stderr. `None` if a
    /// stopping signal arrived: no further run was started, the running ones were forwarded
    /// the signal and waited for, and the stopped ones have no row (a second sweep runs them).
    pub fn run(&self, jobs: &[Job]) -> Result<Option<Vec<Row>>> {
        super::stop::install()?;
        std::fs::create_dir_all(self.out.join("runs")).map_err(|e| Error::io(&self.out, e))?;
        std::fs::create_dir_all(self.out.join("scenes")).map_err(|e| Error::io(&self.out, e))?;
        let csv = self.out.join("sweep.csv");
        let done: BTreeSet<_> = read_rows(&csv)?.iter().map(Row::key).collect();
        if !csv.exists() {
            crate::output::write_file(&csv, format!("{HEADER}\n").as_bytes())?;
        }
        let todo: Vec<&Job> = jobs
            .iter()
            .filter(|j| !done.contains(&(j.case.name.to_string(), j.n, j.variant.name())))
            .collect();
        let skipped = jobs.len() - todo.len();
        if skipped > 0 {
            eprintln!(
                "hsph validate: {skipped} configuration(s) already in {} (not rerun)",
                csv.display()
            );
        }
        let queue = crossbeam::queue::SegQueue::new();
        todo.iter().enumerate().for_each(|j| queue.push(j));
        let file = std::sync::Mutex::new(
            std::fs::OpenOptions::new()
                .append(true)
                .open(&csv)
                .map_err(|e| Error::io(&csv, e))?,
        );
        let total = todo.len();
        let failed: std::sync::Mutex<Option<Error>> = std::sync::Mutex::new(None);
        std::thread::scope(|s| {
            for _ in 0..self.jobs.max(1) {
                s.spawn(|| {
                    while let Some((k, job)) = queue.pop() {
                        if super::stop::stopping() {
                            return;
                        }
                        let row = match self.run_one(job) {
                            Ok(Some(r)) => r,
                            Ok(None) => {
                                eprintln!(
                                    "hsph validate: [{}/{total}] {}: stopped by {} (not recorded; it runs again when the sweep resumes)",
                                    k + 1,
                                    job.dir_name(),
                                    super::stop::name()
                                );
                                return;
                            }
                            Err(e) => {
                                failed.lock().expect("no panics").get_or_insert(e);
                                return;
                            }
                        };
                        eprintln!(
                            "hsph validate: [{}/{total}] {}: error {} in {:.1} s ({})",
                            k + 1,
                            job.dir_name(),
                            fmt_error(row.error),
                            row.wall_s,
                            row.status
                        );
                        let mut f = file.lock().expect("no panics");
                        if let Err(e) = writeln!(f, "{}", row.to_csv()).and_then(|_| f.flush()) {
                            failed
                                .lock()
                                .expect("no panics")
                                .get_or_insert(Error::io(&csv, e));
                            return;
                        }
                    }
                });
            }
        });
        if let Some(e) = failed.into_inner().expect("no panics") {
            return Err(e);
        }
        if super::stop::stopping() {
            return Ok(None);
        }
        read_rows(&csv).map(Some)
    }

    /// Run one configuration as a child `hsph run` and read its `summary.json`; `None` if a
    /// signal stopped it.
    fn run_one(&self, job: &Job) -> Result<Option<Row>> {
        let (file, text) = job.case.scene_for(&job.variant);
        let stem = std::path::Path::new(file)
            .file_stem()
            .map_or(job.case.name.into(), |s| s.to_string_lossy());
        let scene = self.out.join("scenes").join(format!("{stem}.toml"));
        if !scene.exists() {
            crate::output::write_file(&scene, text.as_bytes())?;
        }
        let dir = self.out.join("runs").join(job.dir_name());
        let sets: Vec<String> = job
            .case
            .sets(job.n, &job.variant)
            .into_iter()
            .chain(self.set.iter().cloned())
            .collect();
        let Some(out) = run_child(&self.exe, &scene, &dir, self.threads, &sets)? else {
            return Ok(None);
        };
        let mut row = Row {
            case: job.case.name.to_string(),
            resolution: job.n,
            variant: job.variant.name(),
            dx: job.case.length / job.n as f64,
            particles: 0,
            steps: 0,
            error: f64::NAN,
            wall_s: f64::NAN,
            particle_steps_per_s: f64::NAN,
            peak_rss_bytes: 0,
            threads: self.threads,
            timed: self.jobs <= 1,
            status: "ok".into(),
        };
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            let first = err.lines().rev().find(|l| l.starts_with("hsph:")).unwrap_or("");
            row.status = format!("failed (exit {}): {first}", out.status.code().unwrap_or(-1));
            if out.status.code() == Some(2) {
                // a configuration the scene rejects is a bug of the case, not a result
                return Err(Error::run(format!(
                    "validate: case {} rejected configuration {}: {first}",
                    job.case.name,
                    job.dir_name()
                )));
            }
            return Ok(Some(row));
        }
        // the child's summary is read as every summary is: bounded, its numbers checked
        let s = crate::limits::read_summary(&dir.join("summary.json"))?;
        row.particles = s["particles"].as_u64().unwrap_or(0);
        row.steps = s["steps"].as_u64().unwrap_or(0);
        row.wall_s = s["wall_s"].as_f64().unwrap_or(f64::NAN);
        row.particle_steps_per_s = s["particle_steps_per_s"].as_f64().unwrap_or(f64::NAN);
        row.peak_rss_bytes = s["peak_rss_bytes"].as_u64().unwrap_or(0);
        match error_of(&s["errors"], job.case.error_key) {
            Some(e) => row.error = e,
            None => row.status = format!("no error `{}` measured", job.case.error_key),
        }
        Ok(Some(row))
    }
}

/// Run `exe run scene --out dir --force --quiet --threads T --set …` to its end and return
/// its output (exit status, stdout, stderr); `None` if a stopping signal reached this process
/// meanwhile and the child stopped for it (exit 3, or killed by it): the configuration is to
/// be run again, not recorded. The signal is forwarded to the child ([`super::stop`]).
pub fn run_child(
    exe: &Path,
    scene: &Path,
    dir: &Path,
    threads: usize,
    sets: &[String],
) -> Result<Option<std::process::Output>> {
    let mut cmd = Command::new(exe);
    cmd.arg("run").arg(scene).arg("--out").arg(dir).args([
        "--force",
        "--quiet",
        "--threads",
        &threads.to_string(),
    ]);
    for s in sets {
        cmd.args(["--set", s]);
    }
    let out = super::stop::Child::spawn(cmd, exe)?.wait()?;
    let stopped = out
        .status
        .code()
        .is_none_or(|c| c == crate::signals::EXIT_STOPPED);
    Ok((!(super::stop::stopping() && stopped)).then_some(out))
}

/// The error named `key` in `summary.json`'s `errors`; a key ending in `*` takes the entry
/// with that prefix and the largest number after it (the last time measured).
pub fn error_of(errors: &serde_json::Value, key: &str) -> Option<f64> {
    let map = errors.as_object()?;
    match key.strip_suffix('*') {
        None => map.get(key)?.as_f64(),
        Some(prefix) => map
            .iter()
            .filter_map(|(k, v)| Some((k.strip_prefix(prefix)?.parse::<f64>().ok()?, v.as_f64()?)))
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, v)| v),
    }
}

/// An error as a percentage with three significant figures, or `—`.
pub fn fmt_error(e: f64) -> String {
    if e.is_finite() {
        format!("{:.3} %", 100.0 * e)
    } else {
        "—".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_survive_the_csv() {
        let r = Row {
            case: "poiseuille".into(),
            resolution: 25,
            variant: "quintic_spline-h1.0-dummy-none".into(),
            dx: 4e-5,
            particles: 1234,
            steps: 99,
            error: 0.0028,
            wall_s: 1.5,
            particle_steps_per_s: 1e6,
            peak_rss_bytes: 4096,
            threads: 1,
            timed: true,
            status: "failed (exit 1): a, \"b\"".into(),
        };
        let back = Row::from_csv(&r.to_csv()).unwrap();
        assert_eq!(back.status, "failed (exit 1): a; 'b'");
        assert_eq!(
            Row {
                status: r.status.clone(),
                ..back
            },
            r
        );
        assert!(Row::from_csv("a,b").is_none());
    }

    #[test]
    fn a_starred_key_takes_the_last_time() {
        let e = serde_json::json!({"velocity_linf_t0.6": 0.5, "velocity_linf_t2": 0.01, "other": 9.0});
        assert_eq!(error_of(&e, "velocity_linf_t*"), Some(0.01));
        assert_eq!(error_of(&e, "other"), Some(9.0));
        assert_eq!(error_of(&e, "missing"), None);
    }
}
