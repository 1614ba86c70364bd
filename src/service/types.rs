//! Request and response types of the API, apart from the handlers, so every transport (HTTP
//! JSON and protobuf, the WebSocket stream in both subprotocols) decodes into and encodes from
//! the same structs.
//!
//! Numbers are f64 and travel exactly: serde_json writes the shortest round-trip form and, with
//! `float_roundtrip`, parses it back to the same bits.

use serde::{Deserialize, Serialize};
use swell_waves::InversionMethod;
use swell_waves::fft::SampleFilter;

use crate::scene::SceneSpec;
use crate::scene::clock::ClockReading;
use crate::service::error::ClockUpdateError;

/// `GET /v1/scenes` answer.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SceneList {
    /// Every scene, sorted by id.
    pub scenes: Vec<SceneSummary>,
}

/// One scene in the list.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SceneSummary {
    /// Id.
    pub id: String,
    /// Description.
    pub description: String,
    /// Layer kinds in order (`sine`, `gerstner`, `fft`).
    pub layers: Vec<String>,
    /// Tick rate, Hz.
    pub tick_hz: f64,
}

/// `GET /v1/scenes/{id}` answer: everything a client needs to render the same sea.
#[derive(Debug, Clone, Serialize)]
pub struct SceneDetail {
    /// Id.
    pub id: String,
    /// The spec as stored (defaults filled in).
    pub spec: SceneSpec,
    /// Built waves, FFT settings, seeds, generator name.
    pub derived: serde_json::Value,
    /// `swell_waves::MODEL_VERSION`.
    pub model_version: u32,
    /// FNV-1a 64 (hex) of the canonical spec JSON.
    pub spec_hash: String,
    /// The clock now.
    pub clock: ClockReading,
}

/// `PUT /v1/scenes/{id}/clock` body. Applied in the order seek, rate, pause.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClockUpdate {
    /// New rate (scene seconds per real second; negative runs backwards).
    #[serde(default)]
    pub rate: Option<f64>,
    /// Pause (true) or resume (false).
    #[serde(default)]
    pub paused: Option<bool>,
    /// Seek to this scene time, s.
    #[serde(default)]
    pub t: Option<f64>,
}

impl ClockUpdate {
    /// Checks the numbers before anything changes: `t` as a query time
    /// ([`crate::Limits::check_time`]), `|rate| <=` [`crate::scene::clock::MAX_RATE`].
    ///
    /// # Errors
    /// [`ClockUpdateError`] naming `t` or `rate`.
    pub fn validate(&self, limits: &crate::Limits) -> Result<(), ClockUpdateError> {
        if let Some(t) = self.t {
            limits.check_time(t, "t")?;
        }
        let max = crate::scene::clock::MAX_RATE;
        if let Some(r) = self.rate
            && !(r.is_finite() && r.abs() <= max)
        {
            return Err(ClockUpdateError::Rate { rate: r, max });
        }
        Ok(())
    }
}

/// `GET /v1/scenes/{id}/height` query.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeightQuery {
    /// World x, m.
    pub x: f64,
    /// World z, m.
    pub z: f64,
    /// Scene time, s; absent means the clock's now.
    #[serde(default)]
    pub t: Option<f64>,
}

/// `GET /v1/scenes/{id}/height` answer.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct HeightResponse {
    /// The scene time used, s.
    pub t: f64,
    /// Height of the surface above (x, z), m.
    pub height: f64,
}

/// The fields a sample request may ask for, as named on the wire.
pub const FIELD_NAMES: [&str; 5] = ["height", "normal", "displacement", "jacobian", "residual"];

/// `POST /v1/scenes/{id}/sample` body.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SampleRequest {
    /// Scene time, s; absent means the clock's now.
    #[serde(default)]
    pub t: Option<f64>,
    /// World offset `[x, z]` added (in f64) to every point.
    #[serde(default)]
    pub origin: Option<[f64; 2]>,
    /// Points `[x, z]`, m.
    pub points: Vec<[f64; 2]>,
    /// Fields to answer (see [`FIELD_NAMES`]); default `["height"]`.
    #[serde(default)]
    pub fields: Option<Vec<String>>,
    /// Accuracy settings; default Newton, 8 iterations, 1e-5 m, bicubic.
    #[serde(default)]
    pub accuracy: Option<Accuracy>,
}

