//! Resolving many simultaneous contacts: velocities first, then positions.
//!
//! Velocity phase (the lecture's response with its trap rule, "solution 2"): sweep the
//! contacts, responding to each one that is still approaching; repeat until a sweep responds
//! to nothing or the iteration cap is hit. Each response conserves momentum, and kinetic
//! energy when `k = 1`, so the sweep does too whatever the cap.
//!
//! Position phase (the lecture's "solution 1", which it calls hard with many contacts): move
//! overlapping particles apart along their normal, each by its share of inverse mass, down to
//! a small slop, and push particles out of planes. Positions only: velocities are never
//! touched, so this can never add kinetic energy. Planes go last so a walled box holds its
//! particles.
//!
//! ## Order, determinism and parallelism
//!
//! Particles live in *storage slots* (the world keeps them sorted along space, see
//! [`crate::world`]); contacts are pairs of slots `(i, j)`, `i < j`, sorted. Slots are cut into
//! blocks of `size`; a contact belongs to the block of its `i`. A sweep runs
//!
//! 1. the even blocks, each with the slots of itself and the next block (pairwise disjoint, so
//!    they run in parallel), taking the contacts whose `j` lies in those two blocks;
//! 2. the odd blocks, the same way;
//! 3. the leftover contacts (those whose `j` lies further away), one after another;
//! 4. the plane contacts, block by block (one particle is never in two blocks).
//!
//! Inside a block, contacts go in sorted order. So the order of every response is fixed by the
//! contact set and the slots alone: the same for any thread count, and the same whichever broad
//! phase found the contacts. Running the blocks serially gives the very same bits.
//!
//! The same order runs across processes ([`crate::cluster`]): each process holds a run of
//! whole blocks, and an `Exchange` lends it the particles of the next process's first block
//! that its border block pair touches, runs the leftovers in their global order and adds up
//! the counts that decide when a phase stops. Alone in one process, `Alone` does none of that.

use crate::broadphase::Pair;
use crate::plane::Plane;
use crate::response::{collide, contact_normal};
use crate::vector::Vector;
use rayon::prelude::*;

/// A particle touching a plane: `(slot, plane index)`.
pub type PlaneContact = (u32, u32);

/// The position phase leaves overlapping pairs this fraction of the smaller radius deep, so a
/// resting contact is still detected (`distance < r1 + r2`) on the next step instead of
/// dropping out of the contact list and letting a stack sink. (Box2D's "linear slop" plays
/// the same role.)
pub const SLOP_FRACTION: f64 = 1e-3;

/// Approaches slower than this fraction of the particles' speeds are rounding residue, not
/// approaches: after a `k = 0` response the relative normal speed is zero only up to rounding.
const APPROACH_TOLERANCE: f64 = 1e-12;

/// What the velocity phase did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VelocitySolve {
    /// Sweeps made (1 when nothing was approaching).
    pub iterations: u32,
    /// Responses applied, particle-particle and particle-plane.
    pub responses: u64,
    /// True when the last sweep still found approaching contacts (the cap was hit).
    pub capped: bool,
}

/// How contacts are split into blocks for one step.
#[derive(Debug, Default)]
pub(crate) struct Blocks {
    /// Slots per block (> 0).
    pub size: usize,
    /// `pairs[pair_start[b]..pair_start[b + 1]]` are block `b`'s contacts.
    pair_start: Vec<usize>,
    /// The same for plane contacts.
    plane_start: Vec<usize>,
    /// Contacts whose `j` is beyond the next block, in sorted order.
    pub(crate) leftovers: Vec<Pair>,
    /// Global index of block 0 (non-zero when this process holds a later run of blocks): the
    /// even/odd split goes by global block index.
    first_block: usize,
    /// Run blocks on the thread pool (otherwise serially; same result).
    parallel: bool,
}

