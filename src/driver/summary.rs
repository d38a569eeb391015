//! The end of a run: the final gather and `final.csv`, `summary.json` (figures, timers,
//! traffic, memory, the settled hole, build provenance) and the closing log lines.

use super::diagnostics::{reduce, Reduced};
use super::provenance::provenance;
use super::rank::RankRun;
use super::traffic::log_traffic;
use super::RunOutcome;
use crate::comm::Comm;
use crate::error::{Error, Result};
use crate::output;
use crate::output::snapshot::Piece;
use crate::physics::passes;
use crate::sim::{Simulation, Timer, View, PHASES};
use crate::topology::{Topology, DEFAULT_COST};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::Path;

impl<'a, const D: usize> RankRun<'a, D> {
    /// Final gather, `final.csv` and `summary.json` (rank 0), the closing log lines.
    pub(super) fn finish(mut self) -> Result<RunOutcome> {
        let wall = self.steps_start.elapsed().as_secs_f64();
        // the step loop's peak, before the final gather adds its copy of the particles
        self.loop_peak = crate::memory::peak_rss();
        if self.scene.checkpoint.scheduled() && self.checkpointed != self.sim.step {
            // a finished run can be continued to a later t_end
            self.checkpoint()?;
        }
        self.probes.flush()?;
        let r = reduce(&self.sim, self.comm, Some(self.setup_peak))?;
        let p = &self.sim.p;
        let kinds = &p.kind[..p.n_owned];
        let mut n_fluid = [
            kinds.iter().filter(|k| k.is_fluid()).count() as u64,
            kinds.iter().filter(|k| k.is_solid()).count() as u64,
        ];
        self.comm.all_reduce_sum_u64(&mut n_fluid)?;
        // final.csv gathered on rank 0 up to `output.gather_limit` particles, else per rank
        let gathered = self.n_total <= self.scene.output.gather_limit;
        if gathered {
            // free the step's memory; one rank lends its table to the final view
            self.sim.settle_for_gather();
        }
        let final_view = final_state(&self.sim, self.comm, self.dir, gathered)?;
        let mut writer = self.writer.take();
        log_traffic(
            self.comm,
            writer.as_mut(),
            &mut self.totals,
            &self.layout.node_of,
            self.sim.step,
        )?;
        let Some(mut writer) = writer else {
            return Ok(RunOutcome {
                dir: self.dir.to_path_buf(),
                summary: serde_json::Value::Null,
                errors: BTreeMap::new(),
                stopped_by: self.stopped_by,
            });
        };
        writer.flush()?;
        writer.mirror_series(&self.probes.files())?;
        self.tracker
            .from_probe_files(self.scene, &self.dir.join("probes"));
        if let Some(view) = final_view {
            self.tracker.finish(&view);
            output::write_final(&self.dir.join("final.csv"), &view.p, &view.by_id())?;
        } else if self.scene.reference.is_some() {
            eprintln!(
                "hsph: warning: {} particles exceed output.gather_limit = {}: the reference errors \
                 that need the whole final state are not measured",
                self.n_total, self.scene.output.gather_limit
            );
        }
        // one final state: the other form's files, from a run with another gather_limit, go
        output::names::remove_other_final(self.dir, gathered)?;
        let summary = self.summary(&r, wall, n_fluid[0] as usize, n_fluid[1] as usize);
        output::write_summary(self.dir, &summary)?;
        self.closing_lines(wall);
        Ok(RunOutcome {
            dir: self.dir.to_path_buf(),
            summary,
            errors: std::mem::take(&mut self.tracker.errors),
            stopped_by: self.stopped_by,
        })
    }

