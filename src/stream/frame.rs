//! A tick frame shared by every subscriber, encoded once.
//!
//! A scene's tick loop broadcasts one [`SharedTick`] per tick. Each subscriber asks it for the
//! message of its codec and interest set ([`SharedTick::message`]); the work that does not depend
//! on the subscriber is done once per frame, by whichever subscriber asks first:
//! - each body state is encoded once per codec (a JSON object, a protobuf `BodyState`) and
//!   checked for non-finite numbers once;
//! - the whole frame (no interest set) is assembled once per codec and its bytes shared (a
//!   `Bytes` clone per subscriber, no copy).
//!
//! A subscriber with an interest set gets a frame assembled from the pre-encoded states of its
//! bodies: a few memcpys, no float formatting. The assembled bytes are exactly what
//! [`messages::encode_json`] and [`messages::encode_protobuf`] write for the same (filtered)
//! frame — tested below — so clients see no difference.
//!
//! JSON objects come out with their keys sorted (serde_json's `Value` map without
//! `preserve_order`), so a frame is `{"bodies":[…],"t":…,"tick":…,"type":"tick"}`.

use std::sync::OnceLock;

use axum::extract::ws::Message;
use bytes::{BufMut as _, Bytes, BytesMut};
use prost::Message as _;
use prost::encoding::{WireType, encode_key, encode_varint, encoded_len_varint};

use crate::api::finite::ensure_finite;
use crate::api::types::{BodyState, Tick};
use crate::wire::v1;

use super::messages::{self, Codec, Event, Outgoing, Region};

/// A subscriber's interest set: the bodies a frame carries for it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Interest {
    /// Body ids, sorted, without repeats.
    bodies: Vec<u64>,
    /// Bodies whose position (x, z) lies in this rectangle, re-evaluated every frame.
    region: Option<Region>,
}

impl Interest {
    /// Bodies listed in `bodies` or inside `region`; neither given: every body.
    pub fn new(mut bodies: Vec<u64>, region: Option<Region>) -> Self {
        bodies.sort_unstable();
        bodies.dedup();
        Self { bodies, region }
    }

    /// Whether this is every body of the scene.
    pub fn is_all(&self) -> bool {
        self.bodies.is_empty() && self.region.is_none()
    }

    /// Whether the frame carries `b` for this subscriber.
    pub fn wants(&self, b: &BodyState) -> bool {
        self.is_all()
            || self.bodies.binary_search(&b.id).is_ok()
            || self
                .region
                .is_some_and(|r| r.contains(b.position[0], b.position[2]))
    }
}

/// `swell.v1.ServerMessage.tick` and `swell.v1.Tick.bodies` field numbers.
const SERVER_MESSAGE_TICK: u32 = 5;
const TICK_BODIES: u32 = 3;

/// Per-codec encodings of the body states, made on first demand.
#[derive(Default)]
struct Encoded {
    /// Each body's encoding, in frame order.
    bodies: OnceLock<Vec<Bytes>>,
    /// The whole frame's message payload.
    full: OnceLock<Bytes>,
}

/// One tick frame with its shared encodings.
pub struct SharedTick {
    /// The frame.
    pub tick: Tick,
    /// Per body: whether every number of its state is finite.
    finite: OnceLock<Vec<bool>>,
    json: Encoded,
    protobuf: Encoded,
}

impl std::fmt::Debug for SharedTick {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SharedTick")
            .field("tick", &self.tick)
            .finish()
    }
}

impl SharedTick {
    /// Wraps a frame; nothing is encoded yet.
    pub fn new(tick: Tick) -> Self {
        Self {
            tick,
            finite: OnceLock::new(),
            json: Encoded::default(),
            protobuf: Encoded::default(),
        }
    }

    fn finite(&self) -> &[bool] {
        self.finite.get_or_init(|| {
            self.tick
                .bodies
                .iter()
                .map(|b| ensure_finite(b).is_ok())
                .collect()
        })
    }

    fn encoded(&self, codec: Codec) -> &Encoded {
        match codec {
            Codec::Json => &self.json,
            Codec::Protobuf => &self.protobuf,
        }
    }

    fn bodies(&self, codec: Codec) -> &[Bytes] {
        self.encoded(codec).bodies.get_or_init(|| {
            self.tick
                .bodies
                .iter()
                .map(|b| match codec {
                    Codec::Json => Bytes::from(
                        serde_json::to_vec(&serde_json::to_value(b).unwrap_or_default())
                            .unwrap_or_default(),
                    ),
                    Codec::Protobuf => Bytes::from(v1::BodyState::from(*b).encode_to_vec()),
                })
                .collect()
        })
    }

