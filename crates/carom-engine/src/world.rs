//! The world: particles, planes, a broad phase and the time step that ties them together.
//!
//! One step (length `dt`, time units) takes the phases of [`crate::step`]:
//! 1. gravity: `v += g dt`;
//! 2. contacts: every pair within reach this step, sorted (see [`crate::broadphase`]), and
//!    every particle within reach of a plane; the lecture's detection on each;
//! 3. velocity phase (see [`crate::solver`]), warm-started from the last step's resting
//!    impulses (see [`crate::memory`]);
//! 4. move: `x += v dt`;
//! 5. position phase.
//!
//! A particle's *reach* this step is its radius plus how far it can move, `min(|v| dt, r)`:
//! pairs within reach are solver candidates, so that an overlap the move creates is pushed
//! apart in the same step, while only pairs that overlap (`distance < r1 + r2`) respond.
//!
//! Storage order: every [`REORDER_INTERVAL`] steps the particles' arrays are sorted along
//! space (by the cell of a grid one largest diameter fine, row by row), so that neighbours sit
//! next to each other in memory. Ids never change: [`World::particles`] and every diagnostic
//! are in id order. The sort depends only on the particles' state, never on the broad phase or
//! the thread count, so neither can change a single bit of the result.

use crate::broadphase::{keep_headroom, BroadPhase, BroadPhaseKind, Pair, PARALLEL_MIN};
use crate::brute::BruteForce;
use crate::bucket::counting_sort;
use crate::diagnostics::{self, StepStats};
use crate::domain::Aabb;
use crate::error::EngineError;
use crate::grid::{bounding_box, Grid, GridLayout};
use crate::hash::SpatialHash;
use crate::memory::{self, ContactImpulses, Memory};
use crate::observe::{self, Observables, Tally};
use crate::particles::Particles;
use crate::periodic::{self, Periodic};
use crate::plane::{check_restitution, Plane};
use crate::schedule::{Alone, Blocks, PlaneContact};
use crate::sleep::{self, SleepSettings, Sleepers, DEFAULT_SLEEP_TIME, SLEEP_SPEED_FRACTION};
use crate::solver::{
    self, Contacts, Moving, PlaneRow, Row, SolverSettings, VelocitySolve, WorkList,
};
use crate::step::{self, Phases};
use crate::timing::PhaseTimes;
use crate::vector::Vector;
use fnv::FnvHasher;
use rayon::prelude::*;
use std::cell::OnceCell;
use std::hash::Hasher;
use std::time::Instant;

/// Default cap on velocity sweeps per step.
pub const DEFAULT_VELOCITY_ITERATIONS: u32 = 32;
/// Default position-correction sweeps per step.
pub const DEFAULT_POSITION_ITERATIONS: u32 = 4;
/// Default substeps per step when contacts can rest (Box2D's default too).
pub const DEFAULT_SUBSTEPS: u32 = 4;
/// Steps between two spatial sorts of the particle arrays.
pub const REORDER_INTERVAL: u64 = 32;
/// Smallest block of storage slots the solver hands to one task.
const MIN_BLOCK: usize = 1024;

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
    /// Substeps per step when contacts can rest (gravity and some `k < 1`), >= 1: see
    /// [`crate::solver`]. The velocity sweep cap is shared among them.
    pub substeps: u32,
    /// The simulation space; the grid covers it. `None`: the grid fits the particles.
    pub domain: Option<Aabb<V>>,
    /// Per axis (the first `DIM` entries), whether the domain wraps around on it (see
    /// [`crate::periodic`]): positions stay in `[min, max)` there, contacts reach across the
    /// seam, and walls close only the other axes. Needs a domain.
    pub periodic: [bool; 3],
    /// Which broad phase finds contacts.
    pub broad_phase: BroadPhaseKind,
    /// Grid cells per axis; `None` derives them from the largest radius.
    pub grid_cells: Option<Vec<usize>>,
    /// Contacts approaching slower than this (length per time) do not bounce when their
    /// restitution is below 1: they are resting contacts, and bouncing them makes stacks jitter
    /// and sink. `None`: twice what gravity adds in one step, `2 |g| dt` (zero without
    /// gravity, where every contact follows the lecture's formula exactly). `Some(0.0)` turns
    /// this off. Restitution 1 always bounces, so energy stays exact.
    pub resting_speed: Option<f64>,
    /// Let particles at rest sleep (see [`crate::sleep`]); on by default, as in Box2D and Rapier.
    /// Only when contacts can rest (gravity, and `k < 1` somewhere): an elastic or weightless
    /// world never sleeps. A world split over processes ([`crate::cluster`]) puts the same
    /// particles to sleep.
    pub sleep: bool,
    /// A particle moving slower than this (length / time) rests; `None`: the resting
    /// speed (see [`crate::sleep::SLEEP_SPEED_FRACTION`]).
    pub sleep_speed: Option<f64>,
    /// How long (time units, > 0) a particle and every particle within
    /// [`crate::sleep::WAKE_HOPS`] contact candidates of it must rest before it sleeps.
    pub sleep_time: f64,
}

