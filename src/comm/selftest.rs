//! A self-checking test of any [`Comm`], run by every rank: the same code checks the local
//! back end in `cargo test` and the MPI back end under `mpirun` (`examples/comm_selftest.rs`).
//!
//! It checks all-to-all and sparse exchanges, whole and split in two (including self-sends
//! and messages large enough to leave MPI's eager protocol), per-(source, tag) ordering across interleaved tags,
//! collectives against values each rank computes itself, identical result bits on every
//! rank, NaN propagation, all-gather, broadcast from every root, barrier, and that the
//! traffic log counts exactly the payload bytes and messages sent.

use super::{Comm, Phase, Tag};
use crate::error::{Error, Result};

/// Deterministic payload of message `k` from `src` to `dst`, of length `len`.
pub fn payload(src: usize, dst: usize, k: usize, len: usize) -> Vec<u8> {
    (0..len)
        .map(|i| (src * 31 + dst * 17 + k * 7 + i * 13 + (i >> 8)) as u8)
        .collect()
}

fn fail(comm: &dyn Comm, what: String) -> Error {
    Error::run(format!("rank {}: comm selftest: {what}", comm.rank()))
}

fn expect(comm: &dyn Comm, ok: bool, what: impl FnOnce() -> String) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(fail(comm, what()))
    }
}

/// Length of message `k` from `src` to `dst`: mostly small, some empty, some > 64 KiB.
fn length(src: usize, dst: usize, k: usize) -> usize {
    match (src + 2 * dst + k) % 5 {
        0 => 0,
        1 => 100_000 + src * 11 + dst,
        _ => 1 + (src * 5 + dst * 3 + k) % 97,
    }
}

/// Run every check on this rank. Every rank must call it; returns the first failure.
pub fn run(comm: &dyn Comm) -> Result<()> {
    let (me, p) = (comm.rank(), comm.size());
    expect(comm, me < p, || format!("rank {me} not below size {p}"))?;

    all_to_all(comm)?;
    sparse_exchanges(comm)?;

    // Ordering: interleave two tags to the next rank, receive all of one tag first.
    let next = (me + 1) % p;
    let prev = (me + p - 1) % p;
    for k in 0..20u8 {
        comm.send(next, 31, vec![k, 1])?;
        comm.send(next, 30, vec![k, 0])?;
    }
    for tag in [30, 31] {
        for k in 0..20u8 {
            let m = comm.recv(prev, tag)?;
            expect(comm, m == vec![k, (tag - 30) as u8], || {
                format!("ordering: tag {tag} message {k} from rank {prev} was {m:?}")
            })?;
        }
    }

    // Exact integer sums, including wrap-around and negatives.
    let mut u = [me as u64 + 1, u64::MAX - me as u64, 1 << 40];
    comm.all_reduce_sum_u64(&mut u)?;
    let pu = p as u64;
    let want_u = [
        pu * (pu + 1) / 2,
        (0..pu).fold(0u64, |a, r| a.wrapping_add(u64::MAX - r)),
        pu << 40,
    ];
    expect(comm, u == want_u, || format!("sum u64 {u:?} != {want_u:?}"))?;
    let mut i = [-(me as i64) * 1_000_000_007, i64::MIN / 3 + me as i64];
    comm.all_reduce_sum_i64(&mut i)?;
    let want_i = (0..p as i64).fold([0i64, 0], |a, r| {
        [
            a[0].wrapping_add(-r * 1_000_000_007),
            a[1].wrapping_add(i64::MIN / 3 + r),
        ]
    });
    expect(comm, i == want_i, || format!("sum i64 {i:?} != {want_i:?}"))?;

    // Floating max/min against a rank-order reduction done here, then identical bits.
    let val = |r: usize| [(r as f64 * 0.7).sin(), 1.0 / (r as f64 + 3.0), -0.0];
    let mut mx = val(me);
    let mut mn = val(me);
    comm.all_reduce_max_f64(&mut mx)?;
    comm.all_reduce_min_f64(&mut mn)?;
    for j in 0..3 {
        let m = (0..p).map(|r| val(r)[j]).fold(f64::NEG_INFINITY, f64::max);
        let n = (0..p).map(|r| val(r)[j]).fold(f64::INFINITY, f64::min);
        expect(comm, mx[j] == m && mn[j] == n, || {
            format!("max/min element {j}: {} {} vs {m} {n}", mx[j], mn[j])
        })?;
    }
    let mut nan = [if me == p - 1 { f64::NAN } else { me as f64 }];
    comm.all_reduce_max_f64(&mut nan)?;
    expect(comm, nan[0].is_nan(), || "NaN did not propagate".to_string())?;
    let bits: Vec<u8> = u
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .chain(i.iter().flat_map(|x| x.to_le_bytes()))
        .chain(mx.iter().chain(&mn).flat_map(|x| x.to_bits().to_le_bytes()))
        .collect();
    let all = comm.all_gather_bytes(bits.clone())?;
    expect(comm, all.iter().all(|b| *b == bits), || {
        "collective results differ between ranks".to_string()
    })?;

    // All-gather of different lengths, broadcast from every root, barrier.
    let mine = payload(me, 0, 99, me * 3 + 1);
    let all = comm.all_gather_bytes(mine)?;
    expect(comm, all.len() == p, || {
        format!("all-gather gave {} parts", all.len())
    })?;
    for (r, b) in all.iter().enumerate() {
        expect(comm, *b == payload(r, 0, 99, r * 3 + 1), || {
            format!("all-gather: wrong part of rank {r}")
        })?;
    }
    for root in 0..p {
        let data = if me == root {
            payload(root, 1, 5, 10 + root)
        } else {
            Vec::new()
        };
        let got = comm.broadcast_bytes(root, data)?;
        expect(comm, got == payload(root, 1, 5, 10 + root), || {
            format!("broadcast from rank {root}: wrong bytes")
        })?;
    }
    empty_contributions(comm)?;
    comm.barrier()?;
    Ok(())
}

