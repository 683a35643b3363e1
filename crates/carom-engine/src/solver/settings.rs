//! The solver's settings and tolerances, and how far a particle reaches in a step.

use crate::plane::Plane;
use crate::vector::Vector;

/// With the lecture's rule alone, the position phase leaves overlapping pairs this fraction of
/// the smaller radius deep, so a contact is still detected (`distance < r1 + r2`) on the next
/// step instead of dropping out. When contacts can rest, pairs within this fraction of
/// touching are contacts that may not close in (see `Row::place`). (Box2D's "linear slop"
/// plays the same role.)
pub const SLOP_FRACTION: f64 = 1e-3;

/// Approaches slower than this fraction of the particles' speeds are rounding residue, not
/// approaches: after a `k = 0` response the relative normal speed is zero only up to rounding.
pub(super) const APPROACH_TOLERANCE: f64 = 1e-12;

/// The velocity phase of resting contacts ends when no contact misses its goal (approaching
/// when it should not, or pushing while separating) by more than this fraction of the resting
/// speed. At the default resting speed `2 |g| dt` a contact then sinks by at most
/// `0.002 |g| dt^2` a step (`5e-6` of a radius-1 disc at dt = 1/60 and g = 9.81), which the
/// position phase takes back. The misses add up along a chain of contacts: a looser tolerance
/// (1e-2 was tried) leaves a 100-disc column with a velocity ramp of `g dt` at its top.
pub const RESIDUAL_FRACTION: f64 = 1e-3;

/// How far a particle of radius `r` moving at `speed` reaches in a step of `dt`: its contact
/// candidates this step are the pairs and planes within reach. The move, up to one radius, is
/// covered, so an overlap it creates is pushed apart within the step; the slop keeps a particle
/// resting on a plane a candidate.
#[inline]
pub(crate) fn reach(radius: f64, speed: f64, dt: f64) -> f64 {
    // (speed: what the particle has plus what gravity adds this step)
    radius + SLOP_FRACTION * radius + (speed * dt).min(radius)
}

/// Raises `reach[i]` (see [`reach`]) to what particle `i` would reach at the speed of each of
/// its candidates `(i, j)` in `pairs` (`speed(j)`, length / time; gravity's `fall` added), and
/// `reach[j]` likewise; returns whether any reach grew. Only for the particles `own` says are
/// this caller's (all of them in a world; a rank's own in a split run).
///
/// Why: a particle's reach covers its own move, but a faster neighbour can push it: a disc at
/// 1.3 struck by two at 15-16 moved at 17.7 into a disc that was no candidate of it, and the
/// pair was left 6.7 % of r deep (lecture pile, seed 1, step 274). A push in a collision leaves
/// a particle at most about as fast as the one that struck it, so the contacts found with the
/// raised reaches cover what the first search's partners can do to it within the step. Over
/// 47 seeds of the lecture pile the deepest overlap of any state went from 8.4-28.1 % of r
/// (median 17.4) to 1.3-5.7 % (median 2.0). `reach(r, s)` grows with `s`, so the largest of a
/// particle's raised reaches is the reach at its fastest partner's speed, in any order.
pub(crate) fn raise_to_partners(
    reach: &mut [f64],
    radius: &[f64],
    pairs: &[(u32, u32)],
    speed: impl Fn(usize) -> f64,
    own: impl Fn(usize) -> bool,
    fall: f64,
    dt: f64,
) -> bool {
    let radius_at = |i: usize, partner_speed: f64| self::reach(radius[i], partner_speed + fall, dt);
    crate::broadphase::raise_to_partners(reach, pairs, speed, radius_at, own)
}

/// True when contacts can rest (see [`SolverSettings::lecture_only`]): then a particle's reach
/// is raised to its partners' (see [`raise_to_partners`]). In the lecture's step, a pair a
/// push drives together is found overlapping on the next step, as the lecture's detection
/// does, and the search runs once.
pub(crate) fn reach_covers_pushes<V: Vector>(
    settings: &SolverSettings,
    planes: &[Plane<V>],
) -> bool {
    let elastic = planes.iter().all(|p| p.restitution() >= 1.0);
    !settings.lecture_only(elastic)
}