impl<V: Vector> WorldConfig<V> {
    /// The periodic axes of the domain, or `None` when none is (or there is no domain).
    pub fn periodic(&self) -> Option<Periodic> {
        self.domain
            .as_ref()
            .and_then(|d| Periodic::new(d, &self.periodic))
    }

    /// [`WorldConfig::resting_speed`], or its default `2 |g| dt`.
    pub fn effective_resting_speed(&self) -> f64 {
        self.resting_speed
            .unwrap_or(2.0 * self.gravity.length_squared().sqrt() * self.dt)
    }

    /// What the solver needs of these settings.
    pub fn solver_settings(&self) -> SolverSettings {
        SolverSettings {
            restitution: self.restitution,
            resting_speed: self.effective_resting_speed(),
            velocity_iterations: self.velocity_iterations,
            position_iterations: self.position_iterations,
            substeps: self.substeps,
        }
    }

    /// When particles may sleep in a world with `planes`: `None` when sleeping is off or no
    /// contact can rest.
    pub fn sleep_settings(&self, planes: &[Plane<V>]) -> Option<SleepSettings> {
        let elastic_planes = planes.iter().all(|p| p.restitution() >= 1.0);
        let solver = self.solver_settings();
        if !self.sleep || solver.lecture_only(elastic_planes) {
            return None;
        }
        Some(SleepSettings {
            speed: self
                .sleep_speed
                .unwrap_or(SLEEP_SPEED_FRACTION * solver.resting_speed),
            time: self.sleep_time,
        })
    }
}

impl<V: Vector> Default for WorldConfig<V> {
    fn default() -> Self {
        Self {
            dt: 0.005,
            gravity: V::ZERO,
            restitution: 1.0,
            velocity_iterations: DEFAULT_VELOCITY_ITERATIONS,
            position_iterations: DEFAULT_POSITION_ITERATIONS,
            substeps: DEFAULT_SUBSTEPS,
            domain: None,
            periodic: [false; 3],
            broad_phase: BroadPhaseKind::Grid,
            grid_cells: None,
            resting_speed: None,
            sleep: true,
            sleep_speed: None,
            sleep_time: DEFAULT_SLEEP_TIME,
        }
    }
}

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
            if axes.len() != V::DIM {
                return Err(EngineError::PeriodicAxes {
                    got: axes.len(),
                    dimensions: V::DIM,
                });
            }
            config.periodic = [false; 3];
            config.periodic[..V::DIM].copy_from_slice(axes);
        }
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
        let periodic = check_periodic(&config, &self.particles)?;
        let mut planes = self.planes;
        if let Some(k) = self.walls {
            let domain = config.domain.ok_or(EngineError::EmptyDomain)?;
            // (2 walls per axis, in axis order; a periodic axis has none)
            let walls = domain.walls(k)?.into_iter().enumerate();
            planes.extend(
                walls
                    .filter(|(w, _)| !config.periodic[w / 2])
                    .map(|(_, p)| p),
            );
        }
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
        if !memory::is_valid(&self.impulses, n, planes.len()) {
            return Err(EngineError::ContactImpulses);
        }
        let remembered = Memory::from_ids(&self.impulses, &slots);
        let rest = if self.impulses.rest.is_empty() {
            vec![0.0; n]
        } else {
            ids.iter()
                .map(|&id| self.impulses.rest[id as usize])
                .collect()
        };
        let store = if ids
            .iter()
            .enumerate()
            .all(|(slot, &id)| slot == id as usize)
        {
            particles // already in storage order: move, do not copy
        } else {
            let mut store = Particles::new();
            for &id in &ids {
                let id = id as usize;
                let p = &particles;
                store.position.push(p.position[id]);
                store.velocity.push(p.velocity[id]);
                store.radius.push(p.radius[id]);
                store.mass.push(p.mass[id]);
            }
            store
        };
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
            pairs: Vec::new(),
            rows: Vec::new(),
            plane_contacts: Vec::new(),
            plane_rows: Vec::new(),
            plane_buffers: Vec::new(),
            memory: remembered,
            rest,
            sleepers: Sleepers::default(),
            start: Vec::new(),
            all_asleep: false,
            asleep_overlap: 0.0,
            phase_times: PhaseTimes::default(),
            unsorted_ids: Vec::new(),
            blocks: Blocks::default(),
            stamps: Vec::new(),
            clock: 0,
            block_size: block_size(n, V::DIM),
            sorter: Sorter::default(),
            steps,
            tally: self.tally,
            last_overlap: None,
        })
    }
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

/// The grid the spatial sort orders `n` particles by: over `bounds` (the domain, or the
/// particles' bounding box), cells one largest diameter wide, at most one per particle (finer
/// would not sort any better, only cost memory). Derived from the particles alone, never from
/// the broad phase or its cell count, so that brute force and every grid size see the same
/// storage order and the same bits.
pub(crate) fn sort_layout<V: Vector>(bounds: &Aabb<V>, max_radius: f64, n: usize) -> GridLayout {
    GridLayout::fit(bounds, max_radius, None, (n as f64).max(64.0))
}

