//! # carom-plot
//!
//! Plots for carom, as PNG: the cost of one particle-step against the particle count, one line
//! per configuration, on a logarithmic x axis ([`scaling_plot_png`], `carom bench --plot`);
//! measured values over theory's curve ([`comparison_plot_png`], `carom validate --plots`).
//! Axes, ticks, markers and legends are plotters' own.
//!
//! Everything is drawn in memory (plotters' bitmap backend into an RGB buffer, then encoded with
//! the `png` crate), and text is drawn with `ab_glyph` from a font built into this crate (DejaVu
//! Sans, see `fonts/LICENSE-DejaVu.txt`), so plots look the same on every machine, with or
//! without system fonts.
//!
//! ```
//! use carom_plot::{scaling_plot_png, Series};
//!
//! let grid = Series {
//!     label: "grid".into(),
//!     points: vec![(1e3, 80.0), (1e4, 70.0), (1e5, 75.0), (1e6, 90.0)],
//! };
//! let png = scaling_plot_png(&[grid], "Cost per particle-step", "particles N", "ns per particle-step")
//!     .unwrap();
//! assert_eq!(&png[1..4], b"PNG");
//! ```
#![warn(missing_docs)]

mod canvas;
mod compare;
mod scaling;
#[cfg(test)]
mod tests;

pub use canvas::lay_out;
pub use compare::{comparison_plot_png, save_comparison_plot, Comparison};
pub use scaling::{save_scaling_plot, scaling_plot_png, scaling_plot_png_with};

use plotters::prelude::FontStyle;
use std::sync::OnceLock;

/// The font every label is drawn with: DejaVu Sans 2.37 (Bitstream Vera license, see
/// `fonts/LICENSE-DejaVu.txt`), built in so that no system font is needed. The one copy in
/// the workspace: `carom-render` draws its legend text with it too (through [`font`]).
pub static FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");
/// The family name the built-in font is registered under.
pub(crate) const FAMILY: &str = "sans-serif";

/// Default image width in pixels.
pub const DEFAULT_WIDTH: u32 = 900;
/// Default image height in pixels.
pub const DEFAULT_HEIGHT: u32 = 560;

/// One line of a plot: a label for the legend and its `(x, y)` points, drawn in the order given.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// The legend entry.
    pub label: String,
    /// `(x, y)` points, e.g. `(particle count, ns per particle-step)`.
    pub points: Vec<(f64, f64)>,
}

/// The y axis scale.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum YScale {
    /// Logarithmic when every y is positive and the values span at least a factor of 10,
    /// linear (from zero when every y is non-negative) otherwise.
    #[default]
    Auto,
    /// Linear.
    Linear,
    /// Logarithmic (every y must be positive).
    Log,
}

/// Settings of a plot beyond its data and labels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlotOptions {
    /// Image width in pixels (at least 200).
    pub width: u32,
    /// Image height in pixels (at least 150).
    pub height: u32,
    /// The y axis scale (the x axis is always logarithmic).
    pub y_scale: YScale,
}

impl Default for PlotOptions {
    fn default() -> Self {
        Self {
            width: DEFAULT_WIDTH,
            height: DEFAULT_HEIGHT,
            y_scale: YScale::Auto,
        }
    }
}

/// Why a plot could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// No series were given.
    #[error("nothing to plot: no series")]
    NoSeries,
    /// A series has no points.
    #[error("series \"{0}\" has no points")]
    EmptySeries(String),
    /// A coordinate is NaN or infinite.
    #[error("series \"{series}\", point {index}: {axis} = {value} is not finite")]
    NonFinite {
        /// The series' label.
        series: String,
        /// The point's index in the series.
        index: usize,
        /// `"x"` or `"y"`.
        axis: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A coordinate on a logarithmic axis is zero or negative.
    #[error("series \"{series}\", point {index}: {axis} = {value} cannot be shown on a logarithmic axis (must be > 0)")]
    NonPositive {
        /// The series' label.
        series: String,
        /// The point's index in the series.
        index: usize,
        /// `"x"` or `"y"`.
        axis: &'static str,
        /// The offending value.
        value: f64,
    },
    /// The image size is too small or too large.
    #[error("image size {0}x{1} is out of range (200x150 to 8000x8000)")]
    Size(u32, u32),
    /// The built-in font could not be loaded.
    #[error("the built-in font could not be loaded")]
    Font,
    /// Drawing failed.
    #[error("drawing the plot failed: {0}")]
    Draw(String),
    /// PNG encoding failed.
    #[error("encoding the PNG failed: {0}")]
    Encode(#[from] png::EncodingError),
    /// Writing the file failed.
    #[error("writing the plot failed: {0}")]
    Io(#[from] std::io::Error),
}

/// [`FONT`], parsed once; `None` if it does not parse.
pub fn font() -> Option<&'static ab_glyph::FontRef<'static>> {
    static PARSED: OnceLock<Option<ab_glyph::FontRef<'static>>> = OnceLock::new();
    PARSED
        .get_or_init(|| ab_glyph::FontRef::try_from_slice(FONT).ok())
        .as_ref()
}

pub(crate) fn register_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED
        .get_or_init(|| plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_ok());
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

pub(crate) fn encode_png(rgb: &[u8], w: u32, h: u32) -> Result<Vec<u8>, PlotError> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::High);
        let mut writer = enc.write_header()?;
        writer.write_image_data(rgb)?;
        writer.finish()?;
    }
    Ok(out)
}
