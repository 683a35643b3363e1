//! Particle-plane collisions: the lecture's plane rule.
//!
//! A plane is a point `p` and a unit normal `n` pointing into the allowed half-space. A particle
//! at `x` with radius `r` and velocity `v` collides when `(x - p) . n < r` (it touches or
//! crosses the plane) *and* `n . v < 0` (it is heading deeper in). The response replaces the
//! velocity with `V' = V_T - k V_N`.

use crate::error::EngineError;
use crate::response::split_normal_tangent;
use crate::vector::Vector;

/// An infinite plane that particles bounce off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane<V> {
    point: V,
    normal: V,
    restitution: f64,
}

impl<V: Vector> Plane<V> {
    /// A plane through `point` facing `normal` (any non-zero length; it is normalised) with
    /// restitution `k` in [0, 1].
    pub fn new(point: V, normal: V, restitution: f64) -> Result<Self, EngineError> {
        if !point.is_finite_vector() || !normal.is_finite_vector() {
            return Err(EngineError::NonFinite("plane"));
        }
        let length = normal.length_squared().sqrt();
        if length.is_nan() || length == 0.0 || !length.is_finite() {
            return Err(EngineError::ZeroPlaneNormal);
        }
        check_restitution(restitution)?;
        Ok(Self {
            point,
            normal: normal * (1.0 / length),
            restitution,
        })
    }

    /// A point on the plane.
    pub fn point(&self) -> V {
        self.point
    }

    /// The unit normal, pointing into the allowed side.
    pub fn normal(&self) -> V {
        self.normal
    }

    /// Coefficient of restitution `k` in [0, 1].
    pub fn restitution(&self) -> f64 {
        self.restitution
    }

    /// `(x - p) . n`: how far `x` is on the allowed side (negative behind the plane).
    #[inline]
    pub fn signed_distance(&self, x: V) -> f64 {
        (x - self.point).dot(self.normal)
    }

    /// A lower bound of [`Plane::signed_distance`] over the box from `lo` to `hi`, exact in
    /// floating point: no point of the box has a smaller computed signed distance. (It is the
    /// signed distance of the corner that lies furthest behind the plane; rounding is monotone,
    /// so each term of the dot product, and their sum, is smallest there.) NaN when the box
    /// is not finite on an axis the plane is parallel to, so a caller comparing with `>=` then
    /// skips nothing.
    #[inline]
    pub fn lowest_signed_distance(&self, lo: V, hi: V) -> f64 {
        let mut corner = [0.0; 3];
        for (a, c) in corner.iter_mut().enumerate().take(V::DIM) {
            *c = if self.normal.get(a) >= 0.0 {
                lo.get(a)
            } else {
                hi.get(a)
            };
        }
        self.signed_distance(V::from_slice(&corner))
    }

    /// The lecture's detection: `(x - p) . n < r && n . v < 0`.
    #[inline]
    pub fn is_colliding(&self, x: V, v: V, radius: f64) -> bool {
        self.signed_distance(x) < radius && self.normal.dot(v) < 0.0
    }

    /// The lecture's response `V' = V_T - k V_N`.
    #[inline]
    pub fn bounce(&self, v: V) -> V {
        let parts = split_normal_tangent(v, self.normal);
        parts.tangent - parts.normal * self.restitution
    }

    /// Where a particle at `x` must move so that it just touches the plane (`x` itself when it
    /// is already clear).
    #[inline]
    pub fn push_out(&self, x: V, radius: f64) -> V {
        let mut x = x;
        self.push_out_in_place(&mut x, radius);
        x
    }

    /// [`Plane::push_out`] in place: writes `x` only when it moves (a pass over many
    /// particles, most of them clear, then leaves their memory untouched). Returns whether it
    /// moved.
    #[inline]
    pub fn push_out_in_place(&self, x: &mut V, radius: f64) -> bool {
        let depth = radius - self.signed_distance(*x);
        if depth > 0.0 {
            *x += self.normal * depth;
            true
        } else {
            false
        }
    }
}

pub(crate) fn check_restitution(k: f64) -> Result<(), EngineError> {
    if (0.0..=1.0).contains(&k) {
        Ok(())
    } else {
        Err(EngineError::Restitution(k))
    }
}

/// Particles per box in [`plane_candidates`]: neighbours in storage order lie near each other
/// (the world sorts its particles along space), so most boxes of this many are far from every
/// wall and their particles need no test of their own. (In the bench's 10^6 gas, testing every
/// particle against its four walls took 7.4-8.7 ms a step.)
const CANDIDATE_BOX: usize = 32;

