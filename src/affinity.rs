//! Binding rayon threads to cores (`hsph run --bind cores`, `hsph topology`).
//!
//! The binding policy is the pure function [`thread_cores`], testable without hwloc. The
//! hardware side (cargo feature `hwloc`, crate `hwlocality` against the system hwloc) reads the
//! machine, the cpuset the launcher gave this process, and builds rayon start handlers that bind
//! each pool thread to its core. Without the feature, [`start_handler`] with [`Bind::Cores`] and
//! [`topology_report`] fail with exit status 2 naming the feature.
//!
//! **Policy** (also printed by `hsph topology`), for the C cores of the cpuset the launcher
//! gave this process, shared by R ranks (the local back end's ranks; under MPI one rank, or the
//! node's ranks when the launcher bound none) of T threads each: rank r gets the contiguous block
//! of cores `[r·C/R, (r+1)·C/R)` (at least one core; when R > C, consecutive ranks share one
//! core), and its thread i goes to core `i mod block length` of that block. So threads get
//! distinct cores while they last (R·T ≤ C), ranks sharing a cpuset get disjoint cores while
//! R ≤ C, and beyond that a rank's threads wrap round-robin over its own block, never onto another
//! rank's cores.

use crate::error::{Error, Result};
use std::ops::Range;
use std::sync::Arc;

/// The binding policy in one paragraph, for `hsph topology` and `--help`.
pub const POLICY: &str = "\
the R ranks sharing the launcher's cpuset of C cores get contiguous blocks of cores,
rank r the cores [r*C/R, (r+1)*C/R) (at least one; if R > C, consecutive ranks share one);
thread i of a rank is pinned to core (i mod block length) of its rank's block:
distinct cores while R*T <= C, disjoint ranks while R <= C; beyond that a rank's threads
wrap round-robin over its own block, never onto another rank's cores.";

/// How `hsph run` binds rayon threads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Bind {
    /// Leave placement to the OS (and the launcher's cpuset).
    #[default]
    None,
    /// Pin each rayon thread to one core of the launcher's cpuset (feature `hwloc`).
    Cores,
}

/// The block of core indices (into the cpuset's list of `cores` cores) of rank `local_rank` of
/// the `local_ranks` ranks sharing the cpuset. Never empty when `cores > 0`.
pub fn rank_block(cores: usize, local_rank: usize, local_ranks: usize) -> Range<usize> {
    assert!(local_rank < local_ranks, "rank {local_rank} of {local_ranks}");
    if cores == 0 {
        return 0..0;
    }
    let start = local_rank * cores / local_ranks;
    let end = ((local_rank + 1) * cores / local_ranks).max(start + 1);
    start..end
}

/// The core each of the `threads` threads of rank `local_rank` is pinned to, chosen from
/// `cores` (the cores of the cpuset the launcher gave the process, in topology order) shared by
/// `local_ranks` ranks. See the module documentation for the policy. Empty if `cores` is.
///
/// # Panics
/// If `local_rank >= local_ranks`.
pub fn thread_cores<T: Copy>(cores: &[T], threads: usize, local_rank: usize, local_ranks: usize) -> Vec<T> {
    let block = rank_block(cores.len(), local_rank, local_ranks);
    if block.is_empty() {
        return Vec::new();
    }
    let block = &cores[block];
    (0..threads).map(|i| block[i % block.len()]).collect()
}

/// A rayon start handler for the ranks of this process: `f(local_rank, thread_index)` binds the
/// calling thread to its core.
pub type StartHandler = Arc<dyn Fn(usize, usize) + Send + Sync>;

/// `builder` with `start` (called as `start(rank, thread)`) as its start handler, if any.
pub fn with_start(
    builder: rayon::ThreadPoolBuilder,
    start: Option<&StartHandler>,
    rank: usize,
) -> rayon::ThreadPoolBuilder {
    match start {
        Some(s) => {
            let s = Arc::clone(s);
            builder.start_handler(move |i| s(rank, i))
        }
        None => builder,
    }
}

/// The start handler for `bind` with `local_ranks` ranks of `threads` threads sharing this
/// process's cpuset (the serial and local back ends): `None` for [`Bind::None`]. [`Bind::Cores`]
/// needs the `hwloc` feature (else exit status 2) and reads the machine once, here.
pub fn start_handler(bind: Bind, local_ranks: usize, threads: usize) -> Result<Option<StartHandler>> {
    match bind {
        Bind::None => Ok(None),
        Bind::Cores => cores_handler(local_ranks.max(1), threads, false),
    }
}

/// [`start_handler`] for an MPI rank (call it with local rank 0): the launcher's cpuset is this
/// rank's own, unless the launcher bound nothing, when the node's ranks share it
/// ([`mpi_local_rank`]).
pub fn mpi_start_handler(bind: Bind, threads: usize) -> Result<Option<StartHandler>> {
    match bind {
        Bind::None => Ok(None),
        Bind::Cores => cores_handler(1, threads, true),
    }
}

