//! Long runs that lose nothing: the step loop with trajectories, checkpoints and interrupts,
//! and `carom resume`.
//!
//! - Trajectory (`--trajectory PATH --every K`): one CSV, `step,time,id,...`, a frame at the
//!   start and every K steps, flushed frame by frame, so a killed run leaves every whole frame
//!   readable (only a last, partial frame can be cut). A `.pvd` path writes VTK instead: one
//!   `.vtp` per frame and the `.pvd` collection, each atomically (see [`vtk`]).
//! - Checkpoint (`--checkpoint PATH --checkpoint-every K`): the complete state, written
//!   atomically (temporary, fsync, rename); `carom resume PATH` continues bit for bit.
//! - Ctrl-C or SIGTERM: the current step finishes, a checkpoint is written (if asked for), the
//!   trajectory is flushed, and carom exits with status 130. A second one exits at once, also
//!   with status 130, and leaves no partial file: the temporaries of atomic writes under way
//!   are removed (their targets keep their previous, whole contents), a CSV trajectory is cut
//!   back to its last whole frame, and the writing thread is stopped before it can start or
//!   finish another file (see [`write_whole`]).

use crate::run::{check_output_path, Failure};
use carom_engine::{ContactImpulses, Observables, StepStats, Vector, World};
use carom_output::checkpoint::Checkpoint;
use indicatif::ProgressBar;
use observe::ObservationFile;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

pub mod observe;
pub mod soak;
pub mod vtk;

static STOP: AtomicBool = AtomicBool::new(false);

/// Set by a second interrupt, just before the process exits: from then on no file may be
/// started, finished or appended to.
static EXITING: AtomicBool = AtomicBool::new(false);

/// Exit status after an interrupt (128 + SIGINT), for the graceful stop and the immediate exit.
pub const INTERRUPTED: u8 = 130;

/// Routes Ctrl-C and SIGTERM to a graceful stop (first) or an immediate exit (second).
pub fn install_interrupt_handler() {
    let _ = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            quit_at_once();
        }
        if !QUIET.load(Ordering::SeqCst) {
            eprintln!(
                "carom: interrupted: stopping after this step and writing what was asked for \
                 (interrupt again to quit at once)"
            );
        }
    });
}

/// Set on the ranks of a split run other than rank 0: `mpirun` passes a Ctrl-C to every rank,
/// and one notice is enough.
static QUIET: AtomicBool = AtomicBool::new(false);

/// Keeps this process's interrupt notices to itself (see [`QUIET`]).
pub fn quiet_interrupts() {
    QUIET.store(true, Ordering::SeqCst);
}

/// The second interrupt: leave only whole files and exit with [`INTERRUPTED`].
fn quit_at_once() -> ! {
    EXITING.store(true, Ordering::SeqCst);
    // A write that registered its temporary before this loses it (and then fails to rename it,
    // or halts in `write_whole`); one that starts after this halts before writing a byte.
    carom_output::remove_in_flight_temporaries();
    // Held until the exit, so the CSV files get no further byte.
    let csv = csv_cut();
    for cut in csv.iter() {
        let _ = if cut.whole == 0 {
            std::fs::remove_file(&cut.path)
        } else {
            cut.file.set_len(cut.whole)
        };
    }
    eprintln!("carom: interrupted again: quitting at once; only whole files are left");
    std::process::exit(INTERRUPTED as i32);
}

/// Stops the calling thread for good once a second interrupt is exiting the process, after
/// removing the temporary it may have registered; returns at once otherwise.
fn halt_if_exiting() {
    if EXITING.load(Ordering::SeqCst) {
        carom_output::remove_in_flight_temporaries();
        loop {
            std::thread::park();
        }
    }
}

/// [`carom_output::write_atomic`] that a second interrupt cannot leave half done: the temporary
/// is registered before `write` runs, so either the exiting handler removes it (and the rename
/// fails), or the writer sees the exit coming and halts, removing it itself. A write the exit
/// made fail never reports its error: the thread halts until the process is gone.
pub(crate) fn write_whole<F>(path: &Path, write: F) -> std::io::Result<()>
where
    F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
{
    let result = carom_output::write_atomic(path, |w| {
        halt_if_exiting();
        write(w)
    });
    if result.is_err() {
        halt_if_exiting();
    }
    result
}

/// A CSV file being appended to (the trajectory, the observables) and the length of its whole
/// rows or frames, for a second interrupt to cut it back to.
struct CsvCut {
    path: PathBuf,
    file: std::fs::File,
    /// Bytes up to the end of the last whole frame (0: none yet, and the file is this run's).
    whole: u64,
}

