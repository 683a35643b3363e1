use super::*;
use crate::domain::Aabb;
use glam::DVec2;

/// Rest times take memory only once particles can sleep: a gas of the lecture's step
/// (no gravity, k = 1) never keeps them, a world under gravity with k < 1 does from its
/// first step.
#[test]
fn rest_times_are_kept_only_where_particles_can_sleep() {
    let stepped = |gravity: f64, k: f64| {
        let mut world = World::<DVec2>::builder()
            .dt(0.01)
            .gravity(DVec2::new(0.0, -gravity))
            .restitution(k)
            .domain(Aabb::new(DVec2::splat(-5.0), DVec2::splat(5.0)).unwrap())
            .walls(k)
            .sleep(true)
            .particle(DVec2::ZERO, DVec2::X, 0.5, 1.0)
            .particle(DVec2::new(2.0, 0.0), DVec2::ZERO, 0.5, 1.0)
            .build()
            .unwrap();
        for _ in 0..40 {
            world.step();
        }
        world
    };
    assert!(stepped(0.0, 1.0).rest.is_empty());
    assert_eq!(stepped(9.81, 0.5).rest.len(), 2);
}

/// The deepest overlap over every pair as a fraction of the smaller radius, with mixed radii,
/// across a periodic seam at the nearest image, and 0 when nothing overlaps; it leaves the
/// world's next step as it would have been.
#[test]
fn the_deepest_overlap_is_measured_over_every_pair() {
    let domain = Aabb::new(DVec2::splat(-10.0), DVec2::splat(10.0)).unwrap();
    let world = |periodic: bool, gap: f64| {
        let builder = World::<DVec2>::builder()
            .dt(0.01)
            .domain(domain)
            // (radii 1 and 2, 0.1 deep; radii 0.5 across the seam at x = +-10, `gap` apart)
            .particle(DVec2::new(0.0, 0.0), DVec2::ZERO, 1.0, 1.0)
            .particle(DVec2::new(2.9, 0.0), DVec2::ZERO, 2.0, 1.0)
            .particle(DVec2::new(-9.5, 5.0), DVec2::ZERO, 0.5, 1.0)
            .particle(DVec2::new(9.5 + gap, 5.0), DVec2::ZERO, 0.5, 1.0);
        let builder = if periodic {
            builder.periodic(&[true, false])
        } else {
            builder
        };
        builder.build().unwrap()
    };
    let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
    assert!(close(world(false, 0.0).deepest_overlap(), 0.1));
    // (across the seam, 0.3 deep in discs of radius 0.5)
    assert!(close(world(true, 0.3).deepest_overlap(), 0.6));
    let mut apart = World::<DVec2>::builder()
        .dt(0.01)
        .particle(DVec2::ZERO, DVec2::ZERO, 1.0, 1.0)
        .particle(DVec2::new(2.5, 0.0), DVec2::ZERO, 1.0, 1.0)
        .build()
        .unwrap();
    assert_eq!(apart.deepest_overlap(), 0.0);
    let mut measured = world(false, 0.0);
    let mut unmeasured = world(false, 0.0);
    measured.deepest_overlap();
    measured.step();
    unmeasured.step();
    assert_eq!(measured.state_hash(), unmeasured.state_hash());
}
