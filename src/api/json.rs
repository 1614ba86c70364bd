//! JSON bodies: parsing with the path of the offending field ([`from_slice`], [`from_value`]),
//! and [`RawBody`], the size-limited body extractor admin endpoints take before they check the
//! token and parse, so malformed input always comes back as an [`ApiError`].
//!
//! Query bodies may also be protobuf: see [`crate::api::wire`], whose `Body` extractor decodes
//! either into the same request types. Admin bodies (scene specs, clock updates, body spawns and
//! inputs) are JSON only; protobuf gets 415.

use axum::body::Bytes;
use axum::extract::{FromRequest, Request};
use axum::http::{StatusCode, header};
use serde::de::DeserializeOwned;

use crate::error::ApiError;

/// Parses JSON bytes into `T`, naming the path of a wrong or unknown field.
///
/// # Errors
/// 400 `bad_json` with serde's message and the field path.
pub fn from_slice<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, ApiError> {
    let mut de = serde_json::Deserializer::from_slice(bytes);
    let v = serde_path_to_error::deserialize(&mut de).map_err(path_error)?;
    de.end().map_err(|e| ApiError::bad_json(e.to_string()))?;
    Ok(v)
}

/// Deserialises `T` from a JSON value, naming the path of a wrong or unknown field.
///
/// # Errors
/// 400 `bad_json` with serde's message and the field path.
pub fn from_value<T: DeserializeOwned>(v: serde_json::Value) -> Result<T, ApiError> {
    serde_path_to_error::deserialize(v).map_err(path_error)
}

fn path_error(e: serde_path_to_error::Error<serde_json::Error>) -> ApiError {
    let path = e.path().to_string();
    let message = e.inner().to_string();
    let mut field = if path == "." { String::new() } else { path };
    // serde names an unknown field only in the message; put it in the path too.
    if let Some(rest) = message.strip_prefix("unknown field `")
        && let Some(name) = rest.split('`').next()
    {
        // serde_path_to_error includes the unknown key itself in some paths (plain structs)
        // and not in others (inside internally tagged enums, which serde buffers).
        let last = field.rsplit('.').next().unwrap_or("");
        if last != name {
            field = if field.is_empty() {
                name.to_owned()
            } else {
                format!("{field}.{name}")
            };
        }
    }
    let message = if field.is_empty() {
        message
    } else {
        format!("{field}: {message}")
    };
    ApiError::bad_json(message).with_field(field)
}

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
                StatusCode::UNSUPPORTED_MEDIA_TYPE,
                "unsupported_media_type",
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
            StatusCode::PAYLOAD_TOO_LARGE,
            "body_too_large",
            "request body is larger than the server's limit (max_body_bytes)",
        )),
        Err(r) => Err(ApiError::bad_json(r.body_text())),
    }
}
