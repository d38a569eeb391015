//! Communicators: ranks, messages and collectives, with no knowledge of physics.
//!
//! One rank owns one subdomain. Ranks talk through the [`Comm`] trait, which has three back
//! ends:
//! - [`serial::SerialComm`]: one rank; messages to itself (periodic images) take the same path
//!   as messages to other ranks;
//! - [`local::run_local`]: N ranks as dedicated OS threads in one process, each with its own
//!   rayon pool, messages over crossbeam channels;
//! - `mpi::MpiComm` (cargo feature `mpi`): one rank per MPI process, through rsmpi.
//!
//! ## Semantics shared by every back end
//! - [`Comm::send`] never waits for the receiver (messages are buffered), so any send pattern
//!   followed by receives is deadlock-free. Messages of one (source, destination, tag) triple
//!   arrive in the order they were sent; receives name their source and tag, and callers
//!   receive from peers in a fixed peer order, so results never depend on arrival order.
//! - Collectives are called by every rank in the same order. Their results are bitwise
//!   identical on every rank: integer sums are exact (wrapping, so order independent) and
//!   floating-point max/min are taken in rank order on every rank with one NaN rule.
//! - Every message is counted in a per-rank traffic log ([`TrafficLog`]) under the caller's
//!   current [`Phase`]. Collectives are counted with one logical model on every back end
//!   (see [`collective_traffic`]), whatever the library does underneath, so the logs of a
//!   run agree between the local and MPI back ends.
//! - A failing rank stops the whole run: on the local back end every blocked receive and
//!   collective returns an error and [`local::run_local`] returns one [`Error::Run`] naming
//!   the rank; under MPI, [`Comm::abort`] calls `MPI_Abort`.

pub mod local;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod selftest;
pub mod serial;
mod traffic;

pub use traffic::{collective_traffic, Collective, Phase, TrafficEntry, TrafficLog};

use crate::error::{Error, Result};
use std::sync::Mutex;

/// Message tag. Tags `0..=MAX_TAG` are for callers; every back end rejects larger ones (MPI
/// guarantees only 32767).
pub type Tag = u16;

/// Largest tag a caller may use.
pub const MAX_TAG: Tag = 32767;

/// True if this process looks started by an MPI launcher (mpirun, mpiexec, or srun with
/// PMIx/PMI), judged from the environment variables they set. Needs no MPI library, so a
/// build without the `mpi` feature can say that it was launched by mpirun in vain.
pub fn launched_by_mpi() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"]
        .iter()
        .any(|v| std::env::var_os(v).is_some())
}

/// Current phase and traffic log of one rank: the bookkeeping every back end shares.
#[derive(Debug, Default)]
pub struct Accounting {
    phase: Mutex<Phase>,
    log: Mutex<TrafficLog>,
}

impl Accounting {
    /// Fresh bookkeeping for rank `rank` (phase [`Phase::Other`], empty log).
    pub fn new(rank: usize) -> Self {
        Accounting {
            phase: Mutex::new(Phase::Other),
            log: Mutex::new(TrafficLog::new(rank)),
        }
    }

    /// Count one message of `bytes` payload bytes to `dst` under the current phase.
    pub fn record(&self, dst: usize, bytes: usize) {
        let phase = self.phase();
        lock(&self.log).record(phase, dst, bytes as u64, 1);
    }

    /// Count the logical traffic of one collective (see [`collective_traffic`]).
    pub fn record_collective(&self, kind: Collective, root: usize, size: usize, bytes: usize) {
        let phase = self.phase();
        let mut log = lock(&self.log);
        for (dst, b) in collective_traffic(kind, log.rank(), root, size, bytes) {
            log.record(phase, dst, b as u64, 1);
        }
    }

    /// The phase new messages are counted under.
    pub fn phase(&self) -> Phase {
        *lock(&self.phase)
    }

    /// Set the phase new messages are counted under; returns the previous one.
    pub fn set_phase(&self, phase: Phase) -> Phase {
        std::mem::replace(&mut *lock(&self.phase), phase)
    }

    /// A copy of the whole log (current step and cumulative).
    pub fn log(&self) -> TrafficLog {
        lock(&self.log).clone()
    }

    /// Close the current step: return its entries and start a new empty step (the cumulative
    /// totals keep them).
    pub fn end_step(&self) -> Vec<TrafficEntry> {
        lock(&self.log).end_step()
    }
}

/// Lock a mutex, ignoring poisoning (a panicking rank is reported through the abort path).
pub(crate) fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// A communicator: this rank's view of the run's ranks.
///
/// Object safe: engine code takes `&dyn Comm`. Calls come from the rank's main thread (the
/// thread the rank body runs on), never from inside rayon tasks.
pub trait Comm {
    /// This rank, `0..size()`.
    fn rank(&self) -> usize;

