//! A scene's tick frames, fanned out to its subscribers by a few shard tasks.
//!
//! The tick loop ([`super::ticks`]) hands each frame to `TickLoop::send`. One task per shard
//! (as many shards as the runtime has worker threads) takes the frame and offers it to each of
//! its subscribers in turn ([`Follow::offer`]): a subscriber's frame is assembled and written to
//! its socket there and then, when the socket has room, which it almost always has. A tick costs
//! a few task wakes, not one per subscriber, and the shards write on every worker thread at once.
//!
//! An offer never waits. A socket that cannot take the frame at once keeps it for the
//! subscriber's own writer task, which waits for the socket (and gives up on a client that
//! does not read); meanwhile newer frames replace the one kept, so a slow
//! socket skips to the newest frame rather than falling behind.
//!
//! A session holds a [`Ticks`] while it follows the scene: the loop runs while any is held, and
//! ends ([`Ticks::ended`] fires) when the last is dropped, when the scene is deleted or at shutdown.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, Weak};

use tokio::sync::broadcast;
use tokio_util::sync::{CancellationToken, WaitForCancellationFutureOwned};

use super::frame::SharedTick;

/// Frames buffered per shard between the tick loop and the shard's task. A shard lags only when
/// starved of CPU for this many ticks (two seconds at 30 Hz); it then skips to the newest.
const SHARD_CHANNEL: usize = 64;

/// Subscribers a shard writes to before it lets its worker thread run other tasks: ~2–5 ms of
/// writes on the machines measured (docs/performance.md, P7).
const OFFERS_PER_TURN: usize = 256;

/// Most shards per scene, whatever the number of worker threads.
const MAX_SHARDS: usize = 16;

/// A subscriber as its shard sees it: something to offer each frame to.
pub trait Follow: Send + Sync {
    /// Offers `tick`: written to the subscriber's socket if it has room, else kept for the
    /// subscriber's writer task. Never waits. `chosen` is the shard's scratch
    /// ([`SharedTick::message_with`]).
    fn offer(&self, tick: &SharedTick, chosen: &mut Vec<usize>) -> Offered;
}

/// What became of a frame offered to a subscriber.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Offered {
    /// Written to its socket (or not wanted: not following, or the socket failed).
    Done,
    /// Left to the subscriber's writer task: the socket had no room at once.
    HandedOff,
    /// Left to the writer in place of an older frame it had not sent yet, which is dropped.
    Replaced,
}

/// One shard's subscribers, copied on write: a shard takes the list at each frame without
/// holding the lock while it writes, and a subscriber joining or leaving then copies the list
/// (between frames it changes it in place).
type Followers = Mutex<Arc<Vec<Arc<dyn Follow>>>>;

/// A scene's running tick loop: the frames' channel to the shards, the shards' subscribers and
/// the count of [`Ticks`] held.
pub struct TickLoop {
    tx: broadcast::Sender<Arc<SharedTick>>,
    shards: Box<[Arc<Followers>]>,
    /// [`Ticks`] held: the loop stops when none is.
    held: AtomicUsize,
    /// Cancelled when the loop ends.
    ended: CancellationToken,
    /// Frames left to writers so far ([`Offered::HandedOff`] and [`Offered::Replaced`]).
    handed_off: AtomicU64,
}

impl std::fmt::Debug for TickLoop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TickLoop")
            .field("shards", &self.shards.len())
            .field("held", &self.held.load(Ordering::Relaxed))
            .field("ended", &self.ended.is_cancelled())
            .finish_non_exhaustive()
    }
}

