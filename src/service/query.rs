//! Queries: height, sample, orientation, with no transport in sight.
//!
//! The `run_*` functions are plain, blocking and transport-free: they take a scene, a resolved
//! time and a decoded request and return the response type, so the HTTP handlers
//! ([`crate::api::query`]) and the WebSocket session ([`crate::stream`]) share them. A caller
//! resolves the scene and its time ([`resolve_time`]), then runs the query through
//! [`run_query`]: inline on the reactor when it is cheap (a few points whose FFT frames, if any,
//! are already cached, [`runs_inline`]), else on the compute pool ([`crate::compute`]: a frame to
//! compute and big batches are CPU work). Answers are checked for non-finite numbers where they are encoded
//! ([`crate::service::finite`]), not here.

use glam::DVec2;
use swell_waves::body::MAX_YAW;
use swell_waves::{Inversion, QueryFields, QueryOptions};

use crate::config::Limits;
use crate::frames::FrameCache;
use crate::scene::{Scene, SceneEntry};
use crate::service::error::QueryError;
use crate::service::types::{
    Accuracy, BodyOrientation, HeightResponse, OrientationRequest, OrientationResponse,
    SampleRequest, SampleResponse,
};
use crate::state::AppState;

/// Points per worker thread before a batch is split: below this, threads cost more than they
/// save. Splitting never changes the bits (each point is computed alone).
const POINTS_PER_THREAD: usize = 8192;

/// Checks a time given by a client.
///
/// # Errors
/// [`QueryError::Time`] naming `field` if `t` is not finite or beyond `limits.max_time`.
pub fn check_time(limits: &Limits, t: f64, field: &str) -> Result<f64, QueryError> {
    Ok(limits.check_time(t, field)?)
}

/// Checks a coordinate given by a client: finite and within `limits.max_coordinate`.
///
/// # Errors
/// [`QueryError::Coordinate`] naming the field `field()` returns.
pub(crate) fn check_coord(
    limits: &Limits,
    v: f64,
    field: impl Fn() -> String,
) -> Result<f64, QueryError> {
    if v.is_finite() && v.abs() <= limits.max_coordinate {
        Ok(v)
    } else {
        Err(QueryError::Coordinate {
            field: field(),
            value: v,
            max: limits.max_coordinate,
        })
    }
}

/// When a query runs: its time and the scene clock's now (which decides the frames the cache
/// keeps near, see [`crate::frames`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct At {
    /// The query's time, s: the client's `t`, or now.
    pub t: f64,
    /// The scene clock's time when the query arrived, s.
    pub now: f64,
}

/// The time a query runs at: the client's `t` (checked) or the scene clock's now.
///
/// # Errors
/// As [`check_time`].
pub fn resolve_time(
    state: &AppState,
    entry: &SceneEntry,
    t: Option<f64>,
) -> Result<At, QueryError> {
    let now = state.read_clock(entry).t;
    match t {
        Some(t) => Ok(At {
            t: check_time(&state.limits, t, "t")?,
            now,
        }),
        None => Ok(At { t: now, now }),
    }
}

/// Parses `fields` names into [`QueryFields`]. Absent or empty: height (an empty protobuf
/// list cannot be told from an absent one, so a JSON `[]` means the same).
///
/// # Errors
/// [`QueryError::UnknownField`] naming the first unknown name.
pub fn parse_fields(names: Option<&[String]>) -> Result<QueryFields, QueryError> {
    let Some(names) = names.filter(|n| !n.is_empty()) else {
        return Ok(QueryFields::HEIGHT);
    };
    let mut f = QueryFields::default();
    for (i, n) in names.iter().enumerate() {
        match n.as_str() {
            "height" => f.height = true,
            "normal" => f.normal = true,
            "displacement" => f.displacement = true,
            "jacobian" => f.jacobian = true,
            "residual" => f.residual = true,
            other => {
                return Err(QueryError::UnknownField {
                    index: i,
                    name: other.to_owned(),
                });
            }
        }
    }
    Ok(f)
}

/// Query options from the wire's accuracy settings (defaults for whatever is absent).
///
/// # Errors
/// [`QueryError::Rejected`] naming `accuracy.iterations` or `accuracy.tolerance` (the model's
/// check).
pub fn query_options(acc: Option<&Accuracy>) -> Result<QueryOptions, QueryError> {
    let mut o = QueryOptions::default();
    if let Some(a) = acc {
        let d = Inversion::default();
        o.inversion = Inversion {
            method: a.method.unwrap_or(d.method),
            iterations: a.iterations.unwrap_or(d.iterations),
            tolerance: a.tolerance.unwrap_or(d.tolerance),
        };
        if let Some(f) = a.filter {
            o.filter = f.into();
        }
        if let Some(p) = a.precision {
            o.precision = p.into();
        }
        if let Some(t) = a.time {
            o.time = t;
        }
    }
    o.validate()?;
    Ok(o)
}

