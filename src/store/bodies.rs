//! Floating bodies across a fleet: one sequenced log per scene in Redis, every replica stepping
//! its own copy from it to the same bits.
//!
//! # The log
//! `swell:bodies:<scene>:log` is a Redis Stream of two kinds of entries, in one total order:
//! - commands (`cmd`: spawn, remove, input; `tick`: the scene tick it applies at; `nonce`), which
//!   any replica appends when it accepts a body admin request;
//! - watermarks (`wm`: a scene tick), which only the scene's **sequencer** appends.
//!
//! Both are appended by Lua scripts (Redis runs each alone). The command script gives a command
//! the tick it asked for, or `watermark + 1` if that is already past: nothing is ever applied in
//! the past. The watermark script runs only for the holder of the scene's lease (its fencing
//! token is checked inside the script), so a sequencer that lost its lease (paused, partitioned)
//! can never move the watermark again. Hence every command with `tick <= W` is in the stream
//! before the watermark entry `W`.
//!
//! # Replicas
//! Every replica (the sequencer too) follows the log: commands wait in a pending set ordered by
//! (tick, stream order); at a watermark `W` the replica steps its world to each pending
//! command's tick, applies it, and steps on to `W` ([`crate::bodies::SceneBodies::advance_to`],
//! whose re-anchoring on a jump depends only on the sequence of targets, the same everywhere).
//! The states at a tick are therefore a pure function of the log: bit-identical on every replica,
//! and equal to a single process replaying it. The replica's local body loop does not run for
//! such scenes; states are published to the same watch channel the tick loop reads.
//!
//! # The sequencer
//! One replica per scene holds `swell:bodies:<scene>:lease` (`SET NX PX`, value = a fencing token
//! from `INCR …:fence`), renews it every [`LEASE_RENEW`], and at every tick boundary of the scene
//! clock appends a watermark. If it dies the lease expires after [`LEASE_TTL`] and another
//! replica takes it (with a higher token); bodies pause at the last watermark meanwhile and
//! catch up (or re-anchor, beyond two seconds) at the next one. Acknowledged commands are in
//! Redis already, so none is lost.
//!
//! # Snapshots
//! The sequencer writes `…:snap` every `--snapshot-interval` seconds: the world at a watermark, the pending
//! commands and the stream id it covers; then trims the log to the previous snapshot's id (one
//! interval of slack for a slow follower). Both in one script that checks the lease's fencing
//! token, like the watermark's: a deposed sequencer (paused past its lease, then resumed) cannot
//! overwrite the new holder's snapshot with an older one, nor trim. A joining replica starts
//! from the snapshot. A follower that falls more than an interval behind (starved, paused) would
//! find the entries after its last read trimmed away: after every read it checks that its last
//! entry is still in the stream (the trim removes a prefix, so if it is, nothing after it is
//! gone) and otherwise reloads from the snapshot instead of silently skipping entries.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use redis::AsyncCommands as _;
use redis::aio::MultiplexedConnection;
use redis::streams::{StreamReadOptions, StreamReadReply};
use serde::{Deserialize, Serialize};
use tokio::sync::watch;

use super::fleet::EntryId;
use super::fleet::Fleet;
use crate::bodies::{InputRequest, SpawnRequest, WorldRecord};
use crate::service::types::{InputAccepted, SpawnedBody};
use crate::state::{AppState, StateError};

/// How long a lease lasts without renewal: the failover time after a `kill -9`. Under 2 s at
/// 30 Hz keeps the gap below the 60-tick catch-up limit, so bodies step through it.
pub const LEASE_TTL: Duration = Duration::from_millis(1500);
/// How often the holder renews (and others try to take) the lease.
pub const LEASE_RENEW: Duration = Duration::from_millis(300);
/// How often the sequencer snapshots the world into Redis and trims the log, unless
/// `--snapshot-interval` says otherwise ([`FleetBodies::new`]).
pub const SNAPSHOT_EVERY: Duration = Duration::from_secs(10);
/// How long a spawn waits for its own replica to apply it (one or two ticks normally; a
/// failover takes up to [`LEASE_TTL`]).
const APPLY_TIMEOUT: Duration = Duration::from_secs(4);

