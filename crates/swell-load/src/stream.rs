//! `stream` subscribers: each connects, syncs its clock by ping/pong, subscribes to tick frames
//! with its interest set, and records per frame how late it arrived against the tick's scene
//! time (mapped to this machine's clock through the sync), and whether tick numbers were skipped.
//!
//! "Arrived" is when the frame's last byte reached the subscriber's socket (the kernel's receive
//! stamp, [`crate::rx_time`]): the server's delivery. When the tool got round to reading it is
//! recorded too (the read delay): with many subscribers on the cores the server uses, that adds
//! the tool's own queue of sockets to read.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use futures_util::{SinkExt as _, StreamExt as _};
use hdrhistogram::Histogram;
use serde::Serialize;
use tokio::task::JoinSet;
use tokio_tungstenite::tungstenite::Message;
use tokio_util::sync::CancellationToken;

use crate::cli::Options;
use crate::rx_time::WallClock;
use crate::stats::{Latency, Window, histogram};
use crate::wire::Wire;
use crate::workload::Rng;
use crate::ws::{self, ClockSync, ServerMsg, Ws};

/// Subscribers connecting at once during setup.
const CONNECT_PARALLEL: usize = 16;
/// A frame more than this early counts as a clock-sync miss (delays below zero are recorded as
/// zero): a loopback sync is good to ~0.1 ms.
const EARLY_TOLERANCE_S: f64 = 0.002;

#[derive(Default)]
struct Inner {
    delay: Option<Histogram<u64>>,
    read_delay: Option<Histogram<u64>>,
    /// Frames whose delay is the read time (no kernel stamp).
    unstamped: u64,
    frames: u64,
    gaps: u64,
    out_of_order: u64,
    early: u64,
    bytes: u64,
    bodies: u64,
    wrong_bodies: u64,
    disconnects: BTreeMap<String, u64>,
}

/// What the subscribers saw.
pub struct StreamRecorder {
    window: Window,
    clock: WallClock,
    inner: Mutex<Inner>,
    /// Frames received (progress line).
    pub live_frames: AtomicU64,
    /// Ticks missed (progress line).
    pub live_gaps: AtomicU64,
}

