//! Resolving many simultaneous contacts: velocities first, then (after the particles move)
//! positions.
//!
//! **Velocity phase.** Every contact whose particles overlap (the lecture's detection,
//! `distance < r1 + r2`) is one of two kinds, decided each time a sweep visits it:
//!
//! - an *impact*: approaching (the lecture's trap rule, `p_rel . v_rel < 0`) at or above the
//!   resting speed, or any approach when `k = 1`. It takes the lecture's response
//!   ([`crate::response::collide`]), restitution and all, so an isolated collision is exactly
//!   the lecture's and Newton's cradle passes its velocity along ball by ball.
//! - a *resting* contact (slower than the resting speed, `k < 1`): a sequential impulse as in
//!   Box2D. Its impulse accumulates over the sweeps, never below zero (a contact pushes, it
//!   never pulls), aiming at zero relative normal speed. For a single new contact that is the
//!   lecture's formula with `k = 0`; in a pile, the accumulated impulse is remembered into the
//!   next step ([`crate::memory`]) and applied before the first sweep ("warm starting"), so the
//!   weight of fifty rows does not have to climb up from the floor again every step.
//!
//! Sweeps repeat until one changes nothing (no impact, no resting impulse moving the relative
//! speed by more than [`RESIDUAL_FRACTION`] of the resting speed) or the cap is hit. Every
//! impulse is equal and opposite, so momentum is conserved whatever the cap; with `k = 1`
//! every contact is an impact, so kinetic energy is too.
//!
//! **Position phase** (the lecture's "solution 1", which it calls hard with many contacts):
//! after the particles move, overlapping particles are moved apart along their normal, each by
//! its share of inverse mass, down to a small slop, and pushed out of planes.
//! Positions only: velocities are never touched, so this can never add kinetic energy. Planes
//! go last so a walled box holds its particles. (One exception, the lecture's step under
//! gravity with every plane elastic: a lift out of a plane is paid for from the particle's
//! speed, so that kinetic + potential energy is kept; see `keep_energy`.)
//!
//! The order of every rule application is fixed by [`crate::schedule`].

use crate::broadphase::Pair;
use crate::periodic::apply_shift;
use crate::plane::Plane;
use crate::response::{collide, contact_normal, is_overlapping, split_normal_tangent};
use crate::schedule::{Blocks, Change, Exchange, PlaneContact, Visit};
use crate::vector::Vector;
use rayon::prelude::*;
use std::time::Instant;

/// With the lecture's rule alone, the position phase leaves overlapping pairs this fraction of
/// the smaller radius deep, so a contact is still detected (`distance < r1 + r2`) on the next
/// step instead of dropping out. When contacts can rest, pairs within this fraction of
/// touching are contacts that may not close in (see `Row::place`). (Box2D's "linear slop"
/// plays the same role.)
pub const SLOP_FRACTION: f64 = 1e-3;

/// Approaches slower than this fraction of the particles' speeds are rounding residue, not
/// approaches: after a `k = 0` response the relative normal speed is zero only up to rounding.
const APPROACH_TOLERANCE: f64 = 1e-12;

/// The velocity phase of resting contacts ends when no contact misses its goal (approaching
/// when it should not, or pushing while separating) by more than this fraction of the resting
/// speed. At the default resting speed `2 |g| dt` a contact then sinks by at most
/// `0.002 |g| dt^2` a step (`5e-6` of a radius-1 disc at dt = 1/60 and g = 9.81), which the
/// position phase takes back. The misses add up along a chain of contacts: a looser tolerance
/// (1e-2 was tried) leaves a 100-disc column with a velocity ramp of `g dt` at its top.
pub const RESIDUAL_FRACTION: f64 = 1e-3;

/// How far a particle of radius `r` moving at `speed` reaches in a step of `dt`: its contact
/// candidates this step are the pairs and planes within reach. The move, up to one radius, is
/// covered, so an overlap it creates is pushed apart within the step; the slop keeps a particle
/// resting on a plane a candidate.
#[inline]
pub(crate) fn reach(radius: f64, speed: f64, dt: f64) -> f64 {
    // (speed: what the particle has plus what gravity adds this step)
    radius + SLOP_FRACTION * radius + (speed * dt).min(radius)
}

/// How close a particle of radius `radius` and step reach `reach` (see [`reach`]) must come to
/// a plane to be its candidate this step. When planes bounce in the move (see
/// [`SolverSettings::planes_in_move`]), the position phase pays for every lift out of a plane
/// from the candidate's speed (see [`keep_energy`]), so a particle a pair may push into a plane
/// must be a candidate too: a pair moves a particle by its share of their overlap, less than a
/// radius unless the two pass through each other, so one radius more. (A lift of a particle
/// beyond that is not paid for.)
#[inline]
pub(crate) fn plane_reach(reach: f64, radius: f64, planes_in_move: bool) -> f64 {
    if planes_in_move {
        reach + radius
    } else {
        reach
    }
}

/// The position sweeps stop when no overlap beyond the slop is deeper than this fraction of
/// the smaller radius.
const POSITION_TOLERANCE: f64 = 1e-6;

/// Relative rounding a dead band always covers: a change smaller than this fraction of the
/// values it is made to is rounding, not a change.
const DEAD_BAND_ROUNDING: f64 = 1e-12;

/// Rows per parallel task when preparing contacts.
const ROW_CHUNK: usize = 4096;

/// Particles per parallel task when applying gravity and moving.
const PARTICLE_CHUNK: usize = 8192;

