//! A run's result: one serialisable [`Report`] (`--json`) with a human summary (`Display`).

use std::fmt;

use serde::Serialize;

use crate::cli::{Options, Shape};
use crate::server::ServerProcess;
use crate::stats::{Latency, RequestSummary};
use crate::stream::StreamSummary;

/// The scene as the run found it.
#[derive(Debug, Clone, Serialize)]
pub struct SceneSummary {
    /// Tick frames per second of scene time.
    pub tick_hz: f64,
    /// Clock rate.
    pub rate: f64,
    /// Floating bodies (after `--spawn-bodies`).
    pub bodies: usize,
}

/// The same load shape against `GET /healthz`.
#[derive(Debug, Clone, Serialize)]
pub struct Ceiling {
    /// The `/healthz` run.
    pub healthz: RequestSummary,
    /// Answered req/s of the run over answered req/s of `/healthz`.
    pub ratio: f64,
}

/// Everything a run measured.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// `swell-load`.
    pub tool: &'static str,
    /// The tool's version.
    pub version: &'static str,
    /// The run's options.
    pub options: Options,
    /// The scene.
    pub scene: SceneSummary,
    /// Seconds recorded (the duration, or less when interrupted).
    pub measured_s: f64,
    /// Stopped early by Ctrl-C.
    pub interrupted: bool,
    /// Requests (HTTP or WebSocket queries), if the mode sends any.
    pub requests: Option<RequestSummary>,
    /// Tick frames, if the run had subscribers.
    pub stream: Option<StreamSummary>,
    /// The `/healthz` comparison, with `--ceiling`.
    pub ceiling: Option<Ceiling>,
    /// The server process, with `--server-pid`.
    pub server: Option<ServerProcess>,
    /// The load tool's own CPU over the window, cores (Linux; `None` elsewhere).
    pub tool_cpu_cores: Option<f64>,
}

impl Report {
    /// Whether anything failed: a request error, a missed tick, a lost subscriber.
    pub fn has_failures(&self) -> bool {
        self.requests.as_ref().is_some_and(|r| r.errors > 0)
            || self.ceiling.as_ref().is_some_and(|c| c.healthz.errors > 0)
            || self
                .stream
                .as_ref()
                .is_some_and(|s| s.gaps > 0 || s.out_of_order > 0 || !s.disconnects.is_empty())
    }
}

fn ms(v: f64) -> String {
    if v >= 100.0 {
        format!("{v:.0} ms")
    } else if v >= 1.0 {
        format!("{v:.2} ms")
    } else {
        format!("{:.0} µs", v * 1000.0)
    }
}

fn lat(l: &Latency) -> String {
    format!(
        "p50 {}  p90 {}  p99 {}  p99.9 {}  max {}",
        ms(l.p50_ms),
        ms(l.p90_ms),
        ms(l.p99_ms),
        ms(l.p999_ms),
        ms(l.max_ms)
    )
}

fn bytes(b: f64) -> String {
    if b >= 1e9 {
        format!("{:.2} GB", b / 1e9)
    } else if b >= 1e6 {
        format!("{:.2} MB", b / 1e6)
    } else if b >= 1e3 {
        format!("{:.1} kB", b / 1e3)
    } else {
        format!("{b:.0} B")
    }
}

