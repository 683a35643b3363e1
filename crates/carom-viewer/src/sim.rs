//! The simulation thread: owns the world, steps it, and publishes snapshots for the UI. The UI
//! only sends [`Command`]s and reads the latest [`Snapshot`], so it never waits for a step, a
//! rebuild or a scene fill.

use crate::control::{BroadPhaseChoice, Params};
use carom_engine::glam::{DVec2, DVec3};
use carom_engine::{Pair, Vector, World};
use carom_scene::{AnyScene, Scene};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Requests from the UI.
#[derive(Debug)]
pub enum Command {
    /// Run (true) or pause.
    Play(bool),
    /// One step (while paused).
    Step,
    /// Steps taken per published frame.
    StepsPerFrame(u32),
    /// New restitution, gravity, dt.
    Params(Params),
    /// New broad phase: the world is rebuilt around its current particles.
    BroadPhase(BroadPhaseChoice),
    /// Back to the scene's start (with the current parameters and broad phase).
    Reset,
    /// A new scene (TOML text, its origin for messages); replaces the one Reset returns to.
    Load(String, String),
    /// Stop the thread.
    Quit,
}

/// The world as the UI draws it, in id order. 2D scenes have z = 0.
#[derive(Clone, Debug, Default)]
pub struct Snapshot {
    /// 2 or 3.
    pub dims: usize,
    /// Bumped by every rebuild: the UI restarts its plots and selection.
    pub generation: u64,
    /// Scene name (or origin).
    pub name: String,
    /// Positions.
    pub positions: Vec<DVec3>,
    /// Velocities.
    pub velocities: Vec<DVec3>,
    /// Radii.
    pub radii: Vec<f64>,
    /// Overlapping pairs of the last step (ids).
    pub contacts: Vec<Pair>,
    /// Planes as (point, unit normal), domain walls included.
    pub planes: Vec<(DVec3, DVec3)>,
    /// The domain box.
    pub domain: Option<(DVec3, DVec3)>,
    /// Broad phase name.
    pub broad_phase: &'static str,
    /// Grid cells in use (grid broad phase, after a step).
    pub grid_cells: Option<[usize; 3]>,
    /// Steps taken.
    pub steps: u64,
    /// Simulated time.
    pub time: f64,
    /// Wall milliseconds per step over the last batch (0 before any).
    pub ms_per_step: f64,
    /// Kinetic energy.
    pub kinetic: f64,
    /// Kinetic plus potential energy.
    pub total_energy: f64,
    /// Momentum.
    pub momentum: DVec3,
    /// The parameters the world runs with.
    pub params: Option<Params>,
    /// Broad phase and cells the world was built with.
    pub broad_phase_choice: Option<BroadPhaseChoice>,
}

/// What the UI reads.
#[derive(Debug, Default)]
pub struct Shared {
    /// The latest snapshot.
    pub snapshot: Arc<Snapshot>,
    /// Bumped by every publish.
    pub seq: u64,
    /// The last refusal (bad value, bad scene), cleared by the next success.
    pub error: Option<String>,
    /// True while a scene is being built.
    pub busy: bool,
    /// True while running.
    pub playing: bool,
    /// The last `seq` the UI has drawn: the thread waits for it before stepping on, so that
    /// "steps per frame" holds and the UI always gets its share of the cores.
    pub drawn: u64,
}

/// Handle to the simulation thread.
pub struct Sim {
    tx: Sender<Command>,
    /// Shared state.
    pub shared: Arc<Mutex<Shared>>,
    thread: Option<JoinHandle<()>>,
}

impl Sim {
    /// Starts the thread with a scene (TOML text) and whether to run at once.
    pub fn start(text: String, origin: String, playing: bool) -> Self {
        let (tx, rx) = mpsc::channel();
        let shared = Arc::new(Mutex::new(Shared::default()));
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("carom-sim".into())
            .spawn(move || {
                let report = s.clone();
                let run =
                    std::panic::AssertUnwindSafe(move || run_worker(s, playing, rx, text, origin));
                if let Err(panic) = std::panic::catch_unwind(run) {
                    let why = panic
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default();
                    let mut shared = report.lock().unwrap_or_else(|e| e.into_inner());
                    shared.error = Some(format!("the simulation stopped: {why}"));
                    shared.busy = false;
                    shared.playing = false;
                }
            })
            .expect("cannot start the simulation thread");
        Self {
            tx,
            shared,
            thread: Some(thread),
        }
    }

    /// Sends a command (ignored if the thread is gone).
    pub fn send(&self, c: Command) {
        let _ = self.tx.send(c);
    }

