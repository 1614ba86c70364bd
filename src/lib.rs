//! # swell (the server)
//!
//! An axum + tokio service over the [`swell_waves`] model: scenes (named wave models with a
//! clock and floating bodies), HTTP endpoints that answer height, normal, displacement and
//! body-orientation queries, bit-identical for the same scene, time and point on every replica,
//! and a WebSocket stream of the same queries and of tick frames. No answer carries a NaN or an
//! infinity ([`service::finite`]).
//!
//! ```no_run
//! # async fn run() -> Result<(), Box<dyn std::error::Error>> {
//! let server = swell::Server::bind(swell::Config::default()).await?;
//! println!("listening on {}", server.local_addr());
//! server.run(async { let _ = tokio::signal::ctrl_c().await; }).await?;
//! # Ok(()) }
//! ```
//!
//! # Layout
//! Layers point down; nothing points back up (`tests/server/layers.rs` pins it):
//!
//! ```text
//! lib / main               composition: builds AppState, the router, the loops
//!   api, stream, wire      transports: parse, authorize, call the state, encode
//!   service                transport-free queries
//!   state (AppState)       the registry and its store; applies Ops; the loops that drive it
//!   scene, bodies, impacts, frames, journal, store   domain: plain types and functions
//!   swell-waves            the model
//! ```
//!
//! - [`config`] — [`Config`], limits, the TOML scene file.
//! - [`scene`] — scene specs, built scenes, built-ins, the clock and tick timing, persistence.
//! - [`state`] — [`AppState`]: the registry, the one reducer ([`state::apply`]: every
//!   acknowledged change is a [`journal::Op`], applied by local writes, the journal's replay and
//!   a fleet's feed alike), the store behind one interface ([`state::store`]), the body driver
//!   loop, snapshots, the frame-ahead loop.
//! - [`store`] — a fleet's store: Redis, with a change feed every replica applies and a
//!   sequenced body log per scene.
//! - [`journal`] — durability: every acknowledged change in an fsynced, checksummed log in the
//!   data dir, periodic snapshots, compaction; replayed at start-up ([`state::restore`]).
//! - [`frames`] — the shared, bounded FFT frame cache.
//! - [`bodies`] — server-authoritative floating bodies: a body world per scene, its registry,
//!   and the one way both stores change and step it ([`bodies::drive`]).
//! - [`impacts`] — a scene's impact events.
//! - [`service`] — the transport-free query service: request/response types, time resolution,
//!   the `run_*` queries, JSON decoding, the no-NaN check. HTTP and WebSocket both call it.
//! - [`access`] — roles (`admin`, `game`, `reader`) and the bearer tokens that carry them.
//! - [`api`] — HTTP: routes, middleware, handlers, JSON/protobuf negotiation.
//! - [`stream`] — the WebSocket stream: sessions, message codecs, the per-scene tick loop.
//! - [`wire`] — protobuf types generated from `proto/` and their conversions.
//! - [`peers`] — client addresses (trusted proxies), per-key rate limits, the byte budget of
//!   what clients make the server hold, connections per address.
//! - [`memory`] — handing heap freed after a burst back to the OS (glibc's `malloc_trim`).
//! - [`healthcheck`] — `swell healthcheck`: a tiny HTTP probe for container health checks.
//! - [`error`] — [`ApiError`], the one error type of every endpoint.
//!
//! # Determinism
//! A query's answer depends only on the scene spec, `t` and the point: `t` is taken from the
//! request (or read once from the scene clock and returned), points and times are parsed exactly
//! (serde_json `float_roundtrip`, Rust's correctly rounded `f64` parser for query strings), and
//! numbers are written in shortest round-trip form. A world point is `origin + point` in f64.
//! FFT frames are shared but computed from `(layer, t)` alone, so caching never changes bits.

pub mod access;
pub mod api;
pub mod bodies;
pub mod compute;
pub mod config;
pub mod error;
pub mod frames;
pub mod healthcheck;
pub mod impacts;
pub mod journal;
pub mod lanes;
pub mod memory;
pub mod peers;
pub mod scene;
pub mod service;
pub mod state;
pub mod store;
pub mod stream;
pub mod wire;

use std::future::Future;
use std::net::SocketAddr;
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use metrics_exporter_prometheus::{Matcher, PrometheusBuilder, PrometheusHandle};
use tokio::net::TcpListener;

pub use api::router;
pub use config::{Config, Limits};
pub use error::ApiError;
pub use state::AppState;

/// Why the server could not start.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// Binding the socket or opening the data dir failed.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A limit the server cannot run with, a scene that could not be loaded, or a token that
    /// could not be generated.
    #[error("{0}")]
    Setup(String),
}

