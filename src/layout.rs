//! The run layout, resolved once: back end, rank count, nodes, placement and thread binding.
//!
//! `hsph run`, `hsph plan` and `hsph bench` all go through [`RunLayout::resolve`]. Nodes come
//! from, in order of precedence: a layout file (`--topology`), `--ranks-per-node`, the nodes
//! MPI discovers (`MPI_Comm_split_type(SHARED)`; equal runs of consecutive ranks), or one node
//! holding every rank. A placement that the nodes cannot honour is never dropped silently:
//! the layout records the placement that runs and a warning saying why.

use crate::affinity::Bind;
use crate::error::{Error, Result};
use crate::placement::Placement;
use crate::topology::Topology;

/// Communication back end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Backend {
    /// MPI when built with `mpi` and launched by mpirun/srun, else local when --ranks > 1,
    /// else serial.
    #[default]
    Auto,
    /// One rank in this process.
    Serial,
    /// --ranks N ranks as threads of this process (no MPI needed).
    Local,
    /// MPI (cargo feature `mpi`); the launcher sets the rank count.
    Mpi,
}

impl Backend {
    /// Name in logs and `summary.json`.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Auto => "auto",
            Backend::Serial => "serial",
            Backend::Local => "local",
            Backend::Mpi => "mpi",
        }
    }
}

/// What the user asked for (flags of `run`, `plan`, `bench`).
#[derive(Debug, Clone, Default)]
pub struct LayoutRequest {
    /// Back end.
    pub backend: Backend,
    /// Ranks of the local back end (0 or 1 = one); under MPI the launcher decides.
    pub ranks: usize,
    /// Virtual nodes of this many consecutive ranks (0: discovered or one node).
    pub ranks_per_node: usize,
    /// A node layout file, already read; wins over `ranks_per_node`.
    pub topology: Option<Topology>,
    /// Placement of blocks on ranks.
    pub placement: Placement,
    /// Thread binding.
    pub bind: Bind,
}

/// Where the nodes of a run come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeSource {
    /// `--topology FILE`.
    File,
    /// `--ranks-per-node K`.
    RanksPerNode,
    /// Discovered by MPI.
    Discovered,
    /// Nothing declared or discovered: one node.
    Single,
}

/// The layout a run uses, resolved once.
#[derive(Debug, Clone)]
pub struct RunLayout {
    /// Back end (never `Auto`).
    pub backend: Backend,
    /// Number of ranks.
    pub ranks: usize,
    /// Nodes as the placement sees them (uniform), if the nodes are uniform.
    pub topology: Option<Topology>,
    /// Node of every rank (for traffic reports), whether uniform or not.
    pub node_of: Vec<usize>,
    /// Where the nodes come from.
    pub source: NodeSource,
    /// Placement asked for.
    pub requested: Placement,
    /// Placement that runs (equal to `requested` unless a warning says why not).
    pub placement: Placement,
    /// Thread binding.
    pub bind: Bind,
    /// Why the layout differs from the request, for the log and `summary.json`.
    pub warnings: Vec<String>,
}

/// The back end `req` resolves to (`Auto` decided), with the rank-count checks that need no
/// communicator.
pub fn resolve_backend(req: &LayoutRequest) -> Result<Backend> {
    let b = match req.backend {
        Backend::Auto if cfg!(feature = "mpi") && crate::comm::launched_by_mpi() => Backend::Mpi,
        Backend::Auto if req.ranks > 1 => Backend::Local,
        Backend::Auto => Backend::Serial,
        b => b,
    };
    if b == Backend::Mpi && !cfg!(feature = "mpi") {
        return Err(Error::missing_feature("--backend", "mpi"));
    }
    if b == Backend::Serial && req.ranks > 1 {
        return Err(Error::input(
            "--ranks",
            format!(
                "the serial back end runs one rank, not {}; use --backend local",
                req.ranks
            ),
        ));
    }
    Ok(b)
}

impl RunLayout {
    /// Resolve `req` for `ranks` ranks on back end `backend`; `node_keys` (one per rank, from
    /// [`crate::comm::Comm::node_key`]) are the discovered nodes, if any. Errors are input
    /// errors (exit 2): a layout file or `--ranks-per-node` that does not fit the ranks.
    pub fn resolve(
        req: &LayoutRequest,
        backend: Backend,
        ranks: usize,
        node_keys: Option<&[usize]>,
    ) -> Result<Self> {
        let ranks = ranks.max(1);
        let (topology, node_of, source) = nodes(req, ranks, node_keys)?;
        let mut layout = RunLayout {
            backend,
            ranks,
            topology,
            node_of,
            source,
            requested: req.placement,
            placement: req.placement,
            bind: req.bind,
            warnings: Vec::new(),
        };
        if layout.topology.is_none() && req.placement != Placement::RankOrder {
            layout.placement = Placement::RankOrder;
            layout.warnings.push(format!(
                "placement {} needs nodes holding runs of consecutive ranks, but the discovered \
                 node of each rank is {:?}; running rank-order (declare nodes with \
                 --ranks-per-node or --topology to place blocks)",
                req.placement, layout.node_of
            ));
        }
        Ok(layout)
    }

