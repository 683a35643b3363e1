//! `carom bench`: the lecture's timing table, a scale sweep and piles at dt = 1/60, measured on
//! this machine.
//!
//! Every case runs in a child process of its own (`carom bench --case JSON`), so that its peak
//! resident memory is its own and one case's caches and allocations cannot help another.
//! Scenes are built from TOML text through the same scene loader as `carom run`.

use crate::failure::Failure;
use carom_engine::Vector;
use carom_scene::AnyScene;
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

/// Options of `carom bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// A short run (lecture cases with few steps, sweep up to 10^4 particles): a smoke test.
    #[arg(long)]
    pub quick: bool,
    /// Largest particle count in the scale sweep.
    #[arg(long, default_value_t = 4_000_000, allow_negative_numbers = true)]
    pub max: u64,
    /// Which part to run.
    #[arg(long, value_enum, default_value_t = Part::All)]
    pub only: Part,
    /// Worker threads for every case, 1 to 8 per core (at least 64 on any machine; default:
    /// RAYON_NUM_THREADS, else one per core).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Print the results as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also draw ns per particle-step against N for the sweep, as PNG, to this file.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Internal: run one case and print its result as JSON.
    #[arg(long, hide = true)]
    pub case: Option<String>,
}

/// Parts of the benchmark.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// The lecture's table, the sweep and the piles.
    All,
    /// The lecture's table only.
    Lecture,
    /// The scale sweep only.
    Sweep,
    /// Piles at dt = 1/60 (k = 0.5): the lecture pile falling and settled, a 3D pour, 10^6
    /// discs falling, and 10^6 discs in a pile at rest.
    Piles,
}

/// One benchmark case, as handed to the child process.
#[derive(Serialize, Deserialize, Debug, Clone)]
struct Case {
    group: String,
    name: String,
    toml: String,
    warmup: u64,
    steps: u64,
    threads: Option<usize>,
}

/// What a case measured.
#[derive(Serialize, Deserialize, Debug, Clone)]
struct Measured {
    group: String,
    name: String,
    dimensions: usize,
    particles: usize,
    broad_phase: String,
    threads: usize,
    steps: u64,
    ms_per_step: f64,
    ns_per_particle_step: f64,
    contacts_per_step: f64,
    /// Velocity sweeps a timed step made, on average (every pass's, substeps included): the
    /// solver's share of the work, which the time alone does not show.
    sweeps_per_step: f64,
    /// Responses (rule applications that changed a velocity) a timed step made, on average.
    responses_per_step: f64,
    /// Timed steps that hit the velocity sweeps' cap.
    capped_steps: u64,
    /// Largest overlap at the end of the last step, as a fraction of the smaller radius.
    end_max_overlap: f64,
    /// sqrt(2 KE / total mass) at the end.
    end_v_rms: f64,
    bytes_per_particle: f64,
    peak_rss_bytes: u64,
    setup_seconds: f64,
    /// Milliseconds per timed step in each phase of the step (see `carom_engine::PhaseTimes`).
    phases_ms: Vec<(String, f64)>,
    /// The streaming floor for this many particles, ns per particle (see `crate::floor`).
    floor_ns_per_particle: f64,
}

#[derive(Serialize)]
struct Report<'a> {
    machine: Machine,
    command: String,
    results: &'a [Measured],
}

#[derive(Serialize)]
struct Machine {
    cpu: String,
    cores: usize,
    memory_gib: f64,
    os: String,
}

fn machine() -> Machine {
    use carom_scene::machine;
    Machine {
        cpu: machine::cpu_model().unwrap_or_else(|| "unknown".into()),
        cores: machine::cores(),
        memory_gib: machine::total_memory_bytes().map_or(0.0, |b| b as f64 / (1u64 << 30) as f64),
        os: std::env::consts::OS.to_string(),
    }
}

/// A `[[fill]]`: count, radius, seed.
type Fill = (u64, f64, u64);

/// The lecture's gas: `count` particles in (-100, 100)^2, gravity, walls, k = 1.
fn lecture_toml(broadphase: &str, fills: &[Fill]) -> String {
    let mut t = String::from(
        "dimensions = 2\ndt = 0.005\ngravity = [0.0, -9.8]\nrestitution = 1.0\n\
         [domain]\nmin = [-100.0, -100.0]\nmax = [100.0, 100.0]\nwalls = true\n",
    );
    t.push_str(&format!("[broadphase]\n{broadphase}\n"));
    for &(count, radius, seed) in fills {
        t.push_str(&format!(
            "[[fill]]\ncount = {count}\nradius = {radius}\nspeed = 20.0\nseed = {seed}\n"
        ));
    }
    t
}

