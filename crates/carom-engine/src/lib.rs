//! # carom-engine
//!
//! A particle collision engine that implements the lecture "Collision Detection and Response"
//! exactly, in 2D and 3D, with no I/O: data in, data out.
//!
//! Where each idea of the lecture lives:
//!
//! | lecture | module |
//! |---|---|
//! | detection `distance < r1 + r2`, normal/tangent split, mass-weighted response with restitution, the trap rule `p_rel . v_rel < 0` | [`response`] |
//! | particle-plane rule `(x - p) . n < r && n . v < 0`, `V' = V_T - k V_N` | [`plane`] |
//! | the hash grid (normalise, scale, clamp, floor; buckets; neighbour cells) | [`grid`] |
//! | the buckets themselves: cell lists by a counting sort | [`bucket`] |
//! | brute force, O(n^2) | [`brute`] |
//! | the grid without a box: an unbounded spatial hash (Teschner et al. 2003) | [`hash`] |
//! | many simultaneous contacts: impacts, resting impulses, pushing trapped particles apart | [`solver`] |
//! | resting impulses remembered between steps (warm starting) | [`memory`] |
//! | particles at rest fall asleep, part of a pile at a time | [`sleep`] |
//! | temperature, collision count, virial pressure | [`observe`] |
//! | what kinetic theory says they should be (Enskog, Henderson, Carnahan-Starling, Haff) | [`theory`] |
//! | the fixed order of contacts on threads and processes | [`schedule`] |
//! | one step, as the lecture's `ParticleSystem_Movement()` | [`step`] |
//! | periodic boundaries: wrapping, the minimum image | [`periodic`] |
//! | the particle system stepped in time under gravity | [`world`] |
//! | the same world split over processes (domain decomposition, ghosts) | [`cluster`] |
//!
//! ```
//! use carom_engine::{World, glam::DVec2};
//!
//! // The lecture's example #2: m2 = 2 m1, moving at each other.
//! let n = DVec2::new(3f64.sqrt() / 2.0, -0.5);
//! let mut world = World::builder()
//!     .dt(1e-9)
//!     .particle(DVec2::ZERO, DVec2::new(20.0, 0.0), 1.0, 1.0)
//!     .particle(n * 1.9, DVec2::new(-10.0, 0.0), 1.0, 2.0)
//!     .build()
//!     .unwrap();
//! let momentum = world.momentum();
//! world.step();
//! assert!((world.momentum() - momentum).length() < 1e-9);
//! ```
#![warn(missing_docs)]

pub mod broadphase;
pub mod brute;
pub mod bucket;
pub mod cluster;
pub mod diagnostics;
pub mod domain;
pub mod error;
mod frontier;
pub mod grid;
pub mod hash;
pub mod memory;
pub mod observe;
pub mod particles;
pub mod periodic;
pub mod plane;
pub mod response;
pub mod schedule;
pub mod sleep;
pub mod solver;
pub mod step;
#[cfg(test)]
mod testing;
pub mod theory;
pub mod timing;
pub mod vector;
pub mod world;

pub use broadphase::{BroadPhase, BroadPhaseKind, CellScratch, Pair, Raising, Still};
pub use diagnostics::StepStats;
pub use domain::Aabb;
pub use error::EngineError;
pub use glam;
pub use memory::ContactImpulses;
pub use observe::{Observables, Tally};
pub use particles::Particles;
pub use periodic::Periodic;
pub use plane::Plane;
pub use sleep::SleepSettings;
pub use solver::SolverSettings;
pub use timing::PhaseTimes;
pub use vector::Vector;
pub use world::{Snapshot, World, WorldBuilder, WorldConfig};
