//! One rank's part of a world, stepped in lockstep with the others.

mod contacts;
mod migrate;
mod retake;
mod stepping;

use migrate::own_memory;
use stepping::Stepping;

use crate::broadphase::{BroadPhase, Pair};
use crate::cluster::lender::Leftovers;
use crate::cluster::partition::Partition;
use crate::cluster::sleepers::SplitSleepers;
use crate::cluster::traffic::{Link, Traffic, TrafficKind};
use crate::cluster::transport::Transport;
use crate::cluster::wire::{Reader, Writer};
use crate::diagnostics::StepStats;
use crate::error::EngineError;
use crate::grid::Grid;
use crate::memory::{ContactImpulses, Memory};
use crate::particles::Particles;
use crate::plane::Plane;
use crate::schedule::{Blocks, PlaneContact};
use crate::solver::{PlaneRow, Rows};
use crate::step;
use crate::timing::PhaseTimes;
use crate::vector::Vector;
use crate::world::{block_size, Snapshot, World, WorldConfig, REORDER_INTERVAL};

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
    rows: Rows<V>,
    /// This step's [`StepStats::found_overlap`] among the rows this rank owns.
    found_overlap: f64,
    /// This step's [`StepStats::fastest_move`] among the own particles.
    fastest_move: f64,
    /// What a step taken again needs (see `solver::escape`): the start is the search's copy.
    retakes: crate::solver::Retakes<V>,
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
    /// The velocity of each.
    velocity: Vec<V>,
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
        self.velocity.clear();
        self.ghost_slot.clear();
    }

    /// Adds a particle at `x` with `[reach, radius, mass]`, moving at `velocity`.
    fn push(&mut self, x: V, [reach, radius, mass]: [f64; 3], velocity: V, id: u32) {
        self.position.push(x);
        self.reach.push(reach);
        self.radius.push(radius);
        self.mass.push(mass);
        self.velocity.push(velocity);
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

/// What a rank takes of a whole world: its slots' particles (with room for the halo after
/// them), their ids, rest times and remembered impulses.
struct Share<V> {
    ids: Vec<u32>,
    window: Particles<V>,
    rest: Vec<f64>,
    memory: Memory,
    memory_partners: Vec<u32>,
}

impl<V: Vector> Share<V> {
    /// The particles of `slots` of `world` (every rank built the same one), followed by `halo`
    /// placeholders.
    fn of(world: &World<V>, slots: std::ops::Range<usize>, halo: usize) -> Self {
        let n = world.len();
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
        let room = slots.len() + halo;
        let slot_of = |id: u32| world.slots[id as usize] as usize;
        let window = |v: &[V]| {
            let mut w: Vec<V> = ids.iter().map(|&id| v[slot_of(id)]).collect();
            w.resize(room, V::ZERO);
            w
        };
        let window_f64 = |v: &[f64]| {
            let mut w: Vec<f64> = ids.iter().map(|&id| v[slot_of(id)]).collect();
            w.resize(room, 1.0);
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
        let (memory, memory_partners) = own_memory(&impulses, &slot_in_order, &order, slots);
        let window = Particles {
            position: window(&store.position),
            velocity: window(&store.velocity),
            radius: window_f64(&store.radius),
            mass: window_f64(&store.mass),
        };
        Share {
            ids,
            window,
            rest,
            memory,
            memory_partners,
        }
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
        let share = Share::of(world, slots.clone(), halo);
        Ok(Self {
            config: world.config().clone(),
            planes: world.planes().to_vec(),
            rank,
            first_slot: slots.start,
            own: slots.len(),
            halo,
            window: share.window,
            ids: share.ids,
            max_radius: world.store.max_radius(),
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
            rows: Default::default(),
            found_overlap: 0.0,
            fastest_move: 0.0,
            retakes: Default::default(),
            plane_contacts: Vec::new(),
            plane_rows: Vec::new(),
            memory: share.memory,
            memory_partners: share.memory_partners,
            kept_asleep: Vec::new(),
            arrived_pairs: Vec::new(),
            arrived_planes: Vec::new(),
            rerouting: false,
            rest: share.rest,
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
}
