//! The simulation space: an axis-aligned box, which the grid covers and whose faces can be
//! closed with walls.

use crate::error::EngineError;
use crate::plane::Plane;
use crate::vector::Vector;

/// An axis-aligned box `min..max` (min below max on every axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb<V> {
    /// Lowest corner.
    pub min: V,
    /// Highest corner.
    pub max: V,
}

impl<V: Vector> Aabb<V> {
    /// A box; fails unless `min < max` on every axis and all finite.
    pub fn new(min: V, max: V) -> Result<Self, EngineError> {
        if !min.is_finite_vector() || !max.is_finite_vector() {
            return Err(EngineError::NonFinite("domain"));
        }
        if (0..V::DIM).any(|a| min.get(a) >= max.get(a)) {
            return Err(EngineError::EmptyDomain);
        }
        Ok(Self { min, max })
    }

    /// `max - min`.
    pub fn extent(&self) -> V {
        self.max - self.min
    }

    /// True when `x` lies in the closed box.
    pub fn contains(&self, x: V) -> bool {
        (0..V::DIM).all(|a| x.get(a) >= self.min.get(a) && x.get(a) <= self.max.get(a))
    }

    /// The box's faces as planes facing inwards (2 per axis: min face then max face), all with
    /// restitution `k`.
    pub fn walls(&self, restitution: f64) -> Result<Vec<Plane<V>>, EngineError> {
        let mut planes = Vec::with_capacity(2 * V::DIM);
        for axis in 0..V::DIM {
            let n = V::unit_axis(axis);
            planes.push(Plane::new(self.min, n, restitution)?);
            planes.push(Plane::new(self.max, -n, restitution)?);
        }
        Ok(planes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};

    #[test]
    fn rejects_empty_and_non_finite() {
        assert!(Aabb::new(DVec2::ONE, DVec2::ONE).is_err());
        assert!(Aabb::new(DVec2::new(0.0, 1.0), DVec2::new(1.0, 0.0)).is_err());
        assert!(Aabb::new(DVec2::ZERO, DVec2::new(f64::INFINITY, 1.0)).is_err());
    }

    #[test]
    fn walls_face_inwards() {
        let b = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
        let walls = b.walls(0.5).unwrap();
        assert_eq!(walls.len(), 6);
        for w in &walls {
            assert!(w.signed_distance(DVec3::ZERO) == 1.0);
        }
    }
}
