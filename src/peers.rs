//! Who a request comes from, and what each client may hold: the client address (through trusted
//! proxies only), per-key rate limits, and the byte budget of bodies being read and answers not
//! yet sent.
//!
//! Everything here is bounded: a rate limiter keeps at most [`RateLimiter::MAX_KEYS`] keys
//! (idle ones are forgotten first), and the byte budget's per-peer table holds only peers that
//! hold bytes now.

use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use axum::http::HeaderMap;

/// The TCP peer of a connection, put in every request's extensions by the accept loop
/// ([`crate::api::serve`]). Requests built in-process (tests driving the `Router` directly) have none
/// and are treated as an exempt local peer.
#[derive(Debug, Clone, Copy)]
pub struct PeerAddr(pub SocketAddr);

/// An IP network, `addr/prefix` (`10.0.0.0/8`, `::1/128`); a bare address is a /32 or /128.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IpNet {
    addr: IpAddr,
    prefix: u8,
}

impl IpNet {
    /// Parses `addr[/prefix]`.
    ///
    /// # Errors
    /// A message naming what is wrong.
    pub fn parse(s: &str) -> Result<IpNet, String> {
        let (a, p) = match s.split_once('/') {
            Some((a, p)) => (a, Some(p)),
            None => (s, None),
        };
        let addr: IpAddr = a
            .trim()
            .parse()
            .map_err(|_| format!("{s:?} is not an IP address or network (addr/prefix)"))?;
        let max = if addr.is_ipv4() { 32 } else { 128 };
        let prefix = match p {
            None => max,
            Some(p) => p
                .trim()
                .parse::<u8>()
                .ok()
                .filter(|p| *p <= max)
                .ok_or_else(|| format!("{s:?}: the prefix must be 0..={max}"))?,
        };
        Ok(IpNet { addr, prefix })
    }

    /// Whether `ip` lies in this network (IPv4-mapped IPv6 addresses count as IPv4).
    pub fn contains(&self, ip: IpAddr) -> bool {
        let ip = match ip {
            IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(ip, IpAddr::V4),
            v4 => v4,
        };
        match (self.addr, ip) {
            (IpAddr::V4(n), IpAddr::V4(a)) => {
                let mask = u32::MAX
                    .checked_shl(32 - u32::from(self.prefix))
                    .unwrap_or(0);
                u32::from(n) & mask == u32::from(a) & mask
            }
            (IpAddr::V6(n), IpAddr::V6(a)) => {
                let mask = u128::MAX
                    .checked_shl(128 - u32::from(self.prefix))
                    .unwrap_or(0);
                u128::from(n) & mask == u128::from(a) & mask
            }
            _ => false,
        }
    }
}

/// A list of networks.
#[derive(Debug, Clone, Default)]
pub struct Nets(Vec<IpNet>);

impl Nets {
    /// Parses every entry.
    ///
    /// # Errors
    /// The first entry that is not a network, named.
    pub fn parse(list: &[String]) -> Result<Nets, String> {
        list.iter()
            .map(|s| IpNet::parse(s))
            .collect::<Result<_, _>>()
            .map(Nets)
    }

    /// Whether any network holds `ip`.
    pub fn contains(&self, ip: IpAddr) -> bool {
        self.0.iter().any(|n| n.contains(ip))
    }
}

/// How client addresses are found and who is exempt from per-peer limits.
#[derive(Debug, Clone, Default)]
pub struct PeerPolicy {
    /// Proxies whose `X-Forwarded-For` is believed ([`crate::Limits::trusted_proxies`]).
    pub trusted_proxies: Nets,
    /// Clients the per-peer limits do not apply to ([`crate::Limits::exempt_peers`]).
    pub exempt: Nets,
}

