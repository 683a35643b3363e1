//! The step loop of `carom run` and `carom resume`: steps to the total, writing trajectory
//! frames, observables rows and checkpoints on their intervals, and stopping after a whole step
//! on an interrupt.
//!
//! - Trajectory (`--trajectory PATH --every K`): one CSV, `step,time,id,...`, a frame at the
//!   start and every K steps, flushed frame by frame, so a killed run leaves every whole frame
//!   readable (only a last, partial frame can be cut). A `.pvd` path writes VTK instead: one
//!   `.vtp` per frame and the `.pvd` collection (see [`carom_output::vtk`]).
//! - Checkpoint (`--checkpoint PATH --checkpoint-every K`): the complete state, written
//!   atomically (temporary, fsync, rename); `carom resume PATH` continues bit for bit.

use super::interrupt::{stop_requested, write_whole, CsvFile, Guarded};
use crate::failure::Failure;
use crate::input::check_output_path;
use carom_engine::{Observables, StepStats, Vector, World};
use carom_output::checkpoint::Checkpoint;
use carom_output::observables::ObservablesCsv;
use carom_output::trajectory::CsvTrajectory;
use carom_output::vtk;
use carom_scene::RunSettings;
use indicatif::ProgressBar;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What the step loop drives: one [`World`], or this process's share of one split over ranks
/// ([`crate::cluster::Split`]). Under a split every method but `steps_taken` is collective:
/// all ranks call them at the same steps.
pub trait Stepper<V: Vector> {
    /// One step.
    fn step(&mut self) -> StepStats;
    /// Steps taken so far.
    fn steps_taken(&self) -> u64;
    /// The whole world as it is now, on the process that writes output (`None` on the others).
    fn world(&mut self) -> Option<&mut World<V>>;
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
    fn world(&mut self) -> Option<&mut World<V>> {
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

/// Where long-run output goes.
pub struct Outputs {
    pub checkpoint: Option<(PathBuf, u64)>,
    pub trajectory: Option<(PathBuf, u64)>,
    /// `--observe FILE --every K`.
    pub observe: Option<(PathBuf, u64)>,
    pub scene_toml: String,
    pub origin: String,
    pub settings: RunSettings,
}

/// The folder a VTK trajectory (`.pvd`) writes its frames in (see [`vtk::Series`]); `None`
/// for a CSV trajectory.
pub fn frame_folder(trajectory: &Path) -> Option<PathBuf> {
    vtk::is_pvd(trajectory).then(|| trajectory.with_extension(""))
}

/// Every output of a run, `(flag, path)`, with the folder a VTK trajectory writes its frames
/// in (see [`frame_folder`]): what [`crate::input::check_distinct`] compares.
pub fn named_outputs<'a>(
    outputs: [(&'a str, Option<&'a Path>); 4],
    frames: Option<&'a Path>,
) -> Vec<(&'a str, &'a Path)> {
    outputs
        .into_iter()
        .chain([("--trajectory's frame folder", frames)])
        .filter_map(|(flag, path)| Some((flag, path?)))
        .collect()
}

/// [`check_outputs`], and `--observe` refused in a run split over `ranks` (see
/// `launch::refuse_split_observe`), from the flags alone.
pub fn check_long_run(
    checkpoint: Option<(&Path, u64)>,
    trajectory: Option<(&Path, u64)>,
    observe: Option<(&Path, u64)>,
    ranks: Option<usize>,
) -> Result<(), Failure> {
    check_outputs(checkpoint, trajectory, observe)?;
    if ranks.is_some_and(|r| r > 1) && observe.is_some() {
        return Err(crate::launch::refuse_split_observe());
    }
    Ok(())
}

/// Checks the long-run outputs' paths and intervals, `(path, every)` each, from the flags
/// alone: before the scene is read, whose fill may take seconds.
fn check_outputs(
    checkpoint: Option<(&Path, u64)>,
    trajectory: Option<(&Path, u64)>,
    observe: Option<(&Path, u64)>,
) -> Result<(), Failure> {
    if let Some((path, every)) = checkpoint {
        check_output_path("--checkpoint", path)?;
        if every == 0 {
            return Err(Failure::input("--checkpoint-every: must be at least 1"));
        }
    }
    for (flag, output) in [("--trajectory", trajectory), ("--observe", observe)] {
        if let Some((path, every)) = output {
            check_output_path(flag, path)?;
            if every == 0 {
                return Err(Failure::input("--every: must be at least 1"));
            }
        }
    }
    if let Some(folder) = trajectory.and_then(|(path, _)| frame_folder(path)) {
        if folder.exists() && !folder.is_dir() {
            return Err(Failure::input(format!(
                "--trajectory: {}, the folder its frames go in, is a file",
                folder.display()
            )));
        }
    }
    if let (Some((trajectory, _)), Some((observe, _))) = (trajectory, observe) {
        if trajectory == observe {
            return Err(Failure::input(
                "--observe: the same file as --trajectory; give each its own",
            ));
        }
    }
    Ok(())
}

/// What the loop saw.
#[derive(Default)]
pub struct Driven {
    pub seconds: f64,
    pub steps_run: u64,
    pub contacts_total: u64,
    pub contacts_max: usize,
    /// Pairs that pushed each other, summed over the steps (see `StepStats::pushing`).
    pub pushing_total: u64,
    pub pushing_max: usize,
    pub capped_steps: u64,
    /// Particle-particle collisions (see `carom_engine::observe`).
    pub collisions_total: u64,
    /// The deepest overlap seen in any state of the run (a step's own contacts at its end, and
    /// every pair found at its start: see `StepStats::found_overlap`), as a fraction of the
    /// smaller radius. (The summary measures the end over every pair: see
    /// `World::deepest_overlap`.)
    pub worst_overlap: f64,
    /// The last step that hit the velocity sweep cap.
    pub last_capped: Option<u64>,
    /// Steps taken again because a push drove a particle beyond its reach into another
    /// (`StepStats::retakes` above 0), and the tries taken again in all.
    pub retaken_steps: u64,
    pub retakes: u64,
    /// Steps in which a particle started faster than a radius a step
    /// (`StepStats::fastest_move` above 1), and the fastest such move with its step.
    pub outran_steps: u64,
    pub fastest_move: f64,
    pub fastest_move_step: u64,
    /// Particles asleep in the last step, and the step since which that many have been.
    pub asleep_last: usize,
    pub asleep_since: Option<u64>,
    /// The step at which an interrupt stopped the run.
    pub interrupted_at: Option<u64>,
}

impl Driven {
    /// Adds one step's statistics (`step`: the steps taken after it).
    fn record(&mut self, stats: &StepStats, step: u64) {
        self.steps_run += 1;
        self.contacts_total += stats.contacts as u64;
        self.contacts_max = self.contacts_max.max(stats.contacts);
        self.pushing_total += stats.pushing as u64;
        self.pushing_max = self.pushing_max.max(stats.pushing);
        self.capped_steps += stats.capped as u64;
        self.collisions_total += stats.collisions;
        self.worst_overlap = self.worst_overlap.max(stats.deepest_seen());
        if stats.capped {
            self.last_capped = Some(step);
        }
        self.outran_steps += (stats.fastest_move > 1.0) as u64;
        self.retaken_steps += (stats.retakes > 0) as u64;
        self.retakes += stats.retakes as u64;
        if stats.fastest_move > self.fastest_move {
            (self.fastest_move, self.fastest_move_step) = (stats.fastest_move, step);
        }
        if stats.asleep != self.asleep_last || self.asleep_since.is_none() {
            self.asleep_since = (stats.asleep > 0).then_some(step);
        }
        self.asleep_last = stats.asleep;
    }
}

/// A trajectory being written: CSV (appended, flushed frame by frame) or a VTK series.
enum Trajectory {
    Csv(CsvTrajectory<BufWriter<CsvFile>>),
    Vtk(vtk::Series<Guarded>),
}

impl Trajectory {
    /// Opens the trajectory at `path` (VTK for a `.pvd`, CSV otherwise); a fresh run starts it
    /// with the initial frame, a resumed one continues it.
    fn open<V: Vector>(path: &Path, world: &World<V>) -> Result<Self, Failure> {
        let io = |e| Failure::write(path, e);
        let fresh = world.steps_taken() == 0;
        if vtk::is_pvd(path) {
            let mut series = vtk::Series::open(path, world.steps_taken(), Guarded).map_err(io)?;
            if fresh {
                series.frame(world).map_err(io)?;
            }
            return Ok(Trajectory::Vtk(series));
        }
        let file = CsvFile::open(path, fresh)
            .map_err(|e| Failure::runtime(format!("cannot open {}: {e}", path.display())))?;
        let out = BufWriter::with_capacity(1 << 16, file);
        if !fresh {
            return Ok(Trajectory::Csv(CsvTrajectory::resume(out)));
        }
        let csv = CsvTrajectory::start(out, world).map_err(io)?;
        csv.get_ref().get_ref().mark_whole();
        Ok(Trajectory::Csv(csv))
    }

