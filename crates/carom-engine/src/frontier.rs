//! The work lists' frontier: a sweep after a pass's first visits only the contacts of the
//! particles that changed, found through an index of each block's contacts by particle,
//! instead of scanning every contact of the block for a changed particle.
//!
//! The result is the scan's, bit for bit (see [`crate::schedule`]): a scan visits contact `k`
//! when, on reaching it, one of its particles is stamped at least `since`. Those are the
//! contacts of the particles stamped at least `since` when the block starts, and the contacts
//! after `k` (in the sweep's direction) of the particles the rule changed at `k`. The frontier
//! visits exactly these, in the same order: one bit per contact of the block, the first set
//! before the walk and the second as it goes, taken in the sweep's direction. (Within one
//! parity the blocks' slots are disjoint, so only the block itself changes its particles while
//! it runs.)
//!
//! A falling gas of 10^6 discs makes about 45 such sweeps a step with a few hundred contacts
//! still active; scanning all 10^6 contacts for them was a fifth of the step.

use crate::broadphase::Pair;
use rayon::prelude::*;
use std::cell::RefCell;
use std::ops::Range;

mod stamps;
#[cfg(test)]
mod tests;

pub(crate) use stamps::{GroupStamps, Stamps, GROUP};

/// When the walk has marked more contacts than this fraction of its block's (each contact is
/// listed twice), a scan of the rest is cheaper (and gives the same result): in a pile a change
/// runs through the whole block within one sweep. (Without it the lecture pile, 5000 discs at
/// dt = 1/60, took 1.48x as long.)
const SCAN_ABOVE: usize = 8;

/// How a [`Frontier::walk`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Walk {
    /// Every contact a scan would visit was visited.
    Done,
    /// Scanning is cheaper: scan the contacts past this one in the sweep's direction (all of
    /// them when `None`). A scan from there visits exactly what the walk would have.
    ScanPast(Option<usize>),
}

/// Each block's contacts by particle (see the module notes).
#[derive(Debug, Default)]
pub(crate) struct Frontier {
    blocks: Vec<BlockIndex>,
    /// True when the index matches the blocks planned last.
    ready: bool,
}

/// One block's contacts by the slots of its span (the block and the next).
#[derive(Debug, Default)]
struct BlockIndex {
    /// `list[start[l]..start[l + 1]]` are the contacts of span slot `l`, ascending; length
    /// `reached + 1` (the slots past `reached` have none: in a gas of 10^6 discs, whose
    /// contacts reach a row or two into the next block, 5.1 bytes a particle instead of 8).
    start: Vec<u32>,
    /// Contact (pair) indices; every contact twice, once for each particle.
    list: Vec<u32>,
    /// One past the last span slot with a contact: the slots from here on (most of the next
    /// block's) have none in this block, so the walk does not look at their stamps (nor does
    /// the index hold them).
    reached: usize,
}

/// A walk's scratch, per worker thread, kept between walks (no allocation after warm-up).
#[derive(Default)]
struct Scratch {
    /// The contacts still to visit, one bit per contact of the block.
    pending: Vec<u64>,
    /// The slots stamped when the walk starts.
    seeds: Vec<u32>,
}

impl BlockIndex {
    /// The contacts of span slot `l`, ascending.
    #[inline]
    fn of(&self, l: usize) -> &[u32] {
        &self.list[self.start[l] as usize..self.start[l + 1] as usize]
    }

    /// Indexes the contacts `mine` (pair indices from `first`) of a block whose span is
    /// `base..end`: those whose `j` lies in it.
    ///
    /// (Its passes over the slots are most of its time in a gas, with 0.1 contacts a
    /// particle: two here (see [`crate::bucket::running_sums`]). Three, each sum read back
    /// from the slot before, took 3.3 ms a step in issue 14's gas of 10^6 discs; these
    /// take 0.8.)
    fn build(&mut self, mine: &[Pair], first: usize, base: usize, end: usize) {
        let within = |p: &&Pair| (p.1 as usize) < end;
        let local = |&(i, j): &Pair| (i as usize - base, j as usize - base);
        // (`j > i`: the last slot with a contact is the largest `j`)
        let ends = mine
            .iter()
            .filter(within)
            .map(|&(_, j)| j as usize - base + 1);
        self.reached = ends.max().unwrap_or(0);
        let start = &mut self.start;
        start.clear();
        // (room for the whole span at once, so that a step reaching further than the last
        // does not move the index: moved, its old copy stays in the heap's pages)
        start.reserve_exact(end.saturating_sub(base) + 1);
        start.resize(self.reached + 1, 0);
        // Each slot's count, then the sum of the counts up to it; then the contacts put in
        // from the last, each where its slot's sum less one says: the lists ascend, and each
        // sum ends at its slot's first contact.
        for (i, j) in mine.iter().filter(within).map(local) {
            start[i] += 1;
            start[j] += 1;
        }
        let sum = crate::bucket::running_sums(start);
        self.list.clear();
        self.list.resize(sum as usize, 0);
        for (k, pair) in mine.iter().enumerate().rev() {
            if within(&pair) {
                let (i, j) = local(pair);
                for l in [i, j] {
                    start[l] -= 1;
                    self.list[start[l] as usize] = (first + k) as u32;
                }
            }
        }
    }
}

