//! One rank's part of a world, stepped in lockstep with the others.

use super::lender::{borrower, lender, Leftovers, Lender};
use super::partition::Partition;
use super::sleepers::SplitSleepers;
use super::traffic::{Link, Traffic, TrafficKind};
use super::transport::Transport;
use super::wire::{Reader, Writer};
use crate::broadphase::{BroadPhase, Pair, PARALLEL_MIN};
use crate::diagnostics::StepStats;
use crate::domain::Aabb;
use crate::error::EngineError;
use crate::grid::{bounding_box, widened_reach, Grid, GridLayout};
use crate::memory::{ContactImpulses, Memory};
use crate::particles::Particles;
use crate::plane::Plane;
use crate::schedule::{Blocks, Exchange, PlaneContact};
use crate::sleep;
use crate::solver::{self, Contacts, Moving, PlaneRow, Row, VelocitySolve, WorkList};
use crate::step::{self, Phases};
use crate::timing::PhaseTimes;
use crate::vector::Vector;
use crate::world::{block_size, sort_layout, Snapshot, World, WorldConfig, REORDER_INTERVAL};

/// One rank's share of a [`World`]: the particles in its slots, stepped together with the
/// other ranks' shares through a [`Transport`] so that, put together, they take the very steps
/// the whole world would (both step through the same phases, see [`crate::step`]).
///
/// Every rank builds the same world (from the same scene), splits it with
/// [`Subdomain::new`], then calls [`Subdomain::step`] the same number of times; the calls are
/// collective. [`Subdomain::gather`] puts the state back together on rank 0.
///
/// Memory per rank is its own particles, one borrowed block and its ghosts. At a spatial sort
/// the ranks find where each one's share starts in the global order by bisection (about 50
/// sums of `ranks - 1` numbers), and only the particles that crossed a border move, each with
/// the remembered impulses of the contacts it owned.
pub struct Subdomain<V: Vector> {
    config: WorldConfig<V>,
    planes: Vec<Plane<V>>,
    partition: Partition,
    rank: usize,
    /// The first slot this rank owns.
    first_slot: usize,
    /// Slots this rank owns.
    own: usize,
    /// Slots borrowed from the next rank (its first block), stored after the own ones.
    halo: usize,
    /// Own slots, then the borrowed ones.
    window: Particles<V>,
    /// Id in each own slot.
    ids: Vec<u32>,
    /// Largest radius of the whole world (radii never change).
    max_radius: f64,
    broad_phase: Box<dyn BroadPhase<V>>,
    /// Each own slot's reach this step (see [`crate::world`]).
    reach: Vec<f64>,
    /// Own particles, then ghosts: what the broad phase searches and the rows are made of.
    search: Search<V>,
    /// Borrowed slots (offsets into the next rank's first block) this step's contacts touch.
    needed: Vec<u32>,
    /// Offsets into the own first block that the previous rank's contacts touch this step.
    lent: Vec<u32>,
    /// Whether any rank borrows anything in the sweeps of parity 0 and 1 this step.
    lending: [bool; 2],
    found: Vec<Pair>,
    /// (pair as slots relative to `first_slot`, the pair as search indices), sorted.
    candidates: Vec<(Pair, Pair)>,
    /// This step's candidates whose lower slot is own, as slots relative to `first_slot`.
    pairs: Vec<Pair>,
    /// The id of each pair's `j`.
    partners: Vec<u32>,
    rows: Vec<Row<V>>,
    plane_contacts: Vec<PlaneContact>,
    plane_rows: Vec<PlaneRow<V>>,
    /// Remembered impulses of the contacts this rank owns (relative slots), and the id of each
    /// pair's `j`.
    memory: Memory,
    memory_partners: Vec<u32>,
    /// The sleeping contacts' remembered impulses and partners, kept through `remember`
    /// (reused space).
    kept_asleep: Vec<((u32, u32, f64), u32)>,
    /// After a migration: `(own id, partner id, impulse)` and `(own id, plane, impulse)`
    /// records still to be matched to slots.
    arrived_pairs: Vec<(u32, u32, f64)>,
    arrived_planes: Vec<(u32, u32, f64)>,
    /// Set by a migration: the next contact search places the arrived records.
    rerouting: bool,
    /// How long each own slot has rested (see [`crate::sleep`]).
    rest: Vec<f64>,
    /// This step's sleeping own slots.
    sleepers: SplitSleepers,
    /// Own positions at the start of the step (only when particles may sleep).
    start: Vec<V>,
    /// The deepest overlap in this rank's sleeping contacts (see `World`'s).
    asleep_overlap: f64,
    /// Where this process's steps' time went (its share only; see [`PhaseTimes`]).
    phase_times: PhaseTimes,
    leftovers: Leftovers<V>,
    blocks: Blocks,
    /// The sweep clock of the work lists (unused: a subdomain sweeps every contact).
    clock: u32,
    steps: u64,
    traffic: Traffic,
}

