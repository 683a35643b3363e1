//! The lecture's hash grid: the simulation space divided into cells, each cell a bucket of
//! particle ids, and each particle's candidates taken only from the cells around it.
//!
//! Hash function (the lecture's "Hash Indexing"): normalise the position to (0, 1) over the
//! domain, multiply by the cells per axis, clamp to the grid, round down. Particles outside the
//! domain land in the border cells, so nothing is ever lost.
//!
//! Buckets are stored as cell lists built by a counting sort (`cell_start` offsets into one
//! `ids` array) rather than a `Vec` per cell: the same buckets, without an allocation per cell.
//!
//! Neighbour reach: a particle at `x` with radius `r_i` can touch any particle within
//! `R = r_i + r_max`, so it searches the cells from `hash(x - R')` to `hash(x + R')` on each
//! axis, with `R'` a hair larger than `R` (a relative 1e-9 plus the rounding of `x +- R`).
//! Because the hash is monotone in `x`, this holds in floating point too, not just in real
//! arithmetic: a pair whose centres are a few ulps under `r_i + r_j` apart across a cell
//! boundary is never missed (searching `ceil(R / cell)` cells each way can miss it). With cells
//! one largest diameter wide this is the lecture's 3x3 (3x3x3) block; smaller cells or mixed
//! radii (its radius 1 and 3 demo) widen the search instead of missing contacts.

mod half;
mod packed;
mod periodic;
mod raised;
mod sizes;

use crate::broadphase::{
    collect_pairs, keep_tail, retain_pairs, search_raise_search, BroadPhase, CellScratch, Pair,
    PairFilter, Raising, PARALLEL_MIN, PARALLEL_SEARCH_MIN,
};
use crate::bucket::{counting_sort, counting_sort_parallel};
use crate::domain::Aabb;
use crate::error::EngineError;
use crate::hash::SpatialHash;
use crate::periodic::Periodic;
use crate::response::is_overlapping;
use crate::vector::Vector;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Hard cap on the total cell count (memory: 4 bytes per cell).
pub const MAX_CELLS: u64 = 1 << 28;

/// A uniform grid broad phase.
#[derive(Debug)]
pub struct Grid<V> {
    domain: Option<Aabb<V>>,
    requested_cells: Option<[usize; 3]>,
    layout: GridLayout,
    /// Whether a search has laid the cells out yet (before one there are none to report).
    laid_out: bool,
    cell_of: Vec<u32>,
    cell_start: Vec<u32>,
    ids: Vec<u32>,
    /// Scratch of the parallel counting sort.
    run_totals: Vec<u32>,
    buffers: Vec<Vec<Pair>>,
    /// The walk's copy of the positions and reaches in cell order (see [`packed`]).
    packed: packed::Packed,
    /// The pairs raised radii add (see [`raised`]).
    raised_extra: Vec<Pair>,
    overflow: SpatialHash,
    escaped: bool,
    /// Time spent binning since [`BroadPhase::take_bin_time`] last took it.
    bin_time: Duration,
    /// Periodic axes: neighbour cells wrap around them, pairs are tested at the minimum image.
    periodic: Option<Periodic>,
}

/// How many particles may sit outside the domain (or 1/64 of them, if more) before a step's
/// search goes to the unbounded hash instead of the clamped border cells.
const ESCAPEES_BEFORE_HASHING: usize = 64;

/// Where the grid lies this step: origin, cell size and cells per axis (unused axes have one
/// cell of size 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridLayout {
    /// Corner of cell (0, 0, 0).
    pub origin: [f64; 3],
    /// Cell edge length per axis.
    pub cell_size: [f64; 3],
    /// `1 / cell_size`: the hash multiplies (a division would cost as much as the rest).
    pub inverse_cell_size: [f64; 3],
    /// Cells per axis.
    pub cells: [usize; 3],
}

