//! Where a fill has placed its particles, for the overlap checks of the tries still to come.
//!
//! Two parts. The *settled* particles (all placed before the current batch of tries) lie in
//! cell order, each cell's run of them found by a start offset (a counting sort's layout): a
//! batch's tries, checked in the order of their cells, then read the settled particles nearly
//! in the order they lie in memory, instead of one cache miss after another. The *recent*
//! particles (placed since the last [`PlacementGrid::settle`]) hang off per-cell lists, and a
//! bit per cell says which cells hold any, so a check against them alone reads a bit for most
//! cells. `settle` merges the recent ones into the settled, in place.
//!
//! The cells are the engine's grid layout ([`GridLayout`]), at least one largest diameter
//! wide, so every particle that can touch a new one lies in the 3^D cells around it (up to 4
//! per axis, with the reach widened past rounding).

use carom_engine::grid::GridLayout;
use carom_engine::{Aabb, Periodic, Vector};

/// A placed particle: centre and radius.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Disc<V> {
    centre: V,
    radius: f64,
}

impl<V: Vector> Disc<V> {
    #[inline]
    fn overlaps(&self, x: V, radius: f64) -> bool {
        let reach = radius + self.radius;
        (self.centre - x).length_squared() < reach * reach
    }
}

/// A recent particle: its disc, its cell, and the particle placed before it in that cell.
#[derive(Clone, Copy)]
struct Recent<V> {
    disc: Disc<V>,
    cell: u32,
    next: u32,
}

const EMPTY: u32 = u32::MAX;

/// The cells per axis a particle of some radius at some point must look at: first and last.
type CellRange = ([usize; 3], [usize; 3]);

/// Tries checked in step by [`PlacementGrid::refusals`]: the cell starts of all of them are
/// fetched, then the first settled particle of each of their rows of cells, then they are
/// tested, so that the cache misses of several tries are in flight together.
const TRIES_IN_STEP: usize = 8;

