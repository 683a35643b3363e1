//! The search with radii raised to the partners' speeds (see
//! [`BroadPhase::find_pairs_raised_in`](crate::broadphase::BroadPhase::find_pairs_raised_in)).
//!
//! When the cells hold every pair to neighbouring cells, the first search is the search from
//! one side (see [`super::half`]), which finds each pair once, and one pass over its pairs
//! takes each particle's fastest partner (10^6 falling discs, 2 threads: 4.7 ms a step, and
//! the search 27.6 ms against 36-42 by particle). Otherwise the first search visits every
//! particle's neighbours on both sides (it keeps a pair from its lower particle only), so it
//! raises each particle's radius as it goes, in parallel. Then the particles whose radius grew
//! search again in the same buckets.
//!
//! `is_overlapping` grows with either radius in floating point too (a sum, a square), so the
//! raised search finds every pair the first found, and each pair it adds has a particle whose
//! radius grew: scanning from those finds them all. A pair of two grown particles is taken from
//! the lower one. The first search's test is made again, with the same operands in the same
//! order up to sign, for the same bits, so no pair is added twice.

use super::{for_each_near, largest, Grid};
use crate::broadphase::{gather, keep_headroom, Pair, Raising, Still, CHUNK, PARALLEL_SEARCH_MIN};
use crate::response::is_overlapping;
use crate::vector::Vector;
use rayon::prelude::*;

impl<V: Vector> Grid<V> {
    /// Makes `raised` and `pairs` what a search with `radii`, the raise over its pairs and a
    /// search with the raised radii make (see
    /// [`BroadPhase::find_pairs_raised_in`](crate::broadphase::BroadPhase::find_pairs_raised_in)):
    /// the first search (from one side, then a pass over its pairs; or by particle, visiting
    /// every partner on both sides) raises each particle's radius to its fastest partner's,
    /// then the particles whose radius grew search again (see [`Grid::add_raised_pairs`]).
    pub(super) fn find_raised_pairs(
        &mut self,
        positions: &[V],
        radii: &[f64],
        raising: &Raising<'_>,
        raised: &mut Vec<f64>,
        pairs: &mut Vec<Pair>,
    ) {
        let n = positions.len();
        let max_radius = self.bin(positions, radii);
        let layout = self.layout;
        let Raising {
            speed,
            radius_at,
            still,
        } = *raising;
        if self.searches_from_one_side(max_radius) {
            if still.flags.is_empty() {
                self.search_from_one_side(positions, radii, max_radius, None, pairs);
            } else {
                let keep = |pair: Pair| !still.both(pair);
                self.walk_cells(
                    (positions, radii),
                    max_radius,
                    Some(&keep),
                    still.flags,
                    pairs,
                    |i, j| is_overlapping(positions[i], positions[j], radii[i], radii[j]),
                    None,
                );
                Self::add_still_pairs(positions, radii, &still, pairs);
            }
            raise_over_pairs(raised, radii, pairs, raising, n >= PARALLEL_SEARCH_MIN);
            return self.add_raised_pairs(positions, radii, raised, pairs);
        }
        let (cell_start, ids) = (&self.cell_start, &self.ids);
        let chunks = n.div_ceil(CHUNK);
        if self.buffers.len() < chunks {
            self.buffers.resize_with(chunks, Vec::new);
        }
        raised.resize(n, 0.0);
        let search = |(c, (out, raised)): (usize, (&mut Vec<Pair>, &mut [f64]))| {
            out.clear();
            for (k, raised) in raised.iter_mut().enumerate() {
                let i = c * CHUNK + k;
                let (xi, ri) = (positions[i], radii[i]);
                let first = out.len();
                let mut fastest: Option<f64> = None;
                // (the pair's test from either side: `is_overlapping` is symmetric, bit for bit)
                let partner = |j: usize| (j != i) & is_overlapping(xi, positions[j], ri, radii[j]);
                let hit = |j: usize| {
                    let s = speed[j];
                    fastest = Some(fastest.map_or(s, |f: f64| f.max(s)));
                    if j > i {
                        out.push((i as u32, j as u32));
                    }
                };
                for_each_near(&layout, cell_start, ids, xi, ri + max_radius, partner, hit);
                out[first..].sort_unstable();
                *raised = match fastest {
                    Some(s) => ri.max(radius_at(i, s)),
                    None => ri,
                };
            }
            keep_headroom(out);
        };
        if n >= PARALLEL_SEARCH_MIN {
            (self.buffers[..chunks].par_iter_mut())
                .zip(raised.par_chunks_mut(CHUNK))
                .enumerate()
                .for_each(search);
        } else {
            (self.buffers[..chunks].iter_mut())
                .zip(raised.chunks_mut(CHUNK))
                .enumerate()
                .for_each(search);
        }
        gather(&self.buffers[..chunks], pairs);
        self.add_raised_pairs(positions, radii, raised, pairs);
    }

