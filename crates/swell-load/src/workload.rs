//! What is sent: seeded random points and hulls, prepared once per run as a ring of request
//! variants so that encoding does not compete with the server for the machine's cores.
//!
//! Request `i` of a run is a pure function of `(seed, i)`: its kind (in `mixed`) and its variant
//! come from a SplitMix64 hash of the pair, so the same seed replays the same requests.

use bytes::Bytes;
use prost::Message as _;
use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde_json::{Map, Value, json};

use crate::cli::{Area, Options, QueryKind};
use crate::wire::{Wire, v1};

/// Prepared request bodies take at most about this many bytes per kind (a 4,096-point JSON
/// sample is ~170 kB, so it gets ~48 variants; a single point gets the maximum).
const VARIANT_BYTES: usize = 8 << 20;
/// At most this many variants per kind: enough that the server sees distinct points and cache
/// effects of one repeated body do not flatter it.
const MAX_VARIANTS: usize = 256;
/// At least this many.
const MIN_VARIANTS: usize = 4;

/// The seeded generator of points and hulls (PCG-64 MCG; its raw output is stable across
/// versions, and only the raw output is used).
pub struct Rng(Pcg64Mcg);

impl Rng {
    /// A generator for `seed`.
    pub fn new(seed: u64) -> Self {
        Self(Pcg64Mcg::seed_from_u64(seed))
    }

    /// Uniform in [0, 1), 53 bits.
    pub fn unit(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [a, b).
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.unit()
    }

    /// Uniform in 0..n (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.0.next_u64() % n as u64) as usize
    }

    /// A point in `area`, as `[x, z]`.
    pub fn point(&mut self, area: &Area) -> [f64; 2] {
        [self.range(area.x0, area.x1), self.range(area.z0, area.z1)]
    }
}

/// SplitMix64 of `x`: a fast, well-mixed hash used to pick kinds and variants by index.
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// One prepared HTTP request.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// What it asks.
    pub kind: QueryKind,
    /// Full URL (with the query string for `height`).
    pub url: String,
    /// POST body; `None` for a GET.
    pub body: Option<Bytes>,
    /// Points (or bodies) it asks about: what `points/s` counts.
    pub points: u64,
}

/// One prepared WebSocket query, without its `id` (added per message).
#[derive(Debug, Clone)]
pub struct PreparedWs {
    /// `sample` or `orientation`.
    pub kind: QueryKind,
    /// JSON: the object's text after its opening brace (`"type":…}`), so `{"id":N,` + rest is
    /// the message. Protobuf: the encoded `ClientMessage` without its id; a message with id is
    /// the id field followed by these bytes (protobuf merges concatenated fields).
    pub rest: Bytes,
    /// Points (or bodies) it asks about.
    pub points: u64,
}

impl PreparedWs {
    /// The message with `id`, as a WebSocket frame payload.
    pub fn with_id(&self, wire: Wire, id: u64) -> Vec<u8> {
        match wire {
            Wire::Json => {
                let head = format!("{{\"id\":{id},");
                let mut v = Vec::with_capacity(head.len() + self.rest.len());
                v.extend_from_slice(head.as_bytes());
                v.extend_from_slice(&self.rest);
                v
            }
            Wire::Protobuf => {
                let mut v = v1::ClientMessage {
                    id: Some(id),
                    msg: None,
                }
                .encode_to_vec();
                v.extend_from_slice(&self.rest);
                v
            }
        }
    }
}

fn field_enum(name: &str) -> v1::Field {
    match name {
        "normal" => v1::Field::Normal,
        "displacement" => v1::Field::Displacement,
        "jacobian" => v1::Field::Jacobian,
        "residual" => v1::Field::Residual,
        _ => v1::Field::Height,
    }
}

fn variants_for(bytes_each: usize) -> usize {
    (VARIANT_BYTES / bytes_each.max(1)).clamp(MIN_VARIANTS, MAX_VARIANTS)
}

