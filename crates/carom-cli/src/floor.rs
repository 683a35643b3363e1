//! The streaming floor of `carom bench`: one pass over the particle state that a step must at
//! least read and write, timed on this machine in the same process as the case it sits next to.
//!
//! The pass reads position, velocity, radius and mass and writes position and velocity (80
//! bytes per particle in 2D, 112 in 3D), in parallel over the same rayon pool the case ran on.
//! No step can be faster than this; a case's ns per particle-step over the floor says how
//! many such passes' worth of time the step costs.

use carom_engine::Vector;
use rayon::prelude::*;
use std::time::Instant;

/// Passes timed; the fastest counts (the floor is a bound, not an average).
const PASSES: usize = 7;

/// Particles per parallel task, as the engine's integrator uses.
const CHUNK: usize = 8192;

/// Nanoseconds per particle of the fastest of [`PASSES`] streaming passes over `n` particles
/// of dimension `V::DIM`.
pub fn streaming_floor<V: Vector>(n: usize) -> f64 {
    let n = n.max(1);
    let mut position: Vec<V> = (0..n)
        .map(|i| V::from_slice(&[i as f64; 3][..V::DIM]))
        .collect();
    let mut velocity: Vec<V> = vec![V::from_slice(&[1.0; 3][..V::DIM]); n];
    let radius = vec![0.5_f64; n];
    let mass = vec![1.0_f64; n];
    let dt = 1.0 / 60.0;
    let mut best = f64::INFINITY;
    for _ in 0..PASSES {
        let started = Instant::now();
        position
            .par_chunks_mut(CHUNK)
            .zip(velocity.par_chunks_mut(CHUNK))
            .zip(radius.par_chunks(CHUNK).zip(mass.par_chunks(CHUNK)))
            .for_each(|((x, v), (r, m))| {
                for (((x, v), &r), &m) in x.iter_mut().zip(v.iter_mut()).zip(r).zip(m) {
                    // (a damping that depends on radius and mass, so that neither read is dead)
                    *v = *v * (1.0 - 1e-9 * r / m);
                    *x += *v * dt;
                }
            });
        best = best.min(started.elapsed().as_secs_f64());
    }
    std::hint::black_box((&position, &velocity));
    best * 1e9 / n as f64
}
