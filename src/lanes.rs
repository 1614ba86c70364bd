//! The slow lane: connections from an address that broke a per-peer limit are served, for a
//! while, by threads that run only on CPU time the rest of the server does not want.
//!
//! Every limit in [`crate::api::admission`] and [`crate::api::serve`] already answers an
//! abusive peer cheaply (429, 408, a refused connection, a cut-off reader), but "cheaply" is
//! still thousands of answers a second, written on the same reactor threads as everyone else's.
//! On two cores a well-behaved client's request that arrives behind a burst of them waits.
//! So the address is *demoted* for [`crate::Limits::slow_lane_ms`] after each offence:
//!
//! - its new connections (and its refusals) are served on the slow lane, a runtime of its own
//!   whose threads are `SCHED_IDLE` on Linux (nice 19 where that is refused): the kernel runs
//!   them when no thread of normal priority wants the core, and preempts them the moment one
//!   does. Under no load they are as fast as the reactor; under load they get what is left;
//! - its connection that earned the 429 is closed after the answer (`Connection: close`), so a
//!   flood on kept-alive connections comes back through the slow lane.
//!
//! Offences: a 429 for the address's request rate, a 408 for a slow head or body, a connection
//! over `max_connections_per_peer`, an answer the peer did not read (`http_send_stall_ms`), and
//! on WebSockets a Close 1008 for the message rate or for not reading.
//!
//! The cost of running below everyone: a slow-lane thread preempted while it holds a lock the
//! reactor wants (scene table, byte budget) makes the reactor wait until it runs again, and on a
//! saturated machine a `SCHED_IDLE` thread runs rarely. Critical sections here are microseconds,
//! and the waiting thread's core is then free for it. Measured: the hostile battery with its
//! attackers at normal priority plus two busy loops on the two cores, slowest good answer 37.6 ms
//! with the lane against 60.4 ms without it (one run each; no stall of the length an
//! inversion would cause).
//!
//! What it keys on is the TCP peer, never an address from `X-Forwarded-For`: trusted proxies
//! (and exempt peers) are never demoted, since behind a proxy every client shares its address.
//! Clients behind one NAT share a fate, as they share the per-address limits. Everything is
//! bounded: at most [`SlowLane::MAX_KEYS`] addresses are remembered (expired ones are
//! forgotten first).

use std::collections::HashMap;
use std::future::Future;
use std::net::IpAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

use tokio::net::TcpStream;

use crate::peers::PeerPolicy;

/// Why an address was demoted: a fixed set, so the metric's label never takes client input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Offence {
    /// 429 for the address's request rate.
    Rate,
    /// 408: a request head that did not arrive in time.
    SlowHead,
    /// 408: a body under the minimum rate or past its deadline.
    SlowBody,
    /// A connection over `max_connections_per_peer`.
    Connections,
    /// An HTTP answer the peer did not read (`http_send_stall_ms`).
    NotReading,
    /// A WebSocket closed 1008: over its message rate.
    WsRate,
    /// A WebSocket closed 1008: its answers were not read.
    WsNotReading,
}

impl Offence {
    /// The metric label.
    pub fn as_str(self) -> &'static str {
        match self {
            Offence::Rate => "rate",
            Offence::SlowHead => "slow_head",
            Offence::SlowBody => "slow_body",
            Offence::Connections => "connections",
            Offence::NotReading => "not_reading",
            Offence::WsRate => "ws_rate",
            Offence::WsNotReading => "ws_not_reading",
        }
    }
}

/// Which lane a connection is served on, in every request's extensions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lane {
    /// The server's own runtime.
    Fast,
    /// The slow lane's runtime.
    Slow,
}

/// The demoted addresses of one server, and the way to the slow lane's runtime.
#[derive(Debug)]
pub struct SlowLane {
    /// How long an offence demotes its address; zero: never.
    hold: Duration,
    policy: PeerPolicy,
    /// Address → when its demotion ends.
    demoted: Mutex<HashMap<IpAddr, Instant>>,
    /// Connections (and refusals) served on the slow lane so far.
    served: AtomicU64,
}

impl SlowLane {
    /// Most addresses remembered at once.
    pub const MAX_KEYS: usize = 100_000;

    /// Demotions for `hold` (zero: none) of peers that are neither exempt nor trusted proxies
    /// under `policy`.
    pub fn new(hold: Duration, policy: PeerPolicy) -> SlowLane {
        SlowLane {
            hold,
            policy,
            demoted: Mutex::new(HashMap::new()),
            served: AtomicU64::new(0),
        }
    }

