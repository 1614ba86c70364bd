//! The JSON Schemas of the WebSocket stream's `swell.v1.json` messages in `/openapi.json`:
//! `StreamRequest` (what a client sends) and `StreamMessage` (what the server sends), each a
//! `oneOf` over one component per message kind with a `discriminator` on `type`. A tick frame's
//! `BodyState` and `ImpactEvent` are [`super::body_schemas`]' (the HTTP answers share them).
//!
//! A JSON message is an object tagged by `"type"`, with an optional `"id"`, and its payload's
//! fields inline beside them ([`crate::stream::messages`]). Where the payload is an HTTP body or
//! answer (a `sample` is a `SampleRequest`, its `sample_result` a `SampleResponse`, a `clock`
//! event a `ClockReading`, an `error` the `error` object of `Error`), each of its fields is a
//! `$ref` to that component's field, so the message and the HTTP body cannot drift apart (but
//! for an `error`'s `code`, which also takes the WebSocket-only codes). A
//! `$ref` to the whole component would not do: those schemas are closed
//! (`additionalProperties: false`) and would refuse `type` and `id`.
//!
//! `tests/server/openapi.rs` sends a real session every kind of request, each valid here, and
//! validates every message it gets back.

use serde_json::{Map, Value, json};

use crate::error::ErrorCode;

/// Where the components live, for `$ref`s.
const COMPONENTS: &str = "#/components/schemas/";

/// The request kinds, `type` → component, in the order of `crate::stream::messages::decode_json`.
const REQUESTS: &[(&str, &str)] = &[
    ("ping", "StreamPing"),
    ("sample", "StreamSample"),
    ("orientation", "StreamOrientation"),
    ("subscribe", "StreamSubscribe"),
];

/// What the server sends, `type` → component (`crate::stream::messages::Event`).
const MESSAGES: &[(&str, &str)] = &[
    ("pong", "StreamPong"),
    ("sample_result", "StreamSampleResult"),
    ("orientation_result", "StreamOrientationResult"),
    ("tick", "StreamTick"),
    ("clock", "StreamClock"),
    ("error", "StreamError"),
];

/// The subprotocols, the client's and the server's schema: the stream operation's
/// `x-websocket` extension.
pub fn websocket_extension() -> Value {
    json!({
        "subprotocols": [crate::stream::messages::JSON_PROTOCOL, crate::stream::messages::PROTOBUF_PROTOCOL],
        "client": {"$ref": format!("{COMPONENTS}StreamRequest")},
        "server": {"$ref": format!("{COMPONENTS}StreamMessage")},
        "description": "JSON Schemas of the swell.v1.json text frames; swell.v1.protobuf frames \
            are swell.v1.ClientMessage / ServerMessage (proto/swell/v1/stream.proto)",
    })
}

