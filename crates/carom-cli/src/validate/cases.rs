//! The validation cases, their measurements and their tolerances.

use super::gas::{Gas, Start, DIAMETER, MASS};
use carom_engine::glam::{DVec2, DVec3};
use carom_engine::theory::{compressibility, haff_temperature, haff_time, kurtosis_excess};
use carom_engine::Vector;
use carom_plot::Comparison;

/// The time step of every case, in units of `s sqrt(m / T0)`: a particle at the thermal speed
/// moves 0.5 % of its diameter per step (see the dt table for what larger steps cost).
const DT: f64 = 0.005;

/// How big the gases are and how long they are watched.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Size {
    /// docs/validation.md's figures.
    Full,
    /// The test suite's (fewer particles, shorter windows).
    Quick,
}

impl Size {
    fn particles(self, d: usize) -> usize {
        match (self, d) {
            (Size::Full, 2) => 4000,
            (Size::Full, _) => 4000,
            (Size::Quick, 2) => 1000,
            (Size::Quick, _) => 1000,
        }
    }

    /// Mean free times the equation of state is averaged over.
    fn window(self) -> f64 {
        match self {
            Size::Full => 100.0,
            Size::Quick => 40.0,
        }
    }
}

/// One number measured against theory.
pub struct Check {
    pub name: String,
    pub measured: f64,
    pub theory: f64,
    /// Allowed error: relative (a fraction of `theory`), or absolute when `absolute`.
    pub tolerance: f64,
    pub absolute: bool,
}

impl Check {
    fn relative(name: String, measured: f64, theory: f64, tolerance: f64) -> Self {
        Self {
            name,
            measured,
            theory,
            tolerance,
            absolute: false,
        }
    }

    /// The error: `measured / theory - 1`, or `measured - theory` when absolute.
    pub fn error(&self) -> f64 {
        if self.absolute {
            self.measured - self.theory
        } else {
            self.measured / self.theory - 1.0
        }
    }

    pub fn passes(&self) -> bool {
        self.error().abs() <= self.tolerance
    }

    /// The error as printed (per cent when relative).
    pub fn error_shown(&self) -> f64 {
        self.error() * if self.absolute { 1.0 } else { 100.0 }
    }

    pub fn tolerance_shown(&self) -> f64 {
        self.tolerance * if self.absolute { 1.0 } else { 100.0 }
    }

    pub fn unit(&self) -> &'static str {
        if self.absolute {
            " "
        } else {
            "%"
        }
    }
}

/// What one case measured, and its plots (file name, plot).
pub struct Outcome {
    pub checks: Vec<Check>,
    pub plots: Vec<(&'static str, Comparison)>,
}

/// The cases, in the order they run.
#[derive(Clone, Copy, Debug)]
pub enum Case {
    Haff(usize),
    StateAndRate(usize),
    Maxwell,
}

impl Case {
    pub fn all() -> Vec<Case> {
        vec![
            Case::Haff(2),
            Case::Haff(3),
            Case::StateAndRate(2),
            Case::StateAndRate(3),
            Case::Maxwell,
        ]
    }

    pub fn name(&self) -> String {
        match self {
            Case::Haff(d) => format!("Haff's law, {d}D"),
            Case::StateAndRate(d) => format!("equation of state and collision rate, {d}D"),
            Case::Maxwell => "relaxation to Maxwell-Boltzmann, 2D".into(),
        }
    }