/// Histogram buckets, seconds: 50 µs (a cached single-point query) to 10 s (a timed-out batch).
const LATENCY_BUCKETS: &[f64] = &[
    0.00005, 0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0,
    2.5, 10.0,
];

/// Counters of events that may not happen for a long time (limits hit, peers cut off), shown
/// as 0 from the start: an alert on their rate then sees a series, not a gap, and an operator
/// reading `/metrics` sees that the counter exists (docs/api.md lists them).
const ZERO_FROM_START: &[&str] = &[
    "swell_body_impacts_dropped_total",
    "swell_body_impacts_off_map_total",
    "swell_body_reanchors_total",
    "swell_http_body_timeouts_total",
    "swell_http_buffer_budget_refused_total",
    "swell_http_head_timeouts_total",
    "swell_http_peer_connections_refused_total",
    "swell_http_send_stalls_total",
    "swell_http_shed_total",
    "swell_http_slow_lane_connections_total",
    "swell_queries_abandoned_total",
    "swell_tick_body_lag_total",
    "swell_ws_flood_disconnects_total",
    "swell_ws_idle_disconnects_total",
    "swell_ws_protocol_errors_total",
    "swell_ws_rate_limited_total",
    "swell_ws_read_check_disconnects_total",
    "swell_ws_slow_consumer_disconnects_total",
    "swell_ws_tick_handoffs_total",
    "swell_ws_ticks_skipped_total",
    "swell_ws_too_big_disconnects_total",
];

/// The process-wide Prometheus recorder. `metrics` has one global recorder per process, so
/// several servers in one process (tests) share it.
fn metrics_handle() -> PrometheusHandle {
    static HANDLE: OnceLock<PrometheusHandle> = OnceLock::new();
    HANDLE
        .get_or_init(|| {
            let builder = PrometheusBuilder::new()
                .set_buckets_for_metric(Matcher::Suffix("_seconds".into()), LATENCY_BUCKETS)
                .unwrap_or_else(|_| PrometheusBuilder::new());
            let recorder = builder.build_recorder();
            let handle = recorder.handle();
            if metrics::set_global_recorder(recorder).is_err() {
                tracing::warn!("a metrics recorder was already installed; /metrics will be empty");
            }
            for name in ZERO_FROM_START {
                metrics::counter!(*name).increment(0);
            }
            handle
        })
        .clone()
}

/// A bound, loaded server, not yet serving.
#[derive(Debug)]
pub struct Server {
    listener: TcpListener,
    probe_listener: Option<TcpListener>,
    state: AppState,
    snapshots: journal::snapshot::SnapshotPolicy,
    shutdown_timeout: Duration,
    drain_delay: Duration,
    /// A fleet's Redis store: its change feed and body logs are followed while serving.
    shared: Option<(store::Fleet, store::FleetBodies)>,
}

impl Server {
    /// Loads scenes (built-in, configured, persisted) and binds the socket.
    ///
    /// # Errors
    /// A limit the server cannot run with ([`Limits::validate`]), the socket cannot be bound,
    /// the data dir cannot be opened, a configured scene is invalid.
    pub async fn bind(config: Config) -> Result<Server, StartError> {
        config.limits.validate().map_err(StartError::Setup)?;
        let io = |dir: &std::path::Path| {
            let what = format!("opening data dir {}", dir.display());
            move |source| StartError::Io { what, source }
        };
        // With a shared store (Redis) the data dir is not used: admin changes live in Redis.
        let data_dir = if config.store.is_some() {
            None
        } else {
            config.data_dir.as_ref()
        };
        let (journal, recovered, legacy) = match data_dir {
            Some(dir) => {
                let (j, r) = journal::Journal::open(dir).map_err(io(dir))?;
                // The layout before the journal: read (and imported) only if it is there.
                let legacy = if dir.join("scenes").is_dir() || dir.join("clocks").is_dir() {
                    Some(scene::store::Store::open(dir).map_err(io(dir))?)
                } else {
                    None
                };
                (Some(j), Some(r), legacy)
            }
            None => (None, None, None),
        };
        let token = match config.admin_token.clone().filter(|t| !t.is_empty()) {
            Some(t) => t,
            None => api::admin::generate_token()
                .map_err(|e| StartError::Setup(format!("generating an admin token: {e}")))?,
        };
        let access = access::Access::new(
            &token,
            &config.env_tokens,
            config.tokens_file.clone(),
            config.reads_need_token,
        )
        .map_err(|e| StartError::Setup(e.to_string()))?;
        config.limits.peer_policy().map_err(StartError::Setup)?;
        let state = AppState::new(
            config.limits.clone(),
            journal,
            token,
            access,
            metrics_handle(),
        );
        let mut shared = None;
        if let Some(url) = &config.store {
            let fleet = store::Fleet::new(url.clone()).map_err(StartError::Setup)?;
            tracing::info!(store = %url, "admin changes are shared through Redis");
            let bodies = store::FleetBodies::new(fleet.clone(), config.snapshots.interval);
            state.set_store(Arc::new(store::shared::Shared {
                fleet: fleet.clone(),
                bodies: bodies.clone(),
            }));
            shared = Some((fleet, bodies));
        }
        let loading = state.clone();
        let builtin = config.builtin_scenes;
        let scenes = config.scenes.clone();
        tokio::task::spawn_blocking(move || {
            loading.load(builtin, &scenes, recovered, legacy.as_ref())
        })
        .await
        .map_err(|e| StartError::Setup(e.to_string()))?
        .map_err(StartError::Setup)?;
        let listener = TcpListener::bind(config.bind)
            .await
            .map_err(|source| StartError::Io {
                what: format!("binding {}", config.bind),
                source,
            })?;
        let probe_listener = match config.probe_bind {
            Some(addr) => Some(
                TcpListener::bind(addr)
                    .await
                    .map_err(|source| StartError::Io {
                        what: format!("binding the probe listener {addr}"),
                        source,
                    })?,
            ),
            None => None,
        };
        Ok(Server {
            listener,
            probe_listener,
            state,
            snapshots: config.snapshots,
            shutdown_timeout: config.shutdown_timeout,
            drain_delay: config.drain_delay,
            shared,
        })
    }

