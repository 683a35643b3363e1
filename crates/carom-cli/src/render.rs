//! `carom render`: run a scene and draw it, to a PNG still, an animated GIF or an MP4.
//!
//! The simulation runs sequentially; every `--every` steps a snapshot ([`Frame`]) is taken.
//! Snapshots are gathered in small batches (bounded in memory) and each batch is rendered in
//! parallel with rayon, then written in order. Every output is whole or absent: PNG and GIF go
//! through [`carom_output::write_atomic`], MP4 is written by `ffmpeg` to a temporary in the
//! same folder that is renamed into place only when `ffmpeg` succeeded.

use crate::failure::Failure;
use crate::input::{
    check_distinct, check_output_path, check_steps, load_scene, parse_size, set_threads,
};
use carom_engine::{Vector, World};
use carom_render::{colour_range, Bounds, Camera, Colouring, Frame, GifFrame, GifWriter, Pixmap};
use carom_render::{RenderOptions, MAX_SIZE};
use carom_scene::{AnyScene, MAX_STEPS};
use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// Options of `carom render`.
#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML). Without it, the built-in default scene runs.
    pub scene: Option<PathBuf>,
    /// Render a built-in scene by name instead of a file (see `carom presets`).
    #[arg(long, conflicts_with = "scene")]
    pub preset: Option<String>,
    /// Output file: `.png` (one frame), `.gif` (animated) or `.mp4` (needs `ffmpeg` on PATH).
    /// Written whole or not at all.
    #[arg(long)]
    pub out: PathBuf,
    /// Number of frames, at most 100000. Default 1: the state after the run's steps. With
    /// more, frame i shows step i * every.
    #[arg(long, allow_negative_numbers = true)]
    pub frames: Option<u64>,
    /// Steps between frames. Default: the run's steps spread over the frames; given alone,
    /// frames cover the run (steps / every + 1 frames).
    #[arg(long, allow_negative_numbers = true)]
    pub every: Option<u64>,
    /// Number of steps of the run (overrides the scene's `steps`), at most 10^12.
    #[arg(long, allow_negative_numbers = true)]
    pub steps: Option<u64>,
    /// Image size in pixels, WIDTHxHEIGHT, each 1..=8192.
    #[arg(long, default_value = "800x800")]
    pub size: String,
    /// What the particles' colour shows.
    #[arg(long, value_enum, default_value_t = ColorArg::Speed)]
    pub color: ColorArg,
    /// Fix the colour scale's ends, `MIN,MAX` (e.g. `0,60`). Default: the values' range over
    /// the first frames (up to 8), kept for the whole animation; values beyond it get the
    /// end colours.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub range: Option<Vec<f64>>,
    /// 3D camera: rotation about the vertical (y) axis, degrees.
    #[arg(long, default_value_t = 35.0, allow_negative_numbers = true)]
    pub yaw: f64,
    /// 3D camera: elevation, degrees, within (-90, 90); positive looks down.
    #[arg(long, default_value_t = 25.0, allow_negative_numbers = true)]
    pub pitch: f64,
    /// Worker threads, 1 to 8 per core (at least 64 on any machine; default:
    /// RAYON_NUM_THREADS, else one per core).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
}

/// `--color` values.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorArg {
    /// Length of the velocity (scale from 0).
    Speed,
    /// Particle radius.
    Radius,
    /// Particle id.
    Id,
}

/// The output's kind, from its extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    Gif,
    Mp4,
}

/// The most frames one render may draw (an hour of video at 25 frames per second is 90,000).
const MAX_FRAMES: u64 = 100_000;

/// Which steps to draw: frame i after `first + i * every` steps.
#[derive(Clone, Copy, Debug)]
struct Plan {
    first: u64,
    every: u64,
    frames: u64,
}

impl Plan {
    fn last_step(&self) -> u64 {
        self.first + (self.frames - 1) * self.every
    }
}

