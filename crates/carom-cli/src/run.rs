//! `carom run` and `carom check`.

use crate::driver::step::{check_long_run, frame_folder, named_outputs, Outputs};
use crate::driver::Labels;
use crate::failure::Failure;
use crate::input::{
    apply_overrides, check_cells, check_distinct, check_output_path, check_overrides, check_ranks,
    check_steps, load_scene, set_threads,
};
use crate::launch::{copies_of, run_world};
use carom_engine::Vector;
use carom_scene::RunSettings;
use carom_scene::{AnyScene, Scene};
use clap::ValueEnum;
use std::path::{Path, PathBuf};

/// Options of `carom run`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("framed").args(["trajectory", "observe"]).multiple(true)))]
pub struct RunArgs {
    /// Scene file (TOML; the format is in docs/scene-format.md). Without it, the built-in
    /// default scene runs. A scene's box can be periodic per axis (`[domain] periodic =
    /// [true, false]`: positions wrap into the box, contacts across the seam use the nearest
    /// image; `walls = true` then closes only the other axes).
    pub scene: Option<PathBuf>,
    /// Run a built-in scene by name instead of a file (see `carom presets`).
    #[arg(long, conflicts_with = "scene")]
    pub preset: Option<String>,
    /// Number of steps (overrides the scene's `steps`), at most 10^12.
    #[arg(long, allow_negative_numbers = true)]
    pub steps: Option<u64>,
    /// Write the final state here as CSV (written whole or not at all).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Broad phase (overrides the scene's `[broadphase] kind`).
    #[arg(long, value_enum)]
    pub broadphase: Option<BroadPhaseArg>,
    /// Grid cells per axis, comma separated, e.g. `50,50` (overrides `[broadphase] cells`).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub cells: Option<Vec<usize>>,
    /// Worker threads, 1 to 8 per core (at least 64 on any machine; default: RAYON_NUM_THREADS,
    /// else one per core). Results are identical for every count.
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Write a checkpoint (the complete state, atomically) to this file every
    /// `--checkpoint-every` steps, and on Ctrl-C; continue it with `carom resume`.
    #[arg(long, requires = "checkpoint_every")]
    pub checkpoint: Option<PathBuf>,
    /// Steps between checkpoints.
    #[arg(long, requires = "checkpoint", allow_negative_numbers = true)]
    pub checkpoint_every: Option<u64>,
    /// Write trajectory frames, one at the start and one every `--every` steps: a `.csv` path
    /// writes one CSV with `step` and `time` columns; a `.pvd` path writes a VTK series for
    /// ParaView (one `.vtp` per frame in a folder of the same name, plus the `.pvd` index).
    #[arg(long, requires = "every")]
    pub trajectory: Option<PathBuf>,
    /// Write the observables to this CSV, a row at the start and one every `--every` steps:
    /// `step,time,kinetic_energy,potential_energy,temperature,collisions,pressure,max_overlap`
    /// (granular temperature; collisions since the start; virial pressure over the interval
    /// since the previous row; deepest overlap over every pair, as a fraction of the smaller radius; see
    /// docs/validation.md). Not in split runs (`--ranks`, `mpirun`).
    #[arg(long, requires = "every")]
    pub observe: Option<PathBuf>,
    /// Steps between trajectory frames and observables rows.
    #[arg(long, requires = "framed", allow_negative_numbers = true)]
    pub every: Option<u64>,
    /// Split the run over N ranks, as threads of this process: the decomposition `mpirun -np
    /// N carom run` uses (see "Running on a cluster" in the README), without MPI. The result
    /// is bit-identical to one rank's. At most 8 per core (64 on any machine).
    #[arg(long, allow_negative_numbers = true)]
    pub ranks: Option<usize>,
}

/// `--broadphase` values.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BroadPhaseArg {
    /// The lecture's hash grid.
    Grid,
    /// All pairs, O(n^2).
    Brute,
    /// An unbounded spatial hash (for scenes without walls).
    Hash,
}

