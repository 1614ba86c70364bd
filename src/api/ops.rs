//! Operations endpoints: health, readiness, metrics, the OpenAPI document and the docs page.
//!
//! The OpenAPI document is written by hand (a small `json!` value) rather than generated with
//! utoipa: it keeps the build lean and the API is small. So it cannot drift from the handlers
//! unnoticed, `tests/server/api.rs` checks that every route the router serves is listed, that
//! every `{name}` of a path is declared as a parameter, and that real answers (201, 202, 204, 304)
//! carry statuses the document declares; `tests/server/openapi.rs` checks the sample,
//! orientation, clock, impact, spawn and input request schemas field by field against what the
//! server takes, the answers (a scene's detail and the scene list among them, and the body and
//! impact answers of [`super::body_schemas`]) against what it answers, and every range of those
//! bodies and of the query strings' `t`, `x` and `z` at its ends (taken) and just past them
//! (refused), and the stream's JSON messages ([`super::stream_schemas`]) against a real
//! session's; `tests/server/error_codes.rs` checks that the error codes listed are
//! [`ErrorCode::ALL`]'s.

use axum::extract::State;
use axum::http::{HeaderValue, header};
use axum::response::{Html, IntoResponse, Response};
use serde_json::{Value, json};

use swell_shaders::{Entry, Lang};
use swell_waves::body::{
    MAX_BOX_CELLS_PER_SIDE, MAX_CELLS, MAX_FOOTPRINT, MAX_HULL_SIZE, MAX_MASS, MAX_PROBES,
    MAX_WAVELENGTH_FACTOR, MAX_YAW, MIN_HULL_SIZE,
};
use swell_waves::particles::ripple::{
    MAX_IMPACT_COORD, MAX_IMPACT_RADIUS, MAX_IMPACT_TIME, MAX_STRENGTH, MIN_IMPACT_RADIUS,
};

use crate::access::Role;
use crate::bodies::{MAX_INPUT_FORCE, MAX_INPUT_TICKS, MAX_INPUT_TORQUE};
use crate::error::{ApiError, ErrorCode};
use crate::state::AppState;

/// `GET /healthz`: the process is up.
pub async fn healthz() -> axum::Json<Value> {
    axum::Json(json!({"status": "ok"}))
}

/// `GET /readyz`: scenes are loaded and the server is not shutting down (503 otherwise).
pub async fn readyz(State(state): State<AppState>) -> Result<axum::Json<Value>, ApiError> {
    if state.is_ready() {
        // The store: a replica whose Redis is down stays ready (it serves its last known
        // scenes; admin writes get 503), and says so here.
        let store = state.store().status(&state);
        Ok(axum::Json(
            json!({"status": "ready", "scenes": state.scenes().len(), "store": store}),
        ))
    } else {
        Err(ApiError::new(
            ErrorCode::NotReady,
            "the server is starting or shutting down",
        ))
    }
}

/// `GET /metrics`: Prometheus text format.
pub async fn metrics(State(state): State<AppState>) -> Response {
    metrics::gauge!("swell_frame_cache_entries").set(state.frames.len() as f64);
    metrics::gauge!("swell_scenes").set(state.scenes().len() as f64);
    let mut r = state.metrics.render().into_response();
    r.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/plain; version=0.0.4; charset=utf-8"),
    );
    r
}

/// `GET /openapi.json`: this server's document (the ranges that are limits are its limits).
pub async fn openapi(State(state): State<AppState>) -> axum::Json<Value> {
    axum::Json(openapi_document(&state.limits))
}

/// Every route as `(method, path)`, in the order of the docs.
pub const ROUTES: &[(&str, &str, &str)] = &[
    ("get", "/v1/scenes", "List scenes"),
    (
        "get",
        "/v1/scenes/{id}",
        "Scene spec, derived waves, model version, spec hash",
    ),
    (
        "put",
        "/v1/scenes/{id}",
        "Create or replace a scene (admin)",
    ),
    ("delete", "/v1/scenes/{id}", "Delete a scene (admin)"),
    (
        "get",
        "/v1/scenes/{id}/clock",
        "Scene clock: t, tick, tick_hz, rate, paused, unix, generation",
    ),
    (
        "put",
        "/v1/scenes/{id}/clock",
        "Pause, resume, set rate, seek (admin)",
    ),
    (
        "get",
        "/v1/scenes/{id}/height",
        "Height at one world point: ?x=&z=[&t=]",
    ),
    (
        "post",
        "/v1/scenes/{id}/sample",
        "Batch query: height, normal, displacement, jacobian, residual",
    ),
    (
        "post",
        "/v1/scenes/{id}/orientation",
        "Orientation of floating bodies",
    ),
    (
        "get",
        "/v1/scenes/{id}/bodies",
        "Floating bodies: tick, t, anchor_tick (the body world's world tick 0; absent before the first spawn) and every body's state, mass, hull (kind, length, beam, height, center), spawn_tick and, after a re-anchor, carried {state, inputs}; felt_impacts [{body_tick, t, position, strength, radius}] (the API impacts the body world feels)",
    ),
    (
        "post",
        "/v1/scenes/{id}/bodies",
        "Spawn a floating body (game): {mass, hull, position, yaw?, center_of_mass?, linear_drag?, ...} → 201 state, spawn_tick, anchor_tick",
    ),
    (
        "get",
        "/v1/scenes/{id}/bodies/{bid}",
        "One body's state, mass, hull (kind, length, beam, height, center), spawn_tick and carried?, with tick (the state's) and anchor_tick",
    ),
    (
        "delete",
        "/v1/scenes/{id}/bodies/{bid}",
        "Remove a body (game)",
    ),
    (
        "post",
        "/v1/scenes/{id}/bodies/{bid}/input",
        "Force/torque in the body frame from a tick for some ticks (game): {force?, torque?, from_tick?, ticks?} → 202 {tick, from_tick, ticks, anchor_tick?}",
    ),
    (
        "post",
        "/v1/scenes/{id}/impacts",
        "Add an impact that ripples on the scene's particle layer (game; shared by every replica of a fleet): {position, t?, strength, radius} → 202 {tick, t, body_tick?} (body_tick: the scene tick the body world feels it from)",
    ),
    (
        "get",
        "/v1/scenes/{id}/impacts",
        "Impacts that can still be rippling at ?t= (default now) or later, with the tick each applies at",
    ),
    (
        "get",
        "/v1/scenes/{id}/stream",
        "WebSocket (subprotocols swell.v1.json, swell.v1.protobuf): ping/pong, sample, orientation, subscribe → tick frames",
    ),
    (
        "get",
        "/v1/scenes/{id}/shader",
        "The scene's generated shader code: ?lang=wgsl|glsl|glsl_es|hlsl|msl|hlsl_include|gdshaderinc[&entry=][&layer=]",
    ),
    (
        "get",
        "/v1/scenes/{id}/uniforms",
        "The frame's shader uniforms (per-wave phase offsets in f64) at ?t= (default now)",
    ),
    (
        "get",
        "/v1/scenes/{id}/spectrum",
        "An FFT layer's h0 and ω exactly as drawn: ?layer=",
    ),
    ("get", "/viewer", "The browser viewer"),
    ("get", "/viewer/{scene}", "The browser viewer on one scene"),
    ("get", "/healthz", "Liveness"),
    ("get", "/readyz", "Readiness"),
    ("get", "/metrics", "Prometheus metrics"),
    ("get", "/openapi.json", "This document"),
    ("get", "/docs", "Human-readable API page"),
];

