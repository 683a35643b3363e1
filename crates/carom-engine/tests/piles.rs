//! Piles at dt = 1/60 (issue 10): poured discs and spheres come to rest with small overlaps,
//! a column in a channel holds its height for a minute, and a ball dropped on a pile at rest
//! still bounces as its `k` says. Assertions on state only; the full sizes run in
//! `carom bench`.

use crate::support;

use carom_engine::glam::{DVec2, DVec3};
use carom_engine::{Aabb, Vector, World, WorldBuilder};
use support::{scatter, Lcg};

const DT: f64 = 1.0 / 60.0;
const G: f64 = 9.81;

/// Overlaps at the end of the state, as fractions of the smaller radius: (max, mean over
/// touching pairs), by brute force over the final positions.
fn overlaps<V: Vector>(w: &World<V>) -> (f64, f64) {
    let p = w.particles();
    let (x, r) = (p.positions(), p.radii());
    let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0usize);
    for i in 0..x.len() {
        for j in i + 1..x.len() {
            let d = (x[i] - x[j]).length_squared().sqrt();
            let o = (r[i] + r[j] - d) / r[i].min(r[j]);
            if o > 0.0 {
                max = max.max(o);
                sum += o;
                n += 1;
            }
        }
    }
    (max, if n > 0 { sum / n as f64 } else { 0.0 })
}

fn v_rms<V: Vector>(w: &World<V>) -> f64 {
    let mass: f64 = w.particles().masses().iter().sum();
    (2.0 * w.kinetic_energy() / mass).sqrt()
}

/// `n` particles of radius 1 at random in the upper part of a walled box, falling into a pile.
fn pour<V: Vector>(n: usize, half: f64, seed: u64) -> World<V> {
    let mut rng = Lcg::new(seed);
    let mut b = World::<V>::builder()
        .dt(DT)
        .gravity(V::from_slice(&[0.0, -G, 0.0]))
        .restitution(0.5)
        .domain(Aabb::new(V::from_slice(&[-half; 3]), V::from_slice(&[half; 3])).unwrap())
        .walls(0.5);
    let position = |rng: &mut Lcg| {
        let c: Vec<f64> = (0..3)
            .map(|a| {
                let lo = if a == 1 { 0.0 } else { -half + 1.0 };
                lo + rng.next() * (half - 1.0 - lo)
            })
            .collect();
        V::from_slice(&c)
    };
    let velocity = |rng: &mut Lcg| {
        let v: Vec<f64> = (0..3).map(|_| 7.0 * (rng.next() - 0.5)).collect();
        V::from_slice(&v)
    };
    for (x, v) in scatter(n, &mut rng, position, velocity) {
        b = b.particle(x, v, 1.0, 1.0);
    }
    b.build().unwrap()
}

/// Steps `w` and returns the largest overlap seen from `from` on (at the ends of the steps and
/// among the pairs each step found at its start), and how many of those steps hit the sweep
/// cap.
fn settle<V: Vector>(w: &mut World<V>, steps: usize, from: usize) -> (f64, usize) {
    let (mut worst, mut capped) = (0.0f64, 0);
    for s in 0..steps {
        let st = w.step();
        if s >= from {
            worst = worst.max(st.max_overlap).max(st.found_overlap);
            capped += st.capped as usize;
        }
    }
    (worst, capped)
}

/// Pours `w` for `steps` steps and checks the issue's target 1: at rest (asleep), overlaps at
/// the end under 1 % (max) and 0.2 % (mean) of r, under 5 % after the first 300 steps, and
/// (`calm_at_the_end`) no capped step in the last 600.
fn comes_to_rest<V: Vector>(mut w: World<V>, steps: usize, calm_at_the_end: bool) {
    let (worst, _) = settle(&mut w, steps - 600, 300);
    let (last, capped) = settle(&mut w, 600, 0);
    let worst = worst.max(last);
    // asleep at the end (particles at rest sleep by default), and for the 2D pile, as for the
    // lecture's, no step at the sweep cap in the last 600
    assert_eq!(w.asleep(), w.len(), "asleep at the end");
    if calm_at_the_end {
        assert_eq!(capped, 0, "steps at the sweep cap in the last 600");
    }
    let (max, mean) = overlaps(&w);
    assert!(max <= 0.01, "max overlap {max} r");
    assert!(mean <= 0.002, "mean overlap {mean} r");
    assert!(worst <= 0.05, "largest overlap after the pour {worst} r");
    assert!(v_rms(&w) <= 0.01 * G.sqrt(), "v_rms {}", v_rms(&w));
}