    /// Number of ranks.
    fn size(&self) -> usize;

    /// Phase and traffic log of this rank.
    fn accounting(&self) -> &Accounting;

    /// A key shared by exactly the ranks of this rank's node (its shared-memory domain): under
    /// MPI the lowest world rank of `MPI_Comm_split_type(SHARED)`, never the host name (fake
    /// nodes share one). The serial and local back ends run in one process: one node, key 0.
    fn node_key(&self) -> usize {
        0
    }

    /// Send `bytes` to rank `dst` (which may be this rank) with `tag`. Never waits for the
    /// receiver. Counted in the traffic log under the current phase.
    fn send(&self, dst: usize, tag: Tag, bytes: Vec<u8>) -> Result<()>;

    /// Receive the next message from rank `src` with `tag`, waiting for it. Fails when the run
    /// was aborted, or when the message can never come (a self-receive with nothing sent, a
    /// peer that has finished).
    fn recv(&self, src: usize, tag: Tag) -> Result<Vec<u8>>;

    /// Neighbour exchange: send every `(dst, bytes)` of `sends`, then receive one message
    /// from each rank of `recv_from`, in that order (a rank listed twice gives two messages).
    /// Deadlock-free for any pattern in which the receives match the peers' sends.
    fn exchange(&self, sends: Vec<(usize, Vec<u8>)>, recv_from: &[usize], tag: Tag) -> Result<Vec<Vec<u8>>> {
        for (dst, bytes) in sends {
            self.send(dst, tag, bytes)?;
        }
        recv_from.iter().map(|&src| self.recv(src, tag)).collect()
    }

    /// Start a neighbour exchange that [`Comm::finish_exchange`] completes: the same messages
    /// as [`Comm::exchange`], but the caller may compute between the two calls while they
    /// travel (the overlap of a halo refresh with the interior). The default sends now
    /// (sends never wait) and receives at the finish.
    fn start_exchange(&self, sends: Vec<(usize, Vec<u8>)>, recv_from: &[usize], tag: Tag) -> Result<Pending> {
        for (dst, bytes) in sends {
            self.send(dst, tag, bytes)?;
        }
        Ok(Pending::sent(recv_from, tag))
    }

    /// Complete an exchange begun by [`Comm::start_exchange`]: one message from each rank of
    /// its `recv_from`, in that order.
    fn finish_exchange(&self, x: Pending) -> Result<Vec<Vec<u8>>> {
        match x.stage {
            Stage::Sent => x.recv_from.iter().map(|&src| self.recv(src, x.tag)).collect(),
            Stage::Deferred(sends) => self.exchange(sends, &x.recv_from, x.tag),
            Stage::Receiving(thread) => {
                let me = self.rank();
                let mut remote = thread
                    .join()
                    .map_err(|e| Error::run(format!("rank {me}: receiving thread: {}", panic_message(&*e))))??
                    .into_iter();
                x.recv_from
                    .iter()
                    .map(|&src| match src == me {
                        true => self.recv(src, x.tag),
                        false => remote.next().ok_or_else(|| {
                            Error::run(format!("rank {me}: a message from rank {src} is missing"))
                        }),
                    })
                    .collect()
            }
        }
    }

    /// Element-wise exact (wrapping) sum over ranks, in place.
    fn all_reduce_sum_u64(&self, values: &mut [u64]) -> Result<()>;

    /// Element-wise exact (wrapping) sum over ranks, in place (fixed-point energy sums).
    fn all_reduce_sum_i64(&self, values: &mut [i64]) -> Result<()>;

    /// Element-wise maximum over ranks, in place; NaN if any rank has NaN.
    fn all_reduce_max_f64(&self, values: &mut [f64]) -> Result<()>;

    /// Element-wise minimum over ranks, in place; NaN if any rank has NaN.
    fn all_reduce_min_f64(&self, values: &mut [f64]) -> Result<()>;

    /// Every rank's `bytes`, in rank order.
    fn all_gather_bytes(&self, bytes: Vec<u8>) -> Result<Vec<Vec<u8>>>;

    /// Rank `root`'s `bytes` on every rank (the argument is ignored on the other ranks).
    fn broadcast_bytes(&self, root: usize, bytes: Vec<u8>) -> Result<Vec<u8>>;

    /// Wait until every rank has arrived.
    fn barrier(&self) -> Result<()>;

    /// Stop the whole run because of `message`. Local back end: every rank's blocked
    /// receives and collectives fail and the run returns an error naming this rank; the
    /// returned error is for this rank to propagate. MPI: prints the message and calls
    /// `MPI_Abort` (does not return).
    fn abort(&self, message: &str) -> Error;