/// Sets the bit of contact `k` of a block whose first contact is `first`.
#[inline]
fn mark(bits: &mut [u64], first: usize, k: u32) {
    let bit = k as usize - first;
    bits[bit / 64] |= 1 << (bit % 64);
}

impl Scratch {
    /// Marks the contacts of the slots stamped at least `since` (of the block `index` of
    /// `contacts`) as pending, and takes them from `budget`; false, marking nothing more,
    /// when they are more than it.
    fn seed(
        &mut self,
        index: &BlockIndex,
        contacts: &Range<usize>,
        stamps: &Stamps,
        since: u32,
        budget: &mut usize,
    ) -> bool {
        self.pending.clear();
        self.pending.resize(contacts.len().div_ceil(64), 0);
        // (first a group's seeds, then their lists' lengths; then the lists: the lookups of
        // one stage do not wait on each other, which scattered seeds made the walk's main
        // cost. The count stops at the first group past the budget: in the dense 10^6 pile
        // most slots are seeds in most sweeps, and the seeding was 4.6 % of the step's
        // samples in `perf` when it counted them all)
        self.seeds.clear();
        let mut seeded = 0;
        let lengths =
            |seeds: &[u32]| -> usize { seeds.iter().map(|&l| index.of(l as usize).len()).sum() };
        let within = stamps.collect_since(since, index.reached, &mut self.seeds, |added| {
            seeded += lengths(added);
            seeded <= *budget
        });
        if !within {
            return false;
        }
        *budget -= seeded;
        for &l in &self.seeds {
            for &k in index.of(l as usize) {
                mark(&mut self.pending, contacts.start, k);
            }
        }
        true
    }
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

impl Frontier {
    /// Forgets the index (the blocks were planned anew).
    pub fn clear(&mut self) {
        self.ready = false;
    }

    /// Whether [`Frontier::index`] ran for the blocks planned last.
    pub fn ready(&self) -> bool {
        self.ready
    }

    /// Indexes every block's contacts by particle. Block `b` holds the contacts
    /// `pairs[pair_start[b]..pair_start[b + 1]]` whose `j` lies before `span_end(b)`, and its
    /// span is `b * size..span_end(b)`.
    pub fn index(
        &mut self,
        pairs: &[Pair],
        pair_start: &[usize],
        size: usize,
        n: usize,
        parallel: bool,
    ) {
        let count = pair_start.len() - 1;
        self.blocks.resize_with(count, Default::default);
        let build = |(b, index): (usize, &mut BlockIndex)| {
            let mine = &pairs[pair_start[b]..pair_start[b + 1]];
            index.build(mine, pair_start[b], b * size, ((b + 2) * size).min(n));
        };
        if parallel {
            self.blocks.par_iter_mut().enumerate().for_each(build);
        } else {
            self.blocks.iter_mut().enumerate().for_each(build);
        }
        self.ready = true;
    }

    /// Visits block `block`'s contacts (the pair indices `contacts`) as a scan would (see the
    /// module notes), given the span's `stamps`: `visit(k, stamps)` applies the rule to
    /// contact `k` and returns the span slots of its particles when it changed them. Stops
    /// where a scan becomes cheaper (see [`Walk`]).
    ///
    /// The contacts still to visit are bits, one per contact of the block, taken in the
    /// sweep's direction; a change at `k` sets the bits of its particles' contacts past `k`,
    /// which the walk then reaches in order. (It replaced a heap of indices: on 10^6 falling
    /// discs the velocity phase took 0.68-0.90x as long, the same bits.)
    pub fn walk(
        &self,
        block: usize,
        contacts: Range<usize>,
        reverse: bool,
        stamps: &mut Stamps,
        since: u32,
        mut visit: impl FnMut(usize, &mut Stamps) -> Option<(usize, usize)>,
    ) -> Walk {
        let index = &self.blocks[block];
        let first = contacts.start;
        let mut budget = contacts.len().div_ceil(SCAN_ABOVE) * 2;
        // (in a sparse sweep many blocks have no particle stamped: nothing to seed or clear)
        if !stamps.any_since(since, index.reached) {
            return Walk::Done;
        }
        SCRATCH.with_borrow_mut(|scratch| {
            if !scratch.seed(index, &contacts, stamps, since, &mut budget) {
                return Walk::ScanPast(None);
            }
            let bits = &mut scratch.pending;
            let words = bits.len();
            let word_order: &mut dyn Iterator<Item = usize> = if reverse {
                &mut (0..words).rev()
            } else {
                &mut (0..words)
            };
            for w in word_order {
                while bits[w] != 0 {
                    let bit = if reverse {
                        63 - bits[w].leading_zeros() as usize
                    } else {
                        bits[w].trailing_zeros() as usize
                    };
                    bits[w] &= !(1 << bit);
                    let k = first + w * 64 + bit;
                    if let Some((i, j)) = visit(k, stamps) {
                        let more = index.of(i).len() + index.of(j).len();
                        if more > budget {
                            return Walk::ScanPast(Some(k));
                        }
                        budget -= more;
                        for &m in index.of(i).iter().chain(index.of(j)) {
                            if (m as usize > k) != reverse && m as usize != k {
                                mark(bits, first, m);
                            }
                        }
                    }
                }
            }
            Walk::Done
        })
    }
}
