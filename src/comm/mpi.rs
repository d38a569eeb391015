//! The MPI back end (cargo feature `mpi`): one rank per MPI process, through rsmpi.
//!
//! [`MpiComm::init`] initialises MPI asking for `MPI_THREAD_MULTIPLE`. With MULTIPLE (which
//! Debian's OpenMPI grants), [`Comm::send`] hands each message to a sender thread owned by
//! the (destination, tag) lane, which does a blocking `MPI_Send`: the caller never waits for
//! the receiver, messages of one lane stay in order, and a lane blocked on a large message
//! only holds back later messages of that lane, which the receiver takes after it anyway.
//! Without MULTIPLE (FUNNELED or less), every MPI call is made on the rank's main thread:
//! `send` is then a blocking standard send, so exchanges whose peers send to each other must
//! use [`Comm::exchange`], which posts non-blocking sends before receiving.
//!
//! Receives use `MPI_Mprobe` + `MPI_Mrecv` (variable length, thread safe). Messages to this
//! rank never touch MPI: they are queued as on the serial back end. Integer sums use
//! `MPI_Allreduce` (exact); floating max/min gather every rank's values and reduce them in
//! rank order with the rule the other back ends use, so results are bitwise identical on
//! every rank and across back ends. Traffic is counted with the same logical model as the
//! local back end ([`super::collective_traffic`]).
//!
//! MPI can be initialised once per process: multi-rank tests start `mpirun` on
//! `examples/comm_selftest.rs` (see `tests/comm_mpi.rs`), never MPI inside a `#[test]`.

use super::{check_peer, lock, reduce_f64_in_rank_order, Accounting, Collective, Comm, Pending, Tag};
use crate::error::{Error, Result};
use crossbeam::channel::{unbounded, Sender};
use mpi::datatype::PartitionMut;
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use mpi::Threading;
use std::collections::{BTreeMap, VecDeque};
use std::sync::Mutex;
use std::thread::JoinHandle;

/// One (destination, tag) lane: a queue and the thread that sends it.
struct Lane {
    tx: Option<Sender<Vec<u8>>>,
    thread: Option<JoinHandle<()>>,
}

/// This process's rank in `MPI_COMM_WORLD`. Finalises MPI when dropped (after every queued
/// send has been delivered).
pub struct MpiComm {
    rank: usize,
    size: usize,
    multiple: bool,
    world: SimpleCommunicator,
    self_queue: Mutex<BTreeMap<Tag, VecDeque<Vec<u8>>>>,
    lanes: Mutex<BTreeMap<(usize, Tag), Lane>>,
    accounting: Accounting,
    /// Lowest world rank on this rank's shared-memory node.
    node_key: usize,
    // Declared last: dropped after everything above, which calls MPI_Finalize.
    _universe: Universe,
}

pub use super::launched_by_mpi;

impl MpiComm {
    /// Initialise MPI (asking for `MPI_THREAD_MULTIPLE`) and return this process's rank.
    /// Fails if MPI was already initialised in this process. The environment variable
    /// `HSPH_MPI_THREADING=funneled` asks for `MPI_THREAD_FUNNELED` instead, to test the
    /// fallback path where MULTIPLE is not granted.
    pub fn init() -> Result<MpiComm> {
        let wanted = match std::env::var("HSPH_MPI_THREADING").as_deref() {
            Ok("funneled") => Threading::Funneled,
            _ => Threading::Multiple,
        };
        let (universe, threading) = mpi::initialize_with_threading(wanted)
            .ok_or_else(|| Error::run("MPI was already initialised in this process"))?;
        let world = universe.world();
        let rank = world.rank() as usize;
        let node = world.split_shared(world.rank());
        let mut lowest: mpi::Rank = 0;
        node.all_reduce_into(
            &world.rank(),
            &mut lowest,
            mpi::collective::SystemOperation::min(),
        );
        Ok(MpiComm {
            rank,
            size: world.size() as usize,
            multiple: threading == Threading::Multiple,
            world,
            self_queue: Mutex::new(BTreeMap::new()),
            lanes: Mutex::new(BTreeMap::new()),
            accounting: Accounting::new(rank),
            node_key: lowest as usize,
            _universe: universe,
        })
    }

