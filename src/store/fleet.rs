//! The Redis backend: admin changes shared by every replica of a fleet.
//!
//! # Keys (prefix `swell:`)
//! - `swell:admin` — a hash, the folded admin state ([`AdminState`]): `scene:<id>` → the
//!   scene's last word (`{"put": spec}` or `"deleted"`), `clock:<id>` → its clock record
//!   (`{"t","rate","paused","unix","generation"}`: the clock's anchor), written by an admin
//!   clock change and by a put that moves the scene's epoch (the fresh clock the put's op
//!   carries), dropped by a delete. What a replica needs to catch up from nothing.
//! - `swell:feed` — a Redis Stream, the change feed: one entry per admin change, `op` (the
//!   journal's [`Op`] JSON), `nonce` (which request wrote it) and, for an API impact on a
//!   scene with a body log, `body_tick` (the tick the log sequenced it at, which
//!   [`Op::Impact`]'s unlogged `body_tick` takes on every replica). Trimmed to about
//!   [`FEED_MAXLEN`] entries: the hash, not the stream, is the record.
//! - `swell:impacts:<scene>:list` — a list, the scene's API impacts (each an
//!   [`Impact`](swell_waves::particles::Impact) JSON) in the order they were accepted; and
//!   `swell:impacts:scenes`, the set of scenes that have such a list. Written with the feed
//!   entry that announces the impact (an [`Op::Impact`]) in one script; a scene put or delete
//!   drops the list in the same script that records it, so an impact never outlives the scene
//!   it ripples on. Impacts ripple by closed form from the set alone (their order does not
//!   matter: the set is kept canonically sorted), so every replica that holds the same list
//!   answers the same bits.
//!
//! # Writes
//! One Lua script updates the hash and appends the feed entry atomically (Redis runs a script
//! alone), so the hash and the stream's last id always describe the same state. Writes go
//! through a [`ConnectionManager`]: one multiplexed connection shared by every request (Redis
//! answers a connection's commands in order, so pipelining many requests over one socket is
//! the pooling that suits it), with a response timeout, and reconnects with exponential backoff
//! after a connection error. A write that fails or times out is a 503 `store_unavailable`:
//! admin writes stop while Redis is unreachable, queries go on from the scenes already loaded.
//!
//! # The feed
//! Every replica, the writer included, applies changes in stream order from one loop
//! ([`Fleet::run`]) on a dedicated connection (a blocking `XREAD` would hold up every other
//! command queued behind it on a shared one). On every (re)connect the loop first re-reads
//! the whole hash, every impact list and the stream's last id in one script (one consistent
//! view) and applies what differs from what it has applied, then follows the stream from that
//! id with `XREAD BLOCK`. A notification missed while disconnected is therefore never lost: the
//! re-read covers it. A request that wrote an
//! entry waits until its own replica's loop has applied it (read-your-writes), so the order of
//! changes is the stream's on every replica, and the writer's answer shows the applied state.
//!
//! The scene a put built to validate it is handed to the loop by nonce, so the writing
//! replica does not build an FFT scene twice.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use redis::aio::{ConnectionManager, ConnectionManagerConfig, MultiplexedConnection};
use redis::streams::{StreamId, StreamReadOptions, StreamReadReply};
use redis::{AsyncCommands as _, AsyncConnectionConfig};
use tokio::sync::watch;
use tokio_util::sync::CancellationToken;

use super::url::StoreUrl;
use crate::journal::{AdminScene, AdminState, Op};
use crate::scene::Scene;
use crate::scene::store::ClockRecord;
use crate::state::apply::Prepared;
use crate::state::{AppState, StateError};

/// Feed entries kept (approximately: `MAXLEN ~` trims whole radix-tree nodes, cheaply). A
/// replica that is connected reads entries within milliseconds; one that reconnects re-reads
/// the hash, so the stream only has to outlast a burst of admin changes, not an outage.
pub const FEED_MAXLEN: usize = 10_000;
/// Longest a command may wait for its answer. Redis answers in well under a millisecond on a
/// LAN; a second means it is gone or stalled, and the admin request gets its 503 quickly.
const RESPONSE_TIMEOUT: Duration = Duration::from_secs(1);
/// Longest a TCP connect + handshake to Redis may take.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(1);
/// Longest an admin write waits for the store and then for its own replica to apply it.
const WRITE_TIMEOUT: Duration = Duration::from_secs(2);
const APPLY_TIMEOUT: Duration = Duration::from_secs(5);
/// `XREAD BLOCK` milliseconds: how long the feed waits for an entry before asking again. Short
/// enough that a silently dead connection is noticed in about a second (the response timeout
/// on the feed connection is this plus [`RESPONSE_TIMEOUT`]).
const FEED_BLOCK_MS: usize = 1000;
/// Reconnect backoff of the feed loop: doubles from the first to the last. 100 ms finds a
/// restarted Redis quickly; 2 s keeps a replica from hammering a Redis that is down for long.
const BACKOFF_MIN: Duration = Duration::from_millis(100);
const BACKOFF_MAX: Duration = Duration::from_secs(2);

