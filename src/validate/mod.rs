//! `hsph validate`: run validation cases at several resolutions and method variants, record
//! each run's error against its reference and its cost, chart one against the other, and name
//! the cheapest configuration that meets a target error.
//!
//! Every run is a child `hsph run` of a shipped scene with `--set` overrides
//! ([`cases::Case::overrides`]), so its resolved `scene.toml` is a scene a user can run again
//! (`--write`). Rows go to `<out>/sweep.csv` as runs finish; a sweep run again skips the
//! configurations already there.

pub mod cases;
pub mod charts;
pub mod front;
pub mod lattice;
pub mod map;
pub mod stop;
pub mod sweep;

use crate::error::{Error, Result};
use cases::{Case, Variant};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use sweep::{fmt_error, Job, Row, Runner};

/// What `hsph validate` was asked to do.
#[derive(Debug, Clone)]
pub struct Options {
    /// Case names (empty: every case).
    pub cases: Vec<String>,
    /// Sweep the method variants (otherwise the shipped scene's method only).
    pub sweep: bool,
    /// Resolutions to run (empty: each case's own).
    pub resolutions: Vec<u32>,
    /// Variant names to run (empty: per `sweep`).
    pub variants: Vec<String>,
    /// Output directory.
    pub out: PathBuf,
    /// Runs at once (above 1: costs marked untimed).
    pub jobs: usize,
    /// Rayon threads per run.
    pub threads: usize,
    /// `--set` overrides for every run.
    pub set: Vec<String>,
    /// Error (fraction) the cheapest configuration must meet.
    pub target: Option<f64>,
    /// Where to write that configuration's scene.
    pub write: Option<PathBuf>,
    /// Stability studies to map (`Some(empty)`: all of them).
    pub map: Option<Vec<String>>,
}

/// The stability map of `--map`'s studies, into `--out`.
fn run_map(opts: &Options) -> Result<i32> {
    let names = opts.map.clone().unwrap_or_default();
    std::fs::create_dir_all(&opts.out).map_err(|e| Error::io(&opts.out, e))?;
    stability(&names, &opts.out)
}

/// `--jobs`, `--threads` and `--resolutions` within the limits (exit 2 naming the flag).
fn check_flags(opts: &Options) -> Result<()> {
    use crate::limits::{count, MAX_JOBS, MAX_RESOLUTION, MAX_THREADS};
    count("--jobs", opts.jobs as u64, MAX_JOBS as u64)?;
    count("--threads", opts.threads as u64, MAX_THREADS as u64)?;
    for &n in &opts.resolutions {
        count("--resolutions", n as u64, MAX_RESOLUTION as u64)?;
    }
    Ok(())
}

/// A configuration's scene, loaded with its overrides and the user's `--set` and checked
/// against the limits, before any child run starts: bad input is exit 2 here, naming the key,
/// not a failed run (exit 1) later.
fn check_job(job: &Job, set: &[String]) -> Result<()> {
    let (file, text) = job.case.scene_for(&job.variant);
    let sets: Vec<String> = job
        .case
        .sets(job.n, &job.variant)
        .into_iter()
        .chain(set.iter().cloned())
        .collect();
    let (scene, _) = crate::scene::load_scene_str(text, Path::new(file), job.case.name, &sets)?;
    let opts = crate::driver::RunOptions {
        max_memory: Some(f64::INFINITY),
        ..Default::default()
    };
    crate::driver::check_limits(&scene, 1, 1, &opts).map_err(|e| match e {
        Error::Input { at, key, message } => Error::Input {
            at,
            key,
            message: format!("{message} (case {} at resolution {})", job.case.name, job.n),
        },
        e => e,
    })?;
    Ok(())
}

