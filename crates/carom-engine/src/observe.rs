//! What a researcher checks against kinetic theory: granular temperature, the collision
//! count, the pressure (kinetic plus collisional virial) and the deepest overlap.
//!
//! With `N` particles of masses `m`, velocities `v`, dimension `d` and domain volume `V` (area
//! in 2D), and `u = sum m v / sum m` the mass-weighted mean velocity:
//!
//! - granular temperature `T = sum m |v - u|^2 / (d N)` (energy units);
//! - collisions: particle-particle impacts since the first reading (the start, for
//!   `carom run --observe`). A pair that answers an approach
//!   in a step counts once for that step (with the lecture's response, or as an impact of the
//!   resting-contact solver, see [`crate::solver`]); resting contacts that are not approaching
//!   do not count, and neither do planes;
//! - pressure over an interval `t` since the previous reading:
//!   `P = [ <sum m |v - u|^2> + (1 / t) sum J_ij . r_ij ] / (d V)`, the mean taken over the
//!   ends of the interval's steps, the sum over every impulse `J_ij` that particle `j` gave
//!   `i` during the interval, `r_ij = x_i - x_j` (positive for repulsion). This is the virial
//!   pressure (Allen and Tildesley, *Computer Simulation of Liquids*, 2nd ed., eq. 2.61, with
//!   impulses for forces: hard spheres, eq. 3.44). Planes do not enter: in a walled box
//!   without gravity the walls' impulses *are* the pressure, and the virial theorem makes the
//!   formula above equal to their force per area (the walls' virial is `-d P V`); with gravity
//!   the pressure varies with height and this is its mean over the box. Pairs of sleepers (see
//!   [`crate::sleep`]) add neither collisions nor virial;
//! - max overlap: the largest `(r_i + r_j - |x_i - x_j|) / min(r_i, r_j)` at that step (0 if
//!   none).

use crate::particles::Particles;
use crate::vector::Vector;

/// One reading of a world's observables (see the module notes), as `World::observe` returns
/// and `carom run --observe` writes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Observables {
    /// Steps taken.
    pub step: u64,
    /// Simulated time.
    pub time: f64,
    /// `sum 1/2 m |v|^2`.
    pub kinetic_energy: f64,
    /// `sum -m g . x` (zero at the origin).
    pub potential_energy: f64,
    /// Granular temperature `sum m |v - u|^2 / (d N)` (0 without particles).
    pub temperature: f64,
    /// Particle-particle collisions since the first reading.
    pub collisions: u64,
    /// Pressure over the interval since the previous reading (the kinetic part alone when no
    /// time has passed since it); NaN without a domain to take the volume of.
    pub pressure: f64,
    /// The deepest overlap at this step over every pair (see [`crate::World::deepest_overlap`]),
    /// as a fraction of the smaller radius.
    pub max_overlap: f64,
}

/// The running sums behind [`Observables`]: the collisions since the first reading, and what
/// the pressure needs since the previous one. Part of a world's state (a checkpoint keeps it,
/// so a resumed run reads the same numbers). Nothing is summed before the first reading: a
/// world nobody observes pays nothing for it, and its state (and checkpoint) is the same
/// whether it runs in one process or split over several.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tally {
    /// True once the world has been read (`World::observe`): the sums run from then on.
    pub observing: bool,
    /// Particle-particle collisions since the first reading.
    pub collisions: u64,
    /// `sum J_ij . r_ij` over the impulses since the previous reading (mass x length^2 /
    /// time).
    pub virial: f64,
    /// `sum over steps of dt * sum m |v - u|^2` since the previous reading, each step's sum
    /// taken at its end (mass x length^2 / time).
    pub thermal: f64,
    /// Time since the previous reading.
    pub interval: f64,
}

impl Tally {
    /// Adds one step of length `dt` with `collisions` and `virial`, and `thermal` its
    /// `sum m |v - u|^2` at the end.
    pub(crate) fn add_step(&mut self, dt: f64, collisions: u64, virial: f64, thermal: f64) {
        self.collisions += collisions;
        self.virial += virial;
        self.thermal += dt * thermal;
        self.interval += dt;
    }

    /// The pressure over the interval in a domain of `volume` in `dim` dimensions; `thermal`
    /// is `sum m |v - u|^2` now, used alone when the interval is empty.
    pub fn pressure(&self, thermal: f64, dim: usize, volume: Option<f64>) -> f64 {
        let Some(volume) = volume else {
            return f64::NAN;
        };
        let sum = if self.interval > 0.0 {
            (self.thermal + self.virial) / self.interval
        } else {
            thermal
        };
        sum / (dim as f64 * volume)
    }

