//! What the fuzz targets share: the built-in scenes (built once per process), small limits, and
//! the checks every accepted input must pass.
//!
//! A target decodes its input with the server's own parser, then runs the request the way the
//! HTTP handler or WebSocket session would ([`swell::service::query`]'s `run_*` functions, after the
//! same time check the handler does). The properties:
//!
//! - nothing panics (libFuzzer reports a panic as a crash);
//! - a rejected request is a client error (4xx): a 5xx means the server failed on its own;
//! - an accepted request's answer has only finite numbers, checked twice: by an independent walk
//!   of its JSON form (serde_json writes NaN and ±inf as `null`, and no answer field is
//!   legitimately null) and by the server's own [`swell::service::finite::ensure_finite`].

use std::sync::OnceLock;

use serde_json::Value;
use swell::Limits;
use swell::error::ApiError;
use swell::frames::FrameCache;
use swell::scene::Scene;
use swell::service::query::{At, check_time, run_orientation, run_sample};
use swell::service::types::{
    OrientationRequest, OrientationResponse, SampleRequest, SampleResponse,
};

/// The scene clock's now, fixed: a request without `t` runs at it, as the server's would at the
/// clock's reading. Every query gets this `now` (which frames the cache counts as near) whatever
/// its `t`, as in the server, where clients choose `t` but never `now`; giving each query
/// `now = t` instead made every frame "near" and the cache grow to gigabytes within its
/// 5 s idle window, which no client can do to the server.
pub const DEFAULT_T: f64 = 60.0;

/// Largest FFT grid a fuzzed scene spec may ask for before it is skipped: building and querying
/// a 1024² layer per input would take the fuzzer's whole budget; 64² exercises the same code.
pub const MAX_FUZZ_FFT_RESOLUTION: u32 = 64;

/// The shared state of one fuzzing process.
pub struct Fixture {
    /// Every built-in scene, built.
    pub scenes: Vec<Scene>,
    /// The frame cache the queries share (as the server's is shared by every request).
    pub frames: FrameCache,
    /// The server's default limits, except `max_points` and `max_bodies`, kept small so an
    /// iteration stays fast (the limit checks themselves are exercised all the same).
    pub limits: Limits,
}

/// The process's [`Fixture`], built on first use.
pub fn fixture() -> &'static Fixture {
    static FIXTURE: OnceLock<Fixture> = OnceLock::new();
    FIXTURE.get_or_init(|| Fixture {
        scenes: swell::scene::builtin::specs()
            .into_iter()
            .map(|(id, spec)| Scene::build(&id, spec).expect("built-in scenes build"))
            .collect(),
        frames: FrameCache::new(8),
        limits: Limits {
            max_points: 256,
            max_bodies: 16,
            ..Limits::default()
        },
    })
}

/// A request's time as the handlers resolve it: the client's `t` through the same check, or the
/// scene clock's now ([`DEFAULT_T`]).
///
/// # Errors
/// As [`check_time`].
pub fn resolve(limits: &Limits, t: Option<f64>) -> Result<At, ApiError> {
    let t = match t {
        Some(t) => check_time(limits, t, "t")?,
        None => DEFAULT_T,
    };
    Ok(At { t, now: DEFAULT_T })
}

/// Runs a sample request on every built-in scene and checks the properties.
pub fn check_sample(req: &SampleRequest) {
    let f = fixture();
    let at = match resolve(&f.limits, req.t) {
        Ok(at) => at,
        Err(e) => return assert_client_error(&e),
    };
    for scene in &f.scenes {
        match run_sample(&f.frames, &f.limits, scene, at, req) {
            Ok(r) => {
                assert_eq!(r.t.to_bits(), at.t.to_bits(), "{}: answer's t", scene.id);
                assert_answer_lengths(&r, req.points.len());
                assert_finite(&r, &scene.id, req);
            }
            Err(e) => assert_client_error(&e),
        }
    }
}

/// Runs an orientation request on every built-in scene and checks the properties.
pub fn check_orientation(req: &OrientationRequest) {
    let f = fixture();
    let at = match resolve(&f.limits, req.t) {
        Ok(at) => at,
        Err(e) => return assert_client_error(&e),
    };
    for scene in &f.scenes {
        match run_orientation(&f.frames, &f.limits, scene, at, req) {
            Ok(r) => {
                assert_orientation(&r, req, &scene.id);
            }
            Err(e) => assert_client_error(&e),
        }
    }
}

