//! Particles driven beyond their reach within a step, and the step taken again.
//!
//! A pair is a contact candidate when its particles are within reach of each other where the
//! step starts, and each reach covers the particle's own move and the pushes of its partners
//! (see [`super::raise_to_partners`]). A push passed along a chain of contacts can still drive
//! a particle further: a disc landing at 25 on a column of touching discs at the lecture box's
//! wall, at `k = 0`, carries the whole column down with it, and the column's lowest disc runs
//! into one it had no candidate pair with. The lecture's detection finds that pair only after
//! the move, and the lecture pile at `k = 0` was left 23.9 % of r deep (fill seed 1).
//!
//! So after the velocity phase and the move, each particle that went further than its reach
//! allows, by more than [`ESCAPE_TOLERANCE`] of its radius, is an escapee. When an
//! escapee overlaps, deeper than the tolerance, a particle that was beyond reach of it where
//! the step started (a pair the step never solved), the step is taken back and taken again
//! with every escapee's reach raised to cover its move ([`escape_reach`]), at most
//! [`crate::WorldConfig::retakes`] times (3 by default; see `step::advance`). A pair of particles that stayed within their
//! reaches is a candidate or stays apart, so a step with no escapee is never taken again.
//!
//! Every decision here is a count over particles, the same whichever order, thread or rank
//! counts: a world and a split run take the same steps again. The count of strikes, over a
//! grid of where the escapees ended, is in [`super::strikes`].

use super::settings::SLOP_FRACTION;
use super::strikes::Escapes;
use crate::broadphase::{gather, keep_headroom};
use crate::vector::Vector;
use rayon::prelude::*;

/// How far (as a fraction of its radius) a particle may go beyond its reach, and how deep a
/// pair the step never solved may overlap, before the step is taken again.
pub(crate) const ESCAPE_TOLERANCE: f64 = 0.005;

/// An escapee's reach when the step is taken again is this many times its move (plus its
/// radius): taken again, it is stopped sooner by its new partners, but a partner may also
/// push it further than before.
const MOVE_MARGIN: f64 = 1.25;

/// A particle's reach when the step is taken again after it moved `moved` (length) in the
/// step: its radius and slop (as in [`super::reach`]), and [`MOVE_MARGIN`] times its move.
/// Not capped at a radius as [`super::reach`] is: the reach must cover the move.
#[inline]
pub(crate) fn escape_reach(radius: f64, moved: f64) -> f64 {
    radius + SLOP_FRACTION * radius + MOVE_MARGIN * moved
}

/// How far a particle went from `start` to `end`, when that is further than its `reach`
/// (with `radius`) covers by more than [`ESCAPE_TOLERANCE`] of its radius; `None` otherwise.
#[inline]
pub(crate) fn moved_beyond<V: Vector>(start: V, end: V, reach: f64, radius: f64) -> Option<f64> {
    let moved = (end - start).length_squared().sqrt();
    (moved > reach - radius + ESCAPE_TOLERANCE * radius).then_some(moved)
}

/// A particle's step, as the check reads it: an escapee (one that went beyond its reach, see
/// [`moved_beyond`]) or a particle it may strike.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Moved<V> {
    /// Its particle id (the same on every rank).
    pub id: u32,
    /// Where the step started it.
    pub start: V,
    /// Where the step left it.
    pub end: V,
    /// Its radius.
    pub radius: f64,
    /// Its reach in the step's search (raised: see [`super::raise_to_partners`]).
    pub reach: f64,
}

/// Where a world's step started its particles, and their velocities then, to take the step
/// back (a rank of a split run reads its search's copies instead); empty when contacts cannot
/// rest (the lecture's step finds such pairs after the move, as the lecture's detection does).
#[derive(Clone, Debug, Default)]
pub(crate) struct StepStart<V> {
    pub position: Vec<V>,
    pub velocity: Vec<V>,
}

impl<V: Vector> StepStart<V> {
    /// Keeps `position` and `velocity` when `keep` (steps may be taken again: reaches cover
    /// pushes, see [`super::reach_covers_pushes`]); otherwise lets the copies go.
    pub fn keep(&mut self, keep: bool, position: &[V], velocity: &[V], parallel: bool) {
        if !keep {
            *self = Self::default();
            return;
        }
        copy_into(&mut self.position, position, parallel);
        copy_into(&mut self.velocity, velocity, parallel);
    }

    /// Puts `position` and `velocity` back as they were kept.
    pub fn restore(&self, position: &mut [V], velocity: &mut [V]) {
        position.copy_from_slice(&self.position);
        velocity.copy_from_slice(&self.velocity);
    }
}

