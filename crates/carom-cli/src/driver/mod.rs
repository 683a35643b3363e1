//! The driver `carom run` and `carom resume` share: a world steps to its total with its outputs
//! ([`step`]), alone, split over `mpirun`'s ranks or over thread ranks, under the interrupt
//! handling of [`interrupt`], and ends with the final CSV and the [`summary`].

pub mod interrupt;
pub mod step;
pub mod summary;

use crate::failure::{Failure, INTERRUPTED};
use carom_engine::cluster::Transport;
use carom_engine::{Vector, World};
use indicatif::{ProgressBar, ProgressStyle};
use interrupt::install_interrupt_handler;
use std::path::Path;
use step::{drive, Driven, Outputs, Stepper};

/// The step progress bar (drawn only on a terminal).
pub fn progress_bar(steps: u64) -> ProgressBar {
    let progress = ProgressBar::new(steps);
    progress.set_style(
        ProgressStyle::with_template("{spinner} step {pos}/{len} {wide_bar} {eta} left")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    progress
}

/// Steps `world` to `steps` with its outputs, then finishes (summary, final CSV, status):
/// alone, split over `mpirun`'s ranks (with the `mpi` feature), or split over `ranks` threads.
/// `rebuild` makes another copy of the starting world: every thread rank builds its own, as
/// every MPI rank does.
pub fn run_world<V: Vector>(
    world: World<V>,
    rebuild: &(dyn Fn() -> Result<World<V>, Failure> + Sync),
    ranks: Option<usize>,
    steps: u64,
    outputs: &Outputs,
    run: &Labels,
) -> Result<(), Failure> {
    install_interrupt_handler();
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
            crate::cluster::mpi::check_gather_size(world.len(), V::DIM)
                .map_err(|e| Failure::input(format!("{}: {e}", run.origin)))?;
            return run_split(world, mpi.transport(), true, steps, outputs, run);
        }
    }
    match ranks {
        Some(ranks) if ranks > 1 && outputs.observe.is_some() => {
            return Err(refuse_split_observe());
        }
        Some(ranks) if ranks > 1 => {
            return run_thread_ranks(world, rebuild, ranks, steps, outputs, run);
        }
        _ => {}
    }
    let mut world = world;
    let before = Before::of(&world);
    let progress = progress_bar(steps);
    progress.set_position(world.steps_taken());
    let driven = drive(&mut world, steps, outputs, &progress)?;
    progress.finish_and_clear();
    finish(&world, run, before, &driven)
}

/// `--observe` in a split run: each rank sums the collisional virial of its own contacts, and
/// those sums added in another order would not give one process's bits.
fn refuse_split_observe() -> Failure {
    Failure::input(
        "--observe: not available in a split run (--ranks, mpirun): the pressure's virial is \
         summed per rank and would not match one process's to the bit; observe with one rank",
    )
}

/// How a run is named in its summary, and where its final state goes.
pub struct Labels<'a> {
    pub name: Option<&'a str>,
    pub origin: &'a str,
    pub out: Option<&'a Path>,
}

/// The conserved quantities at the start, to compare the end with.
pub struct Before<V> {
    pub kinetic: f64,
    pub potential: f64,
    pub momentum: V,
}

impl<V: Vector> Before<V> {
    pub fn of(world: &World<V>) -> Self {
        Self {
            kinetic: world.kinetic_energy(),
            potential: world.potential_energy(),
            momentum: world.momentum(),
        }
    }
}

/// `carom run --ranks N`: the split run of `mpirun -np N`, with the ranks as threads of this
/// process talking through shared memory. Same decomposition, same messages, same bits.
fn run_thread_ranks<V: Vector>(
    world: World<V>,
    rebuild: &(dyn Fn() -> Result<World<V>, Failure> + Sync),
    ranks: usize,
    steps: u64,
    outputs: &Outputs,
    run: &Labels,
) -> Result<(), Failure> {
    let mut worlds = vec![world];
    for _ in 1..ranks {
        worlds.push(rebuild()?);
    }
    let transports = carom_engine::cluster::ThreadTransport::group(ranks);
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
            interrupt::quiet_interrupts();
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

/// After the loop: the final CSV (unless interrupted), the summary, and the exit status.
pub fn finish<V: Vector>(
    world: &World<V>,
    run: &Labels,
    before: Before<V>,
    driven: &Driven,
) -> Result<(), Failure> {
    if let Some(at) = driven.interrupted_at {
        return Err(Failure::Interrupted(format!(
            "interrupted after step {at}; trajectory frames so far are on disk, and the \
             checkpoint (if one was asked for) holds step {at}: continue with `carom resume`"
        )));
    }
    if let Some(out) = run.out {
        // Through the interrupt-safe writer, so that a second Ctrl-C cannot leave it half done.
        interrupt::write_whole(out, |w| carom_output::write_state_csv(world.particles(), w))
            .map_err(|e| Failure::write(out, e))?;
    }
    let summary = summary::Summary {
        run,
        world,
        before: &before,
        driven,
    };
    summary.print();
    Ok(())
}
