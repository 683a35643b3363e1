//! Cell lists by counting sort: the one way the engine groups particles by a cell number (the
//! grid's cells, the hash's buckets, the storage order along space).

use rayon::prelude::*;

/// Makes each count the sum of the counts up to it (itself included); returns the last sum
/// (0 when there are none). The counting sorts' and the work lists' index's step from counts
/// to places. (The sum is kept in a register: read back from the count before, each add
/// waited on the store before it, which took the index 3.3 ms a step in issue 14's gas.)
pub(crate) fn running_sums(counts: &mut [u32]) -> u32 {
    let mut sum = 0;
    for count in counts {
        sum += *count;
        *count = sum;
    }
    sum
}

/// Groups `items` by their key: afterwards `order[starts[c] as usize..starts[c + 1] as usize]`
/// lists the items whose key is `c`, in the order `items` gave them (a stable sort, so ties
/// keep that order). `keys[i]` is item `i`'s key, below `buckets`; `items` yields every index
/// of `keys` once. O(items + buckets); reuses the buffers' memory.
pub(crate) fn counting_sort(
    keys: &[u32],
    buckets: usize,
    items: impl IntoIterator<Item = u32>,
    starts: &mut Vec<u32>,
    order: &mut Vec<u32>,
) {
    starts.clear();
    starts.resize(buckets + 1, 0);
    for &k in keys {
        starts[k as usize + 1] += 1;
    }
    running_sums(starts);
    // Scatter with `starts[c]` as the cursor; afterwards it holds the end of cell c, which is
    // the start of cell c + 1, so shifting by one restores the starts.
    order.resize(keys.len(), 0);
    for i in items {
        let slot = &mut starts[keys[i as usize] as usize];
        order[*slot as usize] = i;
        *slot += 1;
    }
    starts.copy_within(0..buckets, 1);
    starts[0] = 0;
}

/// Groups the items `0..keys.len()` by their key on the thread pool, in `parts` runs: afterwards
/// `order[starts[c] as usize..starts[c + 1] as usize]` lists the items whose key is `c`, in
/// increasing order (a stable sort). `keys[i]` is item `i`'s key; `totals` is scratch. Each run
/// reads every key twice, so the work is O(items * parts + buckets); it reuses the buffers'
/// memory. The grid bins with it, and so does `carom bench`'s bare step.
///
/// Every key must be below `buckets`, and there must be fewer than `u32::MAX` items (both
/// checked in debug builds only: the grid's bin is a hot pass).
pub fn counting_sort_parallel(
    keys: &[u32],
    buckets: usize,
    parts: usize,
    starts: &mut Vec<u32>,
    order: &mut Vec<u32>,
    totals: &mut Vec<u32>,
) {
    debug_assert!(keys.len() < u32::MAX as usize, "{} items", keys.len());
    debug_assert!(
        keys.iter().all(|&k| (k as usize) < buckets),
        "a key beyond {buckets}"
    );
    if buckets <= buckets.div_ceil(parts.max(1)).max(1) {
        return counting_sort(keys, buckets, 0..keys.len() as u32, starts, order);
    }
    let items = || keys.iter().enumerate().map(|(i, &k)| (k, i as u32));
    group_by_key(&items, buckets, parts, true, starts, order, totals);
}

