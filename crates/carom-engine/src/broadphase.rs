//! Broad phase: which pairs of particles overlap. Three implementations sit behind one trait:
//! [`brute`](crate::brute) (the lecture's O(n^2) baseline), [`grid`](crate::grid) (the
//! lecture's hash grid) and [`hash`](crate::hash) (the same without a bounding box).
//!
//! Contract shared by both: the output is *every* pair `(i, j)` with `i < j` whose centres are
//! closer than `r_i + r_j`, sorted ascending, and nothing else. Because the set is exact and the
//! order canonical, the solver sees the same contacts whichever broad phase found them, and the
//! trajectories of grid and brute force are bit-identical.

use crate::vector::Vector;
use rayon::prelude::*;
use std::time::Duration;

/// A contact candidate: two particle ids, lower first.
pub type Pair = (u32, u32);

/// Finds overlapping pairs.
pub trait BroadPhase<V: Vector>: Send + Sync {
    /// Replaces `pairs` with every overlapping pair `(i, j)`, `i < j`, sorted ascending.
    fn find_pairs(&mut self, positions: &[V], radii: &[f64], pairs: &mut Vec<Pair>);

    /// [`BroadPhase::find_pairs`], with `scratch` for the working arrays it would otherwise
    /// keep between searches (a cell per particle, a start per cell, the particles in cell
    /// order): a world lends the
    /// spatial sort's, which are free at that point of a step, so the two need memory for one
    /// set of arrays, not two. The same pairs either way.
    fn find_pairs_in(
        &mut self,
        positions: &[V],
        radii: &[f64],
        pairs: &mut Vec<Pair>,
        scratch: &mut CellScratch,
    ) {
        let _ = scratch;
        self.find_pairs(positions, radii, pairs);
    }

    /// [`BroadPhase::find_pairs_in`], keeping only the pairs `keep` holds for (a function of
    /// the pair alone): the same pairs as the search with a retain after it, which is the
    /// default. `kept` is scratch for that retain.
    fn find_pairs_kept_in(
        &mut self,
        positions: &[V],
        radii: &[f64],
        keep: &PairFilter<'_>,
        pairs: &mut Vec<Pair>,
        scratch: &mut CellScratch,
        kept: &mut Vec<usize>,
    ) {
        self.find_pairs_in(positions, radii, pairs, scratch);
        retain_pairs(pairs, kept, positions.len() >= PARALLEL_SEARCH_MIN, keep);
    }

    /// [`BroadPhase::find_pairs_in`] with each radius raised to what its particle would have
    /// at the speed of its fastest partner (see `solver::raise_to_partners` for why): makes
    /// `raised[i]` the largest of `radii[i]` and `raising.radius_at(i, speed(j))` over every
    /// `j` within `radii` of `i`, and `pairs` every pair within `raised`, sorted. By default, a
    /// search, the raise over the pairs it found, and a search again when a radius grew.
    fn find_pairs_raised_in(
        &mut self,
        positions: &[V],
        radii: &[f64],
        raising: &Raising<'_>,
        raised: &mut Vec<f64>,
        pairs: &mut Vec<Pair>,
        scratch: &mut CellScratch,
    ) {
        search_raise_search(self, positions, radii, raising, raised, pairs, scratch);
    }

    /// The time spent binning (laying cells out and filling them) since the last call, for
    /// [`crate::PhaseTimes::bin`]; zero for a search without cells.
    fn take_bin_time(&mut self) -> Duration {
        Duration::ZERO
    }

    /// Short name for reports ("brute", "grid").
    fn name(&self) -> &'static str;

    /// Cells per axis in use (1 on unused axes), as the last search laid them out; `None` when
    /// there is no grid or no search has run yet.
    fn cells(&self) -> Option<[usize; 3]> {
        None
    }
}

/// Which pairs a search keeps (see [`BroadPhase::find_pairs_kept_in`]).
pub type PairFilter<'a> = dyn Fn(Pair) -> bool + Sync + 'a;

/// Working arrays that a search by cells and the spatial sort of a world's storage both need at
/// different times of a step, so one set serves both (see [`BroadPhase::find_pairs_in`]): the
/// layout of a counting sort by cell.
#[derive(Debug, Default)]
pub struct CellScratch {
    /// A cell number per particle.
    pub(crate) keys: Vec<u32>,
    /// Where each cell's run starts.
    pub(crate) starts: Vec<u32>,
    /// The particles in cell order.
    pub(crate) order: Vec<u32>,
}

/// How a particle's radius grows with the speed of a partner that may push it (see
/// [`BroadPhase::find_pairs_raised_in`]).
#[derive(Clone, Copy)]
pub struct Raising<'a> {
    /// Each particle's speed (length / time, >= 0). (An array, not a function: the search
    /// reads a partner's speed for every partner it finds.)
    pub speed: &'a [f64],
    /// Particle `i`'s radius were it moving at the given speed; nondecreasing in the speed.
    pub radius_at: &'a (dyn Fn(usize, f64) -> f64 + Sync),
    /// Particles that have not moved since an earlier search, and what it found among them: a
    /// search may take their pairs from there instead of looking (the same pairs either way).
    pub still: Still<'a>,
}

