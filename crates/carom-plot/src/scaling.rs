//! The scaling plot: one line per series on a logarithmic x axis, linear or logarithmic y.

use crate::canvas::Canvas;
use crate::{
    encode_png, font, register_font, PlotError, PlotOptions, Series, YScale, DEFAULT_HEIGHT,
    DEFAULT_WIDTH, FAMILY,
};
use plotters::coord::combinators::{BindKeyPoints, LogCoord, WithKeyPoints};
use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::coord::CoordTranslate;
use plotters::element::{Drawable, PointCollection};
use plotters::prelude::*;
use plotters_backend::{BackendCoord, DrawingErrorKind};
use std::path::Path;

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
    let labels = Labels {
        title,
        x: x_label,
        y: y_label,
    };
    let x = log_axis(bounds(series, |p| p.0));
    let y = bounds(series, |p| p.1);
    if log_y {
        draw(&mut rgb, (w, h), series, &labels, x, log_axis(y))?;
    } else {
        draw(&mut rgb, (w, h), series, &labels, x, linear_range(y))?;
    }
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
pub(crate) fn check(series: &[Series], y_scale: YScale) -> Result<bool, PlotError> {
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

/// A logarithmic axis around `(lo, hi)` (both > 0), padded a little: plotters' log scale,
/// labelled at 1, 2 and 5 per decade (every decade past four and a half of them, fewer past
/// twelve) with faint lines at the other mantissas. plotters' own log ticks label every
/// mantissa of a narrow range and repeat a decade's end ("10k10k").
fn log_axis((lo, hi): (f64, f64)) -> WithKeyPoints<LogCoord<f64>> {
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
    (a..b)
        .log_scale()
        .with_key_points(major)
        .with_light_points(minor)
}

/// A linear axis' range around `(lo, hi)`: from zero when every value is non-negative, with
/// room beyond the highest point (and the lowest, when it is not zero); never empty, and
/// within half of f64's range so that its span is finite.
fn linear_range((lo, hi): (f64, f64)) -> std::ops::Range<f64> {
    let limit = f64::MAX / 4.0;
    let (mut a, mut b) = (lo.min(0.0).max(-limit), hi.min(limit));
    if b - a <= 0.0 {
        // all values equal (and negative, or all zero)
        let d = if b == 0.0 { 1.0 } else { b.abs() * 0.5 };
        a -= d;
        b += d;
    }
    let room = 0.04 * (b - a);
    let bottom = if a == 0.0 { 0.0 } else { a - room };
    bottom..b + room
}

/// A tick label: SI suffixes from a thousand up (`2k`, `500k`, `4M`), plain decimals with no
/// trailing zeros below, scientific notation for tiny values.
pub(crate) fn format_tick(v: &f64) -> String {
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

/// Marker shapes, cycled per series so that lines differ without colour too.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    Circle,
    Square,
    Triangle,
    Diamond,
}

const SHAPES: [Shape; 4] = [
    Shape::Circle,
    Shape::Square,
    Shape::Triangle,
    Shape::Diamond,
];

/// A data marker: a filled plotters element ([`Circle`], a square [`Rectangle`],
/// [`TriangleMarker`], a diamond [`Polygon`]) of radius `r` pixels in a thin white halo,
/// centred on `at`.
struct Marker<C> {
    at: C,
    shape: Shape,
    r: i32,
    colour: RGBColor,
}

impl<'b, C> PointCollection<'b, C> for &'b Marker<C> {
    type Point = &'b C;
    type IntoIter = std::iter::Once<&'b C>;
    fn point_iter(self) -> Self::IntoIter {
        std::iter::once(&self.at)
    }
}

