//! Brute force broad phase: test every pair. O(n^2); the lecture's baseline ("0.18 s per
//! frame at 5000 particles") and the reference the grid is checked against.

use crate::broadphase::{collect_pairs, BroadPhase, Pair};
use crate::periodic::Periodic;
use crate::response::is_overlapping;
use crate::vector::Vector;

/// Tests all `n (n - 1) / 2` pairs.
#[derive(Debug, Default)]
pub struct BruteForce {
    buffers: Vec<Vec<Pair>>,
    /// Periodic axes: pairs are tested at their minimum-image distance.
    periodic: Option<Periodic>,
}

impl BruteForce {
    /// A new brute-force broad phase.
    pub fn new() -> Self {
        Self::default()
    }

    /// Tests pairs through the minimum image on `periodic`'s axes (see [`crate::periodic`]).
    pub fn with_periodic(mut self, periodic: Option<Periodic>) -> Self {
        self.periodic = periodic;
        self
    }
}

impl<V: Vector> BroadPhase<V> for BruteForce {
    fn find_pairs(&mut self, positions: &[V], radii: &[f64], pairs: &mut Vec<Pair>) {
        let n = positions.len();
        if let Some(p) = self.periodic {
            collect_pairs(n, &mut self.buffers, pairs, |i, out| {
                let (pi, ri) = (positions[i], radii[i]);
                for j in i + 1..n {
                    if is_overlapping(pi, p.image(pi, positions[j]), ri, radii[j]) {
                        out.push((i as u32, j as u32));
                    }
                }
            });
            return;
        }
        collect_pairs(n, &mut self.buffers, pairs, |i, out| {
            let (pi, ri) = (positions[i], radii[i]);
            for j in i + 1..n {
                if is_overlapping(pi, positions[j], ri, radii[j]) {
                    out.push((i as u32, j as u32));
                }
            }
        });
    }

    fn name(&self) -> &'static str {
        "brute"
    }
}
