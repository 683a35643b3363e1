//! The velocity phase and the move: gravity, impacts and resting impulses swept in substeps,
//! then `x += v dt`.

use super::{bounces::*, rows::*, rules::*, settings::*, shock::shock};
use crate::plane::Plane;
use crate::schedule::{Change, Exchange, MoveRules};
use crate::vector::Vector;
use rayon::prelude::*;
use std::time::Instant;

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
///    last step) is an *impact*, and remembers the speed `k s` it would separate at alone;
/// 2. `substeps` times, with `h = dt / substeps`: `v += g h`; the accumulated impulses are
///    applied (from the last step at first: warm starting); *relax* sweeps of accumulated
///    impulses until no contact approaches (a gap may close, no more); `x += v h`; the
///    contacts' geometry is brought up to date. When the last substep's relax hits its cap
///    (any substep's, in a step without impacts), a shock sweep follows (see [`shock`]). What
///    the last relax leaves is remembered for the next step;
/// 3. *restitution* (when there were impacts): sweeps until every impact separates at its
///    `k s`, a pair impact pushing back no more than `k` times the impulse that stopped it
///    (see [`kick_ceiling`]), and no other contact misses its goal by more than the resting
///    speed (what the impacts push into;
///    smaller misses are the relax's, left to the next step). An isolated impact so gets
///    exactly the lecture's formula, one against a pile at rest bounces off it as off a wall,
///    and impacts pressing on each other make no energy.
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
    let plan = StepPlan::new(exchange, settings, gravity, dt, velocity, c, own);
    let mut solve = VelocitySolve::default();
    for (index, pass) in (0..plan.substeps)
        .map(|_| Pass::Relax)
        .chain([Pass::Restitution])
        .enumerate()
    {
        let last_relax = index as u32 + 1 == plan.substeps;
        if pass == Pass::Restitution {
            keep_impulses(exchange, &plan, c);
            if plan.impacts == 0 {
                break;
            }
        } else {
            // (after the first substep, the move before took gravity in: see below)
            if index == 0 {
                let clock = Instant::now();
                let dv = gravity * plan.h;
                accelerate(plan.parallel, &mut velocity[..own], asleep, dv);
                solve.motion += clock.elapsed();
            }
            if plan.warm && !(index > 0 && plan.fused) {
                warm_start(exchange, velocity, c);
            }
        }
        sweep_pass(
            exchange, settings, &plan, pass, last_relax, velocity, c, &mut solve,
        );
        if pass == Pass::Relax {
            let clock = Instant::now();
            // (the next substep's gravity in the same pass over the particles: re-placing the
            // contacts reads positions alone, so it may come after)
            let next_fall = (!last_relax).then_some(gravity * plan.h);
            if plan.fused {
                let warm_next = plan.warm && !last_relax;
                let h = plan.h;
                move_place_and_warm(position, velocity, asleep, c, h, next_fall, warm_next);
            } else {
                let (x, v) = (&mut position[..own], &mut velocity[..own]);
                advance_positions(plan.parallel, x, v, asleep, plan.h, next_fall);
                if plan.substeps > 1 {
                    place(exchange, position, c, plan.h, last_relax);
                }
            }
            solve.motion += clock.elapsed();
        }
    }
    if plan.planes_in_move {
        let clock = Instant::now();
        let bounces = bounce_in_move(&mut position[..own], &mut velocity[..own], c, gravity, dt);
        solve.motion += clock.elapsed();
        solve.responses += exchange.total(bounces);
    }
    exchange.settle_rows(c.blocks, c.rows.reborrow());
    solve
}

/// What [`integrate`] decides once a step, before its passes.
struct StepPlan<V> {
    /// Substeps (1 for the lecture's step).
    substeps: u32,
    /// The substep, `dt / substeps`.
    h: f64,
    /// Impacts classified this step, over every process.
    impacts: u64,
    /// Whether planes bounce in the move (see [`bounce_in_move`]) instead of in the sweeps.
    planes_in_move: bool,
    /// Whether the remembered impulses are applied (warm starting).
    warm: bool,
    /// Whether the move, the re-placing and the next warm start go in one pass (see
    /// [`move_place_and_warm`]): a process alone, with substeps.
    fused: bool,
    /// Whether the passes run on the thread pool.
    parallel: bool,
    /// Up, against gravity, when there is gravity.
    up: Option<V>,
}