impl StreamRecorder {
    /// An empty recorder for `window`.
    pub fn new(window: Window) -> Self {
        Self {
            window,
            clock: WallClock::now(),
            inner: Mutex::default(),
            live_frames: AtomicU64::new(0),
            live_gaps: AtomicU64::new(0),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The summary over `measured` for `subscribers` subscribers each expecting `expected_bodies`
    /// states per frame.
    pub fn summary(&self, subscribers: usize, measured: Duration, tick_hz: f64) -> StreamSummary {
        let g = self.lock();
        let secs = measured.as_secs_f64().max(1e-9);
        StreamSummary {
            subscribers,
            tick_hz,
            frames: g.frames,
            frames_per_s: g.frames as f64 / secs,
            frames_per_s_per_subscriber: g.frames as f64 / secs / subscribers.max(1) as f64,
            expected_frames_per_s_per_subscriber: tick_hz,
            gaps: g.gaps,
            out_of_order: g.out_of_order,
            delay: g.delay.as_ref().map(Latency::of).unwrap_or_default(),
            read_delay: g.read_delay.as_ref().map(Latency::of).unwrap_or_default(),
            frames_timed_at_read: g.unstamped,
            early_frames: g.early,
            bytes_per_s: g.bytes as f64 / secs,
            bodies_per_frame: if g.frames == 0 {
                0.0
            } else {
                g.bodies as f64 / g.frames as f64
            },
            frames_with_unexpected_bodies: g.wrong_bodies,
            disconnects: g.disconnects.iter().map(|(k, v)| (k.clone(), *v)).collect(),
        }
    }
}

/// The stream side of a run.
#[derive(Debug, Clone, Serialize)]
pub struct StreamSummary {
    /// Subscribers connected.
    pub subscribers: usize,
    /// The scene's tick rate.
    pub tick_hz: f64,
    /// Frames received in the window, all subscribers.
    pub frames: u64,
    /// Frames per second, all subscribers.
    pub frames_per_s: f64,
    /// Frames per second per subscriber.
    pub frames_per_s_per_subscriber: f64,
    /// What that should be: the tick rate times the clock rate.
    pub expected_frames_per_s_per_subscriber: f64,
    /// Tick numbers skipped between consecutive frames of a subscriber.
    pub gaps: u64,
    /// Frames whose tick went the wrong way.
    pub out_of_order: u64,
    /// Delivery delay: arrival at the subscriber's socket (the kernel's receive stamp) minus the
    /// tick's scene time on this machine's clock. Frames without a stamp (off Linux, or read
    /// before the kernel turned stamping on) count the read time instead: see
    /// `frames_timed_at_read`.
    pub delay: Latency,
    /// Read delay: when the tool read the frame, minus the tick's scene time. Holds the delivery
    /// delay plus the wait for the tool to get to the socket.
    pub read_delay: Latency,
    /// Frames whose delivery delay is their read time (no kernel receive stamp).
    pub frames_timed_at_read: u64,
    /// Frames that arrived more than 2 ms before their tick (a clock-sync miss).
    pub early_frames: u64,
    /// Frame bytes per second, all subscribers.
    pub bytes_per_s: f64,
    /// Mean body states per frame.
    pub bodies_per_frame: f64,
    /// Frames whose body count differed from the subscriber's interest set (not checked with
    /// `--region`: the count moves as bodies drift).
    pub frames_with_unexpected_bodies: u64,
    /// Subscribers that lost their socket, by reason.
    pub disconnects: BTreeMap<String, u64>,
}

/// A connected, synced, subscribed subscriber.
pub struct Subscriber {
    ws: Ws,
    sync: ClockSync,
    expected_bodies: Option<usize>,
}

/// Connects `n` subscribers. Each follows `o.bodies_per_subscriber` bodies of `ids` (a seeded
/// choice; all when that is 0 or at least `ids.len()`).
///
/// # Errors
/// The first subscriber that could not connect, sync or subscribe, with the reason.
pub async fn connect_all(o: &Options, n: usize, ids: &[u64]) -> Result<Vec<Subscriber>, String> {
    let (url, scene, wire, per, timeout) = (
        o.url.as_str(),
        o.scene.as_str(),
        o.wire,
        o.bodies_per_subscriber,
        o.timeout,
    );
    let region = o.region;
    let compact = o.compact;
    let mut rng = Rng::new(o.seed ^ 0x0005_EED0_F5E7);
    let interests: Vec<Vec<u64>> = (0..n)
        .map(|_| {
            if per == 0 || per >= ids.len() {
                Vec::new()
            } else {
                let mut pool = ids.to_vec();
                // Partial Fisher–Yates: the first `per` entries are a uniform choice.
                for k in 0..per {
                    let j = k + rng.below(pool.len() - k);
                    pool.swap(k, j);
                }
                pool.truncate(per);
                pool
            }
        })
        .collect();
    let slots = Arc::new(tokio::sync::Semaphore::new(CONNECT_PARALLEL));
    let mut set = JoinSet::new();
    for (i, interest) in interests.into_iter().enumerate() {
        let (url, scene, slots) = (url.to_owned(), scene.to_owned(), slots.clone());
        // With a region the count moves as bodies drift in and out: not checked.
        let expected_bodies = if region.is_some() {
            None
        } else if interest.is_empty() {
            Some(ids.len())
        } else {
            Some(interest.len())
        };
        // Frames carry ~400 bytes a body in JSON, ~140 in protobuf, ~60 compact.
        let per_body = match (wire, compact) {
            (Wire::Json, _) => 400,
            (Wire::Protobuf, false) => 140,
            (Wire::Protobuf, true) => 60,
        };
        let read_buffer = ws::read_buffer_for(expected_bodies.unwrap_or(ids.len()) * per_body);
        set.spawn(async move {
            let _permit = slots.acquire_owned().await.expect("never closed");
            let mut ws = ws::connect(&url, &scene, wire, true, read_buffer).await?;
            let sync = ws::sync_clock(&mut ws, wire, timeout).await?;
            ws.send(ws::subscribe(wire, &interest, region, compact))
                .await
                .map_err(|e| format!("subscribe: {e}"))?;
            Ok::<_, String>((
                i,
                Subscriber {
                    ws,
                    sync,
                    expected_bodies,
                },
            ))
        });
    }
    let mut out: Vec<Option<Subscriber>> = (0..n).map(|_| None).collect();
    while let Some(r) = set.join_next().await {
        let (i, s) = r.map_err(|e| format!("subscriber task: {e}"))??;
        out[i] = Some(s);
    }
    Ok(out
        .into_iter()
        .map(|s| s.expect("every index joined"))
        .collect())
}

/// Reads frames until the window ends or `stop` fires, recording into `rec`.
pub async fn follow(
    mut s: Subscriber,
    wire: Wire,
    rate: f64,
    rec: Arc<StreamRecorder>,
    stop: CancellationToken,
) {
    let window = rec.window;
    let direction: i64 = if rate < 0.0 { -1 } else { 1 };
    let mut last: Option<i64> = None;
    let end = tokio::time::sleep_until(window.end.into());
    tokio::pin!(end);
    loop {
        let m = tokio::select! {
            m = s.ws.next() => m,
            _ = &mut end => break,
            _ = stop.cancelled() => break,
        };
        let arrival = Instant::now();
        let m = match m {
            None => {
                rec.lock()
                    .disconnects
                    .entry("closed".into())
                    .and_modify(|n| *n += 1)
                    .or_insert(1);
                return;
            }
            Some(Err(e)) => {
                *rec.lock()
                    .disconnects
                    .entry(format!("error: {e}"))
                    .or_default() += 1;
                return;
            }
            Some(Ok(Message::Close(c))) => {
                let why = c.map_or("close".into(), |c| format!("close {}", u16::from(c.code)));
                *rec.lock().disconnects.entry(why).or_default() += 1;
                return;
            }
            Some(Ok(m)) => m,
        };
        let Some(bytes) = ws::payload(&m) else {
            continue;
        };
        let fast = match wire {
            Wire::Protobuf => ws::protobuf_tick(bytes),
            Wire::Json => ws::json_tick(bytes),
        };
        let Some((tick, t, bodies)) = fast.or_else(|| match ws::decode(wire, bytes) {
            Ok(ServerMsg::Tick { tick, t, bodies }) => Some((tick, t, bodies)),
            _ => None,
        }) else {
            continue;
        };
        let prev = last.replace(tick);
        rec.live_frames.fetch_add(1, Ordering::Relaxed);
        if !window.records(arrival) {
            continue;
        }
        let at_socket = s.ws.get_ref().last_rx().map(|t| rec.clock.instant_of(t));
        let read_delay = s.sync.delay(t, rate, arrival);
        let delay = at_socket.map_or(read_delay, |a| s.sync.delay(t, rate, a));
        let mut g = rec.lock();
        if at_socket.is_none() {
            g.unstamped += 1;
        }
        g.frames += 1;
        g.bytes += bytes.len() as u64;
        g.bodies += bodies as u64;
        if s.expected_bodies.is_some_and(|n| n != bodies) {
            g.wrong_bodies += 1;
        }
        if let Some(p) = prev {
            let step = (tick - p) * direction;
            if step > 1 {
                g.gaps += (step - 1) as u64;
                rec.live_gaps
                    .fetch_add((step - 1) as u64, Ordering::Relaxed);
            } else if step < 1 {
                g.out_of_order += 1;
            }
        }
        if delay < -EARLY_TOLERANCE_S {
            g.early += 1;
        }
        let us = |d: f64| ((d.max(0.0) * 1e6) as u64).max(1);
        g.delay
            .get_or_insert_with(histogram)
            .saturating_record(us(delay));
        g.read_delay
            .get_or_insert_with(histogram)
            .saturating_record(us(read_delay));
    }
    let _ = s.ws.close(None).await;
}