/// A whole world's state at one step, in a form that can travel: what
/// [`crate::cluster::Subdomain::gather`] collects and [`World::restore`] takes.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot<V> {
    /// Steps taken.
    pub steps_taken: u64,
    /// Ids by storage slot (see [`World::storage_order`]).
    pub storage_order: Vec<u32>,
    /// Every particle, by id.
    pub particles: Particles<V>,
    /// The resting contacts' impulses (see [`World::contact_impulses`]).
    pub impulses: ContactImpulses,
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
    /// The periodic axes, from the config (`None`: none; then nothing periodic ever runs).
    periodic: Option<Periodic>,
    planes: Vec<Plane<V>>,
    /// The particles in storage order (sorted along space every few steps).
    pub(crate) store: Particles<V>,
    /// Storage slot -> id.
    pub(crate) ids: Vec<u32>,
    /// Id -> storage slot.
    pub(crate) slots: Vec<u32>,
    /// Id-ordered copy, made when asked for and dropped by the next step.
    by_id: OnceCell<Particles<V>>,
    contacts_by_id: OnceCell<Vec<Pair>>,
    broad_phase: Box<dyn BroadPhase<V>>,
    /// Each slot's reach this step: radius plus `min(|v| dt, radius)`.
    reach: Vec<f64>,
    /// This step's contact candidates (pairs within reach), as storage slots, sorted.
    pairs: Vec<Pair>,
    /// The solver's data for each pair.
    rows: Vec<Row<V>>,
    /// This step's particles within reach of a plane, sorted.
    plane_contacts: Vec<PlaneContact>,
    plane_rows: Vec<PlaneRow<V>>,
    plane_buffers: Vec<Vec<PlaneContact>>,
    /// Resting impulses kept from the last step.
    memory: Memory,
    /// How long each slot has rested (see [`crate::sleep`]).
    rest: Vec<f64>,
    /// Who sleeps this step.
    sleepers: Sleepers,
    /// Positions at the start of the step (only when particles may sleep).
    start: Vec<V>,
    /// Every particle slept through the last step and nothing has woken any since: the next
    /// step would find them all asleep again, so it skips straight to the end.
    all_asleep: bool,
    /// The deepest overlap between sleeping particles (as in [`StepStats::max_overlap`]).
    asleep_overlap: f64,
    /// Where the steps' time went (see [`PhaseTimes`]).
    phase_times: PhaseTimes,
    /// Ids by slot before a sort (scratch).
    unsorted_ids: Vec<u32>,
    blocks: Blocks,
    /// The work lists' stamps, one per slot, and their sweep clock (see [`crate::schedule`]).
    stamps: Vec<u32>,
    clock: u32,
    pub(crate) block_size: usize,
    sorter: Sorter,
    steps: u64,
    /// The observables' running sums (see [`crate::observe`]).
    tally: Tally,
    /// The last step's [`StepStats::max_overlap`] (`None` before the first step).
    last_overlap: Option<f64>,
}

impl<V: Vector> std::fmt::Debug for World<V> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("config", &self.config)
            .field("planes", &self.planes)
            .field("particles", &self.store.len())
            .field("steps", &self.steps)
            .finish()
    }
}

/// Storage slots per solver block for `n` particles in `dim` dimensions: a few rows (2D) or
/// layers (3D) of a spatially sorted box, so that a contact seldom reaches past the next block.
/// A function of `n` alone, so that the contact order is too (and a resumed run matches).
pub(crate) fn block_size(n: usize, dim: usize) -> usize {
    let slab = (n as f64).powf((dim as f64 - 1.0) / dim as f64);
    let factor = if dim == 2 { 8.0 } else { 6.0 };
    ((factor * slab) as usize)
        .next_multiple_of(256)
        .max(MIN_BLOCK)
}

/// The spatial sort's scratch space, kept between sorts.
#[derive(Debug, Default)]
struct Sorter {
    keys: Vec<u32>,
    starts: Vec<u32>,
    order: Vec<u32>,
    done: Vec<u64>,
}

impl Sorter {
    /// Fills `self.order` with the slots of `store` in their sorted order (by grid cell, ties
    /// by id): new slot `s` takes what is now at slot `order[s]`.
    fn plan<V: Vector>(&mut self, store: &Particles<V>, slots: &[u32], domain: Option<Aabb<V>>) {
        let n = store.len();
        let bounds = domain.unwrap_or_else(|| bounding_box(&store.position));
        let layout = sort_layout(&bounds, store.max_radius(), n);
        self.keys.resize(n, 0);
        let key = |(k, &x): (&mut u32, &V)| *k = layout.linear(layout.cell_coords(x)) as u32;
        if n >= PARALLEL_MIN {
            self.keys
                .par_iter_mut()
                .zip(store.position.par_iter())
                .for_each(key);
        } else {
            self.keys
                .iter_mut()
                .zip(store.position.iter())
                .for_each(key);
        }
        // Ties (one cell) go by id, so the new order is a function of the state alone, not of
        // the order before: a world rebuilt from the same state sorts the same way.
        let items = slots.iter().copied();
        counting_sort(
            &self.keys,
            layout.total(),
            items,
            &mut self.starts,
            &mut self.order,
        );
    }

