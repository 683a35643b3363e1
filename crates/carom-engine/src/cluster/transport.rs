//! Message passing between ranks, as the two collectives the decomposition needs.

use std::sync::{Arc, Barrier, Mutex, PoisonError};

/// Collective byte exchange between `size()` ranks. Every rank calls the same methods in the
/// same order (as with MPI collectives); a call returns once every rank has made it.
pub trait Transport {
    /// This rank, `0..size()`.
    fn rank(&self) -> usize;
    /// Number of ranks (>= 1).
    fn size(&self) -> usize;
    /// Every rank's `mine`, indexed by rank.
    fn all_gather(&mut self, mine: &[u8]) -> Vec<Vec<u8>>;
    /// Sends `outgoing[r]` to rank `r` (`outgoing.len() == size()`); returns what every rank
    /// sent to this one, indexed by sender.
    fn all_to_all(&mut self, outgoing: Vec<Vec<u8>>) -> Vec<Vec<u8>>;
    /// Replaces `values` (the same length on every rank) with their sums over all ranks. The
    /// solver calls this once per sweep, so a transport with a cheaper reduction than
    /// [`Transport::all_gather`] (MPI's `MPI_Allreduce`) should provide it.
    fn all_sum(&mut self, values: &mut [u64]) {
        let mut mine = Vec::with_capacity(values.len() * 8);
        for v in values.iter() {
            mine.extend_from_slice(&v.to_le_bytes());
        }
        values.fill(0);
        for bytes in self.all_gather(&mine) {
            for (v, word) in values.iter_mut().zip(bytes.chunks_exact(8)) {
                let mut w = [0u8; 8];
                w.copy_from_slice(word);
                *v += u64::from_le_bytes(w);
            }
        }
    }
}

/// Ranks as threads of one process: a [`Transport`] for tests and for checking the
/// decomposition without an MPI installation.
#[derive(Debug)]
pub struct ThreadTransport {
    rank: usize,
    size: usize,
    shared: Arc<Shared>,
}

#[derive(Debug)]
struct Shared {
    barrier: Barrier,
    /// `mailbox[from * size + to]`.
    mailbox: Mutex<Vec<Vec<u8>>>,
}

impl ThreadTransport {
    /// One transport per rank of a group of `size` (>= 1); hand each to its own thread.
    pub fn group(size: usize) -> Vec<ThreadTransport> {
        let size = size.max(1);
        let shared = Arc::new(Shared {
            barrier: Barrier::new(size),
            mailbox: Mutex::new(vec![Vec::new(); size * size]),
        });
        (0..size)
            .map(|rank| ThreadTransport {
                rank,
                size,
                shared: Arc::clone(&shared),
            })
            .collect()
    }

    fn post_and_collect(&self, post: impl FnOnce(&mut [Vec<u8>]), from_each: bool) -> Vec<Vec<u8>> {
        {
            let mut mailbox = self
                .shared
                .mailbox
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            post(&mut mailbox);
        }
        self.shared.barrier.wait();
        let received = {
            let mailbox = self
                .shared
                .mailbox
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            (0..self.size)
                .map(|from| {
                    let to = if from_each { self.rank } else { 0 };
                    mailbox[from * self.size + to].clone()
                })
                .collect()
        };
        // Nobody posts the next message before everyone has read this one.
        self.shared.barrier.wait();
        received
    }
}

impl Transport for ThreadTransport {
    fn rank(&self) -> usize {
        self.rank
    }
    fn size(&self) -> usize {
        self.size
    }
    fn all_gather(&mut self, mine: &[u8]) -> Vec<Vec<u8>> {
        let at = self.rank * self.size;
        self.post_and_collect(|m| m[at] = mine.to_vec(), false)
    }
    fn all_to_all(&mut self, outgoing: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
        assert_eq!(outgoing.len(), self.size, "one message per rank");
        let at = self.rank * self.size;
        self.post_and_collect(
            |m| {
                for (to, bytes) in outgoing.into_iter().enumerate() {
                    m[at + to] = bytes;
                }
            },
            true,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn threads_gather_and_exchange() {
        let handles: Vec<_> = ThreadTransport::group(3)
            .into_iter()
            .map(|mut t| {
                std::thread::spawn(move || {
                    let r = t.rank() as u8;
                    let all = t.all_gather(&[r, r]);
                    let out = (0..3).map(|to| vec![r * 10 + to as u8]).collect();
                    let got = t.all_to_all(out);
                    (all, got)
                })
            })
            .collect();
        for (rank, h) in handles.into_iter().enumerate() {
            let (all, got) = h.join().unwrap();
            assert_eq!(all, vec![vec![0, 0], vec![1, 1], vec![2, 2]]);
            let want: Vec<Vec<u8>> = (0..3).map(|from| vec![from * 10 + rank as u8]).collect();
            assert_eq!(got, want);
        }
    }
}