pub use crate::bodies::drive::BodyCmd;

/// What applying a command gave (kept for the replica that appended it).
type Outcome = Result<SpawnedBody, StateError>;

/// A scene's followed log, as one replica holds it.
#[derive(Debug, Default, Clone)]
struct Follow {
    /// Commands waiting for their watermark, by (tick, stream id), with their nonce.
    pending: BTreeMap<(i64, EntryId), (BodyCmd, String)>,
    /// The last watermark applied.
    watermark: Option<i64>,
    /// The last stream entry read.
    last: EntryId,
}

/// A snapshot in Redis: the world at a watermark, the commands still waiting, and the last
/// log entry both include.
#[derive(Debug, Serialize, Deserialize)]
struct Snap {
    /// The fencing token of the sequencer that wrote it (absent in snapshots written before
    /// fencing covered them).
    #[serde(default)]
    token: Option<u64>,
    /// `ms-seq` of the last entry included.
    last: String,
    watermark: Option<i64>,
    /// Pending commands: (tick, entry id `ms-seq`, command, nonce).
    pending: Vec<(i64, String, BodyCmd, String)>,
    world: Option<WorldRecord>,
}

impl Snap {
    fn of(f: &Follow, world: Option<WorldRecord>, token: u64) -> Snap {
        Snap {
            token: Some(token),
            last: f.last.to_string(),
            watermark: f.watermark,
            pending: f
                .pending
                .iter()
                .map(|((t, id), (c, n))| (*t, id.to_string(), c.clone(), n.clone()))
                .collect(),
            world,
        }
    }

    fn follow(&self) -> Follow {
        Follow {
            pending: self
                .pending
                .iter()
                .filter_map(|(t, id, c, n)| {
                    Some(((*t, EntryId::parse(id)?), (c.clone(), n.clone())))
                })
                .collect(),
            watermark: self.watermark,
            last: EntryId::parse(&self.last).unwrap_or_default(),
        }
    }
}

/// Body sharing of one replica. Cheap to clone.
#[derive(Clone, Debug)]
pub struct FleetBodies(Arc<Inner>);

#[derive(Debug)]
struct Inner {
    fleet: Fleet,
    /// Scenes this replica follows (a task each).
    following: Mutex<HashSet<String>>,
    /// Outcomes of this replica's own commands, by nonce.
    outcomes: Mutex<HashMap<String, Outcome>>,
    applied: watch::Sender<u64>,
    /// Scenes whose lease this replica holds, with the token.
    leases: Mutex<HashMap<String, u64>>,
    snapshot_every: Duration,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// A scene's body key `swell:bodies:<scene>:<what>` (`log`, `wm`, `snap`, `lease`, `fence`).
pub(crate) fn key(scene: &str, what: &str) -> String {
    format!("swell:bodies:{scene}:{what}")
}

const SCENES_KEY: &str = "swell:bodies:scenes";

/// KEYS: log, wm. ARGV: cmd JSON, nonce, wanted tick. Returns {id, tick}.
const APPEND_SCRIPT: &str = r"
local t = tonumber(ARGV[3])
local wm = redis.call('GET', KEYS[2])
if wm and t <= tonumber(wm) then t = tonumber(wm) + 1 end
local id = redis.call('XADD', KEYS[1], '*', 'cmd', ARGV[1], 'nonce', ARGV[2], 'tick', t)
return {id, t}
";

/// KEYS: log, wm, lease. ARGV: token, watermark. Returns 1, or 0 if the lease is not ours. The
/// entry names its writer's token (`fence`), so the log shows which holder moved it.
const WATERMARK_SCRIPT: &str = r"
if redis.call('GET', KEYS[3]) ~= ARGV[1] then return 0 end
redis.call('SET', KEYS[2], ARGV[2])
redis.call('XADD', KEYS[1], '*', 'wm', ARGV[2], 'fence', ARGV[1])
return 1
";

/// KEYS: snap, log, lease. ARGV: token, snapshot JSON, id to trim the log to ('' none).
/// Returns 1, or 0 (nothing written) if the lease is not ours.
const SNAPSHOT_SCRIPT: &str = r"
if redis.call('GET', KEYS[3]) ~= ARGV[1] then return 0 end
redis.call('SET', KEYS[1], ARGV[2])
if ARGV[3] ~= '' then redis.call('XTRIM', KEYS[2], 'MINID', ARGV[3]) end
return 1
";

/// KEYS: lease. ARGV: token, ttl ms. Renews if ours.
const RENEW_SCRIPT: &str = r"
if redis.call('GET', KEYS[1]) == ARGV[1] then
  redis.call('PEXPIRE', KEYS[1], ARGV[2])
  return 1
end
return 0
";

fn unavailable(message: impl Into<String>) -> StateError {
    StateError::StoreUnavailable(message.into())
}

fn redis_down(e: &redis::RedisError) -> StateError {
    tracing::warn!(error = %e, "store: body write failed");
    unavailable(
        "the shared store (Redis) is unreachable, so body changes are refused until it is back; states keep being served",
    )
}

impl FleetBodies {
    /// Body sharing over `fleet`'s Redis, snapshotting every `snapshot_every` (zero: the
    /// default [`SNAPSHOT_EVERY`]).
    pub fn new(fleet: Fleet, snapshot_every: Duration) -> FleetBodies {
        FleetBodies(Arc::new(Inner {
            fleet,
            following: Mutex::new(HashSet::new()),
            outcomes: Mutex::new(HashMap::new()),
            applied: watch::Sender::new(0),
            leases: Mutex::new(HashMap::new()),
            snapshot_every: if snapshot_every.is_zero() {
                SNAPSHOT_EVERY
            } else {
                snapshot_every
            },
        }))
    }