    /// Locks the shared state (a poisoned lock is still readable).
    pub fn lock(&self) -> std::sync::MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Runs the worker in a thread pool that leaves a core for drawing (the engine's results are
/// the same for any thread count).
fn run_worker(
    shared: Arc<Mutex<Shared>>,
    playing: bool,
    rx: Receiver<Command>,
    text: String,
    origin: String,
) {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .max(2)
        - 1;
    match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(pool) => pool.install(|| Worker::new(shared, playing).run(rx, text, origin)),
        Err(_) => Worker::new(shared, playing).run(rx, text, origin),
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        self.send(Command::Quit);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Why a rebuild did not go through entirely.
enum RebuildError {
    /// No world: the old one runs on.
    Build(String),
    /// Built, but some parameters were refused.
    Params(String),
}

impl std::fmt::Display for RebuildError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RebuildError::Build(e) | RebuildError::Params(e) => f.write_str(e),
        }
    }
}

/// One dimension's world plus the scene it came from.
struct Running<V: Vector> {
    scene: Scene<V>,
    world: World<V>,
}

enum AnyRunning {
    Two(Running<DVec2>),
    Three(Running<DVec3>),
}

fn to3<V: Vector>(v: V) -> DVec3 {
    DVec3::new(v.get(0), v.get(1), if V::DIM > 2 { v.get(2) } else { 0.0 })
}

impl<V: Vector> Running<V> {
    fn new(scene: Scene<V>) -> Result<Self, String> {
        let world = scene.build_world().map_err(|e| e.to_string())?;
        Ok(Self { scene, world })
    }

    /// Rebuilds the world from the scene (its start) or from the current particles, with
    /// `params` and `bp` applied.
    fn rebuild(
        &mut self,
        from_start: bool,
        params: &Params,
        bp: &BroadPhaseChoice,
    ) -> Result<(), RebuildError> {
        let mut scene = self.scene.clone();
        scene.config.broad_phase = bp.kind;
        scene.config.grid_cells = bp.cells.clone();
        if !from_start {
            scene.particles = self.world.particles().clone();
        }
        let mut world = scene
            .into_world()
            .map_err(|e| RebuildError::Build(e.to_string()))?;
        let errors = params.apply(&mut world);
        // keep the choice for the next reset even if this one failed later
        self.scene.config.broad_phase = bp.kind;
        self.scene.config.grid_cells = bp.cells.clone();
        self.world = world;
        if errors.is_empty() {
            Ok(())
        } else {
            Err(RebuildError::Params(errors.join("; ")))
        }
    }

    fn snapshot(&self, generation: u64, name: &str, ms_per_step: f64) -> Snapshot {
        let w = &self.world;
        let p = w.particles();
        let c = w.config();
        Snapshot {
            dims: V::DIM,
            generation,
            name: name.to_string(),
            positions: p.positions().iter().map(|&x| to3(x)).collect(),
            velocities: p.velocities().iter().map(|&x| to3(x)).collect(),
            radii: p.radii().to_vec(),
            contacts: w.contacts().to_vec(),
            planes: w
                .planes()
                .iter()
                .map(|pl| (to3(pl.point()), to3(pl.normal())))
                .collect(),
            domain: c.domain.map(|d| (to3(d.min), to3(d.max))),
            broad_phase: w.broad_phase_name(),
            grid_cells: w.grid_cells(),
            steps: w.steps_taken(),
            time: w.time(),
            ms_per_step,
            kinetic: w.kinetic_energy(),
            total_energy: w.kinetic_energy() + w.potential_energy(),
            momentum: to3(w.momentum()),
            params: Some(Params::of(w)),
            broad_phase_choice: Some(BroadPhaseChoice {
                kind: c.broad_phase,
                cells: c.grid_cells.clone(),
            }),
        }
    }
}

struct Worker {
    shared: Arc<Mutex<Shared>>,
    playing: bool,
    steps_per_frame: u32,
    generation: u64,
    name: String,
    running: Option<AnyRunning>,
    params: Option<Params>,
    bp: Option<BroadPhaseChoice>,
}

/// Longest a batch of steps may take before the thread looks at its commands again.
const BATCH_BUDGET: Duration = Duration::from_millis(100);
/// Fastest publish rate.
const FRAME: Duration = Duration::from_micros(16_667);

macro_rules! with_running {
    ($r:expr, $x:ident => $body:expr) => {
        match $r {
            AnyRunning::Two($x) => $body,
            AnyRunning::Three($x) => $body,
        }
    };
}

