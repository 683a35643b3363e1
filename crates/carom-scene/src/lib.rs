//! # carom-scene
//!
//! TOML scene files for carom: [`load`] reads one, checks every value and builds the particle
//! set (including `[[fill]]` blocks), returning an [`AnyScene`] in 2D or 3D. Every error is a
//! [`SceneError`] that names the file and the field. The format is documented in the
//! repository's `docs/scene-format.md`.

mod error;
mod fill;
pub mod machine;
mod outline;
mod overrides;
mod placement;
mod presets;
mod raw;
mod screen;
mod sections;
mod state;
mod walls;

pub use error::SceneError;
pub use outline::{outline, Outline};
pub use overrides::{check_cells, overridden_broad_phase, OverrideError, RunSettings};
pub use presets::{preset, preset_names, DEFAULT_PRESET, PRESETS};
pub use state::{check_remembered, check_state, check_stored_steps, MAX_STATE_MAGNITUDE};

use carom_engine::glam::{DVec2, DVec3};
use carom_engine::periodic::shortest_period;
use carom_engine::{Aabb, EngineError, Particles, Periodic, Plane, Vector, World, WorldConfig};
use carom_engine::{ContactImpulses, Tally};
use raw::RawScene;
use std::path::Path;

/// Steps run when a scene gives no `steps`.
pub const DEFAULT_STEPS: u64 = 1000;

/// The most steps a run may ask for (the scene's `steps`, `--steps`): 10^12, decades at a
/// microsecond a step. More is a typo (an extra digit or two), refused before any work.
pub const MAX_STEPS: u64 = 1_000_000_000_000;

/// A checked scene in `V`'s dimension, ready to become a [`World`].
#[derive(Debug, Clone)]
pub struct Scene<V: Vector> {
    /// `name` from the file, if any.
    pub name: Option<String>,
    /// `description` from the file, if any.
    pub description: Option<String>,
    /// Steps to run.
    pub steps: u64,
    /// Engine settings.
    pub config: WorldConfig<V>,
    /// Restitution of the domain walls, when `[domain] walls = true`.
    pub walls: Option<f64>,
    /// Extra planes (`[[planes]]`).
    pub planes: Vec<Plane<V>>,
    /// Every particle: explicit ones first, then each fill in order.
    pub particles: Particles<V>,
}

impl<V: Vector> Scene<V> {
    /// Builds the world. Cannot fail for a scene that [`load`] or [`parse`] accepted unless the
    /// fields were changed afterwards.
    pub fn build_world(&self) -> Result<World<V>, EngineError> {
        self.builder(self.particles.clone()).build()
    }

    /// Builds the world, moving the particles into it instead of copying them (for large
    /// scenes, where a copy would double the peak memory).
    pub fn into_world(mut self) -> Result<World<V>, EngineError> {
        let particles = std::mem::take(&mut self.particles);
        self.builder(particles).build()
    }

    /// Builds the world as a continuation: `steps_taken` steps already done, particles in
    /// `storage_order`, the solver remembering `impulses` and the observables going on from
    /// `tally` (see [`carom_engine::WorldBuilder::resume`],
    /// [`carom_engine::WorldBuilder::impulses`] and [`carom_engine::WorldBuilder::tally`]).
    pub fn into_resumed_world(
        mut self,
        steps_taken: u64,
        storage_order: Vec<u32>,
        impulses: ContactImpulses,
        tally: Tally,
    ) -> Result<World<V>, EngineError> {
        let particles = std::mem::take(&mut self.particles);
        self.builder(particles)
            .resume(steps_taken, storage_order)
            .impulses(impulses)
            .tally(tally)
            .build()
    }

