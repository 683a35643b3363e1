//! The side panel: status, playback, physics, particles, broad phase, presets, display, and
//! the selected particle's explanation.

use super::canvas::{fmt_vec, NORMAL_ARROW, TANGENT_ARROW};
use super::ViewerApp;
use crate::colour::Colouring;
use crate::control;
use crate::sim::Command;
use crate::teach;
use carom_engine::BroadPhaseKind;
use eframe::egui::{self, Color32};

impl ViewerApp {
    pub(super) fn side_panel(&mut self, ui: &mut egui::Ui) {
        self.status(ui);
        ui.separator();
        self.playback(ui);
        ui.separator();
        self.physics(ui);
        ui.separator();
        self.particles(ui);
        ui.separator();
        self.broad_phase(ui);
        ui.separator();
        self.presets(ui);
        ui.separator();
        self.display(ui);
        ui.separator();
        self.selection_panel(ui);
    }

    fn status(&self, ui: &mut egui::Ui) {
        let s = &self.snap;
        ui.heading("carom view");
        ui.label(format!(
            "{:.0} fps, {:.3} ms per step",
            self.fps.fps(),
            s.ms_per_step
        ));
        ui.label(format!(
            "{}: {} particles ({}D)",
            s.name,
            s.radii.len(),
            s.dims
        ));
        ui.label(format!("step {}  t = {:.3}", s.steps, s.time));
        ui.label(format!("broad phase: {}", s.broad_phase));
        if self.busy {
            ui.colored_label(Color32::YELLOW, "building the scene...");
        }
        for e in self.error.iter().chain(self.local_error.iter()) {
            ui.colored_label(Color32::from_rgb(255, 110, 110), format!("refused: {e}"));
        }
    }

