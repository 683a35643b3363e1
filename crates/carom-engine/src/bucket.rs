//! Cell lists by counting sort: the one way the engine groups particles by a cell number (the
//! grid's cells, the hash's buckets, the storage order along space).

/// Groups `items` by their key: afterwards `order[starts[c] as usize..starts[c + 1] as usize]`
/// lists the items whose key is `c`, in the order `items` gave them (a stable sort, so ties
/// keep that order). `keys[i]` is item `i`'s key, below `buckets`; `items` yields every index
/// of `keys` once. O(items + buckets); reuses the buffers' memory.
pub(crate) fn counting_sort(
    keys: &[u32],
    buckets: usize,
    items: impl IntoIterator<Item = u32>,
    starts: &mut Vec<u32>,
    order: &mut Vec<u32>,
) {
    starts.clear();
    starts.resize(buckets + 1, 0);
    for &k in keys {
        starts[k as usize + 1] += 1;
    }
    for c in 0..buckets {
        starts[c + 1] += starts[c];
    }
    // Scatter with `starts[c]` as the cursor; afterwards it holds the end of cell c, which is
    // the start of cell c + 1, so shifting by one restores the starts.
    order.resize(keys.len(), 0);
    for i in items {
        let slot = &mut starts[keys[i as usize] as usize];
        order[*slot as usize] = i;
        *slot += 1;
    }
    starts.copy_within(0..buckets, 1);
    starts[0] = 0;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_by_key_keeping_the_given_order() {
        let keys = [2, 0, 2, 1, 0];
        let (mut starts, mut order) = (Vec::new(), Vec::new());
        counting_sort(&keys, 4, 0..5, &mut starts, &mut order);
        assert_eq!(starts, [0, 2, 3, 5, 5]);
        assert_eq!(order, [1, 4, 3, 0, 2]);
        // items in another order: ties follow it
        counting_sort(&keys, 4, [4, 3, 2, 1, 0], &mut starts, &mut order);
        assert_eq!(order, [4, 1, 3, 2, 0]);
    }
}
