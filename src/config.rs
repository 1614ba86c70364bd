//! Server configuration: where to listen, where to persist, the admin token, the limits, and the
//! scenes of an optional TOML file.
//!
//! The TOML file holds scenes and limits:
//!
//! ```toml
//! [limits]
//! max_points = 65536
//!
//! [scenes.harbour]
//! description = "Sheltered harbour"
//! tick_hz = 30
//! seed = 7
//! layers = [{ kind = "sine", waves = [{ amplitude = 0.1, wavelength = 8, direction = [1, 0] }] }]
//! ```
//!
//! Each `[scenes.<id>]` table is a scene spec exactly as `PUT /v1/scenes/{id}` takes it.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::Deserialize;
use swell_waves::particles::ripple::MAX_IMPACT_TIME;

use crate::scene::SceneSpec;

/// Everything [`crate::Server::bind`] needs.
#[derive(Debug, Clone)]
pub struct Config {
    /// Address to listen on; port 0 picks a free one (tests).
    pub bind: SocketAddr,
    /// Directory of persisted scenes and clocks; `None` keeps everything in memory.
    pub data_dir: Option<PathBuf>,
    /// A shared store (Redis) for a fleet of replicas; when set, admin changes live there and
    /// `data_dir` is not used (see [`crate::store`]).
    pub store: Option<crate::store::url::StoreUrl>,
    /// Bearer token for admin endpoints; `None` generates one at start (see
    /// [`crate::Server::admin_token`]).
    pub admin_token: Option<String>,
    /// Tokens file (`role token` lines; see [`crate::access`]), read again when it changes.
    pub tokens_file: Option<PathBuf>,
    /// Tokens from the environment: role → comma-separated tokens.
    pub env_tokens: Vec<(crate::access::Role, String)>,
    /// Whether queries and streams need a `reader` (or higher) token.
    pub reads_need_token: bool,
    /// A second listener for `/healthz`, `/readyz` and `/metrics` only, outside every client
    /// limit (for Kubernetes probes and Prometheus on a port clients cannot reach).
    pub probe_bind: Option<SocketAddr>,
    /// Whether to start with the built-in scenes (`calm`, `lake`, `open-sea`, `storm`).
    pub builtin_scenes: bool,
    /// Scenes from the config file, sorted by id (ids validated at load).
    pub scenes: Vec<(String, SceneSpec)>,
    /// Request limits.
    pub limits: Limits,
    /// When the journal takes snapshots (with a data dir).
    pub snapshots: SnapshotPolicy,
    /// Longest the server waits at shutdown for its tasks (WebSocket sessions flushing their
    /// Close, loops finishing a step) before it writes the final snapshot anyway. 10 s: well
    /// inside Kubernetes' default 30 s grace period, with room for in-flight requests first.
    pub shutdown_timeout: Duration,
    /// How long, after the shutdown signal, the server keeps serving with `/readyz` at 503
    /// before it stops accepting: time for a load balancer to see the 503 (or for Kubernetes
    /// to take the pod out of its endpoints) so no client is sent to a closed port. 0 here (in
    /// process, tests); the `swell` binary's `--drain-delay` defaults to 2 s.
    pub drain_delay: Duration,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            bind: SocketAddr::from(([127, 0, 0, 1], 8080)),
            data_dir: None,
            store: None,
            admin_token: None,
            tokens_file: None,
            env_tokens: Vec::new(),
            reads_need_token: false,
            probe_bind: None,
            builtin_scenes: true,
            scenes: Vec::new(),
            limits: Limits::default(),
            snapshots: Default::default(),
            shutdown_timeout: Duration::from_secs(10),
            drain_delay: Duration::ZERO,
        }
    }
}