impl<C, DB: DrawingBackend> Drawable<DB> for Marker<C> {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut points: I,
        backend: &mut DB,
        size: (u32, u32),
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        let Some((x, y)) = points.next() else {
            return Ok(());
        };
        for (r, style) in [(self.r + 1, WHITE.filled()), (self.r, self.colour.filled())] {
            let at = std::iter::once((x, y));
            match self.shape {
                Shape::Circle => Circle::new((), r, style).draw(at, backend, size)?,
                Shape::Square => {
                    let s = (r as f64 * 0.88).round() as i32;
                    let corners = [(x - s, y - s), (x + s, y + s)];
                    Rectangle::new([(); 2], style).draw(corners.into_iter(), backend, size)?
                }
                Shape::Triangle => {
                    TriangleMarker::new((), r + 2, style).draw(at, backend, size)?;
                }
                Shape::Diamond => {
                    let d = (r as f64 * 1.3).round() as i32;
                    let corners = [(x, y - d), (x + d, y), (x, y + d), (x - d, y)];
                    Polygon::new(vec![(); 4], style).draw(corners.into_iter(), backend, size)?
                }
            }
        }
        Ok(())
    }
}

/// Where `v` sits along `axis`, 0 to 1 (in log space on a log axis).
fn fraction<R: Ranged<ValueType = f64>>(axis: &R, v: f64) -> f64 {
    const FINE: i32 = 1 << 20;
    axis.map(&v, (0, FINE)) as f64 / FINE as f64
}

/// The legend corner that hides the fewest data: each corner's box (as fractions of the plot
/// area, y up) is scored by the points and line samples that fall inside it.
fn legend_corner<X, Y>(series: &[Series], x: &X, y: &Y) -> SeriesLabelPosition
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
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
            .map(|&(px, py)| (fraction(x, px), fraction(y, py)))
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

fn draw<X, Y>(
    rgb: &mut [u8],
    (w, h): (u32, u32),
    series: &[Series],
    labels: &Labels<'_>,
    x_axis: X,
    y_axis: Y,
) -> Result<(), PlotError>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let err = |e: &dyn std::fmt::Display| PlotError::Draw(e.to_string());
    let font = font().ok_or(PlotError::Font)?;
    let root = Canvas::new(rgb, (w, h), font).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    // Sizes are given for the default image and scaled with it.
    let scale = (w as f64 / DEFAULT_WIDTH as f64).min(h as f64 / DEFAULT_HEIGHT as f64);
    let px = |v: f64| ((v * scale).round() as i32).max(1);
    let text = RGBColor(25, 25, 25);

    let mut chart = ChartBuilder::on(&root)
        .caption(labels.title, (FAMILY, px(24.0)).into_font().color(&text))
        .margin(px(14.0))
        .margin_right(px(28.0))
        .x_label_area_size(px(48.0))
        .y_label_area_size(px(78.0))
        .build_cartesian_2d(x_axis, y_axis)
        .map_err(|e| err(&e))?;
    let coord = chart.as_coord_spec();
    let corner = legend_corner(series, coord.x_spec(), coord.y_spec());

    let tick_font = (FAMILY, px(15.0)).into_font().color(&text);
    chart
        .configure_mesh()
        .bold_line_style(RGBColor(200, 200, 200).stroke_width(1))
        .light_line_style(RGBColor(235, 235, 235).stroke_width(1))
        .y_max_light_lines(1)
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

    lines(&mut chart, series, &px)?;

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

/// Every series: its line, a marker at each point, and its legend entry.
fn lines<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    series: &[Series],
    px: &dyn Fn(f64) -> i32,
) -> Result<(), PlotError>
where
    DB: DrawingBackend + 'a,
    CT: CoordTranslate<From = (f64, f64)>,
{
    let err = |e: &dyn std::fmt::Display| PlotError::Draw(e.to_string());
    let r = px(5.0);
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
                        r,
                        colour,
                    }
            });
        chart
            .draw_series(s.points.iter().map(|&at| Marker {
                at,
                shape,
                r,
                colour,
            }))
            .map_err(|e| err(&e))?;
    }
    Ok(())
}
