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

mod builder;
mod config;
mod phases;
mod sorter;

use builder::check_dt;
pub use builder::WorldBuilder;
pub use config::WorldConfig;
pub(crate) use sorter::sort_layout;
use sorter::Sorter;

use crate::broadphase::{BroadPhase, Pair, PARALLEL_MIN};
use crate::diagnostics::{self, StepStats};
use crate::error::EngineError;
use crate::memory::{self, ContactImpulses, Memory};
use crate::observe::{self, Observables, Tally};
use crate::particles::Particles;
use crate::periodic::Periodic;
use crate::plane::{check_restitution, Plane};
use crate::schedule::{Blocks, PlaneContact};
use crate::sleep::{self, Sleepers};
use crate::solver::{PlaneRow, Rows};
use crate::step;
use crate::timing::PhaseTimes;
use crate::vector::Vector;
use fnv::FnvHasher;
use std::cell::OnceCell;
use std::hash::Hasher;

/// Default cap on velocity sweeps per step.
pub const DEFAULT_VELOCITY_ITERATIONS: u32 = 32;
/// Default position-correction sweeps per step: a cap (they stop once nothing moves). 8, not
/// 4, since steps are taken again when a push outruns a reach: over 47 fill seeds of the lecture
/// pile the deepest overlap at the end went from 1.418 to 1.019 % of r at worst, and of any
/// state from 3.019 to 2.923 % (docs/benchmarks.md, twenty-eighth sitting).
pub const DEFAULT_POSITION_ITERATIONS: u32 = 8;
/// Default substeps per step when contacts can rest (Box2D's default too).
pub const DEFAULT_SUBSTEPS: u32 = 4;
/// Default [`WorldConfig::retakes`].
pub const DEFAULT_RETAKES: u32 = 3;
/// Steps between two spatial sorts of the particle arrays.
pub const REORDER_INTERVAL: u64 = 32;
/// Smallest block of storage slots the solver hands to one task.
const MIN_BLOCK: usize = 1024;

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
    /// Each slot's reach this step: radius plus `min(|v| dt, radius)` (see
    /// [`crate::solver::raise_to_partners`] for when that speed is a partner's).
    reach: Vec<f64>,
    /// Where the search writes the reaches raised to the partners' speeds (see
    /// [`BroadPhase::find_pairs_raised_in`]); swapped with `reach` right after, so between
    /// searches it holds the step before's reaches, which nothing reads.
    raised: Vec<f64>,
    /// Each slot's speed this step, `|v|`, when the search raises reaches (see
    /// [`crate::Raising::speed`]); empty otherwise.
    speed: Vec<f64>,
    /// This step's contact candidates (pairs within reach; in the lecture's step, those of
    /// them that close in: see `solver::LectureCandidates`), as storage slots,
    /// sorted.
    pairs: Vec<Pair>,
    /// Scratch for [`crate::broadphase::retain_pairs`].
    pairs_kept: Vec<usize>,
    /// The solver's data for each pair.
    rows: Rows<V>,
    /// This step's particles within reach of a plane, sorted.
    plane_contacts: Vec<PlaneContact>,
    plane_rows: Vec<PlaneRow<V>>,
    plane_buffers: Vec<Vec<PlaneContact>>,
    /// Resting impulses kept from the last step.
    memory: Memory,
    /// How long each slot has rested (see [`crate::sleep`]); empty while every rest time is
    /// zero and particles cannot sleep (the gas of a lecture step never allocates it).
    rest: Vec<f64>,
    /// Who sleeps this step.
    sleepers: Sleepers,
    /// Positions at the start of the step (only when particles may sleep).
    start: Vec<V>,
    /// The last step's contact candidates of two sleepers, sorted (see [`crate::Still`]).
    sleeping_pairs: Vec<Pair>,
    /// Per slot, whether it slept through the last step and stands where it stood at its
    /// search, at rest (see [`crate::Still`]); empty when no slot does.
    still: Vec<bool>,
    /// Whether `sleeping_pairs` are every pair within reach of two of the last step's sleepers
    /// (the lecture's step keeps fewer), in the slots of now (no spatial sort since).
    sleeping_pairs_hold: bool,
    /// Every particle slept through the last step and nothing has woken any since: the next
    /// step would find them all asleep again, so it skips straight to the end.
    all_asleep: bool,
    /// The deepest overlap between sleeping particles (as in [`StepStats::max_overlap`]).
    asleep_overlap: f64,
    /// Where the steps' time went (see [`PhaseTimes`]).
    phase_times: PhaseTimes,
    blocks: Blocks,
    /// The work lists' stamps, one per slot, and their sweep clock (see [`crate::schedule`]).
    stamps: Vec<u32>,
    /// The stamps of each group of [`crate::frontier::GROUP`] slots.
    stamp_groups: Vec<crate::frontier::GroupStamps>,
    clock: u32,
    pub(crate) block_size: usize,
    sorter: Sorter,
    steps: u64,
    /// The observables' running sums (see [`crate::observe`]).
    tally: Tally,
    /// The grid cells the steps' search last laid out (`None` before the first search, and
    /// without a grid): what [`World::grid_cells`] reports, whatever a search between steps
    /// ([`World::deepest_overlap`]) laid out since.
    step_cells: Option<[usize; 3]>,
    /// This step's [`StepStats::found_overlap`].
    found_overlap: f64,
    /// What a step taken again needs (see `solver::escape`).
    retakes: crate::solver::Retakes<V>,
    step_start: crate::solver::StepStart<V>,
    /// This step's [`StepStats::fastest_move`].
    fastest_move: f64,
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
            Some(settings) => {
                // (no rest times yet: every one is zero)
                let rested = if self.rest.is_empty() {
                    0.0 >= settings.time
                } else {
                    true
                };
                rested && sleep::all_still(&self.rest, &self.store.velocity, settings.time)
            }
            None => false,
        }
    }

    /// Wakes every particle: the next step starts with nobody asleep and every rest time at zero.
    fn wake_everything(&mut self) {
        self.rest.fill(0.0);
        self.sleepers.wake_all();
        self.all_asleep = false;
        self.asleep_overlap = 0.0;
        self.sleeping_pairs_hold = false;
    }

    /// Particles asleep in the last step (see [`crate::sleep`]).
    pub fn asleep(&self) -> usize {
        self.sleepers.count
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
        if let Some(rest) = self.rest.get_mut(s) {
            *rest = 0.0;
        }
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
            Vec::new()
        } else {
            storage_order
                .iter()
                .map(|&id| impulses.rest[id as usize])
                .collect()
        };
        self.sleepers.wake_all();
        self.all_asleep = false;
        self.sleeping_pairs_hold = false;
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
        (sorter.scratch.order.iter())
            .map(|&s| self.ids[s as usize])
            .collect()
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
                .zip(&self.rows.row)
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

    /// Grid cells per axis as the last step's search laid them out, if the broad phase is a
    /// grid and a step has searched (a search between steps, such as
    /// [`World::deepest_overlap`]'s, which fits them to the radii alone, is not reported). Cells derived from the particles (no
    /// [`WorldConfig::grid_cells`]) are fitted to each step's reaches, so they may change from
    /// step to step.
    pub fn grid_cells(&self) -> Option<[usize; 3]> {
        self.step_cells
    }

    /// Total kinetic energy, summed in id order.
    pub fn kinetic_energy(&self) -> f64 {
        diagnostics::kinetic_energy_of(self.masses_by_id_with(&self.store.velocity))
    }

    /// Gravitational potential energy (zero at the origin), summed in id order.
    pub fn potential_energy(&self) -> f64 {
        diagnostics::potential_energy_of(
            self.masses_by_id_with(&self.store.position),
            self.config.gravity,
        )
    }

    /// Total momentum, summed in id order.
    pub fn momentum(&self) -> V {
        diagnostics::momentum_of(self.masses_by_id_with(&self.store.velocity))
    }

    /// Total mass, summed in id order.
    pub fn total_mass(&self) -> f64 {
        self.masses_by_id_with(&self.store.velocity)
            .map(|(m, _)| m)
            .sum()
    }

    /// Each particle's mass with its entry of `values` (a stored array), in id order: what
    /// the sums above read, without the id-ordered copy of [`World::particles`] (48 bytes a
    /// particle in 2D, which would otherwise be the largest thing a run allocates at its end).
    fn masses_by_id_with<'a>(&'a self, values: &'a [V]) -> impl Iterator<Item = (f64, V)> + 'a {
        let mass = &self.store.mass;
        self.slots_by_id().map(move |s| (mass[s], values[s]))
    }

    /// Each particle's storage slot, in id order.
    fn slots_by_id(&self) -> impl Iterator<Item = usize> + '_ {
        self.slots[..self.store.len()].iter().map(|&s| s as usize)
    }

    /// The observables now (see [`crate::observe`]), with the pressure over the interval since
    /// the previous call, which this call closes. The first call starts the sums (collisions
    /// count from it; its pressure is the kinetic part alone).
    pub fn observe(&mut self) -> Observables {
        // (over every pair: a step's own measure covers only its contact candidates, and a
        // pair that a collision pushed together from beyond them is found by the next step)
        let max_overlap = self.deepest_overlap();
        let volume = self
            .config
            .domain
            .map(|d| (0..V::DIM).map(|a| d.extent().get(a)).product());
        let thermal = observe::thermal_sum(&self.store.mass, &self.store.velocity);
        let p = &self.store;
        let by_id = || {
            self.slots_by_id()
                .map(|s| (p.mass[s], p.velocity[s], p.position[s]))
        };
        let (kinetic_energy, potential_energy, temperature) =
            observe::energies_and_temperature_of(by_id, self.config.gravity);
        let reading = Observables {
            step: self.steps,
            time: self.time(),
            kinetic_energy,
            potential_energy,
            temperature,
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

    /// The deepest particle-particle overlap among the particles as they are, over every pair
    /// (a search of its own), as a fraction of the smaller radius; 0 when nothing overlaps.
    ///
    /// A step measures its overlap as it goes ([`StepStats::max_overlap`]), but over its own
    /// contact candidates only: a pair that a push drove together from beyond their reach in
    /// the last step is found by the next step's search (see [`StepStats::found_overlap`]),
    /// and this one. Changes nothing in the world (the next step searches afresh).
    pub fn deepest_overlap(&mut self) -> f64 {
        let mut pairs = Vec::new();
        self.broad_phase.find_pairs_in(
            &self.store.position,
            &self.store.radius,
            &mut pairs,
            &mut self.sorter.scratch,
        );
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

#[cfg(test)]
mod tests;
