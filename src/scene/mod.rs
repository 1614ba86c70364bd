//! Scenes: a named wave model (a [`SurfaceSpec`] plus a description and a tick rate), its built
//! [`Surface`], and its clock.
//!
//! - [`answers`] — encoded answers a build shares with every request for them (spectra).
//! - [`builtin`] — the scenes `swell serve` starts with.
//! - [`error`] — [`SceneError`], why a spec or id was refused.
//! - [`clock`] — scene time anchored to wall time: `t = offset + rate·(unix_now − anchor)` from
//!   the scene epoch; pause, rate, seek.
//! - [`store`] — the clock record, and the reader of the pre-journal data dir layout (changes
//!   are now journaled: [`crate::journal`]).

pub mod answers;
pub mod builtin;
pub mod clock;
pub mod error;
pub mod particles;
pub mod store;

use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};
use serde_json::Value;
use swell_waves::body::{MAX_TICK_HZ, MIN_TICK_HZ};
use swell_waves::surface::layer_seed;
use swell_waves::{Layer, LayerSpec, Surface, SurfaceSpec};

pub use clock::Clock;
pub use error::SceneError;

/// Longest scene description, characters (Unicode scalar values, as JSON Schema's `maxLength`
/// in `/openapi.json` counts them; at most 4 bytes each in UTF-8).
pub const MAX_DESCRIPTION: usize = 4096;
/// Name of the seeded generator every layer draws from, as clients should look it up.
pub const RNG_NAME: &str = "pcg32-splitmix64 (see swell_waves::math)";

/// A scene as written by people: `{"description","tick_hz", ...SurfaceSpec fields}`.
///
/// Serialises flat (the surface fields beside `description` and `tick_hz`). Parsing goes through
/// [`SceneSpec::from_value`], which rejects unknown fields at every level and names them (serde's
/// `flatten` cannot be combined with `deny_unknown_fields`, so the split is done by hand).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneSpec {
    /// What the scene is, for people.
    pub description: String,
    /// Ticks per second of scene time (`tick = floor(t·tick_hz)`), in (0, 1000]. Default 30.
    pub tick_hz: f64,
    /// Unix time, s, at which the scene clock reads `t = 0` running at rate 1 (in
    /// [0, [`MAX_EPOCH`]]). Default: [`clock::BUILTIN_EPOCH`] for built-in and configured scenes
    /// (so replicas agree), the time of creation for a scene `PUT` by an admin (filled in and
    /// persisted). Not part of the sea: it moves the clock only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub epoch: Option<f64>,
    /// The waves.
    #[serde(flatten)]
    pub surface: SurfaceSpec,
}

/// Latest scene epoch accepted, Unix seconds (year 5138): far beyond any real schedule, well
/// inside the range where f64 seconds keep microseconds.
pub const MAX_EPOCH: f64 = 1e11;

/// Default tick rate, Hz: a common game network rate.
pub const DEFAULT_TICK_HZ: f64 = 30.0;

impl<'de> Deserialize<'de> for SceneSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Value::deserialize(d)?;
        SceneSpec::from_value(v).map_err(serde::de::Error::custom)
    }
}

impl SceneSpec {
    /// Parses a scene from JSON. Checks the shape (unknown fields, types) and the scene's own
    /// fields; the surface itself is validated when it is built ([`Scene::build`]).
    ///
    /// # Errors
    /// [`SceneError::Malformed`] naming the path of a wrongly typed or unknown field;
    /// [`SceneError::Rejected`] for a bad `tick_hz`, `epoch` or description.
    pub fn from_value(v: Value) -> Result<SceneSpec, SceneError> {
        let malformed = |message: &str, field: Option<&str>| SceneError::Malformed {
            message: message.to_owned(),
            field: field.map(str::to_owned),
        };
        let Value::Object(mut map) = v else {
            return Err(malformed("a scene spec must be a JSON object", None));
        };
        let description = match map.remove("description") {
            None | Some(Value::Null) => String::new(),
            Some(Value::String(s)) => s,
            Some(_) => {
                return Err(malformed(
                    "description must be a string",
                    Some("description"),
                ));
            }
        };
        let tick_hz = match map.remove("tick_hz") {
            None | Some(Value::Null) => DEFAULT_TICK_HZ,
            Some(Value::Number(n)) => n.as_f64().unwrap_or(f64::NAN),
            Some(_) => {
                return Err(malformed("tick_hz must be a number", Some("tick_hz")));
            }
        };
        let epoch = match map.remove("epoch") {
            None | Some(Value::Null) => None,
            Some(Value::Number(n)) => Some(n.as_f64().unwrap_or(f64::NAN)),
            Some(_) => {
                return Err(malformed("epoch must be a number", Some("epoch")));
            }
        };
        let layers = map.get("layers").cloned();
        let surface: SurfaceSpec =
            crate::service::json::from_value(Value::Object(map)).map_err(|e| {
                let e = match &layers {
                    Some(l) => layer_error(l, e),
                    None => e,
                };
                SceneError::Malformed {
                    message: e.message,
                    field: e.field,
                }
            })?;
        let spec = SceneSpec {
            description,
            tick_hz,
            epoch,
            surface,
        };
        spec.validate()?;
        Ok(spec)
    }

