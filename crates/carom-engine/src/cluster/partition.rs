//! Which rank owns which storage slots.

use std::ops::Range;

/// Ranks own runs of whole solver blocks, as even as whole blocks allow, so every rank holds
/// the same number of particles to within one block. Fixed for a run: the particles move
/// between slots (at each spatial sort), the slots do not move between ranks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Partition {
    slots: usize,
    block: usize,
    /// Rank `r` owns blocks `first_block[r]..first_block[r + 1]`.
    first_block: Vec<usize>,
}

impl Partition {
    /// `slots` particles in blocks of `block` slots (> 0) over `ranks` (>= 1) ranks.
    pub fn new(slots: usize, block: usize, ranks: usize) -> Self {
        let block = block.max(1);
        let ranks = ranks.max(1);
        let blocks = slots.div_ceil(block);
        let first_block = (0..=ranks).map(|r| r * blocks / ranks).collect();
        Self {
            slots,
            block,
            first_block,
        }
    }

    /// Total slots (particles).
    pub fn slots(&self) -> usize {
        self.slots
    }

    /// Slots per block.
    pub fn block(&self) -> usize {
        self.block
    }

    /// Number of ranks.
    pub fn ranks(&self) -> usize {
        self.first_block.len() - 1
    }

    /// Total blocks.
    pub fn blocks(&self) -> usize {
        self.slots.div_ceil(self.block)
    }

    /// The blocks rank `rank` owns (empty when there are fewer blocks than ranks).
    pub fn blocks_of(&self, rank: usize) -> Range<usize> {
        self.first_block[rank]..self.first_block[rank + 1]
    }

    /// The slots rank `rank` owns.
    pub fn slots_of(&self, rank: usize) -> Range<usize> {
        let b = self.blocks_of(rank);
        (b.start * self.block).min(self.slots)..(b.end * self.block).min(self.slots)
    }

    /// The slots of block `block`.
    pub fn block_slots(&self, block: usize) -> Range<usize> {
        (block * self.block).min(self.slots)..((block + 1) * self.block).min(self.slots)
    }

    /// The rank owning block `block` (< `blocks()`).
    pub fn owner_of_block(&self, block: usize) -> usize {
        // the last rank whose first block is <= block, skipping empty ranks
        self.first_block.partition_point(|&f| f <= block) - 1
    }

    /// The rank owning slot `slot` (< `slots()`).
    pub fn owner_of_slot(&self, slot: usize) -> usize {
        self.owner_of_block(slot / self.block)
    }

    /// The rank whose first block rank `rank` borrows (the block after its last), if any.
    pub fn halo_owner(&self, rank: usize) -> Option<usize> {
        let b = self.blocks_of(rank);
        (!b.is_empty() && b.end < self.blocks()).then(|| self.owner_of_block(b.end))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_spread_evenly_and_owners_agree() {
        let p = Partition::new(5000, 1024, 4);
        assert_eq!(p.blocks(), 5);
        let sizes: Vec<usize> = (0..4).map(|r| p.slots_of(r).len()).collect();
        assert_eq!(sizes.iter().sum::<usize>(), 5000);
        assert_eq!(sizes, vec![1024, 1024, 1024, 1928]);
        for s in 0..5000 {
            assert!(p.slots_of(p.owner_of_slot(s)).contains(&s));
        }
        assert_eq!(p.halo_owner(0), Some(1));
        assert_eq!(p.halo_owner(3), None);
    }

    #[test]
    fn more_ranks_than_blocks_leaves_some_empty() {
        let p = Partition::new(100, 1024, 3);
        assert_eq!((0..3).map(|r| p.slots_of(r).len()).sum::<usize>(), 100);
        assert_eq!(p.owner_of_slot(99), 2);
        assert!(p.slots_of(0).is_empty());
        assert_eq!(p.halo_owner(2), None);
    }
}
