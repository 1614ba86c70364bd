//! A tick frame shared by every subscriber, encoded once.
//!
//! A scene's tick loop hands one [`SharedTick`] per tick to its fan-out shards
//! ([`super::fanout`]), which ask it for each subscriber's message, of the subscriber's codec
//! and interest set ([`SharedTick::message_with`]); the work that does not depend on the
//! subscriber is done once per frame, for whichever subscriber comes first:
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
use bytes::{BufMut as _, Bytes};
use prost::Message as _;
use prost::encoding::{WireType, encode_key, encode_varint, encoded_len_varint, key_len};

use crate::service::finite::ensure_finite;
use crate::service::types::{BodyState, Tick};
use crate::wire::v1;

use super::messages::{self, Codec, Event, Outgoing, Region};

/// A subscriber's interest set: the bodies a frame carries for it, and in which form.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Interest {
    /// Body ids, sorted, without repeats.
    bodies: Vec<u64>,
    /// Bodies whose position (x, z) lies in this rectangle, re-evaluated every frame.
    region: Option<Region>,
    /// Compact states ([`super::compact`]; protobuf only) instead of the full ones.
    compact: bool,
}

impl Interest {
    /// Bodies listed in `bodies` or inside `region`; neither given: every body.
    pub fn new(mut bodies: Vec<u64>, region: Option<Region>) -> Self {
        bodies.sort_unstable();
        bodies.dedup();
        Self {
            bodies,
            region,
            compact: false,
        }
    }

    /// The same set with compact body states (protobuf frames only; JSON frames ignore it).
    #[must_use]
    pub fn compact(self, compact: bool) -> Self {
        Self { compact, ..self }
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

/// `swell.v1.ServerMessage.tick`, `swell.v1.Tick.bodies`, `Tick.compact`, `CompactBodies.origin`
/// and `CompactBodies.bodies` field numbers.
const SERVER_MESSAGE_TICK: u32 = 5;
const TICK_BODIES: u32 = 3;
const TICK_COMPACT: u32 = 4;
const COMPACT_ORIGIN: u32 = 1;
const COMPACT_BODIES: u32 = 2;

/// What a subscriber's frame is encoded as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Form {
    Json,
    Protobuf,
    /// Protobuf with [`v1::CompactBodies`].
    Compact,
}

impl Form {
    fn of(codec: Codec, interest: &Interest) -> Form {
        match codec {
            Codec::Json => Form::Json,
            Codec::Protobuf if interest.compact => Form::Compact,
            Codec::Protobuf => Form::Protobuf,
        }
    }
}

/// Per-codec encodings of the body states, made on first demand.
#[derive(Default)]
struct Encoded {
    /// Each body's encoding and the frame's fixed parts.
    parts: OnceLock<Parts>,
    /// The whole frame's message payload.
    full: OnceLock<Bytes>,
}

/// What every subscriber's frame of one form is assembled from: the parts that do not depend on
/// the interest set are encoded once per tick, not once per subscriber.
struct Parts {
    /// Each body's encoding, in frame order.
    bodies: Vec<Bytes>,
    /// JSON: `]`, the impacts, `t`, `tick` and `type` (everything after the bodies). Protobuf:
    /// the impacts field (after the bodies).
    tail: Bytes,
    /// Protobuf: the tick's scalar fields as prost writes them (before the bodies).
    head: Bytes,
    /// Compact: the encoded origin.
    origin: Bytes,
}

/// One tick frame with its shared encodings.
pub struct SharedTick {
    /// The frame.
    pub tick: Tick,
    /// Per body: whether every number of its state is finite.
    finite: OnceLock<Vec<bool>>,
    json: Encoded,
    protobuf: Encoded,
    compact: Encoded,
    /// The compact form's origin ([`super::compact::origin`] of every body of the frame).
    origin: OnceLock<[f64; 3]>,
    /// The bodies' ids in frame order, when that is increasing id order (published states
    /// are): 8 bytes a body to search, rather than a whole state's cache lines.
    sorted_ids: OnceLock<Option<Vec<u64>>>,
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
            compact: Encoded::default(),
            origin: OnceLock::new(),
            sorted_ids: OnceLock::new(),
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

    fn encoded(&self, form: Form) -> &Encoded {
        match form {
            Form::Json => &self.json,
            Form::Protobuf => &self.protobuf,
            Form::Compact => &self.compact,
        }
    }

