//! The decomposition over ranks gives the very bits of one world: ranks run as threads here
//! (the `carom` binary's MPI runs are tested in carom-cli).

use crate::support;
use support::Lcg;

use carom_engine::cluster::{Subdomain, ThreadTransport, TrafficKind};
use carom_engine::glam::{DVec2, DVec3};
use carom_engine::{Aabb, BroadPhaseKind, Snapshot, StepStats, Vector, World, WorldBuilder};

/// `n` particles in `(-half, half)^DIM`, every fifth of radius `big`, the rest radius 1.
fn scene<V: Vector>(n: usize, half: f64, big: f64, seed: u64) -> WorldBuilder<V> {
    let mut rng = Lcg::new(seed);
    let mut b = World::<V>::builder();
    for i in 0..n {
        let r = if i % 5 == 0 { big } else { 1.0 };
        let x = rng.vector(-half + r, half - r);
        let v = rng.vector(-20.0, 20.0);
        b = b.particle(x, v, r, rng.range(0.5, 4.0));
    }
    b
}

/// Walled box under gravity, particle k = 0.5 (the lecture's first demo, denser).
fn walled<V: Vector>(n: usize, half: f64, big: f64) -> WorldBuilder<V> {
    scene(n, half, big, 7)
        .dt(0.01)
        .gravity(V::from_slice(&[0.0, -9.81, 0.0]))
        .restitution(0.5)
        .domain(Aabb::new(V::from_slice(&[-half; 3]), V::from_slice(&[half; 3])).unwrap())
        .walls(0.8)
}

/// Runs `steps` steps on `ranks` threads; returns rank 0's gathered state, the bytes rank 0
/// sent and rank 0's statistics of every step.
fn split_run<V: Vector>(
    build: impl Fn() -> World<V> + Sync,
    ranks: usize,
    steps: u64,
) -> (Snapshot<V>, u64, Vec<StepStats>) {
    std::thread::scope(|s| {
        let handles: Vec<_> = ThreadTransport::group(ranks)
            .into_iter()
            .enumerate()
            .map(|(rank, mut t)| {
                let build = &build;
                s.spawn(move || {
                    let world = build();
                    let mut sub = Subdomain::new(&world, rank, ranks).unwrap();
                    let stats: Vec<_> = (0..steps).map(|_| sub.step(&mut t)).collect();
                    let snapshot = sub.gather(&mut t);
                    (snapshot, sub.traffic().total_bytes(), stats)
                })
            })
            .collect();
        let mut results: Vec<_> = handles.into_iter().map(|h| h.join().unwrap()).collect();
        let (snapshot, bytes, stats) = results.remove(0);
        assert!(
            results.iter().all(|(s, ..)| s.is_none()),
            "only rank 0 gathers"
        );
        (snapshot.expect("rank 0 gathers"), bytes, stats)
    })
}

fn check_identical<V: Vector>(build: impl Fn() -> World<V> + Sync, steps: u64, ranks: &[usize]) {
    let mut whole = build();
    let whole_stats: Vec<_> = (0..steps).map(|_| whole.step()).collect();
    for &p in ranks {
        let (snapshot, bytes, stats) = split_run(&build, p, steps);
        assert_eq!(stats, whole_stats, "{p} ranks: the steps' statistics");
        assert_eq!(snapshot.steps_taken, steps);
        assert_eq!(
            snapshot.storage_order,
            whole.storage_order(),
            "{p} ranks: order"
        );
        let mut rebuilt = build();
        rebuilt.restore(snapshot).unwrap();
        assert_eq!(
            rebuilt.state_hash(),
            whole.state_hash(),
            "{p} ranks differ from one world after {steps} steps"
        );
        assert_eq!(
            rebuilt.contact_impulses(),
            whole.contact_impulses(),
            "{p} ranks: remembered impulses and rest times"
        );
        if p > 1 {
            assert!(bytes > 0, "{p} ranks exchanged nothing");
        }
    }
}

#[test]
fn walled_2d_pile_is_bit_identical_on_1_to_4_ranks() {
    // 5000 particles: five solver blocks, so four ranks all hold some; radii 1 and 3 make
    // contacts that reach past the next block (leftovers).
    check_identical(
        || walled::<DVec2>(5000, 100.0, 3.0).build().unwrap(),
        70,
        &[1, 2, 3, 4],
    );
}

