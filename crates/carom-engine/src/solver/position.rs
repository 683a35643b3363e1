//! The position phase (the lecture's "solution 1"): overlapping pairs moved apart, particles
//! pushed out of planes.

use super::{bounces::*, rows::*, rules::*, settings::*};
use crate::response::contact_normal;
use crate::schedule::{Change, Exchange};
use crate::vector::Vector;
use std::sync::atomic::{AtomicU64, Ordering};

/// True when centres `delta` apart are farther apart than `limit` by far more than rounding
/// (a relative 1e-9), told from the squared distance: most pairs of a step are, and the square
/// root and the division can then be skipped. Where it says true, the exact test (`limit -
/// distance <= 0` with `distance` the rounded root) says the same, so no result changes.
#[inline]
fn clearly_apart<V: Vector>(delta: V, limit: f64) -> bool {
    let widened = limit * (1.0 + 1e-9);
    delta.length_squared() > widened * widened
}

/// Moves one overlapping pair apart down to `depth` times the smaller radius.
#[inline]
pub(super) fn separate_pair<V: Vector>(
    record: &RowRecord,
    period: &[f64; 3],
    xi: &mut V,
    xj: &mut V,
    depth: f64,
) -> Change {
    // (moving `x_j` moves its image by as much)
    let image = record.image(*xj, period);
    if clearly_apart(*xi - image, record.reach() - depth * record.min_radius()) {
        return Change::Nothing;
    }
    let (normal, distance) = contact_normal(*xi, image);
    let overlap = record.reach() - distance - depth * record.min_radius();
    if overlap <= 0.0 || rounding(overlap, xi.length_squared() + xj.length_squared()) {
        return Change::Nothing;
    }
    // Inverse-mass shares: the lighter particle moves further.
    let [wi, wj] = record.inverse_mass();
    let share = overlap / (wi + wj);
    *xi += normal * (share * wi);
    *xj -= normal * (share * wj);
    Change::counted_if(overlap > POSITION_TOLERANCE * record.min_radius())
}

/// Position phase: sweeps over the pairs and plane contacts (in the same order as the velocity
/// phase) until nothing moves or the cap is hit, then every particle of a pair against every
/// plane. When planes bounce in the move, the lifts out of planes are paid for from the
/// particles' speeds (see [`keep_energy`]). Returns the largest overlap left, as a fraction of
/// the smaller radius.
pub(crate) fn separate<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    settings: &SolverSettings,
    gravity: V,
    position: &mut [V],
    velocity: &mut [V],
    c: &mut Contacts<V>,
) -> f64 {
    let (blocks, planes, period) = (c.blocks, c.planes, c.period);
    // Pairs are left the slop deep: with the lecture's rule alone, a contact is one while the
    // pair overlaps, so it is still detected on the next step. Resting contacts are left there
    // too: moving them apart to touching (c2096ba) made every contact of a jammed 3D pile a
    // target of every sweep, the sweeps stopped at the cap, and a pour of 10^5 spheres went on
    // sinking into itself (52 % of r deep at step 1600, 8000 spheres in a deep box 36 %; with
    // the slop left: 1.0 %). A stack sinks by the slop at each contact instead (0.1 % of r).
    let depth = SLOP_FRACTION;
    let push_apart = |_: &mut Row<V>, record: &mut RowRecord, xi: &mut V, xj: &mut V| {
        separate_pair(record, &period, xi, xj, depth)
    };
    let out_of_plane = |row: &mut PlaneRow<V>, x: &mut V| {
        let plane = &planes[row.plane as usize];
        let depth = row.radius - plane.signed_distance(*x);
        // (the dead band of `separate_pair`)
        if depth <= 0.0 || rounding(depth, x.length_squared()) {
            return Change::Nothing;
        }
        *x = plane.push_out(*x, row.radius);
        row.lift += depth;
        Change::counted_if(depth > POSITION_TOLERANCE * row.radius)
    };
    let mut visit = None;
    for _ in 0..settings.position_iterations {
        let this = c.work.next(visit);
        visit = Some(this);
        let (in_blocks, leftovers) = blocks.sweep_pairs(
            exchange,
            position,
            &mut c.work.stamps,
            this,
            c.pairs,
            c.rows.reborrow(),
            false,
            &push_apart,
        );
        let on_planes = blocks.run_planes(
            position,
            &mut c.work.stamps,
            this,
            c.plane_contacts,
            c.plane_rows,
            &out_of_plane,
        );
        if exchange.total(in_blocks + on_planes) + leftovers == 0 {
            break;
        }
    }
    let deepest = contain_and_measure(exchange, position, c);
    if settings.planes_in_move(planes, gravity) {
        keep_energy(velocity, c, gravity);
    }
    exchange.settle_rows(blocks, c.rows.reborrow());
    // (every process runs every leftover: the largest over the processes is over every row)
    exchange.largest(deepest)
}

/// Planes last, for every particle the pair sweeps may have moved (the others moved only out
/// of their own planes in the sweeps), so a walled box holds its particles; then each row's
/// overlap, measured. Returns the largest, as a fraction of the smaller radius.
///
/// (This pass reads every row's record and both its particles: it writes only what changes,
/// so the records and positions it leaves as they were need not go back to memory; like the
/// sweeps, it never reads the velocity part of a row.)
fn contain_and_measure<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    position: &mut [V],
    c: &mut Contacts<V>,
) -> f64 {
    let (planes, period) = (c.planes, c.period);
    let out_of_all_planes = |x: &mut V, r: f64| {
        for plane in planes {
            plane.push_out_in_place(x, r);
        }
    };
    // (the largest overlap, taken as the rows go: a pass of its own over the records took
    // 1.8-2.0 ms a step at 10^6 falling discs. A maximum is the same in any order; a non-negative
    // f64's bits order as it does, and the load first leaves the shared value to be read,
    // not written, once the largest is near)
    let deepest = AtomicU64::new(0);
    let finish = |_: &mut Row<V>, record: &mut RowRecord, xi: &mut V, xj: &mut V| {
        // (a sleeping particle, of infinite mass, stays where it sleeps)
        if !planes.is_empty() {
            if !record.sleeps(0) {
                out_of_all_planes(xi, record.radius[0]);
            }
            if !record.sleeps(1) {
                out_of_all_planes(xj, record.radius[1]);
            }
        }
        let image = record.image(*xj, &period);
        let overlap = if clearly_apart(*xi - image, record.reach()) {
            0.0
        } else {
            let (_, distance) = contact_normal(*xi, image);
            ((record.reach() - distance) / record.min_radius()).max(0.0)
        };
        if record.overlap.to_bits() != overlap.to_bits() {
            record.overlap = overlap;
        }
        if overlap > f64::from_bits(deepest.load(Ordering::Relaxed)) {
            deepest.fetch_max(overlap.to_bits(), Ordering::Relaxed);
        }
        Change::Nothing
    };
    (c.blocks).every_pair(exchange, position, c.pairs, c.rows.reborrow(), &finish);
    f64::from_bits(deepest.into_inner())
}
