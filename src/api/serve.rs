//! The accept loop: HTTP/1.1 connections (WebSocket upgrades included) served by hyper, with
//! the two limits `axum::serve` has no setting for.
//!
//! - **`max_connections`**: connections open at once. At the limit the loop stops accepting;
//!   new connections wait in the kernel's listen backlog until one closes (as nginx's
//!   `worker_connections` does), so a burst of clients cannot make the server hold a connection
//!   (and its buffers, ~15 KiB) per client without bound, or run out of file descriptors.
//!   WebSocket sessions count until they end: they are connections.
//! - **`idle_timeout_ms`**: how long a connection may wait for the next request's headers, from
//!   when it opens or its last answer was written (hyper's header read timeout). An idle
//!   keep-alive connection is closed after it, and so is a client that trickles a request's
//!   headers (slowloris). An upgraded WebSocket is not subject to it.
//!
//! - **`head_timeout`**: how long a request's head may take from its first byte. A client that
//!   starts a request and does not finish its headers in time is answered 408
//!   `request_timeout` (the JSON error) and the connection closes; hyper's own header timeout
//!   (the idle timeout) closes without an answer, which is right for an idle connection but
//!   leaves a slow client guessing. The bytes of a body that hyper drains after an early
//!   answer (a 401 or 413 before the body was read) are not a head: they do not start it.
//!
//! - **`per_peer`**: connections open at once from one client address (the TCP peer; peers in
//!   the exempt list are not counted). One more is answered `429` with the JSON error and
//!   closed at once, so one client cannot take every slot.
//! - **`send_stall`**: how long a write to the client may make no progress. A client that stops
//!   reading its answer is disconnected after it (`swell_http_send_stalls_total`), and the
//!   answer's bytes are freed, instead of being held for as long as the client likes.
//!
//! Every request carries its TCP peer as a [`PeerAddr`] extension, for the per-client limits
//! of [`super::admission`].
//!
//! Everything else is what `axum::serve` does: TCP_NODELAY, accept errors logged and retried,
//! graceful shutdown (stop accepting, let every connection finish its request in flight, close
//! idle ones at once). Open connections are published as `swell_http_connections`.

use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::task::{Context, Poll};
use std::time::Duration;

use axum::Router;
use hyper::body::Incoming;
use hyper_util::rt::{TokioIo, TokioTimer};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{OwnedSemaphorePermit, Semaphore, watch};
use tokio::time::Sleep;

use crate::error::ErrorCode;
use crate::lanes::{Offence, SlowLane};
use crate::peers::{ConnCounts, ConnGuard, PeerAddr, PeerPolicy};

/// The limits of [`serve`].
#[derive(Debug, Clone)]
pub struct ConnectionLimits {
    /// Connections open at once (at least 1).
    pub max_connections: usize,
    /// Longest wait for a request's headers on an open connection; `None`: no limit.
    pub idle_timeout: Option<Duration>,
    /// Longest a request's head may take from its first byte (408); `None`: no limit.
    pub head_timeout: Option<Duration>,
    /// Connections open at once per client address.
    pub per_peer: usize,
    /// Longest a write may make no progress; `None`: no limit.
    pub send_stall: Option<Duration>,
    /// Who is exempt from `per_peer`.
    pub policy: PeerPolicy,
    /// Addresses demoted to the slow lane: their connections are served there, and offences
    /// seen here (a refused connection, a slow head, an unread answer) demote.
    pub slow_lane: Arc<SlowLane>,
    /// Most headers the HTTP parser reads ([`crate::Limits::max_headers`] answers below it
    /// with the JSON error; this is the backstop, answered bare).
    pub parser_max_headers: usize,
    /// Longest the drain after `shutdown` waits for open connections (a request in flight, a
    /// client still sending its head or body) before `serve` returns without them.
    pub drain_deadline: Duration,
}