/// Updates the admin hash and appends the feed entry, atomically; a scene put or delete also
/// drops the scene's impact list. A second field is set or deleted in the same step: the
/// scene's clock record, which a put that moves the epoch replaces and a delete drops.
/// KEYS: admin hash, feed, the scene's impact list, the impact index set. ARGV: op JSON, nonce,
/// hash field, value, second field ('' none), its value ('' deletes the field), max feed
/// length, scene whose impacts go ('' none).
/// Returns the new entry's id.
const WRITE_SCRIPT: &str = r"
redis.call('HSET', KEYS[1], ARGV[3], ARGV[4])
if ARGV[5] ~= '' then
  if ARGV[6] ~= '' then
    redis.call('HSET', KEYS[1], ARGV[5], ARGV[6])
  else
    redis.call('HDEL', KEYS[1], ARGV[5])
  end
end
if ARGV[8] ~= '' then
  redis.call('DEL', KEYS[3])
  redis.call('SREM', KEYS[4], ARGV[8])
end
return redis.call('XADD', KEYS[2], 'MAXLEN', '~', ARGV[7], '*', 'op', ARGV[1], 'nonce', ARGV[2])
";

/// Appends an API impact to its scene's list and the feed entry that announces it, atomically,
/// unless the list is full; and, when the scene has a body log, the `impact` command that makes
/// its bodies feel it, sequenced as any body command is (at the tick asked for, or one past the
/// watermark: see [`crate::store::bodies`]). One script, so queries and bodies never disagree
/// on whether an acknowledged impact exists.
/// Impacts at the head of the list more than a ring lifetime older than the new one are
/// dropped first: every replica drops them from its set anyway (an impact more than a lifetime
/// older than the newest cannot ripple), so the list holds live impacts only and a scene does
/// not fill up over a long match. (The list is in arrival order, which is nearly time order;
/// an older impact behind a newer one waits until it reaches the head.)
/// KEYS: the scene's impact list, the impact index set, feed, the scene's body log, its
/// watermark. ARGV: impact JSON, op JSON, nonce, scene id, most impacts, max feed length, body
/// command JSON, wanted tick, the impact's t minus the ring lifetime. Returns the new feed
/// entry's id, followed by a space and the tick the `impact` command was sequenced at when the
/// scene has a body log (the tick every replica's bodies feel it from), or `full:<n>`. The feed
/// entry carries that tick too (field `body_tick`), so every replica's tick frames announce the
/// impact with the tick the log sequenced, not one of their own.
const IMPACT_SCRIPT: &str = r"
local oldest = tonumber(ARGV[9])
while true do
  local head = redis.call('LINDEX', KEYS[1], 0)
  if not head or cjson.decode(head).t >= oldest then break end
  redis.call('LPOP', KEYS[1])
end
local n = redis.call('LLEN', KEYS[1])
if n >= tonumber(ARGV[5]) then return 'full:' .. n end
redis.call('RPUSH', KEYS[1], ARGV[1])
redis.call('SADD', KEYS[2], ARGV[4])
if redis.call('EXISTS', KEYS[4]) == 1 then
  local t = tonumber(ARGV[8])
  local wm = redis.call('GET', KEYS[5])
  if wm and t <= tonumber(wm) then t = tonumber(wm) + 1 end
  redis.call('XADD', KEYS[4], '*', 'cmd', ARGV[7], 'nonce', ARGV[3], 'tick', t)
  local felt = string.format('%d', t)
  return redis.call('XADD', KEYS[3], 'MAXLEN', '~', ARGV[6], '*', 'op', ARGV[2], 'nonce', ARGV[3], 'body_tick', felt) .. ' ' .. felt
end
return redis.call('XADD', KEYS[3], 'MAXLEN', '~', ARGV[6], '*', 'op', ARGV[2], 'nonce', ARGV[3])
";

