//! One rank's part of a world, stepped in lockstep with the others.

use super::partition::Partition;
use super::transport::Transport;
use super::wire::{Reader, Writer};
use crate::broadphase::{BroadPhase, Pair, PARALLEL_MIN};
use crate::diagnostics::StepStats;
use crate::domain::Aabb;
use crate::error::EngineError;
use crate::grid::{bounding_box, widened_reach, Grid, GridLayout};
use crate::particles::Particles;
use crate::plane::Plane;
use crate::solver::{self, pair_mut, Blocks, Body, Contacts, Exchange, PlaneContact};
use crate::vector::Vector;
use crate::world::REORDER_INTERVAL;
use crate::world::{block_size, sort_layout, Snapshot, World, WorldConfig};

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
    /// The whole state collected on rank 0 for output.
    Gather,
}

const KINDS: usize = 6;

impl TrafficKind {
    /// Every kind, in report order.
    pub const ALL: [TrafficKind; KINDS] = [
        TrafficKind::Migration,
        TrafficKind::Halo,
        TrafficKind::Ghosts,
        TrafficKind::Leftovers,
        TrafficKind::Reductions,
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
struct Link<'a, T: ?Sized> {
    transport: &'a mut T,
    traffic: &'a mut Traffic,
}

impl<T: Transport + ?Sized> Link<'_, T> {
    fn ranks(&self) -> usize {
        self.transport.size()
    }

    fn gather(&mut self, kind: TrafficKind, mine: &[u8]) -> Vec<Vec<u8>> {
        let others = self.transport.size() as u64 - 1;
        let k = kind as usize;
        self.traffic.bytes[k] += mine.len() as u64 * others;
        self.traffic.messages[k] += if mine.is_empty() { 0 } else { others };
        self.traffic.collectives[k] += 1;
        self.transport.all_gather(mine)
    }

    fn exchange(&mut self, kind: TrafficKind, outgoing: Vec<Writer>) -> Vec<Vec<u8>> {
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

    /// `local` added up over every rank.
    fn sum(&mut self, local: &[u64]) -> Vec<u64> {
        self.sum_of(TrafficKind::Reductions, local)
    }

    /// `local` added up over every rank, counted as `kind`.
    fn sum_of(&mut self, kind: TrafficKind, local: &[u64]) -> Vec<u64> {
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

/// One rank's share of a [`World`]: the particles in its slots, stepped together with the
/// other ranks' shares through a [`Transport`] so that, put together, they take the very steps
/// the whole world would.
///
/// Every rank builds the same world (from the same scene), splits it with
/// [`Subdomain::new`], then calls [`Subdomain::step`] the same number of times; the calls are
/// collective. [`Subdomain::gather`] puts the state back together on rank 0.
///
/// Memory per rank is its own particles, one borrowed block and its ghosts. At a spatial sort
/// the ranks find where each one's share starts in the global order by bisection (about 50
/// sums of `ranks - 1` numbers), and only the particles that crossed a border move.
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
    /// Own and borrowed particles, then ghosts: what the broad phase searches.
    search_position: Vec<V>,
    search_radius: Vec<f64>,
    /// Global slot of each ghost.
    ghost_slot: Vec<u32>,
    /// Borrowed slots (offsets into the next rank's first block) this step's contacts touch.
    needed: Vec<u32>,
    /// Offsets into the own first block that the previous rank's contacts touch this step.
    lent: Vec<u32>,
    /// Whether any rank borrows anything in the sweeps of parity 0 and 1 this step.
    lending: [bool; 2],
    found: Vec<Pair>,
    /// This step's contacts whose lower slot is own, as slots relative to `first_slot`.
    pairs: Vec<Pair>,
    plane_contacts: Vec<PlaneContact>,
    blocks: Blocks,
    steps: u64,
    traffic: Traffic,
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
    pub fn new(world: &World<V>, rank: usize, ranks: usize) -> Result<Self, EngineError> {
        let n = world.len();
        let partition = Partition::new(n, block_size(n, V::DIM), ranks);
        let slots = partition.slots_of(rank);
        let halo = partition.halo_owner(rank).map_or(0, |_| {
            partition.block_slots(partition.blocks_of(rank).end).len()
        });
        let store = &world.store;
        // The ids in this rank's slots. When the first step will sort anyway, take the order
        // that sort will give: every rank has the whole world here, so that step then finds
        // every particle on its rank already, instead of moving most of them.
        let ids: Vec<u32> = if world.steps_taken() % REORDER_INTERVAL == 0 {
            world.next_sort_order()[slots.clone()].to_vec()
        } else {
            world.ids[slots.clone()].to_vec()
        };
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
            search_position: Vec::new(),
            search_radius: Vec::new(),
            ghost_slot: Vec::new(),
            needed: Vec::new(),
            lent: Vec::new(),
            lending: [false; 2],
            found: Vec::new(),
            pairs: Vec::new(),
            plane_contacts: Vec::new(),
            blocks: Blocks::default(),
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
        let stats = self.step_with(&mut Link {
            transport,
            traffic: &mut traffic,
        });
        self.traffic = traffic;
        stats
    }

    /// The whole world's state, on rank 0 (`None` on the others). Collective.
    pub fn gather<T: Transport + ?Sized>(&mut self, transport: &mut T) -> Option<Snapshot<V>> {
        let mut outgoing: Vec<Writer> = (0..transport.size()).map(|_| Writer::default()).collect();
        for s in 0..self.own {
            outgoing[0]
                .u32(self.ids[s])
                .vector(self.window.position[s])
                .vector(self.window.velocity[s])
                .f64(self.window.radius[s])
                .f64(self.window.mass[s]);
        }
        let rank = transport.rank();
        let received = Link {
            transport,
            traffic: &mut self.traffic,
        }
        .exchange(TrafficKind::Gather, outgoing);
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
                records.push((id, r.vector::<V>(), r.vector::<V>(), r.f64(), r.f64()));
            }
        }
        records.sort_unstable_by_key(|record| record.0);
        let mut particles = Particles::new();
        for (_, x, v, radius, mass) in records {
            particles.position.push(x);
            particles.velocity.push(v);
            particles.radius.push(radius);
            particles.mass.push(mass);
        }
        Some(Snapshot {
            steps_taken: self.steps,
            storage_order,
            particles,
        })
    }

