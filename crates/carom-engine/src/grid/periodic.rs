//! The grid's search across periodic seams (see [`crate::periodic`]): the cells around a
//! particle wrap around the periodic axes, and pairs are tested at the minimum image.

use super::{scan_run, Grid, GridLayout};
use crate::broadphase::{collect_pairs, keep_tail, Pair, PairFilter};
use crate::grid::widened_reach;
use crate::periodic::Periodic;
use crate::response::is_overlapping;
use crate::vector::Vector;

/// Up to two runs of cells `(first, last)` (inclusive) on one axis, and how many there are.
type Runs = ([(usize, usize); 2], usize);

/// Every cell of `runs`, in order.
#[inline]
fn each_cell(runs: &Runs) -> impl Iterator<Item = usize> + '_ {
    runs.0[..runs.1].iter().flat_map(|&(a, b)| a..=b)
}

impl GridLayout {
    /// The cells on periodic `axis` (period `length`) that can hold a particle within `reach`
    /// of `coordinate`, wrapped around the axis: one run, two when the search crosses the
    /// seam, or the whole axis when it would reach round onto itself.
    #[inline]
    fn periodic_runs(&self, axis: usize, coordinate: f64, reach: f64, length: f64) -> Runs {
        let cells = self.cells[axis] as i64;
        // Widened past the rounding of the image too (`x_j + L` is rounded on the scale of
        // the box, not of `x_j`).
        let scale = coordinate.abs() + self.origin[axis].abs() + length;
        let widened = widened_reach(scale, reach);
        let cell = |x: f64| ((x - self.origin[axis]) * self.inverse_cell_size[axis]).floor() as i64;
        let (lo, hi) = (cell(coordinate - widened), cell(coordinate + widened));
        if hi.saturating_sub(lo) + 1 >= cells {
            return ([(0, cells as usize - 1), (0, 0)], 1);
        }
        let (first, last) = (lo.rem_euclid(cells) as usize, hi.rem_euclid(cells) as usize);
        if first <= last {
            ([(first, last), (0, 0)], 1)
        } else {
            ([(first, cells as usize - 1), (0, last)], 2)
        }
    }
}

impl<V: Vector> Grid<V> {
    /// [`BroadPhase::find_pairs`](crate::broadphase::BroadPhase::find_pairs) with periodic
    /// axes, keeping only the pairs `keep` holds for, if any (as [`Grid::search`]): the
    /// positions lie in the domain on those axes (the world wraps them), so no search goes to
    /// the hash; other axes clamp as ever.
    pub(super) fn find_periodic_pairs(
        &mut self,
        periodic: &Periodic,
        positions: &[V],
        radii: &[f64],
        keep: Option<&PairFilter<'_>>,
        pairs: &mut Vec<Pair>,
    ) {
        let max_radius = self.bin(positions, radii);
        if self.searches_from_one_side(max_radius) {
            return self.search_from_one_side(positions, radii, max_radius, keep, pairs);
        }
        let layout = self.layout;
        let (cell_start, ids) = (&self.cell_start, &self.ids);
        collect_pairs(positions.len(), &mut self.buffers, pairs, |i, out| {
            let (pi, ri, first) = (positions[i], radii[i], out.len());
            let mut runs: [Runs; 3] = [([(0, 0); 2], 1); 3];
            for (a, r) in runs.iter_mut().enumerate().take(V::DIM) {
                let reach = ri + max_radius;
                *r = if periodic.is_periodic(a) {
                    layout.periodic_runs(a, pi.get(a), reach, periodic.length(a))
                } else {
                    let (lo, hi) = layout.axis_range(a, pi.get(a), reach);
                    ([(lo, hi), (0, 0)], 1)
                };
            }
            let test = |j: usize| {
                (j > i) & is_overlapping(pi, periodic.image(pi, positions[j]), ri, radii[j])
            };
            let mut hit = |j: usize| out.push((i as u32, j as u32));
            for z in each_cell(&runs[2]) {
                for y in each_cell(&runs[1]) {
                    let row = (z * layout.cells[1] + y) * layout.cells[0];
                    for &(lo, hi) in &runs[0].0[..runs[0].1] {
                        let start = cell_start[row + lo] as usize;
                        let end = cell_start[row + hi + 1] as usize;
                        scan_run(ids, start, end, &test, &mut hit);
                    }
                }
            }
            if let Some(keep) = keep {
                keep_tail(out, first, keep);
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use crate::broadphase::BroadPhase;
    use crate::brute::BruteForce;
    use crate::domain::Aabb;
    use crate::grid::tests::lattice_with_jitter;
    use crate::grid::Grid;
    use crate::periodic::Periodic;
    use glam::DVec3;

    #[test]
    fn periodic_grid_equals_periodic_brute_force_for_any_cell_size() {
        let (pos, rad) = lattice_with_jitter(600);
        // (the cloud fills (-15, 15)^3, the domain: wrapped, as the world keeps it)
        let domain = Aabb::new(DVec3::splat(-15.0), DVec3::splat(15.0)).unwrap();
        for axes in [
            [true, false, false],
            [true, true, true],
            [false, true, true],
        ] {
            let periodic = Periodic::new(&domain, &axes);
            let pos: Vec<DVec3> = pos.iter().map(|&x| periodic.unwrap().wrap(x)).collect();
            let mut expected = Vec::new();
            BruteForce::new()
                .with_periodic(periodic)
                .find_pairs(&pos, &rad, &mut expected);
            let mut plain = Vec::new();
            BruteForce::new().find_pairs(&pos, &rad, &mut plain);
            assert!(
                expected.len() > plain.len(),
                "{axes:?}: pairs across the seams"
            );
            for cells in [[1, 1, 1], [2, 3, 2], [3, 5, 7], [12, 12, 12], [40, 40, 40]] {
                let mut got = Vec::new();
                Grid::new(Some(domain), Some(&cells))
                    .unwrap()
                    .with_periodic(periodic)
                    .find_pairs(&pos, &rad, &mut got);
                assert_eq!(got, expected, "{axes:?}, cells {cells:?}");
            }
        }
    }
}