/// Reads everything a replica catches up from, in one atomic step: the admin hash (flat
/// field/value pairs), the feed's last id ('' when empty), the scenes with impact lists and
/// each one's list.
/// KEYS: admin hash, feed, the impact index set. ARGV: impact list key prefix.
const RESYNC_SCRIPT: &str = r"
local admin = redis.call('HGETALL', KEYS[1])
local last = redis.call('XREVRANGE', KEYS[2], '+', '-', 'COUNT', 1)
local id = ''
if #last > 0 then id = last[1][1] end
local scenes = redis.call('SMEMBERS', KEYS[3])
local lists = {}
for i, s in ipairs(scenes) do
  lists[i] = redis.call('LRANGE', ARGV[1] .. s .. ':list', 0, -1)
end
return {admin, id, scenes, lists}
";

/// The impact index set.
const IMPACT_SCENES_KEY: &str = "swell:impacts:scenes";
/// Prefix of a scene's impact list key (`swell:impacts:<scene>:list`).
const IMPACT_LIST_PREFIX: &str = "swell:impacts:";

fn impact_list_key(scene: &str) -> String {
    format!("{IMPACT_LIST_PREFIX}{scene}:list")
}

/// Timeouts of a connection that blocks in `XREAD` for up to [`FEED_BLOCK_MS`].
fn feed_config() -> AsyncConnectionConfig {
    AsyncConnectionConfig::new()
        .set_connection_timeout(Some(CONNECT_TIMEOUT))
        .set_response_timeout(Some(
            Duration::from_millis(FEED_BLOCK_MS as u64) + RESPONSE_TIMEOUT,
        ))
}

/// A Redis stream entry id, `ms-seq`, ordered as Redis orders them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct EntryId(u64, u64);

impl EntryId {
    /// Past every id.
    pub const MAX: EntryId = EntryId(u64::MAX, u64::MAX);

    /// Parses `ms-seq`.
    pub fn parse(s: &str) -> Option<EntryId> {
        let (a, b) = s.split_once('-')?;
        Some(EntryId(a.parse().ok()?, b.parse().ok()?))
    }
}

impl std::fmt::Display for EntryId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}-{}", self.0, self.1)
    }
}

/// The Redis store of a fleet. Cheap to clone.
#[derive(Clone)]
pub struct Fleet(Arc<Inner>);

struct Inner {
    url: StoreUrl,
    client: redis::Client,
    /// Writes and one-off reads (multiplexed, reconnecting).
    writes: ConnectionManager,
    admin_key: String,
    feed_key: String,
    /// This process, for nonces (random, so two replicas never collide).
    origin: String,
    nonces: AtomicU64,
    /// Whether the feed loop is connected and caught up.
    connected: AtomicBool,
    /// The last feed entry this replica has applied (or covered by a re-read).
    applied: watch::Sender<EntryId>,
    /// Whether the first full re-read is done (the replica is not ready before).
    synced: watch::Sender<bool>,
    /// Scenes built by this replica's put requests, by nonce, waiting for their feed entry.
    prebuilt: Mutex<HashMap<String, Scene>>,
    /// What this replica has applied: the re-read applies only what differs.
    folded: Mutex<AdminState>,
    write_script: redis::Script,
    impact_script: redis::Script,
    resync_script: redis::Script,
}

impl std::fmt::Debug for Fleet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fleet")
            .field("url", &self.0.url)
            .field("origin", &self.0.origin)
            .field("connected", &self.is_connected())
            .field("applied", &*self.0.applied.borrow())
            .finish_non_exhaustive()
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// [`StateError::StoreUnavailable`] (503 `store_unavailable`) with a message for the operator.
fn unavailable(message: impl Into<String>) -> StateError {
    StateError::StoreUnavailable(message.into())
}

