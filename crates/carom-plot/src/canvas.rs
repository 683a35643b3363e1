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
        lay_out(self.font, scale, 0.0, baseline, text, |x, y, coverage| {
            if coverage > 0.0 {
                pixels.push((x, y, coverage));
            }
        });
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

/// Lays `text` out in `font` at `scale` from `x` on `baseline` (pixels, y down): glyphs at
/// their sub-pixel positions with kerning and side bearings; hands each covered pixel and its
/// coverage to `pixel`. Returns the advance (width). `carom-render`'s legend text uses it too.
pub fn lay_out(
    font: &FontRef<'_>,
    scale: PxScale,
    x: f32,
    baseline: f32,
    text: &str,
    mut pixel: impl FnMut(i32, i32, f32),
) -> f32 {
    let scaled = font.as_scaled(scale);
    let mut caret = x;
    let mut previous = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = previous {
            caret += scaled.kern(p, id);
        }
        previous = Some(id);
        let glyph = id.with_scale_and_position(scale, point(caret, baseline));
        caret += scaled.h_advance(id);
        if let Some(outline) = font.outline_glyph(glyph) {
            let b = outline.px_bounds();
            outline.draw(|gx, gy, coverage| {
                pixel(
                    b.min.x as i32 + gx as i32,
                    b.min.y as i32 + gy as i32,
                    coverage,
                )
            });
        }
    }
    caret - x
}
