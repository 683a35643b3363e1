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

/// The relative normal velocity a plane contact aims at in `pass`: an impact that met in the
/// relax pass (it took an impulse at some point) separates at its bounce speed; everything else
/// does not approach faster than its allowance. (A pair's impact is held to Poisson's law too:
/// see [`kick_ceiling`]. A plane's normal is fixed and its other side immovable.)
#[inline]
pub(super) fn goal(pass: Pass, bounce: f64, met: bool, allowance: f64) -> f64 {
    match pass {
        Pass::Restitution if bounce > 0.0 && met => bounce,
        _ => -allowance,
    }
}

/// The most impulse a met impact `row` takes in the restitution pass, from Poisson's law (`k`:
/// the pairs' restitution; `approach`: how fast the pair still approaches when the pass first
/// visits it): what it holds now, plus what stops what is left of the approach (an impact
/// that met in the last substep still closes in), plus `k` times its compression, the impulse
/// the relax substeps passed between the pair this step ([`Row::delivered`]; the warm start
/// gives an impact none) and that stop.
///
/// The pass aims an impact at Newton's law, separating at its bounce (`k` times its approach
/// at the start of the step), but never beyond this: an isolated impact so separates at `k s`,
/// the lecture's formula (both laws agree there), a ball dropped on a pile bounces off it as
/// off a wall (Newton's law, the pile pushing back through its resting contacts), and a new
/// contact that also carries the weight above it does not bounce that weight back.
///
/// Newton's law alone (as in Box2D's restitution pass) made energy where impacts press on each
/// other, and where a fast pair slid round itself within the step's substeps (its normal turned
/// 20 degrees in one case found): in the lecture's box at `k = 0.95` the pile's lower layers
/// gained a little every step until the speeds ran away (the total energy doubling every step
/// by step 150, discs moving 10^13 radii a step). With frictionless contacts Poisson's law
/// makes none: the push in is the least-energy projection of the velocities, and the push back
/// `k` times it (Stronge, *Impact Mechanics*, 2nd ed., 2018).
#[inline]
pub(super) fn kick_ceiling<V: Vector>(row: &Row<V>, approach: f64, k: f64) -> f64 {
    let stop = approach.max(0.0) * row.effective_mass;
    row.impulse + stop + k * (row.delivered + stop)
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

/// The accumulated-impulse rule for one pair in `pass`: push (never pull) until the pair
/// approaches no faster than its allowance, and in the restitution pass push a met impact
/// apart to its bounce, up to its [`kick_ceiling`] (`k`: the pairs' restitution). `resting` is
/// the resting speed: changes of the relative speed up to [`RESIDUAL_FRACTION`] of it keep no
/// sweeps going (0: any change does), and see [`quiet`].
#[inline]
pub(super) fn accumulate_pair<V: Vector>(
    row: &mut Row<V>,
    vi: &mut V,
    vj: &mut V,
    pass: Pass,
    resting: f64,
    k: f64,
) -> Change {
    let tolerance = RESIDUAL_FRACTION * resting;
    let vn = row.normal.dot(*vi - *vj);
    if pass == Pass::Restitution && row.bounce > 0.0 && row.met && !row.kicked {
        // (a kicked impact may not approach at all: its allowance keeps the ceiling instead)
        row.allowance = kick_ceiling(row, -vn, k);
        row.kicked = true;
    }
    let relaxed = |goal: f64| row.impulse - (vn - goal) * row.effective_mass;
    let target = if row.kicked {
        relaxed(0.0).max(relaxed(row.bounce).min(row.allowance))
    } else {
        relaxed(-row.allowance)
    }
    .max(0.0);
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    /// Two unit discs touching along x, as the relax substeps left an impact between them:
    /// approaching at `s` when the step started, the relax passing `delivered` between them
    /// and holding `impulse` now.
    fn met_impact(k: f64, s: f64, delivered: f64, impulse: f64) -> Row<DVec2> {
        let (xi, xj) = (DVec2::new(1.0, 0.0), DVec2::new(-1.0, 0.0));
        let (mut row, _) = Row::new(xi, xj, 1.0, 1.0, 1.0, 1.0, 1.0 / 60.0);
        row.bounce = k * s;
        row.met = true;
        row.delivered = delivered;
        row.impulse = impulse;
        row
    }

    /// The restitution pass on `row` alone, from relative normal velocity `vn`; returns the
    /// relative normal velocity it leaves.
    fn restitute(mut row: Row<DVec2>, vn: f64, k: f64) -> f64 {
        let (mut vi, mut vj) = (DVec2::new(vn / 2.0, 0.0), DVec2::new(-vn / 2.0, 0.0));
        for _ in 0..4 {
            accumulate_pair(&mut row, &mut vi, &mut vj, Pass::Restitution, 0.1, k);
        }
        row.normal.dot(vi - vj)
    }

    #[test]
    fn an_isolated_impact_separates_at_k_times_its_approach() {
        for k in [0.1, 0.5, 0.95, 1.0] {
            let s = 8.0;
            // met at once: the relax stopped it (m_eff s) and holds nothing now
            let at_once = restitute(met_impact(k, s, 0.5 * s, 0.0), 0.0, k);
            // met in the last substep across a gap of `a h`: still closing in at `a`
            let a = 3.0;
            let late = met_impact(k, s, 0.5 * (s - a), 0.5 * (s - a));
            let late = restitute(late, -a, k);
            // met at once under a load: the relax passed the weight above it too
            let loaded = restitute(met_impact(k, s, 0.5 * s + 40.0, 20.0), 0.0, k);
            for (case, vn) in [("at once", at_once), ("late", late), ("loaded", loaded)] {
                assert!((vn - k * s).abs() < 1e-12, "k {k}, {case}: {vn}");
            }
        }
    }

    /// Where other contacts took up part of an impact's approach (it passed less than an
    /// isolated pair would), it pushes back `k` times what it passed (Poisson), not to `k s`.
    #[test]
    fn an_impact_pushes_back_k_times_what_it_passed() {
        let (k, s) = (0.9, 8.0);
        let vn = restitute(met_impact(k, s, 0.5 * s / 4.0, 0.0), 0.0, k);
        assert!((vn - k * s / 4.0).abs() < 1e-12, "{vn}");
    }
}