/// Serves `app` on `listener` until `shutdown` completes, then stops accepting and waits for
/// every connection to finish (idle ones close at once; a request in flight runs to its end),
/// up to `limits.drain_deadline`.
///
/// # Errors
/// None today: accept errors are logged and retried (a full file table eases as connections
/// close). The `Result` keeps the shape of `axum::serve`.
pub async fn serve(
    listener: TcpListener,
    app: Router,
    limits: ConnectionLimits,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let slots = Arc::new(Semaphore::new(limits.max_connections.max(1)));
    // Dropping `stop_rx` tells every connection to shut down gracefully; every connection task
    // holds a `done_rx`, so `done_tx.closed()` completes when the last one ends.
    let (stop_tx, stop_rx) = watch::channel(());
    let (done_tx, done_rx) = watch::channel(());
    tokio::spawn(async move {
        shutdown.await;
        drop(stop_rx);
    });
    let open = Arc::new(AtomicUsize::new(0));
    let per_peer = Arc::new(ConnCounts::default());
    loop {
        let permit = tokio::select! {
            p = slots.clone().acquire_owned() => match p {
                Ok(p) => p,
                Err(_) => break, // never closed
            },
            () = stop_tx.closed() => break,
        };
        let (tcp, remote) = tokio::select! {
            r = listener.accept() => match r {
                Ok(conn) => conn,
                Err(e) => {
                    accept_error(&e).await;
                    continue;
                }
            },
            () = stop_tx.closed() => break,
        };
        if let Err(e) = tcp.set_nodelay(true) {
            tracing::debug!(error = %e, "could not set TCP_NODELAY");
        }
        let peer_slot = if limits.policy.exempt.contains(remote.ip()) {
            None
        } else {
            match per_peer.open(remote.ip(), limits.per_peer.max(1)) {
                Some(g) => Some(g),
                None => {
                    metrics::counter!("swell_http_peer_connections_refused_total").increment(1);
                    limits.slow_lane.demote(remote.ip(), Offence::Connections);
                    let per_peer = limits.per_peer;
                    limits
                        .slow_lane
                        .spawn(limits.slow_lane.lane(remote.ip()), tcp, move |tcp| {
                            refuse(tcp, permit, per_peer)
                        });
                    continue;
                }
            }
        };
        let lane = limits.slow_lane.lane(remote.ip());
        let app = app.clone();
        let heads = Arc::new(Heads::default());
        let seen = Arc::clone(&heads);
        let service = hyper::service::service_fn(move |mut req: hyper::Request<Incoming>| {
            req.extensions_mut().insert(PeerAddr(remote));
            req.extensions_mut().insert(lane);
            seen.start(req.headers().contains_key(hyper::header::UPGRADE));
            let seen = Arc::clone(&seen);
            let progress = Arc::new(BodyProgress::of(req.body()));
            let req = req.map(|body| Watched {
                body,
                progress: Arc::clone(&progress),
            });
            // The router is always ready: `oneshot` polls readiness and calls.
            let answer = tower::ServiceExt::oneshot(app.clone(), req);
            async move {
                let r = answer.await;
                seen.answered(&progress);
                r
            }
        });
        let (stop, done) = (stop_tx.clone(), done_rx.clone());
        let idle_timeout = limits.idle_timeout;
        let parser_max_headers = limits.parser_max_headers;
        let slot = Slot::take(permit, open.clone());
        let (stall_after, head_after) = (limits.send_stall, limits.head_timeout);
        let demote = Demote {
            lane: Arc::clone(&limits.slow_lane),
            peer: remote.ip(),
        };
        limits.slow_lane.spawn(lane, tcp, move |tcp| async move {
            let tcp = Counted {
                tcp,
                _slot: slot,
                _peer: peer_slot,
                stall_after,
                stall: None,
                heads,
                head_after,
                head: None,
                demote,
            };
            let mut builder = hyper::server::conn::http1::Builder::new();
            builder
                .timer(TokioTimer::new())
                .header_read_timeout(idle_timeout)
                .max_headers(parser_max_headers);
            let conn = builder
                .serve_connection(TokioIo::new(tcp), service)
                .with_upgrades();
            let mut conn = std::pin::pin!(conn);
            tokio::select! {
                r = conn.as_mut() => log_end(r, remote),
                () = stop.closed() => {
                    conn.as_mut().graceful_shutdown();
                    log_end(conn.await, remote);
                }
            }
            drop(done);
        });
    }
    drop(listener);
    drop(done_rx);
    if tokio::time::timeout(limits.drain_deadline, done_tx.closed())
        .await
        .is_err()
    {
        // A slow client's head or body, or a long request: not worth holding the exit (and the
        // final snapshot) past the deadline. Their tasks end with the runtime.
        tracing::warn!(
            open = open.load(Ordering::Relaxed),
            deadline_s = limits.drain_deadline.as_secs_f64(),
            "shutdown: connections still open at the deadline; leaving them"
        );
    }
    Ok(())
}

