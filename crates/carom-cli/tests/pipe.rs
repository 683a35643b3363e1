//! `carom` whose reader stops reading (`carom run | head -3`): it ends quietly, as `cat`
//! does, instead of panicking on the failed write.
#![cfg(unix)]

use std::os::fd::{FromRawFd, OwnedFd};
use std::os::unix::process::ExitStatusExt;
use std::process::{Command, Stdio};

/// A pipe whose reading end is already closed: the first write to the other end fails (or
/// raises `SIGPIPE`), every time, with no race against a reader.
fn pipe_nobody_reads() -> OwnedFd {
    let mut ends = [0; 2];
    // SAFETY: `pipe` writes two new descriptors into the array it is given, which is two long.
    assert_eq!(unsafe { libc::pipe(ends.as_mut_ptr()) }, 0, "pipe");
    // SAFETY: both descriptors were just made and nothing else owns them.
    let (read, write) = unsafe { (OwnedFd::from_raw_fd(ends[0]), OwnedFd::from_raw_fd(ends[1])) };
    drop(read);
    write
}

/// Runs `carom args` with its output into [`pipe_nobody_reads`]; asserts that it ended by
/// `SIGPIPE` (or succeeded) and said nothing on stderr.
fn ends_quietly(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_carom"))
        .args(args)
        .stdout(Stdio::from(pipe_nobody_reads()))
        .stderr(Stdio::piped())
        .output()
        .expect("carom starts");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.is_empty(),
        "carom {args:?} said on stderr:\n{stderr}"
    );
    assert!(
        out.status.success() || out.status.signal() == Some(libc::SIGPIPE),
        "carom {args:?} ended with {:?}",
        out.status
    );
}

#[test]
fn the_list_of_scenes_into_a_closed_pipe_ends_quietly() {
    ends_quietly(&["presets"]);
}

#[test]
fn a_run_whose_summary_nobody_reads_ends_quietly_and_writes_its_output_whole() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("final.csv");
    ends_quietly(&["run", "--steps", "20", "--out", out.to_str().unwrap()]);
    // (the state is written before the summary that reports it, so it is there in full; and
    // no temporary is left beside it)
    let text = std::fs::read_to_string(&out).expect("the final state was written");
    assert_eq!(text.lines().count(), 101, "a header and the 100 particles");
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(names.len(), 1, "only the output: {names:?}");
}
