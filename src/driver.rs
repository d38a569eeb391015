//! Running a scene end to end: back end and ranks, thread pools, step loop, output schedule,
//! references, diagnostics and `summary.json`.
//!
//! Every rank runs [`run_rank`]; rank 0 alone writes files. The output directory is chosen and
//! prepared before any rank starts (under MPI by rank 0, which broadcasts it), so bad input
//! exits with status 2 before a step is taken.

use crate::comm::serial::SerialComm;
use crate::comm::{Comm, Phase, TrafficEntry};
use crate::error::{Error, Result};
use crate::output::{self, RunWriter};
use crate::placement::Placement;
use crate::progress::Progress;
use crate::reference::Tracker;
use crate::scene::Scene;
use crate::sim::{Layout, Simulation, PHASES};
use crate::topology::{ByteCost, Topology, DEFAULT_COST};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Communication back end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Backend {
    /// MPI when built with `mpi` and launched by mpirun/srun, else local when ranks > 1, else
    /// serial.
    #[default]
    Auto,
    /// One rank in this process.
    Serial,
    /// N ranks as threads of this process.
    Local,
    /// MPI (cargo feature `mpi`).
    Mpi,
}

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

/// The back end `opts` resolves to.
pub fn resolve_backend(opts: &RunOptions) -> Result<Backend> {
    let b = match opts.backend {
        Backend::Auto if cfg!(feature = "mpi") && crate::comm::launched_by_mpi() => Backend::Mpi,
        Backend::Auto if opts.ranks > 1 => Backend::Local,
        Backend::Auto => Backend::Serial,
        b => b,
    };
    if b == Backend::Mpi && !cfg!(feature = "mpi") {
        return Err(Error::missing_feature("--backend", "mpi"));
    }
    if b == Backend::Serial && opts.ranks > 1 {
        return Err(Error::input(
            "--ranks",
            format!(
                "the serial back end runs one rank, not {}; use --backend local",
                opts.ranks
            ),
        ));
    }
    Ok(b)
}

/// Run a validated scene. The output directory is prepared first; `summary.json` is written
/// only when the run completes.
pub fn run_scene(scene: &Scene, opts: &RunOptions) -> Result<RunOutcome> {
    let backend = resolve_backend(opts)?;
    if backend != Backend::Mpi {
        // the rank count is known: check the layout before any rank starts (exit 2)
        let _ = node_layout_for(opts.ranks.max(1), opts, None)?;
    }
    match backend {
        Backend::Serial | Backend::Auto => {
            let dir = output::prepare_dir(opts.out.as_deref(), &scene.name, opts.force)?;
            let pool = bound_pool(opts.threads, opts.bind)?;
            let comm = SerialComm::new();
            let out = pool.install(|| run_rank(scene, &dir, &comm, "serial", opts))?;
            out.ok_or_else(|| Error::run("rank 0 produced no outcome"))
        }
        Backend::Local => {
            let ranks = opts.ranks.max(1);
            let threads = if opts.threads == 0 {
                (cores() / ranks).max(1)
            } else {
                opts.threads
            };
            let dir = output::prepare_dir(opts.out.as_deref(), &scene.name, opts.force)?;
            let start = crate::affinity::start_handler(opts.bind, ranks, threads)?;
            let outs = crate::comm::local::run_local_with(ranks, threads, start, |comm| {
                run_rank(scene, &dir, comm, "local", opts)
            })?;
            outs.into_iter()
                .flatten()
                .next()
                .ok_or_else(|| Error::run("rank 0 produced no outcome"))
        }
        Backend::Mpi => run_mpi(scene, opts),
    }
}

