//! # carom-render
//!
//! Headless rendering of carom frames: a [`Frame`] (a plain snapshot of a world, 2D or 3D) is
//! drawn into an RGBA8 [`Pixmap`] by [`render`], which can then be written as PNG
//! ([`write_png`]) or collected into an animated GIF ([`GifFrame`], [`GifWriter`]).
//!
//! - **2D**: the view fits the domain (or, without one, the particles' bounding box) with a
//!   margin, y up. Particles are anti-aliased discs with a thin darker rim so that touching
//!   ones stay apart; planes are lines clipped to the view; the domain box is outlined.
//! - **3D**: a perspective orbit camera ([`Camera`]: yaw, pitch, field of view) looks at the
//!   centre of the box, fitted so that the whole box fills the view. Spheres are drawn back to
//!   front (depth sorted), shaded with a Lambert term and a small highlight; the box is a
//!   wireframe; planes are their outline inside the box.
//!
//! Particles are coloured by speed, radius or id ([`Colouring`]) through a slice of the turbo
//! colormap ([`colormap`]) on a near-black [`BACKGROUND`], the same map and background the
//! viewer uses, with a legend bar labelled with the scale's ends and the frame's time and
//! step. Text uses the DejaVu Sans font that `carom-plot` owns ([`carom_plot::FONT`]).
//!
//! Discs are rasterised directly (coverage from the distance to the centre), not as one
//! vector path per particle: 5000 particles at 1024x1024 take a few milliseconds. Lines and
//! outlines use tiny-skia.
//!
//! ```
//! use carom_render::{render, Frame, RenderOptions};
//!
//! let mut frame = Frame::new(2);
//! frame.push([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], 1.0);
//! frame.domain = Some(carom_render::Bounds { min: [-10.0; 3], max: [10.0; 3] });
//! let pixmap = render(&frame, &RenderOptions::default()).unwrap();
//! assert_eq!((pixmap.width(), pixmap.height()), (800, 800));
//! ```
#![warn(missing_docs)]

mod colour;
mod draw;
mod encode;
mod frame;
mod text;
mod view;

pub use colour::{colormap, colormap_rgb8, colour_range, Colouring, BACKGROUND};
pub use encode::{write_png, GifFrame, GifWriter};
pub use frame::{Bounds, Frame, FramePlane};
pub use tiny_skia::Pixmap;
pub use view::Camera;

use std::fmt;

/// The largest width or height [`render`] accepts, in pixels.
pub const MAX_SIZE: u32 = 8192;

/// How to draw a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Image width in pixels, 1..=[`MAX_SIZE`].
    pub width: u32,
    /// Image height in pixels, 1..=[`MAX_SIZE`].
    pub height: u32,
    /// What the particles' colour shows.
    pub colouring: Colouring,
    /// The values at the ends of the colour scale; `None`: [`colour_range`] of this frame.
    /// Animations fix it so that colours mean the same in every frame.
    pub range: Option<(f64, f64)>,
    /// The region to fit in the view; `None`: the frame's domain, else its particles'
    /// bounding box ([`Frame::view_bounds`]). Animations without a domain fix it so that the
    /// view does not jump.
    pub view: Option<Bounds>,
    /// The 3D camera (ignored in 2D).
    pub camera: Camera,
    /// Draw the legend band (colour bar, time and step) at the bottom.
    pub legend: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            width: 800,
            height: 800,
            colouring: Colouring::Speed,
            range: None,
            view: None,
            camera: Camera::default(),
            legend: true,
        }
    }
}

/// Why a frame cannot be rendered.
#[derive(Clone, Debug, PartialEq)]
pub enum RenderError {
    /// Width or height is 0 or above [`MAX_SIZE`].
    Size(u32, u32),
    /// The frame's dimension is not 2 or 3.
    Dimensions(usize),
    /// The frame's arrays have different lengths.
    Lengths,
    /// The pixmap could not be allocated.
    Allocation,
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::Size(w, h) => write!(
                f,
                "image size {w}x{h}: each side must be between 1 and {MAX_SIZE} pixels"
            ),
            RenderError::Dimensions(d) => write!(f, "a frame must be 2D or 3D, got {d}D"),
            RenderError::Lengths => {
                write!(f, "positions, velocities and radii differ in length")
            }
            RenderError::Allocation => write!(f, "cannot allocate the image"),
        }
    }
}

impl std::error::Error for RenderError {}

/// Renders `frame` to a new opaque pixmap of `options.width` x `options.height` pixels.
pub fn render(frame: &Frame, options: &RenderOptions) -> Result<Pixmap, RenderError> {
    let (w, h) = (options.width, options.height);
    if w == 0 || h == 0 || w > MAX_SIZE || h > MAX_SIZE {
        return Err(RenderError::Size(w, h));
    }
    if frame.dimensions != 2 && frame.dimensions != 3 {
        return Err(RenderError::Dimensions(frame.dimensions));
    }
    let n = frame.positions.len();
    if frame.velocities.len() != n || frame.radii.len() != n {
        return Err(RenderError::Lengths);
    }
    let mut pixmap = Pixmap::new(w, h).ok_or(RenderError::Allocation)?;
    draw::frame(&mut pixmap, frame, options);
    Ok(pixmap)
}

#[cfg(test)]
mod tests;
