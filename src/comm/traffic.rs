//! Per-rank traffic log: what this rank sent, to whom, in which phase.

use std::collections::BTreeMap;

/// What a message is for. The caller sets the current phase on its communicator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub enum Phase {
    /// Ghost particle fields.
    Halo,
    /// Particles moving to the rank that now owns them.
    Migration,
    /// Load-balancing collectives and plane updates.
    Balance,
    /// Gathering output.
    Output,
    /// Anything else (start-up, diagnostics).
    #[default]
    Other,
}

impl Phase {
    /// Every phase, in a fixed order.
    pub const ALL: [Phase; 5] = [
        Phase::Halo,
        Phase::Migration,
        Phase::Balance,
        Phase::Output,
        Phase::Other,
    ];

    /// Lower-case name, as in `traffic.csv`.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Halo => "halo",
            Phase::Migration => "migration",
            Phase::Balance => "balance",
            Phase::Output => "output",
            Phase::Other => "other",
        }
    }
}

/// Traffic from this rank to one destination in one phase.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TrafficEntry {
    /// Phase the messages were sent in.
    pub phase: Phase,
    /// Sending rank (the log's owner).
    pub src: usize,
    /// Destination rank (may equal `src`: self-sends are counted too).
    pub dst: usize,
    /// Payload bytes.
    pub bytes: u64,
    /// Number of messages.
    pub messages: u64,
}

/// Counts per (phase, destination) for the current step and for the whole run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TrafficLog {
    rank: usize,
    step: BTreeMap<(Phase, usize), (u64, u64)>,
    total: BTreeMap<(Phase, usize), (u64, u64)>,
}

fn entries(rank: usize, m: &BTreeMap<(Phase, usize), (u64, u64)>) -> Vec<TrafficEntry> {
    m.iter()
        .map(|(&(phase, dst), &(bytes, messages))| TrafficEntry {
            phase,
            src: rank,
            dst,
            bytes,
            messages,
        })
        .collect()
}

impl TrafficLog {
    /// Empty log of rank `rank`.
    pub fn new(rank: usize) -> Self {
        TrafficLog {
            rank,
            ..Default::default()
        }
    }

    /// The rank whose sends this log counts.
    pub fn rank(&self) -> usize {
        self.rank
    }

    /// Count `messages` messages with `bytes` payload bytes in all to `dst`.
    pub fn record(&mut self, phase: Phase, dst: usize, bytes: u64, messages: u64) {
        for m in [&mut self.step, &mut self.total] {
            let e = m.entry((phase, dst)).or_insert((0, 0));
            e.0 += bytes;
            e.1 += messages;
        }
    }

    /// Entries of the current step, sorted by (phase, destination).
    pub fn step(&self) -> Vec<TrafficEntry> {
        entries(self.rank, &self.step)
    }

    /// Entries since the start of the run, sorted by (phase, destination).
    pub fn total(&self) -> Vec<TrafficEntry> {
        entries(self.rank, &self.total)
    }

    /// Return the current step's entries and start an empty step.
    pub fn end_step(&mut self) -> Vec<TrafficEntry> {
        let e = self.step();
        self.step.clear();
        e
    }

    /// Total payload bytes and messages since the start, optionally of one phase only.
    pub fn total_of(&self, phase: Option<Phase>) -> (u64, u64) {
        self.total
            .iter()
            .filter(|((p, _), _)| phase.is_none_or(|q| *p == q))
            .fold((0, 0), |(b, n), (_, &(db, dn))| (b + db, n + dn))
    }
}

/// The kinds of collective, for [`collective_traffic`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Collective {
    /// All-reduce of `bytes` per rank.
    AllReduce,
    /// All-gather; `bytes` is this rank's contribution on a non-root rank and the sum of all
    /// contributions on the root.
    AllGather,
    /// Broadcast of `bytes` from the root.
    Broadcast,
    /// Barrier (zero-byte messages).
    Barrier,
}

/// Logical messages one rank sends in a collective, as `(destination, payload bytes)`.
///
/// The model is "gather to the root, then broadcast from it", which is what the local back
/// end does; the MPI back end records the same whatever the library does, so logs agree
/// between back ends. All-reduce, all-gather and barrier use root 0: a non-root rank sends
/// one message to the root, the root one message to each other rank. A broadcast is one
/// message from the root to each other rank. On one rank a collective sends nothing.
pub fn collective_traffic(
    kind: Collective,
    rank: usize,
    root: usize,
    size: usize,
    bytes: usize,
) -> Vec<(usize, usize)> {
    let bytes = if kind == Collective::Barrier { 0 } else { bytes };
    let root = if kind == Collective::Broadcast { root } else { 0 };
    if rank == root {
        (0..size).filter(|&d| d != root).map(|d| (d, bytes)).collect()
    } else if kind == Collective::Broadcast {
        Vec::new()
    } else {
        vec![(root, bytes)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_keeps_step_and_total() {
        let mut log = TrafficLog::new(2);
        log.record(Phase::Halo, 1, 10, 1);
        log.record(Phase::Halo, 1, 5, 1);
        log.record(Phase::Migration, 0, 7, 1);
        let step = log.end_step();
        assert_eq!(step.len(), 2);
        assert_eq!(
            step[0],
            TrafficEntry {
                phase: Phase::Halo,
                src: 2,
                dst: 1,
                bytes: 15,
                messages: 2
            }
        );
        log.record(Phase::Halo, 3, 1, 1);
        assert_eq!(log.step().len(), 1);
        assert_eq!(log.total_of(None), (23, 4));
        assert_eq!(log.total_of(Some(Phase::Halo)), (16, 3));
    }

    #[test]
    fn collective_model() {
        assert_eq!(
            collective_traffic(Collective::AllReduce, 0, 0, 3, 8),
            vec![(1, 8), (2, 8)]
        );
        assert_eq!(
            collective_traffic(Collective::AllReduce, 2, 0, 3, 8),
            vec![(0, 8)]
        );
        assert_eq!(collective_traffic(Collective::Broadcast, 2, 1, 3, 8), vec![]);
        assert_eq!(
            collective_traffic(Collective::Broadcast, 1, 1, 3, 8),
            vec![(0, 8), (2, 8)]
        );
        assert_eq!(collective_traffic(Collective::Barrier, 1, 0, 3, 8), vec![(0, 0)]);
        assert!(collective_traffic(Collective::AllGather, 0, 0, 1, 8).is_empty());
    }
}
