//! Content negotiation between JSON and protobuf on the HTTP query endpoints.
//!
//! - A body with `Content-Type: application/x-protobuf` decodes from protobuf
//!   (`swell.v1.SampleRequest`, ...) into the same request struct JSON decodes into; any other
//!   content type is read as JSON (so `curl -d` works without a header).
//! - `Accept: application/x-protobuf` makes the answer protobuf (`swell.v1.SampleResponse`,
//!   ...), and every error an `ErrorResponse` ([`protobuf_errors`] re-encodes errors produced
//!   anywhere, extractors included).
//!
//! The conversions themselves live in [`crate::wire::convert`].

use axum::extract::{FromRequest, FromRequestParts, Request};
use axum::http::request::Parts;
use axum::http::{HeaderMap, HeaderValue, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use prost::Message;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::api::json::read_bytes;
use crate::error::{ApiError, ErrorCode};
use crate::service::finite::check_answer;
use crate::service::json::from_slice;
use crate::service::types::{
    HeightResponse, OrientationRequest, OrientationResponse, SampleRequest, SampleResponse,
};
use crate::wire::v1;

/// The protobuf media type, for `Content-Type` and `Accept`.
pub const PROTOBUF: &str = "application/x-protobuf";

/// A wire format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// JSON (the default).
    Json,
    /// Protobuf (`application/x-protobuf`).
    Protobuf,
}

impl Format {
    /// Bytes a number of an answer takes at most in this format (for the byte budget).
    pub fn number_bytes(self) -> usize {
        match self {
            Format::Json => crate::service::query::JSON_NUMBER_BYTES,
            Format::Protobuf => crate::service::query::PROTOBUF_NUMBER_BYTES,
        }
    }
}

fn names_protobuf(headers: &HeaderMap, name: header::HeaderName) -> bool {
    headers
        .get_all(name)
        .iter()
        .any(|v| v.to_str().is_ok_and(|s| s.contains(PROTOBUF)))
}

impl Format {
    /// The answer format a request asks for: protobuf when its `Accept` names
    /// `application/x-protobuf`, else JSON.
    pub fn accepted(headers: &HeaderMap) -> Format {
        if names_protobuf(headers, header::ACCEPT) {
            Format::Protobuf
        } else {
            Format::Json
        }
    }
}

/// A request type that has a protobuf twin.
pub trait FromProto: DeserializeOwned + Sized {
    /// The generated message.
    type Proto: Message + Default;
    /// Converts a decoded message.
    ///
    /// # Errors
    /// 400 naming the field for an invalid enum value or a missing required message.
    fn from_proto(p: Self::Proto) -> Result<Self, ApiError>;
}

impl FromProto for SampleRequest {
    type Proto = v1::SampleRequest;
    fn from_proto(p: v1::SampleRequest) -> Result<Self, ApiError> {
        p.try_into()
    }
}

impl FromProto for OrientationRequest {
    type Proto = v1::OrientationRequest;
    fn from_proto(p: v1::OrientationRequest) -> Result<Self, ApiError> {
        p.try_into()
    }
}

/// Decodes a protobuf message and converts it.
///
/// # Errors
/// 400 `bad_protobuf` for bytes that are not the message; as [`FromProto::from_proto`].
pub fn decode_proto<T: FromProto>(bytes: &[u8]) -> Result<T, ApiError> {
    let p = T::Proto::decode(bytes).map_err(|e| {
        ApiError::new(
            ErrorCode::BadProtobuf,
            format!("malformed protobuf body: {e}"),
        )
    })?;
    T::from_proto(p)
}

/// A query body, JSON or protobuf by its `Content-Type`.
#[derive(Debug)]
pub struct Body<T>(pub T);

impl<S: Send + Sync, T: FromProto> FromRequest<S> for Body<T> {
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, ApiError> {
        let proto = names_protobuf(req.headers(), header::CONTENT_TYPE);
        let bytes = read_bytes(req, state).await?;
        if proto {
            decode_proto(&bytes).map(Body)
        } else {
            from_slice(&bytes).map(Body)
        }
    }
}

/// The answer format, from `Accept`. Never rejects.
#[derive(Debug, Clone, Copy)]
pub struct Accept(pub Format);

impl<S: Send + Sync> FromRequestParts<S> for Accept {
    type Rejection = std::convert::Infallible;

    async fn from_request_parts(parts: &mut Parts, _: &S) -> Result<Self, Self::Rejection> {
        Ok(Accept(Format::accepted(&parts.headers)))
    }
}

/// A response type that has a protobuf twin.
pub trait ToProto: Serialize {
    /// The generated message.
    type Proto: Message;
    /// Converts for the protobuf wire (moves the numbers, never rounds them).
    fn to_proto(self) -> Self::Proto;
}

impl ToProto for SampleResponse {
    type Proto = v1::SampleResponse;
    fn to_proto(self) -> v1::SampleResponse {
        self.into()
    }
}

impl ToProto for OrientationResponse {
    type Proto = v1::OrientationResponse;
    fn to_proto(self) -> v1::OrientationResponse {
        self.into()
    }
}

impl ToProto for HeightResponse {
    type Proto = v1::HeightResponse;
    fn to_proto(self) -> v1::HeightResponse {
        self.into()
    }
}

/// An answer in the format the client accepts.
#[derive(Debug)]
pub struct Reply<T>(pub Format, pub T);

fn protobuf_response(status: axum::http::StatusCode, bytes: Vec<u8>) -> Response {
    let mut r = (status, bytes).into_response();
    r.headers_mut()
        .insert(header::CONTENT_TYPE, HeaderValue::from_static(PROTOBUF));
    r
}

impl<T: ToProto> IntoResponse for Reply<T> {
    /// Checks the answer for non-finite numbers ([`check_answer`]) and encodes it; a
    /// non-finite answer becomes a 500 `non_finite_result` error in either format.
    fn into_response(self) -> Response {
        if let Err(e) = check_answer(&self.1) {
            return e.into_response();
        }
        match self.0 {
            Format::Json => axum::Json(self.1).into_response(),
            Format::Protobuf => protobuf_response(
                axum::http::StatusCode::OK,
                self.1.to_proto().encode_to_vec(),
            ),
        }
    }
}

/// Middleware: when the client accepts protobuf, an error answer (from a handler, an extractor
/// or another layer: every [`ApiError`] leaves a copy of itself in the response extensions) is
/// re-encoded as `swell.v1.ErrorResponse` with the same status and headers.
pub async fn protobuf_errors(req: Request, next: Next) -> Response {
    let format = Format::accepted(req.headers());
    let resp = next.run(req).await;
    if format == Format::Json {
        return resp;
    }
    let Some(err) = resp.extensions().get::<ApiError>().cloned() else {
        return resp;
    };
    let (mut parts, _) = resp.into_parts();
    let body = v1::ErrorResponse::from(&err).encode_to_vec();
    parts
        .headers
        .insert(header::CONTENT_TYPE, HeaderValue::from_static(PROTOBUF));
    parts.headers.remove(header::CONTENT_LENGTH);
    Response::from_parts(parts, axum::body::Body::from(body))
}
