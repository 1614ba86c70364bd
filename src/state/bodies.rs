//! The body driver of a scene on one process: its loop runs while the scene has bodies, and it
//! is the only thing that steps them there. It wakes when the scene clock crosses a tick
//! boundary, advances the bodies to the clock's current tick (off the reactor, in
//! `spawn_blocking`: 1,000 bodies take milliseconds) and publishes their states
//! ([`crate::bodies::registry::Published`]). A late wake-up is not bunched: the next iteration
//! simply steps several fixed ticks to catch up with the clock, so lateness never changes the
//! trajectory. (In a fleet, the scene's log follower drives the world instead:
//! [`crate::store::bodies`].)

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use super::AppState;
use crate::bodies::Sea;
use crate::bodies::registry::SceneBodiesCell;
use crate::scene::clock::{COARSE_WAKE, until_next_tick};

/// Starts the loops of every scene that has bodies (at server start, after a restore).
pub fn start_all(state: &AppState) {
    for (id, cell) in state.bodies.cells() {
        if !cell.lock().is_empty() {
            ensure_running(state, &id, &cell);
        }
    }
}

/// Starts scene `id`'s loop unless it is running. Call after adding a body.
pub fn ensure_running(state: &AppState, id: &str, cell: &Arc<SceneBodiesCell>) {
    if cell
        .running
        .compare_exchange(false, true, Ordering::SeqCst, Ordering::SeqCst)
        .is_ok()
    {
        state
            .tasks
            .spawn(run(state.clone(), id.to_owned(), cell.clone()));
    }
}

/// The loop of one scene: see the module docs. Exits when the scene is deleted, has no bodies
/// left, or the server stops.
async fn run(state: AppState, id: String, cell: Arc<SceneBodiesCell>) {
    tracing::debug!(scene = %id, "body loop started");
    let mut planned: Option<Instant> = None;
    loop {
        let entry = match state.scene(&id) {
            Ok(e) if !state.bodies.is_stopping() && !state.shutdown.is_cancelled() => e,
            _ => break,
        };
        let still_registered = state
            .bodies
            .get(&id)
            .is_some_and(|c| Arc::ptr_eq(&c, &cell));
        if !still_registered {
            break;
        }
        let scene = entry.scene.clone();
        let scene_hz = scene.spec.tick_hz;
        let stepping = cell.clone();
        let journaling = state.clone();
        let frames = state.clone();
        let scene_id = id.clone();
        let reading_entry = entry.clone();
        let done = tokio::task::spawn_blocking(move || {
            // The last stretch to the tick boundary is slept here, on this blocking thread, to
            // the OS timer's precision (the async timer woke us up to `COARSE_WAKE` early).
            if let Some(p) = planned {
                let left = p.saturating_duration_since(Instant::now());
                if !left.is_zero() {
                    std::thread::sleep(left);
                }
                let lateness = Instant::now().saturating_duration_since(p).as_secs_f64();
                metrics::histogram!("swell_tick_lateness_seconds").record(lateness);
            }
            let reading = frames.read_clock(&reading_entry);
            let (target, now) = (reading.tick, reading.t);
            let mut b = stepping.lock();
            if b.is_empty() {
                return None;
            }
            let start = Instant::now();
            let cpu_start = thread_cpu();
            let sea = Sea::Shared {
                cache: &frames.frames,
                scene: &scene,
                now,
            };
            // Impacts the step makes reach the scene before the states are published: the tick
            // loop waits for the states, then takes the new impacts for the same frame.
            let adv = crate::bodies::drive::step(&mut b, target, sea, &scene);
            let took = start.elapsed();
            let cpu = cpu_start
                .zip(thread_cpu())
                .map(|(a, b)| b.saturating_sub(a));
            if adv.steps > 0 || adv.reanchored {
                stepping.publish(&b);
            }
            // A re-anchor is journaled under the same lock, in order with the API's changes
            // (not waited for: nothing was acknowledged; the next commit's fsync covers it).
            if let Err(e) = crate::journal::snapshot::append_body_events(
                journaling.journal(),
                &scene_id,
                &mut b,
            ) {
                tracing::error!(scene = %scene_id, error = %e, "journal: could not record a re-anchor");
            }
            let n = b.len();
            drop(b);
            // The states are out: now, on this thread, the FFT frames the next step reads
            // (through the next tick boundary and the ahead loop's two grid steps past it).
            // Left to the ahead loop, they were computed at the boundary, on the other core,
            // while the next step ran: on two cores, anything else woken then (the tick
            // fan-out, the reactor) had to take one of the two from them.
            if scene.has_fft() {
                let rate = if reading.paused { 0.0 } else { reading.rate };
                frames
                    .frames
                    .compute_through(&scene, now, rate, 1.0 / scene_hz);
            }
            Some((adv, took, cpu, n, target))
        })
        .await;
        match done {
            Ok(Some((adv, took, cpu, n, target))) => {
                if adv.steps > 0 {
                    metrics::histogram!("swell_body_step_seconds")
                        .record(took.as_secs_f64() / f64::from(adv.steps));
                    if let Some(cpu) = cpu {
                        metrics::histogram!("swell_body_step_cpu_seconds")
                            .record(cpu.as_secs_f64() / f64::from(adv.steps));
                    }
                    metrics::counter!("swell_body_ticks_total").increment(u64::from(adv.steps));
                }
                if adv.reanchored {
                    metrics::counter!("swell_body_reanchors_total").increment(1);
                    tracing::debug!(scene = %id, tick = target, "body world re-anchored");
                }
                metrics::gauge!("swell_bodies", "scene" => id.clone()).set(n as f64);
            }
            Ok(None) => {
                // No bodies left: stop, unless one was added between the check and now.
                cell.running.store(false, Ordering::SeqCst);
                if cell.lock().is_empty()
                    || cell
                        .running
                        .compare_exchange(false, true, Ordering::SeqCst, Ordering::SeqCst)
                        .is_err()
                {
                    tracing::debug!(scene = %id, "body loop stopped: no bodies");
                    return;
                }
            }
            Err(e) => {
                tracing::error!(scene = %id, error = %e, "body step panicked");
                break;
            }
        }
        // Sleep until the clock crosses the next tick boundary, read after the step so the step's
        // own duration is not slept again; the tick loop wakes at the same boundary and waits for
        // this loop's states.
        let r = state.read_clock(&entry);
        let wait = until_next_tick(r.t, r.tick, r.tick_hz, r.rate, r.paused);
        planned = Some(Instant::now() + wait);
        // The shutdown token ends the loop at once (not a tick later); the final snapshot is
        // taken after every loop has ended.
        tokio::select! {
            () = state.shutdown.cancelled() => break,
            () = tokio::time::sleep(wait.saturating_sub(COARSE_WAKE)) => {}
        }
    }
    cell.running.store(false, Ordering::SeqCst);
    tracing::debug!(scene = %id, "body loop stopped");
}