/// A random hull: length 4–40 m, beam a quarter to a third of it, any yaw.
fn random_body(rng: &mut Rng, area: &Area) -> ([f64; 2], f64, f64, f64) {
    let position = rng.point(area);
    let length = rng.range(4.0, 40.0);
    let beam = length * rng.range(0.25, 1.0 / 3.0);
    let yaw = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
    (position, yaw, length, beam)
}

/// A sample request's JSON object (without `type`/`id`).
fn sample_json(o: &Options, rng: &mut Rng) -> Map<String, Value> {
    let mut m = Map::new();
    if let Some(t) = o.t {
        m.insert("t".into(), json!(t));
    }
    let pts: Vec<[f64; 2]> = (0..o.points).map(|_| rng.point(&o.area)).collect();
    m.insert("points".into(), json!(pts));
    m.insert("fields".into(), json!(o.fields));
    m
}

fn sample_proto(o: &Options, rng: &mut Rng) -> v1::SampleRequest {
    v1::SampleRequest {
        t: o.t,
        origin: None,
        points: (0..o.points)
            .map(|_| {
                let [x, z] = rng.point(&o.area);
                v1::Point2 { x, z }
            })
            .collect(),
        fields: o.fields.iter().map(|f| field_enum(f) as i32).collect(),
        accuracy: None,
    }
}

fn orientation_json(o: &Options, rng: &mut Rng) -> Map<String, Value> {
    let mut m = Map::new();
    if let Some(t) = o.t {
        m.insert("t".into(), json!(t));
    }
    let bodies: Vec<Value> = (0..o.bodies)
        .map(|_| {
            let (position, yaw, length, beam) = random_body(rng, &o.area);
            json!({"position": position, "yaw": yaw, "length": length, "beam": beam})
        })
        .collect();
    m.insert("bodies".into(), Value::Array(bodies));
    m
}

fn orientation_proto(o: &Options, rng: &mut Rng) -> v1::OrientationRequest {
    v1::OrientationRequest {
        t: o.t,
        bodies: (0..o.bodies)
            .map(|_| {
                let ([x, z], yaw, length, beam) = random_body(rng, &o.area);
                v1::Body {
                    position: Some(v1::Point2 { x, z }),
                    yaw,
                    length,
                    beam,
                    probes: Vec::new(),
                }
            })
            .collect(),
    }
}

/// Builds `n` HTTP requests of `kind`.
fn http_variants(o: &Options, kind: QueryKind, rng: &mut Rng) -> Vec<Prepared> {
    // Variant j queries scene j mod (number of scenes): with the count a multiple of it, every
    // scene gets the same share of the requests.
    let scenes: Vec<&str> = if o.scenes.is_empty() {
        vec![o.scene.as_str()]
    } else {
        o.scenes.iter().map(String::as_str).collect()
    };
    let mut j = 0;
    let mut make = |rng: &mut Rng| -> Prepared {
        let base = format!("{}/v1/scenes/{}", o.url, scenes[j % scenes.len()]);
        j += 1;
        match kind {
            QueryKind::Height => {
                let [x, z] = rng.point(&o.area);
                // `{:?}` of an f64 is its shortest round-trip form: the server parses it back
                // to the same bits.
                let mut url = format!("{base}/height?x={x:?}&z={z:?}");
                if let Some(t) = o.t {
                    url.push_str(&format!("&t={t:?}"));
                }
                Prepared {
                    kind,
                    url,
                    body: None,
                    points: 1,
                }
            }
            QueryKind::Sample => Prepared {
                kind,
                url: format!("{base}/sample"),
                body: Some(match o.wire {
                    Wire::Json => Bytes::from(
                        serde_json::to_vec(&Value::Object(sample_json(o, rng)))
                            .expect("a JSON value serialises"),
                    ),
                    Wire::Protobuf => Bytes::from(sample_proto(o, rng).encode_to_vec()),
                }),
                points: o.points as u64,
            },
            QueryKind::Orientation => Prepared {
                kind,
                url: format!("{base}/orientation"),
                body: Some(match o.wire {
                    Wire::Json => Bytes::from(
                        serde_json::to_vec(&Value::Object(orientation_json(o, rng)))
                            .expect("a JSON value serialises"),
                    ),
                    Wire::Protobuf => Bytes::from(orientation_proto(o, rng).encode_to_vec()),
                }),
                points: o.bodies as u64,
            },
        }
    };
    let first = make(rng);
    let size = first.url.len() + first.body.as_ref().map_or(0, Bytes::len);
    let n = scenes.len();
    let count = (variants_for(size).max(n) / n) * n;
    let mut out = vec![first];
    out.extend((1..count).map(|_| make(rng)));
    out
}