/// Particles the broad phase searches: own ones first, then the ghosts.
#[derive(Debug, Default)]
struct Search<V> {
    position: Vec<V>,
    reach: Vec<f64>,
    radius: Vec<f64>,
    mass: Vec<f64>,
    id: Vec<u32>,
    /// Global slot of each ghost.
    ghost_slot: Vec<u32>,
    /// (id, search index), sorted, for placing records after a migration.
    by_id: Vec<(u32, u32)>,
}

impl<V: Vector> Search<V> {
    fn clear(&mut self) {
        self.position.clear();
        self.reach.clear();
        self.radius.clear();
        self.mass.clear();
        self.id.clear();
        self.ghost_slot.clear();
    }

    fn push(&mut self, x: V, reach: f64, radius: f64, mass: f64, id: u32) {
        self.position.push(x);
        self.reach.push(reach);
        self.radius.push(radius);
        self.mass.push(mass);
        self.id.push(id);
    }

    /// The global slot of search index `k` (own ones start at `first`).
    fn slot(&self, k: usize, own: usize, first: usize) -> usize {
        if k < own {
            first + k
        } else {
            self.ghost_slot[k - own] as usize
        }
    }

    /// The search index of particle `id`, if it is own or a ghost.
    fn index_of(&self, id: u32) -> Option<usize> {
        let k = self.by_id.binary_search_by_key(&id, |e| e.0).ok()?;
        Some(self.by_id[k].1 as usize)
    }
}

impl<V: Vector> std::fmt::Debug for Subdomain<V> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Subdomain")
            .field("rank", &self.rank)
            .field("slots", &(self.first_slot..self.first_slot + self.own))
            .field("halo", &self.halo)
            .field("steps", &self.steps)
            .finish()
    }
}

