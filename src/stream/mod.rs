//! The WebSocket stream `GET /v1/scenes/{id}/stream`: queries on a socket, clock sync and tick
//! frames.
//!
//! - [`messages`] — the messages and their two codecs (`swell.v1.json`, `swell.v1.protobuf`).
//! - [`frame`] — a tick frame shared by every subscriber, each body state encoded once per
//!   codec and each subscriber's frame assembled from those bytes.
//! - [`ticks`] — the per-scene tick loop; it puts in each frame the floating bodies' states the
//!   body loop ([`crate::state::bodies`], the only stepping path) published for its tick.
//!
//! # A session
//! One task reads the socket and answers requests; a writer task sends what the session queues
//! on a bounded queue ([`crate::Limits::ws_send_queue`] entries): answers, errors and
//! subscription changes. Tick frames do not pass through either: while subscribed, the socket
//! is one of its scene's [fan-out](fanout) shard's, whose task writes each frame straight to the
//! socket when it has room (a tick costs a few task wakes, not one per subscriber). A frame the
//! socket has no room for is left to the writer, and newer ones replace it until the writer has
//! sent it. Answers go into the queue with `try_send`, so nothing in the server ever waits on a
//! client's socket: when the queue is full, or one message (or a frame left to the writer)
//! takes longer than [`crate::Limits::ws_send_stall_ms`] to be written to the socket, the client
//! is not reading and is disconnected, without delaying anyone else's ticks (the tick loop and
//! the shards never wait either; a socket that falls behind skips to the newest frame).
//!
//! Queries run as in HTTP ([`crate::service::query::run_sample`] etc.: inline when cheap, else on a
//! blocking thread, see [`crate::service::query::runs_inline`]), a few at a time per socket, each answering into the queue when done (answers carry the request's
//! `id`, and may come back in a different order than asked). Every message is checked for
//! non-finite numbers on its way into the queue ([`messages::Outgoing::finite_or_error`]).
//!
//! A message (or frame) over [`crate::Limits::ws_max_message_bytes`] ends the session with Close
//! 1009 (message too big): tungstenite refuses it on read, and the session queues the Close
//! frame before the socket drops.
//!
//! # Hygiene
//! The handshake's `Sec-WebSocket-Key` must be base64 of 16 bytes (400 otherwise). A session
//! that receives nothing for [`crate::Limits::ws_idle_timeout_ms`] is pinged at half of it and
//! closed (1001) at the end. A client over [`crate::Limits::ws_messages_per_s`] gets a
//! `rate_limited` error for each message over; one that keeps going past twice the burst is
//! closed (1008). Protocol violations close with RFC 6455's codes: 1002 (unmasked frames,
//! reserved bits or opcodes, bad control frames, stray continuations), 1007 (text that is not
//! UTF-8), 1009 (too big). A client that stops reading is sent Close 1008 if the socket takes
//! it, and its unread messages are drained for a moment first, so the connection ends with a
//! FIN rather than a reset.
//!
//! # A deleted scene
//! A session subscribed to a scene that is deleted gets a `not_found` error (no id), then Close
//! [`SCENE_GONE`] (4404) with the reason: reconnecting to the same URL would be refused with 404,
//! and the clients stop there instead of retrying. A session not subscribed learns of it from
//! its next request's `not_found`.
//!
//! # Clock changes
//! Every session hears of every change to its scene's clock ([`AppState::replace_clock`]: a
//! local admin change, or in a fleet the change arriving through the shared feed; and a put
//! that moves the scene's epoch, [`AppState::announce_clock_change`]) and sends a
//! `clock` event (no id) with the clock's reading, generation included, at once. Pongs carry the
//! rate, pause flag and generation too, so a client that misses the event still restarts its
//! clock fit at the next pong.
//!
//! A running clock that reaches ±`limits.max_time` holds there, reading as paused
//! ([`crate::scene::clock`]), with no change to announce: the hold is a pure function of the
//! clock record and the time. So each session times it itself (`ClockWatch`: one timer, armed
//! at each change for the moment the hold starts or ends, no work per tick) and sends one
//! `clock` event, the same reading an admin change's would be (`paused: true`, `t` exactly the
//! limit, the generation unchanged), each time the clock starts holding (or, for a record beyond
//! the limit, stops). Every process does the same from the same record, so in a fleet the
//! sessions of every replica hear of it.
//!
//! # Shutdown
//! Each session watches the server's shutdown token ([`shutdown`](crate::state::Inner::shutdown) field): when it
//! fires, the session queues a Close frame (1001, going away), lets the writer flush it (up to
//! [`CLOSE_GRACE`]) and ends. axum's graceful shutdown does not close upgraded connections on its
//! own.

pub mod compact;
pub mod fanout;
pub mod frame;
pub mod messages;
pub mod registry;
pub mod ticks;

use std::net::IpAddr;
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;

use axum::body::Bytes;
use axum::extract::ws::rejection::WebSocketUpgradeRejection;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade, close_code};
use axum::extract::{Path, State};
use axum::http::{HeaderMap, header};
use axum::response::Response;
use futures_util::{FutureExt as _, Sink, Stream, StreamExt};
use tokio::sync::{Semaphore, broadcast, mpsc};
use tokio_util::sync::CancellationToken;

use crate::error::{ApiError, ErrorCode};
use crate::lanes::Offence;
use crate::peers::{Budget, Charge};
use crate::scene::Clock;
use crate::service::error::QueryError;
use crate::service::json::DECODE_OFF_REACTOR_BYTES;
use crate::service::query::{
    At, orientation_probes, orientation_request_bytes, resolve_time, run_orientation, run_sample,
    runs_inline, sample_request_bytes,
};
use crate::state::AppState;
use fanout::Ticks;
use frame::{Interest, SharedTick};
use messages::{
    Codec, DecodeError, Event, Incoming, JSON_PROTOCOL, Outgoing, PROTOBUF_PROTOCOL, Request,
};

/// Queries one socket may have running at once; more are answered with an `overloaded` error
/// at once. Bounds the CPU one client can hold, like `max_in_flight` does for HTTP.
const QUERIES_PER_SESSION: usize = 8;

/// How long a closing session waits for its writer to flush the Close frame (a client that does
/// not read may never let it through).
pub const CLOSE_GRACE: Duration = Duration::from_secs(2);

/// How long a writer tries to send Close 1008 to a client that stopped reading.
const SLOW_CLOSE_TRY: Duration = Duration::from_millis(500);

/// How long a session drains the messages of a client it drops for not reading, so the socket
/// closes with a FIN, not a reset (closing with unread bytes makes the kernel send RST).
const DRAIN_FOR: Duration = Duration::from_millis(500);