    /// The scenes this replica sequences now, sorted.
    pub fn sequenced(&self) -> Vec<String> {
        let mut v: Vec<String> = lock(&self.0.leases).keys().cloned().collect();
        v.sort();
        v
    }

    /// Whether this replica sequences `scene` now.
    pub fn is_sequencer(&self, scene: &str) -> bool {
        lock(&self.0.leases).contains_key(scene)
    }

    /// Appends a command through the sequencing rule; returns its apply tick and nonce.
    async fn append(
        &self,
        state: &AppState,
        scene: &str,
        cmd: &BodyCmd,
        wanted: i64,
    ) -> Result<(i64, String), StateError> {
        let nonce = self.0.fleet.next_nonce();
        let json = serde_json::to_string(cmd).map_err(StateError::internal)?;
        let mut conn = self.0.fleet.writes();
        let script = redis::Script::new(APPEND_SCRIPT);
        let mut call = script.key(key(scene, "log"));
        call.key(key(scene, "wm"))
            .arg(&json)
            .arg(&nonce)
            .arg(wanted);
        let (_, tick): (String, i64) = tokio::time::timeout(Duration::from_secs(2), async {
            let _: i64 = conn.sadd(SCENES_KEY, scene).await?;
            call.invoke_async(&mut conn).await
        })
        .await
        .map_err(|_| unavailable("the shared store (Redis) did not answer in time"))?
        .map_err(|e| redis_down(&e))?;
        self.ensure_following(state, scene);
        Ok((tick, nonce))
    }

    /// Waits for the outcome of this replica's command `nonce`.
    async fn outcome(&self, nonce: &str) -> Result<SpawnedBody, StateError> {
        let mut rx = self.0.applied.subscribe();
        let found = tokio::time::timeout(APPLY_TIMEOUT, async {
            loop {
                if let Some(o) = lock(&self.0.outcomes).remove(nonce) {
                    return o;
                }
                if rx.changed().await.is_err() {
                    return Err(StateError::internal("body follower stopped"));
                }
            }
        })
        .await;
        found.unwrap_or_else(|_| {
            lock(&self.0.outcomes).remove(nonce);
            Err(unavailable(
                "the change is in the shared log but no sequencer has reached its tick yet (a failover is in progress); it will apply",
            ))
        })
    }

