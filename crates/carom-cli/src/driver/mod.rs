//! The driver `carom run` and `carom resume` share: a world (or this process's share of one,
//! see [`crate::cluster`]) steps to its total with its outputs ([`step`]), under the interrupt
//! handling of [`interrupt`], and ends with the final CSV and the [`summary`]. Which of those
//! runs (alone, over `mpirun`'s ranks, over thread ranks) is [`crate::launch`]'s choice.

pub mod interrupt;
pub mod step;
pub mod summary;

use crate::failure::Failure;
use carom_engine::{Vector, World};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;
use step::Driven;

/// The step progress bar (drawn only on a terminal).
pub fn progress_bar(steps: u64) -> ProgressBar {
    counting_bar(steps, "step")
}

/// A bar counting `len` things (`{counting} {pos}/{len}`), drawn only on a terminal.
pub fn counting_bar(len: u64, counting: &str) -> ProgressBar {
    let progress = ProgressBar::new(len);
    progress.set_style(
        ProgressStyle::with_template(&format!(
            "{{spinner}} {counting} {{pos}}/{{len}} {{wide_bar}} {{eta}} left"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    progress
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

/// After the loop: the final CSV (unless interrupted), the summary, and the exit status.
pub fn finish<V: Vector>(
    world: &mut World<V>,
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
    let grid_cells = world.grid_cells();
    // (over every pair, not only the last step's contacts; not for a run of no steps, whose
    // summary reports no overlap)
    let end_overlap = if driven.steps_run > 0 {
        world.deepest_overlap()
    } else {
        0.0
    };
    let summary = summary::Summary {
        run,
        world,
        before: &before,
        driven,
        end_overlap,
        grid_cells,
    };
    summary.print();
    Ok(())
}