/// CPU time the calling thread has run so far (`clock_gettime(CLOCK_THREAD_CPUTIME_ID)`, through
/// `cpu_time`), or `None` where the system has no such clock: the body loop then reports wall
/// time only. Up to date to the call (unlike `/proc/thread-self/schedstat`, which a running
/// thread's kernel updates only at scheduler ticks, 4 ms here: it under-counted a 7 ms step by
/// ~2 ms on average). A step runs on one blocking-pool thread from start to end, so the
/// difference of two readings around it is the step's own CPU time, not counting time it spent
/// waiting (for a core, or for a frame another thread was computing).
fn thread_cpu() -> Option<Duration> {
    cpu_time::ThreadTime::try_now()
        .ok()
        .map(|t| t.as_duration())
}

#[cfg(test)]
mod tests {
    use std::time::{Duration, Instant};

    /// The thread CPU clock counts this thread's work to within a millisecond, and no more
    /// than the wall time it took (a busy machine only makes it smaller).
    #[test]
    fn thread_cpu_time_counts_this_threads_work() {
        let Some(a) = super::thread_cpu() else {
            eprintln!("no thread CPU clock here: the CPU-time metric is off");
            return;
        };
        let wall = Instant::now();
        let mut x = 0.0_f64;
        let mut cpu = Duration::ZERO;
        while cpu < Duration::from_millis(7) && wall.elapsed() < Duration::from_secs(10) {
            for _ in 0..1000 {
                x = std::hint::black_box(x + 1.0);
            }
            cpu = super::thread_cpu().unwrap() - a;
        }
        let took = wall.elapsed();
        assert!(
            cpu >= Duration::from_millis(7),
            "{cpu:?} of CPU after 10 s busy"
        );
        // Up to date: the loop stops within a few microseconds of 7 ms (a clock updated only
        // at 4 ms scheduler ticks would overshoot to 8 ms).
        assert!(
            cpu < Duration::from_micros(7500),
            "{cpu:?}: the clock lags the thread"
        );
        assert!(
            cpu <= took + Duration::from_micros(100),
            "cpu {cpu:?} > wall {took:?}"
        );
    }
}
