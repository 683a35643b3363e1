//! Contact memory: each resting contact's accumulated impulse, carried from one step to the
//! next so that a pile's support does not have to be rebuilt from nothing every step.
//!
//! The lecture's pairwise response has no memory: under gravity, every step the weight of a
//! pile must travel from the floor up through every row by Gauss-Seidel sweeps, which a few
//! dozen sweeps cannot do for a pile fifty rows deep. Box2D's sequential-impulse solver keeps
//! each contact's accumulated normal impulse and starts the next step from it ("warm
//! starting"); a resting pile then needs one sweep to confirm its support.
//!
//! Only *resting* contacts (approaching slower than the resting speed, restitution below 1)
//! accumulate an impulse here; impacts take the lecture's formula and leave no memory, so an
//! isolated collision is exactly the lecture's and `k = 1` keeps energy exactly.
//!
//! Keys are storage slots while the slots stay fixed (between two spatial sorts), so a lookup
//! is a merge of two sorted lists; at a sort the keys are mapped through the new order. The
//! public form, [`ContactImpulses`], is by particle id and survives checkpoints.

use crate::broadphase::Pair;

/// The accumulated impulses of a world's resting contacts, by particle id: what a checkpoint
/// stores so that a resumed run continues bit for bit.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContactImpulses {
    /// `(a, b, impulse)` for particle pairs, `a < b`, sorted; impulse > 0 (mass x length /
    /// time).
    pub pairs: Vec<(u32, u32, f64)>,
    /// `(particle, plane index, impulse per unit mass)` for particles on planes, sorted;
    /// value > 0 (length / time).
    pub planes: Vec<(u32, u32, f64)>,
    /// How long (time units, >= 0) each particle has rested (see [`crate::sleep`]), by id;
    /// empty when none has.
    pub rest: Vec<f64>,
}

impl ContactImpulses {
    /// True when nothing is remembered.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty() && self.planes.is_empty() && self.rest.iter().all(|&t| t == 0.0)
    }
}

/// The memory a world keeps between steps, keyed by storage slot.
#[derive(Clone, Debug, Default)]
pub(crate) struct Memory {
    /// `(i, j, impulse)`, `i < j` slots, sorted.
    pub pairs: Vec<(u32, u32, f64)>,
    /// `(slot, plane, impulse per unit mass)`, sorted.
    pub planes: Vec<(u32, u32, f64)>,
    /// Reused space for [`Memory::store_keeping_asleep`].
    pub scratch: Vec<(u32, u32, f64)>,
}

impl Memory {
    /// Forgets everything (a changed parameter makes old impulses meaningless).
    pub fn clear(&mut self) {
        self.pairs.clear();
        self.planes.clear();
    }

    /// The remembered impulse of every contact in `keys` (sorted, as `(i, j)`), written
    /// through `set(index into keys, impulse)`; contacts not remembered get nothing.
    pub fn recall(remembered: &[(u32, u32, f64)], keys: &[Pair], mut set: impl FnMut(usize, f64)) {
        let mut m = 0;
        for (k, key) in keys.iter().enumerate() {
            while m < remembered.len() && (remembered[m].0, remembered[m].1) < *key {
                m += 1;
            }
            match remembered.get(m) {
                Some(&(i, j, impulse)) if (i, j) == *key => set(k, impulse),
                _ => {}
            }
        }
    }

    /// Gives every row of this step's contacts (`pairs`, `plane_contacts`, sorted) the impulse
    /// remembered for it, if any.
    pub fn warm_rows<V>(
        &self,
        pairs: &[Pair],
        rows: &mut [crate::solver::Row<V>],
        plane_contacts: &[Pair],
        plane_rows: &mut [crate::solver::PlaneRow<V>],
    ) {
        Self::recall(&self.pairs, pairs, |k, impulse| rows[k].impulse = impulse);
        Self::recall(&self.planes, plane_contacts, |k, impulse| {
            plane_rows[k].impulse = impulse
        });
    }

