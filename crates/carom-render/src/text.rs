//! Text with `ab_glyph` and the DejaVu Sans font that `carom-plot` owns ([`carom_plot::FONT`]).

use ab_glyph::{FontRef, PxScale};

/// The parsed font, or `None` if it does not parse (then no text is drawn).
pub(crate) fn font() -> Option<&'static FontRef<'static>> {
    carom_plot::font()
}

/// Height of a capital letter at font size `size`, pixels.
pub(crate) fn cap_height(size: f32) -> f32 {
    0.73 * size
}

/// Lays `text` out from `x` on `baseline` and hands each covered pixel to `pixel`; returns
/// the advance (width) in pixels.
fn layout(size: f32, x: f32, baseline: f32, text: &str, pixel: impl FnMut(i32, i32, f32)) -> f32 {
    let Some(font) = font() else { return 0.0 };
    carom_plot::lay_out(font, PxScale::from(size), x, baseline, text, pixel)
}

/// The width of `text` at font size `size`, pixels.
pub(crate) fn width(size: f32, text: &str) -> f32 {
    layout(size, 0.0, 0.0, text, |_, _, _| {})
}

/// Draws `text` into an opaque RGBA buffer of `w` x `h`, from `x` on `baseline`; returns
/// its width.
#[allow(clippy::too_many_arguments)]
pub(crate) fn draw(
    data: &mut [u8],
    w: usize,
    h: usize,
    size: f32,
    x: f32,
    baseline: f32,
    rgb: [f32; 3],
    text: &str,
) -> f32 {
    layout(size, x, baseline, text, |px, py, coverage| {
        if px >= 0 && py >= 0 && (px as usize) < w && (py as usize) < h {
            crate::draw::blend(data, py as usize * w + px as usize, rgb, coverage.min(1.0));
        }
    })
}
