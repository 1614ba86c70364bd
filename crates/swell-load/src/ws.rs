//! WebSocket side: connecting with a subprotocol, the stream's messages in both encodings, clock
//! sync by ping/pong, and the `id`-matched query client of `ws-query`.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use futures_util::{SinkExt as _, StreamExt as _};
use prost::Message as _;
use serde::Deserialize;
use serde::de::IgnoredAny;
use tokio::sync::{mpsc, oneshot};
use tokio_tungstenite::tungstenite::{self, Message, client::IntoClientRequest as _};

use crate::rx_time::TimedTcp;
use crate::stats::Outcome;
use crate::wire::{Wire, v1};

/// A client WebSocket (plain TCP: the tool speaks `http://` URLs only).
pub type Ws = tokio_tungstenite::WebSocketStream<TimedTcp>;

/// Pings per clock sync; the one with the shortest round trip wins (its midpoint is the best
/// estimate of when the server read its clock).
const SYNC_PINGS: u32 = 5;
/// Messages queued to one socket's writer before senders wait.
const WRITE_QUEUE: usize = 1024;

/// Read buffer for a socket whose messages are about `message_bytes` long: a power of two that
/// holds one, within 4–64 KiB.
///
/// tungstenite zeroes its read buffer before every read (128 KiB by default): at 30,000 frames
/// a second that memset was 41% of the tool's CPU, stolen from the server it shares the cores
/// with, and still 15% with 16 KiB for frames of 1.4 kB. A message longer than the buffer takes
/// a few reads.
pub fn read_buffer_for(message_bytes: usize) -> usize {
    (message_bytes + 512)
        .next_power_of_two()
        .clamp(4 * 1024, 64 * 1024)
}

/// Opens `GET {url}/v1/scenes/{scene}/stream` with `wire`'s subprotocol and a read buffer of
/// `read_buffer` bytes ([`read_buffer_for`]); with `stamp`, the socket keeps the kernel's
/// receive time of what it reads ([`TimedTcp`]).
///
/// # Errors
/// The reason, with the status and body of a refused upgrade.
pub async fn connect(
    url: &str,
    scene: &str,
    wire: Wire,
    stamp: bool,
    read_buffer: usize,
) -> Result<Ws, String> {
    let ws_url = format!(
        "{}/v1/scenes/{scene}/stream",
        url.replacen("http://", "ws://", 1)
    );
    let mut req = ws_url
        .as_str()
        .into_client_request()
        .map_err(|e| format!("{ws_url}: {e}"))?;
    req.headers_mut().insert(
        "sec-websocket-protocol",
        wire.subprotocol().parse().expect("a valid header value"),
    );
    let config = tungstenite::protocol::WebSocketConfig::default().read_buffer_size(read_buffer);
    let uri = req.uri();
    let (host, port) = (
        uri.host().unwrap_or("127.0.0.1").to_owned(),
        uri.port_u16().unwrap_or(80),
    );
    let tcp = tokio::net::TcpStream::connect((host.as_str(), port))
        .await
        .map_err(|e| format!("{ws_url}: {e}"))?;
    // Each message goes out at once (the pings of the clock sync are timed).
    tcp.set_nodelay(true)
        .map_err(|e| format!("{ws_url}: {e}"))?;
    let tcp = TimedTcp::new(tcp, stamp).map_err(|e| format!("{ws_url}: {e}"))?;
    match tokio_tungstenite::client_async_with_config(req, tcp, Some(config)).await {
        Ok((ws, _)) => Ok(ws),
        Err(tungstenite::Error::Http(resp)) => {
            let body = resp
                .body()
                .as_ref()
                .map(|b| String::from_utf8_lossy(b).into_owned())
                .unwrap_or_default();
            Err(format!(
                "{ws_url}: upgrade refused: {} {}",
                resp.status(),
                body.trim()
            ))
        }
        Err(e) => Err(format!("{ws_url}: {e}")),
    }
}