/// Every CSV file this process appends to, by [`CsvFile::index`].
fn csv_cut() -> std::sync::MutexGuard<'static, Vec<CsvCut>> {
    static CSV: Mutex<Vec<CsvCut>> = Mutex::new(Vec::new());
    CSV.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A CSV file under its `BufWriter`: every write holds the [`csv_cut`] lock and none starts
/// once the process is exiting, so the cut sees no write half done.
pub(crate) struct CsvFile {
    file: std::fs::File,
    /// Length of the file after the last byte written.
    end: u64,
    /// Its place in [`csv_cut`].
    index: usize,
}

impl CsvFile {
    /// Opens `path` for appending rows: a fresh run (`fresh`) starts it empty, a resumed one
    /// appends to what is there.
    pub(crate) fn open(path: &Path, fresh: bool) -> std::io::Result<Self> {
        let file = std::fs::OpenOptions::new()
            .create(true)
            .write(true)
            .append(!fresh)
            .truncate(fresh)
            .open(path)?;
        let end = file.metadata()?.len();
        let mut cuts = csv_cut();
        cuts.push(CsvCut {
            path: path.to_path_buf(),
            file: file.try_clone()?,
            whole: end,
        });
        Ok(Self {
            file,
            end,
            index: cuts.len() - 1,
        })
    }

    /// Records that everything written so far (and flushed) ends in a whole frame or row.
    pub(crate) fn mark_whole(&self) {
        if let Some(cut) = csv_cut().get_mut(self.index) {
            cut.whole = self.end;
        }
    }
}

impl Write for CsvFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let guard = csv_cut();
        if EXITING.load(Ordering::SeqCst) {
            drop(guard);
            halt_if_exiting();
        }
        let n = self.file.write(buf)?;
        self.end += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

/// True once Ctrl-C or SIGTERM asked the run to stop.
pub fn stop_requested() -> bool {
    STOP.load(Ordering::SeqCst)
}

/// What the step loop drives: one [`World`], or this process's share of one split over ranks
/// ([`crate::cluster::Split`]). Under a split every method but `steps_taken` is collective:
/// all ranks call them at the same steps.
pub trait Stepper<V: Vector> {
    /// One step.
    fn step(&mut self) -> StepStats;
    /// Steps taken so far.
    fn steps_taken(&self) -> u64;
    /// The whole world as it is now, on the process that writes output (`None` on the others).
    fn world(&mut self) -> Option<&World<V>>;
    /// A reading of the observables (see [`World::observe`]), closing the pressure's interval;
    /// `None` where there is none to take (a split run, which refuses `--observe`).
    fn observe(&mut self) -> Option<Observables>;
    /// True once Ctrl-C or SIGTERM asked the run (any rank of it) to stop.
    fn stop_requested(&mut self) -> bool;
    /// Runs the step loop `work` where stepping is cheapest.
    fn run_loop(&mut self, work: impl FnOnce(&mut Self) + Send);
}

impl<V: Vector> Stepper<V> for World<V> {
    fn step(&mut self) -> StepStats {
        World::step(self)
    }
    fn steps_taken(&self) -> u64 {
        World::steps_taken(self)
    }
    fn world(&mut self) -> Option<&World<V>> {
        Some(self)
    }
    fn observe(&mut self) -> Option<Observables> {
        Some(World::observe(self))
    }
    fn stop_requested(&mut self) -> bool {
        stop_requested()
    }
    fn run_loop(&mut self, work: impl FnOnce(&mut Self) + Send) {
        // On a pool thread: parallel calls made from outside the pool go through rayon's
        // global queue, which allocates as it goes; from inside, stepping allocates nothing.
        rayon::scope(|_| work(self));
    }
}

/// Run settings a checkpoint must carry besides the scene text.
#[derive(serde::Serialize, serde::Deserialize, Debug, Clone, Default)]
pub struct Settings {
    /// Total steps of the run.
    pub steps: u64,
    /// `--broadphase` override, if any.
    pub broadphase: Option<String>,
    /// `--cells` override, if any.
    pub cells: Option<Vec<usize>>,
}

/// Where long-run output goes.
pub struct Outputs {
    pub checkpoint: Option<(PathBuf, u64)>,
    pub trajectory: Option<(PathBuf, u64)>,
    /// `--observe FILE --every K`.
    pub observe: Option<(PathBuf, u64)>,
    pub scene_toml: String,
    pub origin: String,
    pub settings: Settings,
}