impl Fleet {
    /// A store on `url`. Connects lazily: a replica starts (and serves its built-in and
    /// configured scenes read-only, not yet ready) while Redis is still coming up.
    ///
    /// # Errors
    /// The URL is not one the client can use.
    pub fn new(url: StoreUrl) -> Result<Fleet, String> {
        let client = redis::Client::open(url.as_secret_str()).map_err(|e| format!("{url}: {e}"))?;
        let config = ConnectionManagerConfig::new()
            .set_response_timeout(Some(RESPONSE_TIMEOUT))
            .set_connection_timeout(Some(CONNECT_TIMEOUT))
            .set_min_delay(Duration::from_millis(50))
            .set_max_delay(Duration::from_secs(1))
            .set_number_of_retries(3);
        let writes = ConnectionManager::new_lazy_with_config(client.clone(), config)
            .map_err(|e| format!("{url}: {e}"))?;
        let mut origin = [0u8; 8];
        getrandom::fill(&mut origin).map_err(|e| format!("random instance id: {e}"))?;
        Ok(Fleet(Arc::new(Inner {
            url,
            client,
            writes,
            admin_key: "swell:admin".into(),
            feed_key: "swell:feed".into(),
            origin: origin.iter().map(|b| format!("{b:02x}")).collect(),
            nonces: AtomicU64::new(0),
            connected: AtomicBool::new(false),
            applied: watch::Sender::new(EntryId::default()),
            synced: watch::Sender::new(false),
            prebuilt: Mutex::new(HashMap::new()),
            folded: Mutex::new(AdminState::default()),
            write_script: redis::Script::new(WRITE_SCRIPT),
            impact_script: redis::Script::new(IMPACT_SCRIPT),
            resync_script: redis::Script::new(RESYNC_SCRIPT),
        })))
    }

    /// The store's URL (password hidden when displayed).
    pub fn url(&self) -> &StoreUrl {
        &self.0.url
    }

    /// Whether the change feed is connected and caught up.
    pub fn is_connected(&self) -> bool {
        self.0.connected.load(Ordering::Relaxed)
    }

    /// The last feed entry applied here.
    pub fn applied(&self) -> EntryId {
        *self.0.applied.borrow()
    }

    /// A nonce unique to this process and request (`<instance>-<n>`).
    pub fn next_nonce(&self) -> String {
        format!(
            "{}-{}",
            self.0.origin,
            self.0.nonces.fetch_add(1, Ordering::Relaxed)
        )
    }

    /// Whether `nonce` was made by [`Fleet::next_nonce`] of this process.
    pub fn is_own_nonce(&self, nonce: &str) -> bool {
        nonce
            .strip_prefix(self.0.origin.as_str())
            .is_some_and(|r| r.starts_with('-'))
    }

    /// The shared, reconnecting connection for short commands.
    pub fn writes(&self) -> ConnectionManager {
        self.0.writes.clone()
    }

    /// A dedicated connection for blocking reads (`XREAD BLOCK`), with the feed's timeouts.
    ///
    /// # Errors
    /// Redis cannot be reached.
    pub async fn feed_connection(&self) -> redis::RedisResult<MultiplexedConnection> {
        self.0
            .client
            .get_multiplexed_async_connection_with_config(&feed_config())
            .await
    }

    /// Drops a deleted scene's body log, lease and snapshot (best effort: a later put of the
    /// same id must not inherit them).
    pub async fn delete_body_log(&self, scene: &str) {
        let mut conn = self.0.writes.clone();
        let keys: Vec<String> = ["log", "wm", "lease", "fence", "snap"]
            .iter()
            .map(|k| format!("swell:bodies:{scene}:{k}"))
            .collect();
        let r: redis::RedisResult<()> = redis::pipe()
            .del(&keys)
            .ignore()
            .srem("swell:bodies:scenes", scene)
            .ignore()
            .query_async(&mut conn)
            .await;
        if let Err(e) = r {
            tracing::warn!(scene, error = %e, "store: could not drop a deleted scene's body log");
        }
    }

    /// Waits until the first full re-read of the store is applied.
    pub async fn wait_synced(&self) {
        let mut rx = self.0.synced.subscribe();
        // The sender lives as long as `self`, so this only ends when synced.
        let _ = rx.wait_for(|s| *s).await;
    }

    fn set_connected(&self, up: bool) {
        let was = self.0.connected.swap(up, Ordering::Relaxed);
        metrics::gauge!("swell_store_connected").set(if up { 1.0 } else { 0.0 });
        if was != up {
            if up {
                tracing::info!(store = %self.0.url, "store: connected, caught up");
            } else {
                tracing::warn!(store = %self.0.url, "store: connection lost; serving the last known scenes read-only, admin changes get 503 until it is back");
            }
        }
    }

