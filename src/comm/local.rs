//! The local back end: N ranks as dedicated OS threads of one process.
//!
//! [`run_local`] starts one scoped OS thread per rank (never a rayon task, so a blocking
//! receive can never starve a worker pool), gives each rank its own rayon pool and runs the
//! rank body inside it. Each rank has one unbounded crossbeam inbox; a receive takes messages
//! from the inbox and buffers the ones it is not waiting for by (source, tag), so messages of
//! one (source, tag) stay in order and callers choose the order they receive peers in.
//!
//! Failure: each rank body runs under `catch_unwind`. A rank that returns an error, panics or
//! calls [`Comm::abort`] raises a shared abort (a flag, the first failure's rank and message,
//! and a wake-up channel that is closed); every blocked receive and collective selects on its
//! inbox and that channel, so all ranks return promptly and [`run_local`] returns one
//! [`Error::Run`] naming the failing rank. A rank that waits for a peer which has already
//! finished fails too instead of hanging.

use super::{
    bytes_to_u64s, check_peer, error_text, lock, panic_message, reduce_f64_in_rank_order, u64s_to_bytes,
    Accounting, Collective, Comm, Tag,
};
use crate::affinity::StartHandler;
use crate::error::{Error, Result};
use crossbeam::channel::{bounded, select, unbounded, Receiver, Sender};
use std::collections::{BTreeMap, VecDeque};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// Which stream of messages between two ranks: a caller's tag or the collectives'.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Key {
    User(Tag),
    Collective,
}

impl std::fmt::Display for Key {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Key::User(t) => write!(f, "tag {t}"),
            Key::Collective => write!(f, "a collective"),
        }
    }
}

enum Envelope {
    Data {
        src: usize,
        key: Key,
        bytes: Vec<u8>,
    },
    /// The sender's body has returned: nothing more will come from it.
    Done {
        src: usize,
    },
}

/// The shared abort: first failure, a flag, and a channel closed to wake every waiter.
struct Abort {
    failure: Mutex<Option<(usize, String)>>,
    /// The first failure, when it was an input error (exit 2): every rank agreed on it (a
    /// set-up error found by one rank is shared before any rank returns), so the run reports
    /// it as itself rather than as a rank's failure.
    input: Mutex<Option<(usize, Error)>>,
    raised: AtomicBool,
    signal: Mutex<Option<Sender<()>>>,
    wake: Receiver<()>,
}

impl Abort {
    fn new() -> Self {
        let (tx, rx) = bounded(0);
        Abort {
            failure: Mutex::new(None),
            input: Mutex::new(None),
            raised: AtomicBool::new(false),
            signal: Mutex::new(Some(tx)),
            wake: rx,
        }
    }

    /// Record `rank`'s failure (only the first one counts) and wake every waiter.
    fn raise(&self, rank: usize, message: String) {
        self.raise_error(rank, message, None);
    }

    /// [`Abort::raise`], keeping the error itself when it is an input error.
    fn raise_error(&self, rank: usize, message: String, error: Option<&Error>) {
        {
            let mut f = lock(&self.failure);
            if f.is_none() {
                *f = Some((rank, message));
                if let Some(e @ (Error::Input { .. } | Error::Stopped(_))) = error {
                    *lock(&self.input) = Some((rank, e.clone()));
                }
            }
        }
        self.raised.store(true, Ordering::SeqCst);
        // Dropping the only sender disconnects `wake`: every select on it returns at once.
        lock(&self.signal).take();
    }

    fn is_raised(&self) -> bool {
        self.raised.load(Ordering::SeqCst)
    }

    fn failure(&self) -> Option<(usize, String)> {
        lock(&self.failure).clone()
    }
}

struct Shared {
    inboxes: Vec<Sender<Envelope>>,
    abort: Abort,
}

/// Buffered messages per (source, stream), each queue in arrival order.
type Pending = BTreeMap<(usize, Key), VecDeque<Vec<u8>>>;

/// One rank's communicator in a [`run_local`] run.
pub struct LocalComm {
    rank: usize,
    size: usize,
    shared: Arc<Shared>,
    inbox: Receiver<Envelope>,
    pending: Mutex<Pending>,
    finished: Mutex<Vec<bool>>,
    accounting: Accounting,
}

