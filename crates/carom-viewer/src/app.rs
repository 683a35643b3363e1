//! The window: side panel (controls), canvas (particles and the lecture's overlays), plots.

use crate::colour::{self, ColourBy};
use crate::control::{self, BroadPhaseChoice, Params};
use crate::render;
use crate::sim::{Command, Sim, Snapshot};
use crate::teach;
use crate::view::{self, OrbitCamera, View2};
use crate::ViewOptions;
use carom_engine::glam::{DVec2, DVec3};
use carom_engine::BroadPhaseKind;
use eframe::egui::{
    self, Align2, Color32, FontId, Pos2, Rect, Sense, Shape, Stroke, StrokeKind, TextureHandle,
    TextureOptions, Vec2,
};
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

const RED: Color32 = Color32::from_rgb(235, 40, 40);
const GREEN: Color32 = Color32::from_rgb(40, 220, 80);
const CONTACT: Color32 = Color32::from_rgb(255, 160, 0);
const NORMAL_ARROW: Color32 = Color32::from_rgb(255, 120, 40);
const TANGENT_ARROW: Color32 = Color32::from_rgb(60, 200, 255);
const GRID: Color32 = Color32::from_rgba_premultiplied(70, 70, 90, 90);
const HISTORY: usize = 3000;

/// Samples for the plots.
#[derive(Default)]
struct History {
    time: VecDeque<f64>,
    ms: VecDeque<f64>,
    kinetic: VecDeque<f64>,
    total: VecDeque<f64>,
    momentum: VecDeque<f64>,
}

impl History {
    fn push(&mut self, s: &Snapshot) {
        if self.time.len() >= HISTORY {
            for q in [
                &mut self.time,
                &mut self.ms,
                &mut self.kinetic,
                &mut self.total,
                &mut self.momentum,
            ] {
                q.pop_front();
            }
        }
        self.time.push_back(s.time);
        self.ms.push_back(s.ms_per_step);
        self.kinetic.push_back(s.kinetic);
        self.total.push_back(s.total_energy);
        self.momentum.push_back(s.momentum.length());
    }
}

