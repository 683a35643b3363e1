//! The world: particles, planes, a broad phase and the time step that ties them together.
//!
//! One step (length `dt`, time units):
//! 1. integrate: `v += g dt`, then `x += v dt` (semi-implicit Euler);
//! 2. broad phase: every overlapping pair, sorted (see [`crate::broadphase`]);
//! 3. plane contacts: every particle within its radius of a plane;
//! 4. velocity phase, then position phase (see [`crate::solver`]).

use crate::broadphase::{BroadPhase, BroadPhaseKind, Pair};
use crate::brute::BruteForce;
use crate::diagnostics::{self, StepStats};
use crate::domain::Aabb;
use crate::error::EngineError;
use crate::grid::Grid;
use crate::particles::Particles;
use crate::plane::{check_restitution, Plane};
use crate::solver::{self, PlaneContact};
use crate::vector::Vector;
use rayon::prelude::*;

/// Default cap on velocity sweeps per step.
pub const DEFAULT_VELOCITY_ITERATIONS: u32 = 16;
/// Default position-correction sweeps per step.
pub const DEFAULT_POSITION_ITERATIONS: u32 = 4;

/// Parameters that stay fixed while stepping (some can be changed with setters).
#[derive(Clone, Debug, PartialEq)]
pub struct WorldConfig<V> {
    /// Time step, > 0.
    pub dt: f64,
    /// Acceleration applied to every particle, length per time squared.
    pub gravity: V,
    /// Particle-particle coefficient of restitution `k` in [0, 1].
    pub restitution: f64,
    /// Cap on velocity sweeps per step, >= 1.
    pub velocity_iterations: u32,
    /// Position-correction sweeps per step (0 turns the lecture's "solution 1" off).
    pub position_iterations: u32,
    /// The simulation space; the grid covers it. `None`: the grid fits the particles.
    pub domain: Option<Aabb<V>>,
    /// Which broad phase finds contacts.
    pub broad_phase: BroadPhaseKind,
    /// Grid cells per axis; `None` derives them from the largest radius.
    pub grid_cells: Option<Vec<usize>>,
}

impl<V: Vector> Default for WorldConfig<V> {
    fn default() -> Self {
        Self {
            dt: 0.005,
            gravity: V::ZERO,
            restitution: 1.0,
            velocity_iterations: DEFAULT_VELOCITY_ITERATIONS,
            position_iterations: DEFAULT_POSITION_ITERATIONS,
            domain: None,
            broad_phase: BroadPhaseKind::Grid,
            grid_cells: None,
        }
    }
}

/// Builds a [`World`]; every value is checked in [`WorldBuilder::build`].
#[derive(Debug)]
pub struct WorldBuilder<V: Vector> {
    config: WorldConfig<V>,
    walls: Option<f64>,
    planes: Vec<Plane<V>>,
    particles: Particles<V>,
    first_error: Option<EngineError>,
}

impl<V: Vector> Default for WorldBuilder<V> {
    fn default() -> Self {
        Self {
            config: WorldConfig::default(),
            walls: None,
            planes: Vec::new(),
            particles: Particles::new(),
            first_error: None,
        }
    }
}

