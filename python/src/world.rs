//! The `World` class: a world of either dimension with what a checkpoint needs besides it,
//! built from a scene as `carom run` builds it, stepped without the GIL, written and resumed
//! as the CLI writes and resumes it.

use crate::convert::*;
use crate::errors::*;
use carom_engine::glam::{DVec2, DVec3};
use carom_engine::Vector;
use carom_output::checkpoint::Checkpoint;
use carom_scene::RunSettings;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard, TryLockError};
use std::time::{Duration, Instant};

/// How long the step loop runs without the GIL before it checks for Ctrl-C.
pub(crate) const CHUNK: Duration = Duration::from_millis(50);

/// The origin `from_toml` gives its scenes in messages and checkpoints.
pub(crate) const STRING_ORIGIN: &str = "<string>";

/// A world of either dimension.
pub(crate) enum AnyWorld {
    Two(carom_engine::World<DVec2>),
    Three(carom_engine::World<DVec3>),
}

impl AnyWorld {
    /// 2 or 3.
    pub(crate) fn dimensions(&self) -> usize {
        match self {
            AnyWorld::Two(_) => 2,
            AnyWorld::Three(_) => 3,
        }
    }
}

/// What a checkpoint needs besides the world, and what `repr` shows.
pub(crate) struct Meta {
    /// The scene's TOML text (kept in checkpoints).
    pub(crate) scene_toml: String,
    /// Where it came from: a path, `preset:NAME` or `<string>`.
    pub(crate) origin: String,
    /// The scene's `name`.
    pub(crate) name: Option<String>,
    pub(crate) settings: RunSettings,
}

pub(crate) struct State {
    pub(crate) world: AnyWorld,
    pub(crate) meta: Meta,
    /// Set when the engine panicked in a step: the world may be half stepped.
    pub(crate) broken: Option<String>,
}

/// A particle system built from a scene, stepped in time.
///
/// Make one with `carom.load(path)`, `carom.from_toml(text)`, `carom.preset(name)` or
/// `carom.resume(checkpoint_path)`. Units are the scene's own (carom has none of its own):
/// lengths as the scene's positions and radii, time as its `dt`, mass as its masses.
///
/// Arrays are copies in id order (the order of the scene's particles, explicit ones first,
/// then each fill), float64 unless said otherwise. Changing them changes nothing in the world:
/// use `set_velocities`.
///
/// A world may be used from any thread, one at a time: while `step` runs (without the GIL),
/// any other use of the same world from another thread raises RuntimeError.
#[pyclass(frozen, module = "carom")]
pub(crate) struct World {
    state: Mutex<State>,
}

impl World {
    pub(crate) fn new(world: AnyWorld, meta: Meta) -> Self {
        World {
            state: Mutex::new(State {
                world,
                meta,
                broken: None,
            }),
        }
    }

    /// The state, or why it cannot be had: another thread is stepping the world, or a step
    /// failed inside the engine.
    pub(crate) fn lock(&self) -> PyResult<MutexGuard<'_, State>> {
        let guard = match self.state.try_lock() {
            Ok(guard) => guard,
            Err(TryLockError::WouldBlock) => {
                return Err(PyRuntimeError::new_err(
                    "this World is busy: another thread is stepping it (or writing it to a \
                     file) without the GIL; use it once that call has returned",
                ))
            }
            Err(TryLockError::Poisoned(poisoned)) => poisoned.into_inner(),
        };
        if let Some(why) = &guard.broken {
            return Err(PyRuntimeError::new_err(format!(
                "this World can no longer be used: a step failed inside the engine ({why}); \
                 please report it with the scene"
            )));
        }
        Ok(guard)
    }
}

