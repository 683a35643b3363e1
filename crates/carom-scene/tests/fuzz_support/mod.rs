//! The scene fuzz check, shared by the `cargo fuzz` target (fuzz/fuzz_targets/scene.rs) and the
//! stable, deterministic fallback (tests/fuzz_corpus.rs): bytes -> scene parser and validator
//! -> (if accepted and small) world -> 20 steps, with no panic and every value finite.

use carom_engine::{Vector, World};
use carom_scene::AnyScene;

/// Largest scene (particles) that is stepped; larger accepted scenes are only parsed.
pub const MAX_PARTICLES: usize = 200;
/// Steps run on an accepted scene.
pub const STEPS: u64 = 20;

/// What happened to one input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Refused before parsing: it asks for more particles or solver work than a fuzz input may.
    Skipped,
    /// The parser or validator refused it (with a message, not a panic).
    Rejected,
    /// Accepted, but refused by the world builder.
    BuildRejected,
    /// Accepted, built and stepped; every value stayed finite.
    Stepped,
}

/// Refuses, before the real parser runs, inputs whose accepted form would be too slow for a
/// fuzzer (big fills, huge iteration counts). Anything it cannot read is passed on.
fn too_big(text: &str) -> bool {
    let Ok(table) = text.parse::<toml::Table>() else {
        return false;
    };
    let int = |v: Option<&toml::Value>| v.and_then(toml::Value::as_integer).unwrap_or(0);
    let mut count = 0i64;
    if let Some(fills) = table.get("fill").and_then(|f| f.as_array()) {
        for f in fills {
            count = count.saturating_add(int(f.get("count")).max(0));
        }
    }
    if let Some(p) = table.get("particles").and_then(|p| p.as_array()) {
        count = count.saturating_add(p.len() as i64);
    }
    let solver = table.get("solver");
    let iterations = int(solver.and_then(|s| s.get("velocity_iterations")))
        .max(int(solver.and_then(|s| s.get("position_iterations"))));
    let cells = table
        .get("broadphase")
        .and_then(|b| b.get("cells"))
        .and_then(|c| c.as_array())
        .map(|c| {
            c.iter()
                .map(|x| x.as_integer().unwrap_or(1).max(1))
                .fold(1i64, |a, b| a.saturating_mul(b))
        })
        .unwrap_or(1);
    count > MAX_PARTICLES as i64 || iterations > 1000 || cells > 1_000_000
}

/// Runs one input through the whole path; panics (the fuzz failure) on a non-finite value.
pub fn check(bytes: &[u8]) -> Outcome {
    let text = String::from_utf8_lossy(bytes);
    if too_big(&text) {
        return Outcome::Skipped;
    }
    match carom_scene::parse(&text, "fuzz") {
        Err(e) => {
            // The message must be printable.
            let _ = e.to_string();
            Outcome::Rejected
        }
        Ok(AnyScene::Two(s)) => step(s),
        Ok(AnyScene::Three(s)) => step(s),
    }
}

fn step<V: Vector>(scene: carom_scene::Scene<V>) -> Outcome {
    if scene.particles.len() > MAX_PARTICLES {
        return Outcome::Skipped;
    }
    let Ok(mut world) = scene.build_world() else {
        return Outcome::BuildRejected;
    };
    assert_finite(&world, 0);
    for s in 1..=STEPS {
        world.step();
        assert_finite(&world, s);
    }
    assert!(world.kinetic_energy().is_finite(), "kinetic energy");
    Outcome::Stepped
}

fn assert_finite<V: Vector>(world: &World<V>, step: u64) {
    for id in 0..world.len() {
        let (x, v, r, m) = world.particle(id);
        for a in 0..V::DIM {
            assert!(
                x.get(a).is_finite() && v.get(a).is_finite(),
                "particle {id} not finite after step {step}: x {:?} v {:?}",
                (0..V::DIM).map(|a| x.get(a)).collect::<Vec<_>>(),
                (0..V::DIM).map(|a| v.get(a)).collect::<Vec<_>>(),
            );
        }
        assert!(r.is_finite() && m.is_finite(), "particle {id} radius/mass");
    }
}