/// One open connection's place: a `max_connections` permit and a count in
/// `swell_http_connections`, both given back when the socket is dropped. The socket owns it, so
/// a connection upgraded to a WebSocket keeps its place until the session ends (hyper's
/// connection future finishes at the upgrade and hands the socket on).
struct Slot {
    _permit: OwnedSemaphorePermit,
    open: Arc<AtomicUsize>,
}

impl Slot {
    fn take(permit: OwnedSemaphorePermit, open: Arc<AtomicUsize>) -> Slot {
        let n = open.fetch_add(1, Ordering::Relaxed) + 1;
        publish(n);
        Slot {
            _permit: permit,
            open,
        }
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        publish(self.open.fetch_sub(1, Ordering::Relaxed) - 1);
    }
}

fn publish(open: usize) {
    #[allow(clippy::cast_precision_loss)]
    metrics::gauge!("swell_http_connections").set(open as f64);
}

/// Answers a connection over its peer's limit with 429 and closes it. The write is bounded in
/// time, so a peer that does not read cannot hold the slot.
async fn refuse(mut tcp: TcpStream, permit: OwnedSemaphorePermit, per_peer: usize) {
    use tokio::io::AsyncWriteExt as _;
    let body = format!(
        "{{\"error\":{{\"code\":\"{code}\",\"message\":\"this address has {per_peer} connections open (max_connections_per_peer); close one first\"}}}}",
        code = ErrorCode::TooManyConnections.as_str(),
    );
    let status = ErrorCode::TooManyConnections.status();
    let head = format!(
        "HTTP/1.1 {} {}\r\ncontent-type: application/json\r\ncontent-length: {}\r\nretry-after: 1\r\nconnection: close\r\n\r\n",
        status.as_str(),
        status.canonical_reason().unwrap_or_default(),
        body.len()
    );
    let write = async {
        tcp.write_all(head.as_bytes()).await?;
        tcp.write_all(body.as_bytes()).await?;
        tcp.shutdown().await
    };
    let _ = tokio::time::timeout(Duration::from_secs(1), write).await;
    drop(permit);
}

/// What the connection's service has seen, for the head deadline: requests whose heads were
/// complete, whether one is being answered, whether the connection was upgraded (from then on
/// its bytes are WebSocket frames, not heads), and how many bytes still to be read belong to
/// the body of the request last answered rather than to a new head.
#[derive(Debug, Default)]
struct Heads {
    complete: AtomicU64,
    answering: AtomicBool,
    upgrade: AtomicBool,
    /// Bytes of the last answered request's body that its handler did not take (an early
    /// 401/413 leaves the body unread): hyper drains them after the answer when they are at
    /// hand, and they are not the start of a head. At most what is still on the wire (hyper
    /// may hold some already), so a head's first bytes can be taken for the tail, never the
    /// other way round: the timer may arm late, which leaves a slow head to the idle timeout,
    /// but never for a request that was not started. `u64::MAX`: a body of unknown length
    /// (chunked), whose tail ends at the first read that finds the socket empty
    /// ([`Heads::socket_drained`]).
    tail: AtomicU64,
}

impl Heads {
    fn start(&self, upgrade: bool) {
        self.complete.fetch_add(1, Ordering::Relaxed);
        self.answering.store(true, Ordering::Relaxed);
        self.tail.store(0, Ordering::Relaxed);
        if upgrade {
            self.upgrade.store(true, Ordering::Relaxed);
        }
    }

    /// The request whose body went as `body` says has its answer.
    fn answered(&self, body: &BodyProgress) {
        self.tail.store(body.left(), Ordering::Relaxed);
        self.answering.store(false, Ordering::Relaxed);
    }

    /// A read found the socket empty while no request was being answered. hyper drains an
    /// unread body after its answer only as far as the socket has bytes at hand: past that it
    /// stops reading the connection and closes it after the answer. So a body of unknown length
    /// (chunked) has ended by then, on the wire, one way or the other, and the next byte read
    /// is a head's.
    fn socket_drained(&self) {
        let _ = self
            .tail
            .compare_exchange(u64::MAX, 0, Ordering::Relaxed, Ordering::Relaxed);
    }

    /// Takes `n` bytes just read while no request is being answered: whether any of them start
    /// a head (the rest of the body's tail is used up first).
    fn starts_head(&self, n: u64) -> bool {
        let tail = self.tail.load(Ordering::Relaxed);
        if tail >= n {
            self.tail.store(tail - n, Ordering::Relaxed);
            return false;
        }
        self.tail.store(0, Ordering::Relaxed);
        true
    }
}

