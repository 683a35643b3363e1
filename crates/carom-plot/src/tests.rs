//! Unit tests of the scaling plot: sizes, text, scales, bad data, tick labels, saving.

use crate::scaling::{check, format_tick};
use crate::*;
use std::collections::HashSet;
use std::path::Path;

fn example() -> Vec<Series> {
    let ns = [1e3, 1e4, 1e5, 1e6, 4e6];
    vec![
        Series {
            label: "2D grid, area fraction 0.3".into(),
            points: ns
                .iter()
                .zip([95.0, 82.0, 88.0, 104.0, 118.0])
                .map(|(&n, y)| (n, y))
                .collect(),
        },
        Series {
            label: "3D grid, volume fraction 0.2".into(),
            points: ns
                .iter()
                .zip([180.0, 150.0, 160.0, 190.0, 210.0])
                .map(|(&n, y)| (n, y))
                .collect(),
        },
        Series {
            label: "2D brute force".into(),
            points: vec![(1e3, 300.0), (1e4, 2900.0), (3e4, 8800.0)],
        },
    ]
}

/// Decodes a PNG into (width, height, RGB bytes).
fn decode(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

#[test]
fn renders_a_png_of_the_right_size_with_text_and_colour() {
    let png = scaling_plot_png(
        &example(),
        "carom: cost per particle-step",
        "particles N",
        "ns per particle-step",
    )
    .unwrap();
    let (w, h, rgb) = decode(&png);
    assert_eq!((w, h), (DEFAULT_WIDTH, DEFAULT_HEIGHT));
    let pixels: Vec<[u8; 3]> = rgb.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let distinct: HashSet<[u8; 3]> = pixels.iter().copied().collect();
    assert!(distinct.len() > 50, "only {} colours", distinct.len());
    let dark = pixels.iter().filter(|p| p.iter().all(|&c| c < 80)).count();
    assert!(dark > 2000, "only {dark} dark (text) pixels");
    let white = pixels.iter().filter(|p| **p == [255, 255, 255]).count();
    assert!(
        white > pixels.len() / 2,
        "background should mostly be white"
    );
}

#[test]
fn text_renders() {
    // The same chart with and without a title: the title must add dark pixels in the top
    // band, which only happens when glyphs are actually drawn.
    let dark_top = |title: &str| {
        let (w, _, rgb) = decode(&scaling_plot_png(&example(), title, "N", "ns").unwrap());
        rgb.chunks_exact(3)
            .take(w as usize * 40)
            .filter(|p| p.iter().all(|&c| c < 100))
            .count()
    };
    assert_eq!(dark_top(""), 0);
    assert!(dark_top("A title with some letters") > 200);
}

#[test]
fn options_set_size_and_scale() {
    for y_scale in [YScale::Linear, YScale::Log] {
        let options = PlotOptions {
            width: 400,
            height: 300,
            y_scale,
        };
        let png = scaling_plot_png_with(&example(), "t", "x", "y", &options).unwrap();
        assert_eq!(decode(&png).0, 400);
    }
    let tiny = PlotOptions {
        width: 10,
        ..PlotOptions::default()
    };
    assert!(matches!(
        scaling_plot_png_with(&example(), "t", "x", "y", &tiny),
        Err(PlotError::Size(10, 560))
    ));
}

#[test]
fn auto_scale_picks_log_only_for_wide_ranges() {
    assert!(check(&example(), YScale::Auto).unwrap());
    let flat = vec![Series {
        label: "flat".into(),
        points: vec![(1e3, 80.0), (1e6, 95.0)],
    }];
    assert!(!check(&flat, YScale::Auto).unwrap());
    // zero y is fine on a linear axis
    let zero = vec![Series {
        label: "z".into(),
        points: vec![(1e3, 0.0), (1e6, 95.0)],
    }];
    assert!(!check(&zero, YScale::Auto).unwrap());
    scaling_plot_png(&zero, "t", "x", "y").unwrap();
    scaling_plot_png(&flat, "t", "x", "y").unwrap();
}

#[test]
fn bad_data_is_an_error_not_a_panic() {
    assert!(matches!(
        scaling_plot_png(&[], "t", "x", "y"),
        Err(PlotError::NoSeries)
    ));
    let empty = [Series {
        label: "e".into(),
        points: vec![],
    }];
    assert!(matches!(
        scaling_plot_png(&empty, "t", "x", "y"),
        Err(PlotError::EmptySeries(l)) if l == "e"
    ));
    for x in [0.0, -5.0] {
        let s = [Series {
            label: "s".into(),
            points: vec![(1e3, 1.0), (x, 2.0)],
        }];
        assert!(matches!(
            scaling_plot_png(&s, "t", "x", "y"),
            Err(PlotError::NonPositive {
                axis: "x",
                index: 1,
                ..
            })
        ));
    }
    let s = [Series {
        label: "s".into(),
        points: vec![(1e3, -1.0)],
    }];
    let log = PlotOptions {
        y_scale: YScale::Log,
        ..PlotOptions::default()
    };
    assert!(matches!(
        scaling_plot_png_with(&s, "t", "x", "y", &log),
        Err(PlotError::NonPositive { axis: "y", .. })
    ));
    let s = [Series {
        label: "s".into(),
        points: vec![(1e3, f64::NAN)],
    }];
    assert!(matches!(
        scaling_plot_png(&s, "t", "x", "y"),
        Err(PlotError::NonFinite { axis: "y", .. })
    ));
}

#[test]
fn extreme_values_do_not_hang_or_panic() {
    let wide = [Series {
        label: "wide".into(),
        points: vec![(1e-320, 1e-310), (f64::MAX, f64::MAX), (1.0, -f64::MAX)],
    }];
    let wide_pos = [Series {
        label: "wide".into(),
        points: vec![(1e-320, 1e-310), (f64::MAX, f64::MAX)],
    }];
    for y_scale in [YScale::Auto, YScale::Linear, YScale::Log] {
        let options = PlotOptions {
            y_scale,
            ..PlotOptions::default()
        };
        let _ = scaling_plot_png_with(&wide, "t", "x", "y", &options);
        scaling_plot_png_with(&wide_pos, "t", "x", "y", &options).unwrap();
    }
}

#[test]
fn single_point_and_equal_values_render() {
    let s = [Series {
        label: "one".into(),
        points: vec![(5e3, 42.0)],
    }];
    scaling_plot_png(&s, "t", "x", "y").unwrap();
    let log = PlotOptions {
        y_scale: YScale::Log,
        ..PlotOptions::default()
    };
    scaling_plot_png_with(&s, "t", "x", "y", &log).unwrap();
}

#[test]
fn tick_labels_read_well() {
    let f = |v: f64| format_tick(&v);
    assert_eq!(f(1000.0), "1k");
    assert_eq!(f(2000.0), "2k");
    assert_eq!(f(500_000.0), "500k");
    assert_eq!(f(4e6), "4M");
    assert_eq!(f(50.0), "50");
    assert_eq!(f(0.5), "0.5");
    assert_eq!(f(2.5), "2.5");
    assert_eq!(f(0.0), "0");
    assert_eq!(f(120.0), "120");
    assert_eq!(f(1e-5), "1e-5");
    assert_eq!(f(2.5e20), "2.5e20");
}

#[test]
fn saves_atomically() {
    let dir = std::env::temp_dir().join(format!("carom-plot-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("plot.png");
    save_scaling_plot(&path, &example(), "t", "x", "y").unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(decode(&bytes).0, DEFAULT_WIDTH);
    assert!(save_scaling_plot(&path, &[], "t", "x", "y").is_err());
    assert_eq!(
        std::fs::read(&path).unwrap(),
        bytes,
        "a failed plot leaves the old file"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Writes the example plot to `$CAROM_PLOT_EXAMPLE` (for looking at it).
#[test]
fn example_plot_to_file() {
    if let Ok(path) = std::env::var("CAROM_PLOT_EXAMPLE") {
        save_scaling_plot(
            Path::new(&path),
            &example(),
            "carom: cost per particle-step",
            "particles N",
            "ns per particle-step",
        )
        .unwrap();
    }
}
