//! Ids of particles created during a run (splitting and merging; inlets later):
//! numbered the same on every layout (`docs/splitting.md` §4).
//!
//! Every particle's id is unique and never reused. The set-up numbers its particles by their
//! sites on the nested lattices, below [`crate::scene::lattice::id_bound`]; a particle created
//! later takes its id from a counter, `next_id`, that starts at that bound and is the same on
//! every rank. Each step that creates particles, every rank names its creations by keys
//! (parent id, child index) that depend only on the particles' state; the keys of all ranks are
//! all-gathered and sorted, and the k-th key receives `next_id + k`. The ids therefore depend
//! on what was created, never on which rank or thread created it.
//!
//! The counter is written in checkpoints (`checkpoint::Clock::next_id`), so a restart numbers
//! the next creations as the uninterrupted run does.

use crate::comm::{Comm, Phase};
use crate::error::{Error, Result};

/// Ids stay below 2^54: ghosts are sorted by `id << IMAGE_BITS` (10 bits of image code).
pub const ID_LIMIT: u64 = 1 << (64 - crate::particles::IMAGE_BITS);

/// What names a created particle: the id of the particle it comes from and its index among
/// that particle's children (a merge: the smallest member id and 0).
pub type Key = (u64, u32);

/// The counter of the next free id (the same on every rank).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdCounter {
    next: u64,
}

impl IdCounter {
    /// A counter whose first id is `next` (the set-up's id bound, or a checkpoint's counter).
    pub fn starting_at(next: u64) -> Self {
        IdCounter { next }
    }

    /// The next id to be given: every id given so far, and every set-up id, is below it.
    pub fn next(&self) -> u64 {
        self.next
    }

    /// Collective: ids for this rank's creations `keys` (in the order given), numbered over
    /// the sorted keys of every rank from the counter, which then moves past them. Every rank
    /// calls it at the same step, with its own keys (possibly none). A key created twice (on
    /// one rank or on two) or a counter that would pass [`ID_LIMIT`] is a run error.
    pub fn allocate(&mut self, comm: &dyn Comm, keys: &[Key]) -> Result<Vec<u64>> {
        let mut bytes = Vec::with_capacity(keys.len() * 12);
        for &(parent, child) in keys {
            bytes.extend_from_slice(&parent.to_le_bytes());
            bytes.extend_from_slice(&child.to_le_bytes());
        }
        let prev = comm.set_phase(Phase::Other);
        let gathered = comm.all_gather_bytes(bytes);
        comm.set_phase(prev);
        let mut all: Vec<Key> = gathered?
            .iter()
            .flat_map(|b| b.chunks_exact(12))
            .map(|c| {
                let parent = u64::from_le_bytes(c[..8].try_into().expect("8 bytes"));
                (parent, u32::from_le_bytes(c[8..].try_into().expect("4 bytes")))
            })
            .collect();
        all.sort_unstable();
        if let Some(w) = all.windows(2).find(|w| w[0] == w[1]) {
            return Err(Error::run(format!(
                "particle {} created child {} twice in one step",
                w[0].0, w[0].1
            )));
        }
        let end = self.next.checked_add(all.len() as u64).filter(|&e| e <= ID_LIMIT);
        let Some(end) = end else {
            return Err(Error::run(format!(
                "particle ids: {} creations from next_id = {} would pass the id limit 2^54",
                all.len(),
                self.next
            )));
        };
        let ids = keys
            .iter()
            .map(|k| self.next + all.binary_search(k).expect("own key gathered") as u64)
            .collect();
        self.next = end;
        Ok(ids)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::comm::local::run_local;
    use crate::comm::serial::SerialComm;

    /// A fixed list of creations, spread over the ranks in a way that depends on the layout.
    fn creations() -> Vec<Key> {
        (0..40u64)
            .flat_map(|p| (0..(p % 4) as u32).map(move |c| (1000 + 7 * p, c)))
            .collect()
    }

    #[test]
    fn ids_are_the_sorted_keys_numbered_from_the_counter_on_any_layout() {
        let keys = creations();
        let mut sorted = keys.clone();
        sorted.sort_unstable();
        for ranks in [1, 3, 8] {
            let per_rank = run_local(ranks, 1, |comm| {
                // rank r creates every key whose position, reversed, is r mod ranks
                let mine: Vec<Key> = keys
                    .iter()
                    .rev()
                    .enumerate()
                    .filter(|(k, _)| k % comm.size() == comm.rank())
                    .map(|(_, &key)| key)
                    .collect();
                let mut counter = IdCounter::starting_at(5000);
                let first = counter.allocate(comm, &mine)?;
                // a step without creations moves nothing; the next step continues the count
                let none = counter.allocate(comm, &[])?;
                let again: Vec<Key> = mine.iter().map(|&(p, c)| (p, c + 10)).collect();
                let second = counter.allocate(comm, &again)?;
                Ok((mine, first, none, second, counter.next()))
            })
            .unwrap();
            for (mine, first, none, second, next) in per_rank {
                assert!(none.is_empty());
                assert_eq!(next, 5000 + 2 * keys.len() as u64, "{ranks} ranks");
                for (k, key) in mine.iter().enumerate() {
                    // the oracle: the key's place in the sorted list of every creation
                    let place = sorted.iter().position(|s| s == key).unwrap() as u64;
                    assert_eq!(first[k], 5000 + place, "{ranks} ranks, key {key:?}");
                    assert_eq!(second[k], 5000 + keys.len() as u64 + place);
                }
            }
        }
    }

    #[test]
    fn a_key_created_twice_or_past_the_limit_is_an_error() {
        let comm = SerialComm::new();
        let mut c = IdCounter::starting_at(10);
        let e = c.allocate(&comm, &[(3, 1), (4, 0), (3, 1)]).unwrap_err();
        assert!(e.to_string().contains("particle 3 created child 1 twice"), "{e}");
        let mut c = IdCounter::starting_at(ID_LIMIT - 2);
        assert_eq!(
            c.allocate(&comm, &[(1, 0), (1, 1)]).unwrap(),
            vec![ID_LIMIT - 2, ID_LIMIT - 1]
        );
        let e = c.allocate(&comm, &[(2, 0)]).unwrap_err();
        assert!(e.to_string().contains("id limit 2^54"), "{e}");
        assert_eq!(c.next(), ID_LIMIT, "a refused allocation moves nothing");
    }
}
