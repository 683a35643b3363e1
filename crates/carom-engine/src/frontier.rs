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

/// Slots per group of stamps (see [`Stamps`]); block boundaries are multiples of it.
pub(crate) const GROUP: usize = 64;

/// The work lists' stamps for a run of slots (see [`crate::schedule`]): per slot, the number
/// of the last sweep that changed it, and per group of [`GROUP`] slots which of them the last
/// two sweeps changed (see [`GroupStamps`]), so that a sweep finds the changed slots without
/// reading every stamp. Empty when there are no work lists.
#[derive(Debug, Default)]
pub(crate) struct Stamps<'a> {
    slot: &'a mut [u32],
    group: &'a mut [GroupStamps],
}

/// The stamps of one group of [`GROUP`] slots, one bit per slot: a sweep after a pass's first
/// wants the slots stamped by the sweep before it or by itself, which these bits give without
/// reading the slots' stamps (scattered over memory, those reads were most of the cost of
/// finding them: see [`Frontier::walk`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct GroupStamps {
    /// The largest stamp of the group's slots.
    latest: u32,
    /// The slots stamped `latest`.
    newest: u64,
    /// The slots stamped `latest - 1` (some may have been stamped `latest` since).
    before: u64,
}

impl GroupStamps {
    /// The group's slots stamped at least `since`, as bits, or `None` when the bits cannot
    /// tell (`since` more than one sweep before the latest: the slots' stamps must).
    #[inline]
    fn since(&self, since: u32) -> Option<u64> {
        if self.latest < since {
            Some(0)
        } else if self.latest == since {
            Some(self.newest)
        } else if self.latest - 1 == since {
            Some(self.newest | self.before)
        } else {
            None
        }
    }
}

impl<'a> Stamps<'a> {
    /// The stamps `slot` with their groups `group` (`slot.len()` divided by [`GROUP`],
    /// rounded up; both zero or filled by this type's methods alone).
    pub fn new(slot: &'a mut [u32], group: &'a mut [GroupStamps]) -> Self {
        debug_assert_eq!(group.len(), slot.len().div_ceil(GROUP));
        Self { slot, group }
    }

    /// No stamps: no work list.
    pub fn none() -> Self {
        Self::default()
    }

