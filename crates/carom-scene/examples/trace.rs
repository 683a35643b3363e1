//! Prints a per-interval trace of a scene: sweeps, capped steps, overlaps, v_rms and cost.
//! `cargo run --release -p carom-scene --example trace -- SCENE [EVERY]`
use carom_engine::{Vector, World};
use carom_scene::{load, AnyScene};

fn trace<V: Vector>(mut w: World<V>, steps: u64, every: u64) {
    let (mut capped, mut iters, mut worst) = (0, 0u64, 0.0f64);
    let mut t = std::time::Instant::now();
    for s in 1..=steps {
        let st = w.step();
        capped += st.capped as u64;
        iters += st.velocity_iterations as u64;
        worst = worst.max(st.max_overlap);
        if s % every == 0 || s == steps {
            let mass: f64 = w.particles().masses().iter().sum();
            let vrms = (2.0 * w.kinetic_energy() / mass).sqrt();
            println!(
                "{s:6} capped {capped:4} sweeps/step {:6.1} max_ov {:.5} (worst {:.5}) contacts {:6} v_rms {vrms:.5} ms/step {:.3}",
                iters as f64 / every as f64,
                st.max_overlap,
                worst,
                st.contacts,
                t.elapsed().as_secs_f64() * 1e3 / every as f64
            );
            (capped, iters, worst) = (0, 0, 0.0);
            t = std::time::Instant::now();
        }
    }
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let every: u64 = a.get(2).map_or(50, |s| s.parse().unwrap());
    match load(std::path::Path::new(&a[1])).unwrap() {
        AnyScene::Two(s) => trace(s.clone().into_world().unwrap(), s.steps, every),
        AnyScene::Three(s) => trace(s.clone().into_world().unwrap(), s.steps, every),
    }
}
