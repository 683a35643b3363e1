//! One world's part in each phase of a step (see [`crate::step`]).

use super::*;
use crate::broadphase::{gather, keep_headroom, Pair, Raising, Still};
use crate::diagnostics::StepStats;
use crate::frontier::{self, Stamps};
use crate::memory::Memory;
use crate::observe;
use crate::particles::Particles;
use crate::periodic;
use crate::plane::plane_candidates;
use crate::schedule::{Alone, PlaneContact};
use crate::sleep::{self, Sleepers, Support};
use crate::solver::{self, Contacts, Moving, Row, VelocitySolve, WorkList};
use crate::step::Phases;
use crate::timing::PhaseTimes;
use crate::vector::Vector;
use rayon::prelude::*;
use std::time::Instant;

/// Particles per parallel integration task (fixed, like [`crate::broadphase`]'s chunks).
const INTEGRATE_CHUNK: usize = 4096;

impl<V: Vector> Phases for World<V> {
    fn sort_along_space(&mut self) {
        self.by_id.take();
        self.contacts_by_id.take();
        if self.steps % REORDER_INTERVAL != 0 || self.store.is_empty() || self.sleeps_whole() {
            return;
        }
        self.sorter.sort(
            &mut self.store,
            &mut self.ids,
            &mut self.rest,
            &mut self.slots,
            self.config.domain,
        );
        self.memory.remap(self.sorter.new_slot_of());
        // (the sleepers' marks, their pairs and the start positions are in the old slots)
        self.sleeping_pairs_hold = false;
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
            self.found_overlap = 0.0;
            self.fastest_move = 0.0;
            return;
        }
        if !self.retakes.begin_try() {
            let settings = self.config.solver_settings();
            let retakes =
                settings.retakes > 0 && solver::reach_covers_pushes(&settings, &self.planes);
            let p = &self.store;
            (self.step_start).keep(retakes, &p.position, &p.velocity, parallel);
        }
        let within_reach = self.find_pairs(parallel);
        self.phase_times.bin += self.broad_phase.take_bin_time();
        self.step_cells = self.broad_phase.cells();
        match sleep {
            Some(settings) => {
                // (rest times from the first step that may sleep on: see `World::rest`)
                self.rest.resize(self.store.len(), 0.0);
                self.mark_sleepers(settings.time, within_reach)
            }
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
        self.blocks.index_contacts(self.store.len(), &self.pairs);
        let rows_started = Instant::now();
        let p = &self.store;
        let periodic = self.periodic;
        let sleepers = &self.sleepers;
        // (a sleeper in a pair is a fixed obstacle: infinite mass)
        let mass = |i: usize| solver::moving_mass(p.mass[i], sleepers.sleeps(i));
        self.found_overlap =
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
        solver::prepare_plane_rows(
            &mut self.plane_rows,
            &self.plane_contacts,
            &self.planes,
            &p.position,
            &p.radius,
            dt,
        );
        self.memory.warm_rows(
            &self.pairs,
            &mut self.rows.row,
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
        let (records, sleepers) = (&self.rows.record, &self.sleepers);
        let memory = &mut self.memory;
        let sleeps = |slot: u32| sleepers.sleeps(slot as usize);
        Memory::store_keeping_asleep(
            &mut memory.pairs,
            &mut memory.scratch,
            &self.pairs,
            |k| records[k].kept,
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

    fn take_back_escapes(&mut self, tries: u32) -> bool {
        let retakes = self.config.retakes;
        if tries > retakes || self.all_asleep || self.step_start.position.is_empty() {
            return false;
        }
        let (parallel, p, n) = (self.parallel(), &self.store, self.store.len());
        let (start, reach, ids) = (&self.step_start.position, &self.reach, &self.ids);
        let particle = |s: usize| solver::Moved {
            id: ids[s],
            start: start[s],
            end: p.position[s],
            radius: p.radius[s],
            reach: reach[s],
        };
        let retakes = &mut self.retakes;
        retakes.collect(n, parallel, particle);
        if retakes.escapes.list.is_empty() {
            return false;
        }
        let max_radius = if parallel {
            p.radius.par_iter().copied().reduce(|| 0.0, f64::max)
        } else {
            p.radius.iter().copied().fold(0.0, f64::max)
        };
        retakes.escapes.index(max_radius, n, self.periodic);
        if retakes.escapes.strikes(&p.position, parallel, particle) == 0 {
            return false;
        }
        retakes.take_again(n);
        let p = &mut self.store;
        self.step_start.restore(&mut p.position, &mut p.velocity);
        // (the search looks everywhere again: this try's marks of who is still are its own)
        self.sleeping_pairs_hold = false;
        true
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
        let rows = solver::tally(&self.rows, self.parallel(), self.tally.observing);
        let (collisions, pushing, virial) = if self.all_asleep {
            (0, 0, 0.0)
        } else {
            (rows.collisions, rows.pushing, rows.virial)
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
        // Wrapped last: the rest times above compare where the step started and ended.
        if let (Some(p), false) = (&self.periodic, self.all_asleep) {
            periodic::wrap_all(p, self.parallel(), &mut self.store.position);
        }
        StepStats {
            asleep: self.sleepers.count,
            contacts: rows.touching as usize,
            plane_contacts: self.plane_rows.iter().filter(|r| r.touching).count(),
            pushing: pushing as usize,
            velocity_iterations: solve.iterations,
            responses: solve.responses,
            collisions,
            capped: solve.capped,
            max_overlap,
            found_overlap: self.found_overlap,
            fastest_move: self.fastest_move,
            retakes: 0,
        }
    }
}

impl<V: Vector> World<V> {
    /// This step's pairs within reach (see [`solver::reach`]), the reaches raised to the
    /// partners' speeds when contacts can rest or the lecture's step covers pushes (see
    /// [`solver::reach_covers_pushes`]); returns whether they are every pair within reach (the
    /// lecture's step otherwise keeps only those that close in).
    fn find_pairs(&mut self, parallel: bool) -> bool {
        let (dt, gravity) = (self.config.dt, self.config.gravity);
        let fall = gravity.length_squared().sqrt() * dt;
        let raises = solver::reach_covers_pushes(&self.config.solver_settings(), &self.planes);
        self.mark_still(parallel);
        self.fastest_move = self.measure_reaches(parallel, raises, fall, dt);
        if raises {
            self.retakes.raise(&mut self.reach, &self.store.radius);
        }
        let p = &self.store;
        let (position, radius) = (&p.position, &p.radius);
        let scratch = &mut self.sorter.scratch;
        let settings = self.config.solver_settings();
        match solver::LectureCandidates::new(&settings, &self.planes, gravity, dt) {
            None => {
                let raising = Raising {
                    speed: &self.speed,
                    radius_at: &|i, partner_speed| {
                        solver::reach(radius[i], partner_speed + fall, dt)
                    },
                    still: Still {
                        flags: &self.still,
                        pairs: &self.sleeping_pairs,
                    },
                };
                let (reach, raised) = (&self.reach, &mut self.raised);
                (self.broad_phase).find_pairs_raised_in(
                    position,
                    reach,
                    &raising,
                    raised,
                    &mut self.pairs,
                    scratch,
                );
                std::mem::swap(&mut self.reach, &mut self.raised);
                true
            }
            Some(lecture) => {
                let (periodic, velocity, reach) = (self.periodic, &p.velocity, &self.reach);
                let keeps = |(i, j): Pair| {
                    let (i, j) = (i as usize, j as usize);
                    let (xi, xj) = (position[i], position[j]);
                    let shift = periodic.map_or(V::ZERO, |q| q.shift(xi, xj));
                    let (dx, dv) = (xi - (xj + shift), velocity[i] - velocity[j]);
                    let (radii, reaches) = ([radius[i], radius[j]], [reach[i], reach[j]]);
                    lecture.keeps(dx, dv, [xi, xj], radii, reaches)
                };
                (self.broad_phase).find_pairs_kept_in(
                    position,
                    &self.reach,
                    &keeps,
                    &mut self.pairs,
                    scratch,
                    &mut self.pairs_kept,
                );
                false
            }
        }
    }

    /// Each particle's reach (see [`solver::reach_at`]) into `self.reach`, and its speed into
    /// `self.speed` when the search `raises` reaches (empty otherwise); returns the fastest
    /// move in radii (see `StepStats::fastest_move`).
    fn measure_reaches(&mut self, parallel: bool, raises: bool, fall: f64, dt: f64) -> f64 {
        let p = &self.store;
        self.reach.resize(p.len(), 0.0);
        self.speed.resize(if raises { p.len() } else { 0 }, 0.0);
        // (the speeds, when the search raises reaches, in the same pass: a square root per
        // particle instead of one per partner the search finds)
        let steps = (fall, dt);
        let (reach, speed) = (&mut self.reach[..], &mut self.speed[..]);
        if !parallel {
            let speed = raises.then_some(speed);
            return solver::reaches_of((&p.velocity, &p.radius), steps, reach, speed);
        }
        let particles =
            (p.velocity.par_chunks(INTEGRATE_CHUNK)).zip(p.radius.par_chunks(INTEGRATE_CHUNK));
        let reaches = reach.par_chunks_mut(INTEGRATE_CHUNK);
        if raises {
            let outs = reaches.zip(speed.par_chunks_mut(INTEGRATE_CHUNK));
            outs.zip(particles)
                .map(|((reach, speed), run)| solver::reaches_of(run, steps, reach, Some(speed)))
                .reduce(|| 0.0, f64::max)
        } else {
            reaches
                .zip(particles)
                .map(|(reach, run)| solver::reaches_of(run, steps, reach, None))
                .reduce(|| 0.0, f64::max)
        }
    }

    /// Marks the slots that slept through the last step and have not moved since its search
    /// (see [`Still`]): their reaches are no larger than then (at rest now), so the pairs
    /// among them are among that search's. None when those pairs were not kept.
    fn mark_still(&mut self, parallel: bool) {
        self.still.clear();
        let n = self.store.len();
        if !self.sleeping_pairs_hold || self.sleepers.count == 0 || self.start.len() != n {
            return;
        }
        let (p, asleep, start) = (&self.store, &self.sleepers.asleep, &self.start);
        let still = |s: usize| asleep[s] && p.velocity[s] == V::ZERO && p.position[s] == start[s];
        if parallel {
            (0..n)
                .into_par_iter()
                .map(still)
                .collect_into_vec(&mut self.still);
        } else {
            self.still.extend((0..n).map(still));
        }
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
        let sleepers = &self.sleepers;
        let plane_reach = |i: usize| solver::plane_reach(reach[i], radius[i]);
        let work = |(c, out): (usize, &mut Vec<PlaneContact>)| {
            out.clear();
            let chunk = c * INTEGRATE_CHUNK..((c + 1) * INTEGRATE_CHUNK).min(n);
            let skip = |i: usize| sleepers.sleeps(i);
            plane_candidates(
                planes,
                &position[chunk.clone()],
                chunk.start,
                plane_reach,
                skip,
                out,
            );
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
        gather(&self.plane_buffers[..chunks], &mut self.plane_contacts);
    }

    /// Marks this step's sleepers (see [`crate::sleep`]), stops them, and drops the contacts
    /// between two of them from this step's candidates; keeps the positions the step starts
    /// from.
    fn mark_sleepers(&mut self, time: f64, within_reach: bool) {
        let (p, planes, periodic) = (&self.store, &self.planes, self.periodic);
        let up = sleep::up(self.config.gravity);
        let on_plane = |s: usize| sleep::rests_on_plane(p.position[s], p.radius[s], planes, up);
        let pairs = &self.pairs;
        let in_pair = |k: usize| {
            let (i, j) = (pairs[k].0 as usize, pairs[k].1 as usize);
            let (xi, mut xj) = (p.position[i], p.position[j]);
            if let Some(q) = &periodic {
                xj = q.image(xi, xj);
            }
            sleep::rests_on(xi, xj, p.radius[i], p.radius[j], up)
        };
        let support = Support {
            on_plane: &on_plane,
            in_pair: &in_pair,
        };
        let asleep = self.sleepers.mark(&self.pairs, &self.rest, time, &support);
        self.start.clear();
        self.start.extend_from_slice(&self.store.position);
        self.asleep_overlap = 0.0;
        self.sleeping_pairs.clear();
        self.sleeping_pairs_hold = within_reach;
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
        // (a pair with one particle awake stays: the sleeper is a fixed obstacle in it; the
        // pairs of two sleepers are kept for the next step's search, see `World::mark_still`)
        let sleeping = &mut self.sleeping_pairs;
        self.pairs.retain(|&(i, j)| {
            let both = sleepers.sleeps(i as usize) && sleepers.sleeps(j as usize);
            if both && within_reach {
                sleeping.push((i, j));
            }
            !both
        });
        keep_headroom(sleeping);
    }

    /// This step's contacts, for the solver.
    fn contacts_mut(&mut self) -> (Contacts<'_, V>, &mut Particles<V>, &Sleepers) {
        let n = self.store.len();
        self.stamps.resize(n, 0);
        self.stamp_groups
            .resize(n.div_ceil(frontier::GROUP), Default::default());
        (
            Contacts {
                pairs: &self.pairs,
                rows: self.rows.as_mut(),
                plane_contacts: &self.plane_contacts,
                plane_rows: &mut self.plane_rows,
                planes: &self.planes,
                period: Periodic::periods(self.periodic.as_ref()),
                blocks: &self.blocks,
                work: WorkList {
                    stamps: Stamps::new(&mut self.stamps, &mut self.stamp_groups),
                    clock: &mut self.clock,
                },
            },
            &mut self.store,
            &self.sleepers,
        )
    }
}
