//! The rules applied to one contact: the lecture's response and plane rule, and the
//! accumulated-impulse rule for resting contacts, with their dead bands.

use super::{rows::*, settings::*};
use crate::response::{collide, split_normal_tangent};
use crate::schedule::Change;
use crate::vector::Vector;

/// True when `vn` (relative normal velocity, negative when approaching) is an approach and not
/// rounding residue against speeds whose squares sum to `speed_squared`.
#[inline]
pub(super) fn approaching(vn: f64, speed_squared: f64) -> bool {
    vn < 0.0 && vn * vn > APPROACH_TOLERANCE * APPROACH_TOLERANCE * speed_squared
}

/// True when `change` is within the rounding of values whose squares sum to `squares` (the
/// floor of every dead band).
#[inline]
pub(super) fn rounding(change: f64, squares: f64) -> bool {
    change * change <= DEAD_BAND_ROUNDING * DEAD_BAND_ROUNDING * squares
}

/// The two passes of the velocity phase when contacts can rest (see [`integrate`](super::velocity::integrate)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Pass {
    /// Every contact aims at not approaching (a gap may close, no more).
    Relax,
    /// The impacts aim at separating at `k` times their approach speed.
    Restitution,
}

/// The lecture's rule for one pair: if it overlaps and approaches, its response with
/// restitution `k`.
#[inline]
pub(super) fn lecture_pair<V: Vector>(
    row: &mut Row<V>,
    record: &RowRecord,
    vi: &mut V,
    vj: &mut V,
    k: f64,
) -> bool {
    let vn = row.normal.dot(*vi - *vj);
    if !(row.touching && approaching(vn, vi.length_squared() + vj.length_squared())) {
        return false;
    }
    row.impact = true;
    let n = row.normal;
    match row.inverse_mass {
        // (against a sleeping particle, a fixed obstacle: the lecture's plane rule, relative)
        [_, 0.0] => {
            let change = n * (-(1.0 + k) * vn);
            row.delivered += record.mass[0] * n.dot(change);
            *vi += change;
        }
        [0.0, _] => {
            let change = n * ((1.0 + k) * vn);
            row.delivered -= record.mass[1] * n.dot(change);
            *vj += change;
        }
        _ => {
            let before = *vi;
            (*vi, *vj) = collide(n, *vi, *vj, record.mass[0], record.mass[1], k);
            row.delivered += record.mass[0] * n.dot(*vi - before);
        }
    }
    true
}

/// The relative normal velocity a contact aims at in `pass`: an impact that met in the relax
/// pass (it took an impulse at some point) separates at its bounce speed; everything else does
/// not approach faster than its allowance.
#[inline]
pub(super) fn goal(pass: Pass, bounce: f64, met: bool, allowance: f64) -> f64 {
    match pass {
        Pass::Restitution if bounce > 0.0 && met => bounce,
        _ => -allowance,
    }
}

/// Whether a change of `dv` to a contact's relative normal speed is left undone in `pass`:
/// in the restitution pass, a met impact changes only by more than [`RESIDUAL_FRACTION`] of
/// the resting speed `resting`, and any other contact only by more than `resting`.
///
/// The restitution pass is there for the impacts and for what they push into: a ball landing
/// on a pile must have its bounce carried down to the floor. What the relax sweeps left of a
/// resting contact's goal (a deep pile misses it at the sweep cap every step) is left to the
/// next step's relax. Chasing it here too made the pass a second, full set of relax sweeps in
/// every step of a 3D pile in which anything landed anywhere: its cap, for a few impacts.
///
/// A met impact's change within the residual tolerance is the tail of the sweeps' convergence:
/// it keeps no sweep going, yet made, it marks both particles changed, and every contact of
/// theirs is visited again. In the dense 10^6 pile the restitution pass's last sweeps visited
/// 150,000 to 300,000 rows each for a few hundred changes that counted (docs/benchmarks.md,
/// thirteenth sitting); left undone, the step took 0.81-0.92x as long. An impact's first change
/// (the lecture's formula, for an isolated pair) is far above the band.
#[inline]
fn quiet(pass: Pass, bounce: f64, met: bool, dv: f64, resting: f64) -> bool {
    let band = if bounce > 0.0 && met {
        RESIDUAL_FRACTION * resting
    } else {
        resting
    };
    pass == Pass::Restitution && dv.abs() <= band
}

/// The accumulated-impulse rule for one pair in `pass`: push (never pull) until the pair's
/// relative normal velocity reaches its goal. `resting` is the resting speed: changes of the
/// relative speed up to [`RESIDUAL_FRACTION`] of it keep no sweeps going (0: any change does),
/// and see [`quiet`].
#[inline]
pub(super) fn accumulate_pair<V: Vector>(
    row: &mut Row<V>,
    vi: &mut V,
    vj: &mut V,
    pass: Pass,
    resting: f64,
) -> Change {
    let tolerance = RESIDUAL_FRACTION * resting;
    let vn = row.normal.dot(*vi - *vj);
    let goal = goal(pass, row.bounce, row.met, row.allowance);
    let target = (row.impulse - (vn - goal) * row.effective_mass).max(0.0);
    // (meeting changes an impact's goal in the restitution pass: that is a change too)
    let newly_met = !row.met && target > 0.0;
    row.met |= newly_met;
    let change = target - row.impulse;
    let [wi, wj] = row.inverse_mass;
    // The dead band: a change within rounding of the speeds is not made, so a second visit
    // with unchanged velocities changes nothing (the work lists rely on it).
    let dv = change * (wi + wj);
    if rounding(dv, vi.length_squared() + vj.length_squared())
        || quiet(pass, row.bounce, row.met, dv, resting)
    {
        return if newly_met {
            Change::Counted
        } else {
            Change::Nothing
        };
    }
    row.impulse = target;
    row.delivered += change;
    *vi += row.normal * (change * wi);
    *vj -= row.normal * (change * wj);
    Change::counted_if(dv.abs() > tolerance || newly_met)
}

/// The lecture's plane rule: if the particle touches the plane and heads into it,
/// `V' = V_T - k V_N`.
#[inline]
pub(super) fn lecture_plane<V: Vector>(row: &PlaneRow<V>, v: &mut V) -> bool {
    let vn = row.normal.dot(*v);
    if !(row.touching && approaching(vn, v.length_squared())) {
        return false;
    }
    let parts = split_normal_tangent(*v, row.normal);
    *v = parts.tangent - parts.normal * row.restitution;
    true
}

/// The accumulated-impulse rule for a particle on a plane (see [`accumulate_pair`]).
#[inline]
pub(super) fn accumulate_plane<V: Vector>(
    row: &mut PlaneRow<V>,
    v: &mut V,
    pass: Pass,
    resting: f64,
) -> Change {
    let tolerance = RESIDUAL_FRACTION * resting;
    let vn = row.normal.dot(*v);
    let goal = goal(pass, row.bounce, row.met, row.allowance);
    let target = (row.impulse - (vn - goal)).max(0.0);
    let newly_met = !row.met && target > 0.0;
    row.met |= newly_met;
    let change = target - row.impulse;
    // (the dead bands of `accumulate_pair`)
    if rounding(change, v.length_squared()) || quiet(pass, row.bounce, row.met, change, resting) {
        return if newly_met {
            Change::Counted
        } else {
            Change::Nothing
        };
    }
    row.impulse = target;
    *v += row.normal * change;
    Change::counted_if(change.abs() > tolerance || newly_met)
}
