//! Observables files (`--observe FILE.csv --every K`): the readings of
//! [`carom_engine::observe`], a row at the start and every K steps, flushed row by row as the
//! CSV trajectory is; a resumed run appends to the same file.

use carom_engine::Observables;
use std::io::{self, Write};

/// The file's header line.
pub const HEADER: &str =
    "step,time,kinetic_energy,potential_energy,temperature,collisions,pressure,max_overlap";

/// An observables file being written into `W`.
pub struct ObservablesCsv<W: Write> {
    out: W,
}

impl<W: Write> ObservablesCsv<W> {
    /// Starts writing into `out`: a fresh run (`fresh`) with the header, a resumed one appends.
    pub fn open(mut out: W, fresh: bool) -> io::Result<Self> {
        if fresh {
            writeln!(out, "{HEADER}")?;
        }
        Ok(Self { out })
    }

    /// Appends one reading as a whole row, and flushes.
    pub fn row(&mut self, o: &Observables) -> io::Result<()> {
        writeln!(
            self.out,
            "{},{},{},{},{},{},{},{}",
            o.step,
            o.time,
            o.kinetic_energy,
            o.potential_energy,
            o.temperature,
            o.collisions,
            o.pressure,
            o.max_overlap
        )?;
        self.out.flush()
    }

    /// What it writes into.
    pub fn get_ref(&self) -> &W {
        &self.out
    }
}
