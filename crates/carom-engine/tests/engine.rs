//! The engine's integration tests, one module per file (see `autotests` in Cargo.toml): the
//! physics against the lecture and theory, determinism, checkpoints, ranks as threads,
//! periodic boxes, piles, sleep, escapes and observables. `allocation.rs` runs alone.

mod support;

mod checkpoint_props;
mod cluster;
mod determinism;
mod escapes;
mod observables;
mod periodic;
mod physics;
mod piles;
mod properties;
mod rules;
mod sleep;