#[test]
fn poured_discs_come_to_rest_with_small_overlaps() {
    comes_to_rest(pour::<DVec2>(250, 30.0, 11), 1500, true);
}

#[test]
fn poured_spheres_come_to_rest_with_small_overlaps() {
    comes_to_rest(pour::<DVec3>(400, 12.0, 12), 1200, false);
}

/// Target 4 at a size for CI: a deep 3D pour (2500 spheres about 45 diameters deep in a 12 x 12
/// shaft) comes to rest, asleep, with the overlaps of target 1. A jammed 3D pile is where
/// moving resting pairs apart to touching failed (this pour ended 4.1 % of r deep and still
/// sinking; the 10^5-sphere pour of `carom bench` 52 %), and where a pile that sleeps only
/// whole never slept (its solver noise keeps a few spheres moving somewhere at any time).
#[test]
fn a_deep_3d_pour_comes_to_rest_without_sinking_into_itself() {
    let mut rng = Lcg::new(17);
    let mut b = World::<DVec3>::builder()
        .dt(DT)
        .gravity(DVec3::new(0.0, -G, 0.0))
        .restitution(0.5)
        .domain(Aabb::new(DVec3::new(-6.0, -6.0, -6.0), DVec3::new(6.0, 294.0, 6.0)).unwrap())
        .walls(0.5);
    for k in 0..2500 {
        let (layer, cell) = (k / 25, k % 25);
        let x = DVec3::new(
            -4.4 + 2.2 * (cell % 5) as f64,
            -4.0 + 2.2 * layer as f64,
            -4.4 + 2.2 * (cell / 5) as f64,
        );
        let v = DVec3::new(
            rng.range(-3.5, 3.5),
            rng.range(-3.5, 3.5),
            rng.range(-3.5, 3.5),
        );
        b = b.particle(x, v, 1.0, 1.0);
    }
    comes_to_rest(b.build().unwrap(), 1800, false);
}

/// Target 4, wider: 5000 spheres poured into a 24 x 24 shaft come to rest, asleep, by step
/// 1200 with the overlaps of target 1. With piles asleep only whole (as islands), this test
/// fails: a few spheres are always moving somewhere in the pile (the 5000-sphere pour of
/// docs/benchmarks.md, much like this one, slept from step 2974 then; part by part, from 692).
#[test]
fn a_wide_3d_pour_falls_asleep_part_by_part() {
    let mut rng = Lcg::new(5000);
    let mut b = World::<DVec3>::builder()
        .dt(DT)
        .gravity(DVec3::new(0.0, -G, 0.0))
        .restitution(0.5)
        .domain(
            Aabb::new(
                DVec3::new(-12.0, -12.0, -12.0),
                DVec3::new(12.0, 108.0, 12.0),
            )
            .unwrap(),
        )
        .walls(0.5);
    let position = |rng: &mut Lcg| {
        DVec3::new(
            rng.range(-11.0, 11.0),
            rng.range(-11.0, 107.0),
            rng.range(-11.0, 11.0),
        )
    };
    let velocity = |rng: &mut Lcg| {
        DVec3::new(
            rng.range(-3.5, 3.5),
            rng.range(-3.5, 3.5),
            rng.range(-3.5, 3.5),
        )
    };
    for (x, v) in scatter(5000, &mut rng, position, velocity) {
        b = b.particle(x, v, 1.0, 1.0);
    }
    comes_to_rest(b.build().unwrap(), 1200, false);
}

/// `count` discs of radius 1 stacked from the floor of a channel one diameter (plus 1 %)
/// wide and `height` tall, at rest (g = 9.81, k = 0.5, dt = 1/60, walls of k = 0.5).
fn channel_column(count: usize, height: f64) -> WorldBuilder<DVec2> {
    let mut b = World::<DVec2>::builder()
        .dt(DT)
        .gravity(DVec2::new(0.0, -G))
        .restitution(0.5)
        .domain(Aabb::new(DVec2::new(-1.01, 0.0), DVec2::new(1.01, height)).unwrap())
        .walls(0.5);
    for k in 0..count {
        b = b.particle(DVec2::new(0.0, 1.0 + 2.0 * k as f64), DVec2::ZERO, 1.0, 1.0);
    }
    b
}

/// Target 3: 100 discs stacked in a channel one diameter (plus 1%) wide hold their height for
/// 60 s: the top sinks less than 1 % of r (measured: 0.000; 0.47 % with the shock sweep of
/// 9307d7c, 2.8 % with today's run only once a step). Equal and opposite impulses alone let it sink 12 % while
/// the remembered impulses caught up; the shock sweep holds it.
#[test]
fn a_column_of_100_discs_holds_for_a_minute() {
    let mut w = channel_column(100, 250.0).build().unwrap();
    let top = w.particle(99).0.y;
    for _ in 0..3600 {
        w.step();
    }
    let sunk = top - w.particle(99).0.y;
    assert!(sunk < 0.01, "the top disc sank {sunk} r");
    assert!(v_rms(&w) < 0.01 * G.sqrt(), "v_rms {}", v_rms(&w));
}

