//! [`ErrorCode`]: every code the server can send, each with its one HTTP status.
//!
//! A code means one thing: the status comes from the code, so no caller can pair a code with a
//! different status. The README's "Errors" table lists exactly these codes with these statuses
//! (`tests/server/error_codes.rs` fails otherwise).

use axum::http::StatusCode;

macro_rules! codes {
    ($( $(#[$doc:meta])* $variant:ident = $wire:literal, $status:ident $(, $ws:ident)?; )*) => {
        /// A stable, machine-readable error code: the `code` of `{"error":{"code",...}}` and of a
        /// WebSocket `error` message.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum ErrorCode {
            $( $(#[$doc])* $variant, )*
        }

        impl ErrorCode {
            /// Every code, in the README table's order.
            pub const ALL: &'static [ErrorCode] = &[$(ErrorCode::$variant),*];

            /// The code as sent on the wire, e.g. `bad_json`.
            #[must_use]
            pub const fn as_str(self) -> &'static str {
                match self {
                    $(ErrorCode::$variant => $wire,)*
                }
            }

            /// The one HTTP status of this code. A WebSocket-only code (see
            /// [`Self::websocket_only`]) never goes out over HTTP; it reports 400.
            #[must_use]
            pub const fn status(self) -> StatusCode {
                match self {
                    $(ErrorCode::$variant => StatusCode::$status,)*
                }
            }

            /// Whether the code is sent only in a WebSocket `error` message, never as an HTTP
            /// answer (the README's status column says `—`).
            #[must_use]
            pub const fn websocket_only(self) -> bool {
                match self {
                    $(ErrorCode::$variant => codes!(@ws $($ws)?),)*
                }
            }
        }
    };
    (@ws ws_only) => { true };
    (@ws) => { false };
}

codes! {
    /// Malformed JSON, wrong types, unknown fields.
    BadJson = "bad_json", BAD_REQUEST;
    /// A well-formed request with a value outside what is allowed.
    InvalidValue = "invalid_value", BAD_REQUEST;
    /// A name in `fields` that is not a field.
    UnknownField = "unknown_field", BAD_REQUEST;
    /// A malformed protobuf body or message.
    BadProtobuf = "bad_protobuf", BAD_REQUEST;
    /// A plain GET on `/stream`.
    WebsocketRequired = "websocket_required", BAD_REQUEST;
    /// A WebSocket upgrade offering no subprotocol the server speaks.
    UnsupportedSubprotocol = "unsupported_subprotocol", BAD_REQUEST;
    /// (WebSocket only) a message whose `type` is not a message type.
    UnknownType = "unknown_type", BAD_REQUEST, ws_only;
    /// (WebSocket only) a text frame on a protobuf socket, or a binary frame on a JSON one.
    WrongFrameType = "wrong_frame_type", BAD_REQUEST, ws_only;
    /// A path or query string that cannot be read (a rejection rewritten as JSON).
    BadRequest = "bad_request", BAD_REQUEST;
    /// The request body could not be read.
    BadBody = "bad_body", BAD_REQUEST;
    /// A WebSocket upgrade whose `Sec-WebSocket-Key` is not base64 of 16 bytes.
    BadWebsocketKey = "bad_websocket_key", BAD_REQUEST;
    /// The route's token is missing.
    Unauthorized = "unauthorized", UNAUTHORIZED;
    /// A token that is not valid, or whose role is below the route's.
    Forbidden = "forbidden", FORBIDDEN;
    /// No such scene (or viewer asset).
    NotFound = "not_found", NOT_FOUND;
    /// No such body in the scene.
    BodyNotFound = "body_not_found", NOT_FOUND;
    /// No route matches the path.
    NoSuchRoute = "no_such_route", NOT_FOUND;
    /// The path exists, the method does not.
    MethodNotAllowed = "method_not_allowed", METHOD_NOT_ALLOWED;
    /// The request body did not arrive in time.
    RequestTimeout = "request_timeout", REQUEST_TIMEOUT;
    /// A new scene beyond `max_scenes`.
    TooManyScenes = "too_many_scenes", CONFLICT;
    /// A body spawn beyond `max_scene_bodies`.
    SceneFull = "scene_full", CONFLICT;
    /// An input for a body that holds `MAX_LIVE_INPUTS` inputs still to act.
    TooManyInputs = "too_many_inputs", CONFLICT;
    /// An impact past a scene's limits.
    TooManyImpacts = "too_many_impacts", CONFLICT;
    /// More points (or probes) in one request than `max_points`.
    TooManyPoints = "too_many_points", PAYLOAD_TOO_LARGE;
    /// More bodies in one orientation request than `max_bodies`.
    TooManyBodies = "too_many_bodies", PAYLOAD_TOO_LARGE;
    /// A request body over `max_body_bytes`.
    BodyTooLarge = "body_too_large", PAYLOAD_TOO_LARGE;
    /// A request URI too long to read (a rejection rewritten as JSON).
    UriTooLong = "uri_too_long", URI_TOO_LONG;
    /// A body of a media type the endpoint does not take.
    UnsupportedMediaType = "unsupported_media_type", UNSUPPORTED_MEDIA_TYPE;
    /// An impact's `t` outside the window around the scene clock.
    ImpactOutOfWindow = "impact_out_of_window", UNPROCESSABLE_ENTITY;
    /// The scene's FFT frames would take the server past `max_fft_bytes`.
    FftBudget = "fft_budget", UNPROCESSABLE_ENTITY;
    /// Over a request or message rate.
    RateLimited = "rate_limited", TOO_MANY_REQUESTS;
    /// More connections from one address than `max_connections_per_peer`.
    TooManyConnections = "too_many_connections", TOO_MANY_REQUESTS;
    /// Request headers too large to read (a rejection rewritten as JSON).
    HeadersTooLarge = "headers_too_large", REQUEST_HEADER_FIELDS_TOO_LARGE;
    /// The model rejected the spec.
    InvalidSpec = "invalid_spec", UNPROCESSABLE_ENTITY;
    /// The scene cannot be exported as a shader.
    ShaderUnavailable = "shader_unavailable", UNPROCESSABLE_ENTITY;
    /// Too much in flight or buffered.
    Overloaded = "overloaded", SERVICE_UNAVAILABLE;
    /// The request took longer than `request_timeout_ms`.
    Timeout = "timeout", SERVICE_UNAVAILABLE;
    /// The server is starting or draining.
    NotReady = "not_ready", SERVICE_UNAVAILABLE;
    /// An admin write while the shared store is unreachable.
    StoreUnavailable = "store_unavailable", SERVICE_UNAVAILABLE;
    /// A fault on our side.
    Internal = "internal", INTERNAL_SERVER_ERROR;
    /// The answer came out NaN or infinite.
    NonFiniteResult = "non_finite_result", INTERNAL_SERVER_ERROR;
}

impl std::fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl serde::Serialize for ErrorCode {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl PartialEq<str> for ErrorCode {
    fn eq(&self, other: &str) -> bool {
        self.as_str() == other
    }
}

impl PartialEq<&str> for ErrorCode {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

#[cfg(test)]
mod tests {
    use super::ErrorCode;
    use std::collections::HashSet;

    #[test]
    fn wire_strings_are_unique_snake_case() {
        let mut seen = HashSet::new();
        for c in ErrorCode::ALL {
            let s = c.as_str();
            assert!(seen.insert(s), "{s} twice");
            assert!(
                !s.is_empty() && s.bytes().all(|b| b.is_ascii_lowercase() || b == b'_'),
                "{s}"
            );
            assert!(
                c.status().is_client_error() || c.status().is_server_error(),
                "{s}"
            );
        }
    }
}
