//! The frame-ahead loop: FFT frames computed before the clock reaches them, for scenes being
//! queried ([`crate::frames`] holds the cache and says which frames; this loop says when).

use std::sync::Arc;

use super::AppState;
use crate::frames::AHEAD_PERIOD;

/// The frame-ahead loop: every [`AHEAD_PERIOD`], for each FFT scene queried within
/// [`ACTIVE_FOR`](crate::frames::ACTIVE_FOR), computes the grid frames its clock reaches next
/// ([`crate::frames::FrameCache::compute_ahead`], on the blocking pool). Ends when `state.shutdown` fires.
pub async fn run_ahead(state: AppState) {
    let mut interval = tokio::time::interval(AHEAD_PERIOD);
    interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    loop {
        tokio::select! {
            () = state.shutdown.cancelled() => return,
            _ = interval.tick() => {}
        }
        let active = state.frames.active_scenes();
        if active.is_empty() {
            continue;
        }
        for entry in state.scenes() {
            if !active.contains(&entry.scene.uid) || !entry.scene.has_fft() {
                continue;
            }
            let reading = state.read_clock(&entry);
            let rate = if reading.paused { 0.0 } else { reading.rate };
            let st = state.clone();
            let scene = Arc::clone(&entry.scene);
            let done = tokio::task::spawn_blocking(move || {
                st.frames.compute_ahead(&scene, reading.t, rate)
            })
            .await;
            if let Err(e) = done {
                tracing::error!(error = %e, "computing frames ahead failed");
            }
        }
    }
}
