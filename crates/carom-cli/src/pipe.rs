//! What `carom` does when the program reading its output stops reading.

/// Lets `SIGPIPE` end the process quietly, as it ends `cat` or `ls`, when the reader of its
/// output goes away (`carom run scene.toml | head -3`). Rust starts every program with the
/// signal ignored, so a write to a closed pipe fails instead, and `println!` panics on the
/// failure: a backtrace for a reader's choice, not an error of ours. The output files are
/// written to a temporary and renamed into place (see `carom_output`), so a run ended this
/// way leaves none half written. Elsewhere than Unix there is no such signal.
pub fn end_quietly_when_the_reader_goes() {
    #[cfg(unix)]
    // SAFETY: `signal` sets the disposition of one signal to the default; it touches no memory
    // of ours, and no thread has been started yet to race with it.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
