//! `hsph plan`: a dry run of the parallel layout. Streams the initial sites, decomposes,
//! places the blocks on ranks and counts the halo of one step — every exchange the step makes
//! (ghost build, then the refreshes its passes need) — without running physics or starting
//! ranks. The count uses the engine's own rule ([`crate::halo::ghost_counts`]), so it equals
//! the `halo` traffic of a real run's set-up step (`traffic.csv`, step 0) byte for byte.

use crate::boundary::image_space;
use crate::comm::serial::SerialComm;
use crate::decomp::{fold_parts, Cloud};
use crate::error::{Error, Result};
use crate::halo::Ranks;
use crate::halo::{field_bytes, ghost_counts, record_bytes};
use crate::particles::Fields;
use crate::physics::passes::{build_fields, exchanges, schedule};
use crate::physics::Model;
use crate::placement::Placement;
use crate::placement::{halo_volumes, place_reporting, PairVolumes};
use crate::scene::Scene;
use crate::setup::{LayerShare, SiteSource};
use crate::sim::balanced_blocks;
use crate::topology::Topology;
use serde_json::json;
use std::fmt::Write as _;
use std::path::Path;

/// What one placement gives.
#[derive(Debug, Clone)]
pub struct PlanRow {
    /// Placement method asked for.
    pub placement: Placement,
    /// Placement method that placed the blocks (differs when `node-grid` finds no fit).
    pub ran: Placement,
    /// The load imbalance: max/mean over ranks of the load the decomposition balances
    /// (`balance.load`: particles, or their expected pairs; under `balance.weights`), the
    /// figure a run reports as `imbalance`.
    pub imbalance: f64,
    /// max/mean owned particles over ranks (memory: a rank's share of the particles).
    pub count_imbalance: f64,
    /// Ghosts received from other ranks over all particles.
    pub ghost_fraction: f64,
    /// Halo payload bytes of one step between ranks of one node (self-sends included).
    pub intra_node_bytes: u64,
    /// Halo payload bytes of one step between ranks of different nodes.
    pub inter_node_bytes: u64,
    /// Halo messages of one step.
    pub messages: u64,
    /// Unordered pairs of distinct nodes that exchange ghosts.
    pub node_pairs: usize,
    /// Largest inter-node halo bytes (sent + received) of any node.
    pub max_node_inter_bytes: u64,
    /// Halo bytes per (src rank, dst rank), flat `P × P`.
    pub bytes: Vec<u64>,
    /// Owned particles of each rank.
    pub owned: Vec<u64>,
    /// Each rank's share of the work in particles of the mean cost: its owned particles
    /// weighed by the decomposition's load (expected pairs under `balance.load = "pairs"`, a
    /// dummy wall particle a fraction of a fluid one), scaled to sum to the particles.
    pub work: Vec<f64>,
    /// Ghosts each rank receives in one step's build (self images included).
    pub ghosts: Vec<u64>,
    /// Halo exchanges (messages per communicating rank pair) of one step.
    pub exchanges: u64,
}

/// The exchanges of one step and their bytes per ghost, derived from the passes the scene's
/// model runs ([`crate::physics::passes::exchanges`]): the run refreshes the same fields.
pub fn step_exchanges<const D: usize>(scene: &Scene) -> Vec<(&'static str, u64)> {
    let schedule = schedule(&Model::<D>::new(scene));
    let unsent = Fields::ALL.without(build_fields(&schedule));
    exchanges(&schedule)
        .into_iter()
        .map(|(name, fields)| match fields {
            None => (
                name,
                record_bytes::<D>(crate::setup::dropped_fields(scene).or(unsent)),
            ),
            Some(f) => (name, field_bytes::<D>(f)),
        })
        .collect()
}

/// Plan every placement in `methods` for `ranks` ranks on `topology`.
pub fn plan(scene: &Scene, ranks: usize, topology: &Topology, methods: &[Placement]) -> Result<Vec<PlanRow>> {
    topology.check_ranks(ranks)?;
    crate::with_dim!(scene.dimension, D => plan_dim::<D>(scene, ranks, topology, methods))
}