/// Snapshots rendered at once: enough to keep a few threads busy, few enough to bound memory
/// (about 512 MB for snapshots and images together). It does not depend on the thread count,
/// so neither does the colour scale taken from the first batch: the output is the same for
/// every `--threads`.
fn batch_size(particles: usize, (w, h): (u32, u32)) -> usize {
    let per_frame = particles * 56 + w as usize * h as usize * 8 + 1;
    let by_memory = (512usize << 20) / per_frame;
    by_memory.clamp(1, 8)
}

fn format_of(out: &Path) -> Result<Format, Failure> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("png") => Ok(Format::Png),
        Some("gif") => Ok(Format::Gif),
        Some("mp4") => Ok(Format::Mp4),
        other => Err(Failure::input(format!(
            "--out: {}: {}; use .png (one frame), .gif or .mp4",
            out.display(),
            match other {
                Some(e) => format!("unknown extension `.{e}`"),
                None => "no extension".to_string(),
            }
        ))),
    }
}

/// `ffmpeg` on PATH, if any.
fn find_ffmpeg() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join("ffmpeg"))
        .find(|p| {
            use std::os::unix::fs::PermissionsExt;
            p.metadata()
                .map(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
                .unwrap_or(false)
        })
}

/// The frame plan from the flags and the run's `steps`.
fn plan(args: &RenderArgs, steps: u64) -> Result<Plan, Failure> {
    match (args.frames, args.every) {
        (None, None) | (Some(1), None) => Ok(Plan {
            first: steps,
            every: 1,
            frames: 1,
        }),
        (Some(n), None) => Ok(Plan {
            first: 0,
            every: (steps / (n - 1)).max(1),
            frames: n,
        }),
        (None, Some(k)) => {
            if k > steps {
                return Err(Failure::input(format!(
                    "--every: {k} is more than the run's {steps} steps, which leaves one frame; \
                     leave --every out for a still of the final state"
                )));
            }
            Ok(Plan {
                first: 0,
                every: k,
                frames: steps / k + 1,
            })
        }
        (Some(1), Some(_)) => Err(Failure::input(
            "--every: needs --frames above 1 (one frame shows the state after the run's steps; \
             choose them with --steps)",
        )),
        (Some(n), Some(k)) => Ok(Plan {
            first: 0,
            every: k,
            frames: n,
        }),
    }
}

pub fn render(args: &RenderArgs) -> Result<(), Failure> {
    // Every flag is checked before the scene is loaded or a step is taken.
    let size = parse_size("--size", &args.size, 1..=MAX_SIZE)?;
    if args.frames == Some(0) {
        return Err(Failure::input("--frames: must be at least 1"));
    }
    if let Some(frames) = args.frames.filter(|&n| n > MAX_FRAMES) {
        return Err(Failure::input(format!(
            "--frames: {frames} is more than the limit of {MAX_FRAMES}"
        )));
    }
    check_steps("--steps", args.steps)?;
    if args.every == Some(0) {
        return Err(Failure::input("--every: must be at least 1"));
    }
    if !(args.pitch.is_finite() && args.pitch.abs() < 90.0) {
        return Err(Failure::input(format!(
            "--pitch: must be within (-90, 90) degrees, got {:?}",
            args.pitch
        )));
    }
    if !args.yaw.is_finite() {
        return Err(Failure::input("--yaw: must be a finite number of degrees"));
    }
    if let Some(r) = &args.range {
        if r.len() != 2 || !r.iter().all(|v| v.is_finite()) || r[0] >= r[1] {
            return Err(Failure::input(format!(
                "--range: needs two numbers MIN,MAX with MIN < MAX, got {r:?}"
            )));
        }
    }
    let format = format_of(&args.out)?;
    if format == Format::Png && args.frames.is_some_and(|n| n > 1) {
        return Err(Failure::input(format!(
            "--frames: a .png holds one frame, not {}; write a .gif or .mp4 for an animation",
            args.frames.unwrap_or(1)
        )));
    }
    check_output_path("--out", &args.out)?;
    let scene_file = args.scene.as_deref().map(|s| ("scene file", s));
    check_distinct(&[("--out", &args.out)], scene_file.as_slice())?;
    let ffmpeg = if format == Format::Mp4 {
        Some(find_ffmpeg().ok_or_else(|| {
            Failure::input(
                "--out: writing .mp4 needs `ffmpeg` on PATH, and there is none; \
                 install it or write a .gif",
            )
        })?)
    } else {
        None
    };
    set_threads(args.threads)?;
    let (scene, origin, _, plan) =
        load_scene(args.scene.as_deref(), args.preset.as_deref(), |o, _| {
            checked_plan(args, format, args.steps.unwrap_or(o.steps))
        })?;
    let job = Job {
        args,
        size,
        format,
        ffmpeg,
        origin,
    };
    match scene {
        AnyScene::Two(s) => {
            let world = s
                .into_world()
                .map_err(|e| Failure::input(format!("{}: {e}", job.origin)))?;
            job.run(world, plan)
        }
        AnyScene::Three(s) => {
            let world = s
                .into_world()
                .map_err(|e| Failure::input(format!("{}: {e}", job.origin)))?;
            job.run(world, plan)
        }
    }
}

