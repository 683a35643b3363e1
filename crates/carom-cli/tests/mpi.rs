//! `mpirun -np P carom run`: real MPI processes (needs `--features mpi` and an MPI
//! installation; `.ci/run` installs Open MPI and runs `cargo test -p carom-cli --features mpi
//! --test mpi`). Each run on 1, 2 and 4 ranks must write the very bytes a single process
//! writes.
#![cfg(feature = "mpi")]

mod support;
use support::scene;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const CAROM: &str = env!("CARGO_BIN_EXE_carom");

/// `mpirun` with a session directory of its own: Open MPI keeps one per user under `TMPDIR`,
/// and runs started side by side (the tests run in parallel) removed it under each other
/// ("A call to mkdir was unable to create the desired directory", seen once in CI). The
/// directory lives as long as the returned guard.
fn mpirun_command() -> (Command, tempfile::TempDir) {
    let session = tempfile::tempdir().unwrap();
    let mut command = Command::new("mpirun");
    command.env("TMPDIR", session.path());
    (command, session)
}

/// `mpirun -np ranks carom args...`, allowed as root and with more ranks than cores (CI
/// machines have two). A deadlocked run fails the test after three minutes.
fn mpirun(ranks: usize, args: &[&str]) -> Output {
    let (mut command, _session) = mpirun_command();
    support::run_guarded(
        command
            .args([
                "--allow-run-as-root",
                "--oversubscribe",
                "-np",
                &ranks.to_string(),
                CAROM,
            ])
            .args(args),
        std::time::Duration::from_secs(180),
    )
}

fn ok(out: Output, what: &str) -> String {
    assert!(
        out.status.success(),
        "{what} failed ({:?}): {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr),
        String::from_utf8_lossy(&out.stdout)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn outputs(dir: &Path) -> [PathBuf; 3] {
    [
        dir.join("final.csv"),
        dir.join("run.pvd"),
        dir.join("state.ckpt"),
    ]
}

fn args<'a>(scene: &'a str, steps: &'a str, p: &'a [String; 3]) -> Vec<&'a str> {
    vec![
        "run",
        scene,
        "--steps",
        steps,
        "--out",
        &p[0],
        "--trajectory",
        &p[1],
        "--every",
        "50",
        "--checkpoint",
        &p[2],
        "--checkpoint-every",
        "60",
    ]
}

/// Every file under `dir`, relative, with its bytes.
fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().to_path_buf();
                files.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    files.sort();
    files
}

#[test]
fn one_two_and_four_ranks_write_the_single_process_files() {
    for (file, steps, ranks) in [
        ("lecture_5000_grid100.toml", "200", &[1usize, 2, 4][..]),
        ("lecture_mixed_radii.toml", "150", &[2, 4][..]),
        ("box_3d.toml", "100", &[2][..]),
    ] {
        let path = scene(file);
        let single = tempfile::tempdir().unwrap();
        let p = outputs(single.path()).map(|p| p.display().to_string());
        ok(
            Command::new(CAROM)
                .args(args(&path, steps, &p))
                .output()
                .unwrap(),
            "single process",
        );
        let want = tree(single.path());
        assert!(want.len() >= 4, "outputs missing: {want:?}");
        for &r in ranks {
            let dir = tempfile::tempdir().unwrap();
            let q = outputs(dir.path()).map(|p| p.display().to_string());
            let summary = ok(
                mpirun(r, &args(&path, steps, &q)),
                &format!("{file} on {r} ranks"),
            );
            if r > 1 {
                assert!(
                    summary.contains(&format!("ranks       {r} (particles per rank:")),
                    "{summary}"
                );
                // rank 0 alone prints the summary
                assert_eq!(
                    summary.matches("particles per rank").count(),
                    1,
                    "{summary}"
                );
            }
            let got = tree(dir.path());
            let names =
                |t: &[(PathBuf, Vec<u8>)]| t.iter().map(|f| f.0.clone()).collect::<Vec<_>>();
            assert_eq!(
                names(&got),
                names(&want),
                "{file} on {r} ranks: other files"
            );
            for ((name, a), (_, b)) in want.iter().zip(&got) {
                assert!(a == b, "{file} on {r} ranks: {} differs", name.display());
            }
        }
    }
}

