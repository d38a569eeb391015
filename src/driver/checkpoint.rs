//! A run's checkpoints: when one is due (`[checkpoint]`, the wall clock), writing it with rank
//! 0's run state, and continuing from it (state restored, series cut back to it).

use super::rank::RankRun;
use crate::error::{Error, Result};
use crate::sim::Timer;
use serde_json::json;
use std::time::Instant;

impl<'a, const D: usize> RankRun<'a, D> {
    /// This rank's wall-clock decisions at a step boundary: [stop now before `--max-wall`
    /// (margin: three times the last step plus twice the last checkpoint), checkpoint now for
    /// `--checkpoint-every-minutes`], as 1.0/0.0 for the max-reduce.
    pub(super) fn wall_clock_flags(&self, last_step: &mut Instant) -> [f64; 2] {
        let step_s = last_step.elapsed().as_secs_f64();
        *last_step = Instant::now();
        let elapsed = self.steps_start.elapsed().as_secs_f64();
        let margin = 3.0 * step_s + 2.0 * self.checkpoint_clock.1;
        let stop = self.opts.max_wall.is_some_and(|w| elapsed + margin >= w);
        let due = self
            .opts
            .checkpoint_wall
            .is_some_and(|w| self.checkpoint_clock.0.elapsed().as_secs_f64() >= w);
        [stop as u8 as f64, due as u8 as f64]
    }

    /// True when `[checkpoint]` asks for one at this step.
    pub(super) fn checkpoint_due(&mut self) -> bool {
        let c = &self.scene.checkpoint;
        let by_steps = c.every_steps > 0 && self.sim.step.is_multiple_of(c.every_steps);
        let by_time = c.every > 0.0 && self.sim.t >= self.next_checkpoint * (1.0 - 1e-12);
        if by_time {
            crate::probes::advance_past(&mut self.next_checkpoint, c.every, self.sim.t);
        }
        by_steps || by_time
    }

    /// Collective: write a checkpoint of this step (series flushed first, their lengths in the
    /// manifest so that a restart cuts off anything written after it).
    pub(super) fn checkpoint(&mut self) -> Result<()> {
        let t0 = Instant::now();
        let state = match self.writer.as_mut() {
            Some(w) => {
                w.flush()?;
                self.probes.flush()?;
                Some(self.state()?)
            }
            None => None,
        };
        let built = self.sim.build_positions(self.comm)?;
        let dir = crate::checkpoint::write(
            (&self.sim.p, self.sim.clock(), &self.sim.scene, built),
            self.comm,
            self.dir,
            state,
            self.scene.checkpoint.keep,
        )?;
        self.checkpointed = self.sim.step;
        self.checkpoint_clock = (Instant::now(), t0.elapsed().as_secs_f64());
        if self.stopped_by.is_some() && self.comm.rank() == 0 {
            eprintln!(
                "hsph: checkpoint {} written; continue with `hsph run --restart {}`",
                dir.display(),
                self.dir.display()
            );
        }
        self.sim.timers.add(Timer::Output, t0);
        Ok(())
    }

    /// Rank 0's state for a checkpoint: clocks, counters, reference history, snapshot list and
    /// the length of every series file.
    fn state(&self) -> Result<serde_json::Value> {
        let mut files = vec![
            "timeseries.csv".to_string(),
            "diagnostics.csv".into(),
            "traffic.csv".into(),
        ];
        if self.scene.domain.outflow == crate::scene::Outflow::Remove {
            files.push("removed.csv".into());
        }
        files.extend(self.probes.files());
        let mut series = serde_json::Map::new();
        for f in files {
            let path = self.dir.join(&f);
            let len = std::fs::metadata(&path).map_err(|e| Error::io(&path, e))?.len();
            series.insert(f, json!(len));
        }
        Ok(json!({
            "next_out": self.next_out,
            "next_checkpoint": self.next_checkpoint,
            "removed": self.removed,
            "removed_out": self.removed_out,
            "n_fluid": self.n_fluid,
            "tracker": self.tracker,
            "probes": self.probes.state(),
            "snapshots": self.snapshots.as_ref().map(|w| w.state()),
            "wall_s": self.earlier.0 + self.steps_start.elapsed().as_secs_f64(),
            "segments": self.earlier.1 + 1,
            "splits": self.sim.resized.splits,
            "merges": self.sim.resized.merges,
            "cycles": self.sim.cycles,
            "particles_start": self.particles_start,
            "particles_max": self.population.1,
            "series": series,
            "output_step": self.output_step,
        }))
    }

    /// Continue from a checkpoint's [`RankRun::state`].
    pub(super) fn restore(&mut self, s: &serde_json::Value) -> Result<()> {
        let bad = |what: &str| Error::run(format!("checkpoint: the run state lacks `{what}`"));
        self.next_out = s["next_out"].as_f64().ok_or_else(|| bad("next_out"))?;
        self.next_checkpoint = s["next_checkpoint"]
            .as_f64()
            .ok_or_else(|| bad("next_checkpoint"))?;
        self.removed = s["removed"].as_u64().ok_or_else(|| bad("removed"))?;
        // absent in checkpoints of older builds, which did not count it
        if let Some(out) = s["removed_out"].as_array() {
            for (k, v) in out.iter().enumerate().take(2) {
                self.removed_out[k] = v.as_f64().ok_or_else(|| bad("removed_out"))?;
            }
        }
        self.n_fluid = s["n_fluid"].as_u64().ok_or_else(|| bad("n_fluid"))?;
        self.tracker = serde_json::from_value(s["tracker"].clone()).map_err(|_| bad("tracker"))?;
        self.probes.restore(&s["probes"])?;
        // absent in checkpoints of older builds: counted from this segment on
        self.earlier = (
            s["wall_s"].as_f64().unwrap_or(0.0),
            s["segments"].as_u64().unwrap_or(0),
        );
        // absent in checkpoints of older builds: counted from this segment on
        let count = |k: &str| s[k].as_u64();
        if let (Some(splits), Some(merges)) = (count("splits"), count("merges")) {
            self.sim.resized = crate::sim::Resized { splits, merges };
        }
        if let Some(n) = count("cycles") {
            self.sim.cycles = n;
        }
        if let Some(n) = count("particles_start") {
            self.particles_start = n;
        }
        if let Some(n) = count("particles_max") {
            self.population.1 = self.population.1.max(n);
        }
        // the last output step carries over: a segment that writes none before it stops at the
        // run's end must still record that its checkpoint precedes the last state's row
        self.output_step = count("output_step");
        let root = self.comm.rank() == 0;
        if let Some(w) = self.snapshots.as_mut() {
            w.restore(&s["snapshots"], root)?;
        }
        Ok(())
    }
}
