//! Where a step's wall-clock time goes, phase by phase (for `carom bench`'s breakdown).
//!
//! The clock is read a handful of times a step (about 25 ns a read); it never changes a result,
//! so two runs give the same bits whether anyone looks at the times or not.

use std::time::{Duration, Instant};

/// Wall-clock time spent in each phase of [`crate::World::step`], summed over the steps since
/// the world was built or [`crate::World::reset_phase_times`] was called.
///
/// The phases, in step order (see [`crate::step`]): `sort` (reordering along space every few
/// steps), `bin` (laying the grid's or the hash's cells out over the particles and the counting
/// sort that fills them: issue 14's "bin"; zero for brute force), `search` (the rest of finding
/// the contact candidates: each particle's reach, the pair search and its raise, plane
/// candidates, who sleeps, planning the blocks; `bin` and `search` together are the broad
/// phase), `rows` (the lecture's detection on every candidate and the warm start from
/// remembered impulses), `velocity` (the velocity phase's sweeps: the lecture's response,
/// resting impulses, restitution), `motion` (gravity, the move `x += v dt` and re-placing the
/// rows between substeps), `position` (the position phase, planes included: plane rules run
/// inside the sweeps, so they have no figure of their own) and `bookkeeping` (remembering
/// impulses, sleep, the step's tallies).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PhaseTimes {
    /// Steps timed.
    pub steps: u64,
    /// Reordering along space (and, split over processes, migration).
    pub sort: Duration,
    /// Binning the particles into the broad phase's cells.
    pub bin: Duration,
    /// The rest of finding the contact candidates.
    pub search: Duration,
    /// Building and warm-starting the contact rows.
    pub rows: Duration,
    /// The velocity phase's sweeps.
    pub velocity: Duration,
    /// Gravity and the moves.
    pub motion: Duration,
    /// The position phase.
    pub position: Duration,
    /// Remembering impulses, sleep and tallies.
    pub bookkeeping: Duration,
}

impl PhaseTimes {
    /// The sum of every phase.
    pub fn total(&self) -> Duration {
        self.phases().iter().map(|&(_, time)| time).sum()
    }

    /// The broad phase: `bin` and `search`.
    pub fn broad_phase(&self) -> Duration {
        self.bin + self.search
    }

    /// `(name, time)` for every phase, in step order.
    pub fn phases(&self) -> [(&'static str, Duration); 8] {
        [
            ("sort", self.sort),
            ("bin", self.bin),
            ("search", self.search),
            ("rows", self.rows),
            ("velocity", self.velocity),
            ("motion", self.motion),
            ("position", self.position),
            ("bookkeeping", self.bookkeeping),
        ]
    }
}

/// Time since the last lap, for splitting one span into phases.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Lap(Instant);

impl Lap {
    /// Starts timing now.
    #[inline]
    pub fn start() -> Self {
        Self(Instant::now())
    }

    /// The time since the start or the last lap; the next lap starts now.
    #[inline]
    pub fn lap(&mut self) -> Duration {
        let now = Instant::now();
        let span = now - self.0;
        self.0 = now;
        span
    }
}
