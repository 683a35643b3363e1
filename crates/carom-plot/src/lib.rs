//! # carom-plot
//!
//! Benchmark plots for carom, as PNG: the cost of one particle-step against the particle count,
//! one line per configuration, on a logarithmic x axis.
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

pub use compare::{comparison_plot_png, save_comparison_plot, Comparison};

use canvas::{Canvas, Marker, Shape};
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// The font every label is drawn with: DejaVu Sans 2.37 (Bitstream Vera license, see
/// `fonts/LICENSE-DejaVu.txt`), built in so that no system font is needed.
static FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");
/// The family name the built-in font is registered under.
const FAMILY: &str = "sans-serif";

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

/// Renders a scaling plot (log x, see [`YScale::Auto`] for y) as a PNG of
/// [`DEFAULT_WIDTH`] x [`DEFAULT_HEIGHT`] pixels: line and markers per series, axis labels,
/// tick labels, a legend and the title.
///
/// Every series needs at least one point, every coordinate must be finite and every x > 0.
pub fn scaling_plot_png(
    series: &[Series],
    title: &str,
    x_label: &str,
    y_label: &str,
) -> Result<Vec<u8>, PlotError> {
    scaling_plot_png_with(series, title, x_label, y_label, &PlotOptions::default())
}

/// Like [`scaling_plot_png`], with the size and y scale given in `options`.
pub fn scaling_plot_png_with(
    series: &[Series],
    title: &str,
    x_label: &str,
    y_label: &str,
    options: &PlotOptions,
) -> Result<Vec<u8>, PlotError> {
    let (w, h) = (options.width, options.height);
    if !(200..=8000).contains(&w) || !(150..=8000).contains(&h) {
        return Err(PlotError::Size(w, h));
    }
    let log_y = check(series, options.y_scale)?;
    register_font()?;

    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    let x_axis = Axis::log(bounds(series, |p| p.0));
    let (ylo, yhi) = bounds(series, |p| p.1);
    let y_axis = if log_y {
        Axis::log((ylo, yhi))
    } else {
        Axis::linear(ylo, yhi)
    };
    let labels = Labels {
        title,
        x: x_label,
        y: y_label,
    };
    draw(&mut rgb, (w, h), series, &labels, x_axis, y_axis)?;
    encode_png(&rgb, w, h)
}

/// Renders the plot of [`scaling_plot_png`] and writes it to `path` atomically (whole or not
/// at all, see [`carom_output::write_atomic`]).
pub fn save_scaling_plot(
    path: &Path,
    series: &[Series],
    title: &str,
    x_label: &str,
    y_label: &str,
) -> Result<(), PlotError> {
    let bytes = scaling_plot_png(series, title, x_label, y_label)?;
    carom_output::write_atomic(path, |w| w.write_all(&bytes))?;
    Ok(())
}

/// Checks the data and decides the y scale: `true` for logarithmic.
fn check(series: &[Series], y_scale: YScale) -> Result<bool, PlotError> {
    if series.is_empty() {
        return Err(PlotError::NoSeries);
    }
    let mut all_y_positive = true;
    for s in series {
        if s.points.is_empty() {
            return Err(PlotError::EmptySeries(s.label.clone()));
        }
        for (index, &(x, y)) in s.points.iter().enumerate() {
            let bad = |axis, value| PlotError::NonFinite {
                series: s.label.clone(),
                index,
                axis,
                value,
            };
            if !x.is_finite() {
                return Err(bad("x", x));
            }
            if !y.is_finite() {
                return Err(bad("y", y));
            }
            let non_positive = |axis, value| PlotError::NonPositive {
                series: s.label.clone(),
                index,
                axis,
                value,
            };
            if x <= 0.0 {
                return Err(non_positive("x", x));
            }
            if y <= 0.0 {
                if y_scale == YScale::Log {
                    return Err(non_positive("y", y));
                }
                all_y_positive = false;
            }
        }
    }
    Ok(match y_scale {
        YScale::Log => true,
        YScale::Linear => false,
        YScale::Auto => {
            let (lo, hi) = bounds(series, |p| p.1);
            all_y_positive && hi / lo >= 10.0
        }
    })
}

/// Smallest and largest of one coordinate over every point.
fn bounds(series: &[Series], coord: impl Fn(&(f64, f64)) -> f64) -> (f64, f64) {
    series
        .iter()
        .flat_map(|s| s.points.iter().map(&coord))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
}

fn register_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED
        .get_or_init(|| plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_ok());
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

/// One axis: its range, whether it is logarithmic, and the values that get a tick label and a
/// grid line (`major`) or only a faint grid line (`minor`).
#[derive(Clone, Debug)]
struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
    major: Vec<f64>,
    minor: Vec<f64>,
}