    /// True without work lists.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.slot.is_empty()
    }

    /// Slot `i`'s stamp.
    #[inline]
    pub fn get(&self, i: usize) -> u32 {
        self.slot[i]
    }

    /// Stamps slot `i` with `now`, the newest sweep's number (no stamp is ever larger).
    #[inline]
    pub fn set(&mut self, i: usize, now: u32) {
        self.slot[i] = now;
        let group = &mut self.group[i / GROUP];
        if group.latest != now {
            group.before = if group.latest + 1 == now {
                group.newest
            } else {
                0
            };
            group.newest = 0;
            group.latest = now;
        }
        group.newest |= 1 << (i % GROUP);
    }

    /// Every stamp back to 0.
    pub fn clear(&mut self) {
        self.slot.fill(0);
        self.group.fill(GroupStamps::default());
    }

    /// The same stamps, borrowed anew.
    #[inline]
    pub fn reborrow(&mut self) -> Stamps<'_> {
        Stamps {
            slot: self.slot,
            group: self.group,
        }
    }

    /// Slots `..at` and `at..`; `at` is a multiple of [`GROUP`] or the end (none splits into
    /// none).
    #[inline]
    pub fn split_at(self, at: usize) -> (Stamps<'a>, Stamps<'a>) {
        if self.is_empty() {
            return (Stamps::none(), Stamps::none());
        }
        debug_assert!(at % GROUP == 0 || at == self.slot.len());
        let (a, b) = self.slot.split_at_mut(at);
        let (ga, gb) = self.group.split_at_mut(at.div_ceil(GROUP));
        (Stamps::new(a, ga), Stamps::new(b, gb))
    }

    /// Whether any slot below `end` is stamped at least `since`, from the groups alone.
    #[inline]
    fn any_since(&self, since: u32, end: usize) -> bool {
        let end = end.min(self.slot.len());
        self.group[..end.div_ceil(GROUP)]
            .iter()
            .any(|group| group.latest >= since)
    }

    /// Appends to `out` the slots below `end` stamped at least `since`, ascending, a group of
    /// [`GROUP`] slots at a time. After each group, `more` sees the slots the group added;
    /// when it says false, stops there and returns false.
    fn collect_since(
        &self,
        since: u32,
        end: usize,
        out: &mut Vec<u32>,
        mut more: impl FnMut(&[u32]) -> bool,
    ) -> bool {
        let end = end.min(self.slot.len());
        for (g, group) in self.group[..end.div_ceil(GROUP)].iter().enumerate() {
            let added = out.len();
            let first = g * GROUP;
            let mut bits = match group.since(since) {
                Some(bits) => bits,
                None => {
                    let slots = &self.slot[first..(first + GROUP).min(end)];
                    let stamped = slots.iter().enumerate().filter(|(_, &s)| s >= since);
                    stamped.fold(0, |bits, (l, _)| bits | 1 << l)
                }
            };
            if end - first < GROUP {
                bits &= (1 << (end - first)) - 1;
            }
            while bits != 0 {
                out.push((first + bits.trailing_zeros() as usize) as u32);
                bits &= bits - 1;
            }
            if !more(&out[added..]) {
                return false;
            }
        }
        true
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    /// Stamps and their groups with the stamps `of` each slot, set in the order of the stamps.
    fn stamped(of: &[u32]) -> (Vec<u32>, Vec<GroupStamps>) {
        let (mut slot, mut group) = (
            vec![0; of.len()],
            vec![GroupStamps::default(); of.len().div_ceil(GROUP)],
        );
        let mut stamps = Stamps::new(&mut slot, &mut group);
        let mut order: Vec<usize> = (0..of.len()).filter(|&i| of[i] > 0).collect();
        order.sort_by_key(|&i| of[i]);
        for i in order {
            stamps.set(i, of[i]);
        }
        (slot, group)
    }

    #[test]
    fn groups_find_the_stamped_slots_and_split_with_them() {
        let (mut slot, mut group) = (vec![0; 200], vec![GroupStamps::default(); 4]);
        let mut stamps = Stamps::new(&mut slot, &mut group);
        for (i, now) in [(3, 5), (70, 6), (199, 7), (130, 2)] {
            stamps.set(i, now);
        }
        let since = |stamps: &Stamps, since, end| {
            let mut out = Vec::new();
            stamps.collect_since(since, end, &mut out, |_| true);
            out
        };
        assert_eq!(since(&stamps, 5, 200), vec![3, 70, 199]);
        assert_eq!(since(&stamps, 5, 199), vec![3, 70]);
        // (more than a sweep back: from the slots' stamps)
        assert_eq!(since(&stamps, 2, 200), vec![3, 70, 130, 199]);
        assert_eq!(since(&stamps, 3, 200), vec![3, 70, 199]);
        let (low, high) = stamps.split_at(128);
        assert_eq!(since(&low, 6, 1000), vec![70]);
        assert_eq!(since(&high, 1, 72), vec![2, 71]);
        assert_eq!(since(&high, 1, 71), vec![2]);
    }

    proptest::proptest! {
        /// The groups' bits find what reading every slot's stamp finds, sweep after sweep.
        #[test]
        fn group_bits_find_what_the_slots_say(
            sweeps in proptest::collection::vec(proptest::collection::vec(0usize..300, 0..20), 1..12),
            end in 0usize..320,
        ) {
            let (mut slot, mut group) = (vec![0; 300], vec![GroupStamps::default(); 300usize.div_ceil(GROUP)]);
            let mut stamps = Stamps::new(&mut slot, &mut group);
            for (sweep, changed) in sweeps.iter().enumerate() {
                let now = sweep as u32 + 1;
                for &i in changed {
                    stamps.set(i, now);
                }
                for since in 1..=now {
                    let mut found = Vec::new();
                    stamps.collect_since(since, end, &mut found, |_| true);
                    let read: Vec<u32> = (0..end.min(300) as u32)
                        .filter(|&l| stamps.get(l as usize) >= since)
                        .collect();
                    proptest::prop_assert_eq!(found, read);
                }
            }
        }
    }

    #[test]
    fn every_contact_is_listed_under_both_its_particles_in_order() {
        // one block of 4 slots (span 0..4): contacts (0,1), (0,3), (1,2), (2,3)
        let pairs = [(0, 1), (0, 3), (1, 2), (2, 3)];
        let mut f = Frontier::default();
        f.index(&pairs, &[0, 4], 4, 4, false);
        let b = &f.blocks[0];
        assert_eq!(b.start, vec![0, 2, 4, 6, 8]);
        assert_eq!(b.list, vec![0, 1, 0, 2, 2, 3, 1, 3]);
        assert_eq!(b.reached, 4);
        assert!(f.ready());
        // slots 2 and 3 touch nothing: the walk need not look at their stamps
        f.index(&[(0, 1)], &[0, 1], 4, 4, false);
        assert_eq!(f.blocks[0].reached, 2);
        f.index(&[], &[0, 0], 4, 4, false);
        assert_eq!(f.blocks[0].reached, 0);
    }

    /// Each span slot's contacts, as the index of block `b` lists them and as
    /// the block's pairs (`pair_start`, spans of two blocks of `size` in `n` slots) say.
    fn listed_and_expected(
        f: &Frontier,
        pairs: &[Pair],
        pair_start: &[usize],
        b: usize,
        size: usize,
        n: usize,
    ) -> (Vec<Vec<u32>>, Vec<Vec<u32>>) {
        let index = &f.blocks[b];
        let (base, end) = (b * size, ((b + 2) * size).min(n));
        // (the walk asks only below `reached`: past it, no slot has a contact here)
        let of = |l: usize| match l < index.reached {
            true => index.of(l).to_vec(),
            false => vec![],
        };
        let listed = (0..end - base).map(of).collect();
        let expected = (0..end - base)
            .map(|l| {
                let mine = pair_start[b]..pair_start[b + 1];
                let touches = |&k: &usize| {
                    let (i, j) = pairs[k];
                    (j as usize) < end && [i, j].contains(&((base + l) as u32))
                };
                mine.filter(touches).map(|k| k as u32).collect()
            })
            .collect();
        (listed, expected)
    }

    #[test]
    fn each_index_lists_every_blocks_contacts_by_slot() {
        // blocks of 256 slots in 640: few contacts (a gas), one leaving the span (a leftover)
        let (size, n) = (256, 640);
        let first: Vec<Pair> = vec![
            (0, 300),
            (5, 6),
            (5, 100),
            (200, 201),
            (260, 270),
            (300, 600),
        ];
        let second: Vec<Pair> = vec![(6, 7), (100, 290), (100, 300), (290, 291)];
        let mut f = Frontier::default();
        // (each index over the last one's lists)
        for pairs in [&first, &second, &first] {
            let starts = |b: u32| pairs.partition_point(|&(i, _)| i < b * size as u32);
            let pair_start = [starts(0), starts(1), starts(2), starts(3)];
            f.index(pairs, &pair_start, size, n, false);
            for b in 0..3 {
                let (listed, expected) = listed_and_expected(&f, pairs, &pair_start, b, size, n);
                assert_eq!(listed, expected, "block {b} of {pairs:?}");
            }
            let reached = expected_reach(pairs, &pair_start, 0, 512);
            assert_eq!(f.blocks[0].reached, reached);
        }
        // two contacts a slot (a pile)
        let crowded: Vec<Pair> = (0..255).flat_map(|i| [(i, i + 1), (i, i + 2)]).collect();
        let pair_start = [0, crowded.len(), crowded.len(), crowded.len()];
        f.index(&crowded, &pair_start, size, n, false);
        let (listed, expected) = listed_and_expected(&f, &crowded, &pair_start, 0, size, n);
        assert_eq!(listed, expected);
    }

    /// One past the largest `j` below `end` of block `b`'s pairs (0 when none).
    fn expected_reach(pairs: &[Pair], pair_start: &[usize], b: usize, end: usize) -> usize {
        let mine = &pairs[pair_start[b]..pair_start[b + 1]];
        let ends = mine
            .iter()
            .map(|&(_, j)| j as usize + 1)
            .filter(|&j| j <= end);
        ends.max().unwrap_or(0)
    }

    #[test]
    fn the_walk_follows_changes_forwards_and_backwards() {
        // a chain 0-1-2-3-4: contacts k = (k, k + 1)
        let pairs = [(0, 1), (1, 2), (2, 3), (3, 4)];
        let mut f = Frontier::default();
        f.index(&pairs, &[0, 4], 8, 5, false);
        for reverse in [false, true] {
            // seeded at slot 2 (contacts 1 and 2); every visit changes its particles
            let mut seen = Vec::new();
            let (mut slot, mut group) = stamped(&[0, 0, 1, 0, 0]);
            let mut stamps = Stamps::new(&mut slot, &mut group);
            let step = |k: usize, _: &mut Stamps| {
                seen.push(k);
                Some(pairs[k]).map(|(i, j)| (i as usize, j as usize))
            };
            assert_eq!(f.walk(0, 0..400, reverse, &mut stamps, 1, step), Walk::Done);
            let expected = if reverse {
                vec![2, 1, 0]
            } else {
                vec![1, 2, 3]
            };
            assert_eq!(seen, expected, "reverse {reverse}");
        }
        // a visit that changes nothing passes nothing on
        let mut seen = Vec::new();
        let (mut slot, mut group) = stamped(&[0, 1, 0, 0, 0]);
        let mut stamps = Stamps::new(&mut slot, &mut group);
        let step = |k: usize, _: &mut Stamps| {
            seen.push(k);
            None
        };
        assert_eq!(f.walk(0, 0..400, false, &mut stamps, 1, step), Walk::Done);
        assert_eq!(seen, vec![0, 1]);
        // too many seeds for the size: a scan instead
        let (mut slot, mut group) = stamped(&[1; 5]);
        let mut stamps = Stamps::new(&mut slot, &mut group);
        assert_eq!(
            f.walk(0, 0..4, false, &mut stamps, 1, |_, _| None),
            Walk::ScanPast(None)
        );
        // a budget that runs out on the way: the scan goes on past the last contact visited
        let (mut slot, mut group) = stamped(&[0, 1, 0, 0, 0]);
        let mut stamps = Stamps::new(&mut slot, &mut group);
        let walk = f.walk(0, 0..8, false, &mut stamps, 1, |k, _| {
            Some(pairs[k]).map(|(i, j)| (i as usize, j as usize))
        });
        assert_eq!(walk, Walk::ScanPast(Some(0)));
    }

    #[test]
    fn the_walk_takes_each_contact_once_across_words_in_order() {
        // a star: slot 0 touches slots 1..=130 (contacts 0..130, more than two words of bits)
        let pairs: Vec<Pair> = (1..=130).map(|j| (0, j)).collect();
        let mut f = Frontier::default();
        f.index(&pairs, &[0, pairs.len()], 256, 131, false);
        for reverse in [false, true] {
            let mut seen = Vec::new();
            let (mut slot, mut group) = stamped(&[0; 131]);
            let mut stamps = Stamps::new(&mut slot, &mut group);
            stamps.set(0, 1);
            let step = |k: usize, _: &mut Stamps| {
                seen.push(k);
                Some((0, k + 1))
            };
            // (a block of room enough that the budget does not run out)
            let walked = f.walk(0, 0..100_000, reverse, &mut stamps, 1, step);
            assert_eq!(walked, Walk::Done);
            let mut expected: Vec<usize> = (0..130).collect();
            if reverse {
                expected.reverse();
            }
            assert_eq!(seen, expected, "reverse {reverse}");
        }
    }
}
