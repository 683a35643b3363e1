//! "No allocation in the step loop after warm-up": a counting global allocator watches
//! `World::step` once the buffers have grown to size.

use carom_engine::glam::{DVec2, DVec3};
use carom_engine::world::REORDER_INTERVAL;
use carom_engine::{Aabb, BroadPhaseKind, Vector, World};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// The counter is global, so the tests here take turns, each for the whole of its run: one
/// test's set-up (building worlds, warming them up) would otherwise count as another's step
/// allocations.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn my_turn() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// A jittered lattice gas filling a walled box, elastic and without gravity so that it reaches
/// a steady state (contacts come and go every step, but their number does not keep growing,
/// which would legitimately grow the buffers; an inelastic gas cools and clusters).
fn gas<V: Vector>(per_axis: usize, kind: BroadPhaseKind) -> World<V> {
    gas_in(per_axis, kind, false)
}

/// [`gas`], in a box closed by walls or periodic on every axis.
fn gas_in<V: Vector>(per_axis: usize, kind: BroadPhaseKind, periodic: bool) -> World<V> {
    let spacing = 2.5;
    let half = per_axis as f64 * spacing / 2.0 + 2.0;
    let mut b = World::<V>::builder()
        .dt(0.01)
        .restitution(1.0)
        .domain(Aabb::new(V::from_slice(&[-half; 3]), V::from_slice(&[half; 3])).unwrap())
        .broad_phase(kind);
    b = if periodic {
        b.periodic(&[true; 3][..V::DIM])
    } else {
        b.walls(1.0)
    };
    let mut s = 3u64;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let count = per_axis.pow(V::DIM as u32);
    for k in 0..count {
        let mut c = [0.0; 3];
        let mut rest = k;
        for slot in c.iter_mut().take(V::DIM) {
            *slot = -half + 2.0 + (rest % per_axis) as f64 * spacing + 0.2 * next();
            rest /= per_axis;
        }
        let v = [10.0 * next(), 10.0 * next(), 10.0 * next()];
        b = b.particle(V::from_slice(&c), V::from_slice(&v), 1.0, 1.0);
    }
    b.build().unwrap()
}

/// Allocations in `steps` steps after `warmup` steps (several re-sorts, so that every buffer
/// has reached its working size). The caller holds [`my_turn`].
fn allocations_in_steps<V: Vector>(world: &mut World<V>, warmup: u64, steps: u64) -> usize {
    for _ in 0..warmup {
        world.step();
    }
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for s in 0..steps {
        let b = ALLOCATIONS.load(Ordering::Relaxed);
        let st = world.step();
        let a = ALLOCATIONS.load(Ordering::Relaxed);
        if a != b && std::env::var("ALLOC_DEBUG").is_ok() {
            eprintln!(
                "step {s} (taken {}): {} allocations, contacts {}",
                world.steps_taken(),
                a - b,
                st.contacts
            );
        }
    }
    ALLOCATIONS.load(Ordering::Relaxed) - before
}

#[test]
fn stepping_does_not_allocate_after_warm_up() {
    let _turn = my_turn();
    let warmup = 8 * REORDER_INTERVAL;
    // serial (small) and parallel (above the engine's threshold) paths, all broad phases
    for kind in [
        BroadPhaseKind::Grid,
        BroadPhaseKind::Hash,
        BroadPhaseKind::Brute,
    ] {
        let mut w = gas::<DVec2>(30, kind);
        let n = allocations_in_steps(&mut w, warmup, 2 * REORDER_INTERVAL);
        assert_eq!(n, 0, "2D, 900 particles, {kind:?}: {n} allocations");
    }
    // 22,500 particles: the parallel phases, on a one-thread pool so that no work is stolen
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut w = gas::<DVec2>(150, BroadPhaseKind::Grid);
    let n = pool.install(|| allocations_in_steps(&mut w, warmup, REORDER_INTERVAL));
    assert_eq!(n, 0, "2D, 22,500 particles, one thread: {n} allocations");
    // ... and on two threads. Stepping runs inside the pool: from outside it, every parallel
    // call is injected into rayon's global queue, which allocates a block per 63 injections
    // (rayon's bookkeeping, not the engine's); `carom run` steps inside the pool too.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let mut w = gas::<DVec2>(150, BroadPhaseKind::Grid);
    let n = pool.install(|| allocations_in_steps(&mut w, warmup, REORDER_INTERVAL));
    assert_eq!(n, 0, "2D, 22,500 particles, two threads: {n} allocations");
    let mut w = gas::<DVec3>(12, BroadPhaseKind::Grid);
    let n = allocations_in_steps(&mut w, warmup, REORDER_INTERVAL);
    assert_eq!(n, 0, "3D, 1728 particles: {n} allocations");
}

