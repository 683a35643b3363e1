//! What the side panel's controls do to the engine and to the scene, without a window.

use carom_engine::{BroadPhaseKind, Vector, World};

/// The engine parameters the panel edits in place (no rebuild).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// Particle-particle restitution `k`.
    pub restitution: f64,
    /// Gravity, x y z (z ignored in 2D).
    pub gravity: [f64; 3],
    /// Time step.
    pub dt: f64,
}

impl Params {
    /// The parameters a world runs with now.
    pub fn of<V: Vector>(world: &World<V>) -> Self {
        let c = world.config();
        let mut gravity = [0.0; 3];
        for (a, g) in gravity.iter_mut().enumerate().take(V::DIM) {
            *g = c.gravity.get(a);
        }
        Self {
            restitution: c.restitution,
            gravity,
            dt: c.dt,
        }
    }

    /// Applies every parameter that differs from the world's, through the engine's checked
    /// setters. Returns one message per refused value; the world keeps its old value for those.
    pub fn apply<V: Vector>(&self, world: &mut World<V>) -> Vec<String> {
        let now = Self::of(world);
        let mut errors = Vec::new();
        if self.restitution != now.restitution {
            if let Err(e) = world.set_restitution(self.restitution) {
                errors.push(format!("restitution {}: {e}", self.restitution));
            }
        }
        if self.gravity[..V::DIM] != now.gravity[..V::DIM] {
            if let Err(e) = world.set_gravity(V::from_slice(&self.gravity)) {
                errors.push(format!("gravity {:?}: {e}", &self.gravity[..V::DIM]));
            }
        }
        if self.dt != now.dt {
            if let Err(e) = world.set_dt(self.dt) {
                errors.push(format!("dt {}: {e}", self.dt));
            }
        }
        errors
    }
}

/// Broad phase choice plus grid cells (`None`: derived from the largest radius).
#[derive(Clone, Debug, PartialEq)]
pub struct BroadPhaseChoice {
    /// Which broad phase.
    pub kind: BroadPhaseKind,
    /// Cells per axis for the grid (one entry per dimension).
    pub cells: Option<Vec<usize>>,
}

/// Checks a cells request: `dims` entries, each in 1..=4096, total at most 2^24 (so that a
/// slider can never ask for a grid that would take seconds to allocate).
pub fn check_cells(dims: usize, cells: &[usize]) -> Result<(), String> {
    let total = cells.iter().try_fold(1u64, |t, &c| t.checked_mul(c as u64));
    if cells.len() != dims
        || cells.iter().any(|&c| !(1..=4096).contains(&c))
        || total.is_none_or(|t| t > 1 << 24)
    {
        return Err(format!(
            "grid cells {cells:?}: need {dims} values in 1..=4096, at most 16777216 cells in all"
        ));
    }
    Ok(())
}

/// Largest particle count the panel's rebuild accepts.
pub const MAX_PARTICLES: u64 = 1_000_000;

/// Rewrites scene TOML so that its particles are a single `[[fill]]` of `count` particles of
/// `radius` (the first fill's other keys, such as speed, seed and region, are kept; explicit
/// `[[particles]]` are dropped). A scene without a fill gets one over its domain or, without a
/// domain, over a square (cube) around its particles big enough for a 10% packing.
pub fn refill(text: &str, count: u64, radius: f64) -> Result<String, String> {
    if count == 0 || count > MAX_PARTICLES {
        return Err(format!(
            "particle count must be in 1..={MAX_PARTICLES}, got {count}"
        ));
    }
    if !(radius.is_finite() && radius > 0.0) {
        return Err(format!(
            "radius must be a finite number > 0, got {radius:?}"
        ));
    }
    let mut table: toml::Table = text.parse().map_err(|e| format!("scene text: {e}"))?;
    let dims = table
        .get("dimensions")
        .and_then(|d| d.as_integer())
        .unwrap_or(2)
        .clamp(2, 3) as usize;
    let first_fill = table
        .get("fill")
        .and_then(|f| f.as_array())
        .and_then(|a| a.first())
        .and_then(|f| f.as_table())
        .cloned();
    let mut fill = match first_fill {
        Some(f) => f,
        None => {
            let mut f = toml::Table::new();
            f.insert("speed".into(), toml::Value::Float(10.0));
            f.insert("seed".into(), toml::Value::Integer(1));
            if !table.contains_key("domain") {
                let centre = particle_centre(&table, dims);
                let volume = count as f64 * sphere_volume(dims, radius) / 0.1;
                let half = volume.powf(1.0 / dims as f64) * 0.5;
                let corner = |s: f64| {
                    toml::Value::Array(
                        centre
                            .iter()
                            .map(|c| toml::Value::Float(c + s * half))
                            .collect(),
                    )
                };
                f.insert("min".into(), corner(-1.0));
                f.insert("max".into(), corner(1.0));
            }
            f
        }
    };
    fill.insert("count".into(), toml::Value::Integer(count as i64));
    fill.insert("radius".into(), toml::Value::Float(radius));
    table.remove("particles");
    table.insert(
        "fill".into(),
        toml::Value::Array(vec![toml::Value::Table(fill)]),
    );
    toml::to_string(&table).map_err(|e| format!("scene text: {e}"))
}

fn sphere_volume(dims: usize, r: f64) -> f64 {
    if dims == 2 {
        std::f64::consts::PI * r * r
    } else {
        4.0 / 3.0 * std::f64::consts::PI * r * r * r
    }
}