    /// The nodes as the placement sees them: the uniform topology, or one node when the
    /// discovered nodes are uneven (placement is then rank-order, see `warnings`).
    pub fn placement_topology(&self) -> Topology {
        self.topology.clone().unwrap_or_else(|| {
            Topology::from_ranks_per_node(self.ranks, self.ranks).expect("one node of every rank")
        })
    }

    /// Number of distinct nodes.
    pub fn nodes(&self) -> usize {
        self.node_of.iter().max().map_or(1, |m| m + 1)
    }

    /// Record that the placement step itself ran `used` instead (e.g. `node-grid` when no
    /// factorisation of the nodes over the block grid fits).
    pub fn placed(&mut self, used: Placement) {
        if used != self.placement {
            self.warnings.push(format!(
                "placement {} cannot lay out these nodes over the block grid; ran {used}",
                self.placement
            ));
            self.placement = used;
        }
    }
}

type Nodes = (Option<Topology>, Vec<usize>, NodeSource);

/// The nodes of a run of `ranks` ranks (see the module docs for the precedence).
fn nodes(req: &LayoutRequest, ranks: usize, keys: Option<&[usize]>) -> Result<Nodes> {
    let node_of = |t: &Topology| (0..ranks).map(|r| t.node_of(r)).collect();
    if let Some(t) = &req.topology {
        t.check_ranks(ranks)?;
        return Ok((Some(t.clone()), node_of(t), NodeSource::File));
    }
    if req.ranks_per_node > 0 {
        let t = Topology::from_ranks_per_node(ranks, req.ranks_per_node)?;
        let n = node_of(&t);
        return Ok((Some(t), n, NodeSource::RanksPerNode));
    }
    let Some(keys) = keys else {
        let t = Topology::from_ranks_per_node(ranks, ranks)?;
        let n = node_of(&t);
        return Ok((Some(t), n, NodeSource::Single));
    };
    // discovered: dense node ids in order of first appearance
    let mut ids = Vec::with_capacity(ranks);
    let mut seen: Vec<usize> = Vec::new();
    for &key in keys.iter().take(ranks) {
        let id = seen.iter().position(|&s| s == key).unwrap_or_else(|| {
            seen.push(key);
            seen.len() - 1
        });
        ids.push(id);
    }
    let k = ids.iter().filter(|&&n| n == 0).count();
    let uniform = (0..ranks).all(|r| ids[r] == r / k);
    let source = if seen.len() > 1 {
        NodeSource::Discovered
    } else {
        NodeSource::Single
    };
    let topo = if uniform {
        Some(Topology::from_ranks_per_node(ranks, k)?)
    } else {
        None
    };
    Ok((topo, ids, source))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(placement: Placement) -> LayoutRequest {
        LayoutRequest {
            placement,
            ..Default::default()
        }
    }

    #[test]
    fn uneven_discovered_nodes_run_rank_order_and_say_so() {
        // ranks dealt round-robin over two hosts: no runs of consecutive ranks
        let l = RunLayout::resolve(&req(Placement::MinCut), Backend::Mpi, 4, Some(&[7, 9, 7, 9])).unwrap();
        assert_eq!(l.requested, Placement::MinCut);
        assert_eq!(l.placement, Placement::RankOrder);
        assert_eq!(l.node_of, vec![0, 1, 0, 1]);
        assert_eq!(l.warnings.len(), 1);
        assert!(l.warnings[0].contains("[0, 1, 0, 1]"), "{}", l.warnings[0]);
        // three ranks on one host and one on another are runs of 3 (the last one short)
        let l = RunLayout::resolve(&req(Placement::MinCut), Backend::Mpi, 4, Some(&[7, 7, 7, 9])).unwrap();
        assert_eq!((l.placement, l.nodes()), (Placement::MinCut, 2));
        // even nodes honour it
        let l = RunLayout::resolve(&req(Placement::MinCut), Backend::Mpi, 4, Some(&[7, 7, 9, 9])).unwrap();
        assert_eq!(l.placement, Placement::MinCut);
        assert!(l.warnings.is_empty());
        assert_eq!(l.topology.unwrap().nodes(), 2);
    }

    #[test]
    fn declared_nodes_that_do_not_fit_are_input_errors() {
        let r = LayoutRequest {
            ranks_per_node: 8,
            ..req(Placement::CentreDistance)
        };
        let e = RunLayout::resolve(&r, Backend::Local, 4, None).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        // nothing declared: one node, placement honoured
        let l = RunLayout::resolve(&req(Placement::CentreDistance), Backend::Local, 4, None).unwrap();
        assert_eq!(
            (l.nodes(), l.placement, l.source),
            (1, Placement::CentreDistance, NodeSource::Single)
        );
    }
}
