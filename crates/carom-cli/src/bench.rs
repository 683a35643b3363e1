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

mod bare;
mod cases;
use cases::cases;

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
    #[arg(long, hide = true, conflicts_with_all = ["quick", "threads", "json", "out", "plot"])]
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
    /// Largest overlap at the end of the last step, over every pair (see
    /// `World::deepest_overlap`), as a fraction of the smaller radius.
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
    /// The bare step over the case's particles at its end, ns per particle-step (see
    /// [`bare`]).
    bare_ns_per_particle_step: f64,
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
    if let (Some(out), Some(plot)) = (&args.out, &args.plot) {
        crate::input::check_distinct(&[("--out", out), ("--plot", plot)], &[])?;
    }
    let cases = cases(args);
    if args.plot.is_some() && !cases.iter().any(|c| c.group.starts_with("sweep")) {
        return Err(Failure::input(
            "--plot: draws the sweep, which this run leaves out (see --only)",
        ));
    }
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
    // (carom's step, then the bare step over the same particles: see `bare`)
    type Measure = fn(&Measured) -> f64;
    let measures: [(&str, Measure); 2] = [
        ("", |m| m.ns_per_particle_step),
        (", bare step", |m| m.bare_ns_per_particle_step),
    ];
    let mut series = Vec::new();
    for (suffix, measure) in measures {
        for group in ["sweep 2D", "sweep 3D"] {
            let points: Vec<(f64, f64)> = results
                .iter()
                .filter(|m| m.group == group)
                .map(|m| (m.particles as f64, measure(m)))
                .collect();
            if !points.is_empty() {
                series.push(carom_plot::Series {
                    label: format!("{}{suffix}", group.replace("sweep ", "")),
                    points,
                });
            }
        }
    }
    if series.is_empty() {
        return Err(Failure::input("--plot: the sweep did not run (see --only)"));
    }
    let threads = results.first().map(|m| m.threads).unwrap_or(1);
    carom_plot::save_scaling_plot(
        path,
        &series,
        &format!("carom and the bare step: cost per particle-step ({threads} threads)"),
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
    let times = |reference: f64| r.ns_per_particle_step / reference.max(f64::MIN_POSITIVE);
    println!(
        "{:<44} floor {:.2} ns/particle: {:.0}x; bare step {:.1} ns: {:.1}x; {}",
        "",
        r.floor_ns_per_particle,
        times(r.floor_ns_per_particle),
        r.bare_ns_per_particle_step,
        times(r.bare_ns_per_particle_step),
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
    let steps = case.warmup.saturating_add(case.steps);
    crate::input::check_steps("--case: warmup + steps", Some(steps))?;
    // (the case's own thread count: a case run by hand takes the same pool as under `bench`)
    crate::input::set_threads(case.threads)?;
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
    let (mut contacts, mut capped) = (0u64, 0u64);
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
    let bare_ns_per_particle_step = bare::bare_step_ns(&world);
    // (over every pair, not only the last step's contacts; after the peak, which its search
    // must not raise)
    let end_max_overlap = world.deepest_overlap();
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
        bare_ns_per_particle_step,
    })
}
