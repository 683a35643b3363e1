//! The spatial sort across ranks: particles move to the rank of their new slot, with the
//! remembered impulses of their contacts.

use crate::cluster::traffic::{Link, TrafficKind};
use crate::cluster::transport::Transport;
use crate::cluster::wire::{Reader, Writer};
use crate::domain::Aabb;
use crate::grid::{bounding_box, GridLayout};
use crate::memory::{ContactImpulses, Memory};
use crate::vector::Vector;
use crate::world::sort_layout;

use super::*;

impl<V: Vector> Subdomain<V> {
    /// The spatial sort of [`World`], across ranks: every particle goes to the slot (and so to
    /// the rank) the whole world's sort would give it, with the remembered impulses of the
    /// contacts it owned (placed again at the next contact search).
    pub(super) fn migrate<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        let n = self.partition.slots();
        if n == 0 {
            return;
        }
        let bounds = self.sort_bounds(link);
        let layout = sort_layout(&bounds, self.max_radius, n);
        let mut order: Vec<(u64, u32)> = (0..self.own)
            .map(|s| {
                (
                    sort_value(&layout, self.window.position[s], self.ids[s]),
                    s as u32,
                )
            })
            .collect();
        order.sort_unstable();
        let splits = self.find_splits(link, &order);
        let outgoing = self.departures(&order, &splits, link.ranks());
        let arrivals = link.exchange(TrafficKind::Migration, outgoing);
        self.take_arrivals(arrivals);
        self.memory.clear();
        self.memory_partners.clear();
        self.rerouting = true;
    }

    /// The box the spatial sort's grid covers: the domain, or the bounding box of every rank's
    /// particles (one gather).
    fn sort_bounds<T: Transport + ?Sized>(&self, link: &mut Link<'_, T>) -> Aabb<V> {
        if let Some(domain) = self.config.domain {
            return domain;
        }
        let own = self.own;
        let mut w = Writer::default();
        if own > 0 {
            let b = bounding_box(&self.window.position[..own]);
            w.vector(b.min).vector(b.max);
        }
        let boxes = link.gather(TrafficKind::Reductions, &w.0);
        let mut all: Option<Aabb<V>> = None;
        for bytes in boxes.iter().filter(|b| !b.is_empty()) {
            let mut r = Reader::new(bytes);
            let (min, max) = (r.vector::<V>(), r.vector::<V>());
            all = Some(match all {
                None => Aabb { min, max },
                Some(a) => Aabb {
                    min: a.min.min_components(min),
                    max: a.max.max_components(max),
                },
            });
        }
        all.unwrap_or(Aabb {
            min: V::ZERO,
            max: V::ZERO,
        })
    }

    /// One message per rank: each own particle (in `order`, by sort value) with its state and
    /// its remembered impulses, to the rank whose range of values (`splits`) holds it. Only
    /// the particles that crossed a border move.
    fn departures(&self, order: &[(u64, u32)], splits: &[u64], ranks: usize) -> Vec<Writer> {
        let mut outgoing: Vec<Writer> = (0..ranks).map(|_| Writer::default()).collect();
        let (pairs, planes) = (&self.memory.pairs, &self.memory.planes);
        for &(value, s) in order {
            let w = &mut outgoing[splits.partition_point(|&split| split <= value)];
            let s = s as usize;
            w.u64(value)
                .vector(self.window.position[s])
                .vector(self.window.velocity[s])
                .f64(self.window.radius[s])
                .f64(self.window.mass[s])
                .f64(self.rest[s]);
            let mine = pairs.partition_point(|e| (e.0 as usize) < s)
                ..pairs.partition_point(|e| (e.0 as usize) <= s);
            w.u32(mine.len() as u32);
            for k in mine {
                w.u32(self.memory_partners[k]).f64(pairs[k].2);
            }
            let mine = planes.partition_point(|e| (e.0 as usize) < s)
                ..planes.partition_point(|e| (e.0 as usize) <= s);
            w.u32(mine.len() as u32);
            for k in mine {
                w.u32(planes[k].1).f64(planes[k].2);
            }
        }
        outgoing
    }

    /// Fills the own slots with the particles of `messages` ([`Subdomain::departures`] from
    /// every rank), in order of sort value, and keeps their impulses to be placed again.
    fn take_arrivals(&mut self, messages: Vec<Vec<u8>>) {
        let mut arrived: Vec<(u64, V, V, f64, f64, f64)> = Vec::with_capacity(self.own);
        self.arrived_pairs.clear();
        self.arrived_planes.clear();
        for bytes in messages {
            let mut r = Reader::new(&bytes);
            while !r.is_empty() {
                let record = (r.u64(), r.vector(), r.vector(), r.f64(), r.f64(), r.f64());
                let id = record.0 as u32;
                arrived.push(record);
                for _ in 0..r.u32() {
                    self.arrived_pairs.push((id, r.u32(), r.f64()));
                }
                for _ in 0..r.u32() {
                    self.arrived_planes.push((id, r.u32(), r.f64()));
                }
            }
        }
        arrived.sort_unstable_by_key(|a| a.0);
        debug_assert_eq!(arrived.len(), self.own, "a rank keeps its slot count");
        for (s, (value, x, v, radius, mass, rested)) in arrived.into_iter().enumerate() {
            self.ids[s] = value as u32;
            self.window.position[s] = x;
            self.window.velocity[s] = v;
            self.window.radius[s] = radius;
            self.window.mass[s] = mass;
            self.rest[s] = rested;
        }
    }

    /// The sort values where ranks 1.. start: the value at global position `first slot of
    /// rank r` of all ranks' sorted values (`u64::MAX` past the end), found by bisection with
    /// one sum over ranks per halving. `order` is this rank's values, sorted.
    pub(super) fn find_splits<T: Transport + ?Sized>(
        &self,
        link: &mut Link<'_, T>,
        order: &[(u64, u32)],
    ) -> Vec<u64> {
        let n = self.partition.slots() as u64;
        let targets: Vec<u64> = (1..link.ranks())
            .map(|r| self.partition.slots_of(r).start as u64)
            .collect();
        let mut span = Writer::default();
        if let (Some(first), Some(last)) = (order.first(), order.last()) {
            span.u64(first.0).u64(last.0);
        }
        let (mut min, mut max) = (u64::MAX, 0);
        for bytes in link.gather(TrafficKind::Migration, &span.0) {
            let mut r = Reader::new(&bytes);
            if !r.is_empty() {
                min = min.min(r.u64());
                max = max.max(r.u64());
            }
        }
        // For each target g: the smallest value v with count(values <= v) >= g + 1.
        let mut lo: Vec<u64> = targets.iter().map(|_| min).collect();
        let mut hi: Vec<u64> = targets.iter().map(|_| max).collect();
        loop {
            let open: Vec<usize> = (0..targets.len())
                .filter(|&t| targets[t] < n && lo[t] < hi[t])
                .collect();
            if open.is_empty() {
                break;
            }
            let mids: Vec<u64> = open.iter().map(|&t| lo[t] + (hi[t] - lo[t]) / 2).collect();
            let local: Vec<u64> = mids
                .iter()
                .map(|&mid| order.partition_point(|&(v, _)| v <= mid) as u64)
                .collect();
            let counts = link.sum_of(TrafficKind::Migration, &local);
            for ((&t, &mid), &count) in open.iter().zip(&mids).zip(&counts) {
                if count > targets[t] {
                    hi[t] = mid;
                } else {
                    lo[t] = mid + 1;
                }
            }
        }
        targets
            .iter()
            .zip(lo)
            .map(|(&g, v)| if g >= n { u64::MAX } else { v })
            .collect()
    }

    /// After a migration: turns the records that arrived with the particles into remembered
    /// impulses of this rank's contacts. A record whose partner now has the lower slot on
    /// another rank goes to that rank; one whose partner is out of reach is dropped (its pair
    /// is no candidate this step, which is what one world does with it too). Collective.
    pub(super) fn place_arrived<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        let (own, first) = (self.own, self.first_slot);
        let search = &mut self.search;
        search.by_id.clear();
        search
            .by_id
            .extend(search.id.iter().enumerate().map(|(k, &id)| (id, k as u32)));
        search.by_id.sort_unstable();
        let mut kept: Vec<(u32, u32, f64, u32)> = Vec::new();
        let mut outgoing: Vec<Writer> = (0..link.ranks()).map(|_| Writer::default()).collect();
        for &(a, b, impulse) in &self.arrived_pairs {
            let (Some(ka), Some(kb)) = (search.index_of(a), search.index_of(b)) else {
                continue;
            };
            let (ga, gb) = (search.slot(ka, own, first), search.slot(kb, own, first));
            if ga < gb {
                kept.push(((ga - first) as u32, (gb - first) as u32, impulse, b));
            } else if kb < own {
                kept.push(((gb - first) as u32, (ga - first) as u32, impulse, a));
            } else {
                outgoing[self.partition.owner_of_slot(gb)]
                    .u32(b)
                    .u32(a)
                    .f64(impulse);
            }
        }
        for bytes in link.exchange(TrafficKind::Migration, outgoing) {
            let mut r = Reader::new(&bytes);
            while !r.is_empty() {
                let (b, a, impulse) = (r.u32(), r.u32(), r.f64());
                if let (Some(kb), Some(ka)) = (search.index_of(b), search.index_of(a)) {
                    let ga = search.slot(ka, own, first);
                    kept.push((kb as u32, (ga - first) as u32, impulse, a));
                }
            }
        }
        kept.sort_unstable_by_key(|e| (e.0, e.1));
        self.memory.pairs.clear();
        self.memory_partners.clear();
        for (i, j, impulse, partner) in kept {
            self.memory.pairs.push((i, j, impulse));
            self.memory_partners.push(partner);
        }
        self.memory.planes.clear();
        for &(a, plane, impulse) in &self.arrived_planes {
            if let Some(k) = search.index_of(a) {
                self.memory.planes.push((k as u32, plane, impulse));
            }
        }
        self.memory.planes.sort_unstable_by_key(|e| (e.0, e.1));
    }
}

