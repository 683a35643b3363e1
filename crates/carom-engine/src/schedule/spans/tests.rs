use super::*;
use crate::schedule::Alone;
use crate::solver::{Row, RowRecord};
use glam::DVec2;

/// A rule whose result depends on the order of its applications (as the solver's do).
fn mix(row: &mut Row<DVec2>, _: &mut RowRecord, a: &mut DVec2, b: &mut DVec2) -> Change {
    let (x, y) = (*a, *b);
    *a = x * 0.75 + y * 0.25 + DVec2::new(1e-3, 0.0);
    *b = y * 0.75 + x * 0.25 - DVec2::new(0.0, 1e-3);
    row.impulse += a.x;
    Change::Counted
}

/// `n` slots in blocks of `size` with contacts reaching up to `reach` slots ahead (some
/// past the next block: leftovers), sorted.
pub(in crate::schedule) fn contacts(n: usize, reach: usize) -> Vec<Pair> {
    let mut state = 7u64;
    let mut next = |m: usize| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as usize % m
    };
    let mut pairs: Vec<Pair> = (0..3 * n)
        .map(|_| {
            let i = next(n);
            let j = (i + 1 + next(reach)).min(n - 1);
            (i as u32, j as u32)
        })
        .filter(|&(i, j)| i < j)
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// The values after one sweep of `mix`, the blocks planned with `parallel`.
fn sweep(n: usize, size: usize, pairs: &[Pair], parallel: bool, reverse: bool) -> Vec<u64> {
    let mut blocks = Blocks::default();
    blocks.plan(n, size, pairs, &[], parallel, 0);
    let mut data: Vec<DVec2> = (0..n).map(|i| DVec2::new(i as f64, -(i as f64))).collect();
    let (mut row, mut record) = (
        vec![Row::default(); pairs.len()],
        vec![RowRecord::default(); pairs.len()],
    );
    let rows = RowsMut {
        row: &mut row,
        record: &mut record,
    };
    blocks.sweep_pairs(
        &mut Alone,
        &mut data,
        &mut Stamps::none(),
        Visit::ALL,
        pairs,
        rows,
        reverse,
        &mix,
    );
    let values = data.iter().flat_map(|v| [v.x.to_bits(), v.y.to_bits()]);
    values
        .chain(row.iter().map(|r| r.impulse.to_bits()))
        .collect()
}

/// The schedule of the module notes, one contact after another: even blocks, odd blocks,
/// each forwards or backwards, then the leftovers forwards.
fn by_the_notes(n: usize, size: usize, pairs: &[Pair], reverse: bool) -> Vec<u64> {
    let mut data: Vec<DVec2> = (0..n).map(|i| DVec2::new(i as f64, -(i as f64))).collect();
    let (mut row, mut record) = (
        vec![Row::default(); pairs.len()],
        vec![RowRecord::default(); pairs.len()],
    );
    let blocks = n.div_ceil(size);
    let mut apply = |k: usize| {
        let (i, j) = (pairs[k].0 as usize, pairs[k].1 as usize);
        let (a, b) = pair_mut(&mut data, i, j);
        mix(&mut row[k], &mut record[k], a, b);
    };
    let mut leftovers = Vec::new();
    for parity in 0..2 {
        for b in (parity..blocks).step_by(2) {
            let mut mine: Vec<usize> = (0..pairs.len())
                .filter(|&k| pairs[k].0 as usize / size == b)
                .collect();
            if reverse {
                mine.reverse();
            }
            for k in mine {
                if (pairs[k].1 as usize) < (b + 2) * size {
                    apply(k);
                } else if parity == b % 2 && !leftovers.contains(&k) {
                    leftovers.push(k);
                }
            }
        }
    }
    leftovers.sort_unstable();
    leftovers.into_iter().for_each(&mut apply);
    let values = data.iter().flat_map(|v| [v.x.to_bits(), v.y.to_bits()]);
    values
        .chain(row.iter().map(|r| r.impulse.to_bits()))
        .collect()
}

