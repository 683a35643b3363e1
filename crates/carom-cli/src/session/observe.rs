//! `--observe FILE.csv --every K`: the observables of [`carom_engine::observe`], a row at the
//! start and every K steps, appended and flushed row by row as the CSV trajectory is, so a
//! killed run leaves whole rows only; a resumed run appends to the same file.

use super::CsvFile;
use carom_engine::Observables;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The file's header line.
pub const HEADER: &str =
    "step,time,kinetic_energy,potential_energy,temperature,collisions,pressure,max_overlap";

/// An observables file being written.
pub struct ObservationFile {
    out: BufWriter<CsvFile>,
    path: PathBuf,
}

impl ObservationFile {
    /// Opens `path`: a fresh run (`fresh`) starts it with the header, a resumed one appends.
    pub fn open(path: &Path, fresh: bool) -> std::io::Result<Self> {
        let mut out = BufWriter::new(CsvFile::open(path, fresh)?);
        if fresh {
            writeln!(out, "{HEADER}")?;
        }
        Ok(Self {
            out,
            path: path.to_path_buf(),
        })
    }

    /// Appends one reading as a whole row.
    pub fn row(&mut self, o: &Observables) -> std::io::Result<()> {
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
        self.out.flush()?;
        self.out.get_ref().mark_whole();
        Ok(())
    }

    /// Where it goes, for messages.
    pub fn path(&self) -> &Path {
        &self.path
    }
}
