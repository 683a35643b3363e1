//! Resolving many simultaneous contacts: velocities first, then positions.
//!
//! Velocity phase (the lecture's response with its trap rule, "solution 2"): sweep the
//! contacts in their canonical order (pairs sorted by ids, then plane contacts sorted by
//! particle and plane), responding to each one that is still approaching; repeat until a sweep
//! responds to nothing or the iteration cap is hit. Each response conserves momentum, and
//! kinetic energy when `k = 1`, so the sweep does too whatever the cap.
//!
//! Position phase (the lecture's "solution 1", which it calls hard with many contacts): move
//! overlapping particles apart along their normal, each by its share of inverse mass, and push
//! particles out of planes. Positions only: velocities are never touched, so this can never add
//! kinetic energy. Planes go last so a walled box holds its particles.
//!
//! Both phases visit contacts in an order fixed by the contact set alone, so the result does not
//! depend on which broad phase found the contacts or on how many threads found them.

use crate::broadphase::Pair;
use crate::particles::Particles;
use crate::plane::Plane;
use crate::response::{collide, contact_normal, is_approaching};
use crate::vector::Vector;

/// A particle touching a plane: `(particle id, plane index)`.
pub type PlaneContact = (u32, u32);

/// What the velocity phase did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VelocitySolve {
    /// Sweeps made (1 when nothing was approaching).
    pub iterations: u32,
    /// Responses applied, particle-particle and particle-plane.
    pub responses: u64,
    /// True when the last sweep still found approaching contacts (the cap was hit).
    pub capped: bool,
}

/// Velocity phase. `restitution` is the particle-particle `k`; planes carry their own.
pub(crate) fn solve_velocities<V: Vector>(
    particles: &mut Particles<V>,
    pairs: &[Pair],
    plane_contacts: &[PlaneContact],
    planes: &[Plane<V>],
    restitution: f64,
    max_iterations: u32,
) -> VelocitySolve {
    let Particles {
        position,
        velocity,
        radius,
        mass,
        ..
    } = particles;
    let mut solve = VelocitySolve::default();
    while solve.iterations < max_iterations.max(1) {
        solve.iterations += 1;
        let mut responded = 0u64;
        for &(i, j) in pairs {
            let (i, j) = (i as usize, j as usize);
            let (pi, pj, vi, vj) = (position[i], position[j], velocity[i], velocity[j]);
            if is_approaching(pi, pj, vi, vj) {
                let (normal, _) = contact_normal(pi, pj);
                let (a, b) = collide(normal, vi, vj, mass[i], mass[j], restitution);
                velocity[i] = a;
                velocity[j] = b;
                responded += 1;
            }
        }
        for &(i, p) in plane_contacts {
            let (i, plane) = (i as usize, &planes[p as usize]);
            if plane.is_colliding(position[i], velocity[i], radius[i]) {
                velocity[i] = plane.bounce(velocity[i]);
                responded += 1;
            }
        }
        solve.responses += responded;
        if responded == 0 {
            return solve;
        }
    }
    solve.capped = true;
    solve
}

/// Position phase: `iterations` sweeps over the pairs and plane contacts, then one pass of
/// every particle against every plane.
pub(crate) fn separate<V: Vector>(
    particles: &mut Particles<V>,
    pairs: &[Pair],
    plane_contacts: &[PlaneContact],
    planes: &[Plane<V>],
    iterations: u32,
) {
    let Particles {
        position,
        radius,
        inverse_mass,
        ..
    } = particles;
    for _ in 0..iterations {
        let mut moved = false;
        for &(i, j) in pairs {
            let (i, j) = (i as usize, j as usize);
            let (normal, distance) = contact_normal(position[i], position[j]);
            let overlap = radius[i] + radius[j] - distance;
            if overlap > 0.0 {
                let share = overlap / (inverse_mass[i] + inverse_mass[j]);
                position[i] += normal * (share * inverse_mass[i]);
                position[j] -= normal * (share * inverse_mass[j]);
                moved = true;
            }
        }
        for &(i, p) in plane_contacts {
            let i = i as usize;
            let x = planes[p as usize].push_out(position[i], radius[i]);
            moved |= x != position[i];
            position[i] = x;
        }
        if !moved {
            break;
        }
    }
    if !planes.is_empty() {
        for (x, &r) in position.iter_mut().zip(radius.iter()) {
            for plane in planes {
                *x = plane.push_out(*x, r);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    fn two(p1: DVec2, v1: DVec2, p2: DVec2, v2: DVec2) -> Particles<DVec2> {
        let mut p = Particles::new();
        p.push(p1, v1, 1.0, 1.0).unwrap();
        p.push(p2, v2, 1.0, 3.0).unwrap();
        p
    }

    #[test]
    fn overlapping_pair_moving_apart_is_left_alone() {
        let mut p = two(
            DVec2::ZERO,
            DVec2::new(-1.0, 0.0),
            DVec2::new(1.5, 0.0),
            DVec2::new(2.0, 0.0),
        );
        let before = p.velocities().to_vec();
        let s = solve_velocities(&mut p, &[(0, 1)], &[], &[], 1.0, 8);
        assert_eq!(s.responses, 0);
        assert_eq!(p.velocities(), &before[..]);
    }

    #[test]
    fn approaching_pair_responds_once() {
        let mut p = two(
            DVec2::ZERO,
            DVec2::new(4.0, 0.0),
            DVec2::new(1.5, 0.0),
            DVec2::ZERO,
        );
        let s = solve_velocities(&mut p, &[(0, 1)], &[], &[], 1.0, 8);
        assert_eq!((s.responses, s.iterations, s.capped), (1, 2, false));
        assert!((p.velocities()[0].x + 2.0).abs() < 1e-12);
        assert!((p.velocities()[1].x - 2.0).abs() < 1e-12);
    }

    #[test]
    fn separation_splits_by_inverse_mass_and_keeps_velocity() {
        let mut p = two(DVec2::ZERO, DVec2::X, DVec2::new(1.0, 0.0), DVec2::Y);
        separate(&mut p, &[(0, 1)], &[], &[], 1);
        // overlap 1, masses 1 and 3: the light one moves 3/4, the heavy one 1/4
        assert!((p.positions()[0].x + 0.75).abs() < 1e-12);
        assert!((p.positions()[1].x - 1.25).abs() < 1e-12);
        assert_eq!(p.velocities(), &[DVec2::X, DVec2::Y]);
    }

    #[test]
    fn coincident_centres_separate_without_nan() {
        let mut p = two(DVec2::ONE, DVec2::ZERO, DVec2::ONE, DVec2::ZERO);
        solve_velocities(&mut p, &[(0, 1)], &[], &[], 1.0, 8);
        separate(&mut p, &[(0, 1)], &[], &[], 4);
        assert!(p.positions().iter().all(|x| x.is_finite()));
        assert!((p.positions()[0] - p.positions()[1]).length() >= 2.0 - 1e-12);
    }
}
