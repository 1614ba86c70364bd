//! `swell::memory`: a burst's freed heap is held by glibc until trimmed, then given back. Its own
//! test binary (its own process), so no other test allocates while resident size is measured.

#![cfg(all(target_os = "linux", target_env = "gnu"))]

mod common;

use swell::memory::{TRIM_ABOVE, free_held, release_if_held};

/// Resident bytes of this process.
fn resident() -> usize {
    common::resident_bytes("self")
}

#[test]
fn a_fragmented_burst_is_held_until_trimmed_then_given_back() {
    // A burst of 48 MiB in 4 KiB blocks on a thread of its own (its own arena, as a connection's
    // task on a worker thread would have), every 64th block kept alive so that no heap tail is
    // free and glibc's own trimming of the tail cannot release it.
    const BLOCK: usize = 4096;
    const BLOCKS: usize = (48 << 20) / BLOCK;
    let kept = std::thread::spawn(|| {
        let mut all: Vec<Vec<u8>> = (0..BLOCKS)
            .map(|i| vec![(i % 251) as u8 + 1; BLOCK])
            .collect();
        let kept: Vec<Vec<u8>> = all.iter_mut().step_by(64).map(std::mem::take).collect();
        drop(all);
        kept
    })
    .join()
    .expect("burst thread");
    let held = free_held().expect("glibc has mallinfo2");
    assert!(
        held > 40 << 20,
        "free in the arenas after the burst: {held} bytes"
    );

    // Without a trim the memory stays resident.
    let before = resident();
    assert_eq!(
        release_if_held(usize::MAX),
        None,
        "no trim below the threshold"
    );
    assert!(
        resident() + (8 << 20) > before,
        "memory went back without a trim"
    );

    let trimmed = release_if_held(TRIM_ABOVE);
    let after = resident();
    assert!(trimmed.is_some_and(|h| h > 40 << 20), "{trimmed:?}");
    assert!(
        before.saturating_sub(after) > 32 << 20,
        "resident {before} → {after} bytes: the trim gave back less than 32 MiB"
    );
    assert_eq!(kept.len(), BLOCKS.div_ceil(64));
}
