//! `carom run` and `carom check`.

use crate::session::Stepper;
use crate::session::{drive, install_interrupt_handler, Driven, Outputs, Settings, INTERRUPTED};
use crate::{BroadPhaseArg, RunArgs};
use carom_engine::cluster::Transport;
use carom_engine::{BroadPhaseKind, Vector, World};
use carom_scene::{AnyScene, Scene};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;

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
    /// An exit status without a message (a rank other than 0 of a split run: rank 0 says why).
    pub fn quiet(status: u8) -> Self {
        Self {
            status,
            message: String::new(),
        }
    }
}

/// The TOML text of a scene file, or of a preset (the default one when neither is given), and
/// where it came from. Shared by every subcommand that takes `[SCENE] [--preset NAME]`.
pub fn scene_text(scene: Option<&Path>, preset: Option<&str>) -> Result<(String, String), Failure> {
    match scene {
        Some(path) => {
            let origin = path.display().to_string();
            let text = std::fs::read_to_string(path)
                .map_err(|e| Failure::input(format!("{origin}: cannot read scene file: {e}")))?;
            Ok((text, origin))
        }
        None => {
            let name = preset.unwrap_or(carom_scene::DEFAULT_PRESET);
            let text = carom_scene::preset(name).ok_or_else(|| {
                let names: Vec<_> = carom_scene::preset_names().collect();
                Failure::input(format!(
                    "--preset: no built-in scene `{name}`; there are: {}",
                    names.join(", ")
                ))
            })?;
            Ok((text.to_string(), format!("preset:{name}")))
        }
    }
}

/// The scene a subcommand names, parsed, with its origin and its TOML text (kept in
/// checkpoints).
pub fn load_scene(
    scene: Option<&Path>,
    preset: Option<&str>,
) -> Result<(AnyScene, String, String), Failure> {
    let (text, origin) = scene_text(scene, preset)?;
    let parsed = carom_scene::parse(&text, &origin).map_err(|e| Failure::input(e.to_string()))?;
    Ok((parsed, origin, text))
}

