//! Surface handles: a scene built from its JSON spec, and the queries on it (height with
//! inversion, normal, displacement, Jacobian, residual; a body footprint's orientation), FFT
//! layers included.

use std::ffi::c_char;
use std::sync::{Arc, RwLock};

use glam::DVec2;
use swell_waves::body::{BodyFootprint, MAX_YAW};
use swell_waves::fft::SampleFilter;
use swell_waves::particles::{Impact, Impacts};
use swell_waves::{
    Inversion, InversionMethod, Precision, QueryFields, QueryOptions, SurfaceAt, TimeSampling,
};

use crate::error::{Error, SwellStatus, guard};
use crate::scene::Scene;

/// A built scene (opaque). Made by [`swell_surface_new`], freed by [`swell_surface_free`].
/// Queries on one surface may run on several threads at once; body worlds made from it keep
/// what they need, so it may be freed before them.
pub struct SwellSurface {
    pub(crate) scene: Arc<Scene>,
    /// The impacts whose ripples queries include ([`swell_surface_set_impacts`]).
    impacts: RwLock<Arc<Impacts>>,
}

// What the docs promise of the handles, checked by the compiler: a surface may be queried from
// several threads at once and a world moved between threads (a world's memo is a mutex, but
// stepping needs `&mut`, so one thread at a time).
const _: () = {
    const fn send_sync<T: Send + Sync>() {}
    const fn send<T: Send>() {}
    send_sync::<SwellSurface>();
    send::<crate::SwellWorld>();
};

/// Ask for the height at the world point (with inversion of the horizontal displacement).
pub const SWELL_FIELD_HEIGHT: u32 = 1;
/// Ask for the unit normal of the displaced surface at the world point.
pub const SWELL_FIELD_NORMAL: u32 = 2;
/// Ask for the displacement `(Dx, y, Dz)` of the world point taken as an undisplaced point.
pub const SWELL_FIELD_DISPLACEMENT: u32 = 4;
/// Ask for the Jacobian determinant and the fold flag.
pub const SWELL_FIELD_JACOBIAN: u32 = 8;
/// Ask for the inversion residual.
pub const SWELL_FIELD_RESIDUAL: u32 = 16;
/// Every field (what the golden vectors pin).
pub const SWELL_FIELD_ALL: u32 = 31;

/// Query settings, as the server's `accuracy` object. [`swell_query_options_default`] fills in
/// the server's defaults; pass null to a query to use them.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwellQueryOptions {
    /// Inversion method: 0 Newton (default), 1 fixed point.
    pub method: i32,
    /// Most inversion steps, 0..=64. Default 8.
    pub iterations: u32,
    /// Inversion tolerance, m (finite, >= 0). Default 1e-5.
    pub tolerance: f64,
    /// FFT grid filter: 0 bicubic (default), 1 bilinear, 2 nearest.
    pub filter: i32,
    /// Arithmetic: 0 f64 (default, the model's reference bits), 1 the f32 fast path.
    pub precision: i32,
    /// FFT time sampling: 0 grid (default, linear between grid frames), 1 exact.
    pub time: i32,
}

impl SwellQueryOptions {
    fn defaults() -> SwellQueryOptions {
        let d = Inversion::default();
        SwellQueryOptions {
            method: 0,
            iterations: d.iterations,
            tolerance: d.tolerance,
            filter: 0,
            precision: 0,
            time: 0,
        }
    }

