//! The stream's messages, decoded from and encoded to both subprotocols.
//!
//! Both codecs decode into [`Incoming`] and encode from [`Outgoing`], whose payloads are the
//! HTTP API's own structs: a `sample` message is a [`SampleRequest`] exactly as `POST …/sample`
//! decodes it, and its answer the same [`SampleResponse`].
//!
//! - `swell.v1.json`: text frames, an object tagged by `"type"` with the payload's fields inline
//!   and an optional `"id"` (echoed in the answer).
//! - `swell.v1.protobuf`: binary frames, `swell.v1.ClientMessage` / `swell.v1.ServerMessage`.

use std::sync::Arc;

use prost::Message as _;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use crate::error::{ApiError, ErrorCode};
use crate::scene::clock::ClockReading;
use crate::service::finite::ensure_finite;
use crate::service::json;
use crate::service::types::{
    OrientationRequest, OrientationResponse, SampleRequest, SampleResponse, Tick,
};
use crate::wire::v1;
use crate::wire::v1::{client_message, server_message};

/// The JSON subprotocol (the default when a client asks for none).
pub const JSON_PROTOCOL: &str = "swell.v1.json";
/// The protobuf subprotocol.
pub const PROTOBUF_PROTOCOL: &str = "swell.v1.protobuf";

/// A subprotocol's codec.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Codec {
    /// `swell.v1.json`: text frames.
    Json,
    /// `swell.v1.protobuf`: binary frames.
    Protobuf,
}

impl Codec {
    /// Bytes a number of an answer takes at most in this codec (for the byte budget).
    pub fn number_bytes(self) -> usize {
        match self {
            Codec::Json => crate::service::types::JSON_NUMBER_BYTES,
            Codec::Protobuf => crate::service::types::PROTOBUF_NUMBER_BYTES,
        }
    }
}

/// What a client asked.
#[derive(Debug, Clone)]
pub enum Request {
    /// Clock sync.
    Ping {
        /// The client's clock, echoed.
        client_time: f64,
    },
    /// A sample query, as `POST …/sample`.
    Sample(SampleRequest),
    /// An orientation query, as `POST …/orientation`.
    Orientation(OrientationRequest),
    /// Start or stop tick frames.
    Subscribe {
        /// Whether to receive tick frames.
        ticks: bool,
        /// Body ids to carry in tick frames.
        bodies: Vec<u64>,
        /// Also carry the bodies inside this rectangle (with `bodies` empty: only those).
        region: Option<Region>,
        /// Compact body states (protobuf only).
        compact: bool,
    },
}

/// An axis-aligned rectangle of the sea surface, world metres (bounds included).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// Smallest x.
    pub x0: f64,
    /// Smallest z.
    pub z0: f64,
    /// Largest x.
    pub x1: f64,
    /// Largest z.
    pub z1: f64,
}

impl Region {
    /// Checks `[x0, z0, x1, z1]`: finite, `x0 <= x1`, `z0 <= z1`.
    ///
    /// # Errors
    /// 400 `invalid_value` naming `region`.
    pub fn new([x0, z0, x1, z1]: [f64; 4]) -> Result<Region, ApiError> {
        if ![x0, z0, x1, z1].iter().all(|v| v.is_finite()) {
            return Err(ApiError::invalid(
                "region",
                "region must be four finite numbers [x0, z0, x1, z1] (metres)",
            ));
        }
        if x0 > x1 || z0 > z1 {
            return Err(ApiError::invalid(
                "region",
                format!("region [{x0}, {z0}, {x1}, {z1}] needs x0 <= x1 and z0 <= z1"),
            ));
        }
        Ok(Region { x0, z0, x1, z1 })
    }

    /// Whether the world point `(x, z)` lies inside (bounds included).
    pub fn contains(&self, x: f64, z: f64) -> bool {
        x >= self.x0 && x <= self.x1 && z >= self.z0 && z <= self.z1
    }
}

