//! [`ViewerApp`]: the window's state, one frame of it, and the frame counter behind `--benchmark`.

use super::plots::History;
use crate::colour::Colouring;
use crate::control::{self, BroadPhaseChoice, Params};
use crate::render;
use crate::sim::{Sim, Snapshot};
use crate::view::{OrbitCamera, View2};
use crate::ViewOptions;
use carom_engine::BroadPhaseKind;
use eframe::egui::{self, TextureHandle, TextureOptions, Vec2};
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

/// Frames per second over the last second, and the benchmark's count.
pub(super) struct Fps {
    frames: VecDeque<Instant>,
    pub(super) total: u64,
    bench_start: Option<Instant>,
}

impl Fps {
    fn tick(&mut self) {
        let now = Instant::now();
        self.frames.push_back(now);
        while self.frames.len() > 2 && now.duration_since(self.frames[0]).as_secs_f64() > 1.0 {
            self.frames.pop_front();
        }
        self.total += 1;
    }

    pub(super) fn fps(&self) -> f64 {
        let (Some(a), Some(b)) = (self.frames.front(), self.frames.back()) else {
            return 0.0;
        };
        let span = b.duration_since(*a).as_secs_f64();
        if span > 0.0 {
            (self.frames.len() - 1) as f64 / span
        } else {
            0.0
        }
    }
}

/// Frames skipped before a benchmark starts timing (window setup, first uploads).
const BENCH_WARMUP: u64 = 10;

/// The viewer application. Its parts live in the sibling modules: `panel` (the controls),
/// `canvas` with `canvas_2d` and `canvas_3d` (the picture), `plots` (the time series).
pub struct ViewerApp {
    pub(super) sim: Sim,
    pub(super) snap: Arc<Snapshot>,
    seq: u64,
    generation: u64,
    pub(super) error: Option<String>,
    pub(super) busy: bool,
    pub(super) playing: bool,
    pub(super) steps_per_frame: u32,
    pub(super) params: Params,
    pub(super) colour_by: Colouring,
    pub(super) show_grid: bool,
    pub(super) show_overlays: bool,
    pub(super) count: u64,
    pub(super) radius: f64,
    pub(super) bp: BroadPhaseChoice,
    pub(super) cells: [usize; 3],
    pub(super) scene_text: String,
    pub(super) scene_origin: String,
    pub(super) view2: Option<View2>,
    pub(super) camera: Option<OrbitCamera>,
    pub(super) refit: bool,
    /// Canvas size at the last fit; the picture refits when it changes, unless moved by hand.
    pub(super) fitted_size: Vec2,
    pub(super) moved_by_hand: bool,
    pub(super) selected: Option<usize>,
    pub(super) chosen_contact: Option<usize>,
    pub(super) history: History,
    pub(super) fps: Fps,
    pub(super) disc: TextureHandle,
    pub(super) sphere: TextureHandle,
    options: ViewOptions,
    pub(super) scratch: Vec<f64>,
    pub(super) speeds: Vec<f64>,
    /// Depth and id of the 3D spheres in front of the camera, far to near.
    pub(super) order: Vec<(f64, u32)>,
    /// Per-particle marks for the selection: 0 none, 1 candidate, 2 contact, 3 selected.
    pub(super) marks: Vec<u8>,
    pub(super) local_error: Option<String>,
    pub(super) raster: render::Raster,
    pub(super) raster_texture: Option<TextureHandle>,
    bench_done: bool,
}

impl ViewerApp {
    /// Starts the simulation thread on the options' scene.
    pub fn new(ctx: &egui::Context, options: ViewOptions) -> Self {
        let sim = Sim::start(
            options.scene_text.clone(),
            options.origin.clone(),
            !options.paused,
        );
        let disc = ctx.load_texture("carom-disc", render::disc_image(), TextureOptions::LINEAR);
        let sphere = ctx.load_texture(
            "carom-sphere",
            render::sphere_image(),
            TextureOptions::LINEAR,
        );
        Self {
            sim,
            snap: Arc::new(Snapshot::default()),
            seq: 0,
            generation: 0,
            error: None,
            busy: true,
            playing: !options.paused,
            steps_per_frame: 1,
            params: Params {
                restitution: 1.0,
                gravity: [0.0; 3],
                dt: 0.005,
            },
            colour_by: Colouring::Speed,
            show_grid: true,
            show_overlays: true,
            count: 0,
            radius: 1.0,
            bp: BroadPhaseChoice {
                kind: BroadPhaseKind::Grid,
                cells: None,
            },
            cells: [1; 3],
            scene_text: options.scene_text.clone(),
            scene_origin: options.origin.clone(),
            view2: None,
            camera: None,
            refit: true,
            fitted_size: Vec2::ZERO,
            moved_by_hand: false,
            selected: options.select,
            chosen_contact: None,
            history: History::default(),
            fps: Fps {
                frames: VecDeque::new(),
                total: 0,
                bench_start: None,
            },
            disc,
            sphere,
            options,
            scratch: Vec::new(),
            speeds: Vec::new(),
            order: Vec::new(),
            marks: Vec::new(),
            local_error: None,
            raster: render::Raster::default(),
            raster_texture: None,
            bench_done: false,
        }
    }

