//! Errors from building a world. Stepping never fails.

use thiserror::Error;

/// Why a world, plane or particle could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum EngineError {
    /// A NaN or infinite number in the named quantity.
    #[error("{0} must be finite (no NaN or infinity)")]
    NonFinite(&'static str),
    /// Radius must be > 0.
    #[error("particle {index}: radius must be > 0, got {value}")]
    Radius {
        /// Particle id.
        index: usize,
        /// The rejected value.
        value: f64,
    },
    /// Mass must be > 0.
    #[error("particle {index}: mass must be > 0, got {value}")]
    Mass {
        /// Particle id.
        index: usize,
        /// The rejected value.
        value: f64,
    },
    /// A particle had a NaN or infinite component.
    #[error("particle {0}: position and velocity must be finite")]
    ParticleNotFinite(usize),
    /// Restitution outside [0, 1].
    #[error("restitution must be in [0, 1], got {0}")]
    Restitution(f64),
    /// The time step must be > 0 and finite.
    #[error("dt must be > 0, got {0}")]
    TimeStep(f64),
    /// A plane normal of zero length.
    #[error("plane normal must not be zero")]
    ZeroPlaneNormal,
    /// Zero substeps.
    #[error("substeps must be >= 1")]
    Substeps,
    /// A domain whose min is not below its max on every axis.
    #[error("domain min must be below max on every axis")]
    EmptyDomain,
    /// A grid with zero cells on some axis, or too many cells overall.
    #[error("grid cells must be >= 1 on every axis and at most {max} in total, got {cells:?}")]
    GridCells {
        /// The requested cells per axis.
        cells: Vec<u64>,
        /// The largest total allowed.
        max: u64,
    },
    /// A resume order that is not a permutation of the particle ids.
    #[error("storage order must list every particle id exactly once")]
    StorageOrder,
    /// Resumed contact impulses that cannot belong to this world.
    #[error(
        "contact impulses must name existing particles and planes, once each, with finite \
         values > 0"
    )]
    ContactImpulses,
    /// More particles than ids (u32) can name.
    #[error("too many particles: {0} (at most {max})", max = u32::MAX)]
    TooManyParticles(usize),
}
