//! The layout a run actually got (nodes, ranks per node, threads, CPU sets), printed at start
//! and compared with the plan of the job script that started it.
//!
//! `hsph jobscript` exports `HSPH_JOB_PLAN="nodes=N,ranks_per_node=K,threads_per_rank=T"`; a
//! run that finds it warns where the launcher gave something else (a wrong `--ntasks-per-node`,
//! `--cpus-per-task` not passed on to `srun`, a thread count capped by the CPU mask).

use std::collections::BTreeMap;

/// Environment variable holding the job script's plan.
pub const PLAN_VAR: &str = "HSPH_JOB_PLAN";

/// What one rank reports about itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RankLayout {
    /// Node index of the rank.
    pub node: usize,
    /// Rayon threads of the rank.
    pub threads: usize,
    /// The CPUs the rank may run on (Linux's `Cpus_allowed_list`, e.g. `0-3,8`).
    pub cpus: String,
}

impl RankLayout {
    /// Wire form: `node;threads;cpus`.
    pub fn encode(&self) -> Vec<u8> {
        format!("{};{};{}", self.node, self.threads, self.cpus).into_bytes()
    }

    /// From [`RankLayout::encode`].
    pub fn decode(bytes: &[u8]) -> Option<Self> {
        let s = String::from_utf8_lossy(bytes);
        let mut it = s.splitn(3, ';');
        Some(RankLayout {
            node: it.next()?.parse().ok()?,
            threads: it.next()?.parse().ok()?,
            cpus: it.next()?.to_string(),
        })
    }
}

/// This process's allowed CPUs, from `/proc/self/status` (`?` where that is unavailable).
pub fn cpus_allowed() -> String {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("Cpus_allowed_list:"))
                .map(|v| v.trim().to_string())
        })
        .unwrap_or_else(|| "?".into())
}

/// A job script's plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Plan {
    /// Nodes asked for.
    pub nodes: usize,
    /// Ranks per node asked for.
    pub ranks_per_node: usize,
    /// Threads per rank asked for.
    pub threads_per_rank: usize,
}

impl Plan {
    /// The `HSPH_JOB_PLAN` form.
    pub fn encode(&self) -> String {
        format!(
            "nodes={},ranks_per_node={},threads_per_rank={}",
            self.nodes, self.ranks_per_node, self.threads_per_rank
        )
    }

    /// Parse `nodes=N,ranks_per_node=K,threads_per_rank=T` (`None` if malformed).
    pub fn parse(s: &str) -> Option<Plan> {
        let mut kv = BTreeMap::new();
        for part in s.split(',') {
            let (k, v) = part.split_once('=')?;
            kv.insert(k.trim(), v.trim().parse::<usize>().ok()?);
        }
        Some(Plan {
            nodes: *kv.get("nodes")?,
            ranks_per_node: *kv.get("ranks_per_node")?,
            threads_per_rank: *kv.get("threads_per_rank")?,
        })
    }
}

/// Ranks on each node of `ranks`.
fn per_node(ranks: &[RankLayout]) -> Vec<usize> {
    let nodes = ranks.iter().map(|r| r.node + 1).max().unwrap_or(0);
    let mut n = vec![0; nodes];
    for r in ranks {
        n[r.node] += 1;
    }
    n
}

/// `a` or `a–b`.
fn span(v: impl Iterator<Item = usize> + Clone) -> String {
    let (lo, hi) = (v.clone().min().unwrap_or(0), v.max().unwrap_or(0));
    if lo == hi {
        format!("{lo}")
    } else {
        format!("{lo}–{hi}")
    }
}

/// One line: nodes, ranks per node, threads per rank and the CPU set of each rank (the first 8).
pub fn describe(ranks: &[RankLayout]) -> String {
    let nodes = per_node(ranks);
    let mut cpus: Vec<String> = ranks
        .iter()
        .take(8)
        .enumerate()
        .map(|(k, r)| format!("{k}@node{}: {}", r.node, r.cpus))
        .collect();
    if ranks.len() > 8 {
        cpus.push(format!("… ({} more)", ranks.len() - 8));
    }
    format!(
        "layout: {} node(s), {} rank(s) per node, {} thread(s) per rank; CPUs of rank@node: {}",
        nodes.len(),
        span(nodes.iter().copied()),
        span(ranks.iter().map(|r| r.threads)),
        cpus.join(", ")
    )
}

/// Where the layout differs from `plan`, one sentence each.
pub fn differences(plan: &Plan, ranks: &[RankLayout]) -> Vec<String> {
    let nodes = per_node(ranks);
    let mut out = Vec::new();
    if nodes.len() != plan.nodes {
        out.push(format!(
            "the job script planned {} node(s), the run found {} (node identity from MPI's shared-memory split or --ranks-per-node)",
            plan.nodes,
            nodes.len()
        ));
    }
    if nodes.iter().any(|&n| n != plan.ranks_per_node) {
        out.push(format!(
            "the job script planned {} rank(s) per node, the run has {} per node",
            plan.ranks_per_node,
            nodes.iter().map(|n| n.to_string()).collect::<Vec<_>>().join("/")
        ));
    }
    if let Some(r) = ranks.iter().position(|r| r.threads != plan.threads_per_rank) {
        out.push(format!(
            "the job script planned {} thread(s) per rank, rank {r} runs {} (CPUs {}); set \
             RAYON_NUM_THREADS or pass --cpus-per-task to the launcher",
            plan.threads_per_rank, ranks[r].threads, ranks[r].cpus
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ranks(nodes: &[usize], threads: usize) -> Vec<RankLayout> {
        nodes
            .iter()
            .map(|&node| RankLayout {
                node,
                threads,
                cpus: "0-1".into(),
            })
            .collect()
    }

    #[test]
    fn a_plan_round_trips_and_the_layout_is_compared_with_it() {
        let plan = Plan {
            nodes: 2,
            ranks_per_node: 2,
            threads_per_rank: 1,
        };
        assert_eq!(Plan::parse(&plan.encode()), Some(plan));
        assert_eq!(Plan::parse("nodes=2,ranks_per_node=x,threads_per_rank=1"), None);
        let good = ranks(&[0, 0, 1, 1], 1);
        assert!(differences(&plan, &good).is_empty());
        let one_node = ranks(&[0, 0, 0, 0], 1);
        let d = differences(&plan, &one_node);
        assert_eq!(d.len(), 2, "{d:?}");
        assert!(d[0].contains("planned 2 node(s), the run found 1"));
        assert!(d[1].contains("has 4 per node"));
        let threads = differences(&plan, &ranks(&[0, 0, 1, 1], 2));
        assert_eq!(threads.len(), 1);
        assert!(threads[0].contains("rank 0 runs 2"));
        let r = &good[2];
        assert_eq!(RankLayout::decode(&r.encode()).as_ref(), Some(r));
        assert_eq!(
            describe(&good),
            "layout: 2 node(s), 2 rank(s) per node, 1 thread(s) per rank; CPUs of rank@node: \
             0@node0: 0-1, 1@node0: 0-1, 2@node1: 0-1, 3@node1: 0-1"
        );
    }
}
