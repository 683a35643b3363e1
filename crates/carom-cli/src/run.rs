//! `carom run` and `carom check`.

use crate::{BroadPhaseArg, RunArgs};
use carom_engine::{BroadPhaseKind, Vector, World};
use carom_scene::{AnyScene, Scene};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;
use std::time::Instant;

/// A failure with the exit status it deserves: 2 for bad input, 1 for a failure while working.
pub struct Failure {
    pub status: u8,
    pub message: String,
}

impl Failure {
    pub fn input(message: impl Into<String>) -> Self {
        Self {
            status: 2,
            message: message.into(),
        }
    }
    pub fn runtime(message: impl Into<String>) -> Self {
        Self {
            status: 1,
            message: message.into(),
        }
    }
}

fn load(args: &RunArgs) -> Result<(AnyScene, String), Failure> {
    match (&args.scene, &args.preset) {
        (Some(path), _) => {
            let scene = carom_scene::load(path).map_err(|e| Failure::input(e.to_string()))?;
            Ok((scene, path.display().to_string()))
        }
        (None, preset) => {
            let name = preset.as_deref().unwrap_or(carom_scene::DEFAULT_PRESET);
            let text = carom_scene::preset(name).ok_or_else(|| {
                let names: Vec<_> = carom_scene::preset_names().collect();
                Failure::input(format!(
                    "--preset: no built-in scene `{name}`; there are: {}",
                    names.join(", ")
                ))
            })?;
            let origin = format!("preset:{name}");
            let scene =
                carom_scene::parse(text, &origin).map_err(|e| Failure::input(e.to_string()))?;
            Ok((scene, origin))
        }
    }
}

/// Refuses an output path whose folder is missing or which is a folder itself, before any
/// work is done.
pub fn check_output_path(flag: &str, out: &Path) -> Result<(), Failure> {
    let dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(Failure::input(format!(
            "{flag}: folder {} does not exist",
            dir.display()
        )));
    }
    if out.is_dir() {
        return Err(Failure::input(format!(
            "{flag}: {} is a folder",
            out.display()
        )));
    }
    Ok(())
}

