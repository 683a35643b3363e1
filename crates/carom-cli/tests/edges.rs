//! Edge cases a review of the binary found (thirty-eighth sitting): outputs that reach an input
//! by a link or name a device, checks that came only after the scene's fill or after the run,
//! a lattice fill that never ended, and checkpoints whose checksum holds over values no scene
//! file may give. Each is refused with exit status 2 and one message naming the flag, field or
//! file, and leaves no file behind.

use carom_output::checkpoint::Checkpoint;
use std::path::Path;
use std::process::Output;

mod refusals;

use refusals::{carom, newton_cradle};

/// Runs `args` in `dir` with `env`.
fn run_in(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    carom()
        .args(args)
        .envs(env.iter().copied())
        .current_dir(dir)
        .output()
        .unwrap()
}

/// See [`refusals::refusal`] (some of these take a second: a lattice fill's sites, a view's
/// scene).
fn refused_in(dir: &Path, args: &[&str], env: &[(&str, &str)], says: &[&str]) {
    refusals::refusal(dir, args, env, says);
}

/// A folder holding the Newton's cradle scene as `scene.toml`.
fn with_scene() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(newton_cradle(), dir.path().join("scene.toml")).unwrap();
    dir
}

/// [`with_scene`], and `ck.bin` its checkpoint at step 10.
fn with_checkpoint() -> tempfile::TempDir {
    let dir = with_scene();
    let run = [
        "run",
        "scene.toml",
        "--steps",
        "10",
        "--checkpoint",
        "ck.bin",
    ];
    let out = run_in(
        dir.path(),
        &[&run[..], &["--checkpoint-every", "10"]].concat(),
        &[],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    dir
}

#[cfg(unix)]
#[test]
fn an_output_naming_the_scene_through_a_link_is_refused() {
    let dir = with_scene();
    let d = dir.path();
    std::os::unix::fs::symlink("scene.toml", d.join("link.toml")).unwrap();
    refused_in(
        d,
        &["run", "link.toml", "--out", "scene.toml"],
        &[],
        &["--out", "scene file"],
    );
    refused_in(
        d,
        &["run", "scene.toml", "--out", "link.toml"],
        &[],
        &["--out", "scene file"],
    );
    std::fs::copy(newton_cradle(), d.join("scene.png")).unwrap();
    std::os::unix::fs::symlink("scene.png", d.join("link.png")).unwrap();
    refused_in(
        d,
        &["render", "link.png", "--out", "scene.png"],
        &[],
        &["scene file"],
    );
    assert_eq!(
        std::fs::read(d.join("scene.toml")).unwrap(),
        std::fs::read(newton_cradle()).unwrap()
    );
}

#[test]
fn render_refuses_to_write_over_its_scene() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(newton_cradle(), d.join("scene.png")).unwrap();
    refused_in(
        d,
        &["render", "scene.png", "--out", "scene.png"],
        &[],
        &["--out", "scene file"],
    );
}

/// A named pipe in place of an output was replaced by a regular file (and so was `/dev/null`,
/// when run as root).
#[cfg(unix)]
#[test]
fn an_output_that_is_not_a_regular_file_is_refused() {
    let dir = with_scene();
    let d = dir.path();
    let fifo = std::ffi::CString::new(d.join("pipe").to_str().unwrap()).unwrap();
    // SAFETY: `mkfifo` reads the path, a NUL-terminated string that outlives the call.
    assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o600) }, 0, "mkfifo");
    refused_in(
        d,
        &["run", "scene.toml", "--out", "pipe"],
        &[],
        &["--out", "not a regular file"],
    );
    assert!(!d.join("pipe").is_file(), "the pipe is still a pipe");
    // (read as a scene or a checkpoint, it waited for a writer for good)
    refused_in(d, &["check", "pipe"], &[], &["pipe", "not a regular file"]);
    refused_in(d, &["resume", "pipe"], &[], &["pipe", "not a regular file"]);
}

