//! The grid's search by cells, each pair found once: from the cell that comes first.
//!
//! When every cell is at least as wide as the largest `r_i + r_j`, a pair's cells are
//! neighbours or the same on every axis, so each cell need only look at the cells after it:
//! the rest of its own run (the cell itself past each particle, and the next cell of its row),
//! then the three cells around it in the next row (2D), or also the nine of the next layer
//! (3D). That is half of the 3x3 (3x3x3) block, and every pair is tested once instead of twice
//! (once from each side, the higher one dropping it). The cells are walked in their own order,
//! which is about the storage order (see `World`'s spatial sort), so the positions are read
//! nearly in sequence.
//!
//! When a scene asks for cells narrower than that (the lecture's 100x100 grid over discs of
//! radius 1: cells 2 wide, reaches up to 1.3), a pair lies up to `a` cells apart on an axis
//! ([`GridLayout::cells_apart`]), and the same walk takes the `a` cells after it in its row,
//! then `a` rows (and in 3D `a` layers) of `2 a + 1` cells, up to [`MOST_CELLS_APART`] (the
//! search particle by particle, which tests each pair from both sides, takes wider reaches
//! and periodic grids). The lecture's 5000 discs in the 100x100 grid, `carom run` of 1500
//! steps: 0.88x the time of the search by particle (`farm-bench -n 10 --vs`, same bits).
//!
//! A few large particles among many small ones would make every pair up to 4 cells apart:
//! then the small ones' pairs are walked this way and the large ones search particle by
//! particle (see [`super::sizes`]).
//!
//! Across periodic seams the cells after a cell wrap round (each periodic axis needs three
//! cells or more), and a pair is tested at the minimum image its lower particle sees, as every
//! other search tests it. The resting step's first search, whose radii are then raised to the
//! partners' speeds, is this search too (see [`super::raised`]).
//!
//! Without particles passed over, the walk goes particle by particle along the cell order
//! (away from periodic seams) instead of cell by cell (no branch on each cell's count, which
//! went either way), and tests candidates eight at a time through a packed copy of the
//! positions and reaches, then in `f64` only those that pass (see [`super::packed`]; the same
//! pairs). The bench's 10^6-disc gas, 2 threads: the search 26.4 -> 22.6 ms a step.
//!
//! The pairs come out grouped by cell, not by particle, so they are sorted at the end: the set
//! is exact and its order canonical (see [`crate::broadphase`]), so the solver sees the same
//! contacts as from the search by particle, and every run the same bits. (The bench's 10^6-disc
//! gas, 2 threads: the broad phase took 41 ms a step with the search by particle, 30 with this
//! one, the sort of its pairs included.)

use super::packed::{Packed, LANES};
use super::{scan_run, Grid, GridLayout};
use crate::broadphase::{gather, keep_headroom, Pair, PairFilter, PARALLEL_SEARCH_MIN};
use crate::bucket::sort_pairs_by_counting;
use crate::response::is_overlapping;
use crate::vector::Vector;
use rayon::prelude::*;

/// Cells a parallel task of the search walks (whole rows of them: at least one), unless that
/// leaves fewer than [`FEWEST_TASKS`] tasks.
const CELLS_PER_TASK: usize = 8192;

/// Tasks the search is split into at least, rows allowing: the lecture's 50x50 grid is one
/// task of 8192 cells, and the walk of its 5000 discs then ran on one thread (the demo took
/// 1.11x as long as with the search by particle, in chunks of particles).
const FEWEST_TASKS: usize = 16;

/// How much wider than the largest `r_i + r_j` a cell must be for the search from one side:
/// the cells' bounds are rounded (a relative error of a few ulps of the cell count, at most
/// 2^28 cells a side), and this leaves a pair never more than one cell apart on any axis.
pub(super) const WIDTH_MARGIN: f64 = 1e-6;

impl GridLayout {
    /// True when no two particles of radius at most `max_radius` can touch from cells more
    /// than one apart on any axis (see [`WIDTH_MARGIN`]).
    #[cfg(test)]
    pub(super) fn holds_pairs_to_neighbours<V: Vector>(&self, max_radius: f64) -> bool {
        self.cells_apart::<V>(max_radius) == 1
    }