/// A decoded server message (only what the tool needs).
#[derive(Debug, Clone, PartialEq)]
pub enum ServerMsg {
    /// Clock sync answer.
    Pong {
        /// Echoed id.
        id: Option<u64>,
        /// The scene clock when the server answered, s.
        scene_time: f64,
    },
    /// A tick frame.
    Tick {
        /// Tick number.
        tick: i64,
        /// Its scene time, s.
        t: f64,
        /// Body states carried.
        bodies: usize,
    },
    /// A `sample_result` / `orientation_result`: values answered.
    Answer {
        /// Echoed id.
        id: Option<u64>,
        /// Points or bodies answered.
        values: usize,
    },
    /// A `clock` event (the scene's clock changed; no id): its generation.
    Clock {
        /// The clock's generation.
        generation: u64,
    },
    /// An `error`.
    Error {
        /// Echoed id.
        id: Option<u64>,
        /// Error code.
        code: String,
        /// Message.
        message: String,
    },
}

#[derive(Deserialize)]
struct JsonMsg {
    #[serde(rename = "type")]
    ty: String,
    id: Option<u64>,
    tick: Option<i64>,
    t: Option<f64>,
    scene_time: Option<f64>,
    generation: Option<u64>,
    bodies: Option<Vec<IgnoredAny>>,
    height: Option<Vec<IgnoredAny>>,
    normal: Option<Vec<IgnoredAny>>,
    displacement: Option<Vec<IgnoredAny>>,
    jacobian: Option<Vec<IgnoredAny>>,
    residual: Option<Vec<IgnoredAny>>,
    code: Option<String>,
    message: Option<String>,
}

/// Decodes a frame's payload.
///
/// # Errors
/// A payload that is not a server message of `wire`.
pub fn decode(wire: Wire, payload: &[u8]) -> Result<ServerMsg, String> {
    match wire {
        Wire::Json => {
            let m: JsonMsg = serde_json::from_slice(payload).map_err(|e| e.to_string())?;
            let len = |v: &Option<Vec<IgnoredAny>>| v.as_ref().map_or(0, Vec::len);
            Ok(match m.ty.as_str() {
                "pong" => ServerMsg::Pong {
                    id: m.id,
                    scene_time: m.scene_time.ok_or("pong without scene_time")?,
                },
                "tick" => ServerMsg::Tick {
                    tick: m.tick.ok_or("tick without tick")?,
                    t: m.t.ok_or("tick without t")?,
                    bodies: len(&m.bodies),
                },
                "sample_result" => ServerMsg::Answer {
                    id: m.id,
                    values: [
                        &m.height,
                        &m.normal,
                        &m.displacement,
                        &m.jacobian,
                        &m.residual,
                    ]
                    .into_iter()
                    .map(len)
                    .max()
                    .unwrap_or(0),
                },
                "orientation_result" => ServerMsg::Answer {
                    id: m.id,
                    values: len(&m.bodies),
                },
                "error" => ServerMsg::Error {
                    id: m.id,
                    code: m.code.unwrap_or_default(),
                    message: m.message.unwrap_or_default(),
                },
                "clock" => ServerMsg::Clock {
                    generation: m.generation.unwrap_or_default(),
                },
                other => return Err(format!("unknown message type {other:?}")),
            })
        }
        Wire::Protobuf => {
            use v1::server_message::Msg;
            let m = v1::ServerMessage::decode(payload).map_err(|e| e.to_string())?;
            Ok(match m.msg.ok_or("empty server message")? {
                Msg::Pong(p) => ServerMsg::Pong {
                    id: m.id,
                    scene_time: p.scene_time,
                },
                Msg::Tick(t) => ServerMsg::Tick {
                    tick: t.tick,
                    t: t.t,
                    bodies: t.bodies.len() + t.compact.map_or(0, |c| c.bodies.len()),
                },
                Msg::SampleResult(r) => ServerMsg::Answer {
                    id: m.id,
                    values: crate::workload::sample_len_proto(&r),
                },
                Msg::OrientationResult(r) => ServerMsg::Answer {
                    id: m.id,
                    values: r.bodies.len(),
                },
                Msg::Error(e) => ServerMsg::Error {
                    id: m.id,
                    code: e.code,
                    message: e.message,
                },
                Msg::Clock(c) => ServerMsg::Clock {
                    generation: c.generation,
                },
            })
        }
    }
}