/// The protobuf media type and where its schema lives, for the document.
const PROTOBUF_NOTE: &str = "swell.v1 message from proto/swell/v1/*.proto (the wire schema)";

fn protobuf_content(message: &str) -> Value {
    json!({"schema": {"type": "string", "contentMediaType": "application/x-protobuf",
        "description": format!("{PROTOBUF_NOTE}: swell.v1.{message}")}})
}

fn error_ref() -> Value {
    json!({"description": "error (protobuf `ErrorResponse` when the request accepts application/x-protobuf)",
        "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Error"}},
                    "application/x-protobuf": protobuf_content("ErrorResponse")}})
}

/// The success statuses of an operation, as its handler answers them (`src/api/*.rs`): a
/// client generated from the document treats any other 2xx as unexpected, so this is kept to
/// what the handlers return, and `tests/server/api.rs` checks it against real answers.
fn success(method: &str, path: &str) -> &'static [(&'static str, &'static str)] {
    const NOT_MODIFIED: (&str, &str) = (
        "304",
        "not modified: If-None-Match holds the current ETag (no body)",
    );
    match (method, path) {
        ("put", "/v1/scenes/{id}") => &[
            ("200", "replaced: the scene's detail"),
            ("201", "created: the scene's detail"),
        ],
        ("delete", _) => &[("204", "deleted (no body)")],
        ("post", "/v1/scenes/{id}/bodies") => {
            &[("201", "spawned: its state, spawn_tick, anchor_tick")]
        }
        ("post", "/v1/scenes/{id}/bodies/{bid}/input") => {
            &[("202", "accepted: {tick, from_tick, ticks, anchor_tick?}")]
        }
        ("post", "/v1/scenes/{id}/impacts") => &[("202", "accepted: {tick, t, body_tick?}")],
        ("get", "/v1/scenes/{id}/stream") => &[("101", "switching protocols")],
        (
            "get",
            "/v1/scenes/{id}/shader" | "/v1/scenes/{id}/uniforms" | "/v1/scenes/{id}/spectrum",
        ) => &[
            ("200", "ok, with ETag, Swell-Model-Version, Swell-Spec-Hash"),
            NOT_MODIFIED,
        ],
        _ => &[("200", "ok")],
    }
}

/// The declaration of the path parameter `name`, typed as the handler parses it (the router
/// names them `{id}`, `{bid}` and `{scene}`, `src/api/mod.rs` and `src/api/viewer.rs`).
fn path_parameter(name: &str) -> Value {
    let (schema, description) = match name {
        "id" => (
            json!({"type": "string", "pattern": "^[a-z0-9-]{1,64}$"}),
            "scene id",
        ),
        "bid" => (
            json!({"type": "integer", "minimum": 0, "maximum": u64::MAX}),
            "body id (an unsigned 64-bit integer)",
        ),
        "scene" => (
            json!({"type": "string"}),
            "scene id the page opens (an unknown one gets the page, which says so, with status 404)",
        ),
        _ => (json!({"type": "string"}), ""),
    };
    json!({"name": name, "in": "path", "required": true, "description": description, "schema": schema})
}

/// Every `{name}` in `path`, in order.
fn path_names(path: &str) -> impl Iterator<Item = &str> {
    path.split('/')
        .filter_map(|seg| seg.strip_prefix('{')?.strip_suffix('}'))
}