fn requests(f: &mut fmt::Formatter<'_>, r: &RequestSummary, secs: f64) -> fmt::Result {
    writeln!(
        f,
        "  requests  {} ok, {} failed  ·  {:.1} req/s  ·  {:.0} points/s",
        r.ok, r.errors, r.req_per_s, r.points_per_s
    )?;
    writeln!(f, "  latency   {}", lat(&r.latency))?;
    if let Some(l) = &r.start_lag {
        writeln!(
            f,
            "  tool lag  p50 {}  p99 {}  max {}  (due time to send; part of the latency above)",
            ms(l.p50_ms),
            ms(l.p99_ms),
            ms(l.max_ms)
        )?;
    }
    writeln!(
        f,
        "  bytes     sent {} ({}/s), received {} ({}/s)",
        bytes(r.bytes_sent as f64),
        bytes(r.bytes_sent as f64 / secs),
        bytes(r.bytes_received as f64),
        bytes(r.bytes_received as f64 / secs)
    )?;
    for k in &r.by_query {
        writeln!(
            f,
            "  {:<11} {} ok, {} failed, {:.1} req/s, p50 {} p99 {}",
            k.query.name(),
            k.ok,
            k.errors,
            k.req_per_s,
            ms(k.latency.p50_ms),
            ms(k.latency.p99_ms)
        )?;
    }
    for e in &r.errors_by_kind {
        writeln!(
            f,
            "  error     {} × {}  (first: {})",
            e.count, e.label, e.first
        )?;
    }
    Ok(())
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let o = &self.options;
        let shape = match o.shape {
            _ if o.mode == crate::cli::Mode::Stream => "tick stream".to_string(),
            Shape::OpenLoop {
                rate,
                max_in_flight,
            } => format!("open loop {rate} req/s (≤ {max_in_flight} in flight)"),
            Shape::ClosedLoop { concurrency } => format!("closed loop, {concurrency} workers"),
        };
        let wire = match o.wire {
            crate::wire::Wire::Json => "json",
            crate::wire::Wire::Protobuf => "protobuf",
        };
        let mode = serde_json::to_value(o.mode).ok();
        let mode = mode.as_ref().and_then(|m| m.as_str()).unwrap_or("?");
        writeln!(
            f,
            "swell-load {mode} · {} scene {} · {wire} · {shape}",
            o.url, o.scene
        )?;
        writeln!(
            f,
            "  measured  {:.1} s after {:.1} s warm-up{}",
            self.measured_s,
            o.warmup.as_secs_f64(),
            if self.interrupted {
                " (interrupted: figures so far)"
            } else {
                ""
            }
        )?;
        let secs = self.measured_s.max(1e-9);
        if let Some(r) = &self.requests {
            requests(f, r, secs)?;
        }
        if let Some(c) = &self.ceiling {
            writeln!(
                f,
                "  ceiling   GET /healthz, same shape: {:.1} req/s, {}  →  ratio {:.3}×",
                c.healthz.req_per_s,
                lat(&c.healthz.latency),
                c.ratio
            )?;
            if c.healthz.errors > 0 {
                writeln!(
                    f,
                    "  ceiling   {} /healthz requests failed",
                    c.healthz.errors
                )?;
            }
        }
        if let Some(s) = &self.stream {
            writeln!(
                f,
                "  stream    {} subscribers · {} frames ({:.1}/s each, tick rate {} Hz) · {} ticks missed · {} out of order",
                s.subscribers,
                s.frames,
                s.frames_per_s_per_subscriber,
                s.tick_hz,
                s.gaps,
                s.out_of_order
            )?;
            let at = if s.frames_timed_at_read == 0 {
                "at the socket".to_string()
            } else {
                format!(
                    "{} frames timed at read: no kernel stamp",
                    s.frames_timed_at_read
                )
            };
            writeln!(
                f,
                "  delivery  {}  ({at}; {} frames early beyond sync error)",
                lat(&s.delay),
                s.early_frames
            )?;
            writeln!(
                f,
                "  read      {}  (when this tool read them)",
                lat(&s.read_delay)
            )?;
            writeln!(
                f,
                "  frames    {:.1} bodies each ({} frames off the interest set) · {}/s",
                s.bodies_per_frame,
                s.frames_with_unexpected_bodies,
                bytes(s.bytes_per_s)
            )?;
            for (why, n) in &s.disconnects {
                writeln!(f, "  lost      {n} subscribers: {why}")?;
            }
        }
        if let Some(p) = &self.server {
            writeln!(
                f,
                "  server    pid {}: {:.0}% of one core · RSS {:.1} → {:.1} MiB (peak {:.1})",
                p.pid,
                p.cpu_cores * 100.0,
                p.rss_start_mib,
                p.rss_end_mib,
                p.rss_peak_mib
            )?;
        }
        if let Some(c) = self.tool_cpu_cores {
            writeln!(
                f,
                "  tool      {:.0}% of one core (this process)",
                c * 100.0
            )?;
        }
        Ok(())
    }
}