    fn table(&self) -> std::sync::MutexGuard<'_, HashMap<IpAddr, Instant>> {
        self.demoted
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Whether `peer` can be demoted at all: the lane is on and the peer is neither exempt nor
    /// a trusted proxy.
    pub fn applies_to(&self, peer: IpAddr) -> bool {
        !self.hold.is_zero()
            && !self.policy.exempt.contains(peer)
            && !self.policy.trusted_proxies.contains(peer)
    }

    /// Records an offence of the TCP peer `peer`: its connections go on the slow lane until
    /// `hold` from now. Returns whether it was demoted (false where [`SlowLane::applies_to`]
    /// says no).
    pub fn demote(&self, peer: IpAddr, why: Offence) -> bool {
        if !self.applies_to(peer) {
            return false;
        }
        let now = Instant::now();
        let until = now + self.hold;
        let mut map = self.table();
        if map.len() >= Self::MAX_KEYS && !map.contains_key(&peer) {
            map.retain(|_, end| *end > now);
            if map.len() >= Self::MAX_KEYS {
                // Every one still holds: the one ending first gives way.
                if let Some(first) = map.iter().min_by_key(|(_, end)| **end).map(|(k, _)| *k) {
                    map.remove(&first);
                }
            }
        }
        let fresh = map.insert(peer, until).is_none_or(|end| end <= now);
        drop(map);
        if fresh {
            metrics::counter!("swell_peers_demoted_total", "why" => why.as_str()).increment(1);
        }
        true
    }

    /// The lane for a new connection from `peer`.
    pub fn lane(&self, peer: IpAddr) -> Lane {
        if self.hold.is_zero() {
            return Lane::Fast;
        }
        let mut map = self.table();
        match map.get(&peer) {
            Some(end) if *end > Instant::now() => Lane::Slow,
            Some(_) => {
                map.remove(&peer);
                Lane::Fast
            }
            None => Lane::Fast,
        }
    }

    /// Addresses demoted now (expired ones not yet forgotten excluded).
    pub fn demoted(&self) -> usize {
        let now = Instant::now();
        self.table().values().filter(|end| **end > now).count()
    }

    /// Connections (and refusals) this server has served on the slow lane.
    pub fn served(&self) -> u64 {
        self.served.load(Ordering::Relaxed)
    }

    /// Serves `tcp` with `serve` on `lane`: on the current runtime for [`Lane::Fast`]; for
    /// [`Lane::Slow`] the socket moves to the slow lane's runtime (its readiness is then driven
    /// by that runtime's reactor, on its threads) and `serve` runs there.
    pub fn spawn<F, Fut>(&self, lane: Lane, tcp: TcpStream, serve: F)
    where
        F: FnOnce(TcpStream) -> Fut + Send + 'static,
        Fut: Future<Output = ()> + Send + 'static,
    {
        if lane == Lane::Fast {
            tokio::spawn(serve(tcp));
            return;
        }
        self.served.fetch_add(1, Ordering::Relaxed);
        spawn_slow(tcp, serve);
    }
}

/// [`SlowLane::spawn`] on the slow lane.
fn spawn_slow<F, Fut>(tcp: TcpStream, serve: F)
where
    F: FnOnce(TcpStream) -> Fut + Send + 'static,
    Fut: Future<Output = ()> + Send + 'static,
{
    metrics::counter!("swell_http_slow_lane_connections_total").increment(1);
    let std = match tcp.into_std() {
        Ok(s) => s,
        Err(e) => {
            tracing::debug!(error = %e, "could not move a connection to the slow lane");
            return;
        }
    };
    runtime().spawn(async move {
        match TcpStream::from_std(std) {
            Ok(tcp) => serve(tcp).await,
            Err(e) => tracing::debug!(error = %e, "could not register a slow-lane connection"),
        }
    });
}

/// The slow lane's runtime, started on first use: one thread per core, each `SCHED_IDLE`.
/// Shared by every server in the process and never shut down (its connections end with their
/// servers' graceful shutdown, which they watch like any other).
pub fn runtime() -> &'static tokio::runtime::Handle {
    static RT: OnceLock<tokio::runtime::Runtime> = OnceLock::new();
    RT.get_or_init(|| {
        let threads = std::thread::available_parallelism().map_or(1, usize::from);
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(threads)
            .thread_name("swell-slow-lane")
            .on_thread_start(lower_thread_priority)
            .enable_all()
            .build()
            .expect("the slow lane's runtime: threads and an epoll instance")
    })
    .handle()
}

