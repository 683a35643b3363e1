//! From world coordinates to pixels: a fitted orthographic view in 2D, a perspective orbit
//! camera in 3D.

use crate::frame::Bounds;
use glam::{BVec3, DVec3};

/// The 3D orbit camera. It looks at the centre of the view box from outside, y up, and is
/// fitted so that the whole box fills the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Rotation about the y axis, degrees; 0 looks along -z (from +z).
    pub yaw_degrees: f64,
    /// Elevation above the x-z plane, degrees, within (-90, 90); positive looks down.
    pub pitch_degrees: f64,
    /// Vertical field of view, degrees, within (1, 170).
    pub fov_degrees: f64,
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            yaw_degrees: 35.0,
            pitch_degrees: 25.0,
            fov_degrees: 35.0,
        }
    }
}

/// A rectangle of the image, pixels.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Rect {
    pub x: f64,
    pub y: f64,
    pub w: f64,
    pub h: f64,
}

/// World to pixel mapping.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Projection {
    /// `px = ox + x * scale`, `py = oy - y * scale`.
    Flat { scale: f64, ox: f64, oy: f64 },
    /// Camera frame (eye, right, up, forward) and the focal length and centre in pixels.
    Perspective {
        eye: DVec3,
        right: DVec3,
        up: DVec3,
        forward: DVec3,
        focal: f64,
        cx: f64,
        cy: f64,
    },
}

/// Closer than this (in units of the view box's size) to the eye's plane is not drawn.
const NEAR: f64 = 1e-3;

/// The box's 8 corners, bit `a` of the index choosing max on axis `a`.
pub(crate) fn corners(b: &Bounds) -> [DVec3; 8] {
    let (lo, hi) = (DVec3::from_array(b.min), DVec3::from_array(b.max));
    std::array::from_fn(|i| DVec3::select(BVec3::new(i & 1 == 1, i & 2 == 2, i & 4 == 4), hi, lo))
}

/// A box no thinner than `min_extent` on any of the first `dim` axes.
fn widened(b: Bounds, dim: usize) -> Bounds {
    let mut b = b;
    let largest = (0..dim).map(|a| b.max[a] - b.min[a]).fold(0.0, f64::max);
    let floor = if largest > 0.0 { largest * 1e-3 } else { 1.0 };
    for a in 0..dim {
        if b.max[a] - b.min[a] < floor {
            let c = 0.5 * (b.min[a] + b.max[a]);
            b.min[a] = c - floor / 2.0;
            b.max[a] = c + floor / 2.0;
        }
    }
    b
}

impl Projection {
    /// 2D: `bounds` as large as fits in `area`, centred, y up.
    pub(crate) fn flat(bounds: Bounds, area: Rect) -> Self {
        let b = widened(bounds, 2);
        let (bw, bh) = (b.max[0] - b.min[0], b.max[1] - b.min[1]);
        let scale = (area.w / bw).min(area.h / bh);
        let ox = area.x + (area.w - bw * scale) / 2.0 - b.min[0] * scale;
        let oy = area.y + (area.h - bh * scale) / 2.0 + b.max[1] * scale;
        Projection::Flat { scale, ox, oy }
    }

    /// 3D: the camera orbits the centre of `bounds` at a distance where the box's bounding
    /// sphere fills the field of view; the focal length then makes the projected box fill
    /// `area`, centred.
    pub(crate) fn perspective(bounds: Bounds, camera: &Camera, area: Rect) -> Self {
        let b = widened(bounds, 3);
        let centre = DVec3::from_array(b.centre());
        let radius = 0.5 * DVec3::from_array(b.max).distance(DVec3::from_array(b.min));
        let fov = camera.fov_degrees.clamp(1.0, 170.0).to_radians();
        let (yaw, pitch) = (
            camera.yaw_degrees.to_radians(),
            camera.pitch_degrees.clamp(-89.0, 89.0).to_radians(),
        );
        let distance = radius / (fov / 2.0).sin();
        let dir = DVec3::new(
            pitch.cos() * yaw.sin(),
            pitch.sin(),
            pitch.cos() * yaw.cos(),
        );
        let eye = centre + distance * dir;
        let forward = -dir;
        let right = forward.cross(DVec3::Y).normalize_or_zero();
        let up = right.cross(forward);
        let mut p = Projection::Perspective {
            eye,
            right,
            up,
            forward,
            focal: 1.0,
            cx: 0.0,
            cy: 0.0,
        };
        // Fit the projected corners into the area.
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for c in corners(&b) {
            if let Some((x, y, _)) = p.project(c) {
                x0 = x0.min(x);
                x1 = x1.max(x);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
        if let Projection::Perspective { focal, cx, cy, .. } = &mut p {
            let f = (area.w / (x1 - x0).max(1e-12)).min(area.h / (y1 - y0).max(1e-12));
            *focal = f;
            *cx = area.x + area.w / 2.0 - f * (x0 + x1) / 2.0;
            *cy = area.y + area.h / 2.0 - f * (y0 + y1) / 2.0;
        }
        p
    }

    /// The camera's position (the origin in 2D).
    pub(crate) fn eye(&self) -> DVec3 {
        match *self {
            Projection::Flat { .. } => DVec3::ZERO,
            Projection::Perspective { eye, .. } => eye,
        }
    }

    /// Pixel coordinates and depth (distance along the view direction; 0 in 2D), or `None`
    /// when behind the camera.
    pub(crate) fn project(&self, x: DVec3) -> Option<(f64, f64, f64)> {
        match *self {
            Projection::Flat { scale, ox, oy } => Some((ox + x.x * scale, oy - x.y * scale, 0.0)),
            Projection::Perspective {
                eye,
                right,
                up,
                forward,
                focal,
                cx,
                cy,
            } => {
                let d = x - eye;
                let z = d.dot(forward);
                if z <= NEAR {
                    return None;
                }
                Some((cx + focal * d.dot(right) / z, cy - focal * d.dot(up) / z, z))
            }
        }
    }

    /// The radius in pixels of a sphere of `radius` at depth `z` (from [`Self::project`]).
    pub(crate) fn radius(&self, radius: f64, z: f64) -> f64 {
        match *self {
            Projection::Flat { scale, .. } => radius * scale,
            Projection::Perspective { focal, .. } => {
                focal * radius / (z * z - radius * radius).max(z * z * 1e-6).sqrt()
            }
        }
    }
}
