//! `carom validate`: carom's gases measured against kinetic theory, each case with its
//! tolerance (see docs/validation.md). Periodic boxes, equal particles of diameter 1 and mass
//! 1, temperature 1 at the start: lengths in diameters, times in `s sqrt(m / T0)`.
//!
//! - Haff's law of homogeneous cooling, 2D and 3D: `T(t) = T0 / (1 + t / t0)^2`, `t0 = 2 d /
//!   ((1 - e^2) w0)`, `w0` Enskog's collision frequency at `T0`;
//! - the equation of state at `k = 1`: `Z = P V / (N T)` against Henderson (disks) and
//!   Carnahan-Starling (spheres), two packing fractions each;
//! - the collision frequency at `k = 1` against Enskog's;
//! - relaxation to Maxwell-Boltzmann: a gas started with equal speeds ends with the kurtosis
//!   excess `a2` of a Gaussian, 0.

mod cases;
mod gas;

use crate::failure::Failure;
use cases::{Case, Outcome, Size};
use std::path::PathBuf;

/// Options of `carom validate`.
#[derive(clap::Args, Debug)]
pub struct ValidateArgs {
    /// Smaller gases and shorter windows (what the test suite runs): the same tolerances,
    /// more noise.
    #[arg(long)]
    pub quick: bool,
    /// Also draw every case against theory, as PNG files in this folder.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Also measure how the error falls with dt (the equation of state and the collision
    /// frequency of a 2D gas at packing fraction 0.3, four time steps).
    #[arg(long)]
    pub dt_table: bool,
    /// Worker threads, 1 to 8 per core (at least 64 on any machine; default:
    /// RAYON_NUM_THREADS, else one per core).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
}

/// `carom validate`: exit status 0 when every case is within its tolerance, 1 otherwise.
pub fn validate(args: &ValidateArgs) -> Result<(), Failure> {
    crate::input::set_threads(args.threads)?;
    if let Some(dir) = &args.plots {
        if !dir.is_dir() {
            return Err(Failure::input(format!(
                "--plots: {} is not a folder",
                dir.display()
            )));
        }
    }
    let size = if args.quick { Size::Quick } else { Size::Full };
    let cases = Case::all();
    let progress = indicatif::ProgressBar::new(cases.len() as u64);
    progress.set_style(
        indicatif::ProgressStyle::with_template("{spinner} case {pos}/{len}: {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let mut outcomes: Vec<Outcome> = Vec::new();
    for case in cases {
        progress.set_message(case.name());
        let outcome = case.run(size);
        if let Some(dir) = &args.plots {
            for (file, plot) in &outcome.plots {
                let path = dir.join(file);
                carom_plot::save_comparison_plot(&path, plot).map_err(|e| {
                    Failure::runtime(format!("cannot write {}: {e}", path.display()))
                })?;
            }
        }
        outcomes.push(outcome);
        progress.inc(1);
    }
    progress.finish_and_clear();
    println!(
        "{:<44} {:>10} {:>10} {:>8} {:>6}",
        "case", "measured", "theory", "error", "limit"
    );
    for o in &outcomes {
        for check in &o.checks {
            println!(
                "{:<44} {:>10.4} {:>10.4} {:>7.2}{} {:>5}{} {}",
                check.name,
                check.measured,
                check.theory,
                check.error_shown(),
                check.unit(),
                check.tolerance_shown(),
                check.unit(),
                if check.passes() { "ok" } else { "FAILED" }
            );
        }
    }
    if args.dt_table {
        println!();
        println!("how the error falls with dt (2D, packing fraction 0.3, k = 1):");
        println!(
            "{:>22} {:>12} {:>18}",
            "dt (s sqrt(m/T))", "Z error", "collision rate err"
        );
        for (dt, z, rate) in cases::dt_table(size) {
            println!("{dt:>22} {:>11.2}% {:>17.2}%", 100.0 * z, 100.0 * rate);
        }
    }
    let failed: Vec<&str> = outcomes
        .iter()
        .flat_map(|o| &o.checks)
        .filter(|c| !c.passes())
        .map(|c| c.name.as_str())
        .collect();
    if failed.is_empty() {
        println!("every case within its tolerance");
        Ok(())
    } else {
        Err(Failure::runtime(format!(
            "outside tolerance: {}",
            failed.join(", ")
        )))
    }
}