/// How close a particle of radius `radius` and step reach `reach` (see [`reach`]; raised to
/// its partners' speeds when contacts can rest, see [`raise_to_partners`]) must come to a
/// plane to be its candidate this step: one radius beyond its reach. A neighbour can push a
/// particle faster than either reach says: in the lecture pile (seed 25, step 160) a disc
/// moving at 26.7 struck one resting 0.1 r from the right wall and drove it into the wall at
/// 19.5; the wall was not its candidate, and the pair was left 7.9 % of r deep between the
/// wall and the striker. A push moves a particle less than a radius a step unless the two
/// pass through each other, so one radius more covers it. (Candidates beyond their gap cost
/// one speculative row each, which the sweeps pass over; only particles near a plane have
/// them.) When planes bounce in the move (see [`SolverSettings::planes_in_move`]), the same
/// margin lets the position phase pay for every lift out of a plane from the candidate's
/// speed (see [`keep_energy`](super::bounces::keep_energy)).
#[inline]
pub(crate) fn plane_reach(reach: f64, radius: f64) -> f64 {
    reach + radius
}

/// The position sweeps stop when no overlap beyond the slop is deeper than this fraction of
/// the smaller radius.
pub(super) const POSITION_TOLERANCE: f64 = 1e-6;

/// Relative rounding a dead band always covers: a change smaller than this fraction of the
/// values it is made to is rounding, not a change.
pub(super) const DEAD_BAND_ROUNDING: f64 = 1e-12;

/// Rows per parallel task when preparing contacts.
pub(super) const ROW_CHUNK: usize = 4096;

/// Particles per parallel task when applying gravity and moving.
pub(super) const PARTICLE_CHUNK: usize = 8192;

/// The solver's settings for one step (from [`crate::WorldConfig`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverSettings {
    /// Particle-particle restitution `k` in [0, 1].
    pub restitution: f64,
    /// Approaches slower than this (length / time) rest instead of bouncing when `k < 1`.
    pub resting_speed: f64,
    /// Cap on velocity sweeps, >= 1.
    pub velocity_iterations: u32,
    /// Cap on position sweeps (0: no position correction).
    pub position_iterations: u32,
    /// Substeps per step when contacts can rest (see the module notes), >= 1.
    pub substeps: u32,
}

impl SolverSettings {
    /// True when every contact takes the lecture's response alone: no gravity to rest against
    /// (resting speed 0), or `k = 1` everywhere.
    pub(crate) fn lecture_only(&self, planes_elastic: bool) -> bool {
        self.resting_speed <= 0.0 || (self.restitution >= 1.0 && planes_elastic)
    }

    /// True when plane contacts bounce at their time of impact within the move (see
    /// [`bounce_in_move`](super::bounces::bounce_in_move)) and the position phase keeps energy (see [`keep_energy`](super::bounces::keep_energy)): the
    /// lecture's step, under gravity, with every plane elastic.
    pub(crate) fn planes_in_move<V: Vector>(&self, planes: &[Plane<V>], gravity: V) -> bool {
        let elastic_planes = planes.iter().all(|p| p.restitution() >= 1.0);
        !planes.is_empty() && gravity != V::ZERO && elastic_planes && self.lecture_only(true)
    }

    /// True when every pair takes the lecture's response (`k = 1`, or nothing to rest against).
    pub(super) fn lecture_pairs(&self) -> bool {
        self.restitution >= 1.0 || self.resting_speed <= 0.0
    }
}

/// What the velocity phase did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VelocitySolve {
    /// Sweeps made (1 when nothing was approaching).
    pub iterations: u32,
    /// Rule applications that changed something (impacts and resting impulses).
    pub responses: u64,
    /// True when the last sweep still changed something (the cap was hit).
    pub capped: bool,
    /// Wall-clock time spent on gravity, the moves and re-placing rows (see
    /// [`crate::PhaseTimes::motion`]); the rest of the phase is the sweeps'.
    pub motion: std::time::Duration,
}