#[cfg(feature = "mpi")]
fn run_mpi(scene: &Scene, opts: &RunOptions) -> Result<RunOutcome> {
    use crate::comm::mpi::MpiComm;
    let comm = MpiComm::init()?;
    // rank 0 chooses and prepares the directory; a failure there is everyone's input error
    let prepared = if comm.rank() == 0 {
        match output::prepare_dir(opts.out.as_deref(), &scene.name, opts.force) {
            Ok(d) => format!("ok:{}", d.display()),
            Err(e) => format!("err:{e}"),
        }
    } else {
        String::new()
    };
    let text = String::from_utf8_lossy(&comm.broadcast_bytes(0, prepared.into_bytes())?).into_owned();
    let dir = match text.strip_prefix("ok:") {
        Some(d) => PathBuf::from(d),
        None => {
            let msg = text
                .strip_prefix("err:")
                .unwrap_or(&text)
                .trim_start_matches("error: ");
            return Err(Error::input("--out", msg.to_string()));
        }
    };
    // MPI calls stay on this (main) thread, so the rank body runs here on the global pool
    let n = if opts.threads == 0 { cores() } else { opts.threads };
    let start = crate::affinity::mpi_start_handler(opts.bind, n)?;
    crate::affinity::with_start(rayon::ThreadPoolBuilder::new(), start.as_ref(), 0)
        .num_threads(n)
        .build_global()
        .map_err(|e| Error::run(format!("cannot start {n} threads: {e}")))?;
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        run_rank(scene, &dir, &comm, "mpi", opts)
    }))
    .unwrap_or_else(|p| {
        let what = p
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "panic".into());
        Err(Error::run(format!("panicked: {what}")))
    });
    match result {
        Ok(Some(out)) => Ok(out),
        // other ranks report nothing; MPI is finalised when `comm` drops
        Ok(None) => Ok(RunOutcome {
            dir,
            summary: serde_json::Value::Null,
            errors: BTreeMap::new(),
        }),
        // a layout error is found by every rank alike: exit 2 everywhere, no abort
        Err(e @ Error::Input { .. }) => Err(e),
        Err(e) => Err(comm.abort(e.to_string().trim_start_matches("error: "))),
    }
}

#[cfg(not(feature = "mpi"))]
fn run_mpi(_scene: &Scene, _opts: &RunOptions) -> Result<RunOutcome> {
    Err(Error::missing_feature("--backend", "mpi"))
}

/// The topology of a run of `ranks` ranks: `--topology`, else `--ranks-per-node`, else the
/// nodes discovered (`keys`: one node key per rank, from [`Comm::node_key`]) when they hold
/// equal runs of consecutive ranks; and the node of every rank.
fn node_layout_for(
    ranks: usize,
    opts: &RunOptions,
    keys: Option<&[usize]>,
) -> Result<(Option<Topology>, Vec<usize>)> {
    if let Some(t) = &opts.topology {
        t.check_ranks(ranks)?;
        return Ok((Some(t.clone()), (0..ranks).map(|r| t.node_of(r)).collect()));
    }
    if opts.ranks_per_node > 0 {
        let t = Topology::from_ranks_per_node(ranks, opts.ranks_per_node)?;
        let nodes = (0..ranks).map(|r| t.node_of(r)).collect();
        return Ok((Some(t), nodes));
    }
    // discovered: dense node ids in order of first appearance
    let mut ids = Vec::with_capacity(ranks);
    let mut seen: Vec<usize> = Vec::new();
    for r in 0..ranks {
        let key = keys.map_or(0, |k| k[r]);
        let id = seen.iter().position(|&s| s == key).unwrap_or_else(|| {
            seen.push(key);
            seen.len() - 1
        });
        ids.push(id);
    }
    let k = ids.iter().filter(|&&n| n == 0).count();
    let uniform = (0..ranks).all(|r| ids[r] == r / k);
    let topo = if uniform {
        Some(Topology::from_ranks_per_node(ranks, k)?)
    } else {
        None
    };
    Ok((topo, ids))
}

/// The node layout of this run (collective: gathers every rank's node key).
fn node_layout(comm: &dyn Comm, opts: &RunOptions) -> Result<(Option<Topology>, Vec<usize>)> {
    let prev = comm.set_phase(Phase::Other);
    let keys: Vec<usize> = comm
        .all_gather_bytes((comm.node_key() as u64).to_le_bytes().to_vec())?
        .iter()
        .map(|b| u64::from_le_bytes(b[..8].try_into().expect("8 bytes")) as usize)
        .collect();
    comm.set_phase(prev);
    node_layout_for(comm.size(), opts, Some(&keys))
}