/// Picks the subprotocol: the first the client offers that we speak, JSON when it offers none.
///
/// # Errors
/// 400 `unsupported_subprotocol` when the client offers only protocols we do not speak.
fn negotiate(headers: &HeaderMap) -> Result<Option<Codec>, ApiError> {
    let offered: Vec<String> = headers
        .get_all(header::SEC_WEBSOCKET_PROTOCOL)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .map(|p| p.trim().to_owned())
        .filter(|p| !p.is_empty())
        .collect();
    if offered.is_empty() {
        return Ok(None);
    }
    for p in &offered {
        match p.as_str() {
            JSON_PROTOCOL => return Ok(Some(Codec::Json)),
            PROTOBUF_PROTOCOL => return Ok(Some(Codec::Protobuf)),
            _ => {}
        }
    }
    Err(ApiError::new(
        ErrorCode::UnsupportedSubprotocol,
        format!(
            "none of the offered subprotocols ({}) is spoken here; use {JSON_PROTOCOL} or {PROTOBUF_PROTOCOL}",
            offered.join(", ")
        ),
    ))
}

/// Read buffer of a stream's socket, bytes. tungstenite allocates it per connection and zeroes
/// all of it before every read (128 KiB by default: 128 MiB resident for 1,000 subscribers, and
/// two 128 KiB memsets per message received). A client sends small control messages (subscribe,
/// ping); longer ones, up to `ws_max_message_bytes`, take a few reads.
pub const WS_READ_BUFFER_BYTES: usize = 8 * 1024;

/// `GET /v1/scenes/{id}/stream`: 404 for an unknown scene and 400 for a plain GET or an unknown
/// subprotocol, all before the upgrade.
pub async fn stream(
    State(state): State<AppState>,
    Path(id): Path<String>,
    peer: Option<axum::Extension<crate::peers::PeerAddr>>,
    headers: HeaderMap,
    ws: Result<WebSocketUpgrade, WebSocketUpgradeRejection>,
) -> Result<Response, ApiError> {
    state.scene(&id)?;
    check_key(&headers)?;
    // The client (through trusted proxies); `None` for an exempt one (loopback by default:
    // load tests, sidecars), which has no message rate and no share of the byte budget of its
    // own.
    let client = peer
        .map(|p| state.peer_policy.client(p.0.0.ip(), &headers))
        .filter(|c| !state.peer_policy.exempt.contains(*c));
    let tcp_peer = peer.map(|p| p.0.0.ip());
    let ws = ws.map_err(|r| {
        ApiError::new(ErrorCode::WebsocketRequired, format!(
                "this endpoint is a WebSocket (subprotocols {JSON_PROTOCOL}, {PROTOBUF_PROTOCOL}): {}",
                r.body_text()
            ),
        )
    })?;
    let offered = negotiate(&headers)?;
    let codec = offered.unwrap_or(Codec::Json);
    let limit = state.limits.ws_max_message_bytes;
    let mut ws = ws
        .max_message_size(limit)
        .max_frame_size(limit)
        // Write each message out at once: a game stream wants latency, not batching.
        .write_buffer_size(0)
        .read_buffer_size(WS_READ_BUFFER_BYTES);
    if let Some(c) = offered {
        // Echo exactly the protocol chosen (the client must see it to accept the upgrade).
        ws = ws.protocols([match c {
            Codec::Json => JSON_PROTOCOL,
            Codec::Protobuf => PROTOBUF_PROTOCOL,
        }]);
    }
    // The session is tracked: shutdown waits for its Close to go out before the final snapshot.
    let tasks = state.tasks.clone();
    Ok(ws.on_upgrade(move |socket: WebSocket| {
        tasks.track_future(async move {
            let (sink, stream) = socket.split();
            // Its large decodes take their turn on the compute pool as this client's.
            let lane = Arc::clone(&state.slow_lane);
            let offence =
                crate::compute::for_client(client, session(state, id, codec, client, sink, stream))
                    .await;
            if let (Some(o), Some(p)) = (offence, tcp_peer) {
                lane.demote(p, o);
            }
        })
    }))
}

/// Checks `Sec-WebSocket-Key` (RFC 6455 §4.1: base64 of 16 random bytes), when the request is
/// an upgrade at all (a plain GET is answered `websocket_required` by the upgrade extractor).
///
/// # Errors
/// 400 `bad_websocket_key` naming what is wrong.
fn check_key(headers: &HeaderMap) -> Result<(), ApiError> {
    let Some(key) = headers.get(header::SEC_WEBSOCKET_KEY) else {
        return Ok(());
    };
    if valid_key(key.as_bytes()) {
        Ok(())
    } else {
        Err(ApiError::new(
            ErrorCode::BadWebsocketKey,
            "Sec-WebSocket-Key must be the base64 of 16 bytes (24 characters ending in ==)",
        )
        .with_field("Sec-WebSocket-Key"))
    }
}

/// Whether `key` is the canonical base64 of 16 bytes: 22 alphabet characters, `==`, and no
/// bits set past the 128th in the last character.
fn valid_key(key: &[u8]) -> bool {
    fn value(c: u8) -> Option<u8> {
        match c {
            b'A'..=b'Z' => Some(c - b'A'),
            b'a'..=b'z' => Some(c - b'a' + 26),
            b'0'..=b'9' => Some(c - b'0' + 52),
            b'+' => Some(62),
            b'/' => Some(63),
            _ => None,
        }
    }
    if key.len() != 24 || &key[22..] != b"==" {
        return false;
    }
    let Some(values) = key[..22]
        .iter()
        .map(|&c| value(c))
        .collect::<Option<Vec<u8>>>()
    else {
        return false;
    };
    // 22 characters carry 132 bits; the last 4 must be zero for exactly 16 bytes.
    values[21] & 0x0f == 0
}

/// Why a session ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum End {
    /// The client closed or the connection dropped.
    Client,
    /// The client sent a message or frame over `ws_max_message_bytes`: answered with Close
    /// 1009 (message too big).
    TooBig,
    /// The send queue overflowed: the client stopped reading.
    SlowConsumer,
    /// The server is shutting down.
    Shutdown,
    /// Nothing received for `ws_idle_timeout_ms`: Close 1001.
    Idle,
    /// A protocol violation: Close 1002, or 1007 for text that is not UTF-8.
    Protocol(u16),
    /// Kept sending past the message rate: Close 1008.
    Flood,
    /// The scene was deleted while the session was subscribed: Close [`SCENE_GONE`].
    SceneGone,
}

/// The Close code of a session whose scene was deleted while it was subscribed (an application
/// code, RFC 6455's 4000–4999; 4404 reads as "not found"). After the `not_found` error (no id),
/// so a client knows not to reconnect to the same URL: the upgrade would be refused with 404.
pub const SCENE_GONE: u16 = 4404;