/// A protobuf tick frame's number, scene time and body count, read without decoding the body
/// states: the stream follower does this 30,000 times a second on the cores the server uses,
/// and decoding every state was ~10% of the tool's CPU. `None` for anything that is not a
/// well-formed tick (the caller then uses [`decode`]).
pub fn protobuf_tick(payload: &[u8]) -> Option<(i64, f64, usize)> {
    use prost::encoding::{DecodeContext, WireType, decode_key, decode_varint, skip_field};
    // Field numbers: `ServerMessage.tick`; `Tick.tick`, `.t`, `.bodies`, `.compact`;
    // `CompactBodies.bodies`.
    const MSG_TICK: u32 = 5;
    const TICK: u32 = 1;
    const T: u32 = 2;
    const BODIES: u32 = 3;
    const COMPACT: u32 = 4;
    const COMPACT_BODIES: u32 = 2;
    fn field<'a>(buf: &mut &'a [u8]) -> Option<&'a [u8]> {
        let len = usize::try_from(decode_varint(buf).ok()?).ok()?;
        let (head, rest) = (buf.get(..len)?, buf.get(len..)?);
        *buf = rest;
        Some(head)
    }
    let skip = |wt, tag, buf: &mut &[u8]| skip_field(wt, tag, buf, DecodeContext::default()).ok();
    let mut buf = payload;
    let mut msg = None;
    while !buf.is_empty() {
        match decode_key(&mut buf).ok()? {
            (MSG_TICK, WireType::LengthDelimited) => msg = Some(field(&mut buf)?),
            (tag, wt) => skip(wt, tag, &mut buf)?,
        }
    }
    let mut m = msg?;
    let (mut tick, mut t, mut bodies) = (0_i64, 0.0_f64, 0_usize);
    while !m.is_empty() {
        match decode_key(&mut m).ok()? {
            // int64: two's complement in a 64-bit varint.
            (TICK, WireType::Varint) => tick = decode_varint(&mut m).ok()? as i64,
            (T, WireType::SixtyFourBit) => {
                t = f64::from_le_bytes(m.get(..8)?.try_into().ok()?);
                m = m.get(8..)?;
            }
            (BODIES, WireType::LengthDelimited) => {
                field(&mut m)?;
                bodies += 1;
            }
            (COMPACT, WireType::LengthDelimited) => {
                let mut c = field(&mut m)?;
                while !c.is_empty() {
                    let (tag, wt) = decode_key(&mut c).ok()?;
                    bodies += usize::from(tag == COMPACT_BODIES);
                    skip(wt, tag, &mut c)?;
                }
            }
            (tag, wt) => skip(wt, tag, &mut m)?,
        }
    }
    Some((tick, t, bodies))
}

/// A JSON tick frame's number, scene time and body count, read without parsing the body
/// states: [`protobuf_tick`]'s counterpart for `swell.v1.json`. Parsing every state (even into
/// `IgnoredAny`) was ~30% of the tool's CPU at 1,000 subscribers × 10 bodies, on the cores
/// the server uses. The top-level object's members are walked; `tick` and `t` are parsed as
/// [`decode`] parses them, `bodies`' elements are counted and skipped by their brackets and
/// strings, and any other member is skipped. `None` for anything that is not a well-formed
/// tick as the server writes it (the caller then uses [`decode`]).
pub fn json_tick(payload: &[u8]) -> Option<(i64, f64, usize)> {
    let mut s = Skim { b: payload, i: 0 };
    s.ws();
    s.eat(b'{')?;
    let (mut tick, mut t, mut bodies, mut is_tick) = (None, None, 0, false);
    s.ws();
    if s.peek()? != b'}' {
        loop {
            s.ws();
            let key = s.string()?;
            s.ws();
            s.eat(b':')?;
            s.ws();
            match key {
                b"tick" => tick = Some(serde_json::from_slice::<i64>(s.scalar()?).ok()?),
                b"t" => t = Some(serde_json::from_slice::<f64>(s.scalar()?).ok()?),
                b"type" => is_tick = s.string()? == b"tick",
                b"bodies" => bodies = s.count_array()?,
                _ => s.skip_value()?,
            }
            s.ws();
            match s.next()? {
                b',' => {}
                b'}' => break,
                _ => return None,
            }
        }
    } else {
        s.i += 1;
    }
    s.ws();
    (is_tick && s.i == payload.len()).then_some(())?;
    Some((tick?, t?, bodies))
}

