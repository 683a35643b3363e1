//! Unit tests: known frames, known pixels.

use super::*;

fn pixel(p: &Pixmap, x: u32, y: u32) -> [u8; 3] {
    let c = p.pixel(x, y).unwrap();
    [c.red(), c.green(), c.blue()]
}

fn to_u8(c: [f32; 3]) -> [u8; 3] {
    c.map(|v| (v * 255.0 + 0.5) as u8)
}

fn close(a: [u8; 3], b: [u8; 3]) -> bool {
    a.iter().zip(b).all(|(x, y)| x.abs_diff(y) <= 2)
}

fn no_legend(w: u32, h: u32) -> RenderOptions {
    RenderOptions {
        width: w,
        height: h,
        legend: false,
        ..RenderOptions::default()
    }
}

fn frame_2d() -> Frame {
    let mut f = Frame::new(2);
    f.domain = Some(Bounds {
        min: [-10.0, -10.0, 0.0],
        max: [10.0, 10.0, 0.0],
    });
    f.push([0.0, 0.0, 0.0], [3.0, 4.0, 0.0], 2.0);
    f
}

#[test]
fn one_particle_at_the_centre() {
    let f = frame_2d();
    let p = render(&f, &no_legend(200, 200)).unwrap();
    // Speed 5 on the scale 0..5: the top of the colormap.
    let expected = to_u8(colormap(1.0));
    for (x, y) in [(100, 100), (99, 99), (100, 99), (99, 100), (104, 96)] {
        assert!(
            close(pixel(&p, x, y), expected),
            "({x},{y}): {:?}",
            pixel(&p, x, y)
        );
    }
    for (x, y) in [(0, 0), (199, 0), (0, 199), (199, 199), (100, 2)] {
        assert_eq!(pixel(&p, x, y), BACKGROUND, "({x},{y})");
    }
    // Far from the particle but inside the box: background.
    assert_eq!(pixel(&p, 150, 150), BACKGROUND);
}

#[test]
fn y_points_up_and_x_right() {
    let mut f = frame_2d();
    f.positions[0] = [5.0, 5.0, 0.0];
    let p = render(&f, &no_legend(200, 200)).unwrap();
    // The view fits (-10, 10) in 200 - 2 * 6 pixels: (5, 5) is upper right.
    let s = 188.0 / 20.0;
    let (x, y) = ((100.0 + 5.0 * s) as u32, (100.0 - 5.0 * s) as u32);
    assert!(close(pixel(&p, x, y), to_u8(colormap(1.0))));
    assert_eq!(pixel(&p, 200 - x, 200 - y), BACKGROUND);
}

#[test]
fn colours_follow_the_range() {
    let mut f = frame_2d();
    f.positions[0] = [-5.0, 0.0, 0.0];
    f.push([5.0, 0.0, 0.0], [0.0, 0.0, 0.0], 2.0);
    let p = render(&f, &no_legend(200, 200)).unwrap();
    assert_eq!(
        colour_range(std::slice::from_ref(&f), Colouring::Speed),
        (0.0, 5.0)
    );
    let s = 188.0 / 20.0;
    let fast = pixel(&p, (100.0 - 5.0 * s) as u32, 100);
    let slow = pixel(&p, (100.0 + 5.0 * s) as u32, 100);
    assert!(close(fast, to_u8(colormap(1.0))), "{fast:?}");
    assert!(close(slow, to_u8(colormap(0.0))), "{slow:?}");
}

#[test]
fn planes_are_drawn_and_walls_are_not_doubled() {
    let mut f = frame_2d();
    f.positions.clear();
    f.velocities.clear();
    f.radii.clear();
    f.planes.push(FramePlane {
        point: [0.0, 0.0, 0.0],
        normal: [0.0, 1.0, 0.0],
    });
    let p = render(&f, &no_legend(200, 200)).unwrap();
    // A horizontal line through the middle, across the whole image.
    for x in [1, 50, 100, 198] {
        let c = pixel(&p, x, 100);
        let d = pixel(&p, x, 99);
        assert!(c[0] > 100 || d[0] > 100, "x = {x}: {c:?} {d:?}");
    }
}