    /// True if MPI granted `MPI_THREAD_MULTIPLE` (sends go through sender threads).
    pub fn thread_multiple(&self) -> bool {
        self.multiple
    }

    /// Library name and version, as MPI reports it.
    pub fn library_version() -> String {
        mpi::environment::library_version()
            .unwrap_or_default()
            .trim_end_matches('\0')
            .trim()
            .to_string()
    }

    fn lane_send(&self, dst: usize, tag: Tag, bytes: Vec<u8>) -> Result<()> {
        let mut lanes = lock(&self.lanes);
        let lane = match lanes.entry((dst, tag)) {
            std::collections::btree_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::btree_map::Entry::Vacant(e) => {
                let (tx, rx) = unbounded::<Vec<u8>>();
                let thread = std::thread::Builder::new()
                    .name(format!("mpi send {dst}/{tag}"))
                    .spawn(move || {
                        let world = SimpleCommunicator::world();
                        let peer = world.process_at_rank(dst as mpi::Rank);
                        for bytes in rx {
                            peer.send_with_tag(&bytes[..], mpi::Tag::from(tag));
                        }
                    })
                    .map_err(|e| Error::run(format!("rank {}: sender thread: {e}", self.rank)))?;
                e.insert(Lane {
                    tx: Some(tx),
                    thread: Some(thread),
                })
            }
        };
        lane.tx
            .as_ref()
            .expect("lane open until drop")
            .send(bytes)
            .map_err(|_| Error::run(format!("rank {}: sender thread to rank {dst} stopped", self.rank)))
    }

    fn recv_remote(&self, src: usize, tag: Tag) -> Vec<u8> {
        self.world
            .process_at_rank(src as mpi::Rank)
            .matched_probe_with_tag(mpi::Tag::from(tag))
            .matched_receive_vec::<u8>()
            .0
    }

    fn reduce_f64(&self, values: &mut [f64], max: bool) -> Result<()> {
        let n = values.len();
        let bits: Vec<u64> = values.iter().map(|v| v.to_bits()).collect();
        let mut all = vec![0u64; n * self.size];
        if n > 0 {
            self.world.all_gather_into(&bits[..], &mut all[..]);
        }
        let parts: Vec<Vec<u8>> = all
            .chunks(n.max(1))
            .take(self.size)
            .map(super::u64s_to_bytes)
            .collect();
        reduce_f64_in_rank_order(&parts, values, max);
        self.accounting
            .record_collective(Collective::AllReduce, 0, self.size, 8 * n);
        Ok(())
    }
}

impl Drop for MpiComm {
    fn drop(&mut self) {
        // Close every lane and wait for its queued messages before MPI_Finalize.
        let lanes = std::mem::take(&mut *lock(&self.lanes));
        for (_, mut lane) in lanes {
            lane.tx.take();
            if let Some(t) = lane.thread.take() {
                let _ = t.join();
            }
        }
    }
}

impl Comm for MpiComm {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn accounting(&self) -> &Accounting {
        &self.accounting
    }

    fn node_key(&self) -> usize {
        self.node_key
    }

    fn send(&self, dst: usize, tag: Tag, bytes: Vec<u8>) -> Result<()> {
        check_peer(self.rank, self.size, dst, tag)?;
        self.accounting.record(dst, bytes.len());
        if dst == self.rank {
            lock(&self.self_queue).entry(tag).or_default().push_back(bytes);
            Ok(())
        } else if self.multiple {
            self.lane_send(dst, tag, bytes)
        } else {
            self.world
                .process_at_rank(dst as mpi::Rank)
                .send_with_tag(&bytes[..], mpi::Tag::from(tag));
            Ok(())
        }
    }

