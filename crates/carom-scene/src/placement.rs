//! Where a fill has placed its particles, for the overlap checks of the tries still to come.
//!
//! The placed particles lie in cell order, each cell's run of them found by a start offset (a
//! counting sort's layout): a batch's tries, checked in the order of their cells, then read
//! them nearly in the order they lie in memory, instead of one cache miss after another.
//! [`PlacementGrid::merge`] adds a batch's particles (sorted by cell) in place. While a batch is
//! decided, the grid also indexes the batch's own *survivors* (the tries that overlap nothing
//! placed before the batch, in cell order) by their first in each block of cells, so that each
//! can be checked against the survivors around it (see [`crate::screen`]).
//!
//! The cells are the engine's grid layout ([`GridLayout`]), at least one largest diameter
//! wide, so every particle that can touch a new one lies in the 3^D cells around it (up to 4
//! per axis, with the reach widened past rounding).

use carom_engine::grid::GridLayout;
use carom_engine::{Aabb, Periodic, Vector};

/// A placed particle: centre and radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Disc<V> {
    pub centre: V,
    pub radius: f64,
}

impl<V: Vector> Disc<V> {
    /// True when a particle of `radius` at `x` would overlap this one.
    #[inline]
    pub fn overlaps(&self, x: V, radius: f64) -> bool {
        let reach = radius + self.radius;
        (self.centre - x).length_squared() < reach * reach
    }
}

const EMPTY: u32 = u32::MAX;

/// Cells per entry of the survivors' index: a batch's survivors are found from the first in a
/// block, not in a cell, so the index takes a thirty-second of the memory of one entry a cell
/// (10 MB at 10^6 particles); the survivors before the cell sought are passed over (a block
/// holds less than one survivor on average).
const CELLS_PER_BLOCK: usize = 32;

/// The cells per axis a particle of some radius at some point must look at: first and last.
type CellRange = ([usize; 3], [usize; 3]);

/// The placed particles of a fill, on a grid of cells.
pub(crate) struct PlacementGrid<V> {
    layout: GridLayout,
    max_radius: f64,
    /// Cell `c`'s placed particles are `settled[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    settled: Vec<Disc<V>>,
    /// Per block of [`CELLS_PER_BLOCK`] cells, the first survivor of the batch being decided
    /// in it (an index into the survivors, which lie in cell order), or [`EMPTY`]; all
    /// [`EMPTY`] between batches.
    first_survivor: Vec<u32>,
}

impl<V: Vector> PlacementGrid<V> {
    /// A grid over `bounds` for `capacity` particles of radius at most `max_radius`: the
    /// engine's grid layout, cells about one largest diameter wide, never more than ~4 per
    /// particle (coarser cells stay correct, just slower).
    pub(crate) fn new(bounds: Aabb<V>, max_radius: f64, capacity: usize) -> Self {
        let layout = GridLayout::fit(&bounds, max_radius, None, (4 * capacity + 1024) as f64);
        let cells = layout.total();
        Self {
            layout,
            max_radius,
            starts: vec![0; cells + 1],
            settled: Vec::with_capacity(capacity),
            first_survivor: vec![EMPTY; cells.div_ceil(CELLS_PER_BLOCK)],
        }
    }

    /// The cell holding `x`, as a linear index.
    pub(crate) fn cell_of(&self, x: V) -> u32 {
        self.layout.linear(self.layout.cell_coords(x)) as u32
    }

    /// Places `particles` (centre, radius), in any order.
    pub(crate) fn add(&mut self, particles: impl Iterator<Item = (V, f64)>) {
        let mut sorted: Vec<(u32, Disc<V>)> = particles
            .map(|(centre, radius)| (self.cell_of(centre), Disc { centre, radius }))
            .collect();
        // (stable: a cell's particles keep their order)
        sorted.sort_by_key(|&(cell, _)| cell);
        self.merge(&sorted);
    }

