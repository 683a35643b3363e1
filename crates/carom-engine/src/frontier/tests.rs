//! The frontier against a scan, and the stamps' groups against the slots.

use super::*;

/// Stamps and their groups with the stamps `of` each slot, set in the order of the stamps.
fn stamped(of: &[u32]) -> (Vec<u32>, Vec<GroupStamps>) {
    let (mut slot, mut group) = (
        vec![0; of.len()],
        vec![GroupStamps::default(); of.len().div_ceil(GROUP)],
    );
    let mut stamps = Stamps::new(&mut slot, &mut group);
    let mut order: Vec<usize> = (0..of.len()).filter(|&i| of[i] > 0).collect();
    order.sort_by_key(|&i| of[i]);
    for i in order {
        stamps.set(i, of[i]);
    }
    (slot, group)
}

#[test]
fn groups_find_the_stamped_slots_and_split_with_them() {
    let (mut slot, mut group) = (vec![0; 200], vec![GroupStamps::default(); 4]);
    let mut stamps = Stamps::new(&mut slot, &mut group);
    for (i, now) in [(3, 5), (70, 6), (199, 7), (130, 2)] {
        stamps.set(i, now);
    }
    let since = |stamps: &Stamps, since, end| {
        let mut out = Vec::new();
        stamps.collect_since(since, end, &mut out, |_| true);
        out
    };
    assert_eq!(since(&stamps, 5, 200), vec![3, 70, 199]);
    assert_eq!(since(&stamps, 5, 199), vec![3, 70]);
    // (more than a sweep back: from the slots' stamps)
    assert_eq!(since(&stamps, 2, 200), vec![3, 70, 130, 199]);
    assert_eq!(since(&stamps, 3, 200), vec![3, 70, 199]);
    let (low, high) = stamps.split_at(128);
    assert_eq!(since(&low, 6, 1000), vec![70]);
    assert_eq!(since(&high, 1, 72), vec![2, 71]);
    assert_eq!(since(&high, 1, 71), vec![2]);
}

proptest::proptest! {
    /// The groups' bits find what reading every slot's stamp finds, sweep after sweep.
    #[test]
    fn group_bits_find_what_the_slots_say(
        sweeps in proptest::collection::vec(proptest::collection::vec(0usize..300, 0..20), 1..12),
        end in 0usize..320,
    ) {
        let (mut slot, mut group) = (vec![0; 300], vec![GroupStamps::default(); 300usize.div_ceil(GROUP)]);
        let mut stamps = Stamps::new(&mut slot, &mut group);
        for (sweep, changed) in sweeps.iter().enumerate() {
            let now = sweep as u32 + 1;
            for &i in changed {
                stamps.set(i, now);
            }
            for since in 1..=now {
                let mut found = Vec::new();
                stamps.collect_since(since, end, &mut found, |_| true);
                let read: Vec<u32> = (0..end.min(300) as u32)
                    .filter(|&l| stamps.get(l as usize) >= since)
                    .collect();
                proptest::prop_assert_eq!(found, read);
            }
        }
    }
}

#[test]
fn every_contact_is_listed_under_both_its_particles_in_order() {
    // one block of 4 slots (span 0..4): contacts (0,1), (0,3), (1,2), (2,3)
    let pairs = [(0, 1), (0, 3), (1, 2), (2, 3)];
    let mut f = Frontier::default();
    f.index(&pairs, &[0, 4], 4, 4, false);
    let b = &f.blocks[0];
    assert_eq!(b.start, vec![0, 2, 4, 6, 8]);
    assert_eq!(b.list, vec![0, 1, 0, 2, 2, 3, 1, 3]);
    assert_eq!(b.reached, 4);
    assert!(f.ready());
    // slots 2 and 3 touch nothing: the walk need not look at their stamps
    f.index(&[(0, 1)], &[0, 1], 4, 4, false);
    assert_eq!(f.blocks[0].reached, 2);
    f.index(&[], &[0, 0], 4, 4, false);
    assert_eq!(f.blocks[0].reached, 0);
}

/// Each span slot's contacts, as the index of block `b` lists them and as
/// the block's pairs (`pair_start`, spans of two blocks of `size` in `n` slots) say.
fn listed_and_expected(
    f: &Frontier,
    pairs: &[Pair],
    pair_start: &[usize],
    b: usize,
    size: usize,
    n: usize,
) -> (Vec<Vec<u32>>, Vec<Vec<u32>>) {
    let index = &f.blocks[b];
    let (base, end) = (b * size, ((b + 2) * size).min(n));
    // (the walk asks only below `reached`: past it, no slot has a contact here)
    let of = |l: usize| match l < index.reached {
        true => index.of(l).to_vec(),
        false => vec![],
    };
    let listed = (0..end - base).map(of).collect();
    let expected = (0..end - base)
        .map(|l| {
            let mine = pair_start[b]..pair_start[b + 1];
            let touches = |&k: &usize| {
                let (i, j) = pairs[k];
                (j as usize) < end && [i, j].contains(&((base + l) as u32))
            };
            mine.filter(touches).map(|k| k as u32).collect()
        })
        .collect();
    (listed, expected)
}