/// The solver's settings for one step (from [`crate::WorldConfig`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverSettings {
    /// Particle-particle restitution `k` in [0, 1].
    pub restitution: f64,
    /// Approaches slower than this (length / time) rest instead of bouncing when `k < 1`.
    pub resting_speed: f64,
    /// Cap on velocity sweeps, >= 1.
    pub velocity_iterations: u32,
    /// Cap on position sweeps (0: no position correction).
    pub position_iterations: u32,
    /// Substeps per step when contacts can rest (see the module notes), >= 1.
    pub substeps: u32,
}

impl SolverSettings {
    /// True when every contact takes the lecture's response alone: no gravity to rest against
    /// (resting speed 0), or `k = 1` everywhere.
    pub(crate) fn lecture_only(&self, planes_elastic: bool) -> bool {
        self.resting_speed <= 0.0 || (self.restitution >= 1.0 && planes_elastic)
    }

    /// True when plane contacts bounce at their time of impact within the move (see
    /// [`bounce_in_move`]) and the position phase keeps energy (see [`keep_energy`]): the
    /// lecture's step, under gravity, with every plane elastic.
    pub(crate) fn planes_in_move<V: Vector>(&self, planes: &[Plane<V>], gravity: V) -> bool {
        let elastic_planes = planes.iter().all(|p| p.restitution() >= 1.0);
        !planes.is_empty() && gravity != V::ZERO && elastic_planes && self.lecture_only(true)
    }

    /// True when every pair takes the lecture's response (`k = 1`, or nothing to rest against).
    fn lecture_pairs(&self) -> bool {
        self.restitution >= 1.0 || self.resting_speed <= 0.0
    }
}

/// What the velocity phase did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VelocitySolve {
    /// Sweeps made (1 when nothing was approaching).
    pub iterations: u32,
    /// Rule applications that changed something (impacts and resting impulses).
    pub responses: u64,
    /// True when the last sweep still changed something (the cap was hit).
    pub capped: bool,
    /// Wall-clock time spent on gravity, the moves and re-placing rows (see
    /// [`crate::PhaseTimes::motion`]); the rest of the phase is the sweeps'.
    pub motion: std::time::Duration,
}

/// One contact candidate's solver data, at the same index as its pair.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Row<V> {
    /// Unit normal from `j` to `i` at the start of the velocity phase.
    pub normal: V,
    /// `(m_i, m_j)`, > 0.
    pub mass: [f64; 2],
    /// `(1 / m_i, 1 / m_j)`.
    pub inverse_mass: [f64; 2],
    /// `1 / (1 / m_i + 1 / m_j)`: the impulse that changes the relative normal speed by one.
    pub effective_mass: f64,
    /// `(r_i, r_j)`, > 0.
    pub radius: [f64; 2],
    /// Accumulated impulse this step, >= 0 (mass x length / time).
    pub impulse: f64,
    /// The impulse after the relax pass: what the next step starts from.
    pub kept: f64,
    /// For an impact, the speed its restitution pass aims to separate at (`k` times its
    /// approach speed); 0 for a resting contact.
    pub bounce: f64,
    /// True once the contact took an impulse this step.
    pub met: bool,
    /// Overlap at the end of the step as a fraction of `min_radius` (0 when apart).
    pub overlap: f64,
    /// `|x_i - x_j|` where the contact was last placed (length).
    pub distance: f64,
    /// The normal impulse `j` gave `i` this step, summed over every application (mass x
    /// length / time; positive pushes apart): the collisional virial's `J_ij` (see
    /// [`crate::observe`]).
    pub delivered: f64,
    /// True once the lecture's response answered an approach of this pair this step.
    pub impact: bool,
    /// The lecture's detection at the start of the velocity phase, with distinct centres (a
    /// pair with coincident centres has no direction to respond along).
    pub touching: bool,
    /// How fast a resting contact may still approach this step: the gap between the surfaces
    /// over `dt` (0 when they overlap, infinite for coincident centres). A pair a hair apart
    /// stays in the solver as a *speculative* contact (as in Box2D), so the position phase
    /// opening a contact by a rounding error does not drop a pile's support for a step.
    pub allowance: f64,
    /// What `j` is seen through across periodic seams: every rule that reads positions uses
    /// `x_j + shift` (see [`crate::periodic`]). Whole periods per axis, fixed when the pair is
    /// found; zero without periodic axes (and then `x_j` is used as it is, bit for bit).
    pub shift: V,
}

impl<V: Vector> Row<V> {
    /// The row of particles at `x`, radius `r` and mass `m`, for a step of `dt`.
    #[inline]
    pub fn new(xi: V, xj: V, ri: f64, rj: f64, mi: f64, mj: f64, dt: f64) -> Self {
        Self::across(xi, xj, V::ZERO, ri, rj, mi, mj, dt)
    }

