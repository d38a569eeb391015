//! Node layouts: which ranks share a node, and what a byte costs inside and across nodes.
//!
//! A layout comes from a declarative TOML file (`topology/*.toml`, read by [`Topology::load`])
//! or from the `--ranks-per-node K` override ([`Topology::from_ranks_per_node`]). Either way
//! **virtual nodes hold consecutive ranks**: node `n` holds ranks
//! `n·ranks_per_node .. min((n+1)·ranks_per_node, ranks)` ([`Topology::node_of`]). Node ids are
//! dense, `0..nodes`. On a real cluster the engine derives the same numbering from MPI's
//! shared-memory split; the override wins over it so one machine can emulate many nodes.
//!
//! # File format
//!
//! ```toml
//! name = "four_nodes_24"          # optional; defaults to the file stem
//! description = "..."             # optional, free text
//!
//! [node]
//! count = 4                       # nodes (≥ 1)
//! numa_domains = 2                # NUMA domains per node (≥ 1)
//! cores_per_domain = 12           # physical cores per NUMA domain (≥ 1)
//! ranks = 24                      # MPI ranks (tasks) per node (≥ 1)
//! cpus_per_rank = 1               # optional: cores (threads) per rank; default cores / ranks
//!
//! [cost]                          # relative cost per payload byte (dimensionless, > 0)
//! intra_node = 1.0
//! inter_node = 10.0
//!
//! [latency]                       # per message (s, ≥ 0)
//! intra_node = 5.0e-7
//! inter_node = 2.0e-6
//! ```
//!
//! Unknown keys are errors (a typo must not silently fall back to a default). Every problem is
//! an [`Error::Input`] (exit status 2) naming the file, the line and the dotted key, and what
//! would be valid.
//!
//! A later `hsph jobscript` reads [`Topology::nodes`], [`Topology::tasks_per_node`] and
//! [`Topology::cpus_per_task`] (Slurm's `--nodes`, `--ntasks-per-node`, `--cpus-per-task`).

use crate::error::{Error, Location, Result};
use crate::scene::{first_line, key_at, line_of, span_of_key};
use serde::Deserialize;
use std::ops::Range;
use std::path::Path;
use toml_edit::ImDocument;

/// Per-node hardware and the ranks each node holds, as written in a topology file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeSpec {
    /// Number of nodes.
    pub count: usize,
    /// NUMA domains per node.
    pub numa_domains: usize,
    /// Physical cores per NUMA domain.
    pub cores_per_domain: usize,
    /// MPI ranks (tasks) per node.
    pub ranks: usize,
    /// Cores (rayon threads) per rank; `None` means `cores / ranks` (at least 1).
    #[serde(default)]
    pub cpus_per_rank: Option<usize>,
}

/// Relative cost per payload byte (dimensionless; only ratios matter).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ByteCost {
    /// Between two ranks of one node (shared memory).
    pub intra_node: f64,
    /// Between ranks of different nodes (network).
    pub inter_node: f64,
}

/// Latency per message (s).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Latency {
    /// Between two ranks of one node (s).
    pub intra_node: f64,
    /// Between ranks of different nodes (s).
    pub inter_node: f64,
}

/// The whole topology file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
struct TopologyFile {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    description: Option<String>,
    node: NodeSpec,
    cost: ByteCost,
    latency: Latency,
}

/// Default relative costs and latencies for layouts given only by `--ranks-per-node`: a
/// shared-memory copy against a 100 Gb/s-class network (a ratio of 10 per byte; 0.5 µs vs 2 µs).
pub const DEFAULT_COST: ByteCost = ByteCost {
    intra_node: 1.0,
    inter_node: 10.0,
};
/// See [`DEFAULT_COST`].
pub const DEFAULT_LATENCY: Latency = Latency {
    intra_node: 5.0e-7,
    inter_node: 2.0e-6,
};

/// A node layout of `ranks` ranks: consecutive ranks share a node.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    /// Name (file stem unless the file sets `name`).
    pub name: String,
    /// Free-text description from the file (empty if none).
    pub description: String,
    /// Total ranks.
    ranks: usize,
    /// Ranks per node (the last node may hold fewer, see [`Topology::from_ranks_per_node`]).
    ranks_per_node: usize,
    /// NUMA domains per node.
    pub numa_domains: usize,
    /// Physical cores per NUMA domain.
    pub cores_per_domain: usize,
    /// Cores (threads) per rank.
    cpus_per_rank: usize,
    /// Relative cost per byte inside / across nodes.
    pub cost: ByteCost,
    /// Latency per message inside / across nodes (s).
    pub latency: Latency,
}

