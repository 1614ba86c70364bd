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
//! On other C libraries (musl, macOS) these are no-ops: they have neither call.

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
