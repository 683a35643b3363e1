//! `--observe FILE --every K` on the real binary: the file's exact header, its rows, a resumed
//! run continuing it to the byte, and the refusals.

use std::path::{Path, PathBuf};
use std::process::Command;

fn carom() -> Command {
    Command::new(env!("CARGO_BIN_EXE_carom"))
}

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/lecture_100_k10.toml")
}

fn ok(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn observe(dir: &Path, name: &str, steps: &str) -> PathBuf {
    let path = dir.join(name);
    ok(carom().args([
        "run",
        scene().to_str().unwrap(),
        "--steps",
        steps,
        "--observe",
        path.to_str().unwrap(),
        "--every",
        "10",
    ]));
    path
}

#[test]
fn the_file_has_the_header_and_a_row_at_the_start_and_every_k_steps() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(observe(dir.path(), "obs.csv", "60")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some(
            "step,time,kinetic_energy,potential_energy,temperature,collisions,pressure,max_overlap"
        )
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let steps: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(steps, [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0]);
    for pair in rows.windows(2) {
        // collisions count up from 0; every value is finite, temperature and pressure > 0
        assert!(pair[1][5] >= pair[0][5]);
    }
    assert_eq!(rows[0][5], 0.0);
    assert!(rows.last().unwrap()[5] > 0.0, "the lecture gas collides");
    for r in &rows {
        assert!(r.iter().all(|x| x.is_finite()), "{r:?}");
        assert!(r[4] > 0.0 && r[6] > 0.0, "{r:?}");
    }
}

#[test]
fn a_resumed_run_continues_the_file_to_the_byte() {
    let dir = tempfile::tempdir().unwrap();
    let straight = std::fs::read(observe(dir.path(), "straight.csv", "60")).unwrap();
    // a checkpoint at step 25, between two rows: the pressure's interval goes on from it
    let (ck, obs) = (dir.path().join("ck.bin"), dir.path().join("obs.csv"));
    ok(carom().args([
        "run",
        scene().to_str().unwrap(),
        "--steps",
        "25",
        "--observe",
        obs.to_str().unwrap(),
        "--every",
        "10",
        "--checkpoint",
        ck.to_str().unwrap(),
        "--checkpoint-every",
        "25",
    ]));
    ok(carom().args([
        "resume",
        ck.to_str().unwrap(),
        "--steps",
        "60",
        "--observe",
        obs.to_str().unwrap(),
        "--every",
        "10",
    ]));
    assert_eq!(std::fs::read(obs).unwrap(), straight);
}

#[test]
fn bad_uses_are_refused_before_any_work_and_leave_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let obs = dir.path().join("obs.csv");
    let s = scene();
    let s = s.to_str().unwrap();
    let o = obs.to_str().unwrap();
    for (args, says) in [
        (vec!["run", s, "--observe", o], "--every"),
        (vec!["run", s, "--every", "10"], "--observe"),
        (vec!["run", s, "--observe", o, "--every", "0"], "--every"),
        (
            vec!["run", s, "--observe", o, "--every", "5", "--ranks", "2"],
            "split run",
        ),
        (
            vec!["run", s, "--observe", o, "--every", "5", "--trajectory", o],
            "--trajectory",
        ),
    ] {
        let out = carom().args(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
        assert!(!obs.exists(), "{args:?} left a file");
    }
}

#[test]
fn a_dense_inelastic_periodic_gas_neither_hangs_nor_blows_up() {
    let dir = tempfile::tempdir().unwrap();
    let obs = dir.path().join("collapse.csv");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/inelastic_collapse.toml");
    let summary = ok(carom().args([
        "run",
        scene.to_str().unwrap(),
        "--steps",
        "1500",
        "--observe",
        obs.to_str().unwrap(),
        "--every",
        "100",
    ]));
    // the sweeps hit their cap (the collapse), and the summary says what the solver did then
    assert!(
        summary.contains("solver      the velocity sweeps stopped"),
        "{summary}"
    );
    // momentum: the summary's start and end agree to the digits it prints
    let momentum = summary.lines().find(|l| l.starts_with("momentum")).unwrap();
    let (start, end) = momentum["momentum".len()..].split_once("->").unwrap();
    assert_eq!(start.trim(), end.trim(), "{momentum}");
    let text = std::fs::read_to_string(obs).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 16);
    for pair in rows.windows(2) {
        // it cools, every value stays finite, and no pair sinks deeper than 1 % of a radius
        assert!(pair[1][4] < pair[0][4], "{pair:?}");
        assert!(pair[1].iter().all(|x| x.is_finite()), "{pair:?}");
        assert!(pair[1][7] < 0.01, "{pair:?}");
    }
    assert!(rows[15][5] > 3.0 * 3000.0, "collisions: {}", rows[15][5]);
}
