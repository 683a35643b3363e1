//! The order in which the solver visits contacts, and how that order runs on threads and
//! across processes without changing a bit.
//!
//! Particles live in *storage slots* (the world keeps them sorted along space, see
//! [`crate::world`]); contacts are pairs of slots `(i, j)`, `i < j`, sorted, each with a row of
//! solver data (a row) at the same index. Slots are cut into blocks of `size`;
//! a contact belongs to the block of its `i`. A sweep runs
//!
//! 1. the even blocks, each with the slots of itself and the next block (pairwise disjoint, so
//!    they run in parallel), taking the contacts whose `j` lies in those two blocks;
//! 2. the odd blocks, the same way;
//! 3. the leftover contacts (those whose `j` lies further away), one after another;
//!
//! and plane contacts run block by block (one particle is never in two blocks). One sweep runs
//! otherwise: shock propagation's, block after block in slot order, serially
//! (`Blocks::every_pair_in_order`), then the leftovers. Inside a block,
//! contacts go in sorted order. So the order of every response is fixed by the contact set and
//! the slots alone: the same for any thread count, and the same whichever broad phase found the
//! contacts. Running the blocks serially gives the very same bits. (How one parity's blocks are
//! handed to the thread pool, two to a task, is `spans.rs`'s.)
//!
//! The same order runs across processes ([`crate::cluster`]): each process holds a run of
//! whole blocks, and an `Exchange` lends it the particles of the next process's first block
//! that its border block pair touches, runs the leftovers in their global order and adds up
//! the counts that decide when a phase stops. Alone in one process, `Alone` does none of that.
//!
//! **Work lists.** After the first sweep of a pass, most contacts have nothing left to do: a
//! sweep only needs the contacts one of whose particles changed since the contact was last
//! visited. Each particle carries a *stamp*, the number of the last sweep that changed it
//! (`Visit`); a sweep visits a contact when either stamp is at least `since` (the previous
//! sweep's number). A rule that says it changed nothing (`Change::Nothing`) changed nothing,
//! and a second visit with unchanged particles changes nothing (the rules' dead bands cover
//! rounding), so skipping a contact gives the very bits visiting it would: the work list changes the cost of a sweep, never its result, and a
//! process that visits every contact (the cluster's) stays bit-identical to one that does not.
//! A sweep finds the contacts of its changed particles through an index by particle
//! (`frontier.rs`) instead of scanning every contact, with the same result.

use crate::broadphase::Pair;
use crate::frontier::{Frontier, Stamps};
use crate::solver::{Row, RowRecord, RowsMut};
use crate::vector::Vector;
pub(crate) use both::MoveRules;
use spans::{split_run, PairWork, PlaneWork};

mod both;
mod spans;

/// A particle touching a plane: `(slot, plane index)`.
pub type PlaneContact = (u32, u32);

/// How contacts are split into blocks for one step.
#[derive(Debug, Default)]
pub(crate) struct Blocks {
    /// Slots per block (> 0).
    pub size: usize,
    /// `pairs[pair_start[b]..pair_start[b + 1]]` are block `b`'s contacts.
    pair_start: Vec<usize>,
    /// The same for plane contacts.
    plane_start: Vec<usize>,
    /// Indices (into the pairs) of the contacts whose `j` is beyond the next block, ascending.
    pub(crate) leftovers: Vec<u32>,
    /// Global index of block 0 (non-zero when this process holds a later run of blocks): the
    /// even/odd split goes by global block index.
    first_block: usize,
    /// Run blocks on the thread pool (otherwise serially; same result).
    parallel: bool,
    /// The blocks' contacts by particle, for the work lists (when indexed).
    frontier: Frontier,
}

/// What one application of a rule did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Change {
    /// Nothing: not a bit of the row or the particles changed.
    Nothing,
    /// Something, too little to keep the sweeps going.
    Small,
    /// Enough to keep the sweeps going (counted).
    Counted,
}

impl Change {
    /// 1 when counted.
    #[inline]
    fn count(self) -> u64 {
        (self == Change::Counted) as u64
    }