/// How much of a request's body its handler took, for [`Heads::tail`].
#[derive(Debug)]
struct BodyProgress {
    /// The declared length (`Content-Length`); `None` for a chunked body.
    declared: Option<u64>,
    delivered: AtomicU64,
    ended: AtomicBool,
}

impl BodyProgress {
    fn of(body: &Incoming) -> BodyProgress {
        use http_body::Body as _;
        BodyProgress {
            declared: body.size_hint().exact(),
            delivered: AtomicU64::new(0),
            ended: AtomicBool::new(body.is_end_stream()),
        }
    }

    /// Body bytes hyper has not handed over: 0 once the body ended; unknown (`u64::MAX`) for
    /// an unfinished chunked one.
    fn left(&self) -> u64 {
        if self.ended.load(Ordering::Relaxed) {
            return 0;
        }
        self.declared.map_or(u64::MAX, |n| {
            n.saturating_sub(self.delivered.load(Ordering::Relaxed))
        })
    }
}

/// A request body that counts what its handler takes ([`BodyProgress`]).
struct Watched {
    body: Incoming,
    progress: Arc<BodyProgress>,
}

impl http_body::Body for Watched {
    type Data = hyper::body::Bytes;
    type Error = hyper::Error;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<http_body::Frame<Self::Data>, Self::Error>>> {
        let p = Pin::new(&mut self.body).poll_frame(cx);
        match &p {
            Poll::Ready(Some(Ok(frame))) => {
                if let Some(data) = frame.data_ref() {
                    self.progress
                        .delivered
                        .fetch_add(data.len() as u64, Ordering::Relaxed);
                }
                if self.body.is_end_stream() {
                    self.progress.ended.store(true, Ordering::Relaxed);
                }
            }
            Poll::Ready(None) => self.progress.ended.store(true, Ordering::Relaxed),
            _ => {}
        }
        p
    }

    fn is_end_stream(&self) -> bool {
        self.body.is_end_stream()
    }

    fn size_hint(&self) -> http_body::SizeHint {
        self.body.size_hint()
    }
}

/// The answer to a head that took longer than `head_timeout` (written straight to the socket:
/// hyper has no request to answer yet).
fn head_timeout_answer(after: Duration) -> Vec<u8> {
    let body = format!(
        "{{\"error\":{{\"code\":\"{code}\",\"message\":\"the request's headers did not arrive within {ms} ms of its first byte (head_timeout_ms)\"}}}}",
        code = ErrorCode::RequestTimeout.as_str(),
        ms = after.as_millis(),
    );
    let status = ErrorCode::RequestTimeout.status();
    format!(
        "HTTP/1.1 {} {}\r\ncontent-type: application/json\r\ncontent-length: {}\r\nconnection: close\r\n\r\n{body}",
        status.as_str(),
        status.canonical_reason().unwrap_or_default(),
        body.len()
    )
    .into_bytes()
}

/// A TCP socket with its [`Slot`] and its place in the per-peer count; reads go straight
/// through, writes too, unless one makes no progress for `stall_after`: then the connection
/// fails with `TimedOut` and hyper drops it. A request head still incomplete `head_after` after
/// its first byte is answered 408 here, and hyper then reads the end of the stream.
struct Counted {
    tcp: TcpStream,
    _slot: Slot,
    _peer: Option<ConnGuard>,
    stall_after: Option<Duration>,
    /// Armed while a write is pending; disarmed by any progress.
    stall: Option<Pin<Box<Sleep>>>,
    heads: Arc<Heads>,
    head_after: Option<Duration>,
    /// Armed at the first byte of a head: a byte read while no request is being answered that
    /// is not the tail of the last one's body ([`Heads::starts_head`]), with the count of
    /// complete heads then; disarmed once that count moves. `Some((_, None))`: fired, answered.
    head: Option<(u64, Option<Pin<Box<Sleep>>>)>,
    demote: Demote,
}

/// Where a connection's offences are reported: its peer, to the slow lane.
struct Demote {
    lane: Arc<SlowLane>,
    peer: std::net::IpAddr,
}

