//! Drawing a frame: background, box, planes, particles, legend.

use crate::colour::{colormap, colour_range, position, BACKGROUND};
use crate::frame::{Bounds, Frame, FramePlane};
use crate::text;
use crate::view::{corners, Projection, Rect};
use crate::RenderOptions;
use glam::{DVec2, DVec3, Vec3};
use tiny_skia::{Color, Paint, PathBuilder, Pixmap, Stroke, Transform};

const BOX: [u8; 3] = [120, 126, 142];
const PLANE: [u8; 3] = [236, 168, 72];
const TEXT: [f32; 3] = [0.86, 0.87, 0.9];

/// Blends `rgb` (components in [0, 1]) over the opaque pixel at `index` with `coverage`.
#[inline]
pub(crate) fn blend(data: &mut [u8], index: usize, rgb: [f32; 3], coverage: f32) {
    let p = &mut data[index * 4..index * 4 + 3];
    for (d, s) in p.iter_mut().zip(rgb) {
        let dst = *d as f32;
        *d = (dst + (s * 255.0 - dst) * coverage + 0.5) as u8;
    }
}

/// How a disc is shaded.
#[derive(Clone, Copy)]
enum Shade {
    /// Flat, with a darker rim one pixel wide (2D).
    Flat,
    /// A lit sphere (3D).
    Sphere,
}

/// Light direction in camera space (x right, y up, z towards the viewer).
const LIGHT: [f32; 3] = [-0.42, 0.58, 0.7];

/// Fills an anti-aliased disc of radius `r` pixels centred at (`cx`, `cy`): each pixel's
/// coverage comes from its centre's distance to the edge.
#[allow(clippy::too_many_arguments)]
fn disc(
    data: &mut [u8],
    w: usize,
    h: usize,
    cx: f64,
    cy: f64,
    r: f64,
    rgb: [f32; 3],
    shade: Shade,
) {
    if !(cx.is_finite() && cy.is_finite() && r.is_finite()) {
        return;
    }
    let r = r.max(0.6) as f32;
    let (cx, cy) = (cx as f32, cy as f32);
    let reach = r + 0.5;
    // Float to int casts saturate: off-image discs give empty ranges.
    let x0 = (cx - reach).floor().max(0.0) as usize;
    let x1 = ((cx + reach).ceil().max(0.0) as usize).min(w);
    let y0 = (cy - reach).floor().max(0.0) as usize;
    let y1 = ((cy + reach).ceil().max(0.0) as usize).min(h);
    let reach2 = reach * reach;
    let rim = r >= 2.0;
    let light = Vec3::from_array(LIGHT).normalize();
    // Blinn-Phong's half vector, the viewer along +z
    let half = (light + Vec3::Z).normalize();
    let inv_r = 1.0 / r;
    for y in y0..y1 {
        let dy = y as f32 + 0.5 - cy;
        let row = y * w;
        for x in x0..x1 {
            let dx = x as f32 + 0.5 - cx;
            let d2 = dx * dx + dy * dy;
            if d2 >= reach2 {
                continue;
            }
            let d = d2.sqrt();
            let coverage = (r - d + 0.5).min(1.0);
            if coverage <= 0.0 {
                continue;
            }
            let colour = match shade {
                Shade::Flat => {
                    if rim {
                        let k = 0.55 + 0.45 * (r - d - 0.25).clamp(0.0, 1.0);
                        rgb.map(|c| c * k)
                    } else {
                        rgb
                    }
                }
                Shade::Sphere => {
                    let nx = (dx * inv_r).clamp(-1.0, 1.0);
                    let ny = (-dy * inv_r).clamp(-1.0, 1.0);
                    let normal = Vec3::new(nx, ny, (1.0 - nx * nx - ny * ny).max(0.0).sqrt());
                    let lambert = normal.dot(light).max(0.0);
                    let s = normal.dot(half).max(0.0);
                    let s2 = s * s;
                    let s8 = s2 * s2 * s2 * s2;
                    let specular = 0.35 * s8 * s8 * s8;
                    let k = 0.22 + 0.78 * lambert;
                    rgb.map(|c| (c * k + specular).min(1.0))
                }
            };
            blend(data, row + x, colour, coverage);
        }
    }
}

