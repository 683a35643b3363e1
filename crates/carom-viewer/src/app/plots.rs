//! The plots under the canvas (egui_plot): cost per step, energy and momentum against time.

use super::ViewerApp;
use crate::sim::Snapshot;
use eframe::egui::{self, Color32};
use egui_plot::{AxisHints, Corner, Legend, Line, Plot, PlotPoints};
use std::collections::VecDeque;

/// Samples kept per series: the plots show the last this many snapshots.
const HISTORY: usize = 3000;
/// Plot height in points.
const HEIGHT: f32 = 120.0;

/// Samples for the plots.
#[derive(Default)]
pub(super) struct History {
    time: VecDeque<f64>,
    ms: VecDeque<f64>,
    kinetic: VecDeque<f64>,
    total: VecDeque<f64>,
    momentum: VecDeque<f64>,
}

impl History {
    pub(super) fn push(&mut self, s: &Snapshot) {
        if self.time.len() >= HISTORY {
            for q in [
                &mut self.time,
                &mut self.ms,
                &mut self.kinetic,
                &mut self.total,
                &mut self.momentum,
            ] {
                q.pop_front();
            }
        }
        self.time.push_back(s.time);
        self.ms.push_back(s.ms_per_step);
        self.kinetic.push_back(s.kinetic);
        self.total.push_back(s.total_energy);
        self.momentum.push_back(s.momentum.length());
    }

    /// `values` against simulated time, at most about `points` of them (evenly strided: a
    /// plot a few hundred points wide gains nothing from thousands), non-finite ones left out.
    fn series(&self, values: &VecDeque<f64>, points: usize) -> PlotPoints<'static> {
        let stride = (values.len() / points.max(1)).max(1);
        self.time
            .iter()
            .zip(values)
            .step_by(stride)
            .filter(|(t, v)| t.is_finite() && v.is_finite())
            .map(|(&t, &v)| [t, v])
            .collect()
    }
}

impl ViewerApp {
    pub(super) fn plots(&self, ui: &mut egui::Ui) {
        let h = &self.history;
        let w = (ui.available_width() - 16.0) / 3.0;
        let points = w.max(1.0) as usize;
        let line = |name: &str, values, colour| {
            Line::new(name, h.series(values, points))
                .color(colour)
                .width(1.5)
        };
        ui.horizontal(|ui| {
            plot("ms per step", w).show(ui, |p| {
                p.line(line("ms per step", &h.ms, Color32::from_rgb(255, 200, 60)));
            });
            plot("energy", w)
                .legend(
                    Legend::default()
                        .position(Corner::LeftTop)
                        .text_style(egui::TextStyle::Small)
                        .background_alpha(0.6)
                        .follow_insertion_order(true),
                )
                .show(ui, |p| {
                    let kinetic = Color32::from_rgb(250, 220, 80);
                    p.line(line("kinetic", &h.kinetic, kinetic));
                    let total = Color32::from_rgb(90, 160, 255);
                    p.line(line("kinetic + potential", &h.total, total));
                });
            plot("|momentum|", w).show(ui, |p| {
                p.line(line(
                    "|momentum|",
                    &h.momentum,
                    Color32::from_rgb(120, 230, 140),
                ));
            });
        });
    }
}

/// One small plot against simulated time that follows the data: no zooming or dragging.
fn plot<'a>(title: &str, width: f32) -> Plot<'a> {
    Plot::new(("carom-plot", title.to_string()))
        .width(width)
        .height(HEIGHT)
        // egui_plot labels x ticks 60 points apart; a plot a third of the window wide then
        // showed only "0" of a 0..8 s run
        .custom_x_axes(vec![AxisHints::new_x()
            .label("t")
            .label_spacing(24.0..=40.0)])
        .y_axis_label(title.to_string())
        .allow_zoom(false)
        .allow_drag(false)
        .allow_scroll(false)
        .allow_boxed_zoom(false)
        .auto_bounds(true)
}
