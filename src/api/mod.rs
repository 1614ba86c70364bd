//! The HTTP API: routes, middleware, and the handlers by concern.
//!
//! - [`json`] — the size-limited JSON body extractor.
//! - [`scenes`] — list, detail, put, delete, clock.
//! - [`query`] — height, sample, orientation (the queries themselves are
//!   [`crate::service::query`], shared with the WebSocket).
//! - [`bodies`] — floating-body endpoints (spawn, list, read, delete, input).
//! - [`admin`] — bearer-token check.
//! - [`ops`] — health, readiness, metrics, OpenAPI, docs page.
//! - [`wire`] — JSON/protobuf content negotiation for query bodies and answers.
//! - [`shader`] — the generated shader, the frame's uniforms, FFT spectra (GPU clients).
//! - [`viewer`] — the browser viewer's page and scripts (`/viewer`).
//!
//! Middleware, outermost first: panic → 500 JSON; trace span; metrics by route and status;
//! errors re-encoded as protobuf for clients that accept it;
//! in-flight limit (503 beyond it, never an unbounded queue) and timeout (503); body-size limit.

pub mod admin;
pub mod bodies;
pub mod impacts;
pub mod json;
pub mod ops;
pub mod query;
pub mod scenes;
pub mod serve;
pub mod shader;
pub mod viewer;
pub mod wire;

use std::sync::Arc;
use std::time::Instant;

use axum::Router;
use axum::extract::{DefaultBodyLimit, MatchedPath, Request, State};
use axum::http::StatusCode;
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use tokio::sync::Semaphore;
use tower_http::catch_panic::CatchPanicLayer;
use tower_http::trace::TraceLayer;

use crate::error::ApiError;
use crate::state::AppState;

/// The router over `state`: every endpoint and middleware.
pub fn router(state: AppState) -> Router {
    let limits = state.limits.clone();
    let in_flight = Arc::new(Semaphore::new(limits.max_in_flight.max(1)));
    let timeout = limits.request_timeout();
    Router::new()
        .route("/v1/scenes", get(scenes::list))
        .route(
            "/v1/scenes/{id}",
            get(scenes::get).put(scenes::put).delete(scenes::delete),
        )
        .route(
            "/v1/scenes/{id}/clock",
            get(scenes::get_clock).put(scenes::put_clock),
        )
        .route("/v1/scenes/{id}/height", get(query::height))
        .route("/v1/scenes/{id}/sample", axum::routing::post(query::sample))
        .route(
            "/v1/scenes/{id}/orientation",
            axum::routing::post(query::orientation),
        )
        .route(
            "/v1/scenes/{id}/bodies",
            get(bodies::list).post(bodies::create),
        )
        .route(
            "/v1/scenes/{id}/bodies/{bid}",
            get(bodies::get_one).delete(bodies::delete),
        )
        .route(
            "/v1/scenes/{id}/bodies/{bid}/input",
            axum::routing::post(bodies::input),
        )
        .route(
            "/v1/scenes/{id}/impacts",
            get(impacts::list).post(impacts::create),
        )
        .route("/v1/scenes/{id}/shader", get(shader::shader))
        .route("/v1/scenes/{id}/uniforms", get(shader::uniforms))
        .route("/v1/scenes/{id}/spectrum", get(shader::spectrum))
        .route("/v1/scenes/{id}/stream", get(crate::stream::stream))
        .route("/healthz", get(ops::healthz))
        .route("/readyz", get(ops::readyz))
        .route("/metrics", get(ops::metrics))
        .route("/openapi.json", get(ops::openapi))
        .route("/docs", get(ops::docs))
        .merge(viewer::routes())
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(DefaultBodyLimit::max(limits.max_body_bytes))
        .layer(middleware::from_fn_with_state(
            (in_flight, timeout),
            limit_and_timeout,
        ))
        .layer(middleware::from_fn(wire::protobuf_errors))
        .layer(middleware::from_fn(track_metrics))
        .layer(TraceLayer::new_for_http())
        .layer(CatchPanicLayer::custom(|_panic| {
            ApiError::internal("a handler panicked").into_response()
        }))
        .with_state(state)
}

async fn not_found() -> ApiError {
    ApiError::new(StatusCode::NOT_FOUND, "not_found", "no such endpoint")
}

async fn method_not_allowed() -> ApiError {
    ApiError::new(
        StatusCode::METHOD_NOT_ALLOWED,
        "method_not_allowed",
        "this endpoint does not take that method",
    )
}

/// Sheds load beyond `max_in_flight` (503 at once, rather than queueing without bound) and
/// answers 503 to a request that runs past the timeout. A timed-out blocking query still runs to
/// its end on its thread; the in-flight permit is released with the response, so the limit
/// bounds what clients wait on, not the CPU already committed.
async fn limit_and_timeout(
    State((sem, timeout)): State<(Arc<Semaphore>, std::time::Duration)>,
    req: Request,
    next: Next,
) -> Response {
    let Ok(_permit) = sem.try_acquire() else {
        metrics::counter!("swell_http_shed_total").increment(1);
        return ApiError::overloaded("too many requests in flight; retry shortly").into_response();
    };
    match tokio::time::timeout(timeout, next.run(req)).await {
        Ok(r) => r,
        Err(_) => ApiError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "timeout",
            format!("the request took longer than {} ms", timeout.as_millis()),
        )
        .into_response(),
    }
}

/// Counts requests and records latency by route (the matched pattern, not the raw path, so ids
/// do not explode the label set), method and status.
async fn track_metrics(req: Request, next: Next) -> Response {
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map_or_else(|| "unmatched".to_owned(), |m| m.as_str().to_owned());
    let method = req.method().as_str().to_owned();
    let start = Instant::now();
    let resp = next.run(req).await;
    let status = resp.status().as_u16().to_string();
    let labels = [("route", route), ("method", method), ("status", status)];
    metrics::counter!("swell_http_requests_total", &labels).increment(1);
    metrics::histogram!("swell_http_request_duration_seconds", &labels)
        .record(start.elapsed().as_secs_f64());
    resp
}