/// The query parameters an operation reads, as its handler's query struct declares them
/// (`HeightQuery`, `ShaderQuery`, `UniformsQuery`, `SpectrumQuery`, `impacts::ListQuery`), with
/// the ranges the handlers check from `limits`: every `t` within ±`max_time`
/// ([`crate::Limits::check_time`]), `x` and `z` within ±`max_coordinate`.
fn query_parameters(limits: &crate::Limits, method: &str, path: &str) -> Vec<Value> {
    let q = |name: &str, required: bool, schema: Value, description: &str| {
        json!({"name": name, "in": "query", "required": required, "description": description,
            "schema": schema})
    };
    let num = || json!({"type": "number"});
    let t = || {
        q(
            "t",
            false,
            within(limits.max_time, num()),
            "scene time, s, within ±limits.max_time (default: the scene clock's now)",
        )
    };
    let coord = |name: &str, description: &str| {
        q(
            name,
            true,
            within(limits.max_coordinate, num()),
            description,
        )
    };
    match (method, path) {
        ("get", "/v1/scenes/{id}/height") => vec![
            coord("x", "world x, m, within ±limits.max_coordinate"),
            coord("z", "world z, m, within ±limits.max_coordinate"),
            t(),
        ],
        ("get", "/v1/scenes/{id}/shader") => {
            let langs: Vec<&str> = Lang::ALL.iter().map(|l| l.name()).collect();
            let entries: Vec<&str> = Entry::ALL
                .into_iter()
                .chain(Entry::FFT)
                .chain(Entry::FFT_COMPUTE)
                .map(Entry::name)
                .collect();
            vec![
                q(
                    "lang",
                    true,
                    json!({"type": "string", "enum": langs}),
                    "output language; hlsl_include (Unity, Unreal) and gdshaderinc (Godot 4) are \
                    includes with no entry point",
                ),
                q(
                    "entry",
                    false,
                    json!({"type": "string", "enum": entries}),
                    "one entry point (default: the whole module); not with an include lang; the \
                    swell_fft_* entries give FFT layer `layer`'s pass module",
                ),
                q(
                    "layer",
                    false,
                    json!({"type": "integer", "minimum": 0}),
                    "index of the FFT layer, with (and only with) a swell_fft_* entry",
                ),
            ]
        }
        ("get", "/v1/scenes/{id}/uniforms") => vec![
            t(),
            q(
                "origin",
                false,
                json!({"type": "string", "pattern": "^[^,]+,[^,]+$"}),
                "world origin `x,z`, m, each within ±limits.max_coordinate (default 0,0)",
            ),
        ],
        ("get", "/v1/scenes/{id}/spectrum") => vec![q(
            "layer",
            true,
            json!({"type": "integer", "minimum": 0}),
            "index of an FFT layer",
        )],
        ("get", "/v1/scenes/{id}/impacts") => vec![t()],
        _ => Vec::new(),
    }
}

/// `schema` with the range ±`max`, a limit the server checks as `|v| <= max`. A limit that is
/// not a positive finite number is no range to document (`f64::INFINITY`: any finite value),
/// and `schema` is left open.
fn within(max: f64, mut schema: Value) -> Value {
    if max.is_finite() && max > 0.0 {
        schema["minimum"] = json!(-max);
        schema["maximum"] = json!(max);
    }
    schema
}

/// The request body of an operation: its schema in `components` and whether it may also be
/// protobuf (query bodies only; admin and game bodies are JSON only, `src/api/json.rs`).
fn request_body(method: &str, path: &str) -> Option<(&'static str, bool)> {
    match (method, path) {
        ("put", "/v1/scenes/{id}") => Some(("SceneSpec", false)),
        ("put", "/v1/scenes/{id}/clock") => Some(("ClockUpdate", false)),
        ("post", "/v1/scenes/{id}/sample") => Some(("SampleRequest", true)),
        ("post", "/v1/scenes/{id}/orientation") => Some(("OrientationRequest", true)),
        ("post", "/v1/scenes/{id}/bodies") => Some(("SpawnRequest", false)),
        ("post", "/v1/scenes/{id}/bodies/{bid}/input") => Some(("InputRequest", false)),
        ("post", "/v1/scenes/{id}/impacts") => Some(("ImpactRequest", false)),
        _ => None,
    }
}