impl Blocks {
    /// Splits this step's contacts; `pairs` and `plane_contacts` must be sorted. Slot 0 here
    /// is the first slot of global block `first_block`.
    pub fn plan(
        &mut self,
        n: usize,
        size: usize,
        pairs: &[Pair],
        plane_contacts: &[PlaneContact],
        parallel: bool,
        first_block: usize,
    ) {
        self.size = size.max(1);
        self.parallel = parallel;
        self.first_block = first_block;
        let count = n.div_ceil(self.size).max(1);
        let size = self.size;
        self.pair_start.clear();
        self.plane_start.clear();
        for b in 0..=count {
            let first_slot = (b * size) as u32;
            self.pair_start
                .push(pairs.partition_point(|&(i, _)| i < first_slot));
            self.plane_start
                .push(plane_contacts.partition_point(|&(i, _)| i < first_slot));
        }
        self.leftovers.clear();
        for b in 0..count {
            let limit = ((b + 2) * size) as u32;
            for &(i, j) in &pairs[self.pair_start[b]..self.pair_start[b + 1]] {
                if j >= limit {
                    self.leftovers.push((i, j));
                }
            }
        }
    }

    /// Runs `work(block, first_slot, slots)` on every block of one global parity, each given
    /// the slots of itself and the next block, and adds up what they return.
    fn run_pairs<T, F>(&self, data: &mut [T], global_parity: usize, work: F) -> u64
    where
        T: Send,
        F: Fn(usize, usize, &mut [T]) -> u64 + Sync,
    {
        let size = self.size;
        let parity = (global_parity + self.first_block) % 2;
        let skip = (parity * size).min(data.len());
        let rest = &mut data[skip..];
        let task = |(k, chunk): (usize, &mut [T])| work(parity + 2 * k, skip + 2 * k * size, chunk);
        if self.parallel {
            rest.par_chunks_mut(2 * size).enumerate().map(task).sum()
        } else {
            rest.chunks_mut(2 * size).enumerate().map(task).sum()
        }
    }

    /// One sweep over every pair, in the fixed order: the even blocks, then the odd blocks (each
    /// set in parallel), then the leftovers one after another. `rule(body(i), body(j),
    /// &mut data[i], &mut data[j])` says whether it changed anything. Returns how many did, as
    /// (this process's blocks, all leftovers). `reverse` walks each block's pairs backwards (the
    /// leftovers always go forwards).
    fn sweep_pairs<V, E, B, R>(
        &self,
        exchange: &mut E,
        data: &mut [V],
        pairs: &[Pair],
        reverse: bool,
        body: B,
        rule: R,
    ) -> (u64, u64)
    where
        V: Vector,
        E: Exchange<V>,
        B: Fn(usize) -> Body<V> + Sync,
        R: Fn(&Body<V>, &Body<V>, &mut V, &mut V) -> bool + Sync,
    {
        let in_block = |block: usize, base: usize, slots: &mut [V]| -> u64 {
            let limit = base + slots.len();
            let mut changed = 0;
            let mut one = |&(i, j): &Pair| {
                let (i, j) = (i as usize, j as usize);
                if j < limit {
                    // (the others are leftovers)
                    let (a, b) = pair_mut(slots, i - base, j - base);
                    changed += rule(&body(i), &body(j), a, b) as u64;
                }
            };
            let mine = &pairs[self.pair_start[block]..self.pair_start[block + 1]];
            if reverse {
                mine.iter().rev().for_each(&mut one);
            } else {
                mine.iter().for_each(&mut one);
            }
            changed
        };
        let mut changed = 0;
        for parity in 0..2 {
            exchange.before_blocks(parity, data);
            changed += self.run_pairs(data, parity, in_block);
            exchange.after_blocks(parity, data);
        }
        let leftovers = exchange.leftovers(self, data, &body, &rule);
        (changed, leftovers)
    }