/// The same with periodic axes: the wrap, the shifted rows and the grid's wrapped searches
/// allocate nothing either.
#[test]
fn a_periodic_gas_does_not_allocate() {
    let _turn = my_turn();
    let warmup = 8 * REORDER_INTERVAL;
    for kind in [BroadPhaseKind::Grid, BroadPhaseKind::Brute] {
        let mut w = gas_in::<DVec2>(30, kind, true);
        let n = allocations_in_steps(&mut w, warmup, 2 * REORDER_INTERVAL);
        assert_eq!(
            n, 0,
            "periodic 2D, 900 particles, {kind:?}: {n} allocations"
        );
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let mut w = gas_in::<DVec2>(150, BroadPhaseKind::Grid, true);
    let n = pool.install(|| allocations_in_steps(&mut w, warmup, REORDER_INTERVAL));
    assert_eq!(
        n, 0,
        "periodic 2D, 22,500 particles, two threads: {n} allocations"
    );
    let mut w = gas_in::<DVec3>(12, BroadPhaseKind::Grid, true);
    let n = allocations_in_steps(&mut w, warmup, REORDER_INTERVAL);
    assert_eq!(n, 0, "periodic 3D, 1728 particles: {n} allocations");
}

/// 400 discs of radius 0.7 dropped in rows into a walled box at dt = 1/60, k = 0.5.
fn pile(sleep: bool) -> World<DVec2> {
    let half = 20.0;
    let mut b = World::<DVec2>::builder()
        .dt(1.0 / 60.0)
        .gravity(DVec2::new(0.0, -9.81))
        .restitution(0.5)
        .domain(Aabb::new(DVec2::splat(-half), DVec2::splat(half)).unwrap())
        .walls(0.5)
        .sleep(sleep);
    for k in 0..400 {
        let (i, j) = ((k % 16) as f64, (k / 16) as f64);
        b = b.particle(
            DVec2::new(-18.0 + 2.2 * i, -18.0 + 1.5 * j),
            DVec2::ZERO,
            0.7,
            1.0,
        );
    }
    b.build().unwrap()
}

/// The resting-contact solver (gravity, k < 1: substeps, remembered impulses) allocates nothing
/// once a pile has settled and is kept awake.
#[test]
fn a_settled_pile_does_not_allocate() {
    let _turn = my_turn();
    let mut w = pile(false);
    let n = allocations_in_steps(&mut w, 40 * REORDER_INTERVAL, 2 * REORDER_INTERVAL);
    assert_eq!(n, 0, "settled pile kept awake: {n} allocations");
}

/// Once a pile has fallen asleep (the sleep marks and the kept impulses of sleeping
/// contacts have grown to size), waking it and letting it fall asleep again allocates nothing.
#[test]
fn a_pile_waking_and_falling_asleep_again_does_not_allocate() {
    let _turn = my_turn();
    let mut w = pile(true);
    for _ in 0..40 * REORDER_INTERVAL {
        w.step();
    }
    assert_eq!(w.asleep(), w.len(), "the pile must have fallen asleep");
    w.set_velocity(0, DVec2::new(0.0, 3.0)).unwrap();
    let n = allocations_in_steps(&mut w, 0, 40 * REORDER_INTERVAL);
    assert_eq!(w.asleep(), w.len(), "and fallen asleep again");
    assert_eq!(n, 0, "a pile waking and sleeping again: {n} allocations");
}