    fn to_model(self) -> Result<QueryOptions, Error> {
        let pick = |name: &str, v: i32, n: i32| {
            if (0..n).contains(&v) {
                Ok(v)
            } else {
                Err(Error::invalid(format!(
                    "options.{name} = {v} is out of range: 0..={}",
                    n - 1
                )))
            }
        };
        let o = QueryOptions {
            inversion: Inversion {
                method: match pick("method", self.method, 2)? {
                    0 => InversionMethod::Newton,
                    _ => InversionMethod::FixedPoint,
                },
                iterations: self.iterations,
                tolerance: self.tolerance,
            },
            filter: match pick("filter", self.filter, 3)? {
                0 => SampleFilter::Bicubic,
                1 => SampleFilter::Bilinear,
                _ => SampleFilter::Nearest,
            },
            reference: false,
            precision: match pick("precision", self.precision, 2)? {
                0 => Precision::F64,
                _ => Precision::F32,
            },
            time: match pick("time", self.time, 2)? {
                0 => TimeSampling::Grid,
                _ => TimeSampling::Exact,
            },
        };
        o.validate()
            .map_err(|e| Error::invalid(format!("options: {e}")))?;
        Ok(o)
    }
}

/// The answers for one world point; fields not asked read 0 (the normal straight up, the
/// Jacobian 1).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SwellPoint {
    /// Elevation of the surface above the world point, m.
    pub height: f64,
    /// Unit normal `[x, y, z]` of the displaced surface there.
    pub normal: [f64; 3],
    /// `[Dx, y, Dz]` of the world point taken as undisplaced, m.
    pub displacement: [f64; 3],
    /// Jacobian determinant of the horizontal map at the source point.
    pub jacobian: f64,
    /// Inversion residual, m.
    pub residual: f64,
    /// 1 where the surface folds (`jacobian <= 0`), else 0.
    pub folded: i32,
}

/// A body's footprint for [`swell_surface_orientation`] (the server's `orientation` request).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwellFootprint {
    /// World `[x, z]` of the body origin, m.
    pub position: [f64; 2],
    /// Yaw, rad (about +y), within ±1e9.
    pub yaw: f64,
    /// Length, m, in (0, 10 km].
    pub length: f64,
    /// Beam, m, in (0, 10 km].
    pub beam: f64,
}

/// A footprint's orientation on the sea: the plane fitted through its probe heights.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SwellOrientation {
    /// Height of the fitted plane at the body origin, m.
    pub heave: f64,
    /// World rotation quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
    /// Unit normal of the plane.
    pub normal: [f64; 3],
    /// Pitch, rad (bow up positive).
    pub pitch: f64,
    /// Roll, rad.
    pub roll: f64,
}

/// The byte slice `(ptr, len)`; an empty slice for `len == 0`.
///
/// # Safety
/// `ptr` must point to `len` readable bytes (or `len` be 0).
pub(crate) unsafe fn bytes<'a>(
    ptr: *const c_char,
    len: usize,
    what: &str,
) -> Result<&'a [u8], Error> {
    if len == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(Error::null(what));
    }
    // SAFETY: non-null, and the caller promises `len` readable bytes that outlive the call.
    Ok(unsafe { std::slice::from_raw_parts(ptr.cast::<u8>(), len) })
}

/// `&*p`, or an error naming `what` when `p` is null.
///
/// # Safety
/// A non-null `p` must point to a live, properly aligned `T`.
pub(crate) unsafe fn get<'a, T>(p: *const T, what: &str) -> Result<&'a T, Error> {
    // SAFETY: the caller promises a non-null `p` is valid for the call.
    unsafe { p.as_ref() }.ok_or_else(|| Error::null(what))
}

/// `&mut *p`, or an error naming `what` when `p` is null.
///
/// # Safety
/// A non-null `p` must point to a live, properly aligned `T` no one else uses during the call.
pub(crate) unsafe fn get_mut<'a, T>(p: *mut T, what: &str) -> Result<&'a mut T, Error> {
    // SAFETY: the caller promises a non-null `p` is valid and unaliased for the call.
    unsafe { p.as_mut() }.ok_or_else(|| Error::null(what))
}

fn finite(name: &str, v: f64) -> Result<f64, Error> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::invalid(format!("{name} = {v} must be finite")))
    }
}