impl Topology {
    /// Virtual nodes of `k` consecutive ranks each, for `--ranks-per-node K`: `⌈ranks/k⌉`
    /// nodes, the last one holding `ranks − (nodes−1)·k` ranks when `k` does not divide
    /// `ranks`. Hardware is unknown: one NUMA domain of `k` cores, one core per rank, and the
    /// default costs ([`DEFAULT_COST`], [`DEFAULT_LATENCY`]).
    ///
    /// # Errors
    /// [`Error::Input`] on key `ranks-per-node` if `k == 0` or `k > ranks`, or on `ranks` if
    /// `ranks == 0`.
    pub fn from_ranks_per_node(ranks: usize, k: usize) -> Result<Self> {
        if ranks == 0 {
            return Err(Error::input("ranks", "a layout needs at least one rank"));
        }
        if k == 0 {
            return Err(Error::input(
                "ranks-per-node",
                format!("0 ranks per node is not a layout; give 1 ..= {ranks} (the number of ranks)"),
            ));
        }
        if k > ranks {
            return Err(Error::input(
                "ranks-per-node",
                format!("{k} ranks per node is more than the {ranks} ranks of the run; give 1 ..= {ranks}"),
            ));
        }
        Ok(Topology {
            name: format!("{}x{k}", ranks.div_ceil(k)),
            description: format!("{ranks} ranks, {k} consecutive ranks per virtual node"),
            ranks,
            ranks_per_node: k,
            numa_domains: 1,
            cores_per_domain: k,
            cpus_per_rank: 1,
            cost: DEFAULT_COST,
            latency: DEFAULT_LATENCY,
        })
    }

    /// Read and validate a topology file.
    ///
    /// # Errors
    /// [`Error::Input`] (exit 2) with file, line and key: unreadable file, invalid TOML, an
    /// unknown or missing key, a value out of range.
    pub fn load(path: &Path) -> Result<Self> {
        let text = crate::limits::read_text(path, "--topology")?;
        Self::from_toml(&text, path)
    }

    /// Parse and validate topology text as if read from `file` (used for messages and as the
    /// default name).
    ///
    /// # Errors
    /// As [`Topology::load`].
    pub fn from_toml(text: &str, file: &Path) -> Result<Self> {
        let locate = |key: String, line: Option<usize>, message: String| Error::Input {
            at: Some(Location {
                file: file.to_path_buf(),
                line,
            }),
            key,
            message,
        };
        let doc = ImDocument::parse(text.to_string()).map_err(|e| {
            locate(
                String::new(),
                e.span().map(|s| line_of(text, s.start)),
                format!("not valid TOML: {}", first_line(e.message())),
            )
        })?;
        let raw: TopologyFile = toml::from_str(text).map_err(|e| {
            let span = e.span();
            let mut key = span.as_ref().map(|s| key_at(&doc, s)).unwrap_or_default();
            let mut message = first_line(e.message()).to_string();
            if let Some(field) = message
                .strip_prefix("missing field `")
                .and_then(|r| r.split('`').next())
            {
                key = if key.is_empty() {
                    field.to_string()
                } else {
                    format!("{key}.{field}")
                };
                message.push_str(" (every key is shown in topology/four_nodes_24.toml)");
            }
            let line = span_of_key(text, &key).or(span).map(|s| line_of(text, s.start));
            locate(key, line, message)
        })?;
        let stem = file
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("topology")
            .to_string();
        Self::from_file(raw, stem).map_err(|e| match e {
            Error::Input {
                at: None,
                key,
                message,
            } => {
                let line = span_of_key(text, &key).map(|s| line_of(text, s.start));
                locate(key, line, message)
            }
            other => other,
        })
    }