impl Outputs {
    /// Checks the paths and intervals before any work.
    pub fn check(&self) -> Result<(), Failure> {
        if let Some((path, every)) = &self.checkpoint {
            check_output_path("--checkpoint", path)?;
            if *every == 0 {
                return Err(Failure::input("--checkpoint-every: must be at least 1"));
            }
        }
        for (flag, output) in [
            ("--trajectory", &self.trajectory),
            ("--observe", &self.observe),
        ] {
            if let Some((path, every)) = output {
                check_output_path(flag, path)?;
                if *every == 0 {
                    return Err(Failure::input("--every: must be at least 1"));
                }
            }
        }
        if let (Some((trajectory, _)), Some((observe, _))) = (&self.trajectory, &self.observe) {
            if trajectory == observe {
                return Err(Failure::input(
                    "--observe: the same file as --trajectory; give each its own",
                ));
            }
        }
        Ok(())
    }
}

/// What the loop saw.
#[derive(Default)]
pub struct Driven {
    pub seconds: f64,
    pub steps_run: u64,
    pub contacts_total: u64,
    pub contacts_max: usize,
    pub capped_steps: u64,
    /// Particle-particle collisions (see `carom_engine::observe`).
    pub collisions_total: u64,
    /// The deepest overlap left by the last step and by any step, as fractions of the smaller
    /// radius.
    pub last_overlap: f64,
    pub worst_overlap: f64,
    /// The last step that hit the velocity sweep cap.
    pub last_capped: Option<u64>,
    /// Particles asleep in the last step, and the step since which that many have been.
    pub asleep_last: usize,
    pub asleep_since: Option<u64>,
    /// The step at which an interrupt stopped the run.
    pub interrupted_at: Option<u64>,
}

fn trajectory_header(dim: usize) -> String {
    format!("step,time,{}", carom_output::csv_header(dim))
}

fn write_frame<V: Vector>(out: &mut impl Write, world: &World<V>) -> std::io::Result<()> {
    let (step, time) = (world.steps_taken(), world.time());
    for id in 0..world.len() {
        let (x, v, r, m) = world.particle(id);
        write!(out, "{step},{time},")?;
        carom_output::write_state_row(out, id, x, v, r, m)?;
    }
    out.flush()
}

/// A trajectory being written: CSV (appended, flushed frame by frame) or a VTK series.
enum Trajectory {
    Csv(BufWriter<CsvFile>),
    Vtk(vtk::Series),
}

impl Trajectory {
    /// Opens the trajectory at `path` (VTK for a `.pvd`, CSV otherwise); a fresh run starts it
    /// with the initial frame, a resumed one continues it.
    fn open<V: Vector>(path: &Path, world: &World<V>) -> Result<Self, Failure> {
        let io =
            |e: std::io::Error| Failure::runtime(format!("cannot write {}: {e}", path.display()));
        let fresh = world.steps_taken() == 0;
        if vtk::is_pvd(path) {
            let mut series = vtk::Series::open(path, world.steps_taken()).map_err(io)?;
            if fresh {
                series.frame(world).map_err(io)?;
            }
            return Ok(Trajectory::Vtk(series));
        }
        let file = CsvFile::open(path, fresh)
            .map_err(|e| Failure::runtime(format!("cannot open {}: {e}", path.display())))?;
        let mut w = BufWriter::with_capacity(1 << 16, file);
        if fresh {
            writeln!(w, "{}", trajectory_header(V::DIM)).map_err(io)?;
            write_frame(&mut w, world).map_err(io)?;
            w.get_ref().mark_whole();
        }
        Ok(Trajectory::Csv(w))
    }

    fn frame<V: Vector>(&mut self, world: &World<V>) -> std::io::Result<()> {
        match self {
            Trajectory::Csv(w) => {
                write_frame(w, world)?;
                w.get_ref().mark_whole();
                Ok(())
            }
            Trajectory::Vtk(series) => series.frame(world),
        }
    }
}

/// Writes a checkpoint of `world` atomically.
pub fn save_checkpoint<V: Vector>(
    path: &Path,
    world: &World<V>,
    outputs: &Outputs,
) -> Result<(), Failure> {
    let n = world.len();
    let mut cp = Checkpoint {
        dimensions: V::DIM as u32,
        steps_taken: world.steps_taken(),
        scene_toml: outputs.scene_toml.clone(),
        origin: outputs.origin.clone(),
        settings_json: serde_json::to_string(&outputs.settings)
            .map_err(|e| Failure::runtime(e.to_string()))?,
        storage_order: world.storage_order().to_vec(),
        positions: Vec::with_capacity(n * V::DIM),
        velocities: Vec::with_capacity(n * V::DIM),
        radii: Vec::with_capacity(n),
        masses: Vec::with_capacity(n),
        pair_impulses: Vec::new(),
        plane_impulses: Vec::new(),
        rest: Vec::new(),
        tally: world.tally(),
    };
    let impulses = world.contact_impulses();
    (cp.pair_impulses, cp.plane_impulses, cp.rest) =
        (impulses.pairs, impulses.planes, impulses.rest);
    for id in 0..n {
        let (x, v, r, m) = world.particle(id);
        cp.positions.extend((0..V::DIM).map(|a| x.get(a)));
        cp.velocities.extend((0..V::DIM).map(|a| v.get(a)));
        cp.radii.push(r);
        cp.masses.push(m);
    }
    write_whole(path, |w| cp.write_to(w))
        .map_err(|e| Failure::runtime(format!("cannot write checkpoint {}: {e}", path.display())))
}

