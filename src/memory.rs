//! Handing freed heap back to the operating system.
//!
//! glibc's `malloc` keeps what it frees: a burst of work (a sub-second stall during which
//! open-loop clients open hundreds of extra connections, each with its own buffers) raises the
//! resident size, and once those connections close their memory stays resident, free inside
//! `malloc`'s arenas, for the life of the process. glibc only returns the free tail of the main
//! heap on its own; free pages in the middle of a heap, and in the other threads' arenas, go back
//! only through `malloc_trim`.
//!
//! The server's upkeep loop calls [`release_if_held`] every few seconds: when more than
//! [`TRIM_ABOVE`] bytes sit free in the arenas, it trims them (`madvise(MADV_DONTNEED)` on whole
//! free pages; the memory stays mapped, so later allocations reuse it at the cost of a page
//! fault). Measured (docs/performance.md, "Soak"): a 0.5 s stall under the soak load raised the
//! resident size from 36 to 77 MiB; one trim after the extra connections closed brought it to
//! 21 MiB.
//!
//! The process also caps glibc's arenas ([`limit_arenas`]) before it starts its threads, so
//! what its threads free is kept in common rather than in one arena per thread.
//!
//! On other C libraries (musl, macOS) these are no-ops: they have none of these calls.

/// glibc malloc arenas the server's threads share ([`limit_arenas`]), unless the environment
/// sets `MALLOC_ARENA_MAX`. glibc's default is 8 per core, and it gives a thread that allocates
/// an arena of its own while it is under that: the reactor threads, the compute pool, the
/// blocking pool's threads (which come and go) each keep their own free memory and fragments,
/// and at a steady load the free heap crept up (2.7 → 9.3 MiB in 2.5 minutes of the soak,
/// below the trim line). Two arenas, one per core on the machines measured, keep the free
/// memory in common (1.0 → 2.8 MiB in 6 minutes of the same load), and single-point
/// throughput (many small allocations from both reactor threads) is unchanged. One arena kept
/// it flat but cost up to a third of that throughput (both reactor threads wait on one arena's
/// lock). See docs/performance.md, "Soak".
pub const ARENAS: i32 = 2;

/// Caps glibc's malloc arenas at `n` (`mallopt(M_ARENA_MAX, n)`) unless the environment sets
/// `MALLOC_ARENA_MAX` (glibc's own setting, which then decides). Call it before the process
/// starts threads: a thread keeps the arena it was given. Returns whether the cap was set
/// (`false` off glibc, when the environment decides, or for `n` < 1).
pub fn limit_arenas(n: i32) -> bool {
    cap_arenas(n, std::env::var_os("MALLOC_ARENA_MAX").is_some())
}

/// [`limit_arenas`], told whether the environment decides.
fn cap_arenas(n: i32, environment_decides: bool) -> bool {
    if environment_decides || n < 1 {
        return false;
    }
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: `mallopt` only sets one of the allocator's parameters under its own lock;
        // M_ARENA_MAX bounds the arenas made from now on and frees nothing.
        unsafe { libc::mallopt(libc::M_ARENA_MAX, n) == 1 }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        false
    }
}

/// Free bytes in `malloc`'s arenas above which [`release_if_held`] trims (16 MiB): above what a
/// steady load keeps free between requests, so a server that never had a burst is never
/// trimmed. `malloc` counts a trimmed page as free still (it stays mapped), so once a burst has
/// left more than this free, every upkeep beat trims. That is cheap: a trim of pages already
/// given back only walks the free lists (`swell_memory_trim_seconds`), and reusing a trimmed page
/// costs one page fault.
pub const TRIM_ABOVE: usize = 16 << 20;

/// Bytes `malloc` holds free in all its arenas (`mallinfo2().fordblks`); `None` where the C
/// library has no `mallinfo2`.
#[must_use]
pub fn free_held() -> Option<usize> {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: `mallinfo2` takes no arguments, only reads the allocator's statistics under its
        // own arena locks, and returns a plain struct by value (glibc ≥ 2.33; Debian trixie has
        // 2.41).
        let info = unsafe { libc::mallinfo2() };
        Some(info.fordblks)
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        None
    }
}

/// Returns every whole free page of every arena to the OS (`malloc_trim(0)`). Returns whether
/// any memory was released (always `false` off glibc). Takes the arena locks in turn: call it
/// off the reactor.
pub fn trim() -> bool {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: `malloc_trim` is thread-safe (it locks each arena while trimming it) and only
        // releases pages no live allocation uses.
        unsafe { libc::malloc_trim(0) != 0 }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    {
        false
    }
}

/// Trims when more than `threshold` bytes sit free in the arenas. Returns the free bytes held
/// when it trimmed, `None` when it did not (below the threshold, or not glibc). Publishes
/// `swell_memory_free_held_bytes` (before any trim), counts trims in `swell_memory_trims_total`
/// and times them in `swell_memory_trim_seconds`.
pub fn release_if_held(threshold: usize) -> Option<usize> {
    let held = free_held()?;
    // A gauge is an f64; precision loss above 2^53 bytes is irrelevant.
    #[allow(clippy::cast_precision_loss)]
    metrics::gauge!("swell_memory_free_held_bytes").set(held as f64);
    if held <= threshold {
        return None;
    }
    let start = std::time::Instant::now();
    trim();
    metrics::histogram!("swell_memory_trim_seconds").record(start.elapsed().as_secs_f64());
    metrics::counter!("swell_memory_trims_total").increment(1);
    tracing::debug!(held, "returned free heap to the OS");
    Some(held)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cap is set on glibc; `MALLOC_ARENA_MAX` in the environment decides instead, and a
    /// cap under one arena is not set.
    #[test]
    fn the_arena_cap_is_set_unless_the_environment_sets_it() {
        let glibc = cfg!(all(target_os = "linux", target_env = "gnu"));
        assert_eq!(cap_arenas(ARENAS, false), glibc);
        assert!(!cap_arenas(ARENAS, true), "the environment decides");
        assert!(!cap_arenas(0, false));
    }
}