    /// `POST …/bodies` through the log: 201 state once this replica applied it.
    ///
    /// # Errors
    /// As a local spawn (validated against an empty world first), [`StateError::Body`] over the
    /// limit, [`StateError::StoreUnavailable`] when Redis is unreachable.
    pub async fn spawn(
        &self,
        state: &AppState,
        scene: &str,
        req: SpawnRequest,
    ) -> Result<SpawnedBody, StateError> {
        let entry = state.scene(scene)?;
        let (hz, g) = (entry.scene.spec.tick_hz, entry.scene.spec.surface.gravity);
        // Validate before logging: a command in the log is applied by every replica.
        crate::bodies::SceneBodies::new(0, hz, g)?.spawn(&req)?;
        // The body limit is checked where the spawn applies (crate::bodies::drive::apply), on
        // every replica alike; the outcome answers this request.
        let wanted = state.read_clock(&entry).tick + 1;
        let (_, nonce) = self
            .append(state, scene, &BodyCmd::Spawn(req), wanted)
            .await?;
        self.outcome(&nonce).await
    }

    /// `DELETE …/bodies/{bid}` through the log.
    ///
    /// # Errors
    /// [`StateError::Body`] for a body this replica does not have;
    /// [`StateError::StoreUnavailable`] when Redis is unreachable.
    pub async fn remove(&self, state: &AppState, scene: &str, id: u64) -> Result<(), StateError> {
        let entry = state.scene(scene)?;
        // The body's room for one more input, on this replica's view of the world: inputs racing
        // past the limit together are refused where the log is applied (`SceneBodies::input`, on
        // every replica alike), after their 202.
        let room = state.bodies.get(scene).map(|c| {
            let b = c.lock();
            b.state(id).map(|_| b.input_room(id))
        });
        match room {
            Some(Ok(room)) => room?,
            _ => return Err(crate::bodies::body_not_found(id).into()),
        }
        let wanted = state.read_clock(&entry).tick + 1;
        self.append(state, scene, &BodyCmd::Remove { id }, wanted)
            .await?;
        Ok(())
    }

    /// `POST …/bodies/{bid}/input` through the log: acknowledged (202 with its apply tick) once
    /// it is in Redis.
    ///
    /// # Errors
    /// [`StateError::Body`] for a body this replica does not have or a bad input;
    /// [`StateError::StoreUnavailable`] when Redis is down.
    pub async fn input(
        &self,
        state: &AppState,
        scene: &str,
        id: u64,
        input: InputRequest,
    ) -> Result<InputAccepted, StateError> {
        let entry = state.scene(scene)?;
        let (hz, g) = (entry.scene.spec.tick_hz, entry.scene.spec.surface.gravity);
        let now = state.read_clock(&entry).tick;
        let known = state
            .bodies
            .get(scene)
            .is_some_and(|c| c.lock().state(id).is_ok());
        if !known {
            return Err(crate::bodies::body_not_found(id).into());
        }
        // The same checks as a local input, on a scratch world with one body.
        let mut probe = crate::bodies::SceneBodies::new(now, hz, g)?;
        let bid = probe.spawn(&probe_body())?;
        let mut checked = input;
        checked.from_tick = input.from_tick.map(|f| f.max(now + 1));
        probe.input(bid, &checked)?;
        // Applied at the tick before the one it asks to act from (default: the next tick).
        let wanted = input
            .from_tick
            .map_or(now + 1, |f| f.saturating_sub(1))
            .max(now + 1);
        let (tick, _) = self
            .append(state, scene, &BodyCmd::Input { id, input }, wanted)
            .await?;
        // Applied at `tick`, it acts from the tick asked for unless that is not after `tick`
        // ([`FleetBodies::advance`]). The anchor it meets is not known yet: none is said.
        Ok(InputAccepted {
            tick,
            from_tick: input.from_tick.map_or(tick, |f| f.max(tick)),
            ticks: input.ticks.unwrap_or(1),
            anchor_tick: None,
        })
    }

    /// Follows every scene with a body log (called periodically; cheap when nothing is new).
    pub async fn discover(&self, state: &AppState) {
        let mut conn = self.0.fleet.writes();
        let scenes: Vec<String> = match conn.smembers(SCENES_KEY).await {
            Ok(s) => s,
            Err(_) => return,
        };
        for s in scenes {
            if state.scene(&s).is_ok() {
                self.ensure_following(state, &s);
            }
        }
    }

