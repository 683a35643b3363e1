//! `carom run` over several processes: the world split into slabs between ranks (see
//! [`carom_engine::cluster`]), outputs gathered on rank 0 and written by the same code as a
//! single process.

#[cfg(feature = "mpi")]
pub mod mpi;
mod split;

pub use split::Split;
