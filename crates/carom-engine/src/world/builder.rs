//! Building a world, every value checked.

use super::*;
use crate::broadphase::{BroadPhase, BroadPhaseKind};
use crate::brute::BruteForce;
use crate::domain::Aabb;
use crate::error::EngineError;
use crate::grid::Grid;
use crate::hash::SpatialHash;
use crate::memory::{self, ContactImpulses, Memory};
use crate::observe::Tally;
use crate::particles::Particles;
use crate::periodic::{self, Periodic};
use crate::plane::{check_restitution, Plane};
use crate::schedule::Blocks;
use crate::sleep::Sleepers;
use crate::timing::PhaseTimes;
use crate::vector::Vector;
use std::cell::OnceCell;

/// Builds a [`World`]; every value is checked in [`WorldBuilder::build`].
#[derive(Debug)]
pub struct WorldBuilder<V: Vector> {
    config: WorldConfig<V>,
    walls: Option<f64>,
    periodic: Option<Vec<bool>>,
    planes: Vec<Plane<V>>,
    particles: Particles<V>,
    resume: Option<(u64, Vec<u32>)>,
    impulses: ContactImpulses,
    tally: Tally,
    first_error: Option<EngineError>,
}

impl<V: Vector> Default for WorldBuilder<V> {
    fn default() -> Self {
        Self {
            config: WorldConfig::default(),
            walls: None,
            periodic: None,
            planes: Vec::new(),
            particles: Particles::new(),
            resume: None,
            impulses: ContactImpulses::default(),
            tally: Tally::default(),
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
    /// Close the domain with walls of restitution `k` (on its axes that are not periodic).
    pub fn walls(mut self, restitution: f64) -> Self {
        self.walls = Some(restitution);
        self
    }
    /// Which axes of the domain are periodic, one flag per axis (see
    /// [`WorldConfig::periodic`]).
    pub fn periodic(mut self, axes: &[bool]) -> Self {
        self.periodic = Some(axes.to_vec());
        self
    }
    /// Broad phase.
    pub fn broad_phase(mut self, kind: BroadPhaseKind) -> Self {
        self.config.broad_phase = kind;
        self
    }
    /// The most times one step is taken again (see [`WorldConfig::retakes`]); 0 never.
    pub fn retakes(mut self, retakes: u32) -> Self {
        self.config.retakes = retakes;
        self
    }

    /// Whether the lecture's step covers pushes (see [`WorldConfig::cover_pushes`]).
    pub fn cover_pushes(mut self, on: bool) -> Self {
        self.config.cover_pushes = on;
        self
    }
    /// Substeps per step (see [`WorldConfig::substeps`]), >= 1.
    pub fn substeps(mut self, substeps: u32) -> Self {
        self.config.substeps = substeps;
        self
    }
    /// Resting-contact speed (see [`WorldConfig::resting_speed`]), >= 0.
    pub fn resting_speed(mut self, speed: f64) -> Self {
        self.config.resting_speed = Some(speed);
        self
    }
    /// Lets particles at rest sleep (the default), or not (see [`crate::sleep`]).
    pub fn sleep(mut self, on: bool) -> Self {
        self.config.sleep = on;
        self
    }
    /// Sleep speed (length / time, > 0): see [`WorldConfig::sleep_speed`].
    pub fn sleep_speed(mut self, speed: f64) -> Self {
        self.config.sleep_speed = Some(speed);
        self
    }
    /// Sleep time (time units, > 0): see [`WorldConfig::sleep_time`].
    pub fn sleep_time(mut self, time: f64) -> Self {
        self.config.sleep_time = time;
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

    /// Continues a run: the world starts as if it had taken `steps_taken` steps, with its
    /// particles in `storage_order` (ids by storage slot, from [`World::storage_order`]). With
    /// the particles of the original at that step, the continuation is bit-identical.
    pub fn resume(mut self, steps_taken: u64, storage_order: Vec<u32>) -> Self {
        self.resume = Some((steps_taken, storage_order));
        self
    }

    /// Continues a run's resting contacts too: the impulses [`World::contact_impulses`] gave at
    /// the step the run continues from (needed, with [`WorldBuilder::resume`], for the
    /// continuation to be bit-identical).
    pub fn impulses(mut self, impulses: ContactImpulses) -> Self {
        self.impulses = impulses;
        self
    }

    /// Continues a run's observables: the running sums [`World::tally`] gave at the step the
    /// run continues from (the collision count and the pressure's interval go on from there).
    pub fn tally(mut self, tally: Tally) -> Self {
        self.tally = tally;
        self
    }

    /// Checks everything and builds the world.
    pub fn build(self) -> Result<World<V>, EngineError> {
        if let Some(e) = self.first_error {
            return Err(e);
        }
        let mut config = self.config;
        if let Some(axes) = &self.periodic {
            set_periodic(&mut config, axes)?;
        }
        check_settings(&config)?;
        let periodic = check_periodic(&config, &self.particles)?;
        let planes = with_walls(self.planes, self.walls, &config)?;
        let broad_phase = new_broad_phase(&config)?;
        let mut particles = self.particles;
        if let Some(p) = &periodic {
            periodic::wrap_all(p, false, &mut particles.position);
        }
        let n = particles.len();
        let (steps, ids) = match self.resume {
            None => (0, (0..n as u32).collect()),
            Some((steps, order)) => (steps, order),
        };
        let slots = slots_of(&ids, n)?;
        if !memory::is_valid(&self.impulses, n, planes.len()) {
            return Err(EngineError::ContactImpulses);
        }
        let remembered = Memory::from_ids(&self.impulses, &slots);
        let rest = if self.impulses.rest.is_empty() {
            Vec::new()
        } else {
            ids.iter()
                .map(|&id| self.impulses.rest[id as usize])
                .collect()
        };
        let store = in_storage_order(particles, &ids);
        Ok(World {
            config,
            periodic,
            planes,
            store,
            ids,
            slots,
            by_id: OnceCell::new(),
            contacts_by_id: OnceCell::new(),
            broad_phase,
            reach: Vec::new(),
            raised: Vec::new(),
            speed: Vec::new(),
            pairs: Vec::new(),
            pairs_kept: Vec::new(),
            rows: Rows::with_capacity(n),
            plane_contacts: Vec::new(),
            plane_rows: Vec::new(),
            plane_buffers: Vec::new(),
            memory: remembered,
            rest,
            sleepers: Sleepers::default(),
            start: Vec::new(),
            sleeping_pairs: Vec::new(),
            still: Vec::new(),
            sleeping_pairs_hold: false,
            all_asleep: false,
            asleep_overlap: 0.0,
            phase_times: PhaseTimes::default(),
            blocks: Blocks::default(),
            stamps: Vec::new(),
            stamp_groups: Vec::new(),
            clock: 0,
            block_size: block_size(n, V::DIM),
            sorter: Sorter::default(),
            steps,
            tally: self.tally,
            step_cells: None,
            found_overlap: 0.0,
            retakes: Default::default(),
            step_start: Default::default(),
            fastest_move: 0.0,
        })
    }
}

/// Makes `axes` (one flag per axis) `config`'s periodic axes.
fn set_periodic<V: Vector>(config: &mut WorldConfig<V>, axes: &[bool]) -> Result<(), EngineError> {
    if axes.len() != V::DIM {
        return Err(EngineError::PeriodicAxes {
            got: axes.len(),
            dimensions: V::DIM,
        });
    }
    config.periodic = [false; 3];
    config.periodic[..V::DIM].copy_from_slice(axes);
    Ok(())
}

/// `planes`, then the domain's walls with restitution `walls` when asked: 2 per axis, in axis
/// order, none on a periodic axis.
fn with_walls<V: Vector>(
    mut planes: Vec<Plane<V>>,
    walls: Option<f64>,
    config: &WorldConfig<V>,
) -> Result<Vec<Plane<V>>, EngineError> {
    if let Some(k) = walls {
        let domain = config.domain.ok_or(EngineError::EmptyDomain)?;
        let walls = domain.walls(k)?.into_iter().enumerate();
        planes.extend(
            walls
                .filter(|(w, _)| !config.periodic[w / 2])
                .map(|(_, p)| p),
        );
    }
    Ok(planes)
}

/// The checks of [`WorldBuilder::build`] on the settings alone.
fn check_settings<V: Vector>(config: &WorldConfig<V>) -> Result<(), EngineError> {
    check_dt(config.dt)?;
    if !config.gravity.is_finite_vector() {
        return Err(EngineError::NonFinite("gravity"));
    }
    check_restitution(config.restitution)?;
    if config.substeps == 0 {
        return Err(EngineError::Substeps);
    }
    if let Some(speed) = config.sleep_speed {
        if !(speed.is_finite() && speed > 0.0) {
            return Err(EngineError::NonFinite("sleep speed (must be > 0)"));
        }
    }
    if !(config.sleep_time.is_finite() && config.sleep_time > 0.0) {
        return Err(EngineError::NonFinite("sleep time (must be > 0)"));
    }
    if let Some(speed) = config.resting_speed {
        if !(speed.is_finite() && speed >= 0.0) {
            return Err(EngineError::NonFinite("resting speed (must be >= 0)"));
        }
    }
    Ok(())
}

/// The slot of each id, from the id of each slot (`ids`, for `n` particles): each id in
/// `0..n` exactly once, or an error.
fn slots_of(ids: &[u32], n: usize) -> Result<Vec<u32>, EngineError> {
    let mut slots = vec![u32::MAX; n];
    for (slot, &id) in ids.iter().enumerate() {
        match slots.get_mut(id as usize) {
            Some(s) if *s == u32::MAX => *s = slot as u32,
            _ => return Err(EngineError::StorageOrder),
        }
    }
    if ids.len() != n {
        return Err(EngineError::StorageOrder);
    }
    Ok(slots)
}

/// `particles` (in id order) in the storage order `ids` (the id of each slot).
fn in_storage_order<V: Vector>(particles: Particles<V>, ids: &[u32]) -> Particles<V> {
    if ids
        .iter()
        .enumerate()
        .all(|(slot, &id)| slot == id as usize)
    {
        return particles; // already in storage order: move, do not copy
    }
    let mut store = Particles::new();
    for &id in ids {
        let id = id as usize;
        let p = &particles;
        store.position.push(p.position[id]);
        store.velocity.push(p.velocity[id]);
        store.radius.push(p.radius[id]);
        store.mass.push(p.mass[id]);
    }
    store
}

/// The broad phase `config` asks for.
pub(crate) fn new_broad_phase<V: Vector>(
    config: &WorldConfig<V>,
) -> Result<Box<dyn BroadPhase<V>>, EngineError> {
    let periodic = config.periodic();
    Ok(match config.broad_phase {
        BroadPhaseKind::Brute => Box::new(BruteForce::new().with_periodic(periodic)),
        BroadPhaseKind::Grid => Box::new(
            Grid::new(config.domain, config.grid_cells.as_deref())?.with_periodic(periodic),
        ),
        BroadPhaseKind::Hash if periodic.is_some() => return Err(EngineError::PeriodicHash),
        BroadPhaseKind::Hash => Box::new(SpatialHash::new()),
    })
}

/// The periodic axes `config` asks for, checked against the domain, the broad phase and the
/// largest particle of `particles` (see [`periodic::shortest_period`]).
fn check_periodic<V: Vector>(
    config: &WorldConfig<V>,
    particles: &Particles<V>,
) -> Result<Option<Periodic>, EngineError> {
    if !config.periodic.iter().any(|&a| a) {
        return Ok(None);
    }
    let domain = config.domain.ok_or(EngineError::PeriodicWithoutDomain)?;
    let shortest = periodic::shortest_period(particles.max_radius());
    for axis in (0..V::DIM).filter(|&a| config.periodic[a]) {
        let length = domain.max.get(axis) - domain.min.get(axis);
        if length <= shortest {
            return Err(EngineError::PeriodTooShort {
                axis,
                length,
                shortest,
            });
        }
    }
    if config.broad_phase == BroadPhaseKind::Hash {
        return Err(EngineError::PeriodicHash);
    }
    Ok(config.periodic())
}

pub(super) fn check_dt(dt: f64) -> Result<(), EngineError> {
    if dt.is_finite() && dt > 0.0 {
        Ok(())
    } else {
        Err(EngineError::TimeStep(dt))
    }
}