    /// How many cells apart, on any axis, two particles of radius at most `max_radius` can
    /// touch from (see [`WIDTH_MARGIN`]): 1 when the cells are at least as wide as the largest
    /// `r_i + r_j`, more when a scene asks for finer cells (the lecture's 100x100 grid over
    /// 5000 discs of radius 1, whose reaches are wider than its cells of 2).
    pub(super) fn cells_apart<V: Vector>(&self, max_radius: f64) -> usize {
        let widest = 2.0 * max_radius * (1.0 + WIDTH_MARGIN);
        // (a radius that is not a number holds to no cell count: searched particle by
        // particle, as before the count was taken)
        let apart = |a: usize| match (widest / self.cell_size[a]).ceil() {
            n if n.is_nan() => f64::INFINITY,
            n => n.max(1.0),
        };
        (0..V::DIM)
            .map(apart)
            .fold(1.0, f64::max)
            .min(usize::MAX as f64) as usize
    }
}

impl<V: Vector> Grid<V> {
    /// True when the search from one side can take this layout for particles of radius at
    /// most `max_radius`: the cells hold pairs to neighbours (see [`GridLayout::cells_apart`]),
    /// and a periodic axis has at least three (with fewer, a cell's neighbours on both sides
    /// would be one cell, visited twice); or, without periodic axes, pairs lie at most
    /// [`MOST_CELLS_APART`] cells apart.
    pub(super) fn searches_from_one_side(&self, max_radius: f64) -> bool {
        let wraps = |a: usize| self.periodic.is_some_and(|p| p.is_periodic(a));
        match self.layout.cells_apart::<V>(max_radius) {
            1 => (0..V::DIM).all(|a| !wraps(a) || self.layout.cells[a] >= 3),
            apart => apart <= MOST_CELLS_APART && !(0..V::DIM).any(wraps),
        }
    }

    /// [`BroadPhase::find_pairs`](crate::broadphase::BroadPhase::find_pairs) by cells, each
    /// pair tested from one side (see the [module notes](self)), across the periodic seams if
    /// any, keeping only the pairs `keep` holds for, if any. The buckets must be built, with a
    /// layout the search [can take](Grid::searches_from_one_side).
    pub(super) fn search_from_one_side(
        &mut self,
        positions: &[V],
        radii: &[f64],
        max_radius: f64,
        keep: Option<&PairFilter<'_>>,
        pairs: &mut Vec<Pair>,
    ) {
        let overlaps =
            |i: usize, j: usize| is_overlapping(positions[i], positions[j], radii[i], radii[j]);
        // (at the minimum image as the lower particle sees it, as every other search tests a
        // pair: the image is rounded differently from the other side; away from the seams
        // that image is the partner itself, and the test `overlaps`, bit for bit)
        let at_image;
        let across = match self.periodic {
            Some(periodic) => {
                at_image = move |i: usize, j: usize| {
                    let (low, high) = (i.min(j), i.max(j));
                    let image = periodic.image(positions[low], positions[high]);
                    is_overlapping(positions[low], image, radii[low], radii[high])
                };
                Some(&at_image as SeamTest<'_>)
            }
            None => None,
        };
        let particles = (positions, radii);
        self.walk_cells(particles, max_radius, keep, &[], pairs, overlaps, across);
    }

    /// The walk of [`Grid::search_from_one_side`] over partners of radius (`radii`) at most
    /// `max_radius` (so up to [`GridLayout::cells_apart`] cells apart), with `overlaps(i, j)`
    /// the pair test, which must imply that the two lie within `r_i + r_j` (the packed copy's
    /// prefilter turns away only pairs that do not, see [`super::packed`]). A cell whose
    /// particles and those of the cells after it are all `still` (per particle; empty when
    /// none is) is passed over: `keep` must then drop every pair of two still particles,
    /// which the caller takes from elsewhere (see [`crate::broadphase::Still`]).
    ///
    /// On a periodic grid, `across(i, j)` is the test at the minimum image, taken from the
    /// cells near a seam (see [`Forward::at_seam`]); elsewhere a pair's image is the partner
    /// itself, and the walk takes `overlaps` (a call to `across` costs a call: it is too large
    /// to inline into the scan's four lanes; 10^6 spheres periodic on every axis spent 40 % of
    /// the run in it).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn walk_cells(
        &mut self,
        (positions, radii): (&[V], &[f64]),
        max_radius: f64,
        keep: Option<&PairFilter<'_>>,
        still: &[bool],
        pairs: &mut Vec<Pair>,
        overlaps: impl Fn(usize, usize) -> bool + Sync,
        across: Option<SeamTest<'_>>,
    ) {
        let layout = self.layout;
        let apart = layout.cells_apart::<V>(max_radius);
        let [width, height, depth] = layout.cells;
        let rows = height * depth;
        let rows_per_task = (CELLS_PER_TASK / width).clamp(1, rows.div_ceil(FEWEST_TASKS).max(1));
        let tasks = rows.div_ceil(rows_per_task);
        if self.buffers.len() < tasks {
            self.buffers.resize_with(tasks, Vec::new);
        }
        let after = Forward {
            apart,
            cells: layout.cells,
            wraps: [0, 1, 2].map(|a| self.periodic.is_some_and(|p| p.is_periodic(a))),
            cell_start: &self.cell_start,
        };
        let parallel = positions.len() >= PARALLEL_SEARCH_MIN;
        // Particle by particle along the cell order, through the packed copy, without a branch
        // on each cell's count; unless some cells are passed over (and cell by cell at the
        // periodic seams). (The cells of each particle are not read after the counting sort:
        // their array holds the copy.)
        let mut planar = std::mem::take(&mut self.cell_of);
        let streamed = still.is_empty()
            && (self.packed).fill(
                (positions, radii, max_radius),
                &self.ids,
                &layout,
                &mut planar,
                parallel,
            );
        let streamed = streamed.then_some((&self.packed, &planar[..]));
        let ids = &self.ids;
        let tests = (keep, &overlaps, across);
        let work = |(task, out): (usize, &mut Vec<Pair>)| {
            out.clear();
            for r in task * rows_per_task..((task + 1) * rows_per_task).min(rows) {
                walk_row::<V>(r, &after, streamed, (ids, still), tests, out);
            }
            keep_headroom(out);
        };
        let buffers = &mut self.buffers[..tasks];
        if parallel {
            buffers.par_iter_mut().enumerate().for_each(work);
        } else {
            buffers.iter_mut().enumerate().for_each(work);
        }
        self.cell_of = planar;
        self.sort_walked_pairs(tasks, positions.len(), parallel, pairs);
    }