fn fields_of(mask: u32) -> Result<QueryFields, Error> {
    if mask & !SWELL_FIELD_ALL != 0 {
        return Err(Error::invalid(format!(
            "fields = {mask:#x} has bits beyond SWELL_FIELD_ALL ({SWELL_FIELD_ALL:#x})"
        )));
    }
    Ok(QueryFields {
        height: mask & SWELL_FIELD_HEIGHT != 0,
        normal: mask & SWELL_FIELD_NORMAL != 0,
        displacement: mask & SWELL_FIELD_DISPLACEMENT != 0,
        jacobian: mask & SWELL_FIELD_JACOBIAN != 0,
        residual: mask & SWELL_FIELD_RESIDUAL != 0,
    })
}

impl SwellSurface {
    /// The surface at `t`, its FFT frames from (and kept in) the handle's memo.
    fn at(
        &self,
        t: f64,
        fields: QueryFields,
        options: &QueryOptions,
    ) -> Result<SurfaceAt<'_>, Error> {
        finite("t", t)?;
        let s = &self.scene;
        let sea = s
            .surface
            .at_memo(t, fields, options, &s.memo)
            .map_err(|e| Error::invalid(e.to_string()))?;
        // As the server's queries: the set's rings on the first particle layer, when there are
        // any (`SceneImpacts::apply`).
        let set = Arc::clone(&self.impacts.read().unwrap_or_else(|p| p.into_inner()));
        if set.is_empty() {
            return Ok(sea);
        }
        sea.with_impacts(&set)
            .map_err(|e| Error::invalid(e.to_string()))
    }
}

/// An impact on the scene's particle layer, as `GET /v1/scenes/{id}/impacts` and tick frames
/// list them: a ring of ripples spreading from `position` from scene time `t`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwellImpact {
    /// Scene time of the impact, s.
    pub t: f64,
    /// World `[x, z]` of the impact, m.
    pub position: [f64; 2],
    /// Height of the splash at the impact point at `t`, m, in (0, 100].
    pub strength: f64,
    /// Radius of the ring's particles, m, in [0.01, 1000].
    pub radius: f64,
}

/// Sets the impacts whose ripples the surface's queries include, replacing the set before
/// (`n` = 0 clears it): pass the scene's impacts as `GET /v1/scenes/{id}/impacts` lists them
/// (and add those tick frames announce), and queries give the server's bits for the same set.
/// Safe to call while other threads query: each query uses the set in force when it starts.
/// Body worlds feel API impacts through `swell_world_feel_impact`.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_SPEC`] naming `impacts[i]` for an
/// impact the model rejects (a non-finite or out-of-range value), or more impacts than a scene
/// holds.
///
/// # Safety
/// `surface` a live handle; `impacts` readable for `n` impacts (null when `n` is 0).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_surface_set_impacts(
    surface: *const SwellSurface,
    impacts: *const SwellImpact,
    n: usize,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let s = unsafe { get(surface, "surface") }?;
        let list: &[SwellImpact] = if n == 0 {
            &[]
        } else if impacts.is_null() {
            return Err(Error::null("impacts"));
        } else {
            // SAFETY: non-null, and the caller promises `n` readable impacts.
            unsafe { std::slice::from_raw_parts(impacts, n) }
        };
        let mut events = Vec::with_capacity(list.len());
        for (i, m) in list.iter().enumerate() {
            let impact = Impact {
                t: m.t,
                position: m.position,
                strength: m.strength,
                radius: m.radius,
            };
            impact
                .validate(&format!("impacts[{i}]"))
                .map_err(|e| Error::spec(&e))?;
            events.push(impact);
        }
        let set = Impacts::from_events(events).map_err(|e| Error::spec(&e))?;
        *s.impacts.write().unwrap_or_else(|p| p.into_inner()) = Arc::new(set);
        Ok(())
    })
}

