//! End-to-end tests: the real `carom` binary on real scene files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn carom() -> Command {
    Command::new(env!("CARGO_BIN_EXE_carom"))
}

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

fn run_ok(args: &[&str]) -> Output {
    let out = carom().args(args).output().expect("carom starts");
    assert!(
        out.status.success(),
        "carom {args:?} failed: {}\n{}",
        String::from_utf8_lossy(&out.stderr),
        String::from_utf8_lossy(&out.stdout)
    );
    out
}

/// Runs a scene to a CSV and returns the rows (numbers, id column included).
fn final_state(scene: &Path, extra: &[&str]) -> Vec<Vec<f64>> {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("final.csv");
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    run_ok(&args);
    let text = std::fs::read_to_string(&out).unwrap();
    carom_rows(&text)
}

fn carom_rows(text: &str) -> Vec<Vec<f64>> {
    text.lines()
        .skip(1)
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect()
}

fn assert_close(got: f64, want: f64, what: &str) {
    assert!((got - want).abs() < 1e-9, "{what}: got {got}, want {want}");
}

#[test]
fn lecture_worked_example_1() {
    let rows = final_state(&scenes().join("lecture_example_1.toml"), &[]);
    let s3 = 3f64.sqrt();
    // columns: id,x,y,vx,vy,radius,mass
    assert_close(rows[0][3], 5.0, "v1'.x");
    assert_close(rows[0][4], 5.0 * s3, "v1'.y");
    assert_close(rows[1][3], 15.0, "v2'.x");
    assert_close(rows[1][4], -5.0 * s3, "v2'.y");
}

#[test]
fn lecture_worked_example_2() {
    let rows = final_state(&scenes().join("lecture_example_2.toml"), &[]);
    let s3 = 3f64.sqrt();
    assert_close(rows[0][3], -10.0, "v1'.x");
    assert_close(rows[0][4], 10.0 * s3, "v1'.y");
    assert_close(rows[1][3], 5.0, "v2'.x");
    assert_close(rows[1][4], -5.0 * s3, "v2'.y");
}

#[test]
fn newton_cradle_2d_and_3d() {
    for (file, dim) in [("newton_cradle.toml", 2), ("newton_cradle_3d.toml", 3)] {
        let rows = final_state(&scenes().join(file), &[]);
        let vx = 1 + dim; // id, x.., vx
        let last = rows.last().unwrap();
        assert_close(last[vx], 5.0, &format!("{file}: last ball vx"));
        for row in &rows[..rows.len() - 1] {
            for a in 0..dim {
                assert_close(row[vx + a], 0.0, &format!("{file}: ball {} v", row[0]));
            }
        }
    }
}

#[test]
fn every_shipped_scene_checks_and_runs() {
    let mut n = 0;
    for entry in std::fs::read_dir(scenes()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            n += 1;
            let p = path.to_str().unwrap();
            run_ok(&["check", p]);
            let out = run_ok(&["run", p, "--steps", "3"]);
            let text = String::from_utf8(out.stdout).unwrap();
            assert!(
                text.contains("energy") && text.contains("ms per step"),
                "{text}"
            );
        }
    }
    assert!(n >= 13, "only {n} scenes");
}

#[test]
fn default_scene_runs_with_a_summary() {
    let out = run_ok(&["run", "--steps", "20"]);
    let text = String::from_utf8(out.stdout).unwrap();
    for key in [
        "scene",
        "particles   100 (2D)",
        "steps       20",
        "ms per step",
        "kinetic",
        "momentum",
    ] {
        assert!(text.contains(key), "missing {key:?} in:\n{text}");
    }
    assert!(out.stderr.is_empty(), "no progress bar when not a terminal");
}

