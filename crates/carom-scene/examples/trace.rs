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

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("trace: error: {message}");
            std::process::ExitCode::from(2)
        }
    }
}

/// Reads the arguments and the scene, then traces it; bad input is a message, not a panic.
fn run() -> Result<(), String> {
    let a: Vec<String> = std::env::args().collect();
    let path = a.get(1).ok_or("usage: trace SCENE [EVERY]")?;
    let every: u64 = match a.get(2) {
        None => 50,
        Some(s) => s.parse().ok().filter(|&e| e > 0).ok_or(format!(
            "EVERY: {s:?} is not a whole number of steps above 0"
        ))?,
    };
    let scene = load(std::path::Path::new(path)).map_err(|e| e.to_string())?;
    match scene {
        AnyScene::Two(s) => trace(
            s.clone().into_world().map_err(|e| format!("{path}: {e}"))?,
            s.steps,
            every,
        ),
        AnyScene::Three(s) => trace(
            s.clone().into_world().map_err(|e| format!("{path}: {e}"))?,
            s.steps,
            every,
        ),
    }
    Ok(())
}
