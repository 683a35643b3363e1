//! End-to-end tests of `carom render`: the real binary on shipped scenes.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn carom() -> Command {
    Command::new(env!("CARGO_BIN_EXE_carom"))
}

fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
        .to_str()
        .unwrap()
        .to_string()
}

fn run(args: &[&str]) -> Output {
    carom().args(args).output().expect("carom starts")
}

fn run_ok(args: &[&str]) -> Output {
    let out = run(args);
    assert!(
        out.status.success(),
        "carom {args:?} failed: {}\n{}",
        String::from_utf8_lossy(&out.stderr),
        String::from_utf8_lossy(&out.stdout)
    );
    out
}

/// Decodes a PNG: (width, height, RGB(A) bytes, channels).
fn decode_png(path: &Path) -> (u32, u32, Vec<u8>, usize) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    let channels = info.color_type.samples();
    (info.width, info.height, buf, channels)
}

/// Number of distinct colours and of pixels unlike the top-left one (the background).
fn variety(pixels: &[u8], channels: usize) -> (usize, usize) {
    let px: Vec<&[u8]> = pixels.chunks_exact(channels).collect();
    let mut colours: Vec<&[u8]> = px.clone();
    colours.sort();
    colours.dedup();
    let background = px[0];
    (
        colours.len(),
        px.iter().filter(|p| **p != background).count(),
    )
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect()
}

#[test]
fn png_of_a_shipped_scene() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("still.png");
    let o = run_ok(&[
        "render",
        &scene("lecture_100_k05.toml"),
        "--steps",
        "100",
        "--size",
        "320x240",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("step 100"));
    let (w, h, pixels, channels) = decode_png(&out);
    assert_eq!((w, h), (320, 240));
    let (colours, drawn) = variety(&pixels, channels);
    assert!(colours > 20, "{colours} colours");
    assert!(drawn > 2000, "{drawn} pixels drawn");
    assert_eq!(files_in(dir.path()), vec![out], "no temporary left");
}

#[test]
fn png_of_a_3d_preset() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("box.png");
    run_ok(&[
        "render",
        "--preset",
        "newton_cradle_3d",
        "--size",
        "200x160",
        "--color",
        "id",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (w, h, pixels, channels) = decode_png(&out);
    assert_eq!((w, h), (200, 160));
    let (colours, drawn) = variety(&pixels, channels);
    assert!(
        colours > 20 && drawn > 500,
        "{colours} colours, {drawn} drawn"
    );
}

#[test]
fn gif_has_the_asked_frames() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("anim.gif");
    let o = run_ok(&[
        "render",
        &scene("lecture_100_k05.toml"),
        "--frames",
        "5",
        "--every",
        "20",
        "--size",
        "160x120",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("frames      5"));
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut d = options
        .read_info(std::fs::File::open(&out).unwrap())
        .unwrap();
    assert_eq!((d.width(), d.height()), (160, 120));
    let mut frames = Vec::new();
    while let Some(f) = d.read_next_frame().unwrap() {
        // dt 0.005 x 20 steps = 0.1 time units = 10 hundredths of a second.
        assert_eq!(f.delay, 10);
        frames.push(f.buffer.to_vec());
    }
    assert_eq!(frames.len(), 5);
    assert_ne!(frames[0], frames[4], "the particles move");
    assert_eq!(files_in(dir.path()), vec![out], "no temporary left");
}

#[test]
fn bad_flags_exit_2_and_leave_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = scene("lecture_100_k05.toml");
    let png = d.join("x.png");
    let png = png.to_str().unwrap();
    let gif = d.join("x.gif");
    let gif = gif.to_str().unwrap();
    let bmp = d.join("x.bmp");
    let missing = d.join("no/such/folder/x.png");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--out", bmp.to_str().unwrap()], "--out"),
        (vec!["--out", missing.to_str().unwrap()], "--out"),
        (vec!["--out", png, "--size", "0x100"], "--size"),
        (vec!["--out", png, "--size", "9000x100"], "--size"),
        (vec!["--out", png, "--size", "big"], "--size"),
        (vec!["--out", gif, "--frames", "0"], "--frames"),
        (vec!["--out", png, "--frames", "3"], "--frames"),
        (vec!["--out", png, "--every", "10"], "--every"),
        (vec!["--out", gif, "--every", "0"], "--every"),
        (
            vec!["--out", gif, "--frames", "1", "--every", "5"],
            "--every",
        ),
        (vec!["--out", gif, "--threads", "0"], "--threads"),
        (vec!["--out", png, "--pitch", "95"], "--pitch"),
        (vec!["--out", png, "--range", "5,1"], "--range"),
        (vec!["--out", png, "--range", "1"], "--range"),
    ];
    for (extra, flag) in cases {
        let mut args = vec!["render", s.as_str()];
        args.extend(extra);
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(flag),
            "{args:?}: message should name {flag}: {err}"
        );
        assert!(files_in(d).is_empty(), "{args:?} left a file");
    }
    // A scene that does not exist.
    let o = run(&["render", "no_such_scene.toml", "--out", png]);
    assert_eq!(o.status.code(), Some(2));
    assert!(files_in(d).is_empty());
}