impl TickLoop {
    /// A loop's fan-out with one shard per worker thread of the current runtime, the shards'
    /// tasks spawned on `tasks`.
    pub(crate) fn start(tasks: &tokio_util::task::TaskTracker) -> Arc<TickLoop> {
        let shards = tokio::runtime::Handle::try_current()
            .map_or(1, |h| h.metrics().num_workers())
            .clamp(1, MAX_SHARDS);
        let (tx, _) = broadcast::channel(SHARD_CHANNEL);
        let lp = Arc::new(TickLoop {
            tx,
            shards: (0..shards)
                .map(|_| Arc::new(Mutex::new(Arc::new(Vec::new()))))
                .collect(),
            held: AtomicUsize::new(0),
            ended: CancellationToken::new(),
            handed_off: AtomicU64::new(0),
        });
        for i in 0..lp.shards.len() {
            tasks.spawn(shard(lp.tx.subscribe(), Arc::downgrade(&lp), i));
        }
        lp
    }

    /// A hold on the loop for one session (call under the registry's lock, so the loop cannot
    /// decide to stop in between: see [`crate::stream::registry::Tickers::subscribe`]), in shard
    /// `slot` modulo their number. A session passes the same slot every time, so following again
    /// after an unsubscribe puts it back in the same shard, which sends each frame once: in
    /// another, a frame the old shard was still sending could reach it twice.
    pub(crate) fn hold(self: &Arc<Self>, slot: usize) -> Ticks {
        self.held.fetch_add(1, Ordering::AcqRel);
        Ticks {
            lp: Arc::clone(self),
            shard: slot % self.shards.len(),
            follower: None,
        }
    }

    /// Number of [`Ticks`] held.
    pub(crate) fn held(&self) -> usize {
        self.held.load(Ordering::Acquire)
    }

    /// Hands `tick` to the shards.
    pub(crate) fn send(&self, tick: Arc<SharedTick>) {
        // An error only means no shard task right now (none at shutdown).
        let _ = self.tx.send(tick);
    }

    /// Frames the shards left to subscribers' writer tasks since the loop started, because a
    /// socket had no room for them at once (`swell_ws_tick_handoffs_total` counts them for every
    /// loop). Subscribers that read keep this at zero.
    pub fn handed_off(&self) -> u64 {
        self.handed_off.load(Ordering::Relaxed)
    }

    /// Ends the loop: the shards stop and every holder's [`Ticks::ended`] fires.
    pub(crate) fn end(&self) {
        self.ended.cancel();
    }
}

/// A session's hold on a scene's tick loop, and its place in one shard once it
/// [follows](Ticks::follow). Dropping it leaves the shard.
pub struct Ticks {
    lp: Arc<TickLoop>,
    shard: usize,
    follower: Option<Arc<dyn Follow>>,
}

impl std::fmt::Debug for Ticks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ticks")
            .field("shard", &self.shard)
            .field("following", &self.follower.is_some())
            .finish_non_exhaustive()
    }
}

impl Ticks {
    /// Joins the shard: from the next frame on, `f` is offered every frame. Once per hold; a
    /// second call replaces the first follower.
    pub fn follow(&mut self, f: Arc<dyn Follow>) {
        self.leave();
        // Copy on write: the list is copied only while the shard holds it (mid-frame); between
        // frames the change is made in place, so a thousand subscribers joining do not copy the
        // list a thousand times.
        Arc::make_mut(&mut lock(&self.lp.shards[self.shard])).push(Arc::clone(&f));
        self.follower = Some(f);
    }

    /// Fires when the loop has ended (the scene was deleted, or the server is stopping): no
    /// more frames come.
    pub fn ended(&self) -> WaitForCancellationFutureOwned {
        self.lp.ended.clone().cancelled_owned()
    }

    fn leave(&mut self) {
        let Some(f) = self.follower.take() else {
            return;
        };
        Arc::make_mut(&mut lock(&self.lp.shards[self.shard])).retain(|g| !Arc::ptr_eq(g, &f));
    }
}

impl Drop for Ticks {
    fn drop(&mut self) {
        self.leave();
        self.lp.held.fetch_sub(1, Ordering::AcqRel);
    }
}

/// The lock of a shard's list; a poisoned one is still a whole list (nothing under the lock
/// panics midway: a clone, a push, a `retain` on pointer equality).
fn lock(f: &Followers) -> MutexGuard<'_, Arc<Vec<Arc<dyn Follow>>>> {
    f.lock().unwrap_or_else(|p| p.into_inner())
}