    fn builder(&self, particles: Particles<V>) -> carom_engine::WorldBuilder<V> {
        let mut b = World::builder()
            .dt(self.config.dt)
            .gravity(self.config.gravity)
            .restitution(self.config.restitution)
            .iterations(
                self.config.velocity_iterations,
                self.config.position_iterations,
            )
            .substeps(self.config.substeps)
            .retakes(self.config.retakes)
            .cover_pushes(self.config.cover_pushes)
            .sleep(self.config.sleep)
            .sleep_time(self.config.sleep_time)
            .broad_phase(self.config.broad_phase)
            .particles(particles);
        if let Some(d) = self.config.domain {
            b = b.domain(d);
        }
        if self.config.periodic.iter().any(|&a| a) {
            b = b.periodic(&self.config.periodic[..V::DIM]);
        }
        if let Some(v) = self.config.resting_speed {
            b = b.resting_speed(v);
        }
        if let Some(v) = self.config.sleep_speed {
            b = b.sleep_speed(v);
        }
        if let Some(c) = &self.config.grid_cells {
            b = b.grid_cells(c);
        }
        if let Some(k) = self.walls {
            b = b.walls(k);
        }
        for p in &self.planes {
            b = b.plane(*p);
        }
        b
    }
}

/// A scene of either dimension.
#[derive(Debug, Clone)]
pub enum AnyScene {
    /// `dimensions = 2`
    Two(Scene<DVec2>),
    /// `dimensions = 3`
    Three(Scene<DVec3>),
}

impl AnyScene {
    /// 2 or 3.
    pub fn dimensions(&self) -> usize {
        match self {
            AnyScene::Two(_) => 2,
            AnyScene::Three(_) => 3,
        }
    }
}

/// Reads and checks the scene file at `path`.
pub fn load(path: &Path) -> Result<AnyScene, SceneError> {
    let origin = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| SceneError {
        origin: origin.clone(),
        field: None,
        message: format!("cannot read scene file: {e}"),
    })?;
    parse(&text, &origin)
}

/// Checks scene text; `origin` names it in errors (a path, or `preset:NAME`).
pub fn parse(text: &str, origin: &str) -> Result<AnyScene, SceneError> {
    parse_with_progress(text, origin, &|_, _| {})
}

/// [`parse`], telling `progress` how far the fills have come: `progress(placed, total)`
/// with the particles placed so far and the scene's total, after each batch of random tries
/// (or each 65,536 lattice sites) and once every fill is done. A fill of 10^6 spheres near
/// the densest random packing takes seconds; a command line can show a progress bar.
pub fn parse_with_progress(
    text: &str,
    origin: &str,
    progress: &dyn Fn(u64, u64),
) -> Result<AnyScene, SceneError> {
    let raw: RawScene = toml::from_str(text).map_err(|e| SceneError {
        origin: origin.to_string(),
        field: None,
        message: e.to_string().trim_end().to_string(),
    })?;
    let ctx = Ctx { origin, progress };
    match raw.dimensions {
        2 => Ok(AnyScene::Two(build::<DVec2>(&ctx, raw)?)),
        3 => Ok(AnyScene::Three(build::<DVec3>(&ctx, raw)?)),
        d => Err(ctx.err("dimensions", format!("must be 2 or 3, got {d}"))),
    }
}

/// The largest magnitude any number in a scene may have (lengths, speeds, masses, `dt`,
/// gravity). Squares and products of such values (energies, squared distances, impulses) stay
/// far from f64 overflow even after millions of steps; found by fuzzing: `speed = 1e154` was
/// accepted and made the kinetic energy infinite at once.
pub const MAX_MAGNITUDE: f64 = 1e15;

/// The smallest value a positive quantity (`dt`, radius, mass) may have: an inverse mass of
/// `1 / 5e-324` is infinite, and a sub-normal radius makes grid sizes meaningless.
pub const MIN_POSITIVE: f64 = 1e-15;

fn out_of_scale(value: f64) -> String {
    format!(
        "{value:?} is out of carom's range: magnitudes must be at most {MAX_MAGNITUDE:e} and \
         positive sizes at least {MIN_POSITIVE:e}, so that energies and distances stay finite"
    )
}

pub(crate) struct Ctx<'a> {
    pub origin: &'a str,
    /// See [`parse_with_progress`].
    pub progress: &'a dyn Fn(u64, u64),
}

