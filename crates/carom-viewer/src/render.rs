//! Particle sprites: every particle is one textured quad of a single mesh, so the GPU gets a
//! few draw calls however many particles there are.

use carom_engine::glam::Vec3;
use eframe::egui::{Color32, ColorImage, Mesh, Pos2, Rect, TextureId};
use eframe::epaint::Vertex;

/// Sprite texture size in pixels.
pub const SPRITE: usize = 64;

/// A white disc with a soft one-pixel edge (premultiplied alpha), for 2D particles.
pub fn disc_image() -> ColorImage {
    sprite(|_, _, _| 1.0)
}

/// A white sphere lit from the upper left, front (shade in the colour, alpha at the edge), for
/// 3D particles. The light is fixed relative to the camera, so a sprite is exact for a sphere.
pub fn sphere_image() -> ColorImage {
    let light = Vec3::new(-0.45, 0.55, 0.70).normalize();
    // Blinn-Phong with the viewer along +z
    let half = (light + Vec3::Z).normalize();
    sprite(|x, y, z| {
        let n = Vec3::new(x, y, z);
        let diffuse = n.dot(light).max(0.0);
        let spec = n.dot(half).max(0.0).powf(40.0);
        (0.25 + 0.75 * diffuse + 0.5 * spec).min(1.4)
    })
}

/// Renders a sprite: `shade(x, y, z)` on the unit sphere's front half (y up) gives brightness.
fn sprite(shade: impl Fn(f32, f32, f32) -> f32) -> ColorImage {
    let n = SPRITE;
    let mut px = Vec::with_capacity(n * n);
    let half = n as f32 / 2.0;
    for j in 0..n {
        for i in 0..n {
            let x = (i as f32 + 0.5 - half) / half;
            let y = -(j as f32 + 0.5 - half) / half;
            let r = (x * x + y * y).sqrt();
            // coverage: 1 inside, fading over the last pixel
            let alpha = ((1.0 - r) * half + 0.5).clamp(0.0, 1.0);
            let z = (1.0 - (r * r).min(1.0)).sqrt();
            let s = shade(x, y, z);
            let v = (s.min(1.0) * alpha * 255.0).round() as u8;
            let a = (alpha * 255.0).round() as u8;
            px.push(Color32::from_rgba_premultiplied(v, v, v, a));
        }
    }
    ColorImage::new([n, n], px)
}

/// Adds one sprite quad centred at `c` with half-size `half` points, tinted `color`.
#[inline]
pub fn push_sprite(mesh: &mut Mesh, c: Pos2, half: f32, color: Color32) {
    let base = mesh.vertices.len() as u32;
    let (x0, x1, y0, y1) = (c.x - half, c.x + half, c.y - half, c.y + half);
    mesh.vertices.extend_from_slice(&[
        Vertex {
            pos: Pos2::new(x0, y0),
            uv: Pos2::new(0.0, 0.0),
            color,
        },
        Vertex {
            pos: Pos2::new(x1, y0),
            uv: Pos2::new(1.0, 0.0),
            color,
        },
        Vertex {
            pos: Pos2::new(x1, y1),
            uv: Pos2::new(1.0, 1.0),
            color,
        },
        Vertex {
            pos: Pos2::new(x0, y1),
            uv: Pos2::new(0.0, 1.0),
            color,
        },
    ]);
    mesh.indices
        .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
}

/// An empty mesh on `texture` with room for `n` sprites.
pub fn sprite_mesh(texture: TextureId, n: usize) -> Mesh {
    let mut m = Mesh::with_texture(texture);
    m.vertices.reserve(4 * n);
    m.indices.reserve(6 * n);
    m
}

/// True when a sprite at `c` with half-size `half` can show inside `clip`.
#[inline]
pub fn visible(clip: &Rect, c: Pos2, half: f32) -> bool {
    c.x + half >= clip.min.x
        && c.x - half <= clip.max.x
        && c.y + half >= clip.min.y
        && c.y - half <= clip.max.y
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sprites_are_round_and_opaque_inside() {
        for img in [disc_image(), sphere_image()] {
            assert_eq!(img.size, [SPRITE, SPRITE]);
            let at = |i: usize, j: usize| img.pixels[j * SPRITE + i];
            assert_eq!(at(SPRITE / 2, SPRITE / 2).a(), 255);
            assert_eq!(at(0, 0).a(), 0); // corner: outside the disc
            assert_eq!(at(SPRITE - 1, SPRITE / 2 - 20).a(), 0);
        }
        let s = sphere_image();
        // lit from the upper left: that side is brighter than the lower right
        let at = |i: usize, j: usize| s.pixels[j * SPRITE + i].r();
        assert!(at(20, 20) > at(44, 44));
    }

    #[test]
    fn quads_share_one_mesh() {
        let mut m = sprite_mesh(TextureId::default(), 2);
        push_sprite(&mut m, Pos2::new(10.0, 10.0), 2.0, Color32::RED);
        push_sprite(&mut m, Pos2::new(20.0, 10.0), 2.0, Color32::RED);
        assert_eq!((m.vertices.len(), m.indices.len()), (8, 12));
        assert!(m.is_valid());
        let clip = Rect::from_min_max(Pos2::ZERO, Pos2::new(15.0, 15.0));
        assert!(visible(&clip, Pos2::new(16.0, 5.0), 2.0));
        assert!(!visible(&clip, Pos2::new(18.0, 5.0), 2.0));
    }
}