/// `carom check`: parse the scene and build its world, without stepping.
pub fn check(path: &Path) -> Result<(), Failure> {
    // (RAYON_NUM_THREADS, which the scene's fill would start its threads by)
    set_threads(None)?;
    let (scene, _, _, ()) = load_scene(Some(path), None, |_, _| Ok(()))?;
    let (n, world_check) = match &scene {
        AnyScene::Two(s) => (s.particles.len(), s.build_world().map(|_| ())),
        AnyScene::Three(s) => (s.particles.len(), s.build_world().map(|_| ())),
    };
    world_check.map_err(|e| Failure::input(format!("{}: {e}", path.display())))?;
    println!(
        "{}: ok, {}D, {n} particles",
        path.display(),
        scene.dimensions()
    );
    Ok(())
}

/// `carom run`: every flag checked, then the scene loaded, then the run.
pub fn run(args: &RunArgs) -> Result<(), Failure> {
    set_threads(args.threads)?;
    check_ranks(args.ranks)?;
    check_steps("--steps", args.steps)?;
    check_cells(args.cells.as_deref())?;
    if let Some(out) = &args.out {
        check_output_path("--out", out)?;
    }
    let frames = args.trajectory.as_deref().and_then(frame_folder);
    let outputs = named_outputs(
        [
            ("--out", args.out.as_deref()),
            ("--checkpoint", args.checkpoint.as_deref()),
            ("--trajectory", args.trajectory.as_deref()),
            ("--observe", args.observe.as_deref()),
        ],
        frames.as_deref(),
    );
    let inputs: Vec<(&str, &Path)> = args
        .scene
        .as_deref()
        .map(|scene| ("scene file", scene))
        .into_iter()
        .collect();
    check_distinct(&outputs, &inputs)?;
    check_long_run(
        args.checkpoint.as_deref().zip(args.checkpoint_every),
        args.trajectory.as_deref().zip(args.every),
        args.observe.as_deref().zip(args.every),
        args.ranks,
    )?;
    let (scene, origin, text, ()) = load_scene(
        args.scene.as_deref(),
        args.preset.as_deref(),
        |o, origin| {
            let broadphase = broad_phase_name(args.broadphase);
            check_overrides((o, origin), broadphase, args.cells.as_deref())
        },
    )?;
    match scene {
        AnyScene::Two(s) => run_scene(s, &origin, text, args),
        AnyScene::Three(s) => run_scene(s, &origin, text, args),
    }
}

/// `--broadphase`, as the scene names it.
fn broad_phase_name(broadphase: Option<BroadPhaseArg>) -> Option<&'static str> {
    broadphase.map(|b| match b {
        BroadPhaseArg::Brute => "brute",
        BroadPhaseArg::Grid => "grid",
        BroadPhaseArg::Hash => "hash",
    })
}

fn run_scene<V: Vector>(
    mut scene: Scene<V>,
    origin: &str,
    text: String,
    args: &RunArgs,
) -> Result<(), Failure> {
    if let Some(steps) = args.steps {
        scene.steps = steps;
    }
    let broadphase = broad_phase_name(args.broadphase);
    apply_overrides(&mut scene, broadphase, args.cells.as_deref())?;
    let outputs = Outputs {
        checkpoint: args.checkpoint.clone().zip(args.checkpoint_every),
        trajectory: args.trajectory.clone().zip(args.every),
        observe: args.observe.clone().zip(args.every),
        scene_toml: text,
        origin: origin.to_string(),
        settings: RunSettings {
            steps: scene.steps,
            broadphase: broadphase.map(str::to_string),
            cells: args.cells.clone(),
        },
    };
    let name = scene.name.clone();
    let steps = scene.steps;
    let run = Labels {
        name: name.as_deref(),
        origin,
        out: args.out.as_deref(),
    };
    let build = |copies| {
        copies_of(scene, copies, |s| {
            (s.into_world()).map_err(|e| Failure::input(format!("{origin}: {e}")))
        })
    };
    run_world(build, args.ranks, steps, &outputs, &run)
}
