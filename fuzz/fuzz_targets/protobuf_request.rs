//! Arbitrary bytes as protobuf query bodies: `swell.v1.SampleRequest` (and, from the same bytes,
//! `swell.v1.OrientationRequest`), decoded and converted by the server's `decode_proto` (prost +
//! its `TryFrom`), then run on every built-in scene. Protobuf doubles carry NaN and infinities,
//! which JSON cannot: the query's own checks must refuse them. No panic; a rejection is a 4xx;
//! an answer is finite.
#![no_main]

use libfuzzer_sys::fuzz_target;
use swell::api::wire::decode_proto;
use swell::service::types::{OrientationRequest, SampleRequest};

fuzz_target!(|data: &[u8]| {
    match decode_proto::<SampleRequest>(data) {
        Ok(req) => swell_fuzz::check_sample(&req),
        Err(e) => swell_fuzz::assert_client_error(&e),
    }
    match decode_proto::<OrientationRequest>(data) {
        Ok(req) => swell_fuzz::check_orientation(&req),
        Err(e) => swell_fuzz::assert_client_error(&e),
    }
});