    /// [`Row::new`] for a pair seen through `x_j + shift` (see [`Row::shift`]).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn across(xi: V, xj: V, shift: V, ri: f64, rj: f64, mi: f64, mj: f64, dt: f64) -> Self {
        let mut row = Self {
            normal: V::ZERO,
            mass: [mi, mj],
            inverse_mass: [1.0 / mi, 1.0 / mj],
            effective_mass: 1.0 / (1.0 / mi + 1.0 / mj),
            radius: [ri, rj],
            impulse: 0.0,
            kept: 0.0,
            bounce: 0.0,
            met: false,
            overlap: 0.0,
            distance: 0.0,
            delivered: 0.0,
            impact: false,
            touching: false,
            allowance: 0.0,
            shift,
        };
        row.place(xi, xj, dt);
        row
    }

    /// Where this row sees `j` from `i`: `x_j + shift`, or `x_j` itself when there is no shift.
    #[inline]
    pub fn image(&self, xj: V) -> V {
        apply_shift(xj, self.shift)
    }

    /// Normal, detection and allowance for particles at `xi`, `xj` over a (sub)step `dt`. A
    /// row left out for the step (infinite allowance) stays out.
    #[inline]
    pub fn place(&mut self, xi: V, xj: V, dt: f64) {
        if self.allowance == f64::INFINITY {
            return;
        }
        let xj = self.image(xj);
        let (normal, distance) = contact_normal(xi, xj);
        let [ri, rj] = self.radius;
        self.normal = normal;
        self.distance = distance;
        self.touching = distance > 0.0 && is_overlapping(xi, xj, ri, rj);
        // Within the slop of touching, a contact may not close in: the position phase opens
        // and closes such hairline gaps every step, and letting them turn into approach speeds
        // would keep a pile stirring.
        self.allowance = if distance > 0.0 {
            (distance - (ri + rj) - SLOP_FRACTION * ri.min(rj)).max(0.0) / dt
        } else {
            f64::INFINITY
        };
    }

    /// `r_i + r_j`.
    #[inline]
    pub fn reach(&self) -> f64 {
        self.radius[0] + self.radius[1]
    }

    /// `min(r_i, r_j)`.
    #[inline]
    pub fn min_radius(&self) -> f64 {
        self.radius[0].min(self.radius[1])
    }

    /// True when this pair counts as a collision this step: it answered an approach with the
    /// lecture's response, or it was an impact (see [`integrate`]) that met.
    #[inline]
    pub fn collided(&self) -> bool {
        self.impact || (self.bounce > 0.0 && self.met)
    }
}

/// What a step's rows add up to, in one pass (row order, so the same rows give the same
/// bits).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct RowTally {
    /// Rows whose pair overlapped at the start of the velocity phase.
    pub touching: u64,
    /// Particle-particle collisions (see [`Row::collided`]).
    pub collisions: u64,
    /// The collisional virial `sum J_ij . r_ij`.
    pub virial: f64,
}

/// Adds up `rows` (see [`RowTally`]).
pub(crate) fn tally<V: Vector>(rows: &[Row<V>]) -> RowTally {
    rows.iter().fold(RowTally::default(), |t, row| RowTally {
        touching: t.touching + row.touching as u64,
        collisions: t.collisions + row.collided() as u64,
        virial: t.virial + row.delivered * row.distance,
    })
}

/// One particle-plane candidate's solver data.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct PlaneRow<V> {
    /// The plane's unit normal.
    pub normal: V,
    /// The plane's restitution.
    pub restitution: f64,
    /// The particle's radius.
    pub radius: f64,
    /// Accumulated impulse per unit mass this step, >= 0 (length / time).
    pub impulse: f64,
    /// The impulse after the relax pass (see [`Row::kept`]).
    pub kept: f64,
    /// See [`Row::bounce`].
    pub bounce: f64,
    /// See [`Row::met`].
    pub met: bool,
    /// Index of the plane.
    pub plane: u32,
    /// The lecture's plane detection at the start of the velocity phase, with its threshold
    /// ("in practice we take a threshold distance"): `(x - p) . n < r + SLOP_FRACTION r`, since
    /// the position phase leaves a particle exactly touching its plane.
    pub touching: bool,
    /// How fast a resting contact may still approach the plane this step (see
    /// [`Row::allowance`]).
    pub allowance: f64,
    /// Where the particle's centre was when the row was made (the start of the step): when
    /// planes bounce in the move (see [`bounce_in_move`]), its path this step starts here.
    pub start: V,
    /// How far the position phase pushed the particle out of the plane this step (see
    /// [`keep_energy`]).
    pub lift: f64,
}

impl<V: Vector> PlaneRow<V> {
    /// The row of a particle at `x` with radius `r` against `plane` (index `index`), for a
    /// step of `dt`.
    #[inline]
    pub fn new(plane: &Plane<V>, index: u32, x: V, radius: f64, dt: f64) -> Self {
        let mut row = Self {
            normal: plane.normal(),
            restitution: plane.restitution(),
            radius,
            impulse: 0.0,
            kept: 0.0,
            bounce: 0.0,
            met: false,
            plane: index,
            touching: false,
            allowance: 0.0,
            start: x,
            lift: 0.0,
        };
        row.place(plane, x, dt);
        row
    }

    /// Detection and allowance for the particle at `x` over a (sub)step `dt` (see
    /// [`Row::place`]).
    #[inline]
    pub fn place(&mut self, plane: &Plane<V>, x: V, dt: f64) {
        if self.allowance == f64::INFINITY {
            return;
        }
        let (distance, r) = (plane.signed_distance(x), self.radius);
        self.touching = distance < r + SLOP_FRACTION * r;
        self.allowance = (distance - r - SLOP_FRACTION * r).max(0.0) / dt;
    }
}

