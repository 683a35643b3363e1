//! `carom`: run particle collision scenes from the command line.

mod bench;
mod run;

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
    /// Measure speed: the lecture's brute force vs grid table and a scale sweep.
    Bench(bench::BenchArgs),
}

/// Options of `carom run`.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// Scene file (TOML). Without it, the built-in default scene runs.
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
    let result = match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Check { scene } => run::check(&scene),
        Command::Bench(args) => bench::bench(&args),
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
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("carom: error: {}", e.message);
            ExitCode::from(e.status)
        }
    }
}