    /// Places `added` (each with its cell, sorted by cell), merging them into the placed
    /// ones in place, from the last cell back, each run of placed particles moving once.
    pub(crate) fn merge(&mut self, added: &[(u32, Disc<V>)]) {
        let Some(&(_, placeholder)) = added.first() else {
            return;
        };
        let (old, count) = (self.settled.len(), added.len());
        self.settled.resize(old + count, placeholder);
        let cells = self.starts.len() - 1;
        self.starts[cells] = (old + count) as u32;
        // `shift`: the added particles not yet placed, all in cells up to the current one;
        // cells above it, up to `upper`, hold old particles alone, which move by `shift`.
        let (mut shift, mut upper, mut upper_old_start) = (count, cells, old);
        let mut left = count;
        while left > 0 {
            let cell = added[left - 1].0 as usize;
            let block_start = if cell + 1 < upper {
                self.starts[cell + 1] as usize
            } else {
                upper_old_start
            };
            self.settled
                .copy_within(block_start..upper_old_start, block_start + shift);
            for start in &mut self.starts[cell + 1..upper] {
                *start += shift as u32;
            }
            let mut in_cell = 0;
            while left > 0 && added[left - 1].0 as usize == cell {
                left -= 1;
                in_cell += 1;
            }
            let end = block_start + shift;
            for (slot, (_, disc)) in self.settled[end - in_cell..end]
                .iter_mut()
                .zip(&added[left..left + in_cell])
            {
                *slot = *disc;
            }
            shift -= in_cell;
            upper = cell + 1;
            upper_old_start = block_start;
        }
    }

    /// The first and last cell per axis that can hold a particle touching one of `radius` at
    /// `x`: within reach, widened past rounding (see [`GridLayout::axis_range`]).
    fn cell_range(&self, x: V, radius: f64) -> CellRange {
        let reach = radius + self.max_radius;
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        for a in 0..V::DIM {
            (lo[a], hi[a]) = self.layout.axis_range(a, x.get(a), reach);
        }
        (lo, hi)
    }

    /// The placed particles of one row of cells of `range`: a row's cells are contiguous.
    #[inline]
    fn settled_row(&self, (lo, hi): CellRange, y: usize, z: usize) -> &[Disc<V>] {
        let row = self.layout.linear([0, y, z]);
        let (first, last) = (self.starts[row + lo[0]], self.starts[row + hi[0] + 1]);
        &self.settled[first as usize..last as usize]
    }

    /// True when a particle of `radius` at `x` would overlap a placed one.
    pub(crate) fn overlaps_settled(&self, x: V, radius: f64) -> bool {
        let range = self.cell_range(x, radius);
        let (lo, hi) = range;
        (lo[2]..=hi[2]).any(|z| {
            (lo[1]..=hi[1]).any(|y| {
                self.settled_row(range, y, z)
                    .iter()
                    .any(|d| d.overlaps(x, radius))
            })
        })
    }

    /// Indexes a batch's survivors, whose cells are `cells` (sorted), by the first in each
    /// block of cells, until [`PlacementGrid::forget_survivors`].
    pub(crate) fn index_survivors(&mut self, cells: &[u32]) {
        for (k, &cell) in cells.iter().enumerate() {
            let block = cell as usize / CELLS_PER_BLOCK;
            if k == 0 || cells[k - 1] as usize / CELLS_PER_BLOCK != block {
                self.first_survivor[block] = k as u32;
            }
        }
    }

    /// Undoes [`PlacementGrid::index_survivors`] of `cells`.
    pub(crate) fn forget_survivors(&mut self, cells: &[u32]) {
        for &cell in cells {
            self.first_survivor[cell as usize / CELLS_PER_BLOCK] = EMPTY;
        }
    }