    /// Runs `work(block, first_slot, slots)` on every block with its own slots.
    fn run_blocks<T, F>(&self, data: &mut [T], work: F) -> u64
    where
        T: Send,
        F: Fn(usize, usize, &mut [T]) -> u64 + Sync,
    {
        let size = self.size;
        let task = |(b, chunk): (usize, &mut [T])| work(b, b * size, chunk);
        if self.parallel {
            data.par_chunks_mut(size).enumerate().map(task).sum()
        } else {
            data.chunks_mut(size).enumerate().map(task).sum()
        }
    }
}

/// `&mut s[i]` and `&mut s[j]` at once, for `i < j`.
#[inline]
pub(crate) fn pair_mut<T>(s: &mut [T], i: usize, j: usize) -> (&mut T, &mut T) {
    let (head, tail) = s.split_at_mut(j);
    (&mut head[i], &mut tail[0])
}

/// The read-only facts of one particle that a pair rule reads.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Body<V> {
    /// Centre (in the position phase, where the positions are what changes, unused).
    pub position: V,
    /// Radius, > 0.
    pub radius: f64,
    /// Mass, > 0.
    pub mass: f64,
}

/// What one sweep needs from beyond this process's slots (see the module notes). Every method
/// is collective across processes: all of them make the same calls in the same order.
pub(crate) trait Exchange<V: Vector> {
    /// Before the blocks of global parity `parity` run on `data`.
    fn before_blocks(&mut self, parity: usize, data: &mut [V]);
    /// After the blocks of global parity `parity` ran on `data`.
    fn after_blocks(&mut self, parity: usize, data: &mut [V]);
    /// Runs every leftover pair (of every process) in global order and returns how many
    /// changed anything: the same number on every process.
    fn leftovers<B, R>(&mut self, blocks: &Blocks, data: &mut [V], body: &B, rule: &R) -> u64
    where
        B: Fn(usize) -> Body<V>,
        R: Fn(&Body<V>, &Body<V>, &mut V, &mut V) -> bool;
    /// `local` added up over every process.
    fn total(&mut self, local: u64) -> u64;
}

/// One process holding every slot: nothing to exchange.
pub(crate) struct Alone;

impl<V: Vector> Exchange<V> for Alone {
    #[inline]
    fn before_blocks(&mut self, _parity: usize, _data: &mut [V]) {}
    #[inline]
    fn after_blocks(&mut self, _parity: usize, _data: &mut [V]) {}
    fn leftovers<B, R>(&mut self, blocks: &Blocks, data: &mut [V], body: &B, rule: &R) -> u64
    where
        B: Fn(usize) -> Body<V>,
        R: Fn(&Body<V>, &Body<V>, &mut V, &mut V) -> bool,
    {
        let mut changed = 0;
        for &(i, j) in &blocks.leftovers {
            let (i, j) = (i as usize, j as usize);
            let (a, b) = pair_mut(data, i, j);
            changed += rule(&body(i), &body(j), a, b) as u64;
        }
        changed
    }
    #[inline]
    fn total(&mut self, local: u64) -> u64 {
        local
    }
}

/// Read-only particle data the phases need alongside the array they change.
pub(crate) struct Bodies<'a, V> {
    pub position: &'a [V],
    pub radius: &'a [f64],
    pub mass: &'a [f64],
}

/// Restitution to use for a contact approaching at `speed` (> 0) with nominal `k`: resting
/// contacts (slower than `resting_speed`) do not bounce unless `k = 1`, which keeps energy
/// exactly.
#[inline]
fn effective_restitution(k: f64, speed: f64, resting_speed: f64) -> f64 {
    if k < 1.0 && speed < resting_speed {
        0.0
    } else {
        k
    }
}