/// Frames per second over the last second, and the benchmark's count.
struct Fps {
    frames: VecDeque<Instant>,
    total: u64,
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
    fn fps(&self) -> f64 {
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

/// The viewer application.
pub struct ViewerApp {
    sim: Sim,
    snap: Arc<Snapshot>,
    seq: u64,
    generation: u64,
    error: Option<String>,
    busy: bool,
    playing: bool,
    steps_per_frame: u32,
    params: Params,
    colour_by: ColourBy,
    show_grid: bool,
    show_overlays: bool,
    count: u64,
    radius: f64,
    bp: BroadPhaseChoice,
    cells: [usize; 3],
    scene_text: String,
    scene_origin: String,
    view2: Option<View2>,
    camera: Option<OrbitCamera>,
    refit: bool,
    /// Canvas size at the last fit; the picture refits when it changes, unless moved by hand.
    fitted_size: Vec2,
    moved_by_hand: bool,
    selected: Option<usize>,
    chosen_contact: Option<usize>,
    history: History,
    fps: Fps,
    disc: TextureHandle,
    sphere: TextureHandle,
    options: ViewOptions,
    scratch: Vec<f64>,
    speeds: Vec<f64>,
    order: Vec<(f64, u32)>,
    marks: Vec<u8>,
    local_error: Option<String>,
    raster: render::Raster,
    raster_texture: Option<TextureHandle>,
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
            colour_by: ColourBy::Speed,
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

    fn send_params(&mut self) {
        self.sim.send(Command::Params(self.params));
    }

    fn side_panel(&mut self, ui: &mut egui::Ui) {
        let s = self.snap.clone();
        ui.heading("carom view");
        ui.label(format!(
            "{:.0} fps, {:.3} ms per step",
            self.fps.fps(),
            s.ms_per_step
        ));
        ui.label(format!(
            "{}: {} particles ({}D)",
            s.name,
            s.radii.len(),
            s.dims
        ));
        ui.label(format!("step {}  t = {:.3}", s.steps, s.time));
        ui.label(format!("broad phase: {}", s.broad_phase));
        if self.busy {
            ui.colored_label(Color32::YELLOW, "building the scene...");
        }
        for e in self.error.iter().chain(self.local_error.iter()) {
            ui.colored_label(Color32::from_rgb(255, 110, 110), format!("refused: {e}"));
        }
        ui.separator();

        ui.horizontal(|ui| {
            let label = if self.playing { "Pause" } else { "Play" };
            if ui.button(label).clicked() {
                self.playing = !self.playing;
                self.sim.send(Command::Play(self.playing));
            }
            if ui
                .add_enabled(!self.playing, egui::Button::new("Step"))
                .clicked()
            {
                self.sim.send(Command::Step);
            }
            if ui.button("Reset").clicked() {
                self.sim.send(Command::Reset);
            }
        });
        if ui
            .add(
                egui::Slider::new(&mut self.steps_per_frame, 1..=200)
                    .logarithmic(true)
                    .text("steps / frame"),
            )
            .changed()
        {
            self.sim.send(Command::StepsPerFrame(self.steps_per_frame));
        }

        ui.separator();
        ui.label("Physics");
        let mut changed = false;
        changed |= ui
            .add(egui::Slider::new(&mut self.params.restitution, 0.0..=1.0).text("restitution k"))
            .changed();
        for (a, name) in ["gravity x", "gravity y", "gravity z"]
            .iter()
            .enumerate()
            .take(s.dims.max(2))
        {
            changed |= ui
                .add(egui::Slider::new(&mut self.params.gravity[a], -50.0..=50.0).text(*name))
                .changed();
        }
        changed |= ui
            .add(
                egui::Slider::new(&mut self.params.dt, 1e-5..=0.05)
                    .logarithmic(true)
                    .text("dt"),
            )
            .changed();
        if changed {
            self.send_params();
        }

        ui.separator();
        ui.label("Particles (rebuilds the scene)");
        ui.add(
            egui::DragValue::new(&mut self.count)
                .range(1..=control::MAX_PARTICLES)
                .speed(10)
                .prefix("count "),
        );
        ui.add(
            egui::DragValue::new(&mut self.radius)
                .range(0.01..=100.0)
                .speed(0.01)
                .prefix("radius "),
        );
        if ui.button("Rebuild with this count and radius").clicked() {
            match control::refill(&self.scene_text, self.count, self.radius) {
                Ok(text) => {
                    self.local_error = None;
                    self.sim
                        .send(Command::Load(text, self.scene_origin.clone()));
                }
                Err(e) => self.local_error = Some(e),
            }
        }

        ui.separator();
        ui.label("Broad phase");
        let mut bp_changed = false;
        ui.horizontal(|ui| {
            for (kind, name) in [
                (BroadPhaseKind::Brute, "brute"),
                (BroadPhaseKind::Grid, "grid"),
                (BroadPhaseKind::Hash, "hash"),
            ] {
                bp_changed |= ui.selectable_value(&mut self.bp.kind, kind, name).changed();
            }
        });
        if self.bp.kind == BroadPhaseKind::Grid {
            let mut auto = self.bp.cells.is_none();
            if ui
                .checkbox(&mut auto, "cells from the largest radius")
                .changed()
            {
                self.bp.cells = if auto {
                    None
                } else {
                    Some(self.cells[..s.dims.max(2)].to_vec())
                };
                bp_changed = true;
            }
            ui.horizontal(|ui| {
                for a in 0..s.dims.max(2) {
                    let r = ui.add_enabled(
                        !auto,
                        egui::DragValue::new(&mut self.cells[a])
                            .range(1..=4096)
                            .prefix(["x ", "y ", "z "][a]),
                    );
                    if r.changed() {
                        self.bp.cells = Some(self.cells[..s.dims.max(2)].to_vec());
                        bp_changed = true;
                    }
                }
            });
        }
        if bp_changed {
            let ok = match &self.bp.cells {
                Some(c) => control::check_cells(s.dims.max(2), c),
                None => Ok(()),
            };
            match ok {
                Ok(()) => {
                    self.local_error = None;
                    self.sim.send(Command::BroadPhase(self.bp.clone()));
                }
                Err(e) => self.local_error = Some(e),
            }
        }

        ui.separator();
        egui::ComboBox::from_label("preset")
            .selected_text(
                self.scene_origin
                    .strip_prefix("preset:")
                    .unwrap_or("scene file"),
            )
            .show_ui(ui, |ui| {
                for (name, text) in carom_scene::PRESETS {
                    if ui
                        .selectable_label(self.scene_origin == format!("preset:{name}"), *name)
                        .clicked()
                    {
                        self.scene_text = text.to_string();
                        self.scene_origin = format!("preset:{name}");
                        self.refit = true;
                        self.local_error = None;
                        self.sim.send(Command::Load(
                            self.scene_text.clone(),
                            self.scene_origin.clone(),
                        ));
                    }
                }
            });

        ui.separator();
        ui.label("Display");
        ui.horizontal(|ui| {
            ui.label("colour by");
            for m in ColourBy::ALL {
                ui.selectable_value(&mut self.colour_by, m, m.label());
            }
        });
        ui.checkbox(&mut self.show_grid, "hash grid lines");
        ui.checkbox(&mut self.show_overlays, "selection overlays");
        if ui.button("Fit view").clicked() {
            self.refit = true;
        }
        ui.separator();
        self.selection_panel(ui);
    }

    fn selection_panel(&mut self, ui: &mut egui::Ui) {
        let s = self.snap.clone();
        let Some(id) = self.selected.filter(|&i| i < s.radii.len()) else {
            ui.label("Click a particle: it turns red, the hash grid's neighbour cells and the candidates found there green, its contacts orange.");
            return;
        };
        let layout = self.layout(&s);
        let Some(n) =
            teach::neighbourhood(&layout, s.dims, &s.positions, &s.radii, &s.contacts, id)
        else {
            return;
        };
        ui.label(format!("particle {id}: cell {:?}", &n.cell[..s.dims]));
        ui.label(format!(
            "searches cells {:?}..={:?}: {} candidates, {} contacts",
            &n.lo[..s.dims],
            &n.hi[..s.dims],
            n.candidates.len(),
            n.contacts.len()
        ));
        let v = s.velocities[id];
        ui.label(format!("|v| = {:.3}, r = {}", v.length(), s.radii[id]));
        if n.contacts.is_empty() {
            self.chosen_contact = None;
        } else {
            if self.chosen_contact.is_none_or(|c| !n.contacts.contains(&c)) {
                self.chosen_contact = Some(n.contacts[0]);
            }
            ui.label("contact to explain:");
            ui.horizontal_wrapped(|ui| {
                for &c in n.contacts.iter().take(24) {
                    ui.selectable_value(&mut self.chosen_contact, Some(c), c.to_string());
                }
            });
            if let Some(c) = self.chosen_contact {
                let sp = teach::contact_split(s.positions[id], v, s.positions[c], s.velocities[c]);
                ui.label(format!("normal N = {}", fmt_vec(sp.normal, s.dims)));
                ui.colored_label(
                    NORMAL_ARROW,
                    format!("v_N (red one) = {}", fmt_vec(sp.a.normal, s.dims)),
                );
                ui.colored_label(
                    TANGENT_ARROW,
                    format!("v_T (red one) = {}", fmt_vec(sp.a.tangent, s.dims)),
                );
                ui.label(if sp.approaching {
                    "approaching: p_rel . v_rel < 0, the engine responds"
                } else {
                    "separating: the trap rule skips the response"
                });
            }
        }
        if ui.button("Clear selection").clicked() {
            self.selected = None;
        }
    }

    fn layout(&self, s: &Snapshot) -> carom_engine::grid::GridLayout {
        let max_r = s.radii.iter().copied().fold(0.0, f64::max);
        let cells = if s.broad_phase.starts_with("grid") {
            s.grid_cells
        } else {
            None
        };
        let domain = if cells.is_some() || s.domain.is_some() {
            s.domain
        } else {
            None
        };
        teach::layout_for(s.dims, domain, &s.positions, max_r, cells)
    }

    fn colours(&mut self, s: &Snapshot) -> (f64, f64) {
        self.speeds.clear();
        self.speeds.extend(s.velocities.iter().map(|v| v.length()));
        colour::value_range(self.colour_by, &self.speeds, &s.radii, &mut self.scratch)
    }

    /// Per-particle marks for the selection: 0 none, 1 candidate, 2 contact, 3 selected.
    fn marks(&mut self, s: &Snapshot) -> Option<teach::Neighbourhood> {
        self.marks.clear();
        let id = self
            .selected
            .filter(|&i| i < s.radii.len() && self.show_overlays)?;
        let n = teach::neighbourhood(
            &self.layout(s),
            s.dims,
            &s.positions,
            &s.radii,
            &s.contacts,
            id,
        )?;
        self.marks.resize(s.radii.len(), 0);
        for &c in &n.candidates {
            self.marks[c] = 1;
        }
        for &c in &n.contacts {
            self.marks[c] = 2;
        }
        self.marks[id] = 3;
        Some(n)
    }

    fn particle_colour(&self, i: usize, range: (f64, f64), s: &Snapshot) -> Color32 {
        match self.marks.get(i) {
            Some(3) => return RED,
            Some(1) => return GREEN,
            Some(2) => return CONTACT,
            _ => {}
        }
        let v = colour::value(self.colour_by, i, self.speeds[i], s.radii[i]);
        let [r, g, b] = colour::ramp(colour::normalise(v, range));
        if self.marks.is_empty() {
            Color32::from_rgb(r, g, b)
        } else {
            // fade the rest so the lecture's red and green stand out
            Color32::from_rgb(r / 3, g / 3, b / 3)
        }
    }

    fn canvas(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, Sense::click_and_drag());
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 0.0, Color32::from_rgb(18, 18, 24));
        let s = self.snap.clone();
        if s.dims == 0 {
            painter.text(
                rect.center(),
                Align2::CENTER_CENTER,
                "building the scene...",
                FontId::proportional(18.0),
                Color32::WHITE,
            );
            return;
        }
        let range = self.colours(&s);
        let neighbourhood = self.marks(&s);
        let (zoom, pointer) = ui.input(|i| {
            let scroll = i.smooth_scroll_delta.y as f64;
            (
                (scroll * 0.003).exp() * i.zoom_delta() as f64,
                i.pointer.hover_pos(),
            )
        });
        let hovered = response.hovered();
        let drag = response.drag_delta();
        let clicked = response
            .clicked()
            .then(|| response.interact_pointer_pos())
            .flatten();
        if response.double_clicked() {
            self.refit = true;
        }
        if rect.size() != self.fitted_size && !self.moved_by_hand {
            self.refit = true;
        }
        if self.refit {
            self.fitted_size = rect.size();
            self.moved_by_hand = false;
        } else if drag != Vec2::ZERO || (hovered && zoom != 1.0) {
            self.moved_by_hand = true;
        }
        if s.dims == 2 {
            self.canvas_2d(
                &painter,
                rect,
                &s,
                range,
                neighbourhood.as_ref(),
                (hovered, zoom, pointer, drag, clicked),
            );
        } else {
            self.canvas_3d(
                &painter,
                rect,
                &s,
                range,
                neighbourhood.as_ref(),
                (hovered, zoom, drag, clicked),
            );
        }
        self.legend(&painter, rect, range);
    }