/// Under MPI: the index and count of the ranks sharing this process's cpuset, as the launcher
/// tells them (OpenMPI `OMPI_COMM_WORLD_LOCAL_RANK/SIZE`, MPICH `MPI_LOCALRANKID/MPI_LOCALNRANKS`)
/// when `unbound` (the launcher bound the process to no subset of the machine); otherwise the
/// launcher gave each rank its own cpuset: `(0, 1)`.
pub fn mpi_local_rank(unbound: bool) -> (usize, usize) {
    let var = |k: &str| std::env::var(k).ok().and_then(|v| v.trim().parse::<usize>().ok());
    if !unbound {
        return (0, 1);
    }
    let pairs = [
        ("OMPI_COMM_WORLD_LOCAL_RANK", "OMPI_COMM_WORLD_LOCAL_SIZE"),
        ("MPI_LOCALRANKID", "MPI_LOCALNRANKS"),
    ];
    for (r, n) in pairs {
        if let (Some(r), Some(n)) = (var(r), var(n)) {
            if r < n {
                return (r, n);
            }
        }
    }
    (0, 1)
}

#[cfg(not(feature = "hwloc"))]
fn cores_handler(_local_ranks: usize, _threads: usize, _mpi: bool) -> Result<Option<StartHandler>> {
    Err(Error::missing_feature("--bind cores", "hwloc"))
}

#[cfg(feature = "hwloc")]
fn cores_handler(local_ranks: usize, threads: usize, mpi: bool) -> Result<Option<StartHandler>> {
    let machine = Arc::new(hw::Machine::discover()?);
    machine.check_can_bind()?;
    let (offset, local_ranks) = if mpi {
        mpi_local_rank(machine.unbound())
    } else {
        (0, local_ranks)
    };
    let plans: Vec<Vec<usize>> = (0..local_ranks)
        .map(|r| machine.plan(threads, r, local_ranks))
        .collect();
    Ok(Some(Arc::new(move |rank: usize, thread: usize| {
        if let Some(&core) = plans.get(offset + rank).and_then(|p| p.get(thread)) {
            if let Err(e) = machine.bind_current_thread(core) {
                eprintln!("hsph: warning: cannot bind rank {rank} thread {thread}: {e}");
            }
        }
    })))
}

/// `hsph topology`: the machine (packages, NUMA nodes, cores, PUs with their cpusets), the
/// cpuset this process was given, and the binding plan of `ranks` ranks × `threads` threads.
#[cfg(not(feature = "hwloc"))]
pub fn topology_report(_ranks: usize, _threads: usize) -> Result<String> {
    Err(Error::missing_feature("topology", "hwloc"))
}

/// `hsph topology`: the machine (packages, NUMA nodes, cores, PUs with their cpusets), the
/// cpuset this process was given, and the binding plan of `ranks` ranks × `threads` threads.
#[cfg(feature = "hwloc")]
pub fn topology_report(ranks: usize, threads: usize) -> Result<String> {
    if ranks == 0 {
        return Err(Error::input("--ranks", "must be at least 1"));
    }
    hw::Machine::discover()?.report(ranks, threads)
}

/// The hwloc side: the machine and binding.
#[cfg(feature = "hwloc")]
pub mod hw {
    use super::{thread_cores, POLICY};
    use crate::error::{Error, Result};
    use hwlocality::cpu::binding::CpuBindingFlags;
    use hwlocality::cpu::cpuset::CpuSet;
    use hwlocality::object::attributes::ObjectAttributes;
    use hwlocality::object::types::ObjectType;
    use hwlocality::object::TopologyObject;
    use hwlocality::Topology;
    use std::fmt::Write;

    /// A core this process may run on.
    #[derive(Debug, Clone)]
    pub struct Core {
        /// hwloc logical index (L#).
        pub logical: usize,
        /// OS index (P#), if known.
        pub os: Option<usize>,
        /// Its PUs inside the process's cpuset: what a thread pinned to it is bound to.
        pub cpuset: CpuSet,
    }

    /// The machine as hwloc sees it and the cpuset the launcher gave this process.
    #[derive(Debug)]
    pub struct Machine {
        topology: Topology,
        process: CpuSet,
        cores: Vec<Core>,
    }

    /// `0-3,8` rather than `CpuSet(0-3,8)`.
    pub fn show(set: &CpuSet) -> String {
        let s = set.to_string();
        s.strip_prefix("CpuSet(")
            .and_then(|s| s.strip_suffix(')'))
            .map(str::to_string)
            .unwrap_or(s)
    }

    fn hw_err(what: &str, e: impl std::fmt::Display) -> Error {
        Error::run(format!("hwloc: {what}: {e}"))
    }