    /// Checks the scene's own fields.
    ///
    /// # Errors
    /// [`SceneError::Rejected`] naming `tick_hz`, `epoch` or `description`.
    pub fn validate(&self) -> Result<(), SceneError> {
        // The body model's limit: a scene's bodies step at the scene's tick rate, so a scene may
        // not tick faster than a body world can.
        if !(self.tick_hz.is_finite() && (MIN_TICK_HZ..=MAX_TICK_HZ).contains(&self.tick_hz)) {
            return Err(SceneError::Rejected(swell_waves::SpecError::OutOfRange {
                field: "tick_hz".into(),
                value: self.tick_hz,
                allowed: format!("in [{MIN_TICK_HZ}, {MAX_TICK_HZ}] Hz"),
            }));
        }
        if let Some(e) = self.epoch
            && !(e.is_finite() && (0.0..=MAX_EPOCH).contains(&e))
        {
            return Err(SceneError::Rejected(swell_waves::SpecError::OutOfRange {
                field: "epoch".into(),
                value: e,
                allowed: format!("Unix seconds in [0, {MAX_EPOCH}]"),
            }));
        }
        let chars = self.description.chars().count();
        if chars > MAX_DESCRIPTION {
            return Err(SceneError::Rejected(swell_waves::SpecError::Inconsistent {
                field: "description".into(),
                reason: format!("{chars} characters; at most {MAX_DESCRIPTION} allowed"),
            }));
        }
        Ok(())
    }

    /// The canonical JSON of the spec: fields in declaration order, numbers in shortest
    /// round-trip form, without `epoch` (it moves the clock, not the sea). Its hash identifies
    /// the sea.
    pub fn canonical_json(&self) -> String {
        let sea = SceneSpec {
            epoch: None,
            ..self.clone()
        };
        // Serialising plain data (no maps with non-string keys, no non-finite floats after
        // validation) cannot fail; an empty string would only weaken the hash, not break it.
        serde_json::to_string(&sea).unwrap_or_default()
    }
}

/// Checks a scene id: `[a-z0-9-]{1,64}`.
///
/// # Errors
/// [`SceneError::BadId`].
pub fn validate_id(id: &str) -> Result<(), SceneError> {
    let ok = !id.is_empty()
        && id.len() <= 64
        && id
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-');
    if ok {
        Ok(())
    } else {
        Err(SceneError::BadId { id: id.to_owned() })
    }
}

