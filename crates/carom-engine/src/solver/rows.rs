//! One row of solver data per contact candidate (pairs and plane contacts), and the views of a
//! step's contacts and moving particles that the phases work on.

use super::settings::*;
use crate::broadphase::{keep_headroom, Pair};
use crate::frontier::Stamps;
use crate::periodic::{apply_shift, Wrap};
use crate::plane::Plane;
use crate::response::{contact_normal, is_overlapping};
use crate::schedule::{Blocks, PlaneContact, Visit};
use crate::vector::Vector;
use rayon::prelude::*;

/// The mass a particle of mass `mass` has in this step's rows: infinite when it `sleeps`,
/// so its awake neighbours meet it as a fixed obstacle and nothing they do moves it.
#[inline]
pub(crate) fn moving_mass(mass: f64, sleeps: bool) -> f64 {
    if sleeps {
        f64::INFINITY
    } else {
        mass
    }
}

/// One contact candidate's solver data, at the same index as its pair: the part every
/// velocity sweep reads. The rest of it, which the sweeps never touch, is its
/// [`RowRecord`], at the same index of its own array.
///
/// Why two parts: a full pass over a step's rows costs what reading them from memory costs
/// (at 10^6 discs, half a million rows, any pass over 152-byte rows took 5 ms on 2 cores, the
/// speed of memory there), and a step makes some twenty such passes, most of them sweeps of
/// the velocity phase. Those read this part alone: 80 bytes in 2D, 88 in 3D. (The effective
/// mass could be worked out from the inverse masses, the same bits, for 8 bytes less; the
/// division cost more than the bytes: the awake lecture pile 1.05-1.07x, 10^6 discs no faster.)
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Row<V> {
    /// Unit normal from `j` to `i` at the start of the velocity phase.
    pub normal: V,
    /// `(1 / m_i, 1 / m_j)` (0 for a sleeping particle).
    pub inverse_mass: [f64; 2],
    /// `1 / (1 / m_i + 1 / m_j)`: the impulse that changes the relative normal speed by one.
    pub effective_mass: f64,
    /// Accumulated impulse this step, >= 0 (mass x length / time).
    pub impulse: f64,
    /// For an impact, the speed its restitution pass aims to separate at (`k` times its
    /// approach speed at the start of the step); 0 for a resting contact.
    pub bounce: f64,
    /// How fast a resting contact may still approach this step: the gap between the surfaces
    /// over `dt` (0 when they overlap, infinite for coincident centres). A pair a hair apart
    /// stays in the solver as a *speculative* contact (as in Box2D), so the position phase
    /// opening a contact by a rounding error does not drop a pile's support for a step. Once
    /// the restitution pass has `kicked` an impact (which may not approach at all then), the
    /// most impulse it takes there instead (see [`kick_ceiling`](super::rules::kick_ceiling)).
    pub allowance: f64,
    /// The normal impulse `j` gave `i` this step, summed over every application (mass x
    /// length / time; positive pushes apart): the collisional virial's `J_ij` (see
    /// [`crate::observe`]).
    pub delivered: f64,
    /// True once the contact took an impulse this step.
    pub met: bool,
    /// True once the lecture's response answered an approach of this pair this step.
    pub impact: bool,
    /// True when the step found this pair an impact (approaching at least at the resting
    /// speed, not resting last step), whatever its `k`: at `k = 0` its `bounce` is 0, and it
    /// still counts as a collision once it meets (see [`Row::collided`]).
    pub struck: bool,
    /// True once the restitution pass has set a met impact's ceiling (at its first visit).
    pub kicked: bool,
    /// The lecture's detection at the start of the velocity phase, with distinct centres (a
    /// pair with coincident centres has no direction to respond along).
    pub touching: bool,
}

/// The part of a contact's row that the velocity sweeps never read (see [`Row`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct RowRecord {
    /// `(m_i, m_j)`, > 0; infinite for a sleeping particle (see [`moving_mass`]).
    pub mass: [f64; 2],
    /// `(r_i, r_j)`, > 0.
    pub radius: [f64; 2],
    /// The impulse after the relax pass: what the next step starts from.
    pub kept: f64,
    /// Overlap at the end of the step as a fraction of `min_radius` (0 when apart).
    pub overlap: f64,
    /// `|x_i - x_j|` where the contact was last placed (length), once the velocity phase is
    /// over (the re-placings between substeps do not write it: see `velocity::place`).
    pub distance: f64,
    /// What `j` is seen through across periodic seams: every rule that reads positions uses
    /// `x_j + shift` (see [`RowRecord::image`] and [`crate::periodic`]). Whole periods per
    /// axis, fixed when the pair is found; none without periodic axes (and then `x_j` is used
    /// as it is, bit for bit). Kept as 3 bytes, not a vector: a record is 64 bytes in 2D and
    /// 3D instead of 72 and 80 (at 10^6 falling discs, 3.7 bytes a particle of peak memory).
    pub wrap: Wrap,
}

