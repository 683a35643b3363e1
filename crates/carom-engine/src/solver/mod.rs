//! Resolving many simultaneous contacts: velocities first, then (after the particles move)
//! positions.
//!
//! **Velocity phase.** Every contact whose particles overlap (the lecture's detection,
//! `distance < r1 + r2`) is one of two kinds, decided each time a sweep visits it:
//!
//! - an *impact*: approaching (the lecture's trap rule, `p_rel . v_rel < 0`) at or above the
//!   resting speed, or any approach when `k = 1`. It takes the lecture's response
//!   ([`crate::response::collide`]), restitution and all, so an isolated collision is exactly
//!   the lecture's and Newton's cradle passes its velocity along ball by ball.
//! - a *resting* contact (slower than the resting speed, `k < 1`): a sequential impulse as in
//!   Box2D. Its impulse accumulates over the sweeps, never below zero (a contact pushes, it
//!   never pulls), aiming at zero relative normal speed. For a single new contact that is the
//!   lecture's formula with `k = 0`; in a pile, the accumulated impulse is remembered into the
//!   next step ([`crate::memory`]) and applied before the first sweep ("warm starting"), so the
//!   weight of fifty rows does not have to climb up from the floor again every step.
//!
//! Sweeps repeat until one changes nothing (no impact, no resting impulse moving the relative
//! speed by more than [`RESIDUAL_FRACTION`] of the resting speed) or the cap is hit. Every
//! impulse is equal and opposite, so momentum is conserved; with `k = 1` every contact is an
//! impact, so kinetic energy is too.
//!
//! Under gravity with `k < 1` the step is substepped (see `velocity::integrate`): the relax
//! substeps stop every impact as a resting contact, and a restitution pass after them sends it
//! apart at `k` times its approach (the lecture's formula, for an isolated pair), but a pair
//! never with more than `k` times the impulse that stopped it (Poisson's law: see
//! `rules::kick_ceiling`), so impacts that press on each other make no energy.
//!
//! **Shock propagation** (Guendelman, Bridson and Fedkiw 2003). Equal and opposite impulses
//! carry a pile's weight up a chain of `n` contacts in about `n^2` sweeps, so a stack a hundred
//! discs tall would sink for hundreds of steps before its impulses, remembered from step to
//! step, caught up. When the relax sweeps of a step under gravity hit their cap (the last
//! substep's; in a step without impacts, any substep's), one more sweep follows in which a resting contact holds its lower particle fixed and lifts the upper
//! one, along gravity, until it stops approaching; the sweep runs in slot order, sorted along
//! space, block after block (see [`crate::schedule`]), so up a 2D pile from its floor (a 3D one
//! slab of cells at a time), and support reaches the top in that one sweep. The lower
//! particle does not feel the push: the reaction is what it would have passed on down to the
//! floor (or, in a capped mid-air cluster, is lost, so momentum is exact there only while the
//! sweeps converge; sideways momentum is never touched). Impacts never
//! take part: they keep the lecture's response.
//!
//! **Steps taken again** (see `escape`). Each particle's reach covers its own move and the
//! pushes of the partners it starts the step with; a push passed down a chain of contacts can
//! still drive it further, into a particle it has no contact with. When, after the move, a
//! particle that went beyond its reach overlaps such a one, the step is taken back and taken
//! again with that particle's reach covering its move (a few steps in a thousand of a pile
//! under gravity; in the lecture's own step only with [`crate::WorldConfig::cover_pushes`]:
//! without it, that step finds such pairs after the move, as its detection does).
//!
//! **Position phase** (the lecture's "solution 1", which it calls hard with many contacts):
//! after the particles move, overlapping particles are moved apart along their normal, each by
//! its share of inverse mass, down to a small slop, and pushed out of planes.
//! Positions only: velocities are never touched, so this can never add kinetic energy. Planes
//! go last so a walled box holds its particles. (One exception, the lecture's step under
//! gravity with every plane elastic: a lift out of a plane is paid for from the particle's
//! speed, so that kinetic + potential energy is kept; see `keep_energy`.)
//!
//! The order of every rule application is fixed by [`crate::schedule`].

mod bounces;
mod escape;
mod position;
mod rows;
mod rules;
mod settings;
mod shock;
mod strikes;
mod velocity;

pub use settings::{SolverSettings, VelocitySolve, RESIDUAL_FRACTION, SLOP_FRACTION};

pub(crate) use escape::{Moved, Retakes, StepStart};
pub(crate) use position::separate;
pub(crate) use rows::{
    deepest_placed, moving_mass, prepare_plane_rows, prepare_rows, tally, Contacts, Moving,
    PlaneRow, Row, RowRecord, Rows, RowsMut, WorkList,
};
pub(crate) use settings::{
    plane_reach, raise_to_partners, reach, reach_at, reach_covers_pushes, reaches_of,
    LectureCandidates,
};
pub(crate) use velocity::integrate;