/// Accuracy knobs of a query.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Accuracy {
    /// Inversion method.
    #[serde(default)]
    pub method: Option<InversionMethod>,
    /// Most inversion steps (0..=64).
    #[serde(default)]
    pub iterations: Option<u32>,
    /// Inversion tolerance, m.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// FFT grid filter.
    #[serde(default)]
    pub filter: Option<Filter>,
    /// Evaluation precision: `f64` (the default, the model's reference bits) or `f32` (the
    /// single-precision fast path: a few µm off, several times cheaper).
    #[serde(default)]
    pub precision: Option<Precision>,
    /// FFT time sampling: `grid` (the default: linear between the layer's grid frames, shared
    /// by every query between two grid times) or `exact` (a frame at exactly t).
    #[serde(default)]
    pub time: Option<swell_waves::TimeSampling>,
}

/// Evaluation precision on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    /// f64 throughout (the default).
    F64,
    /// Single-precision fast path (f64 phase reduction, f32 sin/cos and sums).
    F32,
}

impl From<Precision> for swell_waves::Precision {
    fn from(p: Precision) -> swell_waves::Precision {
        match p {
            Precision::F64 => swell_waves::Precision::F64,
            Precision::F32 => swell_waves::Precision::F32,
        }
    }
}

/// FFT grid sampling filter on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Filter {
    /// Nearest node.
    Nearest,
    /// Bilinear.
    Bilinear,
    /// Catmull–Rom bicubic (the default).
    Bicubic,
}

impl From<Filter> for SampleFilter {
    fn from(f: Filter) -> SampleFilter {
        match f {
            Filter::Nearest => SampleFilter::Nearest,
            Filter::Bilinear => SampleFilter::Bilinear,
            Filter::Bicubic => SampleFilter::Bicubic,
        }
    }
}

/// `POST /v1/scenes/{id}/sample` answer: only the fields asked, each one entry per point.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct SampleResponse {
    /// The scene time used, s.
    pub t: f64,
    /// Heights, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height: Option<Vec<f64>>,
    /// Unit normals `[x, y, z]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<Vec<[f64; 3]>>,
    /// Displacements `[Dx, y, Dz]` of the points taken as undisplaced, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub displacement: Option<Vec<[f64; 3]>>,
    /// Jacobian determinants of the horizontal map.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jacobian: Option<Vec<f64>>,
    /// `jacobian ≤ 0` (the surface folds): sent with `jacobian`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub folded: Option<Vec<bool>>,
    /// Inversion residuals, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual: Option<Vec<f64>>,
}

/// Bytes one number of an answer takes at most as JSON (`-1.2345678901234567e-308,`).
pub const JSON_NUMBER_BYTES: usize = 25;

/// Bytes one number of an answer takes as protobuf (a packed double).
pub const PROTOBUF_NUMBER_BYTES: usize = 8;

impl SampleResponse {
    /// An answer at `t` with an empty array, room for `points`, for each of `fields`.
    pub fn with_fields(t: f64, fields: swell_waves::QueryFields, points: usize) -> SampleResponse {
        fn v<T>(on: bool, points: usize) -> Option<Vec<T>> {
            on.then(|| Vec::with_capacity(points))
        }
        SampleResponse {
            t,
            height: v(fields.height, points),
            normal: v(fields.normal, points),
            displacement: v(fields.displacement, points),
            jacobian: v(fields.jacobian, points),
            folded: v(fields.jacobian, points),
            residual: v(fields.residual, points),
        }
    }

