//! A pass that carries positions and velocities together, for a process that holds every slot
//! (see [`super::Exchange::alone`]).
//!
//! Between two substeps the solver moves the particles (`x += v h`, then the next substep's
//! `v += g h`), re-places every contact from the new positions and applies every remembered
//! impulse (the warm start). Apart, that is a pass over the particles, two over the plane
//! contacts and two over the pairs' rows. Together it is one pass, in which each even block's
//! task moves the slots its pairs reach just before it places them (so they are still in the
//! core's cache) and each row is read once. Every particle and every row sees the same
//! operations in the same order as in the separate passes (a particle is moved before any of
//! its contacts is placed, and its velocity takes gravity, then its plane impulses, then its
//! pairs' in their sweep order), so the bits are the same.

use super::spans::{split_run, Part, SpanWork};
use super::{pair_mut, Blocks, ParitySpans, PlaneContact, Split};
use crate::broadphase::Pair;
use crate::frontier::Stamps;
use crate::solver::{Row, RowRecord, RowsMut};
use crate::vector::Vector;

/// A rule for one particle: its slot, position and velocity.
pub(crate) trait ParticleRule<V>: Fn(usize, &mut V, &mut V) + Sync {}
impl<V, F: Fn(usize, &mut V, &mut V) + Sync> ParticleRule<V> for F {}

/// A rule for one plane contact: its row and its particle's position and velocity.
pub(crate) trait PlaneBothRule<V, R>: Fn(&mut R, &mut V, &mut V) + Sync {}
impl<V, R, F: Fn(&mut R, &mut V, &mut V) + Sync> PlaneBothRule<V, R> for F {}

/// A rule for one pair: its row, both positions (`i`'s, `j`'s) and both velocities.
pub(crate) trait PairBothRule<V>:
    Fn(&mut Row<V>, &mut RowRecord, (&mut V, &mut V), (&mut V, &mut V)) + Sync
{
}
impl<V, F: Fn(&mut Row<V>, &mut RowRecord, (&mut V, &mut V), (&mut V, &mut V)) + Sync>
    PairBothRule<V> for F
{
}

/// What [`Blocks::move_and_place`] does to each particle, plane contact and pair.
pub(crate) struct MoveRules<'r, P, Q, F> {
    /// On every particle, first.
    pub particle: &'r P,
    /// On every plane contact, after its particle.
    pub plane: &'r Q,
    /// On every pair, after both its particles and their plane contacts.
    pub pair: &'r F,
}

/// Positions and velocities of a run of slots.
type Both<'a, V> = (&'a mut [V], &'a mut [V]);

impl Blocks {
    /// One pass over every particle and contact: `rules.particle` on every slot, then
    /// `rules.plane` on every plane contact (`plane_contacts[k]` with row `plane_rows[k]`),
    /// then `rules.pair` on every pair in the order of [`Blocks::every_pair`] (the even blocks,
    /// the odd blocks, the leftovers). The particles and plane contacts go with the even
    /// blocks' pairs: each even block's task does its own and the next block's slots first,
    /// which are the slots its pairs reach. `position` and `velocity` hold every slot.
    #[allow(clippy::too_many_arguments)]
    pub fn move_and_place<V: Vector, R: Send>(
        &self,
        position: &mut [V],
        velocity: &mut [V],
        plane_contacts: &[PlaneContact],
        plane_rows: &mut [R],
        pairs: &[Pair],
        mut rows: RowsMut<V>,
        rules: &MoveRules<impl ParticleRule<V>, impl PlaneBothRule<V, R>, impl PairBothRule<V>>,
    ) {
        debug_assert_eq!(position.len(), velocity.len());
        for parity in 0..2 {
            let Some(run) = ParitySpans::of(self, parity, position.len()) else {
                continue;
            };
            let (s0, spans) = (run.slot(0), run.spans);
            let span_rows = SpanRows {
                run: Some(run),
                first: 0,
                pairs: rows
                    .reborrow()
                    .split_at_mut(run.pair_row(spans))
                    .0
                    .split_at_mut(run.pair_row(0))
                    .1,
                // (the even parity's spans hold every block: they take the plane contacts)
                planes: match parity {
                    0 => &mut plane_rows[..run.plane_row(spans)],
                    _ => &mut [],
                },
            };
            let work = MoveWork {
                blocks: self,
                parity,
                pairs,
                plane_contacts,
                rules,
            };
            // (a part's rows are found from its span's number: see `SpanRows`)
            split_run(
                self.parallel,
                0..spans,
                &|c| run.slot(c),
                &|c| c,
                (&mut position[s0..], &mut velocity[s0..]),
                Stamps::none(),
                span_rows,
                &work,
            );
        }
        for &k in &self.leftovers {
            let k = k as usize;
            let (i, j) = pairs[k];
            let (i, j) = (i as usize, j as usize);
            let x = pair_mut(position, i, j);
            let v = pair_mut(velocity, i, j);
            (rules.pair)(&mut rows.row[k], &mut rows.record[k], x, v);
        }
    }
}