impl PeerPolicy {
    /// The client a request comes from: the TCP peer, or, when the peer is a trusted proxy,
    /// the right-most address of `X-Forwarded-For` that is not itself a trusted proxy (the
    /// left part of the header is whatever the client wrote, so it is never believed).
    pub fn client(&self, peer: IpAddr, headers: &HeaderMap) -> IpAddr {
        if !self.trusted_proxies.contains(peer) {
            return peer;
        }
        let mut client = peer;
        let hops: Vec<&str> = headers
            .get_all("x-forwarded-for")
            .iter()
            .filter_map(|v| v.to_str().ok())
            .flat_map(|v| v.split(','))
            .collect();
        for hop in hops.iter().rev() {
            let Ok(ip) = hop.trim().parse::<IpAddr>() else {
                // A malformed hop: stop at the last address we could trust.
                break;
            };
            client = ip;
            if !self.trusted_proxies.contains(ip) {
                break;
            }
        }
        client
    }
}

/// One token bucket: `rate` tokens a second up to `burst`, one taken per request. Shared by the
/// per-key [`RateLimiter`] and a WebSocket session's own message rate.
#[derive(Debug, Clone, Copy)]
pub struct TokenBucket {
    rate: f64,
    burst: f64,
    tokens: f64,
    at: Instant,
}

impl TokenBucket {
    /// A full bucket of `rate` per second with bursts of `burst` (at least 1). A rate of 0 or
    /// less never refuses.
    pub fn new(rate: f64, burst: f64, now: Instant) -> TokenBucket {
        let burst = burst.max(1.0);
        TokenBucket {
            rate,
            burst,
            tokens: burst,
            at: now,
        }
    }

    /// Tokens at `now`, refilled since the last take.
    fn refilled(&self, now: Instant) -> f64 {
        (self.tokens + now.saturating_duration_since(self.at).as_secs_f64() * self.rate)
            .min(self.burst)
    }

    /// Whether the bucket is full at `now` (its client has been quiet for `burst / rate`).
    pub fn is_full(&self, now: Instant) -> bool {
        self.refilled(now) >= self.burst
    }

    /// Takes one token at `now`. `Err(seconds)`: none left; one will be after that long.
    pub fn take(&mut self, now: Instant) -> Result<(), f64> {
        if self.rate <= 0.0 {
            return Ok(());
        }
        let refilled = self.refilled(now);
        self.at = now;
        if refilled >= 1.0 {
            self.tokens = refilled - 1.0;
            Ok(())
        } else {
            self.tokens = refilled;
            Err((1.0 - refilled) / self.rate)
        }
    }
}

/// A token-bucket rate limiter per key: `rate` requests a second on average, bursts of up to
/// `burst`. Keys are forgotten once their bucket is full again, so the table holds only clients
/// active within the last `burst / rate` seconds, and at most [`RateLimiter::MAX_KEYS`].
#[derive(Debug)]
pub struct RateLimiter<K> {
    rate: f64,
    burst: f64,
    buckets: Mutex<HashMap<K, TokenBucket>>,
}

impl<K: std::hash::Hash + Eq + Copy> RateLimiter<K> {
    /// Keys kept at most. 100,000 entries are ~5 MB; beyond it (and after forgetting idle keys)
    /// a new key is refused, as if it were over its rate, until room frees up.
    pub const MAX_KEYS: usize = 100_000;

    /// A limiter of `rate` per second with bursts of `burst` (at least 1). A rate of 0 turns it
    /// off.
    pub fn new(rate: f64, burst: f64) -> Self {
        Self {
            rate,
            burst,
            buckets: Mutex::new(HashMap::new()),
        }
    }

    /// Takes one request for `key` at `now`. `Err(seconds)`: over the rate; the next request
    /// will be allowed after that long.
    pub fn check(&self, key: K, now: Instant) -> Result<(), f64> {
        if self.rate <= 0.0 {
            return Ok(());
        }
        let mut map = self.buckets.lock().unwrap_or_else(|p| p.into_inner());
        if map.len() >= Self::MAX_KEYS && !map.contains_key(&key) {
            map.retain(|_, b| !b.is_full(now));
            if map.len() >= Self::MAX_KEYS {
                return Err(1.0);
            }
        }
        map.entry(key)
            .or_insert_with(|| TokenBucket::new(self.rate, self.burst, now))
            .take(now)
    }
}