impl<V: Vector> Subdomain<V> {
    /// Rank `rank`'s share (of `ranks`) of `world`, which every rank built the same way.
    /// Refuses a world with periodic axes ([`EngineError::PeriodicSplit`]): contacts across a
    /// seam would join the first and the last rank, which the ghost exchange does not do.
    pub fn new(world: &World<V>, rank: usize, ranks: usize) -> Result<Self, EngineError> {
        if world.config().periodic().is_some() {
            return Err(EngineError::PeriodicSplit);
        }
        let n = world.len();
        let partition = Partition::new(n, block_size(n, V::DIM), ranks);
        let slots = partition.slots_of(rank);
        let halo = partition.halo_owner(rank).map_or(0, |_| {
            partition.block_slots(partition.blocks_of(rank).end).len()
        });
        let store = &world.store;
        // The ids in every slot. When the first step will sort anyway, take the order that
        // sort will give: every rank has the whole world here, so that step then finds every
        // particle on its rank already, instead of moving most of them.
        let order: Vec<u32> =
            if world.steps_taken() % REORDER_INTERVAL == 0 && !world.sleeps_whole() {
                world.next_sort_order()
            } else {
                world.ids.clone()
            };
        let ids = order[slots.clone()].to_vec();
        let slot_of = |id: u32| world.slots[id as usize] as usize;
        let window = |v: &[V]| {
            let mut w: Vec<V> = ids.iter().map(|&id| v[slot_of(id)]).collect();
            w.resize(slots.len() + halo, V::ZERO);
            w
        };
        let window_f64 = |v: &[f64]| {
            let mut w: Vec<f64> = ids.iter().map(|&id| v[slot_of(id)]).collect();
            w.resize(slots.len() + halo, 1.0);
            w
        };
        let mut slot_in_order = vec![0u32; n];
        for (slot, &id) in order.iter().enumerate() {
            slot_in_order[id as usize] = slot as u32;
        }
        let impulses = world.contact_impulses();
        let rest = if impulses.rest.is_empty() {
            vec![0.0; ids.len()]
        } else {
            ids.iter().map(|&id| impulses.rest[id as usize]).collect()
        };
        let (memory, memory_partners) =
            own_memory(&impulses, &slot_in_order, &order, slots.clone());
        Ok(Self {
            config: world.config().clone(),
            planes: world.planes().to_vec(),
            rank,
            first_slot: slots.start,
            own: slots.len(),
            halo,
            window: Particles {
                position: window(&store.position),
                velocity: window(&store.velocity),
                radius: window_f64(&store.radius),
                mass: window_f64(&store.mass),
            },
            ids,
            max_radius: store.max_radius(),
            // Every broad phase finds the same pairs, so each rank may pick the one that suits
            // its share: a grid over its own particles and ghosts, not over the whole domain
            // (whose cell count would not shrink with more ranks).
            broad_phase: Box::new(Grid::new(None, None)?),
            reach: Vec::new(),
            search: Search::default(),
            needed: Vec::new(),
            lent: Vec::new(),
            lending: [false; 2],
            found: Vec::new(),
            candidates: Vec::new(),
            pairs: Vec::new(),
            partners: Vec::new(),
            rows: Vec::new(),
            plane_contacts: Vec::new(),
            plane_rows: Vec::new(),
            memory,
            memory_partners,
            kept_asleep: Vec::new(),
            arrived_pairs: Vec::new(),
            arrived_planes: Vec::new(),
            rerouting: false,
            rest,
            sleepers: SplitSleepers::default(),
            start: Vec::new(),
            asleep_overlap: 0.0,
            phase_times: PhaseTimes::default(),
            leftovers: Leftovers::default(),
            blocks: Blocks::default(),
            clock: 0,
            steps: world.steps_taken(),
            traffic: Traffic::default(),
            partition,
        })
    }

    /// Which slots each rank owns.
    pub fn partition(&self) -> &Partition {
        &self.partition
    }

    /// Particles this rank owns.
    pub fn len(&self) -> usize {
        self.own
    }

    /// True when this rank owns no particles (more ranks than blocks).
    pub fn is_empty(&self) -> bool {
        self.own == 0
    }

    /// Steps taken.
    pub fn steps_taken(&self) -> u64 {
        self.steps
    }

    /// What this rank has sent so far.
    pub fn traffic(&self) -> &Traffic {
        &self.traffic
    }

    /// Advances every rank's share by one step. Collective: every rank calls it.
    pub fn step<T: Transport + ?Sized>(&mut self, transport: &mut T) -> StepStats {
        let mut traffic = std::mem::take(&mut self.traffic);
        let stats = step::advance(&mut Stepping {
            sub: self,
            link: &mut Link {
                transport,
                traffic: &mut traffic,
            },
        });
        self.traffic = traffic;
        stats
    }