/// Traffic of every rank since the last call, gathered on rank 0 (collective).
fn gather_traffic(comm: &dyn Comm) -> Result<Vec<TrafficEntry>> {
    let mine = comm.end_traffic_step();
    let mut buf = Vec::with_capacity(mine.len() * 33);
    for e in &mine {
        buf.push(Phase::ALL.iter().position(|p| *p == e.phase).unwrap_or(0) as u8);
        for v in [e.src as u64, e.dst as u64, e.bytes, e.messages] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
    }
    let prev = comm.set_phase(Phase::Output);
    let all = comm.all_gather_bytes(buf)?;
    comm.set_phase(prev);
    let mut out = Vec::new();
    for b in all {
        for rec in b.chunks_exact(33) {
            let w = |k: usize| u64::from_le_bytes(rec[1 + 8 * k..9 + 8 * k].try_into().expect("8 bytes"));
            out.push(TrafficEntry {
                phase: Phase::ALL[rec[0] as usize],
                src: w(0) as usize,
                dst: w(1) as usize,
                bytes: w(2),
                messages: w(3),
            });
        }
    }
    Ok(out)
}

/// Running totals of traffic by phase and by intra/inter node (rank 0).
#[derive(Debug, Default)]
struct TrafficTotals {
    /// Per phase: intra-node bytes, inter-node bytes, messages.
    by_phase: BTreeMap<&'static str, [u64; 3]>,
}

impl TrafficTotals {
    fn add(&mut self, e: &TrafficEntry, nodes: &[usize]) {
        let t = self.by_phase.entry(e.phase.name()).or_default();
        if nodes[e.src] == nodes[e.dst] {
            t[0] += e.bytes;
        } else {
            t[1] += e.bytes;
        }
        t[2] += e.messages;
    }

    /// Totals as JSON, with the cost of the traffic under the topology's relative costs per
    /// byte (intra- vs inter-node): as laid out, and had every byte crossed the network —
    /// the difference is what keeping neighbours on one node (shared memory) saved.
    fn json(&self, cost: &ByteCost) -> serde_json::Value {
        let (intra, inter) = self
            .by_phase
            .values()
            .fold((0, 0), |(a, b), t| (a + t[0], b + t[1]));
        let phases: serde_json::Map<String, serde_json::Value> = self
            .by_phase
            .iter()
            .map(|(k, t)| {
                (
                    k.to_string(),
                    json!({"intra_node_bytes": t[0], "inter_node_bytes": t[1], "messages": t[2]}),
                )
            })
            .collect();
        let layout = intra as f64 * cost.intra_node + inter as f64 * cost.inter_node;
        let all_inter = (intra + inter) as f64 * cost.inter_node;
        json!({
            "intra_node_bytes": intra,
            "inter_node_bytes": inter,
            "phases": phases,
            "estimated_cost": {
                "intra_node_cost_per_byte": cost.intra_node,
                "inter_node_cost_per_byte": cost.inter_node,
                "as_laid_out": layout,
                "if_all_inter_node": all_inter,
                "saved_fraction": if all_inter > 0.0 { 1.0 - layout / all_inter } else { 0.0 },
            },
        })
    }
}

/// One rank's whole run; `Some(outcome)` on rank 0.
pub fn run_rank(
    scene: &Scene,
    dir: &Path,
    comm: &dyn Comm,
    backend: &str,
    opts: &RunOptions,
) -> Result<Option<RunOutcome>> {
    match scene.dimension {
        2 => run_dim::<2>(scene, dir, comm, backend, opts),
        3 => run_dim::<3>(scene, dir, comm, backend, opts),
        d => Err(Error::input("dimension", format!("must be 2 or 3, got {d}"))),
    }
}

/// Header of `diagnostics.csv`.
fn diag_header() -> String {
    let mut h = String::from("step,t,wall_s");
    for p in PHASES {
        for s in ["min", "mean", "max"] {
            h.push_str(&format!(",{p}_s_{s}"));
        }
    }
    h.push_str(",ghosts,remote_ghosts,ghost_fraction,imbalance,migrated,rebalances,particle_steps_per_s");
    h
}