    /// Stores an admin change and waits until this replica has applied it from the feed. `built`
    /// is a put's scene (built already, to validate it). A put that carries a clock moved the
    /// scene's epoch: the stored clock record becomes that clock, in the same atomic step, so a
    /// replica that catches up from the hash (started later, or after an outage) reads the
    /// clock the feed gave every other replica.
    ///
    /// # Errors
    /// [`StateError::StoreUnavailable`] when Redis cannot be written (nothing changed) or the
    /// change was stored but this replica's feed is not connected to apply it (every other
    /// replica, and this one once reconnected, will).
    pub async fn commit(&self, op: Op, built: Option<Scene>) -> Result<(), StateError> {
        // A put or delete starts the scene's impacts afresh (as the journal's fold does). The
        // scene's clock record: the fresh clock of a put that moves the epoch, none after a
        // delete (`""` deletes the field), as the journal's fold has it.
        let none = || Ok(String::new());
        let (field, value, clock_field, clock_value, clears) = match &op {
            Op::ScenePut { scene, spec, clock } => (
                format!("scene:{scene}"),
                serde_json::to_string(&AdminScene::Put(spec.clone())),
                match clock {
                    Some(_) => format!("clock:{scene}"),
                    None => String::new(),
                },
                clock.as_ref().map_or_else(none, serde_json::to_string),
                scene.clone(),
            ),
            Op::SceneDelete { scene } => (
                format!("scene:{scene}"),
                serde_json::to_string(&AdminScene::Deleted),
                format!("clock:{scene}"),
                none(),
                scene.clone(),
            ),
            Op::Clock { scene, clock } => (
                format!("clock:{scene}"),
                serde_json::to_string(clock),
                String::new(),
                none(),
                String::new(),
            ),
            Op::Body { .. } | Op::Impact { .. } => {
                return Err(StateError::internal(
                    "body changes go through the body log, impacts through Fleet::add_impact",
                ));
            }
        };
        let list = impact_list_key(op.scene());
        let value = value.map_err(StateError::internal)?;
        let clock_value = clock_value.map_err(StateError::internal)?;
        let op_json = serde_json::to_string(&op).map_err(StateError::internal)?;
        let nonce = self.next_nonce();
        if let Some(scene) = built {
            lock(&self.0.prebuilt).insert(nonce.clone(), scene);
        }
        let mut call = self.0.write_script.key(&self.0.admin_key);
        call.key(&self.0.feed_key)
            .key(&list)
            .key(IMPACT_SCENES_KEY)
            .arg(&op_json)
            .arg(&nonce)
            .arg(&field)
            .arg(&value)
            .arg(&clock_field)
            .arg(&clock_value)
            .arg(FEED_MAXLEN)
            .arg(&clears);
        self.write_and_apply(call, &nonce).await.map(|_| ())
    }

    /// Stores an API impact of `scene` (its list and the feed entry that announces it, and the
    /// command that makes the scene's bodies feel it from scene tick `wanted` or the first one
    /// not yet sequenced) and waits until this replica has applied it, so the answer's replica
    /// ripples with it. Returns the tick the bodies feel it from (as sequenced in the body log,
    /// which every replica applies it at), or `None` if the scene has no body log.
    ///
    /// # Errors
    /// [`StateError::TooManyImpacts`] when the scene's list holds `max` impacts; otherwise as
    /// [`Fleet::commit`].
    pub async fn add_impact(
        &self,
        scene: &str,
        impact: swell_waves::particles::Impact,
        max: usize,
        wanted: i64,
        lifetime: f64,
    ) -> Result<Option<i64>, StateError> {
        let impact_json = serde_json::to_string(&impact).map_err(StateError::internal)?;
        // Its `body_tick` is not logged: the script puts the tick it sequences beside the op.
        let op_json = serde_json::to_string(&Op::Impact {
            scene: scene.to_owned(),
            impact,
            body_tick: None,
        })
        .map_err(StateError::internal)?;
        let cmd_json = serde_json::to_string(&crate::store::bodies::BodyCmd::Impact(impact))
            .map_err(StateError::internal)?;
        let nonce = self.next_nonce();
        let mut call = self.0.impact_script.key(impact_list_key(scene));
        call.key(IMPACT_SCENES_KEY)
            .key(&self.0.feed_key)
            .key(crate::store::bodies::key(scene, "log"))
            .key(crate::store::bodies::key(scene, "wm"))
            .arg(&impact_json)
            .arg(&op_json)
            .arg(&nonce)
            .arg(scene)
            .arg(max)
            .arg(FEED_MAXLEN)
            .arg(&cmd_json)
            .arg(wanted)
            // Printed in full (Rust's shortest round-trip form), so Lua reads the same double.
            .arg(format!("{:?}", impact.t - lifetime));
        let felt = self.write_and_apply(call, &nonce).await?;
        felt.map(|t| {
            t.parse::<i64>().map_err(|_| {
                StateError::internal(format!("the impact script answered a malformed tick {t:?}"))
            })
        })
        .transpose()
    }