    fn frame<V: Vector>(&mut self, world: &World<V>) -> std::io::Result<()> {
        match self {
            Trajectory::Csv(csv) => {
                csv.frame(world)?;
                csv.get_ref().get_ref().mark_whole();
                Ok(())
            }
            Trajectory::Vtk(series) => series.frame(world),
        }
    }
}

/// An observables file being written, row by row.
type Observations = ObservablesCsv<BufWriter<CsvFile>>;

/// The files the loop writes into, each with its interval and path.
struct Writers<'a> {
    outputs: &'a Outputs,
    /// Open on the process that writes output only.
    trajectory: Option<(Trajectory, u64, PathBuf)>,
    observations: Option<(Observations, u64, PathBuf)>,
}

impl<'a> Writers<'a> {
    /// Opens the trajectory and the observables file; a fresh run writes their first frame
    /// and row.
    fn open<V: Vector, S: Stepper<V>>(
        stepper: &mut S,
        outputs: &'a Outputs,
    ) -> Result<Self, Failure> {
        // collective in a split run, as in `after_step`
        let trajectory = match &outputs.trajectory {
            None => None,
            Some((path, every)) => match stepper.world() {
                Some(world) => Some((Trajectory::open(path, world)?, *every, path.clone())),
                None => None,
            },
        };
        let observations = match &outputs.observe {
            None => None,
            Some((path, every)) => {
                let fresh = stepper.steps_taken() == 0;
                let opened = CsvFile::open(path, fresh)
                    .and_then(|file| ObservablesCsv::open(BufWriter::new(file), fresh))
                    .and_then(|mut file| {
                        if fresh {
                            if let Some(reading) = stepper.observe() {
                                file.row(&reading)?;
                                file.get_ref().get_ref().mark_whole();
                            }
                        }
                        Ok(file)
                    });
                Some((
                    opened.map_err(|e| Failure::write(path, e))?,
                    *every,
                    path.clone(),
                ))
            }
        };
        Ok(Self {
            outputs,
            trajectory,
            observations,
        })
    }

