//! Cell lists by counting sort: the one way the engine groups particles by a cell number (the
//! grid's cells, the hash's buckets, the storage order along space).

use rayon::prelude::*;

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
    for c in 0..buckets {
        starts[c + 1] += starts[c];
    }
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

/// [`counting_sort`] of the items `0..keys.len()` on the thread pool, into the same `starts`
/// and `order`. The buckets are cut into `parts` runs of equal length; the task of each run
/// reads every key and counts, then places, the items whose key falls in its run, in item
/// order, so the result does not depend on `parts` or the threads. Each key is read twice per
/// run: worth it for few runs (one per thread) over many items. `totals` is scratch.
pub(crate) fn counting_sort_parallel(
    keys: &[u32],
    buckets: usize,
    parts: usize,
    starts: &mut Vec<u32>,
    order: &mut Vec<u32>,
    totals: &mut Vec<u32>,
) {
    let width = buckets.div_ceil(parts.max(1)).max(1);
    if buckets <= width {
        return counting_sort(keys, buckets, 0..keys.len() as u32, starts, order);
    }
    starts.clear();
    starts.resize(buckets + 1, 0);
    totals.clear();
    totals.resize(buckets.div_ceil(width), 0);
    // each run's counts, summed up within the run: starts[c + 1] ends up the end of cell c
    starts[1..]
        .par_chunks_mut(width)
        .zip(totals.par_iter_mut())
        .enumerate()
        .for_each(|(run, (ends, total))| {
            let first = run * width;
            for &k in keys {
                if let Some(count) = (k as usize)
                    .checked_sub(first)
                    .and_then(|c| ends.get_mut(c))
                {
                    *count += 1;
                }
            }
            let mut sum = 0;
            for end in ends.iter_mut() {
                sum += *end;
                *end = sum;
            }
            *total = sum;
        });
    let mut before = 0;
    for total in totals.iter_mut() {
        (*total, before) = (before, before + *total);
    }
    starts[1..]
        .par_chunks_mut(width)
        .zip(totals.par_iter())
        .for_each(|(ends, &before)| ends.iter_mut().for_each(|end| *end += before));
    order.resize(keys.len(), 0);
    place_runs(keys, width, 0, &mut starts[..buckets], order, 0);
    // (the cursors now hold each cell's end, which is the next cell's start)
    starts.copy_within(0..buckets, 1);
    starts[0] = 0;
}

/// Places the items of the runs from `first_run` on whose cells' starts (`cursors`, advanced
/// as items go in) lie in `order`, which begins at item position `base`: the runs split in
/// halves, each half on its own task with its own part of `order`.
fn place_runs(
    keys: &[u32],
    width: usize,
    first_run: usize,
    cursors: &mut [u32],
    order: &mut [u32],
    base: u32,
) {
    let runs = cursors.len().div_ceil(width);
    if runs <= 1 {
        let first = first_run * width;
        for (i, &k) in keys.iter().enumerate() {
            if let Some(cursor) = (k as usize)
                .checked_sub(first)
                .and_then(|c| cursors.get_mut(c))
            {
                order[(*cursor - base) as usize] = i as u32;
                *cursor += 1;
            }
        }
        return;
    }
    let half = runs / 2;
    let (left, right) = cursors.split_at_mut(half * width);
    let split = right[0] - base;
    let (left_order, right_order) = order.split_at_mut(split as usize);
    rayon::join(
        || place_runs(keys, width, first_run, left, left_order, base),
        || {
            place_runs(
                keys,
                width,
                first_run + half,
                right,
                right_order,
                base + split,
            )
        },
    );
}