/// FNV-1a, 64 bit, as 16 lower-case hex digits. Specified (offset basis 0xcbf29ce484222325,
/// prime 0x100000001b3) so clients can recompute it over the canonical spec JSON.
pub fn fnv1a64_hex(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// A built scene: immutable once made. Replacing a scene builds a new one.
#[derive(Debug)]
pub struct Scene {
    /// The id.
    pub id: String,
    /// The spec it was built from.
    pub spec: SceneSpec,
    /// The built surface.
    pub surface: Surface,
    /// [`fnv1a64_hex`] of [`SceneSpec::canonical_json`].
    pub spec_hash: String,
    /// This build's identity in the process (a counter): caches key on it, so frames of a
    /// replaced scene are never read for its successor, even one with the same spec.
    pub uid: u64,
    /// Impact events rippling on its particle layer (empty for a new build: replacing a scene
    /// starts its impacts afresh).
    pub impacts: crate::impacts::SceneImpacts,
    /// Answers that are a pure function of this build, encoded once and shared
    /// ([`answers`]); retired with the build.
    pub answers: answers::SceneAnswers,
}

/// Source of [`Scene::uid`].
static NEXT_UID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

impl Scene {
    /// Validates and builds a scene. CPU work (an FFT layer's spectrum): call off the reactor.
    ///
    /// # Errors
    /// [`SceneError::Rejected`] with the model's message and field.
    pub fn build(id: &str, spec: SceneSpec) -> Result<Scene, SceneError> {
        spec.validate()?;
        let surface = Surface::new(&spec.surface)?;
        let spec_hash = fnv1a64_hex(spec.canonical_json().as_bytes());
        let impacts = crate::impacts::SceneImpacts::default();
        if let Some(layer) = surface.impact_layer() {
            impacts.set_lifetime(layer.ripples().lifetime);
        }
        Ok(Scene {
            id: id.to_owned(),
            spec,
            surface,
            spec_hash,
            uid: NEXT_UID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            impacts,
            answers: answers::SceneAnswers::default(),
        })
    }

    /// Whether any layer is an FFT layer (its queries may need a frame computed: CPU work).
    pub fn has_fft(&self) -> bool {
        self.layer_kinds().contains(&"fft")
    }

    /// Layer kinds in order.
    pub fn layer_kinds(&self) -> Vec<&'static str> {
        self.spec
            .surface
            .layers
            .iter()
            .map(LayerSpec::kind)
            .collect()
    }

    /// Everything derived from the spec that a client needs to render the same sea: each layer's
    /// built waves (sine, Gerstner) or FFT settings in use, seeds and the generator's name.
    pub fn derived(&self) -> Value {
        let layers: Vec<Value> = self
            .surface
            .layers()
            .iter()
            .zip(&self.spec.surface.layers)
            .enumerate()
            .map(|(i, (layer, spec))| {
                let default_seed = layer_seed(self.spec.surface.seed, i);
                match (layer, spec) {
                    (Layer::Sine(l), _) => serde_json::json!({
                        "kind": "sine",
                        "waves": l.waves(),
                    }),
                    (Layer::Gerstner(l), LayerSpec::Gerstner(g)) => serde_json::json!({
                        "kind": "gerstner",
                        "seed": g.seed.unwrap_or(default_seed),
                        "fold_number": l.fold_number(),
                        "waves": l.waves(),
                    }),
                    (Layer::Fft(f), LayerSpec::Fft(s)) => serde_json::json!({
                        "kind": "fft",
                        "resolution": f.resolution(),
                        "tile_size": f.tile_size(),
                        "choppiness": f.choppiness(),
                        "repeat_period": f.repeat_period(),
                        "time_step": f.time_step(),
                        "grid_steps": f.grid_steps(),
                        "seed": s.seed.unwrap_or(default_seed),
                        "backend": f.backend(),
                        "modes": f.modes(),
                        "variance": f.variance(),
                        "significant_wave_height": 4.0 * f.variance().sqrt(),
                        "rng": RNG_NAME,
                    }),
                    (Layer::Particles(p), LayerSpec::Particles(s)) => {
                        crate::scene::particles::derived(p, s)
                    }
                    // A built layer always has the kind of its spec.
                    (l, _) => serde_json::json!({ "kind": kind_of(l) }),
                }
            })
            .collect();
        serde_json::json!({
            "fold_number": self.surface.fold_number(),
            "horizontal_motion": self.surface.has_horizontal_motion(),
            "gravity": self.spec.surface.gravity,
            "depth": self.spec.surface.depth,
            "rng": RNG_NAME,
            "layers": layers,
        })
    }
}

fn kind_of(l: &Layer) -> &'static str {
    match l {
        Layer::Sine(_) => "sine",
        Layer::Gerstner(_) => "gerstner",
        Layer::Fft(_) => "fft",
        Layer::Particles(_) => "particles",
    }
}

/// A scene in the registry: the built scene (swapped whole on replace) and its clock.
#[derive(Debug)]
pub struct SceneEntry {
    /// The scene.
    pub scene: Arc<Scene>,
    /// Its clock (see [`clock`]). A std mutex: held for a few arithmetic operations, never
    /// across an await.
    pub clock: Mutex<Clock>,
}
/// `e`, a layer's error, with the path inside the layer. Layers are tagged by `kind`, which serde
/// reads by buffering the layer first, and the path tracking stops at the buffer: an unknown
/// field deep in a sine layer came back as `layers[0].foo`, not `layers[0].waves[0].foo`. The
/// layer is decoded again as its own kind, whose errors carry the whole path.
fn layer_error(
    layers: &Value,
    e: crate::service::json::JsonError,
) -> crate::service::json::JsonError {
    use crate::service::json::from_value;
    let Some((i, _)) = e
        .field
        .as_deref()
        .and_then(|f| f.strip_prefix("layers["))
        .and_then(|r| r.split_once(']'))
        .and_then(|(i, rest)| Some((i.parse::<usize>().ok()?, rest)))
    else {
        return e;
    };
    let Some(Value::Object(layer)) = layers.get(i) else {
        return e;
    };
    let mut body = layer.clone();
    let kind = body.remove("kind");
    let body = Value::Object(body);
    let inner = match kind.as_ref().and_then(Value::as_str) {
        Some("sine") => from_value::<swell_waves::sine::SineLayerSpec>(body).err(),
        Some("gerstner") => from_value::<swell_waves::gerstner::GerstnerLayerSpec>(body).err(),
        Some("fft") => from_value::<swell_waves::fft::FftSpec>(body).err(),
        Some("particles") => from_value::<swell_waves::particles::ParticleLayerSpec>(body).err(),
        _ => None,
    };
    match inner {
        Some(inner) => crate::service::json::JsonError {
            field: Some(match &inner.field {
                Some(f) => format!("layers[{i}].{f}"),
                None => format!("layers[{i}]"),
            }),
            message: if inner.field.is_some() {
                format!("layers[{i}].{}", inner.message)
            } else {
                format!("layers[{i}]: {}", inner.message)
            },
        },
        None => e,
    }
}