/// Steps until `total_steps`, writing trajectory frames and checkpoints, and stopping early
/// (after a whole step) on an interrupt.
pub fn drive<V: Vector, S: Stepper<V>>(
    stepper: &mut S,
    total_steps: u64,
    outputs: &Outputs,
    progress: &ProgressBar,
) -> Result<Driven, Failure> {
    let mut trajectory = match &outputs.trajectory {
        None => None,
        Some((path, every)) => match stepper.world() {
            Some(world) => Some((Trajectory::open(path, world)?, *every, path.clone())),
            None => None,
        },
    };
    let mut observations = match &outputs.observe {
        None => None,
        Some((path, every)) => {
            let fresh = stepper.steps_taken() == 0;
            let opened = ObservationFile::open(path, fresh).and_then(|mut file| {
                if fresh {
                    if let Some(reading) = stepper.observe() {
                        file.row(&reading)?;
                    }
                }
                Ok(file)
            });
            let file = opened
                .map_err(|e| Failure::runtime(format!("cannot write {}: {e}", path.display())))?;
            Some((file, *every))
        }
    };
    let mut driven = Driven::default();
    let started = Instant::now();
    let mut failure = None;
    stepper.run_loop(|stepper| {
        while stepper.steps_taken() < total_steps {
            let stats = stepper.step();
            driven.steps_run += 1;
            driven.contacts_total += stats.contacts as u64;
            driven.contacts_max = driven.contacts_max.max(stats.contacts);
            driven.capped_steps += stats.capped as u64;
            driven.collisions_total += stats.collisions;
            driven.last_overlap = stats.max_overlap;
            driven.worst_overlap = driven.worst_overlap.max(stats.max_overlap);
            let step = stepper.steps_taken();
            if stats.capped {
                driven.last_capped = Some(step);
            }
            if stats.asleep != driven.asleep_last || driven.asleep_since.is_none() {
                driven.asleep_since = (stats.asleep > 0).then_some(step);
            }
            driven.asleep_last = stats.asleep;
            if step % 64 == 0 {
                progress.set_position(step);
            }
            if let Some((_, every)) = &outputs.trajectory {
                if step % every == 0 {
                    if let (Some(world), Some((w, _, path))) = (stepper.world(), &mut trajectory) {
                        if let Err(e) = w.frame(world) {
                            failure = Some(Failure::runtime(format!(
                                "cannot write {}: {e}",
                                path.display()
                            )));
                            return;
                        }
                    }
                }
            }
            if let Some((file, every)) = &mut observations {
                if step % *every == 0 {
                    if let Some(reading) = stepper.observe() {
                        if let Err(e) = file.row(&reading) {
                            failure = Some(Failure::runtime(format!(
                                "cannot write {}: {e}",
                                file.path().display()
                            )));
                            return;
                        }
                    }
                }
            }
            if let Some((path, every)) = &outputs.checkpoint {
                if step % every == 0 {
                    if let Some(world) = stepper.world() {
                        if let Err(e) = save_checkpoint(path, world, outputs) {
                            failure = Some(e);
                            return;
                        }
                    }
                }
            }
            if step < total_steps && stepper.stop_requested() {
                driven.interrupted_at = Some(step);
                return;
            }
        }
    });
    driven.seconds = started.elapsed().as_secs_f64();
    if let Some(f) = failure {
        return Err(f);
    }
    if let Some(at) = driven.interrupted_at {
        if let Some((path, every)) = &outputs.checkpoint {
            if at % every != 0 {
                if let Some(world) = stepper.world() {
                    save_checkpoint(path, world, outputs)?;
                }
            }
        }
    }
    Ok(driven)
}