/// The remembered impulses of the contacts whose lower slot lies in `own_slots`, as slots
/// relative to its start, with each pair's `j` id; `slot_of[id]` and `order[slot]` give the
/// storage order the subdomain starts from.
pub(super) fn own_memory(
    impulses: &ContactImpulses,
    slot_of: &[u32],
    order: &[u32],
    own_slots: std::ops::Range<usize>,
) -> (Memory, Vec<u32>) {
    let first = own_slots.start;
    let mut pairs: Vec<(u32, u32, f64, u32)> = Vec::new();
    for &(a, b, impulse) in &impulses.pairs {
        let (sa, sb) = (slot_of[a as usize] as usize, slot_of[b as usize] as usize);
        let (i, j) = (sa.min(sb), sa.max(sb));
        if own_slots.contains(&i) {
            pairs.push(((i - first) as u32, (j - first) as u32, impulse, order[j]));
        }
    }
    pairs.sort_unstable_by_key(|e| (e.0, e.1));
    let mut memory = Memory::default();
    let mut partners = Vec::with_capacity(pairs.len());
    for (i, j, impulse, partner) in pairs {
        memory.pairs.push((i, j, impulse));
        partners.push(partner);
    }
    for &(a, plane, impulse) in &impulses.planes {
        let s = slot_of[a as usize] as usize;
        if own_slots.contains(&s) {
            memory.planes.push(((s - first) as u32, plane, impulse));
        }
    }
    memory.planes.sort_unstable_by_key(|e| (e.0, e.1));
    (memory, partners)
}

/// Where a particle goes in the storage order: by cell of the sort grid, ties by id, exactly
/// as [`World`]'s counting sort orders them; unique per particle.
pub(super) fn sort_value<V: Vector>(layout: &GridLayout, x: V, id: u32) -> u64 {
    ((layout.linear(layout.cell_coords(x)) as u64) << 32) | id as u64
}
