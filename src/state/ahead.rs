//! The frame-ahead loop: FFT frames computed before the clock reaches them, for scenes being
//! queried ([`crate::frames`] holds the cache and says which frames; this loop says when).

use super::AppState;
use crate::frames::AHEAD_PERIOD;
use crate::scene::SceneEntry;

/// The frame-ahead loop: every [`AHEAD_PERIOD`], for each FFT scene queried within
/// [`ACTIVE_FOR`](crate::frames::ACTIVE_FOR), asks the cache whether a grid frame its clock
/// reaches next is missing ([`crate::frames::FrameCache::ahead_due`], on the reactor: no FFT),
/// then computes the missing ones of every such scene in one job on the blocking pool
/// ([`crate::frames::FrameCache::compute_ahead`]). Most periods find nothing due (a grid step
/// is 17 ms by default, the period 5 ms) and cost no thread hand-off. Ends when
/// `state.shutdown` fires.
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
        let mut due = Vec::new();
        for entry in state.scenes() {
            if !active.contains(&entry.scene.uid) || !entry.scene.has_fft() {
                continue;
            }
            let (now, rate) = clock_now(&state, &entry);
            if state.frames.ahead_due(&entry.scene, now, rate) {
                due.push(entry);
            }
        }
        if due.is_empty() {
            continue;
        }
        let st = state.clone();
        let done = tokio::task::spawn_blocking(move || {
            for entry in due {
                // Read again: the scenes before this one took their frames' time.
                let (now, rate) = clock_now(&st, &entry);
                st.frames.compute_ahead(&entry.scene, now, rate);
            }
        })
        .await;
        if let Err(e) = done {
            tracing::error!(error = %e, "computing frames ahead failed");
        }
    }
}

/// A scene's clock now: its time, s, and its rate (0 while paused).
fn clock_now(state: &AppState, entry: &SceneEntry) -> (f64, f64) {
    let reading = state.read_clock(entry);
    (reading.t, if reading.paused { 0.0 } else { reading.rate })
}
