//! Shock propagation: one sweep up a pile that holds each particle on the ones below it (see
//! the [module notes](super)).

use super::{rows::*, rules::*};
use crate::schedule::{Change, Exchange};
use crate::vector::Vector;

/// Shock propagation (Guendelman, Bridson and Fedkiw 2003), after relax sweeps that hit their
/// cap: one sweep in slot order (sorted by grid cell with the last axis slowest, so under
/// gravity along that axis it runs up a pile from its floor, block after block: see
/// [`crate::schedule::Blocks::every_pair_in_order`]; under gravity across the blocks, in the
/// usual even/odd order) in which a resting contact treats its
/// lower particle as fixed and lifts the upper one, along `up`, just enough that it stops
/// approaching. Planes go first. Support so reaches the top of a pile in one sweep instead of
/// the thousands a chain of a hundred takes with equal and opposite impulses.
///
/// Why along `up` and not along the contact's normal: a disc resting on two below is held by
/// two contacts. Pushed along each normal in turn, it overshoots (by 1/8 of the fall per row of
/// a hexagonal pile), the overshoot lifts the row above by 9/8 of it, and a pile 600 rows tall
/// flew apart in its first step. Lifted along `up`, it moves as fast as its fastest support,
/// never faster, and no sideways motion is made.
///
/// The lift is a correction, not a force the contacts remember: it is not added to the
/// contact's accumulated impulse (the contacts the sweep leaves to equal and opposite impulses
/// accumulate theirs as usual) (warm starting it into the next step pushed the lower
/// particle down by what the sweep never took from it, and the 600 rows did not come to rest).
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
            return accumulate_pair(row, vi, vj, Pass::Relax, 0.0, 0.0);
        }
        let vn = row.normal.dot(*vi - *vj);
        let short = -row.allowance - vn;
        if short <= 0.0 || rounding(short, vi.length_squared() + vj.length_squared()) {
            return Change::Nothing;
        }
        // (i above j: j holds and i rises; else the other way round. The normal points from
        // j to i, so lifting the upper one by `short / |height|` closes the shortfall.)
        let lift = up * (short / height.abs());
        let [mi, mj] = record.mass;
        let impulse = if height > 0.0 {
            *vi += lift;
            short * mi
        } else {
            *vj += lift;
            short * mj
        };
        row.met = true;
        row.delivered += impulse;
        Change::Counted
    };
    // (blocks are slabs along the last axis: stacked up a pile when gravity is along it, as in
    // 2D, and then the sweep must run them one after another; side by side otherwise, as in
    // 3D under gravity along y, where each block holds its part of the pile from floor to top
    // and the even/odd order on two threads carries the support as well: serially, a 10^5
    // sphere pour's settling step took 1.5x as long)
    if up.get(V::DIM - 1).abs() >= SHOCK_MIN_HEIGHT {
        c.blocks
            .every_pair_in_order(exchange, velocity, c.pairs, c.rows.reborrow(), &pairs);
    } else {
        c.blocks
            .every_pair(exchange, velocity, c.pairs, c.rows.reborrow(), &pairs);
    }
}

/// A contact whose normal's `|n . up|` is below this (more than 60 degrees from `up`) has no
/// lower particle in a shock sweep: it takes equal and opposite impulses as usual. (Lifting
/// along `up` closes a shortfall `s` with a lift of `s / |n . up|`, at most `2 s` here; a
/// hexagonal pile's contacts are 30 degrees from `up`. 0.3 and 0.7 both let the lecture pile
/// come to rest later than 0.5 did. Lifting through a contact `theta` from `up` also slides the
/// particle across it by `s tan(theta)`, which keeps a random pile kept awake stirring (v_rms
/// 0.13 at step 1800); 0.85 lets it rest and holds every stack, but over 47 fill seeds the
/// sleeping pile sank 1.5x deeper: docs/benchmarks.md, fortieth sitting.)
const SHOCK_MIN_HEIGHT: f64 = 0.5;