/// What a session hands its writer, in order: a message to send, or a change of the tick
/// subscription (so a `subscribe` answered before a frame takes effect in that order too).
enum Out {
    Message(Message),
    /// A large answer and its charge on the byte budget, given back once it is sent.
    Answer(Message, Charge),
    /// Follow the scene's ticks with this interest. The hold on the scene's loop is used only
    /// when the writer follows none (an existing one keeps its place in the stream: no frame is
    /// lost to an interest change).
    Subscribe(Ticks, Interest),
    /// Stop following ticks.
    Unsubscribe,
}

/// The sending side of a session: encodes and queues, never waits.
#[derive(Clone)]
struct Queue {
    tx: mpsc::Sender<Out>,
    codec: Codec,
    /// Fired when the queue overflows; the session then drops the client.
    slow: CancellationToken,
    /// The server's byte budget ([`AppState::buffers`]): large queries' work and answers, until
    /// sent.
    budget: Arc<Budget>,
    /// Whose share the bytes come from (`None`: an exempt client, charged to the total only).
    client: Option<IpAddr>,
    /// This session's tick shard, the same for every subscription ([`fanout::TickLoop::hold`]).
    slot: usize,
}

/// Sessions started, for their tick shards: round robin.
static SESSIONS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// Answers of at least this many bytes are charged to the budget until sent; smaller ones are
/// bounded by the queue's length.
const CHARGED_ANSWER_BYTES: usize = 64 * 1024;

impl Queue {
    /// Charges `n` bytes for a query's work and answer, or queues the `overloaded` error that
    /// says which budget it would exceed.
    fn reserve(&self, id: Option<u64>, n: usize) -> Option<Charge> {
        let mut c = self.budget.charge(self.client);
        match c.reserve(n) {
            Ok(()) => Some(c),
            Err(e) => {
                self.error(id, e.into());
                None
            }
        }
    }

    /// [`Queue::push`] for a query's answer: the charge its work held becomes the encoded
    /// message's size, held until the writer has sent it.
    fn push_answer(&self, out: Outgoing, charge: Charge) {
        let id = out.id;
        self.push_encoded_answer(id, encode(self.codec, out.finite_or_error()), charge);
    }

    /// [`Queue::push_answer`] for an answer already encoded (on the compute pool).
    fn push_encoded_answer(&self, id: Option<u64>, m: Message, mut charge: Charge) {
        let len = match &m {
            Message::Text(t) => t.len(),
            Message::Binary(b) => b.len(),
            _ => 0,
        };
        if len < CHARGED_ANSWER_BYTES {
            drop(charge);
            return self.push_out(Out::Message(m));
        }
        match charge.resize(len) {
            Ok(()) => self.push_out(Out::Answer(m, charge)),
            Err(which) => {
                drop((m, charge));
                self.error(id, which.into());
            }
        }
    }

    /// Encodes and queues `out`, after the non-finite check every answer passes
    /// ([`Outgoing::finite_or_error`]).
    fn push(&self, out: Outgoing) {
        let out = out.finite_or_error();
        self.push_out(Out::Message(encode(self.codec, out)));
    }

    /// Queues `out`; a full queue means the client is not reading: the session drops it.
    fn push_out(&self, out: Out) {
        if let Err(mpsc::error::TrySendError::Full(_)) = self.tx.try_send(out) {
            self.slow.cancel();
        }
    }

    fn error(&self, id: Option<u64>, e: ApiError) {
        self.push(Outgoing {
            id,
            event: Event::Error(e),
        });
    }
}

/// The writer's view of the session: what to say when the scene goes away and when to give up
/// on the client (the socket knows its codec).
struct Writer {
    scene_id: String,
    shutdown: CancellationToken,
    /// Fired when the scene's tick loop ended because the scene was deleted.
    gone: CancellationToken,
    /// Fired when one message waits `stall` for the socket; the session then drops the client.
    slow: CancellationToken,
    /// [`crate::Limits::ws_send_stall_ms`].
    stall: Duration,
}

/// A session's subscription: its hold on the scene's tick loop, and the loop's end.
struct Following {
    _ticks: Ticks,
    ended: Pin<Box<tokio_util::sync::WaitForCancellationFutureOwned>>,
}

/// Fires when the followed loop ends; pending forever while following none.
async fn loop_ended(sub: &mut Option<Following>) {
    match sub {
        Some(s) => (&mut s.ended).await,
        None => std::future::pending().await,
    }
}

impl Writer {
    /// Sends queued messages until the queue closes (then closes the socket) or a send fails
    /// or stalls; while subscribed, the scene's shards write its tick frames to the same socket
    /// ([`Socket`]), and this task sends only the frames they could not (a socket without room)
    /// and says so when the scene's loop ends.
    async fn run<W>(self, socket: Arc<Socket<W>>, mut rx: mpsc::Receiver<Out>)
    where
        W: Sink<Message> + Unpin + Send + 'static,
    {
        let mut sub: Option<Following> = None;
        // Armed once, not once per message: a fresh wait per loop locks the token and registers
        // and drops a waiter.
        let slow = self.slow.clone().cancelled_owned();
        tokio::pin!(slow);
        loop {
            // A large answer's charge, given back when it has been sent (or dropped).
            let mut _held: Option<Charge> = None;
            // Biased: answers and subscription changes in the order queued, before a frame the
            // shards left for this task.
            let msg = tokio::select! {
                biased;
                // The queue overflowed: the client is not reading.
                () = &mut slow => return self.not_reading(&socket).await,
                out = rx.recv() => match out {
                    None => break,
                    Some(Out::Message(m)) => Some(m),
                    Some(Out::Answer(m, c)) => {
                        _held = Some(c);
                        Some(m)
                    }
                    Some(Out::Subscribe(mut fresh, interest)) => {
                        socket.set_interest(interest);
                        if sub.is_none() {
                            socket.follow(true);
                            fresh.follow(Arc::clone(&socket) as Arc<dyn fanout::Follow>);
                            sub = Some(Following {
                                ended: Box::pin(fresh.ended()),
                                _ticks: fresh,
                            });
                        }
                        continue;
                    }
                    Some(Out::Unsubscribe) => {
                        socket.follow(false);
                        sub = None;
                        continue;
                    }
                },
                // A frame the socket had no room for, or a write to finish.
                () = socket.wake.notified() => None,
                () = loop_ended(&mut sub) => {
                    socket.follow(false);
                    sub = None;
                    if self.shutdown.is_cancelled() {
                        continue;
                    }
                    let out = Outgoing {
                        id: None,
                        event: Event::Error(ApiError::scene_not_found(&self.scene_id)),
                    };
                    // The session then closes the socket (SCENE_GONE), after this error.
                    self.gone.cancel();
                    Some(encode(socket.codec, out))
                },
            };
            let is_close = matches!(msg, Some(Message::Close(_)));
            if is_close {
                // Nothing after the Close frame.
                socket.follow(false);
            }
            // Almost every send completes at once (the socket has room): the stall timer is
            // armed only for one that does not.
            let mut msg = msg;
            let sent = {
                let mut send = std::future::poll_fn(|cx| socket.poll_send(&mut msg, cx));
                let first = std::future::poll_fn(|cx| Poll::Ready(send.poll_unpin(cx))).await;
                match first {
                    Poll::Ready(ok) => Ok(ok),
                    Poll::Pending => tokio::select! {
                        r = tokio::time::timeout(self.stall, send) => r.map_err(|_| ()),
                        () = &mut slow => Err(()),
                    },
                }
            };
            match sent {
                Ok(true) if !is_close => {}
                Ok(_) => return,
                Err(()) => return self.not_reading(&socket).await,
            }
        }
        socket.follow(false);
        let _ = std::future::poll_fn(|cx| socket.poll_close(cx)).await;
    }