    /// Makes `pairs` the pairs the walk left in the first `tasks` buffers, sorted (by
    /// counting when there are many: see [`COUNTING_ABOVE`]), for `n` particles.
    fn sort_walked_pairs(&mut self, tasks: usize, n: usize, parallel: bool, pairs: &mut Vec<Pair>) {
        let buffers = &mut self.buffers[..tasks];
        if buffers.iter().map(Vec::len).sum::<usize>() > n / COUNTING_ABOVE {
            let parts = if parallel {
                rayon::current_num_threads()
            } else {
                1
            };
            // (the bins' cells are not read after the walk: their memory is the sort's starts)
            let (starts, totals) = (&mut self.cell_of, &mut self.run_totals);
            sort_pairs_by_counting(buffers, n, parts, starts, totals, pairs);
            // (still one per particle, as the lent keys the spatial sort reads)
            return self.cell_of.truncate(n);
        }
        gather(buffers, pairs);
        if parallel {
            pairs.par_sort_unstable();
        } else {
            pairs.sort_unstable();
        }
    }
}

/// The walk of row `r` (of all layers' rows, layer by layer) of [`Grid::walk_cells`]: the
/// cells away from the seams particle by particle through the packed copy when `streamed`
/// holds it (and its coordinates), the cells at a seam (or all, without it) cell by cell,
/// each pair at its minimum image there.
#[inline(always)]
fn walk_row<V: Vector>(
    r: usize,
    after: &Forward<'_>,
    streamed: Option<(&Packed, &[u32])>,
    (ids, still): (&[u32], &[bool]),
    tests: (
        Option<&PairFilter<'_>>,
        &(impl Fn(usize, usize) -> bool + ?Sized),
        Option<SeamTest<'_>>,
    ),
    out: &mut Vec<Pair>,
) {
    let [width, height, _] = after.cells;
    let (z, y) = (r / height, r % height);
    let mut rows_after = [0; MOST_RUNS];
    let row_count = after.rows_after(z, y, &mut rows_after);
    let rows_after = &rows_after[..row_count];
    let inside = match streamed {
        Some(_) => after.cells_inside(z, y),
        None => 0..0,
    };
    let (keep, overlaps, _) = tests;
    if let (Some((packed, planar)), false) = (streamed, inside.is_empty()) {
        let row = r * width;
        let cell_start = after.cell_start;
        let places = cell_start[row + inside.start] as usize..cell_start[row + inside.end] as usize;
        let probes = (packed, planar, ids, cell_start);
        scan_row::<V>(
            probes,
            (row, places),
            rows_after,
            after,
            keep,
            out,
            overlaps,
        );
    }
    let by_cell = (0..inside.start).chain(inside.end.max(inside.start)..width);
    scan_cells(after, (ids, still), (z, y, by_cell), rows_after, out, tests);
}