/// The sweep's scene: `n` particles of radius 1 at a fixed area (2D: 0.3) or volume (3D: 0.2)
/// fraction in a walled cube, gravity, k = 1.
fn sweep_toml(dim: usize, n: u64) -> String {
    use std::f64::consts::PI;
    let (side, g) = if dim == 2 {
        ((n as f64 * PI / 0.3).sqrt(), "[0.0, -9.8]")
    } else {
        ((n as f64 * 4.0 / 3.0 * PI / 0.2).cbrt(), "[0.0, -9.8, 0.0]")
    };
    let half = side / 2.0;
    let lo: Vec<String> = (0..dim).map(|_| format!("{:.6}", -half)).collect();
    let hi: Vec<String> = (0..dim).map(|_| format!("{half:.6}")).collect();
    format!(
        "dimensions = {dim}\ndt = 0.005\ngravity = {g}\nrestitution = 1.0\n\
         [domain]\nmin = [{}]\nmax = [{}]\nwalls = true\n\
         [[fill]]\ncount = {n}\nradius = 1.0\nspeed = 10.0\nseed = 1\n",
        lo.join(", "),
        hi.join(", ")
    )
}

/// A pile scene at dt = 1/60, k = 0.5, g = 9.81 (the targets): `count` particles of
/// `radius` poured into a walled box from `min` to `max`, filled at random over the box.
fn pile_toml(dim: usize, count: u64, radius: f64, min: &[f64], max: &[f64]) -> String {
    format!(
        "{}[[fill]]\ncount = {count}\nradius = {radius}\nspeed = 7.0\nseed = {count}\n",
        walled_box_toml(dim, min, max)
    )
}

/// The part of [`pile_toml`] before its fill: settings and the walled box.
fn walled_box_toml(dim: usize, min: &[f64], max: &[f64]) -> String {
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let g = if dim == 2 {
        "[0.0, -9.81]"
    } else {
        "[0.0, -9.81, 0.0]"
    };
    format!(
        "dimensions = {dim}\ndt = 0.016666666666666666\ngravity = {g}\nrestitution = 0.5\n\
         [domain]\nmin = [{}]\nmax = [{}]\nwalls = true\n",
        list(min),
        list(max)
    )
}

/// The pile cases: each scene timed while falling and (where it settles within the bench)
/// once settled.
fn pile_cases(args: &BenchArgs) -> Vec<Case> {
    let threads = args.threads;
    let case = |name: &str, toml: String, warmup: u64, steps: u64| Case {
        group: "piles".into(),
        name: name.into(),
        toml,
        warmup,
        steps,
        threads,
    };
    // the shipped `lecture_pile_60hz` scene (particles at rest sleep, the default), and the same
    // kept awake to time the solver on a settled pile
    let lecture = pile_toml(2, 5000, 1.0, &[-100.0; 2], &[100.0; 2]);
    let awake = format!("{lecture}[solver]\nsleep = false\n");
    if args.quick {
        return vec![case("2D lecture pile, falling", lecture, 10, 20)];
    }
    // 100,000 spheres poured into an 80 x 240 x 80 box: landing by step 400, settling in the
    // pile after, asleep whole from step 996 (see docs/benchmarks.md)
    let pour = pile_toml(
        3,
        100_000,
        1.0,
        &[-40.0, -40.0, -40.0],
        &[40.0, 200.0, 40.0],
    );
    // 10^6 discs r = 0.5 at area fraction 0.3 (they need ~1100 steps to reach the floor)
    let million = pile_toml(2, 1_000_000, 0.5, &[-809.0; 2], &[809.0; 2]);
    // the pile those discs would end as, at rest from the start: 619 hexagonal rows from wall
    // to wall (the box a hair wider, for the fill's spacing), asleep whole from step 32
    let settled = format!(
        "{}[[fill]]\ncount = 1000000\nradius = 0.5\nspeed = 0.0\narrangement = \"hex\"\n\
         min = [-809.001, -809.001]\nmax = [809.001, -200.0]\n",
        walled_box_toml(2, &[-809.001; 2], &[809.001; 2])
    );
    vec![
        case(
            "2D lecture pile, falling (steps 10-300)",
            lecture.clone(),
            10,
            290,
        ),
        case(
            "2D lecture pile, settled awake (1500-1800)",
            awake,
            1500,
            300,
        ),
        case(
            "2D lecture pile, settled asleep (1500-1800)",
            lecture,
            1500,
            300,
        ),
        case("3D pour 10^5, falling (steps 10-60)", pour.clone(), 10, 50),
        case(
            "3D pour 10^5, settling in the pile (steps 600-700)",
            pour.clone(),
            600,
            100,
        ),
        case("3D pour 10^5, asleep (steps 1200-1300)", pour, 1200, 100),
        case("2D 10^6 discs, falling (steps 10-40)", million, 10, 30),
        case(
            "2D 10^6 discs, a pile at rest, awake (steps 5-15)",
            settled.clone(),
            5,
            10,
        ),
        case(
            "2D 10^6 discs, a pile at rest, asleep (steps 35-45)",
            settled,
            35,
            10,
        ),
    ]
}

