//! The two load shapes, over any transport: a request is a future made from its index.
//!
//! - Open loop: request `i` is due at `begin + i/rate`. A timetable thread hands out each due
//!   time as it falls due, and the driver starts the request as its own task (waiting for one of `max_in_flight` slots if the
//!   server is behind); latency runs from the due time, so a stalled server shows its queue.
//! - Closed loop: `concurrency` workers each send, await, record, repeat.
//!
//! Stopping (the window's end, or Ctrl-C through the token): no new requests; in-flight ones get
//! `grace` to finish (1 s after Ctrl-C) and are then dropped and tallied as unanswered.

use std::future::Future;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use tokio::sync::Semaphore;
use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;

use crate::cli::{QueryKind, Shape};
use crate::stats::{Outcome, Recorder};

/// How long in-flight requests get after Ctrl-C.
const INTERRUPT_GRACE: Duration = Duration::from_secs(1);

/// Records an unanswered request if its task is dropped before it finishes.
struct Pending {
    rec: Arc<Recorder>,
    at: Instant,
    kind: QueryKind,
    done: bool,
}

impl Drop for Pending {
    fn drop(&mut self) {
        if !self.done {
            self.rec.record_abandoned(self.at, self.kind);
        }
    }
}

/// Longest single sleep of the timetable thread, so it notices a stopped run promptly.
const TIMETABLE_NAP: Duration = Duration::from_millis(50);

/// The open-loop timetable: `(i, begin + i/rate)` for every due time before `end`, each sent when
/// it falls due. A plain thread sleeping to each due time keeps to it within the OS's sleep slack
/// (~0.1 ms); tokio's timer wheel rounds sleeps up to whole milliseconds, which would add up to a
/// millisecond of the tool's own lateness to every latency. The thread ends at `end` or as soon
/// as the receiver is dropped.
fn timetable(
    begin: Instant,
    end: Instant,
    rate: f64,
) -> tokio::sync::mpsc::UnboundedReceiver<(u64, Instant)> {
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    std::thread::spawn(move || {
        for i in 0u64.. {
            let due = begin + Duration::from_secs_f64(i as f64 / rate);
            if due >= end {
                return;
            }
            loop {
                let now = Instant::now();
                if now >= due || tx.is_closed() {
                    break;
                }
                std::thread::sleep((due - now).min(TIMETABLE_NAP));
            }
            if tx.send((i, due)).is_err() {
                return;
            }
        }
    });
    rx
}

/// Runs `shape` until the recorder's window ends or `stop` fires; returns the measured time
/// (shorter than the window when stopped early). `make(i)` gives request `i`'s kind and future.
pub async fn drive<F, Fut>(
    shape: Shape,
    rec: Arc<Recorder>,
    stop: &CancellationToken,
    grace: Duration,
    make: F,
) -> Duration
where
    F: Fn(u64) -> (QueryKind, Fut) + Send + Sync + 'static,
    Fut: Future<Output = Outcome> + Send + 'static,
{
    let window = rec.window();
    let make = Arc::new(make);
    let mut set = JoinSet::new();
    match shape {
        Shape::OpenLoop {
            rate,
            max_in_flight,
        } => {
            let slots = Arc::new(Semaphore::new(max_in_flight));
            let mut due_times = timetable(window.begin, window.end, rate);
            loop {
                let (i, due) = tokio::select! {
                    d = due_times.recv() => match d { Some(d) => d, None => break },
                    _ = stop.cancelled() => break,
                };
                let permit = tokio::select! {
                    p = slots.clone().acquire_owned() => p.expect("the semaphore is never closed"),
                    _ = stop.cancelled() => break,
                };
                rec.record_lag(due, due.elapsed());
                while set.try_join_next().is_some() {}
                let (kind, fut) = make(i);
                let rec = rec.clone();
                set.spawn(async move {
                    let mut pending = Pending {
                        rec: rec.clone(),
                        at: due,
                        kind,
                        done: false,
                    };
                    let outcome = fut.await;
                    pending.done = true;
                    rec.record(due, kind, due.elapsed(), outcome);
                    drop(permit);
                });
            }
        }
        Shape::ClosedLoop { concurrency } => {
            let next = Arc::new(AtomicU64::new(0));
            for _ in 0..concurrency {
                let (rec, make, next, stop) =
                    (rec.clone(), make.clone(), next.clone(), stop.clone());
                set.spawn(async move {
                    while Instant::now() < window.end && !stop.is_cancelled() {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let (kind, fut) = make(i);
                        let at = Instant::now();
                        let mut pending = Pending {
                            rec: rec.clone(),
                            at,
                            kind,
                            done: false,
                        };
                        let outcome = fut.await;
                        pending.done = true;
                        rec.record(at, kind, at.elapsed(), outcome);
                    }
                });
            }
            tokio::select! {
                _ = tokio::time::sleep_until(window.end.into()) => {}
                _ = stop.cancelled() => {}
            }
        }
    }
    let stopped_at = Instant::now();
    let deadline = tokio::time::Instant::now() + grace;
    let mut interrupted_at = stop.is_cancelled().then(tokio::time::Instant::now);
    loop {
        let until = interrupted_at.map_or(deadline, |t| deadline.min(t + INTERRUPT_GRACE));
        tokio::select! {
            r = set.join_next() => if r.is_none() { break },
            _ = tokio::time::sleep_until(until) => break,
            _ = stop.cancelled(), if interrupted_at.is_none() => {
                interrupted_at = Some(tokio::time::Instant::now());
            }
        }
    }
    // Whatever is left is dropped here; each `Pending` tallies itself as unanswered.
    set.shutdown().await;
    measured(
        window.start,
        window.end,
        stop.is_cancelled().then_some(stopped_at),
    )
}

/// The recorded time: the window, cut short at `stopped_at`.
pub fn measured(start: Instant, end: Instant, stopped_at: Option<Instant>) -> Duration {
    let until = stopped_at.map_or(end, |s| s.min(end));
    until.saturating_duration_since(start)
}