    /// Replaces `into` with the contacts of `keys` (sorted) whose impulse (from `impulse(k)`)
    /// is above zero.
    pub fn store(into: &mut Vec<(u32, u32, f64)>, keys: &[Pair], impulse: impl Fn(usize) -> f64) {
        into.clear();
        for (k, &(i, j)) in keys.iter().enumerate() {
            let value = impulse(k);
            if value > 0.0 {
                into.push((i, j, value));
            }
        }
    }

    /// [`Memory::store`], keeping the entries of `into` that `sleeps` (the contacts of a
    /// sleeping particle with another one are not in `keys`, and keep their impulses for when
    /// they wake) unless `keys` has them too (a sleeper's contact with an awake particle is
    /// solved, and remembers the new impulse); `scratch` is reused space.
    pub fn store_keeping_asleep(
        into: &mut Vec<(u32, u32, f64)>,
        scratch: &mut Vec<(u32, u32, f64)>,
        keys: &[Pair],
        impulse: impl Fn(usize) -> f64,
        sleeps: impl Fn(&(u32, u32, f64)) -> bool,
    ) {
        scratch.clear();
        scratch.extend(into.iter().copied().filter(|e| sleeps(e)));
        if scratch.is_empty() {
            return Self::store(into, keys, impulse);
        }
        into.clear();
        let mut kept = scratch.iter().copied().peekable();
        for (k, &(i, j)) in keys.iter().enumerate() {
            while let Some(e) = kept.next_if(|e| (e.0, e.1) < (i, j)) {
                into.push(e);
            }
            // (a contact solved this step, its sleeper fixed, remembers what it took)
            kept.next_if(|e| (e.0, e.1) == (i, j));
            let value = impulse(k);
            if value > 0.0 {
                into.push((i, j, value));
            }
        }
        into.extend(kept);
    }

    /// Renames slots after a spatial sort: `new_slot_of[slot]` is where what was in `slot`
    /// is now.
    pub fn remap(&mut self, new_slot_of: &[u32]) {
        let moved = |s: u32| new_slot_of[s as usize];
        for entry in &mut self.pairs {
            let (a, b) = (moved(entry.0), moved(entry.1));
            (entry.0, entry.1) = (a.min(b), a.max(b));
        }
        for entry in &mut self.planes {
            entry.0 = moved(entry.0);
        }
        self.sort();
    }

    fn sort(&mut self) {
        let key = |e: &(u32, u32, f64)| (e.0, e.1);
        self.pairs.sort_unstable_by_key(key);
        self.planes.sort_unstable_by_key(key);
    }

    /// The public form, by id.
    pub fn by_id(&self, ids: &[u32]) -> ContactImpulses {
        let mut out = ContactImpulses {
            rest: Vec::new(),
            pairs: self
                .pairs
                .iter()
                .map(|&(i, j, v)| {
                    let (a, b) = (ids[i as usize], ids[j as usize]);
                    (a.min(b), a.max(b), v)
                })
                .collect(),
            planes: self
                .planes
                .iter()
                .map(|&(s, p, v)| (ids[s as usize], p, v))
                .collect(),
        };
        let key = |e: &(u32, u32, f64)| (e.0, e.1);
        out.pairs.sort_unstable_by_key(key);
        out.planes.sort_unstable_by_key(key);
        out
    }

    /// From the public form, for particles stored at `slots[id]`. Entries naming a particle
    /// that does not exist are dropped by the caller's validation, not here.
    pub fn from_ids(impulses: &ContactImpulses, slots: &[u32]) -> Self {
        let slot = |id: u32| slots[id as usize];
        let mut memory = Memory {
            pairs: impulses
                .pairs
                .iter()
                .map(|&(a, b, v)| {
                    let (i, j) = (slot(a), slot(b));
                    (i.min(j), i.max(j), v)
                })
                .collect(),
            planes: impulses
                .planes
                .iter()
                .map(|&(a, p, v)| (slot(a), p, v))
                .collect(),
            scratch: Vec::new(),
        };
        memory.sort();
        memory
    }
}

