//! The solver's settings and tolerances, and how far a particle reaches in a step.

use crate::plane::Plane;
use crate::vector::Vector;
use wide::f64x4;

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

/// A particle's [`reach`] at velocity `v` with radius `radius`, gravity adding `fall` to its
/// speed this step (`|g| dt`), with its speed and its move over `dt` in radii (see
/// [`crate::StepStats::fastest_move`]): what a world and a rank of a split run work out for
/// each of their particles, the same way.
#[inline]
pub(crate) fn reach_at<V: Vector>(v: V, radius: f64, fall: f64, dt: f64) -> (f64, f64, f64) {
    let speed = v.length_squared().sqrt();
    (reach(radius, speed + fall, dt), speed, speed * dt / radius)
}

/// [`reach_at`] for each particle of a run (`velocity`, `radius`), into `reach` and, when
/// given, `speed`; returns the largest move in radii (0 when there is none). Four particles at
/// a time: a square root and a division a particle, one by one, took about 1.7 ms of a step of
/// 10^6 discs on 2 threads. The same bits as [`reach_at`]: each lane takes the same operations
/// in the same order (the square root and the division are correctly rounded either way, and
/// the lanes' `min` and `max` pass over a NaN as `f64`'s do; a property test holds them).
pub(crate) fn reaches_of<V: Vector>(
    (velocity, radius): (&[V], &[f64]),
    (fall, dt): (f64, f64),
    reach: &mut [f64],
    mut speed: Option<&mut [f64]>,
) -> f64 {
    const WIDTH: usize = 4;
    let whole = reach.len() - reach.len() % WIDTH;
    let (slop, fall_lanes, dt_lanes) = (
        f64x4::splat(SLOP_FRACTION),
        f64x4::splat(fall),
        f64x4::splat(dt),
    );
    let mut fastest = f64x4::splat(0.0);
    for k in (0..whole).step_by(WIDTH) {
        let along = |a: usize| f64x4::new(std::array::from_fn(|l| velocity[k + l].get(a)));
        let (vx, vy) = (along(0), along(1));
        let mut squared = vx * vx + vy * vy;
        if V::DIM == 3 {
            let vz = along(2);
            squared += vz * vz;
        }
        let s = squared.sqrt();
        let r = f64x4::new(std::array::from_fn(|l| radius[k + l]));
        let out = (r + slop * r) + ((s + fall_lanes) * dt_lanes).min(r);
        reach[k..k + WIDTH].copy_from_slice(&out.to_array());
        if let Some(speed) = speed.as_deref_mut() {
            speed[k..k + WIDTH].copy_from_slice(&s.to_array());
        }
        fastest = fastest.max(s * dt_lanes / r);
    }
    let mut largest = fastest.to_array().into_iter().fold(0.0, f64::max);
    for k in whole..reach.len() {
        let (s, moves);
        (reach[k], s, moves) = reach_at(velocity[k], radius[k], fall, dt);
        if let Some(speed) = speed.as_deref_mut() {
            speed[k] = s;
        }
        largest = largest.max(moves);
    }
    largest
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

/// True when contacts can rest (see [`SolverSettings::lecture_only`]), or when the scene asks
/// for it ([`SolverSettings::cover_pushes`]): then a particle's reach is raised to its
/// partners' (see [`raise_to_partners`]), every pair within reach is a candidate, and a step
/// whose pushes still outrun a reach is taken again (see `escape`). Otherwise, in the
/// lecture's step, a pair a push drives together is found overlapping on the next step, as the
/// lecture's detection does, and the search runs once. (The lecture's 5000-disc demo, `k = 1`
/// under gravity: covered, the deepest overlap at the end 24.0 % of r -> 0.13 %, of any state
/// 56.4 % -> 9.1 %, for 2.6x the time; see docs/benchmarks.md, twenty-ninth sitting.)
pub(crate) fn reach_covers_pushes<V: Vector>(
    settings: &SolverSettings,
    planes: &[Plane<V>],
) -> bool {
    let elastic = planes.iter().all(|p| p.restitution() >= 1.0);
    settings.cover_pushes || !settings.lecture_only(elastic)
}

/// Which candidates the lecture's step keeps (see [`reach_covers_pushes`]): the pairs that
/// [`close_in_lines`] and, when planes bounce in the move (see
/// [`SolverSettings::planes_in_move`]), every pair of a particle within a plane's candidate
/// distance (see [`plane_reach`]), whose path may turn at the plane within the step. A world
/// and a rank of a split run decide each pair through [`LectureCandidates::keeps`], so both
/// keep the same pairs.
///
/// There, a candidate that is neither touching nor closing in would only wait for the
/// position phase, which it never reaches. A 10^6-disc gas (area fraction 0.3, speed 7,
/// dt = 1/60) has 275,000 pairs within reach and 108,000 that close in: its rows, their
/// sweeps and its peak memory (149 bytes a particle, 118 with the test) were mostly the
/// others'. A pair that a push in the sweeps drives into contact is found overlapping on the
/// next step, as the lecture's detection finds it (and as it was before for a push that
/// outran a reach). (Not where contacts can rest: there a candidate's row also stops a pair
/// closing in faster than its gap allows, and pushes are everywhere. The same test with a
/// margin for the pushes, tried on the lecture pile, let the deepest overlap reach 10.2 % of
/// r against 2.2 %.)
#[derive(Clone, Copy, Debug)]
pub(crate) struct LectureCandidates<'a, V> {
    planes: &'a [Plane<V>],
    /// Planes bounce in the move.
    turns: bool,
    dt: f64,
}