    /// Numbers in the answer (a bool counts as one).
    pub fn numbers(&self) -> usize {
        self.height.as_ref().map_or(0, Vec::len)
            + 3 * self.normal.as_ref().map_or(0, Vec::len)
            + 3 * self.displacement.as_ref().map_or(0, Vec::len)
            + self.jacobian.as_ref().map_or(0, Vec::len)
            + self.folded.as_ref().map_or(0, Vec::len)
            + self.residual.as_ref().map_or(0, Vec::len)
    }

    /// A seeded answer for encoder tests: `n` points, the arrays whose bit is set in `mask` (1
    /// height, 2 normal, 4 displacement, 8 jacobian and folded, 16 residual), numbers drawn from
    /// integers, tiny and large magnitudes and arbitrary finite bit patterns.
    #[cfg(test)]
    pub fn seeded(rng: &mut swell_waves::math::SwellRng, n: usize, mask: u32) -> SampleResponse {
        let mut f = || -> f64 {
            let u = rng.uniform() * 2.0 - 1.0;
            match rng.next_u32() % 4 {
                0 => (u * 3.0).round(),
                1 => u * 1e-300,
                2 => u * 1e6,
                _ => f64::from_bits(rng.next_u64() >> 2) * u.signum(),
            }
        };
        let t = f();
        let mut v = |on: bool, k: usize| on.then(|| (0..n * k).map(|_| f()).collect::<Vec<_>>());
        let triples = |v: Option<Vec<f64>>| {
            v.map(|v| v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        };
        SampleResponse {
            t,
            height: v(mask & 1 != 0, 1),
            normal: triples(v(mask & 2 != 0, 3)),
            displacement: triples(v(mask & 4 != 0, 3)),
            jacobian: v(mask & 8 != 0, 1),
            folded: (mask & 8 != 0).then(|| (0..n).map(|i| i % 3 == 0).collect()),
            residual: v(mask & 16 != 0, 1),
        }
    }

    /// Appends `results`, in order, to each array the answer has.
    pub fn extend(&mut self, results: &[swell_waves::PointResult]) {
        if let Some(v) = &mut self.height {
            v.extend(results.iter().map(|r| r.height));
        }
        if let Some(v) = &mut self.normal {
            v.extend(results.iter().map(|r| r.normal.to_array()));
        }
        if let Some(v) = &mut self.displacement {
            v.extend(results.iter().map(|r| r.displacement.to_array()));
        }
        if let Some(v) = &mut self.jacobian {
            v.extend(results.iter().map(|r| r.jacobian));
        }
        if let Some(v) = &mut self.folded {
            v.extend(results.iter().map(|r| r.folded));
        }
        if let Some(v) = &mut self.residual {
            v.extend(results.iter().map(|r| r.residual));
        }
    }
}

/// `POST /v1/scenes/{id}/orientation` body.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrientationRequest {
    /// Scene time, s; absent means the clock's now.
    #[serde(default)]
    pub t: Option<f64>,
    /// The bodies.
    pub bodies: Vec<Body>,
}

/// A body's footprint on the wire (mirrors `swell_waves::body::BodyFootprint`, with unknown
/// fields rejected).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Body {
    /// World `[x, z]` of the body origin, m.
    pub position: [f64; 2],
    /// Yaw, rad (rotation about +y; positive turns the bow from +x towards −z), within
    /// ±[`swell_waves::body::MAX_YAW`] (10⁹ rad).
    #[serde(default)]
    pub yaw: f64,
    /// Length, m, in (0, 10 km] ([`swell_waves::body::MAX_FOOTPRINT`]).
    pub length: f64,
    /// Beam, m, in (0, 10 km].
    pub beam: f64,
    /// Explicit probes `[u, v]` in the body frame, m, each within ±10 km; default a 3×3 grid
    /// over the footprint.
    #[serde(default)]
    pub probes: Option<Vec<[f64; 2]>>,
}

impl From<Body> for swell_waves::body::BodyFootprint {
    fn from(b: Body) -> Self {
        swell_waves::body::BodyFootprint {
            position: b.position,
            yaw: b.yaw,
            length: b.length,
            beam: b.beam,
            probes: b.probes,
        }
    }
}