/// Request limits. Every limit answers with a 4xx/5xx naming it, never with a stall.
#[derive(Debug, Clone, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Limits {
    /// Most points in one sample request (and probes over all bodies of one orientation
    /// request); beyond it: 413. 65,536 points cost about 10–50 ms of CPU.
    pub max_points: usize,
    /// Most bodies in one orientation request.
    pub max_bodies: usize,
    /// Most floating bodies a scene may simulate; beyond it a spawn gets 409. 1,000 bodies
    /// at 30 Hz take a fraction of a core (docs/bodies.md).
    pub max_scene_bodies: usize,
    /// Largest request body, bytes; beyond it: 413. 8 MiB holds 65,536 points written with
    /// full f64 precision (about 45 bytes each) with room to spare.
    pub max_body_bytes: usize,
    /// Longest request URI (path and query), bytes; beyond it: 414 `uri_too_long`.
    pub max_uri_bytes: usize,
    /// Most bytes of request headers (names, values and separators); beyond it: 431
    /// `headers_too_large`.
    pub max_header_bytes: usize,
    /// Most request headers; beyond it: 431 `headers_too_large`. The HTTP parser itself stops
    /// at 4× this (at least 100) and past 400 KiB of head, answering a bare 431/414.
    pub max_headers: usize,
    /// Requests served at once; more are shed with 503 rather than queued without bound.
    pub max_in_flight: usize,
    /// Longest a request may take, ms; then 503.
    pub request_timeout_ms: u64,
    /// FFT frames kept in the shared cache for times away from a scene clock's now (far-off
    /// grid frames and exact times; see [`crate::frames`]): the frames around now are kept
    /// apart and never evicted by these. A 256² frame with every field is 4 MiB.
    pub frame_cache_entries: usize,
    /// Largest |x|, |z| of a world point, m. At most 1e12 m ([`MAX_COORDINATE_BOUND`]: beyond
    /// it phases lose all precision); a larger one is refused at start ([`Limits::validate`]).
    pub max_coordinate: f64,
    /// Largest |t|, s, for the same reason. At most 1e12 s
    /// ([`swell_waves::particles::ripple::MAX_IMPACT_TIME`], the model's bound on an impact's
    /// time), so that a clock never runs to a time where no impact can be placed; a larger one
    /// is refused at start ([`Limits::validate`]).
    pub max_time: f64,
    /// Largest WebSocket message (and frame) a client may send, bytes; beyond it the socket is
    /// closed (1009). 1 MiB holds a 20,000-point sample request; tungstenite's 64 MiB default
    /// would let one client make the server buffer 64 MiB.
    pub ws_max_message_bytes: usize,
    /// Messages queued for one WebSocket client; when full the client is not reading and is
    /// disconnected. 256 is about 8 s of 30 Hz ticks, far more than a healthy client lags.
    pub ws_send_queue: usize,
    /// Longest one WebSocket message may take to be written to the client's socket, ms; then
    /// the client is not reading and is disconnected (a 10 MB answer to a client on a 1 MB/s
    /// link needs 10 s of it). Tick frames are sent as they come (a writer
    /// behind the tick stream skips to the newest frames), so this is what ends a subscriber
    /// that stopped reading without sending anything.
    pub ws_send_stall_ms: u64,
    /// HTTP connections (WebSocket sessions included) open at once; at the limit new ones wait
    /// in the kernel's listen backlog until one closes. Each open connection holds ~15 KiB;
    /// keep it below the process's open-file limit (`ulimit -n`).
    pub max_connections: usize,
    /// Longest a connection may wait for a request's headers, ms, from when it opens or its last
    /// answer was written: an idle keep-alive connection is closed after it (and so is a client
    /// that trickles its headers). Upgraded WebSockets are not subject to it. 0: no limit.
    pub idle_timeout_ms: u64,
    /// Longest a request's head (request line and headers) may take from its first byte, ms:
    /// 408 `request_timeout`, and the connection closes. 0: no limit (the idle timeout still
    /// applies).
    pub head_timeout_ms: u64,
    /// Longest downtime, s of scene time, that a restarted server steps its bodies through
    /// before it is ready, so that they continue the trajectory of a server that never stopped
    /// (one boat on an FFT scene: ~4.5 ms a tick). After a longer one the bodies re-anchor at the
    /// clock instead: they keep their poses, start from rest, and the server is ready at once.
    /// Capped at the replay limit of 108,000 ticks (an hour at 30 Hz). 0: no catch-up at
    /// start-up (a gap of up to 60 ticks the body loop still steps through, as after any stall).
    pub catch_up_max_s: u64,
    /// Connections open at once from one client address; beyond it a new one is answered 429
    /// and closed. Keeps one peer from taking every `max_connections` slot. Peers in
    /// `exempt_peers` are not counted.
    pub max_connections_per_peer: usize,
    /// Longest a request body may take to arrive, ms, from when the handler's turn comes; then
    /// 408 and the connection is closed.
    pub body_timeout_ms: u64,
    /// Slowest a request body may arrive after a 2 s grace, bytes/s (or the whole body, if it is
    /// smaller); slower: 408. Stops clients that trickle a body to hold a request open. 0: off.
    pub body_min_bytes_per_s: u64,
    /// Bytes the server holds for clients at once: request bodies being read and answers not yet
    /// written. A request that would exceed it gets 503 `overloaded`. 256 MiB.
    pub max_buffered_bytes: usize,
    /// The same, per client address: 24 MiB holds an 8 MiB body and a 65,536-point answer
    /// (~11 MB) at once.
    pub max_buffered_bytes_per_peer: usize,
    /// Longest an HTTP answer may wait for the client to read it, ms: a connection whose writes
    /// make no progress for this long is closed (`swell_http_send_stalls_total`). 0: no limit.
    pub http_send_stall_ms: u64,
    /// Requests a second per client address, on average (0: no limit); beyond it: 429 with
    /// `Retry-After`. Probes are not counted.
    pub peer_requests_per_s: f64,
    /// Burst allowed per client address above the average rate, requests.
    pub peer_requests_burst: f64,
    /// Requests a second per token (0: no limit), so one leaked game token cannot flood the
    /// server from many addresses.
    pub token_requests_per_s: f64,
    /// Burst allowed per token, requests.
    pub token_requests_burst: f64,
    /// WebSocket messages a second one socket may send, on average (0: no limit); beyond it an
    /// `rate_limited` error frame answers each message, and a socket that keeps going past twice
    /// the burst is closed (1008).
    pub ws_messages_per_s: f64,
    /// Burst of WebSocket messages allowed above the average rate.
    pub ws_messages_burst: f64,
    /// A WebSocket that sends nothing for this long, ms, is pinged at half of it and closed
    /// (1001) at the end. 0: never.
    pub ws_idle_timeout_ms: u64,
    /// How far behind a WebSocket client may fall in reading what it is sent, ms. Every session
    /// is pinged at half of this with a payload the client cannot guess; a client whose pong has
    /// not come back this long after the ping was queued is not reading (or is this far behind)
    /// and is closed (1008), as for `ws_send_stall_ms`. The kernel's socket buffers on the way
    /// hold megabytes, so without this a client that stops reading a slow stream is noticed only
    /// once they fill, minutes later. Every WebSocket client library answers pings as it reads.
    /// 0: never.
    pub ws_read_check_ms: u64,
    /// Proxies (`addr/prefix`) whose `X-Forwarded-For` names the client. Default: loopback, where
    /// the shipped nginx runs. Clear it when the server faces clients directly on loopback.
    pub trusted_proxies: Vec<String>,
    /// Clients (`addr/prefix`) that the per-peer limits (connections, rate, bytes) do not
    /// apply to. Default: loopback, so load tests and sidecars on the same host are not
    /// throttled; a client behind a trusted proxy is judged by its forwarded address.
    pub exempt_peers: Vec<String>,
    /// Scenes the server holds at most; a put of a new id beyond it gets 409 `too_many_scenes`.
    /// 1,024: far more than a game server runs, few enough that their specs and clocks stay
    /// small.
    pub max_scenes: usize,
    /// FFT frame memory all scenes may hold, bytes: each scene is charged the near frames of
    /// its FFT layers (every field; 52 MiB for a 256² layer, 832 MiB for 1024²) when it is put,
    /// and a put beyond the budget gets 422 `fft_budget`. 2 GiB.
    pub max_fft_bytes: u64,
    /// Whether `/metrics` on the main listener is public; when false it needs an admin token.
    /// Either way it is also served on `--probe-bind`, if set.
    pub metrics_public: bool,
    /// Threads of the compute pool, which runs batch queries and decodes and encodes large
    /// bodies off the reactor ([`crate::compute`]); 0: one per core. Work beyond them waits its
    /// turn (`swell_compute_queued`).
    pub compute_threads: usize,
    /// How many steps of niceness (0–19) below the server's own priority the compute pool runs,
    /// so that cheap requests, probes and stream ticks get the cores first when batch work
    /// saturates them. 0: the same priority. One setting per process: the first server started
    /// in a process sets the pool up.
    pub compute_nice: i32,
    /// How long an address that broke a per-peer limit (a 429 for its request rate, a 408, a
    /// connection over `max_connections_per_peer`, an answer it did not read, a WebSocket
    /// closed 1008) has its new connections served on the slow lane, ms: threads that run only
    /// on CPU time nobody else wants ([`crate::lanes`]). Keyed by the TCP peer; exempt peers
    /// and trusted proxies are never demoted. 0: no slow lane.
    pub slow_lane_ms: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_points: 65_536,
            max_bodies: 1024,
            max_scene_bodies: 1000,
            max_body_bytes: 8 * 1024 * 1024,
            max_uri_bytes: 8 * 1024,
            max_header_bytes: 32 * 1024,
            max_headers: 64,
            max_in_flight: 512,
            request_timeout_ms: 30_000,
            frame_cache_entries: 32,
            max_coordinate: 1e9,
            max_time: 1e10,
            ws_max_message_bytes: 1024 * 1024,
            ws_send_queue: 256,
            ws_send_stall_ms: 10_000,
            max_connections: 10_000,
            idle_timeout_ms: 60_000,
            head_timeout_ms: 10_000,
            catch_up_max_s: 3600,
            max_connections_per_peer: 256,
            body_timeout_ms: 15_000,
            body_min_bytes_per_s: 4096,
            max_buffered_bytes: 256 * 1024 * 1024,
            max_buffered_bytes_per_peer: 24 * 1024 * 1024,
            http_send_stall_ms: 10_000,
            peer_requests_per_s: 500.0,
            peer_requests_burst: 1000.0,
            token_requests_per_s: 5000.0,
            token_requests_burst: 10_000.0,
            ws_messages_per_s: 100.0,
            ws_messages_burst: 200.0,
            ws_idle_timeout_ms: 60_000,
            ws_read_check_ms: 30_000,
            trusted_proxies: vec!["127.0.0.0/8".into(), "::1".into()],
            exempt_peers: vec!["127.0.0.0/8".into(), "::1".into()],
            metrics_public: true,
            max_scenes: 1024,
            max_fft_bytes: 2 << 30,
            compute_threads: 0,
            compute_nice: 10,
            slow_lane_ms: 30_000,
        }
    }
}