/// Whether `impulses` can belong to a world of `particles` particles and `planes` planes:
/// ids and plane indices in range, pairs of two different particles, every value finite and
/// above zero, no key twice; rest times finite and >= 0, none or one per particle.
pub(crate) fn is_valid(impulses: &ContactImpulses, particles: usize, planes: usize) -> bool {
    let good = |v: f64| v.is_finite() && v > 0.0;
    let pairs_ok = impulses
        .pairs
        .iter()
        .all(|&(a, b, v)| a < b && (b as usize) < particles && good(v))
        && impulses
            .pairs
            .windows(2)
            .all(|w| (w[0].0, w[0].1) < (w[1].0, w[1].1));
    let planes_ok = impulses
        .planes
        .iter()
        .all(|&(a, p, v)| (a as usize) < particles && (p as usize) < planes && good(v))
        && impulses
            .planes
            .windows(2)
            .all(|w| (w[0].0, w[0].1) < (w[1].0, w[1].1));
    let rest_ok = (impulses.rest.is_empty() || impulses.rest.len() == particles)
        && impulses.rest.iter().all(|t| t.is_finite() && *t >= 0.0);
    pairs_ok && planes_ok && rest_ok
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recall_finds_only_remembered_keys() {
        let remembered = [(0, 1, 2.0), (0, 3, 4.0), (2, 5, 6.0)];
        let keys = [(0, 1), (0, 2), (2, 5), (3, 4)];
        let mut got = vec![0.0; keys.len()];
        Memory::recall(&remembered, &keys, |k, v| got[k] = v);
        assert_eq!(got, vec![2.0, 0.0, 6.0, 0.0]);
    }

    #[test]
    fn remap_follows_ids_and_keeps_pairs_ordered() {
        let mut m = Memory {
            pairs: vec![(0, 1, 1.0), (1, 2, 2.0)],
            planes: vec![(2, 0, 3.0)],
            ..Default::default()
        };
        // what was in slot 0 is now in slot 2, slot 1's in 0, slot 2's in 1
        m.remap(&[2, 0, 1]);
        assert_eq!(m.pairs, vec![(0, 1, 2.0), (0, 2, 1.0)]);
        assert_eq!(m.planes, vec![(1, 0, 3.0)]);
    }

    #[test]
    fn by_id_and_back_round_trip() {
        let m = Memory {
            pairs: vec![(0, 2, 1.5)],
            planes: vec![(1, 3, 0.5)],
            ..Default::default()
        };
        let ids = [2, 0, 1];
        let public = m.by_id(&ids);
        assert_eq!(public.pairs, vec![(1, 2, 1.5)]);
        assert!(is_valid(&public, 3, 4));
        let slots = [1, 2, 0];
        let back = Memory::from_ids(&public, &slots);
        assert_eq!(back.pairs, m.pairs);
        assert_eq!(back.planes, m.planes);
    }

    #[test]
    fn storing_keeps_the_sleeping_contacts() {
        let mut into = vec![(0, 1, 1.0), (2, 3, 2.0), (4, 5, 3.0)];
        let mut scratch = Vec::new();
        // slots 0, 1, 4, 5 sleep; this step's (awake) contacts are (2, 3) and (3, 6)
        let keys = [(2, 3), (3, 6)];
        let values = [0.5, 0.0];
        Memory::store_keeping_asleep(
            &mut into,
            &mut scratch,
            &keys,
            |k| values[k],
            |e| [0, 1, 4, 5].contains(&e.0),
        );
        assert_eq!(into, vec![(0, 1, 1.0), (2, 3, 0.5), (4, 5, 3.0)]);
    }

    #[test]
    fn invalid_impulses_are_refused() {
        let bad = [
            vec![(1, 1, 1.0)],
            vec![(0, 5, 1.0)],
            vec![(0, 1, -1.0)],
            vec![(0, 1, f64::NAN)],
            vec![(0, 2, 1.0), (0, 1, 1.0)],
        ];
        for pairs in bad {
            let c = ContactImpulses {
                pairs,
                ..Default::default()
            };
            assert!(!is_valid(&c, 3, 1));
        }
    }
}
