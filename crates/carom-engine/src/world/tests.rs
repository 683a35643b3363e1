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
