//! Colouring particles: the quantity shown, the colormap and the background it is drawn on.
//! The one place for both `carom render` and the viewer (`carom view`), so that a colour
//! means the same in a picture and on screen.

use crate::frame::Frame;

/// The background particles are drawn on (sRGB), in pictures and in the viewer: near black,
/// so that [`colormap`]'s every colour stands out against it (contrast at least 3.2 : 1).
pub const BACKGROUND: [u8; 3] = [17, 19, 25];

/// What the particles' colour shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Colouring {
    /// The length of the velocity (the scale starts at 0).
    #[default]
    Speed,
    /// The radius.
    Radius,
    /// The particle id (shows how particles mix).
    Id,
}

impl Colouring {
    /// Every mode, in menu order.
    pub const ALL: [Colouring; 3] = [Colouring::Speed, Colouring::Radius, Colouring::Id];

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
        let speed = glam::DVec3::from_array(frame.velocities[id]).length();
        self.of(id, speed, frame.radii[id])
    }

    /// The value a particle with this `id`, `speed` and `radius` shows.
    #[inline]
    pub fn of(self, id: usize, speed: f64, radius: f64) -> f64 {
        match self {
            Colouring::Speed => speed,
            Colouring::Radius => radius,
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

/// The colormap: turbo (Google's improved rainbow, polynomial fit by Mikhailov) from 0.12 to
/// 0.88: both of turbo's ends are too dark to see on [`BACKGROUND`] (its low end is dark
/// violet, its high end dark red); the slice kept goes blue, cyan, green, yellow, orange, red.
/// `t` in [0, 1] (clamped; NaN gives the low end); returns sRGB components in [0, 1].
pub fn colormap(t: f64) -> [f32; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let t = 0.12 + 0.76 * t;
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

/// [`colormap`] as 8-bit sRGB.
pub fn colormap_rgb8(t: f64) -> [u8; 3] {
    colormap(t).map(|c| (c * 255.0 + 0.5) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// WCAG's contrast ratio of two sRGB colours.
    fn contrast(a: [u8; 3], b: [u8; 3]) -> f64 {
        let luminance = |c: [u8; 3]| {
            let l = c.map(|v| {
                let v = v as f64 / 255.0;
                if v <= 0.04045 {
                    v / 12.92
                } else {
                    ((v + 0.055) / 1.055).powf(2.4)
                }
            });
            0.2126 * l[0] + 0.7152 * l[1] + 0.0722 * l[2]
        };
        let (x, y) = (luminance(a) + 0.05, luminance(b) + 0.05);
        x.max(y) / x.min(y)
    }

    #[test]
    fn every_colour_stands_out_on_the_background() {
        for k in 0..=100 {
            let c = colormap_rgb8(k as f64 / 100.0);
            assert!(
                contrast(c, BACKGROUND) > 3.2,
                "t = {}: {c:?}",
                k as f64 / 100.0
            );
        }
        assert_eq!(colormap(f64::NAN), colormap(0.0));
        assert_eq!(colormap(-3.0), colormap(0.0));
        assert_eq!(colormap(9.0), colormap(1.0));
    }
}