/// A ball dropped onto a pile at rest bounces off it nearly as off a floor: its rebound speed
/// is between 0.6 and 1.1 times `k` times its impact speed (the pile gives a little within the
/// step's sweeps). In 3D the pile is asleep when the ball arrives, so this is also the ball
/// waking the part of a sleeping pile it lands on.
#[test]
fn a_ball_dropped_on_a_resting_pile_bounces_as_its_k_says() {
    ball_bounces_off(pour::<DVec2>(150, 25.0, 13), 25.0);
}

#[test]
fn a_ball_dropped_on_a_resting_3d_pile_bounces_as_its_k_says() {
    let mut w = pour::<DVec3>(400, 12.0, 12);
    settle(&mut w, 1200, 0);
    assert_eq!(w.asleep(), w.len(), "the pile must be asleep");
    ball_bounces_off(w, 12.0);
}

/// Settles `w` (a pile in a walled box of half-size `half`), drops a ball on its highest
/// particle and checks the rebound (see above).
fn ball_bounces_off<V: Vector>(mut w: World<V>, half: f64) {
    settle(&mut w, 1200, 0);
    assert!(v_rms(&w) < 0.01 * G.sqrt());
    // the highest particle of the pile, and a ball 6 radii above it
    let p = w.particles();
    let height = |x: V| x.get(1);
    let top = (0..p.len())
        .max_by(|&a, &b| height(p.positions()[a]).total_cmp(&height(p.positions()[b])))
        .unwrap();
    let below = p.positions()[top];
    let mut b = World::<V>::builder()
        .dt(DT)
        .gravity(V::from_slice(&[0.0, -G, 0.0]))
        .restitution(0.5)
        .domain(Aabb::new(V::from_slice(&[-half; 3]), V::from_slice(&[half; 3])).unwrap())
        .walls(0.5);
    for i in 0..p.len() {
        b = b.particle(p.positions()[i], p.velocities()[i], 1.0, 1.0);
    }
    let ball = p.len();
    // (the pile's rest times carry over when it has any; the new ball has rested 0 s)
    let mut memory = w.contact_impulses();
    if !memory.rest.is_empty() {
        memory.rest.push(0.0);
    }
    let mut w = b
        .particle(
            below + V::from_slice(&[0.0, 8.0, 0.0]),
            V::from_slice(&[0.0, -8.0, 0.0]),
            1.0,
            1.0,
        )
        .impulses(memory)
        .build()
        .unwrap();
    let mut impact = 0.0;
    for _ in 0..120 {
        let before = height(w.particle(ball).1);
        w.step();
        let after = height(w.particle(ball).1);
        if before < 0.0 && after > 0.0 {
            impact = -before;
            let rebound = after;
            let k = rebound / impact;
            assert!(
                (0.3..=0.55).contains(&k),
                "rebound {rebound} from {impact}: k {k}"
            );
            return;
        }
    }
    panic!("the ball never bounced (impact speed {impact})");
}

/// Hexagonally packed rows of radius-1 discs on the floor of a box `2 n` wide. In a box, even
/// rows hold `n` discs from wall to wall and odd rows `n - 1` in their grooves; in a pyramid
/// each row holds one disc fewer than the row below (the bottom row from wall to wall: the
/// frictionless discs need the walls to hold them).
fn hex_stack(n: usize, rows: usize, pyramid: bool) -> World<DVec2> {
    let width = 2.0 * n as f64;
    let mut b = World::<DVec2>::builder()
        .dt(DT)
        .gravity(DVec2::new(0.0, -G))
        .restitution(0.5)
        .domain(
            Aabb::new(
                DVec2::new(-width / 2.0, 0.0),
                DVec2::new(width / 2.0, 4.0 * rows as f64),
            )
            .unwrap(),
        )
        .walls(0.5);
    for row in 0..rows {
        // discs a row is shifted right by, and so short of n
        let shift = if pyramid { row } else { row % 2 };
        let y = 1.0 + row as f64 * 3f64.sqrt();
        for k in 0..n - shift {
            let x = -width / 2.0 + 1.0 + (shift + 2 * k) as f64;
            b = b.particle(DVec2::new(x, y), DVec2::ZERO, 1.0, 1.0);
        }
    }
    b.build().unwrap()
}

