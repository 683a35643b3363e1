//! The drawing surface: plotters' bitmap backend, with text drawn by this module.
//!
//! plotters 0.3.7's `ab_glyph` text drawing drops each glyph's left side bearing (so "10k"
//! reads "1 0k") and sits the baseline half a font size below the anchor. [`Canvas`] passes every
//! shape straight to [`BitMapBackend`] and lays text out itself with `ab_glyph`, from the same
//! built-in font: glyphs at their true sub-pixel positions with kerning, anti-aliased, capitals
//! centred on the anchor when a label is centred, and rotated for the vertical axis label. Text
//! *measurement* stays plotters' own (advance widths, `size / 1.24` high), so its layout and
//! this drawing agree.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use plotters::prelude::BitMapBackend;
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
};
use std::sync::OnceLock;

/// The parsed built-in font, or `None` if it does not parse.
pub(crate) fn font() -> Option<&'static FontRef<'static>> {
    static FONT: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(crate::FONT).ok())
        .as_ref()
}

/// [`BitMapBackend`] with this crate's text drawing.
pub(crate) struct Canvas<'a> {
    inner: BitMapBackend<'a>,
    font: &'static FontRef<'static>,
}

impl<'a> Canvas<'a> {
    /// A canvas over an RGB buffer of `size` pixels.
    pub(crate) fn new(
        rgb: &'a mut [u8],
        size: (u32, u32),
        font: &'static FontRef<'static>,
    ) -> Self {
        Self {
            inner: BitMapBackend::with_buffer(rgb, size),
            font,
        }
    }
}

type Error<'a> = DrawingErrorKind<<BitMapBackend<'a> as DrawingBackend>::ErrorType>;

impl<'a> DrawingBackend for Canvas<'a> {
    type ErrorType = <BitMapBackend<'a> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }
    fn ensure_prepared(&mut self) -> Result<(), Error<'a>> {
        self.inner.ensure_prepared()
    }
    fn present(&mut self) -> Result<(), Error<'a>> {
        self.inner.present()
    }
    fn draw_pixel(&mut self, point: BackendCoord, color: BackendColor) -> Result<(), Error<'a>> {
        self.inner.draw_pixel(point, color)
    }
    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), Error<'a>> {
        self.inner.draw_line(from, to, style)
    }
    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), Error<'a>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }
    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), Error<'a>> {
        self.inner.draw_path(path, style)
    }
    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), Error<'a>> {
        self.inner.draw_circle(center, radius, style, fill)
    }
    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), Error<'a>> {
        self.inner.fill_polygon(vert, style)
    }
    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), Error<'a>> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn draw_text<T: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &T,
        pos: BackendCoord,
    ) -> Result<(), Error<'a>> {
        let color = style.color();
        if color.alpha == 0.0 || text.is_empty() {
            return Ok(());
        }
        // The box plotters laid out for this text (advance widths, `size / 1.24` high).
        let ((x0, y0), (x1, y1)) = style
            .layout_box(text)
            .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let (width, height) = (x1 - x0, y1 - y0);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        // Same scale as plotters' measurement, so widths agree.
        let scale = PxScale::from(style.size() as f32);
        let font = self.font.as_scaled(scale);
        let cap = self
            .font
            .outline_glyph(font.scaled_glyph('H'))
            .map_or(height as f32 * 0.9, |g| g.px_bounds().height());
        // Capitals centred in the box: a centred label is centred on its anchor.
        let baseline = (height as f32 + cap) / 2.0;
        let transform = style.transform();
        let mut pixels = Vec::new();
        let mut caret = 0f32;
        let mut previous = None;
        for c in text.chars() {
            let id = font.glyph_id(c);
            if let Some(p) = previous {
                caret += font.kern(p, id);
            }
            previous = Some(id);
            let glyph = id.with_scale_and_position(scale, point(caret, baseline));
            caret += font.h_advance(id);
            if let Some(outline) = self.font.outline_glyph(glyph) {
                let b = outline.px_bounds();
                outline.draw(|gx, gy, coverage| {
                    if coverage > 0.0 {
                        pixels.push((
                            b.min.x as i32 + gx as i32,
                            b.min.y as i32 + gy as i32,
                            coverage,
                        ));
                    }
                });
            }
        }
        for (x, y, coverage) in pixels {
            let (x, y) = transform.transform(x + dx, y + dy);
            self.inner.draw_pixel(
                (x + pos.0, y + pos.1),
                BackendColor {
                    alpha: color.alpha * coverage.min(1.0) as f64,
                    rgb: color.rgb,
                },
            )?;
        }
        Ok(())
    }
}

