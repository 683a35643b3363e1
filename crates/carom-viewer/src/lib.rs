//! # carom-viewer
//!
//! `carom view`: an interactive window that shows a carom scene while it runs and teaches the
//! lecture "Collision Detection and Response" with it: the hash grid, one particle's neighbour
//! cells and candidates, its contacts, and a contact's normal/tangent velocity split.
//!
//! The logic is in plain modules that are tested without a window: [`control`] (panel ->
//! engine parameters and scene rebuilds), [`view`] (2D view, 3D orbit camera, picking),
//! [`teach`] (grid, neighbour cells, candidates, contact split), [`colour`] (the live colour
//! range; the map and background are `carom-render`'s, shared with `carom render`) and
//! [`render`] (sprites). [`sim`] steps the world in a background thread; `app` is the egui
//! window, one module per part: side panel, 2D canvas, 3D canvas, plots (egui_plot).
#![warn(missing_docs)]

mod app;
pub mod colour;
pub mod control;
pub mod render;
pub mod sim;
pub mod teach;
pub mod view;

/// What to show and how.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// Scene TOML text.
    pub scene_text: String,
    /// Where it came from (`preset:NAME` or a path), for messages and the presets menu.
    pub origin: String,
    /// Start paused.
    pub paused: bool,
    /// Close the window after this many frames.
    pub exit_after_frames: Option<u64>,
    /// Time this many frames (after a short warm-up), print the mean fps, close.
    pub benchmark_frames: Option<u64>,
    /// Particle selected at the start (as if clicked).
    pub select: Option<usize>,
    /// Initial window size in points.
    pub window_size: [f32; 2],
}

/// Opens the window and runs until it is closed.
pub fn run(options: ViewOptions) -> Result<(), String> {
    let native = eframe::NativeOptions {
        viewport: eframe::egui::ViewportBuilder::default()
            .with_title(format!("carom view: {}", options.origin))
            .with_inner_size(options.window_size),
        renderer: eframe::Renderer::Glow,
        // benchmarks measure drawing, not the monitor's refresh
        vsync: options.benchmark_frames.is_none(),
        ..Default::default()
    };
    eframe::run_native(
        "carom view",
        native,
        Box::new(move |cc| Ok(Box::new(app::ViewerApp::new(&cc.egui_ctx, options)))),
    )
    .map_err(|e| format!("cannot open the viewer window: {e}"))
}
