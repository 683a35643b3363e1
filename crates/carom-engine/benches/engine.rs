//! Criterion benchmarks of the engine's kernels.
//!
//! - `lecture`: the lecture's "Hash Grid vs. w/o Hash" demo, 5000 particles of radius 1 in
//!   (-100, 100)^2 with walls, gravity (0, -9.8), k = 1, dt 0.005: one `World::step` with a
//!   100x100 grid, a 50x50 grid and brute force.
//! - `sweep_2d`, `sweep_3d`: one step of N particles of radius 1 in a walled square (area
//!   fraction 0.3) or cube (volume fraction 0.2) under gravity, N = 10^3, 10^4, 10^5, with
//!   throughput in particles, so criterion's `elem/s` is particle-steps per second
//!   (ns per particle-step = 10^9 / that).
//! - `formulas`: the lecture's response formulas on their own, `response::collide` and
//!   `Plane::bounce` in 2D.
//!
//! Particles start on a jittered lattice (never overlapping) from a fixed-seed LCG, so every
//! run measures the same worlds; each world takes 20 steps before it is measured. A world is
//! stepped on from sample to sample (it is not reset), as in a real run.
//!
//! `cargo bench -p carom-engine` (about two minutes on 2 cores); `-- --quick` for a fast look,
//! `-- lecture` for one group.

#![allow(missing_docs)] // (criterion_group! and criterion_main! generate undocumented functions)

use carom_engine::glam::{DVec2, DVec3};
use carom_engine::{response, Aabb, BroadPhaseKind, Particles, Plane, Vector, World};
use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};
use std::hint::black_box;
use std::time::Duration;

/// Steps every world takes before it is measured.
const WARMUP_STEPS: usize = 20;

/// A 64-bit linear congruential generator (Knuth's MMIX constants): tiny, seeded, portable.
struct Lcg(u64);

impl Lcg {
    fn new(seed: u64) -> Self {
        let mut g = Lcg(seed ^ 0x9e37_79b9_7f4a_7c15);
        g.next_u64();
        g
    }
    fn next_u64(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        self.0
    }
    /// Uniform in [0, 1), from the high 53 bits.
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [-1, 1).
    fn signed(&mut self) -> f64 {
        2.0 * self.unit() - 1.0
    }
    /// Uniform in `0..n`.
    fn below(&mut self, n: usize) -> usize {
        (((self.next_u64() >> 32) * n as u64) >> 32) as usize
    }
}

/// `n` particles of radius `radius` and mass 1 in the cube `[lo, hi]^DIM`: centres on a
/// lattice of cells chosen at random, each jittered inside its cell by less than the gap, so
/// no two overlap and none touches a wall; velocity components uniform in `[-speed, speed)`.
fn jittered_lattice<V: Vector>(
    n: usize,
    radius: f64,
    (lo, hi): (f64, f64),
    speed: f64,
    seed: u64,
) -> Particles<V> {
    let dim = V::DIM;
    let per_axis = (n as f64).powf(1.0 / dim as f64).ceil() as usize;
    let spacing = (hi - lo) / per_axis as f64;
    assert!(
        spacing > 2.0 * radius,
        "{n} particles of radius {radius} do not fit in ({lo}, {hi})^{dim}"
    );
    let jitter = 0.45 * (spacing - 2.0 * radius);
    let mut rng = Lcg::new(seed);
    // A random choice of n cells out of per_axis^dim (a partial Fisher-Yates shuffle).
    let mut cells: Vec<usize> = (0..per_axis.pow(dim as u32)).collect();
    for i in 0..n {
        let j = i + rng.below(cells.len() - i);
        cells.swap(i, j);
    }
    let mut particles = Particles::new();
    for &cell in &cells[..n] {
        let mut x = [0.0; 3];
        let mut v = [0.0; 3];
        let mut rest = cell;
        for a in 0..dim {
            let k = rest % per_axis;
            rest /= per_axis;
            x[a] = lo + (k as f64 + 0.5) * spacing + jitter * rng.signed();
            v[a] = speed * rng.signed();
        }
        particles
            .push(V::from_slice(&x), V::from_slice(&v), radius, 1.0)
            .expect("valid particle");
    }
    particles
}

