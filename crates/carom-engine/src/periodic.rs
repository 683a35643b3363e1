//! Periodic boundaries: on a periodic axis the domain's faces are glued together, so a
//! particle leaving through `max` comes back through `min`, and particles near opposite faces
//! touch across the seam.
//!
//! Two rules carry the whole idea:
//!
//! - **wrap**: at the end of every step each position is brought back into `[min, max)` on
//!   every periodic axis (after everything that compares where a particle started the step
//!   with where it ended it, such as the sleep rest times);
//! - **minimum image**: a pair `(i, j)` is seen through the image of `j` nearest to `i`,
//!   `x_j + s` with the *shift* `s` a whole number of periods on each periodic axis (0 on the
//!   others). The broad phases test pairs at that distance, and each contact row keeps the
//!   shift its pair had when it was found, for the whole step: within a step every pair has
//!   one image, so the solver's rules (which read `x_i` and `x_j + s`, see
//!   [`crate::solver`]) see a contact across the seam exactly as one in the middle of the box.
//!   The velocity rules use only the normal, so the lecture's formula is untouched.
//!
//! The minimum image is unique for every contact because a periodic axis must be longer than
//! twice the farthest a pair can reach in a step ([`shortest_period`]): at most one image of
//! `j` is then within reach of `i`. Shifts are decided from positions wrapped at the start of
//! the step, so `|x_i - x_j| < L` on every periodic axis and one period is always enough.
//!
//! Everything here is arithmetic on the positions alone, the same whichever broad phase or
//! thread runs it, so periodic runs keep the engine's bit-for-bit determinism. A world with no
//! periodic axis never calls any of it: its bits are those of an engine without this module.

use crate::domain::Aabb;
use crate::solver::SLOP_FRACTION;
use crate::vector::Vector;
use rayon::prelude::*;

/// Particles per parallel task when wrapping.
const CHUNK: usize = 8192;

/// Which axes of a domain are periodic, and the domain's extent on them. Not generic over the
/// dimension, so broad phases that are not generic can hold it; unused axes are not periodic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Periodic {
    /// Per axis: glued (`true`) or not.
    axes: [bool; 3],
    /// The domain's lowest corner (length units).
    min: [f64; 3],
    /// The domain's highest corner.
    max: [f64; 3],
    /// The period `max - min` on periodic axes (> 0), 0 on the others.
    length: [f64; 3],
    /// Half the period: an image farther than this is not the nearest.
    half: [f64; 3],
}

/// The shortest period an axis may have for particles of largest radius `max_radius` (length
/// units): twice the farthest a pair can reach in a step. A particle's reach is at most
/// `(2 + SLOP_FRACTION) r` (its radius, the slop, and a move of at most one radius; see
/// [`crate::solver`]), a pair's the sum of two; longer than twice that, only one image of a
/// particle can be within reach of another, so the minimum image is the only one that matters.
pub fn shortest_period(max_radius: f64) -> f64 {
    4.0 * (2.0 + SLOP_FRACTION) * max_radius
}

impl Periodic {
    /// The periodic axes `axes` (one flag per axis of `V`, extra entries ignored) of `domain`;
    /// `None` when no axis is periodic.
    pub fn new<V: Vector>(domain: &Aabb<V>, axes: &[bool]) -> Option<Self> {
        let mut p = Periodic {
            axes: [false; 3],
            min: [0.0; 3],
            max: [0.0; 3],
            length: [0.0; 3],
            half: [0.0; 3],
        };
        for a in 0..V::DIM {
            p.min[a] = domain.min.get(a);
            p.max[a] = domain.max.get(a);
            if axes.get(a).copied().unwrap_or(false) {
                p.axes[a] = true;
                p.length[a] = p.max[a] - p.min[a];
                p.half[a] = 0.5 * p.length[a];
            }
        }
        p.axes.iter().any(|&a| a).then_some(p)
    }

    /// Per axis, whether it is periodic.
    pub fn axes(&self) -> [bool; 3] {
        self.axes
    }

    /// True when `axis` is periodic.
    #[inline]
    pub fn is_periodic(&self, axis: usize) -> bool {
        self.axes[axis]
    }

    /// The period on each axis (0 on those that are not periodic), or all zero without
    /// periodic axes (`None`).
    pub fn periods(periodic: Option<&Periodic>) -> [f64; 3] {
        periodic.map_or([0.0; 3], |p| p.length)
    }

    /// The domain's lowest coordinate on `axis`.
    #[inline]
    pub fn low(&self, axis: usize) -> f64 {
        self.min[axis]
    }

    /// The period on `axis` (0 when it is not periodic).
    #[inline]
    pub fn length(&self, axis: usize) -> f64 {
        self.length[axis]
    }

