//! Measured against theory: one quantity on linear axes, the measured points as markers over
//! the theory's curve (the plots of `docs/validation.md`).

use crate::{encode_png, register_font, PlotError, DEFAULT_HEIGHT, DEFAULT_WIDTH, FAMILY};
use plotters::prelude::*;
use std::path::Path;

/// One comparison plot: `measured` as markers, `theory` as a line, on linear axes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Comparison {
    /// The title above the plot.
    pub title: String,
    /// The x axis' label.
    pub x_label: String,
    /// The y axis' label.
    pub y_label: String,
    /// What carom measured, `(x, y)`.
    pub measured: Vec<(f64, f64)>,
    /// The legend entry of `measured`.
    pub measured_label: String,
    /// What theory says, `(x, y)`, drawn as a line in the order given.
    pub theory: Vec<(f64, f64)>,
    /// The legend entry of `theory`.
    pub theory_label: String,
}

impl Comparison {
    /// The range of every point on one axis, widened by 5 % (and to a unit when flat).
    fn range(&self, axis: impl Fn(&(f64, f64)) -> f64) -> std::ops::Range<f64> {
        let values = self.measured.iter().chain(&self.theory).map(axis);
        let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        let pad = if hi > lo { 0.05 * (hi - lo) } else { 0.5 };
        (lo - pad)..(hi + pad)
    }

    /// Checks that there is something to draw and that every coordinate is finite.
    fn check(&self) -> Result<(), PlotError> {
        for (label, points) in [
            (&self.measured_label, &self.measured),
            (&self.theory_label, &self.theory),
        ] {
            if points.is_empty() {
                return Err(PlotError::EmptySeries(label.clone()));
            }
            for (index, &(x, y)) in points.iter().enumerate() {
                for (axis, value) in [("x", x), ("y", y)] {
                    if !value.is_finite() {
                        return Err(PlotError::NonFinite {
                            series: label.clone(),
                            index,
                            axis,
                            value,
                        });
                    }
                }
            }
        }
        Ok(())
    }
}

/// Renders `plot` as a PNG of [`DEFAULT_WIDTH`] x [`DEFAULT_HEIGHT`] pixels.
pub fn comparison_plot_png(plot: &Comparison) -> Result<Vec<u8>, PlotError> {
    plot.check()?;
    register_font()?;
    let (w, h) = (DEFAULT_WIDTH, DEFAULT_HEIGHT);
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    let err = |e: &dyn std::fmt::Display| PlotError::Draw(e.to_string());
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(&plot.title, (FAMILY, 24))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(72)
            .build_cartesian_2d(plot.range(|p| p.0), plot.range(|p| p.1))
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(&plot.x_label)
            .y_desc(&plot.y_label)
            .label_style((FAMILY, 16))
            .axis_desc_style((FAMILY, 18))
            .draw()
            .map_err(|e| err(&e))?;
        let theory = RGBColor(220, 90, 40);
        let measured = RGBColor(30, 90, 180);
        chart
            .draw_series(LineSeries::new(
                plot.theory.iter().copied(),
                theory.stroke_width(3),
            ))
            .map_err(|e| err(&e))?
            .label(&plot.theory_label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 24, y)], theory.stroke_width(3)));
        chart
            .draw_series(
                plot.measured
                    .iter()
                    .map(|&p| Circle::new(p, 4, measured.filled())),
            )
            .map_err(|e| err(&e))?
            .label(&plot.measured_label)
            .legend(move |(x, y)| Circle::new((x + 12, y), 4, measured.filled()));
        chart
            .configure_series_labels()
            .label_font((FAMILY, 16))
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    encode_png(&rgb, w, h)
}

/// Renders `plot` and writes it to `path` atomically (whole or not at all).
pub fn save_comparison_plot(path: &Path, plot: &Comparison) -> Result<(), PlotError> {
    let bytes = comparison_plot_png(plot)?;
    carom_output::write_atomic(path, |w| w.write_all(&bytes))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_points_over_a_curve() {
        let plot = Comparison {
            title: "Haff".into(),
            x_label: "t / t0".into(),
            y_label: "T / T0".into(),
            measured: (0..10)
                .map(|k| (k as f64 * 0.2, 1.0 / (1.0 + k as f64 * 0.2).powi(2)))
                .collect(),
            measured_label: "carom".into(),
            theory: (0..50)
                .map(|k| (k as f64 * 0.04, 1.0 / (1.0 + k as f64 * 0.04).powi(2)))
                .collect(),
            theory_label: "theory".into(),
        };
        let png = comparison_plot_png(&plot).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let empty = Comparison {
            measured: Vec::new(),
            ..plot
        };
        assert!(matches!(
            comparison_plot_png(&empty),
            Err(PlotError::EmptySeries(_))
        ));
    }
}
