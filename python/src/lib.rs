//! The `carom` Python module: PyO3 bindings over `carom-engine`, `carom-scene` and
//! `carom-output`.
//!
//! A `World` is built exactly as `carom run` builds it (the scene parsed by
//! `carom_scene::parse`, the world by `Scene::into_world`) and stepped by the same
//! `World::step`, on the same rayon pool, so a world stepped from Python gives the very bits the
//! CLI gives. Checkpoints and state CSV files are written by `carom-output`, in the CLI's
//! formats, atomically.
//!
//! Stepping releases the GIL; every `CHUNK` (50 ms) of wall time the loop takes it back for a
//! moment to let Python run its signal handlers, so Ctrl-C stops the loop between two steps.

use carom_output::checkpoint::Checkpoint;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyList;
use std::path::PathBuf;

/// Runs `$body` with `$w` bound to the world inside `$any`, whatever its dimension.
macro_rules! with_world {
    ($any:expr, $w:ident => $body:expr) => {
        match $any {
            AnyWorld::Two($w) => $body,
            AnyWorld::Three($w) => $body,
        }
    };
}

mod convert;
mod errors;
mod world;

use errors::*;
use world::*;

/// Load the scene file at `path` (str or os.PathLike) and build its world, as `carom run PATH`
/// does.
///
/// Raises SceneError (a ValueError) for a scene that is not valid, with the CLI's message
/// (file, field, what is wrong), and OSError if the file cannot be read.
#[pyfunction]
fn load(py: Python<'_>, path: PathBuf) -> PyResult<World> {
    let origin = path.display().to_string();
    let text = carom_output::read_regular_text(&path)
        .map_err(|e| os_error("cannot read scene file", &e, &path))?;
    build(py, text, origin)
}

/// Build the world of a scene given as TOML text (the format of `docs/scene-format.md`).
///
/// Messages name the scene `<string>`. Raises SceneError for a scene that is not valid.
#[pyfunction]
fn from_toml(py: Python<'_>, text: String) -> PyResult<World> {
    build(py, text, STRING_ORIGIN.to_string())
}

/// Build the world of a built-in scene, as `carom run --preset NAME` does (`presets()` lists
/// them; they are the files in the repository's `scenes/` folder).
///
/// Raises ValueError for a name that is not a preset.
#[pyfunction]
fn preset(py: Python<'_>, name: &str) -> PyResult<World> {
    let text = carom_scene::preset(name).ok_or_else(|| {
        let names: Vec<_> = carom_scene::preset_names().collect();
        PyValueError::new_err(format!(
            "no built-in scene `{name}`; there are: {}",
            names.join(", ")
        ))
    })?;
    build(py, text.to_string(), format!("preset:{name}"))
}

/// The names of the built-in scenes, in order (the first is `carom run`'s default).
#[pyfunction]
fn presets(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    PyList::new(py, carom_scene::preset_names())
}

/// Continue from a checkpoint written by `World.checkpoint` or `carom run --checkpoint`, as
/// `carom resume PATH` does: stepping the world on gives the very bits of the run that was never
/// stopped.
///
/// Raises OSError if the file cannot be read, ValueError for a damaged or foreign file, and
/// SceneError if the scene inside it is no longer valid.
#[pyfunction]
fn resume(py: Python<'_>, checkpoint_path: PathBuf) -> PyResult<World> {
    let shown = checkpoint_path.display().to_string();
    let bytes = carom_output::read_regular_file(&checkpoint_path)
        .map_err(|e| os_error("cannot read checkpoint", &e, &checkpoint_path))?;
    let cp = Checkpoint::read_from(&bytes)
        .map_err(|e| PyValueError::new_err(format!("{shown}: {e}")))?;
    let settings: carom_scene::RunSettings = serde_json::from_str(&cp.settings_json)
        .map_err(|e| PyValueError::new_err(format!("{shown}: damaged run settings: {e}")))?;
    // (the fill places its particles on the pool)
    start_threads()?;
    let scene = carom_scene::parse(&cp.scene_toml, &cp.origin)
        .map_err(|e| scene_error(py, format!("{shown}: {e}"), &e.origin, e.field.as_deref()))?;
    let (name, world) = match scene {
        carom_scene::AnyScene::Two(s) => (
            s.name.clone(),
            resumed(s, &cp, &settings).map(AnyWorld::Two),
        ),
        carom_scene::AnyScene::Three(s) => (
            s.name.clone(),
            resumed(s, &cp, &settings).map(AnyWorld::Three),
        ),
    };
    let world = world.map_err(|e| PyValueError::new_err(format!("{shown}: {e}")))?;
    Ok(World::new(
        world,
        Meta {
            scene_toml: cp.scene_toml,
            origin: cp.origin,
            name,
            settings,
        },
    ))
}

/// carom: a particle collision engine (the lecture "Collision Detection and Response", in 2D
/// and 3D), from Python.
///
/// Build a World from a scene (`load`, `from_toml`, `preset`) or a checkpoint (`resume`), step
/// it (`World.step`, with the GIL released) and read its state as numpy arrays. A world
/// stepped here gives the very bits `carom run` gives for the same scene and step count.
///
///     import carom
///     world = carom.preset("lecture_100_k05")
///     world.step(1000)
///     world.positions          # (100, 2) float64, in id order
///
/// The rayon thread pool takes its size from RAYON_NUM_THREADS (default: every core), as the
/// CLI does; the results do not depend on it.
#[pymodule]
fn carom(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add_class::<World>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(from_toml, m)?)?;
    m.add_function(wrap_pyfunction!(preset, m)?)?;
    m.add_function(wrap_pyfunction!(presets, m)?)?;
    m.add_function(wrap_pyfunction!(resume, m)?)?;
    Ok(())
}