    /// A change that was made: counted when `keep_going`, else small.
    #[inline]
    pub fn counted_if(keep_going: bool) -> Self {
        if keep_going {
            Change::Counted
        } else {
            Change::Small
        }
    }
}

impl From<bool> for Change {
    /// `true`: counted; `false`: nothing.
    #[inline]
    fn from(counted: bool) -> Self {
        if counted {
            Change::Counted
        } else {
            Change::Nothing
        }
    }
}

/// A rule applied to one pair: its row (both parts) and the two particles' values (velocities
/// or positions); says what it changed. Used with a work list ([`Visit`]), a rule that returns
/// [`Change::Nothing`] must have changed nothing. (A rule that never reads the
/// [`RowRecord`] never brings it from memory.)
pub(crate) trait PairRule<V>:
    Fn(&mut Row<V>, &mut RowRecord, &mut V, &mut V) -> Change + Sync
{
}
impl<V, F: Fn(&mut Row<V>, &mut RowRecord, &mut V, &mut V) -> Change + Sync> PairRule<V> for F {}

/// Rows a span of work owns: split in two at an index, or empty.
pub(crate) trait Split: Default + Send + Sized {
    /// `..at` and `at..`.
    fn split_at_mut(self, at: usize) -> (Self, Self);
}

impl<T: Send> Split for &mut [T] {
    #[inline]
    fn split_at_mut(self, at: usize) -> (Self, Self) {
        <[T]>::split_at_mut(self, at)
    }
}

/// Two arrays of particle data split at the same slot (see [`Blocks::move_and_place`]).
impl<A: Send, B: Send> Split for (&mut [A], &mut [B]) {
    #[inline]
    fn split_at_mut(self, at: usize) -> (Self, Self) {
        let (a, a_rest) = self.0.split_at_mut(at);
        let (b, b_rest) = self.1.split_at_mut(at);
        ((a, b), (a_rest, b_rest))
    }
}

/// The same for a particle against a plane.
pub(crate) trait PlaneRule<V, R>: Fn(&mut R, &mut V) -> Change + Sync {}
impl<V, R, F: Fn(&mut R, &mut V) -> Change + Sync> PlaneRule<V, R> for F {}

/// Which contacts a sweep visits, and what it stamps (see the module notes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Visit {
    /// Visit the contacts with a particle stamped at least this (0: every contact).
    pub since: u32,
    /// Stamp the particles a rule changed with this (0: stamp nothing).
    pub now: u32,
}

impl Visit {
    /// Every contact, stamping nothing.
    pub const ALL: Visit = Visit { since: 0, now: 0 };

    /// Whether the contact of particles `i` and `j` is visited; `stamps` empty means no work
    /// list (every contact is).
    #[inline]
    fn wants(self, stamps: &Stamps, i: usize, j: usize) -> bool {
        stamps.is_empty() || stamps.get(i).max(stamps.get(j)) >= self.since
    }

    /// Records that the rule changed particles `i` and `j`.
    #[inline]
    fn stamp(self, stamps: &mut Stamps, i: usize, j: usize) {
        if self.now != 0 && !stamps.is_empty() {
            stamps.set(i, self.now);
            stamps.set(j, self.now);
        }
    }
}

impl Blocks {
    /// Splits this step's contacts; `pairs` and `plane_contacts` must be sorted. Slot 0 here
    /// is the first slot of global block `first_block`.
    pub fn plan(
        &mut self,
        n: usize,
        size: usize,
        pairs: &[Pair],
        plane_contacts: &[PlaneContact],
        parallel: bool,
        first_block: usize,
    ) {
        self.size = size.max(1);
        // (the work lists' stamp groups split at block boundaries)
        debug_assert!(self.size % crate::frontier::GROUP == 0 || n <= self.size);
        self.parallel = parallel;
        self.first_block = first_block;
        let count = n.div_ceil(self.size).max(1);
        let size = self.size;
        self.pair_start.clear();
        self.plane_start.clear();
        for b in 0..=count {
            let first_slot = (b * size) as u32;
            self.pair_start
                .push(pairs.partition_point(|&(i, _)| i < first_slot));
            self.plane_start
                .push(plane_contacts.partition_point(|&(i, _)| i < first_slot));
        }
        self.frontier.clear();
        self.leftovers.clear();
        for b in 0..count {
            let limit = ((b + 2) * size) as u32;
            let (first, last) = (self.pair_start[b], self.pair_start[b + 1]);
            for (k, &(_, j)) in pairs[first..last].iter().enumerate() {
                if j >= limit {
                    self.leftovers.push((first + k) as u32);
                }
            }
        }
        crate::broadphase::keep_headroom(&mut self.leftovers);
    }

