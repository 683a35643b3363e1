//! One rank's part in each phase of a step (see [`crate::step`]).

use crate::cluster::lender::Lender;
use crate::cluster::traffic::Link;
use crate::cluster::transport::Transport;
use crate::diagnostics::StepStats;
use crate::frontier::Stamps;
use crate::memory::Memory;
use crate::particles::Particles;
use crate::schedule::Exchange;
use crate::sleep;
use crate::solver::{self, Contacts, Moving, VelocitySolve, WorkList};
use crate::step::Phases;
use crate::timing::PhaseTimes;
use crate::vector::Vector;
use crate::world::REORDER_INTERVAL;

use super::*;

/// A subdomain stepping with its link to the other ranks: what [`step::advance`] drives.
pub(super) struct Stepping<'s, 'l, 't, V: Vector, T: ?Sized> {
    pub(super) sub: &'s mut Subdomain<V>,
    pub(super) link: &'l mut Link<'t, T>,
}

impl<V: Vector, T: Transport + ?Sized> Stepping<'_, '_, '_, V, T> {
    /// Runs `phase` with this rank's exchange and contacts.
    fn solve<R>(
        &mut self,
        phase: impl FnOnce(&mut Lender<'_, '_, T, V>, &mut Particles<V>, &mut Contacts<'_, V>) -> R,
    ) -> R {
        let s = &mut *self.sub;
        let mut exchange = Lender {
            link: self.link,
            partition: &s.partition,
            rank: s.rank,
            first_slot: s.first_slot,
            own: s.own,
            needed: &s.needed,
            lent: &s.lent,
            lending: s.lending,
            leftovers: &mut s.leftovers,
        };
        let mut contacts = Contacts {
            pairs: &s.pairs,
            rows: s.rows.as_mut(),
            plane_contacts: &s.plane_contacts,
            plane_rows: &mut s.plane_rows,
            planes: &s.planes,
            // (split runs refuse periodic axes)
            period: [0.0; 3],
            blocks: &s.blocks,
            // (no work lists across processes: they would change the cost, not the result)
            work: WorkList {
                stamps: Stamps::none(),
                clock: &mut s.clock,
            },
        };
        phase(&mut exchange, &mut s.window, &mut contacts)
    }
}

impl<V: Vector, T: Transport + ?Sized> Phases for Stepping<'_, '_, '_, V, T> {
    fn sort_along_space(&mut self) {
        if self.sub.steps % REORDER_INTERVAL == 0 && !self.sub.sleeps_whole(self.link) {
            self.sub.migrate(self.link);
        }
    }

    fn find_contacts(&mut self) {
        self.sub.find_contacts(self.link);
    }

    fn integrate(&mut self) -> VelocitySolve {
        let settings = self.sub.config.solver_settings();
        let (gravity, dt) = (self.sub.config.gravity, self.sub.config.dt);
        let own = self.sub.own;
        // (taken out for the phase, which borrows the rest of the subdomain)
        let asleep = std::mem::take(&mut self.sub.sleepers.asleep);
        let sleepers = if self.sub.sleepers.count > 0 {
            &asleep[..]
        } else {
            &[]
        };
        let solve = self.solve(|exchange, window, contacts| {
            let moving = Moving {
                position: &mut window.position,
                velocity: &mut window.velocity,
                own,
                asleep: sleepers,
            };
            solver::integrate(exchange, &settings, gravity, dt, moving, contacts)
        });
        self.sub.sleepers.asleep = asleep;
        solve
    }

    fn separate(&mut self) -> f64 {
        let settings = self.sub.config.solver_settings();
        let sleeping = self.sub.config.sleep_settings(&self.sub.planes).is_some();
        let asleep_overlap = self.sub.asleep_overlap;
        let gravity = self.sub.config.gravity;
        self.solve(|exchange, window, contacts| {
            let awake = solver::separate(
                exchange,
                &settings,
                gravity,
                &mut window.position,
                &mut window.velocity,
                contacts,
            );
            if sleeping {
                awake.max(exchange.largest(asleep_overlap))
            } else {
                awake
            }
        })
    }

    fn remember(&mut self) {
        let s = &mut *self.sub;
        let sleepers = &s.sleepers;
        let sleeps = |slot: u32| sleepers.sleeps(slot as usize);
        // (a sleeper's contacts with other sleepers keep their impulses, as in `World`: merged in
        // order)
        s.kept_asleep.clear();
        if sleepers.count > 0 {
            s.kept_asleep.extend(
                s.memory
                    .pairs
                    .iter()
                    .zip(&s.memory_partners)
                    .filter(|(e, _)| sleeps(e.0))
                    .map(|(&e, &p)| (e, p)),
            );
        }
        s.memory.pairs.clear();
        s.memory_partners.clear();
        let mut kept = s.kept_asleep.iter().copied().peekable();
        for ((&(i, j), record), &partner) in s.pairs.iter().zip(&s.rows.record).zip(&s.partners) {
            while let Some((e, p)) = kept.next_if(|(e, _)| (e.0, e.1) < (i, j)) {
                s.memory.pairs.push(e);
                s.memory_partners.push(p);
            }
            // (a contact solved this step, with its sleeper fixed, remembers what it took)
            kept.next_if(|(e, _)| (e.0, e.1) == (i, j));
            if record.kept > 0.0 {
                s.memory.pairs.push((i, j, record.kept));
                s.memory_partners.push(partner);
            }
        }
        for (e, p) in kept {
            s.memory.pairs.push(e);
            s.memory_partners.push(p);
        }
        let plane_rows = &s.plane_rows;
        Memory::store_keeping_asleep(
            &mut s.memory.planes,
            &mut s.memory.scratch,
            &s.plane_contacts,
            |k| plane_rows[k].kept,
            |&(i, _, _)| sleeps(i),
        );
    }

    fn take_back_escapes(&mut self, tries: u32) -> bool {
        self.sub.take_back_escapes(self.link, tries)
    }

    fn times(&mut self) -> &mut PhaseTimes {
        &mut self.sub.phase_times
    }

    fn finish(&mut self, solve: VelocitySolve, max_overlap: f64) -> StepStats {
        let s = &mut *self.sub;
        s.steps += 1;
        let asleep = s.sleepers.flags();
        if let Some(settings) = s.config.sleep_settings(&s.planes) {
            sleep::update_rest(
                false,
                &s.start,
                &s.window.position[..s.own],
                asleep,
                &mut s.rest,
                &settings,
                s.config.dt,
            );
        }
        let rows = crate::solver::tally(&s.rows, s.blocks.parallel(), false);
        let on_planes = s.plane_rows.iter().filter(|r| r.touching).count() as u64;
        let counts = self.link.sum(&[
            rows.touching,
            on_planes,
            s.sleepers.count as u64,
            rows.collisions,
            rows.pushing,
        ]);
        StepStats {
            asleep: counts[2] as usize,
            contacts: counts[0] as usize,
            plane_contacts: counts[1] as usize,
            pushing: counts[4] as usize,
            velocity_iterations: solve.iterations,
            responses: solve.responses,
            collisions: counts[3],
            capped: solve.capped,
            max_overlap,
            found_overlap: self.link.largest(s.found_overlap),
            fastest_move: self.link.largest(s.fastest_move),
            retakes: 0,
        }
    }
}