/// Fills `rows` (one per pair) from `row(pair)`, in parallel when asked.
pub(crate) fn prepare_rows<V: Vector>(
    rows: &mut Vec<Row<V>>,
    pairs: &[Pair],
    parallel: bool,
    row: impl Fn(Pair) -> Row<V> + Sync,
) {
    rows.resize(pairs.len(), Row::default());
    crate::broadphase::keep_headroom(rows);
    let fill = |(out, keys): (&mut [Row<V>], &[Pair])| {
        for (r, &p) in out.iter_mut().zip(keys) {
            *r = row(p);
        }
    };
    if parallel {
        rows.par_chunks_mut(ROW_CHUNK)
            .zip(pairs.par_chunks(ROW_CHUNK))
            .for_each(fill);
    } else {
        fill((rows, pairs));
    }
}

/// True when `vn` (relative normal velocity, negative when approaching) is an approach and not
/// rounding residue against speeds whose squares sum to `speed_squared`.
#[inline]
fn approaching(vn: f64, speed_squared: f64) -> bool {
    vn < 0.0 && vn * vn > APPROACH_TOLERANCE * APPROACH_TOLERANCE * speed_squared
}

/// True when `change` is within the rounding of values whose squares sum to `squares` (the
/// floor of every dead band).
#[inline]
fn rounding(change: f64, squares: f64) -> bool {
    change * change <= DEAD_BAND_ROUNDING * DEAD_BAND_ROUNDING * squares
}

/// The two passes of the velocity phase when contacts can rest (see [`integrate`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pass {
    /// Every contact aims at not approaching (a gap may close, no more).
    Relax,
    /// The impacts aim at separating at `k` times their approach speed.
    Restitution,
}

/// The lecture's rule for one pair: if it overlaps and approaches, its response with
/// restitution `k`.
#[inline]
fn lecture_pair<V: Vector>(row: &mut Row<V>, vi: &mut V, vj: &mut V, k: f64) -> bool {
    let vn = row.normal.dot(*vi - *vj);
    if !(row.touching && approaching(vn, vi.length_squared() + vj.length_squared())) {
        return false;
    }
    let before = *vi;
    (*vi, *vj) = collide(row.normal, *vi, *vj, row.mass[0], row.mass[1], k);
    row.delivered += row.mass[0] * row.normal.dot(*vi - before);
    row.impact = true;
    true
}

/// The relative normal velocity a contact aims at in `pass`: an impact that met in the relax
/// pass (it took an impulse at some point) separates at its bounce speed; everything else does
/// not approach faster than its allowance.
#[inline]
fn goal(pass: Pass, bounce: f64, met: bool, allowance: f64) -> f64 {
    match pass {
        Pass::Restitution if bounce > 0.0 && met => bounce,
        _ => -allowance,
    }
}