    /// Runs a write script (one retry on a dead connection), then waits until this replica's
    /// feed has applied the entry it appended. The script answers the entry's id, optionally
    /// followed by a space and more (returned).
    async fn write_and_apply(
        &self,
        call: redis::ScriptInvocation<'_>,
        nonce: &str,
    ) -> Result<Option<String>, StateError> {
        let write = async {
            let mut conn = self.0.writes.clone();
            match call.invoke_async::<String>(&mut conn).await {
                // The manager's connection died since its last command (Redis restarted): it
                // reconnects on this error, so one more try goes out on the new connection. The
                // script is one atomic step: a try that failed did not write.
                Err(e)
                    if e.is_io_error()
                        || e.is_connection_dropped()
                        || e.is_unrecoverable_error() =>
                {
                    tracing::debug!(error = %e, "store: write failed on a dead connection; retrying once");
                    call.invoke_async::<String>(&mut conn).await
                }
                r => r,
            }
        };
        let written = tokio::time::timeout(WRITE_TIMEOUT, write).await;
        let extra;
        let id = match written {
            Ok(Ok(full)) if full.starts_with("full:") => {
                return Err(StateError::TooManyImpacts(format!(
                    "the scene holds {} impacts, the limit",
                    full.trim_start_matches("full:")
                )));
            }
            Ok(Ok(answer)) => {
                let (id, more) = match answer.split_once(' ') {
                    Some((id, more)) => (id, Some(more.to_owned())),
                    None => (answer.as_str(), None),
                };
                extra = more;
                EntryId::parse(id)
            }
            Ok(Err(e)) => {
                lock(&self.0.prebuilt).remove(nonce);
                tracing::warn!(store = %self.0.url, error = %e, "store: admin write failed");
                return Err(unavailable(
                    "the shared store (Redis) is unreachable, so admin changes are refused until it is back; queries are served from the last known scenes",
                ));
            }
            Err(_) => {
                lock(&self.0.prebuilt).remove(nonce);
                tracing::warn!(store = %self.0.url, "store: admin write timed out");
                return Err(unavailable(
                    "the shared store (Redis) did not answer in time, so admin changes are refused until it is back; queries are served from the last known scenes",
                ));
            }
        };
        let Some(id) = id else {
            lock(&self.0.prebuilt).remove(nonce);
            return Err(StateError::internal("XADD answered with a malformed id"));
        };
        metrics::counter!("swell_store_writes_total").increment(1);
        let mut rx = self.0.applied.subscribe();
        let applied = tokio::time::timeout(APPLY_TIMEOUT, rx.wait_for(|a| *a >= id)).await;
        lock(&self.0.prebuilt).remove(nonce);
        match applied {
            Ok(Ok(_)) => Ok(extra),
            _ => Err(unavailable(format!(
                "the change was stored (feed entry {id}) but this replica has not applied it yet: its change feed is reconnecting to the shared store; every replica applies it once connected"
            ))),
        }
    }

    /// The feed loop: connect, re-read everything, follow the stream; on any error reconnect
    /// with backoff and start over. Ends when `shutdown` fires.
    pub async fn run(self, state: AppState, shutdown: CancellationToken) {
        let config = feed_config();
        let mut backoff = BACKOFF_MIN;
        loop {
            let attempt = async {
                let mut conn = self
                    .0
                    .client
                    .get_multiplexed_async_connection_with_config(&config)
                    .await?;
                let last = self.resync(&mut conn, &state).await?;
                // Warm the write connection too, so the first admin write after an outage
                // does not pay for (or trip over) the manager's reconnect.
                let mut writes = self.0.writes.clone();
                let _: redis::RedisResult<String> =
                    redis::cmd("PING").query_async(&mut writes).await;
                self.set_connected(true);
                let _ = self.0.synced.send_replace(true);
                self.follow(&mut conn, &state, last).await
            };
            let err = tokio::select! {
                () = shutdown.cancelled() => return,
                r = attempt => match r {
                    Ok(()) => return,
                    Err(e) => e,
                },
            };
            if self.is_connected() {
                backoff = BACKOFF_MIN;
            }
            self.set_connected(false);
            tracing::debug!(store = %self.0.url, error = %err, ?backoff, "store: feed reconnecting");
            tokio::select! {
                () = shutdown.cancelled() => return,
                () = tokio::time::sleep(backoff) => {}
            }
            backoff = (backoff * 2).min(BACKOFF_MAX);
        }
    }

