//! A rank's set-up: the simulation (fresh or from a checkpoint), the run files, the set-up's
//! traffic as step 0 and the first output step.

use super::banner::print_warnings;
use super::diagnostics::diag_header;
use super::rank::RankRun;
use super::restart::truncate_series;
use super::traffic::TrafficTotals;
use super::RunOptions;
use crate::checkpoint::Manifest;
use crate::comm::Comm;
use crate::error::Result;
use crate::layout::RunLayout;
use crate::output::{self, RunWriter};
use crate::probes::ProbeSet;
use crate::reference::Tracker;
use crate::scene::Scene;
use crate::sim::Simulation;
use std::path::{Path, PathBuf};
use std::time::Instant;

impl<'a, const D: usize> RankRun<'a, D> {
    /// Set up the simulation, open the run files (rank 0), log the set-up's traffic as step 0
    /// and write the first output step.
    pub(super) fn start(
        scene: &'a Scene,
        dir: &'a Path,
        comm: &'a dyn Comm,
        mut layout: RunLayout,
        opts: &'a RunOptions,
    ) -> Result<Self> {
        let root = comm.rank() == 0;
        let resumed = opts.restart.as_ref();
        let sim = simulation::<D>(scene, dir, comm, &layout, resumed)?;
        layout.placed(sim.placement);
        // the set-up's peak (each rank builds its own sites), then the step loop's own
        let setup_peak = crate::memory::peak_rss();
        let peak_reset = root && crate::memory::reset_peak();
        if root {
            print_warnings::<D>(&layout, scene);
        }
        let writer = if root {
            Some(RunWriter::new(
                dir,
                &sim.scene,
                &diag_header(),
                resumed.is_some(),
            )?)
        } else {
            None
        };
        let probes = ProbeSet::new(&sim.scene, root.then_some(dir), resumed.is_some())?;
        let snapshots = output::writers::writer_for::<D>(scene.output.format, dir)?;
        let fluid = sim.p.kind[..sim.p.n_owned]
            .iter()
            .filter(|k| k.is_integrated())
            .count();
        let mut n_total = [sim.p.n_owned as u64, fluid as u64];
        comm.all_reduce_sum_u64(&mut n_total)?;
        let mut run = RankRun {
            scene,
            dir,
            comm,
            layout,
            opts,
            sim,
            writer,
            snapshots,
            probes,
            tracker: Tracker::default(),
            totals: TrafficTotals::default(),
            n_total: n_total[0] as usize,
            loop_start: Instant::now(),
            steps_start: Instant::now(),
            quiet: opts.quiet || !root,
            stopped_by: None,
            injected_signal: 0,
            setup_peak,
            peak_reset,
            loop_peak: None,
            n_fluid: n_total[1],
            removed: 0,
            population: (n_total[0], n_total[0]),
            particles_start: n_total[0],
            particle_steps: 0.0,
            segment_steps: 0,
            mass_start: 0.0,
            removed_out: [0.0; 2],
            next_out: scene.output.interval,
            next_checkpoint: scene.checkpoint.every,
            checkpointed: u64::MAX,
            checkpoint_clock: (Instant::now(), 0.0),
            earlier: (0.0, 0),
            output_step: None,
        };
        run.report_layout()?;
        if let Some((ck, m)) = resumed {
            run.continue_from(ck, m)?;
            if run.sim.done() && m.run["output_step"].as_u64().is_some_and(|s| s != m.step) {
                // the checkpoint is the run's end, written before its last state's row (off
                // the output schedule), which a run that stopped there may lack: written again
                run.observe(true, true)?;
                run.traffic(run.sim.step)?;
            }
        } else {
            // the set-up's traffic (one step's exchanges at the initial positions) is step 0
            run.traffic(0)?;
        }
        if run.scene.domain.outflow == crate::scene::Outflow::Remove {
            run.mass_start = run.sim.observables(comm)?.mass + run.removed_out[1];
        }
        run.banner();
        run.loop_start = Instant::now();
        if resumed.is_none() {
            run.observe(true, false)?;
        }
        Ok(run)
    }

    /// Continue from the checkpoint `ck` with manifest `m`: the run state restored, said on
    /// rank 0.
    fn continue_from(&mut self, ck: &Path, m: &Manifest) -> Result<()> {
        self.restore(&m.run)?;
        self.checkpointed = m.step;
        if !self.quiet {
            eprintln!(
                "hsph: continuing from {} (step {}, t = {:.6e} s, written on {} rank(s)) on {} rank(s)",
                ck.display(),
                m.step,
                m.t,
                m.ranks,
                self.comm.size()
            );
        }
        Ok(())
    }
}

/// The simulation on `layout`: built afresh, or read from the checkpoint of `resumed` (rank 0
/// then cuts the run's series back to it).
fn simulation<const D: usize>(
    scene: &Scene,
    dir: &Path,
    comm: &dyn Comm,
    layout: &RunLayout,
    resumed: Option<&(PathBuf, Manifest)>,
) -> Result<Simulation<D>> {
    match resumed {
        None => Simulation::<D>::with_layout(scene, comm, layout),
        Some((ck, m)) => {
            let sim = Simulation::<D>::from_checkpoint(scene, comm, layout, ck, m)?;
            if comm.rank() == 0 {
                truncate_series(dir, &m.run["series"])?;
            }
            Ok(sim)
        }
    }
}