/// The configurations `opts` asks of `case`: an exit-2 error names an unknown variant.
fn jobs_of(case: &Case, opts: &Options) -> Result<Vec<Job>> {
    let pool: Vec<Variant> = (case.sweep)();
    let chosen: Vec<Variant> = if !opts.variants.is_empty() {
        opts.variants
            .iter()
            .map(|name| {
                pool.iter().find(|v| &v.name() == name).cloned().ok_or_else(|| {
                    let known: Vec<String> = pool.iter().map(Variant::name).collect();
                    Error::input(
                        "--variants",
                        format!(
                            "case {} has no variant `{name}`; its variants: {}",
                            case.name,
                            known.join(", ")
                        ),
                    )
                })
            })
            .collect::<Result<_>>()?
    } else if opts.sweep {
        pool
    } else {
        vec![case.default.clone()]
    };
    let resolutions = if opts.resolutions.is_empty() {
        case.resolutions.to_vec()
    } else {
        opts.resolutions.clone()
    };
    Ok(chosen
        .iter()
        .flat_map(|v| {
            resolutions.iter().map(move |&n| Job {
                case: case.clone(),
                n,
                variant: v.clone(),
            })
        })
        .collect())
}

/// Check that `out` holds no sweep made with other `--set` overrides (their rows would not
/// compare), recording this one's in `<out>/overrides.txt`.
fn same_overrides(out: &Path, set: &[String]) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let path = out.join("overrides.txt");
    let mine = set.join("\n");
    match std::fs::read_to_string(&path) {
        Ok(old) if old.trim_end() != mine.trim_end() => Err(Error::input(
            "--set",
            format!(
                "{} holds a sweep made with other overrides ({}); use another --out or the same --set",
                out.display(),
                if old.trim().is_empty() {
                    "none".to_string()
                } else {
                    old.trim().replace('\n', ", ")
                }
            ),
        )),
        Ok(_) => Ok(()),
        Err(_) => crate::output::write_file(&path, format!("{mine}\n").as_bytes()),
    }
}

/// Run the stability studies of `names` (all if empty) into `out`: `map.csv`, a chart per
/// study and `map.md`.
fn stability(names: &[String], out: &Path) -> Result<i32> {
    let studies: Vec<map::Study> = if names.is_empty() {
        map::all()
    } else {
        names
            .iter()
            .map(|n| map::find(n).map_err(|m| Error::input("--map", m)))
            .collect::<Result<_>>()?
    };
    let exe =
        std::env::current_exe().map_err(|e| Error::run(format!("validate: cannot find this hsph: {e}")))?;
    let mut md = String::from("# hsph validate --map: where each method fails\n\n");
    for st in &studies {
        let Some(cells) = map::run(st, out, &exe)? else {
            return Ok(stopped(out));
        };
        let files = charts::stability_map(out, st, &cells)?;
        let _ = writeln!(
            md,
            "## {}\n\nScene `{}`; rows: methods; columns: {}.\n",
            st.title, st.file, st.parameter
        );
        md.push_str("| method | ");
        md.push_str(
            &st.values
                .iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join(" | "),
        );
        md.push_str(" |\n|---|");
        md.push_str(&"---|".repeat(st.values.len()));
        md.push('\n');
        for (m, _) in &st.methods {
            let _ = write!(md, "| {m} |");
            for v in &st.values {
                let c = cells.iter().find(|c| c.method == *m && c.value == *v);
                let text = match c {
                    None => "not run".to_string(),
                    Some(c) => {
                        let metric = if c.metric.is_finite() {
                            format!(" ({}: {})", st.metric_name(), map::show_metric(c.metric))
                        } else {
                            String::new()
                        };
                        match &c.reason {
                            None => format!("stable{metric}"),
                            Some(r) => format!("**{r}** at {:.4} s{metric}", c.t_fail),
                        }
                    }
                };
                let _ = write!(md, " {text} |");
            }
            md.push('\n');
        }
        for f in files.iter().filter(|f| f.extension().is_some_and(|e| e == "png")) {
            let name = f
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            let _ = writeln!(md, "\n![{name}]({name})");
        }
        md.push('\n');
    }
    let path = out.join("map.md");
    crate::output::write_file(&path, md.as_bytes())?;
    eprintln!("hsph validate: stability map in {}", path.display());
    Ok(0)
}