    /// After step `step`: the frame, the row and the checkpoint that fall due.
    fn after_step<V: Vector, S: Stepper<V>>(
        &mut self,
        stepper: &mut S,
        step: u64,
    ) -> Result<(), Failure> {
        if let Some((_, every)) = &self.outputs.trajectory {
            // `world` is collective in a split run: every rank calls it, and only the one that
            // writes (the one with a trajectory open) gets the world
            if step % every == 0 {
                if let (Some(world), Some((trajectory, _, path))) =
                    (stepper.world(), &mut self.trajectory)
                {
                    trajectory
                        .frame(world)
                        .map_err(|e| Failure::write(path, e))?;
                }
            }
        }
        if let Some((file, every, path)) = &mut self.observations {
            if step % *every == 0 {
                if let Some(reading) = stepper.observe() {
                    file.row(&reading).map_err(|e| Failure::write(path, e))?;
                    file.get_ref().get_ref().mark_whole();
                }
            }
        }
        if let Some((path, every)) = &self.outputs.checkpoint {
            if step % every == 0 {
                if let Some(world) = stepper.world() {
                    save_checkpoint(path, world, self.outputs)?;
                }
            }
        }
        Ok(())
    }
}

pub fn save_checkpoint<V: Vector>(
    path: &Path,
    world: &World<V>,
    outputs: &Outputs,
) -> Result<(), Failure> {
    let settings_json =
        serde_json::to_string(&outputs.settings).map_err(|e| Failure::runtime(e.to_string()))?;
    let cp = Checkpoint::of_world(
        world,
        outputs.scene_toml.clone(),
        outputs.origin.clone(),
        settings_json,
    );
    write_whole(path, |w| cp.write_to(w))
        .map_err(|e| Failure::runtime(format!("cannot write checkpoint {}: {e}", path.display())))
}

/// Steps until `total_steps`, writing trajectory frames, observables and checkpoints, and
/// stopping early (after a whole step) on an interrupt, after which the checkpoint (if one was
/// asked for) holds the step it stopped at.
pub fn drive<V: Vector, S: Stepper<V>>(
    stepper: &mut S,
    total_steps: u64,
    outputs: &Outputs,
    progress: &ProgressBar,
) -> Result<Driven, Failure> {
    let mut writers = Writers::open(stepper, outputs)?;
    let mut driven = Driven::default();
    let started = Instant::now();
    let mut failure = None;
    stepper.run_loop(|stepper| {
        while stepper.steps_taken() < total_steps {
            let stats = stepper.step();
            let step = stepper.steps_taken();
            driven.record(&stats, step);
            if step % 64 == 0 {
                progress.set_position(step);
            }
            if let Err(e) = writers.after_step(stepper, step) {
                failure = Some(e);
                return;
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
    if let (Some(at), Some((path, every))) = (driven.interrupted_at, &outputs.checkpoint) {
        if at % every != 0 {
            if let Some(world) = stepper.world() {
                save_checkpoint(path, world, outputs)?;
            }
        }
    }
    Ok(driven)
}
