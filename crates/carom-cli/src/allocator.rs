//! The C allocator's settings for the process.

/// glibc's default threshold (bytes) above which a block is mapped on its own, and unmapped
/// when freed.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const MMAP_THRESHOLD: libc::c_int = 128 * 1024;

/// Fixes glibc's mmap threshold at its default, [`MMAP_THRESHOLD`]. Left alone, glibc raises it
/// to the size of each mapped block that is freed (up to 32 MiB); blocks below the new threshold
/// then come from the heap, where memory freed stays resident. `carom resume` frees the
/// checkpoint's arrays (8-16 MB each at 10^6 discs) once the world is built, and its first
/// step then peaked at 231.5 MB, against 188.8 MB with the threshold fixed (10^6 falling discs
/// resumed at step 10 and run to step 11; the uninterrupted run: 197.4 and 193.1 MB). Stepping
/// allocates nothing after warm-up, so no step pays for the mapping. Elsewhere than glibc,
/// nothing to do.
pub fn fix_mmap_threshold() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` changes one setting of the allocator, which guards its own state; it
    // takes no pointer.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD);
    }
}