/// Puts the calling thread at `SCHED_IDLE`, or nice 19 where that is refused (the log says so
/// once). Threads it starts inherit it.
fn lower_thread_priority() {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: sched_setscheduler(0, …) acts on the calling thread and reads a local;
        // setpriority and gettid take and return plain integers.
        let r = unsafe {
            let p = libc::sched_param { sched_priority: 0 };
            if libc::sched_setscheduler(0, libc::SCHED_IDLE, &raw const p) == 0 {
                0
            } else {
                #[allow(clippy::cast_sign_loss)]
                libc::setpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t, 19)
            }
        };
        if r != 0 {
            let e = std::io::Error::last_os_error();
            static WARNED: std::sync::Once = std::sync::Once::new();
            WARNED.call_once(|| {
                tracing::warn!(error = %e, "the slow lane keeps the server's priority");
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::peers::Nets;

    fn ip(s: &str) -> IpAddr {
        s.parse().unwrap()
    }

    fn lane_with(hold_ms: u64) -> SlowLane {
        let policy = PeerPolicy {
            trusted_proxies: Nets::parse(&["10.0.0.1".into()]).unwrap(),
            exempt: Nets::parse(&["127.0.0.1".into()]).unwrap(),
        };
        SlowLane::new(Duration::from_millis(hold_ms), policy)
    }

    #[test]
    fn an_offence_demotes_its_address_for_the_hold_only() {
        let lane = lane_with(200);
        let (a, b) = (ip("192.0.2.7"), ip("192.0.2.8"));
        assert_eq!(lane.lane(a), Lane::Fast);
        assert!(lane.demote(a, Offence::Rate));
        assert_eq!(lane.lane(a), Lane::Slow);
        assert_eq!(lane.lane(b), Lane::Fast, "another address is not touched");
        assert_eq!(lane.demoted(), 1);
        std::thread::sleep(Duration::from_millis(250));
        assert_eq!(lane.lane(a), Lane::Fast, "the demotion ends");
        assert_eq!(lane.demoted(), 0);
    }

    #[test]
    fn exempt_peers_trusted_proxies_and_a_zero_hold_are_never_demoted() {
        let lane = lane_with(60_000);
        for p in ["127.0.0.1", "10.0.0.1"] {
            assert!(!lane.demote(ip(p), Offence::SlowBody), "{p}");
            assert_eq!(lane.lane(ip(p)), Lane::Fast, "{p}");
        }
        let off = lane_with(0);
        assert!(!off.demote(ip("192.0.2.7"), Offence::Rate));
        assert_eq!(off.lane(ip("192.0.2.7")), Lane::Fast);
    }

    #[test]
    fn the_table_is_bounded() {
        let lane = lane_with(60_000);
        for i in 0..SlowLane::MAX_KEYS + 10 {
            let v4 = std::net::Ipv4Addr::from(0x0a01_0000_u32 + u32::try_from(i).unwrap());
            lane.demote(IpAddr::V4(v4), Offence::Connections);
        }
        assert_eq!(lane.demoted(), SlowLane::MAX_KEYS);
        let last = 0x0a01_0000_u32 + u32::try_from(SlowLane::MAX_KEYS + 9).unwrap();
        assert_eq!(
            lane.lane(IpAddr::V4(last.into())),
            Lane::Slow,
            "the newest is kept"
        );
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn the_slow_lane_runs_at_sched_idle() {
        let (tx, rx) = std::sync::mpsc::channel();
        runtime().spawn(async move {
            // SAFETY: no preconditions; 0 is the calling thread.
            let _ = tx.send(unsafe { libc::sched_getscheduler(0) });
        });
        let policy = rx.recv_timeout(Duration::from_secs(10)).unwrap();
        // Containers may refuse SCHED_IDLE; then the thread is at nice 19 instead, and
        // stays SCHED_OTHER.
        assert!(
            policy == libc::SCHED_IDLE || policy == libc::SCHED_OTHER,
            "policy {policy}"
        );
        if policy == libc::SCHED_OTHER {
            let (tx, rx) = std::sync::mpsc::channel();
            runtime().spawn(async move {
                // SAFETY: as above.
                let n = unsafe {
                    #[allow(clippy::cast_sign_loss)]
                    libc::getpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t)
                };
                let _ = tx.send(n);
            });
            assert_eq!(rx.recv_timeout(Duration::from_secs(10)).unwrap(), 19);
        }
    }
}