/// The summary names the cells the search used: those the scene asks for, or those the last
/// step derived from its reaches (it printed those the end's overlap search fitted to the
/// radii alone, and "grid 1x1" for a run of no steps, which lays out no cells).
#[test]
fn the_summary_names_the_cells_the_steps_searched() {
    let line = |args: &[&str]| {
        let out = run_ok(args);
        let text = String::from_utf8(out.stdout).unwrap();
        let line = text.lines().find(|l| l.starts_with("particles"));
        line.unwrap_or_else(|| panic!("no particles line in:\n{text}"))
            .to_string()
    };
    let asked = scenes().join("lecture_5000_grid100.toml");
    let asked = asked.to_str().unwrap();
    for steps in ["0", "2"] {
        let text = line(&["run", asked, "--steps", steps]);
        assert!(text.contains("broad phase grid 100x100, "), "{text}");
    }
    let text = line(&["run", "--steps", "0"]);
    assert!(
        text.contains("broad phase grid, cells derived each step, "),
        "{text}"
    );
    // (the default scene's reaches, its radii swept over a step's motion, take 10 cells a
    // side where its radii alone take 20)
    let text = line(&["run", "--steps", "2"]);
    assert!(
        text.contains("broad phase grid 10x10 (derived: the last step's), "),
        "{text}"
    );
}

/// The summary line of `text` that starts with `key`, and the numbers in it in order.
fn summary_numbers<'a>(text: &'a str, key: &str) -> (&'a str, Vec<f64>) {
    let line = text
        .lines()
        .find(|l| l.starts_with(key))
        .unwrap_or_else(|| panic!("no {key} line in:\n{text}"));
    let numbers = line
        .split([' ', ',', ';', '%'])
        .filter_map(|w| w.parse().ok())
        .collect();
    (line, numbers)
}

/// The default scene's pile rests a hair apart: the summary counts its pairs as pushing, not
/// as overlapping (it read "0.00 per step on average" while up to 152 pairs held the pile up).
#[test]
fn the_summary_counts_a_resting_pile_as_pushing() {
    let out = run_ok(&["run"]);
    let text = String::from_utf8(out.stdout).unwrap();
    // "contacts    A overlapping per step on average, B at most; C pushing, D at most..."
    let (line, numbers) = summary_numbers(&text, "contacts");
    let [overlapping, _, pushing, most_pushing] = numbers[..4] else {
        panic!("{line}")
    };
    assert!(
        line.contains("overlapping") && line.contains("pushing"),
        "{line}"
    );
    assert!(pushing > 10.0 * overlapping.max(0.1), "{line}");
    assert!(most_pushing >= 100.0, "{line}");
}

/// The lecture's 5000-disc demo, scaled to 500 discs: at `k = 1` under gravity the lecture's
/// step leaves pairs that pushes drove together deep in each other (22.8 % of r at most,
/// measured), and `[solver] cover_pushes = true` keeps every state within 0.42 %.
#[test]
fn covering_pushes_keeps_a_dense_elastic_gas_from_sinking_into_itself() {
    let dir = tempfile::tempdir().unwrap();
    let deepest = |cover: bool| {
        let path = dir.path().join(format!("gas_{cover}.toml"));
        let scene = format!(
            "dimensions = 2\ndt = 0.005\nsteps = 600\ngravity = [0.0, -9.8]\n\
             restitution = 1.0\n[solver]\ncover_pushes = {cover}\n[domain]\n\
             min = [-31.6, -31.6]\nmax = [31.6, 31.6]\nwalls = true\n[[fill]]\n\
             count = 500\nradius = 1.0\nmass = 1.0\nspeed = 20.0\nseed = 5000\n"
        );
        std::fs::write(&path, scene).unwrap();
        let out = run_ok(&["run", path.to_str().unwrap(), "--threads", "2"]);
        let text = String::from_utf8(out.stdout).unwrap();
        // "overlap     A% of the smaller radius at the end, B% at most"
        let (line, numbers) = summary_numbers(&text, "overlap");
        *numbers.get(1).unwrap_or_else(|| panic!("{line}"))
    };
    let (lecture, covered) = (deepest(false), deepest(true));
    assert!(lecture > 5.0, "the lecture's step: {lecture} % at most");
    assert!(covered < 1.0, "covering pushes: {covered} % at most");
}

