//! Islands at rest fall asleep, as in Box2D and Rapier: a pile that has come to rest costs
//! (almost) nothing to step, and nothing in it jitters.
//!
//! An *island* is a set of particles connected through this step's contact candidates (pairs
//! within reach of each other, see [`crate::world`]). Planes do not connect: a floor carries
//! many islands. Each particle keeps its *rest time*, how long (time units) it has moved less
//! than `sleep speed x dt` per step. Its displacement over the whole step counts, not its
//! velocity: a particle wedged in a pile whose velocity the position phase cancels every step is
//! at rest, however its velocity reads.
//!
//! At the start of every step, an island all of whose particles have rested for at least the
//! sleep time is *asleep* for the step: its velocities are set to zero, and gravity, the
//! solver and the move skip it (its contacts keep their remembered impulses for when it wakes).
//! An island with any particle that has not rested that long is awake, whole. So whatever
//! touches a sleeping island (a falling ball within reach of it) joins it and wakes it, and
//! the island falls asleep again once everything in it has rested for the sleep time. An
//! awake particle's rest time goes on counting; a sleeping one's stays as it was.
//!
//! Everything here is a function of the state alone (positions, velocities and rest times, in
//! storage order), never of the thread count or the broad phase: the islands are the connected
//! components of a sorted pair list, found by a union-find whose result is a partition that
//! does not depend on the order of unions.

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

/// Default time (time units) an island must rest before it sleeps (Box2D's `b2_timeToSleep`).
pub const DEFAULT_SLEEP_TIME: f64 = 0.5;

/// Particles per parallel task when updating rest times.
const CHUNK: usize = 8192;

/// When islands may sleep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SleepSettings {
    /// A particle that moves less than `speed x dt` in a step rests for that step
    /// (length / time, > 0).
    pub speed: f64,
    /// An island sleeps once every particle in it has rested this long (time, > 0).
    pub time: f64,
}

/// The islands of one step, and which slots sleep through it.
#[derive(Debug, Default)]
pub(crate) struct Islands {
    /// Union-find forest over slots (scratch).
    parent: Vec<u32>,
    /// Per root: whether every particle of its island has rested long enough (scratch).
    ripe: Vec<bool>,
    /// Per slot: asleep this step.
    pub asleep: Vec<bool>,
    /// How many slots are asleep this step.
    pub count: usize,
}

impl Islands {
    /// Finds this step's sleeping slots: those whose island (connected through `pairs`, slots
    /// `i < j`) has every member's `rest` at least `time`. Returns how many sleep.
    pub fn mark(&mut self, pairs: &[Pair], rest: &[f64], time: f64) -> usize {
        let n = rest.len();
        self.asleep.clear();
        self.asleep.resize(n, false);
        self.count = 0;
        // Nobody has rested long enough: no island can sleep, and the union-find is not needed.
        if !rest.iter().any(|&t| t >= time) {
            return 0;
        }
        self.parent.clear();
        self.parent.extend(0..n as u32);
        for &(i, j) in pairs {
            let (a, b) = (find(&mut self.parent, i), find(&mut self.parent, j));
            // The smaller slot becomes the root (any choice gives the same partition).
            if a != b {
                let (low, high) = (a.min(b), a.max(b));
                self.parent[high as usize] = low;
            }
        }
        self.ripe.clear();
        self.ripe.resize(n, true);
        for (slot, &t) in rest.iter().enumerate() {
            if t < time {
                let root = find(&mut self.parent, slot as u32) as usize;
                self.ripe[root] = false;
            }
        }
        for slot in 0..n {
            let root = find(&mut self.parent, slot as u32) as usize;
            if self.ripe[root] {
                self.asleep[slot] = true;
                self.count += 1;
            }
        }
        self.count
    }

    /// True when `slot` sleeps this step.
    #[inline]
    pub fn sleeps(&self, slot: usize) -> bool {
        self.count > 0 && self.asleep[slot]
    }

    /// Per slot, whether it sleeps this step; empty when none does (what the solver takes).
    pub fn sleepers(&self) -> &[bool] {
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

/// The root of `x`'s tree, halving the path on the way.
#[inline]
pub(crate) fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
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
    fn an_island_sleeps_only_when_every_member_has_rested() {
        let mut islands = Islands::default();
        // islands {0, 1, 2} and {3, 4}; 5 alone
        let pairs = [(0, 1), (1, 2), (3, 4)];
        let rest = [1.0, 1.0, 0.2, 1.0, 1.0, 1.0];
        assert_eq!(islands.mark(&pairs, &rest, 0.5), 3);
        assert_eq!(islands.asleep, [false, false, false, true, true, true]);
        // the same partition whatever the order of the pairs
        let reversed = [(3, 4), (1, 2), (0, 1)];
        let mut again = Islands::default();
        again.mark(&reversed, &rest, 0.5);
        assert_eq!(again.asleep, islands.asleep);
    }

    #[test]
    fn nobody_sleeps_before_the_sleep_time() {
        let mut islands = Islands::default();
        assert_eq!(islands.mark(&[(0, 1)], &[0.4, 0.49], 0.5), 0);
        assert!(!islands.sleeps(0));
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
