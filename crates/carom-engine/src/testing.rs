//! What the unit tests share.

/// Uniform numbers in [0, 1) from a 64-bit linear congruential generator seeded with `seed`:
/// the same sequence on every machine, so the tests' clouds are fixed.
pub(crate) fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}