#[test]
fn resume_keeps_its_checkpoint_to_apart_from_its_other_outputs() {
    let dir = with_checkpoint();
    let d = dir.path();
    refused_in(
        d,
        &[
            "resume",
            "ck.bin",
            "--steps",
            "20",
            "--out",
            "x.bin",
            "--checkpoint-to",
            "x.bin",
            "--checkpoint-every",
            "5",
        ],
        &[],
        &["--checkpoint-to", "--out"],
    );
    // (over the checkpoint being read is how a long run goes on)
    let on = run_in(
        d,
        &[
            "resume",
            "ck.bin",
            "--steps",
            "20",
            "--checkpoint-to",
            "ck.bin",
            "--checkpoint-every",
            "5",
        ],
        &[],
    );
    assert!(
        on.status.success(),
        "{}",
        String::from_utf8_lossy(&on.stderr)
    );
}

/// A VTK trajectory `v.pvd` writes its frames in the folder `v`: another output of that
/// name failed after the run, and a file `v` in the way was reported as `v.pvd`.
#[test]
fn a_vtk_trajectory_keeps_its_frame_folder_apart() {
    let dir = with_scene();
    let d = dir.path();
    let vtk = ["run", "scene.toml", "--trajectory", "v.pvd", "--every", "1"];
    refused_in(
        d,
        &[&vtk[..], &["--out", "v"]].concat(),
        &[],
        &["--out", "frame folder"],
    );
    let ck = ["--checkpoint", "v", "--checkpoint-every", "5"];
    refused_in(
        d,
        &[&vtk[..], &ck[..]].concat(),
        &[],
        &["--checkpoint", "frame folder"],
    );
    std::fs::write(d.join("v"), "in the way").unwrap();
    refused_in(
        d,
        &vtk,
        &[],
        &["--trajectory", "the folder its frames go in"],
    );
}

#[test]
fn bench_refuses_a_plot_of_a_sweep_it_does_not_run_before_running() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    refused_in(
        d,
        &[
            "bench", "--quick", "--only", "lecture", "--plot", "p.png", "--out", "b.json",
        ],
        &[],
        &["--plot"],
    );
    refused_in(
        d,
        &["bench", "--quick", "--out", "same", "--plot", "same"],
        &[],
        &["--plot"],
    );
}

#[test]
fn check_and_view_bound_the_threads_of_the_environment() {
    let dir = with_scene();
    let env = [("RAYON_NUM_THREADS", "100000")];
    refused_in(
        dir.path(),
        &["check", "scene.toml"],
        &env,
        &["RAYON_NUM_THREADS"],
    );
    refused_in(
        dir.path(),
        &["view", "scene.toml"],
        &env,
        &["RAYON_NUM_THREADS"],
    );
}

/// Tiny particles on a lattice behind one large particle: the fill went through every site
/// the large one covers (10^24) and never ended.
#[test]
fn a_lattice_fill_that_finds_no_room_ends_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "dimensions = 2\ndt = 0.01\n\
                 [[particles]]\nposition = [-1000.0, -1000.0]\nradius = 1000.0\n\
                 [[fill]]\ncount = 1\nradius = 1e-9\nmin = [-1000.0, -1000.0]\n\
                 max = [1000.0, 1000.0]\narrangement = \"lattice\"\n";
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    refused_in(
        dir.path(),
        &["check", "s.toml"],
        &[],
        &["s.toml", "fill[0].count", "lattice sites"],
    );
}

/// A checkpoint is checked as a scene file is: its checksum says the bytes arrived as
/// written, not that the values in them are sane.
#[test]
fn a_checkpoint_with_values_no_scene_may_give_is_refused() {
    let dir = with_checkpoint();
    let d = dir.path();
    let good = Checkpoint::read_from(&std::fs::read(d.join("ck.bin")).unwrap()).unwrap();
    type Damage = fn(&mut Checkpoint);
    let damages: [(&str, Damage, &str); 6] = [
        ("velocity", |c| c.velocities[0] = 1e300, "velocity"),
        ("radius", |c| c.radii[1] = 1e300, "radius"),
        ("mass", |c| c.masses[1] = 5e-324, "mass"),
        ("steps", |c| c.steps_taken = 1 << 62, "past the limit"),
        (
            "settings",
            |c| c.settings_json = c.settings_json.replace("null", "\"octree\""),
            "run settings",
        ),
        ("tally", |c| c.tally.thermal = f64::NAN, "thermal"),
    ];
    for (name, damage, says) in damages {
        let mut cp = good.clone();
        damage(&mut cp);
        let mut bytes = Vec::new();
        cp.write_to(&mut bytes).unwrap();
        let file = format!("{name}.bin");
        std::fs::write(d.join(&file), bytes).unwrap();
        refused_in(d, &["resume", &file, "--out", "f.csv"], &[], &[&file, says]);
    }
}

