//! Running one world across processes: domain decomposition with ghost particles.
//!
//! Each process (a *rank*) owns a run of whole solver blocks, that is a run of storage slots,
//! and the world keeps its slots sorted along space, so a rank owns a slab of the domain (rows
//! in 2D, layers in 3D) holding the same number of particles as every other rank. The sort,
//! every [`crate::world::REORDER_INTERVAL`] steps, is what rebalances: particles that crossed a
//! border migrate to their new owner then. Every step a rank
//!
//! 1. integrates its own particles;
//! 2. borrows the first block of the next rank (the *halo*: the contacts that straddle the
//!    border belong to the lower block's rank) and receives *ghosts*, the particles of other
//!    ranks within interaction range of its own;
//! 3. finds its contacts (the broad phase over own, halo and ghost particles);
//! 4. runs the solver's sweeps in the very order one process would (see [`crate::solver`]):
//!    the halo goes back and forth around the block pairs that touch it, the few *leftover*
//!    contacts (reaching past the next block) run on every rank in their global order, and
//!    the counts that stop each phase are added up over all ranks. (The shock sweep, which
//!    runs the blocks one after another, runs rank after rank: see `Exchange::in_order`.)
//!
//! So the result is bit-identical to [`crate::World`] for any number of ranks (and threads).
//! The message passing is behind [`Transport`]: [`ThreadTransport`] runs ranks as threads of
//! one process (tests, and a check of the algorithm without MPI); the `carom` command line
//! implements it over MPI.

mod lender;
mod partition;
mod sleepers;
mod subdomain;
mod traffic;
mod transport;
mod wire;

pub use partition::Partition;
pub use subdomain::Subdomain;
pub use traffic::{Traffic, TrafficKind};
pub use transport::{ThreadTransport, Transport};