    /// Sorts the arrays by grid cell, ties by id.
    fn sort<V: Vector>(
        &mut self,
        store: &mut Particles<V>,
        ids: &mut [u32],
        rest: &mut [f64],
        slots: &mut [u32],
        domain: Option<Aabb<V>>,
    ) {
        let n = store.len();
        if n == 0 {
            return;
        }
        self.plan(store, slots, domain);
        // new slot s takes what was at order[s]: apply by following cycles, all arrays at once.
        self.done.clear();
        self.done.resize(n.div_ceil(64), 0);
        let Particles {
            position,
            velocity,
            radius,
            mass,
        } = store;
        for start in 0..n {
            if self.done[start / 64] & (1 << (start % 64)) != 0 {
                continue;
            }
            let saved = (
                position[start],
                velocity[start],
                radius[start],
                mass[start],
                ids[start],
                rest[start],
            );
            let mut s = start;
            loop {
                self.done[s / 64] |= 1 << (s % 64);
                let from = self.order[s] as usize;
                if from == start {
                    (
                        position[s],
                        velocity[s],
                        radius[s],
                        mass[s],
                        ids[s],
                        rest[s],
                    ) = saved;
                    break;
                }
                position[s] = position[from];
                velocity[s] = velocity[from];
                radius[s] = radius[from];
                mass[s] = mass[from];
                ids[s] = ids[from];
                rest[s] = rest[from];
                s = from;
            }
        }
        for (slot, &id) in ids.iter().enumerate() {
            slots[id as usize] = slot as u32;
        }
    }
}

impl<V: Vector> Phases for World<V> {
    fn sort_along_space(&mut self) {
        self.by_id.take();
        self.contacts_by_id.take();
        if self.steps % REORDER_INTERVAL != 0 || self.store.is_empty() || self.sleeps_whole() {
            return;
        }
        self.unsorted_ids.clear();
        self.unsorted_ids.extend_from_slice(&self.ids);
        self.sorter.sort(
            &mut self.store,
            &mut self.ids,
            &mut self.rest,
            &mut self.slots,
            self.config.domain,
        );
        self.memory.remap(&self.unsorted_ids, &self.slots);
    }

    fn find_contacts(&mut self) {
        let parallel = self.parallel();
        let dt = self.config.dt;
        let sleep = self.config.sleep_settings(&self.planes);
        if self.all_asleep {
            // (the sleepers, contacts and rows of a world asleep are those of the last step,
            // which slept whole: nothing to find, nothing to solve)
            self.pairs.clear();
            self.rows.clear();
            self.plane_contacts.clear();
            self.plane_rows.clear();
            return;
        }
        let fall = self.config.gravity.length_squared().sqrt() * dt;
        let reach = |(out, (v, &r)): (&mut f64, (&V, &f64))| {
            *out = solver::reach(r, v.length_squared().sqrt() + fall, dt);
        };
        let p = &self.store;
        self.reach.resize(p.len(), 0.0);
        if parallel {
            self.reach
                .par_iter_mut()
                .zip(p.velocity.par_iter().zip(p.radius.par_iter()))
                .for_each(reach);
        } else {
            self.reach
                .iter_mut()
                .zip(p.velocity.iter().zip(p.radius.iter()))
                .for_each(reach);
        }
        self.broad_phase
            .find_pairs(&self.store.position, &self.reach, &mut self.pairs);
        match sleep {
            Some(settings) => self.mark_sleepers(settings.time),
            None => self.sleepers.wake_all(),
        }
        self.find_plane_contacts(parallel);
        self.blocks.plan(
            self.store.len(),
            self.block_size,
            &self.pairs,
            &self.plane_contacts,
            parallel,
            0,
        );
        let rows_started = Instant::now();
        let p = &self.store;
        let periodic = self.periodic;
        let sleepers = &self.sleepers;
        // (a sleeper in a pair is a fixed obstacle: infinite mass)
        let mass = |i: usize| solver::moving_mass(p.mass[i], sleepers.sleeps(i));
        solver::prepare_rows(&mut self.rows, &self.pairs, parallel, |(i, j)| {
            let (i, j) = (i as usize, j as usize);
            let (xi, xj) = (p.position[i], p.position[j]);
            Row::across(
                xi,
                xj,
                periodic.map_or(V::ZERO, |q| q.shift(xi, xj)),
                p.radius[i],
                p.radius[j],
                mass(i),
                mass(j),
                dt,
            )
        });
        self.plane_rows.clear();
        self.plane_rows.reserve(self.plane_contacts.len());
        keep_headroom(&mut self.plane_rows);
        let planes = &self.planes;
        self.plane_rows
            .extend(self.plane_contacts.iter().map(|&(i, plane)| {
                let i = i as usize;
                PlaneRow::new(
                    &planes[plane as usize],
                    plane,
                    p.position[i],
                    p.radius[i],
                    dt,
                )
            }));
        self.memory.warm_rows(
            &self.pairs,
            &mut self.rows,
            &self.plane_contacts,
            &mut self.plane_rows,
        );
        self.phase_times.rows += rows_started.elapsed();
    }