/// Bytes held for clients: request bodies being read and answers not yet sent, in total and per
/// client address. A charge is given back when its [`Charge`] drops.
#[derive(Debug)]
pub struct Budget {
    max_total: usize,
    max_peer: usize,
    inner: Mutex<BudgetInner>,
}

#[derive(Debug, Default)]
struct BudgetInner {
    total: usize,
    peers: HashMap<IpAddr, usize>,
}

/// Which limit a charge ran into. Its `Display` text is the message a client reads (`crate::error`
/// maps it to 503 `overloaded`, counted in `swell_http_buffer_budget_refused_total`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum OverBudget {
    /// The server's total ([`crate::Limits::max_buffered_bytes`]).
    #[error(
        "the server holds as many request and answer bytes as it allows (max_buffered_bytes); retry shortly"
    )]
    Total,
    /// This client's share ([`crate::Limits::max_buffered_bytes_per_peer`]).
    #[error(
        "this client holds as many request and answer bytes as it may (max_buffered_bytes_per_peer); read your answers or ask for fewer points, then retry"
    )]
    Peer,
}

impl OverBudget {
    /// The limit's name in the configuration.
    #[must_use]
    pub fn limit_name(self) -> &'static str {
        match self {
            OverBudget::Total => "max_buffered_bytes",
            OverBudget::Peer => "max_buffered_bytes_per_peer",
        }
    }

    /// Whose bytes the limit bounds, in words.
    #[must_use]
    pub fn whose(self) -> &'static str {
        match self {
            OverBudget::Total => "the server",
            OverBudget::Peer => "one client",
        }
    }
}

/// A query's reservation ([`Charge::reserve`]) that would take its holder past a limit: the
/// bytes asked for, the limit and its value. Nothing was charged. `crate::error` maps it to
/// 503 `overloaded`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "answering this request would hold {n} more bytes until the answer is sent, over what {} may hold at once ({} = {max}); ask for fewer points or fields, or read the answers already sent, then retry",
    which.whose(),
    which.limit_name()
)]
pub struct ReserveRefused {
    /// Bytes asked for.
    pub n: usize,
    /// The limit it ran into.
    pub which: OverBudget,
    /// That limit's value, bytes.
    pub max: usize,
}

impl Budget {
    /// A budget of `max_total` bytes, `max_peer` of them per client.
    pub fn new(max_total: usize, max_peer: usize) -> Arc<Budget> {
        Arc::new(Budget {
            max_total,
            max_peer,
            inner: Mutex::new(BudgetInner::default()),
        })
    }

    /// Bytes held now, in total.
    pub fn held(&self) -> usize {
        self.inner.lock().unwrap_or_else(|p| p.into_inner()).total
    }

    /// An empty charge for `peer` (`None`: exempt from the per-peer share), to grow with
    /// [`Charge::grow`].
    pub fn charge(self: &Arc<Self>, peer: Option<IpAddr>) -> Charge {
        Charge {
            budget: Arc::clone(self),
            peer,
            bytes: 0,
        }
    }
}

/// Bytes charged to a [`Budget`]; given back on drop.
#[derive(Debug)]
pub struct Charge {
    budget: Arc<Budget>,
    peer: Option<IpAddr>,
    bytes: usize,
}

impl Charge {
    /// Charges `n` more bytes.
    ///
    /// # Errors
    /// The total or the peer's share would be exceeded (nothing is charged).
    pub fn grow(&mut self, n: usize) -> Result<(), OverBudget> {
        if n == 0 {
            return Ok(());
        }
        let b = &self.budget;
        let mut inner = b.inner.lock().unwrap_or_else(|p| p.into_inner());
        if inner.total.saturating_add(n) > b.max_total {
            return Err(OverBudget::Total);
        }
        if let Some(ip) = self.peer {
            let held = inner.peers.get(&ip).copied().unwrap_or(0);
            if held.saturating_add(n) > b.max_peer {
                return Err(OverBudget::Peer);
            }
            inner.peers.insert(ip, held + n);
        }
        inner.total += n;
        self.bytes += n;
        metrics::gauge!("swell_buffered_bytes").set(inner.total as f64);
        Ok(())
    }