/// The walk cell by cell (see [`Grid::walk_cells`]) over the cells `xs` of row `y` of layer
/// `z`, whose rows after it are `rows_after`: each cell's particles against the runs after it
/// (see [`Forward`]), with `across` at a seam (see [`Forward::at_seam`]) and `overlaps`
/// elsewhere, keeping the pairs `keep` holds for; a cell is passed over when it and every run
/// after it are `still` (per particle; empty when none is).
#[inline(always)]
fn scan_cells(
    after: &Forward<'_>,
    (ids, still): (&[u32], &[bool]),
    (z, y, xs): (usize, usize, impl Iterator<Item = usize>),
    rows_after: &[usize],
    out: &mut Vec<Pair>,
    (keep, overlaps, across): (
        Option<&PairFilter<'_>>,
        &(impl Fn(usize, usize) -> bool + ?Sized),
        Option<SeamTest<'_>>,
    ),
) {
    let [width, height, _] = after.cells;
    let (row, cell_start) = ((z * height + y) * width, after.cell_start);
    let seam = after.wraps[0];
    let mut runs = [(0, 0); MOST_RUNS];
    for x in xs {
        let (start, end) = (
            cell_start[row + x] as usize,
            cell_start[row + x + 1] as usize,
        );
        if start == end {
            continue;
        }
        // (written in place: returned by value, the runs were copied through the stack, and
        // the copy's wide load waited on their narrow stores)
        let (own_end, count) = if seam && (x == 0 || x + 1 == width) {
            after.runs_at_seam(row, x, rows_after, &mut runs)
        } else {
            let own_end = after.runs_in_rows(row, x, rows_after, &mut runs);
            (own_end, rows_after.len())
        };
        if !still.is_empty() {
            let moves = |(first, last): (usize, usize)| {
                ids[first..last].iter().any(|&id| !still[id as usize])
            };
            if !moves((start, own_end)) && !runs[..count].iter().any(|&r| moves(r)) {
                continue;
            }
        }
        let (runs, cell) = (&runs[..count], (start, end, own_end));
        match across {
            Some(across) if after.at_seam(z, y, x) => scan_cell(ids, cell, runs, keep, out, across),
            _ => scan_cell(ids, cell, runs, keep, out, overlaps),
        }
    }
}

/// The walk's scan from one cell (see [`Grid::walk_cells`]): each of its particles,
/// `ids[start..end]`, against the particles after it in its own run (to `own_end`) and in
/// `runs`, with the pair test `overlaps`; pushes the pairs found that `keep` holds for, if any.
#[inline(always)]
fn scan_cell(
    ids: &[u32],
    (start, end, own_end): (usize, usize, usize),
    runs: &[(usize, usize)],
    keep: Option<&PairFilter<'_>>,
    out: &mut Vec<Pair>,
    overlaps: &(impl Fn(usize, usize) -> bool + ?Sized),
) {
    for k in start..end {
        let i = ids[k] as usize;
        let test = |j: usize| overlaps(i, j);
        let mut hit = |j: usize| {
            let pair = (i.min(j) as u32, i.max(j) as u32);
            if keep.is_none_or(|keep| keep(pair)) {
                out.push(pair);
            }
        };
        scan_run(ids, k + 1, own_end, &test, &mut hit);
        for &(first, last) in runs {
            scan_run(ids, first, last, &test, &mut hit);
        }
    }
}