    /// The client stopped reading (a send stalled, or the queue overflowed): tells the session
    /// and tries, briefly, to say so with Close 1008 (the socket may have no room for it).
    async fn not_reading<W>(self, socket: &Socket<W>)
    where
        W: Sink<Message> + Unpin,
    {
        self.slow.cancel();
        socket.follow(false);
        let mut close = Some(Message::Close(Some(CloseFrame {
            code: close_code::POLICY,
            reason: "not reading what the server sends".into(),
        })));
        let _ = tokio::time::timeout(
            SLOW_CLOSE_TRY,
            std::future::poll_fn(|cx| socket.poll_send(&mut close, cx)),
        )
        .await;
    }
}

/// A session's socket, shared by its writer task and the shard of the scene's tick loop that
/// writes its frames ([`fanout`]). Every write happens under the lock, in one piece (ready,
/// send, flush), so the two never interleave within a message.
struct Socket<W> {
    inner: std::sync::Mutex<SocketState<W>>,
    codec: Codec,
    /// Wakes the writer: a frame waits in [`SocketState::held`], or a write to finish.
    wake: tokio::sync::Notify,
}

struct SocketState<W> {
    sink: W,
    interest: Interest,
    /// Whether frames are wanted (subscribed, and no Close sent).
    following: bool,
    /// A write did not finish at once: the writer task finishes it (its waker is the one the
    /// socket wakes), and the shard leaves the socket alone until then.
    busy: bool,
    /// The newest frame the shard could not write, for the writer to send.
    held: Option<Message>,
    /// The socket failed: nothing more is written.
    failed: bool,
}

