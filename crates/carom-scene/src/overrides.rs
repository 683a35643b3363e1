//! What a run changes of its scene (`--broadphase`, `--cells`), and the run settings a
//! checkpoint carries besides the scene text: one definition for `carom run`, `carom resume`
//! and the Python module, so that a checkpoint written by one resumes in the other the same
//! way.

use crate::Scene;
use carom_engine::grid::MAX_CELLS;
use carom_engine::{BroadPhaseKind, Vector};

/// Run settings a checkpoint carries besides the scene text, as JSON (its `settings_json`).
#[derive(serde::Serialize, serde::Deserialize, Debug, Clone, Default, PartialEq, Eq)]
pub struct RunSettings {
    /// Total steps of the run (`carom resume` continues to this many).
    pub steps: u64,
    /// The `--broadphase` override (`brute`, `grid` or `hash`), if any.
    pub broadphase: Option<String>,
    /// The `--cells` override (cells per axis), if any.
    pub cells: Option<Vec<usize>>,
}

impl RunSettings {
    /// Applies the overrides to `scene` (see [`Scene::override_broad_phase`]).
    pub fn apply_to<V: Vector>(&self, scene: &mut Scene<V>) -> Result<(), OverrideError> {
        scene.override_broad_phase(self.broadphase.as_deref(), self.cells.as_deref())
    }
}

/// A `--broadphase` or `--cells` a scene cannot take. The messages name the flag.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OverrideError {
    /// Not `brute`, `grid` or `hash`.
    #[error("--broadphase: unknown `{0}`")]
    UnknownBroadPhase(String),
    /// No cell counts, or a zero among them.
    #[error("--cells: needs whole numbers >= 1, one per axis, got {0:?}")]
    NotWhole(Vec<usize>),
    /// More cells in all than the grid allows.
    #[error("--cells: {total} cells in all is more than the limit {limit}")]
    TooMany {
        /// The product of the counts (saturating).
        total: u64,
        /// [`MAX_CELLS`].
        limit: u64,
    },
    /// Not one count per axis of the scene.
    #[error("--cells: needs {dimensions} whole numbers >= 1 (the scene is {dimensions}D), got {cells:?}")]
    PerAxis {
        /// The scene's dimensions.
        dimensions: usize,
        /// What was given.
        cells: Vec<usize>,
    },
    /// Cells for a run that does not use the grid.
    #[error(
        "--cells: only the grid has cells, and this run does not use it; add --broadphase grid"
    )]
    WithoutGrid,
}

/// Checks `--cells` on its own (before a scene is read): whole numbers, within the limit.
pub fn check_cells(cells: &[usize]) -> Result<(), OverrideError> {
    if cells.is_empty() || cells.contains(&0) {
        return Err(OverrideError::NotWhole(cells.to_vec()));
    }
    let total = cells.iter().fold(1u64, |t, &c| t.saturating_mul(c as u64));
    if total > MAX_CELLS {
        return Err(OverrideError::TooMany {
            total,
            limit: MAX_CELLS,
        });
    }
    Ok(())
}

/// The broad phase a run of a `dimensions`-D scene whose own is `scene_kind` takes with
/// `broadphase` (`brute`, `grid` or `hash`, where given), refusing `cells` that are not one
/// whole count per axis or are given for a broad phase without cells. What a scene's
/// overrides are checked by, from its outline before its fill (the command line) and on the
/// scene itself ([`Scene::override_broad_phase`]).
pub fn overridden_broad_phase(
    dimensions: usize,
    scene_kind: BroadPhaseKind,
    broadphase: Option<&str>,
    cells: Option<&[usize]>,
) -> Result<BroadPhaseKind, OverrideError> {
    let kind = match broadphase {
        Some("brute") => BroadPhaseKind::Brute,
        Some("grid") => BroadPhaseKind::Grid,
        Some("hash") => BroadPhaseKind::Hash,
        Some(other) => return Err(OverrideError::UnknownBroadPhase(other.to_string())),
        None => scene_kind,
    };
    if let Some(cells) = cells {
        check_cells(cells)?;
        if cells.len() != dimensions {
            return Err(OverrideError::PerAxis {
                dimensions,
                cells: cells.to_vec(),
            });
        }
        if kind != BroadPhaseKind::Grid {
            return Err(OverrideError::WithoutGrid);
        }
    }
    Ok(kind)
}

