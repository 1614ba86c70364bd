//! The protobuf wire types.
//!
//! Generated at build time by `build.rs` (prost-build fed by protox, no system `protoc`) from
//! `proto/swell/v1/query.proto` and `proto/swell/v1/stream.proto`, the single source of truth for
//! the wire format. Being generated on every build, they are never stale. Do not hand-edit the
//! generated code; change the `.proto` files.
//!
//! - [`convert`] — conversions between these types and the API's own request/response structs
//!   ([`crate::service::types`]), so JSON and protobuf decode to the same internal request.

pub mod convert;

/// `package swell.v1`.
#[allow(missing_docs, clippy::all, clippy::pedantic)]
pub mod v1 {
    include!(concat!(env!("OUT_DIR"), "/swell.v1.rs"));
}