/// Points evaluated between two checks of a sample's deadline: ~1–10 ms of work on one core
/// without impacts; a block bounds how far past its deadline a batch can run.
pub const DEADLINE_BLOCK: usize = 8192;

/// Answers a sample request at `at` (already resolved and checked). Blocking unless
/// [`runs_inline`] said otherwise.
///
/// World point = `origin + point`, added in f64 (and not at all when there is no origin).
///
/// # Errors
/// [`QueryError::TooManyPoints`]; [`QueryError::UnknownField`], [`QueryError::Rejected`] (bad
/// accuracy) or [`QueryError::Coordinate`] (a non-finite or out-of-range coordinate);
/// [`QueryError::Timeout`] when the work runs past `request_timeout_ms` (checked every
/// [`DEADLINE_BLOCK`] points).
pub fn run_sample(
    frames: &FrameCache,
    limits: &Limits,
    scene: &Scene,
    At { t, now }: At,
    req: &SampleRequest,
) -> Result<SampleResponse, QueryError> {
    if req.points.len() > limits.max_points {
        return Err(QueryError::TooManyPoints {
            field: "points",
            n: req.points.len(),
            max: limits.max_points,
        });
    }
    let fields = parse_fields(req.fields.as_deref())?;
    let options = query_options(req.accuracy.as_ref())?;
    let origin = match req.origin {
        Some([x, z]) => Some(DVec2::new(
            check_coord(limits, x, || "origin[0]".into())?,
            check_coord(limits, z, || "origin[1]".into())?,
        )),
        None => None,
    };
    let mut world = Vec::with_capacity(req.points.len());
    for (i, &[x, z]) in req.points.iter().enumerate() {
        let p = DVec2::new(
            check_coord(limits, x, || format!("points[{i}][0]"))?,
            check_coord(limits, z, || format!("points[{i}][1]"))?,
        );
        let w = match origin {
            Some(o) => DVec2::new(o.x + p.x, o.y + p.y),
            None => p,
        };
        // The sum of two in-range values can still leave the range.
        check_coord(limits, w.x, || format!("origin[0] + points[{i}][0]"))?;
        check_coord(limits, w.y, || format!("origin[1] + points[{i}][1]"))?;
        world.push(w);
    }
    // An empty batch has an empty answer: no FFT frame is worth computing for it.
    let sea = if world.is_empty() {
        None
    } else {
        Some(frames.surface_at(scene, t, now, fields, &options)?)
    };
    let threads = (world.len() / POINTS_PER_THREAD).clamp(
        1,
        std::thread::available_parallelism().map_or(1, |n| n.get()),
    );
    // In blocks, with the request's deadline checked between them: a batch that runs past
    // `request_timeout_ms` (the HTTP answer is a 503 by then) stops instead of running on.
    let deadline = std::time::Instant::now() + limits.request_timeout();
    let mut out = SampleResponse::with_fields(t, fields, world.len());
    if let Some(sea) = sea {
        for block in world.chunks(DEADLINE_BLOCK) {
            if std::time::Instant::now() > deadline {
                metrics::counter!("swell_queries_abandoned_total").increment(1);
                return Err(QueryError::Timeout {
                    ms: limits.request_timeout_ms,
                });
            }
            // Only a block's results are held at once: the answer's arrays take 8 B a value,
            // a `PointResult` ~90 B whatever was asked.
            out.extend(&sea.query_batch_parallel(block, fields, threads));
        }
    }
    metrics::counter!("swell_points_sampled_total").increment(world.len() as u64);
    Ok(out)
}

/// The bytes a sample of `points` points asking `fields` holds while it is answered, for the
/// byte budget ([`crate::Limits::max_buffered_bytes`]): its world points (16 B each) and the
/// answer's arrays (8 B a number), plus `encoded_per_number` bytes a number when the answer is
/// encoded whole ([`crate::service::types::JSON_NUMBER_BYTES`] or
/// [`crate::service::types::PROTOBUF_NUMBER_BYTES`]; 0 when it is encoded as
/// it is sent). An estimate from above for the answer, ± a block of results.
pub fn sample_bytes(points: usize, fields: QueryFields, encoded_per_number: usize) -> usize {
    points.saturating_mul(16 + numbers_per_point(fields) * (8 + encoded_per_number))
}

/// Numbers a sample answer has per point for `fields` (`folded` counts as one).
pub fn numbers_per_point(fields: QueryFields) -> usize {
    usize::from(fields.height)
        + 3 * usize::from(fields.normal)
        + 3 * usize::from(fields.displacement)
        + 2 * usize::from(fields.jacobian) // and `folded`
        + usize::from(fields.residual)
}

