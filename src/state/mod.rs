//! The shared state of a running server ([`AppState`]): the scene registry, its store, the
//! frame cache, the body registry, the limits; and the loops that drive them. The top of the
//! server's layers: transports call it; the domain modules below never see it.
//!
//! Scenes live in a `BTreeMap` (sorted listing) behind a std `RwLock` held only to clone an
//! `Arc`. Every acknowledged change is an [`Op`]; admin changes (scene put/delete, clock set)
//! are serialised by one async mutex and follow one order: validate and build → the store makes
//! it durable ([`store`]) → the one reducer applies it ([`apply`]). A change that fails at any
//! step leaves memory as it was.
//!
//! # Layout
//! - [`apply`] — the reducer: an [`Op`] applied to the registry.
//! - [`store`] — the [`store::Store`] interface and the local journal behind it (a fleet's
//!   Redis is [`crate::store::shared`]).
//! - [`restore`] — the journal's replay at start-up.
//! - [`snapshots`] — taking journal snapshots of the registry.
//! - [`bodies`] — the body loop of a scene on one process.
//! - [`ahead`] — FFT frames computed before the clock reaches them.
//! - [`error`] — [`StateError`], why a lookup or change was refused or failed.

pub mod ahead;
pub mod apply;
pub mod bodies;
pub mod error;
pub mod restore;
pub mod snapshots;
pub mod store;

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, RwLock};

use metrics_exporter_prometheus::PrometheusHandle;
use serde_json::Value;
use tokio_util::sync::CancellationToken;
use tokio_util::task::TaskTracker;

use crate::config::Limits;
use crate::frames::FrameCache;
use crate::journal::{Journal, Op, Recovered};
use crate::scene::clock::{BUILTIN_EPOCH, ClockReading, WallClock};
use crate::scene::store::{ClockRecord, SceneRecord, Store};
use crate::scene::{Clock, Scene, SceneEntry, SceneSpec};
use crate::service::types::ClockUpdate;
use crate::stream::registry::Tickers;
use apply::Prepared;
pub use error::StateError;

/// Cheap to clone: one `Arc`.
#[derive(Debug, Clone)]
pub struct AppState(Arc<Inner>);

/// The state itself.
#[derive(Debug)]
pub struct Inner {
    /// Request limits.
    pub limits: Limits,
    /// Shared FFT frames.
    pub frames: FrameCache,
    /// The Prometheus handle that renders `/metrics`.
    pub metrics: PrometheusHandle,
    /// Every scene's floating bodies.
    pub bodies: crate::bodies::registry::BodyRegistry,
    /// Running tick loops, by scene.
    pub tickers: Tickers,
    /// The id of each scene whose clock generation changed ([`AppState::replace_clock`]):
    /// every stream session listens and sends its client a `clock` event for its own scene.
    /// One channel for all scenes: clock changes are rare admin acts, and a session that lags
    /// behind [`CLOCK_CHANGES`] of them just re-reads its scene's clock.
    pub clock_changes: tokio::sync::broadcast::Sender<Arc<str>>,
    /// Fired when the server starts shutting down: the one signal every loop and session
    /// watches. WebSocket sessions send Close (1001) and end, tick, body and snapshot loops stop
    /// (axum's graceful shutdown does neither for upgraded connections).
    pub shutdown: CancellationToken,
    /// Every task the server spawns (sessions, tick and body loops, query work), so shutdown
    /// can await them, with a deadline, before the final snapshot.
    pub tasks: TaskTracker,
    /// Tokens and roles ([`crate::access`]).
    pub access: crate::access::Access,
    /// Trusted proxies and exempt peers, parsed from the limits (checked at bind).
    pub peer_policy: crate::peers::PeerPolicy,
    /// Bytes held for clients ([`Limits::max_buffered_bytes`], per client
    /// [`Limits::max_buffered_bytes_per_peer`]): HTTP request bodies and answers, the working
    /// memory and answers of large queries (HTTP and WebSocket), and WebSocket answers queued
    /// for a client that has not read them yet.
    pub buffers: Arc<crate::peers::Budget>,
    /// Addresses demoted to the slow lane ([`Limits::slow_lane_ms`], [`crate::lanes`]).
    pub slow_lane: Arc<crate::lanes::SlowLane>,
    scenes: RwLock<BTreeMap<String, Arc<SceneEntry>>>,
    journal: Option<Journal>,
    admin_token: String,
    admin_lock: tokio::sync::Mutex<()>,
    ready: AtomicBool,
    wall: WallClock,
    /// Where acknowledged changes go ([`store`]): a fleet's Redis once [`AppState::set_store`]
    /// names one, else the journal (or memory).
    store: std::sync::OnceLock<Arc<dyn store::Store>>,
    /// Held while a local API impact is checked, journaled and applied ([`store::Local`]).
    impacts: Mutex<()>,
}