    /// [`Charge::grow`] for a query's work and answer before it runs.
    ///
    /// # Errors
    /// [`ReserveRefused`] naming the bytes asked for and the limit they would exceed (counted in
    /// `swell_http_buffer_budget_refused_total`).
    pub fn reserve(&mut self, n: usize) -> Result<(), ReserveRefused> {
        self.grow(n).map_err(|which| {
            metrics::counter!("swell_http_buffer_budget_refused_total").increment(1);
            let max = match which {
                OverBudget::Total => self.budget.max_total,
                OverBudget::Peer => self.budget.max_peer,
            };
            ReserveRefused { n, which, max }
        })
    }

    /// Bytes charged now.
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    /// Sets the charge to `n` bytes: charges the difference when that is more (and may fail as
    /// [`Charge::grow`] does), gives it back when less.
    ///
    /// # Errors
    /// Growing would exceed the total or the peer's share (the charge is left as it was).
    pub fn resize(&mut self, n: usize) -> Result<(), OverBudget> {
        if n >= self.bytes {
            return self.grow(n - self.bytes);
        }
        self.give_back(self.bytes - n);
        Ok(())
    }

    fn give_back(&mut self, n: usize) {
        if n == 0 {
            return;
        }
        let mut inner = self.budget.inner.lock().unwrap_or_else(|p| p.into_inner());
        inner.total = inner.total.saturating_sub(n);
        self.bytes -= n;
        metrics::gauge!("swell_buffered_bytes").set(inner.total as f64);
        if let Some(ip) = self.peer
            && let Some(h) = inner.peers.get_mut(&ip)
        {
            *h = h.saturating_sub(n);
            if *h == 0 {
                inner.peers.remove(&ip);
            }
        }
    }
}

impl Drop for Charge {
    fn drop(&mut self) {
        self.give_back(self.bytes);
    }
}

/// Open connections per client address, for the accept loop's per-peer cap.
#[derive(Debug, Default)]
pub struct ConnCounts(Mutex<HashMap<IpAddr, usize>>);

impl ConnCounts {
    /// Counts a new connection from `ip` unless it already has `max`: `None` then.
    pub fn open(self: &Arc<Self>, ip: IpAddr, max: usize) -> Option<ConnGuard> {
        let mut map = self.0.lock().unwrap_or_else(|p| p.into_inner());
        let n = map.entry(ip).or_insert(0);
        if *n >= max {
            if *n == 0 {
                map.remove(&ip);
            }
            return None;
        }
        *n += 1;
        Some(ConnGuard {
            counts: Arc::clone(self),
            ip,
        })
    }
}

/// One counted connection; uncounted on drop.
#[derive(Debug)]
pub struct ConnGuard {
    counts: Arc<ConnCounts>,
    ip: IpAddr,
}

