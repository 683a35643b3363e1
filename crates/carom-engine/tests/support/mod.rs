//! Shared by the engine's integration tests.

use carom_engine::{Vector, World};

/// A small deterministic generator (PCG constants, top 53 bits) so scenes need no `rand` and
/// every failure reproduces exactly.
pub struct Lcg(u64);

impl Lcg {
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x9e37_79b9_7f4a_7c15)
    }
    /// Uniform in [0, 1).
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    /// Each component uniform in [lo, hi).
    pub fn vector<V: Vector>(&mut self, lo: f64, hi: f64) -> V {
        let c = [self.range(lo, hi), self.range(lo, hi), self.range(lo, hi)];
        V::from_slice(&c)
    }
}

/// Every position and velocity finite.
#[allow(dead_code)] // (not every test crate asks)
pub fn all_finite<V: Vector>(w: &World<V>) -> bool {
    let p = w.particles();
    p.positions().iter().all(|x| x.is_finite_vector())
        && p.velocities().iter().all(|v| v.is_finite_vector())
}

/// Largest `r_i + r_j - |x_i - x_j|` over all pairs (brute force), 0 when nothing overlaps.
#[allow(dead_code)] // (not every test crate asks)
pub fn max_overlap<V: Vector>(w: &World<V>) -> f64 {
    let p = w.particles();
    let (x, r) = (p.positions(), p.radii());
    let mut worst = 0.0f64;
    for i in 0..x.len() {
        for j in i + 1..x.len() {
            let d = (x[i] - x[j]).length_squared().sqrt();
            worst = worst.max(r[i] + r[j] - d);
        }
    }
    worst
}

/// `n` unit discs (spheres) at `position(rng)`, drawn again while one would be closer than
/// touching to one placed before, each with `velocity(rng)` drawn once it is placed.
#[allow(dead_code)] // (not every test crate asks)
pub fn scatter<V: Vector>(
    n: usize,
    rng: &mut Lcg,
    position: impl Fn(&mut Lcg) -> V,
    velocity: impl Fn(&mut Lcg) -> V,
) -> Vec<(V, V)> {
    let mut placed: Vec<(V, V)> = Vec::with_capacity(n);
    while placed.len() < n {
        let x = position(rng);
        if placed
            .iter()
            .all(|&(y, _)| (x - y).length_squared() >= 4.0 * 1.0001)
        {
            placed.push((x, velocity(rng)));
        }
    }
    placed
}
