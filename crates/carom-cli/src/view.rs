//! `carom view`: the interactive viewer (see the carom-viewer crate).

use crate::run::Failure;
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
    #[arg(long)]
    pub count: Option<u64>,
    /// Particle radius for `--count` (default: the scene's largest radius).
    #[arg(long, requires = "count")]
    pub radius: Option<f64>,
    /// Start paused.
    #[arg(long)]
    pub paused: bool,
    /// Window size in points, `WIDTHxHEIGHT`.
    #[arg(long, default_value = "1280x800", value_parser = parse_size)]
    pub size: [f32; 2],
    /// Select this particle id at the start, as if clicked (for screenshots).
    #[arg(long, hide = true)]
    pub select: Option<usize>,
    /// Close after this many frames (for scripted runs and tests).
    #[arg(long, hide = true)]
    pub exit_after_frames: Option<u64>,
    /// Draw this many frames after a short warm-up, print the mean frames per second, close.
    #[arg(long, hide = true)]
    pub benchmark_frames: Option<u64>,
}

fn parse_size(s: &str) -> Result<[f32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or("expected WIDTHxHEIGHT, e.g. 1280x800")?;
    let w: f32 = w.trim().parse().map_err(|_| format!("bad width `{w}`"))?;
    let h: f32 = h.trim().parse().map_err(|_| format!("bad height `{h}`"))?;
    if !(200.0..=16384.0).contains(&w) || !(200.0..=16384.0).contains(&h) {
        return Err("width and height must be in 200..=16384".into());
    }
    Ok([w, h])
}

pub fn view(args: &ViewArgs) -> Result<(), Failure> {
    let (mut text, origin) = crate::run::scene_text(args.scene.as_deref(), args.preset.as_deref())?;
    // Check the scene here, so that a bad file is one message and exit status 2, not a window.
    let scene = carom_scene::parse(&text, &origin).map_err(|e| Failure::input(e.to_string()))?;
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
        carom_scene::parse(&text, &origin)
            .map_err(|e| Failure::input(format!("--count/--radius: {e}")))?;
    }
    carom_viewer::run(carom_viewer::ViewOptions {
        scene_text: text,
        origin,
        paused: args.paused,
        exit_after_frames: args.exit_after_frames,
        benchmark_frames: args.benchmark_frames,
        select: args.select,
        window_size: args.size,
    })
    .map_err(Failure::runtime)
}

#[cfg(test)]
mod tests {
    use super::parse_size;

    #[test]
    fn window_sizes() {
        assert_eq!(parse_size("800x600"), Ok([800.0, 600.0]));
        assert!(parse_size("800").is_err());
        assert!(parse_size("10x10").is_err());
        assert!(parse_size("axb").is_err());
    }
}
