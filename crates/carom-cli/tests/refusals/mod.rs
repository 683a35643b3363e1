//! Shared by the bad-input tests (`bad_input.rs`, `edges.rs`): how a refusal looks.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

pub fn carom() -> Command {
    Command::new(env!("CARGO_BIN_EXE_carom"))
}

pub fn newton_cradle() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/newton_cradle.toml")
}

/// The files in `dir`, sorted.
pub fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    names
}

/// Runs `args` in `dir` with `env` (and no display) and checks the refusal: status 2, one
/// line `carom: error: ...` that contains every one of `says`, no panic and no new file in
/// `dir`. Returns how long it took.
pub fn refusal(dir: &Path, args: &[&str], env: &[(&str, &str)], says: &[&str]) -> Duration {
    let before = listing(dir);
    let started = Instant::now();
    let out = carom()
        .args(args)
        .envs(env.iter().copied())
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .current_dir(dir)
        .output()
        .unwrap();
    let took = started.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{args:?}: not one message: {stderr}");
    assert!(lines[0].starts_with("carom: error: "), "{args:?}: {stderr}");
    for word in says {
        assert!(
            lines[0].contains(word),
            "{args:?}: no `{word}` in: {stderr}"
        );
    }
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    assert_eq!(listing(dir), before, "{args:?} left a file");
    took
}