/// When snapshots are taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnapshotPolicy {
    /// A snapshot at least this often while anything was journaled. Bounds the replay after a
    /// crash to this much wall time of changes (body steps between changes are replayed too:
    /// an idle scene with bodies replays at most this long a stretch of its trajectory).
    pub interval: Duration,
    /// A snapshot as soon as this many records were journaled since the last: bounds the log.
    pub max_records: usize,
}

impl Default for SnapshotPolicy {
    /// Every 30 s or 10,000 records: a replay of at most ~900 ticks per scene at 30 Hz (well
    /// under a second for 100 bodies) and a log of a few MiB at most.
    fn default() -> Self {
        SnapshotPolicy {
            interval: Duration::from_secs(30),
            max_records: 10_000,
        }
    }
}

/// A time from a client that is not finite or is beyond [`Limits::max_time`]
/// ([`Limits::check_time`]). The `Display` text is the whole message for people.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field} = {} is out of range: a finite time with |t| <= {max}", swell_waves::error::Num(*t))]
pub struct TimeOutOfRange {
    /// Path of the offending field (`t`, `impacts[0].t`).
    pub field: String,
    /// The time as given, s.
    pub t: f64,
    /// The largest |t| allowed, s ([`Limits::max_time`]).
    pub max: f64,
}

