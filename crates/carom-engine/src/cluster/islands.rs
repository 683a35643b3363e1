//! Sleeping islands across ranks (see [`crate::sleep`]): each rank marks the very slots that
//! one [`crate::World`] would put to sleep, from its own share of the contact candidates.
//!
//! An island is a connected component of the whole world's candidates. A rank holds the
//! candidates whose lower slot it owns, so an island may span ranks. Each rank first joins
//! what it holds (its own slots and the *foreign* slots its candidates reach, all of later
//! ranks), naming each local component by its lowest global slot, which is always an own one.
//! Then, only when some particle anywhere has rested long enough:
//!
//! 1. each rank tells the owner of every foreign slot it reaches which of its components
//!    reaches it (one all-to-all);
//! 2. every rank publishes the joins it learnt (its component, the reaching component) and,
//!    for each of its components that takes part in one, whether all of its own members have
//!    rested long enough (one all-gather);
//! 3. every rank joins those names alike and finds which joined islands are ripe.
//!
//! A slot sleeps when its local component is ripe and, if that component is joined to others,
//! the joined island is ripe too. Everything here is a function of the global state alone
//! (the partition into components does not depend on the order of the joins), so it is the
//! partition [`crate::sleep::Islands`] finds in one process.

use super::partition::Partition;
use super::traffic::{Link, TrafficKind};
use super::transport::Transport;
use super::wire::{Reader, Writer};
use crate::broadphase::Pair;
use crate::sleep::find;

/// This step's sleeping slots of one rank, and reused space.
#[derive(Debug, Default)]
pub(super) struct SplitIslands {
    /// Per own slot: asleep this step.
    pub asleep: Vec<bool>,
    /// How many own slots are asleep this step.
    pub count: usize,
    /// Union-find over own slots, then the foreign slots in `foreign` (scratch).
    parent: Vec<u32>,
    /// Foreign slots (relative to the first own one) the candidates reach, sorted (scratch).
    foreign: Vec<u32>,
    /// Per local root: every own member has rested long enough (scratch).
    ripe: Vec<bool>,
    /// Per local root: joined to another rank's component (scratch).
    joined: Vec<bool>,
}

impl SplitIslands {
    /// Marks this step's sleeping own slots from `pairs` (slots relative to `first_slot`, the
    /// lower one own) and the own slots' rest times. Collective. Returns the own count.
    pub fn mark<T: Transport + ?Sized>(
        &mut self,
        link: &mut Link<'_, T>,
        partition: &Partition,
        first_slot: usize,
        pairs: &[Pair],
        rest: &[f64],
        time: f64,
    ) -> usize {
        let own = rest.len();
        self.asleep.clear();
        self.asleep.resize(own, false);
        self.count = 0;
        let ripe_here = rest.iter().filter(|&&t| t >= time).count() as u64;
        if link.sum_of(TrafficKind::Islands, &[ripe_here])[0] == 0 {
            return 0;
        }
        self.join_locally(pairs, own);
        for (slot, &t) in rest.iter().enumerate() {
            if t < time {
                let root = find(&mut self.parent, slot as u32) as usize;
                self.ripe[root] = false;
            }
        }
        let global_ripe = self.join_across_ranks(link, partition, first_slot, own);
        for slot in 0..own {
            let root = find(&mut self.parent, slot as u32);
            let label = (first_slot + root as usize) as u64;
            let sleeps = self.ripe[root as usize]
                && (!self.joined[root as usize] || global_ripe.is_ripe(label));
            if sleeps {
                self.asleep[slot] = true;
                self.count += 1;
            }
        }
        self.count
    }

    /// The local components over own slots and the foreign slots `pairs` reach; the root of
    /// each is its lowest slot (own slots come first, foreign ones in ascending order).
    fn join_locally(&mut self, pairs: &[Pair], own: usize) {
        self.foreign.clear();
        self.foreign
            .extend(pairs.iter().map(|&(_, j)| j).filter(|&j| j as usize >= own));
        self.foreign.sort_unstable();
        self.foreign.dedup();
        let total = own + self.foreign.len();
        self.parent.clear();
        self.parent.extend(0..total as u32);
        for &(i, j) in pairs {
            let j = self.index(j, own);
            let (a, b) = (find(&mut self.parent, i), find(&mut self.parent, j));
            if a != b {
                self.parent[a.max(b) as usize] = a.min(b);
            }
        }
        self.ripe.clear();
        self.ripe.resize(total, true);
        self.joined.clear();
        self.joined.resize(total, false);
    }

