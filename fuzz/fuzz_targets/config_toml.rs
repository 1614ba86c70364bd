//! Arbitrary text as the server's TOML config file (`swell serve --config`): parsed by
//! `swell::config::parse_toml` (TOML → limits and scene specs through the HTTP body's parser).
//! No panic; each accepted scene (FFT grids up to 64²) builds or is refused with a 4xx, and a
//! built one answers finite heights.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(contents) = swell::config::parse_toml(text) else {
        return;
    };
    // Ids were validated by the parser; at most a few scenes a file, so an iteration stays fast.
    for (id, spec) in contents.scenes.into_iter().take(4) {
        swell::scene::validate_id(&id).expect("parse_toml checks ids");
        swell_fuzz::check_spec(&id, spec);
    }
    if let Some(limits) = contents.limits {
        let _ = limits.request_timeout();
    }
});