impl<'a, V: Vector> LectureCandidates<'a, V> {
    /// The test for a step of `dt`, or `None` when reaches cover pushes (see
    /// [`reach_covers_pushes`]: every pair within reach is then a candidate, with its reach
    /// raised, see [`raise_to_partners`]).
    pub(crate) fn new(
        settings: &SolverSettings,
        planes: &'a [Plane<V>],
        gravity: V,
        dt: f64,
    ) -> Option<Self> {
        let turns = settings.planes_in_move(planes, gravity);
        (!reach_covers_pushes(settings, planes)).then_some(Self { planes, turns, dt })
    }

    /// True when the pair of particles at `x` (`dx = x_i - x_j` as the pair sees it, across
    /// periodic seams), moving at relative velocity `dv`, with radii `radius` and step reaches
    /// `reach`, stays a candidate.
    #[inline]
    pub(crate) fn keeps(&self, dx: V, dv: V, x: [V; 2], radius: [f64; 2], reach: [f64; 2]) -> bool {
        let may_turn = |k: usize| {
            let within = plane_reach(reach[k], radius[k]);
            (self.planes.iter()).any(|plane| plane.signed_distance(x[k]) < within)
        };
        close_in_lines(dx, dv, radius[0] + radius[1], self.dt)
            || (self.turns && (may_turn(0) || may_turn(1)))
    }
}