/// A particle faster than its radius a step is named in the summary, with how fast; a calm
/// run has no such line.
#[test]
fn a_particle_faster_than_its_radius_a_step_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("fast.toml");
    std::fs::write(
        &scene,
        "dimensions = 2\ndt = 0.01\n[[particles]]\nposition = [0.0, 0.0]\n\
         velocity = [300.0, 0.0]\nradius = 1.0\n",
    )
    .unwrap();
    let out = run_ok(&["run", scene.to_str().unwrap(), "--steps", "5"]);
    let text = String::from_utf8(out.stdout).unwrap();
    let line = "moves       in 5 of 5 steps a particle started faster than its radius a step \
                (at most 3.00 radii, at step 1)";
    assert!(text.contains(line), "missing {line:?} in:\n{text}");
    let calm = String::from_utf8(run_ok(&["run", "--steps", "20"]).stdout).unwrap();
    assert!(!calm.contains("moves"), "{calm}");
}

#[test]
fn grid_and_brute_force_write_identical_files() {
    // radii 1 and 3 with 2-unit cells: smaller than the largest diameter
    let scene = scenes().join("lecture_mixed_radii.toml");
    let dir = tempfile::tempdir().unwrap();
    let mut outputs = Vec::new();
    for (name, extra) in [
        ("grid", vec!["--broadphase", "grid"]),
        ("grid37", vec!["--cells", "37,29"]),
        ("hash", vec!["--broadphase", "hash"]),
        ("brute", vec!["--broadphase", "brute"]),
    ] {
        let out = dir.path().join(format!("{name}.csv"));
        let mut args = vec![
            "run",
            scene.to_str().unwrap(),
            "--steps",
            "150",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        run_ok(&args);
        outputs.push(std::fs::read(&out).unwrap());
    }
    assert_eq!(outputs[0], outputs[3], "grid 100x100 vs brute force");
    assert_eq!(outputs[1], outputs[3], "grid 37x29 vs brute force");
    assert_eq!(outputs[2], outputs[3], "hash vs brute force");
}

#[test]
fn one_and_two_threads_write_identical_files() {
    let scene = scenes().join("lecture_5000_grid100.toml");
    let dir = tempfile::tempdir().unwrap();
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.path().join(format!("t{threads}.csv"));
        run_ok(&[
            "run",
            scene.to_str().unwrap(),
            "--steps",
            "60",
            "--threads",
            threads,
            "--out",
            out.to_str().unwrap(),
        ]);
        outputs.push(std::fs::read(&out).unwrap());
    }
    assert_eq!(outputs[0], outputs[1]);
    // and RAYON_NUM_THREADS is honoured the same way
    let out = dir.path().join("env.csv");
    let status = carom()
        .args([
            "run",
            scene.to_str().unwrap(),
            "--steps",
            "60",
            "--out",
            out.to_str().unwrap(),
        ])
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    assert!(status.status.success());
    assert!(String::from_utf8_lossy(&status.stdout).contains("1 threads"));
    assert_eq!(std::fs::read(&out).unwrap(), outputs[0]);
}

#[test]
fn fills_are_reproducible_and_non_overlapping() {
    let scene = scenes().join("lecture_mixed_radii.toml");
    let a = final_state(&scene, &["--steps", "0"]);
    let b = final_state(&scene, &["--steps", "0"]);
    assert_eq!(a, b);
    assert_eq!(a.len(), 2750);
    // no two particles overlap at the start (brute force check)
    for i in 0..a.len() {
        for j in i + 1..a.len() {
            let d = ((a[i][1] - a[j][1]).powi(2) + (a[i][2] - a[j][2]).powi(2)).sqrt();
            assert!(d >= a[i][5] + a[j][5], "{i} and {j} overlap");
        }
    }
}