/// The lecture's step under gravity with k = 1 and elastic walls: walls bounce at their time of
/// impact within the move, and the position phase pays for lifts out of walls from the speeds
/// (own particles only, as every rank does for its own).
#[test]
fn elastic_walled_2d_gas_under_gravity_is_bit_identical_on_2_and_3_ranks() {
    check_identical(
        || {
            walled::<DVec2>(5000, 100.0, 3.0)
                .restitution(1.0)
                .walls(1.0)
                .build()
                .unwrap()
        },
        70,
        &[2, 3],
    );
}

/// The same gas with the lecture's step covering pushes (`cover_pushes`): reaches raised to
/// the partners' speeds, every pair within reach a candidate, and steps taken again, which
/// this gas needs within its first steps.
#[test]
fn a_gas_covering_pushes_is_bit_identical_on_2_and_3_ranks() {
    let build = || {
        walled::<DVec2>(5000, 100.0, 3.0)
            .restitution(1.0)
            .walls(1.0)
            .cover_pushes(true)
            .build()
            .unwrap()
    };
    let mut w = build();
    let retaken = (0..40).filter(|_| w.step().retakes > 0).count();
    assert!(
        retaken > 0,
        "no step was taken again: the test would mean little"
    );
    check_identical(build, 40, &[2, 3]);
}

#[test]
fn open_3d_cloud_with_the_hash_is_bit_identical() {
    let build = || {
        scene::<DVec3>(6000, 30.0, 2.0, 11)
            .dt(0.005)
            .broad_phase(BroadPhaseKind::Hash)
            .build()
            .unwrap()
    };
    check_identical(build, 40, &[2, 4]);
}

/// Above `PARALLEL_MIN` every phase of a world, and of a lone rank, runs in parallel chunks:
/// spheres in a walled box on one rank and two, the whole world on a pool of one thread and of
/// two (the ranks on the global pool), all the same bits.
#[test]
fn a_3d_pile_above_the_parallel_threshold_is_bit_identical_on_ranks_and_threads() {
    let n = 9000;
    assert!(n > carom_engine::broadphase::PARALLEL_MIN);
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let build = || walled::<DVec3>(n, 45.0, 2.0).build().unwrap();
        pool.install(|| check_identical(build, 20, &[1, 2]));
    }
}

#[test]
fn more_ranks_than_blocks_still_agrees() {
    check_identical(
        || walled::<DVec2>(300, 30.0, 2.0).build().unwrap(),
        40,
        &[3],
    );
}

/// A walled box at dt = 1/60 and k = 0, particles of radii 1 and 2 and masses 0.5-4 falling
/// at up to 20 into a pile: pushes down chains of contacts drive particles beyond their
/// reaches, and the steps are taken again (see the solver's notes on escapes).
fn struck_pile() -> World<DVec2> {
    walled::<DVec2>(3000, 80.0, 2.0)
        .dt(1.0 / 60.0)
        .restitution(0.0)
        .build()
        .unwrap()
}

#[test]
fn steps_taken_again_are_bit_identical_on_1_to_3_ranks() {
    let mut whole = struck_pile();
    let retaken = (0..STRUCK_STEPS)
        .filter(|_| whole.step().retakes > 0)
        .count();
    assert!(retaken > 0, "the scene must take steps again");
    check_identical(struck_pile, STRUCK_STEPS, &[1, 2, 3]);
}

const STRUCK_STEPS: u64 = 120;

/// A walled pile at dt = 1/60 whose particles sleep early (a short sleep time, a generous
/// sleep speed), so that sleeping and waking parts span the ranks' borders.
fn sleepy_pile() -> World<DVec2> {
    walled::<DVec2>(3000, 80.0, 2.0)
        .dt(1.0 / 60.0)
        .sleep(true)
        .sleep_speed(6.0)
        .sleep_time(0.1)
        .build()
        .unwrap()
}

#[test]
fn sleeping_is_bit_identical_on_1_to_4_ranks() {
    let mut whole = sleepy_pile();
    let (mut most, mut woke, mut part) = (0, false, false);
    for _ in 0..160 {
        let asleep = whole.step().asleep;
        woke |= asleep < most;
        most = most.max(asleep);
        part |= asleep > 0 && asleep < whole.len();
    }
    assert!(most > 200, "the scene must sleep: at most {most} asleep");
    assert!(woke, "and particles must wake again");
    assert!(part, "with part of the pile asleep and part awake");
    check_identical(sleepy_pile, 160, &[1, 2, 3, 4]);
}