impl GridLayout {
    /// A layout over `bounds` with `cells` per axis, or (when `None`) cells about one largest
    /// diameter wide, coarsened until there are at most `max_cells`.
    pub fn fit<V: Vector>(
        bounds: &Aabb<V>,
        max_radius: f64,
        cells: Option<[usize; 3]>,
        max_cells: f64,
    ) -> Self {
        let diameter = 2.0 * max_radius;
        let mut extent = [1.0f64; 3];
        for (a, e) in extent.iter_mut().enumerate().take(V::DIM) {
            // A degenerate box (all particles in one plane) still needs a cell of some size.
            *e = (bounds.max.get(a) - bounds.min.get(a))
                .max(diameter)
                .max(f64::MIN_POSITIVE);
        }
        let cells = match cells {
            Some(c) => c,
            None => {
                let mut cells = [1usize; 3];
                for a in 0..V::DIM {
                    let fit = (extent[a] / diameter).floor();
                    cells[a] = if fit.is_finite() && fit >= 1.0 {
                        fit.min(1e9) as usize
                    } else {
                        1
                    };
                }
                let total: f64 = cells.iter().map(|&c| c as f64).product();
                if total > max_cells {
                    let shrink = (total / max_cells).powf(1.0 / V::DIM as f64);
                    for c in cells.iter_mut().take(V::DIM) {
                        *c = ((*c as f64 / shrink).floor() as usize).max(1);
                    }
                }
                cells
            }
        };
        let mut layout = GridLayout {
            origin: [0.0; 3],
            cell_size: [1.0; 3],
            inverse_cell_size: [1.0; 3],
            cells,
        };
        for a in 0..V::DIM {
            layout.origin[a] = bounds.min.get(a);
            layout.cell_size[a] = extent[a] / cells[a] as f64;
            layout.inverse_cell_size[a] = 1.0 / layout.cell_size[a];
        }
        layout
    }

    /// The lecture's hash function: normalise, scale, clamp, floor.
    #[inline]
    pub fn cell_coords<V: Vector>(&self, x: V) -> [usize; 3] {
        let mut c = [0usize; 3];
        for (a, slot) in c.iter_mut().enumerate().take(V::DIM) {
            *slot = self.axis_cell(a, x.get(a));
        }
        c
    }

    /// One axis of [`GridLayout::cell_coords`]. Monotone in `coordinate`: every step (a
    /// subtraction, a multiplication by a positive constant, floor, clamp) is.
    #[inline]
    pub fn axis_cell(&self, axis: usize, coordinate: f64) -> usize {
        let t = (coordinate - self.origin[axis]) * self.inverse_cell_size[axis];
        let last = (self.cells[axis] - 1) as f64;
        // Clamped as a float, then truncated (for t >= 0 truncation is floor): the cell that
        // truncating and then clamping the integer gives, for every input (`max` passes over
        // a NaN, which so goes to cell 0). No libm call in the hot loop.
        t.max(0.0).min(last) as usize
    }

    /// The cells on `axis` that can hold a particle within `reach` of `coordinate`, inclusive.
    #[inline]
    pub fn axis_range(&self, axis: usize, coordinate: f64, reach: f64) -> (usize, usize) {
        let widened = widened_reach(coordinate, reach);
        (
            self.axis_cell(axis, coordinate - widened),
            self.axis_cell(axis, coordinate + widened),
        )
    }

    /// Row-major linear index of cell coordinates.
    #[inline]
    pub fn linear(&self, c: [usize; 3]) -> usize {
        (c[2] * self.cells[1] + c[1]) * self.cells[0] + c[0]
    }

    /// Total number of cells.
    pub fn total(&self) -> usize {
        self.cells.iter().product()
    }
}