/// Flags that need nothing of the scene are checked before its fill, which may take seconds:
/// a scene whose fill could never finish shows which comes first.
#[test]
fn flags_are_checked_before_the_scene_is_filled() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = "dimensions = 2\ndt = 0.01\n[domain]\nmin = [0.0, 0.0]\nmax = [10.0, 10.0]\n\
                 walls = true\n[[fill]]\ncount = 1000\nradius = 1.0\n";
    std::fs::write(d.join("full.toml"), scene).unwrap();
    let full = ["run", "full.toml"];
    for (flags, says) in [
        (&["--trajectory", "t.csv", "--every", "0"][..], "--every"),
        (
            &["--checkpoint", "c.bin", "--checkpoint-every", "0"][..],
            "--checkpoint-every",
        ),
        (
            &["--trajectory", "no/t.csv", "--every", "1"][..],
            "--trajectory",
        ),
        (
            &["--observe", "o.csv", "--every", "1", "--ranks", "2"][..],
            "--observe",
        ),
    ] {
        refused_in(d, &[&full[..], flags].concat(), &[], &[says]);
    }
    // (and those that need of the scene only what its text says: its axes, its steps)
    refused_in(
        d,
        &["run", "full.toml", "--cells", "5,5,5"],
        &[],
        &["--cells", "2D"],
    );
    // (cells for a broad phase without them: asked for, or the default of a box without walls)
    let brute = [
        "run",
        "full.toml",
        "--cells",
        "5,5",
        "--broadphase",
        "brute",
    ];
    refused_in(d, &brute, &[], &["--cells", "only the grid"]);
    std::fs::write(
        d.join("open.toml"),
        scene.replace("walls = true", "walls = false"),
    )
    .unwrap();
    let hash = ["run", "open.toml", "--cells", "5,5"];
    refused_in(d, &hash, &[], &["--cells", "only the grid"]);
    let periodic = scene.replace("walls = true", "periodic = [true, true]");
    std::fs::write(d.join("wraps.toml"), periodic).unwrap();
    let hash = ["run", "wraps.toml", "--broadphase", "hash"];
    refused_in(d, &hash, &[], &["--broadphase", "periodic"]);
    let render = ["render", "full.toml", "--steps", "10", "--every", "50"];
    refused_in(
        d,
        &[&render[..], &["--out", "r.gif"]].concat(),
        &[],
        &["--every"],
    );
}

/// A machine that cannot start the worker threads (here: no room for their stacks, which
/// `RUST_MIN_STACK` sizes; a low `ulimit -u` does the same) gets one message and exit status
/// 1 from every command that steps, not a panic in the first parallel phase, and no output.
#[test]
fn threads_that_cannot_start_are_an_error_not_a_panic() {
    let dir = with_scene();
    let huge_stacks = [("RUST_MIN_STACK", "1000000000000000")];
    let commands: [&[&str]; 4] = [
        &["run", "scene.toml", "--steps", "3", "--out", "end.csv"],
        &["run", "scene.toml", "--steps", "3", "--threads", "2"],
        &["check", "scene.toml"],
        &["run", "scene.toml", "--steps", "3", "--ranks", "2"],
    ];
    for args in commands {
        let output = run_in(dir.path(), args, &huge_stacks);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains("threads: "), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{args:?}: {stderr}");
    }
    assert_eq!(refusals::listing(dir.path()), ["scene.toml"]);
}
