//! `carom`: run particle collision scenes from the command line.

mod allocator;
mod bench;
mod cluster;
mod driver;
mod failure;
mod floor;
mod input;
mod launch;
mod pipe;
mod render;
mod resume;
mod run;
mod soak;
mod validate;
mod view;

use clap::{Parser, Subcommand};
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
    Run(run::RunArgs),
    /// Check a scene file without running it.
    Check {
        /// The scene file (TOML).
        scene: PathBuf,
    },
    /// List the built-in scenes (the files in scenes/).
    Presets,
    /// Continue a run from a checkpoint, bit-identically to an uninterrupted run.
    Resume(resume::ResumeArgs),
    /// Measure speed: the lecture's brute force vs grid table and a scale sweep.
    Bench(bench::BenchArgs),
    /// Run a scene and draw it: a PNG of the final state, or an animated GIF/MP4 of frames.
    Render(render::RenderArgs),
    /// Open a window that shows a scene while it runs, with controls, plots and the lecture's
    /// hash grid, neighbour cells and contact normals.
    View(view::ViewArgs),
    /// Long-run check: run a scene (default: the lecture's 5000 particles) for many steps and
    /// print NaN count, escaped particles, energy and peak memory every `--every` steps.
    Soak(soak::SoakArgs),
    /// Measure periodic gases against kinetic theory (Haff's law, the equations of state of
    /// Henderson and Carnahan-Starling, Enskog's collision frequency, Maxwell-Boltzmann) and
    /// say which case is within its tolerance; exit status 1 when one is not.
    Validate(validate::ValidateArgs),
}

fn main() -> ExitCode {
    pipe::end_quietly_when_the_reader_goes();
    allocator::fix_mmap_threshold();
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
        Command::Resume(args) => resume::resume(&args),
        Command::View(args) => view::view(&args),
        Command::Render(args) => render::render(&args),
        Command::Soak(args) => soak::soak(&args),
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
            if speaks && e.speaks() {
                eprintln!("carom: error: {e}");
            }
            #[cfg(feature = "mpi")]
            if let Some(mpi) = cluster::mpi::Mpi::current() {
                // A failure while working on one rank leaves the others waiting in a
                // collective: end them all.
                if mpi.size() > 1 && e.status() == 1 {
                    mpi.abort(1);
                }
            }
            ExitCode::from(e.status())
        }
    };
    #[cfg(feature = "mpi")]
    cluster::mpi::stop();
    status
}
