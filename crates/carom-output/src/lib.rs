//! # carom-output
//!
//! Output formats for carom. Every file is written whole or not at all: the bytes go to a
//! temporary file in the same folder, which is flushed, synced and then renamed over the
//! target, so a crash or a bad input never leaves a half-written file behind.

pub mod checkpoint;
pub mod observables;
pub mod trajectory;
pub mod vtk;

use carom_engine::{Particles, Vector};
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// The file a path names, for comparing paths: the whole path resolved when it exists (a
/// link to a file is the file), else its folder resolved (links, `..`) and its name as given.
/// `None` when the folder does not exist.
fn file_identity(path: &Path) -> Option<std::path::PathBuf> {
    if let Ok(resolved) = path.canonicalize() {
        return Some(resolved);
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Some(dir.canonicalize().ok()?.join(path.file_name()?))
}

/// Whether `a` and `b` name one file: the same path once resolved (see `file_identity`), or,
/// both existing, the same file on the same device under two names (a hard link). What every
/// output is compared with the inputs and the other outputs by, so that none overwrites them.
pub fn same_file(a: &Path, b: &Path) -> bool {
    let (Some(id_a), Some(id_b)) = (file_identity(a), file_identity(b)) else {
        return false;
    };
    if id_a == id_b {
        return true;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(a), Ok(b)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return (a.dev(), a.ino()) == (b.dev(), b.ino());
        }
    }
    false
}

/// The bytes of the file at `path`, refusing anything but a regular file: a named pipe with
/// no writer would block the read for good (and a device may never end).
pub fn read_regular_file(path: &Path) -> io::Result<Vec<u8>> {
    // (before opening it: opening a named pipe to read waits for a writer)
    // (a folder is left to the read, whose error says so with its errno)
    let kind = std::fs::metadata(path)?;
    if !kind.is_file() && !kind.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "not a regular file (a device or a pipe?)",
        ));
    }
    std::fs::read(path)
}

/// [`read_regular_file`] as UTF-8 text.
pub fn read_regular_text(path: &Path) -> io::Result<String> {
    String::from_utf8(read_regular_file(path)?)
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidData, "not UTF-8 text"))
}

/// How the writers of a long run ([`vtk::Series`]) touch their files: whole files through
/// [`write_atomic`] and small writes into an open file as they are. The command line wraps both
/// so that a second Ctrl-C, which exits at once, can neither leave a file half done nor see a
/// write start after it.
pub trait Files {
    /// Writes `path` whole or not at all.
    fn write_whole<W>(&self, path: &Path, write: W) -> io::Result<()>
    where
        W: FnOnce(&mut dyn Write) -> io::Result<()>;

    /// Runs `write`, one small write into a file already open.
    fn append<W>(&self, write: W) -> io::Result<()>
    where
        W: FnOnce() -> io::Result<()>,
    {
        write()
    }
}

/// [`Files`] as they are: [`write_atomic`], and appends at once.
#[derive(Clone, Copy, Debug, Default)]
pub struct Atomic;

impl Files for Atomic {
    fn write_whole<W>(&self, path: &Path, write: W) -> io::Result<()>
    where
        W: FnOnce(&mut dyn Write) -> io::Result<()>,
    {
        write_atomic(path, write)
    }
}

/// Writes `path` atomically: `write` fills a buffered temporary in the same folder, which
/// replaces `path` only if everything succeeded.
pub fn write_atomic<F>(path: &Path, write: F) -> io::Result<()>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    // (the temporary renamed over a device or a named pipe would put a file in its place)
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        return Err(io::Error::other(format!(
            "{} is not a regular file (a device or a pipe?)",
            path.display()
        )));
    }
    // (made and registered under one lock: a process exiting at once between the two would
    // leave a temporary nobody removes)
    let (mut tmp, tmp_path) = {
        let mut in_flight = in_flight();
        if in_flight.closed {
            return Err(io::Error::other(
                "the process is exiting at once: no file is started",
            ));
        }
        let tmp = tempfile::Builder::new()
            .prefix(".carom-")
            .suffix(".tmp")
            .tempfile_in(dir)?;
        let tmp_path = tmp.path().to_path_buf();
        in_flight.paths.push(tmp_path.clone());
        (tmp, tmp_path)
    };
    let result = (|| {
        {
            let mut w = BufWriter::with_capacity(1 << 16, tmp.as_file_mut());
            write(&mut w)?;
            w.flush()?;
        }
        // Temporaries are private (0600); the result is an ordinary file.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            tmp.as_file()
                .set_permissions(std::fs::Permissions::from_mode(0o644))?;
        }
        tmp.as_file().sync_all()?;
        tmp.persist(path).map_err(|e| e.error)?;
        Ok(())
    })();
    in_flight().paths.retain(|p| p != &tmp_path);
    result
}

