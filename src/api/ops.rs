//! Operations endpoints: health, readiness, metrics, the OpenAPI document and the docs page.
//!
//! The OpenAPI document is written by hand (a small `json!` value) rather than generated with
//! utoipa: it keeps the build lean and the API is small; `tests/server/api.rs` checks that every route
//! the router serves is listed.

use axum::extract::State;
use axum::http::{HeaderValue, header};
use axum::response::{Html, IntoResponse, Response};
use serde_json::{Value, json};

use crate::access::Role;
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

/// `GET /openapi.json`.
pub async fn openapi() -> axum::Json<Value> {
    axum::Json(openapi_document())
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
        "Spawn a floating body (game): {mass, hull, position, yaw?, drag?...} → 201 state, spawn_tick, anchor_tick",
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
        "Force/torque in the body frame from a tick for some ticks (game): {force, torque, from_tick?, ticks?} → 202 {tick, from_tick, ticks, anchor_tick?}",
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
        "The scene's generated shader code: ?lang=wgsl|glsl|hlsl|msl|godot|unity|unreal",
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

/// The OpenAPI 3.1 document.
pub fn openapi_document() -> Value {
    let mut paths = serde_json::Map::new();
    for (method, path, summary) in ROUTES {
        let entry = paths.entry(path.to_string()).or_insert_with(|| json!({}));
        let mut op = json!({
            "summary": summary,
            "responses": {"200": {"description": "ok"}, "4XX": error_ref(), "5XX": error_ref()},
        });
        if path.contains("{id}") {
            op["parameters"] = json!([{"name": "id", "in": "path", "required": true,
                "schema": {"type": "string", "pattern": "^[a-z0-9-]{1,64}$"}}]);
        }
        if *path == "/v1/scenes/{id}/height"
            && let Some(p) = op["parameters"].as_array_mut()
        {
            for (n, req) in [("x", true), ("z", true), ("t", false)] {
                p.push(json!({"name": n, "in": "query", "required": req, "schema": {"type": "number"}}));
            }
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
        let schema = match (*method, *path) {
            ("put", "/v1/scenes/{id}") => Some("SceneSpec"),
            ("put", "/v1/scenes/{id}/clock") => Some("ClockUpdate"),
            ("post", "/v1/scenes/{id}/sample") => Some("SampleRequest"),
            ("post", "/v1/scenes/{id}/orientation") => Some("OrientationRequest"),
            _ => None,
        };
        if let Some(s) = schema {
            let mut content = json!({"application/json":
                {"schema": {"$ref": format!("#/components/schemas/{s}")}}});
            if *method == "post" {
                content["application/x-protobuf"] = protobuf_content(s);
            }
            op["requestBody"] = json!({"required": true, "content": content});
        }
        let answer = match *path {
            "/v1/scenes/{id}/sample" => Some("SampleResponse"),
            "/v1/scenes/{id}/orientation" => Some("OrientationResponse"),
            "/v1/scenes/{id}/height" => Some("HeightResponse"),
            _ => None,
        };
        if let Some(a) = answer {
            op["responses"]["200"] = json!({"description": "ok (JSON, or protobuf with Accept: application/x-protobuf)",
                "content": {"application/json": {}, "application/x-protobuf": protobuf_content(a)}});
        }
        if *path == "/v1/scenes/{id}/stream" {
            op["description"] = json!(
                "Upgrade to a WebSocket. Subprotocol swell.v1.json (default): text frames \
                tagged by \"type\" (client: ping {id, client_time}, sample {id, ...as POST sample}, \
                orientation {id, ...}, subscribe {ticks, bodies?}; server: pong, sample_result, \
                orientation_result, tick {tick, t, bodies, impacts? [{tick, t, position, strength, radius, \
                body_tick?}], anchor_tick?}, error {id?, code, message, field?}, \
                clock {t, tick, tick_hz, rate, paused, unix, generation} when the clock changes). \
                swell.v1.protobuf: binary frames of swell.v1.ClientMessage / ServerMessage \
                (proto/swell/v1/stream.proto). 404 for an unknown scene and 400 without an \
                upgrade or with an unknown subprotocol, before the upgrade."
            );
            op["responses"] = json!({"101": {"description": "switching protocols"},
                "4XX": error_ref(), "5XX": error_ref()});
        }
        entry[*method] = op;
    }
    let num = json!({"type": "number"});
    let xz = json!({"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2});
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
            "schemas": {
                "Error": {"type": "object", "properties": {"error": {"type": "object",
                    "required": ["code", "message"],
                    "properties": {"code": {"type": "string"}, "message": {"type": "string"}, "field": {"type": "string"}}}}},
                "SceneSpec": {"type": "object", "required": ["layers"], "properties": {
                    "description": {"type": "string"}, "tick_hz": num, "seed": {"type": "integer"},
                    "gravity": num, "depth": {"type": ["number", "null"]},
                    "layers": {"type": "array", "items": {"type": "object", "required": ["kind"],
                        "properties": {"kind": {"enum": ["sine", "gerstner", "fft"]}}}}}},
                "ClockUpdate": {"type": "object", "properties": {"rate": num, "paused": {"type": "boolean"}, "t": num}},
                "SampleRequest": {"type": "object", "required": ["points"], "properties": {
                    "t": num, "origin": xz, "points": {"type": "array", "items": xz},
                    "fields": {"type": "array", "items": {"enum": ["height", "normal", "displacement", "jacobian", "residual"]}},
                    "accuracy": {"type": "object", "properties": {
                        "method": {"enum": ["newton", "fixed_point"]}, "iterations": {"type": "integer"},
                        "tolerance": num, "filter": {"enum": ["nearest", "bilinear", "bicubic"]},
                        "precision": {"enum": ["f64", "f32"]},
                        "time": {"enum": ["grid", "exact"]}}}}},
                "OrientationRequest": {"type": "object", "required": ["bodies"], "properties": {
                    "t": num, "bodies": {"type": "array", "items": {"type": "object",
                        "required": ["position", "length", "beam"], "properties": {
                            "position": xz, "yaw": num, "length": num, "beam": num,
                            "probes": {"type": "array", "items": xz}}}}}},
            },
        },
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
Admin endpoints need <code>Authorization: Bearer &lt;token&gt;</code>.</p>
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
