//! The solver's [`Exchange`] across ranks: the next rank's first block lent around the block
//! pairs on a border, the leftover contacts run on every rank in their global order, and the
//! counts that stop each phase added up.

use super::partition::Partition;
use super::traffic::{Link, TrafficKind};
use super::transport::Transport;
use super::wire::{Reader, Writer};
use crate::broadphase::Pair;
use crate::frontier::Stamps;
use crate::schedule::{pair_mut, Blocks, Change, Exchange, PairRule, Visit};
use crate::solver::{Row, RowRecord, Rows, RowsMut};
use crate::vector::Vector;

/// The rank that borrows `rank`'s first block (in the sweeps of `parity`, or at all when
/// `None`).
pub(super) fn borrower(partition: &Partition, rank: usize, parity: Option<usize>) -> Option<usize> {
    let first = partition.blocks_of(rank);
    if first.is_empty() || first.start == 0 {
        return None;
    }
    let before = first.start - 1;
    parity
        .is_none_or(|p| before % 2 == p)
        .then(|| partition.owner_of_block(before))
}

/// The rank whose first block `rank` borrows (in the sweeps of `parity`, or at all).
pub(super) fn lender(partition: &Partition, rank: usize, parity: Option<usize>) -> Option<usize> {
    let last = partition.blocks_of(rank).end.checked_sub(1)?;
    let owner = partition.halo_owner(rank)?;
    parity.is_none_or(|p| last % 2 == p).then_some(owner)
}

/// Encodes a solver row.
pub(super) fn write_row<V: Vector>(w: &mut Writer, row: &Row<V>, record: &RowRecord) {
    w.vector(row.normal)
        .f64(record.mass[0])
        .f64(record.mass[1])
        .f64(row.inverse_mass[0])
        .f64(row.inverse_mass[1])
        .f64(record.radius[0])
        .f64(record.radius[1])
        .f64(row.impulse)
        .f64(record.kept)
        .f64(row.bounce)
        .f64(record.overlap)
        .f64(row.allowance)
        .f64(record.distance)
        .f64(row.delivered)
        .u32(
            row.touching as u32
                | (row.met as u32) << 1
                | (row.impact as u32) << 2
                | (row.kicked as u32) << 3
                | (row.struck as u32) << 4,
        );
}

/// Decodes a solver row.
pub(super) fn read_row<V: Vector>(r: &mut Reader) -> (Row<V>, RowRecord) {
    let normal = r.vector();
    let mass = [r.f64(), r.f64()];
    let inverse_mass = [r.f64(), r.f64()];
    let radius = [r.f64(), r.f64()];
    let (impulse, kept, bounce, overlap) = (r.f64(), r.f64(), r.f64(), r.f64());
    let (allowance, distance, delivered) = (r.f64(), r.f64(), r.f64());
    let bits = r.u32();
    let row = Row {
        normal,
        inverse_mass,
        effective_mass: 1.0 / (inverse_mass[0] + inverse_mass[1]),
        impulse,
        bounce,
        allowance,
        delivered,
        touching: bits & 1 != 0,
        met: bits & 2 != 0,
        impact: bits & 4 != 0,
        kicked: bits & 8 != 0,
        struck: bits & 16 != 0,
    };
    let record = RowRecord {
        mass,
        radius,
        kept,
        overlap,
        distance,
        // (split runs refuse periodic axes, so no row of theirs is shifted)
        wrap: Default::default(),
    };
    (row, record)
}

/// This step's leftover contacts of every rank, in global order, with their rows: every rank
/// runs them all on its own copy, so the copies stay equal.
#[derive(Debug, Default)]
pub(super) struct Leftovers<V> {
    /// Indices into `slots` of each contact, in global order.
    pairs: Vec<(u32, u32)>,
    /// Every contact's row.
    rows: Rows<V>,
    /// Every particle some leftover involves, by ascending global slot.
    slots: Vec<u32>,
    /// `slots[own.clone()]` are this rank's.
    own: std::ops::Range<usize>,
    /// `rows[own_rows.clone()]` are this rank's leftovers, in its own order.
    own_rows: std::ops::Range<usize>,
}

impl<V: Vector> Leftovers<V> {
    /// Collects every rank's leftovers (`blocks.leftovers`, indices into `pairs`, whose slots
    /// are relative to `first_slot`) with their rows. Collective.
    pub fn gather<T: Transport + ?Sized>(
        &mut self,
        link: &mut Link<'_, T>,
        first_slot: usize,
        own: usize,
        blocks: &Blocks,
        pairs: &[Pair],
        rows: &Rows<V>,
    ) {
        let first = first_slot as u32;
        let mut mine = Writer::default();
        for &k in &blocks.leftovers {
            let (i, j) = pairs[k as usize];
            mine.u32(first + i).u32(first + j);
            write_row(&mut mine, &rows.row[k as usize], &rows.record[k as usize]);
        }
        let mut global = Vec::new();
        self.rows.clear();
        let me = link.transport.rank();
        for (rank, bytes) in link
            .gather(TrafficKind::Leftovers, &mine.0)
            .iter()
            .enumerate()
        {
            let start = self.rows.len();
            let mut r = Reader::new(bytes);
            while !r.is_empty() {
                global.push((r.u32(), r.u32()));
                self.rows.push(read_row(&mut r));
            }
            if rank == me {
                self.own_rows = start..self.rows.len();
            }
        }
        self.slots.clear();
        self.slots.extend(global.iter().flat_map(|&(i, j)| [i, j]));
        self.slots.sort_unstable();
        self.slots.dedup();
        let own_slots = first..first + own as u32;
        self.own = self.slots.partition_point(|&s| s < own_slots.start)
            ..self.slots.partition_point(|&s| s < own_slots.end);
        let slots = &self.slots;
        let index = |s: u32| slots.binary_search(&s).unwrap_or_default() as u32;
        self.pairs.clear();
        self.pairs
            .extend(global.iter().map(|&(i, j)| (index(i), index(j))));
    }
}

