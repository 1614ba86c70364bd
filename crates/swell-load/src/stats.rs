//! What a run measures: latency histograms (HdrHistogram, microseconds), counts, bytes and an
//! error tally, shared by every task of the run behind one mutex (a record costs ~100 ns against
//! a request's tens of microseconds), plus lock-free live counters for the progress line.

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use hdrhistogram::Histogram;
use serde::Serialize;

use crate::cli::QueryKind;

/// Largest latency the histograms hold exactly, µs (one hour); longer ones saturate.
const HIST_MAX_US: u64 = 3_600_000_000;
/// Significant figures: 3 keeps every percentile within 0.1%.
const HIST_SIGFIG: u8 = 3;

/// A histogram of microseconds.
pub fn histogram() -> Histogram<u64> {
    Histogram::new_with_bounds(1, HIST_MAX_US, HIST_SIGFIG).expect("valid histogram bounds")
}

fn micros(d: Duration) -> u64 {
    u64::try_from(d.as_micros()).unwrap_or(u64::MAX).max(1)
}

/// The measurement window of a run: everything before `start` is warm-up; work scheduled (open
/// loop) or sent (closed loop) in `[start, end)` is recorded.
#[derive(Debug, Clone, Copy)]
pub struct Window {
    /// When the run began (warm-up starts).
    pub begin: Instant,
    /// When recording starts.
    pub start: Instant,
    /// When recording (and scheduling) stops.
    pub end: Instant,
}

impl Window {
    /// A window starting now.
    pub fn new(warmup: Duration, duration: Duration) -> Self {
        let begin = Instant::now();
        Self {
            begin,
            start: begin + warmup,
            end: begin + warmup + duration,
        }
    }

    /// Whether work at `at` is recorded.
    pub fn records(&self, at: Instant) -> bool {
        at >= self.start && at < self.end
    }
}

/// Latency percentiles, milliseconds.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Latency {
    /// Values recorded.
    pub count: u64,
    /// Median.
    pub p50_ms: f64,
    /// 90th percentile.
    pub p90_ms: f64,
    /// 99th percentile.
    pub p99_ms: f64,
    /// 99.9th percentile.
    pub p999_ms: f64,
    /// Largest.
    pub max_ms: f64,
    /// Mean.
    pub mean_ms: f64,
}

impl Latency {
    /// The percentiles of a histogram of microseconds.
    pub fn of(h: &Histogram<u64>) -> Self {
        if h.is_empty() {
            return Self::default();
        }
        let ms = |us: u64| us as f64 / 1000.0;
        Self {
            count: h.len(),
            p50_ms: ms(h.value_at_quantile(0.5)),
            p90_ms: ms(h.value_at_quantile(0.9)),
            p99_ms: ms(h.value_at_quantile(0.99)),
            p999_ms: ms(h.value_at_quantile(0.999)),
            max_ms: ms(h.max()),
            mean_ms: h.mean() / 1000.0,
        }
    }
}

/// How one request ended.
#[derive(Debug)]
pub enum Outcome {
    /// A 2xx answer (and, with `--validate`, a well-formed one).
    Ok {
        /// Points (or bodies) answered.
        points: u64,
        /// Request bytes written (body, or the WebSocket message).
        sent: u64,
        /// Answer bytes read.
        received: u64,
    },
    /// Anything else: the label it is tallied under (`"503 overloaded"`, `"timeout"`, …) and a
    /// longer description kept for the first occurrence of each label.
    Err {
        /// Tally key.
        label: String,
        /// Detail (first occurrence shown in the report).
        detail: String,
    },
}

#[derive(Default)]
struct KindStats {
    ok: u64,
    errors: u64,
    points: u64,
    hist: Option<Histogram<u64>>,
}

struct Inner {
    hist: Histogram<u64>,
    lag: Histogram<u64>,
    ok: u64,
    points: u64,
    sent: u64,
    received: u64,
    errors: BTreeMap<String, (u64, String)>,
    /// Failures by whole second of their due time since the window's start.
    errors_per_second: Vec<u64>,
    kinds: BTreeMap<QueryKind, KindStats>,
}

/// Where request outcomes go.
pub struct Recorder {
    window: Window,
    inner: Mutex<Inner>,
    /// Requests completed in or after the warm-up (progress line).
    pub live_done: AtomicU64,
    /// Requests failed (progress line).
    pub live_errors: AtomicU64,
}