/// A walled box `(lo, hi)^DIM` with gravity 9.8 along -y, k = 1 for particles and walls,
/// holding `particles`, stepped `WARMUP_STEPS` times.
fn world<V: Vector>(
    particles: Particles<V>,
    (lo, hi): (f64, f64),
    broad_phase: BroadPhaseKind,
    cells: Option<&[usize]>,
) -> World<V> {
    let corner = |c: f64| V::from_slice(&[c; 3]);
    let mut builder = World::builder()
        .dt(0.005)
        .gravity(V::unit_axis(1) * -9.8)
        .restitution(1.0)
        .domain(Aabb::new(corner(lo), corner(hi)).expect("valid box"))
        .walls(1.0)
        .broad_phase(broad_phase)
        .particles(particles);
    if let Some(cells) = cells {
        builder = builder.grid_cells(cells);
    }
    let mut world = builder.build().expect("valid world");
    for _ in 0..WARMUP_STEPS {
        world.step();
    }
    world
}

/// The lecture's demo: 5000 particles, radius 1, (-100, 100)^2, speed 20.
fn lecture(c: &mut Criterion) {
    let mut group = c.benchmark_group("lecture");
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(4))
        .throughput(Throughput::Elements(5000));
    let bounds = (-100.0, 100.0);
    let cases: [(&str, BroadPhaseKind, Option<&[usize]>); 3] = [
        ("grid_100x100", BroadPhaseKind::Grid, Some(&[100, 100])),
        ("grid_50x50", BroadPhaseKind::Grid, Some(&[50, 50])),
        ("brute_force", BroadPhaseKind::Brute, None),
    ];
    for (name, kind, cells) in cases {
        let particles = jittered_lattice::<DVec2>(5000, 1.0, bounds, 20.0, 5000);
        let mut w = world(particles, bounds, kind, cells);
        group.bench_function(name, |b| b.iter(|| black_box(w.step())));
    }
    group.finish();
}

/// Half the side of a box holding `n` particles of radius 1 at packing fraction `fraction`.
fn half_side(dim: usize, n: usize, fraction: f64) -> f64 {
    use std::f64::consts::PI;
    let one = if dim == 2 { PI } else { 4.0 / 3.0 * PI };
    0.5 * (n as f64 * one / fraction).powf(1.0 / dim as f64)
}

fn sweep<V: Vector>(c: &mut Criterion, group_name: &str, fraction: f64) {
    let mut group = c.benchmark_group(group_name);
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(4));
    for n in [1_000usize, 10_000, 100_000] {
        let h = half_side(V::DIM, n, fraction);
        let particles = jittered_lattice::<V>(n, 1.0, (-h, h), 10.0, n as u64);
        let mut w = world(particles, (-h, h), BroadPhaseKind::Grid, None);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| black_box(w.step()))
        });
    }
    group.finish();
}

fn sweep_2d(c: &mut Criterion) {
    sweep::<DVec2>(c, "sweep_2d", 0.3);
}

fn sweep_3d(c: &mut Criterion) {
    sweep::<DVec3>(c, "sweep_3d", 0.2);
}

/// The response formulas alone (2D), on the lecture's worked example #2 numbers.
fn formulas(c: &mut Criterion) {
    let mut group = c.benchmark_group("formulas");
    group
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    let normal = DVec2::new(3f64.sqrt() / 2.0, -0.5);
    let (v1, v2) = (DVec2::new(20.0, 0.0), DVec2::new(-10.0, 0.0));
    group.bench_function("collide_2d", |b| {
        b.iter(|| {
            response::collide(
                black_box(normal),
                black_box(v1),
                black_box(v2),
                black_box(1.0),
                black_box(2.0),
                black_box(0.5),
            )
        })
    });
    let floor = Plane::new(DVec2::new(0.0, -100.0), DVec2::Y, 0.5).expect("valid plane");
    group.bench_function("plane_bounce_2d", |b| {
        b.iter(|| black_box(&floor).bounce(black_box(DVec2::new(3.0, -4.0))))
    });
    group.finish();
}

criterion_group!(benches, lecture, sweep_2d, sweep_3d, formulas);
criterion_main!(benches);
