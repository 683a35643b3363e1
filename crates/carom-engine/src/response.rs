//! Particle-particle collision response: the lecture's "Arbitrary Collision Response".
//!
//! Each velocity is split along the collision normal `N` into a normal part
//! `v_N = (N . v) N` and a tangent part `v_T = v - v_N`. The tangent parts are left alone
//! (no friction); the normal parts take the mass-weighted formula with restitution `k`:
//!
//! ```text
//! v'_1N = (m1 v1N + m2 v2N + m2 k (v2N - v1N)) / (m1 + m2)
//! v'_2N = (m1 v1N + m2 v2N + m1 k (v1N - v2N)) / (m1 + m2)
//! ```
//!
//! At `k = 1` this is the lecture's elastic formula
//! `v'_1N = (2 m2 v2N + (m1 - m2) v1N) / (m1 + m2)`; with equal masses it is the lecture's
//! inelastic slide `v'_1 = ((1 + k) v2 + (1 - k) v1) / 2`; at `k = 0` both leave with the
//! centre-of-mass normal velocity. Momentum `m1 v1 + m2 v2` is conserved for every `k`;
//! kinetic energy only for `k = 1` (it drops by `(1 - k^2)` times the normal relative
//! energy otherwise).

use crate::vector::Vector;

/// A velocity split into its part along a unit normal and the rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalTangent<V> {
    /// `(N . v) N`, the lecture's `v_N`.
    pub normal: V,
    /// `v - v_N`, the lecture's `v_T`.
    pub tangent: V,
}

/// Splits `velocity` along the unit vector `unit_normal` (the lecture's velocity decomposition).
#[inline]
pub fn split_normal_tangent<V: Vector>(velocity: V, unit_normal: V) -> NormalTangent<V> {
    let normal = unit_normal * unit_normal.dot(velocity);
    NormalTangent {
        normal,
        tangent: velocity - normal,
    }
}

/// The lecture's collision test: centre distance strictly less than the sum of the radii.
///
/// (The lecture's slide writes `(r_i + r_j) - distance < 0`, which has the sign backwards;
/// its prose, "the distance is less than the sum of their radii", is what this implements.)
#[inline]
pub fn is_overlapping<V: Vector>(p1: V, p2: V, r1: f64, r2: f64) -> bool {
    let reach = r1 + r2;
    (p1 - p2).length_squared() < reach * reach
}

/// The lecture's trap rule (its "solution 2"): respond only while the particles approach,
/// `p_rel . v_rel < 0` with `p_rel = p1 - p2` and `v_rel = v1 - v2`.
#[inline]
pub fn is_approaching<V: Vector>(p1: V, p2: V, v1: V, v2: V) -> bool {
    (p1 - p2).dot(v1 - v2) < 0.0
}

/// Unit collision normal pointing from particle 2 to particle 1, and the centre distance.
///
/// Coincident centres have no direction; they get the first axis, a fixed choice so that
/// the result is deterministic and never NaN.
#[inline]
pub fn contact_normal<V: Vector>(p1: V, p2: V) -> (V, f64) {
    let delta = p1 - p2;
    let distance = delta.length_squared().sqrt();
    if distance > 0.0 {
        (delta * (1.0 / distance), distance)
    } else {
        (V::unit_axis(0), 0.0)
    }
}

/// Normal speeds after impact for masses `m1`, `m2` (> 0), normal speeds `u1`, `u2` and
/// restitution `k` in [0, 1]. This is the scalar core of [`collide`].
#[inline]
pub fn normal_speeds_after(m1: f64, m2: f64, u1: f64, u2: f64, k: f64) -> (f64, f64) {
    let total = m1 + m2;
    let momentum = m1 * u1 + m2 * u2;
    (
        (momentum + m2 * k * (u2 - u1)) / total,
        (momentum + m1 * k * (u1 - u2)) / total,
    )
}

