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
//! The pairs come out grouped by cell, not by particle, so they are sorted at the end: the set
//! is exact and its order canonical (see [`crate::broadphase`]), so the solver sees the same
//! contacts as from the search by particle, and every run the same bits. (The bench's 10^6-disc
//! gas, 2 threads: the search by particle took 35-38 ms a step, this one 17 ms and 4 more to
//! sort the pairs it finds.)

use super::{scan_run, Grid, GridLayout};
use crate::broadphase::{gather, keep_headroom, Pair, PairFilter, PARALLEL_SEARCH_MIN};
use crate::response::is_overlapping;
use crate::vector::Vector;
use rayon::prelude::*;

/// Cells a parallel task of the search walks (whole rows of them: at least one).
const CELLS_PER_TASK: usize = 8192;

/// How much wider than the largest `r_i + r_j` a cell must be for the search from one side:
/// the cells' bounds are rounded (a relative error of a few ulps of the cell count, at most
/// 2^28 cells a side), and this leaves a pair never more than one cell apart on any axis.
const WIDTH_MARGIN: f64 = 1e-6;

impl GridLayout {
    /// True when no two particles of radius at most `max_radius` can touch from cells more
    /// than one apart on any axis (see [`WIDTH_MARGIN`]).
    pub(super) fn holds_pairs_to_neighbours<V: Vector>(&self, max_radius: f64) -> bool {
        let widest = 2.0 * max_radius * (1.0 + WIDTH_MARGIN);
        (0..V::DIM).all(|a| self.cell_size[a] >= widest)
    }
}