impl Counted {
    /// Arms (or polls) the stall timer for a write that is pending.
    fn stalled(&mut self, cx: &mut Context<'_>) -> Option<std::io::Error> {
        let after = self.stall_after?;
        let timer = self
            .stall
            .get_or_insert_with(|| Box::pin(tokio::time::sleep(after)));
        if timer.as_mut().poll(cx).is_ready() {
            metrics::counter!("swell_http_send_stalls_total").increment(1);
            self.demote
                .lane
                .demote(self.demote.peer, Offence::NotReading);
            return Some(std::io::Error::new(
                std::io::ErrorKind::TimedOut,
                "the client did not read its answer (http_send_stall_ms)",
            ));
        }
        None
    }

    fn progress<T>(
        &mut self,
        cx: &mut Context<'_>,
        p: Poll<std::io::Result<T>>,
    ) -> Poll<std::io::Result<T>> {
        match p {
            Poll::Pending => match self.stalled(cx) {
                Some(e) => Poll::Ready(Err(e)),
                None => Poll::Pending,
            },
            ready => {
                self.stall = None;
                ready
            }
        }
    }
}

impl Counted {
    /// The head deadline around a read that returned `p` (`got`: bytes it read).
    fn head_deadline(
        &mut self,
        cx: &mut Context<'_>,
        p: Poll<std::io::Result<()>>,
        got: usize,
    ) -> Poll<std::io::Result<()>> {
        let Some(after) = self.head_after else {
            return p;
        };
        if self.heads.upgrade.load(Ordering::Relaxed) {
            self.head = None;
            return p;
        }
        let complete = self.heads.complete.load(Ordering::Relaxed);
        if let Some((n, Some(_))) = &self.head
            && *n != complete
        {
            self.head = None; // that head arrived
        }
        if matches!(self.head, Some((_, None))) {
            // Answered 408: the stream ends here for hyper.
            return Poll::Ready(Ok(()));
        }
        let answering = self.heads.answering.load(Ordering::Relaxed);
        if p.is_pending() && !answering {
            self.heads.socket_drained();
        }
        if got > 0 && self.head.is_none() && !answering && self.heads.starts_head(got as u64) {
            self.head = Some((complete, Some(Box::pin(tokio::time::sleep(after)))));
        }
        if let (Poll::Pending, Some((_, Some(timer)))) = (&p, &mut self.head)
            && timer.as_mut().poll(cx).is_ready()
        {
            metrics::counter!("swell_http_head_timeouts_total").increment(1);
            self.demote.lane.demote(self.demote.peer, Offence::SlowHead);
            // Best effort: a client that does not read cannot hold us here.
            let _ = self.tcp.try_write(&head_timeout_answer(after));
            self.head = Some((complete, None));
            return Poll::Ready(Ok(()));
        }
        p
    }
}

impl AsyncRead for Counted {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<std::io::Result<()>> {
        let this = self.get_mut();
        let before = buf.filled().len();
        let p = Pin::new(&mut this.tcp).poll_read(cx, buf);
        let got = buf.filled().len() - before;
        this.head_deadline(cx, p, got)
    }
}

impl AsyncWrite for Counted {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<std::io::Result<usize>> {
        let this = self.get_mut();
        let p = Pin::new(&mut this.tcp).poll_write(cx, buf);
        this.progress(cx, p)
    }

    fn poll_write_vectored(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[std::io::IoSlice<'_>],
    ) -> Poll<std::io::Result<usize>> {
        let this = self.get_mut();
        let p = Pin::new(&mut this.tcp).poll_write_vectored(cx, bufs);
        this.progress(cx, p)
    }

    fn is_write_vectored(&self) -> bool {
        self.tcp.is_write_vectored()
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.get_mut().tcp).poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.get_mut().tcp).poll_shutdown(cx)
    }
}

fn log_end(r: Result<(), hyper::Error>, remote: std::net::SocketAddr) {
    if let Err(e) = r {
        // A client that went away, a malformed request or the idle timeout: the connection's
        // business, not the server's.
        tracing::trace!(%remote, error = %e, "connection ended");
    }
}

/// What `axum::serve` does with an accept error: a connection that failed before it was
/// accepted is skipped; anything else (out of file descriptors, out of memory) waits a moment
/// for resources to free up.
async fn accept_error(e: &std::io::Error) {
    use std::io::ErrorKind::{ConnectionAborted, ConnectionRefused, ConnectionReset};
    if matches!(
        e.kind(),
        ConnectionRefused | ConnectionAborted | ConnectionReset
    ) {
        return;
    }
    tracing::error!(error = %e, "accept failed; retrying in 1 s");
    tokio::time::sleep(Duration::from_secs(1)).await;
}
