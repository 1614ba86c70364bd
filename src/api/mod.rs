//! The HTTP API: routes, middleware, and the handlers by concern.
//!
//! - [`json`] — the size-limited JSON body extractor.
//! - [`scenes`] — list, detail, put, delete, clock.
//! - [`query`] — height, sample, orientation (the queries themselves are
//!   [`crate::service::query`], shared with the WebSocket).
//! - [`bodies`] — floating-body endpoints (spawn, list, read, delete, input).
//! - [`admin`] — bearer-token check.
//! - [`ops`] — health, readiness, metrics, OpenAPI, docs page.
//! - [`stream_schemas`] — the JSON Schemas of the WebSocket stream's messages, in the OpenAPI
//!   document.
//! - [`body_schemas`] — the JSON Schemas of bodies and impacts (the HTTP answers and the
//!   stream's tick frames share them), in the OpenAPI document.
//! - [`wire`] — JSON/protobuf content negotiation for query bodies and answers.
//! - [`shader`] — the generated shader, the frame's uniforms, FFT spectra (GPU clients).
//! - [`viewer`] — the browser viewer's page and scripts (`/viewer`).
//!
//! - [`admission`] — rate limits, roles, body deadlines, the in-flight limit and the byte
//!   budget, in that order (the limiters and budgets themselves: [`crate::peers`]).
//!
//! Middleware, outermost first: panic → 500 JSON; trace span; metrics by route and status;
//! errors re-encoded as protobuf for clients that accept it; every other error made JSON;
//! admission ([`admission::admit`]); body-size limit. The health probes sit outside all but
//! the first three: client traffic cannot make them wait.

pub mod admin;
pub mod admission;
pub mod bodies;
pub mod body_schemas;
pub mod errors;
pub mod impacts;
pub mod json;
pub mod ops;
pub mod query;
pub mod scenes;
pub mod serve;
pub mod shader;
pub mod stream_schemas;
pub mod viewer;
pub mod wire;

use std::sync::Arc;
use std::time::Instant;

use axum::Router;
use axum::extract::{DefaultBodyLimit, MatchedPath, Request};
use axum::http::Method;
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use tower_http::catch_panic::CatchPanicLayer;
use tower_http::trace::TraceLayer;

use crate::error::{ApiError, ErrorCode};
use crate::state::AppState;
use errors::HeadLimits;

/// The router over `state`: every endpoint and middleware.
pub fn router(state: AppState) -> Router {
    let limits = state.limits.clone();
    let gate = admission::Gate::new(
        state.clone(),
        state.peer_policy.clone(),
        Arc::clone(&state.buffers),
    );
    let api = Router::new()
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
        .route("/metrics", get(ops::metrics))
        .route("/openapi.json", get(ops::openapi))
        .route("/docs", get(ops::docs))
        .merge(viewer::routes())
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(DefaultBodyLimit::max(limits.max_body_bytes))
        .layer(middleware::from_fn_with_state(gate, admission::admit))
        .layer(middleware::from_fn(errors::json_errors))
        .layer(middleware::from_fn(wire::protobuf_errors));
    let head = HeadLimits::from(&limits);
    probes()
        .merge(api)
        .layer(middleware::from_fn(move |req: Request, next: Next| {
            errors::check_head(head, req, next)
        }))
        .layer(middleware::from_fn(track_metrics))
        .layer(TraceLayer::new_for_http())
        .layer(CatchPanicLayer::custom(|_panic| {
            ApiError::internal("a handler panicked").into_response()
        }))
        .with_state(state)
}

/// `/healthz` and `/readyz`: no admission, no limits.
fn probes() -> Router<AppState> {
    Router::new()
        .route("/healthz", get(ops::healthz))
        .route("/readyz", get(ops::readyz))
}

/// The router of `--probe-bind`: the probes and `/metrics`, nothing a client can fill.
pub fn probe_router(state: AppState) -> Router {
    probes()
        .route("/metrics", get(ops::metrics))
        .fallback(not_found)
        .layer(CatchPanicLayer::custom(|_panic| {
            ApiError::internal("a handler panicked").into_response()
        }))
        .with_state(state)
}

async fn not_found() -> ApiError {
    ApiError::new(ErrorCode::NoSuchRoute, "no such endpoint")
}

async fn method_not_allowed() -> ApiError {
    ApiError::new(
        ErrorCode::MethodNotAllowed,
        "this endpoint does not take that method",
    )
}

/// Counts requests and records latency by route (the matched pattern, not the raw path, so ids
/// do not explode the label set), method and status.
async fn track_metrics(req: Request, next: Next) -> Response {
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map_or_else(|| "unmatched".to_owned(), |m| m.as_str().to_owned());
    // A fixed set: the method is client input, and every label value is a new time series.
    let method = match *req.method() {
        Method::GET => "GET",
        Method::POST => "POST",
        Method::PUT => "PUT",
        Method::DELETE => "DELETE",
        Method::HEAD => "HEAD",
        Method::OPTIONS => "OPTIONS",
        Method::PATCH => "PATCH",
        _ => "other",
    };
    let start = Instant::now();
    let resp = next.run(req).await;
    let status = resp.status().as_u16().to_string();
    let labels = [
        ("route", route),
        ("method", method.to_owned()),
        ("status", status),
    ];
    metrics::counter!("swell_http_requests_total", &labels).increment(1);
    metrics::histogram!("swell_http_request_duration_seconds", &labels)
        .record(start.elapsed().as_secs_f64());
    resp
}
