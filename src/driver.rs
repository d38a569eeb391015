//! Running a scene end to end: thread pool, step loop, output schedule, references, summary.

use crate::error::{Error, Result};
use crate::output::{self, RunWriter};
use crate::progress::Progress;
use crate::reference::Tracker;
use crate::scene::Scene;
use crate::sim::{Simulation, PHASES};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How to run.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Output directory (default `runs/<scene>-<timestamp>`).
    pub out: Option<PathBuf>,
    /// Overwrite a non-empty output directory.
    pub force: bool,
    /// Rayon threads per rank (0 = one per core).
    pub threads: usize,
    /// No progress output.
    pub quiet: bool,
}

/// What a finished run reports.
#[derive(Debug, Clone)]
pub struct RunOutcome {
    /// The run directory.
    pub dir: PathBuf,
    /// The summary written to `summary.json`.
    pub summary: serde_json::Value,
    /// Named relative errors against the scene's reference.
    pub errors: BTreeMap<String, f64>,
}

/// Build a rayon pool of `threads` threads (0 = available cores).
pub fn pool(threads: usize) -> Result<rayon::ThreadPool> {
    let n = if threads == 0 {
        std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
    } else {
        threads
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| Error::run(format!("cannot start {n} threads: {e}")))
}

/// Run a validated scene. The output directory is prepared first; `summary.json` is written
/// only when the run completes.
pub fn run_scene(scene: &Scene, opts: &RunOptions) -> Result<RunOutcome> {
    let dir = output::prepare_dir(opts.out.as_deref(), &scene.name, opts.force)?;
    let pool = pool(opts.threads)?;
    let threads = pool.current_num_threads();
    pool.install(|| match scene.dimension {
        2 => run_dim::<2>(scene, &dir, threads, opts.quiet),
        3 => run_dim::<3>(scene, &dir, threads, opts.quiet),
        d => Err(Error::input("dimension", format!("must be 2 or 3, got {d}"))),
    })
}

fn run_dim<const D: usize>(scene: &Scene, dir: &Path, threads: usize, quiet: bool) -> Result<RunOutcome> {
    let mut sim = Simulation::<D>::new(scene)?;
    let mut writer = RunWriter::new(dir, &sim.scene)?;
    let mut tracker = Tracker::default();
    if !quiet {
        let n_fluid = sim.p.kind[..sim.p.n_owned]
            .iter()
            .filter(|k| **k == crate::particles::Kind::Fluid)
            .count();
        eprintln!(
            "hsph: {} ({}D), {} particles ({} fluid, {} wall), 1 rank × {threads} thread(s), dt₀ = {:.3e} s, output in {}",
            scene.name,
            D,
            sim.n_particles(),
            n_fluid,
            sim.n_particles() - n_fluid,
            sim.dt,
            dir.display()
        );
    }
    let loop_start = Instant::now();
    let t0 = Instant::now();
    writer.output_step(&sim, 0.0)?;
    tracker.at_output(&sim);
    sim.timers.add(4, t0);
    let interval = scene.output.interval;
    let mut next_out = interval;
    let mut progress = Progress::new(sim.n_particles(), quiet);
    let t_output_total_before = sim.timers.seconds[4];
    while !sim.done() {
        sim.advance()?;
        tracker.after_step(&sim);
        if sim.t >= next_out * (1.0 - 1e-12) || sim.done() {
            let t0 = Instant::now();
            while next_out <= sim.t * (1.0 + 1e-12) {
                next_out += interval;
            }
            writer.output_step(&sim, loop_start.elapsed().as_secs_f64())?;
            tracker.at_output(&sim);
            sim.timers.add(4, t0);
        }
        progress.update(sim.step, sim.t, scene.time.t_end);
    }
    progress.finish();
    let wall = loop_start.elapsed().as_secs_f64();
    let _ = t_output_total_before;
    tracker.finish(&sim);
    writer.finish(&sim)?;
    let n = sim.n_particles();
    let steps = sim.step;
    let timers: serde_json::Map<String, serde_json::Value> = PHASES
        .iter()
        .zip(sim.timers.seconds.iter())
        .map(|(k, v)| (format!("{k}_s"), json!(v)))
        .collect();
    let errors: serde_json::Map<String, serde_json::Value> = tracker
        .errors
        .iter()
        .map(|(k, v)| (k.clone(), json!(v)))
        .collect();
    let n_fluid = sim.p.kind[..n]
        .iter()
        .filter(|k| **k == crate::particles::Kind::Fluid)
        .count();
    let summary = json!({
        "hsph_version": env!("CARGO_PKG_VERSION"),
        "scene": scene.name,
        "dimension": D,
        "particles": n,
        "fluid_particles": n_fluid,
        "wall_particles": n - n_fluid,
        "steps": steps,
        "t_end": scene.time.t_end,
        "t": sim.t,
        "wall_s": wall,
        "particle_steps_per_s": if wall > 0.0 { n as f64 * steps as f64 / wall } else { 0.0 },
        "pair_interactions_per_s": if wall > 0.0 { sim.pair_count as f64 / wall } else { 0.0 },
        "threads": threads,
        "ranks": 1,
        "backend": "serial",
        "timers": timers,
        "errors": errors,
    });
    output::write_summary(dir, &summary)?;
    if !quiet {
        eprintln!(
            "hsph: done: {steps} steps in {wall:.2} s ({:.3e} particle-steps/s); results in {}",
            n as f64 * steps as f64 / wall.max(1e-12),
            dir.display()
        );
        for (k, v) in &tracker.errors {
            eprintln!("hsph: error {k} = {:.4} %", v * 100.0);
        }
    }
    Ok(RunOutcome {
        dir: dir.to_path_buf(),
        summary,
        errors: tracker.errors,
    })
}
