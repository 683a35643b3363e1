//! Whether a step's escapees struck anyone (see [`super::escape`]): a grid over where the
//! escapees ended, so that each particle is checked against the few near it.

use super::escape::{Moved, ESCAPE_TOLERANCE};
use crate::periodic::Periodic;
use crate::response::is_overlapping;
use crate::vector::Vector;
use rayon::prelude::*;

impl<V: Vector> Moved<V> {
    /// Whether this escapee overlaps `other` at the end of the step deeper than the tolerance
    /// while the two were beyond reach of each other where it started.
    #[inline]
    fn strikes(&self, other: &Moved<V>, periodic: Option<&Periodic>) -> bool {
        if other.id == self.id {
            return false;
        }
        let image = |a: V, b: V| periodic.map_or(b, |p| p.image(a, b));
        let end = image(self.end, other.end);
        let deep = self.radius + other.radius - ESCAPE_TOLERANCE * self.radius.min(other.radius);
        is_overlapping(self.end, end, deep, 0.0)
            && !is_overlapping(
                self.start,
                image(self.start, other.start),
                self.reach,
                other.reach,
            )
    }
}

/// The escapees of a step and a grid over where they ended, to check every particle against
/// the few near it: a pass over every particle reads its end position and one bit, and only a
/// particle in a marked cell reads the rest.
#[derive(Clone, Debug, Default)]
pub(crate) struct Escapes<V> {
    /// The escapees (of every rank, in a split run).
    pub list: Vec<Moved<V>>,
    /// The grid's lowest corner, the inverse of its cell edge on each axis (an edge at least
    /// the largest distance at which a particle can strike), and cells per axis (1 on unused
    /// axes). On a periodic axis the grid spans the period, its cells wrapping around.
    origin: [f64; 3],
    inverse_cell: [f64; 3],
    cells: [usize; 3],
    /// One bit per cell: whether it lies within one cell of an escapee's.
    marks: Vec<u64>,
    /// (cell, escapee) for every escapee, sorted.
    by_cell: Vec<(usize, u32)>,
    /// The periodic axes, if any.
    periodic: Option<Periodic>,
    /// Whether the grid is laid (when it would not fit, every particle is checked against
    /// every escapee).
    grid: bool,
}

/// At most this many cells in the grid per particle checked (and at least [`FEWEST_CELLS`]):
/// coarser cells then, which mark more particles for the full check.
const CELLS_PER_PARTICLE: usize = 8;
const FEWEST_CELLS: usize = 4096;

