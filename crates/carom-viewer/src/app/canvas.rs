//! The canvas: the pointer's input, the particles' colours and the lecture's marks, the legend
//! and the contact arrows shared by the 2D and 3D pictures (`canvas_2d`, `canvas_3d`).

use super::ViewerApp;
use crate::colour::{self, colormap_rgb8, BACKGROUND};
use crate::sim::Snapshot;
use crate::teach;
use carom_engine::glam::{DVec2, DVec3};
use eframe::egui::{self, Align2, Color32, FontId, Pos2, Rect, Sense, Shape, Stroke, Vec2};

pub(super) const RED: Color32 = Color32::from_rgb(235, 40, 40);
pub(super) const GREEN: Color32 = Color32::from_rgb(40, 220, 80);
pub(super) const CONTACT: Color32 = Color32::from_rgb(255, 160, 0);
pub(super) const NORMAL_ARROW: Color32 = Color32::from_rgb(255, 120, 40);
pub(super) const TANGENT_ARROW: Color32 = Color32::from_rgb(60, 200, 255);
pub(super) const GRID: Color32 = Color32::from_rgba_premultiplied(70, 70, 90, 90);
/// How much of its own colour an unmarked particle keeps while a selection is shown (the rest
/// is background): the lecture's red and green stand out, and every particle stays visible.
const FADE: f32 = 0.45;

/// What the pointer did to the canvas this frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct Input {
    /// The pointer is over the canvas.
    pub(super) hovered: bool,
    /// Zoom factor from the scroll wheel and pinch (1: none).
    pub(super) zoom: f64,
    /// Where the pointer is, if over the window.
    pub(super) pointer: Option<Pos2>,
    /// Drag since the last frame, points.
    pub(super) drag: Vec2,
    /// Where a click landed.
    pub(super) clicked: Option<Pos2>,
}

impl Input {
    fn read(ui: &egui::Ui, response: &egui::Response) -> Self {
        let (zoom, pointer) = ui.input(|i| {
            let scroll = i.smooth_scroll_delta.y as f64;
            (
                (scroll * 0.003).exp() * i.zoom_delta() as f64,
                i.pointer.hover_pos(),
            )
        });
        Self {
            hovered: response.hovered(),
            zoom,
            pointer,
            drag: response.drag_delta(),
            clicked: response
                .clicked()
                .then(|| response.interact_pointer_pos())
                .flatten(),
        }
    }

    /// The user zooms the view.
    pub(super) fn zooms(&self) -> bool {
        self.hovered && self.zoom != 1.0
    }
}

/// What both pictures draw from: the snapshot, the colour range, the selection.
pub(super) struct Scene<'a> {
    pub(super) painter: &'a egui::Painter,
    pub(super) rect: Rect,
    pub(super) snap: &'a Snapshot,
    pub(super) range: (f64, f64),
    pub(super) neighbourhood: Option<&'a teach::Neighbourhood>,
}

impl ViewerApp {
    pub(super) fn canvas(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, Sense::click_and_drag());
        let painter = ui.painter_at(rect);
        let [r, g, b] = BACKGROUND;
        painter.rect_filled(rect, 0.0, Color32::from_rgb(r, g, b));
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
        let input = Input::read(ui, &response);
        if response.double_clicked() {
            self.refit = true;
        }
        if rect.size() != self.fitted_size && !self.moved_by_hand {
            self.refit = true;
        }
        if self.refit {
            self.fitted_size = rect.size();
            self.moved_by_hand = false;
        } else if input.drag != Vec2::ZERO || input.zooms() {
            self.moved_by_hand = true;
        }
        let scene = Scene {
            painter: &painter,
            rect,
            snap: &s,
            range,
            neighbourhood: neighbourhood.as_ref(),
        };
        if s.dims == 2 {
            self.canvas_2d(&scene, input);
        } else {
            self.canvas_3d(&scene, input);
        }
        self.legend(&painter, rect, range);
    }

    /// The broad phase's grid as the lecture draws it: the engine's own cells when it uses a
    /// grid, else the hash grid the teaching module lays over the domain or the particles.
    pub(super) fn layout(&self, s: &Snapshot) -> carom_engine::grid::GridLayout {
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

    /// Fills [`ViewerApp::marks`] for the selection; its neighbourhood, if there is one.
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

    pub(super) fn particle_colour(&self, i: usize, range: (f64, f64), s: &Snapshot) -> Color32 {
        match self.marks.get(i) {
            Some(3) => return RED,
            Some(1) => return GREEN,
            Some(2) => return CONTACT,
            _ => {}
        }
        let v = self.colour_by.of(i, self.speeds[i], s.radii[i]);
        let rgb = colormap_rgb8(colour::normalise(v, range));
        let [r, g, b] = if self.marks.is_empty() {
            rgb
        } else {
            let mix = |c: u8, back: u8| (c as f32 * FADE + back as f32 * (1.0 - FADE)) as u8;
            [0, 1, 2].map(|k| mix(rgb[k], BACKGROUND[k]))
        };
        Color32::from_rgb(r, g, b)
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
            let [r, g, b] = colormap_rgb8(((t0 + t1) * 0.5) as f64);
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

    /// The lecture's velocity split of a contact, drawn at both particles.
    pub(super) fn contact_arrows(
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
}

/// What the view fits: the domain, else the particles with some room to move.
pub(super) fn bounds(s: &Snapshot) -> (DVec3, DVec3) {
    if let Some(d) = s.domain {
        return d;
    }
    let (lo, hi) = s.positions.iter().zip(&s.radii).fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), (&p, &r)| (lo.min(p - DVec3::splat(r)), hi.max(p + DVec3::splat(r))),
    );
    if lo.is_finite() && hi.is_finite() {
        let pad = (hi - lo) * 0.1;
        (lo - pad, hi + pad)
    } else {
        (DVec3::splat(-1.0), DVec3::splat(1.0))
    }
}

pub(super) fn dv(p: Pos2) -> DVec2 {
    DVec2::new(p.x as f64, p.y as f64)
}

pub(super) fn pos(p: DVec2) -> Pos2 {
    Pos2::new(p.x as f32, p.y as f32)
}

fn fmt_num(v: f64) -> String {
    if v != 0.0 && (v.abs() >= 1e5 || v.abs() < 1e-2) {
        format!("{v:.3e}")
    } else {
        format!("{v:.3}")
    }
}

pub(super) fn fmt_vec(v: DVec3, dims: usize) -> String {
    let c = &v.to_array()[..dims];
    let parts: Vec<String> = c.iter().map(|x| format!("{x:.3}")).collect();
    format!("({})", parts.join(", "))
}