/// The accumulated-impulse rule for one pair in `pass`: push (never pull) until the pair's
/// relative normal velocity reaches its goal.
#[inline]
fn accumulate_pair<V: Vector>(
    row: &mut Row<V>,
    vi: &mut V,
    vj: &mut V,
    pass: Pass,
    tolerance: f64,
) -> Change {
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
    if rounding(dv, vi.length_squared() + vj.length_squared()) {
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
fn lecture_plane<V: Vector>(row: &PlaneRow<V>, v: &mut V) -> bool {
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
fn accumulate_plane<V: Vector>(
    row: &mut PlaneRow<V>,
    v: &mut V,
    pass: Pass,
    tolerance: f64,
) -> Change {
    let vn = row.normal.dot(*v);
    let goal = goal(pass, row.bounce, row.met, row.allowance);
    let target = (row.impulse - (vn - goal)).max(0.0);
    let newly_met = !row.met && target > 0.0;
    row.met |= newly_met;
    let change = target - row.impulse;
    // (the dead band of `accumulate_pair`)
    if rounding(change, v.length_squared()) {
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

/// This step's contacts, planned into blocks, with their rows.
pub(crate) struct Contacts<'a, V> {
    pub pairs: &'a [Pair],
    pub rows: &'a mut [Row<V>],
    pub plane_contacts: &'a [PlaneContact],
    pub plane_rows: &'a mut [PlaneRow<V>],
    pub planes: &'a [Plane<V>],
    pub blocks: &'a Blocks,
    pub work: WorkList<'a>,
}

/// The per-particle stamps of the work lists (see [`crate::schedule`]) and the sweep clock
/// that numbers them. Without stamps (an empty slice) every sweep visits every contact, with
/// the same result.
pub(crate) struct WorkList<'a> {
    /// One per slot of the data the sweeps run on, or none.
    pub stamps: &'a mut [u32],
    /// The number of the last sweep (kept between steps; stamps below the current pass's
    /// first sweep mean nothing).
    pub clock: &'a mut u32,
}

impl WorkList<'_> {
    /// The visit of a new sweep: every contact on a pass's first sweep (`previous` = None),
    /// afterwards the contacts with a particle changed since `previous` began.
    fn next(&mut self, previous: Option<Visit>) -> Visit {
        if self.stamps.is_empty() {
            return Visit::ALL;
        }
        if previous.is_none() && *self.clock > u32::MAX / 2 {
            self.stamps.fill(0);
            *self.clock = 0;
        }
        *self.clock += 1;
        Visit {
            since: previous.map_or(0, |p| p.now),
            now: *self.clock,
        }
    }
}

/// The particles a step moves: `position` and `velocity` cover the slots the blocks cover, of
/// which the first `own` belong to this process (the rest are borrowed).
pub(crate) struct Moving<'a, V> {
    pub position: &'a mut [V],
    pub velocity: &'a mut [V],
    pub own: usize,
    /// Per own slot, whether it sleeps this step (see [`crate::sleep`]); empty when none does.
    pub asleep: &'a [bool],
}

/// Gravity, the velocity phase and the move, for one step of `dt`.
///
/// Without gravity (resting speed 0), or with `k = 1` on every contact, this is the lecture's
/// step: `v += g dt`, the lecture's response swept until nothing approaches, `x += v dt`.
/// (Under gravity with every plane elastic, planes bounce at their time of impact within the
/// move instead of in the sweeps: see [`bounce_in_move`].)
/// Otherwise contacts can rest, and the step is Box2D's "soft step" (Catto 2024; Macklin et
/// al. 2019, "Small steps in physics simulation"), with the lecture's formula for impacts:
///
/// 1. each overlapping contact approaching at least at the resting speed (and not resting
///    last step) is an *impact*, and remembers the speed `k s` it is to separate at;
/// 2. `substeps` times, with `h = dt / substeps`: `v += g h`; the accumulated impulses are
///    applied (from the last step at first: warm starting); *relax* sweeps of accumulated
///    impulses until no contact approaches (a gap may close, no more); `x += v h`; the
///    contacts' geometry is brought up to date. What the last relax leaves is remembered for
///    the next step;
/// 3. *restitution* (when there were impacts): sweeps until every impact separates at its
///    `k s` and no other contact approaches. An isolated impact so gets exactly the lecture's
///    formula, and one against a pile at rest bounces off it as off a wall.
///
/// Small steps carry a pile's weight far better than as many sweeps in one step: each
/// substep's error is `h^2` small.
pub(crate) fn integrate<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    settings: &SolverSettings,
    gravity: V,
    dt: f64,
    m: Moving<V>,
    c: &mut Contacts<V>,
) -> VelocitySolve {
    let Moving {
        position,
        velocity,
        own,
        asleep,
    } = m;
    let elastic_planes = c.planes.iter().all(|p| p.restitution() >= 1.0);
    let lecture_only = settings.lecture_only(elastic_planes);
    let substeps = if lecture_only {
        1
    } else {
        settings.substeps.max(1)
    };
    let planes_in_move = settings.planes_in_move(c.planes, gravity);
    let h = dt / substeps as f64;
    let impacts = classify(
        exchange,
        settings,
        velocity,
        c,
        substeps as f64,
        gravity,
        dt,
    );
    let parallel = c.blocks.parallel();
    let mut solve = VelocitySolve::default();
    for pass in (0..substeps)
        .map(|_| Pass::Relax)
        .chain([Pass::Restitution])
    {
        if pass == Pass::Restitution {
            exchange.settle_rows(c.blocks, c.rows);
            for row in c.rows.iter_mut() {
                row.kept = row.impulse;
            }
            for row in c.plane_rows.iter_mut() {
                row.kept = row.impulse;
            }
            exchange.keep_impulses();
            if exchange.total(impacts) == 0 {
                break;
            }
        } else {
            let clock = Instant::now();
            accelerate(parallel, &mut velocity[..own], asleep, gravity * h);
            solve.motion += clock.elapsed();
            if !settings.lecture_pairs() || !elastic_planes {
                warm_start(exchange, velocity, c);
            }
        }
        // (the restitution pass, once a step, may take the whole cap: an impact on a pile must
        // travel through it for the pile to hold)
        let cap = match pass {
            Pass::Restitution => settings.velocity_iterations.max(1),
            Pass::Relax => (settings.velocity_iterations / substeps).max(1),
        };
        let (sweeps, capped) = relax(
            exchange,
            settings,
            velocity,
            c,
            pass,
            cap,
            !planes_in_move,
            &mut solve,
        );
        solve.iterations += sweeps;
        solve.capped |= capped;
        if pass == Pass::Relax {
            let clock = Instant::now();
            advance_positions(parallel, &mut position[..own], &velocity[..own], asleep, h);
            if substeps > 1 {
                place(exchange, position, c, h);
            }
            solve.motion += clock.elapsed();
        }
    }
    if planes_in_move {
        let clock = Instant::now();
        let bounces = bounce_in_move(&mut position[..own], &mut velocity[..own], c, gravity, dt);
        solve.motion += clock.elapsed();
        solve.responses += exchange.total(bounces);
    }
    exchange.settle_rows(c.blocks, c.rows);
    solve
}

/// Most plane bounces one particle takes in one move. (A particle barely moving on a floor
/// would bounce without end; a deeper overlap left over is the position phase's.)
const MOVE_BOUNCES: usize = 4;

/// When the path `x + u s + g s^2 / 2` of a particle of radius `r` first meets `plane`
/// heading into it, for `s` in `[0, span]`: the lecture's plane detection
/// (`(x - p) . n < r` and `n . v < 0`) along the path instead of at the start of the step.
#[inline]
fn time_of_impact<V: Vector>(plane: &Plane<V>, r: f64, x: V, u: V, g: V, span: f64) -> Option<f64> {
    let n = plane.normal();
    // gap(s) = d + a s + b s^2 / 2, heading in while a + b s < 0
    let (d, a, b) = (plane.signed_distance(x) - r, n.dot(u), n.dot(g));
    if d <= 0.0 && a < 0.0 {
        return Some(0.0);
    }
    let mut first: Option<f64> = None;
    let mut meet = |s: f64| {
        if (0.0..=span).contains(&s) && a + b * s < 0.0 {
            first = Some(first.map_or(s, |f| f.min(s)));
        }
    };
    if b == 0.0 {
        if a != 0.0 {
            meet(-d / a);
        }
    } else {
        // (the roots without cancellation)
        let discriminant = a * a - 2.0 * b * d;
        if discriminant >= 0.0 {
            let q = -0.5 * (a + discriminant.sqrt().copysign(a));
            if q != 0.0 {
                meet(2.0 * q / b);
                meet(d / q);
            }
        }
    }
    first
}

