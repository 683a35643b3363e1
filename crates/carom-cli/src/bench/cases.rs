//! The cases `carom bench` measures, as scene TOML: the lecture's gas and its grids, the scale
//! sweep, and the piles at dt = 1/60.

use super::{BenchArgs, Case, Part};

/// A `[[fill]]`: count, radius, seed.
type Fill = (u64, f64, u64);

/// The lecture's gas: `count` particles in (-100, 100)^2, gravity, walls, k = 1.
fn lecture_toml(broadphase: &str, fills: &[Fill]) -> String {
    let mut t = String::from(
        "dimensions = 2\ndt = 0.005\ngravity = [0.0, -9.8]\nrestitution = 1.0\n\
         [domain]\nmin = [-100.0, -100.0]\nmax = [100.0, 100.0]\nwalls = true\n",
    );
    t.push_str(&format!("[broadphase]\n{broadphase}\n"));
    for &(count, radius, seed) in fills {
        t.push_str(&format!(
            "[[fill]]\ncount = {count}\nradius = {radius}\nspeed = 20.0\nseed = {seed}\n"
        ));
    }
    t
}

/// The sweep's scene: `n` particles of radius 1 at a fixed area (2D: 0.3) or volume (3D: 0.2)
/// fraction in a walled cube, gravity, k = 1.
fn sweep_toml(dim: usize, n: u64) -> String {
    use std::f64::consts::PI;
    let (side, g) = if dim == 2 {
        ((n as f64 * PI / 0.3).sqrt(), "[0.0, -9.8]")
    } else {
        ((n as f64 * 4.0 / 3.0 * PI / 0.2).cbrt(), "[0.0, -9.8, 0.0]")
    };
    let half = side / 2.0;
    let lo: Vec<String> = (0..dim).map(|_| format!("{:.6}", -half)).collect();
    let hi: Vec<String> = (0..dim).map(|_| format!("{half:.6}")).collect();
    format!(
        "dimensions = {dim}\ndt = 0.005\ngravity = {g}\nrestitution = 1.0\n\
         [domain]\nmin = [{}]\nmax = [{}]\nwalls = true\n\
         [[fill]]\ncount = {n}\nradius = 1.0\nspeed = 10.0\nseed = 1\n",
        lo.join(", "),
        hi.join(", ")
    )
}

/// A pile scene at dt = 1/60, k = 0.5, g = 9.81 (the targets): `count` particles of
/// `radius` poured into a walled box from `min` to `max`, filled at random over the box.
fn pile_toml(dim: usize, count: u64, radius: f64, min: &[f64], max: &[f64]) -> String {
    format!(
        "{}[[fill]]\ncount = {count}\nradius = {radius}\nspeed = 7.0\nseed = {count}\n",
        walled_box_toml(dim, min, max)
    )
}

/// The part of [`pile_toml`] before its fill: settings and the walled box.
fn walled_box_toml(dim: usize, min: &[f64], max: &[f64]) -> String {
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let g = if dim == 2 {
        "[0.0, -9.81]"
    } else {
        "[0.0, -9.81, 0.0]"
    };
    format!(
        "dimensions = {dim}\ndt = 0.016666666666666666\ngravity = {g}\nrestitution = 0.5\n\
         [domain]\nmin = [{}]\nmax = [{}]\nwalls = true\n",
        list(min),
        list(max)
    )
}

