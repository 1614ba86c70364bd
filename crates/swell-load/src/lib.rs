//! # swell-load
//!
//! A load generator for Swell's HTTP and WebSocket endpoints, and the tool behind every capacity
//! figure in `docs/performance.md`. It talks to a server over the network only.
//!
//! ```text
//! swell-load height --scene open-sea --rate 2000 --duration 10s --ceiling
//! swell-load sample --points 4096 --wire protobuf --concurrency 4
//! swell-load stream --scene calm --spawn-bodies 100 --admin-token $TOKEN --subscribers 1000 --bodies-per-subscriber 10
//! swell-load mixed --rate 4000 --subscribers 50 --json
//! ```
//!
//! # What it measures, and how
//! - **Open loop** (`--rate R`): request `i` is due at `begin + i/R` whatever happened before, and
//!   its latency runs from that due time. A server that stalls shows its queue in the latency
//!   (no coordinated omission). The tool's own lateness in starting requests is reported
//!   separately (`tool lag`), so a saturated load machine is visible as such.
//! - **Closed loop** (`--concurrency C`): C workers each wait for an answer before sending again;
//!   the maximum throughput, latency from send.
//! - Latencies go into HdrHistogram (µs, 3 significant figures): p50/p90/p99/p99.9/max of
//!   answered requests. Failures are tallied by `"<status> <code>"` or transport reason.
//! - **Stream**: each subscriber syncs its clock by ping/pong (shortest of five round trips) and
//!   records, per tick frame, arrival minus the tick's scene time mapped to this machine's clock;
//!   skipped tick numbers are gaps.
//! - **Ceiling** (`--ceiling`): the same shape against `GET /healthz` right after, and the ratio
//!   of answered req/s: a figure that means something on any machine.
//! - Requests are prepared before the run (a seeded ring of variants per kind), so encoding does
//!   not compete with the server for the cores of a shared machine. Request `i` is a pure
//!   function of `(seed, i)`.
//!
//! # Layout
//! - [`cli`] — arguments, validation, [`cli::Options`].
//! - [`workload`] — seeded points and hulls, prepared requests, answer validation.
//! - [`driver`] — the open-loop and closed-loop shapes, over any transport.
//! - [`http`] — the HTTP client and one request's outcome.
//! - [`ws`] — WebSocket connect, the stream's messages, clock sync, the query connection.
//! - [`stream`] — tick-frame subscribers and their delivery statistics.
//! - [`server`] — preflight, `--spawn-bodies`, `/proc` readings of the server process.
//! - [`stats`] — histograms, counters, the request summary.
//! - [`report`] — [`Report`]: JSON and the human summary.
//! - [`run`](mod@run) — one run, start to finish.
//! - [`wire`] — the protobuf types generated from `proto/`, and the two encodings.

pub mod cli;
pub mod driver;
pub mod hostile;
pub mod http;
pub mod report;
pub mod run;
pub mod rx_time;
pub mod server;
pub mod stats;
pub mod stream;
pub mod wire;
pub mod workload;
pub mod ws;

pub use cli::{Args, Options};
pub use report::Report;
pub use run::run;
pub use server::LoadError;
