//! The 2D picture: a pan-and-zoom view of the domain, its walls and planes, the lecture's hash
//! grid and the selection's neighbour cells, every particle, and picking by click.

use super::canvas::{bounds, dv, pos, Input, Scene, CONTACT, GREEN, GRID, RED};
use super::ViewerApp;
use crate::render;
use crate::view::{self, View2};
use carom_engine::glam::{DVec2, DVec3};
use eframe::egui::{
    Align2, Color32, FontId, Pos2, Rect, Shape, Stroke, StrokeKind, TextureOptions, Vec2,
};

impl ViewerApp {
    pub(super) fn canvas_2d(&mut self, scene: &Scene<'_>, input: Input) {
        let view = self.view_2d(scene, input);
        let to = |p: DVec3| pos(view.to_screen(p.truncate()));
        walls_2d(scene, &view, &to);
        self.grid_2d(scene, &view, &to);
        self.particles_2d(scene, &view, &to);

        let (painter, s) = (scene.painter, scene.snap);
        if let Some(n) = scene.neighbourhood {
            for &c in &n.contacts {
                painter.line_segment(
                    [to(s.positions[n.id]), to(s.positions[c])],
                    Stroke::new(1.0, CONTACT),
                );
            }
            if let Some(c) = self.chosen_contact.filter(|c| n.contacts.contains(c)) {
                self.contact_arrows(painter, s, n.id, c, &to);
            }
        }
        if let Some(at) = input.clicked {
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

    /// The view of this frame: fitted when asked (or when particles leave a domain-less
    /// picture), then zoomed and panned by the pointer.
    fn view_2d(&mut self, scene: &Scene<'_>, input: Input) -> View2 {
        let (rect, s) = (scene.rect, scene.snap);
        let centre = dv(rect.center());
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
        if input.zooms() {
            if let Some(p) = input.pointer {
                view.zoom_at(dv(p), input.zoom);
            }
        }
        if input.drag != Vec2::ZERO {
            view.pan(DVec2::new(input.drag.x as f64, input.drag.y as f64));
        }
        *view
    }

    /// The lecture's grid lines, and the selection's cell (red) and neighbour cells (green).
    fn grid_2d(&self, scene: &Scene<'_>, view: &View2, to: &dyn Fn(DVec3) -> Pos2) {
        let (painter, rect) = (scene.painter, scene.rect);
        let layout = self.layout(scene.snap);
        let (o, cs) = (layout.origin, layout.cell_size);
        if self.show_grid {
            let [cx, cy, _] = layout.cells;
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
        if let Some(n) = scene.neighbourhood {
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
    }

    /// Every particle: one mesh of quads, or (very many) one image drawn here.
    fn particles_2d(&mut self, scene: &Scene<'_>, view: &View2, to: &dyn Fn(DVec3) -> Pos2) {
        let (painter, rect, s, range) = (scene.painter, scene.rect, scene.snap, scene.range);
        let scale = view.scale as f32;
        let visible = s
            .positions
            .iter()
            .zip(&s.radii)
            .filter(|&(&p, &r)| render::visible(&rect, to(p), (r as f32 * scale).max(0.8)))
            .count();
        if visible <= render::RASTER_ABOVE {
            let mut mesh = render::sprite_mesh(self.disc.id(), visible);
            for (i, (&p, &r)) in s.positions.iter().zip(&s.radii).enumerate() {
                let c = to(p);
                let half = (r as f32 * scale).max(0.8);
                if render::visible(&rect, c, half) {
                    render::push_sprite(&mut mesh, c, half, self.particle_colour(i, range, s));
                }
            }
            painter.add(Shape::mesh(mesh));
            return;
        }
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
                let t =
                    painter
                        .ctx()
                        .load_texture("carom-particles", image, TextureOptions::NEAREST);
                let id = t.id();
                self.raster_texture = Some(t);
                id
            }
        };
        let uv = Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0));
        painter.image(texture, rect, uv, Color32::WHITE);
    }
}

/// The domain's box and every plane (as a line across the view).
fn walls_2d(scene: &Scene<'_>, view: &View2, to: &dyn Fn(DVec3) -> Pos2) {
    let (painter, s) = (scene.painter, scene.snap);
    if let Some((lo, hi)) = s.domain {
        let r = Rect::from_two_pos(to(lo), to(hi));
        painter.rect_stroke(
            r,
            0.0,
            Stroke::new(1.5, Color32::from_gray(200)),
            StrokeKind::Middle,
        );
    }
    let size = scene.rect.size();
    let far = (DVec2::new(size.x as f64, size.y as f64).length() / view.scale) * 2.0;
    for &(p, n) in &s.planes {
        let t = DVec3::new(-n.y, n.x, 0.0);
        painter.line_segment(
            [to(p - t * far), to(p + t * far)],
            Stroke::new(1.0, Color32::from_rgb(120, 150, 220)),
        );
    }
}
