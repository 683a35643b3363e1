//! How a run of spans goes to the thread pool (see [`super`]): a parity's block pairs, or the
//! planes' blocks. With at least [`PAIR_SPANS_FROM`] spans (or serially), two spans go to a
//! task, and a sweep's two blocks scan their contacts side by side; their work-list walks
//! (see `frontier.rs`) still run one after the other, so a sweep that only walks gains
//! nothing.
//!
//! Why two: a block's scan is a chain, each contact of a particle waiting on the velocity the
//! contact before it wrote, and the core idles while it waits. Two blocks of one parity share
//! no slot and no row, so any interleaving of their contacts gives the bits of running them
//! one after the other, and two chains side by side keep the core busy. (`carom bench --case`,
//! the dense 10^6 pile: 0.90x the step; four blocks to a task were slower than two; see
//! docs/benchmarks.md.)

use super::{pair_mut, Blocks, Change, PairRule, PlaneContact, PlaneRule, Split, Visit};
use crate::broadphase::Pair;
use crate::frontier::{Stamps, Walk};
use crate::solver::RowsMut;
use crate::vector::Vector;
use std::ops::Range;

impl Blocks {
    /// Two blocks' pairs (see [`Blocks::run_parity`]), or one block's when `b` is `None`: each
    /// block's changed contacts through the frontier when there is one (see
    /// [`crate::frontier`]), scanning otherwise or past where the frontier stops; the two
    /// scans go contact by contact in turn (see the module notes). Returns how many
    /// applications changed something.
    fn run_blocks<V: Vector>(
        &self,
        mut a: Span<V>,
        b: Option<Span<V>>,
        visit: Visit,
        pairs: &[Pair],
        reverse: bool,
        rule: &impl PairRule<V>,
    ) -> u64 {
        let (mut changed, mut scan_a) = self.walk_block(&mut a, visit, pairs, reverse, rule);
        let Some(mut b) = b else {
            return changed + scan(&mut a, scan_a, visit, pairs, reverse, rule);
        };
        let (walked, mut scan_b) = self.walk_block(&mut b, visit, pairs, reverse, rule);
        changed += walked;
        let next = |r: &mut Range<usize>| if reverse { r.next_back() } else { r.next() };
        loop {
            match (next(&mut scan_a), next(&mut scan_b)) {
                (Some(ka), Some(kb)) => {
                    changed += apply(&mut a, ka, visit, pairs, rule);
                    changed += apply(&mut b, kb, visit, pairs, rule);
                }
                (Some(k), None) => {
                    changed += apply(&mut a, k, visit, pairs, rule);
                    return changed + scan(&mut a, scan_a, visit, pairs, reverse, rule);
                }
                (None, Some(k)) => {
                    changed += apply(&mut b, k, visit, pairs, rule);
                    return changed + scan(&mut b, scan_b, visit, pairs, reverse, rule);
                }
                (None, None) => return changed,
            }
        }
    }

    /// Every block's pairs on this thread, block after block in slot order, each block with
    /// the slots of itself and the next (see [`Blocks::every_pair_in_order`]); no work list.
    pub(super) fn run_in_order<V: Vector>(
        &self,
        data: &mut [V],
        pairs: &[Pair],
        mut rows: RowsMut<V>,
        rule: &impl PairRule<V>,
    ) -> u64 {
        let (n, size) = (data.len(), self.size);
        let mut changed = 0;
        for block in 0..self.count() {
            let slots = (block * size).min(n)..((block + 2) * size).min(n);
            let (first, last) = (self.pair_start[block], self.pair_start[block + 1]);
            let span = Span {
                block,
                slot_base: slots.start,
                slots: &mut data[slots],
                stamps: Stamps::none(),
                row_base: first,
                rows: rows.reborrow().split_at_mut(last).0.split_at_mut(first).1,
            };
            changed += self.run_blocks(span, None, Visit::ALL, pairs, false, rule);
        }
        changed
    }

