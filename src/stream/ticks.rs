//! The per-scene tick loop: one task per scene, running only while something needs it.
//!
//! A subscriber holds a [`Ticks`] ([`Tickers::subscribe`]), and the loop's shards
//! ([`super::fanout`]) write each frame to the sockets of those that follow. The first
//! subscriber of a scene starts its loop; the loop ends (and leaves the registry) when the last
//! hold is dropped, when the scene is deleted ([`Ticks::ended`] tells subscribers) or at
//! shutdown. A scene with no subscribers costs nothing.
//!
//! Tick numbering follows the scene clock: `tick = floor(t·tick_hz)`, and a frame's `t` is the
//! tick's start `tick / tick_hz`. A frame is sent whenever the clock's tick differs from the last
//! one sent: ticks go up while the clock runs forward, down while it runs backwards, stop while it
//! is paused (a tick is never repeated), and skip when the clock outruns the loop (fast-forward
//! beyond ~1000 ticks per real second, or a seek).
//!
//! # Floating bodies
//! The loop never steps bodies: the scene's body loop ([`crate::state::bodies`]), or in a fleet
//! the scene's log follower ([`crate::store::bodies`]), is the only stepping path. Before each
//! frame the loop waits (at most [`BODY_WAIT_TICKS`] tick periods) for the states of the clock's
//! tick, which the body loop publishes right after the same tick boundary (a follower when the
//! sequencer's watermark reaches it).
//!
//! **A frame's tick is always the tick of the states it carries**, so a client interpolating
//! between frames never puts states at the wrong time. When the states of the clock's tick do
//! not come in time (an overloaded server, a clock jump the body loop has not handled yet, a
//! fleet whose sequencer is failing over) the frame is labelled with the tick of the latest
//! published states instead, if no frame carried them yet, and skipped otherwise (clients see
//! skipped ticks, which the stream contract allows); `swell_tick_body_lag_total` counts each such
//! tick. The loop also wakes on every publication, so states that come after their tick's wait
//! gave up still go out at once, under their own tick, unless a later frame went out first. Earlier, a late frame carried the latest states under the clock's tick: states one or
//! more ticks old, labelled as new, so replicas' frames for one tick could differ.

use std::sync::Arc;
use std::time::Duration;

/// Tick timing lives with the clock ([`crate::scene::clock`]); re-exported for the loop here.
pub use crate::scene::clock::{COARSE_WAKE, MAX_SLEEP, MIN_SLEEP, until_next_tick};
use crate::scene::clock::{ClockReading, tick_of};
use crate::service::types::{BodyState, Tick};
use crate::state::AppState;
use crate::stream::fanout::{TickLoop, Ticks};
use crate::stream::frame::SharedTick;
pub use crate::stream::registry::Tickers;

/// Longest wait for the body loop's states of a frame's tick, in tick periods (and never more
/// than `MAX_SLEEP`, 50 ms).
pub const BODY_WAIT_TICKS: f64 = 1.0;

impl Tickers {
    /// Subscribes to scene `id`'s tick frames, starting its loop if none runs; `slot` picks the
    /// shard: a session passes the same one every time, so it stays in one shard.
    ///
    /// The hold is taken under the registry lock, and the loop decides to stop under the same
    /// lock, so a new subscriber never attaches to a loop that is about to end.
    pub fn subscribe(&self, state: &AppState, id: &str, slot: usize) -> Ticks {
        let mut loops = self.lock();
        if let Some(lp) = loops.get(id) {
            return lp.hold(slot);
        }
        let lp = TickLoop::start(&state.tasks);
        let ticks = lp.hold(slot);
        loops.insert(id.to_owned(), Arc::clone(&lp));
        metrics::gauge!("swell_tick_loops").increment(1.0);
        state.tasks.spawn(run(state.clone(), id.to_owned(), lp));
        ticks
    }
}

/// Sleeps `wait` to within the OS timer's precision (tens of microseconds): the async timer for
/// all but the last [`COARSE_WAKE`], then a thread of the blocking pool for the rest (a thread
/// asleep in `nanosleep` costs no CPU, and the reactor threads stay free; the hop costs a few
/// microseconds, so only loops that need the precision use it).
pub async fn sleep_to_boundary(wait: Duration) {
    let deadline = std::time::Instant::now() + wait;
    if let Some(coarse) = wait.checked_sub(COARSE_WAKE) {
        tokio::time::sleep(coarse).await;
    }
    let left = deadline.saturating_duration_since(std::time::Instant::now());
    if !left.is_zero() {
        // Only a panic in `sleep` (none) could fail the join; the loop goes on either way.
        let _ = tokio::task::spawn_blocking(move || std::thread::sleep(left)).await;
    }
}

/// The tick, world anchor and bodies of the frame to send at clock tick `tick`: the states
/// published for that tick, or (late) the latest published states with their own tick (see the
/// module docs). No bodies: `tick`, no anchor and an empty list, at once.
async fn bodies_for(
    state: &AppState,
    id: &str,
    tick: i64,
    reading: &ClockReading,
) -> (i64, Option<i64>, Vec<BodyState>) {
    let Some(cell) = state.bodies.get(id) else {
        return (tick, None, Vec::new());
    };
    let latest = cell.latest();
    if latest.states.is_empty() && cell.lock().is_empty() {
        return (tick, None, Vec::new());
    }
    // Scene specs bound tick_hz to [MIN_TICK_HZ, MAX_TICK_HZ]; a span that still did not fit a
    // Duration waits the longest sleep.
    let wait = Duration::try_from_secs_f64(BODY_WAIT_TICKS / reading.tick_hz)
        .map_or(MAX_SLEEP, |w| w.min(MAX_SLEEP));
    let (published, exact) = cell.states_at(tick, reading.rate >= 0.0, wait).await;
    if !exact {
        metrics::counter!("swell_tick_body_lag_total").increment(1);
    }
    (
        published.tick,
        Some(published.anchor),
        Arc::unwrap_or_clone(published.states),
    )
}