/// The largest [`Limits::max_coordinate`], m. From 2³⁹ m (5.5·10¹¹) to 2⁴⁰ m neighbouring f64
/// positions are 2⁻¹³ m (0.12 mm) apart, an eighth of the model's shortest wavelength
/// ([`swell_waves::wave::MIN_WAVELENGTH`], 1 mm): a step of one ulp moves such a wave's phase by
/// 0.77 rad, so past 1e12 m the shortest waves are noise, and at 2⁴⁰ m the spacing doubles.
pub const MAX_COORDINATE_BOUND: f64 = 1e12;

impl Limits {
    /// Checks the limits a server cannot run with; the config file's and
    /// [`crate::Server::bind`]'s check.
    ///
    /// # Errors
    /// A message naming the limit: `compute_nice` outside 0..=19; `max_time` not in
    /// (0, 1e12] s ([`MAX_IMPACT_TIME`]: with a larger one a clock could run to times where no
    /// impact can be placed, while the impact body's schema states the smaller bound);
    /// `max_coordinate` not in (0, 1e12] m ([`MAX_COORDINATE_BOUND`]: beyond it positions are
    /// too coarse for the model's shortest waves).
    pub fn validate(&self) -> Result<(), String> {
        if !(0..=19).contains(&self.compute_nice) {
            return Err(format!(
                "limits.compute_nice = {}: niceness steps run from 0 (the server's own priority) to 19",
                self.compute_nice
            ));
        }
        if !(self.max_time > 0.0 && self.max_time <= MAX_IMPACT_TIME) {
            return Err(format!(
                "limits.max_time = {} s is out of range: in (0, {MAX_IMPACT_TIME:e}] s, the \
                 model's bound on an impact's time (a clock past it could place no impact)",
                swell_waves::error::Num(self.max_time)
            ));
        }
        if !(self.max_coordinate > 0.0 && self.max_coordinate <= MAX_COORDINATE_BOUND) {
            return Err(format!(
                "limits.max_coordinate = {} m is out of range: in (0, {MAX_COORDINATE_BOUND:e}] m \
                 (beyond it f64 positions are too coarse for the model's shortest waves, 1 mm)",
                swell_waves::error::Num(self.max_coordinate)
            ));
        }
        Ok(())
    }