    /// The whole world's state, on rank 0 (`None` on the others). Collective.
    pub fn gather<T: Transport + ?Sized>(&mut self, transport: &mut T) -> Option<Snapshot<V>> {
        let size = transport.size();
        let mut outgoing: Vec<Writer> = (0..size).map(|_| Writer::default()).collect();
        for s in 0..self.own {
            outgoing[0]
                .u32(self.ids[s])
                .vector(self.window.position[s])
                .vector(self.window.velocity[s])
                .f64(self.window.radius[s])
                .f64(self.window.mass[s])
                .f64(self.rest[s]);
        }
        let mut remembered: Vec<Writer> = (0..size).map(|_| Writer::default()).collect();
        let w = &mut remembered[0];
        w.u64(self.memory.pairs.len() as u64);
        for (&(i, _, impulse), &partner) in self.memory.pairs.iter().zip(&self.memory_partners) {
            w.u32(self.ids[i as usize]).u32(partner).f64(impulse);
        }
        for &(s, plane, impulse) in &self.memory.planes {
            w.u32(self.ids[s as usize]).u32(plane).f64(impulse);
        }
        let rank = transport.rank();
        let mut link = Link {
            transport,
            traffic: &mut self.traffic,
        };
        let received = link.exchange(TrafficKind::Gather, outgoing);
        let received_memory = link.exchange(TrafficKind::Gather, remembered);
        if rank != 0 {
            return None;
        }
        let n = self.partition.slots();
        let mut storage_order = Vec::with_capacity(n);
        let mut records = Vec::with_capacity(n);
        for bytes in &received {
            let mut r = Reader::new(bytes);
            while !r.is_empty() {
                let id = r.u32();
                storage_order.push(id);
                let (x, v) = (r.vector::<V>(), r.vector::<V>());
                records.push((id, x, v, r.f64(), r.f64(), r.f64()));
            }
        }
        records.sort_unstable_by_key(|record| record.0);
        let mut particles = Particles::new();
        let mut rest = Vec::with_capacity(n);
        for (_, x, v, radius, mass, rested) in records {
            particles.position.push(x);
            particles.velocity.push(v);
            particles.radius.push(radius);
            particles.mass.push(mass);
            rest.push(rested);
        }
        let mut impulses = ContactImpulses::default();
        // (as `World::contact_impulses` gives them: none when nobody has rested)
        if rest.iter().any(|&t| t > 0.0) {
            impulses.rest = rest;
        }
        for bytes in &received_memory {
            let mut r = Reader::new(bytes);
            for _ in 0..r.u64() {
                let (a, b, impulse) = (r.u32(), r.u32(), r.f64());
                impulses.pairs.push((a.min(b), a.max(b), impulse));
            }
            while !r.is_empty() {
                impulses.planes.push((r.u32(), r.u32(), r.f64()));
            }
        }
        let key = |e: &(u32, u32, f64)| (e.0, e.1);
        impulses.pairs.sort_unstable_by_key(key);
        impulses.planes.sort_unstable_by_key(key);
        Some(Snapshot {
            steps_taken: self.steps,
            storage_order,
            particles,
            impulses,
        })
    }