    /// Reads the admin hash and the feed's last id in one transaction, applies every scene and
    /// clock that differs from what this replica applied, and returns the id to follow from.
    async fn resync(
        &self,
        conn: &mut MultiplexedConnection,
        state: &AppState,
    ) -> redis::RedisResult<EntryId> {
        let mut call = self.0.resync_script.key(&self.0.admin_key);
        call.key(&self.0.feed_key)
            .key(IMPACT_SCENES_KEY)
            .arg(IMPACT_LIST_PREFIX);
        let (flat, last, impact_scenes, lists): (
            Vec<String>,
            String,
            Vec<String>,
            Vec<Vec<String>>,
        ) = call.invoke_async(conn).await?;
        let last = EntryId::parse(&last).unwrap_or_default();
        let hash: Vec<(String, String)> = flat
            .chunks_exact(2)
            .map(|p| (p[0].clone(), p[1].clone()))
            .collect();
        let mut stored = AdminState::default();
        for (field, value) in hash {
            if let Some(id) = field.strip_prefix("scene:") {
                match serde_json::from_str::<AdminScene>(&value) {
                    Ok(s) => {
                        stored.scenes.insert(id.to_owned(), s);
                    }
                    Err(e) => {
                        tracing::error!(field, error = %e, "store: skipping an unreadable scene")
                    }
                }
            } else if let Some(id) = field.strip_prefix("clock:") {
                match serde_json::from_str::<ClockRecord>(&value) {
                    Ok(c) => {
                        stored.clocks.insert(id.to_owned(), c);
                    }
                    Err(e) => {
                        tracing::error!(field, error = %e, "store: skipping an unreadable clock")
                    }
                }
            }
        }
        let before = lock(&self.0.folded).clone();
        let mut changed = 0usize;
        for (id, s) in &stored.scenes {
            if before.scenes.get(id) == Some(s) {
                continue;
            }
            changed += 1;
            let op = match s {
                AdminScene::Put(spec) => Op::ScenePut {
                    scene: id.clone(),
                    spec: spec.clone(),
                    clock: None,
                },
                AdminScene::Deleted => Op::SceneDelete { scene: id.clone() },
            };
            apply_built(state, op, None).await;
        }
        for (id, c) in &stored.clocks {
            if before.clocks.get(id) != Some(c) {
                changed += 1;
                let op = Op::Clock {
                    scene: id.clone(),
                    clock: *c,
                };
                state.apply(&op, Prepared::Nothing);
            }
        }
        for id in before.scenes.keys() {
            if !stored.scenes.contains_key(id) {
                tracing::warn!(scene = %id, "store: Redis no longer has this scene (was its data lost?); keeping this replica's copy");
            }
        }
        changed += resync_impacts(state, &impact_scenes, &lists);
        *lock(&self.0.folded) = stored;
        self.0.applied.send_replace(last);
        tracing::info!(changed, last = %last, "store: re-read the shared admin state");
        Ok(last)
    }

    /// Follows the feed from `last`, applying each entry in order. Returns on a connection
    /// error (the caller reconnects and re-reads).
    async fn follow(
        &self,
        conn: &mut MultiplexedConnection,
        state: &AppState,
        mut last: EntryId,
    ) -> redis::RedisResult<()> {
        let opts = StreamReadOptions::default().block(FEED_BLOCK_MS).count(256);
        loop {
            let reply: Option<StreamReadReply> = conn
                .xread_options(&[&self.0.feed_key], &[last.to_string()], &opts)
                .await?;
            for key in reply.map(|r| r.keys).unwrap_or_default() {
                for entry in key.ids {
                    let Some(id) = EntryId::parse(&entry.id) else {
                        continue;
                    };
                    self.apply_entry(&entry, state).await;
                    last = id;
                    self.0.applied.send_replace(last);
                }
            }
        }
    }

