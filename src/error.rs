//! [`ApiError`]: the one error every handler returns, rendered as
//! `{"error":{"code","message","field"?}}` with a fitting status.
//!
//! Lower layers return their own errors (`scene::SceneError`, `bodies::BodyError`,
//! `service::error::QueryError`, `service::json::JsonError`, `wire::convert::ConvertError`, …);
//! `mapping` turns each into an [`ApiError`], so nothing below the transports knows codes or
//! statuses. `protobuf` gives an [`ApiError`] its protobuf form.
//!
//! Client mistakes (4xx) are logged at `debug` at most; only server faults (5xx) are logged as
//! errors, and their internals never reach the client.

use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use swell_waves::SpecError;

mod code;
mod mapping;
mod protobuf;
pub use code::ErrorCode;

/// A request that could not be answered: a stable machine-readable `code` (which fixes the
/// status, [`ApiError::status`]), a message for people, and the offending field's path when
/// there is one.
#[derive(Debug, Clone, PartialEq)]
pub struct ApiError {
    /// Stable code, e.g. `bad_json`, `not_found`, `invalid_spec`; it decides the status.
    pub code: ErrorCode,
    /// What was wrong, in words.
    pub message: String,
    /// Path of the offending field (`points[3][0]`, `layers[1].waves[0].steepness`).
    pub field: Option<String>,
}

/// The wire form of an error: `{"error": {...}}`.
#[derive(Debug, Serialize)]
struct ErrorBody<'a> {
    error: ErrorDetail<'a>,
}

#[derive(Debug, Serialize)]
struct ErrorDetail<'a> {
    code: &'a str,
    message: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    field: Option<&'a str>,
}

impl ApiError {
    /// An error with no field; its status is the code's.
    pub fn new(code: ErrorCode, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
            field: None,
        }
    }

    /// The HTTP status, the code's one status.
    #[must_use]
    pub fn status(&self) -> StatusCode {
        self.code.status()
    }

    /// Names the offending field.
    pub fn with_field(mut self, field: impl Into<String>) -> Self {
        let f = field.into();
        self.field = if f.is_empty() { None } else { Some(f) };
        self
    }

    /// 400 `bad_json`: the body is not JSON of the expected shape.
    pub fn bad_json(message: impl Into<String>) -> Self {
        Self::new(ErrorCode::BadJson, message)
    }

    /// 400 `invalid_value`: a well-formed request with a value outside what is allowed.
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(ErrorCode::InvalidValue, message).with_field(field)
    }

    /// 404 `not_found`: no such scene.
    pub fn scene_not_found(id: &str) -> Self {
        Self::new(ErrorCode::NotFound, format!("no scene with id {id:?}"))
    }

    /// 422 `invalid_spec`: the model rejected a scene spec; message and field are the model's.
    pub fn invalid_spec(e: &SpecError) -> Self {
        Self::new(ErrorCode::InvalidSpec, e.to_string()).with_field(e.field())
    }

    /// 500 `internal`: something failed on our side. The detail is logged, not sent.
    pub fn internal(detail: impl std::fmt::Display) -> Self {
        tracing::error!(%detail, "internal error");
        Self::new(ErrorCode::Internal, "internal server error")
    }

    /// 500 `non_finite_result`: the answer to a valid request came out with a NaN or an
    /// infinity (a model fault the input checks did not foresee). Sent instead of the answer, so
    /// a client never reads a NaN (or JSON's `null`) as a value; the message names the number's
    /// path in the answer (`found` is e.g. `bodies[0].heave = NaN`). Logged as an error.
    pub fn non_finite(found: impl std::fmt::Display) -> Self {
        tracing::error!(%found, "non-finite number in an answer; sent an error instead");
        Self::new(
            ErrorCode::NonFiniteResult,
            format!(
                "the answer came out non-finite ({found}); no answer was sent rather than a wrong one"
            ),
        )
    }

    /// 503 `overloaded`.
    pub fn overloaded(message: impl Into<String>) -> Self {
        Self::new(ErrorCode::Overloaded, message)
    }
}

impl std::fmt::Display for ApiError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {}: {}",
            self.status().as_u16(),
            self.code,
            self.message
        )
    }
}

impl std::error::Error for ApiError {}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let status = self.status();
        if status.is_client_error() {
            tracing::debug!(status = status.as_u16(), code = self.code.as_str(), message = %self.message, "rejected request");
        }
        let body = ErrorBody {
            error: ErrorDetail {
                code: self.code.as_str(),
                message: &self.message,
                field: self.field.as_deref(),
            },
        };
        // Serialising this struct cannot fail (strings only); fall back to a fixed body anyway.
        let bytes = serde_json::to_vec(&body).unwrap_or_else(|_| {
            br#"{"error":{"code":"internal","message":"internal server error"}}"#.to_vec()
        });
        let mut resp = (status, bytes).into_response();
        resp.headers_mut().insert(
            header::CONTENT_TYPE,
            HeaderValue::from_static("application/json"),
        );
        // Kept for `api::wire::protobuf_errors`, which re-encodes it for protobuf clients.
        resp.extensions_mut().insert(self.clone());
        if status == StatusCode::UNAUTHORIZED {
            resp.headers_mut()
                .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
        }
        resp
    }
}