impl<V: Vector> Escapes<V> {
    /// Lays the grid over `list`, for `particles` particles of radius up to `max_radius`.
    pub fn index(&mut self, max_radius: f64, particles: usize, periodic: Option<Periodic>) {
        self.periodic = periodic;
        self.grid = false;
        if self.list.is_empty() {
            return;
        }
        let period = |a: usize| periodic.map_or(0.0, |p| p.length(a));
        let largest = self.list.iter().fold(0.0f64, |m, e| m.max(e.radius));
        let mut cell = (largest + max_radius).max(f64::MIN_POSITIVE);
        let (mut lo, mut hi) = ([0.0f64; 3], [0.0f64; 3]);
        for a in 0..V::DIM {
            lo[a] = self
                .list
                .iter()
                .fold(f64::INFINITY, |m, e| m.min(e.end.get(a)));
            hi[a] = self
                .list
                .iter()
                .fold(f64::NEG_INFINITY, |m, e| m.max(e.end.get(a)));
        }
        // (two cells of margin on each side: a particle in the nearer may be struck, and the
        // other keeps every escapee's neighbours inside the grid whatever the rounding)
        // (on a periodic axis, the period in cells no narrower than `cell`)
        let count = |cell: f64| {
            let mut cells = [1.0f64; 3];
            for a in 0..V::DIM {
                cells[a] = match period(a) {
                    0.0 => ((hi[a] - lo[a]) / cell).floor() + 5.0,
                    length => (length / cell).floor(),
                };
            }
            cells
        };
        let most = (CELLS_PER_PARTICLE * particles).max(FEWEST_CELLS) as f64;
        let mut cells = count(cell);
        while cells.iter().product::<f64>() > most {
            cell *= 2.0;
            cells = count(cell);
        }
        // (a box too wide for any grid, or one that is not a number: every particle is checked
        // against every escapee)
        // (and a period of fewer than three cells, whose neighbours would repeat)
        self.grid = cells.iter().all(|c| c.is_finite() && *c >= 1.0) && cell.is_finite();
        self.grid &= (0..V::DIM).all(|a| period(a) == 0.0 || cells[a] >= 3.0);
        if !self.grid {
            return;
        }
        let cells = cells.map(|c| c as usize);
        let mut inverse_cell = [1.0 / cell; 3];
        for a in 0..V::DIM {
            match (period(a), periodic) {
                (0.0, _) => lo[a] -= 2.0 * cell,
                (length, Some(p)) => {
                    lo[a] = p.low(a);
                    inverse_cell[a] = cells[a] as f64 / length;
                }
                (_, None) => unreachable!("a period without periodic axes"),
            }
        }
        (self.origin, self.inverse_cell, self.cells) = (lo, inverse_cell, cells);
        let total = cells.iter().product::<usize>();
        self.marks.clear();
        self.marks.resize(total.div_ceil(64), 0);
        self.by_cell.clear();
        for k in 0..self.list.len() {
            // (every escapee lies in its grid but where rounding at the largest coordinates
            // says otherwise: then the grid is not used)
            let Some(at) = self.coordinates(self.list[k].end) else {
                self.grid = false;
                return;
            };
            self.by_cell.push((self.index_of(at), k as u32));
            let (around, count) = self.cells_around(at);
            for &c in &around[..count] {
                self.marks[c / 64] |= 1 << (c % 64);
            }
        }
        self.by_cell.sort_unstable();
    }

    /// The grid coordinates of the cell holding `x`, or `None` outside the grid.
    #[inline]
    fn coordinates(&self, x: V) -> Option<[usize; 3]> {
        let x = self.periodic.map_or(x, |p| p.wrap(x));
        let mut at = [0usize; 3];
        for (a, at) in at.iter_mut().enumerate().take(V::DIM) {
            let t = (x.get(a) - self.origin[a]) * self.inverse_cell[a];
            // (a NaN is outside too)
            if !(t >= 0.0 && t < self.cells[a] as f64) {
                return None;
            }
            *at = (t as usize).min(self.cells[a] - 1);
        }
        Some(at)
    }

    /// Cell `at`'s coordinate on `axis` and its neighbours', within the grid (around it on a
    /// periodic axis), and how many.
    #[inline]
    fn near(&self, at: [usize; 3], axis: usize) -> ([usize; 3], usize) {
        let (c, n) = (at[axis], self.cells[axis]);
        if axis >= V::DIM {
            return ([c; 3], 1);
        }
        if self.periodic.is_some_and(|p| p.is_periodic(axis)) {
            return ([(c + n - 1) % n, c, (c + 1) % n], 3);
        }
        let first = c.saturating_sub(1);
        let last = (c + 1).min(n - 1);
        ([first, first + 1, first + 2], last - first + 1)
    }

    #[inline]
    fn index_of(&self, [x, y, z]: [usize; 3]) -> usize {
        (z * self.cells[1] + y) * self.cells[0] + x
    }

    /// The indices of cell `at` and its neighbours (see [`Escapes::near`]), z, then y, then
    /// x ascending, and how many: what an escapee marks and what a particle looks in.
    #[inline]
    fn cells_around(&self, at: [usize; 3]) -> ([usize; 27], usize) {
        let [(xs, nx), (ys, ny), (zs, nz)] = [0, 1, 2].map(|a| self.near(at, a));
        let (mut around, mut count) = ([0; 27], 0);
        for &z in &zs[..nz] {
            for &y in &ys[..ny] {
                for &x in &xs[..nx] {
                    around[count] = self.index_of([x, y, z]);
                    count += 1;
                }
            }
        }
        (around, count)
    }