    /// The message for a subscriber of `codec` following `interest`. A frame whose chosen
    /// states hold a non-finite number becomes an error message, as every outgoing message does
    /// ([`Outgoing::finite_or_error`]).
    pub fn message(&self, codec: Codec, interest: &Interest) -> Message {
        let finite = self.finite();
        let chosen: Vec<usize> = self
            .tick
            .bodies
            .iter()
            .enumerate()
            .filter(|(_, b)| interest.wants(b))
            .map(|(i, _)| i)
            .collect();
        if !self.tick.t.is_finite() || chosen.iter().any(|&i| !finite[i]) {
            return self.checked_slow_path(codec, &chosen);
        }
        let bytes = if interest.is_all() {
            self.encoded(codec)
                .full
                .get_or_init(|| self.assemble(codec, &chosen))
                .clone()
        } else {
            self.assemble(codec, &chosen)
        };
        wrap(codec, bytes)
    }

    /// Builds the frame carrying the bodies at `chosen` from their pre-encoded states.
    fn assemble(&self, codec: Codec, chosen: &[usize]) -> Bytes {
        let parts = self.bodies(codec);
        match codec {
            Codec::Json => {
                let tail = format!(
                    "]{},\"t\":{},\"tick\":{},\"type\":\"tick\"}}",
                    impacts_json(&self.tick),
                    serde_json::to_string(&self.tick.t).unwrap_or_default(),
                    self.tick.tick
                );
                let len: usize = chosen.iter().map(|&i| parts[i].len() + 1).sum();
                let mut out = BytesMut::with_capacity(len + tail.len() + 12);
                out.put_slice(b"{\"bodies\":[");
                for (n, &i) in chosen.iter().enumerate() {
                    if n > 0 {
                        out.put_u8(b',');
                    }
                    out.put_slice(&parts[i]);
                }
                out.put_slice(tail.as_bytes());
                out.freeze()
            }
            Codec::Protobuf => {
                // Tick: its scalar fields as prost writes them (defaults omitted), then each body
                // as a length-delimited field 3; prost writes fields in tag order, so do we.
                let head = v1::Tick {
                    tick: self.tick.tick,
                    t: self.tick.t,
                    bodies: Vec::new(),
                    impacts: Vec::new(),
                }
                .encode_to_vec();
                let impacts = impacts_protobuf(&self.tick);
                let body_len: usize = chosen
                    .iter()
                    .map(|&i| {
                        let n = parts[i].len();
                        1 + encoded_len_varint(n as u64) + n
                    })
                    .sum();
                let tick_len = head.len() + body_len + impacts.len();
                let mut out = BytesMut::with_capacity(tick_len + 12);
                encode_key(SERVER_MESSAGE_TICK, WireType::LengthDelimited, &mut out);
                encode_varint(tick_len as u64, &mut out);
                out.put_slice(&head);
                for &i in chosen {
                    encode_key(TICK_BODIES, WireType::LengthDelimited, &mut out);
                    encode_varint(parts[i].len() as u64, &mut out);
                    out.put_slice(&parts[i]);
                }
                out.put_slice(&impacts);
                out.freeze()
            }
        }
    }

    /// The general path for a frame that fails the finite check: the message
    /// [`Outgoing::finite_or_error`] makes of it (an error naming the bad number).
    fn checked_slow_path(&self, codec: Codec, chosen: &[usize]) -> Message {
        let tick = Tick {
            tick: self.tick.tick,
            t: self.tick.t,
            bodies: chosen
                .iter()
                .map(|&i| self.tick.bodies[i])
                .collect::<Vec<BodyState>>(),
            impacts: self.tick.impacts.clone(),
        };
        let out = Outgoing {
            id: None,
            event: Event::Tick(std::sync::Arc::new(tick)),
        }
        .finite_or_error();
        match codec {
            Codec::Json => Message::Text(messages::encode_json(&out).into()),
            Codec::Protobuf => Message::Binary(messages::encode_protobuf(out).into()),
        }
    }
}

/// The frame's impacts as the JSON fragment `,"impacts":[…]` that sits between `bodies` and
/// `t` (keys sorted), or nothing when there are none (the field is omitted).
fn impacts_json(tick: &Tick) -> String {
    if tick.impacts.is_empty() {
        return String::new();
    }
    format!(
        ",\"impacts\":{}",
        serde_json::to_string(&serde_json::to_value(&tick.impacts).unwrap_or_default())
            .unwrap_or_default()
    )
}

/// The frame's impacts as `swell.v1.Tick` field 4 entries (after the bodies, in tag order).
fn impacts_protobuf(tick: &Tick) -> Vec<u8> {
    if tick.impacts.is_empty() {
        return Vec::new();
    }
    v1::Tick {
        impacts: crate::impacts::to_proto(&tick.impacts),
        ..Default::default()
    }
    .encode_to_vec()
}