    /// The spatial sort of [`World`], across ranks: every particle goes to the slot (and so to
    /// the rank) the whole world's sort would give it, with the remembered impulses of the
    /// contacts it owned (placed again at the next contact search).
    fn migrate<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        let n = self.partition.slots();
        if n == 0 {
            return;
        }
        let own = self.own;
        let bounds = match self.config.domain {
            Some(domain) => domain,
            None => {
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
        };
        let layout = sort_layout(&bounds, self.max_radius, n);
        let mut order: Vec<(u64, u32)> = (0..own)
            .map(|s| {
                (
                    sort_value(&layout, self.window.position[s], self.ids[s]),
                    s as u32,
                )
            })
            .collect();
        order.sort_unstable();
        let splits = self.find_splits(link, &order);
        // Each particle goes to the rank whose range of values holds it: only the particles
        // that crossed a border move.
        let mut outgoing: Vec<Writer> = (0..link.ranks()).map(|_| Writer::default()).collect();
        let (pairs, planes) = (&self.memory.pairs, &self.memory.planes);
        for &(value, s) in &order {
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
        let mut arrived: Vec<(u64, V, V, f64, f64, f64)> = Vec::with_capacity(own);
        self.arrived_pairs.clear();
        self.arrived_planes.clear();
        for bytes in link.exchange(TrafficKind::Migration, outgoing) {
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
        debug_assert_eq!(arrived.len(), own, "a rank keeps its slot count");
        for (s, (value, x, v, radius, mass, rested)) in arrived.into_iter().enumerate() {
            self.ids[s] = value as u32;
            self.window.position[s] = x;
            self.window.velocity[s] = v;
            self.window.radius[s] = radius;
            self.window.mass[s] = mass;
            self.rest[s] = rested;
        }
        self.memory.clear();
        self.memory_partners.clear();
        self.rerouting = true;
    }

    /// The sort values where ranks 1.. start: the value at global position `first slot of
    /// rank r` of all ranks' sorted values (`u64::MAX` past the end), found by bisection with
    /// one sum over ranks per halving. `order` is this rank's values, sorted.
    fn find_splits<T: Transport + ?Sized>(
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

    /// Tells the next rank which of its first block's particles this step's contacts touch
    /// (only those travel in the sweeps), and learns which of its own the previous rank needs.
    fn agree_on_borrowing<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        let (own, halo) = (self.own as u32, self.halo as u32);
        self.needed.clear();
        self.needed.extend(
            self.pairs
                .iter()
                .filter(|&&(_, j)| (own..own + halo).contains(&j))
                .map(|&(_, j)| j - own),
        );
        self.needed.sort_unstable();
        self.needed.dedup();
        let mut mine = Writer::default();
        for &k in &self.needed {
            mine.u32(k);
        }
        let lists = link.gather(TrafficKind::Halo, &mine.0);
        self.lending = [0, 1].map(|parity| {
            (0..self.partition.ranks())
                .any(|r| !lists[r].is_empty() && lender(&self.partition, r, Some(parity)).is_some())
        });
        self.lent.clear();
        if let Some(borrower) = borrower(&self.partition, self.rank, None) {
            let mut r = Reader::new(&lists[borrower]);
            while !r.is_empty() {
                self.lent.push(r.u32());
            }
        }
    }

    /// Receives ghosts (the particles of other ranks within reach of own ones), runs the broad
    /// phase over own and ghost particles and keeps the candidates whose lower slot is own;
    /// then the own plane candidates, the rows, and the remembered impulses.
    fn find_contacts<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        let own = self.own;
        let dt = self.config.dt;
        let fall = self.config.gravity.length_squared().sqrt() * dt;
        self.reach.clear();
        for s in 0..own {
            let (v, r) = (self.window.velocity[s], self.window.radius[s]);
            self.reach
                .push(solver::reach(r, v.length_squared().sqrt() + fall, dt));
        }
        let max_reach = self.reach.iter().copied().fold(0.0, f64::max);
        // A particle j of another rank can reach an own one only from within the own bounding
        // box grown by this rank's largest reach plus j's rank's: each rank sends its box and
        // largest reach, and the others grow it by their own (widened against rounding).
        let mut mine = Writer::default();
        if own > 0 {
            let b = bounding_box(&self.window.position[..own]);
            mine.vector(b.min).vector(b.max).f64(max_reach);
        }
        let boxes = link.gather(TrafficKind::Ghosts, &mine.0);
        let mut outgoing: Vec<Writer> = (0..link.ranks()).map(|_| Writer::default()).collect();
        for (to, bytes) in boxes.iter().enumerate() {
            if to == self.rank || bytes.is_empty() || own == 0 {
                continue;
            }
            let mut r = Reader::new(bytes);
            let (min, max, reach): (V, V, f64) = (r.vector(), r.vector(), r.f64());
            let grow = reach + max_reach;
            let mut lo = [0.0; 3];
            let mut hi = [0.0; 3];
            for a in 0..V::DIM {
                lo[a] = min.get(a) - widened_reach(min.get(a), grow);
                hi[a] = max.get(a) + widened_reach(max.get(a), grow);
            }
            let w = &mut outgoing[to];
            for s in 0..own {
                let x = self.window.position[s];
                if (0..V::DIM).all(|a| x.get(a) >= lo[a] && x.get(a) <= hi[a]) {
                    w.u32((self.first_slot + s) as u32)
                        .u32(self.ids[s])
                        .vector(x)
                        .f64(self.reach[s])
                        .f64(self.window.radius[s])
                        .f64(self.window.mass[s]);
                }
            }
        }
        let search = &mut self.search;
        search.clear();
        for s in 0..own {
            search.push(
                self.window.position[s],
                self.reach[s],
                self.window.radius[s],
                self.window.mass[s],
                self.ids[s],
            );
        }
        for bytes in link.exchange(TrafficKind::Ghosts, outgoing) {
            let mut r = Reader::new(&bytes);
            while !r.is_empty() {
                let (slot, id) = (r.u32(), r.u32());
                let (x, reach, radius, mass) = (r.vector(), r.f64(), r.f64(), r.f64());
                search.ghost_slot.push(slot);
                search.push(x, reach, radius, mass, id);
            }
        }
        self.broad_phase
            .find_pairs(&search.position, &search.reach, &mut self.found);
        let first = self.first_slot;
        self.candidates.clear();
        for &(a, b) in &self.found {
            let (a, b) = (a as usize, b as usize);
            let (sa, sb) = (search.slot(a, own, first), search.slot(b, own, first));
            let ((i, ki), (j, kj)) = if sa < sb {
                ((sa, a), (sb, b))
            } else {
                ((sb, b), (sa, a))
            };
            if (first..first + own).contains(&i) {
                self.candidates.push((
                    ((i - first) as u32, (j - first) as u32),
                    (ki as u32, kj as u32),
                ));
            }
        }
        self.candidates.sort_unstable_by_key(|c| c.0);
        self.pairs.clear();
        self.pairs.extend(self.candidates.iter().map(|c| c.0));
        self.partners.clear();
        self.partners
            .extend(self.candidates.iter().map(|c| search.id[c.1 .1 as usize]));
        self.mark_sleepers(link);
        self.plane_contacts.clear();
        self.plane_rows.clear();
        let in_move =
            (self.config.solver_settings()).planes_in_move(&self.planes, self.config.gravity);
        for s in 0..own {
            if self.sleepers.sleeps(s) {
                continue;
            }
            let x = self.window.position[s];
            for (p, plane) in self.planes.iter().enumerate() {
                let radius = self.window.radius[s];
                if plane.signed_distance(x) < solver::plane_reach(self.reach[s], radius, in_move) {
                    self.plane_contacts.push((s as u32, p as u32));
                    self.plane_rows.push(PlaneRow::new(
                        plane,
                        p as u32,
                        x,
                        self.window.radius[s],
                        dt,
                    ));
                }
            }
        }
        let parallel = self.partition.slots() >= PARALLEL_MIN;
        let candidates = &self.candidates;
        let (search, sleepers) = (&self.search, &self.sleepers);
        self.rows.clear();
        self.rows
            .extend(candidates.iter().map(|&((i, j), (ki, kj))| {
                let (ki, kj) = (ki as usize, kj as usize);
                // (a sleeper in a pair is a fixed obstacle: infinite mass)
                let mass = |k: usize, slot: u32| {
                    solver::moving_mass(search.mass[k], sleepers.sleeps(slot as usize))
                };
                Row::new(
                    search.position[ki],
                    search.position[kj],
                    search.radius[ki],
                    search.radius[kj],
                    mass(ki, i),
                    mass(kj, j),
                    dt,
                )
            }));
        crate::broadphase::keep_headroom(&mut self.rows);
        self.agree_on_borrowing(link);
        self.blocks.plan(
            own + self.halo,
            self.partition.block(),
            &self.pairs,
            &self.plane_contacts,
            parallel,
            self.partition.blocks_of(self.rank).start,
        );
        if self.rerouting {
            self.place_arrived(link);
            self.rerouting = false;
        }
        self.memory.warm_rows(
            &self.pairs,
            &mut self.rows,
            &self.plane_contacts,
            &mut self.plane_rows,
        );
        self.leftovers.gather(
            link,
            self.first_slot,
            own,
            &self.blocks,
            &self.pairs,
            &self.rows,
        );
    }

    /// [`World::sleeps_whole`] over every rank. Collective (only when particles may sleep).
    fn sleeps_whole<T: Transport + ?Sized>(&self, link: &mut Link<'_, T>) -> bool {
        let Some(settings) = self.config.sleep_settings(&self.planes) else {
            return false;
        };
        let own = self.own;
        let still = sleep::all_still(&self.rest, &self.window.velocity[..own], settings.time);
        let restless = u64::from(!still);
        self.partition.slots() > 0 && link.sum_of(TrafficKind::Sleep, &[restless])[0] == 0
    }

    /// [`World`]'s `mark_sleepers` for this rank's share: marks the sleeping own slots
    /// (collectively), stops them and drops their candidates; keeps the own positions the step
    /// starts from.
    fn mark_sleepers<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        self.asleep_overlap = 0.0;
        let Some(settings) = self.config.sleep_settings(&self.planes) else {
            self.sleepers.count = 0;
            return;
        };
        let own = self.own;
        self.start.clear();
        self.start.extend_from_slice(&self.window.position[..own]);
        let up = sleep::up(self.config.gravity);
        let (search, planes, candidates) = (&self.search, &self.planes, &self.candidates);
        let on_plane =
            |s: usize| sleep::rests_on_plane(search.position[s], search.radius[s], planes, up);
        let in_pair = |k: usize| {
            let (ki, kj) = (candidates[k].1 .0 as usize, candidates[k].1 .1 as usize);
            let (xi, xj) = (search.position[ki], search.position[kj]);
            sleep::rests_on(xi, xj, search.radius[ki], search.radius[kj], up)
        };
        let support = sleep::Support {
            on_plane: &on_plane,
            in_pair: &in_pair,
        };
        let asleep = self.sleepers.mark(
            link,
            &self.partition,
            self.first_slot,
            &self.pairs,
            &self.rest,
            settings.time,
            &support,
        );
        if asleep == 0 {
            return;
        }
        let (sleepers, search) = (&self.sleepers, &self.search);
        for &((i, j), (ki, kj)) in &self.candidates {
            if sleepers.sleeps(i as usize) && sleepers.sleeps(j as usize) {
                let (ki, kj) = (ki as usize, kj as usize);
                let (ri, rj) = (search.radius[ki], search.radius[kj]);
                let distance = (search.position[ki] - search.position[kj])
                    .length_squared()
                    .sqrt();
                let overlap = (ri + rj - distance) / ri.min(rj);
                self.asleep_overlap = self.asleep_overlap.max(overlap);
            }
        }
        for (v, &sleeps) in self.window.velocity[..own].iter_mut().zip(&sleepers.asleep) {
            if sleeps {
                *v = V::ZERO;
            }
        }
        // (a pair with one particle awake stays: the sleeper is a fixed obstacle in it)
        let sleeps = |c: &(Pair, Pair)| {
            let (i, j) = c.0;
            sleepers.sleeps(i as usize) && sleepers.sleeps(j as usize)
        };
        let mut k = 0;
        self.partners.retain(|_| {
            k += 1;
            !sleeps(&self.candidates[k - 1])
        });
        self.candidates.retain(|c| !sleeps(c));
        self.pairs.clear();
        self.pairs.extend(self.candidates.iter().map(|c| c.0));
    }