/// The HTTP requests of a run: variants per kind, and the kind weights.
pub struct HttpWorkload {
    kinds: Vec<(QueryKind, u32, Vec<Prepared>)>,
    total_weight: u64,
    seed: u64,
}

impl HttpWorkload {
    /// The workload of `o.mode` (`height`, `sample`, `orientation` or `mixed`).
    pub fn new(o: &Options) -> Self {
        let mut rng = Rng::new(o.seed);
        let weights: Vec<(QueryKind, u32)> = match o.mode {
            crate::cli::Mode::Mixed => o.mix.0.iter().copied().filter(|(_, w)| *w > 0).collect(),
            crate::cli::Mode::Sample => vec![(QueryKind::Sample, 1)],
            crate::cli::Mode::Orientation => vec![(QueryKind::Orientation, 1)],
            _ => vec![(QueryKind::Height, 1)],
        };
        let kinds: Vec<_> = weights
            .into_iter()
            .map(|(k, w)| (k, w, http_variants(o, k, &mut rng)))
            .collect();
        let total_weight = kinds.iter().map(|(_, w, _)| u64::from(*w)).sum();
        Self {
            kinds,
            total_weight,
            seed: o.seed,
        }
    }

    /// `GET /healthz` only: the ceiling run.
    pub fn healthz(o: &Options) -> Self {
        Self {
            kinds: vec![(
                QueryKind::Height,
                1,
                vec![Prepared {
                    kind: QueryKind::Height,
                    url: format!("{}/healthz", o.url),
                    body: None,
                    points: 0,
                }],
            )],
            total_weight: 1,
            seed: o.seed,
        }
    }

    /// Request `i`.
    pub fn get(&self, i: u64) -> &Prepared {
        let h = splitmix64(self.seed ^ splitmix64(i));
        let mut pick = (h >> 32) % self.total_weight;
        for (_, w, variants) in &self.kinds {
            let w = u64::from(*w);
            if pick < w {
                return &variants[(h as u32 as usize) % variants.len()];
            }
            pick -= w;
        }
        unreachable!("pick < total weight")
    }
}

/// The WebSocket queries of a `ws-query` run.
pub struct WsWorkload {
    variants: Vec<PreparedWs>,
    seed: u64,
}

impl WsWorkload {
    /// `--query` messages with `--points` or `--bodies`.
    pub fn new(o: &Options) -> Self {
        let mut rng = Rng::new(o.seed);
        let kind = o.query;
        let make = |rng: &mut Rng| -> PreparedWs {
            let (rest, points) = match (kind, o.wire) {
                (QueryKind::Orientation, Wire::Json) => {
                    (json_rest("orientation", orientation_json(o, rng)), o.bodies)
                }
                (QueryKind::Orientation, Wire::Protobuf) => (
                    v1::ClientMessage {
                        id: None,
                        msg: Some(v1::client_message::Msg::Orientation(orientation_proto(
                            o, rng,
                        ))),
                    }
                    .encode_to_vec(),
                    o.bodies,
                ),
                (_, Wire::Json) => (json_rest("sample", sample_json(o, rng)), o.points),
                (_, Wire::Protobuf) => (
                    v1::ClientMessage {
                        id: None,
                        msg: Some(v1::client_message::Msg::Sample(sample_proto(o, rng))),
                    }
                    .encode_to_vec(),
                    o.points,
                ),
            };
            PreparedWs {
                kind,
                rest: Bytes::from(rest),
                points: points as u64,
            }
        };
        let first = make(&mut rng);
        let mut variants = vec![first.clone()];
        variants.extend((1..variants_for(first.rest.len())).map(|_| make(&mut rng)));
        Self {
            variants,
            seed: o.seed,
        }
    }