    /// Checks a time given by a client.
    ///
    /// # Errors
    /// [`TimeOutOfRange`] naming `field` if `t` is not finite or beyond [`Limits::max_time`].
    pub fn check_time(&self, t: f64, field: &str) -> Result<f64, TimeOutOfRange> {
        if t.is_finite() && t.abs() <= self.max_time {
            Ok(t)
        } else {
            Err(TimeOutOfRange {
                field: field.to_owned(),
                t,
                max: self.max_time,
            })
        }
    }

    /// The request timeout as a duration.
    pub fn request_timeout(&self) -> Duration {
        Duration::from_millis(self.request_timeout_ms)
    }

    /// [`Limits::idle_timeout_ms`] as a duration; `None` when it is 0 (no limit).
    pub fn idle_timeout(&self) -> Option<Duration> {
        (self.idle_timeout_ms > 0).then(|| Duration::from_millis(self.idle_timeout_ms))
    }

    /// [`Limits::head_timeout_ms`] as a duration; `None` when it is 0 (no limit).
    pub fn head_timeout(&self) -> Option<Duration> {
        (self.head_timeout_ms > 0).then(|| Duration::from_millis(self.head_timeout_ms))
    }

    /// [`Limits::body_timeout_ms`] as a duration.
    pub fn body_timeout(&self) -> Duration {
        Duration::from_millis(self.body_timeout_ms)
    }