/// Sorts the pairs of `chunks` into `pairs` (replacing what it held): grouped by their first
/// particle (below `n`) by counting, then each group sorted, so the result is `pairs` sorted
/// whatever the chunks' order. The particles are cut into `parts` runs of equal length, each
/// on its own task, which reads every chunk to count and then place its run's pairs: the
/// result does not depend on `parts`. `counts` (one per particle) and `totals` (one per run)
/// are scratch.
///
/// Why not a comparison sort: the 10^6 falling discs' search finds 550,000 pairs a step, and
/// `par_sort_unstable` took 9 ms of it on 2 threads; a counting sort passes over the pairs a
/// fixed number of times instead of `log` of their number (see docs/benchmarks.md).
pub(crate) fn sort_pairs_by_counting(
    chunks: &[Vec<(u32, u32)>],
    n: usize,
    parts: usize,
    counts: &mut Vec<u32>,
    totals: &mut Vec<u32>,
    pairs: &mut Vec<(u32, u32)>,
) {
    let width = n.div_ceil(parts.max(1)).max(1);
    counts.clear();
    counts.resize(n, 0);
    totals.clear();
    totals.resize(n.div_ceil(width), 0);
    // each run's counts, then their sums before each particle within the run
    let count = |(run, (starts, total)): (usize, (&mut [u32], &mut u32))| {
        let first = run * width;
        for &(i, _) in chunks.iter().flatten() {
            if let Some(c) = (i as usize)
                .checked_sub(first)
                .and_then(|c| starts.get_mut(c))
            {
                *c += 1;
            }
        }
        let mut sum = 0;
        for start in starts.iter_mut() {
            (*start, sum) = (sum, sum + *start);
        }
        *total = sum;
    };
    let parallel = parts > 1;
    if parallel {
        counts
            .par_chunks_mut(width)
            .zip(totals.par_iter_mut())
            .enumerate()
            .for_each(count);
    } else {
        counts
            .chunks_mut(width)
            .zip(totals.iter_mut())
            .enumerate()
            .for_each(count);
    }
    let all = totals.iter().sum::<u32>() as usize;
    debug_assert_eq!(
        all,
        chunks.iter().map(Vec::len).sum::<usize>(),
        "a pair's particle >= n"
    );
    pairs.clear();
    pairs.resize(all, (0, 0));
    crate::broadphase::keep_headroom(pairs);
    place_pair_runs(chunks, width, 0, counts, totals, pairs, parallel);
}

/// Places the pairs of the runs from `first_run` (their starts within the run in `cursors`,
/// their counts in `totals`) into `out`, which holds exactly those runs' pairs, then sorts each
/// particle's group: the runs split in halves, each half on its own task when `parallel`.
fn place_pair_runs(
    chunks: &[Vec<(u32, u32)>],
    width: usize,
    first_run: usize,
    cursors: &mut [u32],
    totals: &[u32],
    out: &mut [(u32, u32)],
    parallel: bool,
) {
    if totals.len() > 1 {
        let half = totals.len() / 2;
        let (left_cursors, right_cursors) = cursors.split_at_mut(half * width);
        let (left_out, right_out) = out.split_at_mut(totals[..half].iter().sum::<u32>() as usize);
        let (left_totals, right_totals) = totals.split_at(half);
        let (left_first, right_first) = (first_run, first_run + half);
        let left = move || {
            let (cursors, totals, out) = (left_cursors, left_totals, left_out);
            place_pair_runs(chunks, width, left_first, cursors, totals, out, parallel)
        };
        let right = move || {
            let (cursors, totals, out) = (right_cursors, right_totals, right_out);
            place_pair_runs(chunks, width, right_first, cursors, totals, out, parallel)
        };
        if parallel {
            rayon::join(left, right);
        } else {
            left();
            right();
        }
        return;
    }
    let first = first_run * width;
    for &pair in chunks.iter().flatten() {
        if let Some(cursor) = (pair.0 as usize)
            .checked_sub(first)
            .and_then(|c| cursors.get_mut(c))
        {
            out[*cursor as usize] = pair;
            *cursor += 1;
        }
    }
    // (each cursor now holds the end of its particle's group)
    let mut start = 0;
    for &end in cursors.iter() {
        let end = end as usize;
        if end - start > 1 {
            out[start..end].sort_unstable();
        }
        start = end;
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