impl<V: Vector> Grid<V> {
    /// A grid over `domain` (or, when `None`, over the particles' bounding box each step)
    /// with `cells` per axis (or, when `None`, cells about one largest diameter wide).
    pub fn new(domain: Option<Aabb<V>>, cells: Option<&[usize]>) -> Result<Self, EngineError> {
        let requested_cells = match cells {
            None => None,
            Some(c) => {
                let total = c.iter().try_fold(1u64, |acc, &n| acc.checked_mul(n as u64));
                if c.len() != V::DIM || c.contains(&0) || total.is_none_or(|t| t > MAX_CELLS) {
                    return Err(EngineError::GridCells {
                        cells: c.iter().map(|&n| n as u64).collect(),
                        max: MAX_CELLS,
                    });
                }
                let mut r = [1; 3];
                r[..V::DIM].copy_from_slice(c);
                Some(r)
            }
        };
        Ok(Self {
            domain,
            requested_cells,
            laid_out: false,
            layout: GridLayout {
                origin: [0.0; 3],
                cell_size: [1.0; 3],
                inverse_cell_size: [1.0; 3],
                cells: [1; 3],
            },
            cell_of: Vec::new(),
            cell_start: Vec::new(),
            ids: Vec::new(),
            run_totals: Vec::new(),
            buffers: Vec::new(),
            packed: packed::Packed::default(),
            raised_extra: Vec::new(),
            overflow: SpatialHash::new(),
            escaped: false,
            bin_time: Duration::ZERO,
            periodic: None,
        })
    }

    /// Searches across `periodic`'s seams (see [`crate::periodic`]); needs a domain, the box
    /// that wraps. Any cell count works: a search that would wrap onto cells it already
    /// covers takes the whole row of cells instead, so no cell is visited twice.
    pub fn with_periodic(mut self, periodic: Option<Periodic>) -> Self {
        self.periodic = periodic;
        self
    }

    /// The layout used by the last [`BroadPhase::find_pairs`] call.
    pub fn layout(&self) -> GridLayout {
        self.layout
    }

    /// The particle ids in a cell (the lecture's bucket), as of the last search.
    pub fn bucket(&self, coords: [usize; 3]) -> &[u32] {
        let c = self.layout.linear(coords);
        &self.ids[self.cell_start[c] as usize..self.cell_start[c + 1] as usize]
    }

    fn plan_layout(&mut self, positions: &[V], max_radius: f64) {
        let bounds = match self.domain {
            Some(d) => d,
            None => bounding_box(positions),
        };
        let layout = GridLayout::fit(
            &bounds,
            max_radius,
            self.requested_cells,
            cell_limit(positions.len()),
        );
        self.layout = layout;
        self.laid_out = true;
    }

    /// True when more particles are outside the domain than the grid's border cells should
    /// hold (see [`ESCAPEES_BEFORE_HASHING`]).
    fn too_many_outside(&self, positions: &[V]) -> bool {
        let Some(domain) = self.domain else {
            return false;
        };
        let outside = if positions.len() >= PARALLEL_MIN {
            positions
                .par_iter()
                .filter(|&&x| !domain.contains(x))
                .count()
        } else {
            positions.iter().filter(|&&x| !domain.contains(x)).count()
        };
        outside > ESCAPEES_BEFORE_HASHING.max(positions.len() / 64)
    }

    /// Swaps the grid's bucket arrays with `scratch`'s (see [`BroadPhase::find_pairs_in`]): the
    /// grid's own stay empty, and the lent ones go back holding the search's buckets, which
    /// nothing reads after it.
    fn lend(&mut self, scratch: &mut CellScratch) {
        std::mem::swap(&mut self.cell_of, &mut scratch.keys);
        std::mem::swap(&mut self.cell_start, &mut scratch.starts);
        std::mem::swap(&mut self.ids, &mut scratch.order);
    }