    /// The phase new messages are counted under.
    fn phase(&self) -> Phase {
        self.accounting().phase()
    }

    /// Set the phase new messages are counted under; returns the previous one.
    fn set_phase(&self, phase: Phase) -> Phase {
        self.accounting().set_phase(phase)
    }

    /// A copy of this rank's traffic log (current step and cumulative).
    fn traffic(&self) -> TrafficLog {
        self.accounting().log()
    }

    /// Close the current step of the traffic log and return its entries.
    fn end_traffic_step(&self) -> Vec<TrafficEntry> {
        self.accounting().end_step()
    }
}

/// A neighbour exchange in flight: begun by [`Comm::start_exchange`], completed by
/// [`Comm::finish_exchange`].
pub struct Pending {
    tag: Tag,
    recv_from: Vec<usize>,
    stage: Stage,
}

/// How far a [`Pending`] exchange has gone.
enum Stage {
    /// Every message sent; all receives left.
    Sent,
    /// Nothing sent yet (a back end whose sends would wait for the receiver: MPI without
    /// `MPI_THREAD_MULTIPLE`); the finish makes the whole exchange.
    Deferred(Vec<(usize, Vec<u8>)>),
    /// Sent; a thread receives the other ranks' messages (in `recv_from` order) while the
    /// caller computes, so that large messages move meanwhile.
    Receiving(std::thread::JoinHandle<Result<Vec<Vec<u8>>>>),
}

impl Pending {
    /// Every message sent; the receives from `recv_from` (in order, with `tag`) are left.
    pub fn sent(recv_from: &[usize], tag: Tag) -> Self {
        Pending {
            tag,
            recv_from: recv_from.to_vec(),
            stage: Stage::Sent,
        }
    }

    /// Nothing sent: the finish exchanges `sends` and receives from `recv_from`.
    pub fn deferred(sends: Vec<(usize, Vec<u8>)>, recv_from: &[usize], tag: Tag) -> Self {
        Pending {
            tag,
            recv_from: recv_from.to_vec(),
            stage: Stage::Deferred(sends),
        }
    }

    /// Every message sent; `thread` receives those of the other ranks of `recv_from` (in its
    /// order), the finish takes this rank's own from its queue.
    pub fn receiving(
        recv_from: &[usize],
        tag: Tag,
        thread: std::thread::JoinHandle<Result<Vec<Vec<u8>>>>,
    ) -> Self {
        Pending {
            tag,
            recv_from: recv_from.to_vec(),
            stage: Stage::Receiving(thread),
        }
    }
}

/// Check a destination or source rank and a tag; the error names the calling rank.
pub(crate) fn check_peer(rank: usize, size: usize, peer: usize, tag: Tag) -> Result<()> {
    if peer >= size {
        return Err(Error::run(format!(
            "rank {rank}: peer rank {peer} out of range (run has {size} ranks)"
        )));
    }
    if tag > MAX_TAG {
        return Err(Error::run(format!(
            "rank {rank}: message tag {tag} above the largest allowed tag {MAX_TAG}"
        )));
    }
    Ok(())
}

/// Little-endian bytes of `u64`s.
pub(crate) fn u64s_to_bytes(v: &[u64]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// `u64`s from little-endian bytes (the length is a multiple of 8).
pub(crate) fn bytes_to_u64s(b: &[u8]) -> Vec<u64> {
    b.chunks_exact(8)
        .map(|c| u64::from_le_bytes(c.try_into().expect("8-byte chunk")))
        .collect()
}

/// Maximum (or minimum) of `a` and `b` with the rule shared by every back end: NaN if either
/// is NaN, else the larger (smaller), keeping `a` on ties (so -0.0/0.0 follow rank order).
pub(crate) fn pick_f64(a: f64, b: f64, max: bool) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if (max && b > a) || (!max && b < a) {
        b
    } else {
        a
    }
}

/// Reduce per-rank `f64` vectors (given as little-endian bytes, in rank order) into `out`.
pub(crate) fn reduce_f64_in_rank_order(parts: &[Vec<u8>], out: &mut [f64], max: bool) {
    for (k, part) in parts.iter().enumerate() {
        for (o, x) in out.iter_mut().zip(bytes_to_u64s(part)) {
            let x = f64::from_bits(x);
            *o = if k == 0 { x } else { pick_f64(*o, x, max) };
        }
    }
}

/// Text of a panic payload.
pub(crate) fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "panic with a non-text payload".to_string()
    }
}

/// An error's message without the `error: ` prefix of its display form.
pub(crate) fn error_text(e: &Error) -> String {
    match e {
        Error::Run(m) => m.clone(),
        other => {
            let s = other.to_string();
            s.strip_prefix("error: ").unwrap_or(&s).to_string()
        }
    }
}