/// True when two particles `dx = x_i - x_j` apart, moving in straight lines at relative
/// velocity `dv = v_i - v_j`, are closer than `(r_i + r_j)(1 + SLOP_FRACTION)` (`sum_radii`
/// is `r_i + r_j`) at some time within `[0, dt]`: touching at the start, at the end, or
/// passing between. Gravity, the same for both, drops out of `dv`; the slop covers the
/// rounding. Exactly symmetric: swapping `i` and `j` negates `dx` and `dv`, which changes no
/// bit of any product, so both sides of a pair (and every rank) decide alike.
///
/// Every case is worked out and the results combined without a branch: which case holds is
/// unpredictable from pair to pair, and the branches took most of the test's time. (A test
/// holds this form to the one with a branch per case, on every kind of input.)
#[inline]
pub(crate) fn close_in_lines<V: Vector>(dx: V, dv: V, sum_radii: f64, dt: f64) -> bool {
    let contact = sum_radii * (1.0 + SLOP_FRACTION);
    let (start, limit) = (dx.length_squared(), contact * contact);
    // (`closing`: the closing speed times the distance; not closing, the distance only grows)
    let closing = -dx.dot(dv);
    let speed_squared = dv.length_squared();
    // (closest at the end of the step or later)
    let closest_at_end = closing >= speed_squared * dt;
    let end_within = (dx + dv * dt).length_squared() < limit;
    // (closest within the step: `start - closing^2 / speed_squared`, without the division)
    let passes_within = start * speed_squared - closing * closing < limit * speed_squared;
    let meets = (closest_at_end & end_within) | (!closest_at_end & passes_within);
    (start < limit) | ((closing > 0.0) & meets)
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
    /// The most times one step is taken again (see `escape`).
    pub retakes: u32,
    /// The lecture's step covers pushes as a step where contacts can rest always does (see
    /// [`crate::WorldConfig::cover_pushes`]).
    pub cover_pushes: bool,
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

#[cfg(test)]
mod tests {
    use super::close_in_lines;
    use super::SLOP_FRACTION;
    use super::{reach_at, reaches_of};
    use crate::vector::Vector;
    use glam::{DVec2, DVec3};

    /// [`reaches_of`] against [`reach_at`] particle by particle: reaches, speeds and the
    /// fastest move bit for bit.
    fn lanes_match_one_by_one<V: Vector>(velocity: &[V], radius: &[f64], fall: f64, dt: f64) {
        let n = velocity.len();
        let (mut reach, mut speed) = (vec![0.0; n], vec![0.0; n]);
        let fastest = reaches_of((velocity, radius), (fall, dt), &mut reach, Some(&mut speed));
        let mut expected = 0.0f64;
        for k in 0..n {
            let (r, s, moves) = reach_at(velocity[k], radius[k], fall, dt);
            assert_eq!(
                (reach[k].to_bits(), speed[k].to_bits()),
                (r.to_bits(), s.to_bits())
            );
            expected = expected.max(moves);
        }
        assert_eq!(fastest.to_bits(), expected.to_bits());
        let mut alone = vec![0.0; n];
        let without = reaches_of((velocity, radius), (fall, dt), &mut alone, None);
        assert_eq!((alone, without.to_bits()), (reach, fastest.to_bits()));
    }

    proptest::proptest! {
        #[test]
        fn reaches_four_at_a_time_are_reaches_one_at_a_time(
            particles in proptest::collection::vec(
                (proptest::array::uniform3(-1e3f64..1e3), 1e-3f64..10.0), 0..23),
            still in proptest::collection::vec(proptest::bool::ANY, 23),
            fall in proptest::sample::select(vec![0.0, 0.1635, 1e3]),
            dt in proptest::sample::select(vec![1.0 / 60.0, 1e-4, 0.5]),
        ) {
            // (some at rest: a speed of exactly zero)
            let at = |k: usize, v: [f64; 3]| if still[k] { [0.0; 3] } else { v };
            let radius: Vec<f64> = particles.iter().map(|p| p.1).collect();
            let flat: Vec<DVec2> = (particles.iter().enumerate())
                .map(|(k, p)| DVec2::from_slice(&at(k, p.0)))
                .collect();
            lanes_match_one_by_one(&flat, &radius, fall, dt);
            let solid: Vec<DVec3> = (particles.iter().enumerate())
                .map(|(k, p)| DVec3::from(at(k, p.0)))
                .collect();
            lanes_match_one_by_one(&solid, &radius, fall, dt);
        }
    }

    /// [`close_in_lines`] with a branch per case, as it was first written.
    fn close_in_lines_by_cases(dx: DVec2, dv: DVec2, sum_radii: f64, dt: f64) -> bool {
        let contact = sum_radii * (1.0 + SLOP_FRACTION);
        let (start, limit) = (dx.length_squared(), contact * contact);
        if start < limit {
            return true;
        }
        let closing = -dx.dot(dv);
        if closing <= 0.0 {
            return false;
        }
        let speed_squared = dv.length_squared();
        if closing >= speed_squared * dt {
            (dx + dv * dt).length_squared() < limit
        } else {
            start * speed_squared - closing * closing < limit * speed_squared
        }
    }

    /// The form without branches decides as the one with a branch per case, for random pairs
    /// and for zeros, infinities and NaN in every component.
    #[test]
    fn the_test_without_branches_decides_as_the_branches_do() {
        let mut next = crate::testing::uniform(11);
        let specials = [
            0.0,
            -0.0,
            1.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            1e-300,
        ];
        let mut pick = |scale: f64| {
            let u = next();
            if u < 0.2 {
                specials[((u * 35.0) as usize).min(specials.len() - 1)]
            } else {
                (next() * 2.0 - 1.0) * scale
            }
        };
        for _ in 0..200_000 {
            let dx = DVec2::new(pick(3.0), pick(3.0));
            let dv = DVec2::new(pick(30.0), pick(30.0));
            let (sum, dt) = (
                pick(2.0).abs(),
                [0.1, 1.0 / 60.0, 0.0][(pick(3.0).abs() as usize).min(2)],
            );
            assert_eq!(
                close_in_lines(dx, dv, sum, dt),
                close_in_lines_by_cases(dx, dv, sum, dt),
                "{dx} {dv} {sum} {dt}"
            );
        }
    }

    /// The straight-line test against the distance sampled along the step, for random pairs:
    /// never a miss (a pair sampled within contact is always kept), and it is symmetric.
    #[test]
    fn pairs_closing_in_lines_are_kept_and_only_they() {
        let mut next = crate::testing::uniform(7);
        let dt = 0.1;
        let (mut kept, mut dropped) = (0, 0);
        for _ in 0..20_000 {
            let dx = DVec2::new(next() * 6.0 - 3.0, next() * 6.0 - 3.0);
            let dv = DVec2::new(next() * 40.0 - 20.0, next() * 40.0 - 20.0);
            let sum = 1.0 + next();
            let keep = close_in_lines(dx, dv, sum, dt);
            assert_eq!(keep, close_in_lines(-dx, -dv, sum, dt), "symmetric");
            let closest = (0..=1000)
                .map(|k| (dx + dv * (dt * k as f64 / 1000.0)).length())
                .fold(f64::INFINITY, f64::min);
            if closest < sum {
                assert!(keep, "{dx} {dv} {sum}: closest {closest}");
            }
            if closest > sum * 1.01 {
                assert!(!keep, "{dx} {dv} {sum}: closest {closest}");
            }
            if keep {
                kept += 1;
            } else {
                dropped += 1;
            }
        }
        assert!(
            kept > 1000 && dropped > 1000,
            "{kept} kept, {dropped} dropped"
        );
    }

    #[test]
    fn touching_resting_and_parting_pairs() {
        let dt = 1.0 / 60.0;
        // (touching, and within the slop, whatever they do)
        assert!(close_in_lines(
            DVec2::new(1.9, 0.0),
            DVec2::new(5.0, 0.0),
            2.0,
            dt
        ));
        assert!(close_in_lines(DVec2::new(2.001, 0.0), DVec2::ZERO, 2.0, dt));
        // (apart and at rest, or parting)
        assert!(!close_in_lines(DVec2::new(2.01, 0.0), DVec2::ZERO, 2.0, dt));
        assert!(!close_in_lines(
            DVec2::new(2.01, 0.0),
            DVec2::new(1.0, 0.0),
            2.0,
            dt
        ));
        // (closing: in contact by the end of the step, or not yet)
        assert!(close_in_lines(
            DVec2::new(2.5, 0.0),
            DVec2::new(-31.0, 0.0),
            2.0,
            dt
        ));
        assert!(!close_in_lines(
            DVec2::new(2.5, 0.0),
            DVec2::new(-29.0, 0.0),
            2.0,
            dt
        ));
        // (passing through each other within the step, apart at both ends)
        assert!(close_in_lines(
            DVec2::new(3.0, 0.5),
            DVec2::new(-360.0, 0.0),
            2.0,
            dt
        ));
        // (passing by, sideways, too far out)
        assert!(!close_in_lines(
            DVec2::new(3.0, 2.5),
            DVec2::new(-360.0, 0.0),
            2.0,
            dt
        ));
    }
}
