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

use std::pin::Pin;

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
use crate::service::finite::ensure_finite;
use crate::service::json::{DECODE_OFF_REACTOR_BYTES, from_slice};
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
            Format::Json => crate::service::types::JSON_NUMBER_BYTES,
            Format::Protobuf => crate::service::types::PROTOBUF_NUMBER_BYTES,
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
        Ok(p.try_into()?)
    }
}

impl FromProto for OrientationRequest {
    type Proto = v1::OrientationRequest;
    fn from_proto(p: v1::OrientationRequest) -> Result<Self, ApiError> {
        Ok(p.try_into()?)
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

impl<S: Send + Sync, T: FromProto + Send + 'static> FromRequest<S> for Body<T> {
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, ApiError> {
        let proto = names_protobuf(req.headers(), header::CONTENT_TYPE);
        let bytes = read_bytes(req, state).await?;
        let big = bytes.len() >= DECODE_OFF_REACTOR_BYTES;
        let decode = move || {
            if proto {
                decode_proto(&bytes).map(Body)
            } else {
                from_slice(&bytes).map(Body).map_err(ApiError::from)
            }
        };
        if big {
            return crate::compute::run(decode)
                .await
                .map_err(ApiError::internal)?;
        }
        decode()
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
    /// Checks the answer for non-finite numbers ([`ensure_finite`]) and encodes it; a
    /// non-finite answer becomes a 500 `non_finite_result` error in either format.
    fn into_response(self) -> Response {
        if let Err(nf) = ensure_finite(&self.1) {
            return ApiError::from(nf).into_response();
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

/// A sample's answer: as [`Reply`], except that a large answer is not encoded on the reactor.
/// An answer of [`STREAMED_ANSWER_BYTES`] or more is encoded whole where the query ran
/// ([`SampleReply::prepare`]), except a JSON one of [`STREAMED_JSON_ANSWER_BYTES`] or more:
/// that is encoded as hyper sends it, a chunk at a time on the compute pool
/// ([`PooledJsonBody`]), so it is never held whole, and a client that reads slowly slows the
/// encoding instead of making the server buffer it.
#[derive(Debug)]
pub enum SampleReply {
    /// Encoded when the response is made.
    Answer(Format, SampleResponse),
    /// A protobuf answer already encoded (or the non-finite number its check found).
    Protobuf(Result<Vec<u8>, ApiError>),
    /// A JSON answer already encoded (or the non-finite number its check found).
    Json(Result<Vec<u8>, ApiError>),
}

/// Answers estimated at this many bytes or more are encoded where the query ran, off the
/// reactor.
pub const STREAMED_ANSWER_BYTES: usize = 64 * 1024;

/// JSON answers estimated at this many bytes or more are encoded as they are sent
/// ([`PooledJsonBody`]) rather than whole: below it, holding the answer whole (charged to the
/// byte budget) costs less than a trip to the compute pool per 32 KiB chunk.
pub const STREAMED_JSON_ANSWER_BYTES: usize = 256 * 1024;

impl SampleReply {
    /// Whether this answer is encoded as it is sent.
    pub fn streams(format: Format, numbers: usize) -> bool {
        format == Format::Json
            && numbers.saturating_mul(crate::service::types::JSON_NUMBER_BYTES)
                >= STREAMED_JSON_ANSWER_BYTES
    }

    /// The reply to `answer`, encoded now when it is large and not streamed (see
    /// [`SampleReply`]): call it where the query ran (on the compute pool for a large one).
    pub fn prepare(format: Format, answer: SampleResponse) -> SampleReply {
        let bytes = answer.numbers().saturating_mul(format.number_bytes());
        if bytes < STREAMED_ANSWER_BYTES || SampleReply::streams(format, answer.numbers()) {
            return SampleReply::Answer(format, answer);
        }
        let checked = ensure_finite(&answer).map_err(ApiError::from);
        match format {
            Format::Protobuf => {
                SampleReply::Protobuf(checked.map(|()| answer.to_proto().encode_to_vec()))
            }
            Format::Json => SampleReply::Json(
                checked.and_then(|()| serde_json::to_vec(&answer).map_err(ApiError::internal)),
            ),
        }
    }
}

impl IntoResponse for SampleReply {
    fn into_response(self) -> Response {
        let (format, answer) = match self {
            SampleReply::Answer(format, answer) => (format, answer),
            SampleReply::Protobuf(Ok(bytes)) => {
                return protobuf_response(axum::http::StatusCode::OK, bytes);
            }
            SampleReply::Json(Ok(bytes)) => {
                let mut r = bytes.into_response();
                r.headers_mut().insert(
                    header::CONTENT_TYPE,
                    HeaderValue::from_static("application/json"),
                );
                return r;
            }
            SampleReply::Protobuf(Err(e)) | SampleReply::Json(Err(e)) => return e.into_response(),
        };
        if !SampleReply::streams(format, answer.numbers()) {
            return Reply(format, answer).into_response();
        }
        if let Err(nf) = ensure_finite(&answer) {
            return ApiError::from(nf).into_response();
        }
        let mut r = axum::body::Body::new(PooledJsonBody::new(answer)).into_response();
        r.headers_mut().insert(
            header::CONTENT_TYPE,
            HeaderValue::from_static("application/json"),
        );
        r
    }
}

/// Bytes a [`SampleJsonBody`] encodes per frame (at least: a frame ends after the element that
/// crosses it).
const CHUNK_BYTES: usize = 32 * 1024;

/// A sample answer's JSON, encoded a chunk at a time as the body is polled: the same bytes as
/// `serde_json::to_vec` of the answer (keys in declaration order: `t`, then each array the
/// answer has).
#[derive(Debug)]
pub struct SampleJsonBody {
    answer: SampleResponse,
    /// The array being written (`0`: not started; `1..=6`: height, normal, displacement,
    /// jacobian, folded, residual; `7`: done) and the next element of it.
    array: usize,
    next: usize,
}

impl SampleJsonBody {
    /// A body for `answer` (checked for non-finite numbers by the caller).
    pub fn new(answer: SampleResponse) -> SampleJsonBody {
        SampleJsonBody {
            answer,
            array: 0,
            next: 0,
        }
    }

    /// Writes elements of array `a` from `self.next` until `buf` reaches [`CHUNK_BYTES`];
    /// whether the array is finished.
    fn write_array(&mut self, a: usize, buf: &mut Vec<u8>) -> bool {
        fn put<T: Serialize>(v: &[T], from: &mut usize, buf: &mut Vec<u8>) -> bool {
            while *from < v.len() {
                if buf.len() >= CHUNK_BYTES {
                    return false;
                }
                if *from > 0 {
                    buf.push(b',');
                }
                // Plain numbers, bools and arrays of them: serialization cannot fail.
                let _ = serde_json::to_writer(&mut *buf, &v[*from]);
                *from += 1;
            }
            true
        }
        let r = &self.answer;
        let next = &mut self.next;
        match a {
            1 => r.height.as_deref().is_none_or(|v| put(v, next, buf)),
            2 => r.normal.as_deref().is_none_or(|v| put(v, next, buf)),
            3 => r.displacement.as_deref().is_none_or(|v| put(v, next, buf)),
            4 => r.jacobian.as_deref().is_none_or(|v| put(v, next, buf)),
            5 => r.folded.as_deref().is_none_or(|v| put(v, next, buf)),
            6 => r.residual.as_deref().is_none_or(|v| put(v, next, buf)),
            _ => true,
        }
    }

    fn has(&self, a: usize) -> Option<&'static str> {
        let r = &self.answer;
        match a {
            1 => r.height.is_some().then_some("height"),
            2 => r.normal.is_some().then_some("normal"),
            3 => r.displacement.is_some().then_some("displacement"),
            4 => r.jacobian.is_some().then_some("jacobian"),
            5 => r.folded.is_some().then_some("folded"),
            6 => r.residual.is_some().then_some("residual"),
            _ => None,
        }
    }

    /// The next chunk of the encoding; `None` once it is all written.
    fn chunk(&mut self) -> Option<Vec<u8>> {
        if self.array > 6 {
            return None;
        }
        let mut buf = Vec::with_capacity(CHUNK_BYTES + 128);
        if self.array == 0 {
            buf.extend_from_slice(b"{\"t\":");
            let _ = serde_json::to_writer(&mut buf, &self.answer.t);
            self.array = 1;
            self.next = usize::MAX;
        }
        while self.array <= 6 {
            let Some(name) = self.has(self.array) else {
                self.array += 1;
                self.next = usize::MAX;
                continue;
            };
            if self.next == usize::MAX {
                buf.extend_from_slice(b",\"");
                buf.extend_from_slice(name.as_bytes());
                buf.extend_from_slice(b"\":[");
                self.next = 0;
            }
            if !self.write_array(self.array, &mut buf) {
                return Some(buf);
            }
            buf.push(b']');
            self.array += 1;
            self.next = usize::MAX;
        }
        buf.push(b'}');
        Some(buf)
    }
}

impl http_body::Body for SampleJsonBody {
    type Data = axum::body::Bytes;
    type Error = std::convert::Infallible;

    fn poll_frame(
        self: std::pin::Pin<&mut Self>,
        _: &mut std::task::Context<'_>,
    ) -> std::task::Poll<Option<Result<http_body::Frame<Self::Data>, Self::Error>>> {
        let chunk = self.get_mut().chunk();
        std::task::Poll::Ready(chunk.map(|c| Ok(http_body::Frame::data(c.into()))))
    }

    fn is_end_stream(&self) -> bool {
        self.array > 6
    }
}

/// A [`SampleJsonBody`] whose chunks are encoded on the compute pool ([`crate::compute`]), not
/// on the reactor thread that polls it: a hundred large answers being sent at once would
/// otherwise take the reactor's time from every cheap request (a 32 KiB chunk is ~0.1–0.3 ms
/// of number formatting). The next chunk is encoded while hyper writes the last one, so a
/// fast reader does not wait for the hop; a reader that stops leaves one chunk encoded ahead.
pub struct PooledJsonBody {
    state: Encoding,
}

type Encoded = (Box<SampleJsonBody>, Option<Vec<u8>>);

enum Encoding {
    /// Nothing being encoded (only before the first poll).
    Idle(Box<SampleJsonBody>),
    /// A chunk on the pool.
    Busy(Pin<Box<dyn Future<Output = Result<Encoded, crate::compute::Lost>> + Send>>),
    Done,
}

impl PooledJsonBody {
    /// A body for `answer` (checked for non-finite numbers by the caller).
    pub fn new(answer: SampleResponse) -> PooledJsonBody {
        PooledJsonBody {
            state: Encoding::Idle(Box::new(SampleJsonBody::new(answer))),
        }
    }
}

fn encode_next(mut body: Box<SampleJsonBody>) -> Encoding {
    Encoding::Busy(Box::pin(crate::compute::run(move || {
        let chunk = body.chunk();
        (body, chunk)
    })))
}

impl http_body::Body for PooledJsonBody {
    type Data = axum::body::Bytes;
    type Error = crate::compute::Lost;

    fn poll_frame(
        self: Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<Option<Result<http_body::Frame<Self::Data>, Self::Error>>> {
        use std::task::Poll;
        let this = self.get_mut();
        loop {
            match std::mem::replace(&mut this.state, Encoding::Done) {
                Encoding::Done => return Poll::Ready(None),
                Encoding::Idle(body) => this.state = encode_next(body),
                Encoding::Busy(mut job) => match job.as_mut().poll(cx) {
                    Poll::Pending => {
                        this.state = Encoding::Busy(job);
                        return Poll::Pending;
                    }
                    Poll::Ready(Err(lost)) => return Poll::Ready(Some(Err(lost))),
                    Poll::Ready(Ok((body, chunk))) => {
                        let Some(chunk) = chunk else {
                            return Poll::Ready(None);
                        };
                        if !http_body::Body::is_end_stream(&*body) {
                            this.state = encode_next(body);
                        }
                        return Poll::Ready(Some(Ok(http_body::Frame::data(chunk.into()))));
                    }
                },
            }
        }
    }

    fn is_end_stream(&self) -> bool {
        matches!(self.state, Encoding::Done)
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

#[cfg(test)]
mod tests {
    use super::*;

    fn encode_streamed(answer: SampleResponse) -> Vec<u8> {
        let mut body = SampleJsonBody::new(answer);
        let mut out = Vec::new();
        let mut chunks = 0;
        while let Some(c) = body.chunk() {
            assert!(c.len() < CHUNK_BYTES + 128, "a chunk of {} bytes", c.len());
            out.extend_from_slice(&c);
            chunks += 1;
        }
        assert!(body.chunk().is_none());
        assert!(chunks >= 1);
        out
    }

    #[test]
    fn a_streamed_sample_answer_has_the_bytes_of_the_whole_encoding() {
        let mut rng = swell_waves::math::SwellRng::new(27, 1);
        for round in 0..64u32 {
            // 0 to ~40,000 points: empty arrays, one chunk, many.
            let n = match round % 4 {
                0 => (rng.next_u32() % 3) as usize,
                1 => (rng.next_u32() % 500) as usize,
                _ => (rng.next_u32() % 40_000) as usize,
            };
            // Every array present at least once in 32 rounds; `height` alone when none is.
            let mask = match round % 32 {
                0 => 1,
                m => m,
            };
            let a = SampleResponse::seeded(&mut rng, n, mask);
            let whole = serde_json::to_vec(&a).unwrap();
            assert_eq!(encode_streamed(a), whole, "round {round}, {n} points");
        }
    }

    /// The body hyper sends: the same bytes, chunk by chunk from the compute pool, and it
    /// says it has ended only after the last chunk.
    #[tokio::test]
    async fn the_pooled_body_sends_the_bytes_of_the_whole_encoding() {
        use http_body::Body as _;
        use http_body_util::BodyExt as _;
        let mut rng = swell_waves::math::SwellRng::new(29, 1);
        for (n, mask) in [(0, 1), (1, 3), (5_000, 7), (30_000, 63)] {
            let a = SampleResponse::seeded(&mut rng, n, mask);
            let whole = serde_json::to_vec(&a).unwrap();
            let mut body = PooledJsonBody::new(a);
            assert!(!body.is_end_stream());
            let mut sent = Vec::new();
            let mut frames = 0;
            while let Some(frame) = body.frame().await {
                let data = frame.unwrap().into_data().unwrap();
                assert!(
                    data.len() < CHUNK_BYTES + 128,
                    "a chunk of {} bytes",
                    data.len()
                );
                sent.extend_from_slice(&data);
                frames += 1;
            }
            assert!(body.is_end_stream());
            assert_eq!(sent, whole, "{n} points");
            assert_eq!(
                frames,
                whole.len().div_ceil(CHUNK_BYTES).max(1),
                "{n} points"
            );
        }
    }

    /// A JSON sample answer is encoded on the reactor when small, whole where the query ran
    /// when mid-sized, and as it is sent when large; each way gives the same bytes, and a
    /// non-finite number is the 500 error whichever way it goes.
    #[tokio::test]
    async fn a_json_sample_answer_has_the_same_bytes_whichever_way_it_is_encoded() {
        use http_body_util::BodyExt as _;
        let mut rng = swell_waves::math::SwellRng::new(31, 1);
        let per_point = crate::service::types::JSON_NUMBER_BYTES;
        let mid_low = STREAMED_ANSWER_BYTES.div_ceil(per_point);
        let mid_high = STREAMED_JSON_ANSWER_BYTES.div_ceil(per_point) - 1;
        for (n, way) in [
            (100, "reactor"),
            (mid_low, "whole"),
            (4096, "whole"),
            (mid_high, "whole"),
            (mid_high + 1, "streamed"),
        ] {
            let a = SampleResponse::seeded(&mut rng, n, 1);
            assert_eq!(a.numbers(), n);
            let whole = serde_json::to_vec(&a).unwrap();
            let reply = SampleReply::prepare(Format::Json, a);
            let got_way = match &reply {
                SampleReply::Json(Ok(_)) => "whole",
                SampleReply::Answer(_, a) if SampleReply::streams(Format::Json, a.numbers()) => {
                    "streamed"
                }
                SampleReply::Answer(..) => "reactor",
                other => panic!("{n} points: {other:?}"),
            };
            assert_eq!(got_way, way, "{n} points");
            let r = reply.into_response();
            assert_eq!(r.status(), 200, "{n} points");
            assert_eq!(r.headers()[header::CONTENT_TYPE], "application/json");
            let sent = r.into_body().collect().await.unwrap().to_bytes();
            assert_eq!(sent, whole, "{n} points");
        }
        for n in [100, 4096, mid_high + 1] {
            let mut a = SampleResponse::seeded(&mut rng, n, 1);
            a.height.as_mut().unwrap()[n / 2] = f64::NAN;
            let r = SampleReply::prepare(Format::Json, a).into_response();
            assert_eq!(r.status(), 500, "{n} points");
            let body = r.into_body().collect().await.unwrap().to_bytes();
            let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
            assert_eq!(v["error"]["code"], "non_finite_result", "{n} points: {v}");
        }
    }
}