impl Recorder {
    /// An empty recorder for `window`.
    pub fn new(window: Window) -> Self {
        Self {
            window,
            inner: Mutex::new(Inner {
                hist: histogram(),
                lag: histogram(),
                ok: 0,
                points: 0,
                sent: 0,
                received: 0,
                errors: BTreeMap::new(),
                errors_per_second: Vec::new(),
                kinds: BTreeMap::new(),
            }),
            live_done: AtomicU64::new(0),
            live_errors: AtomicU64::new(0),
        }
    }

    /// The window.
    pub fn window(&self) -> Window {
        self.window
    }

    /// Records a request that was due (open loop) or sent (closed loop) at `at` and took
    /// `latency` from then. Outside the window it only moves the live counters.
    pub fn record(&self, at: Instant, kind: QueryKind, latency: Duration, outcome: Outcome) {
        self.live_done.fetch_add(1, Ordering::Relaxed);
        if matches!(outcome, Outcome::Err { .. }) {
            self.live_errors.fetch_add(1, Ordering::Relaxed);
        }
        if !self.window.records(at) {
            return;
        }
        let mut g = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        let k = g.kinds.entry(kind).or_default();
        match outcome {
            Outcome::Ok {
                points,
                sent,
                received,
            } => {
                k.ok += 1;
                k.points += points;
                k.hist
                    .get_or_insert_with(histogram)
                    .saturating_record(micros(latency));
                g.ok += 1;
                g.points += points;
                g.sent += sent;
                g.received += received;
                g.hist.saturating_record(micros(latency));
            }
            Outcome::Err { label, detail } => {
                k.errors += 1;
                g.errors.entry(label).or_insert((0, detail)).0 += 1;
                let second = at.saturating_duration_since(self.window.start).as_secs() as usize;
                if g.errors_per_second.len() <= second {
                    g.errors_per_second.resize(second + 1, 0);
                }
                g.errors_per_second[second] += 1;
            }
        }
    }

    /// Records how late the tool itself started an open-loop request after its due time (timer
    /// slack, or waiting for an in-flight slot): the part of a latency that is the tool's.
    pub fn record_lag(&self, due: Instant, lag: Duration) {
        if self.window.records(due) {
            let mut g = self.inner.lock().unwrap_or_else(|p| p.into_inner());
            g.lag.saturating_record(micros(lag));
        }
    }

    /// Records a request still unanswered when the run gave up on it.
    pub fn record_abandoned(&self, at: Instant, kind: QueryKind) {
        self.record(
            at,
            kind,
            Duration::ZERO,
            Outcome::Err {
                label: "unanswered at the end".into(),
                detail: "still in flight when the run stopped waiting".into(),
            },
        );
    }

    /// The summary over `measured` seconds.
    pub fn summary(&self, measured: Duration) -> RequestSummary {
        let g = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        let secs = measured.as_secs_f64().max(1e-9);
        let errors: u64 = g.errors.values().map(|(n, _)| n).sum();
        RequestSummary {
            ok: g.ok,
            errors,
            req_per_s: g.ok as f64 / secs,
            points_per_s: g.points as f64 / secs,
            latency: Latency::of(&g.hist),
            start_lag: (!g.lag.is_empty()).then(|| Latency::of(&g.lag)),
            bytes_sent: g.sent,
            bytes_received: g.received,
            errors_by_kind: g
                .errors
                .iter()
                .map(|(label, (n, detail))| ErrorCount {
                    label: label.clone(),
                    count: *n,
                    first: detail.clone(),
                })
                .collect(),
            errors_per_second: g.errors_per_second.clone(),
            by_query: if g.kinds.len() > 1 {
                g.kinds
                    .iter()
                    .map(|(k, s)| KindSummary {
                        query: *k,
                        ok: s.ok,
                        errors: s.errors,
                        req_per_s: s.ok as f64 / secs,
                        points_per_s: s.points as f64 / secs,
                        latency: s.hist.as_ref().map(Latency::of).unwrap_or_default(),
                    })
                    .collect()
            } else {
                Vec::new()
            },
        }
    }
}