/// Builds the world of `text` (from `origin`) as `carom run` does.
pub(crate) fn build(py: Python<'_>, text: String, origin: String) -> PyResult<World> {
    // (the fill places its particles on the pool)
    start_threads()?;
    let scene = carom_scene::parse(&text, &origin)
        .map_err(|e| scene_error(py, e.to_string(), &e.origin, e.field.as_deref()))?;
    let (name, steps) = match &scene {
        carom_scene::AnyScene::Two(s) => (s.name.clone(), s.steps),
        carom_scene::AnyScene::Three(s) => (s.name.clone(), s.steps),
    };
    let built = match scene {
        carom_scene::AnyScene::Two(s) => s.into_world().map(AnyWorld::Two),
        carom_scene::AnyScene::Three(s) => s.into_world().map(AnyWorld::Three),
    };
    let world = built.map_err(|e| scene_error(py, format!("{origin}: {e}"), &origin, None))?;
    Ok(World::new(
        world,
        Meta {
            scene_toml: text,
            origin,
            name,
            settings: RunSettings {
                steps,
                broadphase: None,
                cells: None,
            },
        },
    ))
}

/// What a call of `World.step(n)` saw, summed over its steps as `carom run`'s summary sums
/// them.
#[derive(Debug, Default)]
pub(crate) struct Seen {
    steps: u64,
    capped_steps: u64,
    retaken_steps: u64,
    collisions: u64,
    /// The deepest overlap of any state the steps passed through (each step's own contacts
    /// at its end, every pair found at its start), a fraction of the smaller radius.
    max_overlap: f64,
    /// Particles asleep in the last step.
    asleep: usize,
    /// Pairs that pushed each other in the last step (see `StepStats::pushing`).
    pushing: usize,
}

impl Seen {
    fn record(&mut self, stats: &carom_engine::StepStats) {
        self.steps += 1;
        self.capped_steps += stats.capped as u64;
        self.retaken_steps += (stats.retakes > 0) as u64;
        self.collisions += stats.collisions;
        self.max_overlap = self.max_overlap.max(stats.deepest_seen());
        self.asleep = stats.asleep;
        self.pushing = stats.pushing;
    }

    /// As a dict for Python.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("steps", self.steps)?;
        d.set_item("capped_steps", self.capped_steps)?;
        d.set_item("retaken_steps", self.retaken_steps)?;
        d.set_item("collisions", self.collisions)?;
        d.set_item("max_overlap", self.max_overlap)?;
        d.set_item("asleep", self.asleep)?;
        d.set_item("pushing", self.pushing)?;
        Ok(d)
    }
}

/// Steps `world` until `left` is 0 or [`CHUNK`] has passed, on the rayon pool as `carom run`
/// steps (see `Stepper::run_loop` in the CLI), recording what each step saw in `seen`.
pub(crate) fn run_chunk(world: &mut AnyWorld, left: &mut u64, seen: &mut Seen) {
    rayon::scope(|_| {
        let started = Instant::now();
        while *left > 0 {
            let stats = with_world!(&mut *world, w => w.step());
            seen.record(&stats);
            *left -= 1;
            if started.elapsed() >= CHUNK {
                break;
            }
        }
    });
}

/// A checkpoint of `world`, as `carom run --checkpoint` writes it.
pub(crate) fn checkpoint_of<V: Vector>(
    world: &carom_engine::World<V>,
    meta: &Meta,
) -> Result<Checkpoint, String> {
    let settings_json = serde_json::to_string(&meta.settings).map_err(|e| e.to_string())?;
    Ok(Checkpoint::of_world(
        world,
        meta.scene_toml.clone(),
        meta.origin.clone(),
        settings_json,
    ))
}

/// The world a checkpoint holds, as `carom resume` rebuilds it; errors as the CLI words them
/// (after `shown: `).
pub(crate) fn resumed<V: Vector>(
    mut scene: carom_scene::Scene<V>,
    cp: &Checkpoint,
    settings: &RunSettings,
) -> Result<carom_engine::World<V>, String> {
    if cp.dimensions as usize != V::DIM {
        return Err("damaged checkpoint: dimensions disagree with its scene".into());
    }
    carom_scene::check_stored_steps(cp.steps_taken, settings.steps)
        .map_err(|e| format!("damaged checkpoint: {e}"))?;
    (settings.apply_to(&mut scene)).map_err(|e| format!("damaged run settings: {e}"))?;
    scene.particles = cp.particles().map_err(|e| e.to_string())?;
    carom_scene::check_state(&scene.particles)
        .and_then(|()| carom_scene::check_remembered(&cp.contact_impulses(), &cp.tally))
        .map_err(|e| format!("damaged checkpoint: {e}"))?;
    scene
        .into_resumed_world(
            cp.steps_taken,
            cp.storage_order.clone(),
            cp.contact_impulses(),
            cp.tally,
        )
        .map_err(|e| e.to_string())
}