    /// How many escapees strike the particle that ended at `end` (`particle()` gives the
    /// rest of it; see [`Moved::strikes`]).
    #[inline]
    pub fn strikes_on(&self, end: V, particle: impl Fn() -> Moved<V>) -> u64 {
        if self.list.is_empty() {
            return 0;
        }
        if !self.grid {
            let (periodic, p) = (self.periodic.as_ref(), particle());
            return self.list.iter().filter(|e| e.strikes(&p, periodic)).count() as u64;
        }
        let Some(at) = self.coordinates(end) else {
            return 0;
        };
        let c = self.index_of(at);
        if self.marks[c / 64] & (1 << (c % 64)) == 0 {
            return 0;
        }
        let p = particle();
        let mut strikes = 0;
        let periodic = self.periodic.as_ref();
        let (around, count) = self.cells_around(at);
        for &c in &around[..count] {
            let first = self.by_cell.partition_point(|&(cell, _)| cell < c);
            for &(_, k) in self.by_cell[first..].iter().take_while(|&&(d, _)| d == c) {
                strikes += self.list[k as usize].strikes(&p, periodic) as u64;
            }
        }
        strikes
    }

    /// How many strikes (see [`Moved::strikes`]) the escapees make on the particles that
    /// ended at `end`, the rest of particle `s` from `particle(s)`; on the thread pool when
    /// `parallel`.
    pub fn strikes(
        &self,
        end: &[V],
        parallel: bool,
        particle: impl Fn(usize) -> Moved<V> + Sync,
    ) -> u64 {
        if self.list.is_empty() {
            return 0;
        }
        let one = |(s, &x): (usize, &V)| self.strikes_on(x, || particle(s));
        if parallel {
            end.par_iter().enumerate().map(one).sum()
        } else {
            end.iter().enumerate().map(one).sum()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::escape::moved;
    use super::*;
    use glam::{DVec2, DVec3};

    /// Brute force's count of strikes, for the grid's to be held to.
    fn brute<V: Vector>(
        escapes: &[Moved<V>],
        particles: &[Moved<V>],
        periodic: Option<&Periodic>,
    ) -> u64 {
        let mut n = 0;
        for e in escapes {
            for p in particles {
                n += e.strikes(p, periodic) as u64;
            }
        }
        n
    }

    fn scatter<V: Vector>(seed: u64) -> (Vec<Moved<V>>, Vec<Moved<V>>) {
        let mut next = crate::testing::uniform(seed);
        let mut point = |scale: f64| V::from_slice(&[0.0; 3].map(|_: f64| next() * scale));
        let particles: Vec<Moved<V>> = (0..400)
            .map(|id| {
                let start = point(30.0);
                moved(id, start, start + point(0.5))
            })
            .collect();
        let escapes = (0..40)
            .map(|k| {
                let mut m = particles[k * 10];
                m.end = m.start + point(3.0);
                m
            })
            .collect();
        (escapes, particles)
    }

    fn the_grid_counts_as_brute_force<V: Vector>() {
        for seed in 1..6 {
            let (list, particles) = scatter::<V>(seed);
            let expected = brute(&list, &particles, None);
            let mut escapes = Escapes {
                list,
                ..Escapes::default()
            };
            escapes.index(1.0, particles.len(), None);
            let counted: u64 = particles
                .iter()
                .map(|p| escapes.strikes_on(p.end, || *p))
                .sum();
            assert_eq!(counted, expected, "seed {seed}");
            let ends: Vec<V> = particles.iter().map(|p| p.end).collect();
            let lookup = |s: usize| particles[s];
            assert_eq!(escapes.strikes(&ends, true, lookup), expected);
        }
    }

    #[test]
    fn the_grid_counts_every_strike_in_2d_and_3d() {
        the_grid_counts_as_brute_force::<DVec2>();
        the_grid_counts_as_brute_force::<DVec3>();
    }

    /// A lone escapee (its grid one cell of it and the margins), anywhere: the grid's edges
    /// fall where rounding puts them, and its neighbours must still be inside.
    #[test]
    fn a_lone_escapee_strikes_its_neighbours_anywhere() {
        for x in [0.0, 0.1, -7.7, 1e6 + 0.3, -123.456789] {
            for (dx, dy) in [(1.5, 0.0), (-1.5, 0.0), (0.0, 1.9), (-1.0, -1.0)] {
                let end = DVec2::new(x, x / 3.0);
                let e = moved(0, end - DVec2::new(5.0, 0.0), end);
                let at = end + DVec2::new(dx, dy);
                let other = moved(1, at, at);
                let mut escapes = Escapes {
                    list: vec![e],
                    ..Escapes::default()
                };
                escapes.index(1.0, 2, None);
                assert_eq!(escapes.strikes_on(at, || other), 1, "at {x} + ({dx}, {dy})");
            }
        }
    }

    /// In a box periodic on x (and, in 3D, z), pairs across the seams: the grid, wrapped,
    /// counts what brute force with the nearest images counts.
    fn the_periodic_grid_counts_as_brute_force<V: Vector>() {
        let (lo, hi) = (V::from_slice(&[0.0; 3]), V::from_slice(&[30.5; 3]));
        let domain = crate::domain::Aabb::new(lo, hi).unwrap();
        let periodic = Periodic::new(&domain, &[true, false, true]).unwrap();
        for seed in 1..6 {
            let (mut list, mut particles) = scatter::<V>(seed);
            for p in particles.iter_mut().chain(list.iter_mut()) {
                (p.start, p.end) = (periodic.wrap(p.start), periodic.wrap(p.end));
            }
            let expected = brute(&list, &particles, Some(&periodic));
            assert!(expected > 0, "seed {seed}: the scatter must strike");
            let mut escapes = Escapes {
                list,
                ..Escapes::default()
            };
            escapes.index(1.0, particles.len(), Some(periodic));
            assert!(escapes.grid, "a grid fits the period");
            let ends: Vec<V> = particles.iter().map(|p| p.end).collect();
            let lookup = |s: usize| particles[s];
            assert_eq!(
                escapes.strikes(&ends, false, lookup),
                expected,
                "seed {seed}"
            );
        }
    }

    #[test]
    fn the_periodic_grid_counts_every_strike_in_2d_and_3d() {
        the_periodic_grid_counts_as_brute_force::<DVec2>();
        the_periodic_grid_counts_as_brute_force::<DVec3>();
    }

    /// Escapees too far apart for any grid (a fuzzed scene): every particle against every
    /// escapee instead, no overflow.
    #[test]
    fn escapees_beyond_any_grid_are_still_checked() {
        let far = DVec2::new(1e300, -1e300);
        let list = vec![moved(0, DVec2::ZERO, DVec2::ZERO), moved(1, far, far)];
        let at = DVec2::new(1.5, 0.0);
        let other = moved(2, DVec2::new(3.0, 0.0), at);
        for x in [f64::MAX, f64::INFINITY, f64::NAN] {
            let mut escapes = Escapes {
                list: list.clone(),
                ..Escapes::default()
            };
            escapes.list[1].end = DVec2::new(x, x);
            escapes.index(1.0, 3, None);
            assert_eq!(escapes.strikes_on(at, || other), 1, "{x}");
        }
    }

    #[test]
    fn a_strike_needs_a_pair_beyond_reach_at_the_start() {
        // Two discs 2.5 apart (beyond reaches 1.1 + 1.1), the escapee ends 1.5 from the other.
        let other = moved(1, DVec2::new(2.5, 0.0), DVec2::new(2.5, 0.0));
        let e = moved(0, DVec2::ZERO, DVec2::new(1.0, 0.0));
        assert!(e.strikes(&other, None));
        // Within reach at the start: a candidate the step solved, not a strike.
        let near = moved(1, DVec2::new(2.1, 0.0), DVec2::new(2.5, 0.0));
        assert!(!e.strikes(&near, None));
        // Touching within the tolerance is no strike; a particle never strikes itself.
        let touching = moved(1, DVec2::new(3.0, 0.0), DVec2::new(2.999, 0.0));
        assert!(!e.strikes(&touching, None));
        assert!(!e.strikes(&moved(0, DVec2::ZERO, DVec2::new(1.0, 0.0)), None));
    }
}
