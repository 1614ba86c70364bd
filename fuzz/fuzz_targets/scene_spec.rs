//! Arbitrary bytes as a scene spec (`PUT /v1/scenes/{id}` body): JSON, then
//! `SceneSpec::from_value`, then `Scene::build`. No panic; a rejection is a 4xx; a built scene
//! answers finite heights at a few times and points. Specs with an FFT grid over 64² are parsed
//! but not built (see `swell_fuzz::MAX_FUZZ_FFT_RESOLUTION`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use swell::scene::SceneSpec;

fuzz_target!(|data: &[u8]| {
    let Ok(value) = swell::service::json::from_slice::<serde_json::Value>(data) else {
        return;
    };
    match SceneSpec::from_value(value) {
        Ok(spec) => swell_fuzz::check_spec("fuzz", spec),
        Err(e) => swell_fuzz::assert_client_error(&swell::ApiError::from(e)),
    }
});