impl<V: Vector> Scene<V> {
    /// Replaces the scene's broad phase with `broadphase` (`brute`, `grid` or `hash`) and its
    /// grid's cells with `cells` (one count per axis; only for the grid), where given.
    pub fn override_broad_phase(
        &mut self,
        broadphase: Option<&str>,
        cells: Option<&[usize]>,
    ) -> Result<(), OverrideError> {
        let own = self.config.broad_phase;
        self.config.broad_phase = overridden_broad_phase(V::DIM, own, broadphase, cells)?;
        if let Some(cells) = cells {
            self.config.grid_cells = Some(cells.to_vec());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{parse, AnyScene};

    fn scene() -> Scene<carom_engine::glam::DVec2> {
        let text = "dimensions = 2\ndt = 0.01\n[[particles]]\nposition = [0.0, 0.0]\n\
                    velocity = [0.0, 0.0]\nradius = 1.0\n";
        match parse(text, "test").unwrap() {
            AnyScene::Two(s) => s,
            AnyScene::Three(_) => unreachable!("a 2D scene"),
        }
    }

    #[test]
    fn overrides_change_the_broad_phase_and_the_cells() {
        let mut s = scene();
        s.override_broad_phase(Some("brute"), None).unwrap();
        assert_eq!(s.config.broad_phase, BroadPhaseKind::Brute);
        s.override_broad_phase(Some("grid"), Some(&[4, 5])).unwrap();
        assert_eq!(s.config.broad_phase, BroadPhaseKind::Grid);
        assert_eq!(s.config.grid_cells, Some(vec![4, 5]));
        let settings = RunSettings {
            steps: 9,
            broadphase: Some("hash".into()),
            cells: None,
        };
        settings.apply_to(&mut s).unwrap();
        assert_eq!(s.config.broad_phase, BroadPhaseKind::Hash);
    }

    #[test]
    fn bad_overrides_are_refused_by_name() {
        let mut s = scene();
        let refused = |s: &mut Scene<_>, b: Option<&str>, c: Option<&[usize]>| {
            s.override_broad_phase(b, c).unwrap_err()
        };
        assert_eq!(
            refused(&mut s, Some("octree"), None),
            OverrideError::UnknownBroadPhase("octree".into())
        );
        assert!(matches!(
            refused(&mut s, Some("grid"), Some(&[4, 0])),
            OverrideError::NotWhole(_)
        ));
        assert!(matches!(
            refused(&mut s, Some("grid"), Some(&[4, 4, 4])),
            OverrideError::PerAxis { dimensions: 2, .. }
        ));
        assert!(matches!(
            refused(&mut s, Some("grid"), Some(&[1 << 20, 1 << 20])),
            OverrideError::TooMany { .. }
        ));
        assert_eq!(
            refused(&mut s, Some("brute"), Some(&[4, 4])),
            OverrideError::WithoutGrid
        );
        let shown = OverrideError::WithoutGrid.to_string();
        assert!(shown.starts_with("--cells: ") && shown.contains("--broadphase grid"));
    }

    /// The JSON a checkpoint carries: the field names are the format (older checkpoints must
    /// still resume).
    #[test]
    fn run_settings_keep_their_json() {
        let settings = RunSettings {
            steps: 40,
            broadphase: Some("grid".into()),
            cells: Some(vec![10, 20]),
        };
        let json = r#"{"steps":40,"broadphase":"grid","cells":[10,20]}"#;
        assert_eq!(serde_json::to_string(&settings).unwrap(), json);
        assert_eq!(serde_json::from_str::<RunSettings>(json).unwrap(), settings);
    }
}