/// Everything decided before simulating.
struct Job<'a> {
    args: &'a RenderArgs,
    size: (u32, u32),
    format: Format,
    ffmpeg: Option<PathBuf>,
    origin: String,
}

/// The frames a render wrote, for its report.
#[derive(Clone, Copy)]
struct Frames {
    plan: Plan,
    /// Simulated time between frames.
    seconds_apart: f64,
    /// A GIF frame's delay (hundredths of a second).
    delay_cs: u16,
}

/// Time spent, for the summary.
#[derive(Default)]
struct Timing {
    simulate: f64,
    render: f64,
}

/// The frame plan for a run of `steps` into `format`, checked before the scene's particles
/// are placed.
fn checked_plan(args: &RenderArgs, format: Format, steps: u64) -> Result<Plan, Failure> {
    let plan = plan(args, steps)?;
    if format == Format::Png && plan.frames > 1 {
        return Err(Failure::input(format!(
            "--every: makes {} frames, and a .png holds one; write a .gif or .mp4",
            plan.frames
        )));
    }
    if plan.frames > MAX_FRAMES {
        return Err(Failure::input(format!(
            "--every: makes {} frames, more than the limit of {MAX_FRAMES}; draw fewer \
                 (--frames) or farther apart (a larger --every)",
            plan.frames
        )));
    }
    let last = plan
        .frames
        .checked_sub(1)
        .and_then(|n| n.checked_mul(plan.every))
        .and_then(|s| s.checked_add(plan.first));
    match last {
        Some(last) if last <= MAX_STEPS => Ok(plan),
        _ => Err(Failure::input(format!(
            "--frames x --every: {} frames {} steps apart go past the limit of {MAX_STEPS} \
                 steps",
            plan.frames, plan.every
        ))),
    }
}

