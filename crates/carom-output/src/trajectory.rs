//! CSV trajectories (`--trajectory PATH.csv --every K`): one file, `step,time,id,x..,v..,
//! radius,mass`, a frame at the start and every K steps. The writer flushes frame by frame, so
//! a killed run leaves every whole frame readable; the caller decides what to write into (the
//! command line's file also records where its last whole frame ends).

use carom_engine::{Vector, World};
use std::io::{self, Write};

/// The header line for `dim` dimensions (without the newline).
pub fn header(dim: usize) -> String {
    format!("step,time,{}", crate::csv_header(dim))
}

/// A CSV trajectory being written into `W`.
pub struct CsvTrajectory<W: Write> {
    out: W,
}

impl<W: Write> CsvTrajectory<W> {
    /// A new trajectory: the header, then `world` as the first frame.
    pub fn start<V: Vector>(mut out: W, world: &World<V>) -> io::Result<Self> {
        writeln!(out, "{}", header(V::DIM))?;
        let mut trajectory = Self { out };
        trajectory.frame(world)?;
        Ok(trajectory)
    }

    /// Frames appended to a trajectory already started (a resumed run).
    pub fn resume(out: W) -> Self {
        Self { out }
    }

    /// Appends `world` as one frame, one row per particle in id order, and flushes.
    pub fn frame<V: Vector>(&mut self, world: &World<V>) -> io::Result<()> {
        let (step, time) = (world.steps_taken(), world.time());
        for id in 0..world.len() {
            let (x, v, r, m) = world.particle(id);
            write!(self.out, "{step},{time},")?;
            crate::write_state_row(&mut self.out, id, x, v, r, m)?;
        }
        self.out.flush()
    }

    /// What it writes into.
    pub fn get_ref(&self) -> &W {
        &self.out
    }
}