/// Plane bounces at their time of impact, for the lecture's step under gravity with elastic
/// planes (`planes_in_move` in [`integrate`]); returns how many bounces this process made.
///
/// The lecture's step answers a plane contact found at the start of the step, on the velocity
/// after gravity, and pushes a particle that the move took into a plane back out. Under
/// gravity neither keeps energy: the bounce comes up to a step late with a velocity gravity
/// has sped up towards the floor (it leaves with `g dt` too much), and the push out lifts it
/// (`m |g|` times the depth). On the lecture's 5000-disc gas at dt = 0.005, the two added 7.1 %
/// and 3.5 % of the initial kinetic energy in 4000 steps, in proportion to dt.
///
/// Here instead each plane candidate follows its path through the step: `x += v dt` after
/// `v += g dt` is exactly the parabola `x(s) = x + u s + g s^2 / 2` with `u = v - g dt / 2`
/// (the velocity at the start of the step). Where that path first meets a plane, the particle
/// takes the lecture's rule `V' = V_T - k V_N` on its velocity at that moment and goes on along
/// the new parabola to the end of the step. Position and velocity stay on one exact parabola
/// through the bounce, so with `k = 1` the energy is what it was, to rounding. A particle
/// whose path meets no plane keeps the bits of the plain move.
fn bounce_in_move<V: Vector>(
    position: &mut [V],
    velocity: &mut [V],
    c: &Contacts<V>,
    g: V,
    dt: f64,
) -> u64 {
    let mut bounces = 0;
    for (i, rows) in on_planes(c.plane_contacts) {
        let rows = &c.plane_rows[rows];
        // where the particle was at the start of the step, its velocity there, and the time
        // its path has taken so far
        let (mut x, mut u, mut t) = (rows[0].start, velocity[i] - g * (0.5 * dt), 0.0);
        let mut bounced = false;
        for _ in 0..MOVE_BOUNCES {
            let hit = rows
                .iter()
                .filter_map(|row| {
                    let plane = &c.planes[row.plane as usize];
                    time_of_impact(plane, row.radius, x, u, g, dt - t).map(|s| (s, plane))
                })
                .fold(None, |first: Option<(f64, &Plane<V>)>, hit| match first {
                    Some(f) if f.0 <= hit.0 => Some(f),
                    _ => Some(hit),
                });
            let Some((s, plane)) = hit else { break };
            x += u * s + g * (0.5 * s * s);
            u = plane.bounce(u + g * s);
            t += s;
            bounced = true;
            bounces += 1;
        }
        if bounced {
            let rest = dt - t;
            position[i] = x + u * rest + g * (0.5 * rest * rest);
            velocity[i] = u + g * (rest - 0.5 * dt);
        }
    }
    bounces
}

/// `v += dv` for every particle not `asleep` (empty: none is), on the thread pool when
/// `parallel` (each particle's update is its own, so the result is the same either way).
fn accelerate<V: Vector>(parallel: bool, velocity: &mut [V], asleep: &[bool], dv: V) {
    let chunk = |(c, v): (usize, &mut [V])| {
        if asleep.is_empty() {
            v.iter_mut().for_each(|v| *v += dv);
        } else {
            let asleep = &asleep[c * PARTICLE_CHUNK..][..v.len()];
            for (v, &sleeps) in v.iter_mut().zip(asleep) {
                if !sleeps {
                    *v += dv;
                }
            }
        }
    };
    if parallel {
        velocity
            .par_chunks_mut(PARTICLE_CHUNK)
            .enumerate()
            .for_each(chunk);
    } else {
        velocity
            .chunks_mut(PARTICLE_CHUNK)
            .enumerate()
            .for_each(chunk);
    }
}

/// `x += v h` for every particle not `asleep` (see [`accelerate`]).
fn advance_positions<V: Vector>(
    parallel: bool,
    position: &mut [V],
    velocity: &[V],
    asleep: &[bool],
    h: f64,
) {
    let chunk = |(c, (x, v)): (usize, (&mut [V], &[V]))| {
        if asleep.is_empty() {
            for (x, v) in x.iter_mut().zip(v) {
                *x += *v * h;
            }
        } else {
            let asleep = &asleep[c * PARTICLE_CHUNK..][..x.len()];
            for ((x, v), &sleeps) in x.iter_mut().zip(v).zip(asleep) {
                if !sleeps {
                    *x += *v * h;
                }
            }
        }
    };
    if parallel {
        position
            .par_chunks_mut(PARTICLE_CHUNK)
            .zip(velocity.par_chunks(PARTICLE_CHUNK))
            .enumerate()
            .for_each(chunk);
    } else {
        position
            .chunks_mut(PARTICLE_CHUNK)
            .zip(velocity.chunks(PARTICLE_CHUNK))
            .enumerate()
            .for_each(chunk);
    }
}