    /// Lays the grid out over this step's particles (cells about one largest reach across)
    /// and bins them, for a search in its own cells (not the hash's: see
    /// [`Grid::too_many_outside`]); returns the largest of `radii`, which every search's reach
    /// adds.
    fn bin(&mut self, positions: &[V], radii: &[f64]) -> f64 {
        let binning = Instant::now();
        self.escaped = false;
        let max_radius = largest(radii);
        self.plan_layout(positions, max_radius);
        self.build_buckets(positions);
        self.bin_time += binning.elapsed();
        max_radius
    }

    /// Bins every particle: the counting sort that fills the buckets.
    fn build_buckets(&mut self, positions: &[V]) {
        let layout = self.layout;
        let n = positions.len();
        self.cell_of.resize(n, 0);
        let bin = |(cell, &x): (&mut u32, &V)| *cell = layout.linear(layout.cell_coords(x)) as u32;
        if n >= PARALLEL_MIN {
            self.cell_of
                .par_iter_mut()
                .zip(positions.par_iter())
                .for_each(bin);
            // (serial, this sort took 6.5-8 ms of a step of the bench's 10^6 gas)
            counting_sort_parallel(
                &self.cell_of,
                layout.total(),
                rayon::current_num_threads(),
                &mut self.cell_start,
                &mut self.ids,
                &mut self.run_totals,
            );
        } else {
            self.cell_of.iter_mut().zip(positions.iter()).for_each(bin);
            counting_sort(
                &self.cell_of,
                layout.total(),
                0..n as u32,
                &mut self.cell_start,
                &mut self.ids,
            );
        }
    }
}

/// Calls `hit(j)` for every particle `j` in the cells within `reach` of `x` (see
/// [`GridLayout::axis_range`]) that `test(j)` holds for, from the buckets `cell_start` and
/// `ids`, row by row (see [`scan_run`]).
#[inline(always)]
pub(crate) fn for_each_near<V: Vector>(
    layout: &GridLayout,
    cell_start: &[u32],
    ids: &[u32],
    x: V,
    reach: f64,
    test: impl Fn(usize) -> bool,
    mut hit: impl FnMut(usize),
) {
    let mut lo = [0usize; 3];
    let mut hi = [0usize; 3];
    for a in 0..V::DIM {
        (lo[a], hi[a]) = layout.axis_range(a, x.get(a), reach);
    }
    for z in lo[2]..=hi[2] {
        for y in lo[1]..=hi[1] {
            let row = (z * layout.cells[1] + y) * layout.cells[0];
            // Cells lo..=hi of one row are contiguous in `ids`.
            let start = cell_start[row + lo[0]] as usize;
            let end = cell_start[row + hi[0] + 1] as usize;
            scan_run(ids, start, end, &test, &mut hit);
        }
    }
}

/// Candidates [`scan_run`] tests at a time.
const LANES: usize = 4;

/// Calls `hit(j)`, in order, for each particle `j` of `ids[start..end]` that `test(j)` holds
/// for. The run is tested [`LANES`] particles at a time, every lane whether or not it lies in
/// the run (a lane past the end tests some valid particle, and its result is dropped), with no
/// branch on any one result: a row of cells holds two or three particles and a test holds for
/// about one in ten, both unpredictably. (The bench's 10^6-disc gas, searched by particle: the
/// broad phase took 39 ms a step against 40 with a test and a branchless push per particle;
/// most of what is left is the tests' loads, not their branches.)
#[inline(always)]
pub(crate) fn scan_run(
    ids: &[u32],
    start: usize,
    end: usize,
    test: &impl Fn(usize) -> bool,
    hit: &mut impl FnMut(usize),
) {
    let last = ids.len().saturating_sub(1);
    let mut k = start;
    while k < end {
        let mut found = 0u32;
        for lane in 0..LANES {
            let j = ids[(k + lane).min(last)] as usize;
            found |= (((k + lane < end) & test(j)) as u32) << lane;
        }
        while found != 0 {
            hit(ids[k + found.trailing_zeros() as usize] as usize);
            found &= found - 1;
        }
        k += LANES;
    }
}