impl Ctx<'_> {
    pub(crate) fn err(&self, field: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError {
            origin: self.origin.to_string(),
            field: Some(field.into()),
            message: message.into(),
        }
    }

    pub(crate) fn vector<V: Vector>(&self, field: &str, values: &[f64]) -> Result<V, SceneError> {
        if values.len() != V::DIM {
            return Err(self.err(
                field,
                format!(
                    "needs {} components (dimensions = {}), got {}",
                    V::DIM,
                    V::DIM,
                    values.len()
                ),
            ));
        }
        if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
            return Err(self.err(field, format!("must be finite, got {bad}")));
        }
        if let Some(bad) = values.iter().find(|v| v.abs() > MAX_MAGNITUDE) {
            return Err(self.err(field, out_of_scale(*bad)));
        }
        Ok(V::from_slice(values))
    }

    pub(crate) fn positive(&self, field: &str, value: f64) -> Result<f64, SceneError> {
        if value.is_finite() && value > 0.0 {
            if !(MIN_POSITIVE..=MAX_MAGNITUDE).contains(&value) {
                return Err(self.err(field, out_of_scale(value)));
            }
            Ok(value)
        } else {
            Err(self.err(field, format!("must be a finite number > 0, got {value:?}")))
        }
    }

    pub(crate) fn non_negative(&self, field: &str, value: f64) -> Result<f64, SceneError> {
        if value.is_finite() && value >= 0.0 {
            if value > MAX_MAGNITUDE {
                return Err(self.err(field, out_of_scale(value)));
            }
            Ok(value)
        } else {
            Err(self.err(
                field,
                format!("must be a finite number >= 0, got {value:?}"),
            ))
        }
    }

    pub(crate) fn restitution(&self, field: &str, value: f64) -> Result<f64, SceneError> {
        if (0.0..=1.0).contains(&value) {
            Ok(value)
        } else {
            Err(self.err(field, format!("must be in [0, 1], got {value:?}")))
        }
    }

    /// `[domain] periodic`: one boolean per axis.
    pub(crate) fn periodic<V: Vector>(&self, value: &toml::Value) -> Result<[bool; 3], SceneError> {
        let field = "domain.periodic";
        let wrong = || {
            self.err(
                field,
                format!(
                    "must be an array of {} booleans (one per axis, dimensions = {}), got {value}",
                    V::DIM,
                    V::DIM
                ),
            )
        };
        let list = value.as_array().ok_or_else(wrong)?;
        if list.len() != V::DIM {
            return Err(wrong());
        }
        let mut axes = [false; 3];
        for (a, v) in list.iter().enumerate() {
            axes[a] = v.as_bool().ok_or_else(wrong)?;
        }
        Ok(axes)
    }

    pub(crate) fn aabb<V: Vector>(
        &self,
        field: &str,
        min: &[f64],
        max: &[f64],
    ) -> Result<Aabb<V>, SceneError> {
        let lo = self.vector::<V>(&format!("{field}.min"), min)?;
        let hi = self.vector::<V>(&format!("{field}.max"), max)?;
        Aabb::new(lo, hi).map_err(|_| {
            self.err(
                field,
                format!("min must be below max on every axis, got min {min:?}, max {max:?}"),
            )
        })
    }
}

/// The scene's `steps`, checked, or [`DEFAULT_STEPS`].
pub(crate) fn steps_of(ctx: &Ctx, raw: &RawScene) -> Result<u64, SceneError> {
    match raw.steps {
        None => Ok(DEFAULT_STEPS),
        Some(s) if (0..=MAX_STEPS as i64).contains(&s) => Ok(s as u64),
        Some(s) => Err(ctx.err("steps", format!("must be in 0..={MAX_STEPS}, got {s}"))),
    }
}

