//! The limits a scene file's particles keep, for particles that come from elsewhere: a
//! checkpoint, whose checksum says that its bytes arrived as written, not that a hand (or
//! another program) wrote sane values into them.

use crate::{MAX_MAGNITUDE, MAX_STEPS, MIN_POSITIVE};
use carom_engine::{ContactImpulses, Particles, Tally, Vector};

/// The largest position or velocity component a state may hold: a run may carry particles
/// beyond a scene's [`MAX_MAGNITUDE`] (a scene at its limits does, falling for a few steps),
/// and its checkpoint resumes; this keeps `m |v|^2` finite for the largest mass (`1e15 x
/// (1e146)^2 = 1e307`).
pub const MAX_STATE_MAGNITUDE: f64 = 1e146;

/// Checks every particle of a state: positions and velocities finite and at most
/// [`MAX_STATE_MAGNITUDE`] in each component, radii and masses (which no step changes) in
/// `MIN_POSITIVE..=MAX_MAGNITUDE`, as a scene file's are. The error names the first particle
/// (by its index in `particles`) and the value that is not.
pub fn check_state<V: Vector>(particles: &Particles<V>) -> Result<(), String> {
    let vectors = [
        ("position", particles.positions()),
        ("velocity", particles.velocities()),
    ];
    for (what, values) in vectors {
        for (id, v) in values.iter().enumerate() {
            for a in 0..V::DIM {
                let x = v.get(a);
                if !(x.is_finite() && x.abs() <= MAX_STATE_MAGNITUDE) {
                    return Err(format!(
                        "particle {id}: {what} {x:?} is not a finite number of magnitude at \
                         most {MAX_STATE_MAGNITUDE:e}"
                    ));
                }
            }
        }
    }
    let sizes = [("radius", particles.radii()), ("mass", particles.masses())];
    for (what, values) in sizes {
        for (id, &x) in values.iter().enumerate() {
            if !(MIN_POSITIVE..=MAX_MAGNITUDE).contains(&x) {
                return Err(format!(
                    "particle {id}: {what} {x:?} is not within {MIN_POSITIVE:e}..={MAX_MAGNITUDE:e}"
                ));
            }
        }
    }
    Ok(())
}

/// Checks a checkpoint's step counts, the step it is at and the one its run goes to, against
/// [`MAX_STEPS`] (a run of 10^18 steps ran until killed).
pub fn check_stored_steps(steps_taken: u64, run_steps: u64) -> Result<(), String> {
    for (what, steps) in [("is at step", steps_taken), ("runs to step", run_steps)] {
        if steps > MAX_STEPS {
            return Err(format!("it {what} {steps}, past the limit of {MAX_STEPS}"));
        }
    }
    Ok(())
}

/// Checks what a state remembers besides its particles: the resting impulses finite, above 0
/// and at most [`MAX_STATE_MAGNITUDE`] (an impulse of 1e300 made the next step's energy
/// infinite), the rest times finite and not negative, and the observables' sums finite, the
/// time and the thermal sum not negative, the collisions below 2^63 (so that no run can wrap
/// the count).
pub fn check_remembered(impulses: &ContactImpulses, tally: &Tally) -> Result<(), String> {
    let kept = |x: f64| x.is_finite() && x > 0.0 && x <= MAX_STATE_MAGNITUDE;
    for (what, list) in [("pair", &impulses.pairs), ("plane", &impulses.planes)] {
        if let Some(&(a, b, x)) = list.iter().find(|&&(_, _, x)| !kept(x)) {
            return Err(format!(
                "the remembered {what} impulse ({a}, {b}) is {x:?}, not a finite number in \
                 (0, {MAX_STATE_MAGNITUDE:e}]"
            ));
        }
    }
    if let Some((id, t)) =
        (impulses.rest.iter().enumerate()).find(|(_, t)| !(t.is_finite() && **t >= 0.0))
    {
        return Err(format!("particle {id}: a rest time of {t:?}"));
    }
    let sums = [
        ("virial", tally.virial, f64::NEG_INFINITY),
        ("thermal", tally.thermal, 0.0),
        ("interval", tally.interval, 0.0),
    ];
    if let Some((what, x, _)) = sums
        .iter()
        .find(|(_, x, least)| !(x.is_finite() && x >= least))
    {
        return Err(format!("the observables' {what} sum is {x:?}"));
    }
    if tally.collisions >= 1 << 63 {
        return Err(format!(
            "the observables' collision count is {}",
            tally.collisions
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use carom_engine::glam::DVec2;

    fn one(x: f64, v: f64, radius: f64, mass: f64) -> Particles<DVec2> {
        let mut p = Particles::new();
        let _ = p.push(DVec2::new(x, 0.0), DVec2::new(v, 0.0), radius, mass);
        p
    }

    #[test]
    fn a_state_out_of_range_is_refused_naming_the_particle_and_the_value() {
        assert!(check_state(&one(1.0, 2.0, 0.5, 1.0)).is_ok());
        // (a run may go past a scene's limits: a scene at them, falling for a few steps)
        assert!(check_state(&one(-6e21, 1e20, 0.5, 1.0)).is_ok());
        for (bad, what) in [
            (one(1e300, 0.0, 0.5, 1.0), "position"),
            (one(0.0, 1e300, 0.5, 1.0), "velocity"),
            (one(0.0, 0.0, 1e300, 1.0), "radius"),
            (one(0.0, 0.0, 0.5, 5e-324), "mass"),
        ] {
            assert_eq!(bad.len(), 1, "the engine takes the {what}");
            let e = check_state(&bad).unwrap_err();
            assert!(e.starts_with(&format!("particle 0: {what} ")), "{e}");
        }
    }

    #[test]
    fn remembered_values_out_of_range_are_refused() {
        let (mut impulses, mut tally) = (ContactImpulses::default(), Tally::default());
        impulses.pairs.push((0, 1, 2.5));
        assert!(check_remembered(&impulses, &tally).is_ok());
        impulses.pairs[0].2 = 1e300;
        let e = check_remembered(&impulses, &tally).unwrap_err();
        assert!(e.contains("pair impulse (0, 1)"), "{e}");
        impulses.pairs.clear();
        tally.thermal = f64::NAN;
        let e = check_remembered(&impulses, &tally).unwrap_err();
        assert!(e.contains("thermal"), "{e}");
        tally.thermal = 0.0;
        tally.collisions = u64::MAX;
        let e = check_remembered(&impulses, &tally).unwrap_err();
        assert!(e.contains("collision count"), "{e}");
    }
}
