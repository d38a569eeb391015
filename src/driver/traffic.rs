//! Message traffic: every rank's traffic gathered on rank 0 as of a step, appended to
//! `traffic.csv`, and its running totals by phase and intra/inter node with their estimated
//! cost (`summary.json`'s `traffic`).

use crate::comm::{Comm, Phase, TrafficEntry};
use crate::error::Result;
use crate::output::RunWriter;
use crate::topology::ByteCost;
use serde_json::json;
use std::collections::BTreeMap;

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
pub(super) struct TrafficTotals {
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
    pub(super) fn json(&self, cost: &ByteCost) -> serde_json::Value {
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

/// Gather the traffic since the last call (collective) and, on rank 0 (`writer`), add it to
/// the totals and append it to `traffic.csv` as of `step`.
pub(super) fn log_traffic<const D: usize>(
    comm: &dyn Comm,
    writer: Option<&mut RunWriter<D>>,
    totals: &mut TrafficTotals,
    node_of: &[usize],
    step: u64,
) -> Result<()> {
    let entries = gather_traffic(comm)?;
    if let Some(w) = writer {
        for e in &entries {
            totals.add(e, node_of);
        }
        w.traffic_rows(step, &entries, node_of)?;
    }
    Ok(())
}
