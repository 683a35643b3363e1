//! Long runs lose nothing: checkpoints, resume, Ctrl-C and SIGKILL, on the real binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

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

/// Reads a trajectory CSV up to its last whole frame: (frames, particles per frame).
fn whole_frames(text: &str, particles: usize) -> Vec<u64> {
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), "step,time,id,x,y,vx,vy,radius,mass");
    let rows: Vec<&str> = lines.collect();
    let mut frames = Vec::new();
    for frame in rows.chunks(particles) {
        let complete = frame.len() == particles
            && frame.iter().all(|l| {
                l.split(',').count() == 9 && l.split(',').all(|f| f.parse::<f64>().is_ok())
            });
        if !complete {
            break;
        }
        let step: u64 = frame[0].split(',').next().unwrap().parse().unwrap();
        assert!(frame.iter().all(|l| l.starts_with(&format!("{step},"))));
        frames.push(step);
    }
    frames
}

fn interrupted_run(dir: &Path, signal: Option<&str>, after: Duration) {
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
            "traj.csv",
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
    std::thread::sleep(after);
    match signal {
        Some(sig) => {
            assert!(Command::new("kill")
                .args([sig, &child.id().to_string()])
                .status()
                .unwrap()
                .success());
            let out = child.wait_with_output().unwrap();
            assert_eq!(
                out.status.code(),
                Some(130),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        None => {
            child.kill().unwrap(); // SIGKILL
            child.wait().unwrap();
        }
    }
    // whatever is on disk is whole: no final output (the run never finished), no temporaries
    assert!(!dir.join("final.csv").exists());
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        assert!(!name.ends_with(".tmp"), "temporary left behind: {name}");
    }
    let frames = whole_frames(
        &std::fs::read_to_string(dir.join("traj.csv")).unwrap(),
        5000,
    );
    assert!(!frames.is_empty());
    assert!(
        frames.iter().enumerate().all(|(k, &s)| s == 100 * k as u64),
        "{frames:?}"
    );
}

#[test]
fn ctrl_c_and_sigterm_stop_cleanly_and_resume_exactly() {
    for (k, sig) in ["-INT", "-TERM"].into_iter().enumerate() {
        let dir = tempfile::tempdir().unwrap();
        interrupted_run(
            dir.path(),
            Some(sig),
            Duration::from_millis(700 + 300 * k as u64),
        );
        // the checkpoint holds the step the run stopped at; resume it to a short total and
        // compare with a straight run to the same total
        let ck = dir.path().join("ck.bin");
        let stopped_at = {
            let bytes = std::fs::read(&ck).unwrap();
            u64::from_le_bytes(bytes[16..24].try_into().unwrap())
        };
        assert!(stopped_at > 0);
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
        assert_eq!(std::fs::read(&out).unwrap(), expected, "{sig}");
    }
}

#[test]
fn sigkill_at_random_points_leaves_only_whole_files() {
    for ms in [150u64, 420, 900] {
        let dir = tempfile::tempdir().unwrap();
        interrupted_run(dir.path(), None, Duration::from_millis(ms));
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
            assert_eq!(std::fs::read(&out).unwrap(), clean, "killed after {ms} ms");
        }
    }
}