/// Steps `w` for `steps` and returns how far its highest disc sank, in radii.
fn top_sinks(mut w: World<DVec2>, steps: usize) -> (f64, World<DVec2>) {
    let highest = |w: &World<DVec2>| {
        w.particles()
            .positions()
            .iter()
            .map(|x| x.y)
            .fold(f64::MIN, f64::max)
    };
    let top = highest(&w);
    for _ in 0..steps {
        w.step();
    }
    (top - highest(&w), w)
}

/// Target 3: 30 hexagonal rows (585 discs) filling a walled box hold for 60 s at dt = 1/60,
/// the top sinking less than 1 % of r (measured: it rises 0.10 %).
#[test]
fn thirty_hexagonal_rows_from_wall_to_wall_hold_for_a_minute() {
    let (sunk, w) = top_sinks(hex_stack(20, 30, false), 3600);
    assert!(sunk < 0.01, "the top row sank {sunk} r");
    assert!(v_rms(&w) < 0.01 * G.sqrt(), "v_rms {}", v_rms(&w));
}

/// A 20-row pyramid (210 discs) holds for 60 s the same way (measured: the apex sinks 0.028 %).
#[test]
fn a_hexagonal_pyramid_holds_for_a_minute() {
    let (sunk, w) = top_sinks(hex_stack(20, 20, true), 3600);
    assert!(sunk < 0.01, "the apex sank {sunk} r");
    assert!(v_rms(&w) < 0.01 * G.sqrt(), "v_rms {}", v_rms(&w));
}

/// The settled phase of a tall pile: 600 hexagonal rows (5700 discs, six solver blocks) stand
/// at rest from the first steps, their contacts overlapping no deeper than the slop. The shock
/// sweep carries the support from the floor to the top in one sweep, block after block; when
/// it ran the even blocks and then the odd ones, the top sank 2.5 r in 120 steps (on a pile
/// 100 discs wide), and when it pushed along each contact's normal it flew apart in one step.
#[test]
fn six_hundred_hexagonal_rows_stand_still() {
    let (sunk, w) = top_sinks(hex_stack(10, 600, false), 120);
    assert!(sunk.abs() < 0.03, "the top row sank {sunk} r");
    assert_eq!(w.asleep(), w.len());
    let (max, _) = overlaps(&w);
    assert!(max < 0.0011, "overlap {max} r");
}

/// The shock sweep on its own: with one velocity sweep a step and no substeps (every step
/// capped), a column of 20 discs does not sink at all and falls asleep. (Without the shock
/// sweep it sank up to 0.66 r, then rose 0.33 r above its start, and never came to rest.)
#[test]
fn one_sweep_a_step_still_holds_a_column() {
    let b = channel_column(20, 50.0).iterations(1, 4).substeps(1);
    let mut w = b.build().unwrap();
    let top = w.particle(19).0.y;
    let mut deepest: f64 = 0.0;
    for _ in 0..600 {
        w.step();
        deepest = deepest.max(top - w.particle(19).0.y);
    }
    assert!(deepest < 0.002, "the top sank {deepest} r");
    assert_eq!(w.asleep(), 20);
}

/// The shock sweep runs only when the sweeps hit their cap: a cluster falling freely under
/// gravity, its contacts resting (k = 0.5) and its sweeps converging, gains exactly the
/// momentum gravity gives it.
#[test]
fn a_converged_cluster_under_gravity_keeps_its_momentum() {
    let mut b = World::<DVec2>::builder()
        .dt(DT)
        .gravity(DVec2::new(0.0, -G))
        .restitution(0.5);
    let bodies = [
        (0.0, 0.0, 0.3, -0.2),
        (1.99, 0.0, -0.5, 0.1),
        (1.0, 1.72, 0.1, -0.6),
        (-1.0, 1.72, 0.2, 0.0),
    ];
    for (x, y, vx, vy) in bodies {
        b = b.particle(DVec2::new(x, y), DVec2::new(vx, vy), 1.0, 1.0 + x.abs());
    }
    let mut w = b.build().unwrap();
    let p0 = w.momentum();
    let mass: f64 = (0..4).map(|i| w.particle(i).3).sum();
    let (mut capped, mut responses) = (0, 0);
    for _ in 0..120 {
        let stats = w.step();
        capped += stats.capped as u32;
        responses += stats.responses;
    }
    assert_eq!(capped, 0);
    assert!(responses > 10, "{responses} responses");
    let expected = p0 + DVec2::new(0.0, -G) * (mass * 120.0 * DT);
    let error = (w.momentum() - expected).length();
    assert!(error < 1e-10 * expected.length(), "|dP| = {error:e}");
}