/// What a stepper keeps to take a step again (see the module's notes).
#[derive(Clone, Debug, Default)]
pub(crate) struct Retakes<V> {
    /// Per slot, how far the particle went in a try taken back this step (0: not beyond its
    /// reach); empty while no try was.
    moved: Vec<f64>,
    /// The slots of this try's escapees, and each chunk's while they are collected.
    escaped: Vec<usize>,
    buffers: Vec<Vec<usize>>,
    /// This try's escapees.
    pub escapes: Escapes<V>,
    /// Whether the step is being taken again (its search keeps `moved`).
    again: bool,
}

impl<V: Vector> Retakes<V> {
    /// At the start of a try: whether it takes the step again (otherwise the last step's
    /// moves are forgotten).
    pub fn begin_try(&mut self) -> bool {
        let again = std::mem::take(&mut self.again);
        if !again {
            self.moved.clear();
        }
        again
    }

    /// Raises each reach to cover the move its particle made in a try taken back this step.
    pub fn raise(&self, reach: &mut [f64], radius: &[f64]) {
        for (s, &moved) in self.moved.iter().enumerate() {
            if moved > 0.0 {
                reach[s] = reach[s].max(escape_reach(radius[s], moved));
            }
        }
    }

    /// Collects this try's escapees among slots `0..n` (`particle(s)`) into `escapes.list`
    /// (a split run then gathers every rank's there).
    pub fn collect(
        &mut self,
        n: usize,
        parallel: bool,
        particle: impl Fn(usize) -> Moved<V> + Sync,
    ) {
        let beyond = |s: usize| {
            let p = particle(s);
            moved_beyond(p.start, p.end, p.reach, p.radius).is_some()
        };
        // (fixed chunks, each into its own buffer, gathered in order: the same list for any
        // number of threads, and no allocation once the buffers have grown)
        let chunks = n.div_ceil(COLLECT_CHUNK);
        if self.buffers.len() < chunks {
            self.buffers.resize_with(chunks, Vec::new);
        }
        let work = |(c, out): (usize, &mut Vec<usize>)| {
            out.clear();
            let slots = c * COLLECT_CHUNK..((c + 1) * COLLECT_CHUNK).min(n);
            out.extend(slots.filter(|&s| beyond(s)));
            keep_headroom(out);
        };
        let buffers = &mut self.buffers[..chunks];
        if parallel {
            buffers.par_iter_mut().enumerate().for_each(work);
        } else {
            buffers.iter_mut().enumerate().for_each(work);
        }
        gather(buffers, &mut self.escaped);
        self.escapes.list.clear();
        self.escapes
            .list
            .extend(self.escaped.iter().map(|&s| particle(s)));
        keep_headroom(&mut self.escapes.list);
    }

    /// Takes note of this try's escapees' moves for the next try (slots `0..n`), which takes
    /// the step again.
    pub fn take_again(&mut self, n: usize) {
        self.moved.resize(n, 0.0);
        for (&s, e) in self.escaped.iter().zip(&self.escapes.list) {
            let moved = (e.end - e.start).length_squared().sqrt();
            self.moved[s] = self.moved[s].max(moved);
        }
        self.again = true;
    }
}

/// Particles per task when the escapees are collected.
const COLLECT_CHUNK: usize = 16_384;

/// Makes `into` a copy of `from`, on the thread pool when `parallel`.
fn copy_into<V: Copy + Send + Sync>(into: &mut Vec<V>, from: &[V], parallel: bool) {
    if into.len() != from.len() {
        into.clear();
        into.extend_from_slice(from);
    } else if parallel {
        const CHUNK: usize = 1 << 14;
        (into.par_chunks_mut(CHUNK))
            .zip(from.par_chunks(CHUNK))
            .for_each(|(a, b)| a.copy_from_slice(b));
    } else {
        into.copy_from_slice(from);
    }
}

/// A particle of radius 1 and reach 1.1 that went from `start` to `end` (for tests).
#[cfg(test)]
pub(super) fn moved<V: Vector>(id: u32, start: V, end: V) -> Moved<V> {
    Moved {
        id,
        start,
        end,
        radius: 1.0,
        reach: 1.1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    #[test]
    fn a_move_within_reach_is_no_escape() {
        let start = DVec2::ZERO;
        assert_eq!(moved_beyond(start, DVec2::new(0.1, 0.0), 1.1, 1.0), None);
        // (the tolerance: 0.5 % of the radius)
        assert_eq!(moved_beyond(start, DVec2::new(0.104, 0.0), 1.1, 1.0), None);
        assert_eq!(
            moved_beyond(start, DVec2::new(0.2, 0.0), 1.1, 1.0),
            Some(0.2)
        );
    }

    #[test]
    fn an_escape_reach_covers_the_move() {
        assert!(escape_reach(1.0, 0.4) >= 1.0 + 0.4);
        // (not capped at a radius as a reach is)
        assert!(escape_reach(1.0, 3.0) >= 4.0);
    }
}
