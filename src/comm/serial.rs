//! The serial back end: one rank, whose messages to itself are queued like any other.

use super::{check_peer, lock, Accounting, Comm, Tag};
use crate::error::{Error, Result};
use std::collections::{BTreeMap, VecDeque};
use std::sync::Mutex;

/// A communicator of one rank. Self-sends (periodic images) go through [`Comm::send`] and
/// [`Comm::recv`] exactly as on many ranks; collectives return their input.
#[derive(Debug)]
pub struct SerialComm {
    queue: Mutex<BTreeMap<Tag, VecDeque<Vec<u8>>>>,
    accounting: Accounting,
}

impl Default for SerialComm {
    fn default() -> Self {
        Self::new()
    }
}

impl SerialComm {
    /// The one-rank communicator.
    pub fn new() -> Self {
        SerialComm {
            queue: Mutex::new(BTreeMap::new()),
            accounting: Accounting::new(0),
        }
    }
}

impl Comm for SerialComm {
    fn rank(&self) -> usize {
        0
    }

    fn size(&self) -> usize {
        1
    }

    fn accounting(&self) -> &Accounting {
        &self.accounting
    }

    fn send(&self, dst: usize, tag: Tag, bytes: Vec<u8>) -> Result<()> {
        check_peer(0, 1, dst, tag)?;
        self.accounting.record(dst, bytes.len());
        lock(&self.queue).entry(tag).or_default().push_back(bytes);
        Ok(())
    }

    fn recv(&self, src: usize, tag: Tag) -> Result<Vec<u8>> {
        check_peer(0, 1, src, tag)?;
        lock(&self.queue)
            .get_mut(&tag)
            .and_then(VecDeque::pop_front)
            .ok_or_else(|| {
                Error::run(format!(
                    "rank 0: receive from itself with tag {tag}, but no such message was sent \
                     (it would wait forever)"
                ))
            })
    }

    fn all_reduce_sum_u64(&self, _values: &mut [u64]) -> Result<()> {
        Ok(())
    }

    fn all_reduce_sum_i64(&self, _values: &mut [i64]) -> Result<()> {
        Ok(())
    }

    fn all_reduce_max_f64(&self, values: &mut [f64]) -> Result<()> {
        // Same NaN rule as on many ranks (canonical NaN).
        for v in values.iter_mut() {
            *v = super::pick_f64(*v, *v, true);
        }
        Ok(())
    }

    fn all_reduce_min_f64(&self, values: &mut [f64]) -> Result<()> {
        for v in values.iter_mut() {
            *v = super::pick_f64(*v, *v, false);
        }
        Ok(())
    }

    fn all_gather_bytes(&self, bytes: Vec<u8>) -> Result<Vec<Vec<u8>>> {
        Ok(vec![bytes])
    }

    fn broadcast_bytes(&self, root: usize, bytes: Vec<u8>) -> Result<Vec<u8>> {
        check_peer(0, 1, root, 0)?;
        Ok(bytes)
    }

    fn barrier(&self) -> Result<()> {
        Ok(())
    }

    fn abort(&self, message: &str) -> Error {
        Error::run(format!("rank 0 failed: {message}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::comm::Phase;

    #[test]
    fn self_sends_in_order_and_counted() {
        let c = SerialComm::new();
        c.set_phase(Phase::Halo);
        c.send(0, 3, vec![1, 2]).unwrap();
        c.send(0, 4, vec![9]).unwrap();
        c.send(0, 3, vec![3]).unwrap();
        assert_eq!(c.recv(0, 4).unwrap(), vec![9]);
        assert_eq!(c.recv(0, 3).unwrap(), vec![1, 2]);
        assert_eq!(c.recv(0, 3).unwrap(), vec![3]);
        assert!(c.recv(0, 3).is_err());
        assert!(c.send(1, 0, vec![]).is_err());
        assert_eq!(c.traffic().total_of(Some(Phase::Halo)), (4, 3));
        let r = c.exchange(vec![(0, vec![5; 5])], &[0], 7).unwrap();
        assert_eq!(r, vec![vec![5; 5]]);
        let mut v = [1.5, -2.0];
        c.all_reduce_max_f64(&mut v).unwrap();
        assert_eq!(v, [1.5, -2.0]);
    }

    #[test]
    fn selftest_passes() {
        crate::comm::selftest::run(&SerialComm::new()).unwrap();
    }
}
