//! Bad input, as a new user (or a typo) would give it (issue 13): every value is refused with
//! exit status 2 and one message naming the flag or field, quickly (before any expensive work),
//! without a panic and without leaving any output file behind.

use std::path::Path;
use std::time::Duration;

/// Generous for a loaded CI machine: the refusals take milliseconds. Before issue 13,
/// `--threads 100000` ran for minutes.
const QUICK: Duration = Duration::from_secs(3);

mod refusals;

use refusals::{carom, listing, newton_cradle, refusal};

/// [`refusal`], and quickly.
fn refused_in(dir: &Path, args: &[&str], env: &[(&str, &str)], says: &[&str]) {
    let took = refusal(dir, args, env, says);
    assert!(took < QUICK, "{args:?} took {took:?}");
}

fn refused(args: &[&str], says: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    refused_in(dir.path(), args, &[], says);
}

/// A clap usage error (unknown value, a flag without the one it needs): status 2, no file.
fn usage_error(args: &[&str], says: &str) {
    let dir = tempfile::tempdir().unwrap();
    let out = carom().args(args).current_dir(dir.path()).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(stderr.contains(says), "{args:?}: no `{says}` in {stderr}");
    assert!(listing(dir.path()).is_empty(), "{args:?} left a file");
}

#[test]
fn thread_and_rank_counts_are_bounded_by_the_machine() {
    let s = newton_cradle();
    let s = s.to_str().unwrap();
    for command in [
        vec!["run", s],
        vec!["render", s, "--out", "a.png"],
        vec!["soak", s],
        vec!["bench"],
        vec!["validate"],
    ] {
        for threads in ["100000", "0", "18446744073709551615"] {
            let mut args = command.clone();
            args.extend(["--threads", threads]);
            refused(&args, &["--threads"]);
        }
        let dir = tempfile::tempdir().unwrap();
        refused_in(
            dir.path(),
            &command,
            &[("RAYON_NUM_THREADS", "100000")],
            &["RAYON_NUM_THREADS", "limit"],
        );
    }
    refused(
        &["run", s, "--ranks", "100000", "--out", "f.csv"],
        &["--ranks", "limit"],
    );
    refused(&["run", s, "--ranks", "0"], &["--ranks"]);
    usage_error(&["run", s, "--threads", "-1"], "--threads");
    usage_error(&["run", s, "--threads", "1e5"], "--threads");
}

#[test]
fn the_limit_is_stated_in_help() {
    let out = carom().args(["run", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("8 per core"), "{help}");
}

#[test]
fn step_counts_are_bounded() {
    let s = newton_cradle();
    let s = s.to_str().unwrap();
    let too_many = "10000000000000"; // 10^13
    refused(
        &["run", s, "--steps", too_many, "--out", "f.csv"],
        &["--steps"],
    );
    refused(
        &["render", s, "--out", "a.gif", "--steps", too_many],
        &["--steps"],
    );
    refused(&["soak", s, "--steps", too_many], &["--steps"]);
    usage_error(&["run", s, "--steps", "1e6"], "--steps");
}

#[test]
fn grid_cells_are_bounded_before_the_scene_is_read() {
    let s = newton_cradle();
    let s = s.to_str().unwrap();
    for cells in ["100000,100000", "0,5", "18446744073709551615,2"] {
        refused(
            &[
                "run",
                s,
                "--broadphase",
                "grid",
                "--cells",
                cells,
                "--out",
                "f.csv",
            ],
            &["--cells"],
        );
    }
}

#[test]
fn an_output_that_would_overwrite_an_input_or_another_output_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(newton_cradle(), d.join("scene.toml")).unwrap();
    refused_in(
        d,
        &["run", "scene.toml", "--out", "scene.toml"],
        &[],
        &["--out", "scene file"],
    );
    refused_in(
        d,
        &[
            "run",
            "scene.toml",
            "--out",
            "f.csv",
            "--trajectory",
            "./f.csv",
            "--every",
            "5",
        ],
        &[],
        &["--trajectory", "--out"],
    );
    refused_in(
        d,
        &[
            "run",
            "scene.toml",
            "--checkpoint",
            "f.csv",
            "--checkpoint-every",
            "5",
            "--out",
            "f.csv",
        ],
        &[],
        &["--checkpoint", "--out"],
    );
    // the scene file is still the scene
    assert_eq!(
        std::fs::read(d.join("scene.toml")).unwrap(),
        std::fs::read(newton_cradle()).unwrap()
    );
}