    /// [`Limits::http_send_stall_ms`] as a duration; `None` when it is 0.
    pub fn http_send_stall(&self) -> Option<Duration> {
        (self.http_send_stall_ms > 0).then(|| Duration::from_millis(self.http_send_stall_ms))
    }

    /// [`Limits::ws_idle_timeout_ms`] as a duration; `None` when it is 0.
    pub fn ws_idle_timeout(&self) -> Option<Duration> {
        (self.ws_idle_timeout_ms > 0).then(|| Duration::from_millis(self.ws_idle_timeout_ms))
    }

    /// [`Limits::ws_read_check_ms`] as a duration; `None` when it is 0.
    pub fn ws_read_check(&self) -> Option<Duration> {
        (self.ws_read_check_ms > 0).then(|| Duration::from_millis(self.ws_read_check_ms))
    }

    /// The trusted proxies and exempt peers, parsed.
    ///
    /// # Errors
    /// An entry that is not `addr[/prefix]`, named.
    pub fn peer_policy(&self) -> Result<crate::peers::PeerPolicy, String> {
        use crate::peers::{Nets, PeerPolicy};
        Ok(PeerPolicy {
            trusted_proxies: Nets::parse(&self.trusted_proxies)
                .map_err(|e| format!("limits.trusted_proxies: {e}"))?,
            exempt: Nets::parse(&self.exempt_peers)
                .map_err(|e| format!("limits.exempt_peers: {e}"))?,
        })
    }

    /// [`Limits::ws_send_stall_ms`] as a duration.
    pub fn ws_send_stall(&self) -> Duration {
        Duration::from_millis(self.ws_send_stall_ms)
    }
}

/// The TOML config file's shape.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileConfig {
    #[serde(default)]
    limits: Option<Limits>,
    #[serde(default)]
    scenes: toml::Table,
}

/// Why a config file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not valid TOML of the expected shape.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// What a config file holds.
#[derive(Debug, Clone, Default)]
pub struct FileContents {
    /// Scenes, sorted by id.
    pub scenes: Vec<(String, SceneSpec)>,
    /// Limits, if the file sets them.
    pub limits: Option<Limits>,
}

/// Reads a TOML config file: its scenes (validated as specs, not yet built) and limits.
///
/// # Errors
/// The file cannot be read, is not TOML, has unknown keys, a bad scene id, or a scene spec that
/// does not parse.
pub fn load_file(path: &Path) -> Result<FileContents, ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
        path: path.to_owned(),
        source,
    })?;
    parse_toml(&text).map_err(|message| ConfigError::Parse {
        path: path.to_owned(),
        message,
    })
}

/// Parses config TOML text (see [`load_file`]).
///
/// # Errors
/// A message naming the scene and field that is wrong.
pub fn parse_toml(text: &str) -> Result<FileContents, String> {
    let file: FileConfig = toml::from_str(text).map_err(|e| e.to_string())?;
    let mut scenes = Vec::new();
    for (id, value) in file.scenes {
        crate::scene::validate_id(&id).map_err(|e| format!("scenes.{id}: {e}"))?;
        // Through serde_json::Value so the TOML and the HTTP body share one parser (and its
        // unknown-field checks).
        let json = serde_json::to_value(&value).map_err(|e| format!("scenes.{id}: {e}"))?;
        let spec = SceneSpec::from_value(json).map_err(|e| {
            let field = e.field().map(|f| format!(".{f}")).unwrap_or_default();
            format!("scenes.{id}{field}: {e}")
        })?;
        scenes.push((id, spec));
    }
    if let Some(l) = &file.limits {
        l.validate()?;
    }
    Ok(FileContents {
        scenes,
        limits: file.limits,
    })
}