    /// Adds to `pairs` (sorted) the pairs of two `still` particles within `radii`, from the
    /// pairs an earlier search found among them (see [`Still`]), keeping `pairs` sorted.
    /// (Merged straight from that list, each tested twice, instead of through a copy: a copy
    /// of a sleeping pile's pairs cost 8 bytes a pair at the peak.)
    fn add_still_pairs(positions: &[V], radii: &[f64], still: &Still<'_>, pairs: &mut Vec<Pair>) {
        // (the walk's test, with the same operands: `is_overlapping` is symmetric, bit for bit)
        let within = |(i, j): Pair| {
            let (a, b) = (i as usize, j as usize);
            still.both((i, j)) && is_overlapping(positions[a], positions[b], radii[a], radii[b])
        };
        merge_kept_into(pairs, still.pairs, within);
    }

    /// Adds to `pairs` (sorted, found with `radii` in the current buckets) the pairs within
    /// `raised`, keeping them sorted.
    pub(super) fn add_raised_pairs(
        &mut self,
        positions: &[V],
        radii: &[f64],
        raised: &[f64],
        pairs: &mut Vec<Pair>,
    ) {
        let n = positions.len();
        let max_raised = largest(raised);
        let layout = self.layout;
        let (cell_start, ids) = (&self.cell_start, &self.ids);
        let grown = |k: usize| raised[k] > radii[k];
        let scan = |i: usize, out: &mut Vec<Pair>| {
            let (pi, ri) = (positions[i], raised[i]);
            let added = |j: usize| {
                // (a pair of two grown particles is the lower one's)
                let theirs = (j == i) | ((j < i) & grown(j));
                let pj = positions[j];
                let added = is_overlapping(pi, pj, ri, raised[j])
                    & !is_overlapping(pi, pj, radii[i], radii[j]);
                added & !theirs
            };
            let hit = |j: usize| out.push((i.min(j) as u32, i.max(j) as u32));
            for_each_near(&layout, cell_start, ids, pi, ri + max_raised, added, hit);
        };
        let chunks = n.div_ceil(CHUNK);
        if self.buffers.len() < chunks {
            self.buffers.resize_with(chunks, Vec::new);
        }
        let work = |(c, out): (usize, &mut Vec<Pair>)| {
            out.clear();
            for i in (c * CHUNK..((c + 1) * CHUNK).min(n)).filter(|&i| grown(i)) {
                scan(i, out);
            }
            keep_headroom(out);
        };
        if n >= PARALLEL_SEARCH_MIN {
            self.buffers[..chunks]
                .par_iter_mut()
                .enumerate()
                .for_each(work);
        } else {
            self.buffers[..chunks].iter_mut().enumerate().for_each(work);
        }
        let extra = &mut self.raised_extra;
        gather(&self.buffers[..chunks], extra);
        if extra.is_empty() {
            return;
        }
        extra.sort_unstable();
        merge_kept_into(pairs, extra, |_| true);
    }
}

/// Makes `raised[i]` the largest of `radii[i]` and `radius_at(i, speed(j))` over the partners
/// `j` of `i` in `pairs`: the fastest partner's speed first, in one pass over the pairs (which
/// a search from one side finds once each), then its radius. The same bits as taking the
/// largest radius: `radius_at` does not fall with the speed, so it keeps the largest speed's
/// radius the largest, and a maximum is the same in any order.
///
/// The same result as [`crate::broadphase::raise_to_partners`] on a copy of `radii`, which the
/// other searches and a rank of a split run use; this form is the grid's because it calls
/// `radius_at` (a `dyn` closure) once a particle instead of twice a pair, on the thread pool,
/// and keeps the fastest speeds in `raised` itself instead of in an array of their own (8 bytes
/// a particle at the peak).
fn raise_over_pairs(
    raised: &mut Vec<f64>,
    radii: &[f64],
    pairs: &[Pair],
    raising: &Raising<'_>,
    parallel: bool,
) {
    let Raising {
        speed, radius_at, ..
    } = *raising;
    // (first the fastest partner's speed, -1 for none: speeds are never negative)
    raised.clear();
    raised.resize(radii.len(), -1.0);
    for &(i, j) in pairs {
        let (i, j) = (i as usize, j as usize);
        raised[i] = raised[i].max(speed[j]);
        raised[j] = raised[j].max(speed[i]);
    }
    let radius = |(i, (fastest, &r)): (usize, (&mut f64, &f64))| {
        *fastest = if *fastest >= 0.0 {
            r.max(radius_at(i, *fastest))
        } else {
            r
        };
    };
    if parallel {
        let each = raised.par_iter_mut().zip(radii.par_iter());
        each.enumerate().for_each(radius);
    } else {
        raised.iter_mut().zip(radii).enumerate().for_each(radius);
    }
}