/// Sorts the pairs of `chunks` into `pairs` (replacing what it held): grouped by their first
/// particle (below `n`) by counting (see [`group_by_key`], in `parts` runs, on the thread pool
/// when more than one), then each group sorted, so the result is the pairs sorted whatever the
/// chunks' order or `parts`. `starts` (one per particle, and one) and `totals` (one per run)
/// are scratch.
///
/// Why not a comparison sort: the 10^6 falling discs' search finds 550,000 pairs a step, and
/// `par_sort_unstable` took 9 ms of it on 2 threads; a counting sort passes over the pairs a
/// fixed number of times instead of `log` of their number (see docs/benchmarks.md).
pub(crate) fn sort_pairs_by_counting(
    chunks: &[Vec<(u32, u32)>],
    n: usize,
    parts: usize,
    starts: &mut Vec<u32>,
    totals: &mut Vec<u32>,
    pairs: &mut Vec<(u32, u32)>,
) {
    let items = || chunks.iter().flatten().map(|&pair| (pair.0, pair));
    let parallel = parts > 1;
    group_by_key(&items, n, parts, parallel, starts, pairs, totals);
    debug_assert_eq!(
        pairs.len(),
        chunks.iter().map(Vec::len).sum::<usize>(),
        "a pair's particle >= n"
    );
    crate::broadphase::keep_headroom(pairs);
    let same_first = |a: &(u32, u32), b: &(u32, u32)| a.0 == b.0;
    if parallel {
        pairs
            .par_chunk_by_mut(same_first)
            .for_each(<[_]>::sort_unstable);
    } else {
        pairs
            .chunk_by_mut(same_first)
            .for_each(<[_]>::sort_unstable);
    }
}

/// The counting sort on the thread pool behind [`counting_sort_parallel`] and
/// [`sort_pairs_by_counting`]: groups the `(key, value)` items that `items()` yields (each key
/// below `buckets`) by key into `out`, in the order `items()` gives them within a key, with
/// `out[starts[c] as usize..starts[c + 1] as usize]` key `c`'s values. The keys are cut into
/// `parts` runs of equal length; the task of each run (on the thread pool when `parallel`)
/// reads every item and counts, then places, those whose key falls in its run, so the result
/// does not depend on `parts` or the threads. Each item is read twice per run: worth it for
/// few runs (one per thread) over many items. `totals` is scratch.
fn group_by_key<T, I>(
    items: &(impl Fn() -> I + Sync),
    buckets: usize,
    parts: usize,
    parallel: bool,
    starts: &mut Vec<u32>,
    out: &mut Vec<T>,
    totals: &mut Vec<u32>,
) where
    T: Copy + Default + Send,
    I: Iterator<Item = (u32, T)>,
{
    let width = buckets.div_ceil(parts.max(1)).max(1);
    starts.clear();
    starts.resize(buckets + 1, 0);
    totals.clear();
    totals.resize(buckets.div_ceil(width), 0);
    // each run's counts, summed up within the run: starts[c + 1] ends up the end of cell c
    let count = |(run, (ends, total)): (usize, (&mut [u32], &mut u32))| {
        let first = run * width;
        for (k, _) in items() {
            if let Some(count) = (k as usize)
                .checked_sub(first)
                .and_then(|c| ends.get_mut(c))
            {
                *count += 1;
            }
        }
        *total = running_sums(ends);
    };
    let add = |(ends, &before): (&mut [u32], &u32)| ends.iter_mut().for_each(|end| *end += before);
    if parallel {
        let runs = starts[1..].par_chunks_mut(width).zip(totals.par_iter_mut());
        runs.enumerate().for_each(count);
    } else {
        let runs = starts[1..].chunks_mut(width).zip(totals.iter_mut());
        runs.enumerate().for_each(count);
    }
    let mut before = 0;
    for total in totals.iter_mut() {
        (*total, before) = (before, before + *total);
    }
    if parallel {
        starts[1..]
            .par_chunks_mut(width)
            .zip(totals.par_iter())
            .for_each(add);
    } else {
        starts[1..]
            .chunks_mut(width)
            .zip(totals.iter())
            .for_each(add);
    }
    out.clear();
    out.resize(starts[buckets] as usize, T::default());
    place_runs(items, width, 0, &mut starts[..buckets], out, 0, parallel);
    // (the cursors now hold each cell's end, which is the next cell's start)
    starts.copy_within(0..buckets, 1);
    starts[0] = 0;
}