    /// The frontier's part of one block's sweep (see [`Blocks::run_blocks`]): how many of its
    /// applications changed something, and the block's contacts left to scan.
    fn walk_block<V: Vector>(
        &self,
        span: &mut Span<V>,
        visit: Visit,
        pairs: &[Pair],
        reverse: bool,
        rule: &impl PairRule<V>,
    ) -> (u64, Range<usize>) {
        let block = span.block;
        let mut mine = self.pair_start[block]..self.pair_start[block + 1];
        let mut changed = 0;
        if visit.since > 0 && !span.stamps.is_empty() && self.frontier.ready() {
            let Span {
                slot_base,
                slots,
                stamps,
                row_base,
                rows,
                ..
            } = span;
            let (slot_base, row_base) = (*slot_base, *row_base);
            let walked = self.frontier.walk(
                block,
                mine.clone(),
                reverse,
                stamps,
                visit.since,
                |k, stamps| {
                    let (i, j) = pairs[k];
                    let (i, j) = (i as usize - slot_base, j as usize - slot_base);
                    let (a, b) = pair_mut(slots, i, j);
                    let change = rule(
                        &mut rows.row[k - row_base],
                        &mut rows.record[k - row_base],
                        a,
                        b,
                    );
                    if change == Change::Nothing {
                        return None;
                    }
                    visit.stamp(stamps, i, j);
                    changed += change.count();
                    Some((i, j))
                },
            );
            match walked {
                Walk::Done => return (changed, 0..0),
                Walk::ScanPast(None) => {}
                Walk::ScanPast(Some(k)) if reverse => mine.end = k,
                Walk::ScanPast(Some(k)) => mine.start = k + 1,
            }
        }
        (changed, mine)
    }
}

/// Contact `k` of `span`'s block in a scan: the rule, when `visit` wants the contact and it
/// lies within the span (pairs reaching beyond it are leftovers). Returns 1 when counted.
#[inline(always)]
fn apply<V: Vector>(
    span: &mut Span<V>,
    k: usize,
    visit: Visit,
    pairs: &[Pair],
    rule: &impl PairRule<V>,
) -> u64 {
    let (i, j) = pairs[k];
    let (i, j) = (i as usize - span.slot_base, j as usize - span.slot_base);
    if j >= span.slots.len() || !visit.wants(&span.stamps, i, j) {
        return 0;
    }
    let (a, b) = pair_mut(span.slots, i, j);
    let r = k - span.row_base;
    let change = rule(&mut span.rows.row[r], &mut span.rows.record[r], a, b);
    if change == Change::Nothing {
        return 0;
    }
    visit.stamp(&mut span.stamps, i, j);
    change.count()
}

/// [`apply`] to every contact of `range`, in the sweep's direction.
fn scan<V: Vector>(
    span: &mut Span<V>,
    range: Range<usize>,
    visit: Visit,
    pairs: &[Pair],
    reverse: bool,
    rule: &impl PairRule<V>,
) -> u64 {
    let one = |k| apply(span, k, visit, pairs, rule);
    if reverse {
        range.rev().map(one).sum()
    } else {
        range.map(one).sum()
    }
}

/// One span of a run as [`split_run`] hands it out: its number, its first slot, its
/// slots and their stamps, the index of its first row, and its rows.
pub(crate) struct Part<'a, D, R> {
    pub(super) span: usize,
    pub(super) slot_base: usize,
    pub(super) data: D,
    pub(super) stamps: Stamps<'a>,
    pub(super) row_base: usize,
    pub(super) rows: R,
}

/// What a run does with its spans, two at a time (see [`split_run`]).
pub(crate) trait SpanWork<D, R>: Sync {
    /// Runs span `a` and, when there is one, span `b` (disjoint from `a`); returns how many
    /// applications changed something.
    fn run(&self, a: Part<D, R>, b: Option<Part<D, R>>) -> u64;
}