fn paint(rgb: [u8; 3], alpha: u8) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(rgb[0], rgb[1], rgb[2], alpha);
    p.anti_alias = true;
    p
}

/// Strokes a polyline (closed when asked) with tiny-skia.
fn polyline(
    pixmap: &mut Pixmap,
    points: &[(f64, f64)],
    closed: bool,
    rgb: [u8; 3],
    alpha: u8,
    width: f64,
) {
    let mut pb = PathBuilder::new();
    for (i, &(x, y)) in points.iter().enumerate() {
        if !(x.is_finite() && y.is_finite()) {
            return;
        }
        if i == 0 {
            pb.move_to(x as f32, y as f32);
        } else {
            pb.line_to(x as f32, y as f32);
        }
    }
    if closed {
        pb.close();
    }
    if let Some(path) = pb.finish() {
        let stroke = Stroke {
            width: width as f32,
            ..Stroke::default()
        };
        pixmap.stroke_path(
            &path,
            &paint(rgb, alpha),
            &stroke,
            Transform::identity(),
            None,
        );
    }
}

/// Clips the segment `a`-`b` to `rect` (Liang-Barsky).
fn clip(a: (f64, f64), b: (f64, f64), rect: Rect) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - rect.x),
        (dx, rect.x + rect.w - a.0),
        (-dy, a.1 - rect.y),
        (dy, rect.y + rect.h - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 <= t1).then_some((
        (a.0 + t0 * dx, a.1 + t0 * dy),
        (a.0 + t1 * dx, a.1 + t1 * dy),
    ))
}

/// True when `plane` is one of the domain's faces (a wall): the box outline shows it.
fn is_domain_face(plane: &FramePlane, domain: Option<&Bounds>, dim: usize) -> bool {
    let Some(d) = domain else { return false };
    (0..dim).any(|a| {
        let tol = 1e-9 * (d.max[a] - d.min[a]).abs().max(1.0);
        plane.normal[a].abs() > 1.0 - 1e-9
            && ((plane.point[a] - d.min[a]).abs() <= tol
                || (plane.point[a] - d.max[a]).abs() <= tol)
    })
}

/// Formats a legend value with about three significant digits.
fn number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        return format!("{v:.2e}");
    }
    let digits = (2 - a.log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}

/// Draws `frame` onto `pixmap` (already allocated at the options' size).
pub(crate) fn frame(pixmap: &mut Pixmap, frame: &Frame, options: &RenderOptions) {
    let [r, g, b] = BACKGROUND;
    pixmap.fill(Color::from_rgba8(r, g, b, 255));
    let (w, h) = (pixmap.width() as f64, pixmap.height() as f64);
    let short = w.min(h);
    let ui = (short / 800.0).max(0.5);
    let font_px = (15.0 * ui).clamp(10.0, 48.0);
    let legend_h = if options.legend {
        (font_px * 2.4).round().min(h / 3.0)
    } else {
        0.0
    };
    let margin = (0.03 * short).max(2.0);
    let area = Rect {
        x: margin,
        y: margin,
        w: (w - 2.0 * margin).max(1.0),
        h: (h - legend_h - 2.0 * margin).max(1.0),
    };
    let visible = Rect {
        x: 0.0,
        y: 0.0,
        w,
        h: h - legend_h,
    };
    let bounds = options.view.unwrap_or_else(|| frame.view_bounds());
    let range = options
        .range
        .unwrap_or_else(|| colour_range(std::slice::from_ref(frame), options.colouring));
    let line = (1.5 * ui).max(1.0);
    let dim = frame.dimensions;
    let colour = |id: usize| colormap(position(options.colouring.value(frame, id), range));

    if dim == 2 {
        flat(
            pixmap,
            frame,
            Projection::flat(bounds, area),
            visible,
            line,
            &colour,
        );
    } else {
        let proj = Projection::perspective(bounds, &options.camera, area);
        perspective(pixmap, frame, proj, &bounds, line, &colour);
    }

    if options.legend {
        legend(pixmap, frame, options, range, font_px, legend_h, margin);
    }
}