/// Particles drawn on the CPU into an image, for scenes so large that a quad each would make
/// the GPU (or Mesa's software renderer) the bottleneck: one texture, one quad, whatever the
/// count. Pixels are premultiplied, transparent where there is no particle.
#[derive(Default)]
pub struct Raster {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Row-major pixels.
    pub pixels: Vec<Color32>,
}

/// Visible particles above which 2D particles are drawn by [`Raster`] instead of one quad each.
pub const RASTER_ABOVE: usize = 20_000;

impl Raster {
    /// Clears to transparent at `width` x `height`.
    pub fn clear(&mut self, width: usize, height: usize) {
        self.width = width;
        self.height = height;
        self.pixels.clear();
        self.pixels.resize(width * height, Color32::TRANSPARENT);
    }

    /// Draws an antialiased disc centred at pixel coordinates `(cx, cy)` (pixel centres at
    /// +0.5) with radius `r` pixels, over what is there.
    #[inline]
    pub fn disc(&mut self, cx: f32, cy: f32, r: f32, color: Color32) {
        let r = r.max(0.5);
        let x0 = (cx - r - 0.5).floor().max(0.0) as usize;
        let y0 = (cy - r - 0.5).floor().max(0.0) as usize;
        let x1 = ((cx + r + 0.5).ceil().max(0.0) as usize).min(self.width);
        let y1 = ((cy + r + 0.5).ceil().max(0.0) as usize).min(self.height);
        let [sr, sg, sb, sa] = color.to_array().map(u32::from);
        for y in y0..y1 {
            let dy = y as f32 + 0.5 - cy;
            let row = &mut self.pixels[y * self.width..(y + 1) * self.width];
            for (x, px) in row.iter_mut().enumerate().take(x1).skip(x0) {
                let dx = x as f32 + 0.5 - cx;
                let cover = (r + 0.5 - (dx * dx + dy * dy).sqrt()).clamp(0.0, 1.0);
                if cover <= 0.0 {
                    continue;
                }
                let c = (cover * 256.0) as u32; // 0..=256
                let a = (sa * c) >> 8;
                let keep = 255 - a;
                let [dr, dg, db, da] = px.to_array().map(u32::from);
                *px = Color32::from_rgba_premultiplied(
                    (((sr * c) >> 8) + dr * keep / 255) as u8,
                    (((sg * c) >> 8) + dg * keep / 255) as u8,
                    (((sb * c) >> 8) + db * keep / 255) as u8,
                    (a + da * keep / 255) as u8,
                );
            }
        }
    }

    /// The image, for a texture (moves the pixels out; the next [`Raster::clear`] reallocates).
    pub fn take_image(&mut self) -> ColorImage {
        ColorImage::new([self.width, self.height], std::mem::take(&mut self.pixels))
    }
}

#[cfg(test)]
mod raster_tests {
    use super::*;

    #[test]
    fn discs_cover_their_area_and_clip_at_the_edges() {
        let mut r = Raster::default();
        r.clear(20, 10);
        r.disc(5.0, 5.0, 3.0, Color32::RED);
        let covered = r.pixels.iter().filter(|p| p.a() > 0).count();
        // area pi r^2 ~ 28, plus a soft edge
        assert!((24..=45).contains(&covered), "{covered}");
        assert_eq!(r.pixels[5 * 20 + 5], Color32::RED);
        assert_eq!(r.pixels[0], Color32::TRANSPARENT);
        // off the image, partly or wholly: no panic
        r.disc(-3.0, 5.0, 4.0, Color32::GREEN);
        r.disc(19.5, 9.5, 4.0, Color32::GREEN);
        r.disc(1e9, -1e9, 4.0, Color32::GREEN);
        r.disc(f32::NAN, 5.0, 4.0, Color32::GREEN);
        // a tiny particle still shows
        r.disc(15.5, 2.5, 0.1, Color32::BLUE);
        assert!(r.pixels[2 * 20 + 15].a() > 0);
        let img = r.take_image();
        assert_eq!(img.size, [20, 10]);
    }
}