#[test]
fn bad_input_under_mpirun_fails_once_with_status_2() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "dimensions = 2\ndt = -1.0\n").unwrap();
    let out = mpirun(2, &["run", bad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.matches("carom: error").count(), 1, "{stderr}");
    assert!(stderr.contains("bad.toml"), "{stderr}");
}

#[test]
fn ranks_flag_is_refused_under_mpirun() {
    let out = mpirun(2, &["run", "--steps", "1", "--ranks", "2"]);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
}

#[test]
fn resume_under_mpirun_splits_and_matches() {
    let path = scene("lecture_5000_grid100.toml");
    let dir = tempfile::tempdir().unwrap();
    let d = |f: &str| dir.path().join(f).display().to_string();
    let (straight, ckpt, resumed) = (d("straight.csv"), d("state.ckpt"), d("resumed.csv"));
    ok(
        Command::new(CAROM)
            .args(["run", &path, "--steps", "160", "--out", &straight])
            .output()
            .unwrap(),
        "straight run",
    );
    ok(
        mpirun(
            2,
            &[
                "run",
                &path,
                "--steps",
                "100",
                "--checkpoint",
                &ckpt,
                "--checkpoint-every",
                "50",
            ],
        ),
        "2-rank run to step 100",
    );
    let summary = ok(
        mpirun(4, &["resume", &ckpt, "--steps", "160", "--out", &resumed]),
        "4-rank resume",
    );
    assert!(summary.contains("ranks       4"), "{summary}");
    assert_eq!(
        std::fs::read(&resumed).unwrap(),
        std::fs::read(&straight).unwrap()
    );
}

#[test]
fn other_commands_refuse_to_run_on_many_ranks() {
    let out = mpirun(2, &["bench", "--quick"]);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        stderr
            .matches("only `carom run` and `carom resume`")
            .count(),
        1,
        "{stderr}"
    );
}

#[test]
fn ctrl_c_to_mpirun_stops_every_rank_at_one_step_with_a_checkpoint() {
    let path = scene("lecture_5000_grid100.toml");
    let dir = tempfile::tempdir().unwrap();
    let ckpt = dir.path().join("state.ckpt");
    let (mut command, _session) = mpirun_command();
    let mut child = command
        .args(["--allow-run-as-root", "--oversubscribe", "-np", "2", CAROM])
        .args(["run", &path, "--steps", "100000000", "--checkpoint"])
        .arg(&ckpt)
        .args(["--checkpoint-every", "200"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // the run is under way once its first checkpoint is on disk
    let started = std::time::Instant::now();
    while !ckpt.exists() {
        assert!(
            started.elapsed().as_secs() < 120,
            "no checkpoint after two minutes"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .unwrap()
        .success());
    let started = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed().as_secs() > 120 {
            let _ = child.kill();
            panic!("mpirun did not stop within two minutes of Ctrl-C");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    // (mpirun's own status after a Ctrl-C is Open MPI's; the ranks exit with 130)
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.matches("carom: interrupted:").count(), 1, "{stderr}");
    let at: u64 = stderr
        .split("interrupted after step ")
        .nth(1)
        .and_then(|rest| rest.split(';').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no stop step in: {stderr}"));
    // the checkpoint holds step `at` on both ranks' behalf: resumed alone, it continues as a
    // straight single-process run does
    let target = (at + 37).to_string();
    let (resumed, straight) = (
        dir.path().join("resumed.csv"),
        dir.path().join("straight.csv"),
    );
    ok(
        Command::new(CAROM)
            .args([
                "resume",
                ckpt.to_str().unwrap(),
                "--steps",
                &target,
                "--out",
            ])
            .arg(&resumed)
            .output()
            .unwrap(),
        "resume",
    );
    ok(
        Command::new(CAROM)
            .args(["run", &path, "--steps", &target, "--out"])
            .arg(&straight)
            .output()
            .unwrap(),
        "straight run",
    );
    assert_eq!(
        std::fs::read(&resumed).unwrap(),
        std::fs::read(&straight).unwrap()
    );
}