/// Per-rank figures reduced over ranks (collective).
struct Reduced {
    /// Per phase: min, mean, max over ranks (s).
    timers: Vec<[f64; 3]>,
    ghosts: u64,
    remote: u64,
    particles: u64,
    migrated: u64,
}

fn reduce<const D: usize>(sim: &Simulation<D>, comm: &dyn Comm) -> Result<Reduced> {
    let prev = comm.set_phase(Phase::Output);
    let mut mine: Vec<u8> = Vec::new();
    for s in sim.timers.seconds {
        mine.extend_from_slice(&s.to_le_bytes());
    }
    let all = comm.all_gather_bytes(mine)?;
    let mut counts = [
        sim.halo.len() as u64,
        sim.halo.remote() as u64,
        sim.p.n_owned as u64,
        sim.balance.migrated,
    ];
    comm.all_reduce_sum_u64(&mut counts)?;
    comm.set_phase(prev);
    let timers = (0..PHASES.len())
        .map(|k| {
            let v: Vec<f64> = all
                .iter()
                .map(|b| f64::from_le_bytes(b[8 * k..8 * k + 8].try_into().expect("8 bytes")))
                .collect();
            let (mut lo, mut hi, mut sum) = (f64::INFINITY, 0.0f64, 0.0);
            for x in &v {
                lo = lo.min(*x);
                hi = hi.max(*x);
                sum += x;
            }
            [lo, sum / v.len() as f64, hi]
        })
        .collect();
    Ok(Reduced {
        timers,
        ghosts: counts[0],
        remote: counts[1],
        particles: counts[2],
        migrated: counts[3],
    })
}

