//! `hsph model`: a performance model of the step loop, calibrated on measured runs
//! (docs/performance_model.md).
//!
//! Bulk-synchronous: a step costs every rank
//!
//! ```text
//! T_r = a·n_r + g·m_r + T_net(node of r)
//! ```
//!
//! with `n_r` its owned particles (weighed by their cost: [`PlanRow::work`], so that under
//! `balance.load = "pairs"` a rank of cheap wall particles counts what it computes) and `m_r`
//! the ghosts it receives per step (both from [`crate::plan`], the engine's own decomposition
//! and halo rule), `a` (s per particle-step)
//! the cost of every pass of a one-rank run, and `g` (s per ghost-step) what a ghost adds to a
//! rank's step between ranks of one node: packing, copying, unpacking and binning it, and the
//! waits of the exchanges (a rank blocks until its neighbours have sent), fitted on runs with
//! a core per rank. Ranks that time-share cores (more ranks than cores, as in the checks on a
//! 2-core machine) hide those waits, so there a core's step is the CPU work of its ranks,
//! `Σ_r (a·n_r + g_cpu·m_r) / C`, with `g_cpu` fitted on such runs.
//! Between nodes, each node's network interface carries its ranks' halo bytes:
//! `T_net = max(bytes out, bytes in) / B + k·λ` for a node, with `B` the bandwidth (B/s),
//! `λ` the latency (s) and `k` the exchanges of a step. The step takes `max_r T_r`, or, with
//! `P` single-threaded ranks time-sharing `C < P` cores, `max(max_r T_r, Σ_r T_r / C)`.
//! Efficiency against one rank is `E = a·N / (P·T_step)`.
//!
//! Threads inside a rank ([`Threads`]) divide its CPU work, `a·n_r + g_cpu·m_r` (with
//! `g_cpu ≤ g`), by `t·e(t)`: `e(2)` is measured on one rank at 1 and 2 threads, beyond 2
//! threads it is assumed, pessimistically `e(t) = e(2)^log2(t)` (every doubling loses what
//! the first did) or optimistically `e(t) = e(2)`. The waits `(g − g_cpu)·m_r` and the
//! network do not shrink with threads. With the exchange overlapped with the interior
//! ([`Options::overlap`]) a rank pays only the part of its exchange (waits and network) that
//! exceeds its interior's compute, the interior being the share `1 − m_r/n_r` of its particles
//! (a boundary particle per ghost received: an assumption). [`layouts`] ranks the layouts
//! ranks × threads of nodes of C cores.
//!
//! Not modelled: memory-bandwidth contention between the ranks of a node, load imbalance
//! that grows during the run (the plan is the initial decomposition), and output. Units:
//! seconds, bytes, particles.

use crate::error::{Error, Result};
use crate::placement::Placement;
use crate::plan::{plan, PlanRow};
use crate::scene::{load_scene, Scene};
use crate::topology::Topology;
use std::fmt::Write as _;
use std::path::Path;

/// The network between nodes (assumed, not measured here: one machine has none).
#[derive(Debug, Clone, Copy)]
pub struct Network {
    /// Bandwidth of one node's interface (B/s).
    pub bandwidth: f64,
    /// Latency of one message (s).
    pub latency: f64,
}

/// Costs measured on this machine.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// Seconds per owned particle-step, every pass (one rank, one thread).
    pub per_particle: f64,
    /// The same, per phase of the step (`summary.json` timers).
    pub per_phase: Vec<(String, f64)>,
    /// Seconds per ghost-step between ranks of one node, waits included (a core per rank).
    pub per_ghost: f64,
    /// CPU seconds per ghost-step (ranks time-sharing cores).
    pub ghost_cpu: f64,
    /// Thread efficiency e(2) = T(1 thread) / (2·T(2 threads)) per particle-step of one rank,
    /// if a 2-thread run was given.
    pub thread_eff: Option<f64>,
}

/// Threads per rank and their efficiency e(t) against one thread (`t·e(t)` is a rank's
/// speed-up on its CPU work).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Threads {
    /// Threads per rank.
    pub t: usize,
    /// e(2), measured.
    pub e2: f64,
    /// Beyond 2 threads: e(t) = e(2)^log2(t) if `true`, e(2) if `false`.
    pub pessimistic: bool,
}