    /// Starts a new interval (the collisions count on), and the sums if they had not started.
    pub(crate) fn restart(&mut self) {
        *self = Tally {
            observing: true,
            collisions: self.collisions,
            ..Tally::default()
        };
    }
}

/// `sum m |v - u|^2` with `u` the mass-weighted mean velocity, in slice order. One pass, as
/// `sum m |v|^2 - |sum m v|^2 / sum m` (never below 0): the step loop takes it every step.
pub fn thermal_sum<V: Vector>(mass: &[f64], velocity: &[V]) -> f64 {
    let (total, momentum, twice_kinetic) = mass.iter().zip(velocity).fold(
        (0.0, V::ZERO, 0.0),
        |(total, momentum, twice_kinetic), (&m, &v)| {
            (
                total + m,
                momentum + v * m,
                twice_kinetic + m * v.length_squared(),
            )
        },
    );
    if total <= 0.0 {
        return 0.0;
    }
    (twice_kinetic - momentum.length_squared() / total).max(0.0)
}

/// Granular temperature `sum m |v - u|^2 / (d N)`, summed in id order with `u` taken first
/// (two passes: exact however fast the whole moves).
pub fn temperature<V: Vector>(particles: &Particles<V>) -> f64 {
    let triples = || {
        let (m, v, x) = (&particles.mass, &particles.velocity, &particles.position);
        (m.iter().zip(v).zip(x)).map(|((&m, &v), &x)| (m, v, x))
    };
    energies_and_temperature_of(triples, V::ZERO).2
}

/// Kinetic energy, potential energy (under `gravity`) and [`temperature`] of the `(mass,
/// velocity, position)` triples that `items` gives, in their order (it is called once per
/// pass): the energies summed as [`crate::diagnostics::kinetic_energy_of`] and
/// [`crate::diagnostics::potential_energy_of`] sum them, the same bits (every sum from `-0.0`,
/// as `Iterator::sum` starts), with the temperature's mean velocity taken first: two passes
/// where separate sums took six. A world
/// reads its particles in id order, one gather a pass: at 10^6 discs a reading took 29 ms of
/// such passes.
pub(crate) fn energies_and_temperature_of<V: Vector, I: Iterator<Item = (f64, V, V)>>(
    items: impl Fn() -> I,
    gravity: V,
) -> (f64, f64, f64) {
    let (mut n, mut total, mut momentum) = (0usize, -0.0, V::ZERO);
    let (mut kinetic, mut potential) = (-0.0, -0.0);
    for (m, v, x) in items() {
        n += 1;
        total += m;
        momentum += v * m;
        kinetic += 0.5 * m * v.length_squared();
        potential += -m * gravity.dot(x);
    }
    if n == 0 {
        return (kinetic, potential, 0.0);
    }
    let mean = momentum * (1.0 / total);
    let sum = items().fold(-0.0, |sum, (m, v, _)| sum + m * (v - mean).length_squared());
    (kinetic, potential, sum / (V::DIM * n) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    #[test]
    fn temperature_ignores_the_mean_motion() {
        let mut p = Particles::new();
        p.push(DVec2::ZERO, DVec2::new(11.0, 5.0), 1.0, 1.0)
            .unwrap();
        p.push(DVec2::X * 5.0, DVec2::new(9.0, 5.0), 1.0, 1.0)
            .unwrap();
        // u = (10, 5); sum m |v - u|^2 = 2; T = 2 / (2 * 2)
        assert_eq!(temperature(&p), 0.5);
        assert_eq!(thermal_sum(&p.mass, &p.velocity), 2.0);
    }

    #[test]
    fn pressure_of_an_ideal_gas_is_n_t_over_v() {
        // no collisions: P V = N T, with sum m |v - u|^2 = d N T
        let (n, t, volume) = (100.0, 2.0, 50.0);
        let thermal = 2.0 * n * t;
        let mut tally = Tally::default();
        for _ in 0..10 {
            tally.add_step(0.1, 0, 0.0, thermal);
        }
        let p = tally.pressure(0.0, 2, Some(volume));
        assert!((p * volume - n * t).abs() < 1e-9 * n * t);
        assert_eq!(
            Tally::default().pressure(thermal, 2, Some(volume)),
            n * t / volume
        );
        assert!(tally.pressure(thermal, 2, None).is_nan());
    }

    #[test]
    fn restart_keeps_the_collisions() {
        let mut tally = Tally::default();
        tally.add_step(0.5, 3, 1.0, 2.0);
        tally.restart();
        assert_eq!(
            tally,
            Tally {
                observing: true,
                collisions: 3,
                ..Tally::default()
            }
        );
    }
}
