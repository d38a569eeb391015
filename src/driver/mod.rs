//! Running a scene end to end: back end and ranks, thread pools, step loop, output schedule,
//! references, diagnostics and `summary.json`.
//!
//! Every rank runs [`run_rank`]; rank 0 alone writes files. The output directory is chosen and
//! prepared before any rank starts (under MPI by rank 0, which broadcasts it), so bad input
//! exits with status 2 before a step is taken.
//!
//! The files, in the order a run meets them:
//!
//! - `mod.rs`: what a run is asked ([`RunOptions`]) and what it reports ([`RunOutcome`]).
//! - `checks.rs`: ranks, threads, memory and probe sizes against the limits, before anything
//!   is allocated ([`check_limits`], [`check_threads`]).
//! - `launch.rs`: [`run_scene`]: back end, layout, run directory, thread pools ([`pool`]),
//!   the ranks as threads of this process or as MPI ranks.
//! - `rank.rs`: one rank's run, [`run_rank`], and the state it carries (`RankRun`), whose
//!   methods live in the files below.
//! - `start.rs`: the set-up (fresh or from a checkpoint) up to the first output step.
//! - `banner.rs`: what a run says as it starts: banner, layout against the job's plan, warnings.
//! - `steps.rs`: the step loop, output steps, removals, the stop at a step boundary.
//! - `frames.rs`: the flow frames of `output.frames`, written by every rank without a gather.
//! - `fault.rs`: test-only fault injection ([`Fault`]).
//! - `checkpoint.rs`: when a checkpoint is due, writing it, continuing from it.
//! - `restart.rs`: a restart as a transaction: everything checked before anything changes.
//! - `summary.rs`: the final state, `final.csv`, `summary.json`, the closing log lines.
//! - `diagnostics.rs`: figures reduced over ranks and the rows of `diagnostics.csv`.
//! - `traffic.rs`: `traffic.csv` and the traffic totals of `summary.json`.
//! - `provenance.rs`: what built this binary ([`features`], [`provenance`]).

mod banner;
mod checkpoint;
mod checks;
mod diagnostics;
mod fault;
pub mod frames;
mod launch;
mod provenance;
mod rank;
mod restart;
mod start;
mod steps;
mod summary;
mod sweeps;
mod traffic;

pub use checks::{check_limits, check_threads, MAX_LOCAL_RANKS, MIN_PARTICLES_PER_RANK};
pub use fault::{Fault, FaultKind};
pub use launch::{bound_pool, pool, run_scene};
pub use provenance::{features, provenance};
pub use rank::run_rank;
pub use restart::{check_restart, nothing_to_run};

pub use crate::layout::Backend;
use crate::layout::LayoutRequest;
use crate::placement::Placement;
use crate::topology::Topology;
use std::collections::BTreeMap;
use std::path::PathBuf;

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