impl Threads {
    /// One thread per rank.
    pub const ONE: Threads = Threads {
        t: 1,
        e2: 1.0,
        pessimistic: true,
    };

    /// e(t): 1 at one thread, measured at two, assumed beyond.
    pub fn efficiency(&self) -> f64 {
        match self.t {
            0 | 1 => 1.0,
            2 => self.e2,
            t if self.pessimistic => self.e2.powf((t as f64).log2()),
            _ => self.e2,
        }
    }

    /// t·e(t).
    pub fn speedup(&self) -> f64 {
        self.t.max(1) as f64 * self.efficiency()
    }
}

/// How a layout runs: threads per rank, and whether the exchange is overlapped with the
/// interior's compute.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Threads per rank.
    pub threads: Threads,
    /// Exchanges hidden behind the interior's compute.
    pub overlap: bool,
}

impl Options {
    /// One thread per rank, no overlap: the engine as it runs today.
    pub const PLAIN: Options = Options {
        threads: Threads::ONE,
        overlap: false,
    };
}

/// A measured run: its scene (as run), ranks, threads, nodes, steps and step-loop seconds.
#[derive(Debug, Clone)]
pub struct Measured {
    /// The run directory.
    pub dir: String,
    /// The scene as the run resolved it (`scene.toml` of the run directory).
    pub scene: Scene,
    /// Ranks, threads per rank and nodes of the run.
    pub ranks: usize,
    /// Threads per rank.
    pub threads: usize,
    /// Nodes of the run.
    pub nodes: usize,
    /// Placement that ran.
    pub placement: Placement,
    /// Particles: the mean population over the steps of a scene whose regions adapt (its
    /// `particles_mean`), else the count.
    pub particles: u64,
    /// Steps taken.
    pub steps: u64,
    /// Step-loop wall time (s).
    pub wall: f64,
    /// Mean seconds per phase over ranks.
    pub phases: Vec<(String, f64)>,
}

impl Measured {
    /// Read `dir/summary.json` and `dir/scene.toml`. Every number of `summary.json` is
    /// checked where it is read, against the limits of the flags that set it
    /// ([`crate::limits::read_summary`]), before anything is sized by it; the model also needs
    /// a run that took steps (`steps` ≥ 1) in a positive, finite `wall_s`, with at least one
    /// particle per rank. Any of these wrong is exit 2 naming the file and the key.
    pub fn read(dir: &Path) -> Result<Self> {
        use crate::limits::{
            FileNumbers, Number, MAX_PARTICLES, MAX_RANKS, MAX_STEPS, MAX_THREADS, MAX_WALL_SECONDS,
        };
        let bad = |what: &str| {
            Error::input(
                dir.display().to_string(),
                format!(
                    "{what}: not a finished run directory of hsph run (it needs summary.json and scene.toml)"
                ),
            )
        };
        let summary = dir.join("summary.json");
        if !summary.exists() {
            return Err(bad("no summary.json"));
        }
        let s = crate::limits::read_summary(&summary)?;
        let f = FileNumbers::of(&summary);
        let need = |k: &str| {
            s.get(k)
                .filter(|v| !v.is_null())
                .map(Number::Json)
                .ok_or_else(|| {
                    f.error(
                        k,
                        "is missing: the model needs it (a summary.json of hsph run has it)".into(),
                    )
                })
        };
        let ranks = f.count("ranks", need("ranks")?, (1, MAX_RANKS as u64))? as usize;
        let threads = f.count("threads", need("threads")?, (1, MAX_THREADS as u64))? as usize;
        let nodes = f.count("nodes", need("nodes")?, (1, ranks as u64))? as usize;
        // a population that changed (`[[refine]] adapt`) is taken at its mean over the
        // steps: the final count would credit every step with the last step's particles
        let particles = match s.get("particles_mean").filter(|v| !v.is_null()) {
            Some(v) => f
                .real("particles_mean", Number::Json(v), (1.0, MAX_PARTICLES as f64))?
                .round() as u64,
            None => f.count("particles", need("particles")?, (1, MAX_PARTICLES))?,
        };
        if (particles as usize) < ranks {
            return Err(f.error(
                "ranks",
                format!("{ranks} ranks for {particles} particles: a run has at least one particle per rank"),
            ));
        }
        let steps = f.count("steps", need("steps")?, (0, MAX_STEPS as u64))?;
        if steps == 0 {
            return Err(f.error(
                "steps",
                "is 0: the model needs a run that took steps (its cost per step); run with more \
                 time.max_steps or a later time.t_end"
                    .into(),
            ));
        }
        let wall = f.real("wall_s", need("wall_s")?, (0.0, MAX_WALL_SECONDS))?;
        if wall <= 0.0 {
            return Err(f.error(
                "wall_s",
                format!("is {wall}: the model needs a positive step-loop time (s), up to {MAX_WALL_SECONDS}"),
            ));
        }
        let placement: Placement = match s.get("placement").and_then(|p| p.as_str()) {
            None => Placement::RankOrder,
            Some(p) => p.parse().map_err(|_| {
                f.error(
                    "placement",
                    format!(
                        "`{p}` is not a placement of hsph (rank-order, centre-distance, node-grid, min-cut)"
                    ),
                )
            })?,
        };
        let phases = s["timers"]
            .as_object()
            .map(|m| {
                m.iter()
                    .filter_map(|(k, v)| Some((k.trim_end_matches("_s").to_string(), v["mean"].as_f64()?)))
                    .collect()
            })
            .unwrap_or_default();
        let (scene, _) = load_scene(&dir.join("scene.toml"), &[])?;
        Ok(Measured {
            dir: dir.display().to_string(),
            scene,
            ranks,
            threads,
            nodes,
            placement,
            particles,
            steps,
            wall,
            phases,
        })
    }