    fn step_with<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) -> StepStats {
        if self.steps % REORDER_INTERVAL == 0 {
            self.migrate(link);
        }
        let dt = self.config.dt;
        let dv = self.config.gravity * dt;
        for (x, v) in self.window.position[..self.own]
            .iter_mut()
            .zip(&mut self.window.velocity[..self.own])
        {
            *v += dv;
            *x += *v * dt;
        }
        self.find_contacts(link);
        self.agree_on_borrowing(link);
        let parallel = self.partition.slots() >= PARALLEL_MIN;
        self.blocks.plan(
            self.own + self.halo,
            self.partition.block(),
            &self.pairs,
            &self.plane_contacts,
            parallel,
            self.partition.blocks_of(self.rank).start,
        );
        let leftovers = Leftovers::gather(link, self);
        let mut exchange = Lender {
            link,
            partition: &self.partition,
            rank: self.rank,
            first_slot: self.first_slot,
            own: self.own,
            needed: &self.needed,
            lent: &self.lent,
            lending: self.lending,
            leftovers: &leftovers,
        };
        let solve = solver::resolve(
            &mut exchange,
            &self.config,
            &mut self.window,
            Contacts {
                pairs: &self.pairs,
                plane_contacts: &self.plane_contacts,
                planes: &self.planes,
                blocks: &self.blocks,
            },
        );
        self.steps += 1;
        let counts = link.sum(&[self.pairs.len() as u64, self.plane_contacts.len() as u64]);
        StepStats {
            contacts: counts[0] as usize,
            plane_contacts: counts[1] as usize,
            velocity_iterations: solve.iterations,
            responses: solve.responses,
            capped: solve.capped,
        }
    }

    /// The spatial sort of [`World`], across ranks: every particle goes to the slot (and so to
    /// the rank) the whole world's sort would give it.
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
        for &(value, s) in &order {
            let s = s as usize;
            outgoing[splits.partition_point(|&split| split <= value)]
                .u64(value)
                .vector(self.window.position[s])
                .vector(self.window.velocity[s])
                .f64(self.window.radius[s])
                .f64(self.window.mass[s]);
        }
        let mut arrived: Vec<(u64, V, V, f64, f64)> = Vec::with_capacity(own);
        for bytes in link.exchange(TrafficKind::Migration, outgoing) {
            let mut r = Reader::new(&bytes);
            while !r.is_empty() {
                arrived.push((r.u64(), r.vector(), r.vector(), r.f64(), r.f64()));
            }
        }
        arrived.sort_unstable_by_key(|a| a.0);
        debug_assert_eq!(arrived.len(), own, "a rank keeps its slot count");
        for (s, (value, x, v, radius, mass)) in arrived.into_iter().enumerate() {
            self.ids[s] = value as u32;
            self.window.position[s] = x;
            self.window.velocity[s] = v;
            self.window.radius[s] = radius;
            self.window.mass[s] = mass;
        }
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

    /// Receives ghosts, runs the broad phase over own, borrowed and ghost particles, and keeps
    /// the contacts whose lower slot is own; then the own plane contacts.
    fn find_contacts<T: Transport + ?Sized>(&mut self, link: &mut Link<'_, T>) {
        let own = self.own;
        // Any particle within r_i + r_j <= 2 max_radius of an own one lies in the own
        // bounding box grown by that (widened against rounding) on every axis.
        let reach = 2.0 * self.max_radius;
        let mut mine = Writer::default();
        if own > 0 {
            let b = bounding_box(&self.window.position[..own]);
            let mut min = [0.0; 3];
            let mut max = [0.0; 3];
            for a in 0..V::DIM {
                min[a] = b.min.get(a) - widened_reach(b.min.get(a), reach);
                max[a] = b.max.get(a) + widened_reach(b.max.get(a), reach);
            }
            mine.vector(V::from_slice(&min)).vector(V::from_slice(&max));
        }
        let boxes = link.gather(TrafficKind::Ghosts, &mine.0);
        let mut outgoing: Vec<Writer> = (0..link.ranks()).map(|_| Writer::default()).collect();
        for (to, bytes) in boxes.iter().enumerate() {
            if to == self.rank || bytes.is_empty() {
                continue;
            }
            let mut r = Reader::new(bytes);
            let (min, max): (V, V) = (r.vector(), r.vector());
            let w = &mut outgoing[to];
            for s in 0..own {
                let x = self.window.position[s];
                if (0..V::DIM).all(|a| x.get(a) >= min.get(a) && x.get(a) <= max.get(a)) {
                    w.u32((self.first_slot + s) as u32)
                        .vector(x)
                        .f64(self.window.radius[s])
                        .f64(self.window.mass[s]);
                }
            }
        }
        // Own particles, then the ghosts. The borrowed block's slots are searched only as
        // ghosts: those out of reach keep stale values, which no contact will read.
        self.search_position.clear();
        self.search_position
            .extend_from_slice(&self.window.position[..own]);
        self.search_radius.clear();
        self.search_radius
            .extend_from_slice(&self.window.radius[..own]);
        self.ghost_slot.clear();
        let first = self.first_slot;
        let borrowed = first + own..first + own + self.halo;
        for bytes in link.exchange(TrafficKind::Ghosts, outgoing) {
            let mut r = Reader::new(&bytes);
            while !r.is_empty() {
                let (slot, x, radius, mass) = (r.u32(), r.vector(), r.f64(), r.f64());
                if borrowed.contains(&(slot as usize)) {
                    let w = slot as usize - first;
                    (
                        self.window.position[w],
                        self.window.radius[w],
                        self.window.mass[w],
                    ) = (x, radius, mass);
                }
                self.ghost_slot.push(slot);
                self.search_position.push(x);
                self.search_radius.push(radius);
            }
        }
        self.broad_phase
            .find_pairs(&self.search_position, &self.search_radius, &mut self.found);
        let slot = |k: u32| -> usize {
            let k = k as usize;
            if k < own {
                first + k
            } else {
                self.ghost_slot[k - own] as usize
            }
        };
        self.pairs.clear();
        for &(a, b) in &self.found {
            let (sa, sb) = (slot(a), slot(b));
            let (i, j) = (sa.min(sb), sa.max(sb));
            if (first..first + own).contains(&i) {
                self.pairs.push(((i - first) as u32, (j - first) as u32));
            }
        }
        self.pairs.sort_unstable();
        self.plane_contacts.clear();
        for s in 0..own {
            for (p, plane) in self.planes.iter().enumerate() {
                if plane.signed_distance(self.window.position[s]) < self.window.radius[s] {
                    self.plane_contacts.push((s as u32, p as u32));
                }
            }
        }
    }
}

