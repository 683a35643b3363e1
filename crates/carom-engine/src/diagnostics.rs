//! Conserved quantities, summed in id order so the same state always gives the same bits.

use crate::particles::Particles;
use crate::vector::Vector;

/// Total kinetic energy `sum 1/2 m |v|^2`.
pub fn kinetic_energy<V: Vector>(particles: &Particles<V>) -> f64 {
    kinetic_energy_of(masses_with(particles, &particles.velocity))
}

/// Total momentum `sum m v`.
pub fn momentum<V: Vector>(particles: &Particles<V>) -> V {
    momentum_of(masses_with(particles, &particles.velocity))
}

/// Gravitational potential energy `sum -m g . x` (zero at the origin).
pub fn potential_energy<V: Vector>(particles: &Particles<V>, gravity: V) -> f64 {
    potential_energy_of(masses_with(particles, &particles.position), gravity)
}

/// Each particle's mass with its entry of `values`, in the particles' order.
pub(crate) fn masses_with<'a, V: Vector>(
    particles: &'a Particles<V>,
    values: &'a [V],
) -> impl Iterator<Item = (f64, V)> + 'a {
    particles.mass.iter().copied().zip(values.iter().copied())
}

/// [`kinetic_energy`] of `(mass, velocity)` pairs, summed in their order.
pub(crate) fn kinetic_energy_of<V: Vector>(items: impl Iterator<Item = (f64, V)>) -> f64 {
    items.map(|(m, v)| 0.5 * m * v.length_squared()).sum()
}

/// [`momentum`] of `(mass, velocity)` pairs, summed in their order.
pub(crate) fn momentum_of<V: Vector>(items: impl Iterator<Item = (f64, V)>) -> V {
    items.fold(V::ZERO, |acc, (m, v)| acc + v * m)
}

/// [`potential_energy`] of `(mass, position)` pairs, summed in their order.
pub(crate) fn potential_energy_of<V: Vector>(
    items: impl Iterator<Item = (f64, V)>,
    gravity: V,
) -> f64 {
    items.map(|(m, x)| -m * gravity.dot(x)).sum()
}

/// What one step did and the state it left.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// Overlapping particle pairs (the lecture's detection) at the start of the velocity phase.
    pub contacts: usize,
    /// Particles touching a plane at the start of the velocity phase.
    pub plane_contacts: usize,
    /// Particle pairs that pushed each other this step: every contact the lecture's response
    /// answered, the sweeps met with an impulse, or that holds a remembered impulse, impacts
    /// and resting contacts alike (0 while the whole world sleeps).
    /// A pile whose contacts still open and close holds many of its pairs a hair apart
    /// (within the slop, see [`crate::solver::SLOP_FRACTION`]): they push without overlapping,
    /// and [`StepStats::contacts`] does not count them.
    pub pushing: usize,
    /// Velocity sweeps made.
    pub velocity_iterations: u32,
    /// Collision responses applied.
    pub responses: u64,
    /// Particle-particle collisions this step (see [`crate::observe`]).
    pub collisions: u64,
    /// True when the velocity sweeps stopped at the cap with contacts still approaching.
    pub capped: bool,
    /// The deepest particle-particle overlap left at the end of the step, as a fraction of the
    /// smaller radius, `(r_i + r_j - |x_i - x_j|) / min(r_i, r_j)`, over this step's contact
    /// candidates (every pair within reach of each other this step); 0 when nothing overlaps.
    pub max_overlap: f64,
    /// The deepest particle-particle overlap among the pairs this step found, measured as
    /// [`StepStats::max_overlap`] is but before anything moved: the state the step started
    /// from (the last step's result), over every pair within reach. `max_overlap` covers only
    /// the step's own contact candidates, and a pair that a push drove together from beyond
    /// their reach is none of them until the next step finds it: its depth shows here.
    pub found_overlap: f64,
    /// How far the fastest particle goes in this step at the speed it starts with, in its own
    /// radii: the largest `|v| dt / r` (0 when everything sleeps, which is at rest). From about
    /// 1 on (exactly: `(|v| + |g| dt) dt > r`) a particle's contact candidates do not cover its
    /// move: a pair it closes on from beyond them is found after the move, as the lecture's
    /// detection finds it, and its depth shows in the next step's
    /// [`StepStats::found_overlap`].
    pub fastest_move: f64,
    /// Particles asleep through this step (see [`crate::sleep`]); their contacts are not in
    /// `contacts`.
    pub asleep: usize,
    /// How many times the step was taken again because a push drove a particle beyond its
    /// reach into one the step never solved a contact with (0 to 3; see the solver's notes).
    pub retakes: u32,
}

impl StepStats {
    /// The deepest overlap of any state the step passed through: its own contacts at its end
    /// ([`StepStats::max_overlap`]) and every pair it found at its start
    /// ([`StepStats::found_overlap`]), as a fraction of the smaller radius.
    pub fn deepest_seen(&self) -> f64 {
        self.max_overlap.max(self.found_overlap)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    #[test]
    fn sums() {
        let mut p = Particles::new();
        p.push(DVec2::new(0.0, 2.0), DVec2::new(3.0, 4.0), 1.0, 2.0)
            .unwrap();
        p.push(DVec2::ZERO, DVec2::new(-1.0, 0.0), 1.0, 1.0)
            .unwrap();
        assert_eq!(kinetic_energy(&p), 25.0 + 0.5);
        assert_eq!(momentum(&p), DVec2::new(5.0, 8.0));
        assert_eq!(potential_energy(&p, DVec2::new(0.0, -10.0)), 40.0);
    }
}