/// Mean position of the scene's explicit particles (origin if none).
fn particle_centre(table: &toml::Table, dims: usize) -> Vec<f64> {
    let mut sum = vec![0.0; dims];
    let mut n = 0.0;
    for p in table
        .get("particles")
        .and_then(|p| p.as_array())
        .into_iter()
        .flatten()
    {
        if let Some(pos) = p.get("position").and_then(|x| x.as_array()) {
            for (s, v) in sum.iter_mut().zip(pos) {
                *s += v
                    .as_float()
                    .or(v.as_integer().map(|i| i as f64))
                    .unwrap_or(0.0);
            }
            n += 1.0;
        }
    }
    if n > 0.0 {
        sum.iter_mut().for_each(|s| *s /= n);
    }
    sum
}

/// The particle count and radius the panel starts with for a scene: its total count and its
/// largest radius.
pub fn count_and_radius(radii: &[f64]) -> (u64, f64) {
    let r = radii.iter().copied().fold(0.0, f64::max);
    (radii.len() as u64, if r > 0.0 { r } else { 1.0 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use carom_engine::glam::DVec2;
    use carom_scene::AnyScene;

    fn world() -> World<DVec2> {
        World::builder()
            .particle(DVec2::ZERO, DVec2::X, 1.0, 1.0)
            .build()
            .unwrap()
    }

    #[test]
    fn params_round_trip_and_apply() {
        let mut w = world();
        let mut p = Params::of(&w);
        assert_eq!(
            p,
            Params {
                restitution: 1.0,
                gravity: [0.0; 3],
                dt: 0.005
            }
        );
        p.restitution = 0.25;
        p.gravity = [0.0, -9.8, 123.0]; // z is ignored in 2D
        p.dt = 0.01;
        assert!(p.apply(&mut w).is_empty());
        assert_eq!(w.config().restitution, 0.25);
        assert_eq!(w.config().gravity, DVec2::new(0.0, -9.8));
        assert_eq!(w.config().dt, 0.01);
    }

    #[test]
    fn bad_params_are_messages_not_panics() {
        let mut w = world();
        let bad = Params {
            restitution: 1.5,
            gravity: [f64::NAN, 0.0, 0.0],
            dt: -1.0,
        };
        let errors = bad.apply(&mut w);
        assert_eq!(errors.len(), 3, "{errors:?}");
        assert!(errors[0].contains("restitution"));
        // the world kept its old, valid values and still steps
        assert_eq!(
            Params::of(&w),
            Params {
                restitution: 1.0,
                gravity: [0.0; 3],
                dt: 0.005
            }
        );
        w.step();
        let zero_dt = Params {
            dt: 0.0,
            ..Params::of(&w)
        };
        assert_eq!(zero_dt.apply(&mut w).len(), 1);
    }

    #[test]
    fn cells_are_checked() {
        assert!(check_cells(2, &[100, 100]).is_ok());
        assert!(check_cells(2, &[0, 100]).is_err());
        assert!(check_cells(3, &[100, 100]).is_err());
        assert!(check_cells(3, &[4096, 4096, 4096]).is_err());
    }

    fn parse(text: &str) -> AnyScene {
        carom_scene::parse(text, "test").unwrap()
    }

    #[test]
    fn refill_changes_count_and_radius_keeping_the_rest() {
        let text = carom_scene::preset("lecture_100_k05").unwrap();
        let new = refill(text, 250, 2.0).unwrap();
        match parse(&new) {
            AnyScene::Two(s) => {
                assert_eq!(s.particles.len(), 250);
                assert!(s.particles.radii().iter().all(|&r| r == 2.0));
                assert_eq!(s.config.restitution, 0.5);
                assert!(s.walls.is_some());
            }
            AnyScene::Three(_) => panic!("2D scene became 3D"),
        }
    }

    #[test]
    fn refill_works_for_every_preset() {
        for (name, text) in carom_scene::PRESETS {
            let new = refill(text, 50, 0.5).unwrap_or_else(|e| panic!("{name}: {e}"));
            let scene =
                carom_scene::parse(&new, name).unwrap_or_else(|e| panic!("{name}: {e}\n{new}"));
            let n = match scene {
                AnyScene::Two(s) => s.particles.len(),
                AnyScene::Three(s) => s.particles.len(),
            };
            assert_eq!(n, 50, "{name}");
        }
    }

    #[test]
    fn refill_refuses_nonsense() {
        let text = carom_scene::preset("lecture_100_k05").unwrap();
        assert!(refill(text, 0, 1.0).is_err());
        assert!(refill(text, MAX_PARTICLES + 1, 1.0).is_err());
        assert!(refill(text, 10, f64::NAN).is_err());
        assert!(refill(text, 10, -1.0).is_err());
        assert!(refill("not toml [", 10, 1.0).is_err());
        // too dense for the domain: the scene parser says so (an error, not a hang or panic)
        let dense = refill(text, 100_000, 4.0).unwrap();
        assert!(carom_scene::parse(&dense, "test").is_err());
    }

    #[test]
    fn count_and_radius_of_a_scene() {
        assert_eq!(count_and_radius(&[1.0, 3.0]), (2, 3.0));
        assert_eq!(count_and_radius(&[]), (0, 1.0));
    }
}