    #[allow(clippy::type_complexity)]
    fn canvas_2d(
        &mut self,
        painter: &egui::Painter,
        rect: Rect,
        s: &Snapshot,
        range: (f64, f64),
        nb: Option<&teach::Neighbourhood>,
        (hovered, zoom, pointer, drag, clicked): (bool, f64, Option<Pos2>, Vec2, Option<Pos2>),
    ) {
        let centre = DVec2::new(rect.center().x as f64, rect.center().y as f64);
        let size = DVec2::new(rect.width() as f64, rect.height() as f64);
        // Without a domain the particles may fly anywhere: follow them until the user moves
        // the view by hand.
        if let (Some(v), None, false) = (&self.view2, s.domain, self.moved_by_hand) {
            let (a, b) = (v.to_world(dv(rect.min)), v.to_world(dv(rect.max)));
            let (lo, hi) = (a.min(b), a.max(b));
            let outside = s.positions.iter().zip(&s.radii).any(|(p, &r)| {
                let p = p.truncate();
                p.x - r < lo.x || p.y - r < lo.y || p.x + r > hi.x || p.y + r > hi.y
            });
            self.refit |= outside;
        }
        if self.refit || self.view2.is_none() {
            let (min, max) = bounds(s);
            self.view2 = Some(View2::fit(min.truncate(), max.truncate(), centre, size));
            self.refit = false;
        }
        let view = self.view2.as_mut().expect("set above");
        view.screen_center = centre;
        if hovered && zoom != 1.0 {
            if let Some(p) = pointer {
                view.zoom_at(dv(p), zoom);
            }
        }
        if drag != Vec2::ZERO {
            view.pan(DVec2::new(drag.x as f64, drag.y as f64));
        }
        let view = *view;
        let to = |p: DVec3| pos(view.to_screen(p.truncate()));

        // the domain box and the planes
        if let Some((lo, hi)) = s.domain {
            let r = Rect::from_two_pos(to(lo), to(hi));
            painter.rect_stroke(
                r,
                0.0,
                Stroke::new(1.5, Color32::from_gray(200)),
                StrokeKind::Middle,
            );
        }
        let far = (size.length() / view.scale) * 2.0;
        for &(p, n) in &s.planes {
            let t = DVec3::new(-n.y, n.x, 0.0);
            painter.line_segment(
                [to(p - t * far), to(p + t * far)],
                Stroke::new(1.0, Color32::from_rgb(120, 150, 220)),
            );
        }

        // the lecture's hash grid
        let layout = self.layout(s);
        if self.show_grid {
            let [cx, cy, _] = layout.cells;
            let (o, cs) = (layout.origin, layout.cell_size);
            let px_per_cell = (cs[0].min(cs[1]) * view.scale) as f32;
            if px_per_cell >= 3.0 && cx <= 2000 && cy <= 2000 {
                let (y0, y1) = (o[1], o[1] + cy as f64 * cs[1]);
                let (x0, x1) = (o[0], o[0] + cx as f64 * cs[0]);
                for i in 0..=cx {
                    let x = o[0] + i as f64 * cs[0];
                    painter.line_segment(
                        [to(DVec3::new(x, y0, 0.0)), to(DVec3::new(x, y1, 0.0))],
                        Stroke::new(1.0, GRID),
                    );
                }
                for j in 0..=cy {
                    let y = o[1] + j as f64 * cs[1];
                    painter.line_segment(
                        [to(DVec3::new(x0, y, 0.0)), to(DVec3::new(x1, y, 0.0))],
                        Stroke::new(1.0, GRID),
                    );
                }
            } else {
                painter.text(
                    rect.left_top() + Vec2::new(8.0, 8.0),
                    Align2::LEFT_TOP,
                    format!("grid {cx}x{cy}: too fine to draw here, zoom in"),
                    FontId::proportional(12.0),
                    Color32::GRAY,
                );
            }
        }
        if let Some(n) = nb {
            let (o, cs) = (layout.origin, layout.cell_size);
            let corner = |c: [usize; 3], add: f64| {
                DVec3::new(
                    o[0] + (c[0] as f64 + add) * cs[0],
                    o[1] + (c[1] as f64 + add) * cs[1],
                    0.0,
                )
            };
            let block = Rect::from_two_pos(to(corner(n.lo, 0.0)), to(corner(n.hi, 1.0)));
            painter.rect_filled(block, 0.0, Color32::from_rgba_unmultiplied(40, 220, 80, 40));
            painter.rect_stroke(block, 0.0, Stroke::new(1.5, GREEN), StrokeKind::Middle);
            let own = Rect::from_two_pos(to(corner(n.cell, 0.0)), to(corner(n.cell, 1.0)));
            painter.rect_stroke(own, 0.0, Stroke::new(1.5, RED), StrokeKind::Middle);
        }

        // every particle: one mesh of quads, or (very many) one image drawn here
        let scale = view.scale as f32;
        let visible = s
            .positions
            .iter()
            .zip(&s.radii)
            .filter(|&(&p, &r)| render::visible(&rect, to(p), (r as f32 * scale).max(0.8)))
            .count();
        if visible > render::RASTER_ABOVE {
            let ppp = painter.ctx().pixels_per_point();
            let (w, h) = (
                (rect.width() * ppp).round() as usize,
                (rect.height() * ppp).round() as usize,
            );
            self.raster.clear(w.max(1), h.max(1));
            for (i, (&p, &r)) in s.positions.iter().zip(&s.radii).enumerate() {
                let c = (to(p) - rect.min) * ppp;
                let half = (r as f32 * scale * ppp).max(0.8);
                self.raster
                    .disc(c.x, c.y, half, self.particle_colour(i, range, s));
            }
            let image = self.raster.take_image();
            let texture = match &mut self.raster_texture {
                Some(t) => {
                    t.set(image, TextureOptions::NEAREST);
                    t.id()
                }
                None => {
                    let t = painter.ctx().load_texture(
                        "carom-particles",
                        image,
                        TextureOptions::NEAREST,
                    );
                    let id = t.id();
                    self.raster_texture = Some(t);
                    id
                }
            };
            let uv = Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0));
            painter.image(texture, rect, uv, Color32::WHITE);
        } else {
            let mut mesh = render::sprite_mesh(self.disc.id(), visible);
            for (i, (&p, &r)) in s.positions.iter().zip(&s.radii).enumerate() {
                let c = to(p);
                let half = (r as f32 * scale).max(0.8);
                if render::visible(&rect, c, half) {
                    render::push_sprite(&mut mesh, c, half, self.particle_colour(i, range, s));
                }
            }
            painter.add(Shape::mesh(mesh));
        }

        if let Some(n) = nb {
            for &c in &n.contacts {
                painter.line_segment(
                    [to(s.positions[n.id]), to(s.positions[c])],
                    Stroke::new(1.0, CONTACT),
                );
            }
            if let Some(c) = self.chosen_contact.filter(|c| n.contacts.contains(c)) {
                self.contact_arrows(painter, s, n.id, c, &|p| to(p));
            }
        }

        if let Some(at) = clicked {
            let tol = 6.0;
            let discs = s
                .positions
                .iter()
                .zip(&s.radii)
                .enumerate()
                .map(|(i, (&p, &r))| (i, view.to_screen(p.truncate()), r * view.scale, 0.0));
            self.selected = view::pick(discs, dv(at), tol);
            self.chosen_contact = None;
        }
    }

    /// The lecture's velocity split of a contact, drawn at both particles.
    fn contact_arrows(
        &self,
        painter: &egui::Painter,
        s: &Snapshot,
        a: usize,
        b: usize,
        to: &dyn Fn(DVec3) -> Pos2,
    ) {
        let sp = teach::contact_split(
            s.positions[a],
            s.velocities[a],
            s.positions[b],
            s.velocities[b],
        );
        let vmax = s.velocities[a]
            .length()
            .max(s.velocities[b].length())
            .max(1e-12);
        // arrows: the faster velocity is 5 radii of the red particle long (in world units)
        let len = 5.0 * s.radii[a] / vmax;
        for (p, split) in [(s.positions[a], sp.a), (s.positions[b], sp.b)] {
            let start = to(p);
            let arrow = |v: DVec3, colour: Color32, width: f32| {
                let end = to(p + v * len);
                painter.arrow(start, end - start, Stroke::new(width, colour));
            };
            arrow(split.normal + split.tangent, Color32::WHITE, 1.0);
            arrow(split.normal, NORMAL_ARROW, 2.5);
            arrow(split.tangent, TANGENT_ARROW, 2.5);
        }
        // the normal line through both centres
        let mid = (s.positions[a] + s.positions[b]) * 0.5;
        let reach = sp.normal * (s.radii[a] + s.radii[b]) * 1.5;
        painter.line_segment(
            [to(mid - reach), to(mid + reach)],
            Stroke::new(1.0, Color32::from_white_alpha(140)),
        );
    }

    #[allow(clippy::type_complexity)]
    fn canvas_3d(
        &mut self,
        painter: &egui::Painter,
        rect: Rect,
        s: &Snapshot,
        range: (f64, f64),
        nb: Option<&teach::Neighbourhood>,
        (hovered, zoom, drag, clicked): (bool, f64, Vec2, Option<Pos2>),
    ) {
        if self.refit || self.camera.is_none() {
            let (min, max) = bounds(s);
            self.camera = Some(OrbitCamera::fit(min, max));
            self.refit = false;
        }
        let cam = self.camera.as_mut().expect("set above");
        if hovered && zoom != 1.0 {
            cam.zoom(zoom);
        }
        if drag != Vec2::ZERO {
            cam.rotate(DVec2::new(drag.x as f64, drag.y as f64));
        }
        let cam = *cam;
        let (eye, basis) = (cam.eye(), cam.basis());
        let centre = dv(rect.center());
        let height = rect.height() as f64;
        let project = |p: DVec3| cam.project(&basis, eye, p, centre, height);
        let to = |p: DVec3| {
            project(p)
                .map(|q| pos(q.screen))
                .unwrap_or(Pos2::new(f32::NAN, f32::NAN))
        };

        let wire = |lo: DVec3, hi: DVec3, stroke: Stroke| {
            for i in 0..8u32 {
                for axis in 0..3 {
                    if i & (1 << axis) == 0 {
                        let j = i | (1 << axis);
                        let c = |k: u32| {
                            DVec3::new(
                                if k & 1 == 0 { lo.x } else { hi.x },
                                if k & 2 == 0 { lo.y } else { hi.y },
                                if k & 4 == 0 { lo.z } else { hi.z },
                            )
                        };
                        if let (Some(a), Some(b)) = (project(c(i)), project(c(j))) {
                            painter.line_segment([pos(a.screen), pos(b.screen)], stroke);
                        }
                    }
                }
            }
        };
        if let Some((lo, hi)) = s.domain {
            wire(lo, hi, Stroke::new(1.5, Color32::from_gray(200)));
        }
        let layout = self.layout(s);
        let (o, cs) = (layout.origin, layout.cell_size);
        let corner = |c: [usize; 3], add: f64| {
            DVec3::new(
                o[0] + (c[0] as f64 + add) * cs[0],
                o[1] + (c[1] as f64 + add) * cs[1],
                o[2] + (c[2] as f64 + add) * cs[2],
            )
        };
        if self.show_grid && layout.cells[0] <= 200 && layout.cells[2] <= 200 {
            // the grid's cells on the floor of the box
            let [cx, _, cz] = layout.cells;
            let y = o[1];
            for i in 0..=cx {
                let x = o[0] + i as f64 * cs[0];
                painter.line_segment(
                    [
                        to(DVec3::new(x, y, o[2])),
                        to(DVec3::new(x, y, o[2] + cz as f64 * cs[2])),
                    ],
                    Stroke::new(1.0, GRID),
                );
            }
            for k in 0..=cz {
                let z = o[2] + k as f64 * cs[2];
                painter.line_segment(
                    [
                        to(DVec3::new(o[0], y, z)),
                        to(DVec3::new(o[0] + cx as f64 * cs[0], y, z)),
                    ],
                    Stroke::new(1.0, GRID),
                );
            }
        }

        // depth-sorted spheres, far to near, one mesh
        self.order.clear();
        let mut projected = Vec::with_capacity(s.positions.len());
        for (i, &p) in s.positions.iter().enumerate() {
            let q = project(p);
            if let Some(q) = q {
                self.order.push((q.depth, i as u32));
            }
            projected.push(q);
        }
        self.order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
        let mut mesh = render::sprite_mesh(self.sphere.id(), self.order.len());
        // the selection's particles go on top, so that the lecture's red and green show
        let mut marked = render::sprite_mesh(self.sphere.id(), 0);
        for &(_, i) in &self.order {
            let i = i as usize;
            let q = projected[i].expect("only projected ones are ordered");
            let c = pos(q.screen);
            let half = (s.radii[i] * q.scale) as f32;
            let half = half.max(0.8);
            if render::visible(&rect, c, half) {
                let target = if self.marks.get(i).is_some_and(|&m| m > 0) {
                    &mut marked
                } else {
                    &mut mesh
                };
                render::push_sprite(target, c, half, self.particle_colour(i, range, s));
            }
        }
        painter.add(Shape::mesh(mesh));
        painter.add(Shape::mesh(marked));

        if let Some(n) = nb {
            wire(
                corner(n.lo, 0.0),
                corner(n.hi, 1.0),
                Stroke::new(1.5, GREEN),
            );
            wire(
                corner(n.cell, 0.0),
                corner(n.cell, 1.0),
                Stroke::new(1.5, RED),
            );
            if let Some(c) = self.chosen_contact.filter(|c| n.contacts.contains(c)) {
                self.contact_arrows(painter, s, n.id, c, &to);
            }
        }
        if let Some(at) = clicked {
            let discs = projected
                .iter()
                .enumerate()
                .filter_map(|(i, q)| q.map(|q| (i, q.screen, s.radii[i] * q.scale, q.depth)));
            self.selected = view::pick(discs, dv(at), 6.0);
            self.chosen_contact = None;
        }
    }

    fn legend(&self, painter: &egui::Painter, rect: Rect, (lo, hi): (f64, f64)) {
        let w = 180.0;
        let bar = Rect::from_min_size(
            rect.right_top() + Vec2::new(-w - 14.0, 28.0),
            Vec2::new(w, 12.0),
        );
        let keys: &[(Color32, &str)] = if self.selected.is_some() && self.show_overlays {
            &[
                (RED, "selected"),
                (GREEN, "candidates (neighbour cells)"),
                (CONTACT, "contacts"),
                (NORMAL_ARROW, "v_N, normal part"),
                (TANGENT_ARROW, "v_T, tangent part"),
            ]
        } else {
            &[]
        };
        let back = Rect::from_min_max(
            bar.min - Vec2::new(8.0, 22.0),
            bar.max + Vec2::new(8.0, 20.0 + 14.0 * keys.len() as f32),
        );
        painter.rect_filled(back, 4.0, Color32::from_black_alpha(170));
        let mut mesh = egui::Mesh::default();
        let steps = 32;
        for k in 0..steps {
            let t0 = k as f32 / steps as f32;
            let t1 = (k + 1) as f32 / steps as f32;
            let [r, g, b] = colour::ramp(((t0 + t1) * 0.5) as f64);
            let seg = Rect::from_min_max(
                Pos2::new(bar.min.x + t0 * w, bar.min.y),
                Pos2::new(bar.min.x + t1 * w, bar.max.y),
            );
            mesh.add_colored_rect(seg, Color32::from_rgb(r, g, b));
        }
        painter.add(Shape::mesh(mesh));
        let f = FontId::proportional(12.0);
        let text = |at: Pos2, align: Align2, t: String, c: Color32| {
            painter.text(at, align, t, f.clone(), c);
        };
        text(
            bar.left_top() - Vec2::new(0.0, 3.0),
            Align2::LEFT_BOTTOM,
            format!("colour = {}", self.colour_by.label()),
            Color32::WHITE,
        );
        text(
            bar.left_bottom() + Vec2::new(0.0, 2.0),
            Align2::LEFT_TOP,
            fmt_num(lo),
            Color32::WHITE,
        );
        text(
            bar.right_bottom() + Vec2::new(0.0, 2.0),
            Align2::RIGHT_TOP,
            fmt_num(hi),
            Color32::WHITE,
        );
        for (k, (c, t)) in keys.iter().enumerate() {
            text(
                Pos2::new(bar.min.x, bar.max.y + 18.0 + 14.0 * k as f32),
                Align2::LEFT_TOP,
                t.to_string(),
                *c,
            );
        }
    }

    fn plots(&self, ui: &mut egui::Ui) {
        let h = &self.history;
        let w = (ui.available_width() - 16.0) / 3.0;
        ui.horizontal(|ui| {
            plot(
                ui,
                w,
                "ms per step",
                &[(&h.ms, Color32::from_rgb(255, 200, 60))],
            );
            plot(
                ui,
                w,
                "energy: kinetic (yellow), kinetic + potential (blue)",
                &[
                    (&h.kinetic, Color32::from_rgb(250, 220, 80)),
                    (&h.total, Color32::from_rgb(90, 160, 255)),
                ],
            );
            plot(
                ui,
                w,
                "|momentum|",
                &[(&h.momentum, Color32::from_rgb(120, 230, 140))],
            );
        });
    }
}