    /// Indexes the contacts `pairs` (those of the last [`Blocks::plan`]) by particle, so that
    /// sweeps with a work list visit the changed contacts without scanning for them (see
    /// [`crate::frontier`]; the same result either way).
    pub fn index_contacts(&mut self, n: usize, pairs: &[Pair]) {
        self.frontier
            .index(pairs, &self.pair_start, self.size, n, self.parallel);
    }

    /// Whether the blocks run on the thread pool.
    pub fn parallel(&self) -> bool {
        self.parallel
    }

    fn count(&self) -> usize {
        self.pair_start.len() - 1
    }

    /// One sweep over every pair, in the fixed order: the even blocks, then the odd blocks (each
    /// set in parallel), then the leftovers one after another. Returns how many applications
    /// of `rule` changed something, as (this process's blocks, all leftovers). `reverse` walks
    /// each block's pairs backwards (the leftovers always go forwards).
    #[allow(clippy::too_many_arguments)]
    pub fn sweep_pairs<V: Vector, E: Exchange<V>>(
        &self,
        exchange: &mut E,
        data: &mut [V],
        stamps: &mut Stamps,
        visit: Visit,
        pairs: &[Pair],
        mut rows: RowsMut<V>,
        reverse: bool,
        rule: &impl PairRule<V>,
    ) -> (u64, u64) {
        let mut changed = 0;
        for parity in 0..2 {
            exchange.before_blocks(parity, data);
            changed += self.run_parity(
                data,
                stamps.reborrow(),
                visit,
                pairs,
                rows.reborrow(),
                parity,
                reverse,
                rule,
            );
            exchange.after_blocks(parity, data);
        }
        let leftovers = exchange.leftovers(self, data, stamps, visit, pairs, rows, rule);
        (changed, leftovers)
    }

    /// [`Blocks::sweep_pairs`] over every pair, forwards, without a work list.
    pub fn every_pair<V: Vector, E: Exchange<V>>(
        &self,
        exchange: &mut E,
        data: &mut [V],
        pairs: &[Pair],
        rows: RowsMut<V>,
        rule: &impl PairRule<V>,
    ) -> (u64, u64) {
        self.sweep_pairs(
            exchange,
            data,
            &mut Stamps::none(),
            Visit::ALL,
            pairs,
            rows,
            false,
            rule,
        )
    }

    /// One sweep over every pair in slot order, serially: block after block (each with its
    /// contacts into the next block), then the leftovers. A change so travels from the first
    /// slot to the last within the sweep, which the even/odd order of [`Blocks::sweep_pairs`]
    /// carries about two blocks (what shock propagation needs: support climbing a pile whose
    /// blocks are its layers). Across processes, each runs its blocks after the one before it
    /// (see [`Exchange::in_order`]). Returns the same counts as [`Blocks::every_pair`].
    pub fn every_pair_in_order<V: Vector, E: Exchange<V>>(
        &self,
        exchange: &mut E,
        data: &mut [V],
        pairs: &[Pair],
        mut rows: RowsMut<V>,
        rule: &impl PairRule<V>,
    ) -> (u64, u64) {
        let changed = exchange.in_order(data, &mut |data: &mut [V]| {
            self.run_in_order(data, pairs, rows.reborrow(), rule)
        });
        let leftovers = exchange.leftovers(
            self,
            data,
            &mut Stamps::none(),
            Visit::ALL,
            pairs,
            rows,
            rule,
        );
        (changed, leftovers)
    }