/// `reach` widened by a relative 1e-9 (far above the rounding of the distance test) and by the
/// rounding of `coordinate +- reach` itself. Searching the cells of `coordinate +- widened`
/// with any monotone cell function then never misses a particle within `reach`; the grid, the
/// hash and the scene loader's placement check all use it.
#[inline]
pub fn widened_reach(coordinate: f64, reach: f64) -> f64 {
    reach * (1.0 + 1e-9) + 4.0 * f64::EPSILON * (coordinate.abs() + reach)
}

/// Most cells a derived layout may have for `n` particles (at least 64): one a particle. Cells
/// one largest reach wide would be 1.4-2.6 a particle in issue 14's gas (area fraction 0.3: 2.6
/// over the radii alone) and more in a dilute one; the walk along the cell order through the
/// packed copy pays nothing for a cell's being empty or holding a few (its runs are tested 8 at
/// a time; the walk cell by cell, at periodic seams or past sleepers, still visits each cell),
/// but the counting sort passes over every cell and their starts take 4 bytes each. Against 4
/// a particle (docs/benchmarks.md, thirty-seventh sitting): that gas's peak 119.0 -> 116.1
/// bytes a particle at the same speed (1000 x 1000 cells instead of up to 1311 x 1311), a
/// dilute gas (10^5 discs, area fraction 0.05) 0.84-0.99x the time; the 3D case, the falling
/// and dense 10^6 discs and the lecture pile as before; the same bits.
pub fn cell_limit(n: usize) -> f64 {
    (n.max(64) as f64).min(MAX_CELLS as f64)
}

/// The largest of `values` (0 when there are none or all are below it; NaN is passed over),
/// on the thread pool for many: a maximum is the same in any order.
pub(crate) fn largest(values: &[f64]) -> f64 {
    if values.len() >= PARALLEL_MIN {
        values.par_iter().copied().reduce(|| 0.0, f64::max)
    } else {
        values.iter().copied().fold(0.0, f64::max)
    }
}

/// The smallest box holding every position (a zero box when there are none).
pub fn bounding_box<V: Vector>(positions: &[V]) -> Aabb<V> {
    let (min, max) = positions
        .par_iter()
        .fold(
            || {
                (
                    V::from_slice(&[f64::INFINITY; 3]),
                    V::from_slice(&[f64::NEG_INFINITY; 3]),
                )
            },
            |(lo, hi), &x| (lo.min_components(x), hi.max_components(x)),
        )
        .reduce(
            || {
                (
                    V::from_slice(&[f64::INFINITY; 3]),
                    V::from_slice(&[f64::NEG_INFINITY; 3]),
                )
            },
            |(a, b), (c, d)| (a.min_components(c), b.max_components(d)),
        );
    if positions.is_empty() {
        Aabb {
            min: V::ZERO,
            max: V::ZERO,
        }
    } else {
        Aabb { min, max }
    }
}

impl<V: Vector> Grid<V> {
    /// The search of [`BroadPhase::find_pairs`] in the domain's cells, keeping only the pairs
    /// `keep` holds for, if any: from one side when the cells hold every pair to neighbouring
    /// cells (see [`half`]), else particle by particle. Either way each pair is tested against
    /// `keep` as soon as it is found, while it is in cache, and never takes room in `pairs` or
    /// the buffers unless kept.
    fn search(
        &mut self,
        positions: &[V],
        radii: &[f64],
        keep: Option<&PairFilter<'_>>,
        pairs: &mut Vec<Pair>,
    ) {
        let max_radius = self.bin(positions, radii);
        let layout = self.layout;
        if self.searches_from_one_side(max_radius) {
            return self.search_from_one_side(positions, radii, max_radius, keep, pairs);
        }
        if let Some(small) = self.small_radius(radii) {
            return self.search_by_sizes(positions, radii, [small, max_radius], keep, pairs);
        }
        let (cell_start, ids) = (&self.cell_start, &self.ids);
        collect_pairs(positions.len(), &mut self.buffers, pairs, |i, out| {
            let (pi, ri, first) = (positions[i], radii[i], out.len());
            let test = |j: usize| (j > i) & is_overlapping(pi, positions[j], ri, radii[j]);
            let hit = |j: usize| out.push((i as u32, j as u32));
            for_each_near(&layout, cell_start, ids, pi, ri + max_radius, test, hit);
            if let Some(keep) = keep {
                keep_tail(out, first, keep);
            }
        });
    }
}