pub fn check(path: &Path) -> Result<(), Failure> {
    let scene = carom_scene::load(path).map_err(|e| Failure::input(e.to_string()))?;
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

pub fn run(args: &RunArgs) -> Result<(), Failure> {
    if let Some(threads) = args.threads {
        if threads == 0 {
            return Err(Failure::input("--threads: must be at least 1"));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .map_err(|e| Failure::runtime(format!("cannot start {threads} threads: {e}")))?;
    }
    if let Some(out) = &args.out {
        check_output_path("--out", out)?;
    }
    let (scene, origin) = load(args)?;
    match scene {
        AnyScene::Two(s) => run_scene(s, &origin, args),
        AnyScene::Three(s) => run_scene(s, &origin, args),
    }
}

fn run_scene<V: Vector>(mut scene: Scene<V>, origin: &str, args: &RunArgs) -> Result<(), Failure> {
    if let Some(steps) = args.steps {
        scene.steps = steps;
    }
    match args.broadphase {
        Some(BroadPhaseArg::Brute) => scene.config.broad_phase = BroadPhaseKind::Brute,
        Some(BroadPhaseArg::Grid) => scene.config.broad_phase = BroadPhaseKind::Grid,
        Some(BroadPhaseArg::Hash) => scene.config.broad_phase = BroadPhaseKind::Hash,
        None => {}
    }
    if let Some(cells) = &args.cells {
        if cells.len() != V::DIM || cells.contains(&0) {
            return Err(Failure::input(format!(
                "--cells: needs {} whole numbers >= 1 (the scene is {}D), got {cells:?}",
                V::DIM,
                V::DIM
            )));
        }
        if scene.config.broad_phase != BroadPhaseKind::Grid {
            return Err(Failure::input(
                "--cells: only the grid has cells, and this run does not use it; add --broadphase grid",
            ));
        }
        scene.config.grid_cells = Some(cells.clone());
    }
    let name = scene.name.clone();
    let steps = scene.steps;
    let mut world = scene
        .into_world()
        .map_err(|e| Failure::input(format!("{origin}: {e}")))?;

    let energy_before = (world.kinetic_energy(), world.potential_energy());
    let momentum_before = world.momentum();

    let progress = ProgressBar::new(steps);
    progress.set_style(
        ProgressStyle::with_template("{spinner} step {pos}/{len} {wide_bar} {eta} left")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut contacts_total: u64 = 0;
    let mut contacts_max = 0usize;
    let mut capped_steps = 0u64;
    let started = Instant::now();
    // Step on a pool thread: parallel calls made from outside the pool go through rayon's
    // global queue, which allocates as it goes; from inside, stepping allocates nothing.
    rayon::scope(|_| {
        for step in 0..steps {
            let stats = world.step();
            contacts_total += stats.contacts as u64;
            contacts_max = contacts_max.max(stats.contacts);
            capped_steps += stats.capped as u64;
            if step % 64 == 63 {
                progress.set_position(step + 1);
            }
        }
    });
    let elapsed = started.elapsed().as_secs_f64();
    progress.finish_and_clear();

    if let Some(out) = &args.out {
        carom_output::save_state_csv(out, world.particles())
            .map_err(|e| Failure::runtime(format!("cannot write {}: {e}", out.display())))?;
    }
    print_summary(
        name.as_deref(),
        steps,
        origin,
        &world,
        energy_before,
        momentum_before,
        elapsed,
        contacts_total,
        contacts_max,
        capped_steps,
        args,
    );
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn print_summary<V: Vector>(
    name: Option<&str>,
    steps: u64,
    origin: &str,
    world: &World<V>,
    (ke0, pe0): (f64, f64),
    p0: V,
    seconds: f64,
    contacts_total: u64,
    contacts_max: usize,
    capped_steps: u64,
    args: &RunArgs,
) {
    let name = name.unwrap_or("(unnamed)");
    println!("scene       {name} [{origin}]");
    let broad = match world.grid_cells() {
        Some(c) => {
            let cells: Vec<String> = c[..V::DIM].iter().map(|n| n.to_string()).collect();
            format!("grid {}", cells.join("x"))
        }
        None => world.broad_phase_name().to_string(),
    };
    println!(
        "particles   {} ({}D), broad phase {broad}, {} threads",
        world.particles().len(),
        V::DIM,
        rayon::current_num_threads()
    );
    println!(
        "steps       {steps} x dt {} = {} time units simulated",
        world.config().dt,
        world.time()
    );
    if steps > 0 {
        println!(
            "time        {:.3} s wall, {:.4} ms per step",
            seconds,
            seconds * 1e3 / steps as f64
        );
        println!(
            "contacts    {:.2} per step on average, {contacts_max} at most{}",
            contacts_total as f64 / steps as f64,
            if capped_steps > 0 {
                format!(", iteration cap reached in {capped_steps} steps")
            } else {
                String::new()
            }
        );
    }
    let (ke1, pe1) = (world.kinetic_energy(), world.potential_energy());
    println!(
        "energy      kinetic {} -> {} ({})",
        fmt(ke0),
        fmt(ke1),
        change(ke0, ke1)
    );
    // Potential energy has an arbitrary zero (the origin), so only its change means anything.
    println!(
        "            kinetic + potential changed by {:+.6e} ({:+.3}% of the initial kinetic)",
        (ke1 + pe1) - (ke0 + pe0),
        if ke0 > 0.0 {
            ((ke1 + pe1) - (ke0 + pe0)) / ke0 * 100.0
        } else {
            0.0
        }
    );
    println!(
        "momentum    {} -> {}",
        vec_fmt(p0),
        vec_fmt(world.momentum())
    );
    if let Some(out) = &args.out {
        println!("output      {}", out.display());
    }
}

fn fmt(x: f64) -> String {
    format!("{x:.6e}")
}

fn change(a: f64, b: f64) -> String {
    if a == 0.0 {
        format!("{:+.3e}", b - a)
    } else {
        format!("{:+.3}%", (b - a) / a.abs() * 100.0)
    }
}

fn vec_fmt<V: Vector>(v: V) -> String {
    let parts: Vec<String> = (0..V::DIM).map(|a| format!("{:.6e}", v.get(a))).collect();
    format!("({})", parts.join(", "))
}

/// Loads the scene named by `args` (a file, a preset, or the default preset), for other
/// subcommands (`carom render`).
pub(crate) fn load_scene(args: &RunArgs) -> Result<(AnyScene, String), Failure> {
    load(args)
}
