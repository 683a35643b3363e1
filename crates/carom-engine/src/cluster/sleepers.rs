//! Sleeping particles across ranks (see [`crate::sleep`]): each rank marks the very slots that
//! one [`crate::World`] would put to sleep, from its own share of the contact candidates.
//!
//! A particle stays awake when it is within [`WAKE_HOPS`] candidate pairs of a restless one
//! (one that has not rested the sleep time). A rank holds the candidates whose lower slot it
//! owns, so the hops cross ranks: the *foreign* slots its candidates reach belong to later
//! ranks, and its own slots may be reached by earlier ranks' candidates. Then, only when some
//! particle anywhere has rested long enough:
//!
//! 1. each rank tells the owner of every foreign slot it reaches that it reaches it, and
//!    whether one of its own slots holds it up (one all-to-all), so every owner knows which
//!    of its slots each rank asks about, and what holds each up;
//! 2. for each hop, every rank sends each other rank whether the slots that rank asks about
//!    are awake, and for each slot of that rank it reaches, whether an awake slot of its own
//!    reaches it (one all-to-all per hop); each rank then marks its own slots exactly as one
//!    world marks them;
//! 3. one exchange more tells every rank the final marks of the foreign slots it reaches, for
//!    the contacts it holds with them.
//!
//! Everything here is a function of the global state alone, so it is the marking
//! [`crate::sleep::Sleepers`] finds in one process.

use super::partition::Partition;
use super::traffic::{Link, TrafficKind};
use super::transport::Transport;
use super::wire::{Reader, Writer};
use crate::broadphase::Pair;
use crate::sleep::{self, Support, WAKE_HOPS};

/// This step's sleeping slots of one rank, and reused space.
#[derive(Debug, Default)]
pub(super) struct SplitSleepers {
    /// Per own slot: asleep this step.
    pub asleep: Vec<bool>,
    /// How many own slots are asleep this step.
    pub count: usize,
    /// Foreign slots (relative to the first own one) the candidates reach, sorted.
    foreign: Vec<u32>,
    /// Per foreign slot (as in `foreign`): asleep this step.
    foreign_asleep: Vec<bool>,
    /// Per rank: the own slots (relative) its candidates reach, in the order it sent them.
    asked: Vec<Vec<u32>>,
    /// Per own slot, then per foreign slot: awake after the hops so far (scratch).
    awake: Vec<bool>,
    /// The next hop's marks; in an exchange, per foreign slot, whether an awake own slot
    /// reaches it (scratch).
    reached: Vec<bool>,
    /// Per own slot: an awake slot of an earlier rank reaches it (scratch).
    from_earlier: Vec<bool>,
    /// Per own slot, then per foreign slot: something holds it up (scratch; see
    /// [`Support`]).
    held: Vec<bool>,
}

impl SplitSleepers {
    /// Marks this step's sleeping own slots from `pairs` (slots relative to `first_slot`, the
    /// lower one own) and the own slots' rest times, and learns which foreign slots `pairs`
    /// reach sleep. Collective. Returns the own count.
    #[allow(clippy::too_many_arguments)]
    pub fn mark<T: Transport + ?Sized>(
        &mut self,
        link: &mut Link<'_, T>,
        partition: &Partition,
        first_slot: usize,
        pairs: &[Pair],
        rest: &[f64],
        time: f64,
        support: &Support<'_>,
    ) -> usize {
        let own = rest.len();
        self.asleep.clear();
        self.asleep.resize(own, false);
        self.count = 0;
        self.foreign.clear();
        self.foreign_asleep.clear();
        let ripe_here = rest.iter().filter(|&&t| t >= time).count() as u64;
        if link.sum_of(TrafficKind::Sleep, &[ripe_here])[0] == 0 {
            return 0;
        }
        self.foreign
            .extend(pairs.iter().map(|&(_, j)| j).filter(|&j| j as usize >= own));
        self.foreign.sort_unstable();
        self.foreign.dedup();
        // what holds each slot up (see `Support`); the owners of foreign slots learn it below
        let places = own + self.foreign.len();
        let foreign = &self.foreign;
        let index = |j: u32| index_of(foreign, j, own);
        sleep::held_up(support, pairs, own, places, &mut self.held, index);
        self.ask_owners(link, partition, first_slot, own);
        self.awake.clear();
        self.awake.extend(rest.iter().map(|&t| t < time));
        self.awake.resize(own + self.foreign.len(), false);
        for _ in 0..WAKE_HOPS {
            self.exchange_marks(link, partition, first_slot, pairs, own);
            self.spread(pairs, own);
        }
        self.count = sleep::put_to_sleep(&mut self.asleep, &self.awake, &self.held);
        // (one exchange more: the foreign slots' final marks, as their owners decided them)
        for (awake, &asleep) in self.awake.iter_mut().zip(&self.asleep) {
            *awake = !asleep;
        }
        self.exchange_marks(link, partition, first_slot, pairs, own);
        self.foreign_asleep
            .extend(self.awake[own..].iter().map(|&awake| !awake));
        self.count
    }

