//! The scene file as written: serde types mirroring the TOML, before any checking. Unknown
//! keys are rejected here (`deny_unknown_fields`), so a typo is an error that names the key.

use serde::Deserialize;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawScene {
    pub name: Option<String>,
    pub description: Option<String>,
    pub dimensions: i64,
    pub dt: f64,
    pub steps: Option<i64>,
    pub gravity: Option<Vec<f64>>,
    pub restitution: Option<f64>,
    pub domain: Option<RawDomain>,
    pub broadphase: Option<RawBroadPhase>,
    pub solver: Option<RawSolver>,
    #[serde(default)]
    pub planes: Vec<RawPlane>,
    #[serde(default)]
    pub particles: Vec<RawParticle>,
    #[serde(default)]
    pub fill: Vec<RawFill>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawDomain {
    pub min: Vec<f64>,
    pub max: Vec<f64>,
    #[serde(default)]
    pub walls: bool,
    pub restitution: Option<f64>,
    /// Any TOML value here, checked by hand, so that a wrong one is an error naming the field.
    pub periodic: Option<toml::Value>,
}

#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub(crate) enum RawBroadPhaseKind {
    Grid,
    Brute,
    Hash,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBroadPhase {
    pub kind: Option<RawBroadPhaseKind>,
    pub cells: Option<Vec<i64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSolver {
    pub velocity_iterations: Option<i64>,
    pub position_iterations: Option<i64>,
    pub substeps: Option<i64>,
    pub retakes: Option<i64>,
    pub cover_pushes: Option<bool>,
    pub resting_speed: Option<f64>,
    pub sleep: Option<bool>,
    pub sleep_speed: Option<f64>,
    pub sleep_time: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawPlane {
    pub point: Vec<f64>,
    pub normal: Vec<f64>,
    pub restitution: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawParticle {
    pub position: Vec<f64>,
    pub velocity: Option<Vec<f64>>,
    pub radius: f64,
    pub mass: Option<f64>,
}

#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub(crate) enum RawArrangement {
    #[default]
    Random,
    Lattice,
    Hex,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawFill {
    pub count: i64,
    pub radius: f64,
    pub mass: Option<f64>,
    pub speed: Option<f64>,
    pub velocity: Option<Vec<f64>>,
    pub seed: Option<i64>,
    pub min: Option<Vec<f64>>,
    pub max: Option<Vec<f64>>,
    #[serde(default)]
    pub arrangement: RawArrangement,
}
