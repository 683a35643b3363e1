//! The observables of `carom_engine::observe` seen through `World`: the collision count, the
//! virial, the temperature and the overlap, on cases worked out by hand, and the pressure of
//! a dilute elastic gas against its equation of state.

use crate::support;
use support::Lcg;

use carom_engine::glam::DVec2;
use carom_engine::{Aabb, World};

/// Two unit discs of mass 1, centres `gap` apart on the x axis, meeting head-on at speed 1
/// each, in a 20 x 20 box.
fn head_on(gap: f64, k: f64) -> World<DVec2> {
    World::builder()
        .dt(0.01)
        .restitution(k)
        .domain(Aabb::new(DVec2::splat(-10.0), DVec2::splat(10.0)).unwrap())
        .particle(DVec2::new(-gap / 2.0, 0.0), DVec2::X, 1.0, 1.0)
        .particle(DVec2::new(gap / 2.0, 0.0), -DVec2::X, 1.0, 1.0)
        .build()
        .unwrap()
}

#[test]
fn a_head_on_collision_counts_once_and_its_virial_is_the_impulse_times_the_distance() {
    for k in [0.0, 0.5, 1.0] {
        let mut world = head_on(1.99, k);
        // nothing is summed before the first reading
        assert!(!world.tally().observing);
        world.step();
        assert_eq!(world.tally().collisions, 0);
        let mut world = head_on(1.99, k);
        world.observe();
        let stats = world.step();
        assert_eq!(stats.collisions, 1, "k = {k}");
        let tally = world.tally();
        assert_eq!(tally.collisions, 1);
        // j gives i (on the left) the impulse m (v_i' - v_i) = -(1 + k) along x, and
        // r_ij = x_i - x_j = (-1.99, 0): J . r = 1.99 (1 + k)
        let expected = 1.99 * (1.0 + k);
        assert!(
            (tally.virial - expected).abs() < 1e-12,
            "k = {k}: {} against {expected}",
            tally.virial
        );
        // once apart, nothing more is counted
        world.step();
        assert_eq!(world.tally().collisions, 1);
    }
}

/// Under gravity (where contacts can rest, and an impact is solved by impulses instead of the
/// lecture's response), a head-on collision counts once too, at every `k`: at `k = 0` it once
/// counted none (an impact was counted by its bounce speed, `k s`).
#[test]
fn a_head_on_collision_under_gravity_counts_once_at_every_k() {
    for k in [0.0, 0.5, 0.9] {
        let mut world = World::builder()
            .dt(0.01)
            .gravity(DVec2::new(0.0, -9.81))
            .restitution(k)
            .particle(DVec2::new(-0.995, 0.0), DVec2::X, 1.0, 1.0)
            .particle(DVec2::new(0.995, 0.0), -DVec2::X, 1.0, 1.0)
            .build()
            .unwrap();
        world.observe();
        let stats = world.step();
        assert_eq!(stats.collisions, 1, "k = {k}");
        world.step();
        assert_eq!(world.tally().collisions, 1, "k = {k}");
    }
}

#[test]
fn a_step_measures_the_overlap_it_starts_from_over_every_pair_it_finds() {
    // 0.1 of r deep at the start; the position phase leaves them the slop deep, which is
    // what the next step finds
    let mut world = head_on(1.9, 0.5);
    let first = world.step();
    assert!((first.found_overlap - 0.1).abs() < 1e-12, "{first:?}");
    assert!(
        first.max_overlap > 0.0 && first.max_overlap < 0.01,
        "{first:?}"
    );
    let second = world.step();
    assert_eq!(second.found_overlap, first.max_overlap);
}

#[test]
fn a_reading_reports_the_state_and_restarts_the_pressure_interval() {
    let mut world = head_on(1.9, 1.0);
    // before any step the overlap is measured by a search of its own: 0.1 of r = 1
    let start = world.observe();
    assert_eq!((start.step, start.collisions), (0, 0));
    assert!((start.max_overlap - 0.1).abs() < 1e-12);
    // T = sum m |v - u|^2 / (d N) = 2 / 4
    assert_eq!(start.temperature, 0.5);
    assert_eq!(start.kinetic_energy, 1.0);
    // no interval yet: the kinetic part alone, sum m |v - u|^2 / (d V) = 2 / (2 * 400)
    assert_eq!(start.pressure, 2.0 / 800.0);
    let stats = world.step();
    let reading = world.observe();
    assert_eq!((reading.step, reading.collisions), (1, 1));
    assert_eq!(reading.max_overlap, stats.max_overlap);
    let tally_after = world.tally();
    assert_eq!((tally_after.virial, tally_after.interval), (0.0, 0.0));
    assert_eq!(tally_after.collisions, 1);
    // the interval was one step: P = (2 + J . r / dt) / (d V), J . r = 2 x 1.9
    let expected = (2.0 + 2.0 * 1.9 / 0.01) / 800.0;
    assert!((reading.pressure - expected).abs() < 1e-9 * expected);
}