/// Responds to one pair if it is approaching; returns whether it did.
#[inline]
#[allow(clippy::too_many_arguments)]
fn respond_pair<V: Vector>(
    pi: V,
    pj: V,
    vi: &mut V,
    vj: &mut V,
    mi: f64,
    mj: f64,
    k: f64,
    resting_speed: f64,
) -> bool {
    let p_rel = pi - pj;
    let v_rel = *vi - *vj;
    let dot = p_rel.dot(v_rel);
    // The trap rule, p_rel . v_rel < 0, ignoring rounding residue.
    let scale = p_rel.length_squared() * (vi.length_squared() + vj.length_squared());
    if !(dot < 0.0 && dot * dot > APPROACH_TOLERANCE * APPROACH_TOLERANCE * scale) {
        return false;
    }
    let (normal, _) = contact_normal(pi, pj);
    let speed = -normal.dot(v_rel);
    let (a, b) = collide(
        normal,
        *vi,
        *vj,
        mi,
        mj,
        effective_restitution(k, speed, resting_speed),
    );
    *vi = a;
    *vj = b;
    true
}

/// Responds to one plane contact if the particle is heading in; returns whether it did.
#[inline]
fn respond_plane<V: Vector>(
    plane: &Plane<V>,
    x: V,
    v: &mut V,
    radius: f64,
    resting_speed: f64,
) -> bool {
    let heading = plane.normal().dot(*v);
    if !(plane.signed_distance(x) < radius
        && heading < 0.0
        && heading * heading > APPROACH_TOLERANCE * APPROACH_TOLERANCE * v.length_squared())
    {
        return false;
    }
    let k = effective_restitution(plane.restitution(), -heading, resting_speed);
    let parts = crate::response::split_normal_tangent(*v, plane.normal());
    *v = parts.tangent - parts.normal * k;
    true
}

/// Velocity phase. `restitution` is the particle-particle `k`; planes carry their own.
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_velocities<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    bodies: &Bodies<V>,
    velocity: &mut [V],
    pairs: &[Pair],
    plane_contacts: &[PlaneContact],
    planes: &[Plane<V>],
    blocks: &Blocks,
    restitution: f64,
    resting_speed: f64,
    max_iterations: u32,
) -> VelocitySolve {
    let Bodies {
        position,
        radius,
        mass,
    } = *bodies;
    let body = |i: usize| Body {
        position: position[i],
        radius: radius[i],
        mass: mass[i],
    };
    let respond = |a: &Body<V>, b: &Body<V>, vi: &mut V, vj: &mut V| {
        respond_pair(
            a.position,
            b.position,
            vi,
            vj,
            a.mass,
            b.mass,
            restitution,
            resting_speed,
        )
    };
    let block_planes = |block: usize, base: usize, v: &mut [V]| -> u64 {
        let mut responded = 0;
        for &(i, p) in &plane_contacts[blocks.plane_start[block]..blocks.plane_start[block + 1]] {
            let i = i as usize;
            responded += respond_plane(
                &planes[p as usize],
                position[i],
                &mut v[i - base],
                radius[i],
                resting_speed,
            ) as u64;
        }
        responded
    };

    let mut solve = VelocitySolve::default();
    while solve.iterations < max_iterations.max(1) {
        solve.iterations += 1;
        // Planes first: a floor's support then travels up a stack within one sweep.
        let on_planes = blocks.run_blocks(velocity, block_planes);
        // Alternate the direction within each block (symmetric Gauss-Seidel): support then
        // spreads both ways through a stack instead of one layer per sweep.
        let reverse = solve.iterations % 2 == 0;
        let (in_blocks, leftovers) =
            blocks.sweep_pairs(exchange, velocity, pairs, reverse, body, respond);
        let responded = exchange.total(on_planes + in_blocks) + leftovers;
        solve.responses += responded;
        if responded == 0 {
            return solve;
        }
    }
    solve.capped = true;
    solve
}

/// This step's contacts, planned into blocks.
pub(crate) struct Contacts<'a, V> {
    pub pairs: &'a [Pair],
    pub plane_contacts: &'a [PlaneContact],
    pub planes: &'a [Plane<V>],
    pub blocks: &'a Blocks,
}

