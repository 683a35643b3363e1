//! `carom resume`: continue a run from its checkpoint, bit for bit, through the same driver as
//! `carom run`.

use crate::driver::step::{check_long_run, frame_folder, named_outputs, Outputs};
use crate::driver::Labels;
use crate::failure::Failure;
use crate::input::{check_distinct, check_output_path, check_ranks, check_steps, set_threads};
use crate::launch::{copies_of, run_world};
use carom_engine::Vector;
use carom_output::checkpoint::Checkpoint;
use carom_scene::RunSettings;
use std::path::PathBuf;

/// Options of `carom resume`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("framed").args(["trajectory", "observe"]).multiple(true)))]
pub struct ResumeArgs {
    /// A checkpoint written by `carom run --checkpoint`.
    pub checkpoint: PathBuf,
    /// Total steps to reach (default: the original run's), at least the checkpoint's step and
    /// at most 10^12.
    #[arg(long, allow_negative_numbers = true)]
    pub steps: Option<u64>,
    /// Write the final state here as CSV.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Keep checkpointing (to this file) every `--checkpoint-every` steps.
    #[arg(long, requires = "checkpoint_every")]
    pub checkpoint_to: Option<PathBuf>,
    /// Steps between checkpoints (with `--checkpoint-to`).
    #[arg(long, requires = "checkpoint_to", allow_negative_numbers = true)]
    pub checkpoint_every: Option<u64>,
    /// Append trajectory frames to this CSV (or VTK series, for a `.pvd`) every `--every` steps.
    #[arg(long, requires = "every")]
    pub trajectory: Option<PathBuf>,
    /// Append the observables to this CSV every `--every` steps (see `carom run --observe`).
    #[arg(long, requires = "every")]
    pub observe: Option<PathBuf>,
    /// Steps between trajectory frames and observables rows.
    #[arg(long, requires = "framed", allow_negative_numbers = true)]
    pub every: Option<u64>,
    /// Worker threads, 1 to 8 per core (at least 64 on any machine).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Split the continued run over N ranks, as threads (see `carom run --ranks`); under
    /// `mpirun` the run is split over its processes anyway.
    #[arg(long, allow_negative_numbers = true)]
    pub ranks: Option<usize>,
}

/// `carom resume`.
pub fn resume(args: &ResumeArgs) -> Result<(), Failure> {
    set_threads(args.threads)?;
    check_ranks(args.ranks)?;
    check_steps("--steps", args.steps)?;
    if let Some(out) = &args.out {
        check_output_path("--out", out)?;
    }
    let frames = args.trajectory.as_deref().and_then(frame_folder);
    let outputs = named_outputs(
        [
            ("--out", args.out.as_deref()),
            ("--checkpoint-to", args.checkpoint_to.as_deref()),
            ("--trajectory", args.trajectory.as_deref()),
            ("--observe", args.observe.as_deref()),
        ],
        frames.as_deref(),
    );
    check_distinct(&outputs, &[])?;
    // (writing the next checkpoints over the one being read is how a long run goes on)
    let over_the_checkpoint: Vec<_> = outputs
        .into_iter()
        .filter(|(flag, _)| *flag != "--checkpoint-to")
        .collect();
    check_distinct(&over_the_checkpoint, &[("checkpoint", &args.checkpoint)])?;
    check_long_run(
        args.checkpoint_to.as_deref().zip(args.checkpoint_every),
        args.trajectory.as_deref().zip(args.every),
        args.observe.as_deref().zip(args.every),
        args.ranks,
    )?;
    let shown = args.checkpoint.display().to_string();
    let bytes = carom_output::read_regular_file(&args.checkpoint)
        .map_err(|e| Failure::input(format!("{shown}: cannot read checkpoint: {e}")))?;
    let cp = Checkpoint::read_from(&bytes).map_err(|source| Failure::Checkpoint {
        path: shown.clone(),
        source,
    })?;
    // (the file's bytes are done with: they would stay beside the world for the whole run)
    drop(bytes);
    let settings: RunSettings = serde_json::from_str(&cp.settings_json)
        .map_err(|e| Failure::input(format!("{shown}: damaged run settings: {e}")))?;
    carom_scene::check_stored_steps(cp.steps_taken, settings.steps)
        .map_err(|e| Failure::input(format!("{shown}: damaged checkpoint: {e}")))?;
    if let Some(steps) = args.steps {
        if steps < cp.steps_taken {
            return Err(Failure::input(format!(
                "--steps: {steps} is before the checkpoint, which is at step {} already; give \
                 the total to reach, at least {}",
                cp.steps_taken, cp.steps_taken
            )));
        }
    }
    let outputs = Outputs {
        checkpoint: args.checkpoint_to.clone().zip(args.checkpoint_every),
        trajectory: args.trajectory.clone().zip(args.every),
        observe: args.observe.clone().zip(args.every),
        scene_toml: cp.scene_toml.clone(),
        origin: cp.origin.clone(),
        settings: RunSettings {
            steps: args.steps.unwrap_or(settings.steps),
            ..settings.clone()
        },
    };
    let scene = crate::input::parse_scene(&cp.scene_toml, &cp.origin)
        .map_err(|e| Failure::input(format!("{shown}: {e}")))?;
    match scene {
        carom_scene::AnyScene::Two(s) => resume_scene(s, cp, &settings, &outputs, args),
        carom_scene::AnyScene::Three(s) => resume_scene(s, cp, &settings, &outputs, args),
    }
}

fn resume_scene<V: Vector>(
    mut scene: carom_scene::Scene<V>,
    cp: Checkpoint,
    settings: &RunSettings,
    outputs: &Outputs,
    args: &ResumeArgs,
) -> Result<(), Failure> {
    let shown = args.checkpoint.display().to_string();
    if cp.dimensions as usize != V::DIM {
        return Err(Failure::input(format!(
            "{shown}: damaged checkpoint: dimensions disagree with its scene"
        )));
    }
    // (the settings are the checkpoint's, not this command's flags: a bad one is its damage)
    (scene.override_broad_phase(settings.broadphase.as_deref(), settings.cells.as_deref()))
        .map_err(|e| Failure::input(format!("{shown}: damaged run settings: {e}")))?;
    scene.particles = cp
        .particles()
        .map_err(|e| Failure::input(format!("{shown}: {e}")))?;
    carom_scene::check_state(&scene.particles)
        .and_then(|()| carom_scene::check_remembered(&cp.contact_impulses(), &cp.tally))
        .map_err(|e| Failure::input(format!("{shown}: damaged checkpoint: {e}")))?;
    let name = scene.name.clone();
    let run = Labels {
        name: name.as_deref(),
        origin: &shown,
        out: args.out.as_deref(),
    };
    // (the closure takes the checkpoint: its arrays go once the worlds are built)
    let build = |copies| {
        let cp = cp;
        copies_of(scene, copies, |s| {
            s.into_resumed_world(
                cp.steps_taken,
                cp.storage_order.clone(),
                cp.contact_impulses(),
                cp.tally,
            )
            .map_err(|e| Failure::input(format!("{shown}: {e}")))
        })
    };
    run_world(build, args.ranks, outputs.settings.steps, outputs, &run)
}