/// The OpenAPI 3.1 document of a server with `limits` (a range the server enforces from its
/// limits, such as a clock seek's `t` within ±`max_time`, is documented with its value).
pub fn openapi_document(limits: &crate::Limits) -> Value {
    let mut paths = serde_json::Map::new();
    for (method, path, summary) in ROUTES {
        let entry = paths.entry(path.to_string()).or_insert_with(|| json!({}));
        let mut responses = serde_json::Map::new();
        for (status, description) in success(method, path) {
            responses.insert((*status).to_owned(), json!({"description": description}));
        }
        responses.insert("4XX".to_owned(), error_ref());
        responses.insert("5XX".to_owned(), error_ref());
        let mut op = json!({"summary": summary, "responses": responses});
        let parameters: Vec<Value> = path_names(path)
            .map(path_parameter)
            .chain(query_parameters(limits, method, path))
            .collect();
        if !parameters.is_empty() {
            op["parameters"] = Value::Array(parameters);
        }
        // Who may call it (crate::access): admin and game routes need their token; reads are
        // public unless the server requires a reader token, so the token is optional there.
        let upper = method.to_ascii_uppercase();
        let m = axum::http::Method::from_bytes(upper.as_bytes()).unwrap_or(axum::http::Method::GET);
        match super::admission::required_role(&m, Some(path), true, false) {
            Some(role @ (Role::Admin | Role::Game)) => {
                op["security"] = json!([{"bearer": []}]);
                op["x-swell-role"] = json!(role.as_str());
            }
            Some(Role::Reader) if *path == "/metrics" => {}
            Some(Role::Reader) => {
                op["security"] = json!([{}, {"bearer": []}]);
                op["x-swell-role"] = json!("reader");
            }
            None => {}
        }
        if *path == "/metrics" {
            op["security"] = json!([{}, {"bearer": []}]);
            op["description"] = json!(
                "Public unless limits.metrics_public = false (then an admin token); also on --probe-bind."
            );
        }
        if let Some((s, protobuf)) = request_body(method, path) {
            let mut content = json!({"application/json":
                {"schema": {"$ref": format!("#/components/schemas/{s}")}}});
            if protobuf {
                content["application/x-protobuf"] = protobuf_content(s);
            }
            op["requestBody"] = json!({"required": true, "content": content});
        }
        // The success answer's schema, and whether it may also be protobuf (the query answers;
        // the clock's reading, a scene's detail and the body and impact answers are JSON only,
        // `src/api/scenes.rs`, `src/api/bodies.rs`, `src/api/impacts.rs`).
        let answer = match (*method, *path) {
            (_, "/v1/scenes/{id}/sample") => Some(("SampleResponse", true)),
            (_, "/v1/scenes/{id}/orientation") => Some(("OrientationResponse", true)),
            (_, "/v1/scenes/{id}/height") => Some(("HeightResponse", true)),
            (_, "/v1/scenes/{id}/clock") => Some(("ClockReading", false)),
            ("get" | "put", "/v1/scenes/{id}") => Some(("SceneDetail", false)),
            ("get", "/v1/scenes") => Some(("SceneList", false)),
            ("get", "/v1/scenes/{id}/bodies") => Some(("BodyList", false)),
            ("post", "/v1/scenes/{id}/bodies") => Some(("SpawnedBody", false)),
            ("get", "/v1/scenes/{id}/bodies/{bid}") => Some(("BodyDetail", false)),
            ("post", "/v1/scenes/{id}/bodies/{bid}/input") => Some(("InputAccepted", false)),
            ("get", "/v1/scenes/{id}/impacts") => Some(("ImpactList", false)),
            ("post", "/v1/scenes/{id}/impacts") => Some(("ImpactAccepted", false)),
            _ => None,
        };
        match answer {
            Some((a, true)) => {
                op["responses"]["200"] = json!({"description": "ok (JSON, or protobuf with Accept: application/x-protobuf)",
                    "content": {"application/json": {"schema": {"$ref": format!("#/components/schemas/{a}")}},
                        "application/x-protobuf": protobuf_content(a)}});
            }
            Some((a, false)) => {
                // Every success with a body (a put's 200 and 201 alike, a spawn's 201, an
                // input's or impact's 202) answers the schema.
                for (status, _) in success(method, path) {
                    if let Some(r) = op["responses"].get_mut(*status)
                        && matches!(*status, "200" | "201" | "202")
                    {
                        r["content"] = json!({"application/json":
                            {"schema": {"$ref": format!("#/components/schemas/{a}")}}});
                    }
                }
            }
            None => {}
        }
        if *path == "/v1/scenes/{id}/stream" {
            op["description"] = json!(
                "Upgrade to a WebSocket. Subprotocol swell.v1.json (default): text frames \
                tagged by \"type\" (client: ping {id, client_time}, sample {id, ...as POST sample}, \
                orientation {id, ...}, subscribe {ticks, bodies?}; server: pong, sample_result, \
                orientation_result, tick {tick, t, bodies, impacts? [{tick, t, position, strength, radius, \
                body_tick?}], anchor_tick?}, error {id?, code, message, field?}, \
                clock {t, tick, tick_hz, rate, paused, unix, generation} when the clock changes, and \
                once when it starts holding at ±limits.max_time). \
                Their JSON Schemas: components StreamRequest (client) and StreamMessage \
                (server), also named by x-websocket. \
                swell.v1.protobuf: binary frames of swell.v1.ClientMessage / ServerMessage \
                (proto/swell/v1/stream.proto). 404 for an unknown scene and 400 without an \
                upgrade or with an unknown subprotocol, before the upgrade."
            );
            op["x-websocket"] = super::stream_schemas::websocket_extension();
        }
        entry[*method] = op;
    }
    let mut schemas = schemas(limits);
    super::body_schemas::add(&mut schemas);
    super::stream_schemas::add(&mut schemas);
    json!({
        "openapi": "3.1.0",
        "info": {
            "title": "Swell",
            "version": env!("CARGO_PKG_VERSION"),
            "description": "Deterministic ocean physics for multiplayer games. Same scene + same t + same point = same bits.",
        },
        "paths": paths,
        "components": {
            "securitySchemes": {"bearer": {"type": "http", "scheme": "bearer"}},
            "schemas": schemas,
        },
    })
}

/// A string schema whose `enum` is the wire strings of `codes`, in their order: generated from
/// [`ErrorCode::ALL`], so a code added there is documented here with no edit.
pub(super) fn error_code_schema<'a>(
    codes: impl Iterator<Item = &'a ErrorCode>,
    description: &str,
) -> Value {
    let codes: Vec<&str> = codes.map(|c| c.as_str()).collect();
    json!({"type": "string", "enum": codes, "description": description})
}