    /// The bound address (the real port when the config asked for port 0).
    pub fn local_addr(&self) -> SocketAddr {
        // A bound listener always has a local address.
        self.listener
            .local_addr()
            .unwrap_or_else(|_| SocketAddr::from(([0, 0, 0, 0], 0)))
    }

    /// The probe listener's address (`--probe-bind`), if there is one.
    pub fn probe_addr(&self) -> Option<SocketAddr> {
        self.probe_listener
            .as_ref()
            .and_then(|l| l.local_addr().ok())
    }

    /// The admin token in force (configured or generated).
    pub fn admin_token(&self) -> &str {
        self.state.admin_token()
    }

    /// The shared state (for in-process tools and tests).
    pub fn state(&self) -> &AppState {
        &self.state
    }

    /// Serves until `shutdown` completes, then stops accepting, lets in-flight requests finish
    /// and returns. Readiness turns off as soon as shutdown starts, so a load balancer stops
    /// sending new work while the last requests drain.
    ///
    /// Shutdown, in order: the signal fires the one shutdown token ([`AppState`]'s `shutdown`),
    /// which every loop and session watches (WebSocket sessions send Close 1001); axum drains
    /// in-flight HTTP requests; every tracked task ([`AppState`]'s `tasks`) is awaited, up to
    /// the configured deadline; then the final journal snapshot is written.
    ///
    /// # Errors
    /// The accept loop failed.
    pub async fn run(
        self,
        shutdown: impl Future<Output = ()> + Send + 'static,
    ) -> std::io::Result<()> {
        let state = self.state.clone();
        let app = router(self.state.clone());
        // The Prometheus handle keeps histogram windows bounded only if upkeep runs. Heap freed
        // after a burst goes back to the OS on the same beat (off the reactor: a trim takes the
        // allocator's locks).
        let upkeep_handle = self.state.metrics.clone();
        let upkeep_stop = state.shutdown.clone();
        let upkeep_state = state.clone();
        state.tasks.spawn(async move {
            let mut tick = tokio::time::interval(Duration::from_secs(5));
            loop {
                tokio::select! {
                    () = upkeep_stop.cancelled() => return,
                    _ = tick.tick() => {
                        upkeep_handle.run_upkeep();
                        // Rotated tokens take effect within one beat.
                        upkeep_state.access.reload_if_changed();
                        let _ = tokio::task::spawn_blocking(|| {
                            memory::release_if_held(memory::TRIM_ABOVE)
                        })
                        .await;
                    }
                }
            }
        });
        // FFT frames the scene clocks are about to reach, computed before queries ask; stops on
        // the shutdown token.
        state
            .tasks
            .spawn(crate::state::ahead::run_ahead(state.clone()));
        // Bodies restored from the data dir resume stepping.
        state::bodies::start_all(&state);
        // Snapshots bound the log and the replay after a crash; they stop with the shutdown
        // signal, before the final snapshot below.
        if let Some(j) = state.journal().cloned() {
            state.tasks.spawn(state::snapshots::run(
                state.clone(),
                j,
                self.snapshots,
                state.shutdown.clone(),
            ));
        }
        match self.shared.clone() {
            Some((fleet, fb)) => {
                // The change feed; ready once the first full read of the shared store is
                // applied (until then this replica could serve scenes the fleet has replaced).
                state
                    .tasks
                    .spawn(fleet.clone().run(state.clone(), state.shutdown.clone()));
                // Body logs: follow every scene that has one (found again every second, so a
                // scene whose first body was spawned through another replica is picked up).
                let (st, stop) = (state.clone(), state.shutdown.clone());
                state.tasks.spawn(async move {
                    let mut every = tokio::time::interval(Duration::from_secs(1));
                    loop {
                        tokio::select! {
                            () = stop.cancelled() => return,
                            _ = every.tick() => fb.discover(&st).await,
                        }
                    }
                });
                let readying = state.clone();
                state.tasks.spawn(async move {
                    tokio::select! {
                        () = readying.shutdown.cancelled() => {}
                        () = fleet.wait_synced() => readying.set_ready(true),
                    }
                });
            }
            None => state.set_ready(true),
        }
        let addr = self.local_addr();
        tracing::info!(%addr, scenes = state.scenes().len(), "serving");
        let compute = compute::configure(compute::Settings::from_limits(&state.limits));
        tracing::info!(
            threads = compute.threads,
            nice = compute.nice,
            "compute pool (compute_threads, compute_nice)"
        );
        // Probes and metrics on their own port: outside every limit clients can fill, and off
        // the public path. Stops with the shutdown token.
        if let Some(probe) = self.probe_listener {
            let app = api::probe_router(state.clone());
            let stop = state.shutdown.clone();
            tracing::info!(addr = ?probe.local_addr().ok(), "serving probes");
            state.tasks.spawn(async move {
                let served = axum::serve(probe, app)
                    .with_graceful_shutdown(async move { stop.cancelled().await })
                    .await;
                if let Err(e) = served {
                    tracing::error!(error = %e, "the probe listener failed");
                }
            });
        }
        let draining = state.clone();
        // TCP_NODELAY (stream frames and small answers go out at once instead of waiting for
        // more bytes to batch), a cap on open connections and an idle timeout.
        let limits = api::serve::ConnectionLimits {
            max_connections: state.limits.max_connections,
            idle_timeout: state.limits.idle_timeout(),
            head_timeout: state.limits.head_timeout(),
            per_peer: state.limits.max_connections_per_peer,
            send_stall: state.limits.http_send_stall(),
            policy: state.peer_policy.clone(),
            slow_lane: Arc::clone(&state.slow_lane),
            parser_max_headers: (4 * state.limits.max_headers).max(100),
            drain_deadline: self.shutdown_timeout,
        };
        let drain_delay = self.drain_delay;
        let stopping_at = Arc::new(std::sync::OnceLock::new());
        let stopping = Arc::clone(&stopping_at);
        let result = api::serve::serve(self.listener, app, limits, async move {
            shutdown.await;
            draining.set_ready(false);
            if !drain_delay.is_zero() {
                // Still serving (the probe port too), with /readyz at 503.
                tracing::info!(
                    delay_s = drain_delay.as_secs_f64(),
                    "shutting down: not ready, serving on while load balancers notice"
                );
                tokio::time::sleep(drain_delay).await;
            }
            let _ = stopping.set(tokio::time::Instant::now());
            // WebSocket sessions send Close and end; tick loops stop.
            draining.shutdown.cancel();
            tracing::info!("shutting down: draining in-flight requests");
        })
        .await;
        // (Already fired unless serving failed.)
        state.shutdown.cancel();
        state.tasks.close();
        // One deadline for the whole drain: connections (above) and tasks share it.
        let left = stopping_at.get().map_or(self.shutdown_timeout, |at| {
            self.shutdown_timeout.saturating_sub(at.elapsed())
        });
        if tokio::time::timeout(left, state.tasks.wait())
            .await
            .is_err()
        {
            tracing::warn!(
                left = state.tasks.len(),
                deadline_s = self.shutdown_timeout.as_secs_f64(),
                "shutdown deadline passed with tasks still running; writing the final snapshot anyway"
            );
        }
        // Stop the body loops and write a final snapshot (the next start replays nothing).
        let saving = state.clone();
        if let Err(e) = tokio::task::spawn_blocking(move || saving.write_final_snapshot()).await {
            tracing::error!(error = %e, "saving bodies panicked");
        }
        tracing::info!("stopped");
        result
    }
}

/// Binds with `config` and serves until `shutdown` completes.
///
/// # Errors
/// As [`Server::bind`] and [`Server::run`].
pub async fn serve(
    config: Config,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), StartError> {
    let server = Server::bind(config).await?;
    server.run(shutdown).await.map_err(|source| StartError::Io {
        what: "serving".into(),
        source,
    })
}

/// Completes on SIGINT (Ctrl-C) or, on Unix, SIGTERM: the shutdown signal of `swell serve`.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        if tokio::signal::ctrl_c().await.is_err() {
            // No signal handler: never complete from this branch.
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => tracing::info!("SIGINT received"),
        () = term => tracing::info!("SIGTERM received"),
    }
}