impl<V: Vector> Row<V> {
    /// The row of particles at `x`, radius `r` and mass `m`, for a step of `dt`.
    #[inline]
    pub fn new(xi: V, xj: V, ri: f64, rj: f64, mi: f64, mj: f64, dt: f64) -> (Self, RowRecord) {
        Self::across(xi, xj, V::ZERO, ri, rj, mi, mj, dt)
    }

    /// [`Row::new`] for a pair seen through `x_j + shift`, a [`crate::periodic::Periodic::shift`]
    /// (see [`RowRecord::wrap`]).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn across(
        xi: V,
        xj: V,
        shift: V,
        ri: f64,
        rj: f64,
        mi: f64,
        mj: f64,
        dt: f64,
    ) -> (Self, RowRecord) {
        let mut row = Self {
            inverse_mass: [1.0 / mi, 1.0 / mj],
            effective_mass: 1.0 / (1.0 / mi + 1.0 / mj),
            ..Self::default()
        };
        let mut record = RowRecord {
            mass: [mi, mj],
            radius: [ri, rj],
            wrap: Wrap::of(shift),
            ..RowRecord::default()
        };
        if let Some(distance) = row.place(&record, xi, apply_shift(xj, shift), dt) {
            record.distance = distance;
        }
        (row, record)
    }

    /// Normal, detection and allowance for particles at `xi` and `xj` (`j` as this row sees
    /// it: [`RowRecord::image`]) over a (sub)step `dt`; returns the distance, or `None` for a
    /// row left out for the step (infinite allowance), which stays out. (The record is only
    /// read: a re-placing that does not keep the distance leaves the record's memory clean.)
    #[inline]
    #[must_use = "the distance is the caller's to keep"]
    pub fn place(&mut self, record: &RowRecord, xi: V, xj: V, dt: f64) -> Option<f64> {
        if self.allowance == f64::INFINITY {
            return None;
        }
        let (normal, distance) = contact_normal(xi, xj);
        let [ri, rj] = record.radius;
        self.normal = normal;
        self.touching = distance > 0.0 && is_overlapping(xi, xj, ri, rj);
        // Within the slop of touching, a contact may not close in: the position phase opens
        // and closes such hairline gaps every step, and letting them turn into approach speeds
        // would keep a pile stirring.
        self.allowance = if distance > 0.0 {
            (distance - (ri + rj) - SLOP_FRACTION * ri.min(rj)).max(0.0) / dt
        } else {
            f64::INFINITY
        };
        Some(distance)
    }

    /// True when this pair counts as a collision this step: it answered an approach with the
    /// lecture's response, or it was an impact (see [`integrate`](super::velocity::integrate)) that met.
    #[inline]
    pub fn collided(&self) -> bool {
        self.impact || (self.struck && self.met)
    }

    /// True when this pair pushed this step: the lecture's response answered an approach, the
    /// sweeps gave it an impulse, or it holds one (a remembered impulse the sweeps left as it
    /// was).
    #[inline]
    pub fn pushed(&self) -> bool {
        self.impact || self.met || self.impulse > 0.0
    }
}

impl RowRecord {
    /// Where this row sees `j` from `i`: `x_j + shift` in a world of periods `period` (see
    /// [`crate::periodic::Periodic::periods`]), or `x_j` itself when there is no shift.
    #[inline]
    pub fn image<V: Vector>(&self, xj: V, period: &[f64; 3]) -> V {
        apply_shift(xj, self.wrap.shift(period))
    }

    /// `r_i + r_j`.
    #[inline]
    pub fn reach(&self) -> f64 {
        self.radius[0] + self.radius[1]
    }

    /// The overlap where the row was placed last (see [`RowRecord::distance`]), as a fraction
    /// of the smaller radius; 0 when apart.
    pub fn placed_overlap(&self) -> f64 {
        ((self.reach() - self.distance) / self.min_radius()).max(0.0)
    }