    /// Seconds per step.
    pub fn per_step(&self) -> f64 {
        self.wall / self.steps as f64
    }

    /// The plan of this run's layout (its placement, nodes of equal size).
    pub fn plan(&self) -> Result<(PlanRow, Topology)> {
        let topo = Topology::from_ranks_per_node(self.ranks, self.ranks.div_ceil(self.nodes))?;
        let row = plan(&self.scene, self.ranks, &topo, &[self.placement])?.remove(0);
        Ok((row, topo))
    }
}

/// One rank's step: its CPU work (divided among its threads), its waits in the exchanges and
/// its node's network share (s).
#[derive(Debug, Clone, Copy)]
struct RankStep {
    cpu: f64,
    wait: f64,
    network: f64,
    /// Share of the CPU work on particles whose neighbours are all owned.
    interior: f64,
}

impl RankStep {
    /// The step's seconds: compute then exchange, or with `overlap` the exchange less what
    /// the interior's compute hides.
    fn total(&self, overlap: bool) -> f64 {
        let exchange = self.wait + self.network;
        match overlap {
            false => self.cpu + exchange,
            true => self.cpu + (exchange - self.interior * self.cpu).max(0.0),
        }
    }
}

/// Per-rank parts of one step for the layout of `row` on `topo`.
fn rank_steps(
    cal: &Calibration,
    net: &Network,
    row: &PlanRow,
    topo: &Topology,
    th: &Threads,
) -> Vec<RankStep> {
    let p = row.owned.len();
    let nodes = topo.nodes();
    let (mut out_b, mut in_b) = (vec![0u64; nodes], vec![0u64; nodes]);
    let mut talks = vec![false; nodes];
    for s in 0..p {
        for d in 0..p {
            let (ns, nd) = (topo.node_of(s), topo.node_of(d));
            let b = row.bytes[s * p + d];
            if ns != nd && b > 0 {
                out_b[ns] += b;
                in_b[nd] += b;
                talks[ns] = true;
                talks[nd] = true;
            }
        }
    }
    let net_t: Vec<f64> = (0..nodes)
        .map(|n| {
            let lat = if talks[n] {
                row.exchanges as f64 * net.latency
            } else {
                0.0
            };
            out_b[n].max(in_b[n]) as f64 / net.bandwidth + lat
        })
        .collect();
    let g_cpu = cal.ghost_cpu.min(cal.per_ghost);
    (0..p)
        .map(|r| {
            let (n, m) = (row.owned[r] as f64, row.ghosts[r] as f64);
            RankStep {
                cpu: (cal.per_particle * row.work[r] + g_cpu * m) / th.speedup(),
                wait: (cal.per_ghost - g_cpu) * m,
                network: net_t[topo.node_of(r)],
                interior: if n > 0.0 { (1.0 - m / n).max(0.0) } else { 0.0 },
            }
        })
        .collect()
}

