//! The `[broadphase]` and `[solver]` sections: each field checked and turned into the
//! engine's settings, with the file and the field named in every error.

use crate::raw::{RawBroadPhaseKind, RawScene};
use crate::{Ctx, SceneError};
use carom_engine::grid::MAX_CELLS;
use carom_engine::world::{
    DEFAULT_POSITION_ITERATIONS, DEFAULT_RETAKES, DEFAULT_SUBSTEPS, DEFAULT_VELOCITY_ITERATIONS,
};
use carom_engine::{BroadPhaseKind, Vector};

/// `[broadphase]`: the kind (by default the grid when `walls` close the domain or it `wraps`,
/// else the unbounded hash) and the grid's cells, if given.
pub(crate) fn broad_phase<V: Vector>(
    ctx: &Ctx,
    raw: &RawScene,
    walls: bool,
    wraps: bool,
) -> Result<(BroadPhaseKind, Option<Vec<usize>>), SceneError> {
    // Default: the lecture's grid when walls close the domain (or it wraps around), otherwise
    // the unbounded hash (particles may roam anywhere, and a grid would clamp them into its
    // border cells).
    let mut broad_phase = if walls || wraps {
        BroadPhaseKind::Grid
    } else {
        BroadPhaseKind::Hash
    };
    let mut grid_cells = None;
    if let Some(b) = &raw.broadphase {
        match b.kind {
            Some(RawBroadPhaseKind::Brute) => broad_phase = BroadPhaseKind::Brute,
            Some(RawBroadPhaseKind::Grid) => broad_phase = BroadPhaseKind::Grid,
            Some(RawBroadPhaseKind::Hash) => broad_phase = BroadPhaseKind::Hash,
            None => {}
        }
        if wraps && broad_phase == BroadPhaseKind::Hash {
            return Err(ctx.err(
                "broadphase.kind",
                "the unbounded hash does not support periodic axes: use \"grid\" or \"brute\"",
            ));
        }
        if let Some(cells) = &b.cells {
            if cells.len() != V::DIM {
                return Err(ctx.err(
                    "broadphase.cells",
                    format!("needs {} entries, got {}", V::DIM, cells.len()),
                ));
            }
            let mut total: u64 = 1;
            let mut out = Vec::with_capacity(V::DIM);
            for &c in cells {
                if c < 1 {
                    return Err(ctx.err(
                        "broadphase.cells",
                        format!("every entry must be >= 1, got {cells:?}"),
                    ));
                }
                total = total.saturating_mul(c as u64);
                out.push(c as usize);
            }
            if total > MAX_CELLS {
                return Err(ctx.err(
                    "broadphase.cells",
                    format!("{total} cells in all is more than the limit {MAX_CELLS}"),
                ));
            }
            if broad_phase != BroadPhaseKind::Grid {
                return Err(ctx.err(
                    "broadphase.cells",
                    "only the grid has cells: set kind = \"grid\" or drop cells",
                ));
            }
            grid_cells = Some(out);
        }
    }

    Ok((broad_phase, grid_cells))
}

/// The most `[solver] retakes` a scene may ask for: each costs up to a step again.
const MOST_RETAKES: i64 = 8;

/// `[solver]`, checked, with the defaults filled in.
pub(crate) struct SolverSettings {
    pub velocity_iterations: u32,
    pub position_iterations: u32,
    pub substeps: u32,
    pub retakes: u32,
    pub cover_pushes: bool,
    pub resting_speed: Option<f64>,
    pub sleep: bool,
    pub sleep_speed: Option<f64>,
    pub sleep_time: f64,
}

/// `[solver]`, checked.
pub(crate) fn solver(ctx: &Ctx, raw: &RawScene) -> Result<SolverSettings, SceneError> {
    let (mut velocity_iterations, mut position_iterations, mut substeps) = (
        DEFAULT_VELOCITY_ITERATIONS,
        DEFAULT_POSITION_ITERATIONS,
        DEFAULT_SUBSTEPS,
    );
    let mut retakes = DEFAULT_RETAKES;
    if let Some(s) = &raw.solver {
        if let Some(n) = s.substeps {
            if !(1..=1000).contains(&n) {
                return Err(ctx.err("solver.substeps", format!("must be in 1..=1000, got {n}")));
            }
            substeps = n as u32;
        }
        if let Some(n) = s.retakes {
            if !(0..=MOST_RETAKES).contains(&n) {
                let range = format!("must be in 0..={MOST_RETAKES}, got {n}");
                return Err(ctx.err("solver.retakes", range));
            }
            retakes = n as u32;
        }
        if let Some(v) = s.velocity_iterations {
            if !(1..=1_000_000).contains(&v) {
                return Err(ctx.err(
                    "solver.velocity_iterations",
                    format!("must be in 1..=1000000, got {v}"),
                ));
            }
            velocity_iterations = v as u32;
        }
        if let Some(p) = s.position_iterations {
            if !(0..=1_000_000).contains(&p) {
                return Err(ctx.err(
                    "solver.position_iterations",
                    format!("must be in 0..=1000000, got {p}"),
                ));
            }
            position_iterations = p as u32;
        }
    }

    let resting_speed = match raw.solver.as_ref().and_then(|s| s.resting_speed) {
        Some(v) => Some(ctx.non_negative("solver.resting_speed", v)?),
        None => None,
    };

    let solver = raw.solver.as_ref();
    let cover_pushes = solver.and_then(|s| s.cover_pushes).unwrap_or(false);
    let sleep = solver.and_then(|s| s.sleep).unwrap_or(true);
    let sleep_speed = match solver.and_then(|s| s.sleep_speed) {
        Some(v) => Some(ctx.positive("solver.sleep_speed", v)?),
        None => None,
    };
    let sleep_time = match solver.and_then(|s| s.sleep_time) {
        Some(v) => ctx.positive("solver.sleep_time", v)?,
        None => carom_engine::sleep::DEFAULT_SLEEP_TIME,
    };

    Ok(SolverSettings {
        velocity_iterations,
        position_iterations,
        substeps,
        retakes,
        cover_pushes,
        resting_speed,
        sleep,
        sleep_speed,
        sleep_time,
    })
}