    /// Message `i`.
    pub fn get(&self, i: u64) -> &PreparedWs {
        let h = splitmix64(self.seed ^ splitmix64(i));
        &self.variants[(h as usize) % self.variants.len()]
    }
}

/// `{"type":ty, …fields}` serialised, without its opening brace.
fn json_rest(ty: &str, fields: Map<String, Value>) -> Vec<u8> {
    let mut m = Map::new();
    m.insert("type".into(), json!(ty));
    m.extend(fields);
    let mut v = serde_json::to_vec(&Value::Object(m)).expect("a JSON value serialises");
    v.remove(0);
    v
}

/// Checks an answer: it decodes, and it carries one value per point (or body) asked about.
///
/// # Errors
/// What was wrong, for the error tally (`invalid answer: …`).
pub fn validate(kind: QueryKind, wire: Wire, body: &[u8], points: u64) -> Result<(), String> {
    let n = match (kind, wire) {
        (QueryKind::Height, Wire::Json) => {
            let v: Value = serde_json::from_slice(body).map_err(|e| e.to_string())?;
            if points == 0 {
                return Ok(()); // /healthz
            }
            v["height"]
                .as_f64()
                .filter(|h| h.is_finite())
                .map(|_| 1)
                .ok_or("no finite height")?
        }
        (QueryKind::Height, Wire::Protobuf) => {
            if points == 0 {
                return Ok(());
            }
            let r = v1::HeightResponse::decode(body).map_err(|e| e.to_string())?;
            if !r.height.is_finite() {
                return Err("non-finite height".into());
            }
            1
        }
        (QueryKind::Sample, Wire::Json) => {
            let v: Value = serde_json::from_slice(body).map_err(|e| e.to_string())?;
            sample_len_json(&v)?
        }
        (QueryKind::Sample, Wire::Protobuf) => {
            let r = v1::SampleResponse::decode(body).map_err(|e| e.to_string())?;
            sample_len_proto(&r)
        }
        (QueryKind::Orientation, Wire::Json) => {
            let v: Value = serde_json::from_slice(body).map_err(|e| e.to_string())?;
            v["bodies"].as_array().ok_or("no bodies array")?.len()
        }
        (QueryKind::Orientation, Wire::Protobuf) => v1::OrientationResponse::decode(body)
            .map_err(|e| e.to_string())?
            .bodies
            .len(),
    };
    if n as u64 != points {
        return Err(format!("{n} values for {points} asked"));
    }
    Ok(())
}

/// Values in a JSON sample answer: the length of its first array field.
pub fn sample_len_json(v: &Value) -> Result<usize, String> {
    for f in ["height", "normal", "displacement", "jacobian", "residual"] {
        if let Some(a) = v[f].as_array() {
            return Ok(a.len());
        }
    }
    Err("no field array in the answer".into())
}