    fn integrate(&mut self) -> VelocitySolve {
        let settings = self.config.solver_settings();
        let (gravity, dt) = (self.config.gravity, self.config.dt);
        if self.all_asleep {
            return VelocitySolve::default();
        }
        let (mut contacts, store, sleepers) = self.contacts_mut();
        let own = store.len();
        let moving = Moving {
            position: &mut store.position,
            velocity: &mut store.velocity,
            own,
            asleep: sleepers.flags(),
        };
        solver::integrate(&mut Alone, &settings, gravity, dt, moving, &mut contacts)
    }

    fn separate(&mut self) -> f64 {
        let settings = self.config.solver_settings();
        let gravity = self.config.gravity;
        if self.all_asleep {
            return self.asleep_overlap;
        }
        let (mut contacts, store, _) = self.contacts_mut();
        let awake = solver::separate(
            &mut Alone,
            &settings,
            gravity,
            &mut store.position,
            &mut store.velocity,
            &mut contacts,
        );
        awake.max(self.asleep_overlap)
    }

    fn remember(&mut self) {
        if self.all_asleep {
            return;
        }
        let (rows, sleepers) = (&self.rows, &self.sleepers);
        let memory = &mut self.memory;
        let sleeps = |slot: u32| sleepers.sleeps(slot as usize);
        Memory::store_keeping_asleep(
            &mut memory.pairs,
            &mut memory.scratch,
            &self.pairs,
            |k| rows[k].kept,
            |&(i, _, _)| sleeps(i),
        );
        let plane_rows = &self.plane_rows;
        Memory::store_keeping_asleep(
            &mut memory.planes,
            &mut memory.scratch,
            &self.plane_contacts,
            |k| plane_rows[k].kept,
            |&(i, _, _)| sleeps(i),
        );
    }

    fn times(&mut self) -> &mut PhaseTimes {
        &mut self.phase_times
    }

    fn finish(&mut self, solve: VelocitySolve, max_overlap: f64) -> StepStats {
        self.steps += 1;
        if let Some(settings) = self.config.sleep_settings(&self.planes) {
            if !self.all_asleep {
                sleep::update_rest(
                    self.parallel(),
                    &self.start,
                    &self.store.position,
                    self.sleepers.flags(),
                    &mut self.rest,
                    &settings,
                    self.config.dt,
                );
            }
            self.all_asleep = !self.store.is_empty() && self.sleepers.count == self.store.len();
        }
        // (all asleep: everything is at rest, no collision, no virial, no thermal motion)
        let rows = solver::tally(&self.rows);
        let (collisions, virial) = if self.all_asleep {
            (0, 0.0)
        } else {
            (rows.collisions, rows.virial)
        };
        if self.tally.observing {
            let thermal = if self.all_asleep {
                0.0
            } else {
                observe::thermal_sum(&self.store.mass, &self.store.velocity)
            };
            self.tally
                .add_step(self.config.dt, collisions, virial, thermal);
        }
        self.last_overlap = Some(max_overlap);
        // Wrapped last: the rest times above compare where the step started and ended.
        if let (Some(p), false) = (&self.periodic, self.all_asleep) {
            periodic::wrap_all(p, self.parallel(), &mut self.store.position);
        }
        StepStats {
            asleep: self.sleepers.count,
            contacts: rows.touching as usize,
            plane_contacts: self.plane_rows.iter().filter(|r| r.touching).count(),
            velocity_iterations: solve.iterations,
            responses: solve.responses,
            collisions,
            capped: solve.capped,
            max_overlap,
        }
    }
}

/// Particles per parallel integration task (fixed, like [`crate::broadphase`]'s chunks).
const INTEGRATE_CHUNK: usize = 4096;

impl<V: Vector> World<V> {
    /// A builder with default settings (dt 0.005, no gravity, k = 1, grid broad phase).
    pub fn builder() -> WorldBuilder<V> {
        WorldBuilder::default()
    }

    /// Advances the world by one time step (see [`crate::step`]).
    pub fn step(&mut self) -> StepStats {
        step::advance(self)
    }

    /// Where the steps' wall-clock time went, phase by phase, since the world was built or
    /// [`World::reset_phase_times`] (see [`PhaseTimes`]).
    pub fn phase_times(&self) -> PhaseTimes {
        self.phase_times
    }

    /// Starts the phase times from zero (say, after a warm-up).
    pub fn reset_phase_times(&mut self) {
        self.phase_times = PhaseTimes::default();
    }

    fn parallel(&self) -> bool {
        self.store.len() >= PARALLEL_MIN
    }

