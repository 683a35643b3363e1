//! The whole UI, headless: egui without a window, the real simulation thread.

use super::canvas::pos;
use super::ViewerApp;
use crate::colour::Colouring;
use crate::control::{self, BroadPhaseChoice};
use crate::sim::Command;
use crate::ViewOptions;
use carom_engine::BroadPhaseKind;
use eframe::egui::{self, Event, Modifiers, PointerButton, Pos2, RawInput, Rect, Shape, Vec2};
use std::time::Instant;

fn options(text: String, origin: &str) -> ViewOptions {
    ViewOptions {
        scene_text: text,
        origin: origin.into(),
        paused: true,
        exit_after_frames: None,
        benchmark_frames: None,
        select: None,
        window_size: [1280.0, 800.0],
    }
}

fn input(events: Vec<Event>) -> RawInput {
    RawInput {
        screen_rect: Some(Rect::from_min_size(Pos2::ZERO, Vec2::new(1280.0, 800.0))),
        events,
        ..Default::default()
    }
}

/// Runs frames until `done` (or panics after 20 s); returns the last frame's shapes.
fn frames_until(
    ctx: &egui::Context,
    app: &mut ViewerApp,
    done: impl Fn(&ViewerApp) -> bool,
) -> Vec<egui::epaint::ClippedShape> {
    let t = Instant::now();
    loop {
        let out = ctx.run(input(vec![]), |ctx| app.frame(ctx));
        if done(app) {
            return out.shapes;
        }
        assert!(t.elapsed().as_secs() < 20, "timed out");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

fn meshes(shapes: &[egui::epaint::ClippedShape], texture: egui::TextureId) -> Vec<usize> {
    shapes
        .iter()
        .filter_map(|c| match &c.shape {
            Shape::Mesh(m) if m.texture_id == texture => Some(m.vertices.len()),
            _ => None,
        })
        .collect()
}

#[test]
fn draws_one_mesh_and_picks_with_a_click() {
    let ctx = egui::Context::default();
    let text = carom_scene::preset("lecture_100_k05").unwrap().to_string();
    let mut app = ViewerApp::new(&ctx, options(text, "preset:lecture_100_k05"));
    frames_until(&ctx, &mut app, |a| a.snap.radii.len() == 100);
    // a few more frames: panels settle, the view fits the canvas
    let shapes = (0..5).fold(Vec::new(), |_, _| {
        ctx.run(input(vec![]), |c| app.frame(c)).shapes
    });
    assert_eq!(
        meshes(&shapes, app.disc.id()),
        vec![400],
        "one mesh, a quad per particle"
    );

    // click particle 17's centre
    let view = app.view2.expect("a 2D view");
    let at = pos(view.to_screen(app.snap.positions[17].truncate()));
    let press = |pressed| Event::PointerButton {
        pos: at,
        button: PointerButton::Primary,
        pressed,
        modifiers: Modifiers::NONE,
    };
    let _ = ctx.run(input(vec![Event::PointerMoved(at)]), |c| app.frame(c));
    let _ = ctx.run(input(vec![press(true)]), |c| app.frame(c));
    let _ = ctx.run(input(vec![press(false)]), |c| app.frame(c));
    let _ = ctx.run(input(vec![]), |c| app.frame(c));
    assert_eq!(app.selected, Some(17));
    assert_eq!(
        app.marks.get(17),
        Some(&3),
        "the picked particle is marked red"
    );
    assert_eq!(app.marks.len(), 100, "every particle has a mark slot");

    // play, step, change everything: frames keep coming, nothing panics
    app.sim.send(Command::Play(true));
    app.sim.send(Command::StepsPerFrame(3));
    frames_until(&ctx, &mut app, |a| a.snap.steps > 10);
    for mode in Colouring::ALL {
        app.colour_by = mode;
        let _ = ctx.run(input(vec![]), |c| app.frame(c));
    }
    app.sim.send(Command::BroadPhase(BroadPhaseChoice {
        kind: BroadPhaseKind::Hash,
        cells: None,
    }));
    frames_until(&ctx, &mut app, |a| a.snap.broad_phase == "hash");
}

#[test]
fn three_d_scenes_draw_sorted_spheres() {
    let ctx = egui::Context::default();
    let text = carom_scene::preset("box_3d").unwrap().to_string();
    let mut app = ViewerApp::new(&ctx, options(text, "preset:box_3d"));
    app.selected = Some(0);
    frames_until(&ctx, &mut app, |a| a.snap.dims == 3);
    let shapes = ctx.run(input(vec![]), |c| app.frame(c)).shapes;
    // unmarked spheres in one mesh, the selection's on top in another
    let m = meshes(&shapes, app.sphere.id());
    assert_eq!(m.len(), 2);
    assert_eq!(m.iter().sum::<usize>(), 4 * 2000);
    assert!(app.camera.is_some());
}

#[test]
fn very_many_particles_are_one_image() {
    let ctx = egui::Context::default();
    let base = carom_scene::preset("lecture_5000_grid100").unwrap();
    let text = control::refill(base, 30_000, 0.2).unwrap();
    let mut app = ViewerApp::new(&ctx, options(text, "preset:lecture_5000_grid100"));
    frames_until(&ctx, &mut app, |a| a.snap.radii.len() == 30_000);
    let shapes = ctx.run(input(vec![]), |c| app.frame(c)).shapes;
    assert!(meshes(&shapes, app.disc.id()).is_empty());
    let raster = app.raster_texture.as_ref().expect("drawn as an image").id();
    assert_eq!(meshes(&shapes, raster), vec![4]);
}
