//! Shared by the split-run tests (`ranks.rs`, `mpi.rs`).

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `command` to the end and returns its output; if it has not ended after `limit`, stops
/// it (SIGTERM, then SIGKILL) and fails the test. A guard against a deadlocked split run
/// hanging CI, not a speed check: the runs it guards take seconds.
pub fn run_guarded(command: &mut Command, limit: Duration) -> Output {
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("{command:?} does not start: {e}"));
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > limit {
            let _ = Command::new("kill")
                .args(["-TERM", &child.id().to_string()])
                .status();
            std::thread::sleep(Duration::from_secs(2));
            let _ = child.kill();
            panic!("{command:?} did not finish within {limit:?} (deadlock?)");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// The path of a shipped scene file, as a string for an argument list.
pub fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
        .display()
        .to_string()
}