/// A decoded client message.
#[derive(Debug, Clone)]
pub struct Incoming {
    /// The client's id, echoed in the answer.
    pub id: Option<u64>,
    /// The request.
    pub request: Request,
}

/// What the server sends.
#[derive(Debug, Clone)]
pub enum Event {
    /// Answer to a ping.
    Pong {
        /// The client's time, echoed.
        client_time: f64,
        /// The scene clock now, s.
        scene_time: f64,
        /// `floor(scene_time·tick_hz)`.
        tick: i64,
        /// Scene seconds per real second.
        rate: f64,
        /// Whether the clock is paused.
        paused: bool,
        /// The clock's generation ([`crate::scene::clock`]).
        generation: u64,
    },
    /// The scene's clock changed (sent unprompted, without an id).
    Clock(ClockReading),
    /// Answer to `sample`.
    SampleResult(SampleResponse),
    /// Answer to `orientation`.
    OrientationResult(OrientationResponse),
    /// A tick frame (shared by every subscriber of the scene).
    Tick(Arc<Tick>),
    /// A request that failed; the socket stays open.
    Error(ApiError),
}

/// A server message.
#[derive(Debug, Clone)]
pub struct Outgoing {
    /// The id of the client message this answers, if it had one.
    pub id: Option<u64>,
    /// The payload.
    pub event: Event,
}

impl Outgoing {
    /// This message, or, when its payload holds a NaN or an infinity, an error with the same id
    /// in its place (500 `non_finite_result` naming the number, see [`crate::service::finite`]).
    /// The session's send queue passes everything through here before encoding, so no
    /// non-finite number reaches a socket in either subprotocol.
    pub fn finite_or_error(self) -> Outgoing {
        #[derive(Serialize)]
        struct PongNumbers {
            client_time: f64,
            scene_time: f64,
            rate: f64,
        }
        let checked = match &self.event {
            Event::Pong {
                client_time,
                scene_time,
                rate,
                ..
            } => ensure_finite(&PongNumbers {
                client_time: *client_time,
                scene_time: *scene_time,
                rate: *rate,
            }),
            Event::Clock(r) => ensure_finite(r),
            Event::SampleResult(r) => ensure_finite(r),
            Event::OrientationResult(r) => ensure_finite(r),
            Event::Tick(t) => ensure_finite(t.as_ref()),
            Event::Error(_) => Ok(()),
        };
        match checked {
            Ok(()) => self,
            Err(nf) => Outgoing {
                id: self.id,
                event: Event::Error(nf.into()),
            },
        }
    }
}

/// A malformed message: the id when it could still be read, and the error.
#[derive(Debug)]
pub struct DecodeError {
    /// The id, if the message had a readable one.
    pub id: Option<u64>,
    /// What was wrong (400).
    pub error: ApiError,
}