impl<V: Vector> StepPlan<V> {
    /// Classifies the step's impacts (see [`classify`]) and settles how the step goes.
    fn new<E: Exchange<V>>(
        exchange: &mut E,
        settings: &SolverSettings,
        gravity: V,
        dt: f64,
        velocity: &mut [V],
        c: &mut Contacts<V>,
        own: usize,
    ) -> Self {
        let elastic_planes = c.planes.iter().all(|p| p.restitution() >= 1.0);
        let substeps = if settings.lecture_only(elastic_planes) {
            1
        } else {
            settings.substeps.max(1)
        };
        let impacts = classify(
            exchange,
            settings,
            velocity,
            c,
            substeps as f64,
            gravity,
            dt,
        );
        let g = gravity.length_squared().sqrt();
        StepPlan {
            substeps,
            h: dt / substeps as f64,
            // (every process's count: each decides the same thing from it)
            impacts: exchange.total(impacts),
            planes_in_move: settings.planes_in_move(c.planes, gravity),
            warm: !settings.lecture_pairs() || !elastic_planes,
            fused: substeps > 1 && exchange.alone() && own == velocity.len(),
            parallel: c.blocks.parallel(),
            up: (gravity != V::ZERO).then(|| gravity * (-1.0 / g)),
        }
    }
}

/// Before the restitution pass: the rows settled between processes, and the impulses the
/// next step's warm start takes kept (the last substep's re-placing kept them already when
/// there are substeps: see [`place`]).
fn keep_impulses<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    plan: &StepPlan<V>,
    c: &mut Contacts<V>,
) {
    exchange.settle_rows(c.blocks, c.rows.reborrow());
    if plan.substeps == 1 {
        c.rows.keep_impulses(plan.parallel);
        for row in c.plane_rows.iter_mut() {
            row.kept = row.impulse;
        }
        exchange.keep_impulses();
    }
}

/// One pass's sweeps (see [`relax`]), then, when they hit their cap, a shock sweep: after the
/// last substep's relax, and after every substep's when nothing struck this step. (A shock
/// sweep in every substep while impacts rain on a pile stirs it, and the lecture pile came to
/// rest at step 1043 instead of 752; but a pile at rest sinks in the substeps that have none,
/// a column of 100 discs 2.8 % of r.)
#[allow(clippy::too_many_arguments)]
fn sweep_pass<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    settings: &SolverSettings,
    plan: &StepPlan<V>,
    pass: Pass,
    last_relax: bool,
    velocity: &mut [V],
    c: &mut Contacts<V>,
    solve: &mut VelocitySolve,
) {
    // (the restitution pass, once a step, may take the whole cap: an impact on a pile must
    // travel through it for the pile to hold)
    let cap = match pass {
        Pass::Restitution => settings.velocity_iterations.max(1),
        Pass::Relax => (settings.velocity_iterations / plan.substeps).max(1),
    };
    let with_planes = !plan.planes_in_move;
    let (sweeps, capped) = relax(
        exchange,
        settings,
        velocity,
        c,
        pass,
        cap,
        with_planes,
        solve,
    );
    let shock_now = last_relax || (pass == Pass::Relax && plan.impacts == 0);
    if let Some(up) = plan
        .up
        .filter(|_| capped && shock_now && !settings.lecture_pairs())
    {
        shock(exchange, velocity, c, up, with_planes);
    }
    solve.iterations += sweeps;
    solve.capped |= capped;
}

