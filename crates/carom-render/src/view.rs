//! From world coordinates to pixels: a fitted orthographic view in 2D, a perspective orbit
//! camera in 3D.

use crate::frame::Bounds;

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
        eye: [f64; 3],
        right: [f64; 3],
        up: [f64; 3],
        forward: [f64; 3],
        focal: f64,
        cx: f64,
        cy: f64,
    },
}

/// Closer than this (in units of the view box's size) to the eye's plane is not drawn.
const NEAR: f64 = 1e-3;

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn normalise(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    if l > 0.0 {
        a.map(|c| c / l)
    } else {
        a
    }
}

/// The box's 8 corners, bit `a` of the index choosing max on axis `a`.
pub(crate) fn corners(b: &Bounds) -> [[f64; 3]; 8] {
    std::array::from_fn(|i| [0, 1, 2].map(|a| if i >> a & 1 == 1 { b.max[a] } else { b.min[a] }))
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
        let centre = b.centre();
        let radius = 0.5 * dot(sub(b.max, b.min), sub(b.max, b.min)).sqrt();
        let fov = camera.fov_degrees.clamp(1.0, 170.0).to_radians();
        let (yaw, pitch) = (
            camera.yaw_degrees.to_radians(),
            camera.pitch_degrees.clamp(-89.0, 89.0).to_radians(),
        );
        let distance = radius / (fov / 2.0).sin();
        let dir = [
            pitch.cos() * yaw.sin(),
            pitch.sin(),
            pitch.cos() * yaw.cos(),
        ];
        let eye = [0, 1, 2].map(|a| centre[a] + distance * dir[a]);
        let forward = dir.map(|c| -c);
        let right = normalise(cross(forward, [0.0, 1.0, 0.0]));
        let up = cross(right, forward);
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
    pub(crate) fn eye(&self) -> [f64; 3] {
        match *self {
            Projection::Flat { .. } => [0.0; 3],
            Projection::Perspective { eye, .. } => eye,
        }
    }

    /// Pixel coordinates and depth (distance along the view direction; 0 in 2D), or `None`
    /// when behind the camera.
    pub(crate) fn project(&self, x: [f64; 3]) -> Option<(f64, f64, f64)> {
        match *self {
            Projection::Flat { scale, ox, oy } => Some((ox + x[0] * scale, oy - x[1] * scale, 0.0)),
            Projection::Perspective {
                eye,
                right,
                up,
                forward,
                focal,
                cx,
                cy,
            } => {
                let d = sub(x, eye);
                let z = dot(d, forward);
                if z <= NEAR {
                    return None;
                }
                Some((
                    cx + focal * dot(d, right) / z,
                    cy - focal * dot(d, up) / z,
                    z,
                ))
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