    fn ensure_following(&self, state: &AppState, scene: &str) {
        if !lock(&self.0.following).insert(scene.to_owned()) {
            return;
        }
        let (me, st, sc) = (self.clone(), state.clone(), scene.to_owned());
        state.tasks.spawn(async move {
            me.follow(&st, &sc).await;
            lock(&me.0.following).remove(&sc);
        });
        let (me, st, sc) = (self.clone(), state.clone(), scene.to_owned());
        state
            .tasks
            .spawn(async move { me.sequence(&st, &sc).await });
    }

    /// The follower of one scene: snapshot, then the log, forever (reconnecting).
    async fn follow(&self, state: &AppState, scene: &str) {
        let mut follow: Option<Follow> = None;
        let mut backoff = Duration::from_millis(100);
        let mut snapped = Instant::now();
        let mut prev_snap: Option<EntryId> = None;
        while !state.shutdown.is_cancelled() && state.scene(scene).is_ok() {
            let run = async {
                let mut conn = self.0.fleet.feed_connection().await?;
                if follow.is_none() {
                    follow = Some(self.load_snapshot(&mut conn, state, scene).await?);
                }
                let f = follow.as_mut().expect("set above");
                let opts = StreamReadOptions::default().block(1000).count(512);
                loop {
                    if state.scene(scene).is_err() {
                        return Ok::<(), redis::RedisError>(());
                    }
                    let reply: Option<StreamReadReply> = conn
                        .xread_options(&[key(scene, "log")], &[f.last.to_string()], &opts)
                        .await?;
                    let entries: Vec<_> = reply
                        .map(|r| r.keys)
                        .unwrap_or_default()
                        .into_iter()
                        .flat_map(|k| k.ids)
                        .collect();
                    if entries.is_empty() {
                        continue;
                    }
                    // Checked after the read: entries trimmed while it blocked show too.
                    if trimmed_past(&mut conn, scene, f.last).await? {
                        tracing::warn!(scene, last = %f.last, "store: the body log was trimmed past this replica's last read; reloading from the snapshot");
                        metrics::counter!("swell_store_body_log_reloads_total").increment(1);
                        *f = self.load_snapshot(&mut conn, state, scene).await?;
                        continue;
                    }
                    self.apply_batch(state, scene, f, entries).await;
                    // The sequencer snapshots what its follower holds (exact: the world at the
                    // last watermark and the commands after it), then trims the log; the script
                    // checks the lease's token, not this replica's belief that it holds it.
                    let token = lock(&self.0.leases).get(scene).copied();
                    if let Some(token) = token
                        && snapped.elapsed() >= self.0.snapshot_every
                    {
                        snapped = Instant::now();
                        let world = state.bodies.get(scene).map(|c| c.lock().world_record());
                        let json =
                            serde_json::to_string(&Snap::of(f, world, token)).unwrap_or_default();
                        if write_snapshot(&mut conn, scene, token, &json, prev_snap).await? {
                            prev_snap = Some(f.last);
                            metrics::counter!("swell_store_body_snapshots_total").increment(1);
                        } else {
                            tracing::warn!(
                                scene,
                                token,
                                "store: body snapshot refused: the lease has a newer holder"
                            );
                            metrics::counter!("swell_store_body_fenced_total").increment(1);
                            prev_snap = None;
                        }
                    }
                }
            };
            tokio::select! {
                () = state.shutdown.cancelled() => return,
                r = run => match r {
                    Ok(()) => return,
                    Err(e) => tracing::debug!(scene, error = %e, "store: body log reconnecting"),
                },
            }
            tokio::select! {
                () = state.shutdown.cancelled() => return,
                () = tokio::time::sleep(backoff) => {}
            }
            backoff = (backoff * 2).min(Duration::from_secs(2));
        }
    }