/// The bytes [`Skim::skip_value`] stops at inside a container: quotes and brackets.
const STRUCTURAL: [bool; 256] = {
    let mut t = [false; 256];
    t[b'"' as usize] = true;
    t[b'{' as usize] = true;
    t[b'}' as usize] = true;
    t[b'[' as usize] = true;
    t[b']' as usize] = true;
    t
};

/// A cursor over a JSON text for [`json_tick`]: it finds where values end, and checks no more
/// than that (the server's frames are JSON; anything odd gives up).
struct Skim<'a> {
    b: &'a [u8],
    i: usize,
}

impl<'a> Skim<'a> {
    fn peek(&self) -> Option<u8> {
        self.b.get(self.i).copied()
    }

    fn next(&mut self) -> Option<u8> {
        let c = self.peek()?;
        self.i += 1;
        Some(c)
    }

    fn eat(&mut self, c: u8) -> Option<()> {
        (self.next()? == c).then_some(())
    }

    fn ws(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t' | b'\n' | b'\r')) {
            self.i += 1;
        }
    }

    /// A string's raw bytes between its quotes (escapes left as written).
    fn string(&mut self) -> Option<&'a [u8]> {
        self.eat(b'"')?;
        let start = self.i;
        loop {
            match self.next()? {
                b'"' => return Some(&self.b[start..self.i - 1]),
                b'\\' => {
                    self.next()?;
                }
                _ => {}
            }
        }
    }

    /// A number, `true`, `false` or `null`: the bytes up to the next delimiter.
    fn scalar(&mut self) -> Option<&'a [u8]> {
        let start = self.i;
        while let Some(c) = self.peek() {
            if matches!(c, b',' | b'}' | b']' | b' ' | b'\t' | b'\n' | b'\r') {
                break;
            }
            self.i += 1;
        }
        (self.i > start).then(|| &self.b[start..self.i])
    }

    /// Past one value of any kind.
    fn skip_value(&mut self) -> Option<()> {
        match self.peek()? {
            b'"' => self.string().map(drop),
            b'{' | b'[' => {
                // One tight pass over the bytes (this is most of what the tool does per JSON
                // frame): brackets counted, strings jumped over.
                let b = &self.b[self.i..];
                let (mut depth, mut k) = (0_usize, 0);
                while k < b.len() {
                    let c = b[k];
                    k += 1;
                    if !STRUCTURAL[usize::from(c)] {
                        continue;
                    }
                    match c {
                        b'"' => loop {
                            let c = *b.get(k)?;
                            k += if c == b'\\' { 2 } else { 1 };
                            if c == b'"' {
                                break;
                            }
                        },
                        b'{' | b'[' => depth += 1,
                        _ => {
                            depth -= 1;
                            if depth == 0 {
                                self.i += k;
                                return Some(());
                            }
                        }
                    }
                }
                None
            }
            _ => self.scalar().map(drop),
        }
    }

    /// Past an array, counting its elements.
    fn count_array(&mut self) -> Option<usize> {
        self.eat(b'[')?;
        self.ws();
        if self.peek()? == b']' {
            self.i += 1;
            return Some(0);
        }
        let mut n = 0;
        loop {
            self.ws();
            self.skip_value()?;
            n += 1;
            self.ws();
            match self.next()? {
                b',' => {}
                b']' => return Some(n),
                _ => return None,
            }
        }
    }
}

/// A frame of `wire`'s kind carrying `payload`.
pub fn frame(wire: Wire, payload: Vec<u8>) -> Message {
    match wire {
        Wire::Json => Message::Text(
            String::from_utf8(payload)
                .expect("JSON messages are built from UTF-8")
                .into(),
        ),
        Wire::Protobuf => Message::Binary(payload.into()),
    }
}

