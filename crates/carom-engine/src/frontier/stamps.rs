//! The work lists' stamps: which slots each sweep changed, per slot and per group of slots.

/// Slots per group of stamps (see [`Stamps`]); block boundaries are multiples of it.
pub(crate) const GROUP: usize = 64;

/// The work lists' stamps for a run of slots (see [`crate::schedule`]): per slot, the number
/// of the last sweep that changed it, and per group of [`GROUP`] slots which of them the last
/// two sweeps changed (see [`GroupStamps`]), so that a sweep finds the changed slots without
/// reading every stamp. Empty when there are no work lists.
#[derive(Debug, Default)]
pub(crate) struct Stamps<'a> {
    slot: &'a mut [u32],
    group: &'a mut [GroupStamps],
}

/// The stamps of one group of [`GROUP`] slots, one bit per slot: a sweep after a pass's first
/// wants the slots stamped by the sweep before it or by itself, which these bits give without
/// reading the slots' stamps (scattered over memory, those reads were most of the cost of
/// finding them: see [`super::Frontier::walk`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct GroupStamps {
    /// The largest stamp of the group's slots.
    latest: u32,
    /// The slots stamped `latest`.
    newest: u64,
    /// The slots stamped `latest - 1` (some may have been stamped `latest` since).
    before: u64,
}

impl GroupStamps {
    /// The group's slots stamped at least `since`, as bits, or `None` when the bits cannot
    /// tell (`since` more than one sweep before the latest: the slots' stamps must).
    #[inline]
    pub(super) fn since(&self, since: u32) -> Option<u64> {
        if self.latest < since {
            Some(0)
        } else if self.latest == since {
            Some(self.newest)
        } else if self.latest - 1 == since {
            Some(self.newest | self.before)
        } else {
            None
        }
    }
}

impl<'a> Stamps<'a> {
    /// The stamps `slot` with their groups `group` (`slot.len()` divided by [`GROUP`],
    /// rounded up; both zero or filled by this type's methods alone).
    pub fn new(slot: &'a mut [u32], group: &'a mut [GroupStamps]) -> Self {
        debug_assert_eq!(group.len(), slot.len().div_ceil(GROUP));
        Self { slot, group }
    }

    /// No stamps: no work list.
    pub fn none() -> Self {
        Self::default()
    }

    /// True without work lists.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.slot.is_empty()
    }

    /// Slot `i`'s stamp.
    #[inline]
    pub fn get(&self, i: usize) -> u32 {
        self.slot[i]
    }

    /// Stamps slot `i` with `now`, the newest sweep's number (no stamp is ever larger).
    #[inline]
    pub fn set(&mut self, i: usize, now: u32) {
        self.slot[i] = now;
        let group = &mut self.group[i / GROUP];
        if group.latest != now {
            group.before = if group.latest + 1 == now {
                group.newest
            } else {
                0
            };
            group.newest = 0;
            group.latest = now;
        }
        group.newest |= 1 << (i % GROUP);
    }

    /// Every stamp back to 0.
    pub fn clear(&mut self) {
        self.slot.fill(0);
        self.group.fill(GroupStamps::default());
    }

    /// The same stamps, borrowed anew.
    #[inline]
    pub fn reborrow(&mut self) -> Stamps<'_> {
        Stamps {
            slot: self.slot,
            group: self.group,
        }
    }

    /// Slots `..at` and `at..`; `at` is a multiple of [`GROUP`] or the end (none splits into
    /// none).
    #[inline]
    pub fn split_at(self, at: usize) -> (Stamps<'a>, Stamps<'a>) {
        if self.is_empty() {
            return (Stamps::none(), Stamps::none());
        }
        debug_assert!(at % GROUP == 0 || at == self.slot.len());
        let (a, b) = self.slot.split_at_mut(at);
        let (ga, gb) = self.group.split_at_mut(at.div_ceil(GROUP));
        (Stamps::new(a, ga), Stamps::new(b, gb))
    }

    /// Whether any slot below `end` is stamped at least `since`, from the groups alone.
    #[inline]
    pub(super) fn any_since(&self, since: u32, end: usize) -> bool {
        let end = end.min(self.slot.len());
        self.group[..end.div_ceil(GROUP)]
            .iter()
            .any(|group| group.latest >= since)
    }

    /// Appends to `out` the slots below `end` stamped at least `since`, ascending, a group of
    /// [`GROUP`] slots at a time. After each group, `more` sees the slots the group added;
    /// when it says false, stops there and returns false.
    pub(super) fn collect_since(
        &self,
        since: u32,
        end: usize,
        out: &mut Vec<u32>,
        mut more: impl FnMut(&[u32]) -> bool,
    ) -> bool {
        let end = end.min(self.slot.len());
        for (g, group) in self.group[..end.div_ceil(GROUP)].iter().enumerate() {
            let added = out.len();
            let first = g * GROUP;
            let mut bits = match group.since(since) {
                Some(bits) => bits,
                None => {
                    let slots = &self.slot[first..(first + GROUP).min(end)];
                    let stamped = slots.iter().enumerate().filter(|(_, &s)| s >= since);
                    stamped.fold(0, |bits, (l, _)| bits | 1 << l)
                }
            };
            if end - first < GROUP {
                bits &= (1 << (end - first)) - 1;
            }
            while bits != 0 {
                out.push((first + bits.trailing_zeros() as usize) as u32);
                bits &= bits - 1;
            }
            if !more(&out[added..]) {
                return false;
            }
        }
        true
    }
}