/// Velocities after a collision along `unit_normal` (either sign: the formula is symmetric).
///
/// Masses must be > 0 and `k` in [0, 1]. The caller decides *whether* to respond (see
/// [`is_overlapping`] and [`is_approaching`]); this only computes *how*.
#[inline]
pub fn collide<V: Vector>(
    unit_normal: V,
    v1: V,
    v2: V,
    m1: f64,
    m2: f64,
    restitution: f64,
) -> (V, V) {
    let s1 = split_normal_tangent(v1, unit_normal);
    let s2 = split_normal_tangent(v2, unit_normal);
    let u1 = unit_normal.dot(v1);
    let u2 = unit_normal.dot(v2);
    let (u1_after, u2_after) = normal_speeds_after(m1, m2, u1, u2, restitution);
    (
        s1.tangent + unit_normal * u1_after,
        s2.tangent + unit_normal * u2_after,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};

    const TOL: f64 = 1e-9;

    fn close(a: DVec2, b: DVec2) -> bool {
        (a - b).length() < TOL
    }

    fn sqrt3() -> f64 {
        3f64.sqrt()
    }

    /// The lecture's normal for both worked examples.
    fn lecture_normal() -> DVec2 {
        DVec2::new(sqrt3() / 2.0, -0.5)
    }

    #[test]
    fn lecture_example_1_decomposition() {
        let s = split_normal_tangent(DVec2::new(20.0, 0.0), lecture_normal());
        assert!(close(s.normal, DVec2::new(15.0, -5.0 * sqrt3())));
        assert!(close(s.tangent, DVec2::new(5.0, 5.0 * sqrt3())));
    }

    #[test]
    fn lecture_example_1_dynamic_static() {
        let (v1, v2) = collide(
            lecture_normal(),
            DVec2::new(20.0, 0.0),
            DVec2::ZERO,
            1.0,
            1.0,
            1.0,
        );
        assert!(close(v1, DVec2::new(5.0, 5.0 * sqrt3())), "{v1}");
        assert!(close(v2, DVec2::new(15.0, -5.0 * sqrt3())), "{v2}");
    }

    #[test]
    fn lecture_example_2_dynamic_dynamic() {
        let n = lecture_normal();
        let s2 = split_normal_tangent(DVec2::new(-10.0, 0.0), n);
        assert!(close(s2.normal, DVec2::new(-7.5, 2.5 * sqrt3())));
        assert!(close(s2.tangent, DVec2::new(-2.5, -2.5 * sqrt3())));
        let (v1, v2) = collide(
            n,
            DVec2::new(20.0, 0.0),
            DVec2::new(-10.0, 0.0),
            1.0,
            2.0,
            1.0,
        );
        assert!(close(v1, DVec2::new(-10.0, 10.0 * sqrt3())), "{v1}");
        assert!(close(v2, DVec2::new(5.0, -5.0 * sqrt3())), "{v2}");
    }

    #[test]
    fn flipping_the_normal_changes_nothing() {
        let n = lecture_normal();
        let a = collide(
            n,
            DVec2::new(20.0, 0.0),
            DVec2::new(-10.0, 3.0),
            1.5,
            2.0,
            0.3,
        );
        let b = collide(
            -n,
            DVec2::new(20.0, 0.0),
            DVec2::new(-10.0, 3.0),
            1.5,
            2.0,
            0.3,
        );
        assert!(close(a.0, b.0) && close(a.1, b.1));
    }

    /// Head-on, unequal masses m1 = 1, m2 = 3, u1 = 4, u2 = 0, for k in {0, 0.5, 1}.
    #[test]
    fn head_on_unequal_masses() {
        let cases = [
            // k, expected u1', u2'
            (0.0, 1.0, 1.0),  // stick: (1*4)/(4) = 1
            (0.5, -0.5, 1.5), // separation speed 0.5 * 4 = 2, momentum 4
            (1.0, -2.0, 2.0), // (2*3*0 + (1-3)*4)/4 = -2 and (2*1*4)/4 = 2
        ];
        for (k, e1, e2) in cases {
            let (u1, u2) = normal_speeds_after(1.0, 3.0, 4.0, 0.0, k);
            assert!(
                (u1 - e1).abs() < TOL && (u2 - e2).abs() < TOL,
                "k={k}: {u1} {u2}"
            );
            // momentum always, energy only at k = 1
            assert!((u1 + 3.0 * u2 - 4.0).abs() < TOL);
            let energy_after = 0.5 * u1 * u1 + 1.5 * u2 * u2;
            if k == 1.0 {
                assert!((energy_after - 8.0).abs() < TOL);
            } else {
                assert!(energy_after < 8.0);
            }
            // the restitution definition: k = -(u1' - u2') / (u1 - u2)
            assert!((-(u1 - u2) / 4.0 - k).abs() < TOL);
        }
    }

    #[test]
    fn equal_masses_match_the_inelastic_slide() {
        for k in [0.0, 0.25, 0.5, 1.0] {
            let (v1, v2) = (7.0, -3.0);
            let (a, b) = normal_speeds_after(2.0, 2.0, v1, v2, k);
            assert!((a - ((1.0 + k) * v2 + (1.0 - k) * v1) / 2.0).abs() < TOL);
            assert!((b - ((1.0 + k) * v1 + (1.0 - k) * v2) / 2.0).abs() < TOL);
        }
    }

    #[test]
    fn detection_uses_strict_less_than() {
        let a = DVec3::ZERO;
        assert!(is_overlapping(a, DVec3::new(1.999, 0.0, 0.0), 1.0, 1.0));
        assert!(!is_overlapping(a, DVec3::new(2.0, 0.0, 0.0), 1.0, 1.0));
        assert!(!is_overlapping(a, DVec3::new(2.5, 0.0, 0.0), 1.0, 1.0));
    }

    #[test]
    fn trap_rule_sign() {
        let p1 = DVec2::ZERO;
        let p2 = DVec2::new(1.0, 0.0);
        assert!(is_approaching(p1, p2, DVec2::new(1.0, 0.0), DVec2::ZERO));
        assert!(!is_approaching(p1, p2, DVec2::new(-1.0, 0.0), DVec2::ZERO));
        assert!(!is_approaching(p1, p2, DVec2::ZERO, DVec2::ZERO));
    }

    #[test]
    fn coincident_centres_get_a_finite_normal() {
        let (n, d) = contact_normal(DVec3::ONE, DVec3::ONE);
        assert_eq!(d, 0.0);
        assert_eq!(n, DVec3::X);
    }
}
