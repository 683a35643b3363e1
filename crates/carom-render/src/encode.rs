//! Writing pixmaps: PNG stills and animated GIFs.

use std::io::{self, Write};
use tiny_skia::Pixmap;

fn other(e: impl std::fmt::Display) -> io::Error {
    io::Error::other(e.to_string())
}

/// Writes `pixmap` (opaque, as [`crate::render`] makes them) as an 8-bit RGB PNG.
pub fn write_png(pixmap: &Pixmap, out: &mut dyn Write) -> io::Result<()> {
    let rgb: Vec<u8> = pixmap
        .data()
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    let mut encoder = png::Encoder::new(out, pixmap.width(), pixmap.height());
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Balanced);
    let mut writer = encoder.write_header().map_err(other)?;
    writer.write_image_data(&rgb).map_err(other)?;
    writer.finish().map_err(other)
}

/// One GIF frame: a pixmap quantised to a 256-colour palette of its own. Quantising is the
/// slow part of writing a GIF, so it is separate from [`GifWriter::write`] and can run in
/// parallel.
pub struct GifFrame(gif::Frame<'static>);

impl GifFrame {
    /// Quantises `pixmap` (NeuQuant); the frame shows for `delay_cs` hundredths of a second.
    pub fn quantise(pixmap: &Pixmap, delay_cs: u16) -> Self {
        let mut rgba = pixmap.data().to_vec();
        let (w, h) = (pixmap.width() as u16, pixmap.height() as u16);
        let mut frame = gif::Frame::from_rgba_speed(w, h, &mut rgba, 10);
        frame.delay = delay_cs;
        GifFrame(frame)
    }
}

/// An animated GIF being written, looping forever.
pub struct GifWriter<W: Write> {
    encoder: gif::Encoder<W>,
}

impl<W: Write> GifWriter<W> {
    /// Starts a GIF of `width` x `height` pixels (each at most 65535).
    pub fn new(out: W, width: u32, height: u32) -> io::Result<Self> {
        let (w, h) = (
            u16::try_from(width).map_err(other)?,
            u16::try_from(height).map_err(other)?,
        );
        let mut encoder = gif::Encoder::new(out, w, h, &[]).map_err(other)?;
        encoder.set_repeat(gif::Repeat::Infinite).map_err(other)?;
        Ok(Self { encoder })
    }

    /// Appends a frame.
    pub fn write(&mut self, frame: &GifFrame) -> io::Result<()> {
        self.encoder.write_frame(&frame.0).map_err(other)
    }

    /// Writes the trailer and hands the output back.
    pub fn finish(self) -> io::Result<W> {
        self.encoder.into_inner()
    }
}