    /// The closing log lines (rank 0): why the run stopped early, or its rate and the
    /// reference's measured values and errors.
    fn closing_lines(&self, wall: f64) {
        if let Some(sig) = self.stopped_by {
            // said even with -q: the run did not finish
            eprintln!(
                "hsph: stopped by {sig} after step {} (t = {:.6e} s of {} s); every CSV is complete up \
                 to the last output step, final.csv holds this step, summary.json says \"complete\": false; \
                 results in {}",
                self.sim.step,
                self.sim.t,
                self.scene.time.t_end,
                self.dir.display()
            );
        } else if !self.quiet {
            eprintln!(
                "hsph: done: {} steps in {wall:.2} s ({:.3e} particle-steps/s); results in {}",
                self.sim.step,
                self.particle_steps / wall.max(1e-12),
                self.dir.display()
            );
            for (k, v) in &self.tracker.measured {
                eprintln!("hsph: measured {k} = {v:.6}");
            }
            for (k, v) in &self.tracker.errors {
                eprintln!("hsph: error {k} = {:.4} %", v * 100.0);
            }
        }
    }

    /// The settled hole of the scene's hole probe, read back from its file on rank 0 (the
    /// whole history, across restarts); null without one.
    fn hole_summary(&self) -> serde_json::Value {
        let Some(name) = self
            .scene
            .probes
            .iter()
            .find_map(|p| p.hole_bodies().map(|_| p.name()))
        else {
            return serde_json::Value::Null;
        };
        let path = self.dir.join("probes").join(format!("{name}.csv"));
        let reference = match &self.scene.reference {
            Some(crate::scene::Reference::Hole { major, minor, source }) => {
                Some((*major, *minor, source.as_str()))
            }
            _ => None,
        };
        match std::fs::read_to_string(&path) {
            Ok(text) => crate::probes::hole::settled(&text, reference),
            Err(_) => serde_json::Value::Null,
        }
    }

    /// The loads of every pressure probe (`crate::probes::loads`), read back on rank 0 from its
    /// every-step series (`crate::probes::loads_file`; the whole history, across restarts),
    /// with the file and how it was sampled: raw and box-filtered maxima (Pa) and, with
    /// `impulse_span`, the first impact's impulse (Pa·s). A file that cannot be read gives
    /// null.
    fn loads_summary(&self) -> serde_json::Value {
        let mut out = serde_json::Map::new();
        // against the experiment, where the scene's reference names one (measured once, by
        // the tracker)
        let compared = &self.tracker.pressure;
        for probe in &self.scene.probes {
            let Some((filter, span)) = probe.load_rules() else {
                continue;
            };
            let (path, raw) = crate::probes::loads_file(&self.dir.join("probes"), probe);
            let read = crate::probes::loads::read_csv(&path, ("t", "p"), (1.0, 1.0));
            // the raw series is every step's sample; the rows read as they were written
            let (window, interval) = match raw {
                true => (0.0, Some(0.0)),
                false => (probe.window(), probe.interval()),
            };
            let file = path
                .strip_prefix(self.dir)
                .unwrap_or(&path)
                .to_string_lossy()
                .into_owned();
            let value = match read
                .ok()
                .and_then(|(t, p)| crate::probes::loads::loads(&t, &p, filter, span))
            {
                Some(l) => json!({
                    "loads": l,
                    "series": file,
                    // a trailing window already averaged the rows the filter reads
                    "trailing_window_s": window,
                    "interval_s": interval,
                }),
                None => serde_json::Value::Null,
            };
            let mut value = value;
            if let (Some(c), Some(v)) = (compared.get(probe.name()), value.as_object_mut()) {
                v.insert("reference".into(), json!(c));
            }
            out.insert(probe.name().to_string(), value);
        }
        serde_json::Value::Object(out)
    }

