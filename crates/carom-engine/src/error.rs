//! Errors from building a world. Stepping never fails.

use thiserror::Error;

/// Why a world, plane or particle could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum EngineError {
    /// A NaN or infinite number in the named quantity.
    #[error("{0} must be finite (no NaN or infinity)")]
    NonFinite(&'static str),
    /// Radius must be > 0.
    #[error("particle {index}: radius must be > 0, got {value:?}")]
    Radius {
        /// Particle id.
        index: usize,
        /// The rejected value.
        value: f64,
    },
    /// Mass must be > 0.
    #[error("particle {index}: mass must be > 0, got {value:?}")]
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
    #[error("restitution must be in [0, 1], got {0:?}")]
    Restitution(f64),
    /// The time step must be > 0 and finite.
    #[error("dt must be > 0, got {0:?}")]
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
    /// Periodic flags whose count is not the number of dimensions.
    #[error("periodic needs one flag per axis ({dimensions}), got {got}")]
    PeriodicAxes {
        /// Flags given.
        got: usize,
        /// Axes of the world.
        dimensions: usize,
    },
    /// Periodic axes need a domain to glue.
    #[error("periodic axes need a domain (its faces are what is glued together)")]
    PeriodicWithoutDomain,
    /// A periodic axis too short for the largest particle (see
    /// [`crate::periodic::shortest_period`]).
    #[error(
        "periodic axis {axis} is {length} long, but must be longer than {shortest} (4 (2 + \
         slop) times the largest radius: twice the farthest a pair reaches in a step, so that \
         only one image of a particle can touch another)"
    )]
    PeriodTooShort {
        /// The axis (0 = x).
        axis: usize,
        /// Its length.
        length: f64,
        /// The shortest allowed.
        shortest: f64,
    },
    /// The unbounded hash has no domain to wrap around.
    #[error(
        "the unbounded hash broad phase does not support periodic axes: use the grid (or \
         brute force)"
    )]
    PeriodicHash,
    /// Split runs do not support periodic axes.
    #[error(
        "a run split over ranks does not support periodic axes: run it in one process \
         (without --ranks or mpirun)"
    )]
    PeriodicSplit,
    /// More particles than ids (u32) can name.
    #[error("too many particles: {0} (at most {max})", max = u32::MAX)]
    TooManyParticles(usize),
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A value out of range is shown as written (`1e300`), not as hundreds of digits.
    #[test]
    fn values_are_shown_short() {
        let shown = [
            EngineError::Restitution(1e300).to_string(),
            EngineError::TimeStep(-1e-300).to_string(),
        ];
        assert!(shown[0].ends_with("got 1e300"), "{}", shown[0]);
        assert!(shown[1].ends_with("got -1e-300"), "{}", shown[1]);
    }
}