/// Particles that stand where they stood at an earlier search whose radii were no smaller than
/// now, and the pairs of two of them it found (see [`Raising::still`]). Those pairs are a
/// superset of the pairs of two of them within the radii now (positions the same, radii no
/// larger: `is_overlapping` grows with either radius in floating point too), so a search may
/// test them again instead of looking around the still particles: a sleeping pile's part of a
/// step is then a pass over its old pairs, not a walk through its cells.
#[derive(Clone, Copy, Debug, Default)]
pub struct Still<'a> {
    /// Per particle, whether it is still; empty when none is.
    pub flags: &'a [bool],
    /// Every pair of two particles still now that the earlier search found (and maybe more),
    /// sorted.
    pub pairs: &'a [Pair],
}

impl Still<'_> {
    /// Whether both particles of `pair` are still.
    #[inline]
    pub fn both(&self, (i, j): Pair) -> bool {
        !self.flags.is_empty() && self.flags[i as usize] & self.flags[j as usize]
    }
}

impl std::fmt::Debug for Raising<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Raising")
    }
}

/// [`BroadPhase::find_pairs_raised_in`] as a search, the raise over the pairs it found (see
/// [`raise_to_partners`]) and, when a radius grew, a search again.
pub(crate) fn search_raise_search<V: Vector, B: BroadPhase<V> + ?Sized>(
    broad_phase: &mut B,
    positions: &[V],
    radii: &[f64],
    raising: &Raising<'_>,
    raised: &mut Vec<f64>,
    pairs: &mut Vec<Pair>,
    scratch: &mut CellScratch,
) {
    broad_phase.find_pairs_in(positions, radii, pairs, scratch);
    raised.clear();
    raised.extend_from_slice(radii);
    let speed = |j: usize| raising.speed[j];
    if raise_to_partners(raised, pairs, speed, raising.radius_at, |_| true) {
        broad_phase.find_pairs_in(positions, raised, pairs, scratch);
    }
}

/// Raises `raised[i]` to `radius_at(i, speed(j))` and `raised[j]` to `radius_at(j, speed(i))`
/// for every pair `(i, j)` in `pairs`, for the particles `own` says are the caller's; returns
/// whether any grew. The largest wins whatever the order (`radius_at` grows with the speed),
/// so the result is the same for every order of the pairs.
pub(crate) fn raise_to_partners(
    raised: &mut [f64],
    pairs: &[Pair],
    speed: impl Fn(usize) -> f64,
    radius_at: impl Fn(usize, f64) -> f64,
    own: impl Fn(usize) -> bool,
) -> bool {
    let mut grew = false;
    let mut raise = |i: usize, partner: usize| {
        if own(i) {
            let r = radius_at(i, speed(partner));
            if r > raised[i] {
                raised[i] = r;
                grew = true;
            }
        }
    };
    for &(i, j) in pairs {
        raise(i as usize, j as usize);
        raise(j as usize, i as usize);
    }
    grew
}

/// Which broad phase a world uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BroadPhaseKind {
    /// All pairs: O(n^2).
    Brute,
    /// The lecture's uniform grid over the domain (cells per axis from
    /// [`crate::WorldConfig::grid_cells`], or derived from the largest radius).
    #[default]
    Grid,
    /// An unbounded spatial hash: for scenes without walls, where particles roam anywhere.
    Hash,
}

/// Particles per work unit in parallel pair searches. Fixed (not derived from the thread count)
/// so that the work split, and therefore every intermediate result, is the same for any number
/// of threads.
pub(crate) const CHUNK: usize = 1024;

/// Below this many particles every phase but the pair search runs on the calling thread:
/// handing out work to the pool costs more than it saves (the solver makes up to a hundred
/// short parallel calls per step, and on a machine whose idle cores halt, a sleeping worker
/// wakes later than a 5000-disc phase ends). Serial and parallel runs give the same bits
/// either way. Measured on 2 cores (docs/benchmarks.md, thirty-seventh sitting), 2 threads,
/// this threshold against 4096: the lecture's 5000 discs in its grids 0.85-0.92x the time, the
/// lecture pile 0.94-0.98x; 10^4 discs about even (a pile 0.99-1.11x serial), and from 2 x 10^4
/// on serial phases cost 1.04-1.22x.
pub const PARALLEL_MIN: usize = 8192;

/// The pair search, one big parallel call per step, pays off from this many particles.
pub const PARALLEL_SEARCH_MIN: usize = 2048;