    fn playback(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            let label = if self.playing { "Pause" } else { "Play" };
            if ui.button(label).clicked() {
                self.playing = !self.playing;
                self.sim.send(Command::Play(self.playing));
            }
            if ui
                .add_enabled(!self.playing, egui::Button::new("Step"))
                .clicked()
            {
                self.sim.send(Command::Step);
            }
            if ui.button("Reset").clicked() {
                self.sim.send(Command::Reset);
            }
        });
        if ui
            .add(
                egui::Slider::new(&mut self.steps_per_frame, 1..=200)
                    .logarithmic(true)
                    .text("steps / frame"),
            )
            .changed()
        {
            self.sim.send(Command::StepsPerFrame(self.steps_per_frame));
        }
    }

    fn physics(&mut self, ui: &mut egui::Ui) {
        ui.label("Physics");
        let mut changed = false;
        changed |= ui
            .add(egui::Slider::new(&mut self.params.restitution, 0.0..=1.0).text("restitution k"))
            .changed();
        for (a, name) in ["gravity x", "gravity y", "gravity z"]
            .iter()
            .enumerate()
            .take(self.snap.dims.max(2))
        {
            changed |= ui
                .add(egui::Slider::new(&mut self.params.gravity[a], -50.0..=50.0).text(*name))
                .changed();
        }
        changed |= ui
            .add(
                egui::Slider::new(&mut self.params.dt, 1e-5..=0.05)
                    .logarithmic(true)
                    .text("dt"),
            )
            .changed();
        if changed {
            self.sim.send(Command::Params(self.params));
        }
    }

    fn particles(&mut self, ui: &mut egui::Ui) {
        ui.label("Particles (rebuilds the scene)");
        ui.add(
            egui::DragValue::new(&mut self.count)
                .range(1..=control::MAX_PARTICLES)
                .speed(10)
                .prefix("count "),
        );
        ui.add(
            egui::DragValue::new(&mut self.radius)
                .range(0.01..=100.0)
                .speed(0.01)
                .prefix("radius "),
        );
        if ui.button("Rebuild with this count and radius").clicked() {
            match control::refill(&self.scene_text, self.count, self.radius) {
                Ok(text) => {
                    self.local_error = None;
                    self.sim
                        .send(Command::Load(text, self.scene_origin.clone()));
                }
                Err(e) => self.local_error = Some(e),
            }
        }
    }

    fn broad_phase(&mut self, ui: &mut egui::Ui) {
        let dims = self.snap.dims.max(2);
        ui.label("Broad phase");
        let mut changed = false;
        ui.horizontal(|ui| {
            for (kind, name) in [
                (BroadPhaseKind::Brute, "brute"),
                (BroadPhaseKind::Grid, "grid"),
                (BroadPhaseKind::Hash, "hash"),
            ] {
                changed |= ui.selectable_value(&mut self.bp.kind, kind, name).changed();
            }
        });
        if self.bp.kind == BroadPhaseKind::Grid {
            changed |= self.grid_cells(ui, dims);
        }
        if !changed {
            return;
        }
        let ok = match &self.bp.cells {
            Some(c) => control::check_cells(dims, c),
            None => Ok(()),
        };
        match ok {
            Ok(()) => {
                self.local_error = None;
                self.sim.send(Command::BroadPhase(self.bp.clone()));
            }
            Err(e) => self.local_error = Some(e),
        }
    }

    /// The grid's cells: automatic, or per axis by hand. True when the choice changed.
    fn grid_cells(&mut self, ui: &mut egui::Ui, dims: usize) -> bool {
        let mut changed = false;
        let mut auto = self.bp.cells.is_none();
        if ui
            .checkbox(&mut auto, "cells from the largest radius")
            .changed()
        {
            self.bp.cells = if auto {
                None
            } else {
                Some(self.cells[..dims].to_vec())
            };
            changed = true;
        }
        ui.horizontal(|ui| {
            for a in 0..dims {
                let r = ui.add_enabled(
                    !auto,
                    egui::DragValue::new(&mut self.cells[a])
                        .range(1..=4096)
                        .prefix(["x ", "y ", "z "][a]),
                );
                if r.changed() {
                    self.bp.cells = Some(self.cells[..dims].to_vec());
                    changed = true;
                }
            }
        });
        changed
    }

    fn presets(&mut self, ui: &mut egui::Ui) {
        egui::ComboBox::from_label("preset")
            .selected_text(
                self.scene_origin
                    .strip_prefix("preset:")
                    .unwrap_or("scene file"),
            )
            .show_ui(ui, |ui| {
                for (name, text) in carom_scene::PRESETS {
                    if ui
                        .selectable_label(self.scene_origin == format!("preset:{name}"), *name)
                        .clicked()
                    {
                        self.scene_text = text.to_string();
                        self.scene_origin = format!("preset:{name}");
                        self.refit = true;
                        self.local_error = None;
                        self.sim.send(Command::Load(
                            self.scene_text.clone(),
                            self.scene_origin.clone(),
                        ));
                    }
                }
            });
    }

    fn display(&mut self, ui: &mut egui::Ui) {
        ui.label("Display");
        ui.horizontal(|ui| {
            ui.label("colour by");
            for m in Colouring::ALL {
                ui.selectable_value(&mut self.colour_by, m, m.label());
            }
        });
        ui.checkbox(&mut self.show_grid, "hash grid lines");
        ui.checkbox(&mut self.show_overlays, "selection overlays");
        if ui.button("Fit view").clicked() {
            self.refit = true;
        }
    }

    fn selection_panel(&mut self, ui: &mut egui::Ui) {
        let s = self.snap.clone();
        let Some(id) = self.selected.filter(|&i| i < s.radii.len()) else {
            ui.label("Click a particle: it turns red, the hash grid's neighbour cells and the candidates found there green, its contacts orange.");
            return;
        };
        let layout = self.layout(&s);
        let Some(n) =
            teach::neighbourhood(&layout, s.dims, &s.positions, &s.radii, &s.contacts, id)
        else {
            return;
        };
        ui.label(format!("particle {id}: cell {:?}", &n.cell[..s.dims]));
        ui.label(format!(
            "searches cells {:?}..={:?}: {} candidates, {} contacts",
            &n.lo[..s.dims],
            &n.hi[..s.dims],
            n.candidates.len(),
            n.contacts.len()
        ));
        let v = s.velocities[id];
        ui.label(format!("|v| = {:.3}, r = {}", v.length(), s.radii[id]));
        if n.contacts.is_empty() {
            self.chosen_contact = None;
        } else {
            if self.chosen_contact.is_none_or(|c| !n.contacts.contains(&c)) {
                self.chosen_contact = Some(n.contacts[0]);
            }
            ui.label("contact to explain:");
            ui.horizontal_wrapped(|ui| {
                for &c in n.contacts.iter().take(24) {
                    ui.selectable_value(&mut self.chosen_contact, Some(c), c.to_string());
                }
            });
            if let Some(c) = self.chosen_contact {
                let sp = teach::contact_split(s.positions[id], v, s.positions[c], s.velocities[c]);
                ui.label(format!("normal N = {}", fmt_vec(sp.normal, s.dims)));
                ui.colored_label(
                    NORMAL_ARROW,
                    format!("v_N (red one) = {}", fmt_vec(sp.a.normal, s.dims)),
                );
                ui.colored_label(
                    TANGENT_ARROW,
                    format!("v_T (red one) = {}", fmt_vec(sp.a.tangent, s.dims)),
                );
                ui.label(if sp.approaching {
                    "approaching: p_rel . v_rel < 0, the engine responds"
                } else {
                    "separating: the trap rule skips the response"
                });
            }
        }
        if ui.button("Clear selection").clicked() {
            self.selected = None;
        }
    }
}
