//! The per-scene body loop and the registry of scenes' bodies.
//!
//! A scene's loop runs while the scene has bodies: each tick of a tokio interval at the scene's
//! tick rate it advances the bodies to the scene clock's current tick (off the reactor, in
//! `spawn_blocking`: 1,000 bodies take milliseconds). Readers take the states from the body
//! world itself, under its lock: the HTTP body endpoints, and the WebSocket tick loop through
//! [`BodiesHook`] (which first catches the bodies up to its frame's tick). Nothing is queued for
//! readers, so a slow one never holds memory or delays the loop. Missed interval ticks are skipped, not bunched: the next iteration simply steps several
//! fixed ticks to catch up with the clock, so lateness never changes the trajectory.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::{BodiesRecord, BodyState, SceneBodies};
use crate::error::ApiError;
use crate::state::AppState;

/// One scene's bodies and their loop flag.
#[derive(Debug)]
pub struct SceneBodiesCell {
    /// The body world. Locked for a step (milliseconds) or a read.
    pub bodies: Mutex<SceneBodies>,
    running: AtomicBool,
}

impl SceneBodiesCell {
    /// Locks the body world (a poisoned lock still holds a consistent world: steps only replace
    /// whole states).
    pub fn lock(&self) -> std::sync::MutexGuard<'_, SceneBodies> {
        self.bodies.lock().unwrap_or_else(|p| p.into_inner())
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
    SceneBodiesCell {
        bodies: Mutex::new(bodies),
        running: AtomicBool::new(false),
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

fn interval_for(tick_hz: f64) -> tokio::time::Interval {
    let mut i = tokio::time::interval(Duration::from_secs_f64(1.0 / tick_hz));
    i.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    i
}

/// The loop of one scene: see the module docs. Exits when the scene is deleted, has no bodies
/// left, or the server stops.
async fn run(state: AppState, id: String, cell: Arc<SceneBodiesCell>) {
    let mut hz = match state.scene(&id) {
        Ok(e) => e.scene.spec.tick_hz,
        Err(_) => {
            cell.running.store(false, Ordering::SeqCst);
            return;
        }
    };
    let mut interval = interval_for(hz);
    tracing::debug!(scene = %id, "body loop started");
    loop {
        // The shutdown token ends the loop at once (not a tick later); the final snapshot is
        // taken after every loop has ended.
        let scheduled = tokio::select! {
            () = state.shutdown.cancelled() => break,
            s = interval.tick() => s,
        };
        let lateness = scheduled.elapsed().as_secs_f64();
        metrics::histogram!("swell_tick_lateness_seconds").record(lateness);
        let entry = match state.scene(&id) {
            Ok(e) if !state.bodies.is_stopping() => e,
            _ => break,
        };
        let still_registered = state
            .bodies
            .get(&id)
            .is_some_and(|c| Arc::ptr_eq(&c, &cell));
        if !still_registered {
            break;
        }
        let target = state.read_clock(&entry).tick;
        let scene = entry.scene.clone();
        let (scene_hz, gravity) = (scene.spec.tick_hz, scene.spec.surface.gravity);
        let stepping = cell.clone();
        let journaling = state.clone();
        let scene_id = id.clone();
        let done = tokio::task::spawn_blocking(move || {
            let mut b = stepping.lock();
            if b.is_empty() {
                return None;
            }
            let start = Instant::now();
            let adv = b.advance_to(target, &scene.surface, scene_hz, gravity);
            let took = start.elapsed();
            // A re-anchor is journaled under the same lock, in order with the API's changes
            // (not waited for: nothing was acknowledged; the next commit's fsync covers it).
            if let Err(e) = crate::journal::snapshot::append_body_events(
                journaling.journal(),
                &scene_id,
                &mut b,
            ) {
                tracing::error!(scene = %scene_id, error = %e, "journal: could not record a re-anchor");
            }
            Some((adv, took, b.len()))
        })
        .await;
        match done {
            Ok(Some((adv, took, n))) => {
                if adv.steps > 0 {
                    metrics::histogram!("swell_body_step_seconds")
                        .record(took.as_secs_f64() / f64::from(adv.steps));
                    metrics::counter!("swell_body_ticks_total").increment(u64::from(adv.steps));
                }
                if adv.reanchored {
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
        if scene_hz != hz {
            hz = scene_hz;
            interval = interval_for(hz);
        }
    }
    cell.running.store(false, Ordering::SeqCst);
    tracing::debug!(scene = %id, "body loop stopped");
}

/// The tick loop's body hook ([`crate::stream::ticks::TickHook`]): before each WebSocket tick
/// frame, catch the scene's bodies (if any) up to the frame's tick and put their states in it.
/// Advancing is idempotent, so this and the body loop never step a tick twice; whichever comes
/// first steps and the other reads. Only the body loop handles clock jumps (seek, reverse):
/// during one, frames carry the bodies' latest states. The body loop keeps simulating without subscribers, so this
/// hook does not keep the tick loop alive.
#[derive(Debug)]
pub struct BodiesHook {
    state: AppState,
    scene: String,
}

impl BodiesHook {
    /// The hook for scene `scene`.
    pub fn new(state: AppState, scene: &str) -> BodiesHook {
        BodiesHook {
            state,
            scene: scene.to_owned(),
        }
    }
}

impl crate::stream::ticks::TickHook for BodiesHook {
    fn on_tick(
        &mut self,
        scene: &crate::scene::Scene,
        _previous: Option<i64>,
        tick: i64,
        _t: f64,
    ) -> Vec<BodyState> {
        let Some(cell) = self.state.bodies.get(&self.scene) else {
            return Vec::new();
        };
        let mut b = cell.lock();
        if b.is_empty() {
            return Vec::new();
        }
        b.catch_up_to(
            tick,
            &scene.surface,
            scene.spec.tick_hz,
            scene.spec.surface.gravity,
        );
        b.states(None)
    }
}
