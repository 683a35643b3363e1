//! The summary `carom run` and `carom resume` print at the end of a run.

use super::step::Driven;
use super::{Before, Labels};
use carom_engine::{Vector, World};

/// Everything the summary reports: how the run is named, the world at the end, the conserved
/// quantities at the start, and what the step loop saw.
pub struct Summary<'a, V: Vector> {
    /// Name, origin and final CSV of the run.
    pub run: &'a Labels<'a>,
    /// The world at the end.
    pub world: &'a World<V>,
    /// Energies and momentum at the start.
    pub before: &'a Before<V>,
    /// What the loop saw.
    pub driven: &'a Driven,
    /// The deepest overlap at the end over every pair (see `World::deepest_overlap`), as a
    /// fraction of the smaller radius.
    pub end_overlap: f64,
    /// The grid's cells in the last step (see `World::grid_cells`), if it took one.
    pub grid_cells: Option<[usize; 3]>,
}

impl<V: Vector> Summary<'_, V> {
    /// Prints the summary to stdout.
    pub fn print(&self) {
        self.print_setup();
        if self.driven.steps_run > 0 {
            self.print_work();
        }
        self.print_conservation();
        if let Some(out) = self.run.out {
            println!("output      {}", out.display());
        }
    }

    /// Scene, particles, broad phase, threads, steps.
    fn print_setup(&self) {
        let (world, run) = (self.world, self.run);
        let name = run.name.unwrap_or("(unnamed)");
        println!("scene       {name} [{}]", run.origin);
        let broad = self.broad_phase();
        println!(
            "particles   {} ({}D), broad phase {broad}, {} threads",
            world.len(),
            V::DIM,
            rayon::current_num_threads()
        );
        println!(
            "steps       {} x dt {} = {} time units simulated",
            self.driven.steps_run,
            world.config().dt,
            world.time()
        );
    }

    /// The broad phase, with the grid's cells: those the scene asks for, or those derived
    /// from the reaches in the last step (they may differ from step to step).
    fn broad_phase(&self) -> String {
        let world = self.world;
        let asked = world.config().grid_cells.as_deref();
        let shown = |c: &[usize]| {
            let cells: Vec<String> = c[..V::DIM].iter().map(|n| n.to_string()).collect();
            cells.join("x")
        };
        let name = world.broad_phase_name();
        // (a grid's name may say that it hashes those outside its domain)
        let Some(note) = name.strip_prefix("grid") else {
            return name.to_string();
        };
        let cells = match (self.grid_cells, asked) {
            (Some(c), Some(_)) => format!(" {}", shown(&c)),
            (None, Some(c)) => format!(" {}", shown(c)),
            (Some(c), None) => format!(" {} (derived: the last step's)", shown(&c)),
            (None, None) => ", cells derived each step".to_string(),
        };
        format!("grid{cells}{note}")
    }

    /// Time, contacts, collisions, the solver's cap, sleep and overlap (for a run of at least
    /// one step).
    fn print_work(&self) {
        let (world, d) = (self.world, self.driven);
        let steps = d.steps_run;
        println!(
            "time        {:.3} s wall, {:.4} ms per step",
            d.seconds,
            d.seconds * 1e3 / steps as f64
        );
        // (a pile rests a hair apart, within the slop: few of its pairs overlap, most push)
        println!(
            "contacts    {:.2} overlapping per step on average, {} at most; {:.2} pushing, {} at \
             most{}",
            d.contacts_total as f64 / steps as f64,
            d.contacts_max,
            d.pushing_total as f64 / steps as f64,
            d.pushing_max,
            match d.last_capped {
                Some(last) if d.capped_steps > 0 => format!(
                    ", iteration cap reached in {} steps (the last at step {last})",
                    d.capped_steps
                ),
                _ => String::new(),
            }
        );
        println!(
            "collisions  {} particle-particle impacts, {:.4} per particle per time unit",
            d.collisions_total,
            d.collisions_total as f64
                / (world.len().max(1) as f64 * steps as f64 * world.config().dt)
        );
        if d.capped_steps > 0 {
            println!(
                "solver      the velocity sweeps stopped at their cap ({} a step, shared by \
                 the substeps when contacts can rest) in {} of {steps} steps: contacts still \
                 approaching then were met again the next step \
                 (under gravity a last sweep up the pile first holds each particle on the ones \
                 below it; the position phase bounds the overlap; a dense gas at low k collapses \
                 inelastically, a deep pile needs more sweeps: [solver] velocity_iterations)",
                world.config().velocity_iterations,
                d.capped_steps
            );
        }
        if world.config().sleep_settings(world.planes()).is_some() {
            let n = world.len();
            match d.asleep_since {
                Some(since) if d.asleep_last == n => {
                    println!("sleep       all {n} particles asleep since step {since}")
                }
                _ => println!(
                    "sleep       {} of {n} particles asleep at the end",
                    d.asleep_last
                ),
            }
        }
        println!(
            "overlap     {:.3}% of the smaller radius at the end, {:.3}% at most",
            self.end_overlap * 100.0,
            d.worst_overlap.max(self.end_overlap) * 100.0
        );
        if d.retaken_steps > 0 {
            println!(
                "retakes     {} of {steps} steps were taken again ({} tries in all): a push down a \
                 chain of contacts drove a particle beyond its reach into one the step had no \
                 contact for, so the step was taken back and taken again with that particle's \
                 reach covering its move",
                d.retaken_steps, d.retakes
            );
        }
        if d.outran_steps > 0 {
            println!(
                "moves       in {} of {steps} steps a particle started faster than its radius a \
                 step (at most {:.2} radii, at step {}): a pair it closed on from beyond its \
                 contact candidates was found after the move, as the lecture's detection finds \
                 it, and pushed apart then (the overlap at most shows how deep); a smaller dt \
                 finds such pairs before they meet",
                d.outran_steps, d.fastest_move, d.fastest_move_step
            );
        }
    }

    /// Energy and momentum, start against end.
    fn print_conservation(&self) {
        let (world, before) = (self.world, self.before);
        let (ke0, pe0) = (before.kinetic, before.potential);
        let (ke1, pe1) = (world.kinetic_energy(), world.potential_energy());
        println!(
            "energy      kinetic {} -> {} ({})",
            fmt(ke0),
            fmt(ke1),
            change(ke0, ke1)
        );
        // Potential energy has an arbitrary zero (the origin), so only its change means anything.
        println!(
            "            kinetic + potential changed by {:+.6e} ({:+.3}% of the initial kinetic)",
            (ke1 + pe1) - (ke0 + pe0),
            if ke0 > 0.0 {
                ((ke1 + pe1) - (ke0 + pe0)) / ke0 * 100.0
            } else {
                0.0
            }
        );
        println!(
            "momentum    {} -> {}",
            vec_fmt(before.momentum),
            vec_fmt(world.momentum())
        );
    }
}

fn fmt(x: f64) -> String {
    format!("{x:.6e}")
}

fn change(a: f64, b: f64) -> String {
    if a == 0.0 {
        format!("{:+.3e}", b - a)
    } else {
        format!("{:+.3}%", (b - a) / a.abs() * 100.0)
    }
}

fn vec_fmt<V: Vector>(v: V) -> String {
    let parts: Vec<String> = (0..V::DIM).map(|a| format!("{:.6e}", v.get(a))).collect();
    format!("({})", parts.join(", "))
}