/// Per-rank seconds of one step for the layout of `row` on `topo` (one thread, no overlap).
pub fn rank_times(cal: &Calibration, net: &Network, row: &PlanRow, topo: &Topology) -> Vec<f64> {
    rank_steps(cal, net, row, topo, &Threads::ONE)
        .iter()
        .map(|s| s.total(false))
        .collect()
}

/// Seconds of a step of `row` on `topo` with `cores` cores: the slowest rank, or with more
/// threads than cores the CPU work of a core (threads add no core).
pub fn step_time(
    cal: &Calibration,
    net: &Network,
    row: &PlanRow,
    topo: &Topology,
    cores: usize,
    o: &Options,
) -> f64 {
    let p = row.owned.len();
    if p * o.threads.t.max(1) <= cores.max(1) {
        return rank_steps(cal, net, row, topo, &o.threads)
            .iter()
            .map(|s| s.total(o.overlap))
            .fold(0.0, f64::max);
    }
    let cpu: f64 = (0..p)
        .map(|r| cal.per_particle * row.work[r] + cal.ghost_cpu * row.ghosts[r] as f64)
        .sum();
    cpu / cores as f64
}

/// Calibrate on a one-rank run `one` (`a`) and multi-rank runs `many` of this machine
/// (`cores`: its cores): runs with a core per rank fit `g` (least squares on their slowest
/// rank), runs with more ranks than cores fit `g_cpu` (on a core's share of the work); a
/// missing kind takes the other's value.
pub fn calibrate(one: &Measured, many: &[Measured], cores: usize) -> Result<Calibration> {
    if one.ranks != 1 || one.threads != 1 {
        return Err(Error::input(
            "--one",
            format!(
                "{}: needs a run on 1 rank with 1 thread (it had {} × {})",
                one.dir, one.ranks, one.threads
            ),
        ));
    }
    let ps = (one.particles * one.steps) as f64;
    let a = one.wall / ps;
    let per_phase = one.phases.iter().map(|(k, v)| (k.clone(), v / ps)).collect();
    // Σ G·(T − A) / Σ G² per kind: [a core per rank, shared cores]
    let mut fit = [(0.0f64, 0.0f64); 2];
    for m in many {
        if m.ranks < 2 || m.threads != 1 || m.nodes != 1 {
            return Err(Error::input(
                "--many",
                format!(
                    "{}: needs a run on 2 or more ranks of 1 thread on one node",
                    m.dir
                ),
            ));
        }
        let (row, _) = m.plan()?;
        let (kind, coef_a, coef_g) = if m.ranks <= cores {
            let r = (0..row.work.len())
                .max_by(|&i, &j| row.work[i].total_cmp(&row.work[j]))
                .unwrap_or(0);
            (0, a * row.work[r], row.ghosts[r] as f64)
        } else {
            let n: u64 = row.owned.iter().sum();
            let g: u64 = row.ghosts.iter().sum();
            (1, a * n as f64 / cores as f64, g as f64 / cores as f64)
        };
        fit[kind].0 += coef_g * (m.per_step() - coef_a);
        fit[kind].1 += coef_g * coef_g;
    }
    let solve = |(num, den): (f64, f64)| (den > 0.0).then(|| (num / den).max(0.0));
    let (wait, cpu) = (solve(fit[0]), solve(fit[1]));
    let (per_ghost, ghost_cpu) = match (wait, cpu) {
        (Some(w), Some(c)) => (w, c),
        (Some(w), None) => (w, w),
        (None, Some(c)) => (c, c),
        (None, None) => {
            return Err(Error::input(
                "--many",
                "give at least one multi-rank run directory",
            ))
        }
    };
    Ok(Calibration {
        per_particle: a,
        per_phase,
        per_ghost,
        ghost_cpu,
        thread_eff: None,
    })
}

