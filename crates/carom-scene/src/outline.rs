//! What a scene's text says before its particles are placed: enough for a command to check
//! its flags against the scene (`--cells` per axis and only for a grid, `--broadphase hash`
//! on periodic axes,
//! `carom render`'s frames against the steps) before a fill that may take seconds.

use crate::raw::RawScene;
use crate::{steps_of, Ctx, SceneError};
use carom_engine::glam::{DVec2, DVec3};
use carom_engine::{BroadPhaseKind, Vector};

/// A scene's dimensions, steps, periodic axes and broad phase, read without placing its
/// particles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outline {
    /// 2 or 3.
    pub dimensions: usize,
    /// Steps to run (the scene's `steps`, or its default).
    pub steps: u64,
    /// Whether any axis wraps around (`[domain] periodic`).
    pub periodic: bool,
    /// The broad phase the scene asks for, or its default (see `[broadphase] kind`).
    pub broad_phase: BroadPhaseKind,
}

/// The [`Outline`] of scene text; the errors are those [`crate::parse`] gives for these
/// fields (`origin` names the text in them).
pub fn outline(text: &str, origin: &str) -> Result<Outline, SceneError> {
    let raw: RawScene = toml::from_str(text).map_err(|e| SceneError {
        origin: origin.to_string(),
        field: None,
        message: e.to_string().trim_end().to_string(),
    })?;
    let ctx = Ctx {
        origin,
        progress: &|_, _| {},
    };
    match raw.dimensions {
        2 => outline_in::<DVec2>(&ctx, &raw),
        3 => outline_in::<DVec3>(&ctx, &raw),
        d => Err(ctx.err("dimensions", format!("must be 2 or 3, got {d}"))),
    }
}

fn outline_in<V: Vector>(ctx: &Ctx, raw: &RawScene) -> Result<Outline, SceneError> {
    let periodic = match raw.domain.as_ref().and_then(|d| d.periodic.as_ref()) {
        Some(value) => ctx.periodic::<V>(value)?.iter().any(|&a| a),
        None => false,
    };
    let walls = raw.domain.as_ref().is_some_and(|d| d.walls);
    let (broad_phase, _) = crate::sections::broad_phase::<V>(ctx, raw, walls, periodic)?;
    Ok(Outline {
        dimensions: V::DIM,
        steps: steps_of(ctx, raw)?,
        periodic,
        broad_phase,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_outline_is_read_without_placing_a_particle() {
        // (a fill that no box could hold: placing it would fail, the outline does not try)
        let text = "dimensions = 3\ndt = 0.01\nsteps = 7\n[domain]\nmin = [0.0, 0.0, 0.0]\n\
                    max = [10.0, 10.0, 10.0]\nperiodic = [true, false, false]\n\
                    [[fill]]\ncount = 100000\nradius = 1.0\n";
        let expected = Outline {
            dimensions: 3,
            steps: 7,
            periodic: true,
            broad_phase: BroadPhaseKind::Grid,
        };
        assert_eq!(outline(text, "t").unwrap(), expected);
        assert!(crate::parse(text, "t").is_err());
        // (no walls: the unbounded hash by default)
        let open = outline("dimensions = 2\ndt = 0.01\n", "t").unwrap();
        assert_eq!(open.broad_phase, BroadPhaseKind::Hash);
        let e = outline("dimensions = 4\ndt = 0.01\n", "t").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("dimensions"));
    }
}