/// One pass's sweeps (see [`integrate`]) until one changes nothing or `cap` is hit; returns the
/// sweeps made and whether the cap was hit. After the first sweep, each sweep visits only the
/// contacts whose particles the sweeps before it changed (the work list).
#[allow(clippy::too_many_arguments)]
fn relax<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    settings: &SolverSettings,
    velocity: &mut [V],
    c: &mut Contacts<V>,
    pass: Pass,
    cap: u32,
    with_planes: bool,
    solve: &mut VelocitySolve,
) -> (u32, bool) {
    let k = settings.restitution;
    let resting = settings.resting_speed;
    let tolerance = RESIDUAL_FRACTION * resting;
    let lecture_pairs = settings.lecture_pairs();
    let pair_rule = |row: &mut Row<V>, vi: &mut V, vj: &mut V| {
        if lecture_pairs {
            lecture_pair(row, vi, vj, k).into()
        } else {
            accumulate_pair(row, vi, vj, pass, tolerance)
        }
    };
    let plane_rule = |row: &mut PlaneRow<V>, v: &mut V| {
        if row.restitution >= 1.0 || resting <= 0.0 {
            lecture_plane(row, v).into()
        } else {
            accumulate_plane(row, v, pass, tolerance)
        }
    };
    let blocks = c.blocks;
    let mut visit = None;
    for sweeps in 1..=cap {
        let this = c.work.next(visit);
        visit = Some(this);
        // Planes first: a floor's support then travels up a stack within one sweep. (Not when
        // they bounce in the move instead: see `bounce_in_move`.)
        let on_planes = if with_planes {
            blocks.run_planes(
                velocity,
                c.work.stamps,
                this,
                c.plane_contacts,
                c.plane_rows,
                &plane_rule,
            )
        } else {
            0
        };
        // Alternate the direction within each block (symmetric Gauss-Seidel): support then
        // spreads both ways through a stack instead of one layer per sweep.
        let reverse = sweeps % 2 == 0;
        let (in_blocks, leftovers) = blocks.sweep_pairs(
            exchange,
            velocity,
            c.work.stamps,
            this,
            c.pairs,
            c.rows,
            reverse,
            &pair_rule,
        );
        let changed = exchange.total(on_planes + in_blocks) + leftovers;
        solve.responses += changed;
        if changed == 0 {
            return (sweeps, false);
        }
    }
    (cap, true)
}

/// Brings every contact's normal, detection and allowance up to date with the positions.
fn place<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    position: &mut [V],
    c: &mut Contacts<V>,
    h: f64,
) {
    let pairs = |row: &mut Row<V>, xi: &mut V, xj: &mut V| {
        row.place(*xi, *xj, h);
        Change::Nothing
    };
    let planes = c.planes;
    let on_planes = |row: &mut PlaneRow<V>, x: &mut V| {
        row.place(&planes[row.plane as usize], *x, h);
        Change::Nothing
    };
    c.blocks
        .every_plane(position, c.plane_contacts, c.plane_rows, &on_planes);
    c.blocks
        .every_pair(exchange, position, c.pairs, c.rows, &pairs);
}

/// Marks this step's impacts (see [`integrate`]) from the velocities before any impulse, and
/// returns how many this process found.
fn classify<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    settings: &SolverSettings,
    velocity: &mut [V],
    c: &mut Contacts<V>,
    substeps: f64,
    gravity: V,
    dt: f64,
) -> u64 {
    // (a pair's approach speed is the same before and after gravity; a plane's is not: as in
    // the lecture's step, the velocity update comes before the collision)
    let (k, resting) = (settings.restitution, settings.resting_speed);
    if resting <= 0.0 {
        return 0;
    }
    // The rows' allowances were made for the whole step; a substep closes a gap in less time.
    let pairs = |row: &mut Row<V>, vi: &mut V, vj: &mut V| {
        let speed = -row.normal.dot(*vi - *vj);
        // An impact across a gap (a pair that would meet within the step) bounces too, when
        // the relax pass finds it meeting: as in Box2D, a speculative contact keeps the speed
        // it bounces with instead of eating it.
        let fast = speed >= resting && row.impulse == 0.0;
        row.bounce = if fast { k * speed } else { 0.0 };
        row.allowance *= substeps;
        (row.bounce > 0.0).into()
    };
    let planes = |row: &mut PlaneRow<V>, v: &mut V| {
        let speed = -row.normal.dot(*v + gravity * dt);
        let fast = speed >= resting && row.impulse == 0.0;
        row.bounce = if fast { row.restitution * speed } else { 0.0 };
        row.allowance *= substeps;
        (row.bounce > 0.0).into()
    };
    let on_planes = c
        .blocks
        .every_plane(velocity, c.plane_contacts, c.plane_rows, &planes);
    let (in_blocks, leftovers) = c
        .blocks
        .every_pair(exchange, velocity, c.pairs, c.rows, &pairs);
    // (every process counts the leftovers: only whether there are any matters)
    on_planes + in_blocks + leftovers
}

/// Applies every remembered impulse once, before the first sweep.
fn warm_start<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    velocity: &mut [V],
    c: &mut Contacts<V>,
) {
    let push = |row: &mut Row<V>, vi: &mut V, vj: &mut V| {
        if row.impulse > 0.0 {
            row.delivered += row.impulse;
            *vi += row.normal * (row.impulse * row.inverse_mass[0]);
            *vj -= row.normal * (row.impulse * row.inverse_mass[1]);
        }
        Change::Nothing
    };
    let on_planes = |row: &mut PlaneRow<V>, v: &mut V| {
        if row.impulse > 0.0 {
            *v += row.normal * row.impulse;
        }
        Change::Nothing
    };
    c.blocks
        .every_plane(velocity, c.plane_contacts, c.plane_rows, &on_planes);
    c.blocks
        .every_pair(exchange, velocity, c.pairs, c.rows, &push);
}