    /// `summary.json`.
    fn summary(&self, r: &Reduced, wall: f64, n_fluid: usize, n_solid: usize) -> serde_json::Value {
        let sim = &self.sim;
        let n = r.particles as usize;
        let errors: serde_json::Map<String, serde_json::Value> = self
            .tracker
            .errors
            .iter()
            .map(|(k, v)| (k.clone(), json!(v)))
            .collect();
        let per_s = |x: f64| if wall > 0.0 { x / wall } else { 0.0 };
        let mut summary = json!({
            "hsph_version": env!("CARGO_PKG_VERSION"),
            "build": provenance(self.layout.backend),
            "complete": self.stopped_by.is_none(),
            "stopped_by": self.stopped_by,
            "scene": self.scene.name,
            // the files the scene builds from beside itself, with their hashes
            "inputs": { "meshes": crate::scene::mesh_file::mesh_inputs(self.scene) },
            "dimension": D,
            "particles": n,
            "fluid_particles": n_fluid,
            "solid_particles": n_solid,
            "wall_particles": n - n_fluid - n_solid,
            "steps": sim.step,
            "t_end": self.scene.time.t_end,
            "t": sim.t,
            "wall_s": wall,
            // a run continued from checkpoints: every segment's wall time up to its checkpoint
            // plus this one (a segment's steps after its last checkpoint were redone)
            "wall_s_all_segments": self.earlier.0 + wall,
            "segments": self.earlier.1 + 1,
            "particle_steps_per_s": per_s(self.particle_steps),
            // list entries visited (pair mode: each owned fluid pair once); the list-free scan
            // counts none, so it reports none rather than zero
            "pair_interactions_per_s": if sim.nl.is_lean() {
                json!(null)
            } else {
                json!(per_s(sim.pair_count as f64 * self.comm.size() as f64))
            },
            "threads": rayon::current_num_threads(),
            "errors": errors,
        });
        if !self.tracker.measured.is_empty() {
            summary["measured"] = json!(self.tracker.measured);
        }
        summary["hole"] = self.hole_summary();
        summary["pressure_loads"] = self.loads_summary();
        self.add_parallel(&mut summary, r, wall);
        self.add_population(&mut summary);
        self.add_stepping(&mut summary);
        self.add_memory(&mut summary, r);
        summary
    }

    /// The parallel layout's figures: decomposition, placement, traffic, ghosts, balance and
    /// the timers (min, mean and max over the ranks, s).
    fn add_parallel(&self, summary: &mut serde_json::Value, r: &Reduced, wall: f64) {
        let sim = &self.sim;
        let steps = sim.step;
        let mut timers = serde_json::Map::new();
        for (k, p) in PHASES.iter().enumerate() {
            timers.insert(
                format!("{p}_s"),
                json!({"min": r.timers[k][0], "mean": r.timers[k][1], "max": r.timers[k][2]}),
            );
        }
        // each pass the step ran, in step order: which physics the forces and integrate
        // phases' time went to
        let mut passes = serde_json::Map::new();
        for &pass in passes::ALL {
            let [lo, mean, hi] = r.pass(pass);
            if hi > 0.0 {
                passes.insert(
                    format!("{}_s", pass.name()),
                    json!({"min": lo, "mean": mean, "max": hi}),
                );
            }
        }
        let comm_s = r.mean(Timer::Halo) + r.mean(Timer::Migration);
        let cost = self
            .layout
            .topology
            .as_ref()
            .map_or(DEFAULT_COST, |t: &Topology| t.cost);
        let figures = json!({
            "ranks": self.comm.size(),
            "backend": self.layout.backend.name(),
            "decomposition": sim.map.decomp.factors().to_vec(),
            "placement": self.layout.placement.name(),
            "placement_requested": self.layout.requested.name(),
            "layout_warnings": self.layout.warnings,
            "nodes": self.layout.nodes(),
            "traffic": self.totals.json(&cost),
            "ghost_fraction": r.remote as f64 / (r.particles as usize).max(1) as f64,
            "imbalance": sim.balance.imbalance,
            "count_imbalance": r.count_imbalance(self.comm.size()),
            "migrations": r.migrated,
            "migrations_per_step": r.migrated as f64 / steps.max(1) as f64,
            "rebalances": sim.balance.rebalance_steps.len(),
            "rebalance_steps": sim.balance.rebalance_steps,
            "max_plane_shift_m": sim.balance.max_plane_shift,
            "communication_fraction": comm_s / wall.max(1e-12),
            "balance_fraction": r.mean(Timer::Balance) / wall.max(1e-12),
            "timers": timers,
            "pass_timers": passes,
            // ghost builds: the same on every rank (the rule is all-reduced), set-up's included
            "ghost_builds": sim.ghost_builds(),
            "skin": self.scene.performance.skin,
        });
        merge_into(summary, figures);
    }

