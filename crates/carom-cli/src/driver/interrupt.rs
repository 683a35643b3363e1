//! Ctrl-C and SIGTERM: the first stops the run after the current step (a checkpoint is
//! written, if asked for, the trajectory flushed, exit status 130); a second exits at once,
//! also with status 130, and leaves no partial file: the temporaries of atomic writes under way
//! are removed (their targets keep their previous, whole contents), a CSV file being appended
//! to is cut back to its last whole frame or row, and the writing thread is stopped before it
//! can start or finish another file (see [`write_whole`] and [`Guarded`]).

use crate::failure::INTERRUPTED;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

static STOP: AtomicBool = AtomicBool::new(false);

/// Set by a second interrupt, just before the process exits: from then on no file may be
/// started, finished or appended to.
static EXITING: AtomicBool = AtomicBool::new(false);

/// Routes Ctrl-C and SIGTERM to a graceful stop (first) or an immediate exit (second).
pub fn install_interrupt_handler() {
    let _ = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            quit_at_once();
        }
        if !QUIET.load(Ordering::SeqCst) {
            eprintln!(
                "carom: interrupted: stopping after this step and writing what was asked for \
                 (interrupt again to quit at once)"
            );
        }
    });
}

/// Set on the ranks of a split run other than rank 0: `mpirun` passes a Ctrl-C to every rank,
/// and one notice is enough.
static QUIET: AtomicBool = AtomicBool::new(false);

/// Keeps this process's interrupt notices to itself (see [`QUIET`]).
pub fn quiet_interrupts() {
    QUIET.store(true, Ordering::SeqCst);
}

/// The second interrupt: leave only whole files and exit with [`INTERRUPTED`].
fn quit_at_once() -> ! {
    EXITING.store(true, Ordering::SeqCst);
    // A write that registered its temporary before this loses it (and then fails to rename it,
    // or halts in `write_whole`); one that starts after this halts before writing a byte.
    carom_output::remove_in_flight_temporaries();
    // Held until the exit, so the CSV files get no further byte.
    let csv = csv_cut();
    for cut in csv.iter() {
        let _ = if cut.whole == 0 {
            std::fs::remove_file(&cut.path)
        } else {
            cut.file.set_len(cut.whole)
        };
    }
    eprintln!("carom: interrupted again: quitting at once; only whole files are left");
    std::process::exit(INTERRUPTED as i32);
}

/// Stops the calling thread for good once a second interrupt is exiting the process, after
/// removing the temporary it may have registered; returns at once otherwise.
fn halt_if_exiting() {
    if EXITING.load(Ordering::SeqCst) {
        carom_output::remove_in_flight_temporaries();
        loop {
            std::thread::park();
        }
    }
}

/// [`carom_output::write_atomic`] that a second interrupt cannot leave half done: the temporary
/// is registered before `write` runs, so either the exiting handler removes it (and the rename
/// fails), or the writer sees the exit coming and halts, removing it itself. A write the exit
/// made fail never reports its error: the thread halts until the process is gone.
pub(crate) fn write_whole<F>(path: &Path, write: F) -> std::io::Result<()>
where
    F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
{
    let result = carom_output::write_atomic(path, |w| {
        halt_if_exiting();
        write(w)
    });
    if result.is_err() {
        halt_if_exiting();
    }
    result
}

/// A CSV file being appended to (the trajectory, the observables) and the length of its whole
/// rows or frames, for a second interrupt to cut it back to.
struct CsvCut {
    path: PathBuf,
    file: std::fs::File,
    /// Bytes up to the end of the last whole frame (0: none yet, and the file is this run's).
    whole: u64,
}

/// Every CSV file this process appends to, by [`CsvFile::index`].
fn csv_cut() -> std::sync::MutexGuard<'static, Vec<CsvCut>> {
    static CSV: Mutex<Vec<CsvCut>> = Mutex::new(Vec::new());
    CSV.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A CSV file under its `BufWriter`: every write holds the [`csv_cut`] lock and none starts
/// once the process is exiting, so the cut sees no write half done.
pub(crate) struct CsvFile {
    file: std::fs::File,
    /// Length of the file after the last byte written.
    end: u64,
    /// Its place in [`csv_cut`].
    index: usize,
}

impl CsvFile {
    /// Opens `path` for appending rows: a fresh run (`fresh`) starts it empty, a resumed one
    /// appends to what is there.
    pub(crate) fn open(path: &Path, fresh: bool) -> std::io::Result<Self> {
        let file = std::fs::OpenOptions::new()
            .create(true)
            .write(true)
            .append(!fresh)
            .truncate(fresh)
            .open(path)?;
        let end = file.metadata()?.len();
        let mut cuts = csv_cut();
        cuts.push(CsvCut {
            path: path.to_path_buf(),
            file: file.try_clone()?,
            whole: end,
        });
        Ok(Self {
            file,
            end,
            index: cuts.len() - 1,
        })
    }

    /// Records that everything written so far (and flushed) ends in a whole frame or row.
    pub(crate) fn mark_whole(&self) {
        if let Some(cut) = csv_cut().get_mut(self.index) {
            cut.whole = self.end;
        }
    }
}

impl Write for CsvFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let guard = csv_cut();
        if EXITING.load(Ordering::SeqCst) {
            drop(guard);
            halt_if_exiting();
        }
        let n = self.file.write(buf)?;
        self.end += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

/// True once Ctrl-C or SIGTERM asked the run to stop.
pub fn stop_requested() -> bool {
    STOP.load(Ordering::SeqCst)
}

/// The files of a long run as a second interrupt needs them written: whole files through
/// [`write_whole`], appends under the lock the exiting handler takes, never after it.
#[derive(Clone, Copy, Debug, Default)]
pub struct Guarded;

impl carom_output::Files for Guarded {
    fn write_whole<W>(&self, path: &Path, write: W) -> std::io::Result<()>
    where
        W: FnOnce(&mut dyn Write) -> std::io::Result<()>,
    {
        write_whole(path, write)
    }

    fn append<W>(&self, write: W) -> std::io::Result<()>
    where
        W: FnOnce() -> std::io::Result<()>,
    {
        let guard = csv_cut();
        if EXITING.load(Ordering::SeqCst) {
            drop(guard);
            halt_if_exiting();
        }
        write()
    }
}
