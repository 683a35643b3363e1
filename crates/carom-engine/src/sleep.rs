//! Particles at rest fall asleep, as in Box2D and Rapier: a pile that has come to rest costs
//! (almost) nothing to step, and nothing in it jitters.
//!
//! Each particle keeps its *rest time*, how long (time units) it has moved less than
//! `sleep speed x dt` per step. Its displacement over the whole step counts, not its velocity:
//! a particle wedged in a pile whose velocity the position phase cancels every step is at
//! rest, however its velocity reads. A particle that has not rested the sleep time is
//! *restless*.
//!
//! At the start of every step, every particle more than [`WAKE_HOPS`] contact candidates
//! (pairs within reach of each other, see [`crate::world`]) away from any restless particle,
//! and held up by something (a plane facing up or a particle below it, within
//! [`SUPPORT_GAP`] of touching), is *asleep* for the step: its velocity is set to zero, and
//! gravity, the solver and the move skip it; its contacts with other sleepers keep their
//! remembered impulses for when it wakes. An awake particle meets a sleeping one as a fixed
//! obstacle (of infinite mass, like a plane), so what rests on a sleeping part of a pile is
//! held by it. Planes do not connect. So
//! whatever comes near a sleeping pile (a falling ball within reach of it) wakes the part of it
//! within reach, and that part falls asleep again once everything near it has rested for the
//! sleep time; an avalanche on one slope of a pile does not keep the rest of it awake.
//!
//! Box2D and Rapier put whole *islands* (connected sets of touching bodies) to sleep at once.
//! carom did too, until a pour of 10^5 frictionless spheres, one island, never slept: its
//! solver noise keeps a few of them moving somewhere at any time (measured: v_rms 0.05 at step
//! 6000 of a 10^5-sphere pour, 81 of 20,000 spheres faster than the sleep speed at step 3000
//! of a smaller one). Asleep part by part, the same pour is asleep whole from step 1017.
//!
//! An awake particle's rest time goes on counting; a sleeping one's stays as it was.
//! Everything here is a function of the state alone (positions, velocities and rest times, in
//! storage order), never of the thread count or the broad phase: each hop reads the marks of
//! the hop before.

use crate::broadphase::Pair;
use crate::vector::Vector;
use rayon::prelude::*;

/// Default sleep speed as a fraction of the resting speed (`2 |g| dt` by default): the resting
/// speed itself, 0.33 length units per time unit at g = 9.81 and dt = 1/60 (Box2D: 0.05 m/s,
/// but its discs have friction). Slower than that, the solver already treats an approach as
/// resting (no bounce). Frictionless discs need that much: a disc in a bowl of its neighbours
/// swings to and fro at up to ~0.25 for ever (nothing damps sliding). Measured on
/// `scenes/lecture_pile_60hz.toml` (at a498b7a, when resting pairs were moved apart to
/// touching): at a tenth of the resting speed the pile stayed awake to the end, at half of it
/// one such disc kept it awake until step 1398, at the resting speed it slept from step 1199
/// (the avalanches on its slopes ended near step 1150). Now it sleeps from step 1021.
pub const SLEEP_SPEED_FRACTION: f64 = 1.0;

/// Default time (time units) a particle and everything near it must rest before it sleeps
/// (Box2D's `b2_timeToSleep`).
pub const DEFAULT_SLEEP_TIME: f64 = 0.5;

/// How many candidate pairs away from a restless particle (one that has not rested the sleep
/// time) a particle stays awake. Everything further sleeps, and its awake neighbours meet it as
/// a fixed obstacle.
pub const WAKE_HOPS: usize = 2;

/// What holds each particle up, asked only when someone may sleep: a particle that nothing
/// holds up stays awake, so that one whose support drifted away while it slept falls back
/// onto it instead of sleeping in mid-air (its fall then wakes its neighbours).
pub(crate) struct Support<'a> {
    /// Whether slot `s` rests on a plane (see [`rests_on_plane`]).
    pub on_plane: &'a dyn Fn(usize) -> bool,
    /// For candidate pair `k`, whether each of its particles rests on the other (see
    /// [`rests_on`]).
    pub in_pair: &'a dyn Fn(usize) -> [bool; 2],
}

