//! Kinetic theory of hard disks and spheres: what a gas of carom particles should measure (see
//! [`crate::observe`] for how it is measured, and `docs/validation.md` for how well it does).
//!
//! Notation: `eta` the packing fraction (area fraction in 2D, volume fraction in 3D) in
//! [0, 1), `d` the dimension (2 or 3), `s` the diameter, `n` the number density (particles per
//! area or volume), `T` the granular temperature `sum m |v - u|^2 / (d N)` and `m` the mass.

use std::f64::consts::PI;

/// The pair correlation at contact, `g(s)`: Henderson's (1975) for disks,
/// `(1 - 7 eta / 16) / (1 - eta)^2`, and Carnahan and Starling's (1969) for spheres,
/// `(1 - eta / 2) / (1 - eta)^3`.
pub fn contact_correlation(d: usize, eta: f64) -> f64 {
    match d {
        2 => (1.0 - 7.0 * eta / 16.0) / (1.0 - eta).powi(2),
        _ => (1.0 - eta / 2.0) / (1.0 - eta).powi(3),
    }
}

/// The compressibility factor `Z = P V / (N T)` of the elastic gas: Henderson's
/// `(1 + eta^2 / 8) / (1 - eta)^2` for disks, Carnahan and Starling's
/// `(1 + eta + eta^2 - eta^3) / (1 - eta)^3` for spheres.
pub fn compressibility(d: usize, eta: f64) -> f64 {
    match d {
        2 => (1.0 + eta * eta / 8.0) / (1.0 - eta).powi(2),
        _ => (1.0 + eta + eta * eta - eta.powi(3)) / (1.0 - eta).powi(3),
    }
}

/// Enskog's collision frequency per particle (collisions each particle takes per unit time):
/// `2 sqrt(pi) n s g(s) sqrt(T / m)` in 2D, `4 sqrt(pi) n s^2 g(s) sqrt(T / m)` in 3D. A gas
/// of `N` particles has `N w / 2` pair collisions per unit time.
pub fn enskog_collision_rate(d: usize, eta: f64, n: f64, s: f64, temperature: f64, m: f64) -> f64 {
    let g = contact_correlation(d, eta);
    let thermal = (temperature / m).sqrt();
    match d {
        2 => 2.0 * PI.sqrt() * n * s * g * thermal,
        _ => 4.0 * PI.sqrt() * n * s * s * g * thermal,
    }
}

/// Haff's law of homogeneous cooling: `T(t) = T0 / (1 + t / t0)^2`.
pub fn haff_temperature(t0_temperature: f64, t: f64, t0: f64) -> f64 {
    t0_temperature / (1.0 + t / t0).powi(2)
}

/// Haff's time scale `t0 = 2 d / ((1 - e^2) w0)` for restitution `e` < 1 and the initial
/// collision frequency `w0` ([`enskog_collision_rate`] at the initial temperature).
pub fn haff_time(d: usize, restitution: f64, initial_rate: f64) -> f64 {
    2.0 * d as f64 / ((1.0 - restitution * restitution) * initial_rate)
}

/// The velocity distribution's kurtosis excess `a2 = d / (d + 2) <v^4> / <v^2>^2 - 1` of
/// velocities `v` (taken from their mean): 0 for Maxwell-Boltzmann, `-2 / (d + 2)` when every
/// speed is the same.
pub fn kurtosis_excess<V: crate::Vector>(velocities: &[V]) -> f64 {
    let n = velocities.len() as f64;
    if n == 0.0 {
        return 0.0;
    }
    let mean = velocities.iter().fold(V::ZERO, |a, &v| a + v) * (1.0 / n);
    let (second, fourth) = velocities.iter().fold((0.0, 0.0), |(s2, s4), &v| {
        let c = (v - mean).length_squared();
        (s2 + c, s4 + c * c)
    });
    let (second, fourth) = (second / n, fourth / n);
    let d = V::DIM as f64;
    d / (d + 2.0) * fourth / (second * second) - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    #[test]
    fn the_dilute_limit_is_the_ideal_gas() {
        for d in [2, 3] {
            assert_eq!(compressibility(d, 0.0), 1.0);
            assert_eq!(contact_correlation(d, 0.0), 1.0);
        }
        // Henderson at eta = 0.5: (1 + 1/32) / 0.25; Carnahan-Starling at 0.5: 1.625 / 0.125
        assert_eq!(compressibility(2, 0.5), 4.125);
        assert_eq!(compressibility(3, 0.5), 13.0);
    }

    #[test]
    fn haff_halves_the_thermal_speed_at_t0() {
        let t0 = haff_time(2, 0.5, 3.0);
        assert_eq!(t0, 4.0 / (0.75 * 3.0));
        assert_eq!(haff_temperature(8.0, t0, t0), 2.0);
    }

    #[test]
    fn equal_speeds_have_the_kurtosis_of_a_ring() {
        let ring: Vec<DVec2> = (0..360)
            .map(|k| DVec2::from_angle(k as f64 * PI / 180.0) * 3.0)
            .collect();
        assert!((kurtosis_excess(&ring) + 0.5).abs() < 1e-12);
    }
}