/// An all-to-all exchange, self included, counted under Halo; the log's bytes checked.
fn all_to_all(comm: &dyn Comm) -> Result<()> {
    let (me, p) = (comm.rank(), comm.size());
    // All-to-all exchange, self included, counted under Halo; check the log's bytes.
    let before = comm.traffic();
    let old = comm.set_phase(Phase::Halo);
    for round in 0..2 {
        let sends: Vec<_> = (0..p)
            .map(|d| (d, payload(me, d, round, length(me, d, round))))
            .collect();
        let from: Vec<usize> = (0..p).rev().collect();
        let got = comm.exchange(sends, &from, 10 + round as Tag)?;
        for (&s, b) in from.iter().zip(&got) {
            expect(comm, *b == payload(s, me, round, length(s, me, round)), || {
                format!("all-to-all round {round}: wrong payload from rank {s}")
            })?;
        }
        let after = comm.traffic();
        for d in 0..p {
            let count = |log: &super::TrafficLog| {
                log.total()
                    .iter()
                    .filter(|e| e.phase == Phase::Halo && e.dst == d)
                    .fold((0, 0), |(b, n), e| (b + e.bytes, n + e.messages))
            };
            let (b0, n0) = count(&before);
            let (b1, n1) = count(&after);
            let want = (0..=round).map(|r| length(me, d, r) as u64).sum::<u64>();
            expect(comm, b1 - b0 == want && n1 - n0 == round as u64 + 1, || {
                format!(
                    "traffic to rank {d}: logged {} bytes in {} messages, sent {want} in {}",
                    b1 - b0,
                    n1 - n0,
                    round + 1
                )
            })?;
        }
    }
    comm.set_phase(old);
    Ok(())
}

/// A sparse exchange to me+1 and me+3 (mod p), whole and split in two; with few ranks both may
/// be the same peer (or this rank), so arrival order within one source is checked too.
fn sparse_exchanges(comm: &dyn Comm) -> Result<()> {
    let (me, p) = (comm.rank(), comm.size());
    // Sparse exchange: to me+1 and me+3 (mod p), in that order; with few ranks both may be the
    // same peer (or this rank), so arrival order within one source is checked too.
    let offsets = [1usize, 3];
    let sends: Vec<_> = offsets
        .iter()
        .map(|&o| {
            let d = (me + o) % p;
            (d, payload(me, d, o, length(me, d, o)))
        })
        .collect();
    let from: Vec<usize> = offsets.iter().map(|&o| (me + p * 4 - o) % p).collect();
    let got = comm.exchange(sends, &from, 20)?;
    for ((&o, &s), b) in offsets.iter().zip(&from).zip(&got) {
        expect(comm, *b == payload(s, me, o, length(s, me, o)), || {
            format!("sparse exchange: wrong payload from rank {s} (offset {o})")
        })?;
    }

    // The same sparse exchange split in two (an overlapped halo refresh): started, a
    // collective in between, then finished; the messages are those of the whole exchange.
    let sends: Vec<_> = offsets
        .iter()
        .map(|&o| {
            let d = (me + o) % p;
            (d, payload(me, d, o + 7, length(me, d, o)))
        })
        .collect();
    let pending = comm.start_exchange(sends, &from, 21)?;
    let mut one = [1u64];
    comm.all_reduce_sum_u64(&mut one)?;
    let got = comm.finish_exchange(pending)?;
    expect(comm, one[0] == p as u64, || {
        "sum during a split exchange".to_string()
    })?;
    for ((&o, &s), b) in offsets.iter().zip(&from).zip(&got) {
        expect(comm, *b == payload(s, me, o + 7, length(s, me, o)), || {
            format!("split exchange: wrong payload from rank {s} (offset {o})")
        })?;
    }
    Ok(())
}

/// Every collective with empty contributions: all ranks empty, some ranks empty, empty
/// reductions, an empty broadcast and an exchange of empty messages (1-rank MPI runs gather
/// nothing from anyone, which once failed inside MPI_Allgatherv).
fn empty_contributions(comm: &dyn Comm) -> Result<()> {
    let (me, p) = (comm.rank(), comm.size());
    let all = comm.all_gather_bytes(Vec::new())?;
    expect(comm, all.len() == p && all.iter().all(|b| b.is_empty()), || {
        "all-gather of nothing from everyone".to_string()
    })?;
    let some = if me % 2 == 1 {
        vec![me as u8; 3]
    } else {
        Vec::new()
    };
    let all = comm.all_gather_bytes(some)?;
    for (r, b) in all.iter().enumerate() {
        let want = if r % 2 == 1 { vec![r as u8; 3] } else { Vec::new() };
        expect(comm, *b == want, || {
            format!("all-gather with empty parts: rank {r}")
        })?;
    }
    comm.all_reduce_sum_u64(&mut [])?;
    comm.all_reduce_sum_i64(&mut [])?;
    comm.all_reduce_max_f64(&mut [])?;
    comm.all_reduce_min_f64(&mut [])?;
    let got = comm.broadcast_bytes(0, Vec::new())?;
    expect(comm, got.is_empty(), || "empty broadcast".to_string())?;
    // every rank sends an empty message to every rank, itself included
    let sends: Vec<(usize, Vec<u8>)> = (0..p).map(|r| (r, Vec::new())).collect();
    let from: Vec<usize> = (0..p).collect();
    let got = comm.exchange(sends, &from, 777)?;
    expect(comm, got.len() == p && got.iter().all(|b| b.is_empty()), || {
        "exchange of empty messages".to_string()
    })
}
