//! Running a scene end to end: back end and ranks, thread pools, step loop, output schedule,
//! references, diagnostics and `summary.json`.
//!
//! Every rank runs [`run_rank`]; rank 0 alone writes files. The output directory is chosen and
//! prepared before any rank starts (under MPI by rank 0, which broadcasts it), so bad input
//! exits with status 2 before a step is taken.

mod checks;
mod diagnostics;
mod launch;
mod provenance;
mod traffic;

pub use checks::{check_limits, check_threads, MAX_LOCAL_RANKS, MIN_PARTICLES_PER_RANK};
pub use launch::{bound_pool, pool, run_scene};
pub use provenance::{features, provenance};

use crate::comm::{Comm, Phase};
use crate::error::{Error, Result};
pub use crate::layout::Backend;
use crate::layout::{LayoutRequest, RunLayout};
use crate::output::snapshot::{Piece, SnapshotWriter};
use crate::output::{self, RunWriter};
use crate::placement::Placement;
use crate::probes::ProbeSet;
use crate::progress::Progress;
use crate::reference::Tracker;
use crate::scene::Scene;
use crate::sim::{Simulation, Timer, PHASES};
use crate::topology::{Topology, DEFAULT_COST};
use diagnostics::{diag_header, diag_row, reduce, Reduced};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;
use traffic::{log_traffic, TrafficTotals};

/// A test-only fault: make `rank` fail at `step`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fault {
    /// Failing rank.
    pub rank: usize,
    /// Step at which it fails.
    pub step: u64,
    /// How it fails.
    pub kind: FaultKind,
}

impl Fault {
    /// The fault named by the test-only environment variable `HSPH_TEST_FAULT=RANK:STEP:KIND`
    /// (KIND `panic` or `nan`), so tests can make a rank of an `mpirun` job fail.
    pub fn from_env() -> Option<Fault> {
        let v = std::env::var("HSPH_TEST_FAULT").ok()?;
        let f: Vec<&str> = v.split(':').collect();
        let kind = match f.get(2).copied() {
            Some("panic") => FaultKind::Panic,
            Some("nan") => FaultKind::Nan,
            Some("signal") => FaultKind::Signal,
            _ => return None,
        };
        Some(Fault {
            rank: f.first()?.parse().ok()?,
            step: f.get(1)?.parse().ok()?,
            kind,
        })
    }
}

/// How an injected fault fails.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultKind {
    /// The rank panics.
    Panic,
    /// One of the rank's particles gets a non-finite position (caught by the state check).
    Nan,
    /// The process records a SIGTERM at that step, as if one had arrived (the stop contract).
    Signal,
}

/// How to run.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Output directory (default `runs/<scene>-<timestamp>`).
    pub out: Option<PathBuf>,
    /// Overwrite a non-empty output directory.
    pub force: bool,
    /// Rayon threads per rank (0 = the cores divided among the ranks of this process).
    pub threads: usize,
    /// No progress output.
    pub quiet: bool,
    /// Ranks of the local back end (0 or 1 = one); under MPI the launcher decides.
    pub ranks: usize,
    /// Back end.
    pub backend: Backend,
    /// Test-only fault injection.
    pub fault: Option<Fault>,
    /// Virtual nodes of this many consecutive ranks (0: the nodes MPI discovers; one node on
    /// the serial and local back ends). Wins over discovery.
    pub ranks_per_node: usize,
    /// A node layout (`--topology FILE`, already read); wins over `ranks_per_node`.
    pub topology: Option<Topology>,
    /// Placement of blocks on ranks.
    pub placement: Placement,
    /// Pin rayon threads to cores (`--bind cores`, feature `hwloc`).
    pub bind: crate::affinity::Bind,
    /// Memory this process may use (bytes), instead of what the machine says (`--max-memory`).
    pub max_memory: Option<f64>,
    /// Fewest particles per rank (`--min-particles-per-rank`; 0 means the default,
    /// [`MIN_PARTICLES_PER_RANK`]).
    pub min_particles_per_rank: usize,
    /// Continue from this checkpoint (`--restart`): its directory and manifest.
    pub restart: Option<(PathBuf, crate::checkpoint::Manifest)>,
    /// Wall-clock limit (s, `--max-wall`): stop with a checkpoint before it.
    pub max_wall: Option<f64>,
    /// Wall-clock time between checkpoints (s, `--checkpoint-every-minutes`).
    pub checkpoint_wall: Option<f64>,
}