impl ViewerApp {
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
}

/// A small line plot of one or more series sharing a y axis.
fn plot(ui: &mut egui::Ui, width: f32, title: &str, series: &[(&VecDeque<f64>, Color32)]) {
    let (rect, _) = ui.allocate_exact_size(Vec2::new(width, 120.0), Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, Color32::from_rgb(25, 25, 32));
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (q, _) in series {
        for &v in q.iter().filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    let f = FontId::proportional(11.0);
    painter.text(
        rect.left_top() + Vec2::new(4.0, 2.0),
        Align2::LEFT_TOP,
        title,
        f.clone(),
        Color32::LIGHT_GRAY,
    );
    if !(lo.is_finite() && hi.is_finite()) {
        return;
    }
    if hi - lo < 1e-12 * hi.abs().max(1e-12) {
        (lo, hi) = (lo - 0.5 * lo.abs().max(1e-9), hi + 0.5 * hi.abs().max(1e-9));
    }
    painter.text(
        rect.right_top() + Vec2::new(-4.0, 2.0),
        Align2::RIGHT_TOP,
        fmt_num(hi),
        f.clone(),
        Color32::GRAY,
    );
    painter.text(
        rect.right_bottom() + Vec2::new(-4.0, -2.0),
        Align2::RIGHT_BOTTOM,
        fmt_num(lo),
        f,
        Color32::GRAY,
    );
    let inner = rect.shrink2(Vec2::new(4.0, 16.0));
    for (q, colour) in series {
        let n = q.len();
        if n < 2 {
            continue;
        }
        let stride = (n / inner.width().max(1.0) as usize).max(1);
        let pts: Vec<Pos2> = (0..n)
            .step_by(stride)
            .filter(|&i| q[i].is_finite())
            .map(|i| {
                let x = inner.min.x + inner.width() * i as f32 / (n - 1) as f32;
                let y = inner.max.y - inner.height() * ((q[i] - lo) / (hi - lo)) as f32;
                Pos2::new(x, y)
            })
            .collect();
        painter.add(Shape::line(pts, Stroke::new(1.5, *colour)));
    }
}

fn bounds(s: &Snapshot) -> (DVec3, DVec3) {
    if let Some(d) = s.domain {
        return d;
    }
    let (lo, hi) = s.positions.iter().zip(&s.radii).fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), (&p, &r)| (lo.min(p - DVec3::splat(r)), hi.max(p + DVec3::splat(r))),
    );
    if lo.is_finite() && hi.is_finite() {
        // particles move: leave them some room
        let pad = (hi - lo) * 0.1;
        (lo - pad, hi + pad)
    } else {
        (DVec3::splat(-1.0), DVec3::splat(1.0))
    }
}