/// Numbers a sample request's answer will have (0 for fields that do not parse: such a request
/// is refused before it costs anything).
pub fn sample_request_numbers(req: &SampleRequest) -> usize {
    parse_fields(req.fields.as_deref())
        .map_or(0, |f| req.points.len().saturating_mul(numbers_per_point(f)))
}

/// [`sample_bytes`] for a request (its fields as asked; a request whose fields do not parse is
/// refused before it costs anything: 0).
pub fn sample_request_bytes(req: &SampleRequest, encoded_per_number: usize) -> usize {
    parse_fields(req.fields.as_deref())
        .map_or(0, |f| sample_bytes(req.points.len(), f, encoded_per_number))
}

/// The bytes an orientation request holds while it is answered, for the byte budget: its
/// probes (16 B each) and, per body, the answer (12 numbers) encoded whole.
pub fn orientation_request_bytes(req: &OrientationRequest, encoded_per_number: usize) -> usize {
    orientation_probes(req).saturating_mul(16).saturating_add(
        req.bodies
            .len()
            .saturating_mul(12 * (8 + encoded_per_number)),
    )
}

/// Height at one world point, with the default accuracy. Blocking unless [`runs_inline`] said
/// otherwise. Bit-identical to the same point in [`run_sample`] with default accuracy.
///
/// # Errors
/// [`QueryError::Coordinate`] for a non-finite or out-of-range coordinate.
pub fn run_height(
    frames: &FrameCache,
    limits: &Limits,
    scene: &Scene,
    At { t, now }: At,
    x: f64,
    z: f64,
) -> Result<HeightResponse, QueryError> {
    let x = check_coord(limits, x, || "x".into())?;
    let z = check_coord(limits, z, || "z".into())?;
    let sea = frames.surface_at(scene, t, now, QueryFields::HEIGHT, &QueryOptions::default())?;
    let r = sea.query(DVec2::new(x, z), QueryFields::HEIGHT);
    metrics::counter!("swell_points_sampled_total").increment(1);
    Ok(HeightResponse {
        t,
        height: r.height,
    })
}

/// Orientation of every body at `at`. Blocking unless [`runs_inline`] said otherwise.
///
/// # Errors
/// [`QueryError::TooManyBodies`], or [`QueryError::TooManyPoints`] for too many probes in total;
/// [`QueryError::Coordinate`], [`QueryError::Yaw`] or [`QueryError::Rejected`] naming
/// `bodies[i].…` for a bad body.
pub fn run_orientation(
    frames: &FrameCache,
    limits: &Limits,
    scene: &Scene,
    At { t, now }: At,
    req: &OrientationRequest,
) -> Result<OrientationResponse, QueryError> {
    if req.bodies.len() > limits.max_bodies {
        return Err(QueryError::TooManyBodies {
            n: req.bodies.len(),
            max: limits.max_bodies,
        });
    }
    // The default footprint has 9 probes.
    let probes: usize = req
        .bodies
        .iter()
        .map(|b| b.probes.as_ref().map_or(9, Vec::len))
        .sum();
    if probes > limits.max_points {
        return Err(QueryError::TooManyPoints {
            field: "bodies",
            n: probes,
            max: limits.max_points,
        });
    }
    let mut bodies = Vec::with_capacity(req.bodies.len());
    for (i, b) in req.bodies.iter().enumerate() {
        check_coord(limits, b.position[0], || format!("bodies[{i}].position[0]"))?;
        check_coord(limits, b.position[1], || format!("bodies[{i}].position[1]"))?;
        if !(b.yaw.is_finite() && b.yaw.abs() <= MAX_YAW) {
            return Err(QueryError::Yaw {
                field: format!("bodies[{i}].yaw"),
                value: b.yaw,
            });
        }
        let fp: swell_waves::body::BodyFootprint = b.clone().into();
        // Validate the footprint now, so no sea is computed for a bad request.
        fp.probes(&format!("bodies[{i}]"))?;
        bodies.push(fp);
    }
    let sea = frames.surface_at(scene, t, now, QueryFields::HEIGHT, &QueryOptions::default())?;
    let mut out = Vec::with_capacity(bodies.len());
    for (i, fp) in bodies.iter().enumerate() {
        let o = fp.orientation(&sea, &format!("bodies[{i}]"))?;
        out.push(BodyOrientation {
            heave: o.heave,
            rotation: o.rotation.to_array(),
            normal: o.normal.to_array(),
            pitch: o.pitch,
            roll: o.roll,
        });
    }
    metrics::counter!("swell_points_sampled_total").increment(probes as u64);
    Ok(OrientationResponse { t, bodies: out })
}

/// Points (sample points, or orientation probes) a query may have and still run on the reactor
/// thread. 64 Gerstner points with height inversion take ~35 µs here (0.56 µs a point on
/// `lake`), about what the hop to the compute pool and back costs in latency and context
/// switches on a loaded 2-core machine; past that, a query could hold a reactor thread long
/// enough to delay other connections, so it moves to the pool.
pub const INLINE_POINTS: usize = 64;