impl Job<'_> {
    /// How frames are drawn, from the flags.
    fn options(&self) -> RenderOptions {
        RenderOptions {
            width: self.size.0,
            height: self.size.1,
            colouring: match self.args.color {
                ColorArg::Speed => Colouring::Speed,
                ColorArg::Radius => Colouring::Radius,
                ColorArg::Id => Colouring::Id,
            },
            range: self.args.range.as_ref().map(|r| (r[0], r[1])),
            camera: Camera {
                yaw_degrees: self.args.yaw,
                pitch_degrees: self.args.pitch,
                ..Camera::default()
            },
            ..RenderOptions::default()
        }
    }

    fn run<V: Vector>(&self, mut world: World<V>, plan: Plan) -> Result<(), Failure> {
        let dt = world.config().dt;
        let frame_seconds = dt * plan.every as f64;
        let out = &self.args.out;
        let write_error = |e: io::Error| Failure::write(out, e);
        let mut timing = Timing::default();
        let started = Instant::now();
        let progress = ProgressBar::new(plan.last_step());
        progress.set_style(
            ProgressStyle::with_template("{spinner} step {pos}/{len} {wide_bar} {msg} {eta} left")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        let mut pipeline = Pipeline {
            world: &mut world,
            plan,
            options: self.options(),
            progress: &progress,
            timing: &mut timing,
        };
        let delay_cs = (frame_seconds * 100.0).round().clamp(2.0, 65535.0) as u16;
        match self.format {
            // One frame: encoded where the pipeline hands it on.
            Format::Png => carom_output::write_atomic(out, |w| {
                pipeline.run(|_, p| Ok(p), |p| carom_render::write_png(&p, w))
            })
            .map_err(write_error)?,
            Format::Gif => carom_output::write_atomic(out, |w| {
                let mut gif = GifWriter::new(w, self.size.0, self.size.1)?;
                let delay = if plan.frames > 1 { delay_cs } else { 0 };
                pipeline.run(|_, p| Ok(GifFrame::quantise(&p, delay)), |f| gif.write(&f))?;
                gif.finish().map(|_| ())
            })
            .map_err(write_error)?,
            Format::Mp4 => {
                let fps = if plan.frames > 1 {
                    1.0 / frame_seconds
                } else {
                    25.0
                };
                let ffmpeg = self.ffmpeg.as_deref().unwrap_or(Path::new("ffmpeg"));
                write_mp4(ffmpeg, out, self.size, fps, &mut pipeline).map_err(write_error)?
            }
        }
        progress.finish_and_clear();
        let total = started.elapsed().as_secs_f64();
        let frames = Frames {
            plan,
            seconds_apart: frame_seconds,
            delay_cs,
        };
        self.report(&frames, world.time(), &timing, total);
        Ok(())
    }

    /// What the render made: the scene, the frame or frames, where the time went, the file.
    fn report(&self, frames: &Frames, time: f64, timing: &Timing, total: f64) {
        let Frames {
            plan,
            seconds_apart: frame_seconds,
            delay_cs,
        } = *frames;
        let out = &self.args.out;
        let timing_line = format!(
            "{:.2} s: {:.2} s simulating, {:.2} s rendering and encoding ({:.1} ms per frame, {} threads)",
            total,
            timing.simulate,
            timing.render,
            timing.render * 1e3 / plan.frames as f64,
            rayon::current_num_threads()
        );
        println!("scene       {} [{}]", self.scene_name(), self.origin);
        if plan.frames == 1 {
            println!(
                "frame       step {} (t = {}), {}x{}",
                plan.first, time, self.size.0, self.size.1
            );
        } else {
            let shown = match self.format {
                Format::Gif => format!(", shown {delay_cs} cs each"),
                Format::Mp4 => format!(", {:.4} fps", 1.0 / frame_seconds),
                Format::Png => String::new(),
            };
            println!(
                "frames      {} of {}x{}, steps 0 to {} every {} ({} time units apart{shown})",
                plan.frames,
                self.size.0,
                self.size.1,
                plan.last_step(),
                plan.every,
                frame_seconds
            );
        }
        println!("time        {timing_line}");
        println!("output      {}", out.display());
    }

    fn scene_name(&self) -> String {
        self.args
            .scene
            .as_ref()
            .and_then(|p| p.file_stem())
            .map(|s| s.to_string_lossy().into_owned())
            .or_else(|| self.args.preset.clone())
            .unwrap_or_else(|| carom_scene::DEFAULT_PRESET.to_string())
    }
}

/// Simulates, snapshots, renders in parallel batches and hands results on in frame order.
struct Pipeline<'a, V: Vector> {
    world: &'a mut World<V>,
    plan: Plan,
    options: RenderOptions,
    progress: &'a ProgressBar,
    timing: &'a mut Timing,
}