/// The [`Exchange`] of one rank for one phase.
pub(super) struct Lender<'a, 'l, T: ?Sized, V> {
    pub link: &'a mut Link<'l, T>,
    pub partition: &'a Partition,
    pub rank: usize,
    pub first_slot: usize,
    pub own: usize,
    /// Borrowed slots (offsets into the next rank's first block) this step's contacts touch.
    pub needed: &'a [u32],
    /// Offsets into the own first block that the previous rank's contacts touch this step.
    pub lent: &'a [u32],
    /// Whether any rank borrows anything in the sweeps of parity 0 and 1 this step.
    pub lending: [bool; 2],
    pub leftovers: &'a mut Leftovers<V>,
}

impl<T: Transport + ?Sized, V: Vector> Lender<'_, '_, T, V> {
    /// Lends (`back == false`) or returns (`back == true`) the borrowed particles the block
    /// pairs of `parity` touch (of either parity when `None`); when `turn` is given, only
    /// rank `turn` returns what it borrowed.
    fn swap_halo(
        &mut self,
        parity: Option<usize>,
        data: &mut [V],
        back: bool,
        turn: Option<usize>,
    ) {
        let lending = match parity {
            Some(p) => self.lending[p],
            None => self.lending[0] || self.lending[1],
        };
        if !lending {
            return;
        }
        let borrower = borrower(self.partition, self.rank, parity)
            .filter(|&b| !back || turn.is_none_or(|t| t == b));
        let lender = lender(self.partition, self.rank, parity)
            .filter(|_| turn.is_none_or(|t| t == self.rank));
        let own = self.own;
        let mut outgoing: Vec<Writer> = (0..self.link.ranks()).map(|_| Writer::default()).collect();
        match (back, borrower, lender) {
            (false, Some(to), _) => {
                for &k in self.lent {
                    outgoing[to].vector(data[k as usize]);
                }
            }
            (true, _, Some(to)) => {
                for &k in self.needed {
                    outgoing[to].vector(data[own + k as usize]);
                }
            }
            _ => {}
        }
        let received = self.link.exchange(TrafficKind::Halo, outgoing);
        match (back, borrower, lender) {
            (false, _, Some(from)) => {
                let mut r = Reader::new(&received[from]);
                for &k in self.needed {
                    data[own + k as usize] = r.vector();
                }
            }
            (true, Some(from), _) => {
                let mut r = Reader::new(&received[from]);
                for &k in self.lent {
                    data[k as usize] = r.vector();
                }
            }
            _ => {}
        }
    }
}

impl<T: Transport + ?Sized, V: Vector> Exchange<V> for Lender<'_, '_, T, V> {
    fn before_blocks(&mut self, parity: usize, data: &mut [V]) {
        self.swap_halo(Some(parity), data, false, None);
    }

    fn after_blocks(&mut self, parity: usize, data: &mut [V]) {
        self.swap_halo(Some(parity), data, true, None);
    }

    fn in_order(&mut self, data: &mut [V], own: &mut dyn FnMut(&mut [V]) -> u64) -> u64 {
        // (every rank's border particles go out at once; then rank after rank runs its blocks
        // and hands back what it borrowed, before the next one runs)
        self.swap_halo(None, data, false, None);
        let mut changed = 0;
        for turn in 0..self.link.ranks() {
            if turn == self.rank {
                changed = own(data);
            }
            self.swap_halo(None, data, true, Some(turn));
        }
        changed
    }

    fn leftovers(
        &mut self,
        _blocks: &Blocks,
        data: &mut [V],
        _stamps: &mut Stamps,
        _visit: Visit,
        _pairs: &[Pair],
        _rows: RowsMut<V>,
        rule: &impl PairRule<V>,
    ) -> u64 {
        let l = &mut *self.leftovers;
        if l.pairs.is_empty() {
            return 0;
        }
        let mut mine = Writer::default();
        for &s in &l.slots[l.own.clone()] {
            mine.vector(data[s as usize - self.first_slot]);
        }
        let mut values: Vec<V> = Vec::with_capacity(l.slots.len());
        for bytes in self.link.gather(TrafficKind::Leftovers, &mine.0) {
            let mut r = Reader::new(&bytes);
            while !r.is_empty() {
                values.push(r.vector());
            }
        }
        let mut changed = 0;
        let rows = l.rows.row.iter_mut().zip(l.rows.record.iter_mut());
        for (&(a, b), (row, record)) in l.pairs.iter().zip(rows) {
            let (va, vb) = pair_mut(&mut values, a as usize, b as usize);
            changed += (rule(row, record, va, vb) == Change::Counted) as u64;
        }
        for k in l.own.clone() {
            data[l.slots[k] as usize - self.first_slot] = values[k];
        }
        changed
    }

    fn settle_rows(&mut self, blocks: &Blocks, rows: RowsMut<V>) {
        let l = &*self.leftovers;
        let own = l.own_rows.clone();
        let settled = l.rows.row[own.clone()].iter().zip(&l.rows.record[own]);
        for (&k, (row, record)) in blocks.leftovers.iter().zip(settled) {
            rows.row[k as usize] = *row;
            rows.record[k as usize] = *record;
        }
    }

    fn keep_impulses(&mut self) {
        self.leftovers.rows.as_mut().keep_impulses(false);
    }

    fn total(&mut self, local: u64) -> u64 {
        self.link.sum(&[local])[0]
    }

    fn largest(&mut self, local: f64) -> f64 {
        self.link.largest(local)
    }
}