    /// `min(r_i, r_j)`.
    #[inline]
    pub fn min_radius(&self) -> f64 {
        self.radius[0].min(self.radius[1])
    }
    /// `(1 / m_i, 1 / m_j)`: the bits of [`Row::inverse_mass`], worked out here so that the
    /// position phase, which reads nothing else of the [`Row`], need not bring it in.
    #[inline]
    pub fn inverse_mass(&self) -> [f64; 2] {
        [1.0 / self.mass[0], 1.0 / self.mass[1]]
    }

    /// Whether particle `side` (0 for `i`, 1 for `j`) sleeps this step (infinite mass, see
    /// [`moving_mass`]).
    #[inline]
    pub fn sleeps(&self, side: usize) -> bool {
        self.mass[side] == f64::INFINITY
    }
}

/// A step's rows: each contact's [`Row`] and [`RowRecord`], at its pair's index in both.
#[derive(Debug, Default)]
pub(crate) struct Rows<V> {
    /// What the velocity sweeps read.
    pub row: Vec<Row<V>>,
    /// The rest.
    pub record: Vec<RowRecord>,
}

impl<V: Vector> Rows<V> {
    /// Room for `rows` rows, reserved and not yet touched (so not yet in memory).
    ///
    /// Why reserve: two arrays that grow by reallocation, each under glibc's largest
    /// threshold for giving an allocation its own mapping (32 MiB), can be copied within the
    /// heap as they grow, and the old copies stay resident: at 10^6 discs in a gas, 25 bytes a
    /// particle of peak memory. Reserved up front at the world's size, they start in mappings
    /// of their own, which grow without copies.
    pub fn with_capacity(rows: usize) -> Self {
        Rows {
            row: Vec::with_capacity(rows),
            record: Vec::with_capacity(rows),
        }
    }

    /// No rows.
    pub fn clear(&mut self) {
        self.row.clear();
        self.record.clear();
    }

    /// How many rows.
    pub fn len(&self) -> usize {
        self.row.len()
    }

    /// Appends one row.
    pub fn push(&mut self, (row, record): (Row<V>, RowRecord)) {
        self.row.push(row);
        self.record.push(record);
    }

    /// Both parts, borrowed for a phase.
    pub fn as_mut(&mut self) -> RowsMut<'_, V> {
        RowsMut {
            row: &mut self.row,
            record: &mut self.record,
        }
    }

    /// See [`crate::broadphase::keep_headroom`].
    pub fn keep_headroom(&mut self) {
        crate::broadphase::keep_headroom(&mut self.row);
        crate::broadphase::keep_headroom(&mut self.record);
    }
}

/// A run of rows, both parts (the same length), borrowed.
#[derive(Debug)]
pub(crate) struct RowsMut<'a, V> {
    /// What the velocity sweeps read.
    pub row: &'a mut [Row<V>],
    /// The rest.
    pub record: &'a mut [RowRecord],
}

impl<V> Default for RowsMut<'_, V> {
    fn default() -> Self {
        RowsMut {
            row: &mut [],
            record: &mut [],
        }
    }
}

impl<'a, V> RowsMut<'a, V> {
    /// The same rows, borrowed anew.
    #[inline]
    pub fn reborrow(&mut self) -> RowsMut<'_, V> {
        RowsMut {
            row: self.row,
            record: self.record,
        }
    }
}

impl<V: Vector> RowsMut<'_, V> {
    /// Marks every row's impulse as the one the relax pass kept ([`RowRecord::kept`]), on the
    /// thread pool when `parallel` (each row's copy is its own: the same result either way).
    /// (On 10^6 falling discs: 4.5-5.7 ms a step on 2 threads, 6.9-8.5 ms serial.)
    pub fn keep_impulses(&mut self, parallel: bool) {
        let keep = |(rows, records): (&[Row<V>], &mut [RowRecord])| {
            for (row, record) in rows.iter().zip(records) {
                record.kept = row.impulse;
            }
        };
        if parallel {
            (self.row.par_chunks(ROW_CHUNK))
                .zip(self.record.par_chunks_mut(ROW_CHUNK))
                .for_each(keep);
        } else {
            keep((self.row, self.record));
        }
    }
}

impl<'a, V: Send> crate::schedule::Split for RowsMut<'a, V> {
    #[inline]
    fn split_at_mut(self, at: usize) -> (Self, Self) {
        let (a, b) = self.row.split_at_mut(at);
        let (c, d) = self.record.split_at_mut(at);
        (RowsMut { row: a, record: c }, RowsMut { row: b, record: d })
    }
}