/// The thread efficiency e(2) from `two`, a run of one rank with 2 threads, against the
/// one-thread run `one`'s seconds per particle-step.
pub fn thread_efficiency(one: &Measured, two: &Measured) -> Result<f64> {
    if two.ranks != 1 || two.threads != 2 {
        return Err(Error::input(
            "--two",
            format!(
                "{}: needs a run on 1 rank with 2 threads (it had {} × {})",
                two.dir, two.ranks, two.threads
            ),
        ));
    }
    let per = |m: &Measured| m.wall / (m.particles * m.steps) as f64;
    let e = per(one) / (2.0 * per(two));
    if !(e.is_finite() && e > 0.0) {
        return Err(Error::input(
            "--two",
            format!("{}: no usable step time (wall {} s)", two.dir, two.wall),
        ));
    }
    Ok(e)
}

/// One prediction.
#[derive(Debug, Clone)]
pub struct Prediction {
    /// Placement.
    pub placement: Placement,
    /// Seconds per step.
    pub step: f64,
    /// Seconds of the slowest rank's compute (owned + ghosts) and of its network share.
    pub compute: f64,
    /// Network seconds of the busiest node.
    pub network: f64,
    /// Speed-up against one rank and parallel efficiency.
    pub speedup: f64,
    /// `speedup / (P·t)`: against one core.
    pub efficiency: f64,
    /// The load imbalance of the plan row (max/mean of the balanced load).
    pub imbalance: f64,
}

/// Predict the step of every plan row.
pub fn predict(
    cal: &Calibration,
    net: &Network,
    rows: &[PlanRow],
    topo: &Topology,
    cores: usize,
    o: &Options,
) -> Vec<Prediction> {
    rows.iter()
        .map(|row| {
            let parts = rank_steps(cal, net, row, topo, &o.threads);
            let step = step_time(cal, net, row, topo, cores, o);
            let n: u64 = row.owned.iter().sum();
            let p = row.owned.len() as f64;
            let speedup = cal.per_particle * n as f64 / step;
            Prediction {
                placement: row.placement,
                step,
                compute: parts.iter().map(|s| s.cpu + s.wait).fold(0.0, f64::max),
                network: parts
                    .iter()
                    .map(|s| s.total(o.overlap) - s.cpu - s.wait)
                    .fold(0.0, f64::max),
                speedup,
                efficiency: speedup / (p * o.threads.t.max(1) as f64),
                imbalance: row.imbalance,
            }
        })
        .collect()
}

/// One layout of [`layouts`]: ranks × threads on nodes of C cores.
#[derive(Debug, Clone)]
pub struct LayoutRow {
    /// Placement of the ranks on the nodes.
    pub placement: Placement,
    /// Particles of the scene.
    pub particles: u64,
    /// Ranks in all.
    pub ranks: usize,
    /// Threads per rank.
    pub threads: usize,
    /// Ghosts received over owned particles.
    pub ghost_fraction: f64,
    /// Thread efficiency e(t), pessimistic and optimistic.
    pub thread_eff: [f64; 2],
    /// Slowest rank's CPU seconds (pessimistic threads) and exchange seconds (waits and network).
    pub compute: f64,
    /// Slowest rank's exchange seconds (waits and network).
    pub exchange: f64,
    /// Seconds per step: pessimistic, optimistic threads; pessimistic with overlap.
    pub step: [f64; 3],
    /// Efficiency against one core, a·N/(P·t·T), pessimistic and optimistic.
    pub efficiency: [f64; 2],
}

/// Every layout ranks × threads (C×1, C/2×2, …, 1×C: the divisors of `cores` C) of `nodes`
/// nodes of C cores for `scene`, under each of `placements`: the plan of each rank count and
/// its step.
pub fn layouts(
    cal: &Calibration,
    net: &Network,
    scene: &Scene,
    (nodes, cores): (usize, usize),
    placements: &[Placement],
) -> Result<Vec<LayoutRow>> {
    let e2 = cal.thread_eff.ok_or_else(|| {
        Error::input(
            "--two",
            "ranking layouts with threads needs the thread efficiency: give a run of the \
             --one run's scene on 1 rank with 2 threads, e.g. --two r1t2",
        )
    })?;
    let mut out = Vec::new();
    for t in (1..=cores).filter(|t| cores % t == 0) {
        let per_node = cores / t;
        let ranks = nodes * per_node;
        let topo = Topology::from_ranks_per_node(ranks, per_node)?;
        for row in plan(scene, ranks, &topo, placements)? {
            out.push(layout_row(
                cal,
                net,
                &row,
                &topo,
                Threads {
                    t,
                    e2,
                    pessimistic: true,
                },
            ));
        }
    }
    Ok(out)
}

