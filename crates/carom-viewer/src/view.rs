//! Screen <-> world mappings: the 2D pan/zoom view, the 3D orbiting camera, and picking a
//! particle under the mouse. Plain numbers in and out (screen points are egui points, y down).

use carom_engine::glam::{DVec2, DVec3};

/// A 2D view: world point `center` sits at screen point `screen_center`, `scale` screen points
/// per world unit, world y up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View2 {
    /// World point at the middle of the canvas.
    pub center: DVec2,
    /// Screen points per world unit (> 0).
    pub scale: f64,
    /// Middle of the canvas, screen points.
    pub screen_center: DVec2,
}

impl View2 {
    /// The view that shows the box `min..max` whole, with a small margin, in a canvas of
    /// `size` screen points centred at `screen_center`.
    pub fn fit(min: DVec2, max: DVec2, screen_center: DVec2, size: DVec2) -> Self {
        let extent = (max - min).max(DVec2::splat(1e-9));
        let scale = ((size.x / extent.x).min(size.y / extent.y) * 0.95).max(1e-9);
        Self {
            center: (min + max) * 0.5,
            scale: if scale.is_finite() { scale } else { 1.0 },
            screen_center,
        }
    }

    /// World -> screen.
    #[inline]
    pub fn to_screen(&self, p: DVec2) -> DVec2 {
        let d = (p - self.center) * self.scale;
        DVec2::new(self.screen_center.x + d.x, self.screen_center.y - d.y)
    }

    /// Screen -> world.
    #[inline]
    pub fn to_world(&self, s: DVec2) -> DVec2 {
        let d = s - self.screen_center;
        self.center + DVec2::new(d.x, -d.y) / self.scale
    }

    /// Zooms by `factor` keeping the world point under screen point `at` where it is.
    pub fn zoom_at(&mut self, at: DVec2, factor: f64) {
        if !(factor.is_finite() && factor > 0.0) {
            return;
        }
        let anchor = self.to_world(at);
        self.scale = (self.scale * factor).clamp(1e-6, 1e9);
        let moved = self.to_screen(anchor) - at;
        self.center += DVec2::new(moved.x, -moved.y) / self.scale;
    }

    /// Moves the picture by `delta` screen points.
    pub fn pan(&mut self, delta: DVec2) {
        self.center -= DVec2::new(delta.x, -delta.y) / self.scale;
    }
}

/// A camera orbiting `target` at `distance`, looking at it: `yaw` around the world y axis,
/// `pitch` up from the x-z plane (radians), vertical field of view `fov_y`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// The point looked at (and orbited).
    pub target: DVec3,
    /// Angle around the world y axis.
    pub yaw: f64,
    /// Angle above the x-z plane, kept inside (-pi/2, pi/2).
    pub pitch: f64,
    /// Distance from the target (> 0).
    pub distance: f64,
    /// Vertical field of view, radians.
    pub fov_y: f64,
}

/// A point seen by the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projected {
    /// Screen position (points, y down).
    pub screen: DVec2,
    /// Distance along the view direction (larger is farther).
    pub depth: f64,
    /// Screen points per world unit at that depth.
    pub scale: f64,
}

const MAX_PITCH: f64 = 1.55;

impl OrbitCamera {
    /// A camera that sees the box `min..max` whole, slightly from above and the side.
    pub fn fit(min: DVec3, max: DVec3) -> Self {
        let fov_y = 45f64.to_radians();
        let radius = ((max - min).length() * 0.5).max(1e-6);
        Self {
            target: (min + max) * 0.5,
            yaw: 0.6,
            pitch: 0.45,
            distance: radius / (fov_y * 0.5).sin() * 1.05,
            fov_y,
        }
    }

    /// Turns the camera for a mouse drag of `delta` screen points.
    pub fn rotate(&mut self, delta: DVec2) {
        self.yaw -= delta.x * 0.01;
        self.pitch = (self.pitch + delta.y * 0.01).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves closer (`factor` > 1) or farther.
    pub fn zoom(&mut self, factor: f64) {
        if factor.is_finite() && factor > 0.0 {
            self.distance = (self.distance / factor).clamp(1e-3, 1e9);
        }
    }

    /// Camera position.
    pub fn eye(&self) -> DVec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + DVec3::new(cp * sy, sp, cp * cy) * self.distance
    }

    /// `(right, up, forward)`, orthonormal, forward from the eye to the target.
    pub fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let forward = (self.target - self.eye()).normalize();
        let right = forward.cross(DVec3::Y).normalize();
        let up = right.cross(forward);
        (right, up, forward)
    }

    /// Projects `p` for a canvas of height `height` points centred at `screen_center`;
    /// `None` behind (or too close to) the camera.
    #[inline]
    pub fn project(
        &self,
        basis: &(DVec3, DVec3, DVec3),
        eye: DVec3,
        p: DVec3,
        screen_center: DVec2,
        height: f64,
    ) -> Option<Projected> {
        let (right, up, forward) = *basis;
        let d = p - eye;
        let depth = d.dot(forward);
        if depth <= self.distance * 1e-3 {
            return None;
        }
        let focal = height * 0.5 / (self.fov_y * 0.5).tan();
        let scale = focal / depth;
        Some(Projected {
            screen: DVec2::new(
                screen_center.x + d.dot(right) * scale,
                screen_center.y - d.dot(up) * scale,
            ),
            depth,
            scale,
        })
    }
}