fn assert_orientation(r: &OrientationResponse, req: &OrientationRequest, scene: &str) {
    assert_eq!(
        r.bodies.len(),
        req.bodies.len(),
        "{scene}: one answer a body"
    );
    assert_finite(r, scene, req);
}

fn assert_answer_lengths(r: &SampleResponse, n: usize) {
    let lens = [
        r.height.as_ref().map(Vec::len),
        r.normal.as_ref().map(Vec::len),
        r.displacement.as_ref().map(Vec::len),
        r.jacobian.as_ref().map(Vec::len),
        r.folded.as_ref().map(Vec::len),
        r.residual.as_ref().map(Vec::len),
    ];
    for l in lens.into_iter().flatten() {
        assert_eq!(l, n, "one answer a point");
    }
}

/// Panics unless `e` is a client error (4xx) as the server would answer it (any lower layer's
/// error, e.g. a `QueryError`, through the server's one mapping into an [`ApiError`]): the
/// server blaming itself for a request means a number went non-finite or an invariant broke.
pub fn assert_client_error<E: Clone + Into<ApiError>>(e: &E) {
    let e: ApiError = e.clone().into();
    assert!(
        e.status().is_client_error(),
        "a request was answered {} {}: {} (field {:?})",
        e.status(),
        e.code,
        e.message,
        e.field
    );
}

/// Panics, naming the request, if any number in `answer` is NaN or infinite.
pub fn assert_finite<T: serde::Serialize, R: std::fmt::Debug + ?Sized>(
    answer: &T,
    scene: &str,
    req: &R,
) {
    let v = serde_json::to_value(answer).expect("answers serialise");
    if let Some(path) = first_non_finite(&v, String::new()) {
        panic!("{scene}: non-finite answer at {path} for {req:?}");
    }
    if let Err(nf) = swell::service::finite::ensure_finite(answer) {
        panic!("{scene}: the server's check found {nf} for {req:?}");
    }
}

/// The path of the first `null` or non-finite number in `v` (serde_json turns NaN and ±inf
/// into `null`; no answer field is null otherwise).
fn first_non_finite(v: &Value, path: String) -> Option<String> {
    match v {
        Value::Null => Some(path),
        Value::Number(n) => (!n.as_f64().is_some_and(f64::is_finite)).then_some(path),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, x)| first_non_finite(x, format!("{path}[{i}]"))),
        Value::Object(m) => m
            .iter()
            .find_map(|(k, x)| first_non_finite(x, format!("{path}.{k}"))),
        Value::Bool(_) | Value::String(_) => None,
    }
}

/// Whether every FFT layer of `spec` is at most [`MAX_FUZZ_FFT_RESOLUTION`] per side.
pub fn small_enough(spec: &swell::scene::SceneSpec) -> bool {
    spec.surface.layers.iter().all(|l| match l {
        swell_waves::LayerSpec::Fft(f) => f.resolution <= MAX_FUZZ_FFT_RESOLUTION,
        _ => true,
    })
}

/// Builds `spec` (if its FFT grids are small enough) and checks that heights at a few times and
/// points are finite, through the server's frame cache and `run_height`.
pub fn check_spec(id: &str, spec: swell::scene::SceneSpec) {
    if !small_enough(&spec) {
        return;
    }
    let scene = match Scene::build(id, spec) {
        Ok(s) => s,
        Err(e) => return assert_client_error(&swell::error::ApiError::from(e)),
    };
    // A cache of its own: this scene is used once, and its frames must not evict the built-ins'.
    let frames = FrameCache::new(4);
    let limits = &fixture().limits;
    for t in [0.0, 12.345, -3.5e3, 1e6] {
        for (x, z) in [(0.0, 0.0), (17.25, -401.5), (-9.9e4, 3.3e5)] {
            match swell::service::query::run_height(
                &frames,
                limits,
                &scene,
                At { t, now: 0.0 },
                x,
                z,
            ) {
                Ok(h) => assert_finite(&h, id, &(t, x, z, &scene.spec)),
                Err(e) => assert_client_error(&e),
            }
        }
    }
}