/// Builds a scene from its JSON spec (UTF-8, `len` bytes, no terminator needed): exactly the
/// text the server accepts for `PUT /v1/scenes/{id}` (`description`, `tick_hz`, `epoch` and the
/// surface: `seed`, `gravity`, `depth`, `layers`). On success `*out` holds a new handle.
///
/// Building an FFT layer draws its spectrum (milliseconds for 256²).
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`] (`out`, or `json` with `len > 0`), [`crate::SWELL_ERR_BAD_JSON`],
/// [`crate::SWELL_ERR_INVALID_SPEC`].
///
/// # Safety
/// `json` must point to `len` readable bytes; `out` must be writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_surface_new(
    json: *const c_char,
    len: usize,
    out: *mut *mut SwellSurface,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let out = unsafe { get_mut(out, "out") }?;
        *out = std::ptr::null_mut();
        // SAFETY: the caller's contract above.
        let text = unsafe { bytes(json, len, "json") }?;
        let scene = Scene::from_json(text)?;
        *out = Box::into_raw(Box::new(SwellSurface {
            scene: Arc::new(scene),
            impacts: RwLock::new(Arc::new(Impacts::default())),
        }));
        Ok(())
    })
}

/// Frees a surface handle. Null is ignored.
///
/// # Safety
/// `surface` must be null or a handle from [`swell_surface_new`] not yet freed, used by no other
/// thread during the call.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_surface_free(surface: *mut SwellSurface) {
    if surface.is_null() {
        return;
    }
    // The handle is gone after this call whatever happens, so unwind safety is moot.
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        // SAFETY: a live handle made by `Box::into_raw` in `swell_surface_new`.
        drop(unsafe { Box::from_raw(surface) });
    }));
}

/// What a scene is: its rates and the few facts a client branches on.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SwellSceneInfo {
    /// Ticks per second of scene time (the body world's step rate), Hz.
    pub tick_hz: f64,
    /// Gravity of the sea, m/s².
    pub gravity: f64,
    /// Unix time of t = 0, s, when `has_epoch` is 1.
    pub epoch: f64,
    /// 1 if the spec gives an epoch.
    pub has_epoch: i32,
    /// 1 if any layer is an FFT layer (queries at a new grid time compute frames).
    pub has_fft: i32,
    /// 1 if the bodies make impacts of their own (splashes and wakes: a body world then needs
    /// every body of the server's to follow it).
    pub has_body_impacts: i32,
    /// Number of layers.
    pub layers: u32,
    /// The fold number `Σ Q·k·A` of the analytic layers (< 1).
    pub fold_number: f64,
    /// The model version the numbers belong to (`swell_waves::MODEL_VERSION`).
    pub model_version: u32,
}

/// Fills `*out` with what the scene is.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`].
///
/// # Safety
/// `surface` must be a live handle (or null); `out` writable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_surface_info(
    surface: *const SwellSurface,
    out: *mut SwellSceneInfo,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let s = unsafe { get(surface, "surface") }?;
        // SAFETY: the caller's contract above.
        let out = unsafe { get_mut(out, "out") }?;
        let sc = &s.scene;
        *out = SwellSceneInfo {
            tick_hz: sc.tick_hz,
            gravity: sc.spec.gravity,
            epoch: sc.epoch.unwrap_or(0.0),
            has_epoch: i32::from(sc.epoch.is_some()),
            has_fft: i32::from(sc.surface.has_fft()),
            has_body_impacts: i32::from(sc.has_body_impacts()),
            layers: sc.surface.layers().len() as u32,
            fold_number: sc.surface.fold_number(),
            model_version: swell_waves::MODEL_VERSION,
        };
        Ok(())
    })
}

