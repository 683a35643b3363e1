//! The 3D picture: an orbit camera around the domain, its wireframe, the lecture's grid on the
//! floor, depth-sorted spheres, the selection's neighbour cells, and picking by click.

use super::canvas::{bounds, dv, pos, Input, Scene, GREEN, GRID, RED};
use super::ViewerApp;
use crate::render;
use crate::view::{self, OrbitCamera, Projected};
use carom_engine::glam::{DVec2, DVec3};
use carom_engine::grid::GridLayout;
use eframe::egui::{self, Color32, Pos2, Shape, Stroke, Vec2};

impl ViewerApp {
    pub(super) fn canvas_3d(&mut self, scene: &Scene<'_>, input: Input) {
        let (painter, rect, s) = (scene.painter, scene.rect, scene.snap);
        let cam = self.camera_3d(scene, input);
        let (eye, basis) = (cam.eye(), cam.basis());
        let centre = dv(rect.center());
        let height = rect.height() as f64;
        let project = |p: DVec3| cam.project(&basis, eye, p, centre, height);
        let to = |p: DVec3| {
            project(p)
                .map(|q| pos(q.screen))
                .unwrap_or(Pos2::new(f32::NAN, f32::NAN))
        };
        let wire = |lo: DVec3, hi: DVec3, stroke: Stroke| wire(painter, &project, lo, hi, stroke);
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
            floor_grid(painter, &layout, &to);
        }

        let projected: Vec<Option<Projected>> = s.positions.iter().map(|&p| project(p)).collect();
        self.spheres(scene, &projected);

        if let Some(n) = scene.neighbourhood {
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
        if let Some(at) = input.clicked {
            let discs = projected
                .iter()
                .enumerate()
                .filter_map(|(i, q)| q.map(|q| (i, q.screen, s.radii[i] * q.scale, q.depth)));
            self.selected = view::pick(discs, dv(at), 6.0);
            self.chosen_contact = None;
        }
    }

    /// The camera of this frame: fitted when asked, then zoomed and turned by the pointer.
    fn camera_3d(&mut self, scene: &Scene<'_>, input: Input) -> OrbitCamera {
        if self.refit || self.camera.is_none() {
            let (min, max) = bounds(scene.snap);
            self.camera = Some(OrbitCamera::fit(min, max));
            self.refit = false;
        }
        let cam = self.camera.as_mut().expect("set above");
        if input.zooms() {
            cam.zoom(input.zoom);
        }
        if input.drag != Vec2::ZERO {
            cam.rotate(DVec2::new(input.drag.x as f64, input.drag.y as f64));
        }
        *cam
    }

    /// Depth-sorted spheres, far to near, in one mesh; the selection's in a second one on
    /// top, so that the lecture's red and green show.
    fn spheres(&mut self, scene: &Scene<'_>, projected: &[Option<Projected>]) {
        let (rect, s) = (scene.rect, scene.snap);
        self.order.clear();
        for (i, q) in projected.iter().enumerate() {
            if let Some(q) = q {
                self.order.push((q.depth, i as u32));
            }
        }
        self.order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
        let mut mesh = render::sprite_mesh(self.sphere.id(), self.order.len());
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
                let colour = self.particle_colour(i, scene.range, s);
                render::push_sprite(target, c, half, colour);
            }
        }
        scene.painter.add(Shape::mesh(mesh));
        scene.painter.add(Shape::mesh(marked));
    }
}

/// The edges of the box `lo`..`hi`, those with both ends in front of the camera.
fn wire(
    painter: &egui::Painter,
    project: &dyn Fn(DVec3) -> Option<Projected>,
    lo: DVec3,
    hi: DVec3,
    stroke: Stroke,
) {
    let corner = |k: u32| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    };
    for i in 0..8u32 {
        for axis in 0..3 {
            if i & (1 << axis) == 0 {
                let j = i | (1 << axis);
                if let (Some(a), Some(b)) = (project(corner(i)), project(corner(j))) {
                    painter.line_segment([pos(a.screen), pos(b.screen)], stroke);
                }
            }
        }
    }
}

/// The grid's cells on the floor of the box (its lowest y).
fn floor_grid(painter: &egui::Painter, layout: &GridLayout, to: &dyn Fn(DVec3) -> Pos2) {
    let (o, cs) = (layout.origin, layout.cell_size);
    let [cx, _, cz] = layout.cells;
    let y = o[1];
    for i in 0..=cx {
        let x = o[0] + i as f64 * cs[0];
        let z1 = o[2] + cz as f64 * cs[2];
        let a = [to(DVec3::new(x, y, o[2])), to(DVec3::new(x, y, z1))];
        painter.line_segment(a, Stroke::new(1.0, GRID));
    }
    for k in 0..=cz {
        let z = o[2] + k as f64 * cs[2];
        let x1 = o[0] + cx as f64 * cs[0];
        let a = [to(DVec3::new(o[0], y, z)), to(DVec3::new(x1, y, z))];
        painter.line_segment(a, Stroke::new(1.0, GRID));
    }
}
