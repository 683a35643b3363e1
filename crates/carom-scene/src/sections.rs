//! The `[broadphase]` and `[solver]` sections: each field checked and turned into the
//! engine's settings, with the file and the field named in every error.

use crate::raw::{RawBroadPhaseKind, RawScene};
use crate::{Ctx, SceneError};
use carom_engine::grid::MAX_CELLS;
use carom_engine::{BroadPhaseKind, Vector, WorldConfig};
use std::ops::RangeInclusive;

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

/// `[solver]`, checked, onto `config` (whose solver fields hold the engine's defaults): each
/// field the section gives replaces its default.
pub(crate) fn apply_solver<V: Vector>(
    ctx: &Ctx,
    raw: &RawScene,
    config: &mut WorldConfig<V>,
) -> Result<(), SceneError> {
    let Some(s) = &raw.solver else {
        return Ok(());
    };
    let count =
        |field: &str, value: Option<i64>, range: RangeInclusive<i64>, into: &mut u32| match value {
            Some(n) if !range.contains(&n) => Err(ctx.err(
                format!("solver.{field}"),
                format!("must be in {}..={}, got {n}", range.start(), range.end()),
            )),
            Some(n) => {
                *into = n as u32;
                Ok(())
            }
            None => Ok(()),
        };
    count("substeps", s.substeps, 1..=1000, &mut config.substeps)?;
    count("retakes", s.retakes, 0..=MOST_RETAKES, &mut config.retakes)?;
    let iterations = s.velocity_iterations;
    count(
        "velocity_iterations",
        iterations,
        1..=1_000_000,
        &mut config.velocity_iterations,
    )?;
    let iterations = s.position_iterations;
    count(
        "position_iterations",
        iterations,
        0..=1_000_000,
        &mut config.position_iterations,
    )?;
    if let Some(v) = s.resting_speed {
        config.resting_speed = Some(ctx.non_negative("solver.resting_speed", v)?);
    }
    if let Some(cover_pushes) = s.cover_pushes {
        config.cover_pushes = cover_pushes;
    }
    if let Some(sleep) = s.sleep {
        config.sleep = sleep;
    }
    if let Some(v) = s.sleep_speed {
        config.sleep_speed = Some(ctx.positive("solver.sleep_speed", v)?);
    }
    if let Some(v) = s.sleep_time {
        config.sleep_time = ctx.positive("solver.sleep_time", v)?;
    }
    Ok(())
}