#[pymethods]
impl World {
    /// Advance the world by `n` time steps (`n * dt` time units), as `carom run` does.
    ///
    /// `n`: an int >= 0 (not a bool), and at most 10^12 steps in all, the limit of
    /// `carom run --steps`; ValueError otherwise. So is a `RAYON_NUM_THREADS` above the
    /// limit `carom` refuses it at (8 per core, at least 64).
    ///
    /// The GIL is released while the engine works, so other Python threads run meanwhile.
    /// In the main thread, Ctrl-C (KeyboardInterrupt, or any exception a signal handler
    /// raises) stops the loop between two steps, within 50 ms or one step: the exception
    /// propagates and the world is left at a whole step (`steps` says which), ready to step
    /// on or to checkpoint.
    ///
    /// Returns what the steps saw, as `carom run`'s summary sums it: a dict with `steps`
    /// (int), `capped_steps` (int: steps whose velocity sweeps stopped at their cap),
    /// `retaken_steps` (int: steps taken again because a push drove a particle beyond its
    /// reach), `collisions` (int: particle-particle impacts), `max_overlap` (the deepest
    /// overlap, a fraction of the smaller radius, over every pair of each state a step started
    /// from and the last step's own contacts at its end: a pair the last step's collisions
    /// pushed together from beyond its contacts is in `deepest_overlap()`, which searches every
    /// pair of the state as it is), `asleep` (int: particles asleep in the
    /// last step) and `pushing` (int: particle pairs that pushed each other in the last step,
    /// impacts and contacts carrying weight, overlapping or a hair apart).
    #[pyo3(signature = (n = None), text_signature = "($self, n=1)")]
    fn step<'py>(
        &self,
        py: Python<'py>,
        n: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let n: i64 = match n {
            None => 1,
            // (a bool is an int to Python: `step(True)` is a slip, not a count)
            Some(n) if n.is_instance_of::<PyBool>() => {
                return Err(PyTypeError::new_err(
                    "n: the number of steps must be an int, got a bool",
                ));
            }
            Some(n) => n.extract()?,
        };
        if n < 0 {
            return Err(PyValueError::new_err(format!(
                "n: the number of steps must be >= 0, got {n}"
            )));
        }
        start_threads()?;
        let mut guard = self.lock()?;
        let state: &mut State = &mut guard;
        let taken = with_world!(&state.world, w => w.steps_taken());
        let limit = carom_scene::MAX_STEPS;
        if taken.saturating_add(n as u64) > limit {
            return Err(PyValueError::new_err(format!(
                "n: {n} steps from step {taken} go past the limit of {limit} steps (that of \
                 `carom run --steps`)"
            )));
        }
        let mut left = n as u64;
        let mut seen = Seen::default();
        while left > 0 {
            let world = &mut state.world;
            let (left_ref, seen_ref) = (&mut left, &mut seen);
            let outcome = py
                .detach(|| catch_unwind(AssertUnwindSafe(|| run_chunk(world, left_ref, seen_ref))));
            if let Err(payload) = outcome {
                let why = panic_text(&*payload);
                state.broken = Some(why.clone());
                return Err(PyRuntimeError::new_err(format!(
                    "a step failed inside the engine: {why}"
                )));
            }
            if left > 0 {
                // Between two whole steps: a KeyboardInterrupt leaves the world here.
                py.check_signals()?;
            }
        }
        seen.to_dict(py)
    }

    /// Particle positions: float64 array of shape (N, d), in id order (length units).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let state = self.lock()?;
        with_world!(&state.world, w => vectors(py, w.particles().positions()))
    }

    /// Particle velocities: float64 array of shape (N, d), in id order (length per time unit).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let state = self.lock()?;
        with_world!(&state.world, w => vectors(py, w.particles().velocities()))
    }

    /// Particle radii: float64 array of shape (N,), in id order (length units).
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let state = self.lock()?;
        let radii = with_world!(&state.world, w => w.particles().radii().to_vec());
        Ok(PyArray1::from_vec(py, radii))
    }

    /// Particle masses: float64 array of shape (N,), in id order (mass units).
    #[getter]
    fn masses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let state = self.lock()?;
        let masses = with_world!(&state.world, w => w.particles().masses().to_vec());
        Ok(PyArray1::from_vec(py, masses))
    }

    /// Simulated time so far, `steps * dt` (time units).
    #[getter]
    fn time(&self) -> PyResult<f64> {
        let state = self.lock()?;
        Ok(with_world!(&state.world, w => w.time()))
    }

    /// Steps taken so far (int; a resumed world counts the steps before its checkpoint).
    #[getter]
    fn steps(&self) -> PyResult<u64> {
        let state = self.lock()?;
        Ok(with_world!(&state.world, w => w.steps_taken()))
    }

    /// 2 or 3.
    #[getter]
    fn dimensions(&self) -> PyResult<usize> {
        let state = self.lock()?;
        Ok(state.world.dimensions())
    }

    /// The time step `dt` (time units).
    #[getter]
    fn dt(&self) -> PyResult<f64> {
        let state = self.lock()?;
        Ok(with_world!(&state.world, w => w.config().dt))
    }

    /// The scene's `name`, or None.
    #[getter]
    fn name(&self) -> PyResult<Option<String>> {
        Ok(self.lock()?.meta.name.clone())
    }

    /// Where the scene came from: its path as given to `load`, `preset:NAME`, or `<string>`.
    #[getter]
    fn origin(&self) -> PyResult<String> {
        Ok(self.lock()?.meta.origin.clone())
    }

    /// The run's total steps: the scene's `steps` (what `carom run` runs when given no
    /// `--steps`), or for a resumed world the total of the run that wrote the checkpoint.
    /// `carom resume` continues a checkpoint of this world to it.
    #[getter]
    fn scene_steps(&self) -> PyResult<u64> {
        Ok(self.lock()?.meta.settings.steps)
    }

    fn __len__(&self) -> PyResult<usize> {
        let state = self.lock()?;
        Ok(with_world!(&state.world, w => w.len()))
    }

    fn __repr__(&self) -> String {
        let state = match self.lock() {
            Ok(state) => state,
            Err(_) => return "<carom.World (busy or unusable)>".to_string(),
        };
        let dim = state.world.dimensions();
        let (n, steps, time, dt, broad) = with_world!(&state.world, w => (
            w.len(),
            w.steps_taken(),
            w.time(),
            w.config().dt,
            w.broad_phase_name(),
        ));
        let name = match &state.meta.name {
            Some(name) => format!("{name:?} "),
            None => String::new(),
        };
        format!(
            "<carom.World {name}[{}]: {dim}D, {n} particles, step {steps}, time {time}, \
             dt {dt}, {broad} broad phase>",
            state.meta.origin
        )
    }

    /// Total kinetic energy `sum m |v|^2 / 2`, summed in id order (mass x length^2 / time^2).
    fn kinetic_energy(&self) -> PyResult<f64> {
        let state = self.lock()?;
        Ok(with_world!(&state.world, w => w.kinetic_energy()))
    }

    /// Gravitational potential energy `sum -m g . x` (zero at the origin), in id order.
    fn potential_energy(&self) -> PyResult<f64> {
        let state = self.lock()?;
        Ok(with_world!(&state.world, w => w.potential_energy()))
    }

    /// Total momentum `sum m v`: float64 array of shape (d,), summed in id order
    /// (mass x length / time).
    fn momentum<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let state = self.lock()?;
        Ok(with_world!(&state.world, w => vector(py, w.momentum())))
    }

    /// The last step's touching pairs: int64 array of shape (M, 2), ids `a < b`, sorted.
    ///
    /// These are the pairs the lecture's detection finds overlapping (`distance < r1 + r2`)
    /// at the start of the step's velocity phase; empty before the first step. Pairs of sleeping
    /// particles (at rest, see the README's notes on sleep) are the remembered resting
    /// contacts that overlap.
    fn contacts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let state = self.lock()?;
        let flat: Vec<i64> = with_world!(&state.world, w => w
            .contacts()
            .iter()
            .flat_map(|&(a, b)| [a as i64, b as i64])
            .collect());
        let m = flat.len() / 2;
        let array = Array2::from_shape_vec((m, 2), flat)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(array.into_pyarray(py))
    }

    /// The deepest particle-particle overlap in the state as it is, over every pair, as a
    /// fraction of the smaller radius (0.0 when nothing overlaps): `(r_a + r_b - |x_a - x_b|)
    /// / min(r_a, r_b)`, by a search of its own. The figure `carom run` prints "at the end".
    /// (A step measures its overlap over its own contact candidates only; see `observe`.)
    fn deepest_overlap(&self) -> PyResult<f64> {
        let mut state = self.lock()?;
        Ok(with_world!(&mut state.world, w => w.deepest_overlap()))
    }

    /// One reading of the observables, as a row of `carom run --observe FILE --every K`.
    ///
    /// A dict with `step` (int), `time`, `kinetic_energy`, `potential_energy`, `temperature`
    /// (granular, `sum m |v - u|^2 / (d N)`, energy units), `collisions` (int: particle-
    /// particle impacts since the first reading), `pressure` (kinetic plus collisional
    /// virial, averaged over the interval since the previous reading; NaN without a domain)
    /// and `max_overlap` (the deepest overlap at this step over every pair, a fraction of the
    /// smaller radius: `deepest_overlap()`).
    ///
    /// Each call closes the pressure's interval and the first one starts the counts: calling
    /// it at step 0 and after every `step(K)` gives the CLI's rows, bit for bit.
    fn observe<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let mut state = self.lock()?;
        let reading = with_world!(&mut state.world, w => w.observe());
        observables(py, &reading)
    }

    /// Replace every particle's velocity (length per time unit).
    ///
    /// `velocities`: array-like of shape (N, d), in id order, every value finite; read as
    /// float64. Raises ValueError naming the problem (shape, or the first particle that is not
    /// finite) and then changes nothing. Particles given a velocity wake up (see the sleep
    /// notes in the README), as with the viewer's pushes.
    fn set_velocities(&self, py: Python<'_>, velocities: &Bound<'_, PyAny>) -> PyResult<()> {
        let numpy = py.import("numpy")?;
        // (numbers only: numpy would read complex numbers, dates, bools and strings as floats)
        let kind: String = numpy
            .call_method1("asarray", (velocities,))
            .and_then(|a| a.getattr("dtype")?.getattr("kind")?.extract())
            .unwrap_or_else(|_| "f".into());
        if !matches!(kind.as_str(), "f" | "i" | "u") {
            return Err(PyValueError::new_err(format!(
                "velocities: must be real numbers (float or int), got an array of numpy kind \
                 '{kind}'"
            )));
        }
        let kwargs = PyDict::new(py);
        kwargs.set_item("dtype", numpy.getattr("float64")?)?;
        let array = numpy
            .call_method("asarray", (velocities,), Some(&kwargs))
            .map_err(|e| {
                PyValueError::new_err(format!(
                    "velocities: cannot be read as an array of float64 numbers: {}",
                    e.value(py)
                ))
            })?;
        let array = array
            .cast_into::<numpy::PyArrayDyn<f64>>()
            .map_err(|_| PyValueError::new_err("velocities: not a float64 array"))?;
        let mut state = self.lock()?;
        let (n, d) = (
            with_world!(&state.world, w => w.len()),
            state.world.dimensions(),
        );
        let shape = array.shape().to_vec();
        if shape != [n, d] {
            let shown: Vec<String> = shape.iter().map(|s| s.to_string()).collect();
            let shown = if shown.len() == 1 {
                format!("({},)", shown[0])
            } else {
                format!("({})", shown.join(", "))
            };
            return Err(PyValueError::new_err(format!(
                "velocities: needs shape ({n}, {d}) (one row of {d} components per particle), \
                 got {shown}"
            )));
        }
        let readonly = array.readonly();
        let values = readonly.as_array();
        let rows: Vec<Vec<f64>> = values
            .outer_iter()
            .map(|r| r.iter().copied().collect())
            .collect();
        if let Some((id, row)) = rows
            .iter()
            .enumerate()
            .find(|(_, r)| r.iter().any(|x| !x.is_finite()))
        {
            return Err(PyValueError::new_err(format!(
                "velocities: must be finite; row {id} (particle {id}) is {row:?}"
            )));
        }
        let most = carom_scene::MAX_MAGNITUDE;
        if let Some((id, row)) =
            (rows.iter().enumerate()).find(|(_, r)| r.iter().any(|x| x.abs() > most))
        {
            return Err(PyValueError::new_err(format!(
                "velocities: row {id} (particle {id}) is {row:?}, beyond carom's range of {most:e} \
                 a component (a scene's velocities keep to it too)"
            )));
        }
        let result = with_world!(&mut state.world, w => {
            let mut result = Ok(());
            for (id, row) in rows.iter().enumerate() {
                if let Err(e) = w.set_velocity(id, Vector::from_slice(row)) {
                    result = Err(e);
                    break;
                }
            }
            result
        });
        result.map_err(|e| PyValueError::new_err(format!("velocities: {e}")))
    }

    /// Write the state as CSV, as `carom run --out PATH` does: `id,x,y,vx,vy,radius,mass`
    /// (3D: with z and vz), one row per particle in id order, every number in its shortest
    /// form that reads back to the same float64.
    ///
    /// The file is written whole or not at all (a temporary in the same folder, renamed over
    /// `path`). Raises OSError (FileNotFoundError for a missing folder) if it cannot be.
    fn write_csv(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        check_output_path(&path)?;
        let mut guard = self.lock()?;
        let state: &mut State = &mut guard;
        check_not_the_scene(&path, &state.meta)?;
        let target = path.clone();
        let world = &mut state.world;
        py.detach(move || {
            with_world!(&*world, w => carom_output::write_atomic(&target, |out| {
                carom_output::write_state_csv(w.particles(), out)
            }))
        })
        .map_err(|e| os_error("cannot write", &e, &path))
    }

    /// Write a checkpoint, as `carom run --checkpoint PATH` does: the complete state, from
    /// which `carom.resume(path)` or `carom resume PATH` continues bit for bit.
    ///
    /// It keeps the scene's text and origin, and the scene's `steps` as the run's total (what
    /// `carom resume` without `--steps` continues to). Written whole or not at all; OSError if
    /// it cannot be.
    fn checkpoint(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        check_output_path(&path)?;
        let mut guard = self.lock()?;
        let state: &mut State = &mut guard;
        check_not_the_scene(&path, &state.meta)?;
        let cp = with_world!(&state.world, w => checkpoint_of(w, &state.meta))
            .map_err(PyRuntimeError::new_err)?;
        let target = path.clone();
        py.detach(move || carom_output::write_atomic(&target, |out| cp.write_to(out)))
            .map_err(|e| os_error("cannot write checkpoint", &e, &path))
    }
}

