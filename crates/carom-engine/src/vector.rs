//! The one abstraction over 2D and 3D: everything in the engine is generic over [`Vector`],
//! implemented for [`glam::DVec2`] and [`glam::DVec3`] (f64 components).

use glam::{DVec2, DVec3};
use std::fmt::Debug;
use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

/// A vector of `DIM` f64 components, the position/velocity type of a simulation.
///
/// The lecture's grid is 3D while its demos are 2D; the engine is written once over this
/// trait so both are the same code path.
pub trait Vector:
    Copy
    + Debug
    + PartialEq
    + Send
    + Sync
    + Default
    + Add<Output = Self>
    + Sub<Output = Self>
    + Neg<Output = Self>
    + Mul<f64, Output = Self>
    + AddAssign
    + SubAssign
    + 'static
{
    /// Number of components (2 or 3).
    const DIM: usize;
    /// The zero vector.
    const ZERO: Self;

    /// Dot product.
    fn dot(self, other: Self) -> f64;
    /// Squared Euclidean length.
    fn length_squared(self) -> f64 {
        self.dot(self)
    }
    /// Component `axis` (`0..DIM`).
    fn get(self, axis: usize) -> f64;
    /// Builds a vector from the first `DIM` entries of `components`.
    ///
    /// # Panics
    /// If `components` has fewer than `DIM` entries.
    fn from_slice(components: &[f64]) -> Self;
    /// The unit vector along `axis`.
    fn unit_axis(axis: usize) -> Self {
        let mut c = [0.0; 3];
        c[axis] = 1.0;
        Self::from_slice(&c)
    }
    /// Component-wise minimum.
    fn min_components(self, other: Self) -> Self;
    /// Component-wise maximum.
    fn max_components(self, other: Self) -> Self;
    /// True when every component is finite.
    fn is_finite_vector(self) -> bool {
        (0..Self::DIM).all(|a| self.get(a).is_finite())
    }
}

impl Vector for DVec2 {
    const DIM: usize = 2;
    const ZERO: Self = DVec2::ZERO;

    #[inline]
    fn dot(self, other: Self) -> f64 {
        DVec2::dot(self, other)
    }
    #[inline]
    fn get(self, axis: usize) -> f64 {
        self[axis]
    }
    #[inline]
    fn from_slice(c: &[f64]) -> Self {
        DVec2::new(c[0], c[1])
    }
    #[inline]
    fn min_components(self, other: Self) -> Self {
        self.min(other)
    }
    #[inline]
    fn max_components(self, other: Self) -> Self {
        self.max(other)
    }
}

impl Vector for DVec3 {
    const DIM: usize = 3;
    const ZERO: Self = DVec3::ZERO;

    #[inline]
    fn dot(self, other: Self) -> f64 {
        DVec3::dot(self, other)
    }
    #[inline]
    fn get(self, axis: usize) -> f64 {
        self[axis]
    }
    #[inline]
    fn from_slice(c: &[f64]) -> Self {
        DVec3::new(c[0], c[1], c[2])
    }
    #[inline]
    fn min_components(self, other: Self) -> Self {
        self.min(other)
    }
    #[inline]
    fn max_components(self, other: Self) -> Self {
        self.max(other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_axes_are_orthonormal() {
        for a in 0..3 {
            for b in 0..3 {
                let d = DVec3::unit_axis(a).dot(DVec3::unit_axis(b));
                assert_eq!(d, if a == b { 1.0 } else { 0.0 });
            }
        }
        assert_eq!(DVec2::unit_axis(1), DVec2::Y);
    }

    #[test]
    fn finite_check_sees_every_component() {
        assert!(DVec3::new(1.0, 2.0, 3.0).is_finite_vector());
        assert!(!DVec3::new(1.0, f64::NAN, 3.0).is_finite_vector());
        assert!(!DVec2::new(f64::INFINITY, 0.0).is_finite_vector());
    }
}