/// The unit vector against `gravity` (zero without gravity).
pub(crate) fn up<V: Vector>(gravity: V) -> V {
    let g = gravity.length_squared().sqrt();
    if g > 0.0 {
        gravity * (-1.0 / g)
    } else {
        V::ZERO
    }
}

/// How far apart (a fraction of the smaller radius) two particles, or a particle and a plane,
/// may be and still hold one up. A resting contact ends within the slop of touching on
/// either side: the position phase leaves overlaps the slop deep, and a gap may close down to
/// the slop and no further (see [`crate::solver::SLOP_FRACTION`]); twice that covers both,
/// and rounding.
pub const SUPPORT_GAP: f64 = 2.0 * crate::solver::SLOP_FRACTION;

/// Whether particles at `xi` and `xj` (radii `ri`, `rj`) rest on each other under gravity
/// pointing along `-up` (a unit vector; zero without gravity, when every particle counts as
/// held up): `[i on j, j on i]`. They must touch within [`SUPPORT_GAP`].
#[inline]
pub(crate) fn rests_on<V: Vector>(xi: V, xj: V, ri: f64, rj: f64, up: V) -> [bool; 2] {
    if up == V::ZERO {
        return [true, true];
    }
    let apart = ri + rj + SUPPORT_GAP * ri.min(rj);
    let d = xi - xj;
    if d.length_squared() >= apart * apart {
        return [false, false];
    }
    let height = d.dot(up);
    [height > 0.0, height < 0.0]
}

/// Whether a particle at `x` (radius `r`) rests on one of `planes` under gravity pointing
/// along `-up` (see [`rests_on`]): it touches a plane that faces up.
#[inline]
pub(crate) fn rests_on_plane<V: Vector>(
    x: V,
    r: f64,
    planes: &[crate::plane::Plane<V>],
    up: V,
) -> bool {
    up == V::ZERO
        || planes
            .iter()
            .any(|p| p.normal().dot(up) > 0.0 && p.signed_distance(x) < r + SUPPORT_GAP * r)
}

/// One hop: marks in `reached` both slots of every pair in `pairs` with either one `awake`.
/// A pair's `i` and `index(j)` are its places in `awake`; places past the end of `reached`
/// (another process's slots) are not marked.
pub(crate) fn spread(
    pairs: &[Pair],
    awake: &[bool],
    reached: &mut [bool],
    index: impl Fn(u32) -> usize,
) {
    for &(i, j) in pairs {
        let (i, j) = (i as usize, index(j));
        if awake[i] || awake[j] {
            reached[i] = true;
            if let Some(r) = reached.get_mut(j) {
                *r = true;
            }
        }
    }
}

/// Fills `held` (`places` long) with what `support` says holds each slot up: the `own`
/// first from their planes, and both slots of every pair (`i` and `index(j)`, as in
/// [`spread`]).
pub(crate) fn held_up(
    support: &Support<'_>,
    pairs: &[Pair],
    own: usize,
    places: usize,
    held: &mut Vec<bool>,
    index: impl Fn(u32) -> usize,
) {
    held.clear();
    held.extend((0..own).map(|s| (support.on_plane)(s)));
    held.resize(places, false);
    for (k, &(i, j)) in pairs.iter().enumerate() {
        let [i_held, j_held] = (support.in_pair)(k);
        held[i as usize] |= i_held;
        held[index(j)] |= j_held;
    }
}

/// Marks `asleep` every slot neither `awake` nor unheld (see [`Support`]), and returns how
/// many.
pub(crate) fn put_to_sleep(asleep: &mut [bool], awake: &[bool], held: &[bool]) -> usize {
    let mut count = 0;
    for ((asleep, &awake), &held) in asleep.iter_mut().zip(awake).zip(held) {
        *asleep = !awake && held;
        count += *asleep as usize;
    }
    count
}

/// Particles per parallel task when updating rest times.
const CHUNK: usize = 8192;

/// When particles may sleep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SleepSettings {
    /// A particle that moves less than `speed x dt` in a step rests for that step
    /// (length / time, > 0).
    pub speed: f64,
    /// A particle sleeps once every particle within [`WAKE_HOPS`] candidate pairs of it has
    /// rested this long (time, > 0).
    pub time: f64,
}