/// Runs `search(i, out)` for every particle, in parallel over fixed chunks, each chunk
/// writing into its own reused buffer, then concatenates the buffers in chunk order into
/// `pairs`. `search` must push pairs `(i, j)` with `j > i`; each chunk is sorted, so the
/// result is globally sorted.
pub(crate) fn collect_pairs<F>(
    n: usize,
    buffers: &mut Vec<Vec<Pair>>,
    pairs: &mut Vec<Pair>,
    search: F,
) where
    F: Fn(usize, &mut Vec<Pair>) + Sync,
{
    let chunks = n.div_ceil(CHUNK);
    if buffers.len() < chunks {
        buffers.resize_with(chunks, Vec::new);
    }
    let work = |(c, out): (usize, &mut Vec<Pair>)| {
        out.clear();
        let end = ((c + 1) * CHUNK).min(n);
        for i in c * CHUNK..end {
            let first = out.len();
            search(i, out);
            // (a chunk's pairs come in order of `i`; only each particle's few partners, found
            // cell by cell, need sorting. A quicksort of the whole chunk was 1.5 % of the samples
            // of `perf record` on the bench's 10^6 gas.)
            out[first..].sort_unstable();
        }
        keep_headroom(out);
    };
    if n >= PARALLEL_SEARCH_MIN {
        buffers[..chunks].par_iter_mut().enumerate().for_each(work);
    } else {
        buffers[..chunks].iter_mut().enumerate().for_each(work);
    }
    gather(&buffers[..chunks], pairs);
}

/// Replaces `into` with the chunk buffers `chunks`, one after another (the per-chunk results
/// of a parallel pass, in chunk order: the same whatever the threads).
pub(crate) fn gather<T: Copy>(chunks: &[Vec<T>], into: &mut Vec<T>) {
    into.clear();
    for chunk in chunks {
        into.extend_from_slice(chunk);
    }
    keep_headroom(into);
}

/// Pairs per parallel task in [`retain_pairs`].
const RETAIN_CHUNK: usize = 16_384;

/// Keeps the pairs for which `keep` holds, in order, on the thread pool when `parallel`: each
/// fixed chunk is compacted in place, then the chunks are moved together, so the result is
/// the same for any number of threads. `kept` is scratch (one count per chunk), kept by the
/// caller so that a step does not allocate.
pub(crate) fn retain_pairs(
    pairs: &mut Vec<Pair>,
    kept: &mut Vec<usize>,
    parallel: bool,
    keep: &PairFilter<'_>,
) {
    if !parallel {
        pairs.retain(|&pair| keep(pair));
        return;
    }
    let compact = |(chunk, count): (&mut [Pair], &mut usize)| {
        let mut to = 0;
        for k in 0..chunk.len() {
            let pair = chunk[k];
            chunk[to] = pair;
            to += keep(pair) as usize;
        }
        *count = to;
    };
    kept.resize(pairs.len().div_ceil(RETAIN_CHUNK), 0);
    keep_headroom(kept);
    (pairs.par_chunks_mut(RETAIN_CHUNK).zip(kept.par_iter_mut())).for_each(compact);
    let mut to = 0;
    for (c, &count) in kept.iter().enumerate() {
        let from = c * RETAIN_CHUNK;
        pairs.copy_within(from..from + count, to);
        to += count;
    }
    pairs.truncate(to);
}

/// Keeps the pairs of `out[first..]` that `keep` holds for, in order, without branching on
/// the test (whose result is unpredictable: see [`crate::grid::scan_run`]).
#[inline]
pub(crate) fn keep_tail(out: &mut Vec<Pair>, first: usize, keep: &PairFilter<'_>) {
    let mut to = first;
    for k in first..out.len() {
        let pair = out[k];
        out[to] = pair;
        to += keep(pair) as usize;
    }
    out.truncate(to);
}

/// Grows `v`'s capacity to half again its length (and at least [`SPARE`] more) once it is
/// three quarters full: contact counts fluctuate from step to step, and a buffer sized to the
/// largest count seen so far would reallocate at every new maximum, long after warm-up. (The
/// spare is for short buffers, whose counts fluctuate most: a chunk of a dilute gas keeps a
/// few dozen pairs.)
pub(crate) fn keep_headroom<T>(v: &mut Vec<T>) {
    if v.len() * 4 > v.capacity() * 3 || v.capacity() - v.len() < SPARE {
        v.reserve(v.len() / 2 + SPARE);
    }
}

/// The least spare room [`keep_headroom`] leaves, in elements.
const SPARE: usize = 64;

#[cfg(test)]
mod tests {
    use super::{keep_tail, retain_pairs, Pair};

    /// Chunked in parallel or on one thread, the same pairs in the same order as `retain`.
    #[test]
    fn retaining_pairs_in_chunks_keeps_the_order() {
        let mut next = crate::testing::uniform(3);
        let all: Vec<Pair> = (0..100_000u32)
            .map(|i| (i, i + 1 + (next() * 9.0) as u32))
            .collect();
        let keep = |(i, j): Pair| (i * 7 + j) % 5 < 2;
        let expected: Vec<Pair> = all.iter().copied().filter(|&p| keep(p)).collect();
        let mut kept = Vec::new();
        for parallel in [false, true] {
            let mut pairs = all.clone();
            retain_pairs(&mut pairs, &mut kept, parallel, &keep);
            assert_eq!(pairs, expected, "parallel {parallel}");
        }
        let mut out = all[..1000].to_vec();
        keep_tail(&mut out, 400, &keep);
        let tail = all[400..1000].iter().copied().filter(|&p| keep(p));
        assert_eq!(
            out,
            all[..400].iter().copied().chain(tail).collect::<Vec<_>>()
        );
    }
}
