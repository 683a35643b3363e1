//! The gases the validation measures: `N` equal particles (diameter 1, mass 1) in a periodic
//! box at a packing fraction, started at temperature 1 with no mean motion.

use carom_engine::{Aabb, Vector, World};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::PI;

/// Diameter `s` of every particle (the unit of length).
pub const DIAMETER: f64 = 1.0;
/// Mass `m` of every particle (the unit of mass); with temperature 1 the unit of time is
/// `s sqrt(m / T)`.
pub const MASS: f64 = 1.0;

/// How the velocities start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// Maxwell-Boltzmann (Gaussian components).
    Maxwell,
    /// Every speed the same, in random directions (far from Maxwell-Boltzmann).
    EqualSpeeds,
}

/// A periodic gas and what theory needs to know of it.
pub struct Gas<V: Vector> {
    pub world: World<V>,
    /// Particles.
    pub n: usize,
    /// The box's volume (area in 2D).
    pub volume: f64,
    /// Packing fraction.
    pub eta: f64,
}

impl<V: Vector> Gas<V> {
    /// `n` particles at packing fraction `eta` (< 0.35 in 2D, < 0.3 in 3D: they start on a
    /// lattice), restitution `k`, time step `dt`, velocities from `start` scaled to
    /// temperature 1, placed and launched from `seed`.
    pub fn new(n: usize, eta: f64, k: f64, dt: f64, start: Start, seed: u64) -> Self {
        let d = V::DIM;
        let r = DIAMETER / 2.0;
        let particle_volume = if d == 2 {
            PI * r * r
        } else {
            4.0 / 3.0 * PI * r.powi(3)
        };
        let volume = n as f64 * particle_volume / eta;
        let side = volume.powf(1.0 / d as f64);
        let per_axis = (n as f64).powf(1.0 / d as f64).ceil() as usize;
        let spacing = side / per_axis as f64;
        assert!(
            spacing > DIAMETER,
            "packing fraction {eta} too high for a lattice start"
        );
        let mut rng = Pcg64::seed_from_u64(seed);
        let mut gaussian = || {
            // Box-Muller
            let (u, v): (f64, f64) = (1.0 - rng.random::<f64>(), rng.random());
            (-2.0 * u.ln()).sqrt() * (2.0 * PI * v).cos()
        };
        let mut velocities: Vec<V> = (0..n)
            .map(|_| {
                let c: Vec<f64> = (0..d).map(|_| gaussian()).collect();
                let v = V::from_slice(&c);
                match start {
                    Start::Maxwell => v,
                    Start::EqualSpeeds => v * (1.0 / v.length_squared().sqrt()),
                }
            })
            .collect();
        let mean = velocities.iter().fold(V::ZERO, |a, &v| a + v) * (1.0 / n as f64);
        let sum: f64 = velocities
            .iter()
            .map(|&v| (v - mean).length_squared())
            .sum();
        // T = sum m |v - u|^2 / (d N) = 1
        let scale = (d as f64 * n as f64 / (MASS * sum)).sqrt();
        for v in &mut velocities {
            *v = (*v - mean) * scale;
        }
        let half = side / 2.0;
        let mut builder = World::builder()
            .dt(dt)
            .restitution(k)
            .domain(
                Aabb::new(
                    V::from_slice(&[-half; 3][..d]),
                    V::from_slice(&[half; 3][..d]),
                )
                .expect("a box of positive side"),
            )
            .periodic(&[true; 3][..d]);
        for (cell, &v) in velocities.iter().enumerate() {
            let mut c = [0.0; 3];
            let mut rest = cell;
            for x in c.iter_mut().take(d) {
                *x = -half + ((rest % per_axis) as f64 + 0.5) * spacing;
                rest /= per_axis;
            }
            builder = builder.particle(V::from_slice(&c[..d]), v, r, MASS);
        }
        let world = builder.build().expect("a valid periodic gas");
        Self {
            world,
            n,
            volume,
            eta,
        }
    }

    /// The number density `n / V`.
    pub fn density(&self) -> f64 {
        self.n as f64 / self.volume
    }

    /// Enskog's collision frequency per particle at temperature `temperature`.
    pub fn enskog_rate(&self, temperature: f64) -> f64 {
        carom_engine::theory::enskog_collision_rate(
            V::DIM,
            self.eta,
            self.density(),
            DIAMETER,
            temperature,
            MASS,
        )
    }

    /// Steps covering `time` (at least one).
    pub fn steps_for(&self, time: f64) -> u64 {
        ((time / self.world.config().dt).ceil() as u64).max(1)
    }

    /// Runs `steps` steps.
    pub fn run(&mut self, steps: u64) {
        for _ in 0..steps {
            self.world.step();
        }
    }
}