/// The pair rows and (in the even parity) plane rows of a run of spans of one parity, from
/// span `first` on; split by span number, each kind of row at its own index.
struct SpanRows<'a, V, R> {
    run: Option<ParitySpans<'a>>,
    first: usize,
    pairs: RowsMut<'a, V>,
    planes: &'a mut [R],
}

impl<V, R> Default for SpanRows<'_, V, R> {
    fn default() -> Self {
        Self {
            run: None,
            first: 0,
            pairs: RowsMut::default(),
            planes: &mut [],
        }
    }
}

impl<V: Send, R: Send> Split for SpanRows<'_, V, R> {
    /// The spans before `first + at` and the rest.
    fn split_at_mut(self, at: usize) -> (Self, Self) {
        let Some(run) = self.run else {
            return (Self::default(), Self::default());
        };
        let (first, mid) = (self.first, self.first + at);
        let pair_cut = run.pair_row(mid) - run.pair_row(first);
        let plane_cut = match run.parity {
            0 => run.plane_row(mid) - run.plane_row(first),
            _ => 0,
        };
        let (pairs_a, pairs_b) = self.pairs.split_at_mut(pair_cut);
        let (planes_a, planes_b) = self.planes.split_at_mut(plane_cut);
        let part = |first, pairs, planes| Self {
            run: Some(run),
            first,
            pairs,
            planes,
        };
        (part(first, pairs_a, planes_a), part(mid, pairs_b, planes_b))
    }
}

/// [`Blocks::move_and_place`]'s work on the spans of one parity.
struct MoveWork<'w, P, Q, F> {
    blocks: &'w Blocks,
    parity: usize,
    pairs: &'w [Pair],
    plane_contacts: &'w [PlaneContact],
    rules: &'w MoveRules<'w, P, Q, F>,
}