/// The walk from one side for the particles at places `places` of the cell order, the row
/// of cells that starts at cell `row` (see [`Grid::walk_cells`]), through `packed`'s prefilter
/// (its coordinates `x` and `y` in `planar`): each particle against the places after it in
/// its row up to the end of the cells its reach and the largest can span (see
/// [`Packed::cells_around`]), and against those cells in each of `rows_after` (see
/// [`Forward::rows_after`]), each a run of places. Only for cells away from the seams (see
/// [`Forward::cells_inside`]): the plain test is then the test at the minimum image.
#[inline(always)]
fn scan_row<V: Vector>(
    (packed, planar, ids, cell_start): (&Packed, &[u32], &[u32], &[u32]),
    (row, places): (usize, std::ops::Range<usize>),
    rows_after: &[usize],
    after: &Forward<'_>,
    keep: Option<&PairFilter<'_>>,
    out: &mut Vec<Pair>,
    overlaps: &(impl Fn(usize, usize) -> bool + ?Sized),
) {
    let last_x = after.cells[0] - 1;
    for group in places.clone().step_by(LANES) {
        let (firsts, lasts) = packed.cells_around(planar, group, last_x);
        for (l, k) in (group..places.end.min(group + LANES)).enumerate() {
            let (first_x, end_x) = (firsts[l] as usize, lasts[l] as usize + 1);
            let probe = packed.probe::<V>(planar, k);
            let i = ids[k] as usize;
            let mut candidate = |place: usize| {
                let j = ids[place] as usize;
                if overlaps(i, j) {
                    let pair = (i.min(j) as u32, i.max(j) as u32);
                    if keep.is_none_or(|keep| keep(pair)) {
                        out.push(pair);
                    }
                }
            };
            let own = (k + 1, cell_start[row + end_x] as usize);
            packed.scan::<V>(planar, probe, own, &mut candidate);
            for &base in rows_after {
                let run = (cell_start[base + first_x], cell_start[base + end_x]);
                let run = (run.0 as usize, run.1 as usize);
                packed.scan::<V>(planar, probe, run, &mut candidate);
            }
        }
    }
}

/// The pair test at the minimum image, taken at the periodic seams (see [`Forward::at_seam`]).
type SeamTest<'a> = &'a (dyn Fn(usize, usize) -> bool + Sync);

/// The pairs are sorted by counting (see [`sort_pairs_by_counting`]) when there are more than
/// one per this many particles: a counting sort passes over every particle, a comparison sort
/// `log` times over the pairs. (The 10^6 falling discs have 0.55 pairs a particle, a gas at
/// area fraction 0.3 with the lecture's candidates 0.11.)
const COUNTING_ABOVE: usize = 4;

/// The cells after a cell that the search from one side visits from it, as runs of the
/// particles in cell order (`cell_start`): the next cell of its row, the next row's three
/// cells, and in 3D the next layer's three rows of three, wrapped around the axes that
/// `wraps` (each with at least three cells) and cut at the others' ends.
struct Forward<'a> {
    /// How many cells apart partners may lie (see [`GridLayout::cells_apart`]); more than 1
    /// only without wraps.
    apart: usize,
    cells: [usize; 3],
    wraps: [bool; 3],
    cell_start: &'a [u32],
}

/// The most cells apart two partners may lie for the search from one side (see
/// [`Grid::searches_from_one_side`]): further, the search goes particle by particle.
pub(super) const MOST_CELLS_APART: usize = 3;

/// The most runs a cell scans after its own, and the most rows after it (see
/// [`Forward::rows_after`]): one cell apart, the own row's first cell across its seam, then up
/// to two runs (a row's three cells split by its seam) in each of the next row and the next
/// layer's three rows (9); `a` cells apart (no seams), `a` rows after it and `a` layers of
/// `2 a + 1` rows (24 for `a` = 3).
const MOST_RUNS: usize = MOST_CELLS_APART * (2 * MOST_CELLS_APART + 2);

/// The fewest cells on a wrapping axis for a walk away from its seams to take the test
/// without the minimum image (see [`Forward::at_seam`]): four hold two cells within half a
/// period, and two more leave room for the rounding of the cells' bounds.
const FEWEST_CELLS_INSIDE: usize = 6;

