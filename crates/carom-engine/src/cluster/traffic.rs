//! What ranks send each other, counted by kind.

use super::transport::Transport;
use super::wire::{Reader, Writer};

/// What a message carried, for the traffic figures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrafficKind {
    /// Particles moving to a new owner at a spatial sort, and the bisection that finds where
    /// each rank's share starts.
    Migration,
    /// A neighbour's first block lent for the contacts across the border, and given back.
    Halo,
    /// Particles within interaction range of another rank's, for its broad phase.
    Ghosts,
    /// The contacts that reach past the next block, run on every rank in global order.
    Leftovers,
    /// Sums that stop a solver phase, bounding boxes, step statistics.
    Reductions,
    /// Which particles sleep, across ranks (see `cluster::sleepers`).
    Sleep,
    /// The whole state collected on rank 0 for output.
    Gather,
}

const KINDS: usize = 7;

impl TrafficKind {
    /// Every kind, in report order.
    pub const ALL: [TrafficKind; KINDS] = [
        TrafficKind::Migration,
        TrafficKind::Halo,
        TrafficKind::Ghosts,
        TrafficKind::Leftovers,
        TrafficKind::Reductions,
        TrafficKind::Sleep,
        TrafficKind::Gather,
    ];

    /// Short name for reports.
    pub fn name(self) -> &'static str {
        match self {
            TrafficKind::Migration => "migration",
            TrafficKind::Halo => "halo",
            TrafficKind::Ghosts => "ghosts",
            TrafficKind::Leftovers => "leftovers",
            TrafficKind::Reductions => "reductions",
            TrafficKind::Sleep => "sleep",
            TrafficKind::Gather => "gather",
        }
    }
}

/// Bytes and messages this rank sent to other ranks (a gather to all counts once per
/// receiver, as it would cost on a network), by kind.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Traffic {
    bytes: [u64; KINDS],
    messages: [u64; KINDS],
    collectives: [u64; KINDS],
}

impl Traffic {
    /// Bytes sent of one kind.
    pub fn bytes(&self, kind: TrafficKind) -> u64 {
        self.bytes[kind as usize]
    }
    /// Point-to-point messages sent of one kind (empty ones not counted).
    pub fn messages(&self, kind: TrafficKind) -> u64 {
        self.messages[kind as usize]
    }
    /// Collective operations of one kind this rank took part in (each is a synchronisation
    /// point: on a network, at least one latency).
    pub fn collectives(&self, kind: TrafficKind) -> u64 {
        self.collectives[kind as usize]
    }
    /// Bytes sent, all kinds.
    pub fn total_bytes(&self) -> u64 {
        self.bytes.iter().sum()
    }
    /// Collective operations, all kinds.
    pub fn total_collectives(&self) -> u64 {
        self.collectives.iter().sum()
    }
}

/// A transport that counts what goes through it.
pub(crate) struct Link<'a, T: ?Sized> {
    pub transport: &'a mut T,
    pub traffic: &'a mut Traffic,
}

impl<T: Transport + ?Sized> Link<'_, T> {
    pub fn ranks(&self) -> usize {
        self.transport.size()
    }

    pub fn gather(&mut self, kind: TrafficKind, mine: &[u8]) -> Vec<Vec<u8>> {
        let others = self.transport.size() as u64 - 1;
        let k = kind as usize;
        self.traffic.bytes[k] += mine.len() as u64 * others;
        self.traffic.messages[k] += if mine.is_empty() { 0 } else { others };
        self.traffic.collectives[k] += 1;
        self.transport.all_gather(mine)
    }

    pub fn exchange(&mut self, kind: TrafficKind, outgoing: Vec<Writer>) -> Vec<Vec<u8>> {
        let me = self.transport.rank();
        let k = kind as usize;
        for (to, w) in outgoing.iter().enumerate() {
            if to != me && !w.0.is_empty() {
                self.traffic.bytes[k] += w.0.len() as u64;
                self.traffic.messages[k] += 1;
            }
        }
        self.traffic.collectives[k] += 1;
        self.transport
            .all_to_all(outgoing.into_iter().map(|w| w.0).collect())
    }

    /// The largest of `local` over every rank.
    pub fn largest(&mut self, local: f64) -> f64 {
        let mut mine = Writer::default();
        mine.f64(local);
        self.gather(TrafficKind::Reductions, &mine.0)
            .iter()
            .map(|bytes| Reader::new(bytes).f64())
            .fold(local, f64::max)
    }

    /// `local` added up over every rank.
    pub fn sum(&mut self, local: &[u64]) -> Vec<u64> {
        self.sum_of(TrafficKind::Reductions, local)
    }

    /// `local` added up over every rank, counted as `kind`.
    pub fn sum_of(&mut self, kind: TrafficKind, local: &[u64]) -> Vec<u64> {
        let mut total = local.to_vec();
        if self.ranks() == 1 {
            return total;
        }
        let k = kind as usize;
        let others = self.transport.size() as u64 - 1;
        self.traffic.bytes[k] += 8 * local.len() as u64 * others;
        self.traffic.messages[k] += others;
        self.traffic.collectives[k] += 1;
        self.transport.all_sum(&mut total);
        total
    }
}
