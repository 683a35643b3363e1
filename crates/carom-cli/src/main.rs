//! `carom`: run particle collision scenes from the command line.

mod bench;
mod cluster;
mod floor;
mod render;
mod run;
mod session;
mod validate;
mod view;

use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use std::process::ExitCode;

/// Particle collision engine: the lecture "Collision Detection and Response", exact and fast.
#[derive(Parser, Debug)]
#[command(name = "carom", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a scene and print a summary; optionally write the final state as CSV.
    Run(RunArgs),
    /// Check a scene file without running it.
    Check {
        /// The scene file (TOML).
        scene: PathBuf,
    },
    /// List the built-in scenes (the files in scenes/).
    Presets,
    /// Continue a run from a checkpoint, bit-identically to an uninterrupted run.
    Resume(session::ResumeArgs),
    /// Measure speed: the lecture's brute force vs grid table and a scale sweep.
    Bench(bench::BenchArgs),
    /// Run a scene and draw it: a PNG of the final state, or an animated GIF/MP4 of frames.
    Render(render::RenderArgs),
    /// Open a window that shows a scene while it runs, with controls, plots and the lecture's
    /// hash grid, neighbour cells and contact normals.
    View(view::ViewArgs),
    /// Long-run check: run a scene (default: the lecture's 5000 particles) for many steps and
    /// print NaN count, escaped particles, energy and peak memory every `--every` steps.
    Soak(session::soak::SoakArgs),
    /// Measure periodic gases against kinetic theory (Haff's law, the equations of state of
    /// Henderson and Carnahan-Starling, Enskog's collision frequency, Maxwell-Boltzmann) and
    /// say which case is within its tolerance; exit status 1 when one is not.
    Validate(validate::ValidateArgs),
}

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
    /// Number of steps (overrides the scene's `steps`).
    #[arg(long)]
    pub steps: Option<u64>,
    /// Write the final state here as CSV (written whole or not at all).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Broad phase (overrides the scene's `[broadphase] kind`).
    #[arg(long, value_enum)]
    pub broadphase: Option<BroadPhaseArg>,
    /// Grid cells per axis, comma separated, e.g. `50,50` (overrides `[broadphase] cells`).
    #[arg(long, value_delimiter = ',')]
    pub cells: Option<Vec<usize>>,
    /// Worker threads (default: RAYON_NUM_THREADS, else one per core). Results are identical
    /// for every count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Write a checkpoint (the complete state, atomically) to this file every
    /// `--checkpoint-every` steps, and on Ctrl-C; continue it with `carom resume`.
    #[arg(long, requires = "checkpoint_every")]
    pub checkpoint: Option<PathBuf>,
    /// Steps between checkpoints.
    #[arg(long, requires = "checkpoint")]
    pub checkpoint_every: Option<u64>,
    /// Write trajectory frames, one at the start and one every `--every` steps: a `.csv` path
    /// writes one CSV with `step` and `time` columns; a `.pvd` path writes a VTK series for
    /// ParaView (one `.vtp` per frame in a folder of the same name, plus the `.pvd` index).
    #[arg(long, requires = "every")]
    pub trajectory: Option<PathBuf>,
    /// Write the observables to this CSV, a row at the start and one every `--every` steps:
    /// `step,time,kinetic_energy,potential_energy,temperature,collisions,pressure,max_overlap`
    /// (granular temperature; collisions since the start; virial pressure over the interval
    /// since the previous row; deepest overlap as a fraction of the smaller radius; see
    /// docs/validation.md). Not in split runs (`--ranks`, `mpirun`).
    #[arg(long, requires = "every")]
    pub observe: Option<PathBuf>,
    /// Steps between trajectory frames and observables rows.
    #[arg(long, requires = "framed")]
    pub every: Option<u64>,
    /// Split the run over N ranks, as threads of this process: the decomposition `mpirun -np
    /// N carom run` uses (see "Running on a cluster" in the README), without MPI. The result
    /// is bit-identical to one rank's.
    #[arg(long)]
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    #[cfg(feature = "mpi")]
    cluster::mpi::start();
    #[cfg(feature = "mpi")]
    if let Some(mpi) = cluster::mpi::Mpi::current() {
        if mpi.size() > 1 && !matches!(cli.command, Command::Run(_) | Command::Resume(_)) {
            if mpi.rank() == 0 {
                eprintln!(
                    "carom: error: only `carom run` and `carom resume` split over mpirun's \
                     ranks; start this command without mpirun"
                );
            }
            cluster::mpi::stop();
            return ExitCode::from(2);
        }
    }
    let result = match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Check { scene } => run::check(&scene),
        Command::Bench(args) => bench::bench(&args),
        Command::Resume(args) => session::resume(&args),
        Command::View(args) => view::view(&args),
        Command::Render(args) => render::render(&args),
        Command::Soak(args) => session::soak::soak(&args),
        Command::Validate(args) => validate::validate(&args),
        Command::Presets => {
            for (name, text) in carom_scene::PRESETS {
                let title = text
                    .lines()
                    .find_map(|l| l.strip_prefix("name = \""))
                    .map(|l| l.trim_end_matches('"'))
                    .unwrap_or("");
                let mark = if *name == carom_scene::DEFAULT_PRESET {
                    " (default)"
                } else {
                    ""
                };
                println!("{name:<22} {title}{mark}");
            }
            Ok(())
        }
    };
    let status = match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // In a split run every rank fails the same way; rank 0 says so once.
            #[cfg(feature = "mpi")]
            let speaks = cluster::mpi::Mpi::current().is_none_or(|m| m.rank() == 0);
            #[cfg(not(feature = "mpi"))]
            let speaks = true;
            if speaks && !e.message.is_empty() {
                eprintln!("carom: error: {}", e.message);
            }
            #[cfg(feature = "mpi")]
            if let Some(mpi) = cluster::mpi::Mpi::current() {
                // A failure while working on one rank leaves the others waiting in a
                // collective: end them all.
                if mpi.size() > 1 && e.status == 1 {
                    mpi.abort(1);
                }
            }
            ExitCode::from(e.status)
        }
    };
    #[cfg(feature = "mpi")]
    cluster::mpi::stop();
    status
}
