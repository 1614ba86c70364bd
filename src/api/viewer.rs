//! The browser viewer: `GET /viewer` and `/viewer/{scene}` serve a page that renders a scene's
//! sea with the exported shaders and its floating bodies from the stream; `/viewer/assets/…`
//! serves its scripts (the page's, its WebGPU renderer, and the worker that runs FFT layers off
//! the main thread) and the `swell-client` package they run on.
//!
//! Every asset is built into the binary (`include_str!`): the page works offline and needs no
//! CDN. It is read-only: it calls GET endpoints, `POST …/sample` and the stream, never an admin
//! endpoint. Sources: `clients/viewer/` (page and script) and `clients/js/src/` (the package).

use axum::Router;
use axum::extract::{Path, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;

use crate::error::{ApiError, ErrorCode};
use crate::state::AppState;

const INDEX_HTML: &str = include_str!("../../clients/viewer/index.html");
const VIEWER_JS: &str = include_str!("../../clients/viewer/viewer.js");
const FFT_WORKER_JS: &str = include_str!("../../clients/viewer/fft-worker.js");
const WEBGPU_JS: &str = include_str!("../../clients/viewer/webgpu.js");

/// The `swell-client` package's modules, by file name (what `viewer.js` imports from
/// `/viewer/assets/client/`).
const CLIENT: &[(&str, &str)] = &[
    ("index.js", include_str!("../../clients/js/src/index.js")),
    ("client.js", include_str!("../../clients/js/src/client.js")),
    ("errors.js", include_str!("../../clients/js/src/errors.js")),
    ("fft.js", include_str!("../../clients/js/src/fft.js")),
    ("interp.js", include_str!("../../clients/js/src/interp.js")),
    ("libm.js", include_str!("../../clients/js/src/libm.js")),
    ("math.js", include_str!("../../clients/js/src/math.js")),
    (
        "particles.js",
        include_str!("../../clients/js/src/particles.js"),
    ),
    ("proto.js", include_str!("../../clients/js/src/proto.js")),
    (
        "session.js",
        include_str!("../../clients/js/src/session.js"),
    ),
    (
        "surface.js",
        include_str!("../../clients/js/src/surface.js"),
    ),
];

/// The viewer's routes (merged into the API router).
pub fn routes() -> Router<AppState> {
    Router::new()
        .route("/viewer", get(page))
        .route("/viewer/", get(page))
        .route("/viewer/{scene}", get(scene_page))
        .route("/viewer/assets/viewer.js", get(script))
        .route("/viewer/assets/fft-worker.js", get(fft_worker))
        .route("/viewer/assets/webgpu.js", get(webgpu))
        .route("/viewer/assets/client/{file}", get(client_module))
        .route("/viewer/assets/{*rest}", get(no_asset))
}

fn asset(content_type: &'static str, body: &'static str) -> Response {
    let mut r = (StatusCode::OK, body).into_response();
    let h = r.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    // The assets change only with the binary; revalidation is cheap and avoids stale scripts.
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
    r
}

/// The page (`/viewer`: the script picks a scene).
async fn page() -> Response {
    asset("text/html; charset=utf-8", INDEX_HTML)
}

/// The page on one scene (the script reads it from the path). An unknown scene still gets the
/// page, which shows the server's `not_found` and offers the picker, but with status 404, so a
/// link checker or a script sees the miss.
async fn scene_page(State(state): State<AppState>, Path(scene): Path<String>) -> Response {
    let mut r = page().await;
    if state.scene(&scene).is_err() {
        *r.status_mut() = StatusCode::NOT_FOUND;
    }
    r
}

/// Any other file under `/viewer/assets/`.
async fn no_asset() -> ApiError {
    ApiError::new(ErrorCode::NotFound, "no such viewer asset")
}

async fn script() -> Response {
    asset("text/javascript; charset=utf-8", VIEWER_JS)
}

async fn fft_worker() -> Response {
    asset("text/javascript; charset=utf-8", FFT_WORKER_JS)
}

async fn webgpu() -> Response {
    asset("text/javascript; charset=utf-8", WEBGPU_JS)
}

async fn client_module(Path(file): Path<String>) -> Result<Response, ApiError> {
    CLIENT
        .iter()
        .find(|(name, _)| *name == file)
        .map(|(_, body)| asset("text/javascript; charset=utf-8", body))
        .ok_or_else(|| ApiError::new(ErrorCode::NotFound, "no such viewer asset"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every module the package's index imports is served, so the page cannot 404 on an import.
    #[test]
    fn every_client_import_is_served() {
        for (name, body) in CLIENT {
            for dep in body.split("from './").skip(1) {
                let file = dep.split('\'').next().unwrap();
                assert!(
                    CLIENT.iter().any(|(n, _)| *n == file),
                    "{name} imports {file}"
                );
            }
        }
        assert!(VIEWER_JS.contains("/viewer/assets/client/index.js"));
        assert!(VIEWER_JS.contains("/viewer/assets/fft-worker.js"));
        assert!(VIEWER_JS.contains("/viewer/assets/webgpu.js"));
        assert!(FFT_WORKER_JS.contains("/viewer/assets/client/fft.js"));
        assert!(!INDEX_HTML.contains("https://") && !VIEWER_JS.contains("https://"));
    }
}
