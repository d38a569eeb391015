//! `hsph bench`: particle-steps/s and pair interactions/s of scenes at given thread counts.
//!
//! Each measurement builds the scene, takes 5 warm-up steps, then times `steps` steps of the
//! step loop with no output; it is repeated `repeat` times and the median is reported, since
//! these machines are shared and noisy. Particle-steps count every particle, walls included.

use crate::comm::serial::SerialComm;
use crate::driver::pool;
use crate::error::Result;
use crate::scene::load_scene;
use crate::sim::Simulation;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to measure.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Thread counts.
    pub threads: Vec<usize>,
    /// Timed steps per measurement.
    pub steps: u64,
    /// Repetitions (median reported).
    pub repeat: usize,
    /// `--set` overrides applied to every scene.
    pub overrides: Vec<String>,
    /// Typed flags applied to every scene (`--interactions`, `--neighbours`).
    pub flags: crate::scene::SceneFlags,
}

/// One measured row.
#[derive(Debug, Clone)]
pub struct BenchRow {
    /// Scene name.
    pub scene: String,
    /// Particles (fluid + wall).
    pub particles: usize,
    /// Rayon threads.
    pub threads: usize,
    /// Median particle-steps per second.
    pub particle_steps_per_s: f64,
    /// Median pair interactions per second (directed neighbour-list entries × passes).
    pub pairs_per_s: f64,
    /// Median microseconds per particle-step.
    pub us_per_particle_step: f64,
}

/// The scenes `hsph bench` times by default (README, "Commands": `bench`).
pub fn default_scenes() -> Vec<PathBuf> {
    ["inputs/dam_break_2d_dsph.toml", "inputs/dam_break_3d_bench.toml"]
        .iter()
        .map(PathBuf::from)
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Measure every scene at every thread count.
pub fn run(scenes: &[PathBuf], o: &BenchOptions) -> Result<Vec<BenchRow>> {
    let mut rows = Vec::new();
    for path in scenes {
        let (mut scene, mut src) = load_scene(path, &o.overrides)?;
        o.flags.apply(&mut scene, &mut src)?;
        // steps are timed from the set-up's lattice: a settling would only delay them
        scene.time.settle = 0.0;
        for &t in &o.threads {
            let row = crate::with_dim!(scene.dimension, D => measure::<D>(path, &scene, t, o))?;
            eprintln!(
                "hsph bench: {} × {} threads: {:.3e} particle-steps/s, {:.3} µs/particle-step",
                row.scene, row.threads, row.particle_steps_per_s, row.us_per_particle_step
            );
            rows.push(row);
        }
    }
    Ok(rows)
}

fn measure<const D: usize>(
    _path: &Path,
    scene: &crate::scene::Scene,
    threads: usize,
    o: &BenchOptions,
) -> Result<BenchRow> {
    let pool = pool(threads)?;
    let threads = pool.current_num_threads();
    let mut rates = Vec::new();
    let mut pair_rates = Vec::new();
    let mut particles = 0;
    for _ in 0..o.repeat.max(1) {
        let r = pool.install(|| -> Result<(f64, f64, usize)> {
            let comm = SerialComm::new();
            let mut sim = Simulation::<D>::new(scene, &comm)?;
            for _ in 0..5 {
                sim.advance(&comm)?;
            }
            let pairs0 = sim.pair_count;
            let start = Instant::now();
            for _ in 0..o.steps {
                sim.advance(&comm)?;
            }
            let wall = start.elapsed().as_secs_f64();
            let n = sim.n_particles();
            Ok((
                n as f64 * o.steps as f64 / wall,
                (sim.pair_count - pairs0) as f64 / wall,
                n,
            ))
        })?;
        rates.push(r.0);
        pair_rates.push(r.1);
        particles = r.2;
    }
    let ps = median(rates);
    Ok(BenchRow {
        scene: scene.name.clone(),
        particles,
        threads,
        particle_steps_per_s: ps,
        pairs_per_s: median(pair_rates),
        us_per_particle_step: 1e6 / ps,
    })
}

/// A markdown table of rows.
pub fn table(rows: &[BenchRow]) -> String {
    let mut s = String::from(
        "| scene | particles | threads | particle-steps/s | µs/particle-step | pair interactions/s |\n\
         |---|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {:.3e} | {:.3} | {} |\n",
            r.scene,
            r.particles,
            r.threads,
            r.particle_steps_per_s,
            r.us_per_particle_step,
            // the list-free scan (`neighbours = "cells"`) counts no list entries
            if r.pairs_per_s > 0.0 {
                format!("{:.3e}", r.pairs_per_s)
            } else {
                "— (no lists)".to_string()
            }
        ));
    }
    s
}