    /// Every (slot, plane) with the particle within reach of the plane, sorted.
    fn find_plane_contacts(&mut self, parallel: bool) {
        self.plane_contacts.clear();
        if self.planes.is_empty() {
            return;
        }
        let n = self.store.len();
        let chunks = n.div_ceil(INTEGRATE_CHUNK);
        if self.plane_buffers.len() < chunks {
            self.plane_buffers.resize_with(chunks, Vec::new);
        }
        let (position, reach, planes) = (&self.store.position, &self.reach, &self.planes);
        let radius = &self.store.radius;
        let in_move = (self.config.solver_settings()).planes_in_move(planes, self.config.gravity);
        let sleepers = &self.sleepers;
        let work = |(c, out): (usize, &mut Vec<PlaneContact>)| {
            out.clear();
            for i in c * INTEGRATE_CHUNK..((c + 1) * INTEGRATE_CHUNK).min(n) {
                if sleepers.sleeps(i) {
                    continue;
                }
                for (p, plane) in planes.iter().enumerate() {
                    if plane.signed_distance(position[i])
                        < solver::plane_reach(reach[i], radius[i], in_move)
                    {
                        out.push((i as u32, p as u32));
                    }
                }
            }
            keep_headroom(out);
        };
        if parallel {
            self.plane_buffers[..chunks]
                .par_iter_mut()
                .enumerate()
                .for_each(work);
        } else {
            self.plane_buffers[..chunks]
                .iter_mut()
                .enumerate()
                .for_each(work);
        }
        for b in &self.plane_buffers[..chunks] {
            self.plane_contacts.extend_from_slice(b);
        }
        keep_headroom(&mut self.plane_contacts);
    }

    /// Marks this step's sleepers (see [`crate::sleep`]), stops them, and drops the contacts
    /// between two of them from this step's candidates; keeps the positions the step starts
    /// from.
    fn mark_sleepers(&mut self, time: f64) {
        let asleep = self.sleepers.mark(&self.pairs, &self.rest, time);
        self.start.clear();
        self.start.extend_from_slice(&self.store.position);
        self.asleep_overlap = 0.0;
        if asleep == 0 {
            return;
        }
        let (sleepers, p) = (&self.sleepers, &self.store);
        // (measured here, as the position phase measures the awake ones)
        for &(i, j) in &self.pairs {
            let (i, j) = (i as usize, j as usize);
            if sleepers.sleeps(i) && sleepers.sleeps(j) {
                let (ri, rj) = (p.radius[i], p.radius[j]);
                let (xi, mut xj) = (p.position[i], p.position[j]);
                if let Some(q) = &self.periodic {
                    xj = q.image(xi, xj);
                }
                let distance = (xi - xj).length_squared().sqrt();
                let overlap = (ri + rj - distance) / ri.min(rj);
                self.asleep_overlap = self.asleep_overlap.max(overlap);
            }
        }
        for (slot, v) in self.store.velocity.iter_mut().enumerate() {
            if sleepers.sleeps(slot) {
                *v = V::ZERO;
            }
        }
        // (a pair with one particle awake stays: the sleeper is a fixed obstacle in it)
        self.pairs
            .retain(|&(i, j)| !(sleepers.sleeps(i as usize) && sleepers.sleeps(j as usize)));
    }

    /// True when particles may sleep and every particle has rested long enough and stands still:
    /// this step then finds the whole world asleep and nothing moves, so the spatial sort is
    /// skipped (it was the only cost of a sleeping world: 3 us a step for the lecture pile,
    /// 0.01 us without). A function of the state alone, so a resumed run skips it too.
    pub(crate) fn sleeps_whole(&self) -> bool {
        // (a world that slept whole through the last step is still: the test is then true,
        // and costs nothing)
        if self.all_asleep {
            return true;
        }
        match self.config.sleep_settings(&self.planes) {
            Some(settings) => sleep::all_still(&self.rest, &self.store.velocity, settings.time),
            None => false,
        }
    }

    /// Wakes every particle: the next step starts with nobody asleep and every rest time at zero.
    fn wake_everything(&mut self) {
        self.rest.fill(0.0);
        self.sleepers.wake_all();
        self.all_asleep = false;
        self.asleep_overlap = 0.0;
    }

    /// Particles asleep in the last step (see [`crate::sleep`]).
    pub fn asleep(&self) -> usize {
        self.sleepers.count
    }

    /// This step's contacts, for the solver.
    fn contacts_mut(&mut self) -> (Contacts<'_, V>, &mut Particles<V>, &Sleepers) {
        self.stamps.resize(self.store.len(), 0);
        (
            Contacts {
                pairs: &self.pairs,
                rows: &mut self.rows,
                plane_contacts: &self.plane_contacts,
                plane_rows: &mut self.plane_rows,
                planes: &self.planes,
                blocks: &self.blocks,
                work: WorkList {
                    stamps: &mut self.stamps,
                    clock: &mut self.clock,
                },
            },
            &mut self.store,
            &self.sleepers,
        )
    }