    /// The blocks of one global parity, each with the slots of itself and the next block.
    #[allow(clippy::too_many_arguments)]
    fn run_parity<V: Vector>(
        &self,
        data: &mut [V],
        stamps: Stamps,
        visit: Visit,
        pairs: &[Pair],
        rows: RowsMut<V>,
        global_parity: usize,
        reverse: bool,
        rule: &impl PairRule<V>,
    ) -> u64 {
        let parity = (global_parity + self.first_block) % 2;
        let Some(run) = ParitySpans::of(self, parity, data.len()) else {
            return 0;
        };
        let (spans, slot, row) = (run.spans, |c| run.slot(c), |c| run.pair_row(c));
        let work = PairWork {
            blocks: self,
            parity,
            visit,
            pairs,
            reverse,
            rule,
        };
        let (s0, r0) = (slot(0), row(0));
        split_run(
            self.parallel,
            0..spans,
            &slot,
            &row,
            &mut data[s0..],
            stamps.split_at(s0).1,
            rows.split_at_mut(row(spans)).0.split_at_mut(r0).1,
            &work,
        )
    }

    /// Applies `rule` to every plane contact (`plane_contacts[k]` with row `plane_rows[k]`)
    /// that `visit` wants, block by block, and returns how many applications changed
    /// something.
    pub fn run_planes<V: Send, R: Send>(
        &self,
        data: &mut [V],
        stamps: &mut Stamps,
        visit: Visit,
        plane_contacts: &[PlaneContact],
        plane_rows: &mut [R],
        rule: &impl PlaneRule<V, R>,
    ) -> u64 {
        let size = self.size;
        let count = self.count();
        let n = data.len();
        let slot = |b: usize| (b * size).min(n);
        let row = |b: usize| self.plane_start[b.min(count)];
        let all = row(count);
        let work = PlaneWork {
            visit,
            plane_contacts,
            rule,
        };
        split_run(
            self.parallel,
            0..count,
            &slot,
            &row,
            data,
            stamps.reborrow(),
            &mut plane_rows[..all],
            &work,
        )
    }

    /// [`Blocks::run_planes`] over every plane contact, without a work list.
    pub fn every_plane<V: Send, R: Send>(
        &self,
        data: &mut [V],
        plane_contacts: &[PlaneContact],
        plane_rows: &mut [R],
        rule: &impl PlaneRule<V, R>,
    ) -> u64 {
        self.run_planes(
            data,
            &mut Stamps::none(),
            Visit::ALL,
            plane_contacts,
            plane_rows,
            rule,
        )
    }
}

/// The spans of one parity's blocks over `n` slots (see [`Blocks::sweep_pairs`]): span `c` is
/// blocks `parity + 2 c` and the next, as slots and as rows.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ParitySpans<'b> {
    blocks: &'b Blocks,
    /// The parity (of this process's blocks).
    pub parity: usize,
    /// How many spans.
    pub spans: usize,
    n: usize,
}

impl<'b> ParitySpans<'b> {
    /// `None` when `parity` has no block with a slot.
    pub fn of(blocks: &'b Blocks, parity: usize, n: usize) -> Option<Self> {
        let count = blocks.count();
        (parity < count && parity * blocks.size < n).then(|| Self {
            blocks,
            parity,
            spans: (count - parity).div_ceil(2),
            n,
        })
    }

    /// The block starting span `c`, or the count past the last.
    fn block(&self, c: usize) -> usize {
        (self.parity + 2 * c).min(self.blocks.count())
    }

    /// Span `c`'s first slot (`n` past the last span).
    pub fn slot(&self, c: usize) -> usize {
        ((self.parity + 2 * c) * self.blocks.size).min(self.n)
    }

    /// Span `c`'s first pair row.
    pub fn pair_row(&self, c: usize) -> usize {
        self.blocks.pair_start[self.block(c)]
    }

    /// Span `c`'s first plane row.
    pub fn plane_row(&self, c: usize) -> usize {
        self.blocks.plane_start[self.block(c)]
    }
}