/// The pair rule over the spans of one parity (see [`Blocks::run_parity`]).
pub(crate) struct PairWork<'w, F> {
    pub blocks: &'w Blocks,
    /// This run's parity: span `c` is the pair of blocks `parity + 2 c` and the next.
    pub parity: usize,
    pub visit: Visit,
    pub pairs: &'w [Pair],
    pub reverse: bool,
    pub rule: &'w F,
}

impl<F> PairWork<'_, F> {
    fn span<'p, V>(&self, part: Part<'p, &'p mut [V], RowsMut<'p, V>>) -> Span<'p, V> {
        Span {
            block: self.parity + 2 * part.span,
            slot_base: part.slot_base,
            slots: part.data,
            stamps: part.stamps,
            row_base: part.row_base,
            rows: part.rows,
        }
    }
}

impl<'a, V: Vector, F: PairRule<V>> SpanWork<&'a mut [V], RowsMut<'a, V>> for PairWork<'_, F> {
    fn run(
        &self,
        a: Part<&'a mut [V], RowsMut<'a, V>>,
        b: Option<Part<&'a mut [V], RowsMut<'a, V>>>,
    ) -> u64 {
        let b = b.map(|b| self.span(b));
        self.blocks.run_blocks(
            self.span(a),
            b,
            self.visit,
            self.pairs,
            self.reverse,
            self.rule,
        )
    }
}

/// The plane rule over blocks (see [`Blocks::run_planes`]).
pub(crate) struct PlaneWork<'w, F> {
    pub visit: Visit,
    pub plane_contacts: &'w [PlaneContact],
    pub rule: &'w F,
}

impl<'a, V: Send, R: Send, F: PlaneRule<V, R>> SpanWork<&'a mut [V], &'a mut [R]>
    for PlaneWork<'_, F>
{
    fn run(
        &self,
        a: Part<&'a mut [V], &'a mut [R]>,
        b: Option<Part<&'a mut [V], &'a mut [R]>>,
    ) -> u64 {
        let one = |part: Part<&'a mut [V], &'a mut [R]>| {
            let Part {
                slot_base,
                data: slots,
                mut stamps,
                row_base,
                rows,
                ..
            } = part;
            let mut changed = 0;
            for (k, r) in rows.iter_mut().enumerate() {
                let i = self.plane_contacts[row_base + k].0 as usize - slot_base;
                if self.visit.wants(&stamps, i, i) {
                    let change = (self.rule)(r, &mut slots[i]);
                    if change != Change::Nothing {
                        self.visit.stamp(&mut stamps, i, i);
                        changed += change.count();
                    }
                }
            }
            changed
        };
        one(a) + b.map_or(0, one)
    }
}

/// Spans in a parallel run from which its tasks take two spans each (see [`split_run`]).
const PAIR_SPANS_FROM: usize = 8;

/// Runs `work` on the spans `spans` of a run (a parity's block pairs, or the planes' blocks),
/// two at a time when there are at least [`PAIR_SPANS_FROM`] or it runs serially (the last
/// alone when their number is odd), else one at a time: span `c` holds the slots
/// `slot(c)..slot(c + 1)` of `data` and the rows `row(c)..row(c + 1)`, counted from
/// `slot(spans.start)` and `row(spans.start)`. On the thread pool when `parallel`, by halves;
/// serially otherwise. Returns the sum of what `work` returns.
#[allow(clippy::too_many_arguments)]
pub(crate) fn split_run<D: Split, R: Split>(
    parallel: bool,
    spans: Range<usize>,
    slot: &(impl Fn(usize) -> usize + Sync),
    row: &(impl Fn(usize) -> usize + Sync),
    data: D,
    stamps: Stamps,
    rows: R,
    work: &impl SpanWork<D, R>,
) -> u64 {
    let run = Run {
        slot,
        row,
        work,
        parallel,
        // (two spans to a task only when there are enough tasks to share out: 5000 discs
        // have five blocks, and the lecture pile took 1.1x as long with its spans paired,
        // measured when such a world still ran its sweeps on the pool, before ce8f8a7)
        paired: spans.len() >= PAIR_SPANS_FROM || !parallel,
    };
    run.split(spans, data, stamps, rows)
}

