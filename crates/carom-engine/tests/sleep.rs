//! Particles at rest sleep (issue 10): a poured pile falls asleep whole, gives the same bits on
//! every thread count and broad phase while it does, wakes when something hits it or a
//! parameter changes, and a ball dropped onto the sleeping pile bounces as its `k` says.
//! Assertions on state only.

use crate::support;

use carom_engine::glam::DVec2;
use carom_engine::{Aabb, BroadPhaseKind, World, WorldBuilder};
use support::{scatter, Lcg};

const DT: f64 = 1.0 / 60.0;
const G: f64 = 9.81;
const HALF: f64 = 25.0;

/// The walled box every scene here uses: dt = 1/60, g = 9.81, k = 0.5, sleep on.
fn the_box() -> WorldBuilder<DVec2> {
    World::<DVec2>::builder()
        .dt(DT)
        .gravity(DVec2::new(0.0, -G))
        .restitution(0.5)
        .domain(Aabb::new(DVec2::splat(-HALF), DVec2::splat(HALF)).unwrap())
        .walls(0.5)
        .sleep(true)
}

/// `n` discs of radius 1 at random in the upper half of a walled box, k = 0.5, sleep on.
fn pour(n: usize, seed: u64) -> WorldBuilder<DVec2> {
    let mut rng = Lcg::new(seed);
    let mut b = the_box();
    let position = |rng: &mut Lcg| {
        DVec2::new(
            rng.range(-HALF + 1.0, HALF - 1.0),
            rng.range(0.0, HALF - 1.0),
        )
    };
    let velocity = |rng: &mut Lcg| DVec2::new(7.0 * (rng.next() - 0.5), 7.0 * (rng.next() - 0.5));
    for (x, v) in scatter(n, &mut rng, position, velocity) {
        b = b.particle(x, v, 1.0, 1.0);
    }
    b
}

/// Steps `w` until every particle sleeps (at most `limit` steps); returns the step count.
fn until_asleep(w: &mut World<DVec2>, limit: usize) -> usize {
    for s in 1..=limit {
        w.step();
        if w.asleep() == w.len() {
            return s;
        }
    }
    panic!("{} of {} asleep after {limit} steps", w.asleep(), w.len());
}

fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn a_poured_pile_falls_asleep_whole_and_costs_nothing_to_step() {
    let mut w = pour(150, 21).build().unwrap();
    let slept = until_asleep(&mut w, 1500);
    assert!(slept > 60, "asleep after only {slept} steps");
    let hash = w.state_hash();
    for _ in 0..100 {
        let st = w.step();
        assert_eq!(st.asleep, w.len());
        assert_eq!(st.velocity_iterations, 0, "a sleeping world runs no sweeps");
    }
    // sleepers do not move at all, and have no velocity
    let end = w.state_hash();
    assert_eq!(w.kinetic_energy(), 0.0);
    let mut again = pour(150, 21).build().unwrap();
    for _ in 0..slept {
        again.step();
    }
    assert_eq!(again.state_hash(), hash);
    for _ in 0..100 {
        again.step();
    }
    assert_eq!(
        again.state_hash(),
        end,
        "sleeping steps change nothing but time"
    );
}

/// A pile asleep still lists its contacts: the resting contacts it fell asleep with, every one
/// overlapping (the lecture's detection), sorted by id, and about as many as while it was
/// awake.
#[test]
fn a_sleeping_pile_still_lists_its_contacts() {
    let mut w = pour(150, 21).build().unwrap();
    let slept = until_asleep(&mut w, 1500);
    let mut awake = pour(150, 21).build().unwrap();
    for _ in 0..slept - 1 {
        awake.step();
    }
    let before = awake.contacts().len();
    w.step();
    assert_eq!(w.asleep(), w.len());
    let contacts = w.contacts();
    assert!(
        contacts.len() * 2 >= before && before > 0,
        "{} asleep against {before} awake",
        contacts.len()
    );
    assert!(contacts.windows(2).all(|p| p[0] < p[1]));
    for &(a, b) in contacts {
        assert!(a < b);
        let ((xa, _, ra, _), (xb, _, rb, _)) = (w.particle(a as usize), w.particle(b as usize));
        assert!(xa.distance(xb) < ra + rb, "{a} and {b} apart");
    }
}

/// The same bits on 1, 2 and 3 threads and with every broad phase, through falling asleep.
#[test]
fn sleeping_is_the_same_on_every_thread_count_and_broad_phase() {
    let run = |threads: usize, kind: BroadPhaseKind| {
        on_threads(threads, || {
            let mut w = pour(150, 22).broad_phase(kind).build().unwrap();
            let mut asleep = Vec::new();
            for _ in 0..900 {
                asleep.push(w.step().asleep);
            }
            (w.state_hash(), asleep)
        })
    };
    let (reference, asleep) = run(1, BroadPhaseKind::Grid);
    assert_eq!(*asleep.last().unwrap(), 150, "the pile must fall asleep");
    for threads in [1, 2, 3] {
        for kind in [
            BroadPhaseKind::Grid,
            BroadPhaseKind::Hash,
            BroadPhaseKind::Brute,
        ] {
            let (hash, counts) = run(threads, kind);
            assert_eq!(hash, reference, "{threads} threads, {kind:?}");
            assert_eq!(counts, asleep, "{threads} threads, {kind:?}");
        }
    }
}