fn run_dim<const D: usize>(
    scene: &Scene,
    dir: &Path,
    comm: &dyn Comm,
    backend: &str,
    opts: &RunOptions,
) -> Result<Option<RunOutcome>> {
    let root = comm.rank() == 0;
    let quiet = opts.quiet || !root;
    let threads = rayon::current_num_threads();
    let (topology, nodes) = node_layout(comm, opts)?;
    let layout = Layout {
        topology,
        placement: opts.placement,
    };
    let mut sim = Simulation::<D>::with_layout(scene, comm, &layout)?;
    let mut writer = if root {
        Some(RunWriter::new(dir, &sim.scene, &diag_header())?)
    } else {
        None
    };
    let mut totals = TrafficTotals::default();
    // the set-up's traffic (one step's exchanges at the initial positions) is step 0
    let traffic = |step: u64, writer: &mut Option<RunWriter>, totals: &mut TrafficTotals| -> Result<()> {
        let entries = gather_traffic(comm)?;
        if let Some(w) = writer.as_mut() {
            for e in &entries {
                totals.add(e, &nodes);
            }
            w.traffic_rows(step, &entries, &nodes)?;
        }
        Ok(())
    };
    traffic(0, &mut writer, &mut totals)?;
    let mut tracker = Tracker::default();
    let mut n_total = [sim.p.n_owned as u64];
    comm.all_reduce_sum_u64(&mut n_total)?;
    let n_total = n_total[0] as usize;
    if !quiet {
        eprintln!(
            "hsph: {} ({}D), {} particles, {} rank(s) × {threads} thread(s) [{backend}], dt₀ = {:.3e} s, output in {}",
            scene.name,
            D,
            n_total,
            comm.size(),
            sim.dt,
            dir.display()
        );
    }
    let loop_start = Instant::now();
    let output =
        |sim: &mut Simulation<D>, tracker: &mut Tracker, writer: &mut Option<RunWriter>| -> Result<()> {
            let t0 = Instant::now();
            let obs = sim.observables(comm)?;
            let r = reduce(sim, comm)?;
            let view = sim.gather(comm)?;
            let wall = loop_start.elapsed().as_secs_f64();
            if let (Some(v), Some(w)) = (view, writer.as_mut()) {
                tracker.at_output(&v);
                let mut row = format!("{},{},{wall:.6}", v.step, v.t);
                for t in &r.timers {
                    row.push_str(&format!(",{:.6},{:.6},{:.6}", t[0], t[1], t[2]));
                }
                let rate = if wall > 0.0 {
                    r.particles as f64 * v.step as f64 / wall
                } else {
                    0.0
                };
                row.push_str(&format!(
                    ",{},{},{:.6},{:.6},{},{},{rate:.1}",
                    r.ghosts,
                    r.remote,
                    r.remote as f64 / r.particles.max(1) as f64,
                    sim.balance.imbalance,
                    r.migrated,
                    sim.balance.rebalance_steps.len()
                ));
                w.output_step(&v, &obs, &row)?;
            }
            sim.timers.add(6, t0);
            Ok(())
        };
    output(&mut sim, &mut tracker, &mut writer)?;
    let interval = scene.output.interval;
    let mut next_out = interval;
    let mut progress = Progress::new(n_total, quiet);
    let step_start = Instant::now();
    while !sim.done() {
        if let Some(f) = opts.fault {
            if f.rank == comm.rank() && f.step == sim.step + 1 {
                match f.kind {
                    FaultKind::Panic => panic!("injected fault on rank {} at step {}", f.rank, f.step),
                    FaultKind::Nan => sim.p.x[0][0] = f64::NAN,
                }
            }
        }
        sim.advance(comm)?;
        if tracker.due(scene, sim.t) {
            let view = sim.gather(comm)?;
            match &view {
                Some(v) => tracker.after_step(v),
                None => tracker.skip(scene, sim.t),
            }
        }
        if sim.t >= next_out * (1.0 - 1e-12) || sim.done() {
            while next_out <= sim.t * (1.0 + 1e-12) {
                next_out += interval;
            }
            output(&mut sim, &mut tracker, &mut writer)?;
            traffic(sim.step, &mut writer, &mut totals)?;
        }
        progress.update(sim.step, sim.t, scene.time.t_end);
    }
    progress.finish();
    let wall = step_start.elapsed().as_secs_f64();
    let r = reduce(&sim, comm)?;
    let final_view = sim.gather(comm)?;
    traffic(sim.step, &mut writer, &mut totals)?;
    let (Some(view), Some(mut writer)) = (final_view, writer) else {
        return Ok(None);
    };
    tracker.finish(&view);
    writer.finish(&view)?;
    let n = r.particles as usize;
    let steps = sim.step;
    let mut timers = serde_json::Map::new();
    for (k, p) in PHASES.iter().enumerate() {
        timers.insert(
            format!("{p}_s"),
            json!({"min": r.timers[k][0], "mean": r.timers[k][1], "max": r.timers[k][2]}),
        );
    }
    let comm_s = r.timers[3][1] + r.timers[4][1];
    let errors: serde_json::Map<String, serde_json::Value> = tracker
        .errors
        .iter()
        .map(|(k, v)| (k.clone(), json!(v)))
        .collect();
    let n_fluid = view
        .p
        .kind
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
        "pair_interactions_per_s": if wall > 0.0 { sim.pair_count as f64 * comm.size() as f64 / wall } else { 0.0 },
        "threads": threads,
        "ranks": comm.size(),
        "backend": backend,
        "decomposition": sim.map.decomp.factors().to_vec(),
        "placement": opts.placement.name(),
        "nodes": nodes.iter().max().map_or(1, |m| m + 1),
        "traffic": totals.json(&layout.topology.as_ref().map_or(DEFAULT_COST, |t| t.cost)),
        "ghost_fraction": r.remote as f64 / n.max(1) as f64,
        "imbalance": sim.balance.imbalance,
        "migrations": r.migrated,
        "migrations_per_step": r.migrated as f64 / steps.max(1) as f64,
        "rebalances": sim.balance.rebalance_steps.len(),
        "rebalance_steps": sim.balance.rebalance_steps,
        "max_plane_shift_m": sim.balance.max_plane_shift,
        "communication_fraction": comm_s / wall.max(1e-12),
        "balance_fraction": r.timers[5][1] / wall.max(1e-12),
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
    Ok(Some(RunOutcome {
        dir: dir.to_path_buf(),
        summary,
        errors: tracker.errors,
    }))
}
