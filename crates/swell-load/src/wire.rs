//! The wire schema's protobuf types (generated from `proto/swell/v1/*.proto` by `build.rs`) and
//! the two encodings a run can use.

/// `swell.v1` messages, generated at build time from the workspace's `proto/`.
#[allow(missing_docs, clippy::all, clippy::pedantic)]
pub mod v1 {
    include!(concat!(env!("OUT_DIR"), "/swell.v1.rs"));
}

/// The encoding of request and response bodies (HTTP) and of messages (WebSocket subprotocol).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Wire {
    /// `application/json`; WebSocket subprotocol `swell.v1.json` (text frames).
    Json,
    /// `application/x-protobuf`; WebSocket subprotocol `swell.v1.protobuf` (binary frames).
    Protobuf,
}

impl Wire {
    /// The HTTP content type of this encoding.
    pub fn content_type(self) -> &'static str {
        match self {
            Wire::Json => "application/json",
            Wire::Protobuf => "application/x-protobuf",
        }
    }

    /// The WebSocket subprotocol of this encoding.
    pub fn subprotocol(self) -> &'static str {
        match self {
            Wire::Json => "swell.v1.json",
            Wire::Protobuf => "swell.v1.protobuf",
        }
    }
}

/// The `code` of an error body in either encoding (`{"error":{"code":…}}` or a
/// `swell.v1.ErrorResponse`); `None` when the body is neither.
pub fn error_code(body: &[u8]) -> Option<String> {
    use prost::Message as _;
    if let Ok(v) = serde_json::from_slice::<serde_json::Value>(body) {
        return v["error"]["code"].as_str().map(str::to_owned);
    }
    v1::ErrorResponse::decode(body)
        .ok()
        .and_then(|e| e.error)
        .map(|e| e.code)
        .filter(|c| !c.is_empty())
}