impl Axis {
    /// Where `v` sits between the ends, 0 to 1 (in log space on a log axis).
    fn fraction(&self, v: f64) -> f64 {
        let t = |v: f64| if self.log { v.log10() } else { v };
        (t(v) - t(self.lo)) / (t(self.hi) - t(self.lo))
    }

    /// A logarithmic axis over `(lo, hi)` (both > 0), padded a little; labelled ticks at 1, 2
    /// and 5 per decade (every decade when the data span more than four, fewer past twelve).
    fn log((lo, hi): (f64, f64)) -> Self {
        let (l0, l1) = (lo.log10(), hi.log10());
        let pad = ((l1 - l0) * 0.05).max(0.15);
        // (kept inside f64's normal range, so that the ends are finite and non-zero)
        let (la, lb) = ((l0 - pad).max(-307.0), (l1 + pad).min(307.0));
        let (a, b) = (10f64.powf(la), 10f64.powf(lb));
        let decades = lb - la;
        let mantissas: &[u32] = if decades <= 4.5 { &[1, 2, 5] } else { &[1] };
        let every = if decades > 12.0 {
            (decades / 8.0).ceil() as i32
        } else {
            1
        };
        let (mut major, mut minor) = (Vec::new(), Vec::new());
        for e in la.floor() as i32..=lb.ceil() as i32 {
            for m in 1..10u32 {
                let v = m as f64 * 10f64.powi(e);
                if v < a || v > b {
                    continue;
                }
                if e.rem_euclid(every) == 0 && mantissas.contains(&m) {
                    major.push(v);
                } else if every == 1 {
                    minor.push(v);
                }
            }
        }
        Self {
            lo: a,
            hi: b,
            log: true,
            major,
            minor,
        }
    }

    /// A linear axis over `(lo, hi)` with about six "nice" ticks; from zero when every value is
    /// non-negative.
    fn linear(lo: f64, hi: f64) -> Self {
        // (halved first when the span would overflow, so that every step below is finite)
        let shrink = if (hi - lo.min(0.0)).is_finite() {
            1.0
        } else {
            0.25
        };
        let (mut a, mut b) = (lo.min(0.0) * shrink, hi * shrink);
        if b - a <= 0.0 {
            // all values equal (and negative, or all zero)
            let d = if b == 0.0 { 1.0 } else { b.abs() * 0.5 };
            a -= d;
            b += d;
        }
        let step = nice_step((b - a) / 6.0);
        // room beyond the highest point (and the lowest, when it is not zero)
        let top = ((b + 0.04 * (b - a)) / step).ceil() * step;
        let bottom = if a == 0.0 {
            0.0
        } else {
            ((a - 0.04 * (b - a)) / step).floor() * step
        };
        let count = ((top - bottom) / step).round().clamp(1.0, 100.0) as i64;
        let major: Vec<f64> = (0..=count)
            .map(|i| (bottom + i as f64 * step) / shrink)
            .collect();
        let minor = major.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
        Self {
            lo: bottom / shrink,
            hi: top / shrink,
            log: false,
            major,
            minor,
        }
    }
}

impl Ranged for Axis {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let f = self.fraction(*value);
        let f = if f.is_finite() {
            f.clamp(-10.0, 10.0)
        } else {
            0.0
        };
        limit.0 + (f * (limit.1 - limit.0) as f64).round() as i32
    }

    fn key_points<Hint: plotters::coord::ranged1d::KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.major.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

/// 1, 2, 5 or 10 times a power of ten, at least `raw`.
fn nice_step(raw: f64) -> f64 {
    let p = 10f64.powf(raw.log10().floor());
    let f = raw / p;
    let m = if f <= 1.0 {
        1.0
    } else if f <= 2.0 {
        2.0
    } else if f <= 5.0 {
        5.0
    } else {
        10.0
    };
    m * p
}

/// A tick label: SI suffixes from a thousand up (`2k`, `500k`, `4M`), plain decimals with no
/// trailing zeros below, scientific notation for tiny values.
fn format_tick(v: &f64) -> String {
    let v = *v;
    let a = v.abs();
    if a == 0.0 {
        return "0".to_string();
    }
    if !(1e-3..1e15).contains(&a) {
        return format!("{v:.1e}").replace(".0e", "e");
    }
    for (scale, suffix) in [(1e12, "T"), (1e9, "G"), (1e6, "M"), (1e3, "k")] {
        if a >= scale * 0.9999 {
            return format!("{}{suffix}", trim(v / scale));
        }
    }
    trim(v)
}