/// Merges the pairs of sorted `extra` that `keep` holds for into sorted `pairs` (no pair in
/// both), from the back, in place.
pub(super) fn merge_kept_into(pairs: &mut Vec<Pair>, extra: &[Pair], keep: impl Fn(Pair) -> bool) {
    let add = extra.iter().filter(|&&pair| keep(pair)).count();
    if add == 0 {
        return;
    }
    let old = pairs.len();
    pairs.resize(old + add, (0, 0));
    keep_headroom(pairs);
    let mut from_back = extra.iter().rev().copied().filter(|&pair| keep(pair));
    let mut next = from_back.next();
    // (`a`: how many of the old pairs are still to place)
    let mut a = old;
    for k in (0..old + add).rev() {
        let Some(pair) = next else { break };
        if a > 0 && pairs[a - 1] > pair {
            pairs[k] = pairs[a - 1];
            a -= 1;
        } else {
            pairs[k] = pair;
            next = from_back.next();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::merge_kept_into;
    use crate::broadphase::{BroadPhase, CellScratch, Raising, Still};
    use crate::brute::BruteForce;
    use crate::domain::Aabb;
    use crate::grid::Grid;
    use glam::DVec2;

    /// The grid's search with raised radii finds the same pairs and raises the radii to the
    /// same bits as a search, the raise over its pairs and a second search (the default, here
    /// brute force's), for every cell size, with mixed radii and speeds.
    #[test]
    fn a_raised_search_finds_what_searching_raising_and_searching_again_finds() {
        let mut next = crate::testing::uniform(99);
        let n = 3000;
        let pos: Vec<DVec2> = (0..n)
            .map(|_| DVec2::new(next() * 80.0 - 40.0, next() * 80.0 - 40.0))
            .collect();
        let radii: Vec<f64> = (0..n).map(|i| if i % 9 == 0 { 2.0 } else { 0.6 }).collect();
        let speeds: Vec<f64> = (0..n).map(|_| next() * next() * 30.0).collect();
        let radius_at = |i: usize, s: f64| radii[i] + (s * 0.02).min(radii[i]);
        let raising = Raising {
            speed: &speeds,
            radius_at: &radius_at,
            still: Default::default(),
        };
        let (mut expected, mut expected_raised) = (Vec::new(), Vec::new());
        let mut scratch = CellScratch::default();
        BruteForce::new().find_pairs_raised_in(
            &pos,
            &radii,
            &raising,
            &mut expected_raised,
            &mut expected,
            &mut scratch,
        );
        let mut first = Vec::new();
        BruteForce::new().find_pairs(&pos, &radii, &mut first);
        assert!(expected.len() > first.len(), "the raise adds pairs");
        let mut search = |grid: &mut Grid<DVec2>| {
            let (mut pairs, mut raised) = (Vec::new(), Vec::new());
            grid.find_pairs_raised_in(
                &pos,
                &radii,
                &raising,
                &mut raised,
                &mut pairs,
                &mut scratch,
            );
            (pairs, raised)
        };
        let expected = (expected, expected_raised);
        // (a domain that leaves most particles outside: the grid hands them to its hash)
        let outside = Aabb::new(DVec2::splat(-10.0), DVec2::splat(10.0)).unwrap();
        let mut escaped = Grid::new(Some(outside), None).unwrap();
        assert_eq!(search(&mut escaped), expected, "most particles outside");
        assert!(BroadPhase::<DVec2>::name(&escaped).contains("hash"));
        let domain = Aabb::new(DVec2::splat(-40.0), DVec2::splat(40.0)).unwrap();
        for cells in [None, Some([5, 7]), Some([60, 60]), Some([200, 200])] {
            let mut grid = Grid::new(Some(domain), cells.as_ref().map(|c| &c[..])).unwrap();
            assert_eq!(search(&mut grid), expected, "cells {cells:?}");
        }
    }

    /// With some particles still (see [`crate::broadphase::Still`]) and their pairs taken from
    /// a wider search, the grid finds the same pairs and raises the radii to the same bits as
    /// a search that looks everywhere, in 2D and 3D; and it takes those pairs from the list
    /// (a list missing one loses it: the walk does not look among still particles).
    #[test]
    fn still_particles_pairs_come_from_the_earlier_search_with_the_same_result() {
        fn check<V: crate::vector::Vector>(at: impl Fn(&mut dyn FnMut() -> f64) -> V, side: f64) {
            let mut next = crate::testing::uniform(7);
            let n = 4000;
            let pos: Vec<V> = (0..n).map(|_| at(&mut next)).collect();
            let radii: Vec<f64> = (0..n)
                .map(|i| if i % 13 == 0 { 1.2 } else { 0.8 })
                .collect();
            // (about two thirds still, at rest: speed 0)
            let flags: Vec<bool> = (0..n).map(|_| next() < 0.67).collect();
            let speeds: Vec<f64> = (0..n)
                .map(|i| if flags[i] { 0.0 } else { next() * 20.0 })
                .collect();
            let radius_at = |i: usize, s: f64| radii[i] + (s * 0.02).min(radii[i]);
            let plain = Raising {
                speed: &speeds,
                radius_at: &radius_at,
                still: Default::default(),
            };
            // (a domain not a whole number of diameters wide: cells wider than one, which the
            // search from one side needs)
            let corner = |c: f64| V::from_slice(&[c; 3][..V::DIM]);
            let domain = Aabb::new(corner(-side), corner(side)).unwrap();
            let mut scratch = CellScratch::default();
            let mut search = |raising: &Raising<'_>| {
                let mut grid = Grid::new(Some(domain), None).unwrap();
                let (mut pairs, mut raised) = (Vec::new(), Vec::new());
                let (r, s) = (&radii[..], &mut scratch);
                grid.find_pairs_raised_in(&pos, r, raising, &mut raised, &mut pairs, s);
                (pairs, raised)
            };
            let expected = search(&plain);
            // the earlier search's pairs among the still: with wider radii, so more of them
            let wider: Vec<f64> = radii.iter().map(|r| r * 1.1).collect();
            let mut earlier = Vec::new();
            BruteForce::new().find_pairs(&pos, &wider, &mut earlier);
            earlier.retain(|&(i, j)| flags[i as usize] && flags[j as usize]);
            let still = Raising {
                still: Still {
                    flags: &flags,
                    pairs: &earlier,
                },
                ..plain
            };
            let found = search(&still);
            assert_eq!(found, expected);
            // (a pair within the radii: the raise cannot add it back)
            let mut within = Vec::new();
            BruteForce::new().find_pairs(&pos, &radii, &mut within);
            within.retain(|&(i, j)| flags[i as usize] && flags[j as usize]);
            assert!(within.len() > 100, "pairs among the still");
            let lost = within[within.len() / 2];
            earlier.retain(|&pair| pair != lost);
            let missing = Raising {
                still: Still {
                    flags: &flags,
                    pairs: &earlier,
                },
                ..plain
            };
            let (pairs, _) = search(&missing);
            assert!(!pairs.contains(&lost) && pairs.len() == expected.0.len() - 1);
        }
        check(
            |next| DVec2::new(next() * 60.0 - 30.0, next() * 60.0 - 30.0),
            30.5,
        );
        check(
            |next| {
                glam::DVec3::new(
                    next() * 24.0 - 12.0,
                    next() * 24.0 - 12.0,
                    next() * 24.0 - 12.0,
                )
            },
            12.5,
        );
    }

    #[test]
    fn merging_keeps_both_lists_in_order() {
        let mut pairs = vec![(0, 3), (1, 2), (4, 9)];
        merge_kept_into(&mut pairs, &[(0, 1), (2, 5), (7, 8)], |_| true);
        assert_eq!(pairs, [(0, 1), (0, 3), (1, 2), (2, 5), (4, 9), (7, 8)]);
        let mut pairs = vec![(5, 6)];
        merge_kept_into(&mut pairs, &[(0, 1), (1, 2)], |_| true);
        assert_eq!(pairs, [(0, 1), (1, 2), (5, 6)]);
        // only the kept ones, wherever they fall; none kept leaves the list as it was
        let mut pairs = vec![(1, 4), (3, 5)];
        let extra = [(0, 2), (1, 3), (2, 9), (4, 6), (7, 8)];
        merge_kept_into(&mut pairs, &extra, |(i, _)| i % 2 == 0);
        assert_eq!(pairs, [(0, 2), (1, 4), (2, 9), (3, 5), (4, 6)]);
        merge_kept_into(&mut pairs, &[(9, 10)], |_| false);
        assert_eq!(pairs.len(), 5);
    }
}