/// Places the items of the runs from `first_run` on whose cells' starts (`cursors`, advanced
/// as items go in) lie in `out`, which begins at position `base`: the runs split in halves,
/// each half on its own task (when `parallel`) with its own part of `out`.
fn place_runs<T, I>(
    items: &(impl Fn() -> I + Sync),
    width: usize,
    first_run: usize,
    cursors: &mut [u32],
    out: &mut [T],
    base: u32,
    parallel: bool,
) where
    T: Copy + Send,
    I: Iterator<Item = (u32, T)>,
{
    let runs = cursors.len().div_ceil(width);
    if runs <= 1 {
        let first = first_run * width;
        for (k, value) in items() {
            if let Some(cursor) = (k as usize)
                .checked_sub(first)
                .and_then(|c| cursors.get_mut(c))
            {
                out[(*cursor - base) as usize] = value;
                *cursor += 1;
            }
        }
        return;
    }
    let half = runs / 2;
    let (left_cursors, right_cursors) = cursors.split_at_mut(half * width);
    let split = right_cursors[0] - base;
    let (left_out, right_out) = out.split_at_mut(split as usize);
    let (left_first, right_first) = (first_run, first_run + half);
    // (each half moves its own cursors and output in: called once)
    let left = move || {
        let (cursors, out) = (left_cursors, left_out);
        place_runs(items, width, left_first, cursors, out, base, parallel)
    };
    let right = move || {
        let (cursors, out) = (right_cursors, right_out);
        place_runs(
            items,
            width,
            right_first,
            cursors,
            out,
            base + split,
            parallel,
        )
    };
    if parallel {
        rayon::join(left, right);
    } else {
        left();
        right();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// On the thread pool or not, in any number of runs: the same cells, in the same order.
        #[test]
        fn parallel_counting_sort_equals_the_serial_one(
            keys in prop::collection::vec(0u32..40, 0..300),
            extra_buckets in 0usize..20,
            parts in 1usize..9,
        ) {
            let buckets = 40 + extra_buckets;
            let (mut starts, mut order) = (Vec::new(), Vec::new());
            counting_sort(&keys, buckets, 0..keys.len() as u32, &mut starts, &mut order);
            let (mut p_starts, mut p_order, mut totals) = (vec![7], vec![9; 3], Vec::new());
            counting_sort_parallel(&keys, buckets, parts, &mut p_starts, &mut p_order, &mut totals);
            prop_assert_eq!(p_starts, starts);
            prop_assert_eq!(p_order, order);
        }
    }

    proptest! {
        /// In any number of runs, from chunks in any order: the pairs sorted.
        #[test]
        fn counting_sort_of_pairs_sorts_them(
            chunks in prop::collection::vec(
                prop::collection::vec((0u32..50, 0u32..50), 0..40), 0..6),
            extra in 0usize..10,
            parts in 1usize..9,
        ) {
            let n = 50 + extra;
            let mut expected: Vec<(u32, u32)> = chunks.iter().flatten().copied().collect();
            expected.sort_unstable();
            let (mut counts, mut totals, mut pairs) = (vec![3; 7], vec![1], vec![(9, 9)]);
            sort_pairs_by_counting(&chunks, n, parts, &mut counts, &mut totals, &mut pairs);
            prop_assert_eq!(pairs, expected);
        }
    }

    #[test]
    fn groups_by_key_keeping_the_given_order() {
        let keys = [2, 0, 2, 1, 0];
        let (mut starts, mut order) = (Vec::new(), Vec::new());
        counting_sort(&keys, 4, 0..5, &mut starts, &mut order);
        assert_eq!(starts, [0, 2, 3, 5, 5]);
        assert_eq!(order, [1, 4, 3, 0, 2]);
        // items in another order: ties follow it
        counting_sort(&keys, 4, [4, 3, 2, 1, 0], &mut starts, &mut order);
        assert_eq!(order, [4, 1, 3, 2, 0]);
    }
}