    async fn load_snapshot(
        &self,
        conn: &mut MultiplexedConnection,
        state: &AppState,
        scene: &str,
    ) -> redis::RedisResult<Follow> {
        let raw: Option<String> = conn.get(key(scene, "snap")).await?;
        let Some(raw) = raw else {
            return Ok(Follow::default());
        };
        match serde_json::from_str::<Snap>(&raw) {
            Ok(snap) => {
                if let Some(w) = &snap.world {
                    match crate::bodies::SceneBodies::from_world_record(w) {
                        Ok(world) => {
                            state.bodies.insert(scene, world);
                            if let Some(cell) = state.bodies.get(scene) {
                                let mut b = cell.lock();
                                // The body impacts the snapshot holds ripple here too.
                                if let Ok(entry) = state.scene(scene) {
                                    b.sync_impacts(&entry.scene.impacts, false);
                                }
                                cell.publish(&b);
                            }
                        }
                        Err(why) => tracing::error!(scene, %why, "store: unreadable body snapshot"),
                    }
                }
                tracing::info!(scene, last = %snap.last, "store: bodies from a snapshot");
                Ok(snap.follow())
            }
            Err(e) => {
                tracing::error!(scene, error = %e, "store: unreadable body snapshot; reading the whole log");
                Ok(Follow::default())
            }
        }
    }

    /// Applies a batch of log entries in order (blocking work off the reactor).
    async fn apply_batch(
        &self,
        state: &AppState,
        scene: &str,
        f: &mut Follow,
        entries: Vec<redis::streams::StreamId>,
    ) {
        let mut owned = std::mem::take(f);
        let (me, st, sc) = (self.clone(), state.clone(), scene.to_owned());
        let done = tokio::task::spawn_blocking(move || {
            for e in entries {
                let Some(id) = EntryId::parse(&e.id) else {
                    continue;
                };
                owned.last = id;
                if let Some(cmd) = e.get::<String>("cmd") {
                    let tick: Option<i64> = e.get("tick");
                    let nonce: String = e.get("nonce").unwrap_or_default();
                    match (serde_json::from_str::<BodyCmd>(&cmd), tick) {
                        (Ok(c), Some(t)) => {
                            owned.pending.insert((t, id), (c, nonce));
                        }
                        _ => tracing::error!(scene = %sc, id = %e.id, "store: skipping an unreadable body command"),
                    }
                } else if let Some(w) = e.get::<i64>("wm") {
                    me.advance(&st, &sc, &mut owned, w);
                }
            }
            owned
        })
        .await;
        match done {
            Ok(next) => *f = next,
            Err(e) => {
                tracing::error!(scene, error = %e, "store: applying body log entries panicked")
            }
        }
        self.0.applied.send_modify(|n| *n += 1);
    }

    /// Steps the world to each pending command with `tick <= w`, applies it, then to `w`.
    fn advance(&self, state: &AppState, scene: &str, f: &mut Follow, w: i64) {
        let Ok(entry) = state.scene(scene) else {
            return;
        };
        let s = &entry.scene;
        let (hz, g) = (s.spec.tick_hz, s.spec.surface.gravity);
        let sea = crate::bodies::Sea::Shared {
            cache: &state.frames,
            scene: s,
            now: state.read_clock(&entry).t,
        };
        let due: Vec<(i64, EntryId)> = f
            .pending
            .range(..=(w, EntryId::MAX))
            .map(|(k, _)| *k)
            .collect();
        for k in due {
            let Some((cmd, nonce)) = f.pending.remove(&k) else {
                continue;
            };
            let tick = k.0;
            let cell = match state.bodies.get(scene) {
                Some(c) => c,
                // Nothing to feel it (the same on every replica: the world exists from the
                // first spawn in the log on).
                None if matches!(cmd, BodyCmd::Impact(_)) => continue,
                None => match state.bodies.get_or_create(scene, tick, hz, g) {
                    Ok(c) => c,
                    Err(e) => {
                        if matches!(cmd, BodyCmd::Spawn(_)) {
                            self.record(&nonce, Err(e.into()));
                        }
                        continue;
                    }
                },
            };
            let mut b = cell.lock();
            crate::bodies::drive::step(&mut b, tick, sea, s);
            let cmd = match cmd {
                // Asked to act from a tick now past: from the next tick instead.
                BodyCmd::Input { id, mut input } => {
                    if input.from_tick.is_some_and(|t| t <= tick) {
                        input.from_tick = None;
                    }
                    BodyCmd::Input { id, input }
                }
                other => other,
            };
            // The same rules (and limits) as a local change. An input for a body removed
            // meanwhile is refused on every replica alike; only a spawn's replica waits for its
            // outcome (the state it answers with): removals, inputs and impacts were answered
            // when they were logged.
            let out =
                crate::bodies::drive::apply(&mut b, scene, &cmd, state.limits.max_scene_bodies);
            let spawned = match cmd {
                BodyCmd::Spawn(_) => {
                    Some(out.map_err(StateError::from).and_then(|id| match id {
                        Some(id) => b.state(id).map_err(StateError::from).map(|state| {
                            SpawnedBody {
                                state,
                                spawn_tick: b.tick(),
                                anchor_tick: b.anchor(),
                            }
                        }),
                        None => Err(StateError::internal("a spawn gave no body id")),
                    }))
                }
                _ => None,
            };
            let _ = b.take_events();
            // Not published here: a tick's states are published once, at the watermark, when
            // every command of the tick is applied (a frame must not carry half a tick).
            drop(b);
            if let Some(out) = spawned {
                self.record(&nonce, out);
            }
        }
        if let Some(cell) = state.bodies.get(scene) {
            let mut b = cell.lock();
            let adv = crate::bodies::drive::step(&mut b, w, sea, s);
            let _ = b.take_events();
            if adv.steps > 0 || adv.reanchored {
                metrics::counter!("swell_body_ticks_total").increment(u64::from(adv.steps));
            }
            if adv.reanchored {
                metrics::counter!("swell_body_reanchors_total").increment(1);
            }
            cell.publish(&b);
        }
        f.watermark = Some(w);
    }