/// Adds the stream's schemas to `schemas`, the components object [`super::ops`] built (the HTTP
/// bodies and answers whose fields the messages share must be among them, and
/// [`super::body_schemas`]' components, which tick frames name).
pub fn add(schemas: &mut Value) {
    let u64_id = |description: &str| json!({"type": "integer", "minimum": 0, "maximum": u64::MAX, "description": description});
    // A client's `id`: an unsigned integer, absent or null for none.
    let client_id = || {
        Some(
            json!({"type": ["integer", "null"], "minimum": 0, "maximum": u64::MAX,
            "description": "echoed in the answer (or the error) to this message"}),
        )
    };
    // The server's: the id of the message answered, absent when it had none (and on events).
    let answer_id = || {
        Some(u64_id(
            "the id of the message this answers; absent when it had none",
        ))
    };
    let clock =
        |field: &str| json!({"$ref": format!("{COMPONENTS}ClockReading/properties/{field}")});
    let payload = |path: &str| payload(schemas, path);
    // A socket's errors come from the same service as the HTTP answers' and add the
    // WebSocket-only codes (`unknown_type`, `wrong_frame_type`): its `code` takes every code.
    // Listing only the codes a session can reach would be a second list kept by hand beside
    // the enum, and one it missed would make a client refuse a real message.
    let mut stream_error = payload("Error/properties/error");
    stream_error.0.insert(
        "code".to_owned(),
        super::ops::error_code_schema(
            ErrorCode::ALL.iter(),
            "what went wrong, one of the README's error codes (the WebSocket-only ones included)",
        ),
    );
    let added = json!({
        // crate::stream::messages::decode_json's `PingBody`.
        "StreamPing": tagged("ping", client_id(), fields(&["client_time"], json!({
            "client_time": {"type": "number", "description": "the client's clock, echoed in the pong"}}))),
        "StreamSample": tagged("sample", client_id(), payload("SampleRequest")),
        "StreamOrientation": tagged("orientation", client_id(), payload("OrientationRequest")),
        // decode_json's `SubscribeBody`, as it checks it.
        "StreamSubscribe": tagged("subscribe", client_id(), fields(&["ticks"], json!({
            "ticks": {"type": "boolean", "description": "start (true) or stop (false) tick frames"},
            "bodies": {"type": ["array", "null"], "items": u64_id("body id"),
                "description": "body ids the frames carry (with region: these and the bodies in \
                it; neither: every body)"},
            "region": {"type": ["array", "null"], "items": {"type": "number"}, "minItems": 4, "maxItems": 4,
                "description": "[x0, z0, x1, z1], m, x0 <= x1 and z0 <= z1: also carry the bodies \
                whose (x, z) lies inside (bounds included)"},
            "compact": {"type": "boolean", "const": false, "default": false,
                "description": "compact body states are for swell.v1.protobuf; true is refused here"}}))),
        // Event::Pong: the clock's reading at the answer.
        "StreamPong": tagged("pong", answer_id(), fields(
            &["client_time", "scene_time", "tick", "rate", "paused", "generation"], json!({
            "client_time": {"type": "number", "description": "the ping's client_time"},
            "scene_time": clock("t"), "tick": clock("tick"), "rate": clock("rate"),
            "paused": clock("paused"), "generation": clock("generation")}))),
        "StreamSampleResult": tagged("sample_result", answer_id(), payload("SampleResponse")),
        "StreamOrientationResult": tagged("orientation_result", answer_id(), payload("OrientationResponse")),
        // crate::service::types::Tick, as crate::stream::frame assembles it: no id.
        "StreamTick": tagged("tick", None, fields(&["tick", "t", "bodies"], json!({
            "tick": {"type": "integer", "description": "floor(t·tick_hz) of the scene clock"},
            "t": {"type": "number", "description": "the tick's start, tick / tick_hz, s"},
            "bodies": {"type": "array", "items": {"$ref": format!("{COMPONENTS}BodyState")},
                "description": "the subscribed bodies' states at this tick"},
            "impacts": {"type": "array", "items": {"$ref": format!("{COMPONENTS}ImpactEvent")},
                "description": "impacts accepted since the previous frame (absent when none)"},
            "anchor_tick": {"type": "integer", "description": "the scene tick the body world \
                is anchored at (absent while the scene has no bodies)"}}))),
        // Event::Clock: sent unprompted, no id.
        "StreamClock": tagged("clock", None, payload("ClockReading")),
        // Event::Error: the HTTP error's `error` object, inline, with its own `code`.
        "StreamError": tagged("error", answer_id(), stream_error),
        "StreamRequest": one_of(REQUESTS, "a swell.v1.json message from the client, a text frame"),
        "StreamMessage": one_of(MESSAGES, "a swell.v1.json message from the server, a text \
            frame: answers (with the request's id), errors (the socket stays open), tick frames \
            while subscribed, and clock events when the scene's clock changes or starts holding \
            at ±limits.max_time"),
    });
    if let Value::Object(added) = added {
        for (name, schema) in added {
            schemas[name.as_str()] = schema;
        }
    }
}

/// An object's `properties` and its `required` names.
fn fields(required: &[&str], properties: Value) -> (Map<String, Value>, Vec<Value>) {
    let properties = match properties {
        Value::Object(map) => map,
        _ => Map::new(),
    };
    (properties, required.iter().map(|r| json!(r)).collect())
}

/// The fields of the object schema at `path` under the components (`SampleRequest`,
/// `Error/properties/error`), each a `$ref` to that schema's field, required where it is.
///
/// # Panics
/// If no object schema with `properties` is at `path` (a programming error, caught by every
/// test that fetches the document).
fn payload(schemas: &Value, path: &str) -> (Map<String, Value>, Vec<Value>) {
    let object = schemas
        .pointer(&format!("/{path}"))
        .unwrap_or_else(|| panic!("no component schema at {path}"));
    let properties = object["properties"]
        .as_object()
        .unwrap_or_else(|| panic!("{path} has no properties"))
        .keys()
        .map(|name| {
            let r = format!("{COMPONENTS}{path}/properties/{name}");
            (name.clone(), json!({"$ref": r}))
        })
        .collect();
    let required = object["required"].as_array().cloned().unwrap_or_default();
    (properties, required)
}

/// The message tagged `kind`: `type`, `id` when the message may carry one, and `payload`'s
/// fields; closed, as the decoder refuses unknown fields and a client may rely on the encoder
/// writing no others.
fn tagged(kind: &str, id: Option<Value>, payload: (Map<String, Value>, Vec<Value>)) -> Value {
    let (mut properties, mut required) = payload;
    properties.insert("type".to_owned(), json!({"const": kind}));
    if let Some(id) = id {
        properties.insert("id".to_owned(), id);
    }
    required.insert(0, json!("type"));
    json!({"type": "object", "required": required, "additionalProperties": false,
        "properties": properties})
}

/// A `oneOf` over `kinds`' components, discriminated by `type`.
fn one_of(kinds: &[(&str, &str)], description: &str) -> Value {
    let refs: Vec<Value> = kinds
        .iter()
        .map(|(_, c)| json!({"$ref": format!("{COMPONENTS}{c}")}))
        .collect();
    let mapping: Map<String, Value> = kinds
        .iter()
        .map(|(kind, c)| ((*kind).to_owned(), json!(format!("{COMPONENTS}{c}"))))
        .collect();
    json!({"oneOf": refs, "description": description,
        "discriminator": {"propertyName": "type", "mapping": mapping}})
}