/// Pays for the position phase's lifts out of planes from the particles' speeds, when planes
/// bounce in the move (the lecture's step under gravity with elastic planes, where nothing
/// else changes the energy: see [`bounce_in_move`]).
///
/// Pushing two particles apart moves their centre of mass nowhere, so it does not change their
/// potential energy; pushing one out of a plane does. Under gravity, a particle that a pair's
/// push sent into the floor and the floor's push lifted back gains `m |g|` times the depth, for
/// nothing: on the lecture's 5000-disc gas at k = 1 that added 0.4 % of the initial kinetic
/// energy every 4000 steps. Energy conservation fixes a particle's speed at a given height in
/// a uniform field whatever path took it there (`v'^2 = v^2 + 2 g . dx`), so a particle moved
/// by `dx` takes that speed, in the direction it had. (Only the planes' pushes: they are the
/// ones that change the energy, and a pair's push changing the pair's velocities would change
/// its momentum.) A particle too slow to pay stops, and the rest is lost.
fn keep_energy<V: Vector>(velocity: &mut [V], c: &Contacts<V>, g: V) {
    for (i, rows) in on_planes(c.plane_contacts) {
        // the work done against gravity, per unit mass
        let work: f64 = c.plane_rows[rows]
            .iter()
            .map(|row| -g.dot(row.normal) * row.lift)
            .sum();
        if work == 0.0 {
            continue;
        }
        let v = &mut velocity[i];
        let kinetic = 0.5 * v.length_squared();
        *v = if kinetic > work {
            *v * ((kinetic - work) / kinetic).sqrt()
        } else {
            V::ZERO
        };
    }
}

/// The particles touching planes, each with the range of its plane contacts (`contacts` is
/// sorted, so a particle's contacts are consecutive).
fn on_planes(
    contacts: &[PlaneContact],
) -> impl Iterator<Item = (usize, std::ops::Range<usize>)> + '_ {
    let mut start = 0;
    contacts.chunk_by(|a, b| a.0 == b.0).map(move |group| {
        let rows = start..start + group.len();
        start = rows.end;
        (group[0].0 as usize, rows)
    })
}

/// Moves one overlapping pair apart down to `depth` times the smaller radius.
#[inline]
fn separate_pair<V: Vector>(row: &Row<V>, xi: &mut V, xj: &mut V, depth: f64) -> Change {
    // (moving `x_j` moves its image by as much)
    let (normal, distance) = contact_normal(*xi, row.image(*xj));
    let overlap = row.reach() - distance - depth * row.min_radius();
    if overlap <= 0.0 || rounding(overlap, xi.length_squared() + xj.length_squared()) {
        return Change::Nothing;
    }
    // Inverse-mass shares: the lighter particle moves further.
    let [wi, wj] = row.inverse_mass;
    let share = overlap / (wi + wj);
    *xi += normal * (share * wi);
    *xj -= normal * (share * wj);
    Change::counted_if(overlap > POSITION_TOLERANCE * row.min_radius())
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
    let (blocks, planes) = (c.blocks, c.planes);
    // Pairs are left the slop deep: with the lecture's rule alone, a contact is one while the
    // pair overlaps, so it is still detected on the next step. Resting contacts are left there
    // too: moving them apart to touching (c2096ba) made every contact of a jammed 3D pile a
    // target of every sweep, the sweeps stopped at the cap, and a pour of 10^5 spheres went on
    // sinking into itself (52 % of r deep at step 1600, 8000 spheres in a deep box 36 %; with
    // the slop left: 1.0 %). A stack sinks by the slop at each contact instead (0.1 % of r).
    let depth = SLOP_FRACTION;
    let push_apart = |row: &mut Row<V>, xi: &mut V, xj: &mut V| separate_pair(row, xi, xj, depth);
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
            c.work.stamps,
            this,
            c.pairs,
            c.rows,
            false,
            &push_apart,
        );
        let on_planes = blocks.run_planes(
            position,
            c.work.stamps,
            this,
            c.plane_contacts,
            c.plane_rows,
            &out_of_plane,
        );
        if exchange.total(in_blocks + on_planes) + leftovers == 0 {
            break;
        }
    }
    // Planes last, for every particle the pair sweeps may have moved (the others moved only
    // out of their own planes above), so a walled box holds its particles; then measure.
    let out_of_all_planes = |x: &mut V, r: f64| {
        for plane in planes {
            *x = plane.push_out(*x, r);
        }
    };
    let finish = |row: &mut Row<V>, xi: &mut V, xj: &mut V| {
        if !planes.is_empty() {
            out_of_all_planes(xi, row.radius[0]);
            out_of_all_planes(xj, row.radius[1]);
        }
        let (_, distance) = contact_normal(*xi, row.image(*xj));
        row.overlap = ((row.reach() - distance) / row.min_radius()).max(0.0);
        Change::Nothing
    };
    blocks.every_pair(exchange, position, c.pairs, c.rows, &finish);
    if settings.planes_in_move(planes, gravity) {
        keep_energy(velocity, c, gravity);
    }
    exchange.settle_rows(blocks, c.rows);
    let local = c.rows.iter().map(|r| r.overlap).fold(0.0, f64::max);
    exchange.largest(local)
}