    /// `x` brought into `[min, max)` on every periodic axis (other axes untouched). A
    /// coordinate already inside is returned as it is, so wrapping twice changes nothing.
    #[inline]
    pub fn wrap<V: Vector>(&self, x: V) -> V {
        let mut c = [0.0; 3];
        let mut moved = false;
        for (a, slot) in c.iter_mut().enumerate().take(V::DIM) {
            *slot = x.get(a);
            if self.axes[a] {
                let y = self.wrap_coordinate(a, *slot);
                // (compared by bits: NaN stays as it is, and so does everything inside)
                if y.to_bits() != slot.to_bits() {
                    *slot = y;
                    moved = true;
                }
            }
        }
        if moved {
            V::from_slice(&c)
        } else {
            x
        }
    }

    /// One coordinate of [`Periodic::wrap`] on periodic `axis`.
    #[inline]
    fn wrap_coordinate(&self, axis: usize, x: f64) -> f64 {
        let (lo, hi, length) = (self.min[axis], self.max[axis], self.length[axis]);
        if (lo..hi).contains(&x) || !x.is_finite() {
            return x;
        }
        let mut y = x - ((x - lo) / length).floor() * length;
        // The quotient may round up to the next whole number (y a hair below lo), and y + L
        // may round up to hi itself: both are the seam, which belongs to lo.
        if y < lo {
            y += length;
        }
        if y >= hi || y < lo {
            y = lo;
        }
        y
    }

    /// The shift that takes `x_j` to its image nearest `x_i`: per periodic axis `+L`, `-L` or
    /// 0 (0 on other axes). Needs `|x_i - x_j| < 1.5 L` on periodic axes, which wrapped
    /// positions satisfy with room to spare. A tie (exactly half a period) keeps `x_j`.
    #[inline]
    pub fn shift<V: Vector>(&self, xi: V, xj: V) -> V {
        let mut s = [0.0; 3];
        let mut any = false;
        for (a, slot) in s.iter_mut().enumerate().take(V::DIM) {
            if self.axes[a] {
                let d = xi.get(a) - xj.get(a);
                if d > self.half[a] {
                    *slot = self.length[a];
                    any = true;
                } else if d < -self.half[a] {
                    *slot = -self.length[a];
                    any = true;
                }
            }
        }
        if any {
            V::from_slice(&s)
        } else {
            V::ZERO
        }
    }

    /// The image of `x_j` nearest `x_i`: `x_j + shift(x_i, x_j)`, and `x_j` itself (the very
    /// bits) when the shift is zero.
    #[inline]
    pub fn image<V: Vector>(&self, xi: V, xj: V) -> V {
        apply_shift(xj, self.shift(xi, xj))
    }
}

/// `x + shift`, and `x` itself (the very bits, signed zeros included) when `shift` is zero:
/// pairs that do not cross a seam, and every pair of a world without periodic axes, compute
/// exactly what they computed before shifts existed.
#[inline]
pub fn apply_shift<V: Vector>(x: V, shift: V) -> V {
    if shift == V::ZERO {
        x
    } else {
        x + shift
    }
}

/// Which whole period a contact sees `x_j` through on each axis (-1, 0 or 1): what a shift of
/// [`Periodic::shift`] holds (each of its components is `0` or `+-` the axis's period) in 3
/// bytes instead of a vector, for the solver's rows to keep.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Wrap([i8; 3]);

impl Wrap {
    /// The wrap of `shift`, a [`Periodic::shift`] (or zero).
    pub fn of<V: Vector>(shift: V) -> Self {
        let mut wrap = [0i8; 3];
        for (a, w) in wrap.iter_mut().enumerate().take(V::DIM) {
            let s = shift.get(a);
            *w = if s > 0.0 {
                1
            } else if s < 0.0 {
                -1
            } else {
                0
            };
        }
        Wrap(wrap)
    }

    /// The shift back, for periods `period` (see [`Periodic::periods`]): the very bits of the
    /// [`Periodic::shift`] it was made from, and zero when it wraps no axis.
    #[inline]
    pub fn shift<V: Vector>(self, period: &[f64; 3]) -> V {
        if self.0 == [0; 3] {
            return V::ZERO;
        }
        let mut s = [0.0; 3];
        for a in 0..V::DIM {
            s[a] = match self.0[a] {
                1 => period[a],
                -1 => -period[a],
                _ => 0.0,
            };
        }
        V::from_slice(&s)
    }
}