impl<V: Vector> Pipeline<'_, V> {
    /// For each planned frame, in order: `work` (in parallel) on the rendered pixmap, then
    /// `sink` on its result.
    fn run<T: Send>(
        &mut self,
        work: impl Fn(usize, Pixmap) -> io::Result<T> + Sync,
        mut sink: impl FnMut(T) -> io::Result<()>,
    ) -> io::Result<()> {
        let batch = batch_size(self.world.len(), (self.options.width, self.options.height));
        let mut frames: Vec<Frame> = Vec::with_capacity(batch);
        let mut fixed = false;
        let mut done = 0u64;
        for i in 0..self.plan.frames {
            let target = self.plan.first + i * self.plan.every;
            let t = Instant::now();
            while self.world.steps_taken() < target {
                self.world.step();
                let s = self.world.steps_taken();
                if s % 64 == 0 {
                    self.progress.set_position(s);
                }
            }
            frames.push(Frame::from_world(self.world));
            self.timing.simulate += t.elapsed().as_secs_f64();
            if frames.len() == batch || i + 1 == self.plan.frames {
                if !fixed {
                    // Fix the colour scale and the view from the first batch, so that colours
                    // mean the same and the view holds still through an animation.
                    fixed = true;
                    if self.options.range.is_none() {
                        self.options.range = Some(colour_range(&frames, self.options.colouring));
                    }
                    if frames[0].domain.is_none() {
                        self.options.view = frames
                            .iter()
                            .filter_map(Frame::particle_bounds)
                            .reduce(Bounds::union);
                    }
                }
                let t = Instant::now();
                let options = &self.options;
                let first = done as usize;
                let results: Vec<io::Result<T>> = frames
                    .par_iter()
                    .enumerate()
                    .map(|(k, f)| {
                        let p = carom_render::render(f, options).map_err(io::Error::other)?;
                        work(first + k, p)
                    })
                    .collect();
                for r in results {
                    sink(r?)?;
                }
                done += frames.len() as u64;
                frames.clear();
                self.timing.render += t.elapsed().as_secs_f64();
                self.progress.set_position(self.world.steps_taken());
                self.progress
                    .set_message(format!("{done}/{} frames", self.plan.frames));
            }
        }
        Ok(())
    }
}

/// Pipes raw RGBA frames into `ffmpeg`, which writes a temporary next to `out`; renamed into
/// place only if everything succeeded.
fn write_mp4<V: Vector>(
    ffmpeg: &Path,
    out: &Path,
    (w, h): (u32, u32),
    fps: f64,
    pipeline: &mut Pipeline<'_, V>,
) -> io::Result<()> {
    let dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let tmp = tempfile::Builder::new()
        .prefix(".carom-")
        .suffix(".mp4")
        .tempfile_in(dir)?;
    let mut child = Command::new(ffmpeg)
        .args(["-hide_banner", "-loglevel", "error", "-y", "-f", "rawvideo"])
        .args(["-pixel_format", "rgba", "-video_size", &format!("{w}x{h}")])
        .args(["-framerate", &format!("{fps}"), "-i", "pipe:0"])
        // yuv420p (what players expect) needs even sides.
        .args([
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "-pix_fmt",
            "yuv420p",
        ])
        .args(["-movflags", "+faststart", "-f", "mp4"])
        .arg(tmp.path())
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| io::Error::other(format!("cannot start {}: {e}", ffmpeg.display())))?;
    let mut stderr = child.stderr.take();
    let messages = std::thread::spawn(move || {
        let mut text = String::new();
        if let Some(s) = stderr.as_mut() {
            let _ = s.read_to_string(&mut text);
        }
        text
    });
    let mut stdin = child.stdin.take();
    // (an ffmpeg that stops early closes the pipe: a failed write, reported below with what
    // ffmpeg said, and the temporary removed)
    let _broken_pipes_are_errors = crate::pipe::BrokenPipesAreErrors::new();
    let fed = pipeline.run(
        |_, p| Ok(p),
        |p| match stdin.as_mut() {
            Some(s) => s.write_all(p.data()),
            None => Err(io::Error::other("ffmpeg's input is closed")),
        },
    );
    drop(stdin);
    let status = child.wait()?;
    let messages = messages.join().unwrap_or_default();
    if !status.success() {
        let said = match messages.trim() {
            "" => String::new(),
            m => format!(": {m}"),
        };
        return Err(io::Error::other(format!("ffmpeg failed ({status}){said}")));
    }
    fed?;
    tmp.as_file().sync_all()?;
    tmp.persist(out).map_err(|e| e.error)?;
    Ok(())
}

#[cfg(test)]
mod tests;