/// `v += dv` for every particle not `asleep` (empty: none is), on the thread pool when
/// `parallel` (each particle's update is its own, so the result is the same either way).
pub(super) fn accelerate<V: Vector>(parallel: bool, velocity: &mut [V], asleep: &[bool], dv: V) {
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

/// `x += v h`, then `v += dv` when `then_fall` is `Some(dv)`, for every particle not `asleep`
/// (see [`accelerate`]).
pub(super) fn advance_positions<V: Vector>(
    parallel: bool,
    position: &mut [V],
    velocity: &mut [V],
    asleep: &[bool],
    h: f64,
    then_fall: Option<V>,
) {
    let one = |x: &mut V, v: &mut V| advance(x, v, h, then_fall);
    let chunk = |(c, (x, v)): (usize, (&mut [V], &mut [V]))| {
        if asleep.is_empty() {
            x.iter_mut().zip(v).for_each(|(x, v)| one(x, v));
        } else {
            let asleep = &asleep[c * PARTICLE_CHUNK..][..x.len()];
            for ((x, v), &sleeps) in x.iter_mut().zip(v).zip(asleep) {
                if !sleeps {
                    one(x, v);
                }
            }
        }
    };
    if parallel {
        position
            .par_chunks_mut(PARTICLE_CHUNK)
            .zip(velocity.par_chunks_mut(PARTICLE_CHUNK))
            .enumerate()
            .for_each(chunk);
    } else {
        position
            .chunks_mut(PARTICLE_CHUNK)
            .zip(velocity.chunks_mut(PARTICLE_CHUNK))
            .enumerate()
            .for_each(chunk);
    }
}

/// One pass's sweeps (see [`integrate`]) until one changes nothing or `cap` is hit; returns the
/// sweeps made and whether the cap was hit. After the first sweep, each sweep visits only the
/// contacts whose particles the sweeps before it changed (the work list).
#[allow(clippy::too_many_arguments)]
pub(super) fn relax<V: Vector, E: Exchange<V>>(
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
    let lecture_pairs = settings.lecture_pairs();
    let pair_rule = |row: &mut Row<V>, record: &mut RowRecord, vi: &mut V, vj: &mut V| {
        if lecture_pairs {
            lecture_pair(row, record, vi, vj, k).into()
        } else {
            accumulate_pair(row, vi, vj, pass, resting, k)
        }
    };
    let plane_rule = |row: &mut PlaneRow<V>, v: &mut V| {
        if row.restitution >= 1.0 || resting <= 0.0 {
            lecture_plane(row, v).into()
        } else {
            accumulate_plane(row, v, pass, resting)
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
                &mut c.work.stamps,
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
            &mut c.work.stamps,
            this,
            c.pairs,
            c.rows.reborrow(),
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

/// Brings every contact's normal, detection and allowance up to date with the positions. With
/// `keep` (after the last substep's relax: nothing changes an impulse from there to the
/// restitution pass), also marks every impulse as the one the relax kept ([`RowRecord::kept`],
/// [`PlaneRow::kept`]) in the same pass: a pass of its own over 10^6 falling discs' rows took
/// 4.5-5.7 ms a step. Only that last place keeps the distance ([`RowRecord::distance`]), and a
/// place where a row leaves the step; the others leave the records unwritten.
pub(super) fn place<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    position: &mut [V],
    c: &mut Contacts<V>,
    h: f64,
    keep: bool,
) {
    let period = c.period;
    let pairs = |row: &mut Row<V>, record: &mut RowRecord, xi: &mut V, xj: &mut V| {
        place_pair(row, record, *xi, *xj, &period, h, keep);
        Change::Nothing
    };
    let planes = c.planes;
    let on_planes = |row: &mut PlaneRow<V>, x: &mut V| {
        place_plane(row, planes, *x, h, keep);
        Change::Nothing
    };
    c.blocks
        .every_plane(position, c.plane_contacts, c.plane_rows, &on_planes);
    c.blocks
        .every_pair(exchange, position, c.pairs, c.rows.reborrow(), &pairs);
}

/// Marks this step's impacts (see [`integrate`]) from the velocities before any impulse, and
/// returns how many this process found.
pub(super) fn classify<V: Vector, E: Exchange<V>>(
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
    let pairs = |row: &mut Row<V>, _: &mut RowRecord, vi: &mut V, vj: &mut V| {
        let speed = -row.normal.dot(*vi - *vj);
        // An impact across a gap (a pair that would meet within the step) bounces too, when
        // the relax pass finds it meeting: as in Box2D, a speculative contact keeps the speed
        // it bounces with instead of eating it.
        let fast = speed >= resting && row.impulse == 0.0;
        row.bounce = if fast { k * speed } else { 0.0 };
        row.struck = fast;
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
    let (in_blocks, leftovers) =
        c.blocks
            .every_pair(exchange, velocity, c.pairs, c.rows.reborrow(), &pairs);
    // (every process counts the leftovers: only whether there are any matters)
    on_planes + in_blocks + leftovers
}

/// Applies every remembered impulse once, before the first sweep.
pub(super) fn warm_start<V: Vector, E: Exchange<V>>(
    exchange: &mut E,
    velocity: &mut [V],
    c: &mut Contacts<V>,
) {
    let push = |row: &mut Row<V>, _: &mut RowRecord, vi: &mut V, vj: &mut V| {
        warm_pair(row, vi, vj);
        Change::Nothing
    };
    let on_planes = |row: &mut PlaneRow<V>, v: &mut V| {
        warm_plane(row, v);
        Change::Nothing
    };
    c.blocks
        .every_plane(velocity, c.plane_contacts, c.plane_rows, &on_planes);
    c.blocks
        .every_pair(exchange, velocity, c.pairs, c.rows.reborrow(), &push);
}

/// One particle's move over `h`: `x += v h`, then `v += dv` when `then_fall` is `Some(dv)`.
#[inline]
fn advance<V: Vector>(x: &mut V, v: &mut V, h: f64, then_fall: Option<V>) {
    *x += *v * h;
    if let Some(dv) = then_fall {
        *v += dv;
    }
}

/// Re-places one pair's row from `xi` and `xj` (`j` as stored; see [`place`]).
#[inline]
fn place_pair<V: Vector>(
    row: &mut Row<V>,
    record: &mut RowRecord,
    xi: V,
    xj: V,
    period: &[f64; 3],
    h: f64,
    keep: bool,
) {
    let xj = record.image(xj, period);
    // (the step's tally reads the distance where the row was last placed: this is that
    // place when it keeps or when the row leaves the step here. Other re-placings leave the
    // record unwritten, which saves writing its memory back: 10^6 falling discs' three
    // re-placings took 12.3 ms a step)
    if let Some(distance) = row.place(record, xi, xj, h) {
        if keep || row.allowance == f64::INFINITY {
            record.distance = distance;
        }
    }
    if keep {
        record.kept = row.impulse;
    }
}

/// Re-places one plane contact's row from its particle at `x` (see [`place`]).
#[inline]
fn place_plane<V: Vector>(row: &mut PlaneRow<V>, planes: &[Plane<V>], x: V, h: f64, keep: bool) {
    if keep {
        row.kept = row.impulse;
    }
    row.place(&planes[row.plane as usize], x, h);
}

/// One pair's remembered impulse, applied (see [`warm_start`]).
#[inline]
fn warm_pair<V: Vector>(row: &mut Row<V>, vi: &mut V, vj: &mut V) {
    if row.impulse > 0.0 {
        row.delivered += row.impulse;
        *vi += row.normal * (row.impulse * row.inverse_mass[0]);
        *vj -= row.normal * (row.impulse * row.inverse_mass[1]);
    }
}

/// One plane contact's remembered impulse, applied (see [`warm_start`]).
#[inline]
fn warm_plane<V: Vector>(row: &PlaneRow<V>, v: &mut V) {
    if row.impulse > 0.0 {
        *v += row.normal * row.impulse;
    }
}

/// For a process holding every slot: [`advance_positions`], [`place`] and, when `warm`,
/// the next substep's [`warm_start`], in one pass (see `schedule/both.rs`) instead of five,
/// with the same bits. At 10^6 falling discs, the five took 5.8 ms of each of a step's three
/// boundaries between substeps (one pass over the particles 0.9, re-placing 3.4, the warm
/// start 1.4); the one pass, about 1.3 ms less.
fn move_place_and_warm<V: Vector>(
    position: &mut [V],
    velocity: &mut [V],
    asleep: &[bool],
    c: &mut Contacts<V>,
    h: f64,
    then_fall: Option<V>,
    warm: bool,
) {
    let (planes, period) = (c.planes, c.period);
    // (the next warm start follows the last re-placing of a step: the restitution pass does
    // not take one)
    let keep = then_fall.is_none();
    let particle = |slot: usize, x: &mut V, v: &mut V| {
        if asleep.is_empty() || !asleep[slot] {
            advance(x, v, h, then_fall);
        }
    };
    let plane = |row: &mut PlaneRow<V>, x: &mut V, v: &mut V| {
        place_plane(row, planes, *x, h, keep);
        if warm {
            warm_plane(row, v);
        }
    };
    let pair = |row: &mut Row<V>,
                record: &mut RowRecord,
                (xi, xj): (&mut V, &mut V),
                (vi, vj): (&mut V, &mut V)| {
        place_pair(row, record, *xi, *xj, &period, h, keep);
        if warm {
            warm_pair(row, vi, vj);
        }
    };
    let rules = MoveRules {
        particle: &particle,
        plane: &plane,
        pair: &pair,
    };
    c.blocks.move_and_place(
        position,
        velocity,
        c.plane_contacts,
        c.plane_rows,
        c.pairs,
        c.rows.reborrow(),
        &rules,
    );
}
