//! The window: side panel (controls), canvas (particles and the lecture's overlays), plots.

mod canvas;
mod canvas_2d;
mod canvas_3d;
mod panel;
mod plots;
#[cfg(test)]
mod tests;
mod viewer;

pub use viewer::ViewerApp;