    /// The particles, in id order.
    ///
    /// The engine stores them sorted along space; this is an id-ordered copy, made on the first
    /// call after a step and kept until the next step. For single values without the copy, use
    /// [`World::particle`].
    pub fn particles(&self) -> &Particles<V> {
        self.by_id.get_or_init(|| {
            let mut p = Particles::new();
            for id in 0..self.store.len() {
                let s = self.slots[id] as usize;
                p.position.push(self.store.position[s]);
                p.velocity.push(self.store.velocity[s]);
                p.radius.push(self.store.radius[s]);
                p.mass.push(self.store.mass[s]);
            }
            p
        })
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.store.len()
    }

    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.store.is_empty()
    }

    /// One particle's state by id: `(position, velocity, radius, mass)`.
    pub fn particle(&self, id: usize) -> (V, V, f64, f64) {
        let s = self.slots[id] as usize;
        (
            self.store.position[s],
            self.store.velocity[s],
            self.store.radius[s],
            self.store.mass[s],
        )
    }

    /// Sets particle `id`'s velocity (for interactive tools). Must be finite.
    pub fn set_velocity(&mut self, id: usize, velocity: V) -> Result<(), EngineError> {
        if !velocity.is_finite_vector() {
            return Err(EngineError::ParticleNotFinite(id));
        }
        self.by_id.take();
        let s = self.slots[id] as usize;
        self.store.velocity[s] = velocity;
        // (a push wakes the particle, and with it its neighbours at the next step)
        self.rest[s] = 0.0;
        self.all_asleep = false;
        Ok(())
    }

    /// All planes, including domain walls.
    pub fn planes(&self) -> &[Plane<V>] {
        &self.planes
    }

    /// The settings.
    pub fn config(&self) -> &WorldConfig<V> {
        &self.config
    }

    /// Replaces the state with `snapshot` (same particle count; the settings and planes stay):
    /// stepping on then gives the very bits the run the snapshot came from gives.
    pub fn restore(&mut self, snapshot: Snapshot<V>) -> Result<(), EngineError> {
        let Snapshot {
            steps_taken,
            storage_order,
            particles,
            impulses,
        } = snapshot;
        let n = self.store.len();
        if particles.len() != n || storage_order.len() != n {
            return Err(EngineError::StorageOrder);
        }
        let mut slots = vec![u32::MAX; n];
        for (slot, &id) in storage_order.iter().enumerate() {
            match slots.get_mut(id as usize) {
                Some(s) if *s == u32::MAX => *s = slot as u32,
                _ => return Err(EngineError::StorageOrder),
            }
        }
        if !memory::is_valid(&impulses, n, self.planes.len()) {
            return Err(EngineError::ContactImpulses);
        }
        self.memory = Memory::from_ids(&impulses, &slots);
        self.rest = if impulses.rest.is_empty() {
            vec![0.0; n]
        } else {
            storage_order
                .iter()
                .map(|&id| impulses.rest[id as usize])
                .collect()
        };
        self.sleepers.wake_all();
        self.all_asleep = false;
        for (slot, &id) in storage_order.iter().enumerate() {
            let id = id as usize;
            self.store.position[slot] = particles.position[id];
            self.store.velocity[slot] = particles.velocity[id];
            self.store.radius[slot] = particles.radius[id];
            self.store.mass[slot] = particles.mass[id];
        }
        self.ids = storage_order;
        self.slots = slots;
        self.steps = steps_taken;
        self.by_id = OnceCell::from(particles);
        self.contacts_by_id.take();
        self.pairs.clear();
        self.rows.clear();
        Ok(())
    }

    /// Ids by storage slot as the next spatial sort will leave them (when the next step sorts;
    /// see [`REORDER_INTERVAL`]), without sorting.
    pub(crate) fn next_sort_order(&self) -> Vec<u32> {
        if self.store.is_empty() {
            return Vec::new();
        }
        let mut sorter = Sorter::default();
        sorter.plan(&self.store, &self.slots, self.config.domain);
        sorter.order.iter().map(|&s| self.ids[s as usize]).collect()
    }

    /// Ids by storage slot: what [`WorldBuilder::resume`] needs to continue this run exactly.
    pub fn storage_order(&self) -> &[u32] {
        &self.ids
    }

    /// The resting contacts' accumulated impulses from the last step, by id: what
    /// [`WorldBuilder::impulses`] needs to continue this run exactly.
    pub fn contact_impulses(&self) -> ContactImpulses {
        let mut out = self.memory.by_id(&self.ids);
        if self.rest.iter().any(|&t| t > 0.0) {
            out.rest = (0..self.store.len())
                .map(|id| self.rest[self.slots[id] as usize])
                .collect();
        }
        out
    }

    /// Steps taken so far.
    pub fn steps_taken(&self) -> u64 {
        self.steps
    }

    /// Simulated time so far (`steps * dt`).
    pub fn time(&self) -> f64 {
        self.steps as f64 * self.config.dt
    }

    /// The last step's overlapping pairs (the lecture's detection at the start of its velocity
    /// phase), as ids `(a, b)` with `a < b`, sorted. Pairs of sleepers are not searched while
    /// they sleep: for them, the resting contacts they remember (those carrying an impulse, see
    /// [`World::contact_impulses`]) that overlap now.
    pub fn contacts(&self) -> &[Pair] {
        self.contacts_by_id.get_or_init(|| {
            let by_id = |i: u32, j: u32| {
                let (a, b) = (self.ids[i as usize], self.ids[j as usize]);
                (a.min(b), a.max(b))
            };
            let mut c: Vec<Pair> = self
                .pairs
                .iter()
                .zip(&self.rows)
                .filter(|(_, row)| row.touching)
                .map(|(&(i, j), _)| by_id(i, j))
                .collect();
            let asleep = |i: u32| self.all_asleep || self.sleepers.sleeps(i as usize);
            let p = &self.store;
            let overlap = |i: usize, j: usize| {
                let (xi, xj) = (p.position[i], p.position[j]);
                let xj = self.periodic.as_ref().map_or(xj, |w| w.image(xi, xj));
                xi != xj && crate::response::is_overlapping(xi, xj, p.radius[i], p.radius[j])
            };
            c.extend(
                self.memory
                    .pairs
                    .iter()
                    .filter(|&&(i, j, _)| asleep(i) && asleep(j))
                    .filter(|&&(i, j, _)| overlap(i as usize, j as usize))
                    .map(|&(i, j, _)| by_id(i, j)),
            );
            c.sort_unstable();
            c.dedup();
            c
        })
    }

    /// Name of the broad phase in use.
    pub fn broad_phase_name(&self) -> &'static str {
        self.broad_phase.name()
    }

    /// Grid cells per axis in use (after the first step), if the broad phase is a grid.
    pub fn grid_cells(&self) -> Option<[usize; 3]> {
        self.broad_phase.cells()
    }

    /// Total kinetic energy, summed in id order.
    pub fn kinetic_energy(&self) -> f64 {
        diagnostics::kinetic_energy(self.particles())
    }

    /// Gravitational potential energy (zero at the origin), summed in id order.
    pub fn potential_energy(&self) -> f64 {
        diagnostics::potential_energy(self.particles(), self.config.gravity)
    }

    /// Total momentum, summed in id order.
    pub fn momentum(&self) -> V {
        diagnostics::momentum(self.particles())
    }

    /// The observables now (see [`crate::observe`]), with the pressure over the interval since
    /// the previous call, which this call closes. The first call starts the sums (collisions
    /// count from it; its pressure is the kinetic part alone).
    pub fn observe(&mut self) -> Observables {
        let max_overlap = match self.last_overlap {
            Some(overlap) => overlap,
            None => self.overlap_now(),
        };
        let volume = self
            .config
            .domain
            .map(|d| (0..V::DIM).map(|a| d.extent().get(a)).product());
        let thermal = observe::thermal_sum(&self.store.mass, &self.store.velocity);
        let reading = Observables {
            step: self.steps,
            time: self.time(),
            kinetic_energy: self.kinetic_energy(),
            potential_energy: self.potential_energy(),
            temperature: observe::temperature(self.particles()),
            collisions: self.tally.collisions,
            pressure: self.tally.pressure(thermal, V::DIM, volume),
            max_overlap,
        };
        self.tally.restart();
        reading
    }

    /// The observables' running sums: what [`WorldBuilder::tally`] needs to continue a run.
    pub fn tally(&self) -> Tally {
        self.tally
    }

    /// The deepest overlap among the particles as they are, by a search of its own (before
    /// the first step, which measures it as it goes).
    fn overlap_now(&mut self) -> f64 {
        let mut pairs = Vec::new();
        self.broad_phase
            .find_pairs(&self.store.position, &self.store.radius, &mut pairs);
        let (p, periodic) = (&self.store, &self.periodic);
        pairs
            .iter()
            .map(|&(i, j)| {
                let (i, j) = (i as usize, j as usize);
                let reach = p.radius[i] + p.radius[j];
                let (xi, mut xj) = (p.position[i], p.position[j]);
                if let Some(periodic) = periodic {
                    xj = periodic.image(xi, xj);
                }
                let distance = (xi - xj).length_squared().sqrt();
                (reach - distance) / p.radius[i].min(p.radius[j])
            })
            .fold(0.0, f64::max)
    }

    /// Changes the particle-particle restitution.
    pub fn set_restitution(&mut self, k: f64) -> Result<(), EngineError> {
        check_restitution(k)?;
        self.config.restitution = k;
        self.memory.clear();
        self.wake_everything();
        Ok(())
    }

    /// Changes gravity.
    pub fn set_gravity(&mut self, g: V) -> Result<(), EngineError> {
        if !g.is_finite_vector() {
            return Err(EngineError::NonFinite("gravity"));
        }
        self.config.gravity = g;
        self.memory.clear();
        self.wake_everything();
        Ok(())
    }

    /// Changes the time step.
    pub fn set_dt(&mut self, dt: f64) -> Result<(), EngineError> {
        check_dt(dt)?;
        self.config.dt = dt;
        self.memory.clear();
        self.wake_everything();
        Ok(())
    }

    /// A 64-bit FNV-1a hash of every position and velocity bit pattern, in id order: equal
    /// hashes mean (with overwhelming likelihood) bit-identical states.
    pub fn state_hash(&self) -> u64 {
        let mut h = FnvHasher::default();
        for id in 0..self.store.len() {
            let s = self.slots[id] as usize;
            let (x, v) = (self.store.position[s], self.store.velocity[s]);
            for a in 0..V::DIM {
                h.write(&x.get(a).to_bits().to_le_bytes());
                h.write(&v.get(a).to_bits().to_le_bytes());
            }
        }
        h.finish()
    }
}