/// `ping {id, client_time}`.
pub fn ping(wire: Wire, id: u64, client_time: f64) -> Message {
    frame(
        wire,
        match wire {
            Wire::Json => serde_json::to_vec(
                &serde_json::json!({"type": "ping", "id": id, "client_time": client_time}),
            )
            .expect("serialises"),
            Wire::Protobuf => v1::ClientMessage {
                id: Some(id),
                msg: Some(v1::client_message::Msg::Ping(v1::Ping { client_time })),
            }
            .encode_to_vec(),
        },
    )
}

/// `subscribe {ticks: true, bodies, region?, compact}` (`compact` only on protobuf).
pub fn subscribe(
    wire: Wire,
    bodies: &[u64],
    region: Option<crate::cli::Area>,
    compact: bool,
) -> Message {
    frame(
        wire,
        match wire {
            Wire::Json => {
                let mut m =
                    serde_json::json!({"type": "subscribe", "ticks": true, "bodies": bodies});
                if let Some(r) = region {
                    m["region"] = serde_json::json!([r.x0, r.z0, r.x1, r.z1]);
                }
                serde_json::to_vec(&m).expect("serialises")
            }
            Wire::Protobuf => v1::ClientMessage {
                id: None,
                msg: Some(v1::client_message::Msg::Subscribe(v1::Subscribe {
                    ticks: true,
                    bodies: bodies.to_vec(),
                    region: region.map(|r| v1::Region {
                        x0: r.x0,
                        z0: r.z0,
                        x1: r.x1,
                        z1: r.z1,
                    }),
                    compact,
                })),
            }
            .encode_to_vec(),
        },
    )
}

/// The payload of a data frame; `None` for control frames.
pub fn payload(m: &Message) -> Option<&[u8]> {
    match m {
        Message::Text(t) => Some(t.as_bytes()),
        Message::Binary(b) => Some(b),
        _ => None,
    }
}

/// A clock sync: the scene clock read `scene_time` at local instant `local`.
#[derive(Debug, Clone, Copy)]
pub struct ClockSync {
    /// Midpoint of the winning ping's round trip.
    pub local: Instant,
    /// The scene time the server answered with.
    pub scene_time: f64,
    /// That ping's round trip.
    pub rtt: Duration,
}

impl ClockSync {
    /// How late `arrival` is for a frame of scene time `t`, s, with the clock at `rate`
    /// (negative: early, i.e. sync error).
    pub fn delay(&self, t: f64, rate: f64, arrival: Instant) -> f64 {
        let expected = (t - self.scene_time) / rate;
        let actual = if arrival >= self.local {
            arrival.duration_since(self.local).as_secs_f64()
        } else {
            -self.local.duration_since(arrival).as_secs_f64()
        };
        actual - expected
    }
}

/// Syncs with the scene clock over `ws` (before subscribing: ticks would interleave).
///
/// # Errors
/// The socket closed or did not answer within `timeout`.
pub async fn sync_clock(ws: &mut Ws, wire: Wire, timeout: Duration) -> Result<ClockSync, String> {
    let mut best: Option<ClockSync> = None;
    for id in 0..u64::from(SYNC_PINGS) {
        let sent = Instant::now();
        ws.send(ping(wire, id, 0.0))
            .await
            .map_err(|e| format!("ping: {e}"))?;
        let scene_time = tokio::time::timeout(timeout, async {
            while let Some(m) = ws.next().await {
                let m = m.map_err(|e| format!("waiting for pong: {e}"))?;
                if let Some(p) = payload(&m)
                    && let Ok(ServerMsg::Pong {
                        id: Some(got),
                        scene_time,
                    }) = decode(wire, p)
                    && got == id
                {
                    return Ok(scene_time);
                }
            }
            Err("closed while waiting for pong".to_string())
        })
        .await
        .map_err(|_| format!("no pong within {timeout:?}"))??;
        let rtt = sent.elapsed();
        if best.is_none_or(|b| rtt < b.rtt) {
            best = Some(ClockSync {
                local: sent + rtt / 2,
                scene_time,
                rtt,
            });
        }
    }
    Ok(best.expect("at least one ping"))
}

enum Reply {
    Values(usize, u64),
    Error(String, String),
    Closed(String),
}

type PendingMap = Arc<Mutex<HashMap<u64, oneshot::Sender<Reply>>>>;

