//! The walk's copy of the positions and reaches in cell order, in 16-bit fixed point and 8
//! bits: a prefilter that never turns a pair away that the exact test takes, and that the
//! exact `f64` test then checks (so the pairs found are the same, bit for bit).
//!
//! Why: the walk from one side (see [`super::half`]) tested each particle against the runs of
//! the cells after it through the bucket's ids, `positions[ids[k]]`: a load that waits on a
//! load, then a branch on each test. In cell order and packed, [`LANES`] candidates are one
//! load of coordinates and one of reaches, tested side by side (about one in ten passes); only
//! those that pass are loaded through the ids and tested in `f64`.
//!
//! Small: a coordinate is its place on the grid's extent in units of `s = extent / 65535`
//! (clamped to it, as the cells clamp), `x` and `y` in one `u32`, which lives in the grid's
//! cells-by-particle array (not read after the counting sort, so no memory is added for it);
//! `z` takes 2 bytes more and a reach 1 (in steps of `r_max / 250`, rounded up).
//!
//! Conservative: clamping never lengthens a distance, and rounding down to a unit moves each
//! coordinate by less than `s`, so two particles' distance in units is at most their distance
//! plus `sqrt(D) s`; a reach rounded up is no shorter. Every sum of two reaches is widened by
//! a margin `m = 1.01 sqrt(D) s + 32 u (4 r_max + sqrt(D) s)` (`u = 2^-24`: the `f32`
//! arithmetic's rounding, a few `u` of the lengths, taken eight times over), so
//! `|x_i - x_j| < r_i + r_j` in `f64` implies the test here holds. Not taken (the walk then
//! tests every candidate in `f64`, as before) when a radius is negative or the extent or a
//! radius is not finite.

use super::GridLayout;
use crate::vector::Vector;
use bytemuck::{cast_slice, pod_read_unaligned};
use rayon::prelude::*;
use wide::{f32x8, i32x8, u16x8, u8x16, CmpLt};

/// Candidates tested at a time: one 256-bit vector of `f32`. (The reaches' padding is twice
/// this: their bytes are read sixteen at a time.)
pub(super) const LANES: usize = 8;

/// Particles per parallel task of the copy.
const CHUNK: usize = 8192;

/// The largest coordinate in units (16 bits).
const UNITS: f64 = 65535.0;

/// The largest reach in steps (8 bits, with room for the rounding up).
const REACH_STEPS: f64 = 250.0;

/// The copy's reaches and `z`, place `k` holding particle `ids[k]` (the coordinates `x` and
/// `y` are in the array [`Packed::fill`] is lent), with [`LANES`] places of padding after the
/// last.
#[derive(Debug, Default)]
pub(super) struct Packed {
    /// `z` in units (empty in 2D).
    z: Vec<u16>,
    /// Each reach in steps, rounded up.
    reach: Vec<u8>,
    /// The length of a unit on each axis.
    unit: [f32; 3],
    /// The length of a reach step.
    step: f32,
    /// The margin every sum of two reaches is widened by (see the [module notes](self)).
    margin: f32,
    /// The margin and the largest reach, plus two units of `x` (see [`Packed::cells_around`]).
    widest: f32,
    /// Units of `x` per length.
    units_per_length: f32,
    /// Cells of the grid's rows per unit of `x`.
    cells_per_unit: f32,
}

/// One particle of the copy, as the scan tests it against the others.
#[derive(Clone, Copy)]
pub(super) struct Probe {
    /// Its coordinates in units.
    at: [f32; 3],
    /// Its reach, plus the margin.
    reach: f32,
}

/// The length `layout` spans on axis `a`.
fn extent_of(layout: &GridLayout, a: usize) -> f64 {
    layout.cell_size[a] * layout.cells[a] as f64
}

/// The copy of the coordinates `x` and `y` in units, one `u32` a place (`y` in the high
/// half), lent to [`Packed::fill`] and [`Packed::scan`].
pub(super) type PlanarUnits = Vec<u32>;

