//! Shock propagation: one sweep up a pile that holds each particle on the ones below it (see
//! the [module notes](super)).

use super::{rows::*, rules::*};
use crate::schedule::{Change, Exchange};
use crate::vector::Vector;

/// Shock propagation (Guendelman, Bridson and Fedkiw 2003), after relax sweeps that hit their
/// cap: one sweep in the fixed order (sorted by grid cell with the last axis slowest, so in 2D
/// under gravity along y it runs up a stack from its floor; in 3D, up each slab of cells) in
/// which a resting contact treats its lower particle as fixed and stops the upper one
/// approaching it. Planes go first. Support so reaches the top of a stack in one sweep instead
/// of the thousands a chain of a hundred takes with equal and opposite impulses. The impulse is
/// added to the contact's accumulated one, so the next step's warm start carries it.
pub(super) fn shock<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    velocity: &mut [V],
    c: &mut Contacts<V>,
    up: V,
    with_planes: bool,
) {
    if with_planes {
        let on_planes =
            |row: &mut PlaneRow<V>, v: &mut V| accumulate_plane(row, v, Pass::Relax, 0.0);
        c.blocks
            .every_plane(velocity, c.plane_contacts, c.plane_rows, &on_planes);
    }
    let pairs = |row: &mut Row<V>, record: &mut RowRecord, vi: &mut V, vj: &mut V| {
        if row.bounce > 0.0 {
            return Change::Nothing;
        }
        let height = row.normal.dot(up);
        // (a sleeping particle is fixed already: the rule for a pair holds it)
        let asleep = row.inverse_mass.contains(&0.0);
        if height.abs() < SHOCK_MIN_HEIGHT || asleep {
            return accumulate_pair(row, vi, vj, Pass::Relax, 0.0);
        }
        let vn = row.normal.dot(*vi - *vj);
        let short = -row.allowance - vn;
        if short <= 0.0 || rounding(short, vi.length_squared() + vj.length_squared()) {
            return Change::Nothing;
        }
        // (i above j: j holds and i takes the whole change; else the other way round)
        let [mi, mj] = record.mass;
        let impulse = if height > 0.0 {
            *vi += row.normal * short;
            short * mi
        } else {
            *vj -= row.normal * short;
            short * mj
        };
        row.met = true;
        row.impulse += impulse;
        row.delivered += impulse;
        Change::Counted
    };
    c.blocks
        .every_pair(exchange, velocity, c.pairs, c.rows.reborrow(), &pairs);
}

/// A contact whose normal is within this cosine of horizontal has no lower particle in a
/// shock sweep: it takes equal and opposite impulses as usual.
const SHOCK_MIN_HEIGHT: f64 = 0.1;
