//! Periodic scenes end to end: the real `carom` binary on `scenes/periodic_*.toml` and on
//! scenes with bad `[domain] periodic` values.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn carom() -> Command {
    Command::new(env!("CARGO_BIN_EXE_carom"))
}

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

fn ok(args: &[&str]) -> Output {
    let out = carom().args(args).output().expect("carom starts");
    assert!(
        out.status.success(),
        "carom {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs `scene` to a CSV with `extra` flags and returns the file's bytes.
fn run_to_csv(dir: &Path, scene: &Path, extra: &[&str]) -> Vec<u8> {
    let out = dir.join("out.csv");
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    ok(&args);
    let bytes = std::fs::read(&out).unwrap();
    std::fs::remove_file(&out).unwrap();
    bytes
}

/// The rows of a final-state CSV (id, position, velocity, radius, mass).
fn rows(csv: &[u8]) -> Vec<Vec<f64>> {
    String::from_utf8_lossy(csv)
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect()
}

#[test]
fn the_periodic_gas_runs_stays_in_its_box_and_keeps_its_energy() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scenes().join("periodic_gas.toml");
    let start = rows(&run_to_csv(dir.path(), &scene, &["--steps", "0"]));
    let grid = run_to_csv(dir.path(), &scene, &["--steps", "150"]);
    let end = rows(&grid);
    assert_eq!(end.len(), 2000);
    // columns: id, x, y, vx, vy, radius, mass; the box is [-90, 90) on both axes
    for r in &end {
        assert!(
            (-90.0..90.0).contains(&r[1]) && (-90.0..90.0).contains(&r[2]),
            "{r:?}"
        );
    }
    let energy = |rows: &[Vec<f64>]| -> f64 {
        rows.iter()
            .map(|r| 0.5 * r[6] * (r[3] * r[3] + r[4] * r[4]))
            .sum()
    };
    let (e0, e1) = (energy(&start), energy(&end));
    assert!(((e1 - e0) / e0).abs() < 1e-10, "{e0} -> {e1}");
    // some disc has crossed a seam: it moved farther than it can in 150 steps, as seen in the box
    let crossed = start
        .iter()
        .zip(&end)
        .filter(|(a, b)| (a[1] - b[1]).abs() > 100.0 || (a[2] - b[2]).abs() > 100.0)
        .count();
    assert!(crossed > 0, "nobody crossed a seam");
    // brute force and two threads write the very same file
    let brute = run_to_csv(
        dir.path(),
        &scene,
        &["--steps", "150", "--broadphase", "brute"],
    );
    assert!(grid == brute, "grid and brute force differ");
    let one = run_to_csv(dir.path(), &scene, &["--steps", "150", "--threads", "1"]);
    assert!(grid == one, "1 thread and the default differ");
}

#[test]
fn a_periodic_run_resumes_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scenes().join("periodic_slab_3d.toml");
    let straight = run_to_csv(dir.path(), &scene, &["--steps", "130"]);
    let ck = dir.path().join("ck.bin");
    ok(&[
        "run",
        scene.to_str().unwrap(),
        "--steps",
        "130",
        "--checkpoint",
        ck.to_str().unwrap(),
        "--checkpoint-every",
        "100",
    ]);
    let out = dir.path().join("resumed.csv");
    ok(&[
        "resume",
        ck.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        std::fs::read(&out).unwrap() == straight,
        "resumed run differs"
    );
}

/// Exit 2, the message on stderr containing every one of `needles`, and no file but the scene.
fn assert_refused(scene_text: &str, extra: &[&str], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.toml");
    std::fs::write(&scene, scene_text).unwrap();
    let out_file = dir.path().join("out.csv");
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--out",
        out_file.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let out = carom().args(&args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{scene_text}\n{args:?}\n{stderr}"
    );
    for needle in needles {
        assert!(stderr.contains(needle), "{needle:?} not in: {stderr}");
    }
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "only the scene file is left ({args:?})"
    );
}

const GAS: &str = "dimensions = 2\ndt = 0.01\nsteps = 5\n\
                   [domain]\nmin = [0.0, 0.0]\nmax = [20.0, 20.0]\nPERIODIC\n\
                   [[fill]]\ncount = 40\nradius = 0.5\nspeed = 3.0\n";

#[test]
fn bad_periodic_values_name_the_file_and_the_field() {
    for bad in [
        "periodic = [true]",
        "periodic = [true, false, true]",
        "periodic = [1, 0]",
        "periodic = [\"yes\", true]",
        "periodic = true",
    ] {
        assert_refused(
            &GAS.replace("PERIODIC", bad),
            &[],
            &["bad.toml", "domain.periodic"],
        );
    }
    // 20 long, radius 3: too short to tell the images apart
    assert_refused(
        &GAS.replace("PERIODIC", "periodic = [false, true]")
            .replace("count = 40\nradius = 0.5", "count = 2\nradius = 3.0"),
        &[],
        &["bad.toml", "domain.periodic", "must be longer than"],
    );
    assert_refused(
        &GAS.replace(
            "PERIODIC",
            "periodic = [true, true]\n[broadphase]\nkind = \"hash\"",
        ),
        &[],
        &["bad.toml", "broadphase.kind", "periodic"],
    );
    // a good scene, then refused by the flags
    let good = GAS.replace("PERIODIC", "periodic = [true, true]");
    assert_refused(&good, &["--broadphase", "hash"], &["bad.toml", "periodic"]);
    assert_refused(&good, &["--ranks", "2"], &["bad.toml", "periodic", "ranks"]);
}

#[test]
fn periodic_scenes_check() {
    for scene in ["periodic_gas.toml", "periodic_slab_3d.toml"] {
        let out = ok(&["check", scenes().join(scene).to_str().unwrap()]);
        assert!(String::from_utf8_lossy(&out.stdout).contains("ok"));
    }
}