    /// After a migration: turns the records that arrived with the particles into remembered
    /// impulses of this rank's contacts. A record whose partner now has the lower slot on
    /// another rank goes to that rank; one whose partner is out of reach is dropped (its pair
    /// is no candidate this step, which is what one world does with it too). Collective.
    fn place_arrived<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
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

/// A subdomain stepping with its link to the other ranks: what [`step::advance`] drives.
struct Stepping<'s, 'l, 't, V: Vector, T: ?Sized> {
    sub: &'s mut Subdomain<V>,
    link: &'l mut Link<'t, T>,
}

impl<V: Vector, T: Transport + ?Sized> Stepping<'_, '_, '_, V, T> {
    /// Runs `phase` with this rank's exchange and contacts.
    fn solve<R>(
        &mut self,
        phase: impl FnOnce(&mut Lender<'_, '_, T, V>, &mut Particles<V>, &mut Contacts<'_, V>) -> R,
    ) -> R {
        let s = &mut *self.sub;
        let mut exchange = Lender {
            link: self.link,
            partition: &s.partition,
            rank: s.rank,
            first_slot: s.first_slot,
            own: s.own,
            needed: &s.needed,
            lent: &s.lent,
            lending: s.lending,
            leftovers: &mut s.leftovers,
        };
        let mut contacts = Contacts {
            pairs: &s.pairs,
            rows: &mut s.rows,
            plane_contacts: &s.plane_contacts,
            plane_rows: &mut s.plane_rows,
            planes: &s.planes,
            blocks: &s.blocks,
            // (no work lists across processes: they would change the cost, not the result)
            work: WorkList {
                stamps: &mut [],
                clock: &mut s.clock,
            },
        };
        phase(&mut exchange, &mut s.window, &mut contacts)
    }
}

