//! An unbounded spatial hash (Teschner et al. 2003, "Optimized Spatial Hashing for Collision
//! Detection of Deformable Objects"): the lecture's grid without its box.
//!
//! Space is cut into cells one largest diameter wide, without end; a cell's integer coordinates
//! are hashed into a table sized to the particle count, and each table entry is a bucket of
//! particle ids (cell lists built by counting sort, like [`crate::grid`]). A particle far away
//! from the rest lands in its own cell and, almost surely, its own bucket, so no scene piles its
//! particles into one bucket just because some escaped the domain, and the table never grows
//! with the extent of space. Cells that collide in the table merely add candidates, which the
//! distance test throws out; a bucket reached through two cells is searched once.

use crate::broadphase::{collect_pairs, BroadPhase, Pair, PARALLEL_SEARCH_MIN};
use crate::bucket::counting_sort;
use crate::grid::widened_reach;
use crate::response::is_overlapping;
use crate::vector::Vector;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// The unbounded hash broad phase.
#[derive(Debug, Default)]
pub struct SpatialHash {
    layout: HashLayout,
    bucket_of: Vec<u32>,
    bucket_start: Vec<u32>,
    ids: Vec<u32>,
    buffers: Vec<Vec<Pair>>,
    /// Time spent binning since [`BroadPhase::take_bin_time`] last took it.
    bin_time: Duration,
}

/// Cell size and table size of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HashLayout {
    /// `1 / cell edge`.
    pub inverse_cell: f64,
    /// Table entries, a power of two.
    pub table_size: usize,
}

impl HashLayout {
    /// Integer cell coordinate on one axis; monotone in `coordinate`, saturating far away.
    #[inline]
    pub fn axis_cell(&self, coordinate: f64) -> i64 {
        let t = coordinate * self.inverse_cell;
        // floor without a libm call: truncate, then step down for negative non-integers
        // (`saturating_sub`: far below i64::MIN, `t as i64` saturates to i64::MIN, which is
        // above `t`; found by fuzzing, where `dt = 4294967296` flung a particle that far)
        let f = t as i64;
        if (f as f64) > t {
            f.saturating_sub(1)
        } else {
            f
        }
    }

    /// Table entry of a cell (Teschner's primes, XOR-combined).
    #[inline]
    pub fn bucket(&self, cell: [i64; 3]) -> usize {
        let h = (cell[0].wrapping_mul(73_856_093))
            ^ (cell[1].wrapping_mul(19_349_663))
            ^ (cell[2].wrapping_mul(83_492_791));
        (h as u64 as usize) & (self.table_size - 1)
    }

    /// Table entry of the cell holding `x`.
    #[inline]
    pub fn bucket_of<V: Vector>(&self, x: V) -> usize {
        let mut c = [0i64; 3];
        for (a, slot) in c.iter_mut().enumerate().take(V::DIM) {
            *slot = self.axis_cell(x.get(a));
        }
        self.bucket(c)
    }
}

impl SpatialHash {
    /// A new, empty hash.
    pub fn new() -> Self {
        Self::default()
    }

    /// The layout of the last search.
    pub fn layout(&self) -> HashLayout {
        self.layout
    }
}

/// Most table entries a search reaches for one particle: 4 cells per axis in 3D.
const MAX_VISITED: usize = 64;