    fn origin(&self) -> [f64; 3] {
        *self
            .origin
            .get_or_init(|| super::compact::origin(&self.tick.bodies))
    }

    fn parts(&self, form: Form) -> &Parts {
        self.encoded(form).parts.get_or_init(|| {
            let origin = self.origin();
            let bodies = self
                .tick
                .bodies
                .iter()
                .map(|b| match form {
                    Form::Json => Bytes::from(
                        serde_json::to_vec(&serde_json::to_value(b).unwrap_or_default())
                            .unwrap_or_default(),
                    ),
                    Form::Protobuf => Bytes::from(v1::BodyState::from(*b).encode_to_vec()),
                    Form::Compact => Bytes::from(super::compact::encode(b, origin).encode_to_vec()),
                })
                .collect();
            match form {
                Form::Json => Parts {
                    bodies,
                    tail: Bytes::from(format!(
                        "]{},\"t\":{},\"tick\":{},\"type\":\"tick\"}}",
                        impacts_json(&self.tick),
                        serde_json::to_string(&self.tick.t).unwrap_or_default(),
                        self.tick.tick
                    )),
                    // Keys sorted: `anchor_tick` (when there is one) before `bodies`.
                    head: Bytes::from(match self.tick.anchor_tick {
                        Some(a) => format!("{{\"anchor_tick\":{a},\"bodies\":["),
                        None => "{\"bodies\":[".to_owned(),
                    }),
                    origin: Bytes::new(),
                },
                Form::Protobuf | Form::Compact => Parts {
                    bodies,
                    // Impacts (field 5) and then the anchor (6) come after the bodies (3) or
                    // the compact bodies (4).
                    tail: Bytes::from(tail_protobuf(&self.tick)),
                    head: Bytes::from(
                        v1::Tick {
                            tick: self.tick.tick,
                            t: self.tick.t,
                            bodies: Vec::new(),
                            compact: None,
                            impacts: Vec::new(),
                            anchor_tick: None,
                        }
                        .encode_to_vec(),
                    ),
                    origin: if form == Form::Compact {
                        let [x, y, z] = origin;
                        Bytes::from(v1::Vec3 { x, y, z }.encode_to_vec())
                    } else {
                        Bytes::new()
                    },
                },
            }
        })
    }

    fn sorted_ids(&self) -> Option<&[u64]> {
        self.sorted_ids
            .get_or_init(|| {
                let b = &self.tick.bodies;
                b.windows(2)
                    .all(|w| w[0].id < w[1].id)
                    .then(|| b.iter().map(|b| b.id).collect())
            })
            .as_deref()
    }

    /// Positions in the frame of the bodies `interest` wants, in frame order, into `out`
    /// (cleared first: a writer keeps one and reuses it every frame). A list of ids is looked up
    /// in the frame (ids × log bodies) rather than the frame scanned against the list.
    fn choose(&self, interest: &Interest, out: &mut Vec<usize>) {
        out.clear();
        let bodies = &self.tick.bodies;
        if interest.is_all() {
            out.extend(0..bodies.len());
        } else if interest.region.is_none()
            && let Some(ids) = self.sorted_ids()
        {
            out.extend(
                interest
                    .bodies
                    .iter()
                    .filter_map(|id| ids.binary_search(id).ok()),
            );
        } else {
            out.extend(
                bodies
                    .iter()
                    .enumerate()
                    .filter(|(_, b)| interest.wants(b))
                    .map(|(i, _)| i),
            );
        }
    }

    /// [`SharedTick::message_with`] with a scratch of its own.
    #[cfg(test)]
    pub fn message(&self, codec: Codec, interest: &Interest) -> Message {
        self.message_with(codec, interest, &mut Vec::new())
    }

