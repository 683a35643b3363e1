//! Long runs lose nothing: checkpoints, resume, Ctrl-C and SIGKILL, on the real binary, with
//! CSV and VTK (`.pvd` + `.vtp`) trajectories.

use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
mod output_files;
use output_files::{check_files_on_disk, check_vtk_series, Ending, Traj};

fn carom() -> Command {
    Command::new(env!("CARGO_BIN_EXE_carom"))
}

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/lecture_5000_grid100.toml")
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

fn straight_run(dir: &Path, steps: &str) -> Vec<u8> {
    let out = dir.join("straight.csv");
    ok(carom().args([
        "run",
        scene().to_str().unwrap(),
        "--steps",
        steps,
        "--out",
        out.to_str().unwrap(),
    ]));
    std::fs::read(out).unwrap()
}

#[test]
fn checkpoint_then_resume_equals_a_straight_run() {
    let dir = tempfile::tempdir().unwrap();
    let expected = straight_run(dir.path(), "230");
    let ck = dir.path().join("ck.bin");
    ok(carom().args([
        "run",
        scene().to_str().unwrap(),
        "--steps",
        "230",
        "--checkpoint",
        ck.to_str().unwrap(),
        "--checkpoint-every",
        "100",
    ]));
    // the checkpoint holds step 200; resume runs the last 30 steps
    let out = dir.path().join("resumed.csv");
    ok(carom().args([
        "resume",
        ck.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    assert_eq!(std::fs::read(&out).unwrap(), expected);
    // and on another thread count
    ok(carom().args([
        "resume",
        ck.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
    ]));
    assert_eq!(std::fs::read(&out).unwrap(), expected);
}

#[test]
fn damaged_or_foreign_checkpoints_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let ck = dir.path().join("ck.bin");
    ok(carom().args([
        "run",
        scene().to_str().unwrap(),
        "--steps",
        "20",
        "--checkpoint",
        ck.to_str().unwrap(),
        "--checkpoint-every",
        "10",
    ]));
    let good = std::fs::read(&ck).unwrap();
    let mut cases: Vec<(Vec<u8>, &str)> = vec![
        (good[..good.len() / 2].to_vec(), "damaged"),
        (b"id,x,y\n".to_vec(), "not a carom checkpoint"),
    ];
    let mut flipped = good.clone();
    flipped[good.len() / 3] ^= 1;
    cases.push((flipped, "checksum"));
    let mut newer = good.clone();
    newer[8..12].copy_from_slice(&7u32.to_le_bytes());
    cases.push((newer, "version 7"));
    for (bytes, words) in cases {
        let bad = dir.path().join("bad.bin");
        std::fs::write(&bad, bytes).unwrap();
        let out = dir.path().join("never.csv");
        let o = carom()
            .args([
                "resume",
                bad.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains("bad.bin") && err.contains(words),
            "{words}: {err}"
        );
        assert!(!out.exists());
    }
    let o = carom()
        .args(["resume", "/nonexistent/ck.bin"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn bad_long_run_flags_are_refused() {
    let s = scene();
    let s = s.to_str().unwrap();
    for args in [
        vec!["run", s, "--checkpoint", "ck.bin"],
        vec![
            "run",
            s,
            "--checkpoint",
            "ck.bin",
            "--checkpoint-every",
            "0",
        ],
        vec!["run", s, "--trajectory", "t.csv", "--every", "0"],
        vec![
            "run",
            s,
            "--trajectory",
            "/nonexistent/t.csv",
            "--every",
            "5",
        ],
    ] {
        let dir = tempfile::tempdir().unwrap();
        let o = carom()
            .args(&args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "{args:?} left a file"
        );
    }
}

/// How a long run is stopped.
#[derive(Clone, Copy, Debug)]
enum Stop {
    /// `kill -INT` or `kill -TERM`: a graceful stop, exit status 130.
    Signal(&'static str),
    /// SIGKILL: no chance to clean up.
    Kill,
}

/// Polls `done` until it holds; fails if carom exits first (or nothing happens for ten minutes,
/// rather than hanging the suite).
fn wait_until(child: &mut Child, what: &str, done: impl Fn() -> bool) {
    let started = Instant::now();
    while !done() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("carom exited ({status}) before {what}");
        }
        assert!(
            started.elapsed() < Duration::from_secs(600),
            "no {what} after ten minutes"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// True once the first trajectory frame is whole on disk.
fn first_frame_written(dir: &Path, traj: Traj, particles: usize) -> bool {
    match traj {
        Traj::Csv => std::fs::read(dir.join("traj.csv"))
            .is_ok_and(|b| b.iter().filter(|&&c| c == b'\n').count() > particles),
        Traj::Vtk => dir.join("traj.pvd").exists(),
    }
}

fn signal(child: &Child, sig: &str) -> bool {
    Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap()
        .success()
}

/// A delay in `0..max` ms that differs from run to run (printed, so a failure can be retried
/// at the same point).
fn random_ms(max: u64) -> u64 {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64;
    (nanos.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 24) % max
}

/// Runs the lecture's 5000 particles (checkpoint every 300 steps, trajectory every 100) and
/// stops it `after` the first trajectory frame is on disk; returns the trajectory's frames.
fn interrupted_run(dir: &Path, traj: Traj, stop: Stop, after: Duration) -> Vec<u64> {
    let s = scene();
    let mut child = carom()
        .args([
            "run",
            s.to_str().unwrap(),
            "--steps",
            "100000",
            "--checkpoint",
            "ck.bin",
            "--checkpoint-every",
            "300",
            "--trajectory",
            traj.file(),
            "--every",
            "100",
            "--out",
            "final.csv",
        ])
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until(&mut child, "the first trajectory frame", || {
        first_frame_written(dir, traj, 5000)
    });
    std::thread::sleep(after);
    let ending = match stop {
        Stop::Signal(sig) => {
            assert!(signal(&child, sig));
            let out = child.wait_with_output().unwrap();
            assert_eq!(
                out.status.code(),
                Some(130),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            Ending::Graceful
        }
        Stop::Kill => {
            child.kill().unwrap(); // SIGKILL
            child.wait().unwrap();
            Ending::Killed
        }
    };
    let context = format!(
        "{traj:?}, {stop:?} {} ms after the first frame",
        after.as_millis()
    );
    let frames = check_files_on_disk(dir, traj, 5000, 100, ending, &context);
    assert!(!frames.is_empty(), "{context}");
    frames
}

#[test]
fn the_series_checker_refuses_damaged_or_stray_frames() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(carom()
        .args(["run", scene().to_str().unwrap(), "--steps", "30"])
        .args(["--trajectory", "traj.pvd", "--every", "10"])
        .current_dir(d));
    assert_eq!(
        check_vtk_series(d, 5000, 10, Ending::Graceful, "clean"),
        [0, 10, 20, 30]
    );
    let fails = |ending: Ending| {
        std::panic::catch_unwind(|| check_vtk_series(d, 5000, 10, ending, "damaged")).is_err()
    };
    let frame = d.join("traj/traj_000000020.vtp");
    let bytes = std::fs::read(&frame).unwrap();
    // a listed frame cut short, or missing
    std::fs::write(&frame, &bytes[..bytes.len() / 2]).unwrap();
    assert!(fails(Ending::Killed));
    std::fs::remove_file(&frame).unwrap();
    assert!(fails(Ending::Killed));
    std::fs::write(&frame, &bytes).unwrap();
    assert!(!fails(Ending::Graceful));
    // the collection cut short
    let pvd = std::fs::read(d.join("traj.pvd")).unwrap();
    std::fs::write(d.join("traj.pvd"), &pvd[..pvd.len() - 20]).unwrap();
    assert!(fails(Ending::Killed));
    std::fs::write(d.join("traj.pvd"), &pvd).unwrap();
    // a temporary: only after SIGKILL
    let tmp = d.join("traj/.carom-abc123.tmp");
    std::fs::write(&tmp, b"<?xml").unwrap();
    assert!(fails(Ending::AtOnce));
    assert!(!fails(Ending::Killed));
    std::fs::remove_file(&tmp).unwrap();
    // an unlisted next frame: whole, and not after a graceful stop; cut short, never
    let next = d.join("traj/traj_000000040.vtp");
    std::fs::write(&next, &bytes).unwrap();
    assert!(fails(Ending::Graceful));
    assert!(!fails(Ending::AtOnce));
    assert!(!fails(Ending::Killed));
    std::fs::write(&next, &bytes[..bytes.len() - 100]).unwrap();
    assert!(fails(Ending::Killed));
    // nor any other frame than the next
    std::fs::remove_file(&next).unwrap();
    std::fs::write(d.join("traj/traj_000000050.vtp"), &bytes).unwrap();
    assert!(fails(Ending::Killed));
}

#[test]
fn ctrl_c_and_sigterm_stop_cleanly_and_resume_exactly() {
    for (traj, sig) in [
        (Traj::Csv, "-INT"),
        (Traj::Csv, "-TERM"),
        (Traj::Vtk, "-INT"),
        (Traj::Vtk, "-TERM"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let after = random_ms(600);
        eprintln!("{traj:?} {sig} {after} ms after the first frame");
        let frames = interrupted_run(
            dir.path(),
            traj,
            Stop::Signal(sig),
            Duration::from_millis(after),
        );
        // the checkpoint holds the step the run stopped at; resume it to a short total and
        // compare with a straight run to the same total
        let ck = dir.path().join("ck.bin");
        let stopped_at = {
            let bytes = std::fs::read(&ck).unwrap();
            u64::from_le_bytes(bytes[16..24].try_into().unwrap())
        };
        assert!(stopped_at > 0);
        // and the trajectory holds every frame up to that step
        assert_eq!(
            frames.last(),
            Some(&(stopped_at / 100 * 100)),
            "{traj:?} {sig}"
        );
        let total = (stopped_at + 37).to_string();
        let expected = straight_run(dir.path(), &total);
        let out = dir.path().join("resumed.csv");
        ok(carom().args([
            "resume",
            ck.to_str().unwrap(),
            "--steps",
            &total,
            "--out",
            out.to_str().unwrap(),
        ]));
        assert_eq!(std::fs::read(&out).unwrap(), expected, "{traj:?} {sig}");
    }
}

fn sigkill_at_random_points(traj: Traj) {
    for ms in [0, 150, 420, 900, random_ms(1500)] {
        eprintln!("{traj:?}: SIGKILL {ms} ms after the first frame");
        let dir = tempfile::tempdir().unwrap();
        interrupted_run(dir.path(), traj, Stop::Kill, Duration::from_millis(ms));
        let ck = dir.path().join("ck.bin");
        if ck.exists() {
            // a checkpoint that exists is whole: it resumes, to the state a clean run reaches
            let out = dir.path().join("resumed.csv");
            let bytes = std::fs::read(&ck).unwrap();
            let at = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
            assert_eq!(at % 300, 0);
            let total = (at + 5).to_string();
            ok(carom().args([
                "resume",
                ck.to_str().unwrap(),
                "--steps",
                &total,
                "--out",
                out.to_str().unwrap(),
            ]));
            let clean = straight_run(dir.path(), &total);
            assert_eq!(
                std::fs::read(&out).unwrap(),
                clean,
                "{traj:?} killed {ms} ms after the first frame"
            );
        }
    }
}

#[test]
fn sigkill_at_random_points_leaves_only_whole_files_csv() {
    sigkill_at_random_points(Traj::Csv);
}

#[test]
fn sigkill_at_random_points_leaves_only_whole_files_vtk() {
    sigkill_at_random_points(Traj::Vtk);
}

/// A scene heavy enough that some file is being written at almost any moment.
const HEAVY: &str = r#"
name = "heavy output"
dimensions = 2
dt = 0.005
steps = 1000000
gravity = [0.0, -9.8]
restitution = 1.0

[domain]
min = [-100.0, -100.0]
max = [100.0, 100.0]
walls = true

[[fill]]
count = 60000
radius = 0.25
speed = 20.0
seed = 11
"#;

/// Particles in [`HEAVY`].
const HEAVY_N: usize = 60000;

/// Starts [`HEAVY`] in `d` with a trajectory frame every step and a checkpoint every step or
/// three, so that some file is always being written (fewer checkpoints with a CSV, so that
/// more signals land in a frame), and waits until the first checkpoint is on disk.
fn start_heavy_run(d: &Path, traj: Traj) -> Child {
    std::fs::write(d.join("heavy.toml"), HEAVY).unwrap();
    let checkpoint_every = match traj {
        Traj::Csv => "3",
        Traj::Vtk => "1",
    };
    let mut child = carom()
        .args(["run", "heavy.toml", "--out", "final.csv"])
        .args([
            "--checkpoint",
            "ck.bin",
            "--checkpoint-every",
            checkpoint_every,
        ])
        .args(["--trajectory", traj.file(), "--every", "1"])
        .current_dir(d)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until(&mut child, "the first checkpoint", || {
        d.join("ck.bin").exists()
    });
    child
}

/// Ctrl-C twice: the first asks for a graceful stop (carom says so on stderr), the second,
/// sent as soon as carom has said it, quits at once. Returns whether it did (rather than the
/// graceful stop finishing first) after checking the exit status and the files.
fn double_ctrl_c(traj: Traj, attempt: u32) -> bool {
    const N: usize = HEAVY_N;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut child = start_heavy_run(d, traj);
    let (tx, rx) = std::sync::mpsc::channel();
    let stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut all = String::new();
        for line in std::io::BufReader::new(stderr).lines() {
            let line = line.unwrap();
            all.push_str(&line);
            all.push('\n');
            let _ = tx.send(line);
        }
        all
    });
    assert!(signal(&child, "-INT"));
    // wait for carom to have taken the first one, so the two cannot merge into one signal
    loop {
        match rx.recv_timeout(Duration::from_secs(600)) {
            Ok(line) if line.contains("interrupted: stopping") => break,
            Ok(_) => {}
            Err(e) => panic!("carom never acknowledged the first Ctrl-C ({e})"),
        }
    }
    signal(&child, "-INT"); // may come too late: the graceful stop may be done already
    let status = child.wait().unwrap();
    let err = reader.join().unwrap();
    let context = format!("{traj:?}, attempt {attempt}: {err}");
    assert_eq!(status.code(), Some(130), "{context}");
    let at_once = err.contains("interrupted again: quitting at once");
    // no temporaries anywhere, and every file there is whole
    let frames = check_files_on_disk(d, traj, N, 1, Ending::AtOnce, &context);
    let ck = d.join("ck.bin");
    let bytes = std::fs::read(&ck).unwrap();
    let at = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    assert!(at >= 1, "{context}");
    eprintln!(
        "{traj:?}, attempt {attempt}: {}, checkpoint at step {at}, frames 0..={}",
        if at_once {
            "quit at once"
        } else {
            "graceful stop first"
        },
        frames.last().unwrap()
    );
    // the checkpoint resumes
    ok(carom().current_dir(d).args([
        "resume",
        "ck.bin",
        "--steps",
        &(at + 1).to_string(),
        "--out",
        "resumed.csv",
    ]));
    let resumed = std::fs::read_to_string(d.join("resumed.csv")).unwrap();
    let (_, rows) = carom_output::read_state_csv(&resumed).unwrap();
    assert_eq!(rows.len(), N, "{context}");
    at_once
}

fn second_ctrl_c_quits_at_once(traj: Traj) {
    // The second Ctrl-C is sent as soon as carom has acknowledged the first; the graceful stop
    // rarely finishes before it lands, but it may on a loaded machine. Every attempt, either
    // way, must leave only whole files and exit with 130; at least one must have quit at once.
    // Several attempts, because each lands at another point of the writes.
    let mut at_once = 0;
    for attempt in 1..=8 {
        at_once += double_ctrl_c(traj, attempt) as u32;
        if attempt >= 4 && at_once > 0 {
            break;
        }
    }
    assert!(at_once > 0, "the second Ctrl-C never quit at once");
}

#[test]
fn second_ctrl_c_quits_at_once_leaving_whole_files_csv() {
    second_ctrl_c_quits_at_once(Traj::Csv);
}

#[test]
fn second_ctrl_c_quits_at_once_leaving_whole_files_vtk() {
    second_ctrl_c_quits_at_once(Traj::Vtk);
}

/// SIGKILL while files are being written all the time: whatever is on disk is whole.
fn sigkill_during_heavy_writes(traj: Traj) {
    for attempt in 1..=4 {
        let ms = random_ms(300);
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let mut child = start_heavy_run(d, traj);
        std::thread::sleep(Duration::from_millis(ms));
        child.kill().unwrap();
        child.wait().unwrap();
        let context =
            format!("{traj:?}, attempt {attempt}: SIGKILL {ms} ms after the first checkpoint");
        let frames = check_files_on_disk(d, traj, HEAVY_N, 1, Ending::Killed, &context);
        eprintln!("{context}: frames 0..={}", frames.last().unwrap());
    }
}

#[test]
fn sigkill_during_heavy_writes_leaves_only_whole_files_csv() {
    sigkill_during_heavy_writes(Traj::Csv);
}

#[test]
fn sigkill_during_heavy_writes_leaves_only_whole_files_vtk() {
    sigkill_during_heavy_writes(Traj::Vtk);
}