    fn recv(&self, src: usize, tag: Tag) -> Result<Vec<u8>> {
        check_peer(self.rank, self.size, src, tag)?;
        if src != self.rank {
            return Ok(self.recv_remote(src, tag));
        }
        lock(&self.self_queue)
            .get_mut(&tag)
            .and_then(VecDeque::pop_front)
            .ok_or_else(|| {
                Error::run(format!(
                    "rank {}: receive from itself with tag {tag}, but no such message was sent \
                     (it would wait forever)",
                    self.rank
                ))
            })
    }

    fn exchange(&self, sends: Vec<(usize, Vec<u8>)>, recv_from: &[usize], tag: Tag) -> Result<Vec<Vec<u8>>> {
        if self.multiple {
            for (dst, bytes) in sends {
                self.send(dst, tag, bytes)?;
            }
            return recv_from.iter().map(|&src| self.recv(src, tag)).collect();
        }
        // FUNNELED: non-blocking sends from this thread, receives, then wait for the sends.
        let mut remote = Vec::new();
        for (dst, bytes) in sends {
            check_peer(self.rank, self.size, dst, tag)?;
            if dst == self.rank {
                self.send(dst, tag, bytes)?;
            } else {
                self.accounting.record(dst, bytes.len());
                remote.push((dst, bytes));
            }
        }
        for &src in recv_from {
            check_peer(self.rank, self.size, src, tag)?;
        }
        mpi::request::scope(|scope| {
            let requests: Vec<_> = remote
                .iter()
                .map(|(dst, b)| {
                    self.world
                        .process_at_rank(*dst as mpi::Rank)
                        .immediate_send_with_tag(scope, &b[..], mpi::Tag::from(tag))
                })
                .collect();
            let out = recv_from.iter().map(|&src| self.recv(src, tag)).collect();
            for r in requests {
                r.wait();
            }
            out
        })
    }

    /// With MULTIPLE the sends go to their lanes and a thread receives the other ranks'
    /// messages while the caller computes, so that large messages move meanwhile (a sender
    /// lane blocked on a large message is released as soon as its receive is posted). The
    /// thread polls with `MPI_Improbe` and sleeps between polls: a blocking probe spins and,
    /// with a rank per core, takes the core from the compute (docs/benchmark-log.md,
    /// "Refreshes overlapped with the interior"). Without
    /// MULTIPLE every MPI call stays on this thread: the whole exchange is made at the finish.
    fn start_exchange(&self, sends: Vec<(usize, Vec<u8>)>, recv_from: &[usize], tag: Tag) -> Result<Pending> {
        for &src in recv_from {
            check_peer(self.rank, self.size, src, tag)?;
        }
        if !self.multiple {
            for (dst, _) in &sends {
                check_peer(self.rank, self.size, *dst, tag)?;
            }
            return Ok(Pending::deferred(sends, recv_from, tag));
        }
        for (dst, bytes) in sends {
            self.send(dst, tag, bytes)?;
        }
        let remote: Vec<usize> = recv_from.iter().copied().filter(|&s| s != self.rank).collect();
        if remote.is_empty() {
            return Ok(Pending::sent(recv_from, tag));
        }
        let thread = std::thread::Builder::new()
            .name(format!("mpi receive {tag}"))
            .spawn(move || {
                let world = SimpleCommunicator::world();
                let mut out = Vec::with_capacity(remote.len());
                for &src in &remote {
                    let peer = world.process_at_rank(src as mpi::Rank);
                    let msg = loop {
                        match peer.immediate_matched_probe_with_tag(mpi::Tag::from(tag)) {
                            Some(found) => break found,
                            None => std::thread::sleep(std::time::Duration::from_micros(50)),
                        }
                    };
                    out.push(msg.matched_receive_vec::<u8>().0);
                }
                Ok(out)
            })
            .map_err(|e| Error::run(format!("rank {}: receiving thread: {e}", self.rank)))?;
        Ok(Pending::receiving(recv_from, tag, thread))
    }