impl<V: Vector> WorldBuilder<V> {
    /// Time step (> 0).
    pub fn dt(mut self, dt: f64) -> Self {
        self.config.dt = dt;
        self
    }
    /// Gravity.
    pub fn gravity(mut self, g: V) -> Self {
        self.config.gravity = g;
        self
    }
    /// Particle-particle restitution `k` in [0, 1].
    pub fn restitution(mut self, k: f64) -> Self {
        self.config.restitution = k;
        self
    }
    /// Velocity sweep cap (>= 1) and position sweeps per step.
    pub fn iterations(mut self, velocity: u32, position: u32) -> Self {
        self.config.velocity_iterations = velocity;
        self.config.position_iterations = position;
        self
    }
    /// The simulation space.
    pub fn domain(mut self, domain: Aabb<V>) -> Self {
        self.config.domain = Some(domain);
        self
    }
    /// Close the domain with walls of restitution `k`.
    pub fn walls(mut self, restitution: f64) -> Self {
        self.walls = Some(restitution);
        self
    }
    /// Broad phase.
    pub fn broad_phase(mut self, kind: BroadPhaseKind) -> Self {
        self.config.broad_phase = kind;
        self
    }
    /// Grid cells per axis (one entry per dimension, each >= 1).
    pub fn grid_cells(mut self, cells: &[usize]) -> Self {
        self.config.grid_cells = Some(cells.to_vec());
        self
    }
    /// Adds a plane.
    pub fn plane(mut self, plane: Plane<V>) -> Self {
        self.planes.push(plane);
        self
    }
    /// Adds a particle (id = number added before it).
    pub fn particle(mut self, position: V, velocity: V, radius: f64, mass: f64) -> Self {
        if let Err(e) = self.particles.push(position, velocity, radius, mass) {
            self.first_error.get_or_insert(e);
        }
        self
    }
    /// Uses `particles` as the particle set (replacing any added so far).
    pub fn particles(mut self, particles: Particles<V>) -> Self {
        self.particles = particles;
        self
    }

    /// Checks everything and builds the world.
    pub fn build(self) -> Result<World<V>, EngineError> {
        if let Some(e) = self.first_error {
            return Err(e);
        }
        let config = self.config;
        check_dt(config.dt)?;
        if !config.gravity.is_finite_vector() {
            return Err(EngineError::NonFinite("gravity"));
        }
        check_restitution(config.restitution)?;
        let mut planes = self.planes;
        if let Some(k) = self.walls {
            let domain = config.domain.ok_or(EngineError::EmptyDomain)?;
            planes.extend(domain.walls(k)?);
        }
        let broad_phase: Box<dyn BroadPhase<V>> = match config.broad_phase {
            BroadPhaseKind::Brute => Box::new(BruteForce::new()),
            BroadPhaseKind::Grid => {
                Box::new(Grid::new(config.domain, config.grid_cells.as_deref())?)
            }
        };
        Ok(World {
            config,
            planes,
            particles: self.particles,
            broad_phase,
            pairs: Vec::new(),
            plane_contacts: Vec::new(),
            steps: 0,
        })
    }
}

fn check_dt(dt: f64) -> Result<(), EngineError> {
    if dt.is_finite() && dt > 0.0 {
        Ok(())
    } else {
        Err(EngineError::TimeStep(dt))
    }
}

/// A particle system that can be stepped.
pub struct World<V: Vector> {
    config: WorldConfig<V>,
    planes: Vec<Plane<V>>,
    particles: Particles<V>,
    broad_phase: Box<dyn BroadPhase<V>>,
    pairs: Vec<Pair>,
    plane_contacts: Vec<PlaneContact>,
    steps: u64,
}

impl<V: Vector> std::fmt::Debug for World<V> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("config", &self.config)
            .field("planes", &self.planes)
            .field("particles", &self.particles.len())
            .field("steps", &self.steps)
            .finish()
    }
}

/// Particles per parallel integration task (fixed, like [`crate::broadphase`]'s chunks).
const INTEGRATE_CHUNK: usize = 4096;

impl<V: Vector> World<V> {
    /// A builder with default settings (dt 0.005, no gravity, k = 1, grid broad phase).
    pub fn builder() -> WorldBuilder<V> {
        WorldBuilder::default()
    }