/// One step's contact resolution with `config`'s settings: the velocity phase, then the
/// position phase.
pub(crate) fn resolve<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    config: &crate::world::WorldConfig<V>,
    particles: &mut crate::particles::Particles<V>,
    contacts: Contacts<V>,
) -> VelocitySolve {
    let crate::particles::Particles {
        position,
        velocity,
        radius,
        mass,
    } = particles;
    let Contacts {
        pairs,
        plane_contacts,
        planes,
        blocks,
    } = contacts;
    let solve = solve_velocities(
        exchange,
        &Bodies {
            position,
            radius,
            mass,
        },
        velocity,
        pairs,
        plane_contacts,
        planes,
        blocks,
        config.restitution,
        config.effective_resting_speed(),
        config.velocity_iterations,
    );
    separate(
        exchange,
        position,
        radius,
        mass,
        pairs,
        plane_contacts,
        planes,
        blocks,
        config.position_iterations,
    );
    solve
}

/// Moves one overlapping pair apart down to the slop; returns whether it moved them.
#[inline]
fn separate_pair<V: Vector>(xi: &mut V, xj: &mut V, ri: f64, rj: f64, mi: f64, mj: f64) -> bool {
    let (normal, distance) = contact_normal(*xi, *xj);
    let overlap = ri + rj - distance - SLOP_FRACTION * ri.min(rj);
    if overlap <= 0.0 {
        return false;
    }
    // Inverse-mass shares: the lighter particle moves further.
    let (wi, wj) = (1.0 / mi, 1.0 / mj);
    let share = overlap / (wi + wj);
    *xi += normal * (share * wi);
    *xj -= normal * (share * wj);
    true
}