    fn all_reduce_sum_u64(&self, values: &mut [u64]) -> Result<()> {
        let send = values.to_vec();
        if !send.is_empty() {
            self.world
                .all_reduce_into(&send[..], values, mpi::collective::SystemOperation::sum());
        }
        self.accounting
            .record_collective(Collective::AllReduce, 0, self.size, 8 * send.len());
        Ok(())
    }

    fn all_reduce_sum_i64(&self, values: &mut [i64]) -> Result<()> {
        let send = values.to_vec();
        if !send.is_empty() {
            self.world
                .all_reduce_into(&send[..], values, mpi::collective::SystemOperation::sum());
        }
        self.accounting
            .record_collective(Collective::AllReduce, 0, self.size, 8 * send.len());
        Ok(())
    }

    fn all_reduce_max_f64(&self, values: &mut [f64]) -> Result<()> {
        self.reduce_f64(values, true)
    }

    fn all_reduce_min_f64(&self, values: &mut [f64]) -> Result<()> {
        self.reduce_f64(values, false)
    }

    fn all_gather_bytes(&self, bytes: Vec<u8>) -> Result<Vec<Vec<u8>>> {
        let too_big = |n: usize| {
            Error::run(format!(
                "rank {}: all-gather of {n} bytes exceeds MPI's 2 GiB count limit",
                self.rank
            ))
        };
        let own = mpi::Count::try_from(bytes.len()).map_err(|_| too_big(bytes.len()))?;
        let mut counts = vec![0 as mpi::Count; self.size];
        self.world.all_gather_into(&own, &mut counts[..]);
        let total: usize = counts.iter().map(|&c| c as usize).sum();
        mpi::Count::try_from(total).map_err(|_| too_big(total))?;
        let displs: Vec<mpi::Count> = counts
            .iter()
            .scan(0, |acc, &c| {
                let d = *acc;
                *acc += c;
                Some(d)
            })
            .collect();
        if total == 0 {
            // every contribution empty: nothing to move (MPI rejects the aliased empty buffers)
            self.accounting
                .record_collective(Collective::AllGather, 0, self.size, 0);
            return Ok(vec![Vec::new(); self.size]);
        }
        let mut buf = vec![0u8; total];
        {
            let mut partition = PartitionMut::new(&mut buf[..], &counts[..], &displs[..]);
            self.world.all_gather_varcount_into(&bytes[..], &mut partition);
        }
        let parts: Vec<Vec<u8>> = counts
            .iter()
            .zip(&displs)
            .map(|(&c, &d)| buf[d as usize..(d + c) as usize].to_vec())
            .collect();
        let logical = if self.rank == 0 { total } else { bytes.len() };
        self.accounting
            .record_collective(Collective::AllGather, 0, self.size, logical);
        Ok(parts)
    }

    fn broadcast_bytes(&self, root: usize, bytes: Vec<u8>) -> Result<Vec<u8>> {
        check_peer(self.rank, self.size, root, 0)?;
        let proc = self.world.process_at_rank(root as mpi::Rank);
        let mut len = [bytes.len() as u64];
        proc.broadcast_into(&mut len[..]);
        let mut buf = if self.rank == root {
            bytes
        } else {
            vec![0u8; len[0] as usize]
        };
        if !buf.is_empty() {
            proc.broadcast_into(&mut buf[..]);
        }
        self.accounting
            .record_collective(Collective::Broadcast, root, self.size, buf.len());
        Ok(buf)
    }

    fn barrier(&self) -> Result<()> {
        self.world.barrier();
        self.accounting
            .record_collective(Collective::Barrier, 0, self.size, 0);
        Ok(())
    }

    fn abort(&self, message: &str) -> Error {
        eprintln!("error: rank {} failed: {message}", self.rank);
        self.world.abort(1)
    }
}