/// Clock changes buffered for stream sessions ([`Inner::clock_changes`]): more than admins make
/// in the time a session takes to read one.
pub const CLOCK_CHANGES: usize = 64;

impl std::ops::Deref for AppState {
    type Target = Inner;
    fn deref(&self) -> &Inner {
        &self.0
    }
}

/// Whether a put created a scene or replaced one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PutOutcome {
    /// New id.
    Created,
    /// Existing id; its clock was kept, unless the put moved the epoch (then a fresh clock from
    /// the new epoch, one generation on).
    Replaced,
}

impl AppState {
    /// A state with no scenes.
    pub fn new(
        limits: Limits,
        journal: Option<Journal>,
        admin_token: String,
        access: crate::access::Access,
        metrics: PrometheusHandle,
    ) -> AppState {
        let peer_policy = limits.peer_policy().unwrap_or_default();
        AppState(Arc::new(Inner {
            access,
            buffers: crate::peers::Budget::new(
                limits.max_buffered_bytes,
                limits.max_buffered_bytes_per_peer,
            ),
            slow_lane: Arc::new(crate::lanes::SlowLane::new(
                std::time::Duration::from_millis(limits.slow_lane_ms),
                peer_policy.clone(),
            )),
            peer_policy,
            frames: FrameCache::new(limits.frame_cache_entries),
            limits,
            metrics,
            bodies: Default::default(),
            tickers: Tickers::default(),
            clock_changes: tokio::sync::broadcast::channel(CLOCK_CHANGES).0,
            shutdown: CancellationToken::new(),
            tasks: TaskTracker::new(),
            scenes: RwLock::new(BTreeMap::new()),
            journal,
            admin_token,
            admin_lock: tokio::sync::Mutex::new(()),
            ready: AtomicBool::new(false),
            wall: WallClock::default(),
            store: std::sync::OnceLock::new(),
            impacts: Mutex::new(()),
        }))
    }

    /// Makes `store` (a fleet's Redis) the store of every change, instead of the journal
    /// (once, before serving).
    pub fn set_store(&self, store: Arc<dyn store::Store>) {
        if self.store.set(store).is_err() {
            tracing::warn!("a store was already set; keeping the first");
        }
    }

    /// Where acknowledged changes go.
    pub fn store(&self) -> &dyn store::Store {
        static LOCAL: store::Local = store::Local;
        match self.store.get() {
            Some(s) => s.as_ref(),
            None => &LOCAL,
        }
    }

    /// Held while a local API impact is checked, journaled and applied.
    pub(crate) fn impact_lock(&self) -> std::sync::MutexGuard<'_, ()> {
        self.impacts.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Unix seconds now, as scene clocks read it: never less than an earlier answer (see
    /// [`WallClock`]).
    pub fn now(&self) -> f64 {
        self.wall.now()
    }

    /// The journal (none without a data dir).
    pub fn journal(&self) -> Option<&Journal> {
        self.journal.as_ref()
    }

    /// The admin token.
    pub fn admin_token(&self) -> &str {
        &self.admin_token
    }

    /// Whether the server takes traffic (scenes loaded, not shutting down).
    pub fn is_ready(&self) -> bool {
        self.ready.load(Ordering::Relaxed)
    }

    /// Marks the server ready or not.
    pub fn set_ready(&self, ready: bool) {
        self.ready.store(ready, Ordering::Relaxed);
    }

    fn read_scenes(&self) -> std::sync::RwLockReadGuard<'_, BTreeMap<String, Arc<SceneEntry>>> {
        // Writers only insert/remove whole entries, so a poisoned map is still consistent.
        self.scenes.read().unwrap_or_else(|p| p.into_inner())
    }

