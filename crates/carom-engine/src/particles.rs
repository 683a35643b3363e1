//! Particle storage: structure of arrays, one `Vec` per quantity, indexed by particle id.

use crate::error::EngineError;
use crate::vector::Vector;

/// Every particle's state. Ids are indices `0..len()` and never change.
///
/// Invariants (checked by [`Particles::push`]): radius and mass are finite and > 0,
/// position and velocity are finite.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Particles<V> {
    pub(crate) position: Vec<V>,
    pub(crate) velocity: Vec<V>,
    pub(crate) radius: Vec<f64>,
    pub(crate) mass: Vec<f64>,
}

impl<V: Vector> Particles<V> {
    /// No particles.
    pub fn new() -> Self {
        Self {
            position: Vec::new(),
            velocity: Vec::new(),
            radius: Vec::new(),
            mass: Vec::new(),
        }
    }

    /// Room for `additional` more particles without reallocating; fails instead of aborting
    /// when memory cannot be had.
    pub fn try_reserve(
        &mut self,
        additional: usize,
    ) -> Result<(), std::collections::TryReserveError> {
        self.position.try_reserve(additional)?;
        self.velocity.try_reserve(additional)?;
        self.radius.try_reserve(additional)?;
        self.mass.try_reserve(additional)
    }

    /// Adds a particle and returns its id. Position in length units, velocity in length per
    /// time unit, radius > 0, mass > 0.
    pub fn push(
        &mut self,
        position: V,
        velocity: V,
        radius: f64,
        mass: f64,
    ) -> Result<usize, EngineError> {
        let index = self.len();
        if index >= u32::MAX as usize {
            return Err(EngineError::TooManyParticles(index + 1));
        }
        if !position.is_finite_vector() || !velocity.is_finite_vector() {
            return Err(EngineError::ParticleNotFinite(index));
        }
        if !(radius.is_finite() && radius > 0.0) {
            return Err(EngineError::Radius {
                index,
                value: radius,
            });
        }
        if !(mass.is_finite() && mass > 0.0) {
            return Err(EngineError::Mass { index, value: mass });
        }
        self.position.push(position);
        self.velocity.push(velocity);
        self.radius.push(radius);
        self.mass.push(mass);
        Ok(index)
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// True when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Centres, by id.
    pub fn positions(&self) -> &[V] {
        &self.position
    }

    /// Velocities, by id.
    pub fn velocities(&self) -> &[V] {
        &self.velocity
    }

    /// Radii (> 0), by id.
    pub fn radii(&self) -> &[f64] {
        &self.radius
    }

    /// Masses (> 0), by id.
    pub fn masses(&self) -> &[f64] {
        &self.mass
    }

    /// The largest radius, 0 when empty.
    pub fn max_radius(&self) -> f64 {
        crate::grid::largest(&self.radius)
    }

    /// Sets particle `id`'s velocity (for interactive tools). Must be finite.
    pub fn set_velocity(&mut self, id: usize, velocity: V) -> Result<(), EngineError> {
        if !velocity.is_finite_vector() {
            return Err(EngineError::ParticleNotFinite(id));
        }
        self.velocity[id] = velocity;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    #[test]
    fn push_validates() {
        let mut p = Particles::<DVec2>::new();
        assert_eq!(p.push(DVec2::ZERO, DVec2::X, 1.0, 2.0), Ok(0));
        assert_eq!(p.masses(), &[2.0]);
        assert!(matches!(
            p.push(DVec2::ZERO, DVec2::X, 0.0, 1.0),
            Err(EngineError::Radius { index: 1, .. })
        ));
        assert!(matches!(
            p.push(DVec2::ZERO, DVec2::X, 1.0, -1.0),
            Err(EngineError::Mass { .. })
        ));
        assert!(p
            .push(DVec2::new(f64::NAN, 0.0), DVec2::X, 1.0, 1.0)
            .is_err());
        assert!(p.push(DVec2::ZERO, DVec2::X, f64::INFINITY, 1.0).is_err());
        assert_eq!(p.len(), 1);
    }
}
