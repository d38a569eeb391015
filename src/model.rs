//! `hsph model`: a performance model of the step loop, calibrated on measured runs (issue 17).
//!
//! Bulk-synchronous: a step costs every rank
//!
//! ```text
//! T_r = a·n_r + g·m_r + T_net(node of r)
//! ```
//!
//! with `n_r` its owned particles and `m_r` the ghosts it receives per step (both from
//! [`crate::plan`], the engine's own decomposition and halo rule), `a` (s per particle-step)
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
//! Not modelled: memory-bandwidth contention between the ranks of a node, threads inside a
//! rank, load imbalance that grows during the run (the plan is the initial decomposition),
//! and output. Units: seconds, bytes, particles.

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
    /// Particles and steps.
    pub particles: u64,
    /// Steps taken.
    pub steps: u64,
    /// Step-loop wall time (s).
    pub wall: f64,
    /// Mean seconds per phase over ranks.
    pub phases: Vec<(String, f64)>,
}

impl Measured {
    /// Read `dir/summary.json` and `dir/scene.toml`.
    pub fn read(dir: &Path) -> Result<Self> {
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
        let text = crate::limits::read_text(&summary, "summary.json")?;
        let s: serde_json::Value =
            serde_json::from_str(&text).map_err(|_| bad("summary.json is not JSON"))?;
        let (scene, _) = load_scene(&dir.join("scene.toml"), &[])?;
        let num = |k: &str| {
            s[k].as_f64()
                .ok_or_else(|| bad(&format!("summary.json lacks `{k}`")))
        };
        let placement: Placement = s["placement"]
            .as_str()
            .and_then(|p| p.parse().ok())
            .unwrap_or(Placement::RankOrder);
        let phases = s["timers"]
            .as_object()
            .map(|m| {
                m.iter()
                    .filter_map(|(k, v)| Some((k.trim_end_matches("_s").to_string(), v["mean"].as_f64()?)))
                    .collect()
            })
            .unwrap_or_default();
        Ok(Measured {
            dir: dir.display().to_string(),
            scene,
            ranks: num("ranks")? as usize,
            threads: num("threads")? as usize,
            nodes: num("nodes")?.max(1.0) as usize,
            placement,
            particles: num("particles")? as u64,
            steps: num("steps")?.max(1.0) as u64,
            wall: num("wall_s")?,
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

/// Per-rank seconds of one step for the layout of `row` on `topo`.
pub fn rank_times(cal: &Calibration, net: &Network, row: &PlanRow, topo: &Topology) -> Vec<f64> {
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
    (0..p)
        .map(|r| compute_time(cal, row, r) + net_t[topo.node_of(r)])
        .collect()
}

/// Seconds rank `r` of `row` spends in a step on its owned particles and its ghosts.
fn compute_time(cal: &Calibration, row: &PlanRow, r: usize) -> f64 {
    cal.per_particle * row.owned[r] as f64 + cal.per_ghost * row.ghosts[r] as f64
}

/// Seconds of a step of `row` on `topo` with `cores` cores (single-threaded ranks): the
/// slowest rank, or with more ranks than cores the CPU work of a core.
pub fn step_time(cal: &Calibration, net: &Network, row: &PlanRow, topo: &Topology, cores: usize) -> f64 {
    let p = row.owned.len();
    if p <= cores.max(1) {
        return rank_times(cal, net, row, topo).into_iter().fold(0.0, f64::max);
    }
    let cpu: f64 = (0..p)
        .map(|r| cal.per_particle * row.owned[r] as f64 + cal.ghost_cpu * row.ghosts[r] as f64)
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
            let r = (0..row.owned.len()).max_by_key(|&r| row.owned[r]).unwrap_or(0);
            (0, a * row.owned[r] as f64, row.ghosts[r] as f64)
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
    })
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
    /// `speedup / P`.
    pub efficiency: f64,
    /// max/mean owned particles.
    pub imbalance: f64,
}

/// Predict the step of every plan row.
pub fn predict(
    cal: &Calibration,
    net: &Network,
    rows: &[PlanRow],
    topo: &Topology,
    cores: usize,
) -> Vec<Prediction> {
    rows.iter()
        .map(|row| {
            let t = rank_times(cal, net, row, topo);
            let step = step_time(cal, net, row, topo, cores);
            let n: u64 = row.owned.iter().sum();
            let p = row.owned.len() as f64;
            let compute = (0..row.owned.len())
                .map(|r| compute_time(cal, row, r))
                .fold(0.0, f64::max);
            let speedup = cal.per_particle * n as f64 / step;
            Prediction {
                placement: row.placement,
                step,
                compute,
                network: (0..t.len())
                    .map(|r| t[r] - compute_time(cal, row, r))
                    .fold(0.0, f64::max),
                speedup,
                efficiency: speedup / p,
                imbalance: row.imbalance,
            }
        })
        .collect()
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
            ghost_fraction: 0.0,
            intra_node_bytes: 0,
            inter_node_bytes: 0,
            messages: 0,
            node_pairs: 0,
            max_node_inter_bytes: 0,
            bytes,
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
        assert!((step_time(&cal, &net, &r, &topo, 4) - want[1]).abs() < 1e-12);
        // two cores for four ranks: the CPU work of a core, without waits or network
        let cpu = (5000.0 * 1e-6 + 150.0 * 5e-7) / 2.0;
        assert!((step_time(&cal, &net, &r, &topo, 2) - cpu).abs() < 1e-12);
        // one node: no network at all
        let one = Topology::from_ranks_per_node(4, 4).unwrap();
        assert!((step_time(&cal, &net, &r, &one, 4) - (2e-3 + 2e-4)).abs() < 1e-12);
    }
}
