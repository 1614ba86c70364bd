//! One error shape everywhere: [`json_errors`] turns a rejection that an extractor or a layer
//! wrote as plain text (a path segment that is not UTF-8, a malformed query string, a body limit)
//! into the JSON error every other rejection is, with a code that fits its status.

use axum::extract::Request;
use axum::http::{StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use http_body_util::BodyExt as _;

use crate::Limits;
use crate::error::{ApiError, ErrorCode};

/// Longest plain-text rejection kept as the JSON error's message, bytes.
const MAX_MESSAGE: usize = 1024;

/// The code of a rejection nobody gave a code, by status. The code decides the status of the
/// rewritten answer: a status with a code of its own keeps it; any other 4xx becomes 400
/// `bad_request` and any other 5xx 500 `internal` (no code has two statuses).
pub fn code_for(status: StatusCode) -> ErrorCode {
    match status.as_u16() {
        400 => ErrorCode::BadRequest,
        401 => ErrorCode::Unauthorized,
        403 => ErrorCode::Forbidden,
        404 => ErrorCode::NoSuchRoute,
        405 => ErrorCode::MethodNotAllowed,
        408 => ErrorCode::RequestTimeout,
        413 => ErrorCode::BodyTooLarge,
        414 => ErrorCode::UriTooLong,
        415 => ErrorCode::UnsupportedMediaType,
        429 => ErrorCode::RateLimited,
        431 => ErrorCode::HeadersTooLarge,
        503 => ErrorCode::Overloaded,
        s if s >= 500 => ErrorCode::Internal,
        _ => ErrorCode::BadRequest,
    }
}

/// Rewrites 4xx/5xx answers that are not JSON (nor protobuf, nor an HTML page) as the JSON
/// error.
pub async fn json_errors(req: Request, next: Next) -> Response {
    let resp = next.run(req).await;
    let status = resp.status();
    if !(status.is_client_error() || status.is_server_error()) {
        return resp;
    }
    let typed = resp
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|ct| {
            // HTML is a page the server wrote on purpose (the viewer on an unknown scene).
            ct.starts_with("application/json")
                || ct.starts_with("application/x-protobuf")
                || ct.starts_with("text/html")
        });
    if typed {
        return resp;
    }
    let (parts, body) = resp.into_parts();
    // Rejection texts are short; a long body is cut rather than read whole.
    let limited = http_body_util::Limited::new(body, MAX_MESSAGE * 4);
    let text = match limited.collect().await {
        Ok(b) => String::from_utf8_lossy(&b.to_bytes()).into_owned(),
        Err(_) => String::new(),
    };
    let mut message: String = text.trim().chars().take(MAX_MESSAGE).collect();
    if message.is_empty() {
        message = status
            .canonical_reason()
            .unwrap_or("request rejected")
            .to_owned();
    }
    let mut out = ApiError::new(code_for(status), message).into_response();
    // Headers that say how to retry or what is allowed survive the rewrite.
    for name in [header::RETRY_AFTER, header::ALLOW, header::CONNECTION] {
        if let Some(v) = parts.headers.get(&name) {
            out.headers_mut().insert(name, v.clone());
        }
    }
    out
}

/// A query string that cannot be read into its fields (`x=abc`, an unknown name, bad
/// percent-encoding): 400 `bad_request`, naming the field when serde's message does
/// (`Failed to deserialize query string: x: invalid float literal`).
pub fn query_rejection(r: &axum::extract::rejection::QueryRejection) -> ApiError {
    let text = r.body_text();
    let detail = text
        .split_once("query string: ")
        .map_or(text.as_str(), |(_, d)| d);
    let field = detail
        .split_once(": ")
        .map(|(f, _)| f)
        .filter(|f| !f.is_empty() && f.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'));
    let e = ApiError::new(
        ErrorCode::BadRequest,
        format!("the query string cannot be read: {detail}"),
    );
    match field {
        Some(f) => e.with_field(f),
        None => e,
    }
}

/// The request-head limits [`check_head`] applies (from [`Limits`]).
#[derive(Debug, Clone, Copy)]
pub struct HeadLimits {
    uri_bytes: usize,
    header_bytes: usize,
    headers: usize,
}

impl From<&Limits> for HeadLimits {
    fn from(l: &Limits) -> HeadLimits {
        HeadLimits {
            uri_bytes: l.max_uri_bytes,
            header_bytes: l.max_header_bytes,
            headers: l.max_headers,
        }
    }
}

/// Answers a request whose URI or headers are over the limits with the JSON 414 or 431,
/// before anything reads them further. (The HTTP parser's own, larger limits answer a bare
/// status: past them there is no request to route.)
pub async fn check_head(limits: HeadLimits, req: Request, next: Next) -> Response {
    let uri = req
        .uri()
        .path_and_query()
        .map_or(req.uri().path().len(), |p| p.as_str().len());
    if uri > limits.uri_bytes {
        return ApiError::new(
            ErrorCode::UriTooLong,
            format!(
                "the request URI is {uri} bytes; at most {} (max_uri_bytes)",
                limits.uri_bytes
            ),
        )
        .into_response();
    }
    let headers = req.headers();
    if headers.len() > limits.headers {
        return ApiError::new(
            ErrorCode::HeadersTooLarge,
            format!(
                "{} request headers; at most {} (max_headers)",
                headers.len(),
                limits.headers
            ),
        )
        .into_response();
    }
    // Each header as written on the wire: `name: value\r\n`.
    let bytes: usize = headers
        .iter()
        .map(|(n, v)| n.as_str().len() + v.len() + 4)
        .sum();
    if bytes > limits.header_bytes {
        return ApiError::new(
            ErrorCode::HeadersTooLarge,
            format!(
                "the request headers are {bytes} bytes; at most {} (max_header_bytes)",
                limits.header_bytes
            ),
        )
        .into_response();
    }
    next.run(req).await
}