/// The temporaries being written right now, and whether the process is exiting (see
/// [`remove_in_flight_temporaries`]).
struct InFlight {
    paths: Vec<std::path::PathBuf>,
    closed: bool,
}

fn in_flight() -> std::sync::MutexGuard<'static, InFlight> {
    static IN_FLIGHT: std::sync::Mutex<InFlight> = std::sync::Mutex::new(InFlight {
        paths: Vec::new(),
        closed: false,
    });
    IN_FLIGHT
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Deletes the temporaries of writes still under way, for a process about to exit at once (a
/// second Ctrl-C): the targets are then untouched, and nothing half-written is left behind.
/// From then on [`write_atomic`] starts no file (it fails before making its temporary), so no
/// write that was about to begin can leave one either.
pub fn remove_in_flight_temporaries() {
    let mut in_flight = in_flight();
    in_flight.closed = true;
    for p in in_flight.paths.drain(..) {
        let _ = std::fs::remove_file(p);
    }
}

/// The CSV header for `dim` dimensions: `id,x,y,vx,vy,radius,mass` or
/// `id,x,y,z,vx,vy,vz,radius,mass`.
pub fn csv_header(dim: usize) -> &'static str {
    if dim == 2 {
        "id,x,y,vx,vy,radius,mass"
    } else {
        "id,x,y,z,vx,vy,vz,radius,mass"
    }
}

/// Writes the state as CSV: the header, then one row per particle in id order. Numbers use
/// Rust's shortest round-trip form, so each reads back to the very same f64.
pub fn write_state_csv<V: Vector>(particles: &Particles<V>, out: &mut dyn Write) -> io::Result<()> {
    writeln!(out, "{}", csv_header(V::DIM))?;
    let rows = particles
        .positions()
        .iter()
        .zip(particles.velocities())
        .zip(particles.radii().iter().zip(particles.masses()));
    for (id, ((&x, &v), (&r, &m))) in rows.enumerate() {
        write_state_row(out, id, x, v, r, m)?;
    }
    Ok(())
}

/// One state row after whatever the caller has written on the line already:
/// `id,x..,v..,radius,mass` and the newline (the columns of [`csv_header`]).
pub fn write_state_row<V: Vector>(
    out: &mut dyn Write,
    id: usize,
    x: V,
    v: V,
    radius: f64,
    mass: f64,
) -> io::Result<()> {
    write!(out, "{id}")?;
    for a in 0..V::DIM {
        write!(out, ",{}", x.get(a))?;
    }
    for a in 0..V::DIM {
        write!(out, ",{}", v.get(a))?;
    }
    writeln!(out, ",{radius},{mass}")
}

/// Writes the state CSV to `path` atomically.
pub fn save_state_csv<V: Vector>(path: &Path, particles: &Particles<V>) -> io::Result<()> {
    write_atomic(path, |w| write_state_csv(particles, w))
}