/// The pile cases: each scene timed while falling and (where it settles within the bench)
/// once settled.
fn pile_cases(args: &BenchArgs) -> Vec<Case> {
    let threads = args.threads;
    let case = |name: &str, toml: String, warmup: u64, steps: u64| Case {
        group: "piles".into(),
        name: name.into(),
        toml,
        warmup,
        steps,
        threads,
    };
    // the shipped `lecture_pile_60hz` scene (particles at rest sleep, the default), and the same
    // kept awake to time the solver on a settled pile
    let lecture = pile_toml(2, 5000, 1.0, &[-100.0; 2], &[100.0; 2]);
    let awake = format!("{lecture}[solver]\nsleep = false\n");
    if args.quick {
        return vec![case("2D lecture pile, falling", lecture, 10, 20)];
    }
    // 100,000 spheres poured into an 80 x 240 x 80 box: landing by step 400, settling in the
    // pile after, asleep whole from step 996 (see docs/benchmarks.md)
    let pour = pile_toml(
        3,
        100_000,
        1.0,
        &[-40.0, -40.0, -40.0],
        &[40.0, 200.0, 40.0],
    );
    // 10^6 discs r = 0.5 at area fraction 0.3 (they need ~1100 steps to reach the floor)
    let million = pile_toml(2, 1_000_000, 0.5, &[-809.0; 2], &[809.0; 2]);
    // the pile those discs would end as, at rest from the start: 619 hexagonal rows from wall
    // to wall (the box a hair wider, for the fill's spacing), asleep whole from step 32
    let settled = format!(
        "{}[[fill]]\ncount = 1000000\nradius = 0.5\nspeed = 0.0\narrangement = \"hex\"\n\
         min = [-809.001, -809.001]\nmax = [809.001, -200.0]\n",
        walled_box_toml(2, &[-809.001; 2], &[809.001; 2])
    );
    vec![
        case(
            "2D lecture pile, falling (steps 10-300)",
            lecture.clone(),
            10,
            290,
        ),
        case(
            "2D lecture pile, settled awake (1500-1800)",
            awake,
            1500,
            300,
        ),
        case(
            "2D lecture pile, settled asleep (1500-1800)",
            lecture,
            1500,
            300,
        ),
        case("3D pour 10^5, falling (steps 10-60)", pour.clone(), 10, 50),
        case(
            "3D pour 10^5, settling in the pile (steps 600-700)",
            pour.clone(),
            600,
            100,
        ),
        case("3D pour 10^5, asleep (steps 1200-1300)", pour, 1200, 100),
        case("2D 10^6 discs, falling (steps 10-40)", million, 10, 30),
        case(
            "2D 10^6 discs, a pile at rest, awake (steps 5-15)",
            settled.clone(),
            5,
            10,
        ),
        case(
            "2D 10^6 discs, a pile at rest, asleep (steps 35-45)",
            settled,
            35,
            10,
        ),
    ]
}

pub(super) fn cases(args: &BenchArgs) -> Vec<Case> {
    let mut out = Vec::new();
    let threads = args.threads;
    if args.only == Part::Piles {
        return pile_cases(args);
    }
    if args.only != Part::Sweep {
        // The same steps for every broad phase, so each times the same physics (the
        // gas settles as it runs, and a pile has more contacts than a gas).
        let steps = if args.quick { 5 } else { 300 };
        let (brute_steps, grid_steps) = (steps, steps);
        let radii: [(&str, Vec<Fill>); 2] = [
            ("r = 1", vec![(5000, 1.0, 5000)]),
            ("r = 1 and 3", vec![(100, 3.0, 3), (4900, 1.0, 1)]),
        ];
        for (label, fills) in radii {
            for (bp, name, steps) in [
                ("kind = \"brute\"", "brute force", brute_steps),
                (
                    "kind = \"grid\"\ncells = [100, 100]",
                    "grid 100x100",
                    grid_steps,
                ),
                (
                    "kind = \"grid\"\ncells = [50, 50]",
                    "grid 50x50",
                    grid_steps,
                ),
            ] {
                out.push(Case {
                    group: "lecture".into(),
                    name: format!("5000 particles, {label}, {name}"),
                    toml: lecture_toml(bp, &fills),
                    warmup: 10,
                    steps,
                    threads,
                });
            }
        }
    }
    let mut single_thread = Vec::new();
    if args.only != Part::Lecture {
        let max = if args.quick {
            args.max.min(10_000)
        } else {
            args.max
        };
        for dim in [2usize, 3] {
            for n in [1_000u64, 10_000, 100_000, 1_000_000, 4_000_000] {
                if n > max {
                    continue;
                }
                let steps = if args.quick { 10 } else { 40 };
                let case = |group: String, name: String, threads| Case {
                    group,
                    name,
                    toml: sweep_toml(dim, n),
                    warmup: 10,
                    steps,
                    threads,
                };
                let name = format!("{dim}D, {n} particles");
                out.push(case(format!("sweep {dim}D"), name.clone(), threads));
                if n == 1_000_000 && threads != Some(1) {
                    let group = format!("threads {dim}D");
                    single_thread.push(case(group, format!("{name}, 1 thread"), Some(1)));
                }
            }
        }
    }
    out.extend(single_thread);
    if args.only == Part::All {
        out.extend(pile_cases(args));
    }
    out
}