/// A ball dropped onto the sleeping pile wakes the part of it within reach, and bounces off it as
/// off a pile that never slept: its rebound is `k` times its impact speed within the pile's
/// give (as in `piles.rs`).
#[test]
fn a_ball_dropped_on_a_sleeping_pile_wakes_it_and_bounces_as_its_k_says() {
    let mut w = pour(150, 23).build().unwrap();
    until_asleep(&mut w, 1500);
    let p = w.particles();
    let top = (0..p.len())
        .max_by(|&a, &b| p.positions()[a].y.total_cmp(&p.positions()[b].y))
        .unwrap();
    let above = p.positions()[top] + DVec2::new(0.0, 8.0);
    let ball = w.len();
    let mut b = the_box();
    for i in 0..p.len() {
        b = b.particle(p.positions()[i], p.velocities()[i], 1.0, 1.0);
    }
    // the pile's rest times carry over (so it is still asleep); the new ball has rested 0 s
    let mut memory = w.contact_impulses();
    memory.rest.push(0.0);
    let mut w = b
        .particle(above, DVec2::new(0.0, -8.0), 1.0, 1.0)
        .impulses(memory)
        .build()
        .unwrap();
    // the pile keeps sleeping while the ball falls towards it
    assert_eq!(w.step().asleep, ball);
    let mut woke = false;
    for _ in 0..120 {
        let before = w.particle(ball).1.y;
        let st = w.step();
        woke |= st.asleep < ball;
        let after = w.particle(ball).1.y;
        if before < 0.0 && after > 0.0 {
            assert!(woke, "the pile must wake when the ball reaches it");
            let k = after / -before;
            assert!(
                (0.3..=0.55).contains(&k),
                "rebound {after} from {before}: k {k}"
            );
            return;
        }
    }
    panic!("the ball never bounced");
}

/// A changed parameter (gravity, k) or a set velocity wakes the sleepers it concerns.
#[test]
fn a_changed_parameter_or_velocity_wakes_sleepers() {
    let mut w = pour(60, 24).build().unwrap();
    until_asleep(&mut w, 1500);
    let n = w.len();

    w.set_gravity(DVec2::new(3.0, -G)).unwrap();
    assert!(w.step().asleep < n, "a new gravity wakes the pile");
    until_asleep(&mut w, 1500);

    w.set_restitution(0.9).unwrap();
    assert!(w.step().asleep < n, "a new k wakes the pile");
    until_asleep(&mut w, 1500);

    // one kicked particle wakes itself and its neighbours
    let x = w.particle(0).0;
    w.set_velocity(0, DVec2::new(0.0, 5.0)).unwrap();
    w.step();
    assert_ne!(w.particle(0).0, x, "the kicked particle moves");
}

/// With sleep off (the default) nothing ever sleeps, and a pile stepped either way agrees
/// until the first particle falls asleep.
#[test]
fn sleep_off_never_sleeps() {
    let mut on = pour(60, 25).build().unwrap();
    let mut off = pour(60, 25).sleep(false).build().unwrap();
    let mut diverged = false;
    for _ in 0..900 {
        let a = on.step().asleep;
        assert_eq!(off.step().asleep, 0);
        if a == 0 && !diverged {
            assert_eq!(on.state_hash(), off.state_hash());
        } else {
            diverged = true;
        }
    }
    assert!(diverged, "the pile with sleep on must have fallen asleep");
}

/// A world resumed from `w`'s state (particles by id, storage order, impulses, rest times).
fn resumed(w: &World<DVec2>) -> World<DVec2> {
    let p = w.particles();
    let mut b = the_box();
    for i in 0..p.len() {
        b = b.particle(
            p.positions()[i],
            p.velocities()[i],
            p.radii()[i],
            p.masses()[i],
        );
    }
    b.resume(w.steps_taken(), w.storage_order().to_vec())
        .impulses(w.contact_impulses())
        .build()
        .unwrap()
}

/// A world asleep skips its spatial sorts (a function of the state: every particle rested and
/// still), so one resumed while asleep, just before a sort, skips it too, and both continue
/// alike once something wakes them.
#[test]
fn a_run_resumed_while_asleep_continues_like_the_original() {
    let mut w = pour(150, 26).build().unwrap();
    until_asleep(&mut w, 1500);
    // up to the step before a spatial sort (every 32 steps)
    while (w.steps_taken() + 1) % 32 != 0 {
        w.step();
    }
    let mut again = resumed(&w);
    assert_eq!(again.state_hash(), w.state_hash());
    for world in [&mut w, &mut again] {
        for _ in 0..5 {
            world.step();
        }
        world.set_velocity(7, DVec2::new(3.0, 4.0)).unwrap();
    }
    for s in 0..200 {
        w.step();
        again.step();
        assert_eq!(
            again.state_hash(),
            w.state_hash(),
            "{s} steps after the kick"
        );
        assert_eq!(again.storage_order(), w.storage_order());
    }
}