/// The 2D picture: the domain's outline, planes as lines across the view, flat discs.
fn flat(
    pixmap: &mut Pixmap,
    frame: &Frame,
    proj: Projection,
    visible: Rect,
    line: f64,
    colour: &dyn Fn(usize) -> [f32; 3],
) {
    let (w, h) = (pixmap.width() as f64, pixmap.height() as f64);
    let p2 = |x: [f64; 3]| proj.project(DVec3::from_array(x)).map(|(x, y, _)| (x, y));
    if let Some(d) = &frame.domain {
        if let (Some(a), Some(c)) = (p2(d.min), p2(d.max)) {
            let pts = [a, (c.0, a.1), c, (a.0, c.1)];
            polyline(pixmap, &pts, true, BOX, 255, line);
        }
    }
    for plane in &frame.planes {
        if is_domain_face(plane, frame.domain.as_ref(), 2) {
            continue;
        }
        let Some(p) = p2(plane.point) else { continue };
        // Along the plane: the normal turned a quarter; pixels have y down.
        let t = DVec2::new(plane.normal[0], plane.normal[1])
            .perp()
            .normalize_or_zero();
        let reach = (p.0 - w / 2.0).hypot(p.1 - h / 2.0) + w + h;
        let a = (p.0 - t.x * reach, p.1 + t.y * reach);
        let b = (p.0 + t.x * reach, p.1 - t.y * reach);
        if let Some((a, b)) = clip(a, b, visible) {
            polyline(pixmap, &[a, b], false, PLANE, 255, line * 1.3);
        }
    }
    let (pw, ph) = (pixmap.width() as usize, pixmap.height() as usize);
    let data = pixmap.data_mut();
    for id in 0..frame.positions.len() {
        if let Some((x, y, _)) = proj.project(DVec3::from_array(frame.positions[id])) {
            let r = proj.radius(frame.radii[id], 0.0);
            disc(data, pw, ph, x, y, r, colour(id), Shade::Flat);
        }
    }
}

/// The 3D picture: the box's back edges, planes' outlines in the box, spheres far to near,
/// the box's front edges.
fn perspective(
    pixmap: &mut Pixmap,
    frame: &Frame,
    proj: Projection,
    bounds: &Bounds,
    line: f64,
    colour: &dyn Fn(usize) -> [f32; 3],
) {
    let p2 = |x: DVec3| proj.project(x).map(|(x, y, _)| (x, y));
    // The box's edges: those on a face turned towards the camera are in front of every
    // particle inside, so they are drawn after the particles, the others before.
    let edges = |front: bool, pixmap: &mut Pixmap| {
        let Some(d) = &frame.domain else { return };
        let eye = proj.eye();
        let c = corners(d);
        let facing = |axis: usize, max: bool| {
            if max {
                eye[axis] > d.max[axis]
            } else {
                eye[axis] < d.min[axis]
            }
        };
        for i in 0..8usize {
            for a in 0..3 {
                let j = i | 1 << a;
                if j == i {
                    continue;
                }
                let (b, e) = ((a + 1) % 3, (a + 2) % 3);
                let is_front = facing(b, i >> b & 1 == 1) || facing(e, i >> e & 1 == 1);
                if is_front == front {
                    if let (Some(p), Some(q)) = (p2(c[i]), p2(c[j])) {
                        polyline(pixmap, &[p, q], false, BOX, 255, line);
                    }
                }
            }
        }
    };
    edges(false, pixmap);
    for plane in &frame.planes {
        if is_domain_face(plane, frame.domain.as_ref(), 3) {
            continue;
        }
        let outline = plane_in_box(plane, bounds);
        let pts: Option<Vec<_>> = outline.iter().map(|&x| p2(x)).collect();
        if let Some(pts) = pts.filter(|p| p.len() >= 3) {
            polyline(pixmap, &pts, true, PLANE, 255, line * 1.3);
        }
    }
    let mut order: Vec<(f64, f64, f64, u32)> = (0..frame.positions.len())
        .filter_map(|id| {
            proj.project(DVec3::from_array(frame.positions[id]))
                .map(|(x, y, z)| (z, x, y, id as u32))
        })
        .collect();
    // Far first; the sort is stable, so equal depths keep id order.
    order.sort_by(|a, b| b.0.total_cmp(&a.0));
    let (pw, ph) = (pixmap.width() as usize, pixmap.height() as usize);
    let data = pixmap.data_mut();
    for (z, x, y, id) in order {
        let id = id as usize;
        let r = proj.radius(frame.radii[id], z);
        disc(data, pw, ph, x, y, r, colour(id), Shade::Sphere);
    }
    edges(true, pixmap);
}