/// What a step's rows add up to (see [`tally`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct RowTally {
    /// Rows whose pair overlapped at the start of the velocity phase.
    pub touching: u64,
    /// Particle-particle collisions (see [`Row::collided`]).
    pub collisions: u64,
    /// Rows that pushed this step (see [`Row::pushed`]).
    pub pushing: u64,
    /// The collisional virial `sum J_ij . r_ij` (0 unless asked for).
    pub virial: f64,
}

/// Adds up `rows` (see [`RowTally`]): the counts on the thread pool when `parallel` (a count
/// is the same in any order), the virial only `with_virial` (an observed world's: see
/// [`crate::observe`]), in row order, so the same rows give the same bits. (The virial reads
/// every record as well as every row: one pass over both on one thread took most of the
/// 5 ms a step of bookkeeping at 10^6 falling discs.)
pub(crate) fn tally<V: Vector>(rows: &Rows<V>, parallel: bool, with_virial: bool) -> RowTally {
    let count = |row: &Row<V>| [row.touching, row.collided(), row.pushed()].map(u64::from);
    let add = |a: [u64; 3], b: [u64; 3]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
    let [touching, collisions, pushing] = if parallel {
        rows.row.par_iter().map(count).reduce(|| [0; 3], add)
    } else {
        rows.row.iter().map(count).fold([0; 3], add)
    };
    let virial = if with_virial {
        let both = rows.row.iter().zip(&rows.record);
        both.fold(0.0, |sum, (row, record)| {
            sum + row.delivered * record.distance
        })
    } else {
        0.0
    };
    RowTally {
        touching,
        collisions,
        pushing,
        virial,
    }
}

/// One particle-plane candidate's solver data.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct PlaneRow<V> {
    /// The plane's unit normal.
    pub normal: V,
    /// The plane's restitution.
    pub restitution: f64,
    /// The particle's radius.
    pub radius: f64,
    /// Accumulated impulse per unit mass this step, >= 0 (length / time).
    pub impulse: f64,
    /// The impulse after the relax pass (see [`RowRecord::kept`]).
    pub kept: f64,
    /// See [`Row::bounce`].
    pub bounce: f64,
    /// See [`Row::met`].
    pub met: bool,
    /// Index of the plane.
    pub plane: u32,
    /// The lecture's plane detection at the start of the velocity phase, with its threshold
    /// ("in practice we take a threshold distance"): `(x - p) . n < r + SLOP_FRACTION r`, since
    /// the position phase leaves a particle exactly touching its plane.
    pub touching: bool,
    /// How fast a resting contact may still approach the plane this step (see
    /// [`Row::allowance`]).
    pub allowance: f64,
    /// Where the particle's centre was when the row was made (the start of the step): when
    /// planes bounce in the move (see [`bounce_in_move`](super::bounces::bounce_in_move)), its path this step starts here.
    pub start: V,
    /// How far the position phase pushed the particle out of the plane this step (see
    /// [`keep_energy`](super::bounces::keep_energy)).
    pub lift: f64,
}

impl<V: Vector> PlaneRow<V> {
    /// The row of a particle at `x` with radius `r` against `plane` (index `index`), for a
    /// step of `dt`.
    #[inline]
    pub fn new(plane: &Plane<V>, index: u32, x: V, radius: f64, dt: f64) -> Self {
        let mut row = Self {
            normal: plane.normal(),
            restitution: plane.restitution(),
            radius,
            impulse: 0.0,
            kept: 0.0,
            bounce: 0.0,
            met: false,
            plane: index,
            touching: false,
            allowance: 0.0,
            start: x,
            lift: 0.0,
        };
        row.place(plane, x, dt);
        row
    }

    /// Detection and allowance for the particle at `x` over a (sub)step `dt` (see
    /// [`Row::place`]).
    #[inline]
    pub fn place(&mut self, plane: &Plane<V>, x: V, dt: f64) {
        if self.allowance == f64::INFINITY {
            return;
        }
        let (distance, r) = (plane.signed_distance(x), self.radius);
        self.touching = distance < r + SLOP_FRACTION * r;
        self.allowance = (distance - r - SLOP_FRACTION * r).max(0.0) / dt;
    }
}