fn plan_dim<const D: usize>(
    scene: &Scene,
    ranks: usize,
    topology: &Topology,
    methods: &[Placement],
) -> Result<Vec<PlanRow>> {
    // the sites are streamed, never stored: `plan` at 10 M particles needs no more memory
    // than the P × P counters (README, "Commands": `plan`)
    let src = SiteSource::<D>::new(scene)?;
    let cloud = LayerShare::of_rank(&src, 0, 1);
    let serial = SerialComm::new();
    let support = Model::<D>::new(scene).kernel.support;
    let space = image_space::<D>(scene);
    let step = step_exchanges::<D>(scene);
    let per_ghost: u64 = step.iter().map(|e| e.1).sum();
    let exchanges = step.len() as u64;
    // the decomposition, the block-to-block ghost counts and the halo volumes do not depend
    // on the placement: compute them once, then only relabel blocks as ranks
    let bounds = (&space.min, &space.max);
    let decomp = balanced_blocks(
        &cloud,
        bounds,
        ranks,
        (src.id_bound(), scene.balance.count_cap()),
        &serial,
    )?;
    let blocks = Ranks::new(decomp.clone(), (0..ranks).collect());
    // the ghosts of the set-up step reach support + skin (sim::skin)
    let reach = support * (1.0 + scene.performance.skin);
    let block_counts = ghost_counts(&cloud, &space, &blocks, &blocks.boxes(), reach);
    let volumes = if methods.iter().any(|m| *m != Placement::RankOrder) {
        halo_volumes(&cloud, &decomp, support)
    } else {
        PairVolumes::zeros(ranks)
    };
    // (particles, load) of every block
    let block_owned = fold_parts(
        &cloud,
        || vec![(0u64, 0u64); ranks],
        |acc, k| {
            cloud.visit_loads(k, |x, id, w| {
                let b = &mut acc[decomp.block_of(x, id)];
                (b.0, b.1) = (b.0 + 1, b.1 + w);
            })
        },
        |mut a, b| {
            a.iter_mut()
                .zip(b)
                .for_each(|(u, v)| (u.0, u.1) = (u.0 + v.0, u.1 + v.1));
            a
        },
    );
    let (n, load) = block_owned
        .iter()
        .fold((0u64, 0u64), |s, b| (s.0 + b.0, s.1 + b.1));
    let per_load = n as f64 / load.max(1) as f64;
    let mut rows = Vec::new();
    for &method in methods {
        let (block_to_rank, ran) = place_reporting(&decomp, topology, method, &volumes);
        let mut counts = vec![0u64; ranks * ranks];
        for s in 0..ranks {
            for d in 0..ranks {
                counts[block_to_rank[s] * ranks + block_to_rank[d]] = block_counts[s * ranks + d];
            }
        }
        let mut owned = vec![0u64; ranks];
        let mut work = vec![0.0; ranks];
        let mut loads = vec![0u64; ranks];
        for (b, c) in block_owned.iter().enumerate() {
            owned[block_to_rank[b]] = c.0;
            loads[block_to_rank[b]] = c.1;
            work[block_to_rank[b]] = c.1 as f64 * per_load;
        }
        let mut row = plan_row(method, ran, counts, owned, topology, per_ghost, exchanges);
        row.imbalance = crate::decomp::rank_imbalance(&loads, &scene.balance.weights);
        row.work = work;
        rows.push(row);
    }
    Ok(rows)
}

/// The row of one placement from its rank-to-rank ghost counts (`counts[src * P + dst]`), its
/// owned particles per rank, the bytes of one ghost in a step's exchanges and their number.
fn plan_row(
    method: Placement,
    ran: Placement,
    counts: Vec<u64>,
    owned: Vec<u64>,
    topology: &Topology,
    per_ghost: u64,
    exchanges: u64,
) -> PlanRow {
    let ranks = owned.len();
    let n: u64 = owned.iter().sum();
    let mean = n as f64 / ranks as f64;
    let count_imbalance = *owned.iter().max().unwrap_or(&0) as f64 / mean.max(1e-300);
    let (mut intra, mut inter, mut remote, mut messages) = (0u64, 0u64, 0u64, 0u64);
    let nodes = topology.nodes();
    let mut node_pair = vec![0u64; nodes * nodes];
    let mut node_inter = vec![0u64; nodes];
    let bytes: Vec<u64> = counts.iter().map(|c| c * per_ghost).collect();
    for s in 0..ranks {
        for d in 0..ranks {
            let c = counts[s * ranks + d];
            if c == 0 {
                continue;
            }
            messages += exchanges;
            if s != d {
                remote += c;
            }
            let (ns, nd) = (topology.node_of(s), topology.node_of(d));
            let b = c * per_ghost;
            if ns == nd {
                intra += b;
            } else {
                inter += b;
                node_pair[ns.min(nd) * nodes + ns.max(nd)] += b;
                node_inter[ns] += b;
                node_inter[nd] += b;
            }
        }
    }
    PlanRow {
        placement: method,
        ran,
        imbalance: count_imbalance,
        count_imbalance,
        ghost_fraction: remote as f64 / n.max(1) as f64,
        intra_node_bytes: intra,
        inter_node_bytes: inter,
        messages,
        node_pairs: node_pair.iter().filter(|&&b| b > 0).count(),
        max_node_inter_bytes: node_inter.into_iter().max().unwrap_or(0),
        bytes,
        ghosts: (0..ranks)
            .map(|d| (0..ranks).map(|s| counts[s * ranks + d]).sum())
            .collect(),
        work: owned.iter().map(|&c| c as f64).collect(),
        owned,
        exchanges,
    }
}