impl Packed {
    /// Copies `positions` and `radii` (at most `max_radius`) in the order of `ids`, on
    /// `layout`'s extent, `x` and `y` into `planar` (in parallel when `parallel`); returns
    /// false, and leaves the copy unusable, when it cannot be taken (see the
    /// [module notes](self)).
    pub(super) fn fill<V: Vector>(
        &mut self,
        (positions, radii, max_radius): (&[V], &[f64], f64),
        ids: &[u32],
        layout: &GridLayout,
        planar: &mut PlanarUnits,
        parallel: bool,
    ) -> bool {
        let extent = |a: usize| extent_of(layout, a);
        let largest_unit = (0..V::DIM).map(|a| extent(a) / UNITS).fold(0.0, f64::max);
        if !(largest_unit.is_finite() && largest_unit > 0.0 && max_radius.is_finite()) {
            return false;
        }
        let n = ids.len();
        planar.resize(n + LANES, 0);
        self.z.resize(if V::DIM == 3 { n + LANES } else { 0 }, 0);
        self.reach.resize(n + 2 * LANES, 0);
        let per_unit: [f64; 3] = std::array::from_fn(|a| UNITS / extent(a).max(f64::MIN_POSITIVE));
        let step = max_radius / REACH_STEPS;
        // (a product rounds a little under the quotient at most: the margin holds that; no
        // steps at all when every radius is zero)
        let per_step = if step > 0.0 { 1.0 / step } else { 0.0 };
        let units = |x: V, a: usize| {
            let t = (x.get(a) - layout.origin[a]) * per_unit[a];
            t.clamp(0.0, UNITS) as u16
        };
        // (each chunk returns its smallest and largest radius)
        let copy = |first: usize, (planar, z, reach): (&mut [u32], &mut [u16], &mut [u8])| {
            let (mut smallest, mut largest) = (f64::INFINITY, 0.0f64);
            for (k, out) in planar.iter_mut().enumerate() {
                let i = ids[first + k] as usize;
                let (x, r) = (positions[i], radii[i]);
                *out = u32::from(units(x, 0)) | u32::from(units(x, 1)) << 16;
                if V::DIM == 3 {
                    z[k] = units(x, 2);
                }
                (smallest, largest) = (smallest.min(r), largest.max(r));
                reach[k] = (r * per_step).ceil() as u8;
            }
            (smallest, largest)
        };
        let extremes = |a: (f64, f64), b: (f64, f64)| (a.0.min(b.0), a.1.max(b.1));
        let none = || (f64::INFINITY, 0.0);
        let (planar, z, reach) = (&mut planar[..n], &mut self.z[..], &mut self.reach[..n]);
        let (smallest, largest) = match (V::DIM, parallel) {
            (3, true) => {
                let chunks = planar
                    .par_chunks_mut(CHUNK)
                    .zip(z[..n].par_chunks_mut(CHUNK));
                let chunks = chunks.zip(reach.par_chunks_mut(CHUNK)).enumerate();
                chunks
                    .map(|(c, ((p, z), r))| copy(c * CHUNK, (p, z, r)))
                    .reduce(none, extremes)
            }
            (_, true) => {
                let chunks = planar
                    .par_chunks_mut(CHUNK)
                    .zip(reach.par_chunks_mut(CHUNK));
                chunks
                    .enumerate()
                    .map(|(c, (p, r))| copy(c * CHUNK, (p, &mut [], r)))
                    .reduce(none, extremes)
            }
            (3, false) => copy(0, (planar, &mut z[..n], reach)),
            (_, false) => copy(0, (planar, &mut [], reach)),
        };
        self.take_scales::<V>(
            layout,
            (step, largest_unit),
            (smallest, largest, max_radius),
        )
    }

    /// Sets the copy's units, reach `step`, margin and widest reach (see the
    /// [module notes](self)) for `layout`'s extent, whose largest unit is `largest_unit`, and
    /// radii at most `max_radius`, of which the copy holds radii from `smallest` to `largest`;
    /// returns whether the copy holds them (no negative radius, and none more steps than a
    /// byte holds).
    fn take_scales<V: Vector>(
        &mut self,
        layout: &GridLayout,
        (step, largest_unit): (f64, f64),
        (smallest, largest, max_radius): (f64, f64, f64),
    ) -> bool {
        let extent = |a: usize| extent_of(layout, a);
        let root_dim = (V::DIM as f64).sqrt();
        let u = f64::from(f32::EPSILON) / 2.0;
        self.unit = std::array::from_fn(|a| (extent(a) / UNITS) as f32);
        self.step = step as f32;
        self.units_per_length = (UNITS / extent(0)) as f32;
        self.cells_per_unit = (extent(0) / UNITS / layout.cell_size[0]) as f32;
        // (from the largest radius there is, which may be over `max_radius`: the search by
        // sizes walks the small, and a large one a little over them still fits a byte)
        let widest = largest.max(max_radius);
        self.margin = (1.01 * root_dim * largest_unit
            + 32.0 * u * (4.0 * widest + root_dim * largest_unit)) as f32;
        self.widest = self.margin + (widest + 2.0 * extent(0) / UNITS) as f32;
        // (a negative radius would make `r_i + r_j` smaller in magnitude with the margin; a
        // radius over `max_radius` would take more steps than a byte holds)
        let fits = if step > 0.0 {
            largest / step <= 255.0
        } else {
            largest <= 0.0
        };
        smallest >= 0.0 && fits
    }