impl LocalComm {
    fn interrupted(&self) -> Error {
        let why = match self.shared.abort.failure() {
            Some((r, m)) => format!("rank {r} failed: {m}"),
            None => "the run was aborted".to_string(),
        };
        Error::run(format!("rank {}: interrupted because {why}", self.rank))
    }

    /// Put a message on `dst`'s stream `key` (no accounting). Self-messages skip the channel.
    fn post(&self, dst: usize, key: Key, bytes: Vec<u8>) -> Result<()> {
        if self.shared.abort.is_raised() {
            return Err(self.interrupted());
        }
        if dst == self.rank {
            lock(&self.pending)
                .entry((dst, key))
                .or_default()
                .push_back(bytes);
            return Ok(());
        }
        let env = Envelope::Data {
            src: self.rank,
            key,
            bytes,
        };
        self.shared.inboxes[dst].send(env).map_err(|_| {
            Error::run(format!(
                "rank {}: sending to rank {dst} ({key}), which has already finished",
                self.rank
            ))
        })
    }

    /// Wait for the next message of stream `key` from `src`.
    fn take(&self, src: usize, key: Key) -> Result<Vec<u8>> {
        loop {
            if self.shared.abort.is_raised() {
                return Err(self.interrupted());
            }
            if let Some(b) = lock(&self.pending)
                .get_mut(&(src, key))
                .and_then(VecDeque::pop_front)
            {
                return Ok(b);
            }
            if src == self.rank {
                return Err(Error::run(format!(
                    "rank {}: receive from itself ({key}), but no such message was sent \
                     (it would wait forever)",
                    self.rank
                )));
            }
            if lock(&self.finished)[src] {
                return Err(Error::run(format!(
                    "rank {}: waiting for a message from rank {src} ({key}), but rank {src} \
                     has finished",
                    self.rank
                )));
            }
            select! {
                recv(self.inbox) -> env => match env {
                    Ok(Envelope::Data { src, key, bytes }) => {
                        lock(&self.pending).entry((src, key)).or_default().push_back(bytes);
                    }
                    Ok(Envelope::Done { src }) => lock(&self.finished)[src] = true,
                    Err(_) => return Err(Error::run(format!("rank {}: inbox closed", self.rank))),
                },
                recv(self.shared.abort.wake) -> _ => {}
            }
        }
    }

    /// Gather every rank's bytes on rank 0 (rank order); `None` on the other ranks.
    fn gather(&self, bytes: Vec<u8>) -> Result<Option<Vec<Vec<u8>>>> {
        if self.rank == 0 {
            let mut all = Vec::with_capacity(self.size);
            all.push(bytes);
            for src in 1..self.size {
                all.push(self.take(src, Key::Collective)?);
            }
            Ok(Some(all))
        } else {
            self.post(0, Key::Collective, bytes)?;
            Ok(None)
        }
    }

    /// Send `root`'s bytes to every other rank; every rank returns them.
    fn spread(&self, root: usize, bytes: Option<Vec<u8>>) -> Result<Vec<u8>> {
        if self.rank == root {
            let bytes = bytes.unwrap_or_default();
            for dst in (0..self.size).filter(|&d| d != root) {
                self.post(dst, Key::Collective, bytes.clone())?;
            }
            Ok(bytes)
        } else {
            self.take(root, Key::Collective)
        }
    }

    /// Reduce per-rank byte vectors on rank 0 with `reduce` and give every rank the result's
    /// bytes (so every rank decodes the same bits).
    fn reduce_bytes(&self, bytes: Vec<u8>, reduce: impl FnOnce(Vec<Vec<u8>>) -> Vec<u8>) -> Result<Vec<u8>> {
        let n = bytes.len();
        let result = self.gather(bytes)?.map(reduce);
        let out = self.spread(0, result)?;
        self.accounting
            .record_collective(Collective::AllReduce, 0, self.size, n);
        Ok(out)
    }

    /// Exact wrapping sum (the same bits for two's-complement `i64`).
    fn reduce_u64(&self, values: &mut [u64]) -> Result<()> {
        let n = values.len();
        let out = self.reduce_bytes(u64s_to_bytes(values), |parts| {
            let mut acc = vec![0u64; n];
            for p in &parts {
                for (a, x) in acc.iter_mut().zip(bytes_to_u64s(p)) {
                    *a = a.wrapping_add(x);
                }
            }
            u64s_to_bytes(&acc)
        })?;
        values.copy_from_slice(&bytes_to_u64s(&out));
        Ok(())
    }