impl RunOptions {
    /// The layout flags of these options.
    pub fn layout_request(&self) -> LayoutRequest {
        LayoutRequest {
            backend: self.backend,
            ranks: self.ranks,
            ranks_per_node: self.ranks_per_node,
            topology: self.topology.clone(),
            placement: self.placement,
            bind: self.bind,
        }
    }
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
    /// The signal that stopped the run early (`None`: it completed).
    pub stopped_by: Option<&'static str>,
}

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
/// Cut every series file of a restarted run back to its length at the checkpoint: rows
/// written after it (before the run stopped) would otherwise be there twice.
fn truncate_series(dir: &Path, series: &serde_json::Value) -> Result<()> {
    let Some(map) = series.as_object() else {
        return Err(Error::run("checkpoint: the run state lacks the series lengths"));
    };
    let bad = |file: &str, why: &str| {
        Error::input(
            "--restart",
            format!("the checkpoint's run state names the series {file:?}, which {why}"),
        )
    };
    for (file, len) in map {
        if !output::is_series_path(file) {
            return Err(bad(file, "is not a series file of a run directory"));
        }
        let path = dir.join(file);
        let meta = std::fs::symlink_metadata(&path).map_err(|e| Error::io(&path, e))?;
        let len = len.as_u64().ok_or_else(|| bad(file, "has no length"))?;
        if !meta.is_file() {
            return Err(bad(file, "is not a regular file"));
        }
        if len > meta.len() {
            return Err(bad(
                file,
                &format!("is {} bytes, shorter than the checkpoint's {len}", meta.len()),
            ));
        }
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        f.set_len(len).map_err(|e| Error::io(&path, e))?;
    }
    Ok(())
}

/// The layout's and the scene's set-up warnings, on rank 0's standard error.
fn print_warnings<const D: usize>(layout: &RunLayout, scene: &Scene) {
    for w in layout
        .warnings
        .iter()
        .chain(&crate::scene::lattice::scene_warnings::<D>(scene))
    {
        eprintln!("hsph: warning: {w}");
    }
}

struct RankRun<'a, const D: usize> {
    scene: &'a Scene,
    dir: &'a Path,
    comm: &'a dyn Comm,
    layout: RunLayout,
    opts: &'a RunOptions,
    sim: Simulation<D>,
    /// Rank 0 only.
    writer: Option<RunWriter<D>>,
    /// Every rank: its snapshot pieces (rank 0 also the index); `None` for `format = "none"`.
    snapshots: Option<Box<dyn SnapshotWriter<D>>>,
    /// Probes on their own clocks (files on rank 0).
    probes: ProbeSet<D>,
    tracker: Tracker,
    totals: TrafficTotals,
    n_total: usize,
    /// Start of the first output step (the `wall_s` column of `diagnostics.csv`).
    loop_start: Instant,
    /// Start of the first step (`wall_s` of `summary.json`).
    steps_start: Instant,
    quiet: bool,
    /// The signal all ranks agreed to stop on, if any.
    stopped_by: Option<&'static str>,
    /// Peak resident set size of the process at the end of the set-up (bytes).
    setup_peak: Option<u64>,
    /// True if the peak was reset after the set-up: the final peak is then the step loop's.
    peak_reset: bool,
    /// Peak resident set size at the end of the step loop, before the final output (bytes).
    loop_peak: Option<u64>,
    /// Fluid particles at the start, over all ranks.
    n_fluid: u64,
    /// Particles removed by the outflow rule so far, over all ranks.
    removed: u64,
    /// Energy (J, or J/m in 2D) and mass (kg, or kg/m in 2D) they carried out, summed in id
    /// order step by step (the same bits on any number of ranks).
    removed_out: [f64; 2],
    /// Simulated time of the next output step (s).
    next_out: f64,
    /// Simulated time of the next scheduled checkpoint (s; with `[checkpoint] every`).
    next_checkpoint: f64,
    /// Step of the last checkpoint written (none yet: `u64::MAX`).
    checkpointed: u64,
    /// When the last checkpoint was written (or the loop started), and how long it took (s).
    checkpoint_clock: (Instant, f64),
    /// Wall time of the earlier segments of a run continued from checkpoints (s), and their
    /// number.
    earlier: (f64, u64),
}