fn build<V: Vector>(ctx: &Ctx, raw: RawScene) -> Result<Scene<V>, SceneError> {
    let dt = ctx.positive("dt", raw.dt)?;
    let steps = steps_of(ctx, &raw)?;
    let gravity = match &raw.gravity {
        Some(g) => ctx.vector::<V>("gravity", g)?,
        None => V::ZERO,
    };
    let restitution = ctx.restitution("restitution", raw.restitution.unwrap_or(1.0))?;

    let mut domain = None;
    let mut walls = None;
    let mut periodic = [false; 3];
    if let Some(d) = &raw.domain {
        domain = Some(ctx.aabb::<V>("domain", &d.min, &d.max)?);
        let k = match d.restitution {
            Some(k) => ctx.restitution("domain.restitution", k)?,
            None => restitution,
        };
        if d.walls {
            walls = Some(k);
        }
        if let Some(value) = &d.periodic {
            periodic = ctx.periodic::<V>(value)?;
        }
    }
    let wraps = periodic.iter().any(|&a| a);

    let (broad_phase, grid_cells) = sections::broad_phase::<V>(ctx, &raw, walls.is_some(), wraps)?;
    let mut config = WorldConfig {
        dt,
        gravity,
        restitution,
        domain,
        periodic,
        broad_phase,
        grid_cells,
        ..WorldConfig::default()
    };
    sections::apply_solver(ctx, &raw, &mut config)?;
    let planes = planes::<V>(ctx, &raw, restitution)?;

    // (the periods take the radii as written: checked before the fills, which may take
    // seconds; a radius out of range is refused by the fills, naming it)
    if let (Some(d), true) = (domain, wraps) {
        check_periods(ctx, &d, &periodic, largest_radius(&raw))?;
    }
    let wrap = domain.and_then(|d| Periodic::new(&d, &periodic));
    let walled = crate::walls::Walled::new(domain, walls.is_some(), periodic);
    let particles = fill::particles::<V>(ctx, &raw, domain, wrap, walled)?;
    let fills: Vec<usize> = raw.fill.iter().map(|f| f.count as usize).collect();
    crate::walls::check_planes(ctx, &planes, &particles, raw.particles.len(), &fills)?;

    Ok(Scene {
        name: raw.name,
        description: raw.description,
        steps,
        config,
        walls,
        planes,
        particles,
    })
}

/// `[[planes]]`, checked (`restitution`: the scene's, for planes without their own).
fn planes<V: Vector>(
    ctx: &Ctx,
    raw: &RawScene,
    restitution: f64,
) -> Result<Vec<Plane<V>>, SceneError> {
    let mut planes = Vec::with_capacity(raw.planes.len());
    for (i, p) in raw.planes.iter().enumerate() {
        let f = |k: &str| format!("planes[{i}].{k}");
        let point = ctx.vector::<V>(&f("point"), &p.point)?;
        let normal = ctx.vector::<V>(&f("normal"), &p.normal)?;
        let k = match p.restitution {
            Some(k) => ctx.restitution(&f("restitution"), k)?,
            None => restitution,
        };
        let plane = Plane::new(point, normal, k).map_err(|e| match e {
            EngineError::ZeroPlaneNormal => ctx.err(f("normal"), "must not be zero"),
            other => ctx.err(format!("planes[{i}]"), other.to_string()),
        })?;
        planes.push(plane);
    }

    Ok(planes)
}

/// Every periodic axis of `domain` longer than [`shortest_period`] for `max_radius`.
/// The largest radius the scene's particles and fills give, among those in range (each is
/// checked where it is placed).
fn largest_radius(raw: &RawScene) -> f64 {
    let radii = raw.particles.iter().map(|p| p.radius);
    let radii = radii.chain(raw.fill.iter().map(|f| f.radius));
    radii
        .filter(|r| (MIN_POSITIVE..=MAX_MAGNITUDE).contains(r))
        .fold(0.0, f64::max)
}

fn check_periods<V: Vector>(
    ctx: &Ctx,
    domain: &Aabb<V>,
    periodic: &[bool; 3],
    max_radius: f64,
) -> Result<(), SceneError> {
    let shortest = shortest_period(max_radius);
    for a in (0..V::DIM).filter(|&a| periodic[a]) {
        let length = domain.max.get(a) - domain.min.get(a);
        if length <= shortest {
            return Err(ctx.err(
                "domain.periodic",
                format!(
                    "axis {a} is {length} long, but a periodic axis must be longer than \
                     {shortest} (4 (2 + slop) times the largest radius, so that only one \
                     image of a particle can touch another)"
                ),
            ));
        }
    }
    Ok(())
}