    fn reduce_f64(&self, values: &mut [f64], max: bool) -> Result<()> {
        let bits: Vec<u64> = values.iter().map(|v| v.to_bits()).collect();
        let n = values.len();
        let out = self.reduce_bytes(u64s_to_bytes(&bits), |parts| {
            let mut acc = vec![0.0; n];
            reduce_f64_in_rank_order(&parts, &mut acc, max);
            u64s_to_bytes(&acc.iter().map(|v| v.to_bits()).collect::<Vec<_>>())
        })?;
        for (v, b) in values.iter_mut().zip(bytes_to_u64s(&out)) {
            *v = f64::from_bits(b);
        }
        Ok(())
    }

    /// Tell every other rank that this one is done.
    fn finish(&self) {
        for (dst, inbox) in self.shared.inboxes.iter().enumerate() {
            if dst != self.rank {
                let _ = inbox.send(Envelope::Done { src: self.rank });
            }
        }
    }
}

/// Concatenate byte vectors with their lengths in front (u64 count, u64 lengths, data).
fn frame(parts: &[Vec<u8>]) -> Vec<u8> {
    let mut head = vec![parts.len() as u64];
    head.extend(parts.iter().map(|p| p.len() as u64));
    let mut out = u64s_to_bytes(&head);
    for p in parts {
        out.extend_from_slice(p);
    }
    out
}

/// Inverse of [`frame`].
fn unframe(b: &[u8]) -> Vec<Vec<u8>> {
    let n = u64::from_le_bytes(b[..8].try_into().expect("8 bytes")) as usize;
    let lens = bytes_to_u64s(&b[8..8 + 8 * n]);
    let mut at = 8 + 8 * n;
    lens.iter()
        .map(|&l| {
            let p = b[at..at + l as usize].to_vec();
            at += l as usize;
            p
        })
        .collect()
}

impl Comm for LocalComm {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn accounting(&self) -> &Accounting {
        &self.accounting
    }

    fn send(&self, dst: usize, tag: Tag, bytes: Vec<u8>) -> Result<()> {
        check_peer(self.rank, self.size, dst, tag)?;
        self.accounting.record(dst, bytes.len());
        self.post(dst, Key::User(tag), bytes)
    }

    fn recv(&self, src: usize, tag: Tag) -> Result<Vec<u8>> {
        check_peer(self.rank, self.size, src, tag)?;
        self.take(src, Key::User(tag))
    }

    fn all_reduce_sum_u64(&self, values: &mut [u64]) -> Result<()> {
        self.reduce_u64(values)
    }

    fn all_reduce_sum_i64(&self, values: &mut [i64]) -> Result<()> {
        let mut u: Vec<u64> = values.iter().map(|&v| v as u64).collect();
        self.reduce_u64(&mut u)?;
        for (v, x) in values.iter_mut().zip(u) {
            *v = x as i64;
        }
        Ok(())
    }

    fn all_reduce_max_f64(&self, values: &mut [f64]) -> Result<()> {
        self.reduce_f64(values, true)
    }

    fn all_reduce_min_f64(&self, values: &mut [f64]) -> Result<()> {
        self.reduce_f64(values, false)
    }

    fn all_gather_bytes(&self, bytes: Vec<u8>) -> Result<Vec<Vec<u8>>> {
        let own = bytes.len();
        let framed = self.gather(bytes)?.map(|parts| frame(&parts));
        let parts = unframe(&self.spread(0, framed)?);
        let logical = if self.rank == 0 {
            parts.iter().map(Vec::len).sum()
        } else {
            own
        };
        self.accounting
            .record_collective(Collective::AllGather, 0, self.size, logical);
        Ok(parts)
    }

    fn broadcast_bytes(&self, root: usize, bytes: Vec<u8>) -> Result<Vec<u8>> {
        check_peer(self.rank, self.size, root, 0)?;
        let out = self.spread(root, Some(bytes))?;
        self.accounting
            .record_collective(Collective::Broadcast, root, self.size, out.len());
        Ok(out)
    }

    fn barrier(&self) -> Result<()> {
        self.gather(Vec::new())?;
        self.spread(0, Some(Vec::new()))?;
        self.accounting
            .record_collective(Collective::Barrier, 0, self.size, 0);
        Ok(())
    }

    fn abort(&self, message: &str) -> Error {
        self.shared.abort.raise(self.rank, message.to_string());
        Error::run(format!("rank {} failed: {message}", self.rank))
    }
}