    /// True when own slot `slot` sleeps this step.
    #[inline]
    pub fn sleeps(&self, slot: usize) -> bool {
        self.count > 0 && self.asleep[slot]
    }

    /// Per own slot, whether it sleeps this step; empty when none does.
    pub fn sleepers(&self) -> &[bool] {
        if self.count > 0 {
            &self.asleep
        } else {
            &[]
        }
    }

    /// Index in the union-find of slot `j` (relative).
    fn index(&self, j: u32, own: usize) -> u32 {
        if (j as usize) < own {
            j
        } else {
            let k = self.foreign.binary_search(&j).expect("a foreign slot");
            (own + k) as u32
        }
    }

    /// Steps 1 to 3 of the module notes: the joined islands, the same on every rank.
    fn join_across_ranks<T: Transport + ?Sized>(
        &mut self,
        link: &mut Link<'_, T>,
        partition: &Partition,
        first_slot: usize,
        own: usize,
    ) -> Joined {
        // 1. "your slot g is in my component named l"
        let mut outgoing: Vec<Writer> = (0..link.ranks()).map(|_| Writer::default()).collect();
        for k in 0..self.foreign.len() {
            let root = find(&mut self.parent, (own + k) as u32) as usize;
            debug_assert!(root < own, "a component reaching out holds an own slot");
            self.joined[root] = true;
            let g = first_slot + self.foreign[k] as usize;
            outgoing[partition.owner_of_slot(g)]
                .u64(g as u64)
                .u64((first_slot + root) as u64);
        }
        // 2. the joins learnt, then each joined component's own ripeness
        let mut joins: Vec<(u64, u64)> = Vec::new();
        for bytes in link.exchange(TrafficKind::Islands, outgoing) {
            let mut r = Reader::new(&bytes);
            while !r.is_empty() {
                let (g, theirs) = (r.u64() as usize, r.u64());
                let root = find(&mut self.parent, (g - first_slot) as u32) as usize;
                self.joined[root] = true;
                joins.push(((first_slot + root) as u64, theirs));
            }
        }
        let mut mine = Writer::default();
        mine.u64(joins.len() as u64);
        for &(a, b) in &joins {
            mine.u64(a).u64(b);
        }
        for root in 0..own {
            if self.joined[root] && find(&mut self.parent, root as u32) as usize == root {
                mine.u64((first_slot + root) as u64)
                    .u32(self.ripe[root] as u32);
            }
        }
        // 3. the same joins and ripeness on every rank
        let mut all_joins = Vec::new();
        let mut ripeness = Vec::new();
        for bytes in link.gather(TrafficKind::Islands, &mine.0) {
            let mut r = Reader::new(&bytes);
            for _ in 0..r.u64() {
                all_joins.push((r.u64(), r.u64()));
            }
            while !r.is_empty() {
                ripeness.push((r.u64(), r.u32() != 0));
            }
        }
        Joined::new(&all_joins, &ripeness)
    }
}

/// The islands joined across ranks: named by their components' labels (global slots).
struct Joined {
    /// Every label, sorted.
    labels: Vec<u64>,
    /// Union-find over `labels`, fully compressed.
    parent: Vec<u32>,
    /// Per root: every part of the island is ripe.
    ripe: Vec<bool>,
}

impl Joined {
    fn new(joins: &[(u64, u64)], ripeness: &[(u64, bool)]) -> Self {
        let mut labels: Vec<u64> = ripeness.iter().map(|&(l, _)| l).collect();
        labels.extend(joins.iter().flat_map(|&(a, b)| [a, b]));
        labels.sort_unstable();
        labels.dedup();
        let at = |l: u64| labels.binary_search(&l).expect("a known label") as u32;
        let mut parent: Vec<u32> = (0..labels.len() as u32).collect();
        for &(a, b) in joins {
            let (a, b) = (find(&mut parent, at(a)), find(&mut parent, at(b)));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
        let mut ripe = vec![true; labels.len()];
        for &(l, r) in ripeness {
            if !r {
                let root = find(&mut parent, at(l)) as usize;
                ripe[root] = false;
            }
        }
        for k in 0..parent.len() {
            parent[k] = find(&mut parent, k as u32);
        }
        Self {
            labels,
            parent,
            ripe,
        }
    }

    /// Whether the island of the component named `label` is ripe.
    fn is_ripe(&self, label: u64) -> bool {
        let k = self.labels.binary_search(&label).expect("a joined label");
        self.ripe[self.parent[k] as usize]
    }
}