/// Fills `*out` with the server's default query settings (its `accuracy` defaults).
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`].
///
/// # Safety
/// `out` must be writable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_query_options_default(out: *mut SwellQueryOptions) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        *unsafe { get_mut(out, "out") }? = SwellQueryOptions::defaults();
        Ok(())
    })
}

/// Queries `n` world points `points[2i], points[2i+1]` = `(x, z)` at scene time `t` (s), asking
/// the fields in the `fields` mask (`SWELL_FIELD_*`), with `options` (null: the defaults), into
/// `out[0..n]`. The same bits as the server's `/sample` with the same accuracy.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite `t` or
/// coordinate, an unknown field bit, or bad options.
///
/// # Safety
/// `surface` a live handle; `points` readable for `2n` doubles and `out` writable for `n`
/// points (both may be null when `n` is 0); `options` null or readable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_surface_sample(
    surface: *const SwellSurface,
    t: f64,
    points: *const f64,
    n: usize,
    fields: u32,
    options: *const SwellQueryOptions,
    out: *mut SwellPoint,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let s = unsafe { get(surface, "surface") }?;
        let fields = fields_of(fields)?;
        let options = match unsafe { options.as_ref() } {
            // SAFETY (above): a non-null `options` is readable.
            Some(o) => o.to_model()?,
            None => QueryOptions::default(),
        };
        if n == 0 {
            return Ok(());
        }
        if points.is_null() {
            return Err(Error::null("points"));
        }
        if out.is_null() {
            return Err(Error::null("out"));
        }
        let len = n
            .checked_mul(2)
            .ok_or_else(|| Error::invalid("n is too large"))?;
        // SAFETY: non-null, and the caller promises `2n` readable doubles.
        let coords = unsafe { std::slice::from_raw_parts(points, len) };
        // SAFETY: non-null, and the caller promises `n` writable points, not aliasing `coords`.
        let out = unsafe { std::slice::from_raw_parts_mut(out, n) };
        let mut world = Vec::with_capacity(n);
        for (i, p) in coords.chunks_exact(2).enumerate() {
            world.push(DVec2::new(
                finite(&format!("points[{i}].x"), p[0])?,
                finite(&format!("points[{i}].z"), p[1])?,
            ));
        }
        let sea = s.at(t, fields, &options)?;
        for (o, r) in out.iter_mut().zip(sea.query_batch(&world, fields)) {
            *o = SwellPoint {
                height: r.height,
                normal: r.normal.to_array(),
                displacement: r.displacement.to_array(),
                jacobian: r.jacobian,
                residual: r.residual,
                folded: i32::from(r.folded),
            };
        }
        Ok(())
    })
}

/// Height at world `(x, z)` at scene time `t`, with the default accuracy (the server's
/// `/height`): `*out` in m.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite input.
///
/// # Safety
/// `surface` a live handle (or null); `out` writable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_surface_height(
    surface: *const SwellSurface,
    t: f64,
    x: f64,
    z: f64,
    out: *mut f64,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let s = unsafe { get(surface, "surface") }?;
        // SAFETY: the caller's contract above.
        let out = unsafe { get_mut(out, "out") }?;
        let p = DVec2::new(finite("x", x)?, finite("z", z)?);
        let sea = s.at(t, QueryFields::HEIGHT, &QueryOptions::default())?;
        *out = sea.query(p, QueryFields::HEIGHT).height;
        Ok(())
    })
}

/// Orientation of a body footprint at scene time `t` (the server's `orientation` query, default
/// accuracy): the plane through the heights at its probes. `probes` holds `n_probes` points
/// `[u, v]` in the body frame (m, u along the length); null with `n_probes` 0 gives the default
/// 3×3 grid over the footprint.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite `t`,
/// position or yaw, a yaw beyond ±1e9 rad, or a footprint the model rejects (size, probes).
///
/// # Safety
/// `surface` a live handle; `footprint` readable; `probes` readable for `2·n_probes` doubles
/// (or null when 0); `out` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_surface_orientation(
    surface: *const SwellSurface,
    t: f64,
    footprint: *const SwellFootprint,
    probes: *const f64,
    n_probes: usize,
    out: *mut SwellOrientation,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let s = unsafe { get(surface, "surface") }?;
        // SAFETY: the caller's contract above.
        let fp = *unsafe { get(footprint, "footprint") }?;
        // SAFETY: the caller's contract above.
        let out = unsafe { get_mut(out, "out") }?;
        finite("footprint.position[0]", fp.position[0])?;
        finite("footprint.position[1]", fp.position[1])?;
        if !(fp.yaw.is_finite() && fp.yaw.abs() <= MAX_YAW) {
            return Err(Error::invalid(format!(
                "footprint.yaw = {} must be finite with |yaw| <= {MAX_YAW} rad",
                fp.yaw
            )));
        }
        let probes = if n_probes == 0 {
            None
        } else {
            if probes.is_null() {
                return Err(Error::null("probes"));
            }
            let len = n_probes
                .checked_mul(2)
                .ok_or_else(|| Error::invalid("n_probes is too large"))?;
            // SAFETY: non-null, and the caller promises `2·n_probes` readable doubles.
            let c = unsafe { std::slice::from_raw_parts(probes, len) };
            Some(c.chunks_exact(2).map(|p| [p[0], p[1]]).collect())
        };
        let body = BodyFootprint {
            position: fp.position,
            yaw: fp.yaw,
            length: fp.length,
            beam: fp.beam,
            probes,
        };
        body.probes("footprint")
            .map_err(|e| Error::invalid(e.to_string()))?;
        let sea = s.at(t, QueryFields::HEIGHT, &QueryOptions::default())?;
        let o = body
            .orientation(&sea, "footprint")
            .map_err(|e| Error::invalid(e.to_string()))?;
        *out = SwellOrientation {
            heave: o.heave,
            rotation: o.rotation.to_array(),
            normal: o.normal.to_array(),
            pitch: o.pitch,
            roll: o.roll,
        };
        Ok(())
    })
}

/// One point of [`swell_surface_displacement_normal_f32`], in single precision.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SwellPointF32 {
    /// `[Dx, y, Dz]` of the point taken as undisplaced, m.
    pub displacement: [f32; 3],
    /// Unit normal `[x, y, z]` of the displaced surface there.
    pub normal: [f32; 3],
}

/// The single-precision fast path for rendering: displacement and normal of `n` undisplaced
/// points `points[2i], points[2i+1]` = `(x0, z0)` at scene time `t`, into `out[0..n]` (phases
/// reduced in f64, then f32 sin/cos and sums; a few micrometres off the f64 model, several
/// times cheaper, and just as deterministic: `proto/vectors/surface_f32_v1.json` pins it).
/// FFT layers are read from their grids at the default filter and time sampling.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite `t` or
/// coordinate.
///
/// # Safety
/// `surface` a live handle; `points` readable for `2n` doubles and `out` writable for `n`
/// points (both may be null when `n` is 0).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_surface_displacement_normal_f32(
    surface: *const SwellSurface,
    t: f64,
    points: *const f64,
    n: usize,
    out: *mut SwellPointF32,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let s = unsafe { get(surface, "surface") }?;
        if n == 0 {
            return Ok(());
        }
        if points.is_null() {
            return Err(Error::null("points"));
        }
        if out.is_null() {
            return Err(Error::null("out"));
        }
        let len = n
            .checked_mul(2)
            .ok_or_else(|| Error::invalid("n is too large"))?;
        // SAFETY: non-null, and the caller promises `2n` readable doubles.
        let coords = unsafe { std::slice::from_raw_parts(points, len) };
        // SAFETY: non-null, and the caller promises `n` writable points, not aliasing `coords`.
        let out = unsafe { std::slice::from_raw_parts_mut(out, n) };
        let mut world = Vec::with_capacity(n);
        for (i, p) in coords.chunks_exact(2).enumerate() {
            world.push(DVec2::new(
                finite(&format!("points[{i}].x"), p[0])?,
                finite(&format!("points[{i}].z"), p[1])?,
            ));
        }
        let options = QueryOptions {
            precision: Precision::F32,
            ..QueryOptions::default()
        };
        let sea = s.at(t, QueryFields::ALL, &options)?;
        let mut fast = vec![swell_waves::SurfacePointF32::default(); n];
        sea.displacement_normal_f32(&world, &mut fast);
        for (o, f) in out.iter_mut().zip(&fast) {
            *o = SwellPointF32 {
                displacement: f.displacement.to_array(),
                normal: f.normal.to_array(),
            };
        }
        Ok(())
    })
}
