//! [`Transport`] over MPI, through the `mpi` crate (rsmpi): each collective of the
//! decomposition is one MPI collective (`MPI_Allgatherv`, `MPI_Alltoallv`, after an
//! `MPI_Allgather`/`MPI_Alltoall` of the byte counts).

use carom_engine::cluster::Transport;
use mpi::collective::SystemOperation;
use mpi::datatype::{Partition, PartitionMut};
use mpi::environment::{Threading, Universe};
use mpi::topology::{Communicator, SimpleCommunicator};
use mpi::traits::*;
use mpi::Count;
use std::sync::{Mutex, PoisonError};

/// MPI's environment for the whole process: set up by [`start`], torn down by [`stop`].
static UNIVERSE: Mutex<Option<Universe>> = Mutex::new(None);

/// Initialises MPI (a world of one rank when not started by `mpirun`). Call once, first.
pub fn start() {
    // Serialized: the step loop runs on a rayon pool thread (see `Split::run_loop`), one MPI
    // call at a time.
    if let Some((universe, _)) = mpi::initialize_with_threading(Threading::Serialized) {
        *UNIVERSE.lock().unwrap_or_else(PoisonError::into_inner) = Some(universe);
    }
}

/// Finalises MPI (every rank must, or `mpirun` reports the job as failed). Call once, last.
pub fn stop() {
    drop(
        UNIVERSE
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take(),
    );
}

/// A handle on `MPI_COMM_WORLD`.
pub struct Mpi {
    world: SimpleCommunicator,
}

impl Mpi {
    /// The running MPI world, if [`start`] set one up.
    pub fn current() -> Option<Self> {
        let universe = UNIVERSE.lock().unwrap_or_else(PoisonError::into_inner);
        universe.as_ref().map(|u| Self { world: u.world() })
    }

    /// A transport over every rank.
    pub fn transport(&self) -> MpiTransport {
        MpiTransport {
            world: self.world.duplicate(),
        }
    }

    /// This process's rank.
    pub fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    /// Number of ranks.
    pub fn size(&self) -> usize {
        self.world.size() as usize
    }

    /// Ends every rank of the job with `status`: after a failure on one rank that the others,
    /// waiting in a collective, cannot see.
    pub fn abort(&self, status: i32) -> ! {
        self.world.abort(status)
    }
}

/// Refuses a split run whose state, gathered on rank 0 for output in one `MPI_Alltoallv`,
/// would pass the 2 GiB that MPI's `int` counts and offsets can address.
pub fn check_gather_size(particles: usize, dimensions: usize) -> Result<(), String> {
    // id, position, velocity, radius, mass
    let record = 4 + 2 * 8 * dimensions + 16;
    let most = Count::MAX as usize / record;
    if particles > most {
        return Err(format!(
            "{particles} particles: a split run gathers the whole state on rank 0 in one MPI \
             message, which holds at most {most} particles in {dimensions}D; run it without mpirun"
        ));
    }
    Ok(())
}

/// [`Transport`] over `MPI_COMM_WORLD`.
pub struct MpiTransport {
    world: SimpleCommunicator,
}

// SAFETY: MPI runs at MPI_THREAD_SERIALIZED (see `start`), which allows calls from any thread
// as long as no two overlap. A transport has one owner, which moves it to the thread that runs
// the step loop and calls it from there only; nothing else in the process calls MPI meanwhile.
unsafe impl Send for MpiTransport {}

fn displacements(counts: &[Count]) -> Vec<Count> {
    counts
        .iter()
        .scan(0, |at, &c| {
            let d = *at;
            *at += c;
            Some(d)
        })
        .collect()
}

fn split(buffer: &[u8], counts: &[Count]) -> Vec<Vec<u8>> {
    let mut at = 0usize;
    counts
        .iter()
        .map(|&c| {
            let part = buffer[at..at + c as usize].to_vec();
            at += c as usize;
            part
        })
        .collect()
}

/// A zeroed buffer of `len` bytes that owns real memory even when empty: MPI refuses a send
/// and a receive buffer at the same address, which two empty `Vec`s (both dangling) would be.
fn buffer(len: usize) -> Vec<u8> {
    let mut b = Vec::with_capacity(len.max(1));
    b.resize(len, 0);
    b
}

fn count(len: usize) -> Count {
    Count::try_from(len).expect("an MPI message above 2 GiB")
}

impl Transport for MpiTransport {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn all_gather(&mut self, mine: &[u8]) -> Vec<Vec<u8>> {
        let size = self.size();
        let mut counts = vec![0 as Count; size];
        self.world
            .all_gather_into(&count(mine.len()), &mut counts[..]);
        let displs = displacements(&counts);
        let total: usize = counts.iter().map(|&c| c as usize).sum();
        let mut received = buffer(total);
        let mut send = buffer(mine.len());
        send.copy_from_slice(mine);
        {
            let mut partition = PartitionMut::new(&mut received[..], &counts[..], &displs[..]);
            self.world
                .all_gather_varcount_into(&send[..], &mut partition);
        }
        split(&received, &counts)
    }

    fn all_sum(&mut self, values: &mut [u64]) {
        let mine = values.to_vec();
        self.world
            .all_reduce_into(&mine[..], values, SystemOperation::sum());
    }

    fn all_to_all(&mut self, outgoing: Vec<Vec<u8>>) -> Vec<Vec<u8>> {
        let send_counts: Vec<Count> = outgoing.iter().map(|m| count(m.len())).collect();
        let mut receive_counts = vec![0 as Count; self.size()];
        self.world
            .all_to_all_into(&send_counts[..], &mut receive_counts[..]);
        let mut send = buffer(send_counts.iter().map(|&c| c as usize).sum());
        let mut at = 0;
        for m in &outgoing {
            send[at..at + m.len()].copy_from_slice(m);
            at += m.len();
        }
        let send_displs = displacements(&send_counts);
        let receive_displs = displacements(&receive_counts);
        let total: usize = receive_counts.iter().map(|&c| c as usize).sum();
        let mut received = buffer(total);
        {
            let send_partition = Partition::new(&send[..], &send_counts[..], &send_displs[..]);
            let mut receive_partition =
                PartitionMut::new(&mut received[..], &receive_counts[..], &receive_displs[..]);
            self.world
                .all_to_all_varcount_into(&send_partition, &mut receive_partition);
        }
        split(&received, &receive_counts)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_state_past_2_gib_is_refused_with_the_limit() {
        assert!(super::check_gather_size(1_000_000, 3).is_ok());
        let e = super::check_gather_size(40_000_000, 3).unwrap_err();
        assert!(e.contains("at most 31580641 particles in 3D"), "{e}");
    }
}
