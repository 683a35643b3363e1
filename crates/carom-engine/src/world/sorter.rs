//! The spatial sort of the particle arrays (see the [module notes](super)).

use crate::broadphase::{CellScratch, PARALLEL_MIN};
use crate::bucket::counting_sort;
use crate::domain::Aabb;
use crate::grid::{bounding_box, GridLayout};
use crate::particles::Particles;
use crate::vector::Vector;
use rayon::prelude::*;

/// The grid the spatial sort orders `n` particles by: over `bounds` (the domain, or the
/// particles' bounding box), cells one largest diameter wide, at most one per particle (finer
/// would not sort any better, only cost memory). Derived from the particles alone, never from
/// the broad phase or its cell count, so that brute force and every grid size see the same
/// storage order and the same bits.
pub(crate) fn sort_layout<V: Vector>(bounds: &Aabb<V>, max_radius: f64, n: usize) -> GridLayout {
    GridLayout::fit(bounds, max_radius, None, (n as f64).max(64.0))
}
/// The spatial sort's scratch space, kept between sorts.
#[derive(Debug, Default)]
pub(super) struct Sorter {
    /// `keys`: each slot's cell while planning; after [`Sorter::sort`], where the slot's
    /// particle went (see [`Sorter::new_slot_of`]), until the next step's search by cells
    /// borrows them (see [`crate::broadphase::BroadPhase::find_pairs_in`]).
    pub(super) scratch: CellScratch,
    done: Vec<u64>,
}

impl Sorter {
    /// Fills `self.scratch.order` with the slots of `store` in their sorted order (by grid cell, ties
    /// by id): new slot `s` takes what is now at slot `order[s]`.
    pub(super) fn plan<V: Vector>(
        &mut self,
        store: &Particles<V>,
        slots: &[u32],
        domain: Option<Aabb<V>>,
    ) {
        let n = store.len();
        let bounds = domain.unwrap_or_else(|| bounding_box(&store.position));
        let layout = sort_layout(&bounds, store.max_radius(), n);
        self.scratch.keys.resize(n, 0);
        let key = |(k, &x): (&mut u32, &V)| *k = layout.linear(layout.cell_coords(x)) as u32;
        if n >= PARALLEL_MIN {
            self.scratch
                .keys
                .par_iter_mut()
                .zip(store.position.par_iter())
                .for_each(key);
        } else {
            self.scratch
                .keys
                .iter_mut()
                .zip(store.position.iter())
                .for_each(key);
        }
        // Ties (one cell) go by id, so the new order is a function of the state alone, not of
        // the order before: a world rebuilt from the same state sorts the same way.
        let items = slots.iter().copied();
        counting_sort(
            &self.scratch.keys,
            layout.total(),
            items,
            &mut self.scratch.starts,
            &mut self.scratch.order,
        );
    }

    /// Sorts the arrays by grid cell, ties by id (`rest` too, unless it is empty).
    pub(super) fn sort<V: Vector>(
        &mut self,
        store: &mut Particles<V>,
        ids: &mut [u32],
        rest: &mut [f64],
        slots: &mut [u32],
        domain: Option<Aabb<V>>,
    ) {
        let n = store.len();
        if n == 0 {
            return;
        }
        self.plan(store, slots, domain);
        // new slot s takes what was at order[s]: apply by following cycles, all arrays at once.
        self.done.clear();
        self.done.resize(n.div_ceil(64), 0);
        let Particles {
            position,
            velocity,
            radius,
            mass,
        } = store;
        let (has_rest, no_rest) = (!rest.is_empty(), &mut [0.0][..]);
        let rest = if has_rest { rest } else { no_rest };
        // (without rest times, every particle reads and writes the one placeholder)
        let at = |s: usize| if has_rest { s } else { 0 };
        for start in 0..n {
            if self.done[start / 64] & (1 << (start % 64)) != 0 {
                continue;
            }
            let saved = (
                position[start],
                velocity[start],
                radius[start],
                mass[start],
                ids[start],
                rest[at(start)],
            );
            let mut s = start;
            loop {
                self.done[s / 64] |= 1 << (s % 64);
                let from = self.scratch.order[s] as usize;
                if from == start {
                    (
                        position[s],
                        velocity[s],
                        radius[s],
                        mass[s],
                        ids[s],
                        rest[at(s)],
                    ) = saved;
                    break;
                }
                position[s] = position[from];
                velocity[s] = velocity[from];
                radius[s] = radius[from];
                mass[s] = mass[from];
                ids[s] = ids[from];
                rest[at(s)] = rest[at(from)];
                s = from;
            }
        }
        for (slot, &id) in ids.iter().enumerate() {
            slots[id as usize] = slot as u32;
        }
        // (the keys are done with: they become the map from old slots to new)
        for (new, &old) in self.scratch.order.iter().enumerate() {
            self.scratch.keys[old as usize] = new as u32;
        }
    }

    /// After [`Sorter::sort`]: for each slot before the sort, the slot its particle is in now.
    pub(super) fn new_slot_of(&self) -> &[u32] {
        &self.scratch.keys
    }
}