/// The request and answer schemas, field for field as serde reads and writes the types: a
/// field with `#[serde(default)]` (or an `Option`) is optional, every other one is `required`;
/// an `Option` also takes `null` (its type lists `"null"`, and an enum of one lists `null`
/// among its values); a type with `deny_unknown_fields` has `additionalProperties: false`; an
/// answer field skipped when `None` is optional; a range the server checks is `minimum` and
/// `maximum` (`exclusiveMinimum` where the check is `>`), and a count it checks `maxItems`,
/// from `limits` where it is one. `tests/server/openapi.rs` checks them against the server.
fn schemas(limits: &crate::Limits) -> Value {
    let num = json!({"type": "number"});
    let xyz = json!({"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3});
    let nullable_enum = |values: &[&str], description: &str| {
        let mut e: Vec<Value> = values.iter().map(|v| json!(v)).collect();
        e.push(Value::Null);
        json!({"type": ["string", "null"], "enum": e, "description": description})
    };
    let fields: Vec<&str> = crate::service::types::FIELD_NAMES.to_vec();
    let max_rate = crate::scene::clock::MAX_RATE;
    // A scene time is within ±limits.max_time (`crate::Limits::check_time`, and the clocks
    // hold there: `Clock::within`); a limit that is not a positive finite number bounds no
    // clock, and is no range to document.
    let within_max_time = |s: Value| within(limits.max_time, s);
    // A world coordinate a query or a body takes is within ±limits.max_coordinate
    // (`crate::service::query::check_coord`).
    let coord = || within(limits.max_coordinate, json!({"type": "number"}));
    // A hull dimension, m (`swell_waves::body::HullSpec::build`).
    let hull_size = |description: &str| {
        json!({"type": "number", "minimum": MIN_HULL_SIZE, "maximum": MAX_HULL_SIZE,
            "description": description})
    };
    // `[x, z]` whose coordinates are each within ±max.
    let xz_within = |max: f64| json!({"type": "array", "items": within(max, json!({"type": "number"})), "minItems": 2, "maxItems": 2});
    json!({
        // crate::error::ApiError's body. `code` lists what an HTTP answer can carry:
        // ErrorCode::ALL but the WebSocket-only codes (the stream's `error` message takes
        // every code, `super::stream_schemas`).
        "Error": {"type": "object", "properties": {"error": {"type": "object",
            "required": ["code", "message"],
            "properties": {
                "code": error_code_schema(ErrorCode::ALL.iter().filter(|c| !c.websocket_only()),
                    "what went wrong, one of the README's error codes (each always with the same status)"),
                "message": {"type": "string"}, "field": {"type": "string"}}}}},
        // crate::scene::SceneSpec: its own fields beside swell_waves::SurfaceSpec's, unknown
        // fields rejected at every level.
        "SceneSpec": {"type": "object", "required": ["layers"], "additionalProperties": false,
            "properties": {
                "description": {"type": "string", "maxLength": crate::scene::MAX_DESCRIPTION},
                "tick_hz": {"type": "number", "minimum": swell_waves::body::MIN_TICK_HZ,
                    "maximum": swell_waves::body::MAX_TICK_HZ, "default": crate::scene::DEFAULT_TICK_HZ},
                "epoch": {"type": "number", "minimum": 0, "maximum": crate::scene::MAX_EPOCH,
                    "description": "Unix time, s, at which the scene clock reads t = 0 at rate 1 \
                    (default: the built-in epoch for configured scenes, the time of creation for a PUT)"},
                "seed": {"type": "integer", "minimum": 0, "maximum": u64::MAX, "default": 0},
                "gravity": num, "depth": {"type": ["number", "null"]},
                "layers": {"type": "array", "minItems": 1, "maxItems": swell_waves::surface::MAX_LAYERS,
                    "items": {"type": "object", "required": ["kind"],
                        "properties": {"kind": {"enum": ["sine", "gerstner", "fft", "particles"]}}}}}},
        // crate::service::types::ClockUpdate: every field an Option (absent or null: unchanged),
        // the numbers checked by ClockUpdate::validate.
        "ClockUpdate": {"type": "object", "additionalProperties": false,
            "description": "Applied in the order seek, rate, pause. The clock never leaves \
                [-limits.max_time, max_time]: one that reaches either end holds there, reading \
                paused: true with its rate kept, until a seek or a rate brings it back inside.",
            "properties": {
                "rate": {"type": ["number", "null"], "minimum": -max_rate, "maximum": max_rate,
                    "description": "scene seconds per real second, negative runs backwards (absent or null: unchanged)"},
                "paused": {"type": ["boolean", "null"],
                    "description": "pause (true) or resume (false) (absent or null: unchanged)"},
                "t": within_max_time(json!({"type": ["number", "null"],
                    "description": "seek to this scene time, s, within ±limits.max_time (absent or null: unchanged)"}))}},
        // crate::service::types::SceneDetail: GET and PUT /v1/scenes/{id}.
        "SceneDetail": {"type": "object", "additionalProperties": false,
            "required": ["id", "spec", "derived", "model_version", "spec_hash", "clock"],
            "properties": {
                "id": {"type": "string"},
                "spec": {"$ref": "#/components/schemas/SceneSpec"},
                "derived": {"type": "object",
                    "description": "built waves, FFT settings, seeds, generator name"},
                "model_version": {"type": "integer", "minimum": 0, "maximum": u32::MAX},
                "spec_hash": {"type": "string", "description": "FNV-1a 64 (hex) of the canonical spec JSON"},
                "clock": {"$ref": "#/components/schemas/ClockReading"}}},
        // crate::scene::clock::ClockReading: GET and PUT …/clock, and a scene's detail.
        "ClockReading": {"type": "object", "additionalProperties": false,
            "required": ["t", "tick", "tick_hz", "rate", "paused", "unix", "generation"],
            "properties": {
                "t": within_max_time(json!({"type": "number", "description": "scene time, s"})),
                "tick": {"type": "integer", "description": "floor(t·tick_hz)"},
                "tick_hz": {"type": "number", "description": "ticks per scene second"},
                "rate": {"type": "number", "minimum": -max_rate, "maximum": max_rate,
                    "description": "scene seconds per real second (negative runs backwards)"},
                "paused": {"type": "boolean",
                    "description": "t is frozen: paused by an admin, or held at ±limits.max_time"},
                "unix": {"type": "number",
                    "description": "Unix time of the reading, s: t at Unix time u is t + rate·(u − unix) unless paused"},
                "generation": {"type": "integer", "minimum": 0, "maximum": u64::MAX,
                    "description": "one more after every admin change of the clock and every scene put that moves the scene's epoch"}}},
        // crate::service::types::SampleRequest and Accuracy; the limits as `run_sample` checks
        // them (`origin + point` too, which no schema can say).
        "SampleRequest": {"type": "object", "required": ["points"], "additionalProperties": false,
            "properties": {
                "t": within_max_time(json!({"type": ["number", "null"],
                    "description": "scene time, s, within ±limits.max_time (default: the clock's now)"})),
                "origin": {"type": ["array", "null"], "items": coord(), "minItems": 2, "maxItems": 2,
                    "description": "world offset [x, z] added (in f64) to every point, m, each within \
                    ±limits.max_coordinate, and so is every sum origin + point (default [0, 0])"},
                "points": {"type": "array", "items": xz_within(limits.max_coordinate), "maxItems": limits.max_points,
                    "description": "points [x, z], m, each within ±limits.max_coordinate; at most limits.max_points"},
                "fields": {"type": ["array", "null"], "items": {"type": "string", "enum": fields},
                    "description": "the fields to answer (default, and when empty: [\"height\"])"},
                "accuracy": {"type": ["object", "null"], "additionalProperties": false,
                    "description": "accuracy settings (default: Newton, 8 iterations, 1e-5 m, bicubic, f64, grid)",
                    "properties": {
                        "method": nullable_enum(&["newton", "fixed_point"], "inversion method"),
                        "iterations": {"type": ["integer", "null"], "minimum": 0,
                            "maximum": swell_waves::query::MAX_ITERATIONS, "description": "most inversion steps"},
                        "tolerance": {"type": ["number", "null"], "minimum": 0, "description": "inversion tolerance, m"},
                        "filter": nullable_enum(&["nearest", "bilinear", "bicubic"], "FFT grid filter"),
                        "precision": nullable_enum(&["f64", "f32"], "evaluation precision"),
                        "time": nullable_enum(&["grid", "exact"], "FFT time sampling")}}}},
        // crate::service::types::SampleResponse: only the fields asked for, one entry per point.
        "SampleResponse": {"type": "object", "required": ["t"], "additionalProperties": false,
            "properties": {
                "t": {"type": "number", "description": "the scene time used, s"},
                "height": {"type": "array", "items": num, "description": "heights, m (with \"height\")"},
                "normal": {"type": "array", "items": xyz, "description": "unit normals [x, y, z] (with \"normal\")"},
                "displacement": {"type": "array", "items": xyz,
                    "description": "displacements [Dx, y, Dz] of the points taken as undisplaced, m (with \"displacement\")"},
                "jacobian": {"type": "array", "items": num,
                    "description": "Jacobian determinants of the horizontal map (with \"jacobian\")"},
                "folded": {"type": "array", "items": {"type": "boolean"},
                    "description": "jacobian <= 0: the surface folds (with \"jacobian\")"},
                "residual": {"type": "array", "items": num, "description": "inversion residuals, m (with \"residual\")"}}},
        // crate::service::types::OrientationRequest and Body; the limits as `run_orientation`
        // and swell_waves::body::BodyFootprint::probes check them. A body has one probe at
        // least (9 by default), so more bodies than limits.max_points are refused whatever
        // limits.max_bodies says.
        "OrientationRequest": {"type": "object", "required": ["bodies"], "additionalProperties": false,
            "properties": {
                "t": within_max_time(json!({"type": ["number", "null"],
                    "description": "scene time, s, within ±limits.max_time (default: the clock's now)"})),
                "bodies": {"type": "array", "maxItems": limits.max_bodies.min(limits.max_points),
                    "description": "at most limits.max_bodies, with at most limits.max_points probes in all",
                    "items": {"type": "object",
                    "required": ["position", "length", "beam"], "additionalProperties": false,
                    "properties": {
                        "position": {"type": "array", "items": coord(), "minItems": 2, "maxItems": 2,
                            "description": "world [x, z] of the body origin, m, each within ±limits.max_coordinate"},
                        "yaw": {"type": "number", "default": 0, "minimum": -MAX_YAW, "maximum": MAX_YAW,
                            "description": "rad, about +y"},
                        "length": {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_FOOTPRINT, "description": "m"},
                        "beam": {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_FOOTPRINT, "description": "m"},
                        "probes": {"type": ["array", "null"], "items": xz_within(MAX_FOOTPRINT),
                            "minItems": 1, "maxItems": MAX_PROBES.min(limits.max_points),
                            "description": "probes [u, v] in the body frame, m (default: a 3×3 grid over the footprint)"}}}}}},
        // crate::service::types::OrientationResponse and BodyOrientation.
        "OrientationResponse": {"type": "object", "required": ["t", "bodies"], "additionalProperties": false,
            "properties": {
                "t": {"type": "number", "description": "the scene time used, s"},
                "bodies": {"type": "array", "description": "one per body, in order", "items": {"type": "object",
                    "required": ["heave", "rotation", "normal", "pitch", "roll"], "additionalProperties": false,
                    "properties": {
                        "heave": {"type": "number", "description": "height of the fitted plane at the body origin, m"},
                        "rotation": {"type": "array", "items": {"type": "number"}, "minItems": 4, "maxItems": 4,
                            "description": "world rotation quaternion [x, y, z, w]"},
                        "normal": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3,
                            "description": "world unit normal [x, y, z]"},
                        "pitch": {"type": "number", "description": "rad, bow up positive"},
                        "roll": {"type": "number", "description": "rad"}}}}}},
        // crate::service::types::HeightResponse.
        "HeightResponse": {"type": "object", "required": ["t", "height"], "additionalProperties": false,
            "properties": {"t": {"type": "number", "description": "the scene time used, s"},
                "height": {"type": "number", "description": "height of the surface above (x, z), m"}}},
        // swell_waves::body::SpawnSpec (crate::bodies::SpawnRequest), unknown fields refused;
        // the position checked by `src/api/bodies.rs`, the yaw by `SceneBodies::spawn`, the rest
        // by swell_waves::body::BodySpec::build (whose errors name the field as the request
        // writes it: `mass`, `hull.length`).
        "SpawnRequest": {"type": "object", "required": ["mass", "hull", "position"],
            "additionalProperties": false, "properties": {
                "mass": {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_MASS,
                    "description": "kg (a mass so small that the hull's inertia tensor underflows, \
                    far below a gram, is refused naming hull)"},
                "hull": {"$ref": "#/components/schemas/HullSpec"},
                "position": {"type": "array", "items": coord(), "minItems": 3, "maxItems": 3,
                    "description": "world position of the body origin [x, y, z], m, each within \
                    ±limits.max_coordinate (where queries may look, `src/api/bodies.rs`)"},
                "yaw": {"type": "number", "default": 0, "minimum": -MAX_YAW, "maximum": MAX_YAW,
                    "description": "rad, about +y"},
                "center_of_mass": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3,
                    "default": [0, 0, 0],
                    "description": "in the body frame, m, inside the hull's bounding box (default: \
                    the body origin, a box's centre)"},
                "linear_drag": {"type": ["number", "null"], "minimum": 0,
                    "description": "N·s/m (default: a fraction of critical heave damping)"},
                "quadratic_drag": {"type": "number", "minimum": 0, "default": 0, "description": "N·s²/m²"},
                "angular_damping": {"type": ["number", "null"], "minimum": 0,
                    "description": "N·m·s/rad (default: the linear default times (L² + B²)/12)"},
                "min_wavelength_factor": {"type": "number", "minimum": 0,
                    "maximum": MAX_WAVELENGTH_FACTOR, "default": 0,
                    "description": "analytic waves shorter than this times the hull length do not move the body"}}},
        // swell_waves::body::HullSpec, tagged by `kind`, as HullSpec::build checks it; unknown
        // fields refused, and a wrong field named inside the hull, by `src/api/bodies.rs`
        // (`check_hull`).
        "HullSpec": {"oneOf": [
            {"type": "object", "required": ["kind", "length", "beam", "height"],
                "additionalProperties": false, "properties": {
                "kind": {"const": "box"},
                "length": hull_size("along +x, m"),
                "beam": hull_size("along +z, m"),
                "height": hull_size("along +y, m"),
                "cells": {"type": ["array", "null"], "items": {"type": "integer", "minimum": 1,
                    "maximum": MAX_BOX_CELLS_PER_SIDE}, "minItems": 2, "maxItems": 2,
                    "description": "columns [along length, along beam] (default [4, 2])"}}},
            {"type": "object", "required": ["kind", "cells"], "additionalProperties": false,
                "properties": {
                "kind": {"const": "cells"},
                "cells": {"type": "array", "minItems": 1, "maxItems": MAX_CELLS, "items": {"type": "object",
                    "required": ["position", "volume", "height"], "additionalProperties": false,
                    "properties": {
                        "position": {"type": "array", "items": num, "minItems": 3, "maxItems": 3,
                            "description": "centre of the column in the body frame, m"},
                        "volume": {"type": "number", "description": format!(
                            "m³, > 0, with volume/height in [{}, {}] m² (a column {MIN_HULL_SIZE} \
                            to {MAX_HULL_SIZE} m wide)",
                            MIN_HULL_SIZE * MIN_HULL_SIZE, MAX_HULL_SIZE * MAX_HULL_SIZE)},
                        "height": hull_size("m")}}}}}],
            "discriminator": {"propertyName": "kind"}},
        // crate::bodies::InputRequest, as SceneBodies::input checks it.
        "InputRequest": {"type": "object", "additionalProperties": false, "properties": {
            "force": {"type": "array", "items": within(MAX_INPUT_FORCE, num.clone()), "minItems": 3, "maxItems": 3,
                "default": [0, 0, 0], "description": "in the body frame, N (x forward)"},
            "torque": {"type": "array", "items": within(MAX_INPUT_TORQUE, num.clone()), "minItems": 3, "maxItems": 3,
                "default": [0, 0, 0], "description": "in the body frame, N·m (y: yaw)"},
            "from_tick": {"type": ["integer", "null"], "description": format!(
                "first scene tick it acts on, from the bodies' tick to {MAX_INPUT_TICKS} ticks \
                after it (default: the bodies' tick, so the next step)")},
            "ticks": {"type": ["integer", "null"], "minimum": 1, "maximum": MAX_INPUT_TICKS, "default": 1}}},
        // crate::service::types::SceneList and SceneSummary: GET /v1/scenes.
        "SceneList": {"type": "object", "required": ["scenes"], "additionalProperties": false,
            "properties": {"scenes": {"type": "array", "description": "every scene, sorted by id",
                "items": {"type": "object", "additionalProperties": false,
                    "required": ["id", "description", "layers", "tick_hz"],
                    "properties": {
                        "id": {"type": "string", "pattern": "^[a-z0-9-]{1,64}$"},
                        "description": {"type": "string", "maxLength": crate::scene::MAX_DESCRIPTION},
                        "layers": {"type": "array", "items": {"enum": ["sine", "gerstner", "fft", "particles"]},
                            "description": "layer kinds in order"},
                        "tick_hz": {"type": "number", "minimum": swell_waves::body::MIN_TICK_HZ,
                            "maximum": swell_waves::body::MAX_TICK_HZ, "description": "ticks per scene second"}}}}}},
        // crate::api::impacts::ImpactRequest: `t` checked against limits.max_time and the
        // position against limits.max_coordinate, then the impact as
        // swell_waves::particles::Impact::validate checks it (its own bounds on t and position).
        "ImpactRequest": {"type": "object", "required": ["position", "strength", "radius"],
            "additionalProperties": false, "properties": {
                "position": xz_within(limits.max_coordinate.min(MAX_IMPACT_COORD)),
                "t": within(limits.max_time.min(MAX_IMPACT_TIME), json!({"type": ["number", "null"],
                    "description": "scene time, s, within ±limits.max_time (default: the start of the next tick)"})),
                "strength": {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_STRENGTH, "description": "splash height, m"},
                "radius": {"type": "number", "minimum": MIN_IMPACT_RADIUS, "maximum": MAX_IMPACT_RADIUS,
                    "description": "particle radius, m"}}},
    })
}