/// A shard's task: offers every frame to each of its subscribers, until the loop ends. It
/// holds the loop weakly: the loop is the registry's and its subscribers'.
async fn shard(mut rx: broadcast::Receiver<Arc<SharedTick>>, lp: Weak<TickLoop>, i: usize) {
    let Some((followers, ended)) = lp
        .upgrade()
        .map(|l| (Arc::clone(&l.shards[i]), l.ended.clone()))
    else {
        return;
    };
    let mut chosen = Vec::new();
    loop {
        let tick = tokio::select! {
            biased;
            () = ended.cancelled() => return,
            r = rx.recv() => r,
        };
        match tick {
            Ok(t) => {
                let list = Arc::clone(&lock(&followers));
                // Outside tokio's cooperative budget: every socket write takes one unit of a
                // task's budget (128 a poll), and past it a write reports "not ready" without
                // trying, which would hand most of a large shard's frames to their writers.
                // Instead the shard yields every `OFFERS_PER_TURN` subscribers, so a crowded
                // scene does not hold a worker thread away from the other connections for a
                // whole tick.
                let (mut handed, mut replaced) = (0u64, 0u64);
                for (i, chunk) in list.chunks(OFFERS_PER_TURN).enumerate() {
                    if i > 0 {
                        tokio::task::yield_now().await;
                    }
                    tokio::task::unconstrained(async {
                        for f in chunk {
                            match f.offer(&t, &mut chosen) {
                                Offered::Done => {}
                                Offered::HandedOff => handed += 1,
                                Offered::Replaced => replaced += 1,
                            }
                        }
                    })
                    .await;
                }
                if handed + replaced > 0 {
                    metrics::counter!("swell_ws_tick_handoffs_total").increment(handed + replaced);
                    metrics::counter!("swell_ws_ticks_skipped_total").increment(replaced);
                    if let Some(l) = lp.upgrade() {
                        l.handed_off.fetch_add(handed + replaced, Ordering::Relaxed);
                    }
                }
            }
            // Starved of CPU for a while: skip to the newest frames rather than replay old ones.
            Err(broadcast::error::RecvError::Lagged(n)) => {
                let subscribers = lock(&followers).len() as u64;
                metrics::counter!("swell_ws_ticks_skipped_total").increment(n * subscribers);
                tracing::debug!(skipped = n, "tick shard lagged");
            }
            Err(broadcast::error::RecvError::Closed) => return,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::types::Tick;

    /// Records the ticks offered to it.
    #[derive(Default)]
    struct Seen(Mutex<Vec<i64>>);

    impl Follow for Seen {
        fn offer(&self, tick: &SharedTick, _: &mut Vec<usize>) -> Offered {
            self.0.lock().unwrap().push(tick.tick.tick);
            Offered::Done
        }
    }

    fn frame(tick: i64) -> Arc<SharedTick> {
        Arc::new(SharedTick::new(Tick {
            tick,
            t: tick as f64 / 30.0,
            bodies: Vec::new(),
            impacts: Vec::new(),
            anchor_tick: None,
        }))
    }

    /// Waits until `seen` has `n` ticks (the shards run on the runtime's workers).
    async fn until(seen: &Seen, n: usize) -> Vec<i64> {
        for _ in 0..500 {
            let v = seen.0.lock().unwrap().clone();
            if v.len() >= n {
                return v;
            }
            tokio::time::sleep(std::time::Duration::from_millis(2)).await;
        }
        panic!("{n} ticks not offered: {:?}", seen.0.lock().unwrap());
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_session_always_joins_the_shard_of_its_slot() {
        let lp = TickLoop::start(&tokio_util::task::TaskTracker::new());
        assert_eq!(lp.shards.len(), 2, "one shard per worker thread");
        for slot in 0..6 {
            let (a, b) = (lp.hold(slot), lp.hold(slot));
            assert_eq!(a.shard, b.shard);
            assert_eq!(a.shard, slot % 2);
        }
        assert_eq!(lp.held(), 0, "every hold dropped");
        lp.end();
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn followers_get_every_frame_in_order_until_they_leave() {
        let lp = TickLoop::start(&tokio_util::task::TaskTracker::new());
        let (a, b) = (Arc::new(Seen::default()), Arc::new(Seen::default()));
        let mut ta = lp.hold(0);
        let mut tb = lp.hold(1);
        ta.follow(Arc::clone(&a) as Arc<dyn Follow>);
        tb.follow(Arc::clone(&b) as Arc<dyn Follow>);
        assert_eq!(lp.held(), 2);
        for t in 0..5 {
            lp.send(frame(t));
        }
        assert_eq!(until(&a, 5).await, [0, 1, 2, 3, 4]);
        assert_eq!(until(&b, 5).await, [0, 1, 2, 3, 4]);
        // Leaving: no more frames, and the hold is given back.
        drop(ta);
        assert_eq!(lp.held(), 1);
        for t in 5..8 {
            lp.send(frame(t));
        }
        assert_eq!(until(&b, 8).await, (0..8).collect::<Vec<_>>());
        assert_eq!(a.0.lock().unwrap().len(), 5, "a frame after leaving");
        // The end of the loop reaches the holders.
        let ended = tb.ended();
        lp.end();
        tokio::time::timeout(std::time::Duration::from_secs(5), ended)
            .await
            .expect("ended fires");
        assert_eq!(lp.handed_off(), 0);
    }

    /// Between frames a shard's list changes in place (joining and leaving do not copy it: a
    /// thousand joins are not a thousand copies); a list a shard holds mid-frame is copied
    /// instead, so the shard's frame goes to the list it took.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_shard_list_changes_in_place_unless_a_frame_holds_it() {
        let lp = TickLoop::start(&tokio_util::task::TaskTracker::new());
        let list = || Arc::clone(&lock(&lp.shards[0]));
        let seen: Vec<Arc<Seen>> = (0..3).map(|_| Arc::new(Seen::default())).collect();
        let mut holds: Vec<Ticks> = (0..3).map(|_| lp.hold(0)).collect();
        holds[0].follow(Arc::clone(&seen[0]) as Arc<dyn Follow>);
        let before = Arc::as_ptr(&list());
        holds[1].follow(Arc::clone(&seen[1]) as Arc<dyn Follow>);
        holds[0].leave();
        let now = list();
        assert_eq!(
            Arc::as_ptr(&now),
            before,
            "the list was copied between frames"
        );
        assert_eq!(now.len(), 1);
        // A shard mid-frame holds the list (as `shard` does): a join copies it.
        let held = now;
        holds[2].follow(Arc::clone(&seen[2]) as Arc<dyn Follow>);
        assert_eq!(held.len(), 1, "the held list changed under its frame");
        assert_ne!(Arc::as_ptr(&list()), Arc::as_ptr(&held));
        assert_eq!(list().len(), 2);
        drop((held, holds));
        lp.end();
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_shard_longer_than_a_turn_offers_every_frame_to_everyone() {
        let lp = TickLoop::start(&tokio_util::task::TaskTracker::new());
        // Every follower in shard 0: several turns of `OFFERS_PER_TURN`.
        let n = 2 * OFFERS_PER_TURN + 7;
        let seen: Vec<Arc<Seen>> = (0..n).map(|_| Arc::new(Seen::default())).collect();
        let holds: Vec<Ticks> = seen
            .iter()
            .map(|f| {
                let mut t = lp.hold(0);
                t.follow(Arc::clone(f) as Arc<dyn Follow>);
                t
            })
            .collect();
        for t in 0..3 {
            lp.send(frame(t));
        }
        for f in &seen {
            assert_eq!(until(f, 3).await, [0, 1, 2]);
        }
        drop(holds);
        lp.end();
    }
}