impl<V: Vector> BroadPhase<V> for SpatialHash {
    fn find_pairs(&mut self, positions: &[V], radii: &[f64], pairs: &mut Vec<Pair>) {
        let binning = Instant::now();
        let n = positions.len();
        let max_radius = crate::grid::largest(radii);
        let cell = (2.0 * max_radius).max(f64::MIN_POSITIVE);
        self.layout = HashLayout {
            inverse_cell: 1.0 / cell,
            table_size: (2 * n).next_power_of_two().max(64),
        };
        let layout = self.layout;
        self.bucket_of.resize(n, 0);
        let bin = |(b, &x): (&mut u32, &V)| *b = layout.bucket_of(x) as u32;
        if n >= PARALLEL_SEARCH_MIN {
            self.bucket_of
                .par_iter_mut()
                .zip(positions.par_iter())
                .for_each(bin);
        } else {
            self.bucket_of
                .iter_mut()
                .zip(positions.iter())
                .for_each(bin);
        }
        let table = layout.table_size;
        counting_sort(
            &self.bucket_of,
            table,
            0..n as u32,
            &mut self.bucket_start,
            &mut self.ids,
        );
        self.bin_time += binning.elapsed();

        let (starts, ids) = (&self.bucket_start, &self.ids);
        collect_pairs(n, &mut self.buffers, pairs, |i, out| {
            let (pi, ri) = (positions[i], radii[i]);
            let reach = ri + max_radius;
            let mut lo = [0i64; 3];
            let mut hi = [0i64; 3];
            for a in 0..V::DIM {
                // Widened past rounding, as in the grid (see crate::grid).
                let c = pi.get(a);
                let widened = widened_reach(c, reach);
                lo[a] = layout.axis_cell(c - widened);
                hi[a] = layout
                    .axis_cell(c + widened)
                    .max(lo[a])
                    .min(lo[a].saturating_add(3));
            }
            let mut visited = [usize::MAX; MAX_VISITED];
            let mut count = 0;
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        let b = layout.bucket([x, y, z]);
                        if visited[..count].contains(&b) {
                            continue;
                        }
                        visited[count] = b;
                        count += 1;
                        for &j in &ids[starts[b] as usize..starts[b + 1] as usize] {
                            let j = j as usize;
                            if j > i && is_overlapping(pi, positions[j], ri, radii[j]) {
                                out.push((i as u32, j as u32));
                            }
                        }
                    }
                }
            }
        });
    }

    fn take_bin_time(&mut self) -> Duration {
        std::mem::take(&mut self.bin_time)
    }

    fn name(&self) -> &'static str {
        "hash"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brute::BruteForce;
    use glam::{DVec2, DVec3};

    fn cloud(n: usize, spread: f64) -> (Vec<DVec3>, Vec<f64>) {
        let mut next = crate::testing::uniform(7);
        let mut pos = Vec::new();
        let mut rad = Vec::new();
        for i in 0..n {
            pos.push(DVec3::new(next(), next(), next()) * spread - DVec3::splat(spread / 2.0));
            rad.push(if i % 5 == 0 { 2.5 } else { 0.7 });
        }
        // far-away escapees, one exactly on another, and negative coordinates
        pos.push(DVec3::new(1e12, -3e11, 5.0));
        rad.push(1.0);
        pos.push(DVec3::new(1e12, -3e11, 5.5));
        rad.push(1.0);
        pos.push(pos[3]);
        rad.push(0.7);
        (pos, rad)
    }

    #[test]
    fn hash_equals_brute_force() {
        let (pos, rad) = cloud(800, 40.0);
        let mut expected = Vec::new();
        BruteForce::new().find_pairs(&pos, &rad, &mut expected);
        let mut got = Vec::new();
        SpatialHash::new().find_pairs(&pos, &rad, &mut got);
        assert!(expected.len() > 100);
        assert_eq!(got, expected);
    }

    #[test]
    fn hash_equals_brute_force_2d_across_cell_boundaries() {
        // centres a few ulps under one diameter apart, straddling cell boundaries
        let mut pos = Vec::new();
        for k in -20..20 {
            let x = k as f64 * 0.1;
            pos.push(DVec2::new(x, 0.0));
            pos.push(DVec2::new((x + 0.1).next_down(), 0.0));
        }
        let rad = vec![0.05; pos.len()];
        let mut expected = Vec::new();
        BruteForce::new().find_pairs(&pos, &rad, &mut expected);
        let mut got = Vec::new();
        SpatialHash::new().find_pairs(&pos, &rad, &mut got);
        assert_eq!(got, expected);
    }

    #[test]
    fn a_far_escapee_does_not_share_the_crowd_bucket() {
        let layout = HashLayout {
            inverse_cell: 0.5,
            table_size: 1 << 12,
        };
        let home = layout.bucket_of(DVec2::new(0.0, 0.0));
        let far = layout.bucket_of(DVec2::new(1e9, 0.0));
        assert_ne!(home, far);
    }
}