    pub fn run(&self, size: Size) -> Outcome {
        match *self {
            Case::Haff(2) => haff::<DVec2>(size),
            Case::Haff(_) => haff::<DVec3>(size),
            Case::StateAndRate(2) => state_and_rate::<DVec2>(size),
            Case::StateAndRate(_) => state_and_rate::<DVec3>(size),
            Case::Maxwell => maxwell(size),
        }
    }
}

/// Lets a gas forget its lattice start: `collisions` mean free times at `k` = 1.
fn equilibrate<V: Vector>(gas: &mut Gas<V>, collisions: f64) {
    let tau = 1.0 / gas.enskog_rate(1.0);
    let steps = gas.steps_for(collisions * tau);
    gas.run(steps);
}

/// Haff's law: gases of 1000 particles at packing 0.1 and `k` = 0.95 cooling for two `t0`,
/// sampled every `t0 / 10` (the mean over seeds: one quick, four in full). Why these: the
/// homogeneous cooling state is unstable (shear modes, then clusters: Goldhirsch and Zanetti
/// 1993), the sooner the more inelastic, the denser and the larger the box; docs/validation.md
/// shows what e = 0.9 or 4000 particles give.
fn haff<V: Vector>(size: Size) -> Outcome {
    let d = V::DIM;
    let (eta, e, n) = (0.1, 0.95, 1000);
    let seeds = match size {
        Size::Full => 4,
        Size::Quick => 1,
    };
    // T / T0 at k t0 / 10, k = 0..=20, summed over the seeds
    let mut sums = [0.0; 21];
    let mut times = [0.0; 21];
    for seed in 0..seeds {
        let mut gas = Gas::<V>::new(n, eta, 1.0, DT, Start::Maxwell, 7 + 10 * seed + d as u64);
        equilibrate(&mut gas, 10.0);
        gas.world.set_restitution(e).expect("k in [0, 1]");
        let start = gas.world.observe();
        let t0 = haff_time(d, e, gas.enskog_rate(start.temperature));
        let mut elapsed = 0.0;
        sums[0] += 1.0;
        for k in 1..=20 {
            let steps = gas.steps_for(k as f64 * t0 / 10.0 - elapsed);
            gas.run(steps);
            elapsed += steps as f64 * DT;
            sums[k] += gas.world.observe().temperature / start.temperature;
            times[k] += elapsed / t0;
        }
    }
    let measured: Vec<(f64, f64)> = sums
        .iter()
        .zip(&times)
        .map(|(&t, &x)| (x / seeds as f64, t / seeds as f64))
        .collect();
    let worst = measured
        .iter()
        .map(|&(x, ratio)| ratio / haff_temperature(1.0, x, 1.0) - 1.0)
        .fold(
            0.0f64,
            |worst, e| if e.abs() > worst.abs() { e } else { worst },
        );
    let theory = (0..=100)
        .map(|k| {
            let x = k as f64 * 0.02;
            (x, haff_temperature(1.0, x, 1.0))
        })
        .collect();
    let file = if d == 2 { "haff_2d.png" } else { "haff_3d.png" };
    Outcome {
        checks: vec![Check::relative(
            format!("Haff {d}D: largest T / T_Haff - 1 over 2 t0"),
            1.0 + worst,
            1.0,
            0.03,
        )],
        plots: vec![(
            file,
            Comparison {
                title: format!(
                    "Haff's law, {d}D: {n} particles, packing {eta}, e = {e}, {seeds} run(s)"
                ),
                x_label: "t / t0".into(),
                y_label: "T / T0".into(),
                measured,
                measured_label: "carom".into(),
                theory,
                theory_label: "T0 / (1 + t/t0)^2 (Enskog t0)".into(),
            },
        )],
    }
}

/// Z and the collision frequency of an elastic gas at `eta`, over `window` mean free times,
/// with time step `dt`: `(Z, w / w_Enskog)`.
fn measure_state<V: Vector>(size: Size, eta: f64, dt: f64, seed: u64) -> (f64, f64, f64, f64) {
    let mut gas = Gas::<V>::new(size.particles(V::DIM), eta, 1.0, dt, Start::Maxwell, seed);
    equilibrate(&mut gas, 10.0);
    let before = gas.world.observe();
    let tau = 1.0 / gas.enskog_rate(before.temperature);
    let steps = gas.steps_for(size.window() * tau);
    gas.run(steps);
    let after = gas.world.observe();
    let interval = after.time - before.time;
    let temperature = after.temperature;
    let z = after.pressure * gas.volume / (gas.n as f64 * temperature);
    let rate = 2.0 * (after.collisions - before.collisions) as f64 / (gas.n as f64 * interval);
    (
        z,
        compressibility(V::DIM, eta),
        rate,
        gas.enskog_rate(temperature),
    )
}

/// The equation of state and the collision frequency at two packing fractions.
fn state_and_rate<V: Vector>(size: Size) -> Outcome {
    let d = V::DIM;
    let etas: [f64; 2] = if d == 2 { [0.1, 0.3] } else { [0.1, 0.25] };
    let mut checks = Vec::new();
    let (mut z_points, mut rate_points) = (Vec::new(), Vec::new());
    for (k, &eta) in etas.iter().enumerate() {
        let (z, z_theory, rate, rate_theory) = measure_state::<V>(size, eta, DT, 20 + k as u64);
        let law = if d == 2 {
            "Henderson"
        } else {
            "Carnahan-Starling"
        };
        checks.push(Check::relative(
            format!("Z {d}D, packing {eta} ({law})"),
            z,
            z_theory,
            0.03,
        ));
        checks.push(Check::relative(
            format!("collision frequency {d}D, packing {eta} (Enskog)"),
            rate,
            rate_theory,
            0.03,
        ));
        z_points.push((eta, z));
        // per particle, at T = 1 (the rate scales as sqrt(T))
        rate_points.push((eta, rate / rate_theory));
    }
    let curve = |f: &dyn Fn(f64) -> f64| -> Vec<(f64, f64)> {
        (0..=40)
            .map(|k| k as f64 * 0.01)
            .map(|x| (x, f(x)))
            .collect()
    };
    let (z_file, rate_file) = if d == 2 {
        ("state_2d.png", "collision_rate_2d.png")
    } else {
        ("state_3d.png", "collision_rate_3d.png")
    };
    let law = if d == 2 {
        "Henderson (1 + eta^2/8) / (1 - eta)^2"
    } else {
        "Carnahan-Starling (1 + eta + eta^2 - eta^3) / (1 - eta)^3"
    };
    Outcome {
        checks,
        plots: vec![
            (
                z_file,
                Comparison {
                    title: format!("Equation of state, {d}D, k = 1"),
                    x_label: "packing fraction eta".into(),
                    y_label: "Z = P V / (N T)".into(),
                    measured: z_points,
                    measured_label: "carom".into(),
                    theory: curve(&|eta| compressibility(d, eta)),
                    theory_label: law.into(),
                },
            ),
            (
                rate_file,
                Comparison {
                    title: format!("Collision frequency, {d}D, k = 1"),
                    x_label: "packing fraction eta".into(),
                    y_label: "measured / Enskog".into(),
                    measured: rate_points,
                    measured_label: "carom".into(),
                    theory: curve(&|_| 1.0),
                    theory_label: "Enskog".into(),
                },
            ),
        ],
    }
}

/// A 2D elastic gas started with equal speeds relaxes to Maxwell-Boltzmann: `a2` averaged
/// over snapshots one mean free time apart, after ten.
fn maxwell(size: Size) -> Outcome {
    let mut gas = Gas::<DVec2>::new(size.particles(2) * 2, 0.2, 1.0, DT, Start::EqualSpeeds, 5);
    let tau = 1.0 / gas.enskog_rate(1.0);
    let a2 = |gas: &mut Gas<DVec2>| kurtosis_excess(gas.world.particles().velocities());
    let mut measured = vec![(0.0, a2(&mut gas))];
    let (mut elapsed, mut sum, mut count) = (0.0, 0.0, 0);
    let snapshots = match size {
        Size::Full => 40,
        Size::Quick => 20,
    };
    for k in 1..=10 + snapshots {
        let steps = gas.steps_for(k as f64 * tau - elapsed);
        gas.run(steps);
        elapsed += steps as f64 * DT;
        let now = a2(&mut gas);
        measured.push((elapsed / tau, now));
        if k > 10 {
            sum += now;
            count += 1;
        }
    }
    let mean = sum / count as f64;
    Outcome {
        checks: vec![Check {
            name: "a2 2D after 10 mean free times (MB: 0)".into(),
            measured: mean,
            theory: 0.0,
            tolerance: 0.05,
            absolute: true,
        }],
        plots: vec![(
            "maxwell_2d.png",
            Comparison {
                title: format!(
                    "Relaxation to Maxwell-Boltzmann, 2D: {} particles, equal speeds at t = 0",
                    gas.n
                ),
                x_label: "t / mean free time".into(),
                y_label: "a2 = (d/(d+2)) <v^4> / <v^2>^2 - 1".into(),
                measured,
                measured_label: "carom".into(),
                theory: vec![(0.0, 0.0), (elapsed / tau, 0.0)],
                theory_label: "Maxwell-Boltzmann (a2 = 0)".into(),
            },
        )],
    }
}

/// `(dt, Z error, collision frequency error)` of the 2D gas at packing 0.3 for four steps.
pub fn dt_table(size: Size) -> Vec<(f64, f64, f64)> {
    [0.04, 0.02, 0.01, 0.005]
        .into_iter()
        .map(|dt| {
            let (z, z_theory, rate, rate_theory) = measure_state::<DVec2>(size, 0.3, dt, 21);
            (dt, z / z_theory - 1.0, rate / rate_theory - 1.0)
        })
        .collect()
}

// (used by the docs' units: lengths in diameters, masses in particle masses)
const _: () = assert!(DIAMETER == 1.0 && MASS == 1.0);
