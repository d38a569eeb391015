//! Launching a run: the back end, the layout, the run directory and thread pools before the
//! ranks start, then every rank's [`run_rank`] (threads of this process, or one MPI rank).

use super::checks::{check_limits, check_threads};
use super::rank::run_rank;
use super::{Backend, RunOptions, RunOutcome};
use crate::comm::serial::SerialComm;
use crate::comm::{Comm, Phase};
use crate::error::{Error, Result};
use crate::layout::{resolve_backend, LayoutRequest, RunLayout};
use crate::output;
use crate::scene::Scene;
use std::path::Path;
#[cfg(feature = "mpi")]
use std::path::PathBuf;

/// Build a rayon pool of `threads` threads (0 = available cores).
pub fn pool(threads: usize) -> Result<rayon::ThreadPool> {
    let n = if threads == 0 { cores() } else { threads };
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| Error::run(format!("cannot start {n} threads: {e}")))
}

/// [`pool`] with its threads pinned by `bind` (one rank owning this process's cpuset).
pub fn bound_pool(threads: usize, bind: crate::affinity::Bind) -> Result<rayon::ThreadPool> {
    let n = if threads == 0 { cores() } else { threads };
    let start = crate::affinity::start_handler(bind, 1, n)?;
    crate::affinity::with_start(rayon::ThreadPoolBuilder::new(), start.as_ref(), 0)
        .num_threads(n)
        .build()
        .map_err(|e| Error::run(format!("cannot start {n} threads: {e}")))
}

fn cores() -> usize {
    std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
}

/// Run a validated scene. The layout is resolved and the output directory prepared first (bad
/// input exits 2 before a step is taken); `summary.json` is written only when the run
/// completes.
pub fn run_scene(scene: &Scene, opts: &RunOptions) -> Result<RunOutcome> {
    let req = opts.layout_request();
    let backend = resolve_backend(&req)?;
    if backend == Backend::Mpi {
        return run_mpi(scene, opts, &req);
    }
    crate::limits::ranks("--ranks", opts.ranks.max(1))?;
    let layout = RunLayout::resolve(&req, backend, opts.ranks.max(1), None)?;
    check_limits(scene, layout.ranks, layout.ranks, opts)?;
    check_threads(opts.threads, layout.ranks, true)?;
    if let (Some(dir), Some((_, m))) = (&opts.out, &opts.restart) {
        // a restart continues in its run directory, which is not prepared afresh: under its
        // lock, everything it will cut or write is checked before anything changes
        let _lock = output::DirLock::take(dir, "--restart")?;
        super::check_restart(dir, scene, m)?;
        return run_prepared(scene, opts, &layout, dir);
    }
    let (dir, _lock) = output::prepare_dir(opts.out.as_deref(), &scene.name, opts.force)?;
    cleaning_up(&dir, run_prepared(scene, opts, &layout, &dir))
}

/// Run on the local or serial back end in the prepared directory `dir`.
fn run_prepared(scene: &Scene, opts: &RunOptions, layout: &RunLayout, dir: &Path) -> Result<RunOutcome> {
    let outcome = match layout.backend {
        Backend::Local => {
            let threads = if opts.threads == 0 {
                (cores() / layout.ranks).max(1)
            } else {
                opts.threads
            };
            let start = crate::affinity::start_handler(opts.bind, layout.ranks, threads)?;
            // rank 0's outcome carries the summary
            crate::comm::local::run_local_with(layout.ranks, threads, start, |comm| {
                run_rank(scene, dir, comm, layout, opts)
            })?
            .into_iter()
            .next()
        }
        _ => {
            let pool = bound_pool(opts.threads, opts.bind)?;
            let comm = SerialComm::new();
            Some(pool.install(|| run_rank(scene, dir, &comm, layout, opts))?)
        }
    };
    outcome.ok_or_else(|| Error::run("rank 0 produced no outcome"))
}

/// `result` of a run in `dir`, and on failure the run directory removed if nothing was written
/// into it (a scene error found during the set-up leaves no empty directory behind).
fn cleaning_up<T>(dir: &Path, result: Result<T>) -> Result<T> {
    if result.is_err() {
        output::remove_if_empty(dir);
    }
    result
}