/// One WebSocket carrying queries: a writer task fed by a bounded queue and a reader task that
/// hands each answer to the query with its `id`.
pub struct QueryConn {
    tx: mpsc::Sender<Message>,
    pending: PendingMap,
    next_id: AtomicU64,
    wire: Wire,
    timeout: Duration,
}

impl QueryConn {
    /// Takes over `ws`.
    pub fn new(ws: Ws, wire: Wire, timeout: Duration) -> Self {
        let (mut sink, mut stream) = ws.split();
        let (tx, mut rx) = mpsc::channel::<Message>(WRITE_QUEUE);
        let pending: PendingMap = Arc::default();
        // Writer: ends when every sender is dropped (the connection is dropped), then closes.
        tokio::spawn(async move {
            while let Some(m) = rx.recv().await {
                if sink.send(m).await.is_err() {
                    return;
                }
            }
            let _ = sink.close().await;
        });
        // Reader: ends when the socket closes; every query still waiting is told why.
        let p = pending.clone();
        tokio::spawn(async move {
            let reason = loop {
                match stream.next().await {
                    None => break "connection closed".to_string(),
                    Some(Err(e)) => break format!("connection lost: {e}"),
                    Some(Ok(Message::Close(c))) => {
                        break format!("server closed the socket: {c:?}");
                    }
                    Some(Ok(m)) => {
                        let Some(bytes) = payload(&m) else { continue };
                        let n = bytes.len() as u64;
                        let (id, reply) = match decode(wire, bytes) {
                            Ok(ServerMsg::Answer { id, values }) => (id, Reply::Values(values, n)),
                            Ok(ServerMsg::Error { id, code, message }) => {
                                (id, Reply::Error(code, message))
                            }
                            _ => continue,
                        };
                        let waiter = id.and_then(|id| p.lock().expect("not poisoned").remove(&id));
                        if let Some(w) = waiter {
                            let _ = w.send(reply);
                        }
                    }
                }
            };
            for (_, w) in p.lock().expect("not poisoned").drain() {
                let _ = w.send(Reply::Closed(reason.clone()));
            }
        });
        Self {
            tx,
            pending,
            next_id: AtomicU64::new(1),
            wire,
            timeout,
        }
    }