#[test]
fn mp4_without_ffmpeg_is_refused_before_running() {
    let dir = tempfile::tempdir().unwrap();
    let empty = tempfile::tempdir().unwrap();
    let out = dir.path().join("movie.mp4");
    let o = carom()
        .args([
            "render",
            &scene("lecture_5000_grid100.toml"),
            "--frames",
            "10",
        ])
        .args(["--out", out.to_str().unwrap()])
        .env("PATH", empty.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("ffmpeg"), "{err}");
    assert!(files_in(dir.path()).is_empty());
}

/// An `ffmpeg` that stops before reading its input: an error that says what it said, exit
/// status 1, and no temporary left (carom was killed by `SIGPIPE` writing the first frame).
#[cfg(unix)]
#[test]
fn mp4_whose_ffmpeg_stops_early_is_an_error_that_leaves_nothing() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let bin = tempfile::tempdir().unwrap();
    let ffmpeg = bin.path().join("ffmpeg");
    std::fs::write(&ffmpeg, "#!/bin/sh\necho 'Unknown encoder' >&2\nexit 1\n").unwrap();
    std::fs::set_permissions(&ffmpeg, std::fs::Permissions::from_mode(0o755)).unwrap();
    let out = dir.path().join("movie.mp4");
    let o = carom()
        .args(["render", &scene("lecture_100_k05.toml"), "--frames", "5"])
        .args(["--size", "64x64", "--out", out.to_str().unwrap()])
        .env("PATH", bin.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("Unknown encoder"), "{err}");
    assert!(
        files_in(dir.path()).is_empty(),
        "{:?}",
        files_in(dir.path())
    );
}

#[test]
fn gif_is_the_same_for_every_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.path().join(format!("t{threads}.gif"));
        run_ok(&[
            "render",
            "--preset",
            "pool_break",
            "--frames",
            "12",
            "--every",
            "10",
            "--size",
            "96x64",
            "--threads",
            threads,
            "--out",
            out.to_str().unwrap(),
        ]);
        bytes.push(std::fs::read(&out).unwrap());
    }
    assert_eq!(bytes[0], bytes[1]);
}

#[test]
fn mp4_when_ffmpeg_is_on_path() {
    let found = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("ffmpeg").is_file()));
    if !found {
        eprintln!("no ffmpeg on PATH: skipped");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("movie.mp4");
    run_ok(&[
        "render",
        &scene("lecture_100_k05.toml"),
        "--frames",
        "6",
        "--size",
        "101x75",
        "--out",
        out.to_str().unwrap(),
    ]);
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(&bytes[4..8], b"ftyp", "an MP4 file");
    assert_eq!(files_in(dir.path()), vec![out], "no temporary left");
}
