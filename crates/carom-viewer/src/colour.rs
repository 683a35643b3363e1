//! Colour maps for particles and the legend that explains them.

/// What a particle's colour shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ColourBy {
    /// Speed `|v|`, from 0 to (about) the fastest.
    #[default]
    Speed,
    /// Radius, smallest to largest.
    Radius,
    /// Particle id, 0 to n - 1.
    Id,
}

impl ColourBy {
    /// Every mode, in menu order.
    pub const ALL: [ColourBy; 3] = [ColourBy::Speed, ColourBy::Radius, ColourBy::Id];

    /// Menu and legend label.
    pub fn label(self) -> &'static str {
        match self {
            ColourBy::Speed => "speed",
            ColourBy::Radius => "radius",
            ColourBy::Id => "id",
        }
    }
}

/// Stops of a perceptually ordered ramp (viridis-like, dark blue to yellow).
const RAMP: [[f32; 3]; 6] = [
    [68.0, 1.0, 84.0],
    [65.0, 68.0, 135.0],
    [42.0, 120.0, 142.0],
    [34.0, 168.0, 132.0],
    [122.0, 209.0, 81.0],
    [253.0, 231.0, 37.0],
];

/// The ramp at `t` in [0, 1] (clamped; NaN gives the low end), as RGB.
pub fn ramp(t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) } as f32;
    let x = t * (RAMP.len() - 1) as f32;
    let i = (x.floor() as usize).min(RAMP.len() - 2);
    let f = x - i as f32;
    let (a, b) = (RAMP[i], RAMP[i + 1]);
    [0, 1, 2].map(|c| (a[c] + (b[c] - a[c]) * f).round() as u8)
}

/// The range a colour mode maps onto the ramp: `(low, high)` with `high > low`.
///
/// Speed uses 0 to the 98th percentile (one very fast particle should not make every other
/// one dark); radius the smallest to the largest; id 0 to n - 1.
pub fn value_range(
    mode: ColourBy,
    speeds: &[f64],
    radii: &[f64],
    scratch: &mut Vec<f64>,
) -> (f64, f64) {
    let (lo, hi) = match mode {
        ColourBy::Speed => {
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
        ColourBy::Radius => radii
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &r| {
                (a.min(r), b.max(r))
            }),
        ColourBy::Id => (0.0, radii.len().saturating_sub(1) as f64),
    };
    if !(lo.is_finite() && hi.is_finite()) {
        (0.0, 1.0)
    } else if hi - lo <= f64::EPSILON * hi.abs().max(1.0) {
        (lo, lo + 1.0)
    } else {
        (lo, hi)
    }
}

/// The value a particle's colour encodes.
#[inline]
pub fn value(mode: ColourBy, id: usize, speed: f64, radius: f64) -> f64 {
    match mode {
        ColourBy::Speed => speed,
        ColourBy::Radius => radius,
        ColourBy::Id => id as f64,
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
    fn ramp_ends_and_clamping() {
        assert_eq!(ramp(0.0), [68, 1, 84]);
        assert_eq!(ramp(1.0), [253, 231, 37]);
        assert_eq!(ramp(-5.0), ramp(0.0));
        assert_eq!(ramp(7.0), ramp(1.0));
        assert_eq!(ramp(f64::NAN), ramp(0.0));
    }

    #[test]
    fn ranges_are_never_empty() {
        let mut s = Vec::new();
        assert_eq!(value_range(ColourBy::Speed, &[], &[], &mut s), (0.0, 1.0));
        assert_eq!(
            value_range(ColourBy::Radius, &[0.0], &[2.0, 2.0], &mut s),
            (2.0, 3.0)
        );
        assert_eq!(
            value_range(ColourBy::Id, &[0.0; 4], &[1.0; 4], &mut s),
            (0.0, 3.0)
        );
        let speeds: Vec<f64> = (0..=100).map(f64::from).collect();
        let (lo, hi) = value_range(ColourBy::Speed, &speeds, &[1.0; 101], &mut s);
        assert_eq!((lo, hi), (0.0, 98.0));
        let with_nan = [1.0, f64::NAN, 3.0];
        let (_, hi) = value_range(ColourBy::Speed, &with_nan, &[1.0; 3], &mut s);
        assert!(hi.is_finite());
    }
}
