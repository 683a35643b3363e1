//! A fill's random numbers: where each try and each velocity takes its numbers from the fill's
//! stream (PCG, seeded), so that they can be drawn in chunks on the thread pool and still be
//! the numbers one draw after another would give.

use super::Fill;
use carom_engine::Vector;
use rand::Rng;
use rand_pcg::Pcg64;
use rayon::prelude::*;

/// How far along the fill's random stream its velocities are drawn: the positions of the tries
/// come from the start of the stream and the velocities from here, so a try's position does
/// not depend on how many tries before it were placed. (No fill comes near 2^100 draws.)
pub(super) const VELOCITY_STREAM_OFFSET: u128 = 1 << 100;

impl<V: Vector> Fill<V> {
    /// A random velocity: the base velocity plus a random direction times a speed uniform in
    /// [0, speed].
    pub(super) fn velocity(&self, rng: &mut Pcg64) -> V {
        self.base_velocity + random_direction::<V>(rng) * (self.speed * rng.random::<f64>())
    }

    /// The next `n` velocities of `stream` ([`Fill::velocity`] `n` times, [`VELOCITY_DRAWS`]
    /// numbers each) into `out` (see [`draw_in_chunks`]).
    pub(super) fn velocities(&self, stream: &mut Pcg64, n: usize, out: &mut Vec<V>) {
        out.clear();
        out.resize(n, V::ZERO);
        let draws = VELOCITY_DRAWS[V::DIM - 2];
        draw_in_chunks(stream, out, draws, |numbers| self.velocity(numbers));
    }
}

/// Numbers of the random stream one [`Fill::velocity`] takes in 2D and in 3D: a direction
/// (an angle; or a height and an angle) and a speed.
const VELOCITY_DRAWS: [usize; 2] = [2, 3];

/// Items (tries or velocities) one task of [`draw_in_chunks`] draws.
const DRAWS_PER_TASK: usize = 8192;

/// Fills `out` with `draw` of the stream, item after item, each taking exactly `numbers` of
/// it, and leaves `stream` past them all: on the thread pool in chunks, each from the stream
/// advanced to its first item, so the same items in the same order for any thread count.
fn draw_in_chunks<T: Send>(
    stream: &mut Pcg64,
    out: &mut [T],
    numbers: usize,
    draw: impl Fn(&mut Pcg64) -> T + Sync,
) {
    let start: &Pcg64 = stream;
    out.par_chunks_mut(DRAWS_PER_TASK)
        .enumerate()
        .for_each(|(chunk_index, chunk)| {
            let mut chunk_stream = start.clone();
            chunk_stream.advance((chunk_index * DRAWS_PER_TASK * numbers) as u128);
            for item in chunk {
                *item = draw(&mut chunk_stream);
            }
        });
    stream.advance((out.len() * numbers) as u128);
}

/// The next `size` random tries of `stream` (one number a coordinate) in the box `(lo, span)`,
/// each passed through `wrap`, appended to `tries` (see [`draw_in_chunks`]).
pub(super) fn draw_tries<V: Vector>(
    stream: &mut Pcg64,
    (lo, span): (V, V),
    wrap: impl Fn(V) -> V + Sync,
    size: usize,
    tries: &mut Vec<V>,
) {
    let first = tries.len();
    tries.resize(first + size, V::ZERO);
    draw_in_chunks(stream, &mut tries[first..], V::DIM, |numbers| {
        let mut c = [0.0; 3];
        for (a, slot) in c.iter_mut().enumerate().take(V::DIM) {
            *slot = lo.get(a) + span.get(a) * numbers.random::<f64>();
        }
        wrap(V::from_slice(&c))
    });
}

/// A uniformly random unit vector.
fn random_direction<V: Vector>(rng: &mut Pcg64) -> V {
    use std::f64::consts::TAU;
    if V::DIM == 2 {
        let angle = TAU * rng.random::<f64>();
        V::from_slice(&[angle.cos(), angle.sin()])
    } else {
        let z = 2.0 * rng.random::<f64>() - 1.0;
        let angle = TAU * rng.random::<f64>();
        let s = (1.0 - z * z).max(0.0).sqrt();
        V::from_slice(&[s * angle.cos(), s * angle.sin(), z])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use carom_engine::Aabb;
    use glam::{DVec2, DVec3};
    use rand::SeedableRng;

    /// Tries and velocities drawn in chunks on the thread pool are the numbers one draw after
    /// another gives, in the same order, and leave the stream where it would be: over several
    /// chunks, in 2D and 3D.
    #[test]
    fn chunked_draws_are_the_sequential_draws() {
        fn check<V: Vector>() {
            let n = 2 * DRAWS_PER_TASK + 3;
            let (lo, span) = (V::from_slice(&[-3.0; 3]), V::from_slice(&[7.0; 3]));
            let mut chunked = Pcg64::seed_from_u64(5);
            let mut one_by_one = chunked.clone();
            let mut tries = vec![V::ZERO];
            draw_tries(&mut chunked, (lo, span), |x| x * 2.0, n, &mut tries);
            let mut expected = vec![V::ZERO];
            for _ in 0..n {
                let mut c = [0.0; 3];
                for slot in c.iter_mut().take(V::DIM) {
                    *slot = -3.0 + 7.0 * one_by_one.random::<f64>();
                }
                expected.push(V::from_slice(&c) * 2.0);
            }
            assert_eq!(tries, expected);
            assert_eq!(chunked, one_by_one);

            let fill = Fill {
                count: n as u64,
                radius: 1.0,
                mass: 1.0,
                speed: 2.0,
                base_velocity: V::from_slice(&[0.5; 3]),
                region: Aabb::new(lo, lo + span).unwrap(),
            };
            let mut velocities = Vec::new();
            fill.velocities(&mut chunked, n, &mut velocities);
            let expected: Vec<V> = (0..n).map(|_| fill.velocity(&mut one_by_one)).collect();
            assert_eq!(velocities, expected);
            assert_eq!(chunked, one_by_one);
        }
        check::<DVec2>();
        check::<DVec3>();
    }
}
