//! What `carom` does when the program reading its output stops reading.

/// Lets `SIGPIPE` end the process quietly, as it ends `cat` or `ls`, when the reader of its
/// output goes away (`carom run scene.toml | head -3`). Rust starts every program with the
/// signal ignored, so a write to a closed pipe fails instead, and `println!` panics on the
/// failure: a backtrace for a reader's choice, not an error of ours. The output files are
/// written to a temporary and renamed into place (see `carom_output`), so a run ended this
/// way leaves none half written. Elsewhere than Unix there is no such signal.
pub fn end_quietly_when_the_reader_goes() {
    set_sigpipe(Disposition::Default);
}

/// While it lives, a write to a closed pipe fails with an error instead of ending the process
/// (see [`end_quietly_when_the_reader_goes`]): for a pipe into a program of ours, such as
/// `ffmpeg` encoding an MP4, whose early exit is an error to report (with what it said) and
/// whose temporary output is to be removed.
pub struct BrokenPipesAreErrors(());

impl BrokenPipesAreErrors {
    /// Broken pipes are errors until the guard is dropped.
    pub fn new() -> Self {
        set_sigpipe(Disposition::Ignore);
        BrokenPipesAreErrors(())
    }
}

impl Drop for BrokenPipesAreErrors {
    fn drop(&mut self) {
        set_sigpipe(Disposition::Default);
    }
}

/// What `SIGPIPE` does.
enum Disposition {
    /// End the process.
    Default,
    /// Nothing: the write fails with `EPIPE`.
    Ignore,
}

fn set_sigpipe(disposition: Disposition) {
    #[cfg(unix)]
    {
        let handler = match disposition {
            Disposition::Default => libc::SIG_DFL,
            Disposition::Ignore => libc::SIG_IGN,
        };
        // SAFETY: `signal` sets the disposition of one signal to the default or to ignore it;
        // it touches no memory of ours and installs no handler that could run our code.
        unsafe {
            libc::signal(libc::SIGPIPE, handler);
        }
    }
    #[cfg(not(unix))]
    let _ = disposition;
}