#[test]
fn depth_order_near_sphere_covers_far_one() {
    for near_id in [0usize, 1] {
        let mut f = Frame::new(3);
        f.domain = Some(Bounds {
            min: [-10.0; 3],
            max: [10.0; 3],
        });
        // Camera on +z: larger z is nearer.
        let zs = if near_id == 0 {
            [5.0, -5.0]
        } else {
            [-5.0, 5.0]
        };
        for z in zs {
            f.push([0.0, 0.0, z], [0.0; 3], 2.0);
        }
        let options = RenderOptions {
            colouring: Colouring::Id,
            camera: Camera {
                yaw_degrees: 0.0,
                pitch_degrees: 0.0,
                fov_degrees: 35.0,
            },
            ..no_legend(200, 200)
        };
        let p = render(&f, &options).unwrap();
        // Id 0 is at the blue end of the colormap, id 1 at the red end.
        let c = pixel(&p, 100, 100);
        if near_id == 0 {
            assert!(c[2] > c[0], "near sphere is id 0 (blue): {c:?}");
        } else {
            assert!(c[0] > c[2], "near sphere is id 1 (red): {c:?}");
        }
        assert_eq!(pixel(&p, 100, 2), BACKGROUND);
    }
}

#[test]
fn rejects_bad_sizes_and_dimensions() {
    let f = frame_2d();
    for (w, h) in [(0, 10), (10, 0), (MAX_SIZE + 1, 10)] {
        assert_eq!(
            render(&f, &no_legend(w, h)).unwrap_err(),
            RenderError::Size(w, h)
        );
    }
    let mut bad = f.clone();
    bad.dimensions = 4;
    assert!(render(&bad, &no_legend(10, 10)).is_err());
    bad = f;
    bad.radii.push(1.0);
    assert_eq!(
        render(&bad, &no_legend(10, 10)).unwrap_err(),
        RenderError::Lengths
    );
}

#[test]
fn legend_has_text_and_bar() {
    assert!(text::font().is_some(), "the bundled font parses");
    let f = frame_2d();
    let with = render(
        &f,
        &RenderOptions {
            width: 400,
            height: 400,
            ..RenderOptions::default()
        },
    )
    .unwrap();
    let without = render(&f, &no_legend(400, 400)).unwrap();
    let band = |p: &Pixmap| {
        (370..400)
            .flat_map(|y| (0..400).map(move |x| (x, y)))
            .filter(|&(x, y)| pixel(p, x, y) != BACKGROUND)
            .count()
    };
    // Without the legend only the box's bottom edge is there.
    assert!(band(&without) < 1000, "{}", band(&without));
    assert!(
        band(&with) > band(&without) + 500,
        "legend drawn: {}",
        band(&with)
    );
}

#[test]
fn png_and_gif_encode() {
    let f = frame_2d();
    let p = render(&f, &no_legend(64, 48)).unwrap();
    let mut png_bytes = Vec::new();
    write_png(&p, &mut png_bytes).unwrap();
    let decoder = png::Decoder::new(std::io::Cursor::new(&png_bytes));
    let reader = decoder.read_info().unwrap();
    assert_eq!((reader.info().width, reader.info().height), (64, 48));

    let mut gif_bytes = Vec::new();
    let mut g = GifWriter::new(&mut gif_bytes, 64, 48).unwrap();
    for _ in 0..3 {
        g.write(&GifFrame::quantise(&p, 4)).unwrap();
    }
    g.finish().unwrap();
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut d = options.read_info(std::io::Cursor::new(&gif_bytes)).unwrap();
    let mut frames = 0;
    while let Some(frame) = d.read_next_frame().unwrap() {
        assert_eq!(frame.delay, 4);
        frames += 1;
    }
    assert_eq!(frames, 3);
}

#[test]
fn from_world_snapshots_in_id_order() {
    use carom_engine::glam::DVec2;
    use carom_engine::{Aabb, World};
    let world = World::builder()
        .domain(Aabb::new(DVec2::splat(-5.0), DVec2::splat(5.0)).unwrap())
        .walls(1.0)
        .particle(DVec2::new(1.0, 2.0), DVec2::new(3.0, 4.0), 0.5, 1.0)
        .particle(DVec2::new(-1.0, -2.0), DVec2::ZERO, 0.25, 1.0)
        .build()
        .unwrap();
    let f = Frame::from_world(&world);
    assert_eq!(f.dimensions, 2);
    assert_eq!(f.positions, vec![[1.0, 2.0, 0.0], [-1.0, -2.0, 0.0]]);
    assert_eq!(f.velocities[0], [3.0, 4.0, 0.0]);
    assert_eq!(f.radii, vec![0.5, 0.25]);
    assert_eq!(f.planes.len(), 4);
    assert_eq!(f.domain.unwrap().max, [5.0, 5.0, 0.0]);
    assert_eq!((f.step, f.time), (0, 0.0));
}