/// Blocks two to a task (many blocks) and one to a task (few) on the thread pool, and
/// serially, all give the bits of the schedule the module notes state.
#[test]
fn paired_spans_keep_the_order_of_the_notes() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    // (4096 / 64: 32 spans a parity, paired; 1162 / 64: 10 and 9, the last block partial;
    // the others too few to pair on the pool)
    for (n, size) in [(4096, 64), (1162, 64), (1000, 256), (300, 64)] {
        let pairs = contacts(n, 3 * size / 2);
        for reverse in [false, true] {
            let expected = by_the_notes(n, size, &pairs, reverse);
            for parallel in [true, false] {
                let got = pool.install(|| sweep(n, size, &pairs, parallel, reverse));
                assert!(
                    got == expected,
                    "n {n}, size {size}, parallel {parallel}, reverse {reverse}"
                );
            }
        }
    }
}

/// A one-sided rule (`b` ahead of `a` along x by at least their difference in y, the slot
/// numbers), applied by moving both: order matters, and a second visit with unchanged
/// values changes nothing, as work lists need.
fn push(_: &mut Row<DVec2>, _: &mut RowRecord, a: &mut DVec2, b: &mut DVec2) -> Change {
    let (gap, needed) = (b.x - a.x, b.y - a.y);
    if gap >= needed - 1e-9 {
        return Change::Nothing;
    }
    let d = (needed - gap) * 0.5;
    a.x -= d;
    b.x += d;
    Change::Counted
}

/// Sweeps through the work lists (the frontier's walks, their scans past where a walk
/// stops, two blocks to a task) give the bits of full serial sweeps.
#[test]
fn paired_work_list_sweeps_match_full_serial_sweeps() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for (n, size) in [(4096, 64), (1162, 64)] {
        let pairs = contacts(n, 3 * size / 2);
        // (a squeezed stretch every 512 slots, whose pushes spread for many sweeps, in a
        // loose row: some blocks walk a few contacts, others change too many to walk)
        let mut x = 0.0;
        let start: Vec<DVec2> = (0..n)
            .map(|i| {
                x += if i % 512 < 24 { 0.8 } else { 1.3 } + ((i * 7919) % 1013) as f64 * 1e-5;
                DVec2::new(x, i as f64)
            })
            .collect();
        let run = |work_list: bool| {
            let mut blocks = Blocks::default();
            blocks.plan(n, size, &pairs, &[], work_list, 0);
            blocks.index_contacts(n, &pairs);
            let mut data = start.clone();
            let (mut row, mut record) = (
                vec![Row::default(); pairs.len()],
                vec![RowRecord::default(); pairs.len()],
            );
            let mut slot = vec![0; n];
            let mut group = vec![Default::default(); n.div_ceil(crate::frontier::GROUP)];
            let mut stamps = if work_list {
                Stamps::new(&mut slot, &mut group)
            } else {
                Stamps::none()
            };
            let mut changed = Vec::new();
            for sweep in 1..=8u32 {
                let visit = if work_list {
                    Visit {
                        since: sweep - 1,
                        now: sweep,
                    }
                } else {
                    Visit::ALL
                };
                let rows = RowsMut {
                    row: &mut row,
                    record: &mut record,
                };
                let reverse = sweep % 2 == 0;
                let sweep = |stamps: &mut Stamps| {
                    let pairs = &pairs;
                    blocks.sweep_pairs(
                        &mut Alone, &mut data, stamps, visit, pairs, rows, reverse, &push,
                    )
                };
                changed.push(pool.install(|| sweep(&mut stamps)));
            }
            let bits = data.iter().map(|v| v.x.to_bits()).collect::<Vec<_>>();
            (bits, changed)
        };
        let (expected, counts) = run(false);
        // (few contacts change after the first sweep: the later sweeps walk)
        assert!(
            counts[1].0 > 0 && counts[1].0 * 20 < pairs.len() as u64,
            "{counts:?}"
        );
        assert!(run(true) == (expected, counts), "n {n}, size {size}");
    }
}