impl<V: Vector, T: Transport + ?Sized> Phases for Stepping<'_, '_, '_, V, T> {
    fn sort_along_space(&mut self) {
        if self.sub.steps % REORDER_INTERVAL == 0 && !self.sub.sleeps_whole(self.link) {
            self.sub.migrate(self.link);
        }
    }

    fn find_contacts(&mut self) {
        self.sub.find_contacts(self.link);
    }

    fn integrate(&mut self) -> VelocitySolve {
        let settings = self.sub.config.solver_settings();
        let (gravity, dt) = (self.sub.config.gravity, self.sub.config.dt);
        let own = self.sub.own;
        // (taken out for the phase, which borrows the rest of the subdomain)
        let asleep = std::mem::take(&mut self.sub.sleepers.asleep);
        let sleepers = if self.sub.sleepers.count > 0 {
            &asleep[..]
        } else {
            &[]
        };
        let solve = self.solve(|exchange, window, contacts| {
            let moving = Moving {
                position: &mut window.position,
                velocity: &mut window.velocity,
                own,
                asleep: sleepers,
            };
            solver::integrate(exchange, &settings, gravity, dt, moving, contacts)
        });
        self.sub.sleepers.asleep = asleep;
        solve
    }

    fn separate(&mut self) -> f64 {
        let settings = self.sub.config.solver_settings();
        let sleeping = self.sub.config.sleep_settings(&self.sub.planes).is_some();
        let asleep_overlap = self.sub.asleep_overlap;
        let gravity = self.sub.config.gravity;
        self.solve(|exchange, window, contacts| {
            let awake = solver::separate(
                exchange,
                &settings,
                gravity,
                &mut window.position,
                &mut window.velocity,
                contacts,
            );
            if sleeping {
                awake.max(exchange.largest(asleep_overlap))
            } else {
                awake
            }
        })
    }

    fn remember(&mut self) {
        let s = &mut *self.sub;
        let sleepers = &s.sleepers;
        let sleeps = |slot: u32| sleepers.sleeps(slot as usize);
        // (a sleeper's contacts with other sleepers keep their impulses, as in `World`: merged in
        // order)
        s.kept_asleep.clear();
        if sleepers.count > 0 {
            s.kept_asleep.extend(
                s.memory
                    .pairs
                    .iter()
                    .zip(&s.memory_partners)
                    .filter(|(e, _)| sleeps(e.0))
                    .map(|(&e, &p)| (e, p)),
            );
        }
        s.memory.pairs.clear();
        s.memory_partners.clear();
        let mut kept = s.kept_asleep.iter().copied().peekable();
        for ((&(i, j), row), &partner) in s.pairs.iter().zip(&s.rows).zip(&s.partners) {
            while let Some((e, p)) = kept.next_if(|(e, _)| (e.0, e.1) < (i, j)) {
                s.memory.pairs.push(e);
                s.memory_partners.push(p);
            }
            // (a contact solved this step, with its sleeper fixed, remembers what it took)
            kept.next_if(|(e, _)| (e.0, e.1) == (i, j));
            if row.kept > 0.0 {
                s.memory.pairs.push((i, j, row.kept));
                s.memory_partners.push(partner);
            }
        }
        for (e, p) in kept {
            s.memory.pairs.push(e);
            s.memory_partners.push(p);
        }
        let plane_rows = &s.plane_rows;
        Memory::store_keeping_asleep(
            &mut s.memory.planes,
            &mut s.memory.scratch,
            &s.plane_contacts,
            |k| plane_rows[k].kept,
            |&(i, _, _)| sleeps(i),
        );
    }

    fn times(&mut self) -> &mut PhaseTimes {
        &mut self.sub.phase_times
    }

    fn finish(&mut self, solve: VelocitySolve, max_overlap: f64) -> StepStats {
        let s = &mut *self.sub;
        s.steps += 1;
        let asleep = s.sleepers.flags();
        if let Some(settings) = s.config.sleep_settings(&s.planes) {
            sleep::update_rest(
                false,
                &s.start,
                &s.window.position[..s.own],
                asleep,
                &mut s.rest,
                &settings,
                s.config.dt,
            );
        }
        let rows = crate::solver::tally(&s.rows);
        let on_planes = s.plane_rows.iter().filter(|r| r.touching).count() as u64;
        let counts = self.link.sum(&[
            rows.touching,
            on_planes,
            s.sleepers.count as u64,
            rows.collisions,
        ]);
        StepStats {
            asleep: counts[2] as usize,
            contacts: counts[0] as usize,
            plane_contacts: counts[1] as usize,
            velocity_iterations: solve.iterations,
            responses: solve.responses,
            collisions: counts[3],
            capped: solve.capped,
            max_overlap,
        }
    }
}

/// The remembered impulses of the contacts whose lower slot lies in `own_slots`, as slots
/// relative to its start, with each pair's `j` id; `slot_of[id]` and `order[slot]` give the
/// storage order the subdomain starts from.
fn own_memory(
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
fn sort_value<V: Vector>(layout: &GridLayout, x: V, id: u32) -> u64 {
    ((layout.linear(layout.cell_coords(x)) as u64) << 32) | id as u64
}