impl<W: Sink<Message> + Unpin> Socket<W> {
    fn new(sink: W, codec: Codec) -> Self {
        Socket {
            inner: std::sync::Mutex::new(SocketState {
                sink,
                interest: Interest::default(),
                following: false,
                busy: false,
                held: None,
                failed: false,
            }),
            codec,
            wake: tokio::sync::Notify::new(),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, SocketState<W>> {
        // The state is consistent between statements: a panic elsewhere leaves it usable.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn set_interest(&self, interest: Interest) {
        self.lock().interest = interest;
    }

    /// Starts or stops taking frames; stopping drops a frame still held.
    fn follow(&self, on: bool) {
        let mut s = self.lock();
        s.following = on;
        if !on {
            s.held = None;
        }
    }

    /// Writes a frame the shard left (if any), then `msg` (if any), then flushes. Ready(true)
    /// when all is written, Ready(false) when the socket failed. The caller's waker is the one
    /// the socket will wake; until the write finishes the shard leaves the socket alone.
    fn poll_send(&self, msg: &mut Option<Message>, cx: &mut Context<'_>) -> Poll<bool> {
        let mut guard = self.lock();
        let s = &mut *guard;
        if s.failed {
            return Poll::Ready(false);
        }
        for slot in [&mut s.held, msg] {
            if slot.is_none() {
                continue;
            }
            match Pin::new(&mut s.sink).poll_ready(cx) {
                Poll::Pending => {
                    s.busy = true;
                    return Poll::Pending;
                }
                Poll::Ready(Err(_)) => {
                    s.failed = true;
                    return Poll::Ready(false);
                }
                Poll::Ready(Ok(())) => {}
            }
            if let Some(m) = slot.take()
                && Pin::new(&mut s.sink).start_send(m).is_err()
            {
                s.failed = true;
                return Poll::Ready(false);
            }
        }
        match Pin::new(&mut s.sink).poll_flush(cx) {
            Poll::Pending => {
                s.busy = true;
                Poll::Pending
            }
            Poll::Ready(r) => {
                s.busy = false;
                s.failed |= r.is_err();
                Poll::Ready(r.is_ok())
            }
        }
    }

    fn poll_close(&self, cx: &mut Context<'_>) -> Poll<()> {
        let mut s = self.lock();
        if s.failed {
            return Poll::Ready(());
        }
        Pin::new(&mut s.sink).poll_close(cx).map(|_| ())
    }
}

impl<W: Sink<Message> + Unpin + Send + 'static> fanout::Follow for Socket<W> {
    fn offer(&self, tick: &SharedTick, chosen: &mut Vec<usize>) -> fanout::Offered {
        use fanout::Offered;
        let mut guard = self.lock();
        let s = &mut *guard;
        if !s.following || s.failed {
            return Offered::Done;
        }
        // Encoded once per frame and shared (see `frame`): only the subscriber's own selection
        // of pre-encoded body states is assembled here.
        let m = tick.message_with(self.codec, &s.interest, chosen);
        if s.busy || s.held.is_some() {
            // The writer is finishing a write: this frame waits for it, replacing an older one.
            return match s.held.replace(m) {
                Some(_) => Offered::Replaced,
                None => Offered::HandedOff,
            };
        }
        // Never waits: a socket without room hands the frame to the writer task, which waits
        // with its own waker (a no-op waker here wakes nobody).
        let mut cx = Context::from_waker(std::task::Waker::noop());
        match Pin::new(&mut s.sink).poll_ready(&mut cx) {
            Poll::Ready(Ok(())) => {}
            Poll::Ready(Err(_)) => {
                s.failed = true;
                return Offered::Done;
            }
            Poll::Pending => {
                s.held = Some(m);
                s.busy = true;
                drop(guard);
                self.wake.notify_one();
                return Offered::HandedOff;
            }
        }
        if Pin::new(&mut s.sink).start_send(m).is_err() {
            s.failed = true;
            return Offered::Done;
        }
        match Pin::new(&mut s.sink).poll_flush(&mut cx) {
            Poll::Ready(r) => {
                s.failed |= r.is_err();
                Offered::Done
            }
            Poll::Pending => {
                s.busy = true;
                drop(guard);
                self.wake.notify_one();
                Offered::HandedOff
            }
        }
    }
}

/// `out` encoded for `codec` (JSON text or protobuf binary).
fn encode(codec: Codec, out: Outgoing) -> Message {
    match codec {
        Codec::Json => Message::Text(messages::encode_json(&out).into()),
        Codec::Protobuf => Message::Binary(messages::encode_protobuf(out).into()),
    }
}

/// Runs one session over any message sink and stream (a real socket, or channels in tests).
/// `client` is the client's address, `None` for an exempt one ([`crate::Limits::exempt_peers`]):
/// no message rate limit, and its bytes count to the server's total budget only.
///
/// Returns the client's offence, if the session ended for one: Close 1008 for its message rate
/// or for not reading (the caller demotes its peer to the slow lane).
pub async fn session<W, R>(
    state: AppState,
    scene_id: String,
    codec: Codec,
    client: Option<IpAddr>,
    sink: W,
    mut stream: R,
) -> Option<Offence>
where
    W: Sink<Message> + Unpin + Send + 'static,
    R: Stream<Item = Result<Message, axum::Error>> + Unpin,
{
    metrics::gauge!("swell_ws_sessions").increment(1.0);
    metrics::counter!("swell_ws_sessions_total").increment(1);
    let (tx, rx) = mpsc::channel(state.limits.ws_send_queue.max(1));
    let queue = Queue {
        tx,
        codec,
        slow: CancellationToken::new(),
        budget: Arc::clone(&state.buffers),
        client,
        slot: SESSIONS.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
    };
    let shutdown = state.shutdown.clone();
    let slow = queue.slow.clone();
    let gone = CancellationToken::new();
    let mut writer = state.tasks.spawn(
        Writer {
            scene_id: scene_id.clone(),
            shutdown: shutdown.clone(),
            gone: gone.clone(),
            slow: slow.clone(),
            stall: state.limits.ws_send_stall(),
        }
        .run(Arc::new(Socket::new(sink, codec)), rx),
    );
    let permits = Arc::new(Semaphore::new(QUERIES_PER_SESSION));
    let mut subscribed = false;
    let idle = state.limits.ws_idle_timeout();
    let mut last_heard = tokio::time::Instant::now();
    let mut pinged = false;
    let mut check = ReadCheck::new(state.limits.ws_read_check(), last_heard);
    let mut rate = MessageRate::new(
        if client.is_none() {
            0.0
        } else {
            state.limits.ws_messages_per_s
        },
        state.limits.ws_messages_burst,
    );
    // Clock changes of any scene ([`crate::state::Inner::clock_changes`]); this session tells
    // its client about its own scene's, once per change it sees, and when its clock starts or
    // stops holding at the time limit ([`ClockWatch`]).
    let mut clock_changes = state.clock_changes.subscribe();
    let mut clock_watch = ClockWatch::new(&state, &scene_id);
    let end = loop {
        // Pinged at half the idle timeout, closed at the end of it; the read check's pings and
        // deadlines; and the next look at the clock's hold.
        let idle_wake = idle.map(|d| last_heard + if pinged { d } else { d / 2 });
        let wake = [idle_wake, check.wake(), clock_watch.next]
            .into_iter()
            .flatten()
            .min();
        // Biased: shutdown and overflow win over more work. (Ticks are the writer's: see
        // `Writer::run`.)
        tokio::select! {
            biased;
            () = shutdown.cancelled() => break End::Shutdown,
            () = slow.cancelled() => break End::SlowConsumer,
            () = gone.cancelled() => break End::SceneGone,
            () = sleep_until(wake) => {
                let now = tokio::time::Instant::now();
                if clock_watch.next.is_some_and(|at| at <= now) {
                    clock_watch.tell(&state, &scene_id, &queue, false);
                }
                match check.poll(now) {
                    Err(Behind) => {
                        // The writer says why (Close 1008) before the session drops the client;
                        // counted as a slow consumer too.
                        metrics::counter!("swell_ws_read_check_disconnects_total").increment(1);
                        queue.slow.cancel();
                        break End::SlowConsumer;
                    }
                    Ok(Some(ping)) => queue.push_out(Out::Message(ping)),
                    Ok(None) => {}
                }
                if idle_wake.is_some_and(|at| at <= now) {
                    if pinged {
                        break End::Idle;
                    }
                    pinged = true;
                    queue.push_out(Out::Message(Message::Ping(Bytes::from_static(b"swell"))));
                }
            }
            changed = clock_changes.recv() => match changed {
                Ok(scene) if *scene == *scene_id => clock_watch.tell(&state, &scene_id, &queue, true),
                Ok(_) => {}
                // Missed some: one of them may have been this scene's.
                Err(broadcast::error::RecvError::Lagged(_)) => {
                    clock_watch.tell(&state, &scene_id, &queue, true);
                }
                // The state holds the sender for as long as any session runs.
                Err(broadcast::error::RecvError::Closed) => break End::Shutdown,
            },
            msg = stream.next() => {
                last_heard = tokio::time::Instant::now();
                pinged = false;
                let decoded = match msg {
                    Some(Err(e)) if too_big(&e) => break End::TooBig,
                    Some(Err(e)) if violation(&e).is_some() => {
                        break End::Protocol(violation(&e).unwrap_or(close_code::PROTOCOL));
                    }
                    None | Some(Err(_)) | Some(Ok(Message::Close(_))) => break End::Client,
                    // Control frames: tungstenite answers pings itself.
                    Some(Ok(Message::Ping(_))) => continue,
                    Some(Ok(Message::Pong(p))) => {
                        check.pong(&p, tokio::time::Instant::now());
                        continue;
                    }
                    Some(Ok(_)) if !rate.allow(std::time::Instant::now()) => {
                        if rate.flooding() {
                            break End::Flood;
                        }
                        metrics::counter!("swell_ws_rate_limited_total").increment(1);
                        queue.error(None, ApiError::new(ErrorCode::RateLimited, format!(
                                "more than {} messages a second on this socket (ws_messages_per_s); this one was dropped",
                                state.limits.ws_messages_per_s
                            ),
                        ));
                        continue;
                    }
                    // A large message (a big sample) is decoded on the compute pool, as HTTP
                    // bodies are (`DECODE_OFF_REACTOR_BYTES`): this session waits for it, the
                    // other connections on this reactor thread do not.
                    Some(Ok(Message::Text(t))) => match codec {
                        Codec::Json if t.len() >= DECODE_OFF_REACTOR_BYTES => {
                            off_reactor(move || messages::decode_json(t.as_str())).await
                        }
                        Codec::Json => messages::decode_json(t.as_str()),
                        Codec::Protobuf => Err(wrong_frame("text", PROTOBUF_PROTOCOL, "binary")),
                    },
                    Some(Ok(Message::Binary(b))) => match codec {
                        Codec::Protobuf if b.len() >= DECODE_OFF_REACTOR_BYTES => {
                            off_reactor(move || messages::decode_protobuf(&b)).await
                        }
                        Codec::Protobuf => messages::decode_protobuf(&b),
                        Codec::Json => Err(wrong_frame("binary", JSON_PROTOCOL, "text")),
                    },
                };
                match decoded {
                    Ok(m) => handle(&state, &scene_id, &queue, &permits, &mut subscribed, m),
                    Err(DecodeError { id, error }) => queue.error(id, error),
                }
            }
        }
    };
    let offence = match end {
        End::SlowConsumer => Some(Offence::WsNotReading),
        End::Flood => Some(Offence::WsRate),
        _ => None,
    };
    // Unsubscribe first, so the tick loop can stop if this was its last subscriber (a writer
    // still flushing its queue sends no more frames).
    if subscribed {
        queue.push_out(Out::Unsubscribe);
    }
    match end {
        End::SlowConsumer => {
            // The writer tries Close 1008 (the socket may have no room). Meanwhile read and
            // drop what the client sent, so the socket closes with a FIN rather than a reset.
            metrics::counter!("swell_ws_slow_consumer_disconnects_total").increment(1);
            tracing::info!(scene = %scene_id, "disconnecting a WebSocket client that stopped reading");
            drop(queue);
            let drain = async {
                while let Ok(Some(Ok(_))) = tokio::time::timeout(DRAIN_FOR, stream.next()).await {}
            };
            let _ = tokio::time::timeout(CLOSE_GRACE, async {
                let _ = tokio::join!(drain, &mut writer);
            })
            .await;
            writer.abort();
        }
        End::Shutdown
        | End::Client
        | End::TooBig
        | End::Idle
        | End::Protocol(_)
        | End::Flood
        | End::SceneGone => {
            let close = |code: u16, reason: String| {
                Out::Message(Message::Close(Some(CloseFrame {
                    code,
                    reason: reason.into(),
                })))
            };
            match end {
                End::Idle => {
                    metrics::counter!("swell_ws_idle_disconnects_total").increment(1);
                    let _ = queue.tx.try_send(close(
                        close_code::AWAY,
                        "idle: nothing received (ws_idle_timeout_ms)".into(),
                    ));
                }
                End::Protocol(code) => {
                    metrics::counter!("swell_ws_protocol_errors_total").increment(1);
                    let why = if code == close_code::INVALID {
                        "a text message that is not UTF-8"
                    } else {
                        "a WebSocket protocol violation"
                    };
                    let _ = queue.tx.try_send(close(code, why.into()));
                }
                End::SceneGone => {
                    let _ = queue
                        .tx
                        .try_send(close(SCENE_GONE, format!("scene {scene_id} was deleted")));
                }
                End::Flood => {
                    metrics::counter!("swell_ws_flood_disconnects_total").increment(1);
                    let _ = queue.tx.try_send(close(
                        close_code::POLICY,
                        format!(
                            "kept sending over {} messages a second (ws_messages_per_s)",
                            state.limits.ws_messages_per_s
                        ),
                    ));
                }
                _ => {}
            }
            if end == End::Shutdown {
                let _ = queue
                    .tx
                    .try_send(Out::Message(Message::Close(Some(CloseFrame {
                        code: close_code::AWAY,
                        reason: "server shutting down".into(),
                    }))));
            }
            if end == End::TooBig {
                // The read half is unusable after the error (tungstenite fuses it), but the
                // write half still works: say why before the connection drops, or the client
                // sees only an abnormal closure (1005/1006).
                metrics::counter!("swell_ws_too_big_disconnects_total").increment(1);
                let _ = queue
                    .tx
                    .try_send(Out::Message(Message::Close(Some(CloseFrame {
                        code: close_code::SIZE,
                        reason: format!(
                            "message larger than {} bytes (ws_max_message_bytes)",
                            state.limits.ws_max_message_bytes
                        )
                        .into(),
                    }))));
            }
            // Queries still running hold clones of the queue; the writer ends once they finish
            // or the grace period runs out.
            drop(queue);
            if tokio::time::timeout(CLOSE_GRACE, &mut writer)
                .await
                .is_err()
            {
                writer.abort();
            }
        }
    }
    metrics::gauge!("swell_ws_sessions").decrement(1.0);
    offence
}

/// Sleeps until `at`; forever without one.
async fn sleep_until(at: Option<tokio::time::Instant>) {
    match at {
        Some(at) => tokio::time::sleep_until(at).await,
        None => std::future::pending().await,
    }
}

/// The check that a client reads what it is sent ([`crate::Limits::ws_read_check_ms`]).
///
/// Every half of the limit the session queues a ping whose 8-byte payload is a keyed hash of a
/// counter (SipHash with this session's random keys), so only a client that has read the ping
/// can answer it; the pong must come back within the limit of the ping being queued. The
/// writer's other checks (a full queue, one message stalled `ws_send_stall_ms`) see a
/// non-reader only once the kernel's socket buffers on the way are full: megabytes, minutes for
/// a client that reads nothing of a few tens of KB/s. A late pong after the deadline no longer
/// matters: the session has ended.
struct ReadCheck {
    limit: Option<Duration>,
    keys: std::hash::RandomState,
    /// Pings sent so far (the hashed counter).
    sent: u64,
    /// The payload of the ping waiting for its pong, and when its pong is due.
    waiting: Option<([u8; 8], tokio::time::Instant)>,
    /// When the next ping goes out (with none waiting).
    next: tokio::time::Instant,
}

/// A pong overdue: the client has not read for [`crate::Limits::ws_read_check_ms`].
#[derive(Debug, PartialEq, Eq)]
struct Behind;

impl ReadCheck {
    fn new(limit: Option<Duration>, now: tokio::time::Instant) -> Self {
        Self {
            limit,
            keys: std::hash::RandomState::new(),
            sent: 0,
            waiting: None,
            next: now + limit.unwrap_or_default() / 2,
        }
    }