impl Worker {
    fn new(shared: Arc<Mutex<Shared>>, playing: bool) -> Self {
        Self {
            shared,
            playing,
            steps_per_frame: 1,
            generation: 0,
            name: String::new(),
            running: None,
            params: None,
            bp: None,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn set_error(&self, e: Option<String>) {
        self.lock().error = e;
    }

    fn run(mut self, rx: Receiver<Command>, text: String, origin: String) {
        self.load(&text, &origin);
        loop {
            let started = Instant::now();
            // Commands: all that are waiting; while paused, wait for one.
            let mut step_once = false;
            let mut first = if self.playing {
                rx.try_recv().ok()
            } else {
                match rx.recv_timeout(Duration::from_millis(200)) {
                    Ok(c) => Some(c),
                    Err(RecvTimeoutError::Timeout) => None,
                    Err(RecvTimeoutError::Disconnected) => return,
                }
            };
            while let Some(c) = first.take().or_else(|| rx.try_recv().ok()) {
                match c {
                    Command::Quit => return,
                    Command::Play(p) => self.playing = p,
                    Command::Step => step_once = true,
                    Command::StepsPerFrame(n) => self.steps_per_frame = n.clamp(1, 10_000),
                    Command::Params(p) => self.set_params(p),
                    Command::BroadPhase(bp) => self.set_broad_phase(bp),
                    Command::Reset => self.reset(),
                    Command::Load(text, origin) => self.load(&text, &origin),
                }
                self.lock().playing = self.playing;
            }
            if self.playing || step_once {
                let n = if self.playing {
                    self.steps_per_frame
                } else {
                    1
                };
                self.steps(n);
                if self.playing {
                    self.wait_drawn(started);
                }
            }
        }
    }

    /// Waits (a frame at least, [`BATCH_BUDGET`] at most) until the UI has drawn the last
    /// snapshot.
    fn wait_drawn(&self, started: Instant) {
        loop {
            let spent = started.elapsed();
            let drawn = {
                let s = self.lock();
                s.drawn >= s.seq
            };
            if (drawn && spent >= FRAME) || spent >= BATCH_BUDGET {
                return;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    fn steps(&mut self, n: u32) {
        let Some(r) = self.running.as_mut() else {
            return;
        };
        let t = Instant::now();
        let mut done = 0u32;
        with_running!(r, r => {
            while done < n {
                r.world.step();
                done += 1;
                if t.elapsed() > BATCH_BUDGET {
                    break;
                }
            }
        });
        let ms = t.elapsed().as_secs_f64() * 1e3 / done.max(1) as f64;
        self.publish(ms);
    }

    fn publish(&self, ms_per_step: f64) {
        let Some(r) = self.running.as_ref() else {
            return;
        };
        let snap = with_running!(r, r => r.snapshot(self.generation, &self.name, ms_per_step));
        let mut s = self.lock();
        s.snapshot = Arc::new(snap);
        s.seq += 1;
        s.playing = self.playing;
    }

    fn load(&mut self, text: &str, origin: &str) {
        self.lock().busy = true;
        let result = carom_scene::parse(text, origin)
            .map_err(|e| e.to_string())
            .and_then(|scene| {
                let name = match &scene {
                    AnyScene::Two(s) => s.name.clone(),
                    AnyScene::Three(s) => s.name.clone(),
                };
                let running = match scene {
                    AnyScene::Two(s) => AnyRunning::Two(Running::new(s)?),
                    AnyScene::Three(s) => AnyRunning::Three(Running::new(s)?),
                };
                Ok((running, name.unwrap_or_else(|| origin.to_string())))
            });
        match result {
            Ok((running, name)) => {
                self.running = Some(running);
                self.name = name;
                self.params = None;
                self.bp = None;
                self.generation += 1;
                self.set_error(None);
                self.publish(0.0);
            }
            Err(e) => self.set_error(Some(e)),
        }
        self.lock().busy = false;
    }

    fn set_params(&mut self, p: Params) {
        let Some(r) = self.running.as_mut() else {
            return;
        };
        // remember what the world accepted (a refused value keeps the old one)
        let (errors, kept) = with_running!(r, r => (p.apply(&mut r.world), Params::of(&r.world)));
        self.params = Some(kept);
        self.set_error(if errors.is_empty() {
            None
        } else {
            Some(errors.join("; "))
        });
        self.publish(0.0);
    }

    fn current(&self) -> Option<(Params, BroadPhaseChoice)> {
        let r = self.running.as_ref()?;
        Some(with_running!(r, r => {
            let c = r.world.config();
            (
                self.params.unwrap_or_else(|| Params::of(&r.world)),
                self.bp.clone().unwrap_or(BroadPhaseChoice { kind: c.broad_phase, cells: c.grid_cells.clone() }),
            )
        }))
    }

    fn set_broad_phase(&mut self, bp: BroadPhaseChoice) {
        let Some((params, old)) = self.current() else {
            return;
        };
        self.bp = Some(bp.clone());
        if !self.rebuild(false, &params, &bp) {
            self.bp = Some(old);
        }
    }

    fn reset(&mut self) {
        let Some((params, bp)) = self.current() else {
            return;
        };
        self.rebuild(true, &params, &bp);
        self.generation += 1;
        self.publish(0.0);
    }

    /// False when the world could not be built (it then runs on unchanged).
    fn rebuild(&mut self, from_start: bool, params: &Params, bp: &BroadPhaseChoice) -> bool {
        let Some(r) = self.running.as_mut() else {
            return false;
        };
        let result = with_running!(r, r => r.rebuild(from_start, params, bp));
        let built = !matches!(result, Err(RebuildError::Build(_)));
        self.set_error(result.err().map(|e| e.to_string()));
        self.publish(0.0);
        built
    }
}

#[cfg(test)]
mod tests;
