//! The registry of scenes' bodies: each scene's world behind its lock, and its published states.
//!
//! The driver that steps a world ([`crate::state::bodies`]) publishes its states here
//! ([`Published`], a `watch` channel: readers get the latest, nothing is queued for them, so a
//! slow reader never holds memory or delays the driver). The WebSocket tick loop waits for the
//! states of its frame's tick ([`SceneBodiesCell::states_at`]); the HTTP body endpoints read the
//! world under its lock.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::watch;

use super::{BodiesRecord, BodyState, SceneBodies};

/// The bodies' states as the body loop (or an admin change) last left them.
#[derive(Debug, Clone, PartialEq)]
pub struct Published {
    /// Scene tick of the states.
    pub tick: i64,
    /// Scene tick the world was anchored at ([`SceneBodies::anchor`]).
    pub anchor: i64,
    /// States in id order.
    pub states: Arc<Vec<BodyState>>,
}

/// One scene's bodies, their loop flag and their published states.
#[derive(Debug)]
pub struct SceneBodiesCell {
    /// The body world. Locked for a step (milliseconds) or a read.
    pub bodies: Mutex<SceneBodies>,
    /// Whether the scene's body loop runs ([`crate::state::bodies`] starts and stops it).
    pub running: AtomicBool,
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
            anchor: b.anchor(),
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
    /// [`super::BodyError::Rejected`] if the scene's tick rate or gravity is outside the body
    /// model's range.
    pub fn get_or_create(
        &self,
        id: &str,
        tick: i64,
        tick_hz: f64,
        gravity: f64,
    ) -> Result<Arc<SceneBodiesCell>, super::BodyError> {
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
}

fn new_cell(bodies: SceneBodies) -> SceneBodiesCell {
    let (published, _) = watch::channel(Published {
        tick: bodies.tick(),
        anchor: bodies.anchor(),
        states: Arc::new(bodies.states(None)),
    });
    SceneBodiesCell {
        bodies: Mutex::new(bodies),
        running: AtomicBool::new(false),
        published,
    }
}