/// Failed requests under one label.
#[derive(Debug, Clone, Serialize)]
pub struct ErrorCount {
    /// `"<status> <code>"`, `"timeout"`, `"connect error"`, `"invalid answer"`, …
    pub label: String,
    /// How many.
    pub count: u64,
    /// The first one's detail.
    pub first: String,
}

/// One query kind's share of a `mixed` run.
#[derive(Debug, Clone, Serialize)]
pub struct KindSummary {
    /// The kind.
    pub query: QueryKind,
    /// Answered.
    pub ok: u64,
    /// Failed.
    pub errors: u64,
    /// Answered per second.
    pub req_per_s: f64,
    /// Points answered per second.
    pub points_per_s: f64,
    /// Latency of answered requests.
    pub latency: Latency,
}

/// The request side of a run.
#[derive(Debug, Clone, Serialize)]
pub struct RequestSummary {
    /// Requests answered with 2xx (and valid, with `--validate`).
    pub ok: u64,
    /// Requests failed.
    pub errors: u64,
    /// Answered requests per second of the measured window.
    pub req_per_s: f64,
    /// Points (or bodies) answered per second.
    pub points_per_s: f64,
    /// Latency of answered requests, from the due time (open loop) or send (closed loop).
    pub latency: Latency,
    /// Open loop: how late the tool started requests after their due time (included in
    /// `latency`); a large p99 here means the load machine, not the server, was behind.
    pub start_lag: Option<Latency>,
    /// Request bytes (bodies or WebSocket messages) of answered requests.
    pub bytes_sent: u64,
    /// Answer bytes of answered requests.
    pub bytes_received: u64,
    /// Failures by label.
    pub errors_by_kind: Vec<ErrorCount>,
    /// Failures by whole second of their due time since the measured window began (`[3]`:
    /// requests due in the fourth second), up to the last second with one; empty without
    /// failures. Ties errors to an event of the run (a replica killed, a failover).
    pub errors_per_second: Vec<u64>,
    /// Per query kind (`mixed` only).
    pub by_query: Vec<KindSummary>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_window_is_recorded_and_percentiles_are_real() {
        let w = Window::new(Duration::from_secs(1), Duration::from_secs(10));
        let r = Recorder::new(w);
        let ok = || Outcome::Ok {
            points: 2,
            sent: 10,
            received: 20,
        };
        // Warm-up: counted live, not recorded.
        r.record(w.begin, QueryKind::Sample, Duration::from_millis(50), ok());
        for ms in 1..=100u64 {
            r.record(w.start, QueryKind::Sample, Duration::from_millis(ms), ok());
        }
        r.record(
            w.start,
            QueryKind::Height,
            Duration::ZERO,
            Outcome::Err {
                label: "503 overloaded".into(),
                detail: "x".into(),
            },
        );
        r.record(w.end, QueryKind::Sample, Duration::from_millis(1), ok());
        let s = r.summary(Duration::from_secs(10));
        assert_eq!(s.ok, 100);
        assert_eq!(s.errors, 1);
        assert_eq!(s.errors_by_kind[0].label, "503 overloaded");
        assert_eq!(s.bytes_sent, 1000);
        assert!((s.req_per_s - 10.0).abs() < 1e-9);
        assert!((s.points_per_s - 20.0).abs() < 1e-9);
        assert!((s.latency.p50_ms - 50.0).abs() < 0.1, "{:?}", s.latency);
        assert!((s.latency.p99_ms - 99.0).abs() < 0.1, "{:?}", s.latency);
        assert!((s.latency.max_ms - 100.0).abs() < 0.1, "{:?}", s.latency);
        assert_eq!(s.by_query.len(), 2);
        assert_eq!(r.live_done.load(Ordering::Relaxed), 103);
        assert_eq!(s.errors_per_second, [1]);
    }

    #[test]
    fn errors_are_counted_by_the_second_they_were_due() {
        let w = Window::new(Duration::ZERO, Duration::from_secs(10));
        let r = Recorder::new(w);
        let err = || Outcome::Err {
            label: "502".into(),
            detail: "x".into(),
        };
        for ms in [2100, 2900, 4000] {
            r.record(
                w.start + Duration::from_millis(ms),
                QueryKind::Height,
                Duration::ZERO,
                err(),
            );
        }
        let s = r.summary(Duration::from_secs(10));
        assert_eq!(s.errors_per_second, [0, 0, 2, 0, 1]);
    }
}
