//! Arbitrary bytes as a `POST /v1/scenes/{id}/orientation` JSON body: parsed with the server's
//! own parser, then run on every built-in scene. No panic; a rejection is a 4xx; an answer is
//! finite.
#![no_main]

use libfuzzer_sys::fuzz_target;
use swell::service::types::OrientationRequest;

fuzz_target!(|data: &[u8]| {
    if let Ok(req) = swell::service::json::from_slice::<OrientationRequest>(data) {
        swell_fuzz::check_orientation(&req);
    }
});