impl DecodeError {
    fn new(id: Option<u64>, error: ApiError) -> Self {
        Self { id, error }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PingBody {
    client_time: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SubscribeBody {
    ticks: bool,
    #[serde(default)]
    bodies: Option<Vec<u64>>,
    #[serde(default)]
    region: Option<[f64; 4]>,
    #[serde(default)]
    compact: bool,
}

/// The `id` of a message that does not parse as a whole (a number that overflows f64 elsewhere
/// in it, `1e999`), so its error can still carry the id: the other members are skipped
/// unconverted.
fn readable_id(text: &str) -> Option<u64> {
    #[derive(Deserialize)]
    struct IdOnly {
        id: Option<u64>,
    }
    serde_json::from_str::<IdOnly>(text).ok()?.id
}

/// Decodes a JSON text frame.
///
/// # Errors
/// `bad_json` for text that is not an object, a missing or unknown `type`, a bad `id`, or a
/// payload that does not decode (with the field's path); the id is kept when it was readable.
pub fn decode_json(text: &str) -> Result<Incoming, DecodeError> {
    let value: Value = json::from_slice(text.as_bytes())
        .map_err(|e| DecodeError::new(readable_id(text), e.into()))?;
    let Value::Object(mut map) = value else {
        return Err(DecodeError::new(
            None,
            ApiError::bad_json("a message must be a JSON object with a \"type\""),
        ));
    };
    let id = match map.remove("id") {
        None | Some(Value::Null) => None,
        Some(v) => match v.as_u64() {
            Some(id) => Some(id),
            None => {
                return Err(DecodeError::new(
                    None,
                    ApiError::bad_json(format!("id = {v} is not an unsigned integer"))
                        .with_field("id"),
                ));
            }
        },
    };
    let ty = match map.remove("type") {
        Some(Value::String(s)) => s,
        _ => {
            return Err(DecodeError::new(
                id,
                ApiError::bad_json(
                    "a message needs a string \"type\": ping, sample, orientation or subscribe",
                )
                .with_field("type"),
            ));
        }
    };
    let rest = Value::Object(map);
    let request = match ty.as_str() {
        "ping" => json::from_value::<PingBody>(rest)
            .map(|p| Request::Ping {
                client_time: p.client_time,
            })
            .map_err(ApiError::from),
        "sample" => json::from_value(rest)
            .map(Request::Sample)
            .map_err(ApiError::from),
        "orientation" => json::from_value(rest)
            .map(Request::Orientation)
            .map_err(ApiError::from),
        "subscribe" => json::from_value::<SubscribeBody>(rest)
            .map_err(ApiError::from)
            .and_then(|s| {
            if s.compact {
                return Err(ApiError::invalid(
                    "compact",
                    "compact body states are for the protobuf stream (swell.v1.protobuf); \
                     JSON tick frames carry the full states",
                ));
            }
            Ok(Request::Subscribe {
                ticks: s.ticks,
                bodies: s.bodies.unwrap_or_default(),
                region: s.region.map(Region::new).transpose()?,
                compact: false,
            })
        }),
        other => Err(ApiError::new(ErrorCode::UnknownType, format!(
                "type = {other:?} is not a message type; expected ping, sample, orientation or subscribe"
            ),
        )
        .with_field("type")),
    }
    .map_err(|e| DecodeError::new(id, e))?;
    Ok(Incoming { id, request })
}

/// Decodes a protobuf binary frame (`swell.v1.ClientMessage`).
///
/// # Errors
/// `bad_protobuf` for bytes that are not a `ClientMessage` or one without `msg`; the payload's
/// conversion errors (bad enum values, missing positions) with the field named.
pub fn decode_protobuf(bytes: &[u8]) -> Result<Incoming, DecodeError> {
    let m = v1::ClientMessage::decode(bytes).map_err(|e| {
        DecodeError::new(
            None,
            ApiError::new(
                ErrorCode::BadProtobuf,
                format!("malformed ClientMessage: {e}"),
            ),
        )
    })?;
    let id = m.id;
    let request = match m.msg {
        // Protobuf doubles can carry NaN and infinities (JSON cannot): refuse them here rather
        // than echo one back in the pong.
        Some(client_message::Msg::Ping(p)) if !p.client_time.is_finite() => Err(ApiError::invalid(
            "client_time",
            format!("client_time must be a finite number, got {}", p.client_time),
        )),
        Some(client_message::Msg::Ping(p)) => Ok(Request::Ping {
            client_time: p.client_time,
        }),
        Some(client_message::Msg::Sample(s)) => {
            s.try_into().map(Request::Sample).map_err(ApiError::from)
        }
        Some(client_message::Msg::Orientation(o)) => o
            .try_into()
            .map(Request::Orientation)
            .map_err(ApiError::from),
        Some(client_message::Msg::Subscribe(s)) => s
            .region
            .map(|r| Region::new([r.x0, r.z0, r.x1, r.z1]))
            .transpose()
            .map(|region| Request::Subscribe {
                ticks: s.ticks,
                bodies: s.bodies,
                region,
                compact: s.compact,
            }),
        None => Err(ApiError::new(
            ErrorCode::BadProtobuf,
            "ClientMessage has no msg (ping, sample, orientation or subscribe)",
        )
        .with_field("msg")),
    }
    .map_err(|e| DecodeError::new(id, e))?;
    Ok(Incoming { id, request })
}

/// Serialising the payload structs (numbers, strings, arrays) cannot fail; `Null` is a fallback.
fn to<T: serde::Serialize>(v: &T) -> Value {
    serde_json::to_value(v).unwrap_or(Value::Null)
}

fn tagged(ty: &str, id: Option<u64>, payload: Value) -> Value {
    let mut map = match payload {
        Value::Object(m) => m,
        _ => Map::new(),
    };
    map.insert("type".into(), Value::String(ty.into()));
    if let Some(id) = id {
        map.insert("id".into(), Value::from(id));
    }
    Value::Object(map)
}

/// A sample answer as JSON, written straight from its arrays: the bytes of the generic path
/// (keys in sorted order, as a `serde_json` map has them) without building a tree of a
/// `Value` for every number, which for a large sample held several times the answer's size.
#[derive(Serialize)]
struct SampleJson<'a> {
    #[serde(skip_serializing_if = "Option::is_none")]
    displacement: Option<&'a Vec<[f64; 3]>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    folded: Option<&'a Vec<bool>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    height: Option<&'a Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    id: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    jacobian: Option<&'a Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    normal: Option<&'a Vec<[f64; 3]>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    residual: Option<&'a Vec<f64>>,
    t: f64,
    #[serde(rename = "type")]
    kind: &'static str,
}

/// Encodes a server message as JSON text.
pub fn encode_json(out: &Outgoing) -> String {
    if let Event::SampleResult(r) = &out.event {
        let json = SampleJson {
            displacement: r.displacement.as_ref(),
            folded: r.folded.as_ref(),
            height: r.height.as_ref(),
            id: out.id,
            jacobian: r.jacobian.as_ref(),
            normal: r.normal.as_ref(),
            residual: r.residual.as_ref(),
            t: r.t,
            kind: "sample_result",
        };
        // Sized once: 25 bytes a number at most.
        let mut buf =
            Vec::with_capacity(128 + r.numbers() * crate::service::types::JSON_NUMBER_BYTES);
        if serde_json::to_writer(&mut buf, &json).is_ok()
            && let Ok(text) = String::from_utf8(buf)
        {
            return text;
        }
    }
    encode_json_value(out)
}

/// [`encode_json`] through a `serde_json::Value`.
fn encode_json_value(out: &Outgoing) -> String {
    let v = match &out.event {
        Event::Pong {
            client_time,
            scene_time,
            tick,
            rate,
            paused,
            generation,
        } => tagged(
            "pong",
            out.id,
            serde_json::json!({
                "client_time": client_time, "scene_time": scene_time, "tick": tick,
                "rate": rate, "paused": paused, "generation": generation,
            }),
        ),
        Event::Clock(r) => tagged("clock", out.id, to(r)),
        Event::SampleResult(r) => tagged("sample_result", out.id, to(r)),
        Event::OrientationResult(r) => tagged("orientation_result", out.id, to(r)),
        Event::Tick(t) => tagged("tick", out.id, to(t.as_ref())),
        Event::Error(e) => {
            let mut v = serde_json::json!({"code": e.code, "message": e.message});
            if let Some(f) = &e.field {
                v["field"] = Value::String(f.clone());
            }
            tagged("error", out.id, v)
        }
    };
    v.to_string()
}

/// Encodes a server message as protobuf (`swell.v1.ServerMessage`).
pub fn encode_protobuf(out: Outgoing) -> Vec<u8> {
    let msg = match out.event {
        Event::Pong {
            client_time,
            scene_time,
            tick,
            rate,
            paused,
            generation,
        } => server_message::Msg::Pong(v1::Pong {
            client_time,
            scene_time,
            tick,
            rate,
            paused,
            generation,
        }),
        Event::Clock(r) => server_message::Msg::Clock(v1::ClockChange {
            t: r.t,
            tick: r.tick,
            tick_hz: r.tick_hz,
            rate: r.rate,
            paused: r.paused,
            unix: r.unix,
            generation: r.generation,
        }),
        Event::SampleResult(r) => server_message::Msg::SampleResult(r.into()),
        Event::OrientationResult(r) => server_message::Msg::OrientationResult(r.into()),
        Event::Tick(t) => server_message::Msg::Tick(t.as_ref().into()),
        Event::Error(e) => server_message::Msg::Error((&e).into()),
    };
    v1::ServerMessage {
        id: out.id,
        msg: Some(msg),
    }
    .encode_to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sample_answer_is_encoded_as_the_generic_path_encodes_it() {
        let mut rng = swell_waves::math::SwellRng::new(28, 0);
        for round in 0..200 {
            let n = (rng.next_u32() % 20) as usize;
            let r = SampleResponse::seeded(&mut rng, n, round % 32);
            let id = (round % 3 != 0).then_some(round as u64);
            let out = Outgoing {
                id,
                event: Event::SampleResult(r),
            };
            assert_eq!(encode_json(&out), encode_json_value(&out), "round {round}");
        }
    }

    #[test]
    fn json_ping_round_trips_id_and_time() {
        let m = decode_json(r#"{"type":"ping","id":7,"client_time":1.25}"#).unwrap();
        assert_eq!(m.id, Some(7));
        assert!(matches!(m.request, Request::Ping { client_time } if client_time == 1.25));
    }

    #[test]
    fn json_unknown_type_keeps_the_id() {
        // A number that overflows f64 fails the whole message; the id still comes back.
        let e = decode_json(r#"{"type":"ping","id":13,"client_time":1e999}"#).unwrap_err();
        assert_eq!((e.id, e.error.code), (Some(13), ErrorCode::BadJson));
        let e = decode_json(r#"{"type":"ping","id":14}"#).unwrap_err();
        assert_eq!(e.error.field.as_deref(), Some("client_time"), "{e:?}");
        let e = decode_json(r#"{"type":"dance","id":3}"#).unwrap_err();
        assert_eq!((e.id, e.error.code.as_str()), (Some(3), "unknown_type"));
    }

    #[test]
    fn compact_states_are_protobuf_only() {
        let e =
            decode_json(r#"{"type":"subscribe","id":4,"ticks":true,"compact":true}"#).unwrap_err();
        assert_eq!((e.id, e.error.field.as_deref()), (Some(4), Some("compact")));
        let m = v1::ClientMessage {
            id: Some(5),
            msg: Some(client_message::Msg::Subscribe(v1::Subscribe {
                ticks: true,
                compact: true,
                ..Default::default()
            })),
        };
        let Request::Subscribe { compact, .. } =
            decode_protobuf(&m.encode_to_vec()).unwrap().request
        else {
            panic!("not a subscribe")
        };
        assert!(compact);
    }

    #[test]
    fn json_sample_rejects_unknown_fields_by_path() {
        let e = decode_json(r#"{"type":"sample","id":1,"points":[],"colour":1}"#).unwrap_err();
        assert_eq!(e.error.field.as_deref(), Some("colour"));
    }

    /// Regression (issue 11): a socket answer with a NaN in it was encoded as it was (`null` in
    /// JSON, a NaN in protobuf). It must become an error with the request's id instead.
    #[test]
    fn issue_11_non_finite_socket_answer_becomes_an_error() {
        let answer = SampleResponse {
            t: 3.0,
            height: Some(vec![0.5, f64::NAN]),
            ..Default::default()
        };
        let out = Outgoing {
            id: Some(9),
            event: Event::SampleResult(answer.clone()),
        }
        .finite_or_error();
        let Event::Error(e) = &out.event else {
            panic!("a NaN answer went through: {out:?}");
        };
        assert_eq!((out.id, e.code.as_str()), (Some(9), "non_finite_result"));
        assert!(e.message.contains("height[1]"), "{}", e.message);
        let v: Value = serde_json::from_str(&encode_json(&out)).unwrap();
        assert_eq!(v["type"], "error");
        // A finite answer passes untouched.
        let ok = SampleResponse {
            height: Some(vec![0.5, 0.25]),
            ..answer
        };
        let out = Outgoing {
            id: Some(10),
            event: Event::SampleResult(ok.clone()),
        }
        .finite_or_error();
        assert!(matches!(out.event, Event::SampleResult(r) if r == ok));
    }

    #[test]
    fn protobuf_ping_with_a_nan_time_is_refused() {
        let bytes = v1::ClientMessage {
            id: Some(2),
            msg: Some(client_message::Msg::Ping(v1::Ping {
                client_time: f64::NAN,
            })),
        }
        .encode_to_vec();
        let e = decode_protobuf(&bytes).unwrap_err();
        assert_eq!(
            (e.id, e.error.code.as_str(), e.error.field.as_deref()),
            (Some(2), "invalid_value", Some("client_time"))
        );
    }

    /// The pong carries the clock's rate, pause flag and generation in both codecs, and a
    /// `clock` event its whole reading, without an id.
    #[test]
    fn pong_and_clock_event_carry_rate_paused_generation() {
        let pong = Outgoing {
            id: Some(1),
            event: Event::Pong {
                client_time: 0.5,
                scene_time: 10.0,
                tick: 300,
                rate: 2.0,
                paused: true,
                generation: 7,
            },
        };
        let v: Value = serde_json::from_str(&encode_json(&pong)).unwrap();
        assert_eq!(
            (v["rate"].as_f64(), v["paused"].as_bool()),
            (Some(2.0), Some(true))
        );
        assert_eq!(v["generation"], 7);
        let m = v1::ServerMessage::decode(encode_protobuf(pong).as_slice()).unwrap();
        let Some(server_message::Msg::Pong(p)) = m.msg else {
            panic!("not a pong")
        };
        assert_eq!((p.rate, p.paused, p.generation), (2.0, true, 7));

        let reading = ClockReading {
            t: 5.0,
            tick: 150,
            tick_hz: 30.0,
            rate: -1.0,
            paused: false,
            unix: 1.8e9,
            generation: 3,
        };
        let clock = Outgoing {
            id: None,
            event: Event::Clock(reading),
        };
        let v: Value = serde_json::from_str(&encode_json(&clock)).unwrap();
        assert_eq!(v["type"], "clock");
        assert!(v.get("id").is_none());
        assert_eq!(
            (v["t"].as_f64(), v["generation"].as_u64()),
            (Some(5.0), Some(3))
        );
        let m = v1::ServerMessage::decode(encode_protobuf(clock).as_slice()).unwrap();
        let Some(server_message::Msg::Clock(c)) = m.msg else {
            panic!("not a clock event")
        };
        assert_eq!(
            (m.id, c.t, c.rate, c.unix, c.generation),
            (None, 5.0, -1.0, 1.8e9, 3)
        );
    }

    #[test]
    fn json_error_frame_has_type_id_code_field() {
        let out = Outgoing {
            id: Some(4),
            event: Event::Error(ApiError::invalid("t", "bad t")),
        };
        let v: Value = serde_json::from_str(&encode_json(&out)).unwrap();
        assert_eq!(v["type"], "error");
        assert_eq!(v["id"], 4);
        assert_eq!(v["code"], "invalid_value");
        assert_eq!(v["field"], "t");
    }
}