fn cases(args: &BenchArgs) -> Vec<Case> {
    let mut out = Vec::new();
    let threads = args.threads;
    if args.only == Part::Piles {
        return pile_cases(args);
    }
    if args.only != Part::Sweep {
        // The same steps for every broad phase, so each times the same physics (the
        // gas settles as it runs, and a pile has more contacts than a gas).
        let steps = if args.quick { 5 } else { 300 };
        let (brute_steps, grid_steps) = (steps, steps);
        let radii: [(&str, Vec<Fill>); 2] = [
            ("r = 1", vec![(5000, 1.0, 5000)]),
            ("r = 1 and 3", vec![(100, 3.0, 3), (4900, 1.0, 1)]),
        ];
        for (label, fills) in radii {
            for (bp, name, steps) in [
                ("kind = \"brute\"", "brute force", brute_steps),
                (
                    "kind = \"grid\"\ncells = [100, 100]",
                    "grid 100x100",
                    grid_steps,
                ),
                (
                    "kind = \"grid\"\ncells = [50, 50]",
                    "grid 50x50",
                    grid_steps,
                ),
            ] {
                out.push(Case {
                    group: "lecture".into(),
                    name: format!("5000 particles, {label}, {name}"),
                    toml: lecture_toml(bp, &fills),
                    warmup: 10,
                    steps,
                    threads,
                });
            }
        }
    }
    let mut single_thread = Vec::new();
    if args.only != Part::Lecture {
        let max = if args.quick {
            args.max.min(10_000)
        } else {
            args.max
        };
        for dim in [2usize, 3] {
            for n in [1_000u64, 10_000, 100_000, 1_000_000, 4_000_000] {
                if n > max {
                    continue;
                }
                let steps = if args.quick { 10 } else { 40 };
                out.push(Case {
                    group: format!("sweep {dim}D"),
                    name: format!("{dim}D, {n} particles"),
                    toml: sweep_toml(dim, n),
                    warmup: 10,
                    steps,
                    threads,
                });
                if n == 1_000_000 && threads != Some(1) {
                    single_thread.push(Case {
                        group: format!("threads {dim}D"),
                        name: format!("{dim}D, {n} particles, 1 thread"),
                        toml: sweep_toml(dim, n),
                        warmup: 10,
                        steps,
                        threads: Some(1),
                    });
                }
            }
        }
    }
    out.extend(single_thread);
    if args.only == Part::All {
        out.extend(pile_cases(args));
    }
    out
}

