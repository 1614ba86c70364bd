//! The per-scene body loop and the registry of scenes' bodies.
//!
//! A scene's loop runs while the scene has bodies, and it is the only thing that steps them: it
//! wakes when the scene clock crosses a tick boundary, advances the bodies to the clock's current
//! tick (off the reactor, in `spawn_blocking`: 1,000 bodies take milliseconds) and publishes
//! their states ([`Published`], a `watch` channel: readers get the latest, nothing is queued for
//! them, so a slow reader never holds memory or delays the loop). The WebSocket tick loop waits
//! for the states of its frame's tick there ([`SceneBodiesCell::states_at`]); the HTTP body
//! endpoints read the world under its lock. A late wake-up is not bunched: the next iteration
//! simply steps several fixed ticks to catch up with the clock, so lateness never changes the
//! trajectory.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::sync::watch;

use super::{BodiesRecord, BodyState, SceneBodies, Sea};
use crate::error::ApiError;
use crate::state::AppState;

/// The bodies' states as the body loop (or an admin change) last left them.
#[derive(Debug, Clone, PartialEq)]
pub struct Published {
    /// Scene tick of the states.
    pub tick: i64,
    /// States in id order.
    pub states: Arc<Vec<BodyState>>,
}

/// One scene's bodies, their loop flag and their published states.
#[derive(Debug)]
pub struct SceneBodiesCell {
    /// The body world. Locked for a step (milliseconds) or a read.
    pub bodies: Mutex<SceneBodies>,
    running: AtomicBool,
    published: watch::Sender<Published>,
}

impl SceneBodiesCell {
    /// Locks the body world (a poisoned lock still holds a consistent world: steps only replace
    /// whole states).
    pub fn lock(&self) -> std::sync::MutexGuard<'_, SceneBodies> {
        self.bodies.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Publishes `b`'s states (call with the lock held, after a step or an admin change, so
    /// publications are in the world's order).
    pub fn publish(&self, b: &SceneBodies) {
        self.published.send_replace(Published {
            tick: b.tick(),
            states: Arc::new(b.states(None)),
        });
    }

    /// A receiver of the publications from now on (the tick loop wakes on them).
    pub fn watch(&self) -> watch::Receiver<Published> {
        self.published.subscribe()
    }

    /// The latest published states.
    pub fn latest(&self) -> Published {
        self.published.borrow().clone()
    }

    /// The states the body loop publishes for scene tick `tick`, waiting for them up to `wait`.
    /// Reached means: published at `tick`, or beyond it in the clock's direction (`forward`: the
    /// clock runs forward) when the loop has already moved on. On timeout (the loop is
    /// overloaded, or stopped: no bodies) the latest states come back, and `exact` is false.
    pub async fn states_at(&self, tick: i64, forward: bool, wait: Duration) -> (Published, bool) {
        let mut rx = self.published.subscribe();
        let reached = |p: &Published| {
            p.tick == tick || (forward && p.tick > tick) || (!forward && p.tick < tick)
        };
        let got = tokio::time::timeout(wait, rx.wait_for(|p| reached(p)))
            .await
            .ok()
            .and_then(Result::ok)
            .map(|p| p.clone());
        match got {
            Some(p) => {
                let exact = p.tick == tick;
                (p, exact)
            }
            None => (self.latest(), false),
        }
    }
}

/// Every scene's bodies.
#[derive(Debug, Default)]
pub struct BodyRegistry {
    scenes: Mutex<BTreeMap<String, Arc<SceneBodiesCell>>>,
    stopping: AtomicBool,
}

impl BodyRegistry {
    fn map(&self) -> std::sync::MutexGuard<'_, BTreeMap<String, Arc<SceneBodiesCell>>> {
        self.scenes.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The bodies of scene `id`, if it ever had any.
    pub fn get(&self, id: &str) -> Option<Arc<SceneBodiesCell>> {
        self.map().get(id).cloned()
    }

    /// The bodies of scene `id`, created empty (anchored at `tick`) if needed.
    ///
    /// # Errors
    /// 422 if the scene's tick rate or gravity is outside the body model's range.
    pub fn get_or_create(
        &self,
        id: &str,
        tick: i64,
        tick_hz: f64,
        gravity: f64,
    ) -> Result<Arc<SceneBodiesCell>, ApiError> {
        let mut map = self.map();
        if let Some(c) = map.get(id) {
            return Ok(c.clone());
        }
        let bodies = SceneBodies::new(tick, tick_hz, gravity)?;
        let cell = Arc::new(new_cell(bodies));
        map.insert(id.to_owned(), cell.clone());
        Ok(cell)
    }

    /// Installs restored bodies for scene `id`.
    pub fn insert(&self, id: &str, bodies: SceneBodies) {
        self.map().insert(id.to_owned(), Arc::new(new_cell(bodies)));
    }

    /// Forgets a deleted scene's bodies (its loop stops at its next tick).
    pub fn remove_scene(&self, id: &str) {
        self.map().remove(id);
    }

    /// Every scene's body cell, by scene id.
    pub fn cells(&self) -> Vec<(String, Arc<SceneBodiesCell>)> {
        self.map()
            .iter()
            .map(|(id, c)| (id.clone(), c.clone()))
            .collect()
    }

    /// Persistable records of every scene with bodies.
    pub fn records(&self) -> Vec<(String, BodiesRecord)> {
        self.map()
            .iter()
            .map(|(id, c)| (id.clone(), c.lock().record()))
            .collect()
    }

    /// Stops every loop at its next tick (graceful shutdown).
    pub fn stop(&self) {
        self.stopping.store(true, Ordering::SeqCst);
    }

    /// Whether loops are stopping.
    pub fn is_stopping(&self) -> bool {
        self.stopping.load(Ordering::SeqCst)
    }

    /// Starts the loops of every scene that has bodies (at server start, after a restore).
    pub fn start_all(&self, state: &AppState) {
        let cells: Vec<(String, Arc<SceneBodiesCell>)> = self
            .map()
            .iter()
            .map(|(id, c)| (id.clone(), c.clone()))
            .collect();
        for (id, cell) in cells {
            if !cell.lock().is_empty() {
                ensure_running(state, &id, &cell);
            }
        }
    }
}

fn new_cell(bodies: SceneBodies) -> SceneBodiesCell {
    let (published, _) = watch::channel(Published {
        tick: bodies.tick(),
        states: Arc::new(bodies.states(None)),
    });
    SceneBodiesCell {
        bodies: Mutex::new(bodies),
        running: AtomicBool::new(false),
        published,
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
        let (scene_hz, gravity) = (scene.spec.tick_hz, scene.spec.surface.gravity);
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
            let adv = b.advance_to(target, sea, scene_hz, gravity);
            let took = start.elapsed();
            let cpu = cpu_start
                .zip(thread_cpu())
                .map(|(a, b)| b.saturating_sub(a));
            // Impacts the step made reach the scene before the states are published: the tick
            // loop waits for the states, then takes the new impacts for the same frame.
            scene.impacts.sync_bodies(&mut b, true);
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
        let wait = crate::stream::ticks::until_next_tick(r.t, r.tick, r.tick_hz, r.rate, r.paused);
        planned = Some(Instant::now() + wait);
        // The shutdown token ends the loop at once (not a tick later); the final snapshot is
        // taken after every loop has ended.
        tokio::select! {
            () = state.shutdown.cancelled() => break,
            () = tokio::time::sleep(wait.saturating_sub(crate::stream::ticks::COARSE_WAKE)) => {}
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