/// Fills `rows` (one per pair) from `row(pair)`, in parallel when asked; returns the deepest
/// overlap where they were placed (see [`RowRecord::placed_overlap`]).
pub(crate) fn prepare_rows<V: Vector>(
    rows: &mut Rows<V>,
    pairs: &[Pair],
    parallel: bool,
    row: impl Fn(Pair) -> (Row<V>, RowRecord) + Sync,
) -> f64 {
    rows.row.resize(pairs.len(), Row::default());
    rows.record.resize(pairs.len(), RowRecord::default());
    rows.keep_headroom();
    // (the deepest overlap in the same pass: a pass of its own would read the records again)
    let fill = |(out, keys): (RowsMut<V>, &[Pair])| {
        let mut deepest = 0.0f64;
        for ((r, c), &p) in out.row.iter_mut().zip(out.record).zip(keys) {
            (*r, *c) = row(p);
            deepest = deepest.max(c.placed_overlap());
        }
        deepest
    };
    let chunks = |(row, record)| RowsMut { row, record };
    if parallel {
        (rows.row.par_chunks_mut(ROW_CHUNK))
            .zip(rows.record.par_chunks_mut(ROW_CHUNK))
            .map(chunks)
            .zip(pairs.par_chunks(ROW_CHUNK))
            .map(fill)
            .reduce(|| 0.0, f64::max)
    } else {
        fill((rows.as_mut(), pairs))
    }
}

/// The deepest of `rows`' overlaps where they were placed (see [`RowRecord::placed_overlap`]),
/// on this thread (a rank's rows; [`prepare_rows`] finds a world's as it places them).
pub(crate) fn deepest_placed<V>(rows: &Rows<V>) -> f64 {
    (rows.record.iter())
        .map(RowRecord::placed_overlap)
        .fold(0.0, f64::max)
}

/// Replaces `rows` with one [`PlaneRow`] per plane contact `(slot, plane)`, the particles at
/// `position` with radius `radius`, for a step of `dt`.
pub(crate) fn prepare_plane_rows<V: Vector>(
    rows: &mut Vec<PlaneRow<V>>,
    contacts: &[PlaneContact],
    planes: &[Plane<V>],
    position: &[V],
    radius: &[f64],
    dt: f64,
) {
    rows.clear();
    rows.reserve(contacts.len());
    keep_headroom(rows);
    rows.extend(contacts.iter().map(|&(slot, plane)| {
        let slot = slot as usize;
        PlaneRow::new(
            &planes[plane as usize],
            plane,
            position[slot],
            radius[slot],
            dt,
        )
    }));
}

/// This step's contacts, planned into blocks, with their rows.
pub(crate) struct Contacts<'a, V> {
    pub pairs: &'a [Pair],
    pub rows: RowsMut<'a, V>,
    pub plane_contacts: &'a [PlaneContact],
    pub plane_rows: &'a mut [PlaneRow<V>],
    pub planes: &'a [Plane<V>],
    /// The periods of the world's periodic axes, 0 on the others (see [`RowRecord::image`]).
    pub period: [f64; 3],
    pub blocks: &'a Blocks,
    pub work: WorkList<'a>,
}

/// The per-particle stamps of the work lists (see [`crate::schedule`]) and the sweep clock
/// that numbers them. Without stamps (an empty slice) every sweep visits every contact, with
/// the same result.
pub(crate) struct WorkList<'a> {
    /// One per slot of the data the sweeps run on, or none.
    pub stamps: Stamps<'a>,
    /// The number of the last sweep (kept between steps; stamps below the current pass's
    /// first sweep mean nothing).
    pub clock: &'a mut u32,
}

impl WorkList<'_> {
    /// The visit of a new sweep: every contact on a pass's first sweep (`previous` = None),
    /// afterwards the contacts with a particle changed since `previous` began.
    pub(super) fn next(&mut self, previous: Option<Visit>) -> Visit {
        if self.stamps.is_empty() {
            return Visit::ALL;
        }
        if previous.is_none() && *self.clock > u32::MAX / 2 {
            self.stamps.clear();
            *self.clock = 0;
        }
        *self.clock += 1;
        Visit {
            since: previous.map_or(0, |p| p.now),
            now: *self.clock,
        }
    }
}

/// The particles a step moves: `position` and `velocity` cover the slots the blocks cover, of
/// which the first `own` belong to this process (the rest are borrowed).
pub(crate) struct Moving<'a, V> {
    pub position: &'a mut [V],
    pub velocity: &'a mut [V],
    pub own: usize,
    /// Per own slot, whether it sleeps this step (see [`crate::sleep`]); empty when none does.
    pub asleep: &'a [bool],
}
