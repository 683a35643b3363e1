//! How a run is launched, for `carom run` and `carom resume` alike: alone, split over
//! `mpirun`'s ranks (with the `mpi` feature), or split over thread ranks (`--ranks N`); each
//! way steps through [`crate::driver`]. Above both the driver and [`crate::cluster`] (whose
//! split world is one of the driver's steppers), so neither depends on the other's caller.

use crate::driver::interrupt::{install_interrupt_handler, quiet_interrupts};
use crate::driver::step::{drive, Outputs, Stepper};
use crate::driver::{finish, progress_bar, Before, Labels};
use crate::failure::{Failure, INTERRUPTED};
use carom_engine::cluster::Transport;
use carom_engine::{Vector, World};
use indicatif::ProgressBar;

/// Builds a run's starting worlds: `copies(n)` gives `n >= 1` copies of the same world (one
/// per thread rank), built from what the closure owns (the scene, the checkpoint), which is
/// dropped once they are built: a run at 10^6 particles does not keep the scene's particle
/// arrays (48 bytes a particle) beside the world's for its whole length.
pub trait BuildWorlds<V: Vector>: FnOnce(usize) -> Result<Vec<World<V>>, Failure> {}
impl<V: Vector, F: FnOnce(usize) -> Result<Vec<World<V>>, Failure>> BuildWorlds<V> for F {}

/// `copies` (at least one) of what `make` makes of `source`: of clones of it, the last of
/// `source` itself.
pub fn copies_of<S: Clone, W>(
    source: S,
    copies: usize,
    make: impl Fn(S) -> Result<W, Failure>,
) -> Result<Vec<W>, Failure> {
    let mut made = Vec::with_capacity(copies.max(1));
    for _ in 1..copies {
        made.push(make(source.clone())?);
    }
    made.push(make(source)?);
    Ok(made)
}

/// Builds the worlds of a run and steps them to `steps` with its outputs, then finishes
/// (summary, final CSV, status): alone, split over `mpirun`'s ranks (with the `mpi` feature),
/// or split over `ranks` threads (each its own copy of the world, as every MPI rank builds its
/// own). The flags a split run refuses are refused before any world is built.
pub fn run_world<V: Vector>(
    build: impl BuildWorlds<V>,
    ranks: Option<usize>,
    steps: u64,
    outputs: &Outputs,
    run: &Labels,
) -> Result<(), Failure> {
    #[cfg(feature = "mpi")]
    if let Some(mpi) = crate::cluster::mpi::Mpi::current() {
        if mpi.size() > 1 {
            if ranks.is_some() {
                return Err(Failure::input(
                    "--ranks: not under mpirun, where the ranks are mpirun's processes",
                ));
            }
            if outputs.observe.is_some() {
                return Err(refuse_split_observe());
            }
            let world = one_world(build)?;
            crate::cluster::mpi::check_gather_size(world.len(), V::DIM)
                .map_err(|e| Failure::input(format!("{}: {e}", run.origin)))?;
            install_interrupt_handler();
            return run_split(world, mpi.transport(), true, steps, outputs, run);
        }
    }
    match ranks {
        Some(ranks) if ranks > 1 && outputs.observe.is_some() => {
            return Err(refuse_split_observe());
        }
        Some(ranks) if ranks > 1 => {
            let worlds = build(ranks)?;
            install_interrupt_handler();
            return run_thread_ranks(worlds, steps, outputs, run);
        }
        _ => {}
    }
    let mut world = one_world(build)?;
    install_interrupt_handler();
    let before = Before::of(&world);
    let progress = progress_bar(steps);
    progress.set_position(world.steps_taken());
    let driven = drive(&mut world, steps, outputs, &progress)?;
    progress.finish_and_clear();
    finish(&mut world, run, before, &driven)
}

/// The one world of a run that is not split over threads.
fn one_world<V: Vector>(build: impl BuildWorlds<V>) -> Result<World<V>, Failure> {
    build(1)?
        .pop()
        .ok_or_else(|| Failure::runtime("no world was built"))
}

/// `--observe` in a split run: each rank sums the collisional virial of its own contacts, and
/// those sums added in another order would not give one process's bits.
pub(crate) fn refuse_split_observe() -> Failure {
    Failure::input(
        "--observe: not available in a split run (--ranks, mpirun): the pressure's virial is \
         summed per rank and would not match one process's to the bit; observe with one rank",
    )
}

/// `carom run --ranks N`: the split run of `mpirun -np N`, with the ranks as threads of this
/// process talking through shared memory. Same decomposition, same messages, same bits.
fn run_thread_ranks<V: Vector>(
    worlds: Vec<World<V>>,
    steps: u64,
    outputs: &Outputs,
    run: &Labels,
) -> Result<(), Failure> {
    let transports = carom_engine::cluster::ThreadTransport::group(worlds.len());
    std::thread::scope(|s| {
        let handles: Vec<_> = worlds
            .into_iter()
            .zip(transports)
            .map(|(world, transport)| {
                s.spawn(move || run_split(world, transport, false, steps, outputs, run))
            })
            .collect();
        let mut results = handles.into_iter().map(|h| {
            h.join()
                .unwrap_or_else(|_| Err(Failure::runtime("a rank thread panicked")))
        });
        let first = results.next().unwrap_or(Ok(()));
        // The other ranks end as rank 0 does, or fail on their own.
        results.fold(first, |acc, r| {
            acc.and(r.or_else(|e| if e.speaks() { Err(e) } else { Ok(()) }))
        })
    })
}

/// A run split over ranks (MPI processes or threads): every output written by rank 0 from the
/// gathered state, the same files a single process writes.
///
/// `on_pool`: step on a rayon pool thread (one rank per process). Thread ranks must not: they
/// would wait for each other in collectives while queued behind each other for the pool.
fn run_split<V: Vector, T: Transport + Send>(
    world: World<V>,
    transport: T,
    on_pool: bool,
    steps: u64,
    outputs: &Outputs,
    run: &Labels,
) -> Result<(), Failure> {
    let before = Before::of(&world);
    let mut split = crate::cluster::Split::new(world, transport, on_pool)
        .map_err(|e| Failure::input(format!("{}: {e}", run.origin)))?;
    let progress = if split.rank() == 0 {
        progress_bar(steps)
    } else {
        if on_pool {
            // its own process: rank 0 speaks for the job
            quiet_interrupts();
        }
        ProgressBar::hidden()
    };
    progress.set_position(split.steps_taken());
    let driven = drive(&mut split, steps, outputs, &progress)?;
    progress.finish_and_clear();
    let report = split.report();
    let Some(world) = split.world() else {
        // Rank 0 reports; the others end with the same status, quietly.
        return match driven.interrupted_at {
            Some(_) => Err(Failure::Quiet(INTERRUPTED)),
            None => Ok(()),
        };
    };
    finish(world, run, before, &driven)?;
    if let Some(report) = report {
        report.print(driven.steps_run);
    }
    Ok(())
}