/// Up to four significant digits, trailing zeros removed.
fn trim(v: f64) -> String {
    let decimals = (3 - v.abs().log10().floor() as i32).clamp(0, 6) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

struct Labels<'a> {
    title: &'a str,
    x: &'a str,
    y: &'a str,
}

/// Line colours: a colour-blind-friendly qualitative palette (Okabe-Ito, without yellow).
const COLOURS: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(230, 159, 0),
    RGBColor(0, 0, 0),
];

/// Marker shapes, cycled per series.
const SHAPES: [Shape; 4] = [
    Shape::Circle,
    Shape::Square,
    Shape::Triangle,
    Shape::Diamond,
];

/// The legend corner that hides the fewest data: each corner's box (as fractions of the plot
/// area, y up) is scored by the points and line samples that fall inside it.
fn legend_corner(series: &[Series], x: &Axis, y: &Axis) -> SeriesLabelPosition {
    let longest = series
        .iter()
        .map(|s| s.label.chars().count())
        .max()
        .unwrap_or(0) as f64;
    let box_w = (0.08 + 0.011 * longest).min(0.9);
    let box_h = (0.075 * series.len() as f64 + 0.04).min(0.9);
    let mut samples = Vec::new();
    for s in series {
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .map(|&(px, py)| (x.fraction(px), y.fraction(py)))
            .collect();
        samples.extend(pts.iter().copied());
        for w in pts.windows(2) {
            for k in 1..24 {
                let t = k as f64 / 24.0;
                samples.push((
                    w[0].0 + t * (w[1].0 - w[0].0),
                    w[0].1 + t * (w[1].1 - w[0].1),
                ));
            }
        }
    }
    let corners = [
        (SeriesLabelPosition::UpperLeft, 0.0, 1.0 - box_h),
        (SeriesLabelPosition::UpperRight, 1.0 - box_w, 1.0 - box_h),
        (SeriesLabelPosition::LowerRight, 1.0 - box_w, 0.0),
        (SeriesLabelPosition::LowerLeft, 0.0, 0.0),
    ];
    let margin = 0.03;
    let mut best = (usize::MAX, SeriesLabelPosition::UpperLeft);
    for (pos, x0, y0) in corners {
        let hidden = samples
            .iter()
            .filter(|&&(sx, sy)| {
                (x0 - margin..=x0 + box_w + margin).contains(&sx)
                    && (y0 - margin..=y0 + box_h + margin).contains(&sy)
            })
            .count();
        if hidden < best.0 {
            best = (hidden, pos);
        }
    }
    best.1
}

fn draw(
    rgb: &mut [u8],
    (w, h): (u32, u32),
    series: &[Series],
    labels: &Labels<'_>,
    x_axis: Axis,
    y_axis: Axis,
) -> Result<(), PlotError> {
    let err = |e: &dyn std::fmt::Display| PlotError::Draw(e.to_string());
    let font = canvas::font().ok_or(PlotError::Font)?;
    let root = Canvas::new(rgb, (w, h), font).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    // Sizes are given for the default image and scaled with it.
    let scale = (w as f64 / DEFAULT_WIDTH as f64).min(h as f64 / DEFAULT_HEIGHT as f64);
    let px = |v: f64| ((v * scale).round() as i32).max(1);
    let text = RGBColor(25, 25, 25);
    let corner = legend_corner(series, &x_axis, &y_axis);

    let mut chart = ChartBuilder::on(&root)
        .caption(labels.title, (FAMILY, px(24.0)).into_font().color(&text))
        .margin(px(14.0))
        .margin_right(px(28.0))
        .x_label_area_size(px(48.0))
        .y_label_area_size(px(78.0))
        .build_cartesian_2d(x_axis, y_axis)
        .map_err(|e| err(&e))?;

    let tick_font = (FAMILY, px(15.0)).into_font().color(&text);
    chart
        .configure_mesh()
        .bold_line_style(RGBColor(200, 200, 200).stroke_width(1))
        .light_line_style(RGBColor(235, 235, 235).stroke_width(1))
        .axis_style(RGBColor(80, 80, 80).stroke_width(1))
        .x_label_formatter(&format_tick)
        .y_label_formatter(&format_tick)
        .x_label_style(tick_font.clone())
        .y_label_style(tick_font)
        .x_desc(labels.x)
        .y_desc(labels.y)
        .axis_desc_style((FAMILY, px(17.0)).into_font().color(&text))
        .draw()
        .map_err(|e| err(&e))?;

    let r = 5.0 * scale;
    let line_width = px(2.0) as u32;
    for (i, s) in series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let shape = SHAPES[i % SHAPES.len()];
        let legend_line = px(30.0);
        chart
            .draw_series(LineSeries::new(
                s.points.iter().copied(),
                colour.stroke_width(line_width),
            ))
            .map_err(|e| err(&e))?
            .label(s.label.as_str())
            .legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(
                        vec![(0, 0), (legend_line, 0)],
                        colour.stroke_width(line_width),
                    )
                    + Marker {
                        at: (legend_line / 2, 0),
                        shape,
                        radius: r,
                        colour,
                    }
            });
        chart
            .draw_series(s.points.iter().map(|&p| Marker {
                at: p,
                shape,
                radius: r,
                colour,
            }))
            .map_err(|e| err(&e))?;
    }

    chart
        .configure_series_labels()
        .position(corner)
        .margin(px(12.0))
        .legend_area_size(px(40.0))
        .label_font((FAMILY, px(15.0)).into_font().color(&text))
        .background_style(WHITE.mix(0.92))
        .border_style(RGBColor(160, 160, 160))
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