impl Drop for ConnGuard {
    fn drop(&mut self) {
        let mut map = self.counts.0.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(n) = map.get_mut(&self.ip) {
            *n -= 1;
            if *n == 0 {
                map.remove(&self.ip);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn networks() {
        let n = IpNet::parse("10.1.0.0/16").unwrap();
        assert!(n.contains("10.1.200.3".parse().unwrap()));
        assert!(!n.contains("10.2.0.1".parse().unwrap()));
        assert!(n.contains("::ffff:10.1.0.9".parse().unwrap()));
        let lo6 = IpNet::parse("::1").unwrap();
        assert!(lo6.contains("::1".parse().unwrap()));
        assert!(!lo6.contains("::2".parse().unwrap()));
        assert!(
            IpNet::parse("0.0.0.0/0")
                .unwrap()
                .contains("8.8.8.8".parse().unwrap())
        );
        assert!(IpNet::parse("10.0.0.0/33").is_err());
        assert!(IpNet::parse("nope").is_err());
    }

    #[test]
    fn forwarded_for_is_believed_from_trusted_proxies_only() {
        let policy = PeerPolicy {
            trusted_proxies: Nets::parse(&["127.0.0.1/8".into(), "10.0.0.0/8".into()]).unwrap(),
            exempt: Nets::default(),
        };
        let mut h = HeaderMap::new();
        // The client wrote a fake first hop; nginx (10.0.0.2) appended the real one.
        h.insert(
            "x-forwarded-for",
            "6.6.6.6, 203.0.113.9, 10.0.0.2".parse().unwrap(),
        );
        assert_eq!(
            policy.client("127.0.0.1".parse().unwrap(), &h),
            "203.0.113.9".parse::<IpAddr>().unwrap()
        );
        // From an untrusted peer the header is ignored.
        assert_eq!(
            policy.client("198.51.100.1".parse().unwrap(), &h),
            "198.51.100.1".parse::<IpAddr>().unwrap()
        );
        // A malformed hop: the last good address.
        h.insert("x-forwarded-for", "garbage".parse().unwrap());
        assert_eq!(
            policy.client("127.0.0.1".parse().unwrap(), &h),
            "127.0.0.1".parse::<IpAddr>().unwrap()
        );
    }

    #[test]
    fn the_rate_limiter_allows_bursts_then_the_rate() {
        let l = RateLimiter::new(10.0, 5.0);
        let t0 = Instant::now();
        for _ in 0..5 {
            assert!(l.check(1u32, t0).is_ok());
        }
        let wait = l.check(1, t0).unwrap_err();
        assert!((wait - 0.1).abs() < 1e-9, "{wait}");
        // Another key has its own bucket.
        assert!(l.check(2, t0).is_ok());
        // 100 ms later one more.
        let t1 = t0 + Duration::from_millis(100);
        assert!(l.check(1, t1).is_ok());
        assert!(l.check(1, t1).is_err());
        assert!(RateLimiter::new(0.0, 1.0).check(1u8, t0).is_ok());
    }

    #[test]
    fn the_budget_holds_totals_and_shares_and_gives_back_on_drop() {
        let b = Budget::new(100, 60);
        let (p, q) = ("1.1.1.1".parse().ok(), "2.2.2.2".parse().ok());
        let mut a = b.charge(p);
        a.grow(50).unwrap();
        assert_eq!(a.grow(20), Err(OverBudget::Peer));
        let mut c = b.charge(q);
        assert_eq!(c.grow(60), Err(OverBudget::Total));
        c.grow(50).unwrap();
        let mut exempt = b.charge(None);
        assert_eq!(exempt.grow(1), Err(OverBudget::Total));
        drop(a);
        assert_eq!(b.held(), 50);
        exempt.grow(50).unwrap();
        drop((c, exempt));
        assert_eq!(b.held(), 0);
        assert!(b.inner.lock().unwrap().peers.is_empty());
    }

    #[test]
    fn a_charge_resizes_both_ways_and_keeps_its_size_when_growing_fails() {
        let b = Budget::new(100, 60);
        let p: IpAddr = "1.2.3.4".parse().unwrap();
        let mut c = b.charge(Some(p));
        c.resize(50).unwrap();
        assert_eq!((c.bytes(), b.held()), (50, 50));
        assert_eq!(c.resize(61), Err(OverBudget::Peer));
        assert_eq!((c.bytes(), b.held()), (50, 50));
        c.resize(20).unwrap();
        assert_eq!((c.bytes(), b.held()), (20, 20));
        // The peer's share shrank too: another charge for it may take the rest.
        b.charge(Some(p)).grow(40).unwrap();
        c.resize(0).unwrap();
        assert_eq!(b.held(), 0);
        assert!(b.inner.lock().unwrap().peers.is_empty());
    }

    #[test]
    fn connections_per_peer() {
        let c = Arc::new(ConnCounts::default());
        let ip: IpAddr = "1.2.3.4".parse().unwrap();
        let a = c.open(ip, 2).unwrap();
        let _b = c.open(ip, 2).unwrap();
        assert!(c.open(ip, 2).is_none());
        drop(a);
        assert!(c.open(ip, 2).is_some());
    }
}