/// Run `hsph validate`; returns the exit status (0, or 1 when `--target` is met by no run).
pub fn command(opts: &Options) -> Result<i32> {
    check_flags(opts)?;
    if opts.map.is_some() && opts.cases.is_empty() {
        // the stability map runs its own studies: the case flags would be silently ignored
        let case_only = [
            ("--set", !opts.set.is_empty()),
            ("--variants", !opts.variants.is_empty()),
            ("--resolutions", !opts.resolutions.is_empty()),
            ("--sweep", opts.sweep),
            ("--target", opts.target.is_some()),
            ("--write", opts.write.is_some()),
        ];
        if let Some((flag, _)) = case_only.iter().find(|(_, given)| *given) {
            return Err(Error::input(
                *flag,
                "applies to validation cases, not to --map's studies; name a case too, e.g. \
                 hsph validate poiseuille --map",
            ));
        }
        return run_map(opts);
    }
    let cases: Vec<Case> = if opts.cases.is_empty() {
        cases::all()
    } else {
        opts.cases
            .iter()
            .map(|c| cases::find(c).map_err(|m| Error::input("CASE", m)))
            .collect::<Result<_>>()?
    };
    if opts.write.is_some() && opts.target.is_none() {
        return Err(Error::input(
            "--write",
            "needs --target ERROR (the error the written scene must meet)".to_string(),
        ));
    }
    if let Some(t) = opts.target {
        if !(t > 0.0 && t.is_finite()) || cases.len() != 1 {
            return Err(Error::input(
                "--target",
                format!("needs one case and a positive error (a fraction: 0.005 is 0.5 %), got {t} for {} case(s)", cases.len()),
            ));
        }
    }
    if let Some(w) = &opts.write {
        crate::output::refuse_non_regular(w)?;
    }
    let mut jobs = Vec::new();
    for c in &cases {
        jobs.extend(jobs_of(c, opts)?);
    }
    for job in &jobs {
        check_job(job, &opts.set)?;
    }
    if opts.map.is_some() {
        let status = run_map(opts)?;
        if status != 0 {
            return Ok(status);
        }
    }
    same_overrides(&opts.out, &opts.set)?;
    let exe =
        std::env::current_exe().map_err(|e| Error::run(format!("validate: cannot find this hsph: {e}")))?;
    let runner = Runner {
        out: opts.out.clone(),
        threads: opts.threads.max(1),
        jobs: opts.jobs.max(1),
        set: opts.set.clone(),
        exe,
    };
    let Some(rows) = runner.run(&jobs)? else {
        return Ok(stopped(&opts.out));
    };
    let mut md = String::from("# hsph validate\n\n");
    for c in &cases {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.case == c.name).collect();
        let mut files = charts::cost_error(&opts.out, c.name, &mine)?;
        files.extend(charts::convergence(&opts.out, c.name, &mine)?);
        md.push_str(&case_markdown(c, &mine));
        for f in files.iter().filter(|f| f.extension().is_some_and(|e| e == "png")) {
            let name = f
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            let _ = writeln!(md, "![{name}]({name})\n");
        }
    }
    let path = opts.out.join("validate.md");
    crate::output::write_file(&path, md.as_bytes())?;
    eprintln!(
        "hsph validate: {} rows in {}; charts and validate.md beside it",
        rows.len(),
        opts.out.join("sweep.csv").display()
    );
    match opts.target {
        None => Ok(0),
        Some(t) => target(&cases[0], &rows, t, &opts.out, opts.write.as_deref()),
    }
}

/// Say that a signal stopped the sweep in `out` and how to resume it; the exit status of a
/// stopped command.
fn stopped(out: &Path) -> i32 {
    eprintln!(
        "hsph validate: stopped by {}: every run it started has ended; finished configurations are in \
         {}; run the same command again to resume (the stopped configurations run again)",
        stop::name(),
        out.join("sweep.csv").display()
    );
    crate::signals::EXIT_STOPPED
}