    /// The message for a subscriber of `codec` following `interest`. A frame whose chosen
    /// states hold a non-finite number becomes an error message, as every outgoing message does
    /// ([`Outgoing::finite_or_error`]). `chosen` is the caller's scratch for the chosen
    /// positions (a writer keeps one), so a frame a tick allocates nothing but the frame.
    pub fn message_with(
        &self,
        codec: Codec,
        interest: &Interest,
        chosen: &mut Vec<usize>,
    ) -> Message {
        let finite = self.finite();
        self.choose(interest, chosen);
        if !self.tick.t.is_finite() || chosen.iter().any(|&i| !finite[i]) {
            return self.checked_slow_path(codec, chosen);
        }
        let form = Form::of(codec, interest);
        let all = interest.bodies.is_empty() && interest.region.is_none();
        let bytes = if all {
            self.encoded(form)
                .full
                .get_or_init(|| self.assemble(form, chosen))
                .clone()
        } else {
            self.assemble(form, chosen)
        };
        wrap(codec, bytes)
    }

    /// Builds the frame carrying the bodies at `chosen` from their pre-encoded states.
    fn assemble(&self, form: Form, chosen: &[usize]) -> Bytes {
        let Parts {
            bodies: parts,
            tail,
            head,
            origin,
        } = self.parts(form);
        match form {
            Form::Json => {
                let len = head.len()
                    + chosen.iter().map(|&i| parts[i].len()).sum::<usize>()
                    + chosen.len().saturating_sub(1)
                    + tail.len();
                let mut out = Vec::with_capacity(len);
                out.put_slice(head);
                for (n, &i) in chosen.iter().enumerate() {
                    if n > 0 {
                        out.put_u8(b',');
                    }
                    out.put_slice(&parts[i]);
                }
                out.put_slice(tail);
                exact(out, len)
            }
            Form::Protobuf | Form::Compact => {
                // Tick: its scalar fields as prost writes them (defaults omitted), then each body
                // as a length-delimited field 3, or the compact bodies as field 4 (origin, then
                // each body), then the impacts; prost writes fields in tag order, so do we.
                let field_len = |n: usize| 1 + encoded_len_varint(n as u64) + n;
                let body_len: usize = chosen.iter().map(|&i| field_len(parts[i].len())).sum();
                let compact = form == Form::Compact;
                let tick_len = head.len()
                    + if compact {
                        field_len(field_len(origin.len()) + body_len)
                    } else {
                        body_len
                    }
                    + tail.len();
                let len =
                    key_len(SERVER_MESSAGE_TICK) + encoded_len_varint(tick_len as u64) + tick_len;
                let mut out = Vec::with_capacity(len);
                encode_key(SERVER_MESSAGE_TICK, WireType::LengthDelimited, &mut out);
                encode_varint(tick_len as u64, &mut out);
                out.put_slice(head);
                let body_field = if compact {
                    encode_key(TICK_COMPACT, WireType::LengthDelimited, &mut out);
                    encode_varint((field_len(origin.len()) + body_len) as u64, &mut out);
                    encode_key(COMPACT_ORIGIN, WireType::LengthDelimited, &mut out);
                    encode_varint(origin.len() as u64, &mut out);
                    out.put_slice(origin);
                    COMPACT_BODIES
                } else {
                    TICK_BODIES
                };
                for &i in chosen {
                    encode_key(body_field, WireType::LengthDelimited, &mut out);
                    encode_varint(parts[i].len() as u64, &mut out);
                    out.put_slice(&parts[i]);
                }
                out.put_slice(tail);
                exact(out, len)
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
            anchor_tick: self.tick.anchor_tick,
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

/// The frame's fields after the bodies as `swell.v1.Tick` writes them, in tag order: the
/// impacts (field 5) and the world's anchor (6); empty when it has neither.
fn tail_protobuf(tick: &Tick) -> Vec<u8> {
    v1::Tick {
        impacts: crate::wire::convert::impact_events(&tick.impacts),
        anchor_tick: tick.anchor_tick,
        ..Default::default()
    }
    .encode_to_vec()
}

/// An assembled frame as `Bytes`. Its capacity was computed to be its length, so the `Vec`
/// becomes `Bytes` without a second allocation (`Bytes::from` a `Vec` with spare capacity
/// allocates a shared header, and its drop is an atomic decrement: per subscriber, per frame).
fn exact(out: Vec<u8>, len: usize) -> Bytes {
    debug_assert_eq!(out.len(), len, "frame length computed wrong");
    Bytes::from(out)
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
        // Published states are in id order (the lookup path); a frame out of order is scanned.
        let sorted = [0, 1, 2, 3, 4, 5, 6];
        let shuffled = [4, 0, 6, 2, 1, 5, 3];
        let cases = [(10234, 341.1333333333333), (0, 0.0), (-5, -0.25), (7, 2.0)];
        for ((tick_no, t), order) in cases.into_iter().zip([sorted, shuffled, sorted, shuffled]) {
            let tick = Tick {
                tick: tick_no,
                t,
                bodies: order.map(|i| body(i * 3, i as f64 + 0.37)).to_vec(),
                impacts: Vec::new(),
                // With and without a body world's anchor (a JSON key before `bodies`, a
                // protobuf field after them).
                anchor_tick: (tick_no % 2 == 0).then_some(tick_no - 3),
            };
            let shared = SharedTick::new(tick.clone());
            // One scratch for every set, as a writer keeps (left longer by a bigger set).
            let mut chosen = Vec::new();
            for codec in [Codec::Json, Codec::Protobuf] {
                // Everything, twice (the second from the shared bytes).
                for _ in 0..2 {
                    let all = Interest::default();
                    assert_eq!(bytes(shared.message(codec, &all)), expected(codec, &tick));
                }
                // Interest sets: some, none present, one.
                for interest in [&[0u64, 6, 18][..], &[18, 3, 0], &[1, 2], &[9]] {
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
                        bytes(shared.message_with(codec, &set, &mut chosen)),
                        expected(codec, &filtered),
                        "{codec:?} {interest:?}"
                    );
                }
            }
        }
    }

    /// Compact frames are what prost writes for the same `Tick.compact`, the origin is the
    /// whole frame's (whatever the interest set), and they decode within the proto's bounds.
    #[test]
    fn compact_frames_are_prosts_bytes_and_decode_within_the_bounds() {
        let tick = Tick {
            tick: 99,
            t: 3.3,
            bodies: (0..7)
                .map(|i| {
                    let mut b = body(i * 3, 1000.0 + i as f64 * 11.3);
                    let q = [0.1 * i as f64, -0.2, 0.3, 0.9];
                    let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
                    b.rotation = q.map(|c| c / n);
                    b
                })
                .collect(),
            impacts: Vec::new(),
            anchor_tick: None,
        };
        let shared = SharedTick::new(tick.clone());
        let origin = super::super::compact::origin(&tick.bodies);
        assert_eq!(origin, [1034.0, -129.0, 0.0]);
        for interest in [&[][..], &[0u64, 6, 18], &[9]] {
            let chosen: Vec<&BodyState> = tick
                .bodies
                .iter()
                .filter(|b| interest.is_empty() || interest.contains(&b.id))
                .collect();
            let want = v1::ServerMessage {
                id: None,
                msg: Some(v1::server_message::Msg::Tick(v1::Tick {
                    tick: 99,
                    t: 3.3,
                    bodies: Vec::new(),
                    impacts: Vec::new(),
                    anchor_tick: None,
                    compact: Some(v1::CompactBodies {
                        origin: Some(v1::Vec3 {
                            x: origin[0],
                            y: origin[1],
                            z: origin[2],
                        }),
                        bodies: chosen
                            .iter()
                            .map(|b| super::super::compact::encode(b, origin))
                            .collect(),
                    }),
                })),
            }
            .encode_to_vec();
            let set = Interest::new(interest.to_vec(), None).compact(true);
            let got = bytes(shared.message(Codec::Protobuf, &set));
            assert_eq!(got, want, "{interest:?}");
            // Decoded by a client: within the documented bounds of the full states.
            let Some(v1::server_message::Msg::Tick(t)) =
                v1::ServerMessage::decode(&got[..]).unwrap().msg
            else {
                panic!("not a tick")
            };
            let c = t.compact.unwrap();
            let o = c.origin.unwrap();
            for (d, b) in c.bodies.iter().zip(&chosen) {
                let d = super::super::compact::decode(d, [o.x, o.y, o.z]).unwrap();
                for (k, ok) in origin.iter().enumerate() {
                    let bound = (b.position[k] - ok).abs() * f64::from(f32::EPSILON);
                    assert!((d.position[k] - b.position[k]).abs() <= bound);
                }
                for k in 0..4 {
                    assert!((d.rotation[k] - b.rotation[k]).abs() < 2.1e-6);
                }
            }
            // Smaller than the full frame of the same bodies (these have zero components that
            // the full form omits; real states are ~2.3x smaller, see the proto).
            let full =
                bytes(shared.message(Codec::Protobuf, &Interest::new(interest.to_vec(), None)));
            if chosen.len() > 3 {
                assert!(
                    got.len() * 3 < full.len() * 2,
                    "{} vs {}",
                    got.len(),
                    full.len()
                );
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
            anchor_tick: None,
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
            anchor_tick: None,
        });
        let all = Interest::default();
        let text = String::from_utf8(bytes(shared.message(Codec::Json, &all))).unwrap();
        assert!(text.contains("\"type\":\"error\""), "{text}");
        let one = Interest::new(vec![1], None);
        let text = String::from_utf8(bytes(shared.message(Codec::Json, &one))).unwrap();
        assert!(text.contains("\"type\":\"tick\""), "{text}");
    }
}

/// Tick frames carrying impacts (moved here from `crate::impacts`: frame encoding is the
/// stream's).
#[cfg(test)]
mod impact_frames {
    use std::sync::Arc;

    use axum::extract::ws::Message;
    use swell_waves::particles::Impact;

    use super::{Interest, SharedTick};
    use crate::impacts::ImpactEvent;
    use crate::service::types::Tick;
    use crate::stream::messages::{self, Codec, Event, Outgoing};

    fn impact(t: f64) -> Impact {
        Impact {
            t,
            position: [1.5, -2.25],
            strength: 0.4,
            radius: 0.6,
        }
    }

    /// A frame with impacts is assembled to exactly the bytes of the general encoders (JSON
    /// keys sorted, protobuf field 4 after the bodies), and one without omits the field. An API
    /// impact's body tick goes out in both; a body-made impact has none.
    #[test]
    fn frames_carry_impacts_in_both_codecs() {
        let felt = ImpactEvent {
            body_tick: Some(88),
            ..ImpactEvent::new(&impact(2.5), 30.0)
        };
        for impacts in [
            vec![],
            vec![ImpactEvent::new(&impact(3.01), 30.0)],
            vec![felt, ImpactEvent::new(&impact(3.01), 30.0)],
        ] {
            let tick = Tick {
                tick: 91,
                t: 91.0 / 30.0,
                bodies: Vec::new(),
                impacts: impacts.clone(),
                // After the impacts in both codecs when there are both.
                anchor_tick: (!impacts.is_empty()).then_some(80),
            };
            let shared = SharedTick::new(tick.clone());
            for codec in [Codec::Json, Codec::Protobuf] {
                let out = Outgoing {
                    id: None,
                    event: Event::Tick(Arc::new(tick.clone())),
                };
                let want = match codec {
                    Codec::Json => messages::encode_json(&out).into_bytes(),
                    Codec::Protobuf => messages::encode_protobuf(out),
                };
                let got = match shared.message(codec, &Interest::default()) {
                    Message::Text(t) => t.as_str().as_bytes().to_vec(),
                    Message::Binary(b) => b.to_vec(),
                    other => panic!("{other:?}"),
                };
                assert_eq!(got, want, "{codec:?}");
            }
            let text = match shared.message(Codec::Json, &Interest::default()) {
                Message::Text(t) => t.as_str().to_owned(),
                other => panic!("{other:?}"),
            };
            assert_eq!(text.contains("\"impacts\""), !impacts.is_empty(), "{text}");
            let v: serde_json::Value = serde_json::from_str(&text).unwrap();
            for (i, e) in impacts.iter().enumerate() {
                assert_eq!(v["impacts"][i]["body_tick"].as_i64(), e.body_tick, "{text}");
            }
            let proto = match shared.message(Codec::Protobuf, &Interest::default()) {
                Message::Binary(b) => b,
                other => panic!("{other:?}"),
            };
            let decoded =
                <crate::wire::v1::ServerMessage as prost::Message>::decode(proto).unwrap();
            let Some(crate::wire::v1::server_message::Msg::Tick(t)) = decoded.msg else {
                panic!("{decoded:?}");
            };
            let ticks: Vec<_> = t.impacts.iter().map(|i| i.body_tick).collect();
            let want: Vec<_> = impacts.iter().map(|i| i.body_tick).collect();
            assert_eq!(ticks, want);
        }
        assert_eq!(ImpactEvent::new(&impact(3.01), 30.0).tick, 91);
        assert_eq!(ImpactEvent::new(&impact(3.0), 30.0).tick, 90);
    }
}