impl<'a, const D: usize> RankRun<'a, D> {
    /// Set up the simulation, open the run files (rank 0), log the set-up's traffic as step 0
    /// and write the first output step.
    fn start(
        scene: &'a Scene,
        dir: &'a Path,
        comm: &'a dyn Comm,
        mut layout: RunLayout,
        opts: &'a RunOptions,
    ) -> Result<Self> {
        let root = comm.rank() == 0;
        let resumed = opts.restart.as_ref();
        let sim = match resumed {
            None => Simulation::<D>::with_layout(scene, comm, &layout)?,
            Some((ck, m)) => {
                let sim = Simulation::<D>::from_checkpoint(scene, comm, &layout, ck, m)?;
                if root {
                    truncate_series(dir, &m.run["series"])?;
                }
                sim
            }
        };
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
            setup_peak,
            peak_reset,
            loop_peak: None,
            n_fluid: n_total[1],
            removed: 0,
            removed_out: [0.0; 2],
            next_out: scene.output.interval,
            next_checkpoint: scene.checkpoint.every,
            checkpointed: u64::MAX,
            checkpoint_clock: (Instant::now(), 0.0),
            earlier: (0.0, 0),
        };
        run.report_layout()?;
        if let Some((ck, m)) = resumed {
            run.restore(&m.run)?;
            run.checkpointed = m.step;
            if !run.quiet {
                eprintln!(
                    "hsph: continuing from {} (step {}, t = {:.6e} s, written on {} rank(s)) on {} rank(s)",
                    ck.display(),
                    m.step,
                    m.t,
                    m.ranks,
                    comm.size()
                );
            }
        } else {
            // the set-up's traffic (one step's exchanges at the initial positions) is step 0
            run.traffic(0)?;
        }
        run.banner();
        run.loop_start = Instant::now();
        if resumed.is_none() {
            run.probes.after_step(&run.sim, comm, true, false)?;
            run.output()?;
        }
        Ok(run)
    }

    /// The run's first log line: version, scene, particles, layout, dt₀, where the output goes.
    fn banner(&self) {
        if !self.quiet {
            eprintln!(
            "hsph {} ({}{}): {} ({}D), {} particles, {} rank(s) × {} thread(s) [{}], dt₀ = {:.3e} s, output in {}",
            env!("CARGO_PKG_VERSION"),
            env!("HSPH_GIT_COMMIT"),
            features().iter().map(|f| format!(", {f}")).collect::<String>(),
            self.scene.name,
            D,
            self.n_total,
            self.comm.size(),
            rayon::current_num_threads(),
            self.layout.backend.name(),
            self.sim.dt,
            self.dir.display()
        );
        }
    }

    /// Collective when it has something to say: print the layout the run got (nodes, ranks
    /// per node, threads, CPU sets) and warn where it differs from the job script's plan
    /// (`HSPH_JOB_PLAN`, [`crate::joblayout`]).
    fn report_layout(&self) -> Result<()> {
        use crate::joblayout::{self as jl, Plan, RankLayout};
        let plan_text = std::env::var(jl::PLAN_VAR).ok();
        if self.opts.quiet && plan_text.is_none() {
            return Ok(());
        }
        let me = RankLayout {
            node: self.layout.node_of[self.comm.rank()],
            threads: rayon::current_num_threads(),
            cpus: jl::cpus_allowed(),
        };
        let all = self.comm.all_gather_bytes(me.encode())?;
        if self.comm.rank() != 0 {
            return Ok(());
        }
        let ranks: Vec<RankLayout> = all.iter().filter_map(|b| RankLayout::decode(b)).collect();
        if !self.opts.quiet {
            eprintln!("hsph: {}", jl::describe(&ranks));
        }
        match plan_text.as_deref().map(|t| (t, Plan::parse(t))) {
            Some((_, Some(plan))) => {
                for d in jl::differences(&plan, &ranks) {
                    eprintln!("hsph: warning: {d}");
                }
            }
            Some((t, None)) => eprintln!(
                "hsph: warning: {}=`{t}` is not of the form {}",
                jl::PLAN_VAR,
                Plan {
                    nodes: 2,
                    ranks_per_node: 4,
                    threads_per_rank: 6
                }
                .encode()
            ),
            None => {}
        }
        Ok(())
    }

    /// Append the traffic since the last call to `traffic.csv` as of `step` (collective).
    fn traffic(&mut self, step: u64) -> Result<()> {
        log_traffic(
            self.comm,
            self.writer.as_mut(),
            &mut self.totals,
            &self.layout.node_of,
            step,
        )
    }

    /// One output step (collective): observables, reduced diagnostics, every rank's snapshot
    /// piece; the state is gathered only for a reference that measures the whole flow.
    fn output(&mut self) -> Result<()> {
        let t0 = Instant::now();
        let mut obs = self.sim.observables(self.comm)?;
        [obs.removed_energy, obs.removed_mass] = self.removed_out;
        let r = reduce(&self.sim, self.comm, self.setup_peak)?;
        if Tracker::measures_at_output(self.scene) {
            // both such references (front, cavity) read the fluid alone
            let fluid = |p: &crate::particles::Particles<D>, i: usize| p.kind[i].is_fluid();
            if let Some(v) = self.sim.gather_where(self.comm, &fluid)? {
                self.tracker.at_output(&v);
            }
        }
        let wall = self.loop_start.elapsed().as_secs_f64();
        let stamp = output::Stamp {
            step: self.sim.step,
            t: self.sim.t,
            dt: self.sim.dt,
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

    /// Steps until the end, with the reference tracker, output steps and progress.
    fn step_loop(&mut self) -> Result<()> {
        let interval = self.scene.output.interval;
        let mut progress = Progress::new(self.n_total, self.quiet);
        self.steps_start = Instant::now();
        self.checkpoint_clock.0 = Instant::now();
        let mut last_step = Instant::now();
        while !self.sim.done() {
            self.inject_fault();
            self.sim.advance(self.comm)?;
            self.report_removals()?;
            if self.tracker.due(self.scene, self.sim.t) {
                match &self.sim.gather(self.comm)? {
                    Some(v) => self.tracker.after_step(v),
                    None => self.tracker.skip(self.scene, self.sim.t),
                }
            }
            let scheduled = self.sim.t >= self.next_out * (1.0 - 1e-12);
            let t0 = Instant::now();
            self.probes.after_step(&self.sim, self.comm, scheduled, false)?;
            self.sim.timers.add(Timer::Output, t0);
            if scheduled {
                crate::probes::advance_past(&mut self.next_out, interval, self.sim.t);
                self.output()?;
                self.traffic(self.sim.step)?;
            }
            progress.update(self.sim.step, self.sim.t, self.scene.time.t_end);
            // a step boundary: stop here if any rank has received a stopping signal or is about
            // to run out of wall-clock time (one collective decides for all)
            let mut clock = self.wall_clock_flags(&mut last_step);
            self.stopped_by = crate::signals::agreed_stop_with(self.comm, &mut clock)?;
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
                self.probes.after_step(&self.sim, self.comm, true, true)?;
                self.output()?;
                self.traffic(self.sim.step)?;
            }
            if self.stopped_by.is_some() {
                break;
            }
        }
        progress.finish();
        Ok(())
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
        let limit = self.scene.domain.max_removed_fraction * self.n_fluid as f64;
        if self.removed as f64 > limit {
            let r = &rows[0];
            return Err(Error::run(format!(
                "step {}, t = {:.6e} s: {} of {} moving (fluid and solid) particles removed ({:.3} %), more than \
                 domain.max_removed_fraction = {}; among them particle id {} {} at position {:?} \
                 (see removed.csv; enlarge the domain, check the walls, or raise the fraction)",
                self.sim.step,
                self.sim.t,
                self.removed,
                self.n_fluid,
                100.0 * self.removed as f64 / self.n_fluid.max(1) as f64,
                self.scene.domain.max_removed_fraction,
                r.id,
                r.reason,
                r.x
            )));
        }
        Ok(())
    }

    /// The test-only fault of `opts`, if it is due on this rank now.
    fn inject_fault(&mut self) {
        // test-only: `HSPH_TEST_STEP_DELAY_MS=N` sleeps N ms before every step, so that a
        // small run outlasts a real scheduler time limit on any machine (the Slurm CI test);
        // the physics and its bits are untouched
        static DELAY: std::sync::OnceLock<Option<u64>> = std::sync::OnceLock::new();
        let delay = DELAY.get_or_init(|| {
            std::env::var("HSPH_TEST_STEP_DELAY_MS")
                .ok()
                .and_then(|v| v.parse::<u64>().ok())
        });
        if let Some(ms) = *delay {
            std::thread::sleep(std::time::Duration::from_millis(ms));
        }
        if let Some(f) = self.opts.fault {
            if f.rank == self.comm.rank() && f.step == self.sim.step + 1 {
                match f.kind {
                    FaultKind::Panic => panic!("injected fault on rank {} at step {}", f.rank, f.step),
                    FaultKind::Nan => self.sim.p.x[0][0] = f64::NAN,
                    FaultKind::Signal => crate::signals::raise_for_test(signal_hook::consts::SIGTERM),
                }
            }
        }
    }

    /// This rank's wall-clock decisions at a step boundary: [stop now before `--max-wall`
    /// (margin: three times the last step plus twice the last checkpoint), checkpoint now for
    /// `--checkpoint-every-minutes`], as 1.0/0.0 for the max-reduce.
    fn wall_clock_flags(&self, last_step: &mut Instant) -> [f64; 2] {
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
    fn checkpoint_due(&mut self) -> bool {
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
    fn checkpoint(&mut self) -> Result<()> {
        let t0 = Instant::now();
        let state = match self.writer.as_mut() {
            Some(w) => {
                w.flush()?;
                self.probes.flush()?;
                Some(self.state()?)
            }
            None => None,
        };
        let dir = crate::checkpoint::write(
            (&self.sim.p, self.sim.clock(), &self.sim.scene),
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
            "series": series,
        }))
    }

    /// Continue from a checkpoint's [`RankRun::state`].
    fn restore(&mut self, s: &serde_json::Value) -> Result<()> {
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
        let root = self.comm.rank() == 0;
        if let Some(w) = self.snapshots.as_mut() {
            w.restore(&s["snapshots"], root)?;
        }
        Ok(())
    }

    /// Final gather, `final.csv` and `summary.json` (rank 0), the closing log lines.
    fn finish(mut self) -> Result<RunOutcome> {
        let wall = self.steps_start.elapsed().as_secs_f64();
        // the step loop's peak, before the final gather adds its copy of the particles
        self.loop_peak = crate::memory::peak_rss();
        if self.scene.checkpoint.scheduled() && self.checkpointed != self.sim.step {
            // a finished run can be continued to a later t_end
            self.checkpoint()?;
        }
        self.probes.flush()?;
        let r = reduce(&self.sim, self.comm, self.setup_peak)?;
        let p = &self.sim.p;
        let kinds = &p.kind[..p.n_owned];
        let mut n_fluid = [
            kinds.iter().filter(|k| k.is_fluid()).count() as u64,
            kinds.iter().filter(|k| k.is_solid()).count() as u64,
        ];
        self.comm.all_reduce_sum_u64(&mut n_fluid)?;
        // final.csv gathered on rank 0 up to `output.gather_limit` particles, else per rank
        let gathered = self.n_total <= self.scene.output.gather_limit;
        let final_view = if gathered {
            self.sim.gather(self.comm)?
        } else {
            let piece = Piece::new(p, (0.0, 0), (self.comm.rank(), 1), &self.sim.scene);
            let dir = self.dir.join("final");
            std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
            let path = dir.join(format!("rank_{:04}.csv", self.comm.rank()));
            output::write_final(&path, p, &piece.order)?;
            None
        };
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
        let summary = self.summary(&r, wall, n_fluid[0] as usize, n_fluid[1] as usize);
        output::write_summary(self.dir, &summary)?;
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
            let (n, steps) = (r.particles as f64, self.sim.step as f64);
            eprintln!(
                "hsph: done: {steps} steps in {wall:.2} s ({:.3e} particle-steps/s); results in {}",
                n * steps / wall.max(1e-12),
                self.dir.display()
            );
            for (k, v) in &self.tracker.measured {
                eprintln!("hsph: measured {k} = {v:.6}");
            }
            for (k, v) in &self.tracker.errors {
                eprintln!("hsph: error {k} = {:.4} %", v * 100.0);
            }
        }
        Ok(RunOutcome {
            dir: self.dir.to_path_buf(),
            summary,
            errors: std::mem::take(&mut self.tracker.errors),
            stopped_by: self.stopped_by,
        })
    }

    /// The settled hole of the scene's hole probe, read back from its file on rank 0 (the
    /// whole history, across restarts); null without one.
    fn hole_summary(&self) -> serde_json::Value {
        let Some(name) = self.scene.probes.iter().find_map(|p| match p {
            crate::scene::Probe::Hole { name, .. } => Some(name),
            _ => None,
        }) else {
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

    /// `summary.json`.
    fn summary(&self, r: &Reduced, wall: f64, n_fluid: usize, n_solid: usize) -> serde_json::Value {
        let sim = &self.sim;
        let n = r.particles as usize;
        let steps = sim.step;
        let mut timers = serde_json::Map::new();
        for (k, p) in PHASES.iter().enumerate() {
            timers.insert(
                format!("{p}_s"),
                json!({"min": r.timers[k][0], "mean": r.timers[k][1], "max": r.timers[k][2]}),
            );
        }
        let comm_s = r.mean(Timer::Halo) + r.mean(Timer::Migration);
        let errors: serde_json::Map<String, serde_json::Value> = self
            .tracker
            .errors
            .iter()
            .map(|(k, v)| (k.clone(), json!(v)))
            .collect();
        let per_s = |x: f64| if wall > 0.0 { x / wall } else { 0.0 };
        let cost = self
            .layout
            .topology
            .as_ref()
            .map_or(DEFAULT_COST, |t: &Topology| t.cost);
        let mut summary = json!({
            "hsph_version": env!("CARGO_PKG_VERSION"),
            "build": provenance(self.layout.backend),
            "complete": self.stopped_by.is_none(),
            "stopped_by": self.stopped_by,
            "scene": self.scene.name,
            "dimension": D,
            "particles": n,
            "fluid_particles": n_fluid,
            "solid_particles": n_solid,
            "wall_particles": n - n_fluid - n_solid,
            "steps": steps,
            "t_end": self.scene.time.t_end,
            "t": sim.t,
            "wall_s": wall,
            // a run continued from checkpoints: every segment's wall time up to its checkpoint
            // plus this one (a segment's steps after its last checkpoint were redone)
            "wall_s_all_segments": self.earlier.0 + wall,
            "segments": self.earlier.1 + 1,
            "particle_steps_per_s": per_s(n as f64 * steps as f64),
            // list entries visited (pair mode: each owned fluid pair once); the list-free scan
            // counts none, so it reports none rather than zero
            "pair_interactions_per_s": if sim.nl.is_lean() {
                json!(null)
            } else {
                json!(per_s(sim.pair_count as f64 * self.comm.size() as f64))
            },
            "threads": rayon::current_num_threads(),
            "ranks": self.comm.size(),
            "backend": self.layout.backend.name(),
            "decomposition": sim.map.decomp.factors().to_vec(),
            "placement": self.layout.placement.name(),
            "placement_requested": self.layout.requested.name(),
            "layout_warnings": self.layout.warnings,
            "nodes": self.layout.nodes(),
            "traffic": self.totals.json(&cost),
            "ghost_fraction": r.remote as f64 / n.max(1) as f64,
            "imbalance": sim.balance.imbalance,
            "migrations": r.migrated,
            "migrations_per_step": r.migrated as f64 / steps.max(1) as f64,
            "removed_particles": self.removed,
            "removed_fraction": self.removed as f64 / self.n_fluid.max(1) as f64,
            "outflow": self.scene.domain.outflow,
            "rebalances": sim.balance.rebalance_steps.len(),
            "rebalance_steps": sim.balance.rebalance_steps,
            "max_plane_shift_m": sim.balance.max_plane_shift,
            "communication_fraction": comm_s / wall.max(1e-12),
            "balance_fraction": r.mean(Timer::Balance) / wall.max(1e-12),
            "timers": timers,
            "errors": errors,
        });
        if !self.tracker.measured.is_empty() {
            summary["measured"] = json!(self.tracker.measured);
        }
        // per rank, from the set-up on: O(N/P) with the distributed set-up
        summary["particle_high_water"] = json!(r.high_water.iter().map(|h| h[0]).collect::<Vec<_>>());
        summary["ghost_high_water"] = json!(r.high_water.iter().map(|h| h[1]).collect::<Vec<_>>());
        // each process's peak (under MPI each rank is one; local ranks share one process)
        summary["peak_rss_bytes_per_rank"] = json!(r.high_water.iter().map(|h| h[2]).collect::<Vec<_>>());
        // machine dependent, like wall_s: summary.json is not compared across runs
        let now = crate::memory::peak_rss();
        summary["peak_rss_bytes"] = json!(now.max(self.setup_peak));
        summary["setup_peak_rss_bytes"] = json!(self.setup_peak);
        summary["step_peak_rss_bytes"] = json!(if self.peak_reset { self.loop_peak } else { None });
        summary["removed_energy"] = json!(self.removed_out[0]);
        summary["removed_mass"] = json!(self.removed_out[1]);
        summary["hole"] = self.hole_summary();
        summary
    }
}