impl Forward<'_> {
    /// True unless every pair that cell `x` of row `y` of layer `z` tests lies within two
    /// cells of each other on every axis that wraps, without a wrap between them, so that its
    /// image nearest either is the other itself: the cell is at least one cell from either
    /// end of each such axis, and the axis has [`FEWEST_CELLS_INSIDE`] cells or more (two
    /// cells are then at most half a period).
    #[inline]
    fn at_seam(&self, z: usize, y: usize, x: usize) -> bool {
        [x, y, z]
            .into_iter()
            .enumerate()
            .any(|(a, c)| self.at_seam_of(a, c))
    }

    /// [`Forward::at_seam`] on one axis: `axis` wraps, and coordinate `c` is at one of its
    /// ends or the axis has fewer than [`FEWEST_CELLS_INSIDE`] cells.
    #[inline]
    fn at_seam_of(&self, axis: usize, c: usize) -> bool {
        let n = self.cells[axis];
        self.wraps[axis] && (n < FEWEST_CELLS_INSIDE || c == 0 || c + 1 == n)
    }

    /// The cells of row `y` of layer `z` whose every pair lies away from the seams (see
    /// [`Forward::at_seam`]): all of them without wraps, none when the row is at a seam of
    /// the second or third axis, else all but the first and the last when the first axis
    /// wraps. The walk takes them particle by particle (see `scan_row`).
    fn cells_inside(&self, z: usize, y: usize) -> std::ops::Range<usize> {
        let width = self.cells[0];
        let row_at_seam = self.at_seam_of(1, y) || self.at_seam_of(2, z);
        if row_at_seam || (self.wraps[0] && width < FEWEST_CELLS_INSIDE) {
            0..0
        } else if self.wraps[0] {
            1..width - 1
        } else {
            0..width
        }
    }

    /// The coordinate `by` cells from `c` on `axis`: wrapped round when the axis wraps, else
    /// `None` beyond its ends.
    #[inline]
    fn moved(&self, axis: usize, c: usize, by: isize) -> Option<usize> {
        let (n, to) = (self.cells[axis] as isize, c as isize + by);
        if (0..n).contains(&to) {
            Some(to as usize)
        } else {
            self.wraps[axis].then(|| to.rem_euclid(n) as usize)
        }
    }

    /// The rows whose cells around `x` are after cell `x` of row `y` of layer `z` (see
    /// [`Forward`]), the same for every cell of the row, each as its first cell's index,
    /// written into the first places of `into`: the `apart` rows after it, and in 3D the
    /// `apart` layers after it, rows `y - apart` to `y + apart`, wrapped round the axes that
    /// wrap (partners then lie one cell apart, and an axis that wraps has three cells or more,
    /// so no row comes twice) and cut at the others' ends. Returns how many it wrote. (Once a
    /// row: a cell's runs are then two loads a row, see [`Forward::runs_in_rows`].)
    #[inline]
    fn rows_after(&self, z: usize, y: usize, into: &mut [usize; MOST_RUNS]) -> usize {
        let [width, height, _] = self.cells;
        let a = self.apart as isize;
        let mut count = 0;
        let mut add = |z: Option<usize>, y: Option<usize>| {
            if let (Some(z), Some(y)) = (z, y) {
                into[count] = (z * height + y) * width;
                count += 1;
            }
        };
        for dy in 1..=a {
            add(Some(z), self.moved(1, y, dy));
        }
        for dz in 1..=a {
            for dy in -a..=a {
                add(self.moved(2, z, dz), self.moved(1, y, dy));
            }
        }
        count
    }

    /// For cell `x` of the row whose first cell is `row`, not at a seam of its row: writes
    /// the runs after it (see [`Forward`]), the cells `x - apart..=x + apart` of each of the
    /// row's `rows_after` (see [`Forward::rows_after`]), into the first places of `into`, and
    /// returns where the run from each of the cell's particles ends (the rest of its own cell
    /// and the cells of its row to `x + apart`).
    #[inline]
    fn runs_in_rows(
        &self,
        row: usize,
        x: usize,
        rows_after: &[usize],
        into: &mut [(usize, usize); MOST_RUNS],
    ) -> usize {
        let a = self.apart;
        let (first, end) = (x.saturating_sub(a), (x + a).min(self.cells[0] - 1) + 1);
        for (run, &base) in into.iter_mut().zip(rows_after) {
            let start = self.cell_start[base + first] as usize;
            *run = (start, self.cell_start[base + end] as usize);
        }
        self.cell_start[row + end] as usize
    }

    /// [`Forward::runs_in_rows`] for the cell `x` at a seam of a row that wraps (the first
    /// or the last; partners then lie one cell apart), whose three cells around it in each
    /// row after it are two runs: returns also how many runs it wrote.
    #[inline]
    fn runs_at_seam(
        &self,
        row: usize,
        x: usize,
        rows_after: &[usize],
        into: &mut [(usize, usize); MOST_RUNS],
    ) -> (usize, usize) {
        let last = self.cells[0] - 1;
        let mut count = 0;
        let mut add = |base: usize, first: usize, end: usize| {
            let start = self.cell_start[base + first] as usize;
            into[count] = (start, self.cell_start[base + end + 1] as usize);
            count += 1;
        };
        let own_end = if x == last {
            add(row, 0, 0);
            self.cell_start[row + x + 1] as usize
        } else {
            self.cell_start[row + x + 2] as usize
        };
        for &base in rows_after {
            if x == 0 {
                add(base, 0, 1);
                add(base, last, last);
            } else {
                add(base, x - 1, x);
                add(base, 0, 0);
            }
        }
        (own_end, count)
    }
}

#[cfg(test)]
mod tests;
