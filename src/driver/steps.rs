//! The step loop: steps, removals under `outflow = "remove"`, the reference tracker, output
//! steps with their traffic, flow frames, and the stop at a step boundary (signal, wall clock,
//! end).

use super::diagnostics::{diag_row, reduce};
use super::rank::RankRun;
use super::traffic::log_traffic;
use crate::comm::Phase;
use crate::error::{Error, Result};
use crate::output;
use crate::output::snapshot::Piece;
use crate::progress::Progress;
use crate::reference::Tracker;
use crate::sim::Timer;
use std::time::Instant;

impl<'a, const D: usize> RankRun<'a, D> {
    /// Steps until the end, with the reference tracker, output steps and progress.
    pub(super) fn step_loop(&mut self) -> Result<()> {
        let interval = self.scene.output.interval;
        let mut progress = Progress::new(self.quiet, self.sim.t, self.scene.time.t_end);
        self.steps_start = Instant::now();
        self.checkpoint_clock.0 = Instant::now();
        let mut last_step = Instant::now();
        while !self.sim.done() {
            self.inject_fault();
            let before = (self.sim.resized, self.removed);
            let t0 = self.sim.t;
            self.sim.advance(self.comm)?;
            self.report_removals()?;
            self.count_population(before);
            if self.tracker.due(self.scene, self.sim.t) {
                self.sim.release_step_buffers();
                match &self.sim.gather(self.comm)? {
                    Some(v) => self.tracker.after_step(v),
                    None => self.tracker.skip(self.scene, self.sim.t),
                }
            }
            let scheduled = self.sim.t >= self.next_out * (1.0 - 1e-12);
            self.observe(scheduled, false)?;
            if scheduled {
                crate::probes::advance_past(&mut self.next_out, interval, self.sim.t);
                self.traffic(self.sim.step)?;
            }
            self.write_frames(t0)?;
            progress.update(
                self.sim.step,
                self.sim.t,
                self.scene.time.t_end,
                self.particle_steps,
            );
            // a step boundary: stop here if any rank has received a stopping signal or is about
            // to run out of wall-clock time (one collective decides for all)
            let mut clock = self.wall_clock_flags(&mut last_step);
            self.stopped_by = crate::signals::agreed_stop_with(self.comm, self.injected_signal, &mut clock)?;
            if self.stopped_by.is_none() && clock[0] > 0.0 {
                self.stopped_by = Some("max-wall");
            }
            let end = self.sim.done() && self.scene.checkpoint.scheduled();
            if self.stopped_by.is_some() || self.checkpoint_due() || end || clock[1] > 0.0 {
                self.checkpoint()?;
            }
            if self.sim.done() && !scheduled {
                // the last state, off the output schedule: written after the checkpoint, so a
                // continued run does not keep this row
                self.observe(true, true)?;
                self.traffic(self.sim.step)?;
            }
            if self.stopped_by.is_some() {
                break;
            }
        }
        progress.finish();
        Ok(())
    }

    /// After a step (collective): the probes, and on an `output` step the reference tracker
    /// (fed from the probes' gather: one gather per step) and the output step itself.
    /// `output_only` as in [`crate::probes::ProbeSet::after_step`].
    pub(super) fn observe(&mut self, output: bool, output_only: bool) -> Result<()> {
        let t0 = Instant::now();
        // both such references (front, cavity) read the fluid alone
        let fluid = output && Tracker::measures_at_output(self.scene);
        if output || self.probes.gathers(self.sim.t, (output, output_only), fluid) {
            // the view and the output need none of the step's lists
            self.sim.release_step_buffers();
        }
        let view = self
            .probes
            .after_step(&self.sim, self.comm, (output, output_only), fluid)?;
        if let (Some(v), true) = (&view, fluid) {
            self.tracker.at_output(v);
        }
        drop(view);
        self.sim.timers.add(Timer::Output, t0);
        match output {
            true => self.output(),
            false => Ok(()),
        }
    }

