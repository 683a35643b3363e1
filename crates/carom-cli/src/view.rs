//! `carom view`: the interactive viewer (see the carom-viewer crate).

use crate::failure::Failure;
use crate::input::{parse_size, scene_text};
use std::path::PathBuf;

/// Options of `carom view`.
#[derive(clap::Args, Debug)]
pub struct ViewArgs {
    /// Scene file (TOML). Without it, the built-in default scene opens.
    pub scene: Option<PathBuf>,
    /// Open a built-in scene by name instead of a file (see `carom presets`).
    #[arg(long, conflicts_with = "scene")]
    pub preset: Option<String>,
    /// Replace the scene's particles with one fill of this many (keeps its domain and fill
    /// settings; the panel's "rebuild" does the same).
    #[arg(long, allow_negative_numbers = true)]
    pub count: Option<u64>,
    /// Particle radius for `--count` (default: the scene's largest radius).
    #[arg(long, requires = "count", allow_negative_numbers = true)]
    pub radius: Option<f64>,
    /// Start paused.
    #[arg(long)]
    pub paused: bool,
    /// Window size in points, `WIDTHxHEIGHT`, each side 200..=16384.
    #[arg(long, default_value = "1280x800")]
    pub size: String,
    /// Select this particle id at the start, as if clicked (for screenshots).
    #[arg(long, hide = true, allow_negative_numbers = true)]
    pub select: Option<usize>,
    /// Close after this many frames (for scripted runs and tests).
    #[arg(long, hide = true, allow_negative_numbers = true)]
    pub exit_after_frames: Option<u64>,
    /// Draw this many frames after a short warm-up, print the mean frames per second, close.
    #[arg(long, hide = true, allow_negative_numbers = true)]
    pub benchmark_frames: Option<u64>,
}

pub fn view(args: &ViewArgs) -> Result<(), Failure> {
    let (w, h) = parse_size("--size", &args.size, 200..=16384)?;
    // (RAYON_NUM_THREADS, which the scene's fill would start its threads by)
    crate::input::set_threads(None)?;
    if let Some(radius) = args.radius.filter(|r| !(r.is_finite() && *r > 0.0)) {
        return Err(Failure::input(format!(
            "--radius: must be a finite number > 0, got {radius:?}"
        )));
    }
    let limit = carom_viewer::control::MAX_PARTICLES;
    if let Some(count) = args.count.filter(|&n| n == 0 || n > limit) {
        return Err(Failure::input(format!(
            "--count: must be in 1..={limit}, got {count}"
        )));
    }
    let (mut text, origin) = scene_text(args.scene.as_deref(), args.preset.as_deref())?;
    // Check the scene here, so that a bad file is one message and exit status 2, not a window.
    let mut scene = crate::input::parse_scene(&text, &origin)?;
    if let Some(count) = args.count {
        let radius = match args.radius {
            Some(r) => r,
            None => {
                let radii = match &scene {
                    carom_scene::AnyScene::Two(s) => s.particles.radii().to_vec(),
                    carom_scene::AnyScene::Three(s) => s.particles.radii().to_vec(),
                };
                carom_viewer::control::count_and_radius(&radii).1
            }
        };
        text = carom_viewer::control::refill(&text, count, radius)
            .map_err(|e| Failure::input(format!("--count/--radius: {e}")))?;
        scene = crate::input::parse_scene(&text, &origin)
            .map_err(|e| Failure::input(format!("--count/--radius: {e}")))?;
    }
    let particles = match &scene {
        carom_scene::AnyScene::Two(s) => s.particles.len(),
        carom_scene::AnyScene::Three(s) => s.particles.len(),
    };
    if let Some(id) = args.select.filter(|&id| id >= particles) {
        return Err(Failure::input(format!(
            "--select: no particle {id}; the scene has {particles} (ids 0 to {})",
            particles.saturating_sub(1)
        )));
    }
    carom_viewer::run(carom_viewer::ViewOptions {
        scene_text: text,
        origin,
        paused: args.paused,
        exit_after_frames: args.exit_after_frames,
        benchmark_frames: args.benchmark_frames,
        select: args.select,
        window_size: [w as f32, h as f32],
    })
    .map_err(Failure::runtime)
}