    /// With `time.stepping = "local"`: the cycles of two substeps the run took (over every
    /// segment), of its `steps` (which count substeps).
    fn add_stepping(&self, summary: &mut serde_json::Value) {
        if self.sim.local {
            merge_into(summary, json!({ "stepping": "local", "cycles": self.sim.cycles }));
        }
    }

    /// How the population changed: particles removed by the outflow rule (count, fraction of
    /// the moving mass, their mass in kg and energy in J) and, in a scene whose regions
    /// `adapt`, the splits and merges since the run began (over every segment of a run
    /// continued from checkpoints), the population's start and peak, and its mean over this
    /// segment's steps.
    fn add_population(&self, summary: &mut serde_json::Value) {
        let mut figures = json!({
            "removed_particles": self.removed,
            "removed_fraction": self.removed_fraction(),
            "outflow": self.scene.domain.outflow,
            "removed_energy": self.removed_out[0],
            "removed_mass": self.removed_out[1],
        });
        if self.sim.adapts() {
            figures["splits"] = json!(self.sim.resized.splits);
            figures["merges"] = json!(self.sim.resized.merges);
            figures["particles_start"] = json!(self.particles_start);
            figures["particles_max"] = json!(self.population.1);
            // the population the segment's steps carried on average, which a cost per
            // particle-step (`hsph model`'s calibration) divides by
            figures["particles_mean"] = json!(self.particle_steps / self.segment_steps.max(1) as f64);
        }
        merge_into(summary, figures);
    }

    /// Memory: per-rank particle and ghost high water (O(N/P) with the distributed set-up) and
    /// peak resident set sizes in bytes (machine dependent, like `wall_s`: `summary.json` is not
    /// compared across runs). Under MPI each rank is one process; local ranks share one.
    fn add_memory(&self, summary: &mut serde_json::Value, r: &Reduced) {
        let high = |k: usize| r.high_water.iter().map(|h| h[k]).collect::<Vec<_>>();
        let now = crate::memory::peak_rss();
        // what the run's structures hold at its end, summed over ranks, and per particle:
        // the capacities of their vectors, which keep their largest size through the run
        let names = ["table", "lists", "cells", "scratch"];
        let sum = |k: usize| high(k).iter().sum::<u64>();
        let n = r.particles.max(1) as f64;
        let parts: serde_json::Map<_, _> = (names.iter().enumerate())
            .map(|(k, name)| (name.to_string(), json!(sum(3 + k))))
            .collect();
        let per: serde_json::Map<_, _> = (names.iter().enumerate())
            .map(|(k, name)| (name.to_string(), json!((sum(3 + k) as f64 / n).round())))
            .collect();
        merge_into(
            summary,
            json!({
                "particle_high_water": high(0),
                "ghost_high_water": high(1),
                "peak_rss_bytes_per_rank": high(2),
                "peak_rss_bytes": now.max(self.setup_peak),
                "setup_peak_rss_bytes": self.setup_peak,
                "step_peak_rss_bytes": if self.peak_reset { self.loop_peak } else { None },
                "memory_parts_bytes": parts,
                "memory_parts_bytes_per_particle": per,
            }),
        );
    }
}

/// Add every key of the object `more` to the object `summary`.
fn merge_into(summary: &mut serde_json::Value, more: serde_json::Value) {
    if let (Some(to), serde_json::Value::Object(from)) = (summary.as_object_mut(), more) {
        to.extend(from);
    }
}

/// The final state: gathered on rank 0 for `final.csv` when `gathered` (the view returned
/// there, `None` elsewhere), else every rank's own `final/rank_NNNN.csv`.
fn final_state<'s, const D: usize>(
    sim: &'s Simulation<D>,
    comm: &dyn Comm,
    dir: &Path,
    gathered: bool,
) -> Result<Option<View<'s, D>>> {
    if gathered {
        return sim.gather(comm);
    }
    let p = &sim.p;
    let piece = Piece::new(p, (0.0, 0), (comm.rank(), 1), &sim.scene);
    let dir = dir.join("final");
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let path = dir.join(format!("rank_{:04}.csv", comm.rank()));
    output::write_final(&path, p, &piece.order)?;
    Ok(None)
}