    /// One output step (collective): observables, reduced diagnostics, every rank's snapshot
    /// piece.
    fn output(&mut self) -> Result<()> {
        let t0 = Instant::now();
        let mut obs = self.sim.observables(self.comm)?;
        [obs.removed_energy, obs.removed_mass] = self.removed_out;
        let r = reduce(&self.sim, self.comm, None)?;
        let wall = self.loop_start.elapsed().as_secs_f64();
        self.output_step = Some(self.sim.step);
        let stamp = output::Stamp {
            step: self.sim.step,
            t: self.sim.t,
            dt: self.sim.step_length(),
        };
        if let Some(w) = self.writer.as_mut() {
            let row = diag_row(&r, &self.sim, wall, self.removed);
            w.output_step(&stamp, &obs, &row)?;
        }
        if let Some(w) = self.snapshots.as_mut() {
            let sim = &self.sim;
            let piece = Piece::new(
                &sim.p,
                (sim.t, sim.step),
                (self.comm.rank(), self.comm.size()),
                &sim.scene,
            );
            w.write(&piece, &self.scene.output.fields)?;
        }
        // a killed run loses at most the output interval of probe rows
        self.probes.flush()?;
        if let Some(w) = self.writer.as_ref() {
            w.mirror_series(&self.probes.files())?;
        }
        self.sim.timers.add(Timer::Output, t0);
        Ok(())
    }

    /// Append the traffic since the last call to `traffic.csv` as of `step` (collective).
    pub(super) fn traffic(&mut self, step: u64) -> Result<()> {
        log_traffic(
            self.comm,
            self.writer.as_mut(),
            &mut self.totals,
            &self.layout.node_of,
            step,
        )
    }

    /// Move the population on by a step's splits, merges and removals (counts the same on
    /// every rank, `before` them), and add it to the segment's particle-steps.
    fn count_population(&mut self, before: (crate::sim::Resized, u64)) {
        let k = (1u64 << D) - 1;
        let r = self.sim.resized;
        let grown = self.population.0 + k * (r.splits - before.0.splits);
        let now = grown - k * (r.merges - before.0.merges) - (self.removed - before.1);
        self.population = (now, self.population.1.max(grown).max(now));
        self.particle_steps += now as f64;
        self.segment_steps += 1;
    }

    /// The fraction of the moving mass the outflow rule removed so far (0 without removals).
    pub(super) fn removed_fraction(&self) -> f64 {
        if self.mass_start > 0.0 {
            self.removed_out[1] / self.mass_start
        } else {
            0.0
        }
    }

    /// Collective, under `outflow = "remove"`: count the particles every rank removed this step,
    /// log them in `removed.csv` (rank 0, sorted by id) and stop the run once more than
    /// `domain.max_removed_fraction` of the fluid is gone.
    fn report_removals(&mut self) -> Result<()> {
        if self.scene.domain.outflow != crate::scene::Outflow::Remove {
            return Ok(());
        }
        let mine = std::mem::take(&mut self.sim.removed);
        let prev = self.comm.set_phase(Phase::Other);
        let mut count = [mine.len() as u64];
        self.comm.all_reduce_sum_u64(&mut count)?;
        if count[0] == 0 {
            self.comm.set_phase(prev);
            return Ok(());
        }
        let bytes: Vec<u8> = mine.iter().flat_map(|r| r.to_bytes()).collect();
        let all = self.comm.all_gather_bytes(bytes)?;
        self.comm.set_phase(prev);
        let mut rows: Vec<_> = all
            .iter()
            .flat_map(|b| crate::sim::outflow::Removal::from_bytes(b, D))
            .collect();
        rows.sort_by_key(|r| r.id);
        for r in &rows {
            self.removed_out[0] += r.energy;
            self.removed_out[1] += r.mass;
        }
        if let Some(w) = self.writer.as_mut() {
            w.removed_rows(&rows)?;
            if self.removed == 0 {
                let r = &rows[0];
                eprintln!(
                    "hsph: warning: step {}: particle id {} {} at position {:?} and was removed \
                     (domain.outflow = \"remove\"; every removal is in removed.csv and counted in summary.json)",
                    r.step, r.id, r.reason, r.x
                );
            }
        }
        self.removed += count[0];
        let fraction = self.removed_fraction();
        if fraction > self.scene.domain.max_removed_fraction {
            let r = &rows[0];
            return Err(Error::run(format!(
                "step {}, t = {:.6e} s: {} moving (fluid and solid) particles removed, {:.3} % of the \
                 moving mass, more than domain.max_removed_fraction = {}; among them particle id {} {} \
                 at position {:?} (see removed.csv; enlarge the domain, check the walls, or raise the \
                 fraction)",
                self.sim.step,
                self.sim.t,
                self.removed,
                100.0 * fraction,
                self.scene.domain.max_removed_fraction,
                r.id,
                r.reason,
                r.x
            )));
        }
        Ok(())
    }
}