    /// When the check next needs the session: a pong's deadline, or the next ping.
    fn wake(&self) -> Option<tokio::time::Instant> {
        self.limit?;
        Some(self.waiting.map_or(self.next, |(_, due)| due))
    }

    /// At `now`: [`Behind`] when a pong is overdue, else the ping to queue if one is due.
    fn poll(&mut self, now: tokio::time::Instant) -> Result<Option<Message>, Behind> {
        let Some(limit) = self.limit else {
            return Ok(None);
        };
        match self.waiting {
            Some((_, due)) if due <= now => Err(Behind),
            Some(_) => Ok(None),
            None if self.next <= now => {
                use std::hash::BuildHasher as _;
                let payload = self.keys.hash_one(self.sent).to_le_bytes();
                self.sent += 1;
                self.waiting = Some((payload, now + limit));
                Ok(Some(Message::Ping(Bytes::copy_from_slice(&payload))))
            }
            None => Ok(None),
        }
    }

    /// A pong arrived at `now`: if it answers the waiting ping, the next one goes out in half
    /// the limit. Other pongs (unsolicited ones, the idle check's) change nothing.
    fn pong(&mut self, payload: &[u8], now: tokio::time::Instant) {
        if let (Some(limit), Some((want, _))) = (self.limit, self.waiting)
            && payload == want
        {
            self.waiting = None;
            self.next = now + limit / 2;
        }
    }
}

/// A socket's message rate: a token bucket, and a count of messages refused in a row.
struct MessageRate {
    bucket: crate::peers::TokenBucket,
    burst: f64,
    refused: u32,
}

impl MessageRate {
    fn new(rate: f64, burst: f64) -> Self {
        Self {
            bucket: crate::peers::TokenBucket::new(rate, burst, std::time::Instant::now()),
            burst: burst.max(1.0),
            refused: 0,
        }
    }