impl<'a, V, R, P, Q, F> SpanWork<Both<'a, V>, SpanRows<'a, V, R>> for MoveWork<'_, P, Q, F>
where
    V: Vector,
    R: Send,
    P: ParticleRule<V>,
    Q: PlaneBothRule<V, R>,
    F: PairBothRule<V>,
{
    fn run(
        &self,
        a: Part<Both<'a, V>, SpanRows<'a, V, R>>,
        b: Option<Part<Both<'a, V>, SpanRows<'a, V, R>>>,
    ) -> u64 {
        let one = |part: Part<Both<'a, V>, SpanRows<'a, V, R>>| {
            let Part {
                span,
                slot_base,
                data: (x, v),
                rows,
                ..
            } = part;
            let block = self.parity + 2 * span;
            let MoveRules {
                particle,
                plane,
                pair,
            } = self.rules;
            if self.parity == 0 {
                for (s, (x, v)) in x.iter_mut().zip(v.iter_mut()).enumerate() {
                    particle(slot_base + s, x, v);
                }
                let first = self.blocks.plane_start[block];
                for (k, r) in rows.planes.iter_mut().enumerate() {
                    let i = self.plane_contacts[first + k].0 as usize - slot_base;
                    plane(r, &mut x[i], &mut v[i]);
                }
            }
            let (first, last) = (
                self.blocks.pair_start[block],
                self.blocks.pair_start[block + 1],
            );
            let RowsMut { row, record } = rows.pairs;
            for k in first..last {
                let (i, j) = self.pairs[k];
                let (i, j) = (i as usize - slot_base, j as usize - slot_base);
                // (pairs reaching past the span are leftovers)
                if j < x.len() {
                    let r = k - first;
                    pair(
                        &mut row[r],
                        &mut record[r],
                        pair_mut(x, i, j),
                        pair_mut(v, i, j),
                    );
                }
            }
        };
        one(a);
        if let Some(b) = b {
            one(b);
        }
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::schedule::spans::tests::contacts;
    use crate::schedule::{Alone, Change};
    use glam::DVec2;

    /// Positions, velocities, rows and plane rows after `run` on a fixed start.
    fn state(
        run: impl FnOnce(&Blocks, &mut [DVec2], &mut [DVec2], &mut [f64], &[Pair], RowsMut<DVec2>),
        n: usize,
        pairs: &[Pair],
        plane_contacts: &[PlaneContact],
        parallel: bool,
    ) -> Vec<u64> {
        let mut blocks = Blocks::default();
        blocks.plan(n, 1024, pairs, plane_contacts, parallel, 0);
        let mut x: Vec<DVec2> = (0..n)
            .map(|i| DVec2::new(i as f64, 0.5 * i as f64))
            .collect();
        let mut v: Vec<DVec2> = (0..n).map(|i| DVec2::new(1.0, -(i as f64) / 7.0)).collect();
        let (mut row, mut record) = (
            vec![Row::default(); pairs.len()],
            vec![RowRecord::default(); pairs.len()],
        );
        let mut plane_rows = vec![0.0; plane_contacts.len()];
        let rows = RowsMut {
            row: &mut row,
            record: &mut record,
        };
        run(&blocks, &mut x, &mut v, &mut plane_rows, pairs, rows);
        let values = x.iter().chain(&v).flat_map(|p| [p.x, p.y]);
        let rows = row.iter().flat_map(|r| [r.normal.x, r.normal.y, r.impulse]);
        values
            .chain(rows)
            .chain(plane_rows)
            .map(f64::to_bits)
            .collect()
    }

    /// The move: `x += v / 8`, then `v += (0, -1/3)`.
    fn particle(_: usize, x: &mut DVec2, v: &mut DVec2) {
        *x += *v * 0.125;
        *v += DVec2::new(0.0, -1.0 / 3.0);
    }

    /// A re-placing (the row from the positions), then a push from the row: a result that
    /// depends on the order of every step.
    fn pair_place(row: &mut Row<DVec2>, xi: DVec2, xj: DVec2) {
        row.normal = (xi - xj) * 1e-3 + row.normal * 0.5;
        row.impulse = row.normal.x;
    }
    fn pair_push(row: &Row<DVec2>, vi: &mut DVec2, vj: &mut DVec2) {
        *vi += row.normal * 0.3 + *vj * 0.01;
        *vj -= row.normal * 0.7 - *vi * 0.01;
    }

    #[test]
    fn one_pass_gives_the_bits_of_the_separate_passes() {
        // (20 blocks: a parity's ten spans go two to a task on the thread pool, as at 10^6)
        let n = 20 * 1024;
        let pairs = contacts(n, 2500);
        let plane_contacts: Vec<PlaneContact> = (0..n as u32).step_by(7).map(|i| (i, 0)).collect();
        let separate = |blocks: &Blocks,
                        x: &mut [DVec2],
                        v: &mut [DVec2],
                        plane_rows: &mut [f64],
                        pairs: &[Pair],
                        mut rows: RowsMut<DVec2>| {
            x.iter_mut()
                .zip(v.iter_mut())
                .for_each(|(x, v)| particle(0, x, v));
            let place = |r: &mut f64, x: &mut DVec2| {
                *r = x.x * 0.25 + x.y;
                Change::Nothing
            };
            blocks.every_plane(x, &plane_contacts, plane_rows, &place);
            let place =
                |row: &mut Row<DVec2>, _: &mut RowRecord, xi: &mut DVec2, xj: &mut DVec2| {
                    pair_place(row, *xi, *xj);
                    Change::Nothing
                };
            blocks.every_pair(&mut Alone, x, pairs, rows.reborrow(), &place);
            let push = |r: &mut f64, v: &mut DVec2| {
                *v += DVec2::splat(*r) * 1e-2;
                Change::Nothing
            };
            blocks.every_plane(v, &plane_contacts, plane_rows, &push);
            let push = |row: &mut Row<DVec2>, _: &mut RowRecord, vi: &mut DVec2, vj: &mut DVec2| {
                pair_push(row, vi, vj);
                Change::Nothing
            };
            blocks.every_pair(&mut Alone, v, pairs, rows, &push);
        };
        let together = |blocks: &Blocks,
                        x: &mut [DVec2],
                        v: &mut [DVec2],
                        plane_rows: &mut [f64],
                        pairs: &[Pair],
                        rows: RowsMut<DVec2>| {
            let plane = |r: &mut f64, x: &mut DVec2, v: &mut DVec2| {
                *r = x.x * 0.25 + x.y;
                *v += DVec2::splat(*r) * 1e-2;
            };
            let pair = |row: &mut Row<DVec2>,
                        _: &mut RowRecord,
                        (xi, xj): (&mut DVec2, &mut DVec2),
                        (vi, vj): (&mut DVec2, &mut DVec2)| {
                pair_place(row, *xi, *xj);
                pair_push(row, vi, vj);
            };
            let rules = MoveRules {
                particle: &particle,
                plane: &plane,
                pair: &pair,
            };
            blocks.move_and_place(x, v, &plane_contacts, plane_rows, pairs, rows, &rules);
        };
        assert!(pairs
            .iter()
            .any(|&(i, j)| j as usize >= (i as usize / 1024 + 2) * 1024));
        let expected = state(separate, n, &pairs, &plane_contacts, false);
        for parallel in [false, true] {
            let got = state(together, n, &pairs, &plane_contacts, parallel);
            assert!(got == expected, "parallel {parallel}");
        }
    }
}