/// Whether a query of `points` points asking `fields` with `options` at `at.t` is cheap enough
/// to answer on the reactor: few points, and every FFT frame it reads already in the cache (a
/// frame to compute takes milliseconds; at the scene's now the frame-ahead loop has them ready).
/// A frame could in principle be evicted between this check and its use (far frames only);
/// then that one query computes it where it runs.
pub fn runs_inline(
    frames: &FrameCache,
    scene: &Scene,
    at: At,
    points: usize,
    fields: QueryFields,
    options: &QueryOptions,
) -> bool {
    points <= INLINE_POINTS && frames.has_frames(scene, at.t, fields, options)
}

/// [`runs_inline`] for a sample request: its fields and accuracy (a request whose fields or
/// accuracy do not parse runs inline: it answers with an error at once).
pub fn sample_runs_inline(frames: &FrameCache, scene: &Scene, at: At, req: &SampleRequest) -> bool {
    match (
        parse_fields(req.fields.as_deref()),
        query_options(req.accuracy.as_ref()),
    ) {
        (Ok(fields), Ok(options)) => {
            runs_inline(frames, scene, at, req.points.len(), fields, &options)
        }
        _ => true,
    }
}

/// Runs query work: at once when it is cheap (`inline`), else on the compute pool
/// ([`crate::compute`]), off the reactor and below its priority. The work's error is the caller's choice (a [`QueryError`] or anything a
/// [`QueryError`] converts into).
///
/// # Errors
/// The work's error; [`QueryError::Task`] (converted) when the work panicked.
pub async fn run_query<T: Send + 'static, E: From<QueryError> + Send + 'static>(
    inline: bool,
    f: impl FnOnce() -> Result<T, E> + Send + 'static,
) -> Result<T, E> {
    if inline {
        return f();
    }
    crate::compute::run(f)
        .await
        .map_err(|e| E::from(QueryError::Task(e.to_string())))?
}

/// Probes an orientation request samples: each body's explicit probes, or the default 3×3.
pub fn orientation_probes(req: &OrientationRequest) -> usize {
    req.bodies
        .iter()
        .map(|b| b.probes.as_ref().map_or(9, Vec::len))
        .fold(0usize, usize::saturating_add)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Work that is not cheap runs on the compute pool's threads (below the reactor's
    /// priority), cheap work where it is called.
    #[tokio::test]
    async fn work_off_the_reactor_runs_on_the_compute_pool() {
        let name = || std::thread::current().name().unwrap_or_default().to_owned();
        let off = run_query::<_, QueryError>(false, move || Ok(name()))
            .await
            .unwrap();
        assert!(off.starts_with("swell-compute-"), "{off}");
        let here = name();
        let inline = run_query::<_, QueryError>(true, move || Ok(name()))
            .await
            .unwrap();
        assert_eq!(inline, here);
        // A panic is an error for its request, not a crash.
        let e = run_query::<(), QueryError>(false, || panic!("boom"))
            .await
            .unwrap_err();
        assert!(matches!(e, QueryError::Task(_)), "{e:?}");
    }

    use crate::scene::builtin::built as builtin;

    #[test]
    fn small_queries_run_inline_unless_they_need_a_frame_computed() {
        let (lake, calm, storm) = (builtin("lake"), builtin("calm"), builtin("storm"));
        let frames = FrameCache::new(4);
        let at = At { t: 12.3, now: 12.3 };
        let (h, o) = (QueryFields::HEIGHT, QueryOptions::default());
        assert!(runs_inline(&frames, &lake, at, 1, h, &o));
        assert!(runs_inline(&frames, &calm, at, INLINE_POINTS, h, &o));
        assert!(!runs_inline(&frames, &calm, at, INLINE_POINTS + 1, h, &o));
        // An FFT scene whose frames are not computed yet: the compute pool.
        assert!(!runs_inline(&frames, &storm, at, 1, h, &o));
        // Once they are (the frame-ahead loop's job at now), on the reactor.
        frames.surface_at(&storm, at.t, at.now, h, &o).unwrap();
        assert!(runs_inline(&frames, &storm, at, 1, h, &o));
        // Normals need slopes the cached frames lack.
        let n = QueryFields { normal: true, ..h };
        assert!(!runs_inline(&frames, &storm, at, 1, n, &o));
        let req: OrientationRequest = serde_json::from_value(serde_json::json!({
            "bodies": [{"position": [0, 0], "length": 5, "beam": 2},
                       {"position": [0, 0], "length": 5, "beam": 2, "probes": [[0, 0], [1, 0]]}]
        }))
        .unwrap();
        assert_eq!(orientation_probes(&req), 11);
    }
}