/// `carom bench`.
pub fn bench(args: &BenchArgs) -> Result<(), Failure> {
    if let Some(json) = &args.case {
        return run_case(json);
    }
    crate::input::check_threads(args.threads)?;
    for (flag, path) in [("--out", &args.out), ("--plot", &args.plot)] {
        if let Some(p) = path {
            crate::input::check_output_path(flag, p)?;
        }
    }
    let cases = cases(args);
    let exe = std::env::current_exe()
        .map_err(|e| Failure::runtime(format!("cannot find the carom binary: {e}")))?;
    let progress = ProgressBar::new(cases.len() as u64);
    progress.set_style(
        ProgressStyle::with_template("{spinner} case {pos}/{len} {wide_msg} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut results = Vec::new();
    for case in &cases {
        progress.set_message(case.name.clone());
        let json = serde_json::to_string(case).map_err(|e| Failure::runtime(e.to_string()))?;
        let mut cmd = Command::new(&exe);
        cmd.args(["bench", "--case", &json]);
        if let Some(t) = case.threads {
            cmd.env("RAYON_NUM_THREADS", t.to_string());
        }
        let output = cmd
            .output()
            .map_err(|e| Failure::runtime(format!("cannot start a benchmark case: {e}")))?;
        if !output.status.success() {
            return Err(Failure::runtime(format!(
                "benchmark case `{}` failed: {}",
                case.name,
                String::from_utf8_lossy(&output.stderr).trim()
            )));
        }
        let measured: Measured = serde_json::from_slice(&output.stdout).map_err(|e| {
            Failure::runtime(format!(
                "benchmark case `{}` gave no result: {e}",
                case.name
            ))
        })?;
        results.push(measured);
        progress.inc(1);
    }
    progress.finish_and_clear();

    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let report = Report {
        machine: machine(),
        command,
        results: &results,
    };
    let json =
        serde_json::to_string_pretty(&report).map_err(|e| Failure::runtime(e.to_string()))?;
    if let Some(path) = &args.out {
        carom_output::write_atomic(path, |w| std::io::Write::write_all(w, json.as_bytes()))
            .map_err(|e| Failure::runtime(format!("cannot write {}: {e}", path.display())))?;
    }
    if let Some(path) = &args.plot {
        plot(path, &results)?;
    }
    if args.json {
        println!("{json}");
    } else {
        print_table(&report);
    }
    Ok(())
}

fn plot(path: &std::path::Path, results: &[Measured]) -> Result<(), Failure> {
    let mut series = Vec::new();
    for group in ["sweep 2D", "sweep 3D"] {
        let points: Vec<(f64, f64)> = results
            .iter()
            .filter(|m| m.group == group)
            .map(|m| (m.particles as f64, m.ns_per_particle_step))
            .collect();
        if !points.is_empty() {
            series.push(carom_plot::Series {
                label: group.replace("sweep ", ""),
                points,
            });
        }
    }
    if series.is_empty() {
        return Err(Failure::input("--plot: the sweep did not run (see --only)"));
    }
    let threads = results.first().map(|m| m.threads).unwrap_or(1);
    carom_plot::save_scaling_plot(
        path,
        &series,
        &format!("carom: cost per particle-step ({threads} threads)"),
        "particles N",
        "ns per particle-step",
    )
    .map_err(|e| Failure::runtime(format!("cannot draw {}: {e}", path.display())))
}

fn print_table(report: &Report) {
    let m = &report.machine;
    println!(
        "machine: {} ({} cores, {:.0} GiB, {})",
        m.cpu, m.cores, m.memory_gib, m.os
    );
    println!("command: {}", report.command);
    println!();
    println!(
        "{:<44} {:>9} {:>8} {:>10} {:>12} {:>14} {:>10}",
        "case", "particles", "threads", "ms/step", "ns/particle", "contacts/step", "bytes/part"
    );
    let mut group = "";
    for r in report.results {
        if r.group != group {
            group = &r.group;
            println!("-- {group}");
        }
        println!(
            "{:<44} {:>9} {:>8} {:>10.4} {:>12.1} {:>14.1} {:>10.0}",
            r.name,
            r.particles,
            r.threads,
            r.ms_per_step,
            r.ns_per_particle_step,
            r.contacts_per_step,
            r.bytes_per_particle
        );
        print_phases(r);
        if r.group == "piles" {
            println!(
                "{:<44} capped {}/{} steps, end: max overlap {:.3}% r, v_rms {:.4}",
                "",
                r.capped_steps,
                r.steps,
                100.0 * r.end_max_overlap,
                r.end_v_rms
            );
        }
    }
    // The lecture's comparison: grid against brute force in this run.
    for radii in ["r = 1,", "r = 1 and 3,"] {
        let find = |bp: &str| {
            report
                .results
                .iter()
                .find(|r| r.group == "lecture" && r.name.contains(radii) && r.name.ends_with(bp))
        };
        if let (Some(b), Some(g)) = (find("brute force"), find("grid 100x100")) {
            println!(
                "lecture {}: grid 100x100 is {:.0}x faster than brute force here (lecture: 0.18 s vs 0.006 s, 30x)",
                radii.trim_end_matches(','),
                b.ms_per_step / g.ms_per_step
            );
        }
    }
    for dim in ["2D", "3D"] {
        let one = report
            .results
            .iter()
            .find(|r| r.group == format!("threads {dim}"));
        let many = report
            .results
            .iter()
            .find(|r| r.group == format!("sweep {dim}") && r.particles == 1_000_000);
        if let (Some(a), Some(b)) = (one, many) {
            println!(
                "{dim} at 10^6: {} threads are {:.2}x faster than 1 thread",
                b.threads,
                a.ms_per_step / b.ms_per_step
            );
        }
    }
}

/// A case's phase breakdown and its ratio to the streaming floor, under its row of the table.
fn print_phases(r: &Measured) {
    let phases: Vec<String> = r
        .phases_ms
        .iter()
        .filter(|(_, ms)| *ms > 0.0)
        .map(|(name, ms)| {
            format!(
                "{name} {:.0}%",
                100.0 * ms / r.ms_per_step.max(f64::MIN_POSITIVE)
            )
        })
        .collect();
    println!(
        "{:<44} floor {:.2} ns/particle: {:.0}x; {}",
        "",
        r.floor_ns_per_particle,
        r.ns_per_particle_step / r.floor_ns_per_particle.max(f64::MIN_POSITIVE),
        phases.join(", ")
    );
    println!(
        "{:<44} solver: {:.1} velocity sweeps and {:.0} responses a step",
        "", r.sweeps_per_step, r.responses_per_step
    );
}

/// Peak resident memory of this process so far (0 where the system does not say).
fn peak_rss_bytes() -> u64 {
    carom_scene::machine::peak_rss_bytes().unwrap_or(0)
}

fn run_case(json: &str) -> Result<(), Failure> {
    let case: Case =
        serde_json::from_str(json).map_err(|e| Failure::input(format!("--case: {e}")))?;
    let started = Instant::now();
    let scene = carom_scene::parse(&case.toml, &format!("bench:{}", case.name))?;
    let measured = match scene {
        AnyScene::Two(s) => measure(&case, s, started),
        AnyScene::Three(s) => measure(&case, s, started),
    }?;
    println!(
        "{}",
        serde_json::to_string(&measured).map_err(|e| Failure::runtime(e.to_string()))?
    );
    Ok(())
}

fn measure<V: Vector>(
    case: &Case,
    scene: carom_scene::Scene<V>,
    started: Instant,
) -> Result<Measured, Failure> {
    let mut world = scene
        .into_world()
        .map_err(|e| Failure::input(e.to_string()))?;
    let n = world.len();
    let (mut contacts, mut capped, mut end_max_overlap) = (0u64, 0u64, 0.0);
    let (mut sweeps, mut responses) = (0u64, 0u64);
    // On a pool thread, as `carom run` steps (see run.rs).
    let (setup_seconds, seconds) = rayon::scope(|_| {
        for _ in 0..case.warmup {
            world.step();
        }
        let setup_seconds = started.elapsed().as_secs_f64();
        world.reset_phase_times();
        let t = Instant::now();
        for _ in 0..case.steps {
            let stats = world.step();
            contacts += stats.contacts as u64;
            capped += stats.capped as u64;
            sweeps += stats.velocity_iterations as u64;
            responses += stats.responses;
            end_max_overlap = stats.max_overlap;
        }
        (setup_seconds, t.elapsed().as_secs_f64())
    });
    let mass = world.total_mass();
    let end_v_rms = (2.0 * world.kinetic_energy() / mass.max(f64::MIN_POSITIVE)).sqrt();
    let steps = case.steps.max(1) as f64;
    let peak = peak_rss_bytes();
    let phases = world.phase_times();
    let phases_ms = phases
        .phases()
        .iter()
        .map(|(name, time)| (name.to_string(), time.as_secs_f64() * 1e3 / steps))
        .collect();
    // (after the case, on the same pool: the floor's buffers must not count in its peak)
    let floor_ns_per_particle = rayon::scope(|_| crate::floor::streaming_floor::<V>(n));
    Ok(Measured {
        group: case.group.clone(),
        name: case.name.clone(),
        dimensions: V::DIM,
        particles: n,
        broad_phase: world.broad_phase_name().to_string(),
        threads: rayon::current_num_threads(),
        steps: case.steps,
        ms_per_step: seconds * 1e3 / steps,
        ns_per_particle_step: seconds * 1e9 / steps / n.max(1) as f64,
        contacts_per_step: contacts as f64 / steps,
        sweeps_per_step: sweeps as f64 / steps,
        responses_per_step: responses as f64 / steps,
        capped_steps: capped,
        end_max_overlap,
        end_v_rms,
        bytes_per_particle: peak as f64 / n.max(1) as f64,
        peak_rss_bytes: peak,
        setup_seconds,
        phases_ms,
        floor_ns_per_particle,
    })
}