/// Which slots sleep through one step.
#[derive(Debug, Default)]
pub(crate) struct Sleepers {
    /// Per slot: within reach of a restless slot after the hops so far (scratch).
    awake: Vec<bool>,
    /// The next hop's marks (scratch).
    reached: Vec<bool>,
    /// Per slot: something holds it up (scratch; see [`Support`]).
    held: Vec<bool>,
    /// Per slot: asleep this step.
    pub asleep: Vec<bool>,
    /// How many slots are asleep this step.
    pub count: usize,
}

impl Sleepers {
    /// Finds this step's sleeping slots: every slot more than [`WAKE_HOPS`] candidate pairs
    /// (`pairs`, slots `i < j`) away from any slot whose `rest` is under `time`. Returns how
    /// many sleep.
    pub fn mark(
        &mut self,
        pairs: &[Pair],
        rest: &[f64],
        time: f64,
        support: &Support<'_>,
    ) -> usize {
        let n = rest.len();
        self.asleep.clear();
        self.asleep.resize(n, false);
        self.count = 0;
        // Nobody has rested long enough: nobody sleeps, and nothing needs spreading.
        if !rest.iter().any(|&t| t >= time) {
            return 0;
        }
        self.awake.clear();
        self.awake.extend(rest.iter().map(|&t| t < time));
        // (`awake` and `reached` take turns: each hop reads the last one's marks alone, so the
        // result does not depend on the order of the pairs)
        for _ in 0..WAKE_HOPS {
            self.reached.clear();
            self.reached.extend_from_slice(&self.awake);
            spread(pairs, &self.awake, &mut self.reached, |j| j as usize);
            std::mem::swap(&mut self.awake, &mut self.reached);
        }
        held_up(support, pairs, n, n, &mut self.held, |j| j as usize);
        self.count = put_to_sleep(&mut self.asleep, &self.awake, &self.held);
        self.count
    }

    /// True when `slot` sleeps this step.
    #[inline]
    pub fn sleeps(&self, slot: usize) -> bool {
        self.count > 0 && self.asleep[slot]
    }

    /// Per slot, whether it sleeps this step; empty when none does (what the solver takes).
    pub fn flags(&self) -> &[bool] {
        if self.count > 0 {
            &self.asleep
        } else {
            &[]
        }
    }

    /// Nobody sleeps (a parameter changed, or sleeping is off).
    pub fn wake_all(&mut self) {
        self.asleep.clear();
        self.count = 0;
    }
}

/// After a step of `dt` that took each awake slot from `before` to `after`: a slot that moved
/// less than `settings.speed x dt` rests `dt` longer, any other starts again from zero; a
/// sleeping slot (`asleep`, empty when none) keeps its rest time.
pub(crate) fn update_rest<V: Vector>(
    parallel: bool,
    before: &[V],
    after: &[V],
    asleep: &[bool],
    rest: &mut [f64],
    settings: &SleepSettings,
    dt: f64,
) {
    let still = settings.speed * dt;
    let still_squared = still * still;
    let chunk = |(c, rest): (usize, &mut [f64])| {
        let start = c * CHUNK;
        for (k, t) in rest.iter_mut().enumerate() {
            let s = start + k;
            if !asleep.is_empty() && asleep[s] {
                continue;
            }
            let moved = (after[s] - before[s]).length_squared();
            *t = if moved < still_squared { *t + dt } else { 0.0 };
        }
    };
    if parallel {
        rest.par_chunks_mut(CHUNK).enumerate().for_each(chunk);
    } else {
        rest.chunks_mut(CHUNK).enumerate().for_each(chunk);
    }
}