async fn run(state: AppState, id: String, lp: Arc<TickLoop>) {
    // The last clock tick handled, and the tick of the last frame sent (they differ when body
    // states were late: see the module docs).
    let mut last: Option<i64> = None;
    let mut sent: Option<i64> = None;
    // Impacts added before the loop started are not news: a joining client lists them with
    // `GET …/impacts`; frames carry those accepted since (see `crate::impacts`).
    let mut impacts_seen = state
        .scene(&id)
        .map_or(0, |e| e.scene.impacts.since(u64::MAX).0);
    loop {
        let entry = {
            let mut loops = state.tickers.lock();
            let entry = state.scene(&id).ok();
            let stop = lp.held() == 0 || entry.is_none() || state.shutdown.is_cancelled();
            if stop {
                loops.remove(&id);
                metrics::gauge!("swell_tick_loops").decrement(1.0);
                // Tells every subscriber still holding on that no more frames come.
                lp.end();
                return;
            }
            entry
        };
        let Some(entry) = entry else { return };
        // Subscribed before anything is read, so a publication from now on wakes the sleep below.
        let cell = state.bodies.get(&id);
        let mut published = cell.as_ref().map(|c| c.watch());
        let reading = state.read_clock(&entry);
        let tick = tick_of(reading.t, reading.tick_hz);
        let forward = reading.rate >= 0.0;
        let frame = if last != Some(tick) {
            last = Some(tick);
            // A tick is never repeated: states already sent (no new ones came) wait for the next
            // turn, and so do the impacts accepted meanwhile.
            Some(bodies_for(&state, &id, tick, &reading).await).filter(|(t, _, _)| sent != Some(*t))
        } else {
            // States published after their tick's frame stopped waiting for them (the tick was
            // skipped): sent now, under their own tick, if no later frame went out.
            cell.as_ref().and_then(|c| {
                let p = c.latest();
                let due = if forward {
                    p.tick <= tick && sent.is_none_or(|s| p.tick > s)
                } else {
                    p.tick >= tick && sent.is_none_or(|s| p.tick < s)
                };
                let any = !p.states.is_empty() || !c.lock().is_empty();
                (due && any).then(|| (p.tick, Some(p.anchor), Arc::unwrap_or_clone(p.states)))
            })
        };
        if let Some((tick, anchor_tick, bodies)) = frame {
            let t = tick as f64 / reading.tick_hz;
            let impacts = crate::impacts::frame_events(&entry.scene, &mut impacts_seen);
            lp.send(Arc::new(SharedTick::new(Tick {
                tick,
                t,
                bodies,
                impacts,
                anchor_tick,
            })));
            metrics::counter!("swell_ticks_total").increment(1);
            sent = Some(tick);
        }
        let wait = until_next_tick(
            reading.t,
            tick,
            reading.tick_hz,
            reading.rate,
            reading.paused,
        );
        // With bodies, the stepping path's publication (right after the boundary) wakes the
        // loop: the clock needs to be precise only without them.
        let stepped = cell.as_ref().is_some_and(|c| !c.latest().states.is_empty());
        // Woken early by a body publication: late states go out as soon as they exist.
        let publication = async {
            let changed = match published.as_mut() {
                Some(rx) => rx.changed().await.is_ok(),
                None => false,
            };
            if !changed {
                // No bodies, or the scene's bodies were dropped: only the clock wakes the loop.
                std::future::pending::<()>().await;
            }
        };
        let clock = async {
            if stepped {
                tokio::time::sleep(wait).await;
            } else {
                sleep_to_boundary(wait).await;
            }
        };
        tokio::select! {
            () = clock => {}
            () = publication => {}
            () = state.shutdown.cancelled() => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Never wakes before the boundary, whether the wait is shorter than the coarse part or
    /// longer (how late it wakes is a measurement: `swell_tick_lateness_seconds`).
    #[tokio::test]
    async fn the_boundary_sleep_never_wakes_early() {
        for ms in [0, 1, 3, 7] {
            let wait = Duration::from_millis(ms);
            let start = std::time::Instant::now();
            sleep_to_boundary(wait).await;
            assert!(
                start.elapsed() >= wait,
                "{ms} ms: woke after {:?}",
                start.elapsed()
            );
        }
    }

    #[test]
    fn sleeps_until_the_next_boundary_in_the_clock_direction() {
        // 30 Hz, t just past tick 30's start: the next boundary is 1/30 s later at rate 1.
        let d = until_next_tick(1.0, 30, 30.0, 1.0, false).as_secs_f64();
        assert!((d - (1.0 / 30.0 + 1e-4)).abs() < 1e-9, "{d}");
        // Rate 2: half the real time.
        let d2 = until_next_tick(1.0, 30, 30.0, 2.0, false).as_secs_f64();
        assert!((d2 - (1.0 / 60.0 + 1e-4)).abs() < 1e-9, "{d2}");
        // Backwards from the middle of tick 30: cross its start.
        let back = until_next_tick(1.0 + 0.5 / 30.0, 30, 30.0, -1.0, false).as_secs_f64();
        assert!((back - (0.5 / 30.0 + 1e-4)).abs() < 1e-9, "{back}");
        assert_eq!(until_next_tick(1.0, 30, 30.0, 1.0, true), MAX_SLEEP);
        assert_eq!(until_next_tick(1.0, 30, 1.0, 1.0, false), MAX_SLEEP);
    }
}