    /// `x` and `y` in units at places `k..k + LANES`.
    #[inline(always)]
    fn planar_units(planar: &[u32], k: usize) -> (f32x8, f32x8) {
        let words: i32x8 = pod_read_unaligned(cast_slice(&planar[k..k + LANES]));
        let half = i32x8::splat(0xffff);
        let x = f32x8::from_i32x8(words & half);
        (x, f32x8::from_i32x8((words >> 16) & half))
    }

    /// The reaches in steps at places `k..k + LANES`.
    #[inline(always)]
    fn steps(&self, k: usize) -> f32x8 {
        let bytes: u8x16 = pod_read_unaligned(&self.reach[k..k + 2 * LANES]);
        f32x8::from_i32x8(i32x8::from_u16x8(u16x8::from_u8x16_low(bytes)))
    }

    /// `z` in units at places `k..k + LANES`.
    #[inline(always)]
    fn z_units(&self, k: usize) -> f32x8 {
        let z: u16x8 = pod_read_unaligned(cast_slice(&self.z[k..k + LANES]));
        f32x8::from_i32x8(i32x8::from_u16x8(z))
    }

    /// Place `k` of the copy, to test against others.
    #[inline(always)]
    pub(super) fn probe<V: Vector>(&self, planar: &[u32], k: usize) -> Probe {
        let xy = planar[k];
        let z = if V::DIM == 3 { self.z[k] } else { 0 };
        Probe {
            at: [(xy & 0xffff) as f32, (xy >> 16) as f32, f32::from(z)],
            reach: f32::from(self.reach[k]) * self.step + self.margin,
        }
    }

    /// For each of the particles at places `k..k + LANES`, the first and the last cell along
    /// its row (of `last + 1` cells) that can hold a particle within reach of it: those within
    /// its reach and the largest, taken from its coordinate in units. Never fewer than its
    /// partners' cells, in whichever cells the grid put them, however the units round: the
    /// reaches are rounded up and two units wider, and cells and units both clamp at the
    /// extent's ends. (Eight at a time: one at a time, each particle's scans waited on the
    /// chain of arithmetic that places them.)
    #[inline(always)]
    pub(super) fn cells_around(
        &self,
        planar: &[u32],
        k: usize,
        last: usize,
    ) -> ([i32; LANES], [i32; LANES]) {
        let (x, _) = Self::planar_units(planar, k);
        let reach = self
            .steps(k)
            .mul_add(f32x8::splat(self.step), f32x8::splat(self.widest));
        let span = reach * self.units_per_length;
        let (none, last) = (f32x8::splat(0.0), f32x8::splat(last as f32));
        let cell = |units: f32x8| {
            let cells = (units * self.cells_per_unit).max(none).min(last);
            cells.fast_trunc_int().to_array()
        };
        (cell(x - span), cell(x + span))
    }

    /// Calls `candidate(k)`, in order, for each place `k` in `first..last` whose particle may
    /// lie within reach of `probe`'s (every one the exact test takes, and a few more).
    ///
    /// The first [`LANES`] places are tested whatever the run's length, the lanes past its end
    /// dropped: a run is most often a few particles, and a loop on its length turned on a
    /// branch that went either way.
    #[inline(always)]
    pub(super) fn scan<V: Vector>(
        &self,
        planar: &[u32],
        probe: Probe,
        (first, last): (usize, usize),
        candidate: &mut impl FnMut(usize),
    ) {
        // (the first group whatever the length: a loop that tests before it runs)
        let mut k = first;
        loop {
            let left = last.saturating_sub(k).min(LANES);
            let mut found = self.lanes::<V>(planar, probe, k) & ((1u32 << left) - 1);
            while found != 0 {
                candidate(k + found.trailing_zeros() as usize);
                found &= found - 1;
            }
            k += LANES;
            if k >= last {
                return;
            }
        }
    }

    /// The prefilter at places `k..k + LANES`, one bit per place (lowest first).
    #[inline(always)]
    fn lanes<V: Vector>(&self, planar: &[u32], probe: Probe, k: usize) -> u32 {
        let (x, y) = Self::planar_units(planar, k);
        let along = |a: usize, units: f32x8| (f32x8::splat(probe.at[a]) - units) * self.unit[a];
        let (dx, dy) = (along(0, x), along(1, y));
        let mut d2 = dx * dx + dy * dy;
        if V::DIM == 3 {
            let dz = along(2, self.z_units(k));
            d2 += dz * dz;
        }
        let limit = self
            .steps(k)
            .mul_add(f32x8::splat(self.step), f32x8::splat(probe.reach));
        d2.cmp_lt(limit * limit).move_mask() as u32
    }
}

#[cfg(test)]
mod tests;