/// `POST /v1/scenes/{id}/orientation` answer.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct OrientationResponse {
    /// The scene time used, s.
    pub t: f64,
    /// One per body, in order.
    pub bodies: Vec<BodyOrientation>,
}

/// A body's orientation.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct BodyOrientation {
    /// Height of the fitted plane at the body origin, m.
    pub heave: f64,
    /// World rotation quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
    /// World unit normal `[x, y, z]`.
    pub normal: [f64; 3],
    /// Pitch, rad (bow up positive).
    pub pitch: f64,
    /// Roll, rad.
    pub roll: f64,
}

/// A floating body's state in a tick frame (server-authoritative simulation). Mirrors
/// `swell.v1.BodyState`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct BodyState {
    /// Body id (unique within the scene).
    pub id: u64,
    /// World position of the body origin (the hull's centre) `[x, y, z]`, m.
    pub position: [f64; 3],
    /// World rotation quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
    /// Linear velocity, m/s.
    pub velocity: [f64; 3],
    /// Angular velocity (world frame), rad/s.
    pub angular_velocity: [f64; 3],
    /// Submerged fraction of the hull volume during the last step, 0..1 (0 until the body's
    /// first step after a spawn, a restore or a clock jump).
    pub submerged: f64,
    /// The last step went non-finite and was rolled back: the state is the last good one.
    #[serde(default)]
    pub quarantined: bool,
}

/// A floating body as `GET /v1/scenes/{id}/bodies` and `GET …/bodies/{bid}` describe it: its
/// state (the fields of [`BodyState`], flattened) and what does not change after the spawn, its
/// mass and hull, so a client can draw it at its size. Tick frames carry states only (their
/// size per body stays what it was); a client fetches this once per new body id.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct BodyDescription {
    /// The body's current state.
    #[serde(flatten)]
    pub state: BodyState,
    /// Mass, kg.
    pub mass: f64,
    /// The hull's kind and extent.
    pub hull: HullExtent,
    /// Scene tick the body was spawned at (its spawn request then applied at rest). Absent for
    /// a body restored from a record written before spawn ticks were kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spawn_tick: Option<i64>,
    /// Present when the body came into the scene's current body world from an earlier one (a
    /// re-anchor after a clock jump): it starts at the world's `anchor_tick` from this, not from
    /// its spawn.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub carried: Option<CarriedBody>,
}

/// A body as a re-anchor carried it into the scene's current body world: what a client starts
/// its own world from at `anchor_tick` to follow the server's bits (spawn the body there, put
/// it at `state`, queue `inputs`, then the inputs accepted since).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CarriedBody {
    /// Its state at the anchor tick (`submerged` 0 and warm starts cold, as the new world
    /// starts it).
    pub state: BodyState,
    /// Its inputs still running at the re-anchor, as the new world holds them: each acts from
    /// the anchor tick for the ticks it had left.
    pub inputs: Vec<InputSpan>,
}

/// A body input as the world holds it: a force and torque in the body frame from a scene tick
/// for a number of ticks.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct InputSpan {
    /// Force `[x, y, z]` in the body frame, N.
    pub force: [f64; 3],
    /// Torque `[x, y, z]` in the body frame, N·m.
    pub torque: [f64; 3],
    /// First scene tick it acts on.
    pub from_tick: i64,
    /// Number of ticks it acts for.
    pub ticks: u64,
}

/// An API impact a scene's body world feels, with the scene tick it reached the world at: what
/// a client replaying the bodies feels it at (`swell_world_feel_impact`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct FeltImpact {
    /// Scene tick the body world feels it from; absent for one restored from a record written
    /// before the ticks were kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body_tick: Option<i64>,
    /// Scene time of the impact, s.
    pub t: f64,
    /// World `[x, z]`, m.
    pub position: [f64; 2],
    /// Splash height at the impact point, m.
    pub strength: f64,
    /// Particle radius of the ring, m.
    pub radius: f64,
}