/// A disc struck into a third one it had no contact with (beyond its reach where the step
/// started: the lecture's step finds that pair overlapping on the next step) leaves the step
/// deep in it. The step's own measure covers its contacts only; a reading covers every pair.
#[test]
fn a_reading_measures_the_overlap_over_every_pair_not_only_the_steps_contacts() {
    // A at -1.99 moving at 10 strikes B at rest (r = 1, k = 1: they swap speeds); B moves
    // 10 x 0.1 = 1 into C at rest at 2.5: 0.5 of r deep at the end of the step.
    let mut world = World::builder()
        .dt(0.1)
        .restitution(1.0)
        .particle(DVec2::new(-1.99, 0.0), DVec2::new(10.0, 0.0), 1.0, 1.0)
        .particle(DVec2::ZERO, DVec2::ZERO, 1.0, 1.0)
        .particle(DVec2::new(2.5, 0.0), DVec2::ZERO, 1.0, 1.0)
        .build()
        .unwrap();
    world.observe();
    let stats = world.step();
    assert!(stats.max_overlap < 0.01, "{stats:?}");
    let reading = world.observe();
    assert!((reading.max_overlap - 0.5).abs() < 0.02, "{reading:?}");
    assert_eq!(reading.max_overlap, world.deepest_overlap());
    // (the next step finds it, as the lecture's detection does)
    assert_eq!(world.step().found_overlap, reading.max_overlap);
}

/// A reading's energies and temperature are the very bits of the world's own sums
/// (`kinetic_energy`, `potential_energy`, `observe::temperature`), which it takes in fewer
/// passes; an empty world's too.
#[test]
fn a_reading_sums_the_energies_and_temperature_as_the_world_does() {
    let mut rng = Lcg::new(7);
    let mut builder = World::builder()
        .dt(1.0 / 60.0)
        .gravity(DVec2::new(0.3, -9.81))
        .restitution(0.5)
        .domain(Aabb::new(DVec2::splat(-40.0), DVec2::splat(40.0)).unwrap())
        .walls(0.5);
    for i in 0..900 {
        let x = DVec2::new((i % 30) as f64 * 2.5 - 37.0, (i / 30) as f64 * 2.5 - 37.0);
        let v: DVec2 = rng.vector(-5.0, 5.0);
        builder = builder.particle(x, v, 1.0, 0.5 + (i % 7) as f64);
    }
    let mut world = builder.build().unwrap();
    for _ in 0..40 {
        world.step();
    }
    reads_as_the_world_sums(&mut world);
    reads_as_the_world_sums(&mut World::<DVec2>::builder().dt(0.01).build().unwrap());
}

/// A reading of `world` against its own energies and the temperature summed in id order, two
/// passes of their own (`0` without particles), bit for bit.
fn reads_as_the_world_sums(world: &mut World<DVec2>) {
    let reading = world.observe();
    let p = world.particles();
    let by_id = || {
        p.masses()
            .iter()
            .copied()
            .zip(p.velocities().iter().copied())
    };
    let temperature = match p.len() {
        0 => 0.0,
        n => {
            let total: f64 = by_id().map(|(m, _)| m).sum();
            let mean = by_id().fold(DVec2::ZERO, |u, (m, v)| u + v * m) * (1.0 / total);
            let sum: f64 = by_id().map(|(m, v)| m * (v - mean).length_squared()).sum();
            sum / (2 * n) as f64
        }
    };
    let observed = carom_engine::observe::temperature(p);
    let sums = [
        (reading.kinetic_energy, world.kinetic_energy()),
        (reading.potential_energy, world.potential_energy()),
        (reading.temperature, temperature),
        (observed, temperature),
    ];
    for (read, summed) in sums {
        assert_eq!(read.to_bits(), summed.to_bits(), "{read} against {summed}");
    }
}

/// Henderson's (1975) equation of state for hard disks: `Z = (1 + eta^2 / 8) / (1 - eta)^2`.
fn henderson(eta: f64) -> f64 {
    (1.0 + eta * eta / 8.0) / (1.0 - eta).powi(2)
}

#[test]
fn a_dilute_elastic_gas_in_a_walled_box_has_the_pressure_of_its_equation_of_state() {
    // 400 discs r = 0.5 at area fraction 0.1, k = 1, no gravity: Z = P V / (N T).
    let (n, r, eta) = (400usize, 0.5, 0.1);
    let area = n as f64 * std::f64::consts::PI * r * r / eta;
    let half = area.sqrt() / 2.0;
    let per_axis = (n as f64).sqrt().ceil() as usize;
    let spacing = 2.0 * half / per_axis as f64;
    let mut rng = Lcg::new(11);
    let mut builder = World::builder()
        .dt(0.002)
        .restitution(1.0)
        .domain(Aabb::new(DVec2::splat(-half), DVec2::splat(half)).unwrap())
        .walls(1.0);
    for cell in 0..n {
        let (i, j) = (cell % per_axis, cell / per_axis);
        let x = DVec2::new(
            -half + (i as f64 + 0.5) * spacing,
            -half + (j as f64 + 0.5) * spacing,
        );
        let v: DVec2 = rng.vector(-1.0, 1.0);
        builder = builder.particle(x, v, r, 1.0);
    }
    let mut world = builder.build().unwrap();
    // relax, then average over a long window (each reading is one window)
    for _ in 0..2000 {
        world.step();
    }
    world.observe();
    for _ in 0..6000 {
        world.step();
    }
    let reading = world.observe();
    let z = reading.pressure * area / (n as f64 * reading.temperature);
    // The virial theorem with the walls' virial (-d P_wall A_inner, A_inner the area the
    // centres reach) makes P V = P_wall A_inner; the gas inside is at the packing fraction of
    // N discs in A_inner.
    let inner = (2.0 * half - 2.0 * r).powi(2);
    let expected = henderson(eta * area / inner);
    assert!(
        (z / expected - 1.0).abs() < 0.03,
        "Z = {z}, Henderson {expected}"
    );
}