/// `&mut s[i]` and `&mut s[j]` at once, for `i < j`.
#[inline]
pub(crate) fn pair_mut<T>(s: &mut [T], i: usize, j: usize) -> (&mut T, &mut T) {
    let (head, tail) = s.split_at_mut(j);
    (&mut head[i], &mut tail[0])
}

/// What one sweep needs from beyond this process's slots (see the module notes). Every method
/// is collective across processes: all of them make the same calls in the same order.
pub(crate) trait Exchange<V: Vector> {
    /// Before the blocks of global parity `parity` run on `data`.
    fn before_blocks(&mut self, parity: usize, data: &mut [V]);
    /// After the blocks of global parity `parity` ran on `data`.
    fn after_blocks(&mut self, parity: usize, data: &mut [V]);
    /// Runs every leftover pair (of every process) in global order and returns how many
    /// changed anything: the same number on every process. May visit pairs `visit` does not
    /// want (the result is the same), and stamps as `visit` says.
    #[allow(clippy::too_many_arguments)]
    fn leftovers(
        &mut self,
        blocks: &Blocks,
        data: &mut [V],
        stamps: &mut Stamps,
        visit: Visit,
        pairs: &[Pair],
        rows: RowsMut<V>,
        rule: &impl PairRule<V>,
    ) -> u64;
    /// Copies what the leftover rules changed in this process's own leftover rows back into
    /// `rows` (a process that runs the leftovers on a copy of every process's rows).
    fn settle_rows(&mut self, blocks: &Blocks, rows: RowsMut<V>);
    /// Marks the impulses now accumulated as the ones the relax pass kept (`Row::kept`) on the
    /// rows this exchange runs for every process (the own rows are marked by the caller).
    fn keep_impulses(&mut self);
    /// Runs `own` (this process's blocks, in order, on `data`) after every process before it
    /// ran its own, with the particles of the next process's first block lent for it: a sweep
    /// in global slot order. Returns what `own` returns.
    fn in_order(&mut self, data: &mut [V], own: &mut dyn FnMut(&mut [V]) -> u64) -> u64;
    /// `local` added up over every process.
    fn total(&mut self, local: u64) -> u64;
    /// The largest of `local` over every process.
    fn largest(&mut self, local: f64) -> f64;
    /// True when this process holds every slot (nothing is lent), so that a pass may carry
    /// positions and velocities together (see [`Blocks::move_and_place`]).
    fn alone(&self) -> bool {
        false
    }
}

/// One process holding every slot: nothing to exchange.
pub(crate) struct Alone;

impl<V: Vector> Exchange<V> for Alone {
    #[inline]
    fn before_blocks(&mut self, _parity: usize, _data: &mut [V]) {}
    #[inline]
    fn after_blocks(&mut self, _parity: usize, _data: &mut [V]) {}
    fn leftovers(
        &mut self,
        blocks: &Blocks,
        data: &mut [V],
        stamps: &mut Stamps,
        visit: Visit,
        pairs: &[Pair],
        rows: RowsMut<V>,
        rule: &impl PairRule<V>,
    ) -> u64 {
        let mut changed = 0;
        for &k in &blocks.leftovers {
            let (i, j) = pairs[k as usize];
            let (i, j) = (i as usize, j as usize);
            if !visit.wants(stamps, i, j) {
                continue;
            }
            let (a, b) = pair_mut(data, i, j);
            let change = rule(
                &mut rows.row[k as usize],
                &mut rows.record[k as usize],
                a,
                b,
            );
            if change != Change::Nothing {
                visit.stamp(stamps, i, j);
                changed += change.count();
            }
        }
        changed
    }
    #[inline]
    fn in_order(&mut self, data: &mut [V], own: &mut dyn FnMut(&mut [V]) -> u64) -> u64 {
        own(data)
    }
    #[inline]
    fn settle_rows(&mut self, _blocks: &Blocks, _rows: RowsMut<V>) {}
    #[inline]
    fn keep_impulses(&mut self) {}
    #[inline]
    fn total(&mut self, local: u64) -> u64 {
        local
    }
    #[inline]
    fn largest(&mut self, local: f64) -> f64 {
        local
    }
    fn alone(&self) -> bool {
        true
    }
}
