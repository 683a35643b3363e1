//! `carom run --ranks N`: the split run (ghosts, a borrowed border block, migration, gathered
//! output) with the ranks as threads. Every output file must be byte-identical to the one a
//! single process writes, and a checkpoint from a split run must resume in a single process.

mod support;
use support::scene;

use std::path::{Path, PathBuf};
use std::process::Command;

/// Runs carom (a deadlocked split run fails the test after two minutes).
fn carom(args: &[&str]) -> String {
    let out = run_guarded(Command::new(env!("CARGO_BIN_EXE_carom")).args(args));
    assert!(
        out.status.success(),
        "carom {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn run_guarded(command: &mut Command) -> std::process::Output {
    support::run_guarded(command, std::time::Duration::from_secs(120))
}

/// Runs `scene` for `steps` with `extra` flags into `dir`, with a final state, a CSV
/// trajectory and a checkpoint; returns the three paths and the summary.
fn run_into(dir: &Path, scene: &str, steps: &str, extra: &[&str]) -> ([PathBuf; 3], String) {
    let paths = [
        dir.join("final.csv"),
        dir.join("trajectory.csv"),
        dir.join("state.ckpt"),
    ];
    let p: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    let mut args = vec![
        "run",
        scene,
        "--steps",
        steps,
        "--out",
        &p[0],
        "--trajectory",
        &p[1],
        "--every",
        "40",
        "--checkpoint",
        &p[2],
        "--checkpoint-every",
        "70",
    ];
    args.extend_from_slice(extra);
    let summary = carom(&args);
    (paths, summary)
}

fn assert_same_files(a: &[PathBuf; 3], b: &[PathBuf; 3], what: &str) {
    for (x, y) in a.iter().zip(b) {
        let (x_bytes, y_bytes) = (std::fs::read(x).unwrap(), std::fs::read(y).unwrap());
        assert!(!x_bytes.is_empty());
        assert!(
            x_bytes == y_bytes,
            "{what}: {} differs from the single-process {}",
            y.display(),
            x.display()
        );
    }
}

#[test]
fn split_runs_write_the_single_process_files() {
    for (file, steps, ranks) in [
        ("lecture_5000_grid100.toml", "160", &["2", "4"][..]),
        ("lecture_mixed_radii.toml", "160", &["3"][..]),
        ("box_3d.toml", "120", &["2"][..]),
    ] {
        let path = scene(file);
        let one = tempfile::tempdir().unwrap();
        let (single, _) = run_into(one.path(), &path, steps, &[]);
        for &r in ranks {
            let dir = tempfile::tempdir().unwrap();
            let (split, summary) = run_into(dir.path(), &path, steps, &["--ranks", r]);
            assert!(
                summary.contains(&format!("ranks       {r} (particles per rank:")),
                "no split summary in:\n{summary}"
            );
            assert!(summary.contains("KiB sent per rank per step"));
            assert_same_files(&single, &split, &format!("{file} on {r} ranks"));
        }
    }
}

#[test]
fn a_split_runs_checkpoint_resumes_in_one_process() {
    let path = scene("lecture_5000_grid100.toml");
    let one = tempfile::tempdir().unwrap();
    let (single, _) = run_into(one.path(), &path, "150", &[]);
    let dir = tempfile::tempdir().unwrap();
    // stop the split run at step 140 (last checkpoint at 140), resume alone to 150
    let (split, _) = run_into(dir.path(), &path, "140", &["--ranks", "2"]);
    let resumed = dir.path().join("resumed.csv");
    carom(&[
        "resume",
        split[2].to_str().unwrap(),
        "--steps",
        "150",
        "--out",
        resumed.to_str().unwrap(),
    ]);
    assert_eq!(
        std::fs::read(&resumed).unwrap(),
        std::fs::read(&single[0]).unwrap(),
        "resuming a 2-rank checkpoint alone differs from the straight run"
    );
}

#[test]
fn zero_ranks_is_refused() {
    let out = run_guarded(
        Command::new(env!("CARGO_BIN_EXE_carom")).args(["run", "--steps", "1", "--ranks", "0"]),
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--ranks"));
}

/// A pile whose particles fall asleep (dt = 1/60, a short sleep time): 2500 discs, so two or
/// three ranks each own whole solver blocks.
const SLEEPY: &str = r#"
dimensions = 2
dt = 0.016666666666666666
steps = 600
gravity = [0.0, -9.81]
restitution = 0.5
[solver]
sleep = true
sleep_time = 0.2
[domain]
min = [-50.0, -50.0]
max = [50.0, 50.0]
walls = true
[[fill]]
count = 2500
radius = 0.5
speed = 1.0
seed = 3
min = [-49.0, -49.0]
max = [49.0, 0.0]
"#;

/// Sleepers span the ranks' borders: a split run sleeps the very same ones and
/// writes the single process's bytes (final state, trajectory, checkpoint with rest times).
#[test]
fn a_sleeping_scene_splits_into_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sleepy.toml");
    std::fs::write(&path, SLEEPY).unwrap();
    let path = path.to_str().unwrap();
    let one = tempfile::tempdir().unwrap();
    // (the pile falls asleep whole at step 555; the last checkpoint is at 560)
    let (single, summary) = run_into(one.path(), path, "600", &[]);
    assert!(
        summary.contains("all 2500 particles asleep since step"),
        "{summary}"
    );
    for r in ["2", "3"] {
        let split_dir = tempfile::tempdir().unwrap();
        let (split, summary) = run_into(split_dir.path(), path, "600", &["--ranks", r]);
        assert!(
            summary.contains("all 2500 particles asleep since step"),
            "{summary}"
        );
        assert_same_files(&single, &split, &format!("sleepy.toml on {r} ranks"));
    }
}