fn wrap(codec: Codec, bytes: Bytes) -> Message {
    match codec {
        Codec::Json => Message::Text(
            axum::extract::ws::Utf8Bytes::try_from(bytes)
                .expect("assembled from UTF-8 JSON fragments"),
        ),
        Codec::Protobuf => Message::Binary(bytes),
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;

    fn body(id: u64, k: f64) -> BodyState {
        BodyState {
            id,
            position: [k, -0.125 * k, 1e-7 * k],
            rotation: [0.0, 0.1 * k, 0.0, 0.995],
            velocity: [1.5, 0.0, -k],
            angular_velocity: [0.0, 0.0, 0.25],
            submerged: 0.3,
            quarantined: id.is_multiple_of(2),
        }
    }

    fn expected(codec: Codec, tick: &Tick) -> Vec<u8> {
        let out = Outgoing {
            id: None,
            event: Event::Tick(Arc::new(tick.clone())),
        };
        match codec {
            Codec::Json => messages::encode_json(&out).into_bytes(),
            Codec::Protobuf => messages::encode_protobuf(out),
        }
    }

    fn bytes(m: Message) -> Vec<u8> {
        match m {
            Message::Text(t) => t.as_str().as_bytes().to_vec(),
            Message::Binary(b) => b.to_vec(),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn assembled_frames_are_the_bytes_of_the_general_encoder() {
        for (tick_no, t) in [(10234, 341.1333333333333), (0, 0.0), (-5, -0.25), (7, 2.0)] {
            let tick = Tick {
                tick: tick_no,
                t,
                bodies: (0..7).map(|i| body(i * 3, i as f64 + 0.37)).collect(),
                impacts: Vec::new(),
            };
            let shared = SharedTick::new(tick.clone());
            for codec in [Codec::Json, Codec::Protobuf] {
                // Everything, twice (the second from the shared bytes).
                for _ in 0..2 {
                    let all = Interest::default();
                    assert_eq!(bytes(shared.message(codec, &all)), expected(codec, &tick));
                }
                // Interest sets: some, none present, one.
                for interest in [&[0u64, 6, 18][..], &[1, 2], &[9]] {
                    let filtered = Tick {
                        bodies: tick
                            .bodies
                            .iter()
                            .filter(|b| interest.contains(&b.id))
                            .copied()
                            .collect(),
                        ..tick.clone()
                    };
                    let set = Interest::new(interest.to_vec(), None);
                    assert_eq!(
                        bytes(shared.message(codec, &set)),
                        expected(codec, &filtered),
                        "{codec:?} {interest:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_region_picks_the_bodies_inside_it_together_with_listed_ids() {
        // Bodies i at x = i + 0.37, z = -0.125·x: a region over x in [2, 4] holds ids 6 and 9.
        let tick = Tick {
            tick: 1,
            t: 0.5,
            bodies: (0..7).map(|i| body(i * 3, i as f64 + 0.37)).collect(),
            impacts: Vec::new(),
        };
        let shared = SharedTick::new(tick.clone());
        let ids = |i: &Interest| -> Vec<u64> {
            let v: serde_json::Value =
                serde_json::from_slice(&bytes(shared.message(Codec::Json, i))).unwrap();
            v["bodies"]
                .as_array()
                .unwrap()
                .iter()
                .map(|b| b["id"].as_u64().unwrap())
                .collect()
        };
        let region = Region::new([2.0, -10.0, 4.0, 10.0]).unwrap();
        assert_eq!(ids(&Interest::new(vec![], Some(region))), [6, 9]);
        assert_eq!(ids(&Interest::new(vec![0, 9], Some(region))), [0, 6, 9]);
        let far = Region::new([100.0, 100.0, 200.0, 200.0]).unwrap();
        assert_eq!(ids(&Interest::new(vec![], Some(far))), Vec::<u64>::new());
        assert!(Region::new([1.0, 0.0, 0.0, 1.0]).is_err());
        assert!(Region::new([0.0, 0.0, f64::NAN, 1.0]).is_err());
    }

    #[test]
    fn a_non_finite_body_becomes_an_error_only_for_those_who_follow_it() {
        let mut bad = body(4, 1.0);
        bad.velocity[1] = f64::NAN;
        let shared = SharedTick::new(Tick {
            tick: 3,
            t: 0.1,
            bodies: vec![body(1, 2.0), bad],
            impacts: Vec::new(),
        });
        let all = Interest::default();
        let text = String::from_utf8(bytes(shared.message(Codec::Json, &all))).unwrap();
        assert!(text.contains("\"type\":\"error\""), "{text}");
        let one = Interest::new(vec![1], None);
        let text = String::from_utf8(bytes(shared.message(Codec::Json, &one))).unwrap();
        assert!(text.contains("\"type\":\"tick\""), "{text}");
    }
}