#[cfg(feature = "mpi")]
fn run_mpi(scene: &Scene, opts: &RunOptions, req: &LayoutRequest) -> Result<RunOutcome> {
    use crate::comm::mpi::MpiComm;
    let comm = MpiComm::init()?;
    // the layout is found by every rank alike from the same node keys: exit 2 everywhere
    let layout = RunLayout::resolve(req, Backend::Mpi, comm.size(), Some(&node_keys(&comm)?))?;
    check_limits(scene, layout.ranks, 1, opts)?;
    // under mpirun the rank count is known only here
    crate::scene::check_rank_weights(scene, layout.ranks, "the MPI ranks (mpirun -np)")?;
    check_threads(opts.threads, 1, comm.rank() == 0)?;
    let (dir, _lock) = mpi_prepare_dir(&comm, scene, opts)?;
    // MPI calls stay on this (main) thread, so the rank body runs here on the global pool
    let n = if opts.threads == 0 { cores() } else { opts.threads };
    let start = crate::affinity::mpi_start_handler(opts.bind, n)?;
    crate::affinity::with_start(rayon::ThreadPoolBuilder::new(), start.as_ref(), 0)
        .num_threads(n)
        .build_global()
        .map_err(|e| Error::run(format!("cannot start {n} threads: {e}")))?;
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        run_rank(scene, &dir, &comm, &layout, opts)
    }))
    .unwrap_or_else(|p| {
        let what = p
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "panic".into());
        Err(Error::run(format!("panicked: {what}")))
    });
    if result.is_err() && comm.rank() == 0 {
        output::remove_if_empty(&dir);
    }
    match result {
        // other ranks' outcomes have no summary; MPI is finalised when `comm` drops
        Ok(out) => Ok(out),
        Err(e @ (Error::Input { .. } | Error::Stopped(_))) => Err(e),
        Err(e) => Err(comm.abort(e.to_string().trim_start_matches("error: "))),
    }
}

/// Rank 0 chooses and prepares the run directory and broadcasts it; a failure there is every
/// rank's input error.
#[cfg(feature = "mpi")]
fn mpi_prepare_dir(
    comm: &dyn Comm,
    scene: &Scene,
    opts: &RunOptions,
) -> Result<(PathBuf, Option<output::DirLock>)> {
    let mut lock = None;
    let prepared = if comm.rank() != 0 {
        String::new()
    } else if let (Some(dir), Some((_, m))) = (&opts.out, &opts.restart) {
        // a restart continues in its run directory, which is not prepared afresh: under its
        // lock, everything it will cut or write is checked before anything changes
        let checked = output::DirLock::take(dir, "--restart")
            .and_then(|l| super::check_restart(dir, scene, m).map(|()| l));
        match checked {
            Ok(l) => {
                lock = Some(l);
                format!("ok:{}", dir.display())
            }
            Err(e) => format!("err:{e}"),
        }
    } else {
        match output::prepare_dir(opts.out.as_deref(), &scene.name, opts.force) {
            Ok((d, l)) => {
                lock = Some(l);
                format!("ok:{}", d.display())
            }
            Err(e) => format!("err:{e}"),
        }
    };
    let text = String::from_utf8_lossy(&comm.broadcast_bytes(0, prepared.into_bytes())?).into_owned();
    match text.strip_prefix("ok:") {
        Some(d) => Ok((PathBuf::from(d), lock)),
        None => {
            let msg = text
                .strip_prefix("err:")
                .unwrap_or(&text)
                .trim_start_matches("error: ");
            Err(Error::input("--out", msg.to_string()))
        }
    }
}

#[cfg(not(feature = "mpi"))]
fn run_mpi(_scene: &Scene, _opts: &RunOptions, _req: &LayoutRequest) -> Result<RunOutcome> {
    Err(Error::missing_feature("--backend", "mpi"))
}

/// Every rank's node key ([`Comm::node_key`]), all-gathered (collective).
#[cfg_attr(not(feature = "mpi"), allow(dead_code))]
fn node_keys(comm: &dyn Comm) -> Result<Vec<usize>> {
    let prev = comm.set_phase(Phase::Other);
    let keys = comm
        .all_gather_bytes((comm.node_key() as u64).to_le_bytes().to_vec())?
        .iter()
        .map(|b| u64::from_le_bytes(b[..8].try_into().expect("8 bytes")) as usize)
        .collect();
    comm.set_phase(prev);
    Ok(keys)
}