/// Marker shapes, cycled per series so that lines differ without colour too.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Shape {
    Circle,
    Square,
    Triangle,
    Diamond,
}

impl Shape {
    /// Signed distance in pixels from `(x, y)` (relative to the centre, y down) to the edge of
    /// this shape of radius `r`: negative inside. Sizes are chosen so that all shapes look
    /// about as heavy as the circle.
    fn distance(self, x: f64, y: f64, r: f64) -> f64 {
        match self {
            Shape::Circle => (x * x + y * y).sqrt() - r,
            Shape::Square => x.abs().max(y.abs()) - 0.88 * r,
            Shape::Diamond => (x.abs() + y.abs() - 1.3 * r) * std::f64::consts::FRAC_1_SQRT_2,
            Shape::Triangle => {
                // equilateral, pointing up, centred on its centroid
                let t = 1.3 * r;
                let (s, c) = (0.5f64, 3f64.sqrt() / 2.0);
                let bottom = y - t * s;
                let right = c * x - s * y - t * s;
                let left = -c * x - s * y - t * s;
                bottom.max(right).max(left)
            }
        }
    }
}

/// A data marker: a filled, anti-aliased shape with a thin white halo, centred on `at`.
pub(crate) struct Marker<C> {
    pub(crate) at: C,
    pub(crate) shape: Shape,
    /// Radius in pixels.
    pub(crate) radius: f64,
    pub(crate) colour: plotters::style::RGBColor,
}

impl<'b, C> plotters::element::PointCollection<'b, C> for &'b Marker<C> {
    type Point = &'b C;
    type IntoIter = std::iter::Once<&'b C>;
    fn point_iter(self) -> Self::IntoIter {
        std::iter::once(&self.at)
    }
}

impl<C, DB: DrawingBackend> plotters::element::Drawable<DB> for Marker<C> {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut points: I,
        backend: &mut DB,
        _: (u32, u32),
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        let Some((cx, cy)) = points.next() else {
            return Ok(());
        };
        const HALO: f64 = 1.3;
        const SUB: usize = 4;
        let reach = (self.radius * 1.4 + HALO + 1.0).ceil() as i32;
        let (r, g, b) = (self.colour.0, self.colour.1, self.colour.2);
        for py in -reach..=reach {
            for px in -reach..=reach {
                // coverage of the shape and of shape plus halo, by 4x4 supersampling
                let (mut inner, mut outer) = (0usize, 0usize);
                for sy in 0..SUB {
                    for sx in 0..SUB {
                        let x = px as f64 + (sx as f64 + 0.5) / SUB as f64 - 0.5;
                        let y = py as f64 + (sy as f64 + 0.5) / SUB as f64 - 0.5;
                        let d = self.shape.distance(x, y, self.radius);
                        inner += usize::from(d <= 0.0);
                        outer += usize::from(d <= HALO);
                    }
                }
                let n = (SUB * SUB) as f64;
                let at = (cx + px, cy + py);
                if outer > inner {
                    let white = BackendColor {
                        alpha: outer as f64 / n,
                        rgb: (255, 255, 255),
                    };
                    backend.draw_pixel(at, white)?;
                }
                if inner > 0 {
                    let fill = BackendColor {
                        alpha: inner as f64 / n,
                        rgb: (r, g, b),
                    };
                    backend.draw_pixel(at, fill)?;
                }
            }
        }
        Ok(())
    }
}