/// Options of `carom resume`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("framed").args(["trajectory", "observe"]).multiple(true)))]
pub struct ResumeArgs {
    /// A checkpoint written by `carom run --checkpoint`.
    pub checkpoint: PathBuf,
    /// Total steps to reach (default: the original run's).
    #[arg(long)]
    pub steps: Option<u64>,
    /// Write the final state here as CSV.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Keep checkpointing (to this file) every `--checkpoint-every` steps.
    #[arg(long, requires = "checkpoint_every")]
    pub checkpoint_to: Option<PathBuf>,
    /// Steps between checkpoints.
    #[arg(long)]
    pub checkpoint_every: Option<u64>,
    /// Append trajectory frames to this CSV (or VTK series, for a `.pvd`) every `--every` steps.
    #[arg(long, requires = "every")]
    pub trajectory: Option<PathBuf>,
    /// Append the observables to this CSV every `--every` steps (see `carom run --observe`).
    #[arg(long, requires = "every")]
    pub observe: Option<PathBuf>,
    /// Steps between trajectory frames and observables rows.
    #[arg(long, requires = "framed")]
    pub every: Option<u64>,
    /// Worker threads.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Split the continued run over N ranks, as threads (see `carom run --ranks`); under
    /// `mpirun` the run is split over its processes anyway.
    #[arg(long)]
    pub ranks: Option<usize>,
}

/// `carom resume`.
pub fn resume(args: &ResumeArgs) -> Result<(), Failure> {
    crate::run::set_threads(args.threads)?;
    let shown = args.checkpoint.display().to_string();
    let bytes = std::fs::read(&args.checkpoint)
        .map_err(|e| Failure::input(format!("{shown}: cannot read checkpoint: {e}")))?;
    let cp = Checkpoint::read_from(&bytes).map_err(|e| Failure::input(format!("{shown}: {e}")))?;
    let settings: Settings = serde_json::from_str(&cp.settings_json)
        .map_err(|e| Failure::input(format!("{shown}: damaged run settings: {e}")))?;
    let outputs = Outputs {
        checkpoint: args.checkpoint_to.clone().zip(args.checkpoint_every),
        trajectory: args.trajectory.clone().zip(args.every),
        observe: args.observe.clone().zip(args.every),
        scene_toml: cp.scene_toml.clone(),
        origin: cp.origin.clone(),
        settings: Settings {
            steps: args.steps.unwrap_or(settings.steps),
            ..settings.clone()
        },
    };
    outputs.check()?;
    if let Some(out) = &args.out {
        check_output_path("--out", out)?;
    }
    let scene = carom_scene::parse(&cp.scene_toml, &cp.origin)
        .map_err(|e| Failure::input(format!("{shown}: {e}")))?;
    match scene {
        carom_scene::AnyScene::Two(s) => resume_scene(s, &cp, &settings, &outputs, args),
        carom_scene::AnyScene::Three(s) => resume_scene(s, &cp, &settings, &outputs, args),
    }
}

fn resume_scene<V: Vector>(
    mut scene: carom_scene::Scene<V>,
    cp: &Checkpoint,
    settings: &Settings,
    outputs: &Outputs,
    args: &ResumeArgs,
) -> Result<(), Failure> {
    let shown = args.checkpoint.display().to_string();
    if cp.dimensions as usize != V::DIM {
        return Err(Failure::input(format!(
            "{shown}: damaged checkpoint: dimensions disagree with its scene"
        )));
    }
    crate::run::apply_overrides(
        &mut scene,
        settings.broadphase.as_deref(),
        settings.cells.as_deref(),
    )?;
    let mut particles = carom_engine::Particles::new();
    for id in 0..cp.radii.len() {
        let d = V::DIM;
        particles
            .push(
                V::from_slice(&cp.positions[id * d..id * d + d]),
                V::from_slice(&cp.velocities[id * d..id * d + d]),
                cp.radii[id],
                cp.masses[id],
            )
            .map_err(|e| Failure::input(format!("{shown}: {e}")))?;
    }
    scene.particles = particles;
    let name = scene.name.clone();
    let rebuild = || {
        scene
            .clone()
            .into_resumed_world(
                cp.steps_taken,
                cp.storage_order.clone(),
                ContactImpulses {
                    pairs: cp.pair_impulses.clone(),
                    planes: cp.plane_impulses.clone(),
                    rest: cp.rest.clone(),
                },
                cp.tally,
            )
            .map_err(|e| Failure::input(format!("{shown}: {e}")))
    };
    let world = rebuild()?;
    let run = crate::run::Labels {
        name: name.as_deref(),
        origin: &shown,
        out: args.out.as_deref(),
    };
    crate::run::run_world(
        world,
        &rebuild,
        args.ranks,
        outputs.settings.steps,
        outputs,
        &run,
    )
}