/// Sets the global thread count (`--threads`), refusing 0.
pub fn set_threads(threads: Option<usize>) -> Result<(), Failure> {
    if let Some(threads) = threads {
        if threads == 0 {
            return Err(Failure::input("--threads: must be at least 1"));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .map_err(|e| Failure::runtime(format!("cannot start {threads} threads: {e}")))?;
    }
    Ok(())
}

/// Applies `--broadphase` and `--cells` to a scene.
pub fn apply_overrides<V: Vector>(
    scene: &mut Scene<V>,
    broadphase: Option<&str>,
    cells: Option<&[usize]>,
) -> Result<(), Failure> {
    match broadphase {
        Some("brute") => scene.config.broad_phase = BroadPhaseKind::Brute,
        Some("grid") => scene.config.broad_phase = BroadPhaseKind::Grid,
        Some("hash") => scene.config.broad_phase = BroadPhaseKind::Hash,
        Some(other) => return Err(Failure::input(format!("--broadphase: unknown `{other}`"))),
        None => {}
    }
    if let Some(cells) = cells {
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
        scene.config.grid_cells = Some(cells.to_vec());
    }
    Ok(())
}

/// The step progress bar (drawn only on a terminal).
pub fn progress_bar(steps: u64) -> ProgressBar {
    let progress = ProgressBar::new(steps);
    progress.set_style(
        ProgressStyle::with_template("{spinner} step {pos}/{len} {wide_bar} {eta} left")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    progress
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
    set_threads(args.threads)?;
    if let Some(out) = &args.out {
        check_output_path("--out", out)?;
    }
    let (scene, origin, text) = load_scene(args.scene.as_deref(), args.preset.as_deref())?;
    match scene {
        AnyScene::Two(s) => run_scene(s, &origin, text, args),
        AnyScene::Three(s) => run_scene(s, &origin, text, args),
    }
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
    let broadphase = args.broadphase.map(|b| match b {
        BroadPhaseArg::Brute => "brute",
        BroadPhaseArg::Grid => "grid",
        BroadPhaseArg::Hash => "hash",
    });
    apply_overrides(&mut scene, broadphase, args.cells.as_deref())?;
    let outputs = Outputs {
        checkpoint: args.checkpoint.clone().zip(args.checkpoint_every),
        trajectory: args.trajectory.clone().zip(args.every),
        observe: args.observe.clone().zip(args.every),
        scene_toml: text,
        origin: origin.to_string(),
        settings: Settings {
            steps: scene.steps,
            broadphase: broadphase.map(str::to_string),
            cells: args.cells.clone(),
        },
    };
    outputs.check()?;
    let name = scene.name.clone();
    let steps = scene.steps;
    let rebuild = || {
        scene
            .clone()
            .into_world()
            .map_err(|e| Failure::input(format!("{origin}: {e}")))
    };
    let world = rebuild()?;
    let run = Labels {
        name: name.as_deref(),
        origin,
        out: args.out.as_deref(),
    };
    run_world(world, &rebuild, args.ranks, steps, &outputs, &run)
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
        Some(0) => return Err(Failure::input("--ranks: must be at least 1")),
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
            acc.and(r.or_else(|e| if e.message.is_empty() { Ok(()) } else { Err(e) }))
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
            crate::session::quiet_interrupts();
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
            Some(_) => Err(Failure::quiet(INTERRUPTED)),
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
        return Err(Failure {
            status: INTERRUPTED,
            message: format!(
                "interrupted after step {at}; trajectory frames so far are on disk, and the \
                 checkpoint (if one was asked for) holds step {at}: continue with `carom resume`"
            ),
        });
    }
    if let Some(out) = run.out {
        // Through the session's writer, so that a second Ctrl-C cannot leave it half done.
        crate::session::write_whole(out, |w| carom_output::write_state_csv(world.particles(), w))
            .map_err(|e| Failure::runtime(format!("cannot write {}: {e}", out.display())))?;
    }
    print_summary(run.name, run.origin, world, &before, driven, run.out);
    Ok(())
}

fn print_summary<V: Vector>(
    name: Option<&str>,
    origin: &str,
    world: &World<V>,
    before: &Before<V>,
    driven: &crate::session::Driven,
    out: Option<&Path>,
) {
    let steps = driven.steps_run;
    let (ke0, pe0, p0) = (before.kinetic, before.potential, before.momentum);
    let (seconds, contacts_total, contacts_max) =
        (driven.seconds, driven.contacts_total, driven.contacts_max);
    let (capped_steps, last_overlap, worst_overlap) = (
        driven.capped_steps,
        driven.last_overlap,
        driven.worst_overlap,
    );
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
            match driven.last_capped {
                Some(last) if capped_steps > 0 => format!(
                    ", iteration cap reached in {capped_steps} steps (the last at step {last})"
                ),
                _ => String::new(),
            }
        );
        println!(
            "collisions  {} particle-particle impacts, {:.4} per particle per time unit",
            driven.collisions_total,
            driven.collisions_total as f64
                / (world.len().max(1) as f64 * steps as f64 * world.config().dt)
        );
        if capped_steps > 0 {
            println!(
                "solver      the velocity sweeps stopped at their cap ({}) in {capped_steps} of \
                 {steps} steps: contacts still approaching then were met again the next step \
                 (momentum stays exact, the position phase bounds the overlap; a dense gas at \
                 low k collapses inelastically, a deep pile needs more sweeps: [solver] \
                 velocity_iterations)",
                world.config().velocity_iterations
            );
        }
        if world.config().sleep_settings(world.planes()).is_some() {
            let n = world.len();
            match driven.asleep_since {
                Some(since) if driven.asleep_last == n => {
                    println!("sleep       all {n} particles asleep since step {since}")
                }
                _ => println!(
                    "sleep       {} of {n} particles asleep at the end",
                    driven.asleep_last
                ),
            }
        }
        println!(
            "overlap     {:.3}% of the smaller radius at the end, {:.3}% at most",
            last_overlap * 100.0,
            worst_overlap * 100.0
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
    if let Some(out) = out {
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
