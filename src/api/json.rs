//! JSON bodies over HTTP: [`RawBody`], the size-limited body extractor admin endpoints take
//! before they check the token and parse (with [`crate::service::json::from_slice`], which names
//! the path of the offending field), so malformed input always comes back as an [`ApiError`].
//!
//! Query bodies may also be protobuf: see [`crate::api::wire`], whose `Body` extractor decodes
//! either into the same request types. Admin bodies (scene specs, clock updates, body spawns and
//! inputs) are JSON only; protobuf gets 415.

use axum::body::Bytes;
use axum::extract::{FromRequest, Request};
use axum::http::{StatusCode, header};

use crate::error::{ApiError, ErrorCode};

/// The raw body of a request, size-limited, with errors as [`ApiError`]. Admin handlers take this
/// and parse after checking the token, so an unauthenticated client learns nothing about specs.
#[derive(Debug)]
pub struct RawBody(pub Bytes);

impl<S: Send + Sync> FromRequest<S> for RawBody {
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, Self::Rejection> {
        if let Some(ct) = req.headers().get(header::CONTENT_TYPE)
            && ct.as_bytes().starts_with(b"application/x-protobuf")
        {
            return Err(ApiError::new(
                ErrorCode::UnsupportedMediaType,
                "this endpoint takes JSON only (protobuf is for query bodies)",
            ));
        }
        read_bytes(req, state).await.map(RawBody)
    }
}

/// Reads a whole body within the size limit.
///
/// # Errors
/// 413 `body_too_large` beyond `max_body_bytes`; 400 if the body cannot be read.
pub async fn read_bytes<S: Send + Sync>(req: Request, state: &S) -> Result<Bytes, ApiError> {
    match Bytes::from_request(req, state).await {
        Ok(b) => Ok(b),
        Err(r) if r.status() == StatusCode::PAYLOAD_TOO_LARGE => Err(ApiError::new(
            ErrorCode::BodyTooLarge,
            "request body is larger than the server's limit (max_body_bytes)",
        )),
        Err(r) => Err(ApiError::bad_json(r.body_text())),
    }
}