/// What stays the same while [`split_run`] halves a run: where each span's slots and rows
/// start, what to do with them, and whether spans go two to a task.
struct Run<'r, S, W, K> {
    slot: &'r S,
    row: &'r W,
    work: &'r K,
    parallel: bool,
    paired: bool,
}

impl<S, W, K> Run<'_, S, W, K>
where
    S: Fn(usize) -> usize + Sync,
    W: Fn(usize) -> usize + Sync,
{
    /// The spans `spans` (see [`split_run`]), by halves on the thread pool down to a task.
    fn split<D: Split, R: Split>(
        &self,
        spans: Range<usize>,
        data: D,
        stamps: Stamps,
        rows: R,
    ) -> u64
    where
        K: SpanWork<D, R>,
    {
        if !self.parallel || spans.len() <= 1 + self.paired as usize {
            return self.in_order(spans, data, stamps, rows);
        }
        let (s0, r0) = ((self.slot)(spans.start), (self.row)(spans.start));
        // (an even number of spans on the left, so that the pairs are the same however the
        // run is split: the results are the same either way, the cost is not)
        let half = spans.len() / 2;
        let mid = spans.start
            + if self.paired {
                half.next_multiple_of(2)
            } else {
                half
            };
        let (left_data, right_data) = data.split_at_mut((self.slot)(mid) - s0);
        let (left_stamps, right_stamps) = stamps.split_at((self.slot)(mid) - s0);
        let (left_rows, right_rows) = rows.split_at_mut((self.row)(mid) - r0);
        let (a, b) = rayon::join(
            || self.split(spans.start..mid, left_data, left_stamps, left_rows),
            || self.split(mid..spans.end, right_data, right_stamps, right_rows),
        );
        a + b
    }

    /// The spans `spans` on this thread, in order, two to each call of `work` (one when not
    /// paired: a task's run is then a single span).
    fn in_order<D: Split, R: Split>(
        &self,
        spans: Range<usize>,
        data: D,
        stamps: Stamps,
        rows: R,
    ) -> u64
    where
        K: SpanWork<D, R>,
    {
        let (mut data, mut stamps, mut rows) = (data, stamps, rows);
        let mut take = |c: usize| {
            let (s, r) = ((self.slot)(c), (self.row)(c));
            let (len, count) = ((self.slot)(c + 1) - s, (self.row)(c + 1) - r);
            let (here, rest) = std::mem::take(&mut data).split_at_mut(len);
            let (here_stamps, rest_stamps) = std::mem::take(&mut stamps).split_at(len);
            let (here_rows, rest_rows) = std::mem::take(&mut rows).split_at_mut(count);
            (data, stamps, rows) = (rest, rest_stamps, rest_rows);
            Part {
                span: c,
                slot_base: s,
                data: here,
                stamps: here_stamps,
                row_base: r,
                rows: here_rows,
            }
        };
        let mut total = 0;
        for c in spans.clone().step_by(2) {
            let a = take(c);
            let b = (c + 1 < spans.end).then(|| take(c + 1));
            total += self.work.run(a, b);
        }
        total
    }
}

/// One block's share of a parity run: its span of slots (the block and the next), their
/// stamps, and the rows of the block's own pairs.
struct Span<'a, V> {
    block: usize,
    /// The span's first slot.
    slot_base: usize,
    slots: &'a mut [V],
    stamps: Stamps<'a>,
    /// Index of the first row in `rows`.
    row_base: usize,
    rows: RowsMut<'a, V>,
}

#[cfg(test)]
pub(super) mod tests;