/// Values in a protobuf sample answer.
pub fn sample_len_proto(r: &v1::SampleResponse) -> usize {
    [
        r.height.len(),
        r.normal.len(),
        r.displacement.len(),
        r.jacobian.len(),
        r.residual.len(),
    ]
    .into_iter()
    .max()
    .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser as _;

    fn opts(argv: &[&str]) -> Options {
        let mut v = vec!["swell-load"];
        v.extend_from_slice(argv);
        crate::cli::Args::try_parse_from(v)
            .unwrap()
            .into_options()
            .unwrap()
    }

    /// `--scenes`: every scene gets the same share of the requests.
    #[test]
    fn scenes_share_the_requests_evenly() {
        let o = opts(&["height", "--scenes", "a,b,c"]);
        assert_eq!(o.scene, "a");
        let w = HttpWorkload::new(&o);
        let mut counts = [0u32; 3];
        for i in 0..30_000 {
            let url = &w.get(i).url;
            let k = ["/a/", "/b/", "/c/"]
                .iter()
                .position(|s| url.contains(s))
                .unwrap();
            counts[k] += 1;
        }
        assert!(
            counts.iter().all(|c| (9_500..=10_500).contains(c)),
            "{counts:?}"
        );
    }

    #[test]
    fn same_seed_same_requests_and_the_mix_follows_its_weights() {
        let o = opts(&[
            "mixed",
            "--mix",
            "height=90,sample=9,orientation=1",
            "--points",
            "4",
        ]);
        let a = HttpWorkload::new(&o);
        let b = HttpWorkload::new(&o);
        let mut counts = [0u32; 3];
        for i in 0..20_000 {
            let (pa, pb) = (a.get(i), b.get(i));
            assert_eq!(pa.url, pb.url);
            assert_eq!(pa.body, pb.body);
            counts[pa.kind as usize] += 1;
        }
        // 90/9/1 of 20,000, within a few standard deviations.
        assert!((17_700..=18_300).contains(&counts[0]), "{counts:?}");
        assert!((1_600..=2_000).contains(&counts[1]), "{counts:?}");
        assert!((120..=290).contains(&counts[2]), "{counts:?}");
    }

    #[test]
    fn points_fall_in_the_area_and_round_trip_exactly() {
        let o = opts(&[
            "sample",
            "--points",
            "50",
            "--area",
            "10,20,30,40",
            "--t",
            "60",
        ]);
        let w = HttpWorkload::new(&o);
        let v: Value = serde_json::from_slice(w.get(3).body.as_ref().unwrap()).unwrap();
        assert_eq!(v["t"], json!(60.0));
        let pts = v["points"].as_array().unwrap();
        assert_eq!(pts.len(), 50);
        for p in pts {
            let (x, z) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
            assert!((10.0..30.0).contains(&x) && (20.0..40.0).contains(&z));
        }
    }

    #[test]
    fn ws_messages_carry_their_id_in_both_encodings() {
        let o = opts(&["ws-query", "--points", "3"]);
        let m = WsWorkload::new(&o).get(0).with_id(Wire::Json, 77);
        let v: Value = serde_json::from_slice(&m).unwrap();
        assert_eq!(v["id"], json!(77));
        assert_eq!(v["type"], json!("sample"));
        assert_eq!(v["points"].as_array().unwrap().len(), 3);

        let o = opts(&[
            "ws-query",
            "--wire",
            "protobuf",
            "--query",
            "orientation",
            "--bodies",
            "2",
        ]);
        let m = WsWorkload::new(&o).get(5).with_id(Wire::Protobuf, 9);
        let msg = v1::ClientMessage::decode(&m[..]).unwrap();
        assert_eq!(msg.id, Some(9));
        match msg.msg {
            Some(v1::client_message::Msg::Orientation(r)) => assert_eq!(r.bodies.len(), 2),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn big_batches_get_fewer_variants() {
        let o = opts(&["sample", "--points", "4096"]);
        let w = HttpWorkload::new(&o);
        let n = w.kinds[0].2.len();
        assert!((MIN_VARIANTS..MAX_VARIANTS).contains(&n), "{n}");
        assert_eq!(
            HttpWorkload::new(&opts(&["height"])).kinds[0].2.len(),
            MAX_VARIANTS
        );
    }
}
