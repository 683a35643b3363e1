//! A batch of placement tries and the checks that decide which of them are placed: exactly
//! those that overlap nothing placed before them, as one try after another would decide.
//!
//! Two checks, both on the thread pool, each try's answer its own:
//! 1. every try against the particles placed before the batch (in the order of the tries'
//!    cells, so that tries checked one after another read neighbouring cells);
//! 2. every try that passed (a *survivor*) against the survivors before it in the batch,
//!    found around it through the grid's index of survivors; overlapping pairs are rare.
//!
//! Then one pass in try order settles the chains: a survivor is placed unless a survivor
//! before it that it overlaps was placed.

use crate::fill::Placer;
use crate::placement::{Disc, PlacementGrid};
use carom_engine::Vector;
use rayon::prelude::*;

/// Tries per task of a batch's checks on the thread pool.
const TRIES_PER_TASK: usize = 512;

/// A batch of tries and the scratch of its checks (kept from batch to batch).
#[derive(Default)]
pub(crate) struct Screen<V> {
    /// The tries, in the order they were drawn.
    pub tries: Vec<V>,
    /// Whether each try is placed (after [`Screen::decide`]).
    pub placed: Vec<bool>,
    /// Each try's cell (high half) and index (low half), sorted.
    by_cell: Vec<u64>,
    /// The tries in that order.
    sorted_tries: Vec<V>,
    /// Whether each try in that order overlaps a particle placed before the batch.
    sorted_refused: Vec<bool>,
    /// The survivors' keys (as in `by_cell`), in cell order.
    survivors: Vec<u64>,
    /// Their cells.
    survivor_cells: Vec<u32>,
    /// Their positions (read many times each by the survivors around them: here in the
    /// order they are read in, rather than in try order).
    survivor_centres: Vec<V>,
    /// `(try, earlier try)` for every two survivors that overlap, sorted.
    conflicts: Vec<(u32, u32)>,
    /// The placed survivors with their cells, in cell order: what [`Screen::settle`] merges.
    added: Vec<(u32, Disc<V>)>,
}

/// The try index of a key of [`Screen::by_cell`].
#[inline]
fn index(key: u64) -> usize {
    (key & u64::from(u32::MAX)) as usize
}

impl<V: Vector> Screen<V> {
    /// Fills [`Screen::placed`] for a particle of `radius` at each try.
    pub fn decide(&mut self, placer: &mut Placer<V>, radius: f64) {
        self.check_placed(placer, radius);
        self.survivors.clear();
        self.survivor_centres.clear();
        let sorted = self.by_cell.iter().zip(&self.sorted_tries);
        for ((&key, &x), _) in sorted
            .zip(&self.sorted_refused)
            .filter(|&(_, &refused)| !refused)
        {
            self.survivors.push(key);
            self.survivor_centres.push(x);
        }
        self.survivor_cells.clear();
        self.survivor_cells
            .extend(self.survivors.iter().map(|&key| (key >> 32) as u32));
        placer.grid.index_survivors(&self.survivor_cells);
        self.check_survivors(placer, radius);
        placer.grid.forget_survivors(&self.survivor_cells);
        self.placed.clear();
        self.placed.resize(self.tries.len(), false);
        for &key in &self.survivors {
            self.placed[index(key)] = true;
        }
        // (by later try: the earlier one's fate is settled by the time it is read)
        for &(later, earlier) in &self.conflicts {
            if self.placed[earlier as usize] {
                self.placed[later as usize] = false;
            }
        }
    }

    /// Sorts the tries by cell and checks each against the particles placed before the batch.
    fn check_placed(&mut self, placer: &Placer<V>, radius: f64) {
        let grid = &placer.grid;
        self.by_cell.clear();
        self.by_cell.extend(
            self.tries
                .iter()
                .enumerate()
                .map(|(k, &x)| (u64::from(grid.cell_of(x)) << 32) | k as u64),
        );
        // (the keys are in try order, so a stable sort by the cell alone orders them by cell,
        // then by try, as a sort of the whole keys would)
        radsort::sort_by_key(&mut self.by_cell, |&key| (key >> 32) as u32);
        let tries = &self.tries;
        self.sorted_tries.clear();
        self.sorted_tries
            .par_extend(self.by_cell.par_iter().map(|&key| tries[index(key)]));
        self.sorted_refused.clear();
        self.sorted_refused.resize(self.tries.len(), false);
        self.sorted_tries
            .par_chunks(TRIES_PER_TASK)
            .zip(self.sorted_refused.par_chunks_mut(TRIES_PER_TASK))
            .for_each(|(xs, refused)| placer.refusals(xs.iter().copied(), radius, refused));
    }

    /// Fills [`Screen::conflicts`]: every survivor against the survivors of lower try index
    /// around it (the grid indexes the survivors).
    fn check_survivors(&mut self, placer: &Placer<V>, radius: f64) {
        let (survivors, cells) = (&self.survivors, &self.survivor_cells);
        let centres = &self.survivor_centres;
        let grid: &PlacementGrid<V> = &placer.grid;
        self.conflicts = survivors
            .par_chunks(TRIES_PER_TASK)
            .zip(centres.par_chunks(TRIES_PER_TASK))
            .flat_map_iter(|(keys, xs)| {
                let mut found = Vec::new();
                for (&key, &x) in keys.iter().zip(xs) {
                    let k = index(key);
                    placer.across_seams(x, radius, |image| {
                        grid.survivors_near(image, radius, cells, |s| {
                            let earlier = index(survivors[s]);
                            let disc = Disc {
                                centre: centres[s],
                                radius,
                            };
                            if earlier < k && disc.overlaps(image, radius) {
                                found.push((k as u32, earlier as u32));
                            }
                        });
                        false
                    });
                }
                found
            })
            .collect();
        self.conflicts.sort_unstable();
    }

    /// How many tries are placed, at most `most`, and the end of the tries they come from
    /// (the index after the last one counted, or all of them).
    pub fn placed_up_to(&self, most: u64) -> (usize, usize) {
        let mut taken = 0;
        for (k, _) in self.placed.iter().enumerate().filter(|(_, &placed)| placed) {
            taken += 1;
            if taken as u64 == most {
                return (taken, k + 1);
            }
        }
        (taken, self.tries.len())
    }

    /// The positions of the placed tries before try `end`, in try order.
    pub fn placed_tries(&self, end: usize) -> impl Iterator<Item = &V> {
        (self.tries[..end].iter().zip(&self.placed))
            .filter(|(_, &placed)| placed)
            .map(|(x, _)| x)
    }

    /// Adds the placed tries before try `end` to `grid`.
    pub fn settle(&mut self, grid: &mut PlacementGrid<V>, end: usize, radius: f64) {
        self.added.clear();
        let survivors = self.survivors.iter().zip(&self.survivor_cells);
        for ((&key, &cell), &centre) in survivors.zip(&self.survivor_centres) {
            let k = index(key);
            if k < end && self.placed[k] {
                self.added.push((cell, Disc { centre, radius }));
            }
        }
        grid.merge(&self.added);
    }
}
