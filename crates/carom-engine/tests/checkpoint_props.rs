//! Property: over random small scenes, 2D and 3D, saving a checkpoint after some steps and
//! resuming from its bytes gives the very same state (bit for bit, by `state_hash`) as running
//! straight through. The round trip goes through `carom_output::checkpoint::Checkpoint`'s real
//! byte format (`write_to` / `read_from`), not through in-memory copies. Some scenes let particles
//! sleep, so a checkpoint taken with sleepers (their rest times) resumes the same.

use carom_engine::glam::{DVec2, DVec3};
use carom_engine::{Aabb, BroadPhaseKind, Particles, Vector, World, WorldBuilder};
use carom_output::checkpoint::Checkpoint;
use proptest::prelude::*;

/// The scene parameters a checkpoint's scene text would carry (everything but the particles).
#[derive(Debug, Clone)]
struct Setup {
    kind: BroadPhaseKind,
    walls: bool,
    gravity: [f64; 3],
    restitution: f64,
    dt: f64,
    /// Particles sleep at this speed (after 0.05 time units at rest), or never.
    sleep_speed: Option<f64>,
}

type Body = ([f64; 3], [f64; 3], f64, f64);

fn builder<V: Vector>(setup: &Setup, particles: Particles<V>) -> WorldBuilder<V> {
    let mut b = World::builder()
        .dt(setup.dt)
        .gravity(V::from_slice(&setup.gravity))
        .restitution(setup.restitution)
        .broad_phase(setup.kind)
        .particles(particles);
    if let Some(speed) = setup.sleep_speed {
        b = b.sleep(true).sleep_speed(speed).sleep_time(0.05);
    }
    if setup.walls {
        let half = V::from_slice(&[10.0; 3]);
        b = b
            .domain(Aabb::new(V::ZERO - half, half).unwrap())
            .walls(0.9);
    }
    b
}

fn particles<V: Vector>(bodies: &[Body]) -> Particles<V> {
    let mut p = Particles::new();
    for (x, v, r, m) in bodies {
        p.push(V::from_slice(x), V::from_slice(v), *r, *m).unwrap();
    }
    p
}

/// The checkpoint `carom run` would write for `world` (see carom-cli's `save_checkpoint`).
fn checkpoint_of<V: Vector>(world: &World<V>) -> Checkpoint {
    let mut cp = Checkpoint {
        dimensions: V::DIM as u32,
        steps_taken: world.steps_taken(),
        scene_toml: String::new(),
        origin: "proptest".into(),
        settings_json: "{}".into(),
        storage_order: world.storage_order().to_vec(),
        positions: Vec::new(),
        velocities: Vec::new(),
        radii: Vec::new(),
        masses: Vec::new(),
        pair_impulses: world.contact_impulses().pairs,
        plane_impulses: world.contact_impulses().planes,
        rest: world.contact_impulses().rest,
        tally: world.tally(),
    };
    for id in 0..world.len() {
        let (x, v, r, m) = world.particle(id);
        cp.positions.extend((0..V::DIM).map(|a| x.get(a)));
        cp.velocities.extend((0..V::DIM).map(|a| v.get(a)));
        cp.radii.push(r);
        cp.masses.push(m);
    }
    cp
}

fn resume_from<V: Vector>(setup: &Setup, bytes: &[u8]) -> World<V> {
    let cp = Checkpoint::read_from(bytes).expect("a checkpoint we just wrote reads back");
    assert_eq!(cp.dimensions as usize, V::DIM);
    let d = V::DIM;
    let mut p = Particles::new();
    for id in 0..cp.radii.len() {
        p.push(
            V::from_slice(&cp.positions[id * d..id * d + d]),
            V::from_slice(&cp.velocities[id * d..id * d + d]),
            cp.radii[id],
            cp.masses[id],
        )
        .unwrap();
    }
    builder(setup, p)
        .resume(cp.steps_taken, cp.storage_order)
        .impulses(carom_engine::ContactImpulses {
            pairs: cp.pair_impulses,
            planes: cp.plane_impulses,
            rest: cp.rest,
        })
        .tally(cp.tally)
        .build()
        .expect("resumed world builds")
}

fn check<V: Vector>(setup: &Setup, bodies: &[Body], before: u64, after: u64) {
    let mut straight = builder::<V>(setup, particles(bodies)).build().unwrap();
    for _ in 0..before {
        straight.step();
    }
    let mut bytes = Vec::new();
    checkpoint_of(&straight).write_to(&mut bytes).unwrap();
    let mut resumed = resume_from::<V>(setup, &bytes);
    assert_eq!(
        resumed.state_hash(),
        straight.state_hash(),
        "right after resume"
    );
    assert_eq!(resumed.steps_taken(), straight.steps_taken());
    for s in 0..after {
        straight.step();
        resumed.step();
        assert_eq!(
            resumed.state_hash(),
            straight.state_hash(),
            "{s} steps after resuming at {before}"
        );
    }
}

fn coords(lo: f64, hi: f64) -> impl Strategy<Value = [f64; 3]> {
    [lo..hi, lo..hi, lo..hi]
}

fn body() -> impl Strategy<Value = Body> {
    // Inside (-10, 10) with room for the largest radius; overlaps are allowed on purpose.
    (
        coords(-8.5, 8.5),
        coords(-6.0, 6.0),
        prop_oneof![Just(0.5), Just(1.0), 0.2f64..1.5],
        0.5f64..4.0,
    )
}

fn setup() -> impl Strategy<Value = Setup> {
    (
        prop_oneof![
            Just(BroadPhaseKind::Grid),
            Just(BroadPhaseKind::Brute),
            Just(BroadPhaseKind::Hash)
        ],
        any::<bool>(),
        prop_oneof![Just([0.0; 3]), coords(-10.0, 10.0)],
        prop_oneof![Just(1.0), Just(0.0), 0.0f64..=1.0],
        prop_oneof![Just(0.01), 0.001f64..0.02],
        prop_oneof![Just(None), Just(Some(0.5)), Just(Some(5.0))],
    )
        .prop_map(
            |(kind, walls, gravity, restitution, dt, sleep_speed)| Setup {
                // The grid needs a domain: without walls, use the hash.
                kind: if !walls && kind == BroadPhaseKind::Grid {
                    BroadPhaseKind::Hash
                } else {
                    kind
                },
                walls,
                gravity,
                restitution,
                dt,
                sleep_speed,
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn checkpoint_then_resume_equals_straight_run_2d(
        setup in setup(),
        bodies in prop::collection::vec(body(), 1..40),
        before in 0u64..60,
        after in 1u64..60,
    ) {
        check::<DVec2>(&setup, &bodies, before, after);
    }

    #[test]
    fn checkpoint_then_resume_equals_straight_run_3d(
        setup in setup(),
        bodies in prop::collection::vec(body(), 1..40),
        before in 0u64..60,
        after in 1u64..60,
    ) {
        check::<DVec3>(&setup, &bodies, before, after);
    }
}