impl<V: Vector> BroadPhase<V> for Grid<V> {
    fn find_pairs(&mut self, positions: &[V], radii: &[f64], pairs: &mut Vec<Pair>) {
        if let Some(periodic) = self.periodic {
            return self.find_periodic_pairs(&periodic, positions, radii, None, pairs);
        }
        // Particles that left the domain all land in its border cells; if many did, those
        // cells would turn the search quadratic. The unbounded hash finds exactly the same
        // pairs, so use it for such steps instead.
        if self.too_many_outside(positions) {
            self.escaped = true;
            return self.overflow.find_pairs(positions, radii, pairs);
        }
        self.search(positions, radii, None, pairs);
    }

    fn find_pairs_kept_in(
        &mut self,
        positions: &[V],
        radii: &[f64],
        keep: &PairFilter<'_>,
        pairs: &mut Vec<Pair>,
        scratch: &mut CellScratch,
        kept: &mut Vec<usize>,
    ) {
        // (the hash, for many particles outside the domain as in `find_pairs`, searches and
        // then keeps)
        if self.periodic.is_none() && self.too_many_outside(positions) {
            self.escaped = true;
            self.overflow.find_pairs(positions, radii, pairs);
            return retain_pairs(pairs, kept, positions.len() >= PARALLEL_SEARCH_MIN, keep);
        }
        self.lend(scratch);
        match self.periodic {
            Some(periodic) => {
                self.find_periodic_pairs(&periodic, positions, radii, Some(keep), pairs)
            }
            None => self.search(positions, radii, Some(keep), pairs),
        }
        self.lend(scratch);
    }

    fn find_pairs_in(
        &mut self,
        positions: &[V],
        radii: &[f64],
        pairs: &mut Vec<Pair>,
        scratch: &mut CellScratch,
    ) {
        self.lend(scratch);
        self.find_pairs(positions, radii, pairs);
        self.lend(scratch);
    }

    fn find_pairs_raised_in(
        &mut self,
        positions: &[V],
        radii: &[f64],
        raising: &Raising<'_>,
        raised: &mut Vec<f64>,
        pairs: &mut Vec<Pair>,
        scratch: &mut CellScratch,
    ) {
        // (a periodic grid searches, raises and searches again; so does the hash for a grid
        // with many particles outside its domain, as in `find_pairs`)
        if self.periodic.is_some() {
            return search_raise_search(self, positions, radii, raising, raised, pairs, scratch);
        }
        self.escaped = self.too_many_outside(positions);
        if self.escaped {
            let hash = &mut self.overflow;
            return search_raise_search(hash, positions, radii, raising, raised, pairs, scratch);
        }
        self.lend(scratch);
        self.find_raised_pairs(positions, radii, raising, raised, pairs);
        self.lend(scratch);
    }

    fn take_bin_time(&mut self) -> Duration {
        std::mem::take(&mut self.bin_time) + BroadPhase::<V>::take_bin_time(&mut self.overflow)
    }

    fn name(&self) -> &'static str {
        if self.escaped {
            "grid (hash while particles are outside the domain)"
        } else {
            "grid"
        }
    }

    fn cells(&self) -> Option<[usize; 3]> {
        self.laid_out.then_some(self.layout.cells)
    }
}

#[cfg(test)]
pub(super) mod tests;