    /// Validate the deserialised file (errors carry the key only; the caller locates them).
    fn from_file(f: TopologyFile, stem: String) -> Result<Self> {
        let n = &f.node;
        for (key, v) in [
            ("node.count", n.count),
            ("node.numa_domains", n.numa_domains),
            ("node.cores_per_domain", n.cores_per_domain),
            ("node.ranks", n.ranks),
        ] {
            crate::limits::count(key, v as u64, crate::limits::MAX_RANKS as u64)?;
        }
        crate::limits::count(
            "node.count",
            (n.count as u64).saturating_mul(n.ranks as u64),
            crate::limits::MAX_RANKS as u64,
        )
        .map_err(|_| {
            Error::input(
                "node.count",
                format!(
                    "{} nodes × {} ranks is above the limit of {} ranks",
                    n.count,
                    n.ranks,
                    crate::limits::MAX_RANKS
                ),
            )
        })?;
        let cores = n.numa_domains * n.cores_per_domain;
        let cpus = match n.cpus_per_rank {
            Some(0) => return Err(Error::input("node.cpus_per_rank", "must be at least 1")),
            Some(c) => c,
            None => (cores / n.ranks).max(1),
        };
        if n.cpus_per_rank.is_some() && n.ranks * cpus > cores {
            return Err(Error::input(
                "node.cpus_per_rank",
                format!(
                    "{} ranks × {cpus} cpus per rank = {} exceeds the node's {cores} cores \
                     (numa_domains × cores_per_domain); give at most {}",
                    n.ranks,
                    n.ranks * cpus,
                    (cores / n.ranks).max(1)
                ),
            ));
        }
        for (key, v) in [
            ("cost.intra_node", f.cost.intra_node),
            ("cost.inter_node", f.cost.inter_node),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::input(
                    key,
                    format!("{v} is not a positive finite relative cost"),
                ));
            }
        }
        for (key, v) in [
            ("latency.intra_node", f.latency.intra_node),
            ("latency.inter_node", f.latency.inter_node),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::input(
                    key,
                    format!("{v} is not a latency in seconds (finite, ≥ 0)"),
                ));
            }
        }
        Ok(Topology {
            name: f.name.unwrap_or(stem),
            description: f.description.unwrap_or_default(),
            ranks: n.count * n.ranks,
            ranks_per_node: n.ranks,
            numa_domains: n.numa_domains,
            cores_per_domain: n.cores_per_domain,
            cpus_per_rank: cpus,
            cost: f.cost,
            latency: f.latency,
        })
    }

    /// Check that this layout fits a run of `ranks` ranks (`--ranks P` against a file).
    ///
    /// # Errors
    /// [`Error::Input`] on key `ranks` when the layout holds a different number of ranks.
    pub fn check_ranks(&self, ranks: usize) -> Result<()> {
        if ranks != self.ranks {
            return Err(Error::input(
                "ranks",
                format!(
                    "the topology `{}` holds {} nodes × {} ranks = {} ranks, not {ranks}; \
                     use --ranks {} or --ranks-per-node",
                    self.name,
                    self.nodes(),
                    self.ranks_per_node,
                    self.ranks,
                    self.ranks
                ),
            ));
        }
        Ok(())
    }

    /// Total ranks.
    pub fn ranks(&self) -> usize {
        self.ranks
    }

    /// Number of nodes (dense ids `0..nodes`).
    pub fn nodes(&self) -> usize {
        self.ranks.div_ceil(self.ranks_per_node)
    }

    /// Ranks per node (the last node may hold fewer under [`Topology::from_ranks_per_node`]).
    pub fn ranks_per_node(&self) -> usize {
        self.ranks_per_node
    }

    /// Slurm's `--ntasks-per-node`: same as [`Topology::ranks_per_node`].
    pub fn tasks_per_node(&self) -> usize {
        self.ranks_per_node
    }

    /// Slurm's `--cpus-per-task`: cores (threads) per rank.
    pub fn cpus_per_task(&self) -> usize {
        self.cpus_per_rank
    }

    /// Physical cores per node.
    pub fn cores_per_node(&self) -> usize {
        self.numa_domains * self.cores_per_domain
    }

    /// Node holding `rank` (consecutive ranks share a node).
    ///
    /// # Panics
    /// If `rank ≥ ranks()`.
    pub fn node_of(&self, rank: usize) -> usize {
        assert!(rank < self.ranks, "rank {rank} out of range 0..{}", self.ranks);
        rank / self.ranks_per_node
    }

    /// Ranks of node `node`, ascending.
    pub fn ranks_of(&self, node: usize) -> Range<usize> {
        let lo = (node * self.ranks_per_node).min(self.ranks);
        let hi = ((node + 1) * self.ranks_per_node).min(self.ranks);
        lo..hi
    }

    /// Ranks node `node` holds (its capacity for blocks).
    pub fn node_size(&self, node: usize) -> usize {
        self.ranks_of(node).len()
    }

    /// NUMA domain (within its node) of `rank`, with the node's ranks spread over its domains
    /// in contiguous runs (rank-local index × domains / ranks per node).
    pub fn numa_of(&self, rank: usize) -> usize {
        let local = rank - self.ranks_of(self.node_of(rank)).start;
        local * self.numa_domains / self.ranks_per_node
    }

    /// The link from `src` to `dst`: (relative cost per byte, latency per message in s) —
    /// the intra-node pair when both ranks share a node, else the inter-node pair.
    pub fn link(&self, src: usize, dst: usize) -> (f64, f64) {
        if self.node_of(src) == self.node_of(dst) {
            (self.cost.intra_node, self.latency.intra_node)
        } else {
            (self.cost.inter_node, self.latency.inter_node)
        }
    }
}

#[cfg(test)]
mod tests;