/// One layout's figures: `th` pessimistic, and the same threads optimistic.
fn layout_row(cal: &Calibration, net: &Network, row: &PlanRow, topo: &Topology, th: Threads) -> LayoutRow {
    let (ranks, t) = (row.owned.len(), th.t);
    let opt = Threads {
        pessimistic: false,
        ..th
    };
    let at = |threads, overlap| Options { threads, overlap };
    let step = |o: Options| step_time(cal, net, row, topo, ranks * t, &o);
    let parts = rank_steps(cal, net, row, topo, &th);
    let slowest = (0..parts.len())
        .max_by(|&a, &b| parts[a].total(false).total_cmp(&parts[b].total(false)))
        .unwrap_or(0);
    let n: u64 = row.owned.iter().sum();
    let steps = [step(at(th, false)), step(at(opt, false)), step(at(th, true))];
    let eff = |s: f64| cal.per_particle * n as f64 / (s * (ranks * t) as f64);
    LayoutRow {
        placement: row.placement,
        particles: n,
        ranks,
        threads: t,
        ghost_fraction: row.ghosts.iter().sum::<u64>() as f64 / n.max(1) as f64,
        thread_eff: [th.efficiency(), opt.efficiency()],
        compute: parts.get(slowest).map_or(0.0, |s| s.cpu),
        exchange: parts.get(slowest).map_or(0.0, |s| s.wait + s.network),
        step: steps,
        efficiency: [eff(steps[0]), eff(steps[1])],
    }
}

/// The layouts as a table, the fastest named and why.
pub fn layouts_text(rows: &[LayoutRow], cores: usize) -> String {
    let mut s = String::from(
        "| layout (ranks × threads) | placement | ghost fraction | thread eff. (pess.–opt.) | compute s | exchange s | s/step pess. | s/step opt. | s/step pess., overlap | efficiency pess.–opt. |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} × {} | {} | {:.3} | {:.3}–{:.3} | {:.5} | {:.5} | {:.5} | {:.5} | {:.5} | {:.3}–{:.3} |",
            r.ranks,
            r.threads,
            r.placement.name(),
            r.ghost_fraction,
            r.thread_eff[0],
            r.thread_eff[1],
            r.compute,
            r.exchange,
            r.step[0],
            r.step[1],
            r.step[2],
            r.efficiency[0],
            r.efficiency[1]
        );
    }
    let by = |k: usize| {
        let mut order: Vec<&LayoutRow> = rows.iter().collect();
        order.sort_by(|a, b| a.step[k].total_cmp(&b.step[k]));
        order
    };
    let (pess, opt) = (by(0), by(1));
    if let (Some(b), Some(o)) = (pess.first(), opt.first()) {
        // the reason: against the one-thread layout, or against the runner-up if that is it
        let flat = rows
            .iter()
            .find(|r| r.threads == 1 && r.placement == b.placement && b.threads != 1);
        let other = flat.or_else(|| pess.iter().copied().find(|r| r.threads != b.threads));
        let _ = write!(
            s,
            "\nfastest on nodes of {cores} cores: {} × {} ({}) at {:.5} s/step with pessimistic \
             threads ({} × {} ({}) with optimistic threads).",
            b.ranks,
            b.threads,
            b.placement.name(),
            b.step[0],
            o.ranks,
            o.threads,
            o.placement.name()
        );
        if let Some(a) = other {
            let _ = write!(
                s,
                " Against {} × {} ({}, {:.5} s/step): ghost fraction {:.3} instead of {:.3}, exchange \
                 {:.5} s instead of {:.5} s, compute {:.5} s instead of {:.5} s, thread efficiency \
                 {:.3} instead of {:.3}.",
                a.ranks,
                a.threads,
                a.placement.name(),
                a.step[0],
                b.ghost_fraction,
                a.ghost_fraction,
                b.exchange,
                a.exchange,
                b.compute,
                a.compute,
                b.thread_eff[0],
                a.thread_eff[0]
            );
        }
        s.push('\n');
    }
    s
}