fn dv(p: Pos2) -> DVec2 {
    DVec2::new(p.x as f64, p.y as f64)
}

fn pos(p: DVec2) -> Pos2 {
    Pos2::new(p.x as f32, p.y as f32)
}

fn fmt_num(v: f64) -> String {
    if v != 0.0 && (v.abs() >= 1e5 || v.abs() < 1e-2) {
        format!("{v:.3e}")
    } else {
        format!("{v:.3}")
    }
}

fn fmt_vec(v: DVec3, dims: usize) -> String {
    let c = &v.to_array()[..dims];
    let parts: Vec<String> = c.iter().map(|x| format!("{x:.3}")).collect();
    format!("({})", parts.join(", "))
}

impl eframe::App for ViewerApp {
    fn update(&mut self, ctx: &egui::Context, _frame: &mut eframe::Frame) {
        self.frame(ctx);

        let frames = self.fps.total;
        if let Some(n) = self.options.benchmark_frames {
            if frames == BENCH_WARMUP {
                self.fps.bench_start = Some(Instant::now());
            }
            if let Some(t) = self
                .fps
                .bench_start
                .filter(|_| frames >= BENCH_WARMUP + n && !self.bench_done)
            {
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
        if self.options.exit_after_frames.is_some_and(|n| frames >= n) {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }
}

#[cfg(test)]
mod tests {
    //! The whole UI, headless: egui without a window, the real simulation thread.
    use super::*;
    use egui::{Event, Modifiers, PointerButton, RawInput};

    fn options(text: String, origin: &str) -> ViewOptions {
        ViewOptions {
            scene_text: text,
            origin: origin.into(),
            paused: true,
            exit_after_frames: None,
            benchmark_frames: None,
            select: None,
            window_size: [1280.0, 800.0],
        }
    }

    fn input(events: Vec<Event>) -> RawInput {
        RawInput {
            screen_rect: Some(Rect::from_min_size(Pos2::ZERO, Vec2::new(1280.0, 800.0))),
            events,
            ..Default::default()
        }
    }

    /// Runs frames until `done` (or panics after 20 s); returns the last frame's shapes.
    fn frames_until(
        ctx: &egui::Context,
        app: &mut ViewerApp,
        done: impl Fn(&ViewerApp) -> bool,
    ) -> Vec<egui::epaint::ClippedShape> {
        let t = Instant::now();
        loop {
            let out = ctx.run(input(vec![]), |ctx| app.frame(ctx));
            if done(app) {
                return out.shapes;
            }
            assert!(t.elapsed().as_secs() < 20, "timed out");
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }

    fn meshes(shapes: &[egui::epaint::ClippedShape], texture: egui::TextureId) -> Vec<usize> {
        shapes
            .iter()
            .filter_map(|c| match &c.shape {
                Shape::Mesh(m) if m.texture_id == texture => Some(m.vertices.len()),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn draws_one_mesh_and_picks_with_a_click() {
        let ctx = egui::Context::default();
        let text = carom_scene::preset("lecture_100_k05").unwrap().to_string();
        let mut app = ViewerApp::new(&ctx, options(text, "preset:lecture_100_k05"));
        frames_until(&ctx, &mut app, |a| a.snap.radii.len() == 100);
        // a few more frames: panels settle, the view fits the canvas
        let shapes = (0..5).fold(Vec::new(), |_, _| {
            ctx.run(input(vec![]), |c| app.frame(c)).shapes
        });
        assert_eq!(
            meshes(&shapes, app.disc.id()),
            vec![400],
            "one mesh, a quad per particle"
        );

        // click particle 17's centre
        let view = app.view2.expect("a 2D view");
        let at = pos(view.to_screen(app.snap.positions[17].truncate()));
        let press = |pressed| Event::PointerButton {
            pos: at,
            button: PointerButton::Primary,
            pressed,
            modifiers: Modifiers::NONE,
        };
        let _ = ctx.run(input(vec![Event::PointerMoved(at)]), |c| app.frame(c));
        let _ = ctx.run(input(vec![press(true)]), |c| app.frame(c));
        let _ = ctx.run(input(vec![press(false)]), |c| app.frame(c));
        let _ = ctx.run(input(vec![]), |c| app.frame(c));
        assert_eq!(app.selected, Some(17));
        assert_eq!(
            app.marks.get(17),
            Some(&3),
            "the picked particle is marked red"
        );
        assert_eq!(app.marks.len(), 100, "every particle has a mark slot");

        // play, step, change everything: frames keep coming, nothing panics
        app.sim.send(Command::Play(true));
        app.sim.send(Command::StepsPerFrame(3));
        frames_until(&ctx, &mut app, |a| a.snap.steps > 10);
        for mode in ColourBy::ALL {
            app.colour_by = mode;
            let _ = ctx.run(input(vec![]), |c| app.frame(c));
        }
        app.sim.send(Command::BroadPhase(BroadPhaseChoice {
            kind: BroadPhaseKind::Hash,
            cells: None,
        }));
        frames_until(&ctx, &mut app, |a| a.snap.broad_phase == "hash");
    }

    #[test]
    fn three_d_scenes_draw_sorted_spheres() {
        let ctx = egui::Context::default();
        let text = carom_scene::preset("box_3d").unwrap().to_string();
        let mut app = ViewerApp::new(&ctx, options(text, "preset:box_3d"));
        app.selected = Some(0);
        frames_until(&ctx, &mut app, |a| a.snap.dims == 3);
        let shapes = ctx.run(input(vec![]), |c| app.frame(c)).shapes;
        // unmarked spheres in one mesh, the selection's on top in another
        let m = meshes(&shapes, app.sphere.id());
        assert_eq!(m.len(), 2);
        assert_eq!(m.iter().sum::<usize>(), 4 * 2000);
        assert!(app.camera.is_some());
    }

    #[test]
    fn very_many_particles_are_one_image() {
        let ctx = egui::Context::default();
        let base = carom_scene::preset("lecture_5000_grid100").unwrap();
        let text = control::refill(base, 30_000, 0.2).unwrap();
        let mut app = ViewerApp::new(&ctx, options(text, "preset:lecture_5000_grid100"));
        frames_until(&ctx, &mut app, |a| a.snap.radii.len() == 30_000);
        let shapes = ctx.run(input(vec![]), |c| app.frame(c)).shapes;
        assert!(meshes(&shapes, app.disc.id()).is_empty());
        let raster = app.raster_texture.as_ref().expect("drawn as an image").id();
        assert_eq!(meshes(&shapes, raster), vec![4]);
    }
}