/// Appends to `out`, in order, `(first + k, p)` for each particle `k` of `positions` within its
/// `reach(first + k)` of plane `p` (`signed_distance < reach`), but for those `skip` names.
/// Particles are taken [`CANDIDATE_BOX`] at a time, and a box whose bounding box lies at least
/// its largest reach in front of every plane is passed over whole: exact, never a guess (see
/// [`Plane::lowest_signed_distance`]).
pub(crate) fn plane_candidates<V: Vector>(
    planes: &[Plane<V>],
    positions: &[V],
    first: usize,
    reach: impl Fn(usize) -> f64,
    skip: impl Fn(usize) -> bool,
    out: &mut Vec<(u32, u32)>,
) {
    for (b, chunk) in positions.chunks(CANDIDATE_BOX).enumerate() {
        let start = first + b * CANDIDATE_BOX;
        let (mut lo, mut hi) = (chunk[0], chunk[0]);
        for &x in &chunk[1..] {
            lo = lo.min_components(x);
            hi = hi.max_components(x);
        }
        let far = (start..start + chunk.len())
            .map(&reach)
            .fold(f64::NEG_INFINITY, f64::max);
        if planes
            .iter()
            .all(|plane| plane.lowest_signed_distance(lo, hi) >= far)
        {
            continue;
        }
        for (i, &x) in (start..).zip(chunk) {
            if skip(i) {
                continue;
            }
            for (p, plane) in planes.iter().enumerate() {
                if plane.signed_distance(x) < reach(i) {
                    out.push((i as u32, p as u32));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};
    use proptest::prelude::*;

    proptest! {
        /// No point of a box has a computed signed distance below the box's bound, for any
        /// plane: a pass that skips a box by its bound skips no contact.
        #[test]
        fn lowest_signed_distance_bounds_every_point_of_the_box(
            point in prop::array::uniform3(-1e3f64..1e3),
            normal in prop::array::uniform3(-1.0f64..1.0),
            corners in prop::array::uniform6(-1e3f64..1e3),
            fractions in prop::collection::vec(prop::array::uniform3(0.0f64..=1.0), 1..16),
        ) {
            prop_assume!(normal.iter().any(|&c| c != 0.0));
            let plane = Plane::new(DVec3::from(point), DVec3::from(normal), 0.5).unwrap();
            let a = DVec3::new(corners[0], corners[1], corners[2]);
            let b = DVec3::new(corners[3], corners[4], corners[5]);
            let (lo, hi) = (a.min(b), a.max(b));
            let bound = plane.lowest_signed_distance(lo, hi);
            for f in fractions {
                let x = (lo + (hi - lo) * DVec3::from(f)).clamp(lo, hi);
                prop_assert!(bound <= plane.signed_distance(x));
            }
            // the corners themselves, where the bound is reached
            for x in [lo, hi, DVec3::new(lo.x, hi.y, lo.z), DVec3::new(hi.x, lo.y, hi.z)] {
                prop_assert!(bound <= plane.signed_distance(x));
            }
        }
    }

    #[test]
    fn lowest_signed_distance_of_a_box_is_its_deepest_corner() {
        let wall = Plane::new(DVec2::new(-10.0, 0.0), DVec2::new(1.0, 0.0), 1.0).unwrap();
        let (lo, hi) = (DVec2::new(-9.0, -100.0), DVec2::new(5.0, 100.0));
        assert_eq!(wall.lowest_signed_distance(lo, hi), 1.0);
        // infinite on an axis the plane is parallel to: no bound (NaN), so nothing is skipped
        let unbounded = DVec2::new(-9.0, f64::NEG_INFINITY);
        assert!(wall.lowest_signed_distance(unbounded, hi).is_nan());
    }

    fn floor(k: f64) -> Plane<DVec2> {
        Plane::new(DVec2::new(0.0, -50.0), DVec2::new(0.0, 3.0), k).unwrap()
    }

    #[test]
    fn normal_is_normalised() {
        assert_eq!(floor(1.0).normal(), DVec2::Y);
    }

    #[test]
    fn zero_normal_is_rejected() {
        assert!(matches!(
            Plane::new(DVec2::ZERO, DVec2::ZERO, 0.5),
            Err(EngineError::ZeroPlaneNormal)
        ));
        assert!(Plane::new(DVec2::ZERO, DVec2::new(f64::NAN, 1.0), 0.5).is_err());
        assert!(Plane::new(DVec2::ZERO, DVec2::Y, 1.5).is_err());
    }

    #[test]
    fn detection_needs_contact_and_approach() {
        let p = floor(1.0);
        let down = DVec2::new(3.0, -4.0);
        assert!(p.is_colliding(DVec2::new(0.0, -49.5), down, 1.0));
        assert!(
            !p.is_colliding(DVec2::new(0.0, -49.5), -down, 1.0),
            "moving away"
        );
        assert!(
            !p.is_colliding(DVec2::new(0.0, -48.0), down, 1.0),
            "clear of it"
        );
    }

    #[test]
    fn bounce_is_tangent_minus_k_normal() {
        for k in [0.0, 0.5, 0.8, 1.0] {
            let v = floor(k).bounce(DVec2::new(3.0, -4.0));
            assert!(
                (v - DVec2::new(3.0, 4.0 * k)).length() < 1e-12,
                "k={k}: {v}"
            );
        }
        // a tilted plane in 3D: V_T kept, V_N reversed and scaled
        let n = DVec3::new(1.0, 1.0, 0.0).normalize();
        let plane = Plane::new(DVec3::ZERO, n, 0.5).unwrap();
        let v = DVec3::new(-2.0, 0.0, 1.0);
        let after = plane.bounce(v);
        let vn = n * n.dot(v);
        assert!((after - ((v - vn) - vn * 0.5)).length() < 1e-12);
    }

    #[test]
    fn push_out_moves_to_contact() {
        let p = floor(1.0);
        let x = p.push_out(DVec2::new(2.0, -52.0), 1.0);
        assert!((x - DVec2::new(2.0, -49.0)).length() < 1e-12);
        assert_eq!(
            p.push_out(DVec2::new(2.0, -10.0), 1.0),
            DVec2::new(2.0, -10.0)
        );
    }
}