/// True when every particle has rested at least `time` and stands exactly still (its
/// velocity zero): the next step finds them all asleep.
pub(crate) fn all_still<V: Vector>(rest: &[f64], velocity: &[V], time: f64) -> bool {
    rest.iter().all(|&t| t >= time) && velocity.iter().all(|&v| v == V::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    #[test]
    fn a_particle_sleeps_only_beyond_the_wake_hops_of_every_restless_one() {
        assert_eq!(WAKE_HOPS, 2);
        let mut sleepers = Sleepers::default();
        let held = Support {
            on_plane: &|_| true,
            in_pair: &|_| [false, false],
        };
        // a chain 0-1-2-3-4-5 with 0 restless; 6 alone
        let pairs = [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5)];
        let rest = [0.2, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        assert_eq!(sleepers.mark(&pairs, &rest, 0.5, &held), 4);
        assert_eq!(
            sleepers.asleep,
            [false, false, false, true, true, true, true]
        );
        // the same marks whatever the order of the pairs
        let reversed = [(4, 5), (3, 4), (2, 3), (1, 2), (0, 1)];
        let mut again = Sleepers::default();
        again.mark(&reversed, &rest, 0.5, &held);
        assert_eq!(again.asleep, sleepers.asleep);
        // everything at rest: everything sleeps
        assert_eq!(sleepers.mark(&pairs, &[1.0; 7], 0.5, &held), 7);
        // 6 held up by nothing, 5 resting on 4: 6 stays awake
        let held = Support {
            on_plane: &|s| s < 6,
            in_pair: &|k| [false, k == 4],
        };
        sleepers.mark(&pairs, &[1.0; 7], 0.5, &held);
        assert_eq!(sleepers.asleep, [true, true, true, true, true, true, false]);
        let alone = Support {
            on_plane: &|s| s != 5,
            in_pair: &|_| [false, false],
        };
        sleepers.mark(&pairs, &[1.0; 7], 0.5, &alone);
        assert!(!sleepers.sleeps(5), "5 rests on nothing");
    }

    #[test]
    fn particles_rest_on_what_touches_them_from_below() {
        let up = DVec2::Y;
        let (a, b) = (DVec2::ZERO, DVec2::new(0.6, 1.9));
        assert_eq!(rests_on(b, a, 1.0, 1.0, up), [true, false]);
        assert_eq!(rests_on(a, b, 1.0, 1.0, up), [false, true]);
        // a gap of 1 % of r: nothing rests
        let c = DVec2::new(0.0, 2.01);
        assert_eq!(rests_on(c, a, 1.0, 1.0, up), [false, false]);
        // without gravity everything is held
        assert_eq!(rests_on(c, a, 1.0, 1.0, DVec2::ZERO), [true, true]);
        let floor = crate::plane::Plane::new(DVec2::ZERO, up, 0.5).unwrap();
        assert!(rests_on_plane(DVec2::new(3.0, 1.0), 1.0, &[floor], up));
        assert!(!rests_on_plane(DVec2::new(3.0, 1.02), 1.0, &[floor], up));
        let wall = crate::plane::Plane::new(DVec2::ZERO, DVec2::X, 0.5).unwrap();
        assert!(!rests_on_plane(DVec2::new(1.0, 5.0), 1.0, &[wall], up));
    }

    #[test]
    fn nobody_sleeps_before_the_sleep_time() {
        let mut sleepers = Sleepers::default();
        let held = Support {
            on_plane: &|_| true,
            in_pair: &|_| [true, true],
        };
        assert_eq!(sleepers.mark(&[(0, 1)], &[0.4, 0.49], 0.5, &held), 0);
        assert!(!sleepers.sleeps(0));
    }

    #[test]
    fn rest_time_counts_small_moves_and_restarts_on_a_large_one() {
        let settings = SleepSettings {
            speed: 1.0,
            time: 0.5,
        };
        let before = [DVec2::ZERO, DVec2::ZERO, DVec2::ZERO];
        let after = [DVec2::new(0.05, 0.0), DVec2::new(0.2, 0.0), DVec2::ZERO];
        let mut rest = [0.3, 0.3, 0.3];
        update_rest(
            false,
            &before,
            &after,
            &[false, false, true],
            &mut rest,
            &settings,
            0.1,
        );
        assert_eq!(rest, [0.3 + 0.1, 0.0, 0.3]);
    }

    #[test]
    fn all_still_needs_every_rest_time_and_zero_velocities() {
        let still = [DVec2::ZERO, DVec2::new(-0.0, 0.0)];
        assert!(all_still(&[0.5, 0.7], &still, 0.5));
        assert!(!all_still(&[0.5, 0.49], &still, 0.5));
        assert!(!all_still(
            &[0.5, 0.5],
            &[DVec2::ZERO, DVec2::new(0.0, -1e-300)],
            0.5
        ));
        assert!(!all_still(
            &[0.5, 0.5],
            &[DVec2::new(1e-300, 0.0), DVec2::ZERO],
            0.5
        ));
    }
}