    fn write_scenes(&self) -> std::sync::RwLockWriteGuard<'_, BTreeMap<String, Arc<SceneEntry>>> {
        self.scenes.write().unwrap_or_else(|p| p.into_inner())
    }

    /// A scene by id.
    ///
    /// # Errors
    /// [`StateError::SceneNotFound`] if there is none.
    pub fn scene(&self, id: &str) -> Result<Arc<SceneEntry>, StateError> {
        self.read_scenes()
            .get(id)
            .cloned()
            .ok_or_else(|| StateError::SceneNotFound { id: id.to_owned() })
    }

    /// A scene just changed through the shared store: [`StateError::SceneGone`] if another
    /// replica's change (applied in between, in feed order) already removed it.
    fn applied_scene(&self, id: &str) -> Result<Arc<SceneEntry>, StateError> {
        self.scene(id)
            .map_err(|_| StateError::SceneGone { id: id.to_owned() })
    }

    /// Every scene, sorted by id.
    pub fn scenes(&self) -> Vec<Arc<SceneEntry>> {
        self.read_scenes().values().cloned().collect()
    }

    /// A scene's clock reading now.
    pub fn read_clock(&self, entry: &SceneEntry) -> ClockReading {
        let (clock, now) = self.clock_now(entry);
        clock.read(now, entry.scene.spec.tick_hz)
    }

    /// A scene's clock and the Unix time now, read together: for a caller that needs more of
    /// the clock at that instant than its reading (whether it is held, when that changes).
    pub fn clock_now(&self, entry: &SceneEntry) -> (Clock, f64) {
        let clock = *entry.clock.lock().unwrap_or_else(|p| p.into_inner());
        (clock, self.now())
    }

    /// Sets a scene's clock: every path that changes a clock (a local admin change, the
    /// journal's replay, a fleet's feed) comes through here, so stream sessions hear of every
    /// change ([`Inner::clock_changes`]) whichever path brought it. Any change is announced,
    /// not only a new generation: two admins changing one clock through two replicas at once
    /// can both write the same next generation (the feed's order decides which clock every
    /// replica ends with), and clients still hear of the second.
    pub fn replace_clock(&self, entry: &SceneEntry, clock: Clock) {
        // Every clock a scene holds comes through here or `insert_loaded`: both bound it.
        let clock = clock.within(self.limits.max_time);
        let before = std::mem::replace(
            &mut *entry.clock.lock().unwrap_or_else(|p| p.into_inner()),
            clock,
        );
        if before != clock {
            self.announce_clock_change(&entry.scene.id);
        }
    }

    /// Tells scene `id`'s stream sessions that its clock changed ([`Inner::clock_changes`]):
    /// each sends its client a `clock` event with the reading then.
    pub fn announce_clock_change(&self, id: &str) {
        // An error only means no session is listening.
        let _ = self.clock_changes.send(Arc::from(id));
    }

    /// Inserts a scene at start-up (no persistence, no lock), with `clock` or one started from
    /// the scene's epoch ([`BUILTIN_EPOCH`] if it gives none).
    pub fn insert_loaded(&self, scene: Scene, clock: Option<Clock>) {
        let clock = clock
            .unwrap_or_else(|| Clock::from_epoch(scene.spec.epoch.unwrap_or(BUILTIN_EPOCH)))
            .within(self.limits.max_time);
        let id = scene.id.clone();
        let old = self.write_scenes().insert(
            id,
            Arc::new(SceneEntry {
                scene: Arc::new(scene),
                clock: Mutex::new(clock),
            }),
        );
        if let Some(old) = old {
            self.frames.forget_scene(old.scene.uid);
            old.scene.answers.retire();
        }
    }

    /// Removes a scene at start-up.
    pub fn remove_loaded(&self, id: &str) {
        let old = self.write_scenes().remove(id);
        if let Some(old) = old {
            self.frames.forget_scene(old.scene.uid);
            old.scene.answers.retire();
        }
    }

    /// Checks that scene `id` built as `scene` fits the scene count and the FFT memory budget,
    /// counting every other scene as it is now.
    ///
    /// # Errors
    /// [`StateError::TooManyScenes`] at [`Limits::max_scenes`] (a new id only);
    /// [`StateError::FftBudget`] when the FFT frames of all scenes would exceed
    /// [`Limits::max_fft_bytes`].
    pub fn check_room_for(&self, id: &str, scene: &Scene) -> Result<(), StateError> {
        let map = self.read_scenes();
        if !map.contains_key(id) && map.len() >= self.limits.max_scenes {
            return Err(StateError::TooManyScenes { held: map.len() });
        }
        let mine = FrameCache::scene_bytes(scene);
        if mine == 0 {
            return Ok(());
        }
        let others: u64 = map
            .iter()
            .filter(|(k, _)| k.as_str() != id)
            .map(|(_, e)| FrameCache::scene_bytes(&e.scene))
            .sum();
        if others + mine > self.limits.max_fft_bytes {
            return Err(StateError::FftBudget {
                mine,
                others,
                max: self.limits.max_fft_bytes,
            });
        }
        Ok(())
    }

    /// Creates or replaces scene `id` from its spec JSON; a replaced scene keeps its clock
    /// unless the put moves its epoch (then the clock starts afresh from the new epoch, one
    /// generation on: see [`crate::scene::clock`]). A new scene's clock is generation 0.
    ///
    /// # Errors
    /// [`StateError::Scene`] for a bad id or a malformed or invalid spec; as
    /// [`Self::check_room_for`]; [`StateError::Internal`] or [`StateError::StoreUnavailable`] if
    /// it cannot be persisted.
    pub async fn put_scene(
        &self,
        id: &str,
        spec: Value,
    ) -> Result<(PutOutcome, Arc<SceneEntry>), StateError> {
        crate::scene::validate_id(id)?;
        let parsed = SceneSpec::from_value(spec)?;
        let owned_id = id.to_owned();
        // Building an FFT layer evaluates its spectrum at every mode: CPU work, off the reactor.
        let scene = tokio::task::spawn_blocking(move || Scene::build(&owned_id, parsed))
            .await
            .map_err(StateError::internal)??;
        let mut scene = scene;
        let _guard = self.admin_lock.lock().await;
        self.check_room_for(id, &scene)?;
        // The epoch: as given; else a replaced scene's; else now (a new scene starts at t = 0,
        // and the journaled spec remembers when, so its clock survives restarts).
        let old = self.scene(id).ok();
        let old_epoch = old.as_ref().and_then(|o| o.scene.spec.epoch);
        let given = scene.spec.epoch;
        if given.is_none() {
            scene.spec.epoch = if old.is_some() {
                old_epoch
            } else {
                Some(self.now())
            };
        }
        // Journal the canonical form: what the scene is, with defaults filled in.
        let spec = serde_json::to_value(&scene.spec).map_err(StateError::internal)?;
        let outcome = if old.is_some() {
            PutOutcome::Replaced
        } else {
            PutOutcome::Created
        };
        // A moved epoch starts a fresh clock one generation after the replaced one, so a client
        // whose fit was at the old generation restarts it (pongs of the two clocks would carry
        // the same generation otherwise). Computed here, once, and recorded with the put, as a
        // clock change is: every replay and replica takes the record as it is.
        let clock = match (&old, given) {
            (Some(old), Some(epoch)) if given != old_epoch => {
                let replaced = *old.clock.lock().unwrap_or_else(|p| p.into_inner());
                // Read at the epoch (t = 0): restored, that is `Clock::from_epoch` to the bit on
                // every process whose system clock has reached the epoch, whatever its skew. An
                // epoch still to come is read now instead: a record from the future would be
                // anchored at the restoring process's now (`ClockRecord::restore`). Unbounded,
                // so a far epoch's reading survives the record (see `ClockRecord::of`).
                let at = epoch.min(self.now());
                Some(ClockRecord::of(&replaced.restarted_from(epoch), at))
            }
            _ => None,
        };
        let op = Op::ScenePut {
            scene: id.to_owned(),
            spec,
            clock,
        };
        self.store()
            .commit(self, op, Prepared::Scene(Box::new(scene)))
            .await?;
        Ok((outcome, self.applied_scene(id)?))
    }

    /// Deletes scene `id`.
    ///
    /// # Errors
    /// [`StateError::SceneNotFound`] if there is none; [`StateError::Internal`] or
    /// [`StateError::StoreUnavailable`] if the deletion cannot be persisted.
    pub async fn delete_scene(&self, id: &str) -> Result<(), StateError> {
        let _guard = self.admin_lock.lock().await;
        self.scene(id)?;
        let op = Op::SceneDelete {
            scene: id.to_owned(),
        };
        self.store().commit(self, op, Prepared::Nothing).await
    }

    /// Applies a clock update (seek, then rate, then pause) and returns the new reading. The
    /// clock holds at ±[`Limits::max_time`] (see [`crate::scene::clock`]): a seek to exactly
    /// the limit, or a rate that takes the clock there, leaves it reading the limit, held.
    ///
    /// # Errors
    /// [`StateError::SceneNotFound`]; [`StateError::Clock`] for a non-finite or out-of-range `t`
    /// or `rate`; [`StateError::Internal`] or [`StateError::StoreUnavailable`] if it cannot be
    /// persisted.
    pub async fn set_clock(
        &self,
        id: &str,
        update: ClockUpdate,
    ) -> Result<ClockReading, StateError> {
        update.validate(&self.limits)?;
        let _guard = self.admin_lock.lock().await;
        let entry = self.scene(id)?;
        let now = self.now();
        let mut clock = *entry.clock.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(t) = update.t {
            clock.seek(now, t);
        }
        if let Some(r) = update.rate {
            clock.set_rate(now, r);
        }
        if let Some(p) = update.paused {
            clock.set_paused(now, p);
        }
        // One update is one change, whatever it moved: clients restart their fit at it.
        clock.next_generation();
        let rec = ClockRecord::of(&clock, now);
        let op = Op::Clock {
            scene: id.to_owned(),
            clock: rec,
        };
        // The local store applies the clock as computed here; a fleet's feed, the record.
        self.store()
            .commit(self, op, Prepared::Clock(clock))
            .await?;
        let entry = self.applied_scene(id)?;
        Ok(self.read_clock(&entry))
    }

    /// Adds an API impact to `entry`'s scene (rings living `lifetime` s), through the store;
    /// the scene tick its bodies feel it from (see the store's `add_impact`).
    ///
    /// # Errors
    /// [`StateError::TooManyImpacts`] over a limit, [`StateError::ImpactRejected`] for an impact
    /// the model rejects; [`StateError::Internal`] if it cannot be journaled;
    /// [`StateError::StoreUnavailable`] when a fleet's Redis is unreachable.
    pub async fn add_impact(
        &self,
        entry: Arc<SceneEntry>,
        impact: swell_waves::particles::Impact,
        lifetime: f64,
    ) -> Result<Option<i64>, StateError> {
        self.store().add_impact(self, entry, impact, lifetime).await
    }

    /// Spawns a body in scene `id`; its state, spawn tick and the world's anchor.
    ///
    /// # Errors
    /// [`StateError::SceneNotFound`]; [`StateError::Body`] for a full scene or a request the
    /// body model rejects; [`StateError::Internal`] or [`StateError::StoreUnavailable`] from the
    /// store.
    pub async fn spawn_body(
        &self,
        id: &str,
        req: crate::bodies::SpawnRequest,
    ) -> Result<crate::service::types::SpawnedBody, StateError> {
        let entry = self.scene(id)?;
        self.store().spawn_body(self, entry, req).await
    }

    /// Removes body `bid` of scene `id`.
    ///
    /// # Errors
    /// [`StateError::SceneNotFound`], [`StateError::Body`] for an unknown body;
    /// [`StateError::Internal`] or [`StateError::StoreUnavailable`] from the store.
    pub async fn remove_body(&self, id: &str, bid: u64) -> Result<(), StateError> {
        let entry = self.scene(id)?;
        self.store().remove_body(self, entry, bid).await
    }

    /// Queues an input for body `bid` of scene `id`; the tick it was accepted at and the tick
    /// it acts from.
    ///
    /// # Errors
    /// [`StateError::SceneNotFound`], [`StateError::Body`] for an unknown body or a bad input;
    /// [`StateError::Internal`] or [`StateError::StoreUnavailable`] from the store.
    pub async fn body_input(
        &self,
        id: &str,
        bid: u64,
        input: crate::bodies::InputRequest,
    ) -> Result<crate::service::types::InputAccepted, StateError> {
        let entry = self.scene(id)?;
        self.store().body_input(self, entry, bid, input).await
    }

    /// Loads built-in, configured and journaled scenes, in that order (later sources win; a
    /// journaled deletion removes a built-in or configured scene), then the journaled clocks and
    /// bodies ([`restore`]). `legacy` is a data dir written before the journal
    /// (per-file scenes, clocks, bodies): read only when the journal is empty, and imported into
    /// it. Blocking: builds every scene.
    ///
    /// # Errors
    /// A built-in or configured scene that does not build (a persisted one that no longer builds
    /// is logged and skipped, so a model upgrade cannot keep the server down).
    pub fn load(
        &self,
        builtin: bool,
        configured: &[(String, SceneSpec)],
        recovered: Option<Recovered>,
        legacy: Option<&Store>,
    ) -> Result<(), String> {
        if builtin {
            for (id, spec) in crate::scene::builtin::specs() {
                let scene =
                    Scene::build(&id, spec).map_err(|e| format!("built-in scene {id}: {e}"))?;
                self.insert_loaded(scene, None);
            }
        }
        for (id, spec) in configured {
            let scene = Scene::build(id, spec.clone())
                .map_err(|e| format!("configured scene {id}: {e}"))?;
            self.insert_loaded(scene, None);
        }
        let empty = recovered
            .as_ref()
            .is_none_or(|r| r.snapshot.is_none() && r.records.is_empty());
        if let Some(rec) = recovered {
            restore::restore(self, rec);
        }
        match legacy {
            Some(store) if empty => self.load_legacy(store),
            _ => Ok(()),
        }
    }

    /// Reads a data dir of the pre-journal layout and imports it into the journal.
    fn load_legacy(&self, store: &Store) -> Result<(), String> {
        let loaded = store.load_scenes();
        let mut ops = Vec::new();
        let mut bodies_found = false;
        for (path, why) in loaded.bad {
            tracing::error!(path = %path.display(), %why, "skipping unreadable scene file");
        }
        for (id, rec) in loaded.records {
            match rec {
                SceneRecord::Deleted => {
                    self.remove_loaded(&id);
                    ops.push(Op::SceneDelete { scene: id.clone() });
                }
                SceneRecord::Put(v) => {
                    ops.push(Op::ScenePut {
                        scene: id.clone(),
                        spec: v.clone(),
                        clock: None,
                    });
                    match SceneSpec::from_value(v).and_then(|spec| Scene::build(&id, spec)) {
                        Ok(scene) => self.insert_loaded(scene, None),
                        Err(e) => {
                            tracing::error!(scene = %id, error = %e, "skipping persisted scene that no longer builds");
                        }
                    }
                }
            }
        }
        // Clocks: a persisted reading, anchored at the wall time it was taken.
        let now = self.now();
        for entry in self.scenes() {
            let id = &entry.scene.id;
            match store.load_clock(id) {
                Ok(Some(rec)) => {
                    self.replace_clock(&entry, rec.restore(now));
                    ops.push(Op::Clock {
                        scene: id.clone(),
                        clock: rec,
                    });
                }
                Ok(None) => {}
                Err(why) => tracing::error!(scene = %id, %why, "skipping unreadable clock file"),
            }
            // Bodies saved at the last graceful shutdown, anchored at their tick (the loop
            // re-anchors them at the clock's tick on its first step).
            match store.load_bodies(id) {
                Ok(Some(v)) => {
                    let (hz, g) = (entry.scene.spec.tick_hz, entry.scene.spec.surface.gravity);
                    match serde_json::from_value::<crate::bodies::BodiesRecord>(v)
                        .map_err(|e| e.to_string())
                        .and_then(|r| {
                            crate::bodies::SceneBodies::from_record(&r, hz, g)
                                .map_err(|e| e.to_string())
                        }) {
                        Ok(b) => {
                            bodies_found = true;
                            // Not bit-exact (the old file kept no anchor): the bodies carry on
                            // from their saved states.
                            self.bodies.insert(id, b);
                        }
                        Err(why) => {
                            tracing::error!(scene = %id, %why, "skipping unreadable bodies file")
                        }
                    }
                }
                Ok(None) => {}
                Err(why) => tracing::error!(scene = %id, %why, "skipping unreadable bodies file"),
            }
        }
        if ops.is_empty() && !bodies_found {
            return Ok(());
        }
        tracing::info!(
            records = ops.len(),
            "imported a data dir of the pre-journal layout"
        );
        if let Some(j) = &self.journal {
            j.append_all(ops)
                .and_then(|_| snapshots::take(self, j))
                .map_err(|e| format!("importing the old data dir into the journal: {e}"))?;
        }
        Ok(())
    }
}

impl AppState {
    /// Stops the body loops and writes a final snapshot (graceful shutdown), so the next start
    /// replays nothing. Blocking file I/O: call from `spawn_blocking`.
    pub fn write_final_snapshot(&self) {
        self.bodies.stop();
        let Some(j) = &self.journal else {
            return;
        };
        match snapshots::take(self, j) {
            Ok(()) => tracing::info!(seq = j.last_seq(), "journal: final snapshot written"),
            Err(e) => {
                tracing::error!(error = %e, "journal: final snapshot failed (the log holds every change)")
            }
        }
    }
}

/// Largest |rate| of a clock ([`crate::scene::clock::MAX_RATE`]).
pub use crate::scene::clock::MAX_RATE;
