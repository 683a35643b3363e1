//! The checks every subcommand shares, made before any work: the scene a subcommand names, the
//! thread and rank counts, step counts, grid cells, window and image sizes, output paths. Each
//! refusal is a [`Failure::Input`] (exit status 2) that names the flag.

use crate::failure::Failure;
use carom_engine::{BroadPhaseKind, Vector};
use carom_scene::{AnyScene, Outline, Scene, MAX_STEPS};
use std::path::Path;

/// The TOML text of a scene file, or of a preset (the default one when neither is given), and
/// where it came from. Shared by every subcommand that takes `[SCENE] [--preset NAME]`.
pub fn scene_text(scene: Option<&Path>, preset: Option<&str>) -> Result<(String, String), Failure> {
    match scene {
        Some(path) => {
            let origin = path.display().to_string();
            let text = carom_output::read_regular_text(path)
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
/// checkpoints), and what `check` made of its [`Outline`] and origin: `check` sees them first,
/// before the fills that may take seconds, and may refuse the command's flags against them.
pub fn load_scene<T>(
    scene: Option<&Path>,
    preset: Option<&str>,
    check: impl FnOnce(&Outline, &str) -> Result<T, Failure>,
) -> Result<(AnyScene, String, String, T), Failure> {
    let (text, origin) = scene_text(scene, preset)?;
    let checked = check(&carom_scene::outline(&text, &origin)?, &origin)?;
    let parsed = parse_scene(&text, &origin)?;
    Ok((parsed, origin, text, checked))
}

/// Refuses `--broadphase` and `--cells` that the scene of `outline` cannot take (see
/// [`carom_scene::overridden_broad_phase`]), and the unbounded hash on periodic axes, before
/// the scene's fill.
pub fn check_overrides(
    (outline, origin): (&Outline, &str),
    broadphase: Option<&str>,
    cells: Option<&[usize]>,
) -> Result<(), Failure> {
    let (dimensions, own) = (outline.dimensions, outline.broad_phase);
    let kind = carom_scene::overridden_broad_phase(dimensions, own, broadphase, cells)
        .map_err(overridden)?;
    if kind == BroadPhaseKind::Hash && outline.periodic {
        return Err(Failure::input(format!(
            "{origin}: --broadphase: the unbounded hash does not support periodic axes, which \
             the scene has: use the grid (or brute force)"
        )));
    }
    Ok(())
}

/// [`carom_scene::parse`], with a progress bar while a large scene's fills are placed.
pub fn parse_scene(text: &str, origin: &str) -> Result<AnyScene, carom_scene::SceneError> {
    let bar = std::cell::OnceCell::new();
    let parsed = carom_scene::parse_with_progress(text, origin, &|placed, total| {
        if total >= FILL_PROGRESS_FROM {
            bar.get_or_init(|| crate::driver::counting_bar(total, "placing particles"))
                .set_position(placed);
        }
    });
    if let Some(bar) = bar.get() {
        bar.finish_and_clear();
    }
    parsed
}

/// Scenes of this many particles or more show their fill's progress (on a terminal: indicatif
/// draws nothing when standard error is not one). A fill of 10^6 spheres near the densest
/// random packing takes seconds.
const FILL_PROGRESS_FROM: u64 = 100_000;

pub use carom_scene::machine::thread_limit;

fn check_count(flag: &str, count: usize) -> Result<(), Failure> {
    let limit = thread_limit();
    if count == 0 {
        return Err(Failure::input(format!("{flag}: must be at least 1")));
    }
    if count > limit {
        return Err(Failure::input(format!(
            "{flag}: {count} is more than the limit of {limit} on this machine (8 per core, \
             at least 64; {} cores here)",
            carom_scene::machine::cores()
        )));
    }
    Ok(())
}

/// Checks a thread count (`--threads`, else `RAYON_NUM_THREADS`): 1 to [`thread_limit`].
pub fn check_threads(threads: Option<usize>) -> Result<(), Failure> {
    if let Some(threads) = threads {
        return check_count("--threads", threads);
    }
    // (a typo in RAYON_NUM_THREADS is as bad as one in --threads)
    match carom_scene::machine::threads_from_environment() {
        Some(n) => check_count("RAYON_NUM_THREADS", n),
        None => Ok(()),
    }
}

/// Starts the global thread pool (`--threads`, else `RAYON_NUM_THREADS`, else one per core),
/// refusing 0 and more than [`thread_limit`], before any parallel work; a machine that cannot
/// start the threads is an error, not a panic (see
/// [`carom_scene::machine::start_thread_pool`]).
pub fn set_threads(threads: Option<usize>) -> Result<(), Failure> {
    check_threads(threads)?;
    carom_scene::machine::start_thread_pool(threads).map_err(Failure::runtime)
}

/// `--ranks`: 1 to [`thread_limit`] (each rank is a thread with a whole copy of the world).
pub fn check_ranks(ranks: Option<usize>) -> Result<(), Failure> {
    ranks.map_or(Ok(()), |r| check_count("--ranks", r))
}

/// A step count (`--steps`) of at most [`MAX_STEPS`].
pub fn check_steps(flag: &str, steps: Option<u64>) -> Result<(), Failure> {
    match steps {
        Some(s) if s > MAX_STEPS => Err(Failure::input(format!(
            "{flag}: {s} is more than the limit of {MAX_STEPS} steps"
        ))),
        _ => Ok(()),
    }
}

/// `--cells`, before the scene is read: every entry at least 1, and no more cells in all than
/// the grid allows (see [`carom_scene::check_cells`]).
pub fn check_cells(cells: Option<&[usize]>) -> Result<(), Failure> {
    cells
        .map_or(Ok(()), carom_scene::check_cells)
        .map_err(overridden)
}

/// Applies `--broadphase` and `--cells` to a scene (see [`Scene::override_broad_phase`]).
pub fn apply_overrides<V: Vector>(
    scene: &mut Scene<V>,
    broadphase: Option<&str>,
    cells: Option<&[usize]>,
) -> Result<(), Failure> {
    scene
        .override_broad_phase(broadphase, cells)
        .map_err(overridden)
}

/// A refused override, as bad input.
pub fn overridden(e: carom_scene::OverrideError) -> Failure {
    Failure::input(e.to_string())
}

/// `WIDTHxHEIGHT` (or `WIDTHXHEIGHT`) with each side in `sides`, for `flag`.
pub fn parse_size(
    flag: &str,
    text: &str,
    sides: std::ops::RangeInclusive<u32>,
) -> Result<(u32, u32), Failure> {
    let bad = || {
        Failure::input(format!(
            "{flag}: expected WIDTHxHEIGHT with each side {}..={}, e.g. 800x800, got `{text}`",
            sides.start(),
            sides.end()
        ))
    };
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if !sides.contains(&w) || !sides.contains(&h) {
        return Err(bad());
    }
    Ok((w, h))
}

/// Refuses, before any work is done, an output path whose folder is missing or cannot be
/// written in, or which is a folder itself or anything else but a file (a device or a named
/// pipe: an output is written to a temporary renamed over it, which would put a file in the
/// place of `/dev/null`).
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
    if out.exists() && !out.is_file() {
        return Err(Failure::input(format!(
            "{flag}: {} is not a regular file (a device or a pipe?); leave the flag out to \
             write nothing",
            out.display()
        )));
    }
    // (the run would otherwise find out at its end, when it writes its temporary there)
    tempfile::Builder::new()
        .prefix(".carom-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(|e| {
            let dir = dir.display();
            Failure::input(format!("{flag}: cannot write in folder {dir}: {e}"))
        })?;
    Ok(())
}

/// Refuses two outputs naming the same file, and an output naming one of the `inputs` (the
/// scene or checkpoint being read, which it would overwrite).
pub fn check_distinct(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<(), Failure> {
    for (i, (flag, path)) in outputs.iter().enumerate() {
        for (other, other_path) in &outputs[..i] {
            if carom_output::same_file(path, other_path) {
                return Err(Failure::input(format!(
                    "{flag}: {} is also the file of {other}; give each its own",
                    path.display()
                )));
            }
        }
        for (what, input) in inputs {
            if carom_output::same_file(path, input) {
                return Err(Failure::input(format!(
                    "{flag}: {} is the {what} being read, which this would overwrite",
                    path.display()
                )));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(
            parse_size("--size", "800x600", 1..=8192).ok(),
            Some((800, 600))
        );
        assert_eq!(
            parse_size("--size", "8192X1", 1..=8192).ok(),
            Some((8192, 1))
        );
        for bad in ["800", "10x10", "axb", "0x5", "-1x200", "300x20000", ""] {
            let e = parse_size("--size", bad, 200..=16384).expect_err(bad);
            assert_eq!(e.status(), 2);
            assert!(e.to_string().starts_with("--size: "), "{e}");
        }
    }

    #[test]
    fn counts_are_bounded() {
        assert!(check_count("--threads", 1).is_ok());
        assert!(check_count("--threads", thread_limit()).is_ok());
        let e = check_count("--threads", thread_limit() + 1).unwrap_err();
        assert!(e.to_string().starts_with("--threads: "), "{e}");
        assert!(check_count("--ranks", 0).is_err());
        assert!(thread_limit() >= 64);
    }

    #[test]
    fn cells_and_steps_are_bounded() {
        assert!(check_cells(Some(&[100, 100])).is_ok());
        assert!(check_cells(Some(&[0, 5])).is_err());
        assert!(check_cells(Some(&[1 << 20, 1 << 20, 1 << 20])).is_err());
        assert!(check_steps("--steps", Some(MAX_STEPS)).is_ok());
        assert!(check_steps("--steps", Some(MAX_STEPS + 1)).is_err());
    }

    #[test]
    fn outputs_must_be_distinct_and_not_an_input() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.csv");
        let same = dir.path().join(".").join("a.csv");
        let b = dir.path().join("b.csv");
        assert!(check_distinct(&[("--out", &a), ("--trajectory", &b)], &[]).is_ok());
        let e = check_distinct(&[("--out", &a), ("--trajectory", &same)], &[]).unwrap_err();
        assert!(e.to_string().starts_with("--trajectory: "), "{e}");
        let e = check_distinct(&[("--out", &a)], &[("scene file", &same)]).unwrap_err();
        assert!(e.to_string().contains("scene file"), "{e}");
    }

    /// A scene read through a link (symbolic or hard) is the file it links to: an output
    /// naming that file was not refused, and overwrote the scene.
    #[cfg(unix)]
    #[test]
    fn an_input_read_through_a_link_is_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("scene.toml");
        std::fs::write(&scene, "dimensions = 2").unwrap();
        let (soft, hard) = (dir.path().join("soft.toml"), dir.path().join("hard.toml"));
        std::os::unix::fs::symlink(&scene, &soft).unwrap();
        std::fs::hard_link(&scene, &hard).unwrap();
        for link in [&soft, &hard] {
            let e = check_distinct(&[("--out", &scene)], &[("scene file", link)]).unwrap_err();
            assert!(e.to_string().contains("scene file"), "{e}");
            let e = check_distinct(&[("--out", link)], &[("scene file", &scene)]).unwrap_err();
            assert!(e.to_string().contains("scene file"), "{e}");
        }
        let other = dir.path().join("other.csv");
        assert!(check_distinct(&[("--out", &other)], &[("scene file", &soft)]).is_ok());
    }
}
