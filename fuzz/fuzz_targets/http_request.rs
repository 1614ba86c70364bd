//! Arbitrary bytes as an HTTP request through the server's whole router (admission, roles,
//! extractors, handlers), in process. The first byte picks the shape, the rest is split at the
//! first 0xFF into `a` and `b`:
//! - 0: `GET /v1/scenes/calm/height?{a}` — query strings;
//! - 1: `GET /v1/scenes/harbour/impacts?{a}` — query strings of another extractor;
//! - 2: `POST /v1/scenes/harbour/impacts` with the admin token and body `a` — impact bodies;
//! - 3: `GET /v1/scenes/calm/stream` with `Sec-WebSocket-Key: {a}` and
//!   `Sec-WebSocket-Protocol: {b}` — the WebSocket handshake's checks.
//!
//! No panic; never a 5xx but 503 (load shedding); every rejection is the JSON error with a code.
#![no_main]

use std::sync::OnceLock;

use axum::body::Body;
use axum::http::{Method, Request, header};
use libfuzzer_sys::fuzz_target;
use tower::ServiceExt as _;

const TOKEN: &str = "fuzz-admin-token";

struct Fixture {
    rt: tokio::runtime::Runtime,
    app: axum::Router,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .expect("a runtime");
        let config = swell::Config {
            bind: ([127, 0, 0, 1], 0).into(),
            admin_token: Some(TOKEN.into()),
            ..Default::default()
        };
        let server = rt
            .block_on(swell::Server::bind(config))
            .expect("the server binds");
        let app = swell::router(server.state().clone());
        // The listener is never served; the state lives as long as the process.
        std::mem::forget(server);
        Fixture { rt, app }
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else {
        return;
    };
    let (a, b) = match rest.iter().position(|&c| c == 0xFF) {
        Some(i) => (&rest[..i], &rest[i + 1..]),
        None => (rest, &[][..]),
    };
    let text = String::from_utf8_lossy(a);
    let req = match which % 4 {
        0 => Request::get(format!("/v1/scenes/calm/height?{text}")).body(Body::empty()),
        1 => Request::get(format!("/v1/scenes/harbour/impacts?{text}")).body(Body::empty()),
        2 => Request::builder()
            .method(Method::POST)
            .uri("/v1/scenes/harbour/impacts")
            .header(header::AUTHORIZATION, format!("Bearer {TOKEN}"))
            .header(header::CONTENT_TYPE, "application/json")
            .header(header::CONTENT_LENGTH, a.len())
            .body(Body::from(a.to_vec())),
        _ => {
            let mut r = Request::get("/v1/scenes/calm/stream")
                .header(header::UPGRADE, "websocket")
                .header(header::CONNECTION, "upgrade")
                .header(header::SEC_WEBSOCKET_VERSION, "13");
            if let Ok(v) = header::HeaderValue::from_bytes(a) {
                r = r.header(header::SEC_WEBSOCKET_KEY, v);
            }
            if let Ok(v) = header::HeaderValue::from_bytes(b) {
                r = r.header(header::SEC_WEBSOCKET_PROTOCOL, v);
            }
            r.body(Body::empty())
        }
    };
    // A URI the client could not have sent (bytes that are not allowed in one) is not a request.
    let Ok(req) = req else { return };
    let f = fixture();
    let resp =
        f.rt.block_on(f.app.clone().oneshot(req))
            .expect("the router is infallible");
    let status = resp.status();
    assert!(
        !status.is_server_error() || status.as_u16() == 503,
        "{status} for a client's request"
    );
    if status.is_client_error() || status.is_server_error() {
        let ct = resp
            .headers()
            .get(header::CONTENT_TYPE)
            .and_then(|v| v.to_str().ok())
            .unwrap_or("")
            .to_owned();
        assert!(ct.starts_with("application/json"), "{status} as {ct:?}");
        let body =
            f.rt.block_on(axum::body::to_bytes(resp.into_body(), 1 << 20))
                .expect("an error body");
        let v: serde_json::Value = serde_json::from_slice(&body).expect("a JSON error");
        assert!(v["error"]["code"].is_string(), "{v}");
    }
});