/// The particle under screen point `at`: among the discs (screen centre, screen radius,
/// depth) that contain it, the nearest to the viewer (smallest depth); if none does, the one
/// whose edge is closest, if within `tolerance` points.
pub fn pick(
    discs: impl Iterator<Item = (usize, DVec2, f64, f64)>,
    at: DVec2,
    tolerance: f64,
) -> Option<usize> {
    let mut inside: Option<(f64, f64, usize)> = None;
    let mut near: Option<(f64, usize)> = None;
    for (id, centre, radius, depth) in discs {
        let d = (centre - at).length();
        if d <= radius {
            // front-most first, then the closest centre
            let key = (depth, d, id);
            if inside.is_none_or(|best| (key.0, key.1) < (best.0, best.1)) {
                inside = Some(key);
            }
        } else if d - radius <= tolerance && near.is_none_or(|best| d - radius < best.0) {
            near = Some((d - radius, id));
        }
    }
    inside.map(|k| k.2).or(near.map(|k| k.1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec2, b: DVec2) -> bool {
        (a - b).length() < 1e-9
    }

    #[test]
    fn view2_round_trips_and_flips_y() {
        let v = View2::fit(
            DVec2::splat(-100.0),
            DVec2::splat(100.0),
            DVec2::new(400.0, 300.0),
            DVec2::new(800.0, 600.0),
        );
        assert!(close(v.to_screen(DVec2::ZERO), DVec2::new(400.0, 300.0)));
        // y up in the world is up on screen (smaller y)
        assert!(v.to_screen(DVec2::new(0.0, 100.0)).y < 300.0);
        // the whole box fits the smaller side
        let top = v.to_screen(DVec2::new(-100.0, 100.0));
        assert!(top.y >= 0.0 && top.x >= 0.0);
        let p = DVec2::new(12.5, -40.0);
        assert!(close(v.to_world(v.to_screen(p)), p));
    }

    #[test]
    fn zoom_keeps_the_anchor_and_ignores_nonsense() {
        let mut v = View2::fit(DVec2::ZERO, DVec2::ONE, DVec2::ZERO, DVec2::splat(100.0));
        let at = DVec2::new(13.0, -7.0);
        let before = v.to_world(at);
        v.zoom_at(at, 2.5);
        assert!(close(v.to_world(at), before));
        let saved = v;
        v.zoom_at(at, f64::NAN);
        v.zoom_at(at, 0.0);
        assert_eq!(v, saved);
        v.pan(DVec2::new(10.0, 0.0));
        assert!(close(v.to_world(at + DVec2::new(10.0, 0.0)), before));
    }

    #[test]
    fn degenerate_fit_is_finite() {
        let v = View2::fit(DVec2::ZERO, DVec2::ZERO, DVec2::ZERO, DVec2::ZERO);
        assert!(v.scale.is_finite() && v.scale > 0.0);
    }

    #[test]
    fn camera_projects_target_to_centre_and_orders_depth() {
        let cam = OrbitCamera::fit(DVec3::splat(-20.0), DVec3::splat(20.0));
        let (eye, basis) = (cam.eye(), cam.basis());
        let c = DVec2::new(300.0, 200.0);
        let t = cam.project(&basis, eye, cam.target, c, 400.0).unwrap();
        assert!(close(t.screen, c));
        assert!((t.depth - cam.distance).abs() < 1e-9);
        // every corner of the box is in front of the camera and on the canvas
        for i in 0..8 {
            let corner = DVec3::new(
                if i & 1 == 0 { -20.0 } else { 20.0 },
                if i & 2 == 0 { -20.0 } else { 20.0 },
                if i & 4 == 0 { -20.0 } else { 20.0 },
            );
            let p = cam.project(&basis, eye, corner, c, 400.0).unwrap();
            assert!((p.screen.y - 200.0).abs() <= 200.0, "{p:?}");
        }
        // the point nearer the eye is nearer in depth and drawn larger
        let near = cam
            .project(&basis, eye, cam.target + (eye - cam.target) * 0.5, c, 400.0)
            .unwrap();
        assert!(near.depth < t.depth && near.scale > t.scale);
        // behind the eye: not drawn
        assert!(cam
            .project(&basis, eye, eye * 2.0 - cam.target, c, 400.0)
            .is_none());
    }

    #[test]
    fn camera_rotation_keeps_distance_and_clamps_pitch() {
        let mut cam = OrbitCamera::fit(DVec3::ZERO, DVec3::ONE);
        cam.rotate(DVec2::new(123.0, 1e6));
        assert!(cam.pitch <= MAX_PITCH);
        assert!(((cam.eye() - cam.target).length() - cam.distance).abs() < 1e-9);
        let (r, u, f) = cam.basis();
        assert!(r.dot(u).abs() < 1e-9 && r.dot(f).abs() < 1e-9 && u.dot(f).abs() < 1e-9);
        assert!(u.y > 0.0, "the world's up stays up on screen");
    }

    #[test]
    fn picking_prefers_front_then_near() {
        let discs = vec![
            (0, DVec2::new(0.0, 0.0), 5.0, 10.0),
            (1, DVec2::new(1.0, 0.0), 5.0, 2.0), // in front
            (2, DVec2::new(30.0, 0.0), 2.0, 1.0),
        ];
        assert_eq!(
            pick(discs.clone().into_iter(), DVec2::new(0.5, 0.0), 3.0),
            Some(1)
        );
        // outside every disc, but within tolerance of #2's edge
        assert_eq!(
            pick(discs.clone().into_iter(), DVec2::new(26.0, 0.0), 3.0),
            Some(2)
        );
        assert_eq!(pick(discs.into_iter(), DVec2::new(100.0, 0.0), 3.0), None);
        // equal depth (2D): the closest centre wins
        let flat = vec![
            (0, DVec2::ZERO, 4.0, 0.0),
            (1, DVec2::new(3.0, 0.0), 4.0, 0.0),
        ];
        assert_eq!(pick(flat.into_iter(), DVec2::new(2.0, 0.0), 0.0), Some(1));
    }
}