    async fn apply_entry(&self, entry: &StreamId, state: &AppState) {
        let Some(mut op) = entry
            .get::<String>("op")
            .and_then(|s| serde_json::from_str::<Op>(&s).ok())
        else {
            tracing::error!(id = %entry.id, "store: skipping an unreadable feed entry");
            return;
        };
        if let Op::Impact { body_tick, .. } = &mut op {
            // The tick the impact script sequenced in the body log: tick frames announce it.
            *body_tick = entry.get::<i64>("body_tick");
        }
        let nonce: Option<String> = entry.get("nonce");
        let built = match &op {
            Op::ScenePut { .. } => nonce.and_then(|n| lock(&self.0.prebuilt).remove(&n)),
            _ => None,
        };
        apply_built(state, op.clone(), built).await;
        lock(&self.0.folded).apply(&op);
        metrics::counter!("swell_store_feed_applied_total").increment(1);
        tracing::debug!(id = %entry.id, "store: applied a feed entry");
    }
}

/// Applies a feed's op ([`AppState::apply`]), building a put's scene off the reactor unless
/// this replica built it already (`built`: the writer hands its scene over).
async fn apply_built(state: &AppState, op: Op, built: Option<Scene>) {
    let prepared = match (&op, built) {
        (_, Some(scene)) => Prepared::Scene(Box::new(scene)),
        (Op::ScenePut { scene, spec, .. }, None) => {
            let (id, spec) = (scene.clone(), spec.clone());
            match tokio::task::spawn_blocking(move || crate::state::apply::build(&id, &spec)).await
            {
                Ok(Some(scene)) => Prepared::Scene(Box::new(scene)),
                // Logged by `build`: every replica skips it alike.
                _ => return,
            }
        }
        _ => Prepared::Nothing,
    };
    state.apply(&op, prepared);
}

/// Adds to every scene the API impacts Redis holds that this replica lacks (`scenes[i]`'s list
/// is `lists[i]`), each as the feed would have: an [`Op::Impact`] through [`AppState::apply`],
/// oldest first, so its tick frames carry the ones added while it was disconnected. An impact
/// this replica holds and Redis does not (Redis lost data) is kept, as scenes are, and logged.
/// Returns how many scenes changed.
pub fn resync_impacts(state: &AppState, scenes: &[String], lists: &[Vec<String>]) -> usize {
    use swell_waves::particles::{Impact, Impacts};
    let mut stored: HashMap<&str, Vec<Impact>> = HashMap::new();
    for (scene, list) in scenes.iter().zip(lists) {
        let events = list
            .iter()
            .filter_map(|j| match serde_json::from_str::<Impact>(j) {
                Ok(i) if i.validate("").is_ok() => Some(i),
                _ => {
                    tracing::error!(scene, "store: skipping an unreadable impact");
                    None
                }
            })
            .collect();
        stored.insert(scene.as_str(), events);
    }
    let mut changed = 0;
    for entry in state.scenes() {
        let scene = &entry.scene;
        let want = stored.remove(scene.id.as_str()).unwrap_or_default();
        let want = match Impacts::from_events(want) {
            Ok(w) => w,
            Err(e) => {
                tracing::error!(scene = %scene.id, error = %e, "store: impacts over the limit");
                continue;
            }
        };
        let have = scene.impacts.api();
        let fresh = crate::impacts::missing(have.events(), want.events());
        let extra = crate::impacts::missing(want.events(), have.events()).len();
        if extra > 0 {
            tracing::warn!(scene = %scene.id, extra, "store: Redis lacks impacts this replica holds (was its data lost?); keeping them");
        }
        if fresh.is_empty() {
            continue;
        }
        changed += 1;
        for impact in fresh {
            // Caught up, not announced with a tick: GET …/bodies lists the tick the bodies feel
            // it from.
            let op = Op::Impact {
                scene: scene.id.clone(),
                impact,
                body_tick: None,
            };
            state.apply(&op, Prepared::Nothing);
        }
    }
    changed
}

#[cfg(test)]
mod tests {
    use super::EntryId;

    #[test]
    fn entry_ids_order_as_redis_orders_them() {
        let a = EntryId::parse("1700000000000-0").unwrap();
        let b = EntryId::parse("1700000000000-1").unwrap();
        let c = EntryId::parse("1700000000001-0").unwrap();
        assert!(EntryId::default() < a && a < b && b < c);
        // Numeric, not lexicographic: 9-0 < 10-0.
        assert!(EntryId::parse("9-0").unwrap() < EntryId::parse("10-0").unwrap());
        assert_eq!(b.to_string(), "1700000000000-1");
        for bad in ["", "12", "a-1", "1-b", "-1"] {
            assert_eq!(EntryId::parse(bad), None, "{bad:?}");
        }
    }
}