/// The markdown of one case: its norm, a row per run (front runs marked), convergence orders.
fn case_markdown(c: &Case, rows: &[&Row]) -> String {
    let mut s = format!("## {} (`{}`)\n\nError: {}.\n\n", c.name, c.file, c.norm);
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| {
            if r.ok() {
                (r.wall_s, r.error)
            } else {
                (f64::NAN, f64::NAN)
            }
        })
        .collect();
    let front = front::pareto(&pts);
    s.push_str("| variant | n | dx (m) | particles | error | wall (s) | particle-steps/s | peak RSS | front | status |\n");
    s.push_str("|---|---|---|---|---|---|---|---|---|---|\n");
    for (i, r) in rows.iter().enumerate() {
        let _ = writeln!(
            s,
            "| {} | {} | {:.3e} | {} | {} | {:.2} | {:.3e} | {} | {} | {} |",
            r.variant,
            r.resolution,
            r.dx,
            r.particles,
            fmt_error(r.error),
            r.wall_s,
            r.particle_steps_per_s,
            crate::report::human_bytes(r.peak_rss_bytes as f64),
            if front.contains(&i) { "●" } else { "" },
            r.status
        );
    }
    let mut names: Vec<&str> = Vec::new();
    rows.iter().for_each(|r| {
        if !names.contains(&r.variant.as_str()) {
            names.push(&r.variant)
        }
    });
    s.push_str("\nConvergence order p of error ≈ c·dxᵖ (least squares on log–log):\n\n");
    for n in names {
        let pairs: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.variant == n && r.ok())
            .map(|r| (r.dx, r.error))
            .collect();
        let p = front::convergence_order(&pairs).map_or("—".to_string(), |(p, _)| format!("{p:.2}"));
        let _ = writeln!(s, "- {n}: {p}");
    }
    s.push('\n');
    s
}

/// Name the cheapest successful run of `case` whose error is at most `t`, and with `write`
/// copy its resolved scene there; exit status 1 if no run met it.
fn target(case: &Case, rows: &[Row], t: f64, out: &Path, write: Option<&Path>) -> Result<i32> {
    let best = rows
        .iter()
        .filter(|r| r.case == case.name && r.ok() && r.error <= t)
        .min_by(|a, b| a.wall_s.total_cmp(&b.wall_s).then(a.particles.cmp(&b.particles)));
    let Some(r) = best else {
        let lowest = rows
            .iter()
            .filter(|r| r.case == case.name && r.ok())
            .map(|r| r.error)
            .fold(f64::INFINITY, f64::min);
        eprintln!(
            "hsph validate: no run of {} met {} (the lowest error is {}); sweep finer resolutions (--resolutions) or more variants (--sweep)",
            case.name,
            fmt_error(t),
            fmt_error(lowest)
        );
        return Ok(1);
    };
    let dir = out
        .join("runs")
        .join(format!("{}-n{}-{}", r.case, r.resolution, r.variant));
    println!(
        "cheapest configuration of {} with error ≤ {}: variant {} at n = {} (dx = {:.3e} m): error {}, {:.2} s wall on {} thread(s), {:.3e} particle-steps/s, peak RSS {}; scene {}",
        case.name,
        fmt_error(t),
        r.variant,
        r.resolution,
        r.dx,
        fmt_error(r.error),
        r.wall_s,
        r.threads,
        r.particle_steps_per_s,
        crate::report::human_bytes(r.peak_rss_bytes as f64),
        dir.join("scene.toml").display()
    );
    if let Some(w) = write {
        let src = dir.join("scene.toml");
        let text = std::fs::read(&src).map_err(|e| Error::io(&src, e))?;
        crate::output::write_file(w, &text)?;
        println!("wrote {}", w.display());
    }
    Ok(0)
}