/// `POST /v1/scenes/{id}/bodies` answer (201): the new body's state and the ticks a client
/// needs to mirror it in its own world.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SpawnedBody {
    /// The body's state right after the spawn (at rest).
    #[serde(flatten)]
    pub state: BodyState,
    /// Scene tick the spawn applied at (the states' tick).
    pub spawn_tick: i64,
    /// Scene tick the body world is anchored at (world tick 0).
    pub anchor_tick: i64,
}

/// `POST /v1/scenes/{id}/bodies/{bid}/input` answer (202).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct InputAccepted {
    /// On one process: the tick the bodies were at when it was accepted; in a fleet: the tick
    /// it applies at.
    pub tick: i64,
    /// First scene tick it acts on (`from_tick` as asked, or the tick it applies at when that
    /// was not given or is already past in a fleet).
    pub from_tick: i64,
    /// Number of ticks it acts for.
    pub ticks: u64,
    /// Scene tick the body world was anchored at when it was accepted (one process only: a
    /// fleet answers before its replicas apply it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anchor_tick: Option<i64>,
}

/// A hull's kind and the box that bounds it in the body frame (x along the length, y up, z
/// along the beam), m.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct HullExtent {
    /// `box` or `cells`, as spawned.
    pub kind: HullKind,
    /// Extent along x, m: a box hull's length; for cells, the bounding box of the cells' columns
    /// (each a square of side `sqrt(volume/height)` around its position).
    pub length: f64,
    /// Extent along z, m (a box hull's beam).
    pub beam: f64,
    /// Extent along y, m (a box hull's height).
    pub height: f64,
    /// Centre of that box in the body frame `[x, y, z]`, m (a box hull: the origin).
    pub center: [f64; 3],
}

/// The hull kinds of a spawn request.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum HullKind {
    /// `{"kind": "box", ...}`.
    Box,
    /// `{"kind": "cells", ...}`.
    Cells,
}

impl From<&swell_waves::body::HullSpec> for HullExtent {
    fn from(h: &swell_waves::body::HullSpec) -> Self {
        use swell_waves::body::HullSpec;
        match h {
            HullSpec::Box {
                length,
                beam,
                height,
                ..
            } => HullExtent {
                kind: HullKind::Box,
                length: *length,
                beam: *beam,
                height: *height,
                center: [0.0; 3],
            },
            HullSpec::Cells { cells } => {
                let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for c in cells {
                    let side = (c.volume / c.height).sqrt();
                    let half = [0.5 * side, 0.5 * c.height, 0.5 * side];
                    for a in 0..3 {
                        lo[a] = lo[a].min(c.position[a] - half[a]);
                        hi[a] = hi[a].max(c.position[a] + half[a]);
                    }
                }
                if cells.is_empty() {
                    (lo, hi) = ([0.0; 3], [0.0; 3]);
                }
                HullExtent {
                    kind: HullKind::Cells,
                    length: hi[0] - lo[0],
                    beam: hi[2] - lo[2],
                    height: hi[1] - lo[1],
                    center: std::array::from_fn(|a| 0.5 * (lo[a] + hi[a])),
                }
            }
        }
    }
}

/// A tick frame of the WebSocket stream: the scene's tick number, its time, and the body states
/// at that tick (empty when the scene has no floating bodies, or none the subscriber asked
/// for). Mirrors `swell.v1.Tick`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Tick {
    /// `floor(t·tick_hz)` of the scene clock.
    pub tick: i64,
    /// The tick's start time `tick / tick_hz`, s.
    pub t: f64,
    /// Body states at this tick.
    pub bodies: Vec<BodyState>,
    /// Impacts accepted since the previous frame ([`crate::impacts`]); omitted when none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub impacts: Vec<crate::impacts::ImpactEvent>,
    /// Scene tick the scene's body world is anchored at when these states were published
    /// (world tick 0); omitted while the scene has no bodies. A change means a clock jump
    /// re-anchored the world: a client replaying bodies rebuilds from `GET …/bodies`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anchor_tick: Option<i64>,
}