    /// Takes one message at `now`; false when over the rate.
    fn allow(&mut self, now: std::time::Instant) -> bool {
        let ok = self.bucket.take(now).is_ok();
        self.refused = if ok { 0 } else { self.refused + 1 };
        ok
    }

    /// Whether the client kept going after being told: more refused in a row than twice the
    /// burst.
    fn flooding(&self) -> bool {
        f64::from(self.refused) > 2.0 * self.burst
    }
}

/// The RFC 6455 close code for a read error that is the client's protocol violation: 1007 for
/// text that is not UTF-8, 1002 for the rest (unmasked or reserved frames, bad control frames,
/// stray continuations). `None` for I/O errors and the like (the connection is gone).
fn violation(e: &axum::Error) -> Option<u16> {
    let mut cur: Option<&(dyn std::error::Error + 'static)> = Some(e);
    while let Some(err) = cur {
        match err.downcast_ref::<tungstenite::Error>() {
            Some(tungstenite::Error::Utf8(_)) => return Some(close_code::INVALID),
            Some(tungstenite::Error::Protocol(_)) => return Some(close_code::PROTOCOL),
            _ => {}
        }
        cur = err.source();
    }
    None
}

/// Whether a read error is tungstenite refusing a message or a frame over the size limit
/// (`max_message_size` / `max_frame_size`, both set to `ws_max_message_bytes`). Walks the
/// error's sources, so it does not depend on how axum wraps tungstenite's error.
fn too_big(e: &axum::Error) -> bool {
    let mut cur: Option<&(dyn std::error::Error + 'static)> = Some(e);
    while let Some(err) = cur {
        if let Some(tungstenite::Error::Capacity(
            tungstenite::error::CapacityError::MessageTooLong { .. },
        )) = err.downcast_ref::<tungstenite::Error>()
        {
            return true;
        }
        cur = err.source();
    }
    false
}

fn wrong_frame(got: &str, protocol: &str, want: &str) -> DecodeError {
    DecodeError {
        id: None,
        error: ApiError::new(
            ErrorCode::WrongFrameType,
            format!("a {got} frame on {protocol}; this subprotocol uses {want} frames"),
        ),
    }
}

/// A session's watch on its scene's clock hold (see the module docs, "Clock changes"): whether
/// the clock was held when the session last read it, and when to look again.
#[derive(Debug)]
struct ClockWatch {
    /// [`Clock::held`] at the session's last read of the clock.
    held: bool,
    /// When the hold may next start or end ([`Clock::until_hold_change`]); `None`: not while the
    /// clock record stays as it is (the next change re-arms it).
    next: Option<tokio::time::Instant>,
}

impl ClockWatch {
    /// The clock as the session starts (its client learns that much from its first pong).
    fn new(state: &AppState, scene_id: &str) -> ClockWatch {
        let mut watch = ClockWatch {
            held: false,
            next: None,
        };
        if let Ok(entry) = state.scene(scene_id) {
            let (clock, now) = state.clock_now(&entry);
            watch.saw(&clock, now);
        }
        watch
    }

    fn saw(&mut self, clock: &Clock, now: f64) {
        self.held = clock.held(now);
        self.next = clock
            .until_hold_change(now)
            .map(|wait| tokio::time::Instant::now() + wait);
    }

    /// Reads the scene's clock now and queues a `clock` event with its reading: always after a
    /// change (`changed`), otherwise only if the clock started or stopped holding since the last
    /// read, so a hold is told once. Nothing if the scene is gone: the client hears of that from
    /// its next request or the end of its tick frames.
    fn tell(&mut self, state: &AppState, scene_id: &str, queue: &Queue, changed: bool) {
        let Ok(entry) = state.scene(scene_id) else {
            self.next = None;
            return;
        };
        let (clock, now) = state.clock_now(&entry);
        let news = changed || clock.held(now) != self.held;
        self.saw(&clock, now);
        if news {
            queue.push(Outgoing {
                id: None,
                event: Event::Clock(clock.read(now, entry.scene.spec.tick_hz)),
            });
        }
    }
}

/// Decodes a large message on the compute pool ([`crate::compute`]).
async fn off_reactor(
    decode: impl FnOnce() -> Result<Incoming, DecodeError> + Send + 'static,
) -> Result<Incoming, DecodeError> {
    crate::compute::run(decode).await.unwrap_or_else(|e| {
        Err(DecodeError {
            id: None,
            error: ApiError::internal(e),
        })
    })
}

/// Acts on one client message.
fn handle(
    state: &AppState,
    scene_id: &str,
    queue: &Queue,
    permits: &Arc<Semaphore>,
    subscribed: &mut bool,
    m: Incoming,
) {
    let id = m.id;
    match m.request {
        Request::Ping { client_time } => match state.scene(scene_id) {
            Ok(entry) => {
                let r = state.read_clock(&entry);
                queue.push(Outgoing {
                    id,
                    event: Event::Pong {
                        client_time,
                        scene_time: r.t,
                        tick: r.tick,
                        rate: r.rate,
                        paused: r.paused,
                        generation: r.generation,
                    },
                });
            }
            Err(e) => queue.error(id, e.into()),
        },
        Request::Subscribe {
            ticks,
            bodies,
            region,
            compact,
        } => {
            // The writer owns the subscription (it reads the frames, see `Writer::run`); it
            // keeps the receiver it has, so a fresh one only matters when it has none (a first
            // subscribe, or after the scene's loop ended).
            if !ticks {
                *subscribed = false;
                queue.push_out(Out::Unsubscribe);
            } else if let Err(e) = state.scene(scene_id) {
                queue.error(id, e.into());
            } else {
                *subscribed = true;
                queue.push_out(Out::Subscribe(
                    state.tickers.subscribe(state, scene_id, queue.slot),
                    Interest::new(bodies, region).compact(compact),
                ));
            }
        }
        Request::Sample(req) => query(
            state,
            scene_id,
            queue,
            permits,
            Asked {
                id,
                t: req.t,
                bytes: sample_request_bytes(&req, queue.codec.number_bytes()),
            },
            {
                let points = req.points.len();
                let fields = crate::service::query::parse_fields(req.fields.as_deref());
                let options = crate::service::query::query_options(req.accuracy.as_ref());
                move |st, scene, at| match (fields, options) {
                    (Ok(f), Ok(o)) => runs_inline(&st.frames, scene, at, points, f, &o),
                    _ => true,
                }
            },
            move |st, scene, at| {
                run_sample(&st.frames, &st.limits, scene, at, &req).map(Event::SampleResult)
            },
        ),
        Request::Orientation(req) => {
            query(
                state,
                scene_id,
                queue,
                permits,
                Asked {
                    id,
                    t: req.t,
                    bytes: orientation_request_bytes(&req, queue.codec.number_bytes()),
                },
                {
                    let probes = orientation_probes(&req);
                    move |st, scene, at| {
                        runs_inline(
                            &st.frames,
                            scene,
                            at,
                            probes,
                            swell_waves::QueryFields::HEIGHT,
                            &swell_waves::QueryOptions::default(),
                        )
                    }
                },
                move |st, scene, at| {
                    run_orientation(&st.frames, &st.limits, scene, at, &req)
                        .map(Event::OrientationResult)
                },
            );
        }
    }
}

/// What a query message asked, as far as running it goes.
struct Asked {
    /// The client's id.
    id: Option<u64>,
    /// Its time (`None`: now).
    t: Option<f64>,
    /// What its work and answer hold, for the byte budget
    /// ([`crate::service::query::sample_bytes`]).
    bytes: usize,
}

/// Runs a query as HTTP does (scene lookup, time resolution, the same `run_*` function, inline
/// when cheap ([`runs_inline`]) or on a blocking thread) and queues its answer.
fn query(
    state: &AppState,
    scene_id: &str,
    queue: &Queue,
    permits: &Arc<Semaphore>,
    Asked { id, t, bytes }: Asked,
    inline: impl FnOnce(&AppState, &crate::scene::Scene, At) -> bool,
    run: impl FnOnce(&AppState, &crate::scene::Scene, At) -> Result<Event, QueryError> + Send + 'static,
) {
    let Ok(permit) = Arc::clone(permits).try_acquire_owned() else {
        queue.error(
            id,
            ApiError::overloaded(format!(
                "{QUERIES_PER_SESSION} queries are already running on this socket; wait for an answer"
            )),
        );
        return;
    };
    let Some(charge) = queue.reserve(id, bytes) else {
        return;
    };
    let resolved = state
        .scene(scene_id)
        .map_err(ApiError::from)
        .and_then(|entry| Ok((resolve_time(state, &entry, t)?, Arc::clone(&entry.scene))));
    let (at, scene) = match resolved {
        Ok(v) => v,
        Err(e) => return queue.error(id, e),
    };
    if inline(state, &scene, at) {
        drop(permit);
        match run(state, &scene, at) {
            Ok(event) => queue.push_answer(Outgoing { id, event }, charge),
            Err(e) => queue.error(id, e.into()),
        }
        return;
    }
    let st = state.clone();
    let queue = queue.clone();
    let codec = queue.codec;
    state.tasks.spawn(async move {
        // Encoded where it ran too: a large answer is milliseconds of number formatting that
        // the reactor should not spend.
        let result = crate::compute::run_for(queue.client, move || {
            run(&st, &scene, at)
                .map(|event| encode(codec, Outgoing { id, event }.finite_or_error()))
        })
        .await
        .map_err(|e| QueryError::Task(e.to_string()))
        .and_then(|r| r);
        drop(permit);
        match result {
            Ok(m) => queue.push_encoded_answer(id, m, charge),
            Err(e) => queue.error(id, e.into()),
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn payload(m: Option<Message>) -> Bytes {
        match m {
            Some(Message::Ping(p)) => p,
            other => panic!("not a ping: {other:?}"),
        }
    }

    #[test]
    fn the_read_check_pings_at_half_its_limit_and_wants_that_ping_back_in_time() {
        let limit = Duration::from_secs(10);
        let t0 = tokio::time::Instant::now();
        let mut c = ReadCheck::new(Some(limit), t0);
        assert_eq!(c.wake(), Some(t0 + limit / 2));
        assert_eq!(c.poll(t0 + Duration::from_secs(1)), Ok(None));
        let at = t0 + limit / 2;
        let first = payload(c.poll(at).unwrap());
        assert_eq!(first.len(), 8);
        // Waiting: no second ping, the deadline is the next wake.
        assert_eq!(c.poll(at + Duration::from_secs(1)), Ok(None));
        assert_eq!(c.wake(), Some(at + limit));
        // A pong that does not echo the ping (unsolicited, or guessed) changes nothing.
        c.pong(b"swell", at + Duration::from_secs(2));
        c.pong(&[0; 8], at + Duration::from_secs(2));
        assert_eq!(c.wake(), Some(at + limit));
        // The right one: the next ping in half the limit, with another payload.
        let back = at + Duration::from_secs(3);
        c.pong(&first, back);
        assert_eq!(c.wake(), Some(back + limit / 2));
        let second = payload(c.poll(back + limit / 2).unwrap());
        assert_ne!(first, second);
        // Unanswered: behind at the deadline, not before.
        let due = back + limit / 2 + limit;
        assert_eq!(c.poll(due - Duration::from_millis(1)), Ok(None));
        assert_eq!(c.poll(due), Err(Behind));
    }

    #[test]
    fn two_sessions_ping_with_payloads_a_client_cannot_predict() {
        let t0 = tokio::time::Instant::now();
        let limit = Duration::from_millis(2);
        let mut a = ReadCheck::new(Some(limit), t0);
        let mut b = ReadCheck::new(Some(limit), t0);
        assert_ne!(
            payload(a.poll(t0 + limit).unwrap()),
            payload(b.poll(t0 + limit).unwrap())
        );
    }

    #[test]
    fn a_zero_read_check_never_pings() {
        let t0 = tokio::time::Instant::now();
        let mut c = ReadCheck::new(None, t0);
        assert_eq!(c.wake(), None);
        assert_eq!(c.poll(t0 + Duration::from_secs(3600)), Ok(None));
    }
}