    /// Calls `visit(k)` for every survivor `k` (see [`PlacementGrid::index_survivors`], with
    /// the same `cells`) in a cell that can hold a particle touching one of `radius` at `x`.
    #[inline]
    pub(crate) fn survivors_near(
        &self,
        x: V,
        radius: f64,
        cells: &[u32],
        mut visit: impl FnMut(usize),
    ) {
        let (lo, hi) = self.cell_range(x, radius);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                let row = self.layout.linear([0, y, z]);
                let (first, last) = (row + lo[0], row + hi[0]);
                // (the first survivor of the first block of the row's cells that has one, then
                // past those in cells before the first)
                let blocks = first / CELLS_PER_BLOCK..=last / CELLS_PER_BLOCK;
                let Some(k) = blocks.map(|b| self.first_survivor[b]).find(|&k| k != EMPTY) else {
                    continue;
                };
                let mut k = k as usize;
                while k < cells.len() && (cells[k] as usize) < first {
                    k += 1;
                }
                while k < cells.len() && cells[k] as usize <= last {
                    visit(k);
                    k += 1;
                }
            }
        }
    }

    /// `test` of `x` and of its images across the seams of `periodic` (`domain`'s periodic
    /// axes) that lie within reach of another particle, until one says true: `x` is wrapped,
    /// so an image one period away can only touch particles near the opposite face.
    pub(crate) fn across_seams(
        &self,
        periodic: &Periodic,
        domain: &Aabb<V>,
        x: V,
        radius: f64,
        mut test: impl FnMut(V) -> bool,
    ) -> bool {
        let reach = radius + self.max_radius;
        // Per axis: no shift, and one period towards the far face when x is near a face.
        let mut shifts = [[0.0; 2]; 3];
        let mut count = [1usize; 3];
        for a in (0..V::DIM).filter(|&a| periodic.is_periodic(a)) {
            let (c, length) = (x.get(a), periodic.length(a));
            let widened = carom_engine::grid::widened_reach(c.abs() + length, reach);
            if c - domain.min.get(a) < widened {
                shifts[a][1] = length;
                count[a] = 2;
            } else if domain.max.get(a) - c < widened {
                shifts[a][1] = -length;
                count[a] = 2;
            }
        }
        for z in &shifts[2][..count[2]] {
            for y in &shifts[1][..count[1]] {
                for sx in &shifts[0][..count[0]] {
                    if test(x + V::from_slice(&[*sx, *y, *z])) {
                        return true;
                    }
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    /// After merging in several rounds, every cell's run holds exactly the particles added
    /// in that cell, and the overlap check sees them.
    #[test]
    fn merging_sorts_every_particle_into_its_cell() {
        let bounds = Aabb::new(DVec2::splat(0.0), DVec2::splat(20.0)).unwrap();
        let mut grid = PlacementGrid::new(bounds, 0.5, 400);
        let mut s = 3u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 * 20.0
        };
        let mut all = Vec::new();
        for round in [1, 0, 7, 50, 3, 200] {
            let added: Vec<DVec2> = (0..round).map(|_| DVec2::new(next(), next())).collect();
            grid.add(added.iter().map(|&x| (x, 0.5)));
            all.extend(added);
            assert_eq!(grid.settled.len(), all.len());
            for c in 0..grid.starts.len() - 1 {
                let mut here: Vec<DVec2> = grid.settled
                    [grid.starts[c] as usize..grid.starts[c + 1] as usize]
                    .iter()
                    .map(|d| d.centre)
                    .collect();
                let mut expected: Vec<DVec2> = all
                    .iter()
                    .copied()
                    .filter(|&x| grid.cell_of(x) as usize == c)
                    .collect();
                let key = |v: &DVec2| (v.x.to_bits(), v.y.to_bits());
                here.sort_by_key(key);
                expected.sort_by_key(key);
                assert_eq!(here, expected, "cell {c}");
            }
            assert!(all.iter().all(|&x| grid.overlaps_settled(x, 0.01)));
        }
    }

    /// Every survivor near a point is visited, and only survivors of the cells around it.
    #[test]
    fn survivors_near_a_point_are_all_visited() {
        let bounds = Aabb::new(DVec2::splat(0.0), DVec2::splat(20.0)).unwrap();
        let mut grid = PlacementGrid::new(bounds, 0.5, 400);
        let mut points: Vec<DVec2> = (0..300)
            .map(|k| DVec2::new((k * 7 % 200) as f64 / 10.0, (k * 13 % 200) as f64 / 10.0))
            .collect();
        points.sort_by_key(|&x| grid.cell_of(x));
        let cells: Vec<u32> = points.iter().map(|&x| grid.cell_of(x)).collect();
        grid.index_survivors(&cells);
        for &x in &points {
            let mut seen = Vec::new();
            grid.survivors_near(x, 0.5, &cells, |k| seen.push(k));
            for (k, &y) in points.iter().enumerate() {
                if (x - y).length() < 1.0 {
                    assert!(seen.contains(&k), "{x} misses {y}");
                }
            }
        }
        grid.forget_survivors(&cells);
        assert!(grid.first_survivor.iter().all(|&f| f == EMPTY));
    }
}