/// Refuses an output `path` that is the scene file the world was read from (what `carom run`
/// refuses for its outputs).
fn check_not_the_scene(path: &std::path::Path, meta: &Meta) -> PyResult<()> {
    let scene = std::path::Path::new(&meta.origin);
    if scene.is_file() && carom_output::same_file(path, scene) {
        return Err(PyValueError::new_err(format!(
            "cannot write {}: it is the scene file this world was read from, which this would \
             overwrite",
            path.display()
        )));
    }
    Ok(())
}

/// Refuses a `RAYON_NUM_THREADS` above the limit `carom` refuses it at (see
/// `carom_scene::machine::thread_limit`), then starts the thread pool if it is not running
/// (ValueError; RuntimeError when the machine cannot start the threads, which would otherwise
/// panic inside the first parallel phase): before a fill or a step can start them.
pub(crate) fn start_threads() -> PyResult<()> {
    let limit = carom_scene::machine::thread_limit();
    match carom_scene::machine::threads_from_environment() {
        Some(n) if n > limit => Err(PyValueError::new_err(format!(
            "RAYON_NUM_THREADS: {n} is more than the limit of {limit} on this machine (8 per \
             core, at least 64)"
        ))),
        _ => carom_scene::machine::start_thread_pool(None).map_err(PyRuntimeError::new_err),
    }
}