/// Why a state CSV could not be read back.
#[derive(Debug, thiserror::Error)]
pub enum StateCsvError {
    /// No header line.
    #[error("empty file")]
    Empty,
    /// A field that is not a number.
    #[error("row {row}: {source}")]
    Number {
        /// Data row, from 1.
        row: usize,
        /// What the number parser said.
        source: std::num::ParseFloatError,
    },
    /// A row with more or fewer fields than the header.
    #[error("row {row}: {found} fields, header has {expected}")]
    Width {
        /// Data row, from 1.
        row: usize,
        /// Its fields.
        found: usize,
        /// The header's.
        expected: usize,
    },
    /// Not CSV at all (e.g. not UTF-8).
    #[error(transparent)]
    Csv(#[from] csv::Error),
}

/// Reads a state CSV back: the column names and each row's numbers (the id column included).
pub fn read_state_csv(text: &str) -> Result<(Vec<String>, Vec<Vec<f64>>), StateCsvError> {
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .from_reader(text.as_bytes());
    let header: Vec<String> = reader.headers()?.iter().map(str::to_string).collect();
    if header.is_empty() {
        return Err(StateCsvError::Empty);
    }
    let mut rows = Vec::new();
    for (n, record) in reader.records().enumerate() {
        let (record, row) = (record?, n + 1);
        let numbers = record
            .iter()
            .map(str::parse::<f64>)
            .collect::<Result<Vec<_>, _>>()
            .map_err(|source| StateCsvError::Number { row, source })?;
        if numbers.len() != header.len() {
            return Err(StateCsvError::Width {
                row,
                found: numbers.len(),
                expected: header.len(),
            });
        }
        rows.push(numbers);
    }
    Ok((header, rows))
}

#[cfg(test)]
mod tests {
    use super::*;
    use carom_engine::glam::{DVec2, DVec3};

    #[test]
    fn csv_round_trips_bit_for_bit() {
        let mut p = Particles::new();
        p.push(
            DVec3::new(0.1, -1.0 / 3.0, 1e-300),
            DVec3::new(std::f64::consts::PI, -0.0, 7.0),
            0.3,
            2.5,
        )
        .unwrap();
        let mut out = Vec::new();
        write_state_csv(&p, &mut out).unwrap();
        let (header, rows) = read_state_csv(std::str::from_utf8(&out).unwrap()).unwrap();
        assert_eq!(header.join(","), csv_header(3));
        assert_eq!(rows[0][1].to_bits(), 0.1f64.to_bits());
        assert_eq!(rows[0][2].to_bits(), (-1.0f64 / 3.0).to_bits());
        assert_eq!(rows[0][4].to_bits(), std::f64::consts::PI.to_bits());
        assert_eq!(rows[0][5].to_bits(), (-0.0f64).to_bits());
    }

    #[test]
    fn bad_state_files_are_refused_with_the_row() {
        assert!(matches!(read_state_csv(""), Err(StateCsvError::Empty)));
        let e = read_state_csv("id,x\n0,1\n1,oops\n").unwrap_err();
        assert!(matches!(e, StateCsvError::Number { row: 2, .. }), "{e}");
        let e = read_state_csv("id,x\n0,1,2\n").unwrap_err();
        assert_eq!(e.to_string(), "row 1: 3 fields, header has 2");
    }

    #[test]
    fn atomic_write_leaves_nothing_on_failure() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.csv");
        let r = write_atomic(&target, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "no target, no temporary"
        );
        let mut p = Particles::new();
        p.push(DVec2::ZERO, DVec2::X, 1.0, 1.0).unwrap();
        save_state_csv(&target, &p).unwrap();
        assert_eq!(
            std::fs::read_to_string(&target).unwrap(),
            "id,x,y,vx,vy,radius,mass\n0,0,0,1,0,1,1\n"
        );
    }

    /// A named pipe (or a device) in place of the target is refused, not replaced by a file.
    #[cfg(unix)]
    #[test]
    fn atomic_write_refuses_a_target_that_is_not_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let pipe = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&pipe).status();
        if !made.is_ok_and(|s| s.success()) {
            return eprintln!("no mkfifo: skipped");
        }
        let e = write_atomic(&pipe, |w| w.write_all(b"x")).unwrap_err();
        assert!(e.to_string().contains("not a regular file"), "{e}");
        assert!(!pipe.is_file(), "the pipe is still a pipe");
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temporary"
        );
    }
}