    /// Takes the newest snapshot; on a rebuild, re-reads the controls from it.
    fn poll(&mut self) {
        let (snap, seq) = {
            let s = self.sim.lock();
            self.error = s.error.clone();
            self.busy = s.busy;
            self.playing = s.playing;
            (s.snapshot.clone(), s.seq)
        };
        if seq == self.seq {
            return;
        }
        self.seq = seq;
        let new_scene = snap.generation != self.generation;
        if new_scene {
            let dims_changed = snap.dims != self.snap.dims;
            self.generation = snap.generation;
            self.history = History::default();
            self.selected = if self.generation == 1 {
                self.options.select
            } else {
                None
            };
            self.chosen_contact = None;
            if let Some(p) = snap.params {
                self.params = p;
            }
            if let Some(bp) = &snap.broad_phase_choice {
                self.bp = bp.clone();
            }
            (self.count, self.radius) = control::count_and_radius(&snap.radii);
            self.refit |= dims_changed || self.view2.is_none() && self.camera.is_none();
        }
        // The cells boxes follow the engine while cells are automatic; explicit cells are the
        // user's (overwriting them from a snapshot taken before their rebuild would fight the
        // drag), and are only read back from a new scene.
        match (&self.bp.cells, snap.grid_cells) {
            (None, Some(c)) => self.cells = c,
            (Some(c), _) if new_scene => {
                for (slot, &v) in self.cells.iter_mut().zip(c) {
                    *slot = v;
                }
            }
            _ => {}
        }
        if snap.ms_per_step > 0.0 {
            self.history.push(&snap);
        }
        self.snap = snap;
    }

    /// One frame of the whole UI (everything but closing the window): testable headless.
    pub fn frame(&mut self, ctx: &egui::Context) {
        self.poll();
        self.fps.tick();
        egui::SidePanel::left("controls")
            .resizable(true)
            .default_width(300.0)
            .show(ctx, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.side_panel(ui));
            });
        egui::TopBottomPanel::bottom("plots").show(ctx, |ui| self.plots(ui));
        egui::CentralPanel::default()
            .frame(egui::Frame::NONE)
            .show(ctx, |ui| self.canvas(ui));
        self.sim.lock().drawn = self.seq;
        ctx.request_repaint();
    }

    /// Counts a benchmark's frames; prints its result and closes the window when done.
    fn benchmark(&mut self, ctx: &egui::Context, n: u64) {
        let frames = self.fps.total;
        if frames == BENCH_WARMUP {
            self.fps.bench_start = Some(Instant::now());
        }
        let Some(t) = self
            .fps
            .bench_start
            .filter(|_| frames >= BENCH_WARMUP + n && !self.bench_done)
        else {
            return;
        };
        self.bench_done = true;
        let secs = t.elapsed().as_secs_f64();
        println!(
            "benchmark: {} particles ({}D), {n} frames in {secs:.3} s: {:.1} fps (mean {:.2} ms per frame); simulation {:.3} ms per step",
            self.snap.radii.len(),
            self.snap.dims,
            n as f64 / secs,
            secs * 1e3 / n as f64,
            self.snap.ms_per_step
        );
        ctx.send_viewport_cmd(egui::ViewportCommand::Close);
    }
}

impl eframe::App for ViewerApp {
    fn update(&mut self, ctx: &egui::Context, _frame: &mut eframe::Frame) {
        self.frame(ctx);
        if let Some(n) = self.options.benchmark_frames {
            self.benchmark(ctx, n);
        }
        if self
            .options
            .exit_after_frames
            .is_some_and(|n| self.fps.total >= n)
        {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }
}