    /// Sends `q` with a fresh id and waits for its answer.
    pub async fn query(&self, q: &crate::workload::PreparedWs, check: bool) -> Outcome {
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let msg = q.with_id(self.wire, id);
        let sent = msg.len() as u64;
        let (tx, rx) = oneshot::channel();
        self.pending.lock().expect("not poisoned").insert(id, tx);
        if self.tx.send(frame(self.wire, msg)).await.is_err() {
            self.pending.lock().expect("not poisoned").remove(&id);
            return Outcome::Err {
                label: "connection closed".into(),
                detail: "the socket's writer has stopped".into(),
            };
        }
        match tokio::time::timeout(self.timeout, rx).await {
            Err(_) => {
                self.pending.lock().expect("not poisoned").remove(&id);
                Outcome::Err {
                    label: "timeout".into(),
                    detail: format!("no answer to id {id} within {:?}", self.timeout),
                }
            }
            Ok(Err(_)) => Outcome::Err {
                label: "connection closed".into(),
                detail: "the socket's reader has stopped".into(),
            },
            Ok(Ok(Reply::Closed(why))) => Outcome::Err {
                label: "connection closed".into(),
                detail: why,
            },
            Ok(Ok(Reply::Error(code, message))) => Outcome::Err {
                label: format!("error {code}"),
                detail: message,
            },
            Ok(Ok(Reply::Values(n, received))) => {
                if check && n as u64 != q.points {
                    return Outcome::Err {
                        label: "invalid answer".into(),
                        detail: format!("{n} values for {} asked", q.points),
                    };
                }
                Outcome::Ok {
                    points: q.points,
                    sent,
                    received,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn server_messages_decode_in_both_encodings() {
        let tick = br#"{"type":"tick","tick":7,"t":0.35,"bodies":[{"id":1},{"id":2}]}"#;
        assert_eq!(
            decode(Wire::Json, tick).unwrap(),
            ServerMsg::Tick {
                tick: 7,
                t: 0.35,
                bodies: 2
            }
        );
        let ans = br#"{"type":"sample_result","id":4,"t":1.0,"height":[1,2,3],"normal":[[0,1,0],[0,1,0],[0,1,0]]}"#;
        assert_eq!(
            decode(Wire::Json, ans).unwrap(),
            ServerMsg::Answer {
                id: Some(4),
                values: 3
            }
        );
        let pb = v1::ServerMessage {
            id: Some(3),
            msg: Some(v1::server_message::Msg::Pong(v1::Pong {
                client_time: 0.0,
                scene_time: 12.5,
                tick: 375,
                ..Default::default()
            })),
        }
        .encode_to_vec();
        assert_eq!(
            decode(Wire::Protobuf, &pb).unwrap(),
            ServerMsg::Pong {
                id: Some(3),
                scene_time: 12.5
            }
        );
        assert!(decode(Wire::Json, b"{\"type\":\"dance\"}").is_err());
    }

    /// The envelope reader agrees with the full decoder on full and compact frames, with and
    /// without impacts, and gives up on what is not a tick.
    #[test]
    fn protobuf_ticks_read_without_decoding_the_states() {
        let body = |id| v1::BodyState {
            id,
            position: Some(v1::Vec3 {
                x: 1.5,
                y: -0.25,
                z: 3.0,
            }),
            ..Default::default()
        };
        let compact = v1::CompactBodies {
            origin: Some(v1::Vec3::default()),
            bodies: vec![v1::CompactBodyState::default(); 3],
        };
        let impact = v1::ImpactEvent {
            tick: 9,
            ..Default::default()
        };
        let frames = [
            (-12, 0.0, vec![], None, vec![]),
            (
                10234,
                341.1333333333333,
                vec![body(1), body(7)],
                None,
                vec![],
            ),
            (5, 0.25, vec![], Some(compact), vec![impact]),
            (
                i64::MAX,
                -1e300,
                vec![body(u64::MAX)],
                None,
                vec![impact; 2],
            ),
        ];
        for (tick, t, bodies, compact, impacts) in frames {
            let pb = v1::ServerMessage {
                id: None,
                msg: Some(v1::server_message::Msg::Tick(v1::Tick {
                    tick,
                    t,
                    bodies,
                    compact,
                    impacts,
                    anchor_tick: None,
                })),
            }
            .encode_to_vec();
            let Ok(ServerMsg::Tick { tick, t, bodies }) = decode(Wire::Protobuf, &pb) else {
                panic!("not a tick");
            };
            assert_eq!(protobuf_tick(&pb), Some((tick, t, bodies)));
        }
        let pong = v1::ServerMessage {
            id: Some(3),
            msg: Some(v1::server_message::Msg::Pong(v1::Pong::default())),
        }
        .encode_to_vec();
        assert_eq!(protobuf_tick(&pong), None);
        // Truncated: no answer rather than a wrong one.
        let pb = v1::ServerMessage {
            id: None,
            msg: Some(v1::server_message::Msg::Tick(v1::Tick {
                tick: 3,
                bodies: vec![body(1)],
                ..Default::default()
            })),
        }
        .encode_to_vec();
        for cut in 1..pb.len() {
            assert_eq!(protobuf_tick(&pb[..cut]), None, "cut at {cut}");
        }
    }

    /// The JSON envelope reader agrees with the full decoder on ticks as the server writes them
    /// (with and without `anchor_tick` and impacts, pretty-printed too), on bodies holding
    /// strings with brackets, quotes and escapes, and on seeded random nested states; it gives
    /// up on other messages and on every truncation.
    #[test]
    fn json_ticks_read_without_parsing_the_states() {
        let body = |id: u64| {
            serde_json::json!({"id": id, "position": [1.5, -0.25, 3e-7],
                "orientation": [0.0, 0.0, 0.0, 1.0], "velocity": [-1e300, 0, 2],
                "note": "]}\"{[\\\u{1}é", "nested": {"a": [[], {}, [null, true, false]]}})
        };
        let tick = |tick: i64, t: f64, bodies: Vec<serde_json::Value>, extra: serde_json::Value| {
            let mut v = serde_json::json!({"type": "tick", "tick": tick, "t": t, "bodies": bodies});
            if let (Some(v), Some(extra)) = (v.as_object_mut(), extra.as_object()) {
                v.extend(extra.clone());
            }
            v
        };
        let mut frames = vec![
            tick(-12, 0.0, vec![], serde_json::json!({})),
            tick(
                10234,
                341.1333333333333,
                vec![body(1), body(7)],
                serde_json::json!({}),
            ),
            tick(
                5,
                0.25,
                vec![body(3)],
                serde_json::json!({"anchor_tick": 4, "impacts": [{"position": [1, 2], "tick": 9}]}),
            ),
            tick(
                i64::MAX,
                -1e300,
                vec![body(u64::MAX); 10],
                serde_json::json!({}),
            ),
        ];
        // Seeded random states: nested arrays, objects, numbers and strings.
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move |n: u64| {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 33) % n
        };
        fn value(next: &mut impl FnMut(u64) -> u64, depth: u32) -> serde_json::Value {
            match next(if depth > 3 { 4 } else { 6 }) {
                0 => serde_json::json!(null),
                1 => serde_json::json!(next(1000) as f64 / 7.0 - 50.0),
                2 => serde_json::json!(["x", "]", "\"", "\\", "{"][next(5) as usize]),
                3 => serde_json::json!(next(2) == 0),
                4 => (0..next(4)).map(|_| value(next, depth + 1)).collect(),
                _ => (0..next(4))
                    .map(|k| (format!("k{k}"), value(next, depth + 1)))
                    .collect::<serde_json::Map<_, _>>()
                    .into(),
            }
        }
        for n in 0..200 {
            let bodies = (0..next(12)).map(|_| value(&mut next, 0)).collect();
            frames.push(tick(n, n as f64 / 30.0, bodies, serde_json::json!({})));
        }
        for f in &frames {
            for text in [serde_json::to_string(f), serde_json::to_string_pretty(f)] {
                let text = text.unwrap();
                let Ok(ServerMsg::Tick { tick, t, bodies }) = decode(Wire::Json, text.as_bytes())
                else {
                    panic!("not a tick: {text}");
                };
                assert_eq!(
                    json_tick(text.as_bytes()),
                    Some((tick, t, bodies)),
                    "{text}"
                );
            }
        }
        for other in [
            r#"{"type":"pong","id":3,"scene_time":12.5}"#,
            r#"{"type":"error","code":"bad_request","message":"tick"}"#,
            r#"{"tick":3,"t":0.1,"bodies":[]}"#,
            r#"{"type":"tick","tick":3,"bodies":[]}"#,
            r#"{"type":"tick","tick":3,"t":0.1,"bodies":[]} x"#,
            r#"{}"#,
            r#"[]"#,
        ] {
            assert_eq!(json_tick(other.as_bytes()), None, "{other}");
        }
        let text = serde_json::to_string(&frames[2]).unwrap();
        for cut in 0..text.len() {
            assert_eq!(json_tick(&text.as_bytes()[..cut]), None, "cut at {cut}");
        }
    }

    /// A read buffer holds one message (with room for its header), is a power of two, and
    /// stays within 4–64 KiB: 1.4 kB protobuf frames get 4 KiB, not the 16 KiB memset per read.
    #[test]
    fn read_buffers_fit_the_frames() {
        for (bytes, want) in [
            (0, 4096),
            (1_400, 4096),
            (4_000, 8192),
            (14_000, 16_384),
            (38_000, 65_536),
            (1 << 20, 65_536),
        ] {
            assert_eq!(read_buffer_for(bytes), want, "{bytes} bytes");
        }
    }

    #[test]
    fn delay_maps_scene_time_through_the_sync() {
        let local = Instant::now();
        let s = ClockSync {
            local,
            scene_time: 100.0,
            rtt: Duration::ZERO,
        };
        // A frame for t = 101 arriving 1.002 s after the sync at rate 1 is 2 ms late.
        let d = s.delay(101.0, 1.0, local + Duration::from_millis(1002));
        assert!((d - 0.002).abs() < 1e-9, "{d}");
        // At rate 2, t = 101 is due 0.5 s after the sync.
        let d = s.delay(101.0, 2.0, local + Duration::from_millis(500));
        assert!(d.abs() < 1e-9, "{d}");
    }
}
