//! One rank's run: the state it carries from the set-up to `summary.json` ([`RankRun`]) and
//! its course, [`run_rank`]: start, step loop, finish. The methods live with what they do:
//! `start.rs`, `banner.rs`, `steps.rs`, `fault.rs`, `checkpoint.rs`, `summary.rs`.

use super::traffic::TrafficTotals;
use super::{RunOptions, RunOutcome};
use crate::comm::Comm;
use crate::error::Result;
use crate::layout::RunLayout;
use crate::output::snapshot::SnapshotWriter;
use crate::output::RunWriter;
use crate::probes::ProbeSet;
use crate::reference::Tracker;
use crate::scene::Scene;
use crate::sim::Simulation;
use std::path::Path;
use std::time::Instant;

/// One rank's whole run on a resolved layout; rank 0's outcome holds the summary (the other
/// ranks' hold `Null`), every rank's says whether a signal stopped it.
pub fn run_rank(
    scene: &Scene,
    dir: &Path,
    comm: &dyn Comm,
    layout: &RunLayout,
    opts: &RunOptions,
) -> Result<RunOutcome> {
    crate::with_dim!(scene.dimension, D => {
        let mut run = RankRun::<D>::start(scene, dir, comm, layout.clone(), opts)?;
        run.step_loop()?;
        run.finish()
    })
}

/// The state of one rank's run between the set-up and `summary.json`.
pub(super) struct RankRun<'a, const D: usize> {
    pub(super) scene: &'a Scene,
    pub(super) dir: &'a Path,
    pub(super) comm: &'a dyn Comm,
    pub(super) layout: RunLayout,
    pub(super) opts: &'a RunOptions,
    pub(super) sim: Simulation<D>,
    /// Rank 0 only.
    pub(super) writer: Option<RunWriter<D>>,
    /// Every rank: its snapshot pieces (rank 0 also the index); `None` for `format = "none"`.
    pub(super) snapshots: Option<Box<dyn SnapshotWriter<D>>>,
    /// Probes on their own clocks (files on rank 0).
    pub(super) probes: ProbeSet<D>,
    pub(super) tracker: Tracker,
    pub(super) totals: TrafficTotals,
    pub(super) n_total: usize,
    /// Start of the first output step (the `wall_s` column of `diagnostics.csv`).
    pub(super) loop_start: Instant,
    /// Start of the first step (`wall_s` of `summary.json`).
    pub(super) steps_start: Instant,
    pub(super) quiet: bool,
    /// The signal all ranks agreed to stop on, if any.
    pub(super) stopped_by: Option<&'static str>,
    /// A signal the test-only fault `signal` recorded for this run alone (0: none). Not the
    /// process's flag: runs of other tests in the same process must not see it.
    pub(super) injected_signal: usize,
    /// Peak resident set size of the process at the end of the set-up (bytes).
    pub(super) setup_peak: Option<u64>,
    /// True if the peak was reset after the set-up: the final peak is then the step loop's.
    pub(super) peak_reset: bool,
    /// Peak resident set size at the end of the step loop, before the final output (bytes).
    pub(super) loop_peak: Option<u64>,
    /// Fluid particles at the start, over all ranks.
    pub(super) n_fluid: u64,
    /// Particles removed by the outflow rule so far, over all ranks.
    pub(super) removed: u64,
    /// Particles now over all ranks, counted from this segment's start by the splits, merges
    /// and removals (no collective), and the most there were.
    pub(super) population: (u64, u64),
    /// Particles over all ranks when the run began (its first segment's set-up).
    pub(super) particles_start: u64,
    /// Particle-steps of this segment: the population summed over its steps, and the steps.
    pub(super) particle_steps: f64,
    /// Steps of this segment.
    pub(super) segment_steps: u64,
    /// Mass of the fluid and solid particles at the run's first step (kg, or kg/m in 2D): the
    /// observables' exact Σm now plus what was removed before (a restart's). The outflow rule's
    /// budget and `removed_fraction` are fractions of it, so particles that split or merge
    /// (`[[refine]] adapt`) count by what they weigh, not by their number.
    pub(super) mass_start: f64,
    /// Energy (J, or J/m in 2D) and mass (kg, or kg/m in 2D) they carried out, summed in id
    /// order step by step (the same bits on any number of ranks).
    pub(super) removed_out: [f64; 2],
    /// Simulated time of the next output step (s).
    pub(super) next_out: f64,
    /// Simulated time of the next scheduled checkpoint (s; with `[checkpoint] every`).
    pub(super) next_checkpoint: f64,
    /// Step of the last checkpoint written (none yet: `u64::MAX`).
    pub(super) checkpointed: u64,
    /// When the last checkpoint was written (or the loop started), and how long it took (s).
    pub(super) checkpoint_clock: (Instant, f64),
    /// Wall time of the earlier segments of a run continued from checkpoints (s), and their
    /// number.
    pub(super) earlier: (f64, u64),
    /// Step of the last output row written (none yet: `None`); a checkpoint records it, so a
    /// restart at the end knows whether the last state's row is still to be written.
    pub(super) output_step: Option<u64>,
}