/// The table `hsph plan` prints.
pub fn table(scene: &Scene, ranks: usize, topology: &Topology, rows: &[PlanRow]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "plan: {} on {ranks} ranks, {} node(s) of {} rank(s) ({}); halo of one step",
        scene.name,
        topology.nodes(),
        topology.ranks_per_node(),
        topology.name
    );
    let _ = writeln!(
        s,
        "| placement | load imbalance | count imbalance | ghost fraction | intra-node MB | inter-node MB | inter % | node pairs | max node inter MB |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let tot = (r.intra_node_bytes + r.inter_node_bytes).max(1) as f64;
        let _ = writeln!(
            s,
            "| {} | {:.4} | {:.4} | {:.4} | {:.3} | {:.3} | {:.1} | {} | {:.3} |",
            placement_label(r),
            r.imbalance,
            r.count_imbalance,
            r.ghost_fraction,
            r.intra_node_bytes as f64 / 1e6,
            r.inter_node_bytes as f64 / 1e6,
            100.0 * r.inter_node_bytes as f64 / tot,
            r.node_pairs,
            r.max_node_inter_bytes as f64 / 1e6
        );
    }
    s
}

/// The placement of a row as printed: the method, and what ran instead if it fell back.
fn placement_label(r: &PlanRow) -> String {
    if r.ran == r.placement {
        r.placement.name().to_string()
    } else {
        format!("{} (ran {})", r.placement, r.ran)
    }
}

/// Write `plan.json` and `plan.csv` into `dir`.
pub fn write(dir: &Path, scene: &Scene, ranks: usize, topology: &Topology, rows: &[PlanRow]) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let list: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            json!({
                "placement": r.placement.name(),
                "placement_ran": r.ran.name(),
                "imbalance": r.imbalance,
                "count_imbalance": r.count_imbalance,
                "ghost_fraction": r.ghost_fraction,
                "halo_intra_node_bytes": r.intra_node_bytes,
                "halo_inter_node_bytes": r.inter_node_bytes,
                "halo_messages": r.messages,
                "node_pairs": r.node_pairs,
                "max_node_inter_bytes": r.max_node_inter_bytes,
                "rank_pair_bytes": r.bytes,
            })
        })
        .collect();
    let doc = json!({
        "scene": scene.name,
        "ranks": ranks,
        "nodes": topology.nodes(),
        "ranks_per_node": topology.ranks_per_node(),
        "topology": topology.name,
        "placements": list,
    });
    let pj = dir.join("plan.json");
    let text = serde_json::to_string_pretty(&doc).map_err(|e| Error::run(e.to_string()))?;
    crate::output::write_file(&pj, (text + "\n").as_bytes())?;
    let mut csv = String::from(
        "placement,imbalance,count_imbalance,ghost_fraction,halo_intra_node_bytes,halo_inter_node_bytes,halo_messages,node_pairs,max_node_inter_bytes\n",
    );
    for r in rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{}",
            r.placement.name(),
            r.imbalance,
            r.count_imbalance,
            r.ghost_fraction,
            r.intra_node_bytes,
            r.inter_node_bytes,
            r.messages,
            r.node_pairs,
            r.max_node_inter_bytes
        );
    }
    let pc = dir.join("plan.csv");
    crate::output::write_file(&pc, csv.as_bytes())
}