    /// True when slot `j` (relative to the first own slot; own, or foreign and reached by this
    /// step's candidates) sleeps this step.
    #[inline]
    pub fn sleeps(&self, j: usize) -> bool {
        match j.checked_sub(self.asleep.len()) {
            None => self.count > 0 && self.asleep[j],
            Some(_) => self.foreign_sleeps(j as u32),
        }
    }

    /// Per own slot, whether it sleeps this step; empty when none does.
    pub fn flags(&self) -> &[bool] {
        if self.count > 0 {
            &self.asleep
        } else {
            &[]
        }
    }

    fn foreign_sleeps(&self, j: u32) -> bool {
        match self.foreign.binary_search(&j) {
            Ok(k) => self.foreign_asleep.get(k).copied().unwrap_or(false),
            Err(_) => false,
        }
    }

    /// Index in `awake` of slot `j` (relative; foreign ones after the own ones).
    fn index(&self, j: u32, own: usize) -> usize {
        index_of(&self.foreign, j, own)
    }

    /// Step 1 of the module notes.
    fn ask_owners<T: Transport + ?Sized>(
        &mut self,
        link: &mut Link<'_, T>,
        partition: &Partition,
        first_slot: usize,
        own: usize,
    ) {
        let mut outgoing: Vec<Writer> = (0..link.ranks()).map(|_| Writer::default()).collect();
        for (k, &j) in self.foreign.iter().enumerate() {
            let g = first_slot + j as usize;
            outgoing[partition.owner_of_slot(g)]
                .u64(g as u64)
                .u32(self.held[own + k] as u32);
        }
        let incoming = link.exchange(TrafficKind::Sleep, outgoing);
        self.asked.resize_with(incoming.len(), Vec::new);
        for (asked, bytes) in self.asked.iter_mut().zip(&incoming) {
            asked.clear();
            let mut r = Reader::new(bytes);
            while !r.is_empty() {
                let g = r.u64() as usize;
                debug_assert!((first_slot..first_slot + own).contains(&g));
                asked.push((g - first_slot) as u32);
                self.held[g - first_slot] |= r.u32() != 0;
            }
        }
    }

    /// Step 2 of the module notes, the exchange: brings the foreign slots' marks up to date
    /// and wakes the own slots that an awake slot of an earlier rank reaches.
    fn exchange_marks<T: Transport + ?Sized>(
        &mut self,
        link: &mut Link<'_, T>,
        partition: &Partition,
        first_slot: usize,
        pairs: &[Pair],
        own: usize,
    ) {
        // per foreign slot: whether an awake own slot reaches it
        self.reached.clear();
        self.reached.resize(self.foreign.len(), false);
        for &(i, j) in pairs {
            if j as usize >= own && self.awake[i as usize] {
                let k = self.index(j, own) - own;
                self.reached[k] = true;
            }
        }
        // To each rank: whether the own slots it asks about are awake, then, for each of its
        // slots reached here, whether an awake own slot reaches it.
        let mut outgoing: Vec<Writer> = (0..link.ranks()).map(|_| Writer::default()).collect();
        for (out, asked) in outgoing.iter_mut().zip(&self.asked) {
            for &s in asked {
                out.u32(self.awake[s as usize] as u32);
            }
        }
        for (&j, &reached) in self.foreign.iter().zip(&self.reached) {
            let owner = partition.owner_of_slot(first_slot + j as usize);
            outgoing[owner].u32(reached as u32);
        }
        let incoming = link.exchange(TrafficKind::Sleep, outgoing);
        // From each rank, the same two parts seen from the other side.
        let mut readers: Vec<Reader> = incoming.iter().map(|b| Reader::new(b)).collect();
        for k in 0..self.foreign.len() {
            let owner = partition.owner_of_slot(first_slot + self.foreign[k] as usize);
            self.awake[own + k] = readers[owner].u32() != 0;
        }
        self.from_earlier.clear();
        self.from_earlier.resize(own, false);
        for (r, asked) in readers.iter_mut().zip(&self.asked) {
            for &s in asked {
                if r.u32() != 0 {
                    self.from_earlier[s as usize] = true;
                }
            }
        }
    }

    /// Step 2 of the module notes, the hop: every own slot in a candidate pair with an awake
    /// slot wakes (the foreign slots' marks are brought up to date by the next exchange).
    fn spread(&mut self, pairs: &[Pair], own: usize) {
        self.reached.clear();
        self.reached.extend(
            (self.awake[..own].iter())
                .zip(&self.from_earlier)
                .map(|(&awake, &reached)| awake || reached),
        );
        let foreign = &self.foreign;
        let index = |j: u32| index_of(foreign, j, own);
        sleep::spread(pairs, &self.awake, &mut self.reached, index);
        self.awake[..own].copy_from_slice(&self.reached);
    }
}

/// Index in a rank's marks of slot `j` (relative to its first own slot): own slots first,
/// then the `foreign` ones (sorted) its candidates reach.
fn index_of(foreign: &[u32], j: u32, own: usize) -> usize {
    if (j as usize) < own {
        j as usize
    } else {
        own + foreign.binary_search(&j).expect("a foreign slot")
    }
}