    fn record(&self, nonce: &str, out: Outcome) {
        if self.0.fleet.is_own_nonce(nonce) {
            lock(&self.0.outcomes).insert(nonce.to_owned(), out);
        }
    }

    /// The lease loop of one scene: take the lease when free, and while holding it append a
    /// watermark at every tick boundary, renew, snapshot.
    async fn sequence(&self, state: &AppState, scene: &str) {
        let (lease, fence) = (key(scene, "lease"), key(scene, "fence"));
        let wm_script = redis::Script::new(WATERMARK_SCRIPT);
        let renew = redis::Script::new(RENEW_SCRIPT);
        let mut token: Option<String> = None;
        let mut renewed = Instant::now();
        let mut last_wm: Option<i64> = None;
        while !state.shutdown.is_cancelled() {
            let Ok(entry) = state.scene(scene) else {
                break;
            };
            let mut conn = self.0.fleet.writes();
            if token.is_none() {
                // Try to take the lease (a fresh token each try: an old holder's writes fail).
                let free: redis::RedisResult<bool> = conn.exists(&lease).await.map(|e: bool| !e);
                if free.unwrap_or(false) {
                    let t: redis::RedisResult<u64> = conn.incr(&fence, 1).await;
                    if let Ok(t) = t {
                        let v = t.to_string();
                        let ok: redis::RedisResult<Option<String>> = redis::cmd("SET")
                            .arg(&lease)
                            .arg(&v)
                            .arg("NX")
                            .arg("PX")
                            .arg(LEASE_TTL.as_millis() as u64)
                            .query_async(&mut conn)
                            .await;
                        if matches!(ok, Ok(Some(_))) {
                            tracing::info!(
                                scene,
                                token = t,
                                "store: this replica sequences the scene's bodies"
                            );
                            lock(&self.0.leases).insert(scene.to_owned(), t);
                            token = Some(v);
                            renewed = Instant::now();
                            last_wm = None;
                        }
                    }
                }
                if token.is_none() {
                    tokio::select! {
                        () = state.shutdown.cancelled() => break,
                        () = tokio::time::sleep(LEASE_RENEW) => {}
                    }
                    continue;
                }
            }
            let tok = token.clone().unwrap_or_default();
            if renewed.elapsed() >= LEASE_RENEW {
                let mut call = renew.key(&lease);
                call.arg(&tok).arg(LEASE_TTL.as_millis() as u64);
                let ours: redis::RedisResult<i64> = call.invoke_async(&mut conn).await;
                match ours {
                    Ok(1) => renewed = Instant::now(),
                    Ok(_) => {
                        tracing::warn!(
                            scene,
                            "store: lost the body lease (renewal refused: it has a newer holder)"
                        );
                        metrics::counter!("swell_store_body_fenced_total").increment(1);
                        token = None;
                        lock(&self.0.leases).remove(scene);
                        continue;
                    }
                    Err(_) => {}
                }
                if renewed.elapsed() >= LEASE_TTL {
                    // Could not renew in time: another replica may hold it now.
                    tracing::warn!(
                        scene,
                        "store: gave up the body lease (not renewed within its TTL)"
                    );
                    token = None;
                    lock(&self.0.leases).remove(scene);
                    continue;
                }
            }
            let r = state.read_clock(&entry);
            if last_wm != Some(r.tick) {
                let mut call = wm_script.key(key(scene, "log"));
                call.key(key(scene, "wm")).key(&lease).arg(&tok).arg(r.tick);
                match call.invoke_async::<i64>(&mut conn).await {
                    Ok(1) => last_wm = Some(r.tick),
                    Ok(_) => {
                        tracing::warn!(
                            scene,
                            "store: watermark refused: the lease has a newer holder"
                        );
                        metrics::counter!("swell_store_body_fenced_total").increment(1);
                        token = None;
                        lock(&self.0.leases).remove(scene);
                        continue;
                    }
                    Err(_) => {}
                }
            }
            let wait =
                crate::stream::ticks::until_next_tick(r.t, r.tick, r.tick_hz, r.rate, r.paused)
                    .min(LEASE_RENEW);
            tokio::select! {
                () = state.shutdown.cancelled() => break,
                () = tokio::time::sleep(wait) => {}
            }
        }
        // Hand the lease over at once on a graceful stop.
        if let Some(tok) = token {
            let mut conn = self.0.fleet.writes();
            let del = redis::Script::new(
                "if redis.call('GET', KEYS[1]) == ARGV[1] then return redis.call('DEL', KEYS[1]) end return 0",
            );
            let mut call = del.key(&lease);
            call.arg(&tok);
            let _: redis::RedisResult<i64> = call.invoke_async(&mut conn).await;
            lock(&self.0.leases).remove(scene);
        }
    }
}

/// Writes `snapshot` (JSON) as `scene`'s body snapshot and trims its log to `trim_to` (ids
/// before it go), in one script, if `token` is the lease's fencing token now. Returns whether it
/// wrote: `false` means the lease has another holder and nothing changed.
///
/// # Errors
/// Redis unreachable or answering with an error.
pub async fn write_snapshot(
    conn: &mut impl redis::aio::ConnectionLike,
    scene: &str,
    token: u64,
    snapshot: &str,
    trim_to: Option<EntryId>,
) -> redis::RedisResult<bool> {
    let script = redis::Script::new(SNAPSHOT_SCRIPT);
    let mut call = script.key(key(scene, "snap"));
    call.key(key(scene, "log"))
        .key(key(scene, "lease"))
        .arg(token)
        .arg(snapshot)
        .arg(trim_to.map(|p| p.to_string()).unwrap_or_default());
    Ok(call.invoke_async::<i64>(conn).await? == 1)
}

/// Whether the log was trimmed past `last`, the follower's last read entry: it is gone from the
/// stream (a trim removes a prefix, so while `last` is there nothing after it is gone). A
/// follower that read nothing yet (`last` = 0-0, no snapshot when it started) is behind when a
/// snapshot exists now: a trim only ever follows one.
async fn trimmed_past(
    conn: &mut MultiplexedConnection,
    scene: &str,
    last: EntryId,
) -> redis::RedisResult<bool> {
    if last == EntryId::default() {
        return conn.exists(key(scene, "snap")).await;
    }
    let at = last.to_string();
    let found: redis::streams::StreamRangeReply = conn.xrange(key(scene, "log"), &at, &at).await?;
    Ok(found.ids.is_empty())
}

/// A small body to check an input against.
fn probe_body() -> SpawnRequest {
    serde_json::from_value(serde_json::json!({
        "mass": 1000.0,
        "hull": {"kind": "box", "length": 4.0, "beam": 2.0, "height": 1.0},
        "position": [0.0, 0.0, 0.0]
    }))
    .expect("a valid spawn request")
}