/// `GET /docs`: a self-contained page (no CDN) that renders the endpoint list from
/// `/openapi.json`.
pub async fn docs() -> Html<&'static str> {
    Html(DOCS_HTML)
}

const DOCS_HTML: &str = r#"<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>Swell API</title>
<style>
body{font:15px/1.5 system-ui,sans-serif;max-width:60rem;margin:2rem auto;padding:0 1rem;color:#123}
h1{margin-bottom:0}.m{display:inline-block;width:4.5rem;font:bold 12px monospace;text-transform:uppercase}
.get{color:#06c}.post{color:#080}.put{color:#a60}.delete{color:#c00}
li{list-style:none;margin:.3rem 0}code{background:#eef;padding:0 .2rem}pre{background:#f4f6f8;padding:.6rem;overflow:auto}
</style></head><body>
<h1>Swell API</h1><p id="desc"></p>
<p>Machine-readable: <a href="/openapi.json">/openapi.json</a>. Errors are <code>{"error":{"code","message","field"}}</code>.
Admin and game endpoints (🔒) need <code>Authorization: Bearer &lt;token&gt;</code>.</p>
<ul id="routes"><li>loading /openapi.json…</li></ul>
<h2>Schemas</h2><div id="schemas"></div>
<script>
fetch('/openapi.json').then(r=>r.json()).then(doc=>{
  document.getElementById('desc').textContent=doc.info.description+' (version '+doc.info.version+')';
  const ul=document.getElementById('routes');ul.innerHTML='';
  for(const [path,ops] of Object.entries(doc.paths)){for(const [m,op] of Object.entries(ops)){
    const li=document.createElement('li');const s=document.createElement('span');s.className='m '+m;s.textContent=m;
    const c=document.createElement('code');c.textContent=path;li.append(s,c,' — '+op.summary+(op.security?' 🔒':''));ul.append(li);}}
  const sc=document.getElementById('schemas');
  for(const [name,s] of Object.entries(doc.components.schemas)){const h=document.createElement('h3');h.textContent=name;
    const p=document.createElement('pre');p.textContent=JSON.stringify(s,null,2);sc.append(h,p);}
}).catch(e=>{document.getElementById('routes').textContent='could not load /openapi.json: '+e;});
</script></body></html>
"#;

#[cfg(test)]
mod tests {
    use super::*;

    /// The `/shader` summary lists exactly the languages the handler accepts (it once offered
    /// godot, unity and unreal, which get 400).
    #[test]
    fn shader_summary_lists_the_accepted_langs() {
        let (_, _, summary) = ROUTES
            .iter()
            .find(|(m, p, _)| *m == "get" && *p == "/v1/scenes/{id}/shader")
            .unwrap();
        let langs = summary
            .split("?lang=")
            .nth(1)
            .and_then(|rest| rest.split('[').next())
            .unwrap();
        let names: Vec<&str> = Lang::ALL.iter().map(|l| l.name()).collect();
        assert_eq!(langs, names.join("|"));
    }

    /// The ranges that are limits are the given limits, and a limit that bounds nothing (not a
    /// positive finite number) gives no range.
    #[test]
    fn ranges_follow_the_limits() {
        let limits = crate::Limits {
            max_time: 5.0,
            max_coordinate: 7.0,
            max_points: 300,
            max_bodies: 2,
            ..Default::default()
        };
        let doc = openapi_document(&limits);
        let s = &doc["components"]["schemas"];
        let sample = &s["SampleRequest"]["properties"];
        assert_eq!(sample["t"]["maximum"], json!(5.0));
        assert_eq!(sample["points"]["maxItems"], json!(300));
        assert_eq!(sample["points"]["items"]["items"]["minimum"], json!(-7.0));
        let orientation = &s["OrientationRequest"]["properties"];
        assert_eq!(orientation["bodies"]["maxItems"], json!(2));
        let probes = &orientation["bodies"]["items"]["properties"]["probes"];
        assert_eq!(probes["maxItems"], json!(MAX_PROBES));
        let height = &doc["paths"]["/v1/scenes/{id}/height"]["get"]["parameters"];
        let x = height.as_array().unwrap().iter().find(|p| p["name"] == "x");
        assert_eq!(x.unwrap()["schema"]["maximum"], json!(7.0));

        // Fewer points than one body's probes: a body cannot have more probes than that.
        let few = crate::Limits {
            max_points: 10,
            ..limits
        };
        let doc = openapi_document(&few);
        let orientation = &doc["components"]["schemas"]["OrientationRequest"]["properties"];
        let probes = &orientation["bodies"]["items"]["properties"]["probes"];
        assert_eq!(probes["maxItems"], json!(10));

        let open = crate::Limits {
            max_time: f64::INFINITY,
            max_coordinate: f64::INFINITY,
            ..Default::default()
        };
        let doc = openapi_document(&open);
        let sample = &doc["components"]["schemas"]["SampleRequest"]["properties"];
        assert!(sample["t"].get("maximum").is_none(), "{}", sample["t"]);
        assert!(sample["origin"]["items"].get("minimum").is_none());
        // An impact's t is still bounded by the model.
        let impact = &doc["components"]["schemas"]["ImpactRequest"]["properties"];
        assert_eq!(impact["t"]["maximum"], json!(MAX_IMPACT_TIME));
    }

    #[test]
    fn path_names_are_the_braced_segments() {
        let names: Vec<&str> = path_names("/v1/scenes/{id}/bodies/{bid}/input").collect();
        assert_eq!(names, ["id", "bid"]);
        assert_eq!(path_names("/healthz").count(), 0);
    }
}
