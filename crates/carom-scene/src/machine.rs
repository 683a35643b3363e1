//! What this machine says about itself through `/proc` (Linux): total memory, this process's
//! peak resident memory and the CPU's model name. The one place carom reads `/proc`: the scene
//! loader (fills that cannot fit in memory) and the command line (`carom bench`, `carom soak`)
//! both ask here. Elsewhere every answer is `None`. Also what the machine allows of threads:
//! their limit, `RAYON_NUM_THREADS`, and the start of the pool the command line and the Python
//! module step on.

/// A `/proc` file's line `KEY: number ...` (e.g. `MemTotal:       23998640 kB`): the number.
fn field(file: &str, key: &str) -> Option<u64> {
    let text = std::fs::read_to_string(file).ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    line[key.len()..].split_whitespace().next()?.parse().ok()
}

/// Total memory in bytes (`MemTotal` of `/proc/meminfo`).
pub fn total_memory_bytes() -> Option<u64> {
    field("/proc/meminfo", "MemTotal:").map(|kib| kib * 1024)
}

/// This process's peak resident memory so far in bytes (`VmHWM` of `/proc/self/status`).
pub fn peak_rss_bytes() -> Option<u64> {
    field("/proc/self/status", "VmHWM:").map(|kib| kib * 1024)
}

/// The CPU's model name (the first `model name` of `/proc/cpuinfo`).
pub fn cpu_model() -> Option<String> {
    let text = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("model name"))?;
    Some(line.split_once(':')?.1.trim().to_string())
}

/// The most worker threads (and thread ranks) a command or the Python module may start: 8
/// per core, and at least 64 on any machine. Results are the same for every count; more
/// threads than cores only wait for each other, and a typo (`--threads 100000`) would keep
/// the machine busy for minutes creating them.
pub fn thread_limit() -> usize {
    (8 * cores()).max(64)
}

/// The thread count `RAYON_NUM_THREADS` asks for, if it asks for one: rayon reads it itself,
/// and takes 0 or anything but a number as one thread per core.
pub fn threads_from_environment() -> Option<usize> {
    let value = std::env::var("RAYON_NUM_THREADS").ok()?;
    value.trim().parse::<usize>().ok().filter(|&n| n > 0)
}

/// Starts rayon's global pool, which every parallel phase runs on: `threads` workers, else
/// as many as `RAYON_NUM_THREADS` or the cores say (rayon's own default). Started on demand,
/// inside the first parallel phase, a pool whose threads the machine cannot start (a low
/// `ulimit -u`, no room for their stacks) panics there; started here, it gives an error to
/// report. A pool already running is kept when no count is asked for. Rayon tries its pool
/// once a process, so after a failure every call fails the same way.
pub fn start_thread_pool(threads: Option<usize>) -> Result<(), String> {
    static FAILURE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    if let Some(failure) = FAILURE.get() {
        return Err(failure.clone());
    }
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(threads) = threads {
        builder = builder.num_threads(threads);
    }
    let Err(e) = builder.build_global() else {
        return Ok(());
    };
    // (no I/O error behind it: the pool runs already)
    let threads_failed = std::error::Error::source(&e).is_some();
    if !threads_failed && threads.is_none() {
        return Ok(());
    }
    let count = threads.map_or("the worker".to_string(), |n| n.to_string());
    let failure = format!("cannot start {count} threads: {e}");
    if threads_failed {
        let _ = FAILURE.set(failure.clone());
    }
    Err(failure)
}

/// Cores this process may use (1 when the system does not say).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[cfg(target_os = "linux")]
    fn linux_answers() {
        assert!(total_memory_bytes().is_some_and(|b| b > 1 << 20));
        assert!(peak_rss_bytes().is_some_and(|b| b > 0));
        assert!(cores() >= 1);
    }

    #[test]
    fn missing_files_and_keys_are_none() {
        assert_eq!(field("/nonexistent/meminfo", "MemTotal:"), None);
        assert_eq!(field("/proc/self/status", "NoSuchKey:"), None);
    }
}