/// `n` discs of radius 1 at random over a walled box of half-size `half` (no two closer than
/// touching), velocities up to 3.5 on each axis, restitution `k` for pairs and walls.
fn lively_box(n: usize, half: f64, k: f64, seed: u64) -> World<DVec2> {
    let mut rng = Lcg::new(seed);
    let mut b = World::<DVec2>::builder()
        .dt(DT)
        .gravity(DVec2::new(0.0, -G))
        .restitution(k)
        .domain(Aabb::new(DVec2::splat(-half), DVec2::splat(half)).unwrap())
        .walls(k);
    let inside = half - 1.0;
    let position =
        |rng: &mut Lcg| DVec2::new(rng.range(-inside, inside), rng.range(-inside, inside));
    let velocity = |rng: &mut Lcg| DVec2::new(rng.range(-3.5, 3.5), rng.range(-3.5, 3.5));
    for (x, v) in scatter(n, &mut rng, position, velocity) {
        b = b.particle(x, v, 1.0, 1.0);
    }
    b.build().unwrap()
}

/// A lively pile never makes energy: 400 discs falling in a small box at `k` near 1, where
/// impacts press on each other in the lower layers every step. With each impact aimed at
/// separating at `k` times its approach (Newton's law) and nothing else (before Poisson's law
/// capped it: see the solver's `kick_ceiling`), the total energy at `k = 0.95` ran away within
/// 100 steps (a box of 500 such discs: 3950 at the start, 1.8e7 at step 100, 10^13 radii a step
/// by step 160; here the old pass fails at `k = 0.95`, step 137: 797.5 against 331.4).
/// Kinetic plus potential energy may only rise by what the position phase lifts the discs (the
/// bound: 5 % of a radius for every disc; measured, it never rose above the start, and was
/// 688 below it by step 50 at `k = 0.99`).
#[test]
fn a_lively_pile_at_k_near_1_never_makes_energy() {
    for (k, seed) in [(0.95, 5), (0.99, 6)] {
        let mut w = lively_box(400, 28.0, k, seed);
        let energy = |w: &World<DVec2>| w.kinetic_energy() + w.potential_energy();
        let start = energy(&w);
        let lift = w.len() as f64 * G * 0.05;
        for step in 1..=300 {
            w.step();
            let now = energy(&w);
            assert!(
                now <= start + lift,
                "k = {k}, step {step}: energy {now} against {start} at the start"
            );
        }
    }
}

/// Every pair of a column at rest on a floor pushes ([`StepStats::pushing`]), carrying the
/// weight above it, whether or not the lecture's detection finds it overlapping
/// ([`StepStats::contacts`]); asleep, nothing pushes.
///
/// [`StepStats::contacts`]: carom_engine::StepStats::contacts
/// [`StepStats::pushing`]: carom_engine::StepStats::pushing
#[test]
fn every_pair_of_a_resting_column_pushes() {
    let column = |sleep: bool| channel_column(10, 40.0).sleep(sleep).build().unwrap();
    let mut w = column(false);
    let mut last = w.step();
    for _ in 0..60 {
        last = w.step();
    }
    assert_eq!(last.pushing, 9, "{last:?}");
    let mut w = column(true);
    for _ in 0..600 {
        last = w.step();
    }
    assert_eq!(last.asleep, 10, "{last:?}");
    assert_eq!(last.pushing, 0, "{last:?}");
}

/// A column partly asleep: the top disc of a sleeping column, kicked up, falls back onto it
/// and wakes the discs within reach of it. Only the pairs with an awake disc can push (two
/// sleepers' contacts leave the solver), and once the top disc rests again every awake disc
/// presses on the one below it: `pushing` counts those pairs, no more and no fewer.
#[test]
fn a_column_partly_asleep_pushes_only_where_awake() {
    let mut w = channel_column(10, 40.0).build().unwrap();
    for _ in 0..600 {
        w.step();
    }
    assert_eq!(w.asleep(), 10);
    w.set_velocity(9, DVec2::new(0.0, 3.0)).unwrap();
    let mut resting_partly = 0;
    for _ in 0..120 {
        let s = w.step();
        let awake = 10 - s.asleep;
        // (the pairs with an awake disc are the awake discs' pairs with the disc below)
        assert!(s.pushing <= awake, "{s:?}");
        if s.asleep > 0 && awake > 1 && s.pushing == awake {
            resting_partly += 1;
        }
    }
    assert!(
        resting_partly > 0,
        "no step found the column partly asleep and pressing"
    );
    assert_eq!(w.asleep(), 10, "the column should sleep again");
}