#[test]
fn resume_refuses_a_total_before_the_checkpoint_and_a_lone_interval() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = newton_cradle();
    let run = carom()
        .args(["run", s.to_str().unwrap(), "--steps", "20"])
        .args(["--checkpoint", "ck.bin", "--checkpoint-every", "20"])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    refused_in(
        d,
        &["resume", "ck.bin", "--steps", "10", "--out", "f.csv"],
        &[],
        &["--steps", "20"],
    );
    refused_in(
        d,
        &["resume", "ck.bin", "--out", "ck.bin"],
        &[],
        &["--out", "checkpoint"],
    );
    refused_in(
        d,
        &["resume", "ck.bin", "--threads", "100000"],
        &[],
        &["--threads"],
    );
    refused_in(
        d,
        &["resume", "ck.bin", "--ranks", "100000"],
        &[],
        &["--ranks"],
    );
    // --checkpoint-every alone used to be ignored
    let out = carom()
        .args(["resume", "ck.bin", "--checkpoint-every", "5"])
        .current_dir(d)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--checkpoint-to"));
    // resuming to the checkpoint's own step is fine (nothing to step, the final CSV written)
    let same = carom()
        .args(["resume", "ck.bin", "--steps", "20", "--out", "f.csv"])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(
        same.status.success(),
        "{}",
        String::from_utf8_lossy(&same.stderr)
    );
}

#[test]
fn render_frame_counts_are_bounded() {
    let s = newton_cradle();
    let s = s.to_str().unwrap();
    refused(
        &["render", s, "--out", "a.gif", "--frames", "1000000"],
        &["--frames"],
    );
    refused(
        &[
            "render", s, "--out", "a.gif", "--every", "1", "--steps", "1000000",
        ],
        &["--every", "frames"],
    );
    refused(
        &[
            "render",
            s,
            "--out",
            "a.gif",
            "--frames",
            "3",
            "--every",
            "1000000000000000000",
        ],
        &["--frames x --every"],
    );
}

#[test]
fn view_refuses_a_bad_selection_or_radius_before_a_window() {
    refused(
        &["view", "--preset", "newton_cradle", "--select", "99999"],
        &["--select"],
    );
    for radius in ["-1", "0", "nan", "inf"] {
        refused(
            &["view", "--count", "10", "--radius", radius],
            &["--radius"],
        );
    }
    refused(&["view", "--size", "100000x100000"], &["--size"]);
}

/// Scenes the walls cannot hold, through `carom run` and `carom check`.
#[test]
fn scenes_the_walls_cannot_hold_are_refused_naming_file_and_field() {
    let walled = |body: &str| {
        format!(
            "dimensions = 2\ndt = 0.01\nsteps = 10\n[domain]\nmin = [0.0, 0.0]\n\
             max = [10.0, 10.0]\nwalls = true\n{body}"
        )
    };
    let cases = [
        (
            walled("[[particles]]\nposition = [12.0, 5.0]\nradius = 1.0\n"),
            "particles[0].position",
        ),
        (
            walled("[[particles]]\nposition = [5.0, 5.0]\nradius = 6.0\n"),
            "particles[0].radius",
        ),
        (
            walled("[[fill]]\ncount = 10\nradius = 0.5\nmin = [20.0, 0.0]\nmax = [30.0, 10.0]\n"),
            "fill[0].max",
        ),
        (
            "dimensions = 2\ndt = 0.01\nsteps = 10000000000000\n".to_string(),
            "steps",
        ),
    ];
    for (text, field) in cases {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("bad.toml"), &text).unwrap();
        let says = ["bad.toml", field];
        refused_in(d, &["run", "bad.toml", "--out", "f.csv"], &[], &says);
        refused_in(d, &["check", "bad.toml"], &[], &says);
        refused_in(d, &["render", "bad.toml", "--out", "a.png"], &[], &says);
    }
}