    /// Advances the world by one time step.
    pub fn step(&mut self) -> StepStats {
        let dt = self.config.dt;
        let dv = self.config.gravity * dt;
        let Particles {
            position, velocity, ..
        } = &mut self.particles;
        position
            .par_chunks_mut(INTEGRATE_CHUNK)
            .zip(velocity.par_chunks_mut(INTEGRATE_CHUNK))
            .for_each(|(xs, vs)| {
                for (x, v) in xs.iter_mut().zip(vs.iter_mut()) {
                    *v += dv;
                    *x += *v * dt;
                }
            });

        self.broad_phase.find_pairs(
            &self.particles.position,
            &self.particles.radius,
            &mut self.pairs,
        );

        self.plane_contacts.clear();
        if !self.planes.is_empty() {
            for (i, (&x, &r)) in self
                .particles
                .position
                .iter()
                .zip(&self.particles.radius)
                .enumerate()
            {
                for (p, plane) in self.planes.iter().enumerate() {
                    if plane.signed_distance(x) < r {
                        self.plane_contacts.push((i as u32, p as u32));
                    }
                }
            }
        }

        let solve = solver::solve_velocities(
            &mut self.particles,
            &self.pairs,
            &self.plane_contacts,
            &self.planes,
            self.config.restitution,
            self.config.velocity_iterations,
        );
        solver::separate(
            &mut self.particles,
            &self.pairs,
            &self.plane_contacts,
            &self.planes,
            self.config.position_iterations,
        );
        self.steps += 1;
        StepStats {
            contacts: self.pairs.len(),
            plane_contacts: self.plane_contacts.len(),
            velocity_iterations: solve.iterations,
            responses: solve.responses,
            capped: solve.capped,
        }
    }

    /// The particles.
    pub fn particles(&self) -> &Particles<V> {
        &self.particles
    }

    /// The particles, for tools that edit velocities between steps.
    pub fn particles_mut(&mut self) -> &mut Particles<V> {
        &mut self.particles
    }

    /// All planes, including domain walls.
    pub fn planes(&self) -> &[Plane<V>] {
        &self.planes
    }

    /// The settings.
    pub fn config(&self) -> &WorldConfig<V> {
        &self.config
    }

    /// Steps taken so far.
    pub fn steps_taken(&self) -> u64 {
        self.steps
    }

    /// Simulated time so far (`steps * dt`).
    pub fn time(&self) -> f64 {
        self.steps as f64 * self.config.dt
    }

    /// Overlapping pairs found in the last step, sorted.
    pub fn contacts(&self) -> &[Pair] {
        &self.pairs
    }

    /// Name of the broad phase in use.
    pub fn broad_phase_name(&self) -> &'static str {
        self.broad_phase.name()
    }

    /// Grid cells per axis in use (after the first step), if the broad phase is a grid.
    pub fn grid_cells(&self) -> Option<[usize; 3]> {
        self.broad_phase.cells()
    }

    /// Total kinetic energy.
    pub fn kinetic_energy(&self) -> f64 {
        diagnostics::kinetic_energy(&self.particles)
    }

    /// Gravitational potential energy (zero at the origin).
    pub fn potential_energy(&self) -> f64 {
        diagnostics::potential_energy(&self.particles, self.config.gravity)
    }

    /// Total momentum.
    pub fn momentum(&self) -> V {
        diagnostics::momentum(&self.particles)
    }

    /// Changes the particle-particle restitution.
    pub fn set_restitution(&mut self, k: f64) -> Result<(), EngineError> {
        check_restitution(k)?;
        self.config.restitution = k;
        Ok(())
    }

    /// Changes gravity.
    pub fn set_gravity(&mut self, g: V) -> Result<(), EngineError> {
        if !g.is_finite_vector() {
            return Err(EngineError::NonFinite("gravity"));
        }
        self.config.gravity = g;
        Ok(())
    }

    /// Changes the time step.
    pub fn set_dt(&mut self, dt: f64) -> Result<(), EngineError> {
        check_dt(dt)?;
        self.config.dt = dt;
        Ok(())
    }

    /// A 64-bit FNV-1a hash of every position and velocity bit pattern, in id order: equal
    /// hashes mean (with overwhelming likelihood) bit-identical states.
    pub fn state_hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |x: f64| {
            for b in x.to_bits().to_le_bytes() {
                h ^= b as u64;
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for (x, v) in self.particles.position.iter().zip(&self.particles.velocity) {
            for a in 0..V::DIM {
                eat(x.get(a));
                eat(v.get(a));
            }
        }
        h
    }
}