#[test]
fn each_index_lists_every_blocks_contacts_by_slot() {
    // blocks of 256 slots in 640: few contacts (a gas), one leaving the span (a leftover)
    let (size, n) = (256, 640);
    let first: Vec<Pair> = vec![
        (0, 300),
        (5, 6),
        (5, 100),
        (200, 201),
        (260, 270),
        (300, 600),
    ];
    let second: Vec<Pair> = vec![(6, 7), (100, 290), (100, 300), (290, 291)];
    let mut f = Frontier::default();
    // (each index over the last one's lists)
    for pairs in [&first, &second, &first] {
        let starts = |b: u32| pairs.partition_point(|&(i, _)| i < b * size as u32);
        let pair_start = [starts(0), starts(1), starts(2), starts(3)];
        f.index(pairs, &pair_start, size, n, false);
        for b in 0..3 {
            let (listed, expected) = listed_and_expected(&f, pairs, &pair_start, b, size, n);
            assert_eq!(listed, expected, "block {b} of {pairs:?}");
        }
        let reached = expected_reach(pairs, &pair_start, 0, 512);
        assert_eq!(f.blocks[0].reached, reached);
    }
    // two contacts a slot (a pile)
    let crowded: Vec<Pair> = (0..255).flat_map(|i| [(i, i + 1), (i, i + 2)]).collect();
    let pair_start = [0, crowded.len(), crowded.len(), crowded.len()];
    f.index(&crowded, &pair_start, size, n, false);
    let (listed, expected) = listed_and_expected(&f, &crowded, &pair_start, 0, size, n);
    assert_eq!(listed, expected);
}

/// One past the largest `j` below `end` of block `b`'s pairs (0 when none).
fn expected_reach(pairs: &[Pair], pair_start: &[usize], b: usize, end: usize) -> usize {
    let mine = &pairs[pair_start[b]..pair_start[b + 1]];
    let ends = mine
        .iter()
        .map(|&(_, j)| j as usize + 1)
        .filter(|&j| j <= end);
    ends.max().unwrap_or(0)
}

#[test]
fn the_walk_follows_changes_forwards_and_backwards() {
    // a chain 0-1-2-3-4: contacts k = (k, k + 1)
    let pairs = [(0, 1), (1, 2), (2, 3), (3, 4)];
    let mut f = Frontier::default();
    f.index(&pairs, &[0, 4], 8, 5, false);
    for reverse in [false, true] {
        // seeded at slot 2 (contacts 1 and 2); every visit changes its particles
        let mut seen = Vec::new();
        let (mut slot, mut group) = stamped(&[0, 0, 1, 0, 0]);
        let mut stamps = Stamps::new(&mut slot, &mut group);
        let step = |k: usize, _: &mut Stamps| {
            seen.push(k);
            Some(pairs[k]).map(|(i, j)| (i as usize, j as usize))
        };
        assert_eq!(f.walk(0, 0..400, reverse, &mut stamps, 1, step), Walk::Done);
        let expected = if reverse {
            vec![2, 1, 0]
        } else {
            vec![1, 2, 3]
        };
        assert_eq!(seen, expected, "reverse {reverse}");
    }
    // a visit that changes nothing passes nothing on
    let mut seen = Vec::new();
    let (mut slot, mut group) = stamped(&[0, 1, 0, 0, 0]);
    let mut stamps = Stamps::new(&mut slot, &mut group);
    let step = |k: usize, _: &mut Stamps| {
        seen.push(k);
        None
    };
    assert_eq!(f.walk(0, 0..400, false, &mut stamps, 1, step), Walk::Done);
    assert_eq!(seen, vec![0, 1]);
    // too many seeds for the size: a scan instead
    let (mut slot, mut group) = stamped(&[1; 5]);
    let mut stamps = Stamps::new(&mut slot, &mut group);
    assert_eq!(
        f.walk(0, 0..4, false, &mut stamps, 1, |_, _| None),
        Walk::ScanPast(None)
    );
    // a budget that runs out on the way: the scan goes on past the last contact visited
    let (mut slot, mut group) = stamped(&[0, 1, 0, 0, 0]);
    let mut stamps = Stamps::new(&mut slot, &mut group);
    let walk = f.walk(0, 0..8, false, &mut stamps, 1, |k, _| {
        Some(pairs[k]).map(|(i, j)| (i as usize, j as usize))
    });
    assert_eq!(walk, Walk::ScanPast(Some(0)));
}

#[test]
fn the_walk_takes_each_contact_once_across_words_in_order() {
    // a star: slot 0 touches slots 1..=130 (contacts 0..130, more than two words of bits)
    let pairs: Vec<Pair> = (1..=130).map(|j| (0, j)).collect();
    let mut f = Frontier::default();
    f.index(&pairs, &[0, pairs.len()], 256, 131, false);
    for reverse in [false, true] {
        let mut seen = Vec::new();
        let (mut slot, mut group) = stamped(&[0; 131]);
        let mut stamps = Stamps::new(&mut slot, &mut group);
        stamps.set(0, 1);
        let step = |k: usize, _: &mut Stamps| {
            seen.push(k);
            Some((0, k + 1))
        };
        // (a block of room enough that the budget does not run out)
        let walked = f.walk(0, 0..100_000, reverse, &mut stamps, 1, step);
        assert_eq!(walked, Walk::Done);
        let mut expected: Vec<usize> = (0..130).collect();
        if reverse {
            expected.reverse();
        }
        assert_eq!(seen, expected, "reverse {reverse}");
    }
}
