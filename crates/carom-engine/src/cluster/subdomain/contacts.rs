//! One rank's contact search: ghosts, candidates, who sleeps, rows and remembered impulses.

use crate::broadphase::{Pair, PARALLEL_MIN};
use crate::cluster::lender::{borrower, lender};
use crate::cluster::traffic::{Link, TrafficKind};
use crate::cluster::transport::Transport;
use crate::cluster::wire::{Reader, Writer};
use crate::grid::{bounding_box, largest, widened_reach};
use crate::plane::plane_candidates;
use crate::sleep;
use crate::solver::{self, Row};
use crate::vector::Vector;

use super::*;

impl<V: Vector> Subdomain<V> {
    /// Tells the next rank which of its first block's particles this step's contacts touch
    /// (only those travel in the sweeps), and learns which of its own the previous rank needs.
    pub(super) fn agree_on_borrowing<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        let (own, halo) = (self.own as u32, self.halo as u32);
        self.needed.clear();
        self.needed.extend(
            self.pairs
                .iter()
                .filter(|&&(_, j)| (own..own + halo).contains(&j))
                .map(|&(_, j)| j - own),
        );
        self.needed.sort_unstable();
        self.needed.dedup();
        let mut mine = Writer::default();
        for &k in &self.needed {
            mine.u32(k);
        }
        let lists = link.gather(TrafficKind::Halo, &mine.0);
        self.lending = [0, 1].map(|parity| {
            (0..self.partition.ranks())
                .any(|r| !lists[r].is_empty() && lender(&self.partition, r, Some(parity)).is_some())
        });
        self.lent.clear();
        if let Some(borrower) = borrower(&self.partition, self.rank, None) {
            let mut r = Reader::new(&lists[borrower]);
            while !r.is_empty() {
                self.lent.push(r.u32());
            }
        }
    }

    /// Sends this rank's box and largest reach, and its ghosts with their reach and speed, to
    /// the others, receives theirs, and finds the pairs among own and ghost particles within
    /// reach (`self.found`, in search indices).
    fn search_with_ghosts<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        let own = self.own;
        let max_reach = largest(&self.reach);
        // A particle j of another rank can reach an own one only from within the own bounding
        // box grown by this rank's largest reach plus j's rank's: each rank sends its box and
        // largest reach, and the others grow it by their own (widened against rounding).
        let mut mine = Writer::default();
        if own > 0 {
            let b = bounding_box(&self.window.position[..own]);
            mine.vector(b.min).vector(b.max).f64(max_reach);
        }
        let boxes = link.gather(TrafficKind::Ghosts, &mine.0);
        let mut outgoing: Vec<Writer> = (0..link.ranks()).map(|_| Writer::default()).collect();
        for (to, bytes) in boxes.iter().enumerate() {
            if to == self.rank || bytes.is_empty() || own == 0 {
                continue;
            }
            let mut r = Reader::new(bytes);
            let (min, max, reach): (V, V, f64) = (r.vector(), r.vector(), r.f64());
            let grow = reach + max_reach;
            let mut lo = [0.0; 3];
            let mut hi = [0.0; 3];
            for a in 0..V::DIM {
                lo[a] = min.get(a) - widened_reach(min.get(a), grow);
                hi[a] = max.get(a) + widened_reach(max.get(a), grow);
            }
            let w = &mut outgoing[to];
            for s in 0..own {
                let x = self.window.position[s];
                if (0..V::DIM).all(|a| x.get(a) >= lo[a] && x.get(a) <= hi[a]) {
                    w.u32((self.first_slot + s) as u32)
                        .u32(self.ids[s])
                        .vector(x)
                        .f64(self.reach[s])
                        .f64(self.window.radius[s])
                        .f64(self.window.mass[s])
                        .vector(self.window.velocity[s]);
                }
            }
        }
        let search = &mut self.search;
        search.clear();
        for s in 0..own {
            search.push(
                self.window.position[s],
                [self.reach[s], self.window.radius[s], self.window.mass[s]],
                self.window.velocity[s],
                self.ids[s],
            );
        }
        for bytes in link.exchange(TrafficKind::Ghosts, outgoing) {
            let mut r = Reader::new(&bytes);
            while !r.is_empty() {
                let (slot, id) = (r.u32(), r.u32());
                let (x, reach, radius, mass) = (r.vector(), r.f64(), r.f64(), r.f64());
                search.ghost_slot.push(slot);
                search.push(x, [reach, radius, mass], r.vector(), id);
            }
        }
        self.broad_phase
            .find_pairs(&search.position, &search.reach, &mut self.found);
    }

    /// Receives ghosts (the particles of other ranks within reach of own ones), runs the broad
    /// phase over own and ghost particles and keeps the candidates whose lower slot is own;
    /// then the own plane candidates, the rows, and the remembered impulses.
    pub(super) fn find_contacts<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        self.find_pairs(link);
        self.phase_times.bin += self.broad_phase.take_bin_time();
        self.mark_sleepers(link);
        self.find_plane_contacts();
        self.prepare_pair_rows();
        let (own, parallel) = (self.own, self.partition.slots() >= PARALLEL_MIN);
        self.agree_on_borrowing(link);
        self.blocks.plan(
            own + self.halo,
            self.partition.block(),
            &self.pairs,
            &self.plane_contacts,
            parallel,
            self.partition.blocks_of(self.rank).start,
        );
        if self.rerouting {
            self.place_arrived(link);
            self.rerouting = false;
        }
        self.memory.warm_rows(
            &self.pairs,
            &mut self.rows.row,
            &self.plane_contacts,
            &mut self.plane_rows,
        );
        self.leftovers.gather(
            link,
            self.first_slot,
            own,
            &self.blocks,
            &self.pairs,
            &self.rows,
        );
    }

    /// The reaches, the search with ghosts (raised and again, as a world's), and the
    /// candidates whose lower slot is own: `pairs` in slots, sorted, and each one's partner id.
    fn find_pairs<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        let own = self.own;
        let dt = self.config.dt;
        let fall = self.config.gravity.length_squared().sqrt() * dt;
        self.reach.clear();
        self.fastest_move = 0.0;
        for s in 0..own {
            let (v, r) = (self.window.velocity[s], self.window.radius[s]);
            let (reach, _, moves) = solver::reach_at(v, r, fall, dt);
            self.reach.push(reach);
            self.fastest_move = self.fastest_move.max(moves);
        }
        let settings = self.config.solver_settings();
        let raises = solver::reach_covers_pushes(&settings, &self.planes);
        // (as a world does: a step taken again reaches as far as its escapees went)
        self.retakes.begin_try();
        if raises {
            self.retakes.raise(&mut self.reach, &self.window.radius);
        }
        self.search_with_ghosts(link);
        // (as a world does: see `solver::raise_to_partners`; a ghost's velocity came with it,
        // and every rank searches again when any raised a reach)
        if raises {
            let search = &self.search;
            let speed = |k: usize| search.velocity[k].length_squared().sqrt();
            let (reach, radius, found) = (&mut self.reach, &search.radius, &self.found);
            let grew =
                solver::raise_to_partners(reach, radius, found, speed, |k| k < own, fall, dt);
            if link.sum(&[grew as u64])[0] > 0 {
                self.search_with_ghosts(link);
            }
        }
        let search = &self.search;
        let first = self.first_slot;
        // (as a world does: see `solver::LectureCandidates`)
        let gravity = self.config.gravity;
        let lecture = solver::LectureCandidates::new(&settings, &self.planes, gravity, dt);
        self.candidates.clear();
        for &(a, b) in &self.found {
            let (a, b) = (a as usize, b as usize);
            if let Some(lecture) = &lecture {
                let (x, v) = (&search.position, &search.velocity);
                let (dx, dv) = (x[a] - x[b], v[a] - v[b]);
                let radii = [search.radius[a], search.radius[b]];
                if !lecture.keeps(
                    dx,
                    dv,
                    [x[a], x[b]],
                    radii,
                    [search.reach[a], search.reach[b]],
                ) {
                    continue;
                }
            }
            let (sa, sb) = (search.slot(a, own, first), search.slot(b, own, first));
            let ((i, ki), (j, kj)) = if sa < sb {
                ((sa, a), (sb, b))
            } else {
                ((sb, b), (sa, a))
            };
            if (first..first + own).contains(&i) {
                self.candidates.push((
                    ((i - first) as u32, (j - first) as u32),
                    (ki as u32, kj as u32),
                ));
            }
        }
        self.candidates.sort_unstable_by_key(|c| c.0);
        self.pairs.clear();
        self.pairs.extend(self.candidates.iter().map(|c| c.0));
        self.partners.clear();
        self.partners
            .extend(self.candidates.iter().map(|c| search.id[c.1 .1 as usize]));
    }

    /// Own particles' plane candidates and their rows.
    fn find_plane_contacts(&mut self) {
        let (own, dt) = (self.own, self.config.dt);
        self.plane_contacts.clear();
        let (window, reach, sleepers) = (&self.window, &self.reach, &self.sleepers);
        plane_candidates(
            &self.planes,
            &window.position[..own],
            0,
            |s| solver::plane_reach(reach[s], window.radius[s]),
            |s| sleepers.sleeps(s),
            &mut self.plane_contacts,
        );
        solver::prepare_plane_rows(
            &mut self.plane_rows,
            &self.plane_contacts,
            &self.planes,
            &window.position,
            &window.radius,
            dt,
        );
    }

    /// A row per pair candidate, from the search's copies of both particles.
    fn prepare_pair_rows(&mut self) {
        let dt = self.config.dt;
        let candidates = &self.candidates;
        let (search, sleepers) = (&self.search, &self.sleepers);
        self.rows.clear();
        for &((i, j), (ki, kj)) in candidates {
            let (ki, kj) = (ki as usize, kj as usize);
            // (a sleeper in a pair is a fixed obstacle: infinite mass)
            let mass = |k: usize, slot: u32| {
                solver::moving_mass(search.mass[k], sleepers.sleeps(slot as usize))
            };
            self.rows.push(Row::new(
                search.position[ki],
                search.position[kj],
                search.radius[ki],
                search.radius[kj],
                mass(ki, i),
                mass(kj, j),
                dt,
            ));
        }
        self.rows.keep_headroom();
        self.found_overlap = solver::deepest_placed(&self.rows);
    }

    /// [`World::sleeps_whole`] over every rank. Collective (only when particles may sleep).
    pub(super) fn sleeps_whole<T: Transport + ?Sized>(&self, link: &mut Link<'_, T>) -> bool {
        let Some(settings) = self.config.sleep_settings(&self.planes) else {
            return false;
        };
        let own = self.own;
        let still = sleep::all_still(&self.rest, &self.window.velocity[..own], settings.time);
        let restless = u64::from(!still);
        self.partition.slots() > 0 && link.sum_of(TrafficKind::Sleep, &[restless])[0] == 0
    }

    /// [`World`]'s `mark_sleepers` for this rank's share: marks the sleeping own slots
    /// (collectively), stops them and drops their candidates; keeps the own positions the step
    /// starts from.
    pub(super) fn mark_sleepers<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        self.asleep_overlap = 0.0;
        let Some(settings) = self.config.sleep_settings(&self.planes) else {
            self.sleepers.count = 0;
            return;
        };
        let own = self.own;
        self.start.clear();
        self.start.extend_from_slice(&self.window.position[..own]);
        let up = sleep::up(self.config.gravity);
        let (search, planes, candidates) = (&self.search, &self.planes, &self.candidates);
        let on_plane =
            |s: usize| sleep::rests_on_plane(search.position[s], search.radius[s], planes, up);
        let in_pair = |k: usize| {
            let (ki, kj) = (candidates[k].1 .0 as usize, candidates[k].1 .1 as usize);
            let (xi, xj) = (search.position[ki], search.position[kj]);
            sleep::rests_on(xi, xj, search.radius[ki], search.radius[kj], up)
        };
        let support = sleep::Support {
            on_plane: &on_plane,
            in_pair: &in_pair,
        };
        let asleep = self.sleepers.mark(
            link,
            &self.partition,
            self.first_slot,
            &self.pairs,
            &self.rest,
            settings.time,
            &support,
        );
        if asleep == 0 {
            return;
        }
        let (sleepers, search) = (&self.sleepers, &self.search);
        for &((i, j), (ki, kj)) in &self.candidates {
            if sleepers.sleeps(i as usize) && sleepers.sleeps(j as usize) {
                let (ki, kj) = (ki as usize, kj as usize);
                let (ri, rj) = (search.radius[ki], search.radius[kj]);
                let distance = (search.position[ki] - search.position[kj])
                    .length_squared()
                    .sqrt();
                let overlap = (ri + rj - distance) / ri.min(rj);
                self.asleep_overlap = self.asleep_overlap.max(overlap);
            }
        }
        for (v, &sleeps) in self.window.velocity[..own].iter_mut().zip(&sleepers.asleep) {
            if sleeps {
                *v = V::ZERO;
            }
        }
        // (a pair with one particle awake stays: the sleeper is a fixed obstacle in it)
        let sleeps = |c: &(Pair, Pair)| {
            let (i, j) = c.0;
            sleepers.sleeps(i as usize) && sleepers.sleeps(j as usize)
        };
        let mut k = 0;
        self.partners.retain(|_| {
            k += 1;
            !sleeps(&self.candidates[k - 1])
        });
        self.candidates.retain(|c| !sleeps(c));
        self.pairs.clear();
        self.pairs.extend(self.candidates.iter().map(|c| c.0));
    }
}
