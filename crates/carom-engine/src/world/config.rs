//! The parameters a world is built with.

use super::*;
use crate::broadphase::BroadPhaseKind;
use crate::domain::Aabb;
use crate::periodic::Periodic;
use crate::plane::Plane;
use crate::sleep::{SleepSettings, DEFAULT_SLEEP_TIME, SLEEP_SPEED_FRACTION};
use crate::solver::SolverSettings;
use crate::vector::Vector;

/// Parameters that stay fixed while stepping (some can be changed with setters).
#[derive(Clone, Debug, PartialEq)]
pub struct WorldConfig<V> {
    /// Time step, > 0.
    pub dt: f64,
    /// Acceleration applied to every particle, length per time squared.
    pub gravity: V,
    /// Particle-particle coefficient of restitution `k` in [0, 1].
    pub restitution: f64,
    /// Cap on velocity sweeps per step, >= 1.
    pub velocity_iterations: u32,
    /// Position-correction sweeps per step (0 turns the lecture's "solution 1" off).
    pub position_iterations: u32,
    /// Substeps per step when contacts can rest (gravity and some `k < 1`), >= 1: see
    /// [`crate::solver`]. The velocity sweep cap is shared among them.
    pub substeps: u32,
    /// The most times one step is taken again when a push drove a particle beyond its reach
    /// into one the step had no contact for (see [`crate::solver`]); 0 never takes a step
    /// again. Only when contacts can rest or [`WorldConfig::cover_pushes`] says so (the
    /// lecture's step finds such pairs after the move).
    pub retakes: u32,
    /// Whether the lecture's step (no gravity, `k = 1` with elastic planes, or a resting speed
    /// of 0) covers pushes as a step where contacts can rest always does: each particle's
    /// contact candidates then cover what its partners can push it to within the step, and the
    /// step is taken again when a push still outruns them (see [`crate::solver`]). Off by default: the lecture's
    /// detection finds a pair a push drove together overlapping on the next step, and a dense
    /// gas under gravity ends steps with such pairs deep in each other.
    pub cover_pushes: bool,
    /// The simulation space; the grid covers it. `None`: the grid fits the particles.
    pub domain: Option<Aabb<V>>,
    /// Per axis (the first `DIM` entries), whether the domain wraps around on it (see
    /// [`crate::periodic`]): positions stay in `[min, max)` there, contacts reach across the
    /// seam, and walls close only the other axes. Needs a domain.
    pub periodic: [bool; 3],
    /// Which broad phase finds contacts.
    pub broad_phase: BroadPhaseKind,
    /// Grid cells per axis; `None` derives them from the largest radius.
    pub grid_cells: Option<Vec<usize>>,
    /// Contacts approaching slower than this (length per time) do not bounce when their
    /// restitution is below 1: they are resting contacts, and bouncing them makes stacks jitter
    /// and sink. `None`: twice what gravity adds in one step, `2 |g| dt` (zero without
    /// gravity, where every contact follows the lecture's formula exactly). `Some(0.0)` turns
    /// this off. Restitution 1 always bounces, so energy stays exact.
    pub resting_speed: Option<f64>,
    /// Let particles at rest sleep (see [`crate::sleep`]); on by default, as in Box2D and Rapier.
    /// Only when contacts can rest (gravity, and `k < 1` somewhere): an elastic or weightless
    /// world never sleeps. A world split over processes ([`crate::cluster`]) puts the same
    /// particles to sleep.
    pub sleep: bool,
    /// A particle moving slower than this (length / time) rests; `None`: the resting
    /// speed (see [`crate::sleep::SLEEP_SPEED_FRACTION`]).
    pub sleep_speed: Option<f64>,
    /// How long (time units, > 0) a particle and every particle within
    /// [`crate::sleep::WAKE_HOPS`] contact candidates of it must rest before it sleeps.
    pub sleep_time: f64,
}

impl<V: Vector> WorldConfig<V> {
    /// The periodic axes of the domain, or `None` when none is (or there is no domain).
    pub fn periodic(&self) -> Option<Periodic> {
        self.domain
            .as_ref()
            .and_then(|d| Periodic::new(d, &self.periodic))
    }

    /// [`WorldConfig::resting_speed`], or its default `2 |g| dt`.
    pub fn effective_resting_speed(&self) -> f64 {
        self.resting_speed
            .unwrap_or(2.0 * self.gravity.length_squared().sqrt() * self.dt)
    }

    /// What the solver needs of these settings.
    pub fn solver_settings(&self) -> SolverSettings {
        SolverSettings {
            restitution: self.restitution,
            resting_speed: self.effective_resting_speed(),
            velocity_iterations: self.velocity_iterations,
            position_iterations: self.position_iterations,
            substeps: self.substeps,
            retakes: self.retakes,
            cover_pushes: self.cover_pushes,
        }
    }

    /// When particles may sleep in a world with `planes`: `None` when sleeping is off or no
    /// contact can rest.
    pub fn sleep_settings(&self, planes: &[Plane<V>]) -> Option<SleepSettings> {
        let elastic_planes = planes.iter().all(|p| p.restitution() >= 1.0);
        let solver = self.solver_settings();
        if !self.sleep || solver.lecture_only(elastic_planes) {
            return None;
        }
        Some(SleepSettings {
            speed: self
                .sleep_speed
                .unwrap_or(SLEEP_SPEED_FRACTION * solver.resting_speed),
            time: self.sleep_time,
        })
    }
}

impl<V: Vector> Default for WorldConfig<V> {
    fn default() -> Self {
        Self {
            dt: 0.005,
            gravity: V::ZERO,
            restitution: 1.0,
            velocity_iterations: DEFAULT_VELOCITY_ITERATIONS,
            position_iterations: DEFAULT_POSITION_ITERATIONS,
            substeps: DEFAULT_SUBSTEPS,
            retakes: DEFAULT_RETAKES,
            cover_pushes: false,
            domain: None,
            periodic: [false; 3],
            broad_phase: BroadPhaseKind::Grid,
            grid_cells: None,
            resting_speed: None,
            sleep: true,
            sleep_speed: None,
            sleep_time: DEFAULT_SLEEP_TIME,
        }
    }
}