fn encode_png(rgb: &[u8], w: u32, h: u32) -> Result<Vec<u8>, PlotError> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    fn example() -> Vec<Series> {
        let ns = [1e3, 1e4, 1e5, 1e6, 4e6];
        vec![
            Series {
                label: "2D grid, area fraction 0.3".into(),
                points: ns
                    .iter()
                    .zip([95.0, 82.0, 88.0, 104.0, 118.0])
                    .map(|(&n, y)| (n, y))
                    .collect(),
            },
            Series {
                label: "3D grid, volume fraction 0.2".into(),
                points: ns
                    .iter()
                    .zip([180.0, 150.0, 160.0, 190.0, 210.0])
                    .map(|(&n, y)| (n, y))
                    .collect(),
            },
            Series {
                label: "2D brute force".into(),
                points: vec![(1e3, 300.0), (1e4, 2900.0), (3e4, 8800.0)],
            },
        ]
    }

    /// Decodes a PNG into (width, height, RGB bytes).
    fn decode(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgb);
        buf.truncate(info.buffer_size());
        (info.width, info.height, buf)
    }

    #[test]
    fn renders_a_png_of_the_right_size_with_text_and_colour() {
        let png = scaling_plot_png(
            &example(),
            "carom: cost per particle-step",
            "particles N",
            "ns per particle-step",
        )
        .unwrap();
        let (w, h, rgb) = decode(&png);
        assert_eq!((w, h), (DEFAULT_WIDTH, DEFAULT_HEIGHT));
        let pixels: Vec<[u8; 3]> = rgb.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let distinct: HashSet<[u8; 3]> = pixels.iter().copied().collect();
        assert!(distinct.len() > 50, "only {} colours", distinct.len());
        let dark = pixels.iter().filter(|p| p.iter().all(|&c| c < 80)).count();
        assert!(dark > 2000, "only {dark} dark (text) pixels");
        let white = pixels.iter().filter(|p| **p == [255, 255, 255]).count();
        assert!(
            white > pixels.len() / 2,
            "background should mostly be white"
        );
    }

    #[test]
    fn text_renders() {
        // The same chart with and without a title: the title must add dark pixels in the top
        // band, which only happens when glyphs are actually drawn.
        let dark_top = |title: &str| {
            let (w, _, rgb) = decode(&scaling_plot_png(&example(), title, "N", "ns").unwrap());
            rgb.chunks_exact(3)
                .take(w as usize * 40)
                .filter(|p| p.iter().all(|&c| c < 100))
                .count()
        };
        assert_eq!(dark_top(""), 0);
        assert!(dark_top("A title with some letters") > 200);
    }

    #[test]
    fn options_set_size_and_scale() {
        for y_scale in [YScale::Linear, YScale::Log] {
            let options = PlotOptions {
                width: 400,
                height: 300,
                y_scale,
            };
            let png = scaling_plot_png_with(&example(), "t", "x", "y", &options).unwrap();
            assert_eq!(decode(&png).0, 400);
        }
        let tiny = PlotOptions {
            width: 10,
            ..PlotOptions::default()
        };
        assert!(matches!(
            scaling_plot_png_with(&example(), "t", "x", "y", &tiny),
            Err(PlotError::Size(10, 560))
        ));
    }

    #[test]
    fn auto_scale_picks_log_only_for_wide_ranges() {
        assert!(check(&example(), YScale::Auto).unwrap());
        let flat = vec![Series {
            label: "flat".into(),
            points: vec![(1e3, 80.0), (1e6, 95.0)],
        }];
        assert!(!check(&flat, YScale::Auto).unwrap());
        // zero y is fine on a linear axis
        let zero = vec![Series {
            label: "z".into(),
            points: vec![(1e3, 0.0), (1e6, 95.0)],
        }];
        assert!(!check(&zero, YScale::Auto).unwrap());
        scaling_plot_png(&zero, "t", "x", "y").unwrap();
        scaling_plot_png(&flat, "t", "x", "y").unwrap();
    }

    #[test]
    fn bad_data_is_an_error_not_a_panic() {
        assert!(matches!(
            scaling_plot_png(&[], "t", "x", "y"),
            Err(PlotError::NoSeries)
        ));
        let empty = [Series {
            label: "e".into(),
            points: vec![],
        }];
        assert!(matches!(
            scaling_plot_png(&empty, "t", "x", "y"),
            Err(PlotError::EmptySeries(l)) if l == "e"
        ));
        for x in [0.0, -5.0] {
            let s = [Series {
                label: "s".into(),
                points: vec![(1e3, 1.0), (x, 2.0)],
            }];
            assert!(matches!(
                scaling_plot_png(&s, "t", "x", "y"),
                Err(PlotError::NonPositive {
                    axis: "x",
                    index: 1,
                    ..
                })
            ));
        }
        let s = [Series {
            label: "s".into(),
            points: vec![(1e3, -1.0)],
        }];
        let log = PlotOptions {
            y_scale: YScale::Log,
            ..PlotOptions::default()
        };
        assert!(matches!(
            scaling_plot_png_with(&s, "t", "x", "y", &log),
            Err(PlotError::NonPositive { axis: "y", .. })
        ));
        let s = [Series {
            label: "s".into(),
            points: vec![(1e3, f64::NAN)],
        }];
        assert!(matches!(
            scaling_plot_png(&s, "t", "x", "y"),
            Err(PlotError::NonFinite { axis: "y", .. })
        ));
    }

    #[test]
    fn extreme_values_do_not_hang_or_panic() {
        let wide = [Series {
            label: "wide".into(),
            points: vec![(1e-320, 1e-310), (f64::MAX, f64::MAX), (1.0, -f64::MAX)],
        }];
        let wide_pos = [Series {
            label: "wide".into(),
            points: vec![(1e-320, 1e-310), (f64::MAX, f64::MAX)],
        }];
        for y_scale in [YScale::Auto, YScale::Linear, YScale::Log] {
            let options = PlotOptions {
                y_scale,
                ..PlotOptions::default()
            };
            let _ = scaling_plot_png_with(&wide, "t", "x", "y", &options);
            scaling_plot_png_with(&wide_pos, "t", "x", "y", &options).unwrap();
        }
    }

    #[test]
    fn single_point_and_equal_values_render() {
        let s = [Series {
            label: "one".into(),
            points: vec![(5e3, 42.0)],
        }];
        scaling_plot_png(&s, "t", "x", "y").unwrap();
        let log = PlotOptions {
            y_scale: YScale::Log,
            ..PlotOptions::default()
        };
        scaling_plot_png_with(&s, "t", "x", "y", &log).unwrap();
    }

    #[test]
    fn tick_labels_read_well() {
        let f = |v: f64| format_tick(&v);
        assert_eq!(f(1000.0), "1k");
        assert_eq!(f(2000.0), "2k");
        assert_eq!(f(500_000.0), "500k");
        assert_eq!(f(4e6), "4M");
        assert_eq!(f(50.0), "50");
        assert_eq!(f(0.5), "0.5");
        assert_eq!(f(2.5), "2.5");
        assert_eq!(f(0.0), "0");
        assert_eq!(f(120.0), "120");
        assert_eq!(f(1e-5), "1e-5");
        assert_eq!(f(2.5e20), "2.5e20");
    }

    #[test]
    fn saves_atomically() {
        let dir = std::env::temp_dir().join(format!("carom-plot-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("plot.png");
        save_scaling_plot(&path, &example(), "t", "x", "y").unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(decode(&bytes).0, DEFAULT_WIDTH);
        assert!(save_scaling_plot(&path, &[], "t", "x", "y").is_err());
        assert_eq!(
            std::fs::read(&path).unwrap(),
            bytes,
            "a failed plot leaves the old file"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Writes the example plot to `$CAROM_PLOT_EXAMPLE` (for looking at it).
    #[test]
    fn example_plot_to_file() {
        if let Ok(path) = std::env::var("CAROM_PLOT_EXAMPLE") {
            save_scaling_plot(
                Path::new(&path),
                &example(),
                "carom: cost per particle-step",
                "particles N",
                "ns per particle-step",
            )
            .unwrap();
        }
    }
}
