//! One time step: the lecture's `ParticleSystem_Movement()` ("particle position update,
//! particle velocity update, collision"), as named phases.
//!
//! [`crate::World`] and the cluster's [`crate::cluster::Subdomain`] both step through
//! `advance`, so a world split over processes takes the very same phases in the very same
//! order as one world does; only what each phase does with its share of the particles differs.
//!
//! The velocities are resolved *before* the particles move (semi-implicit Euler with the
//! contacts solved in between, as game engines do): a resting pile whose contacts cancel
//! gravity then does not move at all, instead of sinking by `g dt^2` a step and being pushed
//! back up.

use crate::diagnostics::StepStats;
use crate::solver::VelocitySolve;
use crate::timing::{Lap, PhaseTimes};
use std::time::Duration;

/// What a stepper does in each phase of [`advance`].
pub(crate) trait Phases {
    /// Every [`crate::world::REORDER_INTERVAL`] steps, sorts the particles along space so that
    /// neighbours sit next to each other in memory (and, across processes, move to the
    /// process that owns their slot).
    fn sort_along_space(&mut self);
    /// The broad phase (the lecture's hash grid, or brute force) over each particle's reach
    /// this step, then the lecture's detection and the remembered impulses for each candidate.
    fn find_contacts(&mut self);
    /// Gravity (`v += g dt`), the velocity phase (the lecture's response and trap rule for
    /// impacts, accumulated impulses for resting contacts) and the move (`x += v dt`), in
    /// substeps when contacts can rest (see [`crate::solver::integrate`]).
    fn integrate(&mut self) -> VelocitySolve;
    /// The position phase (the lecture's "solution 1"); returns the largest overlap left.
    fn separate(&mut self) -> f64;
    /// Keeps this step's resting impulses for the next step's warm start.
    fn remember(&mut self);
    /// Counts the step and reports it.
    fn finish(&mut self, solve: VelocitySolve, max_overlap: f64) -> StepStats;
    /// After `integrate`, the step tried `tries` times: whether a particle went beyond its
    /// reach into one the step never solved a contact with (see `solver::escape`), and the
    /// step may be taken again (`tries` is at most [`crate::WorldConfig::retakes`]). If so,
    /// puts the particles back where the step started them, at the speeds it started them
    /// with, and raises those particles' reaches for the step to be taken again.
    fn take_back_escapes(&mut self, tries: u32) -> bool;
    /// Where the stepper's time went; `find_contacts` adds its `rows` itself.
    fn times(&mut self) -> &mut PhaseTimes;
}

/// Advances `stepper` by one time step.
pub(crate) fn advance(stepper: &mut impl Phases) -> StepStats {
    let mut clock = Lap::start();
    stepper.sort_along_space();
    let sort = clock.lap();
    let (rows_before, bin_before) = (stepper.times().rows, stepper.times().bin);
    // (a step taken again is timed in its phases, the search and the velocity phase again)
    let (mut find, mut integrate, mut motion) = (Duration::ZERO, Duration::ZERO, Duration::ZERO);
    let mut tries = 0;
    let solve = loop {
        stepper.find_contacts();
        find += clock.lap();
        let solve = stepper.integrate();
        motion += solve.motion;
        tries += 1;
        let again = stepper.take_back_escapes(tries);
        integrate += clock.lap();
        if !again {
            break solve;
        }
    };
    let max_overlap = stepper.separate();
    let position = clock.lap();
    stepper.remember();
    let mut stats = stepper.finish(solve, max_overlap);
    stats.retakes = tries - 1;
    let bookkeeping = clock.lap();
    let times = stepper.times();
    times.steps += 1;
    times.sort += sort;
    // (find_contacts timed its rows and its binning; the search is the rest)
    let timed_inside = (times.rows - rows_before) + (times.bin - bin_before);
    times.search += find.saturating_sub(timed_inside);
    times.motion += motion;
    times.velocity += integrate.saturating_sub(motion);
    times.position += position;
    times.bookkeeping += bookkeeping;
    stats
}