/// A split run started from a world in which particles sleep (their rest times go with the
/// particles) continues like it.
#[test]
fn a_world_split_while_asleep_continues_like_the_original() {
    let mut whole = sleepy_pile();
    for _ in 0..120 {
        whole.step();
    }
    assert!(whole.asleep() > 0);
    let start = Snapshot {
        steps_taken: whole.steps_taken(),
        storage_order: whole.storage_order().to_vec(),
        particles: whole.particles().clone(),
        impulses: whole.contact_impulses(),
    };
    let build = || {
        let mut w = sleepy_pile();
        w.restore(start.clone()).unwrap();
        w
    };
    let (snapshot, ..) = split_run(build, 3, 50);
    for _ in 0..50 {
        whole.step();
    }
    let mut rebuilt = sleepy_pile();
    rebuilt.restore(snapshot).unwrap();
    assert_eq!(rebuilt.state_hash(), whole.state_hash());
    assert_eq!(rebuilt.contact_impulses(), whole.contact_impulses());
}

#[test]
fn restored_world_continues_like_the_original() {
    let build = || walled::<DVec2>(2000, 60.0, 3.0).build().unwrap();
    let mut whole = build();
    for _ in 0..45 {
        whole.step();
    }
    let (snapshot, ..) = split_run(build, 2, 45);
    let mut continued = build();
    continued.restore(snapshot).unwrap();
    for _ in 0..30 {
        whole.step();
        continued.step();
    }
    assert_eq!(continued.state_hash(), whole.state_hash());
}

#[test]
fn traffic_is_counted_by_kind() {
    let build = || walled::<DVec2>(5000, 100.0, 3.0).build().unwrap();
    std::thread::scope(|s| {
        let handles: Vec<_> = ThreadTransport::group(2)
            .into_iter()
            .enumerate()
            .map(|(rank, mut t)| {
                s.spawn(move || {
                    let mut sub = Subdomain::new(&build(), rank, 2).unwrap();
                    for _ in 0..10 {
                        sub.step(&mut t);
                    }
                    sub.traffic().clone()
                })
            })
            .collect();
        for h in handles {
            let t = h.join().unwrap();
            for kind in [
                TrafficKind::Halo,
                TrafficKind::Ghosts,
                TrafficKind::Migration,
            ] {
                assert!(t.bytes(kind) > 0, "{} sent nothing", kind.name());
            }
            assert_eq!(t.bytes(TrafficKind::Gather), 0);
            assert!(t.total_collectives() >= 10);
        }
    });
}

mod random_scenes {
    use super::*;
    use proptest::prelude::*;

    /// A random scene: 2100-4000 particles (at least three solver blocks in 2D), radii 1 and
    /// `big`, any restitution, gravity and walls or neither (an open cloud with the hash).
    fn build<V: Vector>(n: usize, big: f64, k: f64, walled_box: bool, seed: u64) -> World<V> {
        let half = 2.6 * (n as f64).powf(1.0 / V::DIM as f64);
        // (every other seed with particles that sleep early)
        let b = scene::<V>(n, half, big, seed)
            .restitution(k)
            .sleep(seed % 2 == 0)
            .sleep_speed(3.0)
            .sleep_time(0.02);
        let b = if walled_box {
            b.dt(0.005)
                .gravity(V::from_slice(&[0.0, -9.81, 0.0]))
                .domain(Aabb::new(V::from_slice(&[-half; 3]), V::from_slice(&[half; 3])).unwrap())
                .walls(0.7)
        } else {
            b.dt(0.004).broad_phase(BroadPhaseKind::Hash)
        };
        b.build().unwrap()
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 6, ..ProptestConfig::default() })]

        #[test]
        fn any_2d_scene_is_bit_identical_on_any_rank_count(
            n in 2100usize..4000, big in 1.0f64..3.0, k in 0.0f64..=1.0, walled_box: bool,
            seed in 0u64..1000, ranks in 2usize..=4, steps in 20u64..50,
        ) {
            check_identical(|| build::<DVec2>(n, big, k, walled_box, seed), steps, &[ranks]);
        }

        #[test]
        fn any_3d_scene_is_bit_identical_on_any_rank_count(
            n in 2100usize..4000, big in 1.0f64..2.0, k in 0.0f64..=1.0, walled_box: bool,
            seed in 0u64..1000, ranks in 2usize..=3, steps in 20u64..40,
        ) {
            check_identical(|| build::<DVec3>(n, big, k, walled_box, seed), steps, &[ranks]);
        }
    }
}