/// The calibration as text.
pub fn calibration_text(cal: &Calibration, one: &Measured, many: &[Measured]) -> String {
    let mut s = String::new();
    let runs: Vec<String> = many
        .iter()
        .map(|m| format!("{} ({} ranks)", m.dir, m.ranks))
        .collect();
    let _ = writeln!(
        s,
        "calibration: a = {:.3} µs per particle-step ({}: {} particles × {} steps, 1 rank); \
         g = {:.3} µs per ghost-step with a core per rank, g_cpu = {:.3} µs with shared cores \
         (fitted on {})",
        cal.per_particle * 1e6,
        one.dir,
        one.particles,
        one.steps,
        cal.per_ghost * 1e6,
        cal.ghost_cpu * 1e6,
        runs.join(", ")
    );
    let phases: Vec<String> = cal
        .per_phase
        .iter()
        .filter(|(_, v)| *v > 0.0)
        .map(|(k, v)| format!("{k} {:.3}", v * 1e6))
        .collect();
    let _ = writeln!(s, "per phase (µs per particle-step): {}", phases.join(", "));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(owned: Vec<u64>, ghosts: Vec<u64>, bytes: Vec<u64>) -> PlanRow {
        PlanRow {
            placement: Placement::RankOrder,
            ran: Placement::RankOrder,
            imbalance: 1.0,
            count_imbalance: 1.0,
            ghost_fraction: 0.0,
            intra_node_bytes: 0,
            inter_node_bytes: 0,
            messages: 0,
            node_pairs: 0,
            max_node_inter_bytes: 0,
            bytes,
            work: owned.iter().map(|&c| c as f64).collect(),
            owned,
            ghosts,
            exchanges: 3,
        }
    }

    #[test]
    fn model_step_by_hand() {
        // 4 ranks on 2 nodes of 2; rank 1 sends 1 MB to rank 2 (other node), rank 0 to rank 1
        // (same node) 2 MB: only the first crosses the network
        let cal = Calibration {
            per_particle: 1e-6,
            per_phase: Vec::new(),
            per_ghost: 2e-6,
            ghost_cpu: 5e-7,
            thread_eff: None,
        };
        let net = Network {
            bandwidth: 1e9,
            latency: 1e-6,
        };
        let mut bytes = vec![0u64; 16];
        bytes[6] = 1_000_000; // 1 → 2
        bytes[1] = 2_000_000; // 0 → 1
        let r = row(vec![1000, 2000, 1000, 1000], vec![0, 100, 50, 0], bytes);
        let topo = Topology::from_ranks_per_node(4, 2).unwrap();
        let t = rank_times(&cal, &net, &r, &topo);
        // node traffic 1 MB each way: 1 ms + 3 exchanges × 1 µs on every rank
        let net_t = 1e-3 + 3e-6;
        let want = [
            1e-3 + net_t,
            2e-3 + 2e-4 + net_t,
            1e-3 + 1e-4 + net_t,
            1e-3 + net_t,
        ];
        for (a, b) in t.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{t:?}");
        }
        let plain = Options::PLAIN;
        assert!((step_time(&cal, &net, &r, &topo, 4, &plain) - want[1]).abs() < 1e-12);
        // two cores for four ranks: the CPU work of a core, without waits or network
        let cpu = (5000.0 * 1e-6 + 150.0 * 5e-7) / 2.0;
        assert!((step_time(&cal, &net, &r, &topo, 2, &plain) - cpu).abs() < 1e-12);
        // one node: no network at all
        let one = Topology::from_ranks_per_node(4, 4).unwrap();
        assert!((step_time(&cal, &net, &r, &one, 4, &plain) - (2e-3 + 2e-4)).abs() < 1e-12);
    }

    /// e(t): 1, the measured e(2), then e(2)^log2(t) or e(2).
    #[test]
    fn thread_efficiency_measured_at_two_assumed_beyond() {
        let th = |t, pessimistic| Threads {
            t,
            e2: 0.9,
            pessimistic,
        };
        assert_eq!(th(1, true).efficiency(), 1.0);
        assert_eq!(th(2, true).efficiency(), 0.9);
        assert_eq!(th(2, false).efficiency(), 0.9);
        assert!((th(4, true).efficiency() - 0.81).abs() < 1e-12);
        assert!((th(8, true).efficiency() - 0.729).abs() < 1e-12);
        assert_eq!(th(8, false).efficiency(), 0.9);
        assert!((th(4, true).speedup() - 3.24).abs() < 1e-12);
    }

    /// Threads divide a rank's CPU work, not its waits or the network; an overlapped
    /// exchange costs only what exceeds the interior's compute.
    #[test]
    fn threads_and_overlap_by_hand() {
        let cal = Calibration {
            per_particle: 1e-6,
            per_phase: Vec::new(),
            per_ghost: 2e-6,
            ghost_cpu: 5e-7,
            thread_eff: Some(0.8),
        };
        let net = Network {
            bandwidth: 1e9,
            latency: 0.0,
        };
        // two ranks on two nodes, 1 MB each way
        let mut bytes = vec![0u64; 4];
        bytes[1] = 1_000_000;
        bytes[2] = 1_000_000;
        let r = row(vec![1000, 1000], vec![100, 100], bytes);
        let topo = Topology::from_ranks_per_node(2, 1).unwrap();
        let two = Options {
            threads: Threads {
                t: 2,
                e2: 0.8,
                pessimistic: true,
            },
            overlap: false,
        };
        let cpu = (1000.0 * 1e-6 + 100.0 * 5e-7) / 1.6;
        let exchange = 100.0 * 1.5e-6 + 1e-3;
        let t = step_time(&cal, &net, &r, &topo, 4, &two);
        assert!((t - (cpu + exchange)).abs() < 1e-12, "{t}");
        // overlapped: the interior (1 − 100/1000 of the work) hides 0.9·cpu of the exchange
        let over = step_time(&cal, &net, &r, &topo, 4, &Options { overlap: true, ..two });
        assert!((over - (cpu + exchange - 0.9 * cpu)).abs() < 1e-12, "{over}");
        // one thread, no overlap: the bulk-synchronous model as before
        let plain = step_time(&cal, &net, &r, &topo, 2, &Options::PLAIN);
        assert!((plain - (1e-3 + 2e-4 + 1e-3)).abs() < 1e-12, "{plain}");
    }

    /// Ranking the layouts of a 4-core node: with threads as good as ranks (e(2) = 1) and a
    /// cost per ghost, one rank of 4 threads (no ghosts) is fastest; with threads worth
    /// nothing (e(2) = 0.5) four ranks of one thread are.
    #[test]
    fn layouts_rank_ranks_against_threads() {
        let (scene, _) = load_scene(Path::new("inputs/hydrostatic_2d.toml"), &[]).unwrap();
        let net = Network {
            bandwidth: 1e9,
            latency: 1e-6,
        };
        let cal = |e2| Calibration {
            per_particle: 1e-6,
            per_phase: Vec::new(),
            per_ghost: 2e-6,
            ghost_cpu: 5e-7,
            thread_eff: Some(e2),
        };
        let fastest = |e2| {
            let rows = layouts(&cal(e2), &net, &scene, (1, 4), &[Placement::RankOrder]).unwrap();
            let got: Vec<(usize, usize)> = rows.iter().map(|r| (r.ranks, r.threads)).collect();
            assert_eq!(got, vec![(4, 1), (2, 2), (1, 4)]);
            assert_eq!(rows[2].ghost_fraction, 0.0);
            assert!(rows[0].ghost_fraction > rows[1].ghost_fraction);
            let b = rows
                .iter()
                .min_by(|a, b| a.step[0].total_cmp(&b.step[0]))
                .unwrap();
            (b.ranks, b.threads)
        };
        assert_eq!(fastest(1.0), (1, 4));
        assert_eq!(fastest(0.5), (4, 1));
        let none = Calibration {
            thread_eff: None,
            ..cal(1.0)
        };
        assert!(layouts(&none, &net, &scene, (1, 4), &[Placement::RankOrder]).is_err());
    }
}