/// The polygon where `plane` cuts the box `b` (empty when it misses), in order around it.
fn plane_in_box(plane: &FramePlane, b: &Bounds) -> Vec<DVec3> {
    let c = corners(b);
    let n = DVec3::from_array(plane.normal).normalize_or_zero();
    let on = DVec3::from_array(plane.point);
    let side = |x: DVec3| (x - on).dot(n);
    let mut points: Vec<DVec3> = Vec::new();
    for i in 0..8usize {
        for a in 0..3 {
            let j = i | 1 << a;
            if j == i {
                continue;
            }
            let (da, db) = (side(c[i]), side(c[j]));
            if (da <= 0.0) != (db <= 0.0) {
                let t = da / (da - db);
                points.push(c[i] + t * (c[j] - c[i]));
            }
        }
    }
    if points.len() < 3 {
        return Vec::new();
    }
    let centre = points.iter().sum::<DVec3>() / points.len() as f64;
    let helper = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let u = n.cross(helper).normalize_or_zero();
    let v = n.cross(u);
    let angle = |p: &DVec3| {
        let d = *p - centre;
        d.dot(v).atan2(d.dot(u))
    };
    points.sort_by(|p, q| angle(p).total_cmp(&angle(q)));
    points
}

/// The legend band: label, colour bar with its ends, and time and step on the right.
fn legend(
    pixmap: &mut Pixmap,
    frame: &Frame,
    options: &RenderOptions,
    (lo, hi): (f64, f64),
    font_px: f64,
    legend_h: f64,
    margin: f64,
) {
    let (w, h) = (pixmap.width() as usize, pixmap.height() as usize);
    let size = font_px as f32;
    let mid = h as f32 - legend_h as f32 / 2.0;
    let baseline = mid + text::cap_height(size) / 2.0;
    let gap = size * 0.6;
    let label = options.colouring.label();
    let (lo_text, hi_text) = (number(lo), number(hi));
    let right = format!("t = {}   step {}", number_time(frame.time), frame.step);
    let margin = margin as f32;
    let right_w = text::width(size, &right);
    let fixed =
        text::width(size, label) + text::width(size, &lo_text) + text::width(size, &hi_text);
    let available = w as f32 - 2.0 * margin - right_w - fixed - 5.0 * gap;
    let bar_w = available.min(0.4 * w as f32).max(size * 3.0);
    let bar_h = size * 0.8;

    let data = pixmap.data_mut();
    let mut x = margin;
    x += text::draw(data, w, h, size, x, baseline, TEXT, label) + gap;
    x += text::draw(data, w, h, size, x, baseline, TEXT, &lo_text) + gap * 0.7;
    let bar_x = x;
    let (y0, y1) = (
        (mid - bar_h / 2.0).round() as usize,
        (mid + bar_h / 2.0).round() as usize,
    );
    let (x0, x1) = (
        bar_x.round() as usize,
        ((bar_x + bar_w).round() as usize).min(w),
    );
    for px in x0..x1 {
        let t = (px - x0) as f64 / (x1 - x0 - 1).max(1) as f64;
        let c = colormap(t);
        for py in y0..y1.min(h) {
            blend(data, py * w + px, c, 1.0);
        }
    }
    x = bar_x + bar_w + gap * 0.7;
    text::draw(data, w, h, size, x, baseline, TEXT, &hi_text);
    text::draw(
        data,
        w,
        h,
        size,
        w as f32 - margin - right_w,
        baseline,
        TEXT,
        &right,
    );
}

fn number_time(t: f64) -> String {
    if t.abs() < 1e5 {
        format!("{t:.2}")
    } else {
        format!("{t:.3e}")
    }
}