/// Where a particle goes in the storage order: by cell of the sort grid, ties by id, exactly
/// as [`World`]'s counting sort orders them; unique per particle.
fn sort_value<V: Vector>(layout: &GridLayout, x: V, id: u32) -> u64 {
    ((layout.linear(layout.cell_coords(x)) as u64) << 32) | id as u64
}

/// The rank that borrows `rank`'s first block (in the sweeps of `parity`, or at all when
/// `None`).
fn borrower(partition: &Partition, rank: usize, parity: Option<usize>) -> Option<usize> {
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
fn lender(partition: &Partition, rank: usize, parity: Option<usize>) -> Option<usize> {
    let last = partition.blocks_of(rank).end.checked_sub(1)?;
    let owner = partition.halo_owner(rank)?;
    parity.is_none_or(|p| last % 2 == p).then_some(owner)
}

/// This step's leftover contacts of every rank, in global order, with the bodies of the
/// particles they involve.
struct Leftovers<V> {
    /// Indices into `slots` of each contact, in global order.
    pairs: Vec<(u32, u32)>,
    /// Every particle some leftover involves, by ascending slot.
    slots: Vec<u32>,
    bodies: Vec<Body<V>>,
    /// `slots[own.clone()]` are this rank's.
    own: std::ops::Range<usize>,
}

impl<V: Vector> Leftovers<V> {
    fn gather<T: Transport + ?Sized>(link: &mut Link<'_, T>, sub: &Subdomain<V>) -> Self {
        let first = sub.first_slot as u32;
        let mut mine = Writer::default();
        for &(i, j) in &sub.blocks.leftovers {
            mine.u32(first + i).u32(first + j);
        }
        let mut global = Vec::new();
        for bytes in link.gather(TrafficKind::Leftovers, &mine.0) {
            let mut r = Reader::new(&bytes);
            while !r.is_empty() {
                global.push((r.u32(), r.u32()));
            }
        }
        let mut slots: Vec<u32> = global.iter().flat_map(|&(i, j)| [i, j]).collect();
        slots.sort_unstable();
        slots.dedup();
        let own_slots = first..first + sub.own as u32;
        let own = slots.partition_point(|&s| s < own_slots.start)
            ..slots.partition_point(|&s| s < own_slots.end);
        let index = |s: u32| slots.binary_search(&s).unwrap_or_default() as u32;
        let pairs = global.iter().map(|&(i, j)| (index(i), index(j))).collect();
        let mut bodies = Vec::new();
        if !slots.is_empty() {
            let mut w = Writer::default();
            for &s in &slots[own.clone()] {
                let s = (s - first) as usize;
                w.vector(sub.window.position[s])
                    .f64(sub.window.radius[s])
                    .f64(sub.window.mass[s]);
            }
            for bytes in link.gather(TrafficKind::Leftovers, &w.0) {
                let mut r = Reader::new(&bytes);
                while !r.is_empty() {
                    bodies.push(Body {
                        position: r.vector(),
                        radius: r.f64(),
                        mass: r.f64(),
                    });
                }
            }
        }
        Self {
            pairs,
            slots,
            bodies,
            own,
        }
    }
}

/// The solver's [`Exchange`] across ranks: lends and returns first blocks around the block
/// pairs on a border, runs the leftovers everywhere, adds up counts.
struct Lender<'a, 'l, T: ?Sized, V> {
    link: &'a mut Link<'l, T>,
    partition: &'a Partition,
    rank: usize,
    first_slot: usize,
    own: usize,
    needed: &'a [u32],
    lent: &'a [u32],
    lending: [bool; 2],
    leftovers: &'a Leftovers<V>,
}

impl<T: Transport + ?Sized, V: Vector> Lender<'_, '_, T, V> {
    /// Lends (`back == false`) or returns (`back == true`) the borrowed particles the block
    /// pairs of `parity` touch.
    fn swap_halo(&mut self, parity: usize, data: &mut [V], back: bool) {
        if !self.lending[parity] {
            return;
        }
        let borrower = borrower(self.partition, self.rank, Some(parity));
        let lender = lender(self.partition, self.rank, Some(parity));
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
        self.swap_halo(parity, data, false);
    }

    fn after_blocks(&mut self, parity: usize, data: &mut [V]) {
        self.swap_halo(parity, data, true);
    }

    fn leftovers<B, R>(&mut self, _blocks: &Blocks, data: &mut [V], _body: &B, rule: &R) -> u64
    where
        B: Fn(usize) -> Body<V>,
        R: Fn(&Body<V>, &Body<V>, &mut V, &mut V) -> bool,
    {
        let l = self.leftovers;
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
        for &(a, b) in &l.pairs {
            let (a, b) = (a as usize, b as usize);
            let (va, vb) = pair_mut(&mut values, a, b);
            changed += rule(&l.bodies[a], &l.bodies[b], va, vb) as u64;
        }
        for k in l.own.clone() {
            data[l.slots[k] as usize - self.first_slot] = values[k];
        }
        changed
    }

    fn total(&mut self, local: u64) -> u64 {
        self.link.sum(&[local])[0]
    }
}