/// Run `body` on `ranks` ranks, each a dedicated OS thread with its own rayon pool of
/// `threads` threads (the body runs inside `pool.install`, so rayon calls in it use that
/// pool). Returns the ranks' results in rank order.
///
/// If any rank fails (returns an error, panics or calls [`Comm::abort`]), every other rank's
/// blocked receives and collectives fail promptly, and the result is one [`Error::Run`]
/// `rank R failed: MESSAGE` naming the first rank that failed. The process is not exited.
/// `ranks` or `threads` of zero is an [`Error::Input`].
pub fn run_local<T, F>(ranks: usize, threads: usize, body: F) -> Result<Vec<T>>
where
    T: Send,
    F: Fn(&LocalComm) -> Result<T> + Sync,
{
    run_local_with(ranks, threads, None, body)
}

/// [`run_local`] whose rank pools run `start(rank, thread_index)` first on each of their
/// threads (rayon's start handler): `--bind cores` pins them there
/// ([`crate::affinity::start_handler`]).
pub fn run_local_with<T, F>(
    ranks: usize,
    threads: usize,
    start: Option<StartHandler>,
    body: F,
) -> Result<Vec<T>>
where
    T: Send,
    F: Fn(&LocalComm) -> Result<T> + Sync,
{
    if ranks == 0 {
        return Err(Error::input("ranks", "the number of ranks must be at least 1"));
    }
    if threads == 0 {
        return Err(Error::input(
            "threads",
            "the number of threads per rank must be at least 1",
        ));
    }
    let (txs, rxs): (Vec<_>, Vec<_>) = (0..ranks).map(|_| unbounded()).unzip();
    let shared = Arc::new(Shared {
        inboxes: txs,
        abort: Abort::new(),
    });
    let body = &body;
    let results: Vec<Option<T>> = std::thread::scope(|s| {
        let handles: Vec<_> = rxs
            .into_iter()
            .enumerate()
            .map(|(rank, inbox)| {
                let shared = Arc::clone(&shared);
                let start = start.clone();
                std::thread::Builder::new()
                    .name(format!("rank {rank}"))
                    .spawn_scoped(s, move || {
                        run_rank(rank, ranks, threads, start, shared, inbox, body)
                    })
            })
            .collect();
        handles
            .into_iter()
            .enumerate()
            .map(|(rank, h)| match h {
                Ok(h) => h.join().ok().flatten(),
                Err(e) => {
                    shared
                        .abort
                        .raise(rank, format!("cannot start the rank's thread: {e}"));
                    None
                }
            })
            .collect()
    });
    if let Some((rank, message)) = shared.abort.failure() {
        if let Some((_, e)) = lock(&shared.abort.input).take() {
            return Err(e);
        }
        return Err(Error::run(format!("rank {rank} failed: {message}")));
    }
    results
        .into_iter()
        .collect::<Option<Vec<T>>>()
        .ok_or_else(|| Error::run("a rank stopped without a result"))
}

fn run_rank<T, F>(
    rank: usize,
    size: usize,
    threads: usize,
    start: Option<StartHandler>,
    shared: Arc<Shared>,
    inbox: Receiver<Envelope>,
    body: &F,
) -> Option<T>
where
    T: Send,
    F: Fn(&LocalComm) -> Result<T> + Sync,
{
    let comm = LocalComm {
        rank,
        size,
        shared: Arc::clone(&shared),
        inbox,
        pending: Mutex::new(BTreeMap::new()),
        finished: Mutex::new(vec![false; size]),
        accounting: Accounting::new(rank),
    };
    let builder = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(move |i| format!("rank {rank} worker {i}"));
    let outcome = match crate::affinity::with_start(builder, start.as_ref(), rank).build() {
        Ok(pool) => catch_unwind(AssertUnwindSafe(|| pool.install(|| body(&comm)))),
        Err(e) => Ok(Err(Error::run(format!(
            "cannot start the rank's rayon pool: {e}"
        )))),
    };
    let result = match outcome {
        Ok(Ok(v)) => Some(v),
        Ok(Err(e)) => {
            shared.abort.raise_error(rank, error_text(&e), Some(&e));
            None
        }
        Err(p) => {
            shared
                .abort
                .raise(rank, format!("panicked: {}", panic_message(&*p)));
            None
        }
    };
    comm.finish();
    result
}

#[cfg(test)]
mod tests;