impl<V: Vector> Grid<V> {
    /// [`BroadPhase::find_pairs`](crate::broadphase::BroadPhase::find_pairs) by cells, each
    /// pair tested from one side (see the [module notes](self)), keeping only the pairs `keep`
    /// holds for, if any. The buckets must be built, with cells that
    /// [hold pairs to neighbours](GridLayout::holds_pairs_to_neighbours).
    pub(super) fn search_from_one_side(
        &mut self,
        positions: &[V],
        radii: &[f64],
        keep: Option<&PairFilter<'_>>,
        pairs: &mut Vec<Pair>,
    ) {
        let layout = self.layout;
        let [width, height, depth] = layout.cells;
        let rows = height * depth;
        let rows_per_task = (CELLS_PER_TASK / width).max(1);
        let tasks = rows.div_ceil(rows_per_task);
        if self.buffers.len() < tasks {
            self.buffers.resize_with(tasks, Vec::new);
        }
        let (cell_start, ids) = (&self.cell_start, &self.ids);
        // The run of cells `first..=last` (clamped to its row) of the row `y` of layer `z`.
        let run = |z: usize, y: usize, first: usize, last: usize| {
            let row = (z * height + y) * width;
            let start = cell_start[row + first] as usize;
            (start, cell_start[row + last.min(width - 1) + 1] as usize)
        };
        let work = |(task, out): (usize, &mut Vec<Pair>)| {
            out.clear();
            for r in task * rows_per_task..((task + 1) * rows_per_task).min(rows) {
                let (z, y) = (r / height, r % height);
                for x in 0..width {
                    let (start, end) = run(z, y, x, x);
                    if start == end {
                        continue;
                    }
                    // Every run after the cell's own that it can touch: the next row's three
                    // cells, and in 3D the next layer's three rows of three.
                    let mut after = [(0, 0); 4];
                    let mut count = 0;
                    let left = x.saturating_sub(1);
                    if y + 1 < height {
                        after[count] = run(z, y + 1, left, x + 1);
                        count += 1;
                    }
                    if z + 1 < depth {
                        for up in y.saturating_sub(1)..=(y + 1).min(height - 1) {
                            after[count] = run(z + 1, up, left, x + 1);
                            count += 1;
                        }
                    }
                    let own_row_end = run(z, y, x, x + 1).1;
                    for k in start..end {
                        let i = ids[k] as usize;
                        let (xi, ri) = (positions[i], radii[i]);
                        let test = |j: usize| is_overlapping(xi, positions[j], ri, radii[j]);
                        let mut hit = |j: usize| {
                            let pair = (i.min(j) as u32, i.max(j) as u32);
                            if keep.is_none_or(|keep| keep(pair)) {
                                out.push(pair);
                            }
                        };
                        scan_run(ids, k + 1, own_row_end, &test, &mut hit);
                        for &(first, last) in &after[..count] {
                            scan_run(ids, first, last, &test, &mut hit);
                        }
                    }
                }
            }
            keep_headroom(out);
        };
        let parallel = positions.len() >= PARALLEL_SEARCH_MIN;
        let buffers = &mut self.buffers[..tasks];
        if parallel {
            buffers.par_iter_mut().enumerate().for_each(work);
        } else {
            buffers.iter_mut().enumerate().for_each(work);
        }
        gather(buffers, pairs);
        if parallel {
            pairs.par_sort_unstable();
        } else {
            pairs.sort_unstable();
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::broadphase::{BroadPhase, CellScratch, Pair};
    use crate::brute::BruteForce;
    use crate::domain::Aabb;
    use crate::grid::Grid;
    use crate::vector::Vector;
    use glam::{DVec2, DVec3};

    /// A cloud of `n` particles in (-20, 20) on every axis, radii 0.5 and 1.5.
    fn cloud<V: Vector>(n: usize, seed: u64) -> (Vec<V>, Vec<f64>) {
        let mut next = crate::testing::uniform(seed);
        let positions = (0..n)
            .map(|_| V::from_slice(&[0.0; 3].map(|_: f64| next() * 40.0 - 20.0)))
            .collect();
        let radii = (0..n).map(|i| if i % 5 == 0 { 1.5 } else { 0.5 }).collect();
        (positions, radii)
    }

    /// The search from one side finds exactly brute force's pairs (and, keeping some, what a
    /// retain after it keeps), in 2D and 3D, with cells exactly as wide as it needs and wider,
    /// with particles clamped into the border cells.
    fn finds_what_brute_force_finds<V: Vector>() {
        let (positions, radii) = cloud::<V>(3000, 7);
        let mut expected = Vec::new();
        BruteForce::new().find_pairs(&positions, &radii, &mut expected);
        let keep = |(i, j): Pair| (i + 2 * j) % 3 != 1;
        let mut kept = expected.clone();
        kept.retain(|&pair| keep(pair));
        // (a domain a little inside the cloud: its border cells take the few particles beyond)
        let domain = Aabb::new(V::from_slice(&[-19.9; 3]), V::from_slice(&[19.9; 3])).unwrap();
        let (mut scratch, mut retained) = (CellScratch::default(), Vec::new());
        for cells in [1, 5, 13] {
            let mut grid = Grid::new(Some(domain), Some(&vec![cells; V::DIM])).unwrap();
            let mut got = Vec::new();
            grid.find_pairs(&positions, &radii, &mut got);
            assert!(grid.layout().holds_pairs_to_neighbours::<V>(1.5));
            assert_eq!(BroadPhase::<V>::name(&grid), "grid");
            assert_eq!(got, expected, "{} cells", cells);
            grid.find_pairs_kept_in(
                &positions,
                &radii,
                &keep,
                &mut got,
                &mut scratch,
                &mut retained,
            );
            assert_eq!(got, kept, "{} cells, keeping some", cells);
        }
        // (13 cells of 39.8 / 13 = 3.06 hold pairs of radius 1.5; 14 of 2.84 would not)
        let grid = Grid::<V>::new(Some(domain), Some(&vec![14; V::DIM])).unwrap();
        let mut grid = grid;
        let mut got = Vec::new();
        grid.find_pairs(&positions, &radii, &mut got);
        assert!(!grid.layout().holds_pairs_to_neighbours::<V>(1.5));
        assert_eq!(got, expected, "14 cells, searched by particle");
    }

    #[test]
    fn the_search_from_one_side_finds_what_brute_force_finds_2d() {
        finds_what_brute_force_finds::<DVec2>();
    }

    #[test]
    fn the_search_from_one_side_finds_what_brute_force_finds_3d() {
        finds_what_brute_force_finds::<DVec3>();
    }
}
