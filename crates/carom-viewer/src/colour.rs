//! The viewer's colour scale: the map and background are `carom-render`'s (one map for
//! pictures and the window); the range here follows a live simulation.

pub use carom_render::{colormap_rgb8, Colouring, BACKGROUND};

/// The range a colour mode maps onto the colour map: `(low, high)` with `high > low`.
///
/// Speed uses 0 to the 98th percentile (one very fast particle should not make every other
/// one dark); radius the smallest to the largest; id 0 to n - 1.
pub fn value_range(
    mode: Colouring,
    speeds: &[f64],
    radii: &[f64],
    scratch: &mut Vec<f64>,
) -> (f64, f64) {
    let (lo, hi) = match mode {
        Colouring::Speed => {
            scratch.clear();
            scratch.extend(speeds.iter().copied().filter(|s| s.is_finite()));
            if scratch.is_empty() {
                (0.0, 1.0)
            } else {
                let k = ((scratch.len() - 1) as f64 * 0.98) as usize;
                let (_, v, _) = scratch.select_nth_unstable_by(k, f64::total_cmp);
                (0.0, *v)
            }
        }
        Colouring::Radius => radii
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &r| {
                (a.min(r), b.max(r))
            }),
        Colouring::Id => (0.0, radii.len().saturating_sub(1) as f64),
    };
    if !(lo.is_finite() && hi.is_finite()) {
        (0.0, 1.0)
    } else if hi - lo <= f64::EPSILON * hi.abs().max(1.0) {
        (lo, lo + 1.0)
    } else {
        (lo, hi)
    }
}

/// Position of `v` on the ramp for the range `(lo, hi)`.
#[inline]
pub fn normalise(v: f64, (lo, hi): (f64, f64)) -> f64 {
    (v - lo) / (hi - lo)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_are_never_empty() {
        let mut s = Vec::new();
        assert_eq!(value_range(Colouring::Speed, &[], &[], &mut s), (0.0, 1.0));
        assert_eq!(
            value_range(Colouring::Radius, &[0.0], &[2.0, 2.0], &mut s),
            (2.0, 3.0)
        );
        assert_eq!(
            value_range(Colouring::Id, &[0.0; 4], &[1.0; 4], &mut s),
            (0.0, 3.0)
        );
        let speeds: Vec<f64> = (0..=100).map(f64::from).collect();
        let (lo, hi) = value_range(Colouring::Speed, &speeds, &[1.0; 101], &mut s);
        assert_eq!((lo, hi), (0.0, 98.0));
        let with_nan = [1.0, f64::NAN, 3.0];
        let (_, hi) = value_range(Colouring::Speed, &with_nan, &[1.0; 3], &mut s);
        assert!(hi.is_finite());
    }
}