/// Position phase: `iterations` sweeps over the pairs and plane contacts (in the same order
/// as the velocity phase), then every particle of a pair against every plane.
#[allow(clippy::too_many_arguments)]
pub(crate) fn separate<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    position: &mut [V],
    radius: &[f64],
    mass: &[f64],
    pairs: &[Pair],
    plane_contacts: &[PlaneContact],
    planes: &[Plane<V>],
    blocks: &Blocks,
    iterations: u32,
) {
    // The positions are what changes here, so a body's own position is not read.
    let body = |i: usize| Body {
        position: V::ZERO,
        radius: radius[i],
        mass: mass[i],
    };
    let push_apart = |a: &Body<V>, b: &Body<V>, xi: &mut V, xj: &mut V| {
        separate_pair(xi, xj, a.radius, b.radius, a.mass, b.mass)
    };
    let block_planes = |block: usize, base: usize, x: &mut [V]| -> u64 {
        let mut moved = 0;
        for &(i, p) in &plane_contacts[blocks.plane_start[block]..blocks.plane_start[block + 1]] {
            let i = i as usize;
            let before = x[i - base];
            x[i - base] = planes[p as usize].push_out(before, radius[i]);
            moved += (x[i - base] != before) as u64;
        }
        moved
    };
    for _ in 0..iterations {
        let (in_blocks, leftovers) =
            blocks.sweep_pairs(exchange, position, pairs, false, body, push_apart);
        let on_planes = blocks.run_blocks(position, block_planes);
        if exchange.total(in_blocks + on_planes) + leftovers == 0 {
            break;
        }
    }
    if planes.is_empty() {
        return;
    }
    // Planes last, for every particle the pair sweeps may have moved (the others moved only
    // out of their own planes above), so a walled box holds its particles.
    let out_of_all_planes = |x: &mut V, r: f64| {
        for plane in planes {
            *x = plane.push_out(*x, r);
        }
    };
    blocks.sweep_pairs(exchange, position, pairs, false, body, |a, b, xi, xj| {
        out_of_all_planes(xi, a.radius);
        out_of_all_planes(xj, b.radius);
        false
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    struct Two {
        position: Vec<DVec2>,
        velocity: Vec<DVec2>,
        radius: Vec<f64>,
        mass: Vec<f64>,
        blocks: Blocks,
    }

    fn two(p1: DVec2, v1: DVec2, p2: DVec2, v2: DVec2) -> Two {
        let mut blocks = Blocks::default();
        blocks.plan(2, 1024, &[(0, 1)], &[], false, 0);
        Two {
            position: vec![p1, p2],
            velocity: vec![v1, v2],
            radius: vec![1.0, 1.0],
            mass: vec![1.0, 3.0],
            blocks,
        }
    }

    impl Two {
        fn solve(&mut self, k: f64) -> VelocitySolve {
            let bodies = Bodies {
                position: &self.position,
                radius: &self.radius,
                mass: &self.mass,
            };
            solve_velocities(
                &mut Alone,
                &bodies,
                &mut self.velocity,
                &[(0, 1)],
                &[],
                &[],
                &self.blocks,
                k,
                0.0,
                8,
            )
        }
        fn separate(&mut self, iterations: u32) {
            separate(
                &mut Alone,
                &mut self.position,
                &self.radius,
                &self.mass,
                &[(0, 1)],
                &[],
                &[],
                &self.blocks,
                iterations,
            );
        }
    }

    #[test]
    fn overlapping_pair_moving_apart_is_left_alone() {
        let mut p = two(
            DVec2::ZERO,
            DVec2::new(-1.0, 0.0),
            DVec2::new(1.5, 0.0),
            DVec2::new(2.0, 0.0),
        );
        let before = p.velocity.clone();
        let s = p.solve(1.0);
        assert_eq!(s.responses, 0);
        assert_eq!(p.velocity, before);
    }

    #[test]
    fn approaching_pair_responds_once() {
        let mut p = two(
            DVec2::ZERO,
            DVec2::new(4.0, 0.0),
            DVec2::new(1.5, 0.0),
            DVec2::ZERO,
        );
        let s = p.solve(1.0);
        assert_eq!((s.responses, s.iterations, s.capped), (1, 2, false));
        assert!((p.velocity[0].x + 2.0).abs() < 1e-12);
        assert!((p.velocity[1].x - 2.0).abs() < 1e-12);
    }

    #[test]
    fn perfectly_inelastic_pair_settles_in_one_response() {
        let mut p = two(
            DVec2::ZERO,
            DVec2::new(4.0, 1.0),
            DVec2::new(1.5, 0.8),
            DVec2::new(-1.0, -2.0),
        );
        let s = p.solve(0.0);
        assert_eq!((s.responses, s.capped), (1, false));
    }

    #[test]
    fn separation_splits_by_inverse_mass_and_keeps_velocity() {
        let mut p = two(DVec2::ZERO, DVec2::X, DVec2::new(1.0, 0.0), DVec2::Y);
        p.separate(1);
        // overlap 1 (less the slop), masses 1 and 3: the light one moves 3/4, the heavy one 1/4
        let overlap = 1.0 - SLOP_FRACTION;
        assert!((p.position[0].x + 0.75 * overlap).abs() < 1e-12);
        assert!((p.position[1].x - 1.0 - 0.25 * overlap).abs() < 1e-12);
        assert_eq!(p.velocity, vec![DVec2::X, DVec2::Y]);
    }

    #[test]
    fn coincident_centres_separate_without_nan() {
        let mut p = two(DVec2::ONE, DVec2::ZERO, DVec2::ONE, DVec2::ZERO);
        p.solve(1.0);
        p.separate(4);
        assert!(p.position.iter().all(|x| x.is_finite()));
        assert!((p.position[0] - p.position[1]).length() >= 2.0 - 2.0 * SLOP_FRACTION);
    }

    #[test]
    fn slow_approach_does_not_bounce_below_k_1() {
        assert_eq!(effective_restitution(0.5, 0.01, 0.1), 0.0);
        assert_eq!(effective_restitution(0.5, 1.0, 0.1), 0.5);
        assert_eq!(
            effective_restitution(1.0, 0.01, 0.1),
            1.0,
            "k = 1 keeps energy exactly"
        );
    }
}