/// The settled and recent particles of a fill, on a grid of cells.
pub(crate) struct PlacementGrid<V> {
    layout: GridLayout,
    max_radius: f64,
    /// Cell `c`'s settled particles are `settled[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    settled: Vec<Disc<V>>,
    /// Per cell, its latest recent particle (an index into `recent`), or [`EMPTY`].
    head: Vec<u32>,
    recent: Vec<Recent<V>>,
    /// One bit per cell: set for the cells that hold a recent particle.
    marks: Vec<u64>,
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
            head: vec![EMPTY; cells],
            recent: Vec::new(),
            marks: vec![0; cells.div_ceil(64)],
        }
    }

    /// The cell holding `x`, as a linear index.
    pub(crate) fn cell_of(&self, x: V) -> usize {
        self.layout.linear(self.layout.cell_coords(x))
    }

    /// Adds a recent particle at `centre`.
    pub(crate) fn insert(&mut self, centre: V, radius: f64) {
        let cell = self.cell_of(centre);
        self.recent.push(Recent {
            disc: Disc { centre, radius },
            cell: cell as u32,
            next: self.head[cell],
        });
        self.head[cell] = (self.recent.len() - 1) as u32;
        self.marks[cell / 64] |= 1u64 << (cell % 64);
    }

    /// Makes every recent particle settled: merges them (sorted by cell) into the settled
    /// ones, in place, from the last cell back, each run of settled particles moving once.
    pub(crate) fn settle(&mut self) {
        if self.recent.is_empty() {
            return;
        }
        let mut keys: Vec<u64> = self
            .recent
            .iter()
            .enumerate()
            .map(|(k, r)| (u64::from(r.cell) << 32) | k as u64)
            .collect();
        keys.sort_unstable();
        let (old, added) = (self.settled.len(), self.recent.len());
        let placeholder = self.recent[0].disc;
        self.settled.resize(old + added, placeholder);
        let cells = self.head.len();
        self.starts[cells] = (old + added) as u32;
        // `shift`: the recent particles not yet placed, all in cells up to the current one;
        // cells above it, up to `upper`, hold settled particles alone, which move by `shift`.
        let (mut shift, mut upper, mut upper_old_start) = (added, cells, old);
        let mut left = added;
        while left > 0 {
            let cell = (keys[left - 1] >> 32) as usize;
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
            while left > 0 && (keys[left - 1] >> 32) as usize == cell {
                left -= 1;
                in_cell += 1;
            }
            let end = block_start + shift;
            for (slot, &key) in self.settled[end - in_cell..end]
                .iter_mut()
                .zip(&keys[left..left + in_cell])
            {
                *slot = self.recent[(key & u64::from(u32::MAX)) as usize].disc;
            }
            shift -= in_cell;
            upper = cell + 1;
            upper_old_start = block_start;
        }
        for r in &self.recent {
            self.head[r.cell as usize] = EMPTY;
            self.marks[r.cell as usize / 64] = 0;
        }
        self.recent.clear();
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

    /// The settled particles of one row of cells of `range`: a row's cells are contiguous.
    #[inline]
    fn settled_row(&self, (lo, hi): CellRange, y: usize, z: usize) -> &[Disc<V>] {
        let row = self.layout.linear([0, y, z]);
        let (first, last) = (self.starts[row + lo[0]], self.starts[row + hi[0] + 1]);
        &self.settled[first as usize..last as usize]
    }

    /// True when a particle of `radius` at `x` would overlap a settled one.
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

    /// True when a particle of `radius` at `x` would overlap a recent one.
    pub(crate) fn overlaps_recent(&self, x: V, radius: f64) -> bool {
        let (lo, hi) = self.cell_range(x, radius);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                let row = self.layout.linear([0, y, z]);
                for cell in row + lo[0]..=row + hi[0] {
                    if self.marks[cell / 64] & (1u64 << (cell % 64)) == 0 {
                        continue;
                    }
                    let mut j = self.head[cell];
                    while j != EMPTY {
                        let r = &self.recent[j as usize];
                        if r.disc.overlaps(x, radius) {
                            return true;
                        }
                        j = r.next;
                    }
                }
            }
        }
        false
    }

    /// [`PlacementGrid::overlaps_settled`] of each of `tries` (no recent particles may
    /// exist), [`TRIES_IN_STEP`] at a time in stages: the same answers, with the misses of
    /// several tries overlapping.
    pub(crate) fn refusals(
        &self,
        mut tries: impl Iterator<Item = V>,
        radius: f64,
        refused: &mut [bool],
    ) {
        debug_assert!(self.recent.is_empty());
        for refused in refused.chunks_mut(TRIES_IN_STEP) {
            let mut step = [V::ZERO; TRIES_IN_STEP];
            for (x, try_) in step.iter_mut().zip(&mut tries).take(refused.len()) {
                *x = try_;
            }
            let step = &step[..refused.len()];
            let mut ranges: [CellRange; TRIES_IN_STEP] = [([0; 3], [0; 3]); TRIES_IN_STEP];
            for (&x, range) in step.iter().zip(&mut ranges) {
                *range = self.cell_range(x, radius);
                let (lo, hi) = *range;
                for z in lo[2]..=hi[2] {
                    for y in lo[1]..=hi[1] {
                        prefetch(&self.starts[self.layout.linear([lo[0], y, z])]);
                    }
                }
            }
            for &range in &ranges[..step.len()] {
                let (lo, hi) = range;
                for z in lo[2]..=hi[2] {
                    for y in lo[1]..=hi[1] {
                        if let Some(first) = self.settled_row(range, y, z).first() {
                            prefetch(first);
                        }
                    }
                }
            }
            for (&x, refused) in step.iter().zip(refused.iter_mut()) {
                *refused = self.overlaps_settled(x, radius);
            }
        }
    }

    /// `test` of `x` and of its images across the seams of `periodic` (`domain`'s periodic
    /// axes) that lie within reach of another particle: `x` is wrapped, so an image one
    /// period away can only touch particles near the opposite face.
    pub(crate) fn across_seams(
        &self,
        periodic: &Periodic,
        domain: &Aabb<V>,
        x: V,
        radius: f64,
        test: impl Fn(V) -> bool,
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

/// Hints the processor to bring the cache line of `value` in; no effect on any result.
#[inline]
fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: a prefetch is a hint: it never faults and reads nothing the program sees,
        // and the address is a live reference besides.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((value as *const T).cast::<i8>()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    /// After settling in several rounds, every cell's settled run holds exactly the
    /// particles inserted in that cell, and the overlap checks see them.
    #[test]
    fn settling_sorts_every_particle_into_its_cell() {
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
            for _ in 0..round {
                let x = DVec2::new(next(), next());
                grid.insert(x, 0.5);
                all.push(x);
            }
            assert!(all
                .iter()
                .all(|&x| grid.overlaps_recent(x, 0.01) || grid.overlaps_settled(x, 0.01)));
            grid.settle();
            assert_eq!(grid.settled.len(), all.len());
            assert!(grid.recent.is_empty() && grid.marks.iter().all(|&m| m == 0));
            for c in 0..grid.head.len() {
                let mut here: Vec<DVec2> = grid.settled
                    [grid.starts[c] as usize..grid.starts[c + 1] as usize]
                    .iter()
                    .map(|d| d.centre)
                    .collect();
                let mut expected: Vec<DVec2> = all
                    .iter()
                    .copied()
                    .filter(|&x| grid.cell_of(x) == c)
                    .collect();
                let key = |v: &DVec2| (v.x.to_bits(), v.y.to_bits());
                here.sort_by_key(key);
                expected.sort_by_key(key);
                assert_eq!(here, expected, "cell {c}");
            }
            assert!(all.iter().all(|&x| grid.overlaps_settled(x, 0.01)));
            assert!(!grid.overlaps_recent(DVec2::splat(10.0), 5.0));
        }
    }
}
