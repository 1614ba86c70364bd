//! Arbitrary bytes as a WebSocket client message in both subprotocols: as a `swell.v1.json` text
//! frame (when the bytes are UTF-8, as tungstenite requires of text frames) and as a
//! `swell.v1.protobuf` binary frame. A decoded query runs as the session runs it; a decoded ping
//! or subscribe must carry only finite numbers. No panic; a rejection is a 4xx; an answer is
//! finite and encodes in both codecs.
#![no_main]

use libfuzzer_sys::fuzz_target;
use swell::stream::messages::{
    Event, Incoming, Outgoing, Request, decode_json, decode_protobuf, encode_json, encode_protobuf,
};

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        check(decode_json(text));
    }
    check(decode_protobuf(data));
});

fn check(decoded: Result<Incoming, swell::stream::messages::DecodeError>) {
    let m = match decoded {
        Ok(m) => m,
        Err(e) => return swell_fuzz::assert_client_error(&e.error),
    };
    match &m.request {
        Request::Ping { client_time } => {
            assert!(client_time.is_finite(), "ping accepted with {client_time}");
            let out = Outgoing {
                id: m.id,
                event: Event::Pong {
                    client_time: *client_time,
                    scene_time: swell_fuzz::DEFAULT_T,
                    tick: 0,
                    rate: 1.0,
                    paused: false,
                    generation: 0,
                },
            };
            encode_both(out);
        }
        Request::Sample(req) => swell_fuzz::check_sample(req),
        Request::Orientation(req) => swell_fuzz::check_orientation(req),
        Request::Subscribe { region, .. } => {
            if let Some(r) = region {
                let v = [r.x0, r.z0, r.x1, r.z1];
                assert!(v.iter().all(|x| x.is_finite()), "region accepted: {r:?}");
                assert!(r.x0 <= r.x1 && r.z0 <= r.z1, "region accepted: {r:?}");
            }
        }
    }
}

/// Encodes as the session's send queue does: through `finite_or_error`, then each codec.
fn encode_both(out: Outgoing) {
    let out = out.finite_or_error();
    assert!(
        !matches!(out.event, Event::Error(_)),
        "a finite pong became an error"
    );
    let _ = encode_json(&out);
    let _ = encode_protobuf(out);
}
