//! `carom soak`: a long run of one scene (by default the lecture's 5000-particle scene) that
//! reports, every `--every` steps, what must never drift: non-finite values, particles that
//! escaped the walls, the energy, and the peak memory. Not part of `cargo test`; see the
//! README ("Soak") and scripts/soak.sh.

use crate::driver::interrupt::{install_interrupt_handler, stop_requested};
use crate::failure::Failure;
use crate::input::{check_steps, scene_text, set_threads};
use carom_engine::{Vector, World};
use carom_scene::AnyScene;
use std::path::PathBuf;
use std::time::Instant;

/// Options of `carom soak`.
#[derive(clap::Args, Debug)]
pub struct SoakArgs {
    /// Scene file (default: the built-in lecture_5000_grid100, the lecture's 5000 particles).
    pub scene: Option<PathBuf>,
    /// Steps to run, at most 10^12.
    #[arg(long, default_value_t = 1_000_000, allow_negative_numbers = true)]
    pub steps: u64,
    /// Steps between report lines.
    #[arg(long, default_value_t = 10_000, allow_negative_numbers = true)]
    pub every: u64,
    /// Worker threads, 1 to 8 per core (at least 64 on any machine).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
}

/// `carom soak`.
pub fn soak(args: &SoakArgs) -> Result<(), Failure> {
    set_threads(args.threads)?;
    check_steps("--steps", Some(args.steps))?;
    if args.every == 0 {
        return Err(Failure::input("--every: must be at least 1"));
    }
    let (text, origin) = scene_text(args.scene.as_deref(), Some("lecture_5000_grid100"))?;
    let scene = crate::input::parse_scene(&text, &origin)?;
    match scene {
        AnyScene::Two(s) => soak_world(s.into_world(), &origin, args),
        AnyScene::Three(s) => soak_world(s.into_world(), &origin, args),
    }
}

/// Peak resident memory in MiB, where the system says.
fn peak_rss_mib() -> Option<f64> {
    carom_scene::machine::peak_rss_bytes().map(|b| b as f64 / (1024.0 * 1024.0))
}

/// Non-finite particles and particles whose centre left the domain (0 when it has no walls).
fn census<V: Vector>(world: &World<V>) -> (usize, usize) {
    let domain = world.config().domain;
    let (mut nan, mut outside) = (0, 0);
    for id in 0..world.len() {
        let (x, v, _, _) = world.particle(id);
        if !(x.is_finite_vector() && v.is_finite_vector()) {
            nan += 1;
        } else if let Some(d) = &domain {
            if !d.contains(x) {
                outside += 1;
            }
        }
    }
    (nan, outside)
}

fn soak_world<V: Vector>(
    world: Result<World<V>, carom_engine::EngineError>,
    origin: &str,
    args: &SoakArgs,
) -> Result<(), Failure> {
    let mut world = world.map_err(|e| Failure::input(format!("{origin}: {e}")))?;
    install_interrupt_handler();
    println!(
        "# soak {origin}: {} particles, {}D, {} steps, {} threads",
        world.len(),
        V::DIM,
        args.steps,
        rayon::current_num_threads()
    );
    println!(
        "{:>10} {:>10} {:>5} {:>7} {:>14} {:>14} {:>9} {:>8}",
        "step", "time", "nan", "outside", "kinetic", "total", "rss_MiB", "wall_s"
    );
    let started = Instant::now();
    let (mut worst_nan, mut worst_outside) = (0, 0);
    let mut line = |world: &World<V>| {
        let (nan, outside) = census(world);
        worst_nan = worst_nan.max(nan);
        worst_outside = worst_outside.max(outside);
        let ke = world.kinetic_energy();
        println!(
            "{:>10} {:>10.3} {:>5} {:>7} {:>14.6e} {:>14.6e} {:>9.1} {:>8.1}",
            world.steps_taken(),
            world.time(),
            nan,
            outside,
            ke,
            ke + world.potential_energy(),
            peak_rss_mib().unwrap_or(f64::NAN),
            started.elapsed().as_secs_f64()
        );
    };
    line(&world);
    let mut interrupted = false;
    rayon::scope(|_| {
        while world.steps_taken() < args.steps {
            world.step();
            if world.steps_taken() % args.every == 0 || world.steps_taken() == args.steps {
                line(&world);
            }
            if stop_requested() {
                interrupted = true;
                return;
            }
        }
    });
    if interrupted {
        line(&world);
    }
    println!(
        "# {} steps in {:.1} s; most non-finite at once: {worst_nan}; most outside at once: \
         {worst_outside}; peak RSS {:.1} MiB",
        world.steps_taken(),
        started.elapsed().as_secs_f64(),
        peak_rss_mib().unwrap_or(f64::NAN)
    );
    if worst_nan > 0 || worst_outside > 0 {
        return Err(Failure::runtime(
            "soak found non-finite or escaped particles",
        ));
    }
    if interrupted {
        return Err(Failure::Interrupted(format!(
            "interrupted after step {}",
            world.steps_taken()
        )));
    }
    Ok(())
}
