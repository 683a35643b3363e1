//! Colouring particles: the quantity shown and the colormap.

use crate::frame::Frame;

/// What the particles' colour shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Colouring {
    /// The length of the velocity (the scale starts at 0).
    Speed,
    /// The radius.
    Radius,
    /// The particle id (shows how particles mix).
    Id,
}

impl Colouring {
    /// The legend's label.
    pub fn label(self) -> &'static str {
        match self {
            Colouring::Speed => "speed",
            Colouring::Radius => "radius",
            Colouring::Id => "id",
        }
    }

    /// The value particle `id` of `frame` shows.
    pub fn value(self, frame: &Frame, id: usize) -> f64 {
        match self {
            Colouring::Speed => {
                let v = frame.velocities[id];
                (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
            }
            Colouring::Radius => frame.radii[id],
            Colouring::Id => id as f64,
        }
    }
}

/// The colour scale's ends over `frames`: minimum and maximum of the shown value (speed
/// starts at 0). `(0, 1)` without particles.
pub fn colour_range(frames: &[Frame], colouring: Colouring) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for f in frames {
        for id in 0..f.positions.len() {
            let v = colouring.value(f, id);
            if v.is_finite() {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    if colouring == Colouring::Speed {
        lo = 0.0;
    }
    if lo > hi {
        (0.0, 1.0)
    } else {
        (lo, hi)
    }
}

/// Where `value` sits on the scale `range`, in [0, 1] (0.5 when the range is one value).
pub(crate) fn position(value: f64, (lo, hi): (f64, f64)) -> f64 {
    if hi > lo {
        ((value - lo) / (hi - lo)).clamp(0.0, 1.0)
    } else {
        0.5
    }
}

/// The colormap: turbo (Google's improved rainbow, polynomial fit by Mikhailov), with its
/// darkest tenth cut off so that the low end stands out on the dark background. `t` in
/// [0, 1] (clamped); returns sRGB components in [0, 1].
pub fn colormap(t: f64) -> [f32; 3] {
    let t = 0.1 + 0.9 * t.clamp(0.0, 1.0);
    let r = 0.13572138
        + t * (4.6153926
            + t * (-42.66032258 + t * (132.13108234 + t * (-152.94239396 + t * 59.28637943))));
    let g = 0.09140261
        + t * (2.19418839
            + t * (4.84296658 + t * (-14.18503333 + t * (4.27729857 + t * 2.82956604))));
    let b = 0.1066733
        + t * (12.64194608
            + t * (-60.58204836 + t * (110.36276771 + t * (-89.90310912 + t * 27.34824973))));
    [r, g, b].map(|c| c.clamp(0.0, 1.0) as f32)
}
