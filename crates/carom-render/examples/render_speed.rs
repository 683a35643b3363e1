//! Times [`carom_render::render`] on 5000 particles at 1024x1024 (2D and 3D), against
//! drawing the same 2D discs as one tiny-skia path each.
//!
//! `cargo run --release -p carom-render --example render_speed`

use carom_render::{render, Bounds, Frame, RenderOptions};
use std::time::Instant;
use tiny_skia::{FillRule, Paint, PathBuilder, Pixmap, Transform};

/// A frame of `n` particles of radius 1 spread over (-100, 100) (a fixed pseudo-random
/// pattern).
fn frame(dimensions: usize, n: usize) -> Frame {
    let mut f = Frame::new(dimensions);
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * 198.0 - 99.0
    };
    for _ in 0..n {
        let z = if dimensions == 3 { next() } else { 0.0 };
        let x = [next(), next(), z];
        let v = [next() / 5.0, next() / 5.0, 0.0];
        f.push(x, v, 1.0);
    }
    f.domain = Some(Bounds {
        min: [-100.0; 3],
        max: [100.0; 3],
    });
    f
}

fn time(what: &str, rounds: u32, mut work: impl FnMut()) {
    work();
    let t = Instant::now();
    for _ in 0..rounds {
        work();
    }
    let ms = t.elapsed().as_secs_f64() * 1e3 / rounds as f64;
    println!("{what:<48} {ms:8.2} ms per frame");
}

fn main() {
    let options = RenderOptions {
        width: 1024,
        height: 1024,
        ..RenderOptions::default()
    };
    let f2 = frame(2, 5000);
    let f3 = frame(3, 5000);
    time("2D, 5000 particles, 1024x1024", 50, || {
        render(&f2, &options).unwrap();
    });
    time("3D, 5000 particles, 1024x1024", 50, || {
        render(&f3, &options).unwrap();
    });
    time("2D + PNG encoding", 10, || {
        let p = render(&f2, &options).unwrap();
        carom_render::write_png(&p, &mut Vec::new()).unwrap();
    });
    time("2D + GIF quantisation", 10, || {
        let p = render(&f2, &options).unwrap();
        carom_render::GifFrame::quantise(&p, 4);
    });
    // The alternative: one tiny-skia path per particle.
    let scale = 1024.0 * 0.94 / 200.0;
    time("comparison: one tiny-skia path per disc (2D)", 10, || {
        let mut p = Pixmap::new(1024, 1024).unwrap();
        let mut paint = Paint {
            anti_alias: true,
            ..Paint::default()
        };
        for x in &f2.positions {
            paint.set_color_rgba8(80, 120, 240, 255);
            let (cx, cy) = (512.0 + x[0] * scale, 512.0 - x[1] * scale);
            if let Some(path) = PathBuilder::from_circle(cx as f32, cy as f32, scale as f32) {
                p.fill_path(
                    &path,
                    &paint,
                    FillRule::Winding,
                    Transform::identity(),
                    None,
                );
            }
        }
    });
}