    impl Machine {
        /// Read the topology and this process's CPU binding (as the launcher set it).
        pub fn discover() -> Result<Machine> {
            let topology = Topology::new().map_err(|e| hw_err("cannot read the topology", e))?;
            let process = topology
                .cpu_binding(CpuBindingFlags::PROCESS)
                .or_else(|_| topology.cpu_binding(CpuBindingFlags::THREAD))
                .unwrap_or_else(|_| topology.cpuset().clone_target());
            let mut cores: Vec<Core> = Vec::new();
            let mut ty = ObjectType::Core;
            if topology.objects_with_type(ty).len() == 0 {
                ty = ObjectType::PU; // no core objects: each PU is a core
            }
            for obj in topology.objects_with_type(ty) {
                let Some(set) = obj.cpuset() else { continue };
                let usable = &*set & &process;
                if usable.weight().unwrap_or(0) > 0 {
                    cores.push(Core {
                        logical: obj.logical_index(),
                        os: obj.os_index(),
                        cpuset: usable,
                    });
                }
            }
            if cores.is_empty() {
                return Err(Error::run(format!(
                    "hwloc: no core of this machine is in this process's cpuset {}",
                    show(&process)
                )));
            }
            Ok(Machine {
                topology,
                process,
                cores,
            })
        }

        /// The cores this process may run on, in topology order.
        pub fn cores(&self) -> &[Core] {
            &self.cores
        }

        /// The cpuset the launcher gave this process.
        pub fn process_cpuset(&self) -> &CpuSet {
            &self.process
        }

        /// True if the process may run on the whole machine (the launcher bound nothing).
        pub fn unbound(&self) -> bool {
            self.process.includes(self.topology.cpuset())
        }

        /// Indices into [`Machine::cores`] of rank `local_rank`'s threads.
        pub fn plan(&self, threads: usize, local_rank: usize, local_ranks: usize) -> Vec<usize> {
            let idx: Vec<usize> = (0..self.cores.len()).collect();
            thread_cores(&idx, threads, local_rank, local_ranks)
        }

        /// Fail (exit 1) if this OS cannot bind threads.
        pub fn check_can_bind(&self) -> Result<()> {
            let ok = self
                .topology
                .feature_support()
                .cpu_binding()
                .is_some_and(|s| s.set_current_thread());
            if ok {
                Ok(())
            } else {
                Err(Error::run("hwloc: this system cannot bind threads to cores"))
            }
        }

        /// Bind the calling thread to core `core` (an index into [`Machine::cores`]).
        pub fn bind_current_thread(&self, core: usize) -> Result<()> {
            let set = &self.cores[core].cpuset;
            self.topology
                .bind_cpu(set, CpuBindingFlags::THREAD)
                .map_err(|e| hw_err(&format!("binding to PUs {}", show(set)), e))
        }

        /// The calling thread's CPU binding as hwloc reads it back from the OS.
        pub fn current_thread_binding(&self) -> Result<CpuSet> {
            self.topology
                .cpu_binding(CpuBindingFlags::THREAD)
                .map_err(|e| hw_err("reading the thread binding", e))
        }

        fn list(&self, w: &mut String, ty: ObjectType, label: &str) {
            let objs: Vec<&TopologyObject> = self.topology.objects_with_type(ty).collect();
            let _ = writeln!(w, "{label}s: {}", objs.len());
            for o in objs {
                let set = o.cpuset().map(|s| show(&s)).unwrap_or_default();
                let os = o.os_index().map(|i| format!(" P#{i}")).unwrap_or_default();
                let mem = match o.attributes() {
                    Some(ObjectAttributes::NUMANode(a)) => a
                        .local_memory()
                        .map(|m| format!(", memory {} MiB", m.get() >> 20))
                        .unwrap_or_default(),
                    _ => String::new(),
                };
                let _ = writeln!(w, "  {label} L#{}{os}: cpuset {set}{mem}", o.logical_index());
            }
        }

        /// The `hsph topology` text.
        pub fn report(&self, ranks: usize, threads: usize) -> Result<String> {
            let mut w = String::new();
            self.list(&mut w, ObjectType::Package, "package");
            self.list(&mut w, ObjectType::NUMANode, "NUMA node");
            self.list(&mut w, ObjectType::Core, "core");
            self.list(&mut w, ObjectType::PU, "PU");
            let _ = writeln!(
                w,
                "process cpuset (from the launcher): {} -> {} usable core(s)",
                show(&self.process),
                self.cores.len()
            );
            let threads = if threads == 0 {
                (self.cores.len() / ranks).max(1)
            } else {
                threads
            };
            let _ = writeln!(
                w,
                "binding plan for --ranks {ranks} --threads {threads} --bind cores \
                 (ranks as threads of this process):"
            );
            let _ = writeln!(w, "  policy:");
            for line in POLICY.lines() {
                let _ = writeln!(w, "    {line}");
            }
            for r in 0..ranks {
                let cores: Vec<String> = self
                    .plan(threads, r, ranks)
                    .into_iter()
                    .enumerate()
                    .map(|(i, c)| {
                        let c = &self.cores[c];
                        format!("t{i}->core L#{} (PU {})", c.logical, show(&c.cpuset))
                    })
                    .collect();
                let _ = writeln!(w, "  rank {r}: {}", cores.join(", "));
            }
            Ok(w)
        }
    }
}

#[cfg(test)]
mod tests;