/// A bad scene: exit status 2, a message naming the file and the field, no output file.
fn assert_rejected(toml: &str, field: &str) {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.toml");
    std::fs::write(&scene, toml).unwrap();
    let out_file = dir.path().join("out.csv");
    let out = carom()
        .args([
            "run",
            scene.to_str().unwrap(),
            "--out",
            out_file.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{toml}\n{stderr}");
    assert!(stderr.contains("bad.toml"), "file not named: {stderr}");
    assert!(
        stderr.contains(field),
        "field {field:?} not named: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "only the scene file is left"
    );
}

const GOOD: &str = r#"
dimensions = 2
dt = 0.005
steps = 10
gravity = [0.0, -9.8]
restitution = 0.5
[domain]
min = [-10.0, -10.0]
max = [10.0, 10.0]
walls = true
[[particles]]
position = [0.0, 0.0]
velocity = [1.0, 0.0]
radius = 1.0
mass = 1.0
[[fill]]
count = 10
radius = 0.5
speed = 1.0
seed = 1
"#;

/// The scene format's reference block, every key with a value, is a scene `carom check`
/// takes (its plane once cut through its fill's region, and `carom check` refused it).
#[test]
fn the_scene_format_reference_checks() {
    let doc = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/scene-format.md");
    let doc = std::fs::read_to_string(doc).unwrap();
    let block = doc.split("```toml\n").nth(1).expect("a ```toml block");
    let block = block.split("```").next().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("reference.toml");
    std::fs::write(&scene, block).unwrap();
    let out = run_ok(&["check", scene.to_str().unwrap()]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("ok, 2D"), "{text}");
}

#[test]
fn the_good_scene_is_good() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("good.toml");
    std::fs::write(&scene, GOOD).unwrap();
    run_ok(&["run", scene.to_str().unwrap()]);
}

#[test]
fn bad_scenes_are_rejected_with_file_and_field() {
    let cases: &[(&str, &str, &str)] = &[
        // (replace this, with this, expected field in the message)
        ("dt = 0.005", "dt = 0.005 +", "line"), // malformed TOML
        ("radius = 1.0\nmass", "radus = 1.0\nmass", "radus"), // unknown key
        ("walls = true", "walls = true\ncolour = \"red\"", "colour"), // unknown key in a table
        (
            "position = [0.0, 0.0]",
            "position = [0.0, 0.0, 0.0]",
            "particles[0].position",
        ),
        ("gravity = [0.0, -9.8]", "gravity = [0.0]", "gravity"),
        (
            "velocity = [1.0, 0.0]",
            "velocity = [nan, 0.0]",
            "particles[0].velocity",
        ),
        (
            "velocity = [1.0, 0.0]",
            "velocity = [inf, 0.0]",
            "particles[0].velocity",
        ),
        (
            "radius = 1.0\nmass",
            "radius = 0.0\nmass",
            "particles[0].radius",
        ),
        (
            "radius = 1.0\nmass",
            "radius = -2.0\nmass",
            "particles[0].radius",
        ),
        (
            "radius = 1.0\nmass",
            "radius = nan\nmass",
            "particles[0].radius",
        ),
        ("mass = 1.0", "mass = 0.0", "particles[0].mass"),
        ("restitution = 0.5", "restitution = 1.5", "restitution"),
        ("restitution = 0.5", "restitution = -0.1", "restitution"),
        ("restitution = 0.5", "restitution = nan", "restitution"),
        ("dt = 0.005", "dt = 0.0", "dt"),
        ("dt = 0.005", "dt = -1.0", "dt"),
        ("dt = 0.005", "dt = inf", "dt"),
        ("max = [10.0, 10.0]", "max = [-10.0, 10.0]", "domain"),
        (
            "walls = true",
            "walls = true\n[broadphase]\ncells = [0, 10]",
            "broadphase.cells",
        ),
        (
            "walls = true",
            "walls = true\n[broadphase]\ncells = [10]",
            "broadphase.cells",
        ),
        (
            "walls = true",
            "walls = true\n[broadphase]\nkind = \"gird\"",
            "gird",
        ),
        (
            "walls = true",
            "walls = true\n[broadphase]\nkind = \"brute\"\ncells = [5, 5]",
            "broadphase.cells",
        ),
        (
            "walls = true",
            "walls = true\n[[planes]]\npoint = [0.0, 0.0]\nnormal = [0.0, 0.0]",
            "planes[0].normal",
        ),
        (
            "walls = true",
            "walls = true\n[[planes]]\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\nrestitution = 2.0",
            "planes[0].restitution",
        ),
        ("count = 10", "count = 100000000000", "fill[0].count"),
        ("count = 10", "count = 0", "fill[0].count"),
        ("count = 10", "count = 5000", "fill[0].count"), // cannot hold them
        ("dimensions = 2", "dimensions = 4", "dimensions"),
        ("steps = 10", "steps = -3", "steps"),
        (
            "walls = true",
            "walls = true\n[solver]\nsleep = 1",
            "sleep = 1", // the TOML reader quotes the line
        ),
        (
            "walls = true",
            "walls = true\n[solver]\nsleep = true\nsleep_speed = 0.0",
            "solver.sleep_speed",
        ),
        (
            "walls = true",
            "walls = true\n[solver]\nsleep = true\nsleep_time = -1.0",
            "solver.sleep_time",
        ),
        (
            "walls = true",
            "walls = true\n[solver]\nsleep = true\nsleep_time = nan",
            "solver.sleep_time",
        ),
        (
            "walls = true",
            "walls = true\n[solver]\nslep = true",
            "slep",
        ),
        (
            "walls = true",
            "walls = true\n[solver]\nretakes = 9",
            "solver.retakes",
        ),
        (
            "walls = true",
            "walls = true\n[solver]\nretakes = -1",
            "solver.retakes",
        ),
    ];
    for (from, to, field) in cases {
        assert!(GOOD.contains(from), "{from}");
        assert_rejected(&GOOD.replacen(from, to, 1), field);
    }
}

#[test]
fn missing_scene_file_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let out = carom()
        .args(["run", "/nonexistent/scene.toml"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/scene.toml"));
}

#[test]
fn bad_flags_are_rejected() {
    let scene = scenes().join("newton_cradle.toml");
    let s = scene.to_str().unwrap();
    for args in [
        vec!["run", s, "--threads", "0"],
        vec!["run", s, "--broadphase", "octree"],
        vec!["run", s, "--steps", "-1"],
        vec!["run", s, "--cells", "0,5"],
        vec!["run", s, "--cells", "5,5"], // the cradle has no walls, so no grid
        vec!["run", s, "--broadphase", "grid", "--cells", "5,5,5"],
        vec!["run", s, "--out", "/nonexistent/dir/out.csv"],
        vec!["run", "--preset", "no_such_scene"],
        vec!["run", s, "--bogus"],
    ] {
        let out = carom().args(&args).output().unwrap();
        assert_eq!(
            out.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// A bench case run by hand (`carom bench --case JSON`, what `carom bench` runs in each child)
/// takes its own thread count, not every core, and refuses a count out of range.
#[test]
fn a_bench_case_runs_on_its_own_threads() {
    let case = |threads: usize| {
        serde_json::json!({
            "group": "test", "name": "gas", "warmup": 1, "steps": 2, "threads": threads,
            "toml": "dimensions = 2\ndt = 0.01\n[domain]\nmin = [-20.0, -20.0]\n\
                     max = [20.0, 20.0]\nwalls = true\n[[fill]]\ncount = 100\nradius = 0.5\n\
                     speed = 1.0\n"
        })
        .to_string()
    };
    for threads in [1, 3] {
        let out = run_ok(&["bench", "--case", &case(threads)]);
        let text = String::from_utf8(out.stdout).unwrap();
        let measured: serde_json::Value = serde_json::from_str(text.trim()).unwrap();
        assert_eq!(measured["threads"], threads, "{text}");
    }
    let out = carom()
        .args(["bench", "--case", &case(0)])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn bench_quick_measures_every_case() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let out = run_ok(&[
        "bench",
        "--quick",
        "--max",
        "1000",
        "--out",
        json.to_str().unwrap(),
    ]);
    let table = String::from_utf8(out.stdout).unwrap();
    assert!(table.contains("grid 100x100 is"), "{table}");
    // every case: its streaming floor, the ratio to it and where the step's time went
    let breakdowns = table
        .lines()
        .filter(|l| l.contains("ns/particle: ") && l.contains("bare step"))
        .count();
    assert!(breakdowns > 0, "{table}");
    assert!(
        table.contains("velocity") && table.contains("bin") && table.contains("search"),
        "{table}"
    );
    // and the solver's work beside its time
    let solver = table
        .lines()
        .filter(|l| l.contains("velocity sweeps and"))
        .count();
    assert_eq!(solver, breakdowns, "{table}");
    let text = std::fs::read_to_string(&json).unwrap();
    let report: serde_json::Value = serde_json::from_str(&text).unwrap();
    for case in report["results"].as_array().unwrap() {
        // the two references: the floor, and the bare step, which moves and searches too
        let floor = case["floor_ns_per_particle"].as_f64().unwrap();
        let bare = case["bare_ns_per_particle_step"].as_f64().unwrap();
        assert!(floor > 0.0 && bare > floor, "{case}");
        let phases = case["phases_ms"].as_array().unwrap();
        let names: Vec<&str> = phases.iter().map(|p| p[0].as_str().unwrap()).collect();
        assert_eq!(
            names,
            [
                "sort",
                "bin",
                "search",
                "rows",
                "velocity",
                "motion",
                "position",
                "bookkeeping"
            ]
        );
        // every step sweeps at least once (no case sleeps whole), and the lecture's gases
        // collide
        let sweeps = case["sweeps_per_step"].as_f64().unwrap();
        let responses = case["responses_per_step"].as_f64().unwrap();
        assert!(sweeps >= 1.0, "{case}");
        if case["group"] == "lecture" {
            assert!(responses > 0.0, "{case}");
        }
        // the phases cover the step: together within the timed steps' wall time
        let sum: f64 = phases.iter().map(|p| p[1].as_f64().unwrap()).sum();
        let step = case["ms_per_step"].as_f64().unwrap();
        assert!(
            sum > 0.0 && sum <= step * 1.01 + 1e-3,
            "phases {sum} ms of {step} ms: {case}"
        );
    }

    for key in [
        "\"machine\"",
        "\"ms_per_step\"",
        "\"ns_per_particle_step\"",
        "\"bytes_per_particle\"",
        "brute force",
        "2D, 1000 particles",
        "3D, 1000 particles",
    ] {
        assert!(text.contains(key), "{key} missing from {text}");
    }
    assert!(!text.contains("NaN") && !text.contains("null"), "{text}");
}

#[test]
fn bench_rejects_bad_flags_before_working() {
    for args in [
        vec!["bench", "--threads", "0"],
        vec!["bench", "--out", "/nonexistent/dir/b.json"],
        vec!["bench", "--only", "everything"],
    ] {
        let out = carom().args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}

#[test]
fn particles_far_outside_a_grid_domain_match_brute_force() {
    // no walls: half the particles leave the domain quickly, so the grid switches to the hash
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("escape.toml");
    std::fs::write(
        &scene,
        "dimensions = 2\ndt = 0.01\nsteps = 300\nrestitution = 0.9\n\
         [domain]\nmin = [-10.0, -10.0]\nmax = [10.0, 10.0]\n\
         [broadphase]\nkind = \"grid\"\n\
         [[fill]]\ncount = 400\nradius = 0.3\nspeed = 30.0\nseed = 2\n",
    )
    .unwrap();
    let a = final_state(&scene, &[]);
    let b = final_state(&scene, &["--broadphase", "brute"]);
    assert_eq!(a, b);
    let outside = a
        .iter()
        .filter(|r| r[1].abs() > 10.0 || r[2].abs() > 10.0)
        .count();
    assert!(outside > 100, "only {outside} escaped");
}
