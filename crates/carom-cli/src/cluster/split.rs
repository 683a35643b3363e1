//! A run split over ranks, as the step loop sees it.

use crate::driver::interrupt::stop_requested;
use crate::driver::step::Stepper;
use carom_engine::cluster::{Subdomain, TrafficKind, Transport};
use carom_engine::{StepStats, Vector, World};

/// This rank's part of a run. Every rank builds the whole world from the scene (so they agree
/// on every setting), keeps its share, and steps it with the others. Rank 0 also keeps the
/// whole world, refreshed from the ranks' shares whenever output needs it.
pub struct Split<V: Vector, T: Transport> {
    part: Subdomain<V>,
    transport: T,
    world: World<V>,
    gathered_at: Option<u64>,
    on_pool: bool,
}

impl<V: Vector, T: Transport> Split<V, T> {
    /// Splits `world` (built the same way on every rank). `on_pool`: run the step loop on a
    /// rayon pool thread, which only a process holding one rank may do.
    pub fn new(
        world: World<V>,
        transport: T,
        on_pool: bool,
    ) -> Result<Self, carom_engine::EngineError> {
        let part = Subdomain::new(&world, transport.rank(), transport.size())?;
        Ok(Self {
            part,
            transport,
            world,
            gathered_at: None,
            on_pool,
        })
    }

    /// This rank.
    pub fn rank(&self) -> usize {
        self.transport.rank()
    }

    /// Particles per rank and every rank's traffic so far, on rank 0. Collective.
    pub fn report(&mut self) -> Option<Report> {
        let t = self.part.traffic();
        let mut mine = Vec::new();
        mine.extend_from_slice(&(self.part.len() as u64).to_le_bytes());
        for kind in TrafficKind::ALL {
            mine.extend_from_slice(&t.bytes(kind).to_le_bytes());
            mine.extend_from_slice(&t.collectives(kind).to_le_bytes());
        }
        let all = self.transport.all_gather(&mine);
        if self.rank() != 0 {
            return None;
        }
        let words = |b: &[u8]| -> Vec<u64> {
            b.chunks_exact(8)
                .map(|c| u64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
                .collect()
        };
        let mut report = Report::default();
        for bytes in &all {
            let w = words(bytes);
            report.owned.push(w.first().copied().unwrap_or(0) as usize);
            report
                .traffic
                .push(w[1..].chunks_exact(2).map(|c| (c[0], c[1])).collect());
        }
        Some(report)
    }
}

/// What a split run reports after its summary.
#[derive(Debug, Default)]
pub struct Report {
    /// Particles per rank.
    pub owned: Vec<usize>,
    /// `traffic[rank][kind] = (bytes, collectives)`, kinds in [`TrafficKind::ALL`] order.
    pub traffic: Vec<Vec<(u64, u64)>>,
}

impl Report {
    /// The split-run lines of `carom run`'s summary: particles per rank and what the ranks
    /// sent each other per step (mean over ranks), by kind.
    pub fn print(&self, steps: u64) {
        let owned: Vec<String> = self.owned.iter().map(|n| n.to_string()).collect();
        println!(
            "ranks       {} (particles per rank: {})",
            self.owned.len(),
            owned.join(", ")
        );
        if steps == 0 || self.traffic.is_empty() {
            return;
        }
        let ranks = self.traffic.len() as f64;
        let mut parts = Vec::new();
        let (mut bytes, mut collectives) = (0.0, 0.0);
        for (k, kind) in TrafficKind::ALL.iter().enumerate() {
            if *kind == TrafficKind::Gather {
                continue; // output, not stepping
            }
            let b = self.traffic.iter().map(|t| t[k].0 as f64).sum::<f64>() / ranks / steps as f64;
            bytes += b;
            collectives += self.traffic[0][k].1 as f64 / steps as f64;
            parts.push(format!("{} {:.2}", kind.name(), b / 1024.0));
        }
        println!(
            "traffic     {:.2} KiB sent per rank per step ({} KiB), {collectives:.1} collectives per step",
            bytes / 1024.0,
            parts.join(", ")
        );
    }
}

impl<V: Vector, T: Transport + Send> Stepper<V> for Split<V, T> {
    fn step(&mut self) -> StepStats {
        self.part.step(&mut self.transport)
    }

    fn steps_taken(&self) -> u64 {
        self.part.steps_taken()
    }

    fn world(&mut self) -> Option<&mut World<V>> {
        let steps = self.part.steps_taken();
        if self.gathered_at != Some(steps) {
            if let Some(snapshot) = self.part.gather(&mut self.transport) {
                // The snapshot comes from the same world: same count, a valid order.
                self.world
                    .restore(snapshot)
                    .expect("a gathered state fits the world it came from");
            }
            self.gathered_at = Some(steps);
        }
        (self.transport.rank() == 0).then_some(&mut self.world)
    }

    fn observe(&mut self) -> Option<carom_engine::Observables> {
        // (refused before the run starts: the collisional virial is summed per rank)
        None
    }

    fn stop_requested(&mut self) -> bool {
        // Signals reach ranks at different moments: stop when any rank saw one, all at the
        // same step.
        let mine = [stop_requested() as u8];
        self.transport
            .all_gather(&mine)
            .iter()
            .any(|v| v.first() == Some(&1))
    }

    fn run_loop(&mut self, work: impl FnOnce(&mut Self) + Send) {
        if self.on_pool {
            // As for one world: parallel calls from outside the pool would hand every one of
            // them to a worker and wait (two context switches each).
            rayon::scope(|_| work(self));
        } else {
            work(self);
        }
    }
}