/// Wraps every position (see [`Periodic::wrap`]), on the thread pool when `parallel` (each
/// particle's wrap is its own, so the result is the same either way).
pub(crate) fn wrap_all<V: Vector>(periodic: &Periodic, parallel: bool, positions: &mut [V]) {
    let chunk = |x: &mut [V]| x.iter_mut().for_each(|x| *x = periodic.wrap(*x));
    if parallel {
        positions.par_chunks_mut(CHUNK).for_each(chunk);
    } else {
        positions.chunks_mut(CHUNK).for_each(chunk);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};

    /// A row's 3-byte wrap gives back the very bits of the shift it was made from.
    #[test]
    fn a_wrap_gives_back_its_shift() {
        let domain = Aabb::new(DVec3::new(-3.5, 0.25, -10.0), DVec3::new(6.0, 7.0, 10.0)).unwrap();
        for axes in [
            [true, false, true],
            [true, true, true],
            [false, true, false],
        ] {
            let p = Periodic::new(&domain, &axes).unwrap();
            let period = Periodic::periods(Some(&p));
            for (xi, xj) in [
                (DVec3::new(-3.4, 0.3, -9.9), DVec3::new(5.9, 6.9, 9.9)),
                (DVec3::new(5.9, 6.9, 9.9), DVec3::new(-3.4, 0.3, -9.9)),
                (DVec3::new(1.0, 3.0, 0.0), DVec3::new(1.5, 3.5, 0.5)),
            ] {
                let shift: DVec3 = p.shift(xi, xj);
                let back: DVec3 = Wrap::of(shift).shift(&period);
                assert_eq!(
                    back.to_array().map(f64::to_bits),
                    shift.to_array().map(f64::to_bits)
                );
            }
        }
        assert_eq!(Wrap::of(DVec2::ZERO).shift::<DVec2>(&[0.0; 3]), DVec2::ZERO);
    }

    fn unit_box() -> Periodic {
        let domain = Aabb::new(DVec2::new(-5.0, 0.0), DVec2::new(5.0, 4.0)).unwrap();
        Periodic::new(&domain, &[true, false]).unwrap()
    }

    #[test]
    fn no_periodic_axis_is_none() {
        let domain = Aabb::new(DVec3::ZERO, DVec3::ONE).unwrap();
        assert!(Periodic::new(&domain, &[false, false, false]).is_none());
        assert!(Periodic::new(&domain, &[]).is_none());
        let p = Periodic::new(&domain, &[false, false, true]).unwrap();
        assert_eq!(p.axes(), [false, false, true]);
        assert_eq!(p.length(2), 1.0);
        assert_eq!(p.length(0), 0.0);
    }

    #[test]
    fn wrap_brings_periodic_axes_into_the_half_open_box() {
        let p = unit_box();
        // inside: the very bits
        for x in [
            DVec2::new(-5.0, 1.0),
            DVec2::new(4.999, -3.0),
            DVec2::new(-0.0, 0.5),
        ] {
            assert_eq!(p.wrap(x).x.to_bits(), x.x.to_bits());
            assert_eq!(p.wrap(x).y.to_bits(), x.y.to_bits());
        }
        // the seam belongs to min; one period or many; the other axis is left alone
        assert_eq!(p.wrap(DVec2::new(5.0, 9.0)), DVec2::new(-5.0, 9.0));
        assert_eq!(p.wrap(DVec2::new(6.5, -1.0)), DVec2::new(-3.5, -1.0));
        assert_eq!(p.wrap(DVec2::new(-6.5, 0.0)), DVec2::new(3.5, 0.0));
        assert_eq!(p.wrap(DVec2::new(27.0, 0.0)), DVec2::new(-3.0, 0.0));
        assert_eq!(p.wrap(DVec2::new(-33.0, 0.0)), DVec2::new(-3.0, 0.0));
        // a hair below min: up by one period, and never onto max itself
        let hair = p.wrap(DVec2::new(-5.0 - 1e-17, 0.0)).x;
        assert!((-5.0..5.0).contains(&hair), "{hair}");
        let tiny = p.wrap(DVec2::new(-5.0 - f64::EPSILON * 8.0, 0.0)).x;
        assert!((-5.0..5.0).contains(&tiny), "{tiny}");
        // idempotent
        let once = p.wrap(DVec2::new(123.456, 0.0));
        assert_eq!(p.wrap(once), once);
    }

    #[test]
    fn minimum_image_across_the_seam() {
        let p = unit_box();
        let (a, b) = (DVec2::new(4.5, 1.0), DVec2::new(-4.7, 1.2));
        // b seen from a: one period up
        assert_eq!(p.shift(a, b), DVec2::new(10.0, 0.0));
        assert_eq!(p.image(a, b), DVec2::new(5.3, 1.2));
        // a seen from b: one period down
        assert_eq!(p.image(b, a), DVec2::new(-5.5, 1.0));
        // in the middle: no shift, the very bits
        let (c, d) = (DVec2::new(0.5, -0.0), DVec2::new(-0.5, -0.0));
        assert_eq!(p.shift(c, d), DVec2::ZERO);
        assert_eq!(p.image(c, d).y.to_bits(), (-0.0f64).to_bits());
        // a non-periodic axis is never shifted, however far apart
        assert_eq!(
            p.shift(DVec2::new(0.0, 100.0), DVec2::new(0.0, -100.0)),
            DVec2::ZERO
        );
        // exactly half a period: no shift
        assert_eq!(p.shift(DVec2::new(5.0, 0.0), DVec2::ZERO), DVec2::ZERO);
    }

    #[test]
    fn shortest_period_covers_two_reaches() {
        // a pair of radius-1 particles reaches at most 2 (2 + slop): twice that
        assert_eq!(shortest_period(1.0), 8.0 + 4.0 * SLOP_FRACTION);
    }
}
