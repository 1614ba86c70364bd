//! Body worlds: a scene's floating bodies stepped exactly as the server steps them
//! (`src/bodies/mod.rs`: the settings for its anchor tick, the default damping of a spawn, the
//! sea read with the authority's options and FFT frames kept between steps), so a client that
//! replays the same spawns and inputs at the same ticks reaches the server's states bit for bit.
//!
//! Impacts go through the model's [`WorldImpacts`], the type the server's scene bodies step
//! through: API impacts are felt from the scene tick the server says they reached its body world
//! ([`swell_world_feel_impact`]), and when the scene's particle layer has `body_impacts` each
//! step derives the bodies' splashes and wakes and the later steps ripple on them, as the
//! server's do.

use std::collections::BTreeMap;
use std::ffi::c_char;
use std::sync::Arc;

use swell_waves::FrameMemo;
use swell_waves::body::{
    BodyInput, BodySpec, BodyState, BodyStatus, MAX_YAW, SpawnSpec, World, WorldImpacts,
    authority_settings, authority_step_options,
};
use swell_waves::particles::Impact;

use crate::error::{Error, SWELL_ERR_BAD_JSON, SWELL_ERR_NOT_FOUND, SwellStatus, guard};
use crate::scene::Scene;
use crate::surface::{SwellImpact, SwellSurface, bytes, get, get_mut};

/// `from_tick` of a [`SwellInput`] that acts from the world's current tick (the next one it
/// steps), the server's default.
pub const SWELL_FROM_NOW: i64 = i64::MIN;

/// Most ticks one input may act for (the server's limit).
pub const SWELL_MAX_INPUT_TICKS: u64 = 10_000_000;

/// A scene's body world (opaque). Made by [`swell_world_new`] or [`swell_world_clone`], freed by
/// [`swell_world_free`]. Not for use by two threads at once.
pub struct SwellWorld {
    scene: Arc<Scene>,
    world: World,
    /// Each body's spec (defaults filled in), for [`swell_world_set_state`].
    specs: BTreeMap<u64, BodySpec>,
    /// Scene tick of world tick 0.
    anchor: i64,
    /// FFT frames of the last steps (a tick reads most of the previous tick's grid frames).
    memo: FrameMemo,
    /// The API impacts felt and the impacts the bodies made: what the bodies step on besides
    /// the surface (the server's own type).
    impacts: WorldImpacts,
    /// API impacts to feel when the world reaches their scene tick, in tick order (stable:
    /// those of one tick in the order given).
    pending: Vec<(i64, Impact)>,
}

/// A force and torque on one body for a span of ticks (the server's body input).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwellInput {
    /// Force `[x, y, z]` in the body frame, N (x forward: thrust).
    pub force: [f64; 3],
    /// Torque `[x, y, z]` in the body frame, N·m (y: rudder/yaw).
    pub torque: [f64; 3],
    /// First scene tick it acts on, not before the world's current tick; [`SWELL_FROM_NOW`] for
    /// the current tick.
    pub from_tick: i64,
    /// Number of ticks it acts for, 1..=10⁷.
    pub ticks: u64,
}

/// One body's state, as the server streams it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SwellBodyState {
    /// The body's id.
    pub id: u64,
    /// World position of the body origin, m.
    pub position: [f64; 3],
    /// World rotation quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
    /// Linear velocity, m/s.
    pub velocity: [f64; 3],
    /// Angular velocity (world frame), rad/s.
    pub angular_velocity: [f64; 3],
    /// Submerged fraction of the hull volume after the last step, in [0, 1].
    pub submerged: f64,
    /// 1 if the last step was rolled back (the state had turned non-finite).
    pub quarantined: i32,
}

fn not_found(id: u64) -> Error {
    Error::new(
        SWELL_ERR_NOT_FOUND,
        format!("no body with id {id} in this world"),
    )
}

impl SwellWorld {
    /// The scene tick the states are at.
    fn tick(&self) -> i64 {
        self.anchor + self.world.tick() as i64
    }

    /// Feels the pending API impacts due at the current tick, as the server feels an impact
    /// before it steps from the tick it reached the world at.
    fn feel_due(&mut self) {
        let now = self.tick();
        let due = self.pending.partition_point(|(at, _)| *at <= now);
        for (at, impact) in self.pending.drain(..due) {
            // Validated when queued, so feeling cannot fail; an impact whose tick was passed
            // without a step (never: steps are one tick each) would be felt late.
            let _ = self.impacts.feel(impact, Some(at));
        }
    }

    /// One fixed step of every body, on the scene's sea read as the server reads it, rippled by
    /// the impacts felt and made so far; then the impacts this step made
    /// ([`WorldImpacts::step_memo`], which the server's steps go through too).
    fn step_once(&mut self) -> Result<(), Error> {
        self.feel_due();
        let options = authority_step_options();
        self.impacts
            .step_memo(&mut self.world, &self.scene.surface, &options, &self.memo)
            .map(|_| ())
            .map_err(|e| Error::spec(&e))
    }

    fn spawn(&mut self, json: &[u8], id: Option<u64>) -> Result<u64, Error> {
        let req: SpawnSpec = serde_json::from_slice(json)
            .map_err(|e| Error::new(SWELL_ERR_BAD_JSON, format!("spawn request: {e}")))?;
        // The server's checks (`SceneBodies::spawn`), before the model's.
        for (i, v) in req.position.iter().enumerate() {
            if !v.is_finite() {
                return Err(Error::invalid(format!(
                    "position[{i}] = {v} must be finite"
                )));
            }
        }
        if !(req.yaw.is_finite() && req.yaw.abs() <= MAX_YAW) {
            return Err(Error::invalid(format!(
                "yaw = {} must be finite with |yaw| <= {MAX_YAW} rad",
                req.yaw
            )));
        }
        let spec = req.body_spec(self.scene.spec.gravity);
        let state = BodyState::at_rest(glam::DVec3::from_array(req.position), req.yaw);
        let id = match id {
            None => self.world.add(&spec, state).map_err(|e| Error::spec(&e))?,
            Some(id) => {
                if self.world.body(id).is_some() {
                    return Err(Error::new(
                        SWELL_ERR_NOT_FOUND,
                        format!("a body with id {id} is already in this world"),
                    ));
                }
                self.world
                    .insert(id, &spec, state)
                    .map_err(|e| Error::spec(&e))?;
                id
            }
        };
        self.specs.insert(id, spec);
        Ok(id)
    }
}

fn state_out(id: u64, b: &swell_waves::body::Body) -> SwellBodyState {
    let s = b.state();
    SwellBodyState {
        id,
        position: s.position.to_array(),
        rotation: s.rotation.to_array(),
        velocity: s.velocity.to_array(),
        angular_velocity: s.angular_velocity.to_array(),
        submerged: b.status().submerged,
        quarantined: i32::from(b.status().quarantined),
    }
}

/// Makes an empty body world for the scene of `surface`, anchored at scene tick `anchor_tick`
/// (world tick 0 is that scene tick), with the scene's tick rate and gravity, as the server
/// makes a scene's world. On success `*out` holds a new handle.
///
/// The anchor is part of the bits: to reproduce the server's states, use the tick its world is
/// anchored at (the scene tick of the scene's first spawn, or of its last re-anchor), which the
/// server publishes as `anchor_tick` (spawn answer, `GET …/bodies`, tick frames).
///
/// When the scene's particle layer has `body_impacts`, every step derives the bodies' splashes
/// and wakes as the server's do, and later steps feel them: then each body moves the others, so
/// the world must hold every body of the server's (spawned at its `spawn_tick`, with its
/// inputs) to follow it. API impacts are fed with [`swell_world_feel_impact`].
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_SPEC`] if the scene's tick rate or
/// gravity is out of the body model's range.
///
/// # Safety
/// `surface` a live handle (or null); `out` writable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_new(
    surface: *const SwellSurface,
    anchor_tick: i64,
    out: *mut *mut SwellWorld,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let out = unsafe { get_mut(out, "out") }?;
        *out = std::ptr::null_mut();
        // SAFETY: the caller's contract above.
        let s = unsafe { get(surface, "surface") }?;
        let scene = Arc::clone(&s.scene);
        let settings = authority_settings(anchor_tick, scene.tick_hz, scene.spec.gravity);
        let world = World::new(settings).map_err(|e| Error::spec(&e))?;
        *out = Box::into_raw(Box::new(SwellWorld {
            scene,
            world,
            specs: BTreeMap::new(),
            anchor: anchor_tick,
            memo: FrameMemo::new(),
            impacts: WorldImpacts::new(),
            pending: Vec::new(),
        }));
        Ok(())
    })
}

/// Frees a world. Null is ignored.
///
/// # Safety
/// `world` must be null or a live handle, used by no other thread during the call.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_free(world: *mut SwellWorld) {
    if world.is_null() {
        return;
    }
    // The handle is gone after this call whatever happens, so unwind safety is moot.
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        // SAFETY: a live handle made by `Box::into_raw` in this module.
        drop(unsafe { Box::from_raw(world) });
    }));
}

/// A copy of `world` with everything that decides its later ticks (bodies, their warm starts,
/// the input log, the impacts felt, pending and made): stepping the copy and the original alike gives the same bits. Keep one at
/// the last tick the server confirmed, to rewind to when its inputs turn out to differ.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`].
///
/// # Safety
/// `world` a live handle (or null); `out` writable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_clone(
    world: *const SwellWorld,
    out: *mut *mut SwellWorld,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let out = unsafe { get_mut(out, "out") }?;
        *out = std::ptr::null_mut();
        // SAFETY: the caller's contract above.
        let w = unsafe { get(world, "world") }?;
        *out = Box::into_raw(Box::new(SwellWorld {
            scene: Arc::clone(&w.scene),
            world: w.world.clone(),
            specs: w.specs.clone(),
            anchor: w.anchor,
            memo: FrameMemo::new(),
            impacts: w.impacts.clone(),
            pending: w.pending.clone(),
        }));
        Ok(())
    })
}

/// Makes `dst` a copy of `src` (as [`swell_world_clone`], into an existing handle): rewinds a
/// prediction to a confirmed world.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`].
///
/// # Safety
/// `dst` and `src` live handles (or null), `dst` used by no other thread during the call.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_assign(
    dst: *mut SwellWorld,
    src: *const SwellWorld,
) -> SwellStatus {
    guard(|| {
        if std::ptr::eq(dst, src) {
            return Ok(());
        }
        // SAFETY: the caller's contract above; `dst != src`, so the borrows do not alias.
        let s = unsafe { get(src, "src") }?;
        // SAFETY: as above.
        let d = unsafe { get_mut(dst, "dst") }?;
        if !Arc::ptr_eq(&d.scene, &s.scene) {
            // The memo's frames are keyed by layer index and time, not by scene: frames of
            // another scene must not be read for this one.
            d.memo = FrameMemo::new();
            d.scene = Arc::clone(&s.scene);
        }
        d.world = s.world.clone();
        d.specs = s.specs.clone();
        d.anchor = s.anchor;
        d.impacts = s.impacts.clone();
        d.pending = s.pending.clone();
        Ok(())
    })
}

/// `*out` = the scene tick the states are at (the next tick a step computes).
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`].
///
/// # Safety
/// `world` a live handle (or null); `out` writable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_tick(world: *const SwellWorld, out: *mut i64) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get(world, "world") }?;
        // SAFETY: the caller's contract above.
        *unsafe { get_mut(out, "out") }? = w.tick();
        Ok(())
    })
}

/// `*out` = the scene time the states are at, s (`anchor/tick_hz + n/tick_hz`).
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`].
///
/// # Safety
/// `world` a live handle (or null); `out` writable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_time(world: *const SwellWorld, out: *mut f64) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get(world, "world") }?;
        // SAFETY: the caller's contract above.
        *unsafe { get_mut(out, "out") }? = w.world.time();
        Ok(())
    })
}

/// Spawns a body at the world's current tick from the JSON the server takes for
/// `POST /v1/scenes/{id}/bodies` (`mass`, `hull`, `position`, optional `yaw`,
/// `center_of_mass`, `linear_drag`, `quadratic_drag`, `angular_damping`,
/// `min_wavelength_factor`; the damping defaults are the server's), at rest. `*out_id` gets the
/// next free id, as the server gives it in a world with the same history; to mirror a body
/// whose id the server chose, use [`swell_world_spawn_as`].
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_BAD_JSON`];
/// [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite position or a yaw beyond ±1e9;
/// [`crate::SWELL_ERR_INVALID_SPEC`] for a body the model rejects.
///
/// # Safety
/// `world` a live handle; `json` readable for `len` bytes; `out_id` writable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_spawn(
    world: *mut SwellWorld,
    json: *const c_char,
    len: usize,
    out_id: *mut u64,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get_mut(world, "world") }?;
        // SAFETY: the caller's contract above.
        let out_id = unsafe { get_mut(out_id, "out_id") }?;
        // SAFETY: the caller's contract above.
        let text = unsafe { bytes(json, len, "json") }?;
        *out_id = w.spawn(text, None)?;
        Ok(())
    })
}

/// [`swell_world_spawn`] with the id `id` (the one the server gave the body). A body's
/// trajectory does not depend on its id or on the other bodies, so a client may hold only its
/// own boat under the server's id.
///
/// # Errors
/// As [`swell_world_spawn`]; [`crate::SWELL_ERR_NOT_FOUND`] if `id` is taken.
///
/// # Safety
/// `world` a live handle; `json` readable for `len` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_spawn_as(
    world: *mut SwellWorld,
    id: u64,
    json: *const c_char,
    len: usize,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get_mut(world, "world") }?;
        // SAFETY: the caller's contract above.
        let text = unsafe { bytes(json, len, "json") }?;
        w.spawn(text, Some(id))?;
        Ok(())
    })
}

/// Removes body `id`, its inputs and its wake distance.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_NOT_FOUND`].
///
/// # Safety
/// `world` a live handle (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_remove(world: *mut SwellWorld, id: u64) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get_mut(world, "world") }?;
        w.specs.remove(&id);
        w.impacts.forget(id);
        if w.world.remove(id) {
            Ok(())
        } else {
            Err(not_found(id))
        }
    })
}

/// Queues an input for body `id`, as the server does (`SceneBodies::input`): it acts from
/// `input.from_tick` (scene ticks; [`SWELL_FROM_NOW`] for the current tick) for `input.ticks`
/// ticks. Inputs for the same body and tick add up in the order given.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_NOT_FOUND`];
/// [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a tick before the current one, `ticks` outside
/// 1..=10⁷, or a non-finite component.
///
/// # Safety
/// `world` a live handle; `input` readable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_input(
    world: *mut SwellWorld,
    id: u64,
    input: *const SwellInput,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get_mut(world, "world") }?;
        // SAFETY: the caller's contract above.
        let i = *unsafe { get(input, "input") }?;
        if w.world.body(id).is_none() {
            return Err(not_found(id));
        }
        let now = w.tick();
        let from = if i.from_tick == SWELL_FROM_NOW {
            now
        } else {
            i.from_tick
        };
        if from < now {
            return Err(Error::invalid(format!(
                "from_tick = {from} is in the past: the bodies are at tick {now}"
            )));
        }
        if !(1..=SWELL_MAX_INPUT_TICKS).contains(&i.ticks) {
            return Err(Error::invalid(format!(
                "ticks = {} is out of range: 1..={SWELL_MAX_INPUT_TICKS}",
                i.ticks
            )));
        }
        // As the server: far ahead of a negative anchor the difference overflows.
        let relative = from.checked_sub(w.anchor).ok_or_else(|| {
            Error::invalid(format!(
                "from_tick = {from} is out of range: more than i64::MAX ticks after the world's anchor {}",
                w.anchor
            ))
        })?;
        w.world
            .input(BodyInput {
                body: id,
                force: i.force,
                torque: i.torque,
                from_tick: relative as u64,
                ticks: i.ticks,
            })
            .map_err(|e| Error::invalid(e.to_string()))
    })
}

/// Steps every body by one tick (`1/tick_hz` s).
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`].
///
/// # Safety
/// `world` a live handle (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_step(world: *mut SwellWorld) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get_mut(world, "world") }?;
        w.step_once()?;
        w.world.prune_inputs();
        Ok(())
    })
}

/// Steps every body until the states are at scene tick `tick` (nothing if they are already).
/// Each tick costs a sea evaluation per hull cell and substep: step in small spans.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a tick before the
/// current one (bodies only move forward: rewind with [`swell_world_assign`]).
///
/// # Safety
/// `world` a live handle (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_step_to(world: *mut SwellWorld, tick: i64) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get_mut(world, "world") }?;
        let now = w.tick();
        if tick < now {
            return Err(Error::invalid(format!(
                "tick = {tick} is in the past: the bodies are at tick {now}"
            )));
        }
        while w.tick() < tick {
            w.step_once()?;
        }
        // Inputs that ended cannot act again; dropping them changes no later state.
        w.world.prune_inputs();
        Ok(())
    })
}

/// `*out` = body `id`'s state at the world's current tick.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_NOT_FOUND`].
///
/// # Safety
/// `world` a live handle (or null); `out` writable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_state(
    world: *const SwellWorld,
    id: u64,
    out: *mut SwellBodyState,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get(world, "world") }?;
        // SAFETY: the caller's contract above.
        let out = unsafe { get_mut(out, "out") }?;
        let b = w.world.body(id).ok_or_else(|| not_found(id))?;
        *out = state_out(id, b);
        Ok(())
    })
}

/// Number of bodies in the world, into `*out`.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`].
///
/// # Safety
/// `world` a live handle (or null); `out` writable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_len(world: *const SwellWorld, out: *mut usize) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get(world, "world") }?;
        // SAFETY: the caller's contract above.
        *unsafe { get_mut(out, "out") }? = w.world.len();
        Ok(())
    })
}

/// Puts body `id` at `state` (its `id` field is ignored; the rotation is normalised unless it
/// is within 1e-9 of unit length): the fallback of a reconciliation when a client only has the
/// server's streamed state. The server's next ticks also depend on where each hull cell's
/// height inversion starts (its warm start, not on the wire), so after this the prediction
/// follows the server to within the inversion tolerance (1 mm), not to the bit; rewinding to a
/// confirmed world ([`swell_world_assign`]) and replaying the inputs keeps the bits. The one
/// state it is on the bits from is a body's `carried.state` at a re-anchored world's
/// `anchor_tick` (`GET …/bodies`), put on a world anchored there: the server starts that world
/// cold too.
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_NOT_FOUND`];
/// [`crate::SWELL_ERR_INVALID_ARGUMENT`] for a non-finite or degenerate state.
///
/// # Safety
/// `world` a live handle; `state` readable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_set_state(
    world: *mut SwellWorld,
    id: u64,
    state: *const SwellBodyState,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get_mut(world, "world") }?;
        // SAFETY: the caller's contract above.
        let s = *unsafe { get(state, "state") }?;
        let spec = w.specs.get(&id).cloned().ok_or_else(|| not_found(id))?;
        let st = BodyState {
            position: glam::DVec3::from_array(s.position),
            rotation: glam::DQuat::from_array(s.rotation),
            velocity: glam::DVec3::from_array(s.velocity),
            angular_velocity: glam::DVec3::from_array(s.angular_velocity),
        };
        let status = BodyStatus {
            submerged: s.submerged,
            quarantined: s.quarantined != 0,
            ..BodyStatus::default()
        };
        w.world
            .restore_body(id, &spec, st, status, None)
            .map_err(|e| Error::invalid(e.to_string()))
    })
}

/// Makes the world's bodies feel an API impact (`POST /v1/scenes/{id}/impacts`) from scene
/// tick `at_tick` on, as the server's do: pass the `body_tick` the server published for it (the
/// impact answer's `body_tick`, or `felt_impacts[i].tick` in `GET …/bodies`), the tick it
/// reached the server's body world at; [`SWELL_FROM_NOW`] for the world's current tick. An
/// impact at a later tick waits until a step reaches that tick. The tick matters to the bits:
/// the same impact felt a tick earlier or later gives other states (rings alive before the
/// impact's own time `t` are not, but the pruning of old ones and the ripples of an impact whose
/// `t` is already past are).
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`]; [`crate::SWELL_ERR_INVALID_SPEC`] naming `impact.…` for an impact
/// the model rejects (a non-finite or out-of-range value); [`crate::SWELL_ERR_INVALID_ARGUMENT`]
/// for a tick before the world's current one (rewind to a world at or before it with
/// [`swell_world_assign`], then feel it and step again). Nothing changes on an error.
///
/// # Safety
/// `world` a live handle (or null); `impact` readable (or null).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_feel_impact(
    world: *mut SwellWorld,
    impact: *const SwellImpact,
    at_tick: i64,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get_mut(world, "world") }?;
        // SAFETY: the caller's contract above.
        let m = *unsafe { get(impact, "impact") }?;
        let impact = Impact {
            t: m.t,
            position: m.position,
            strength: m.strength,
            radius: m.radius,
        };
        impact.validate("impact").map_err(|e| Error::spec(&e))?;
        let now = w.tick();
        let at = if at_tick == SWELL_FROM_NOW {
            now
        } else {
            at_tick
        };
        if at < now {
            return Err(Error::invalid(format!(
                "at_tick = {at} is in the past: the bodies are at tick {now} (rewind to a world at or before it)"
            )));
        }
        if at == now {
            w.impacts
                .feel(impact, Some(at))
                .map_err(|e| Error::spec(&e))?;
        } else {
            let i = w.pending.partition_point(|(t, _)| *t <= at);
            w.pending.insert(i, (at, impact));
        }
        Ok(())
    })
}

/// Copies the impacts the world's bodies made (splashes and wakes, when the scene's particle
/// layer has `body_impacts`; canonical order, pruned to the last hour) into `out`, at most
/// `cap` of them; `*out_len` = how many there are (more than `cap`: call again with a larger
/// buffer). With the scene's API impacts they are what the server's queries ripple with
/// ([`crate::swell_surface_set_impacts`]).
///
/// # Errors
/// [`crate::SWELL_ERR_NULL`] (`out` may be null when `cap` is 0).
///
/// # Safety
/// `world` a live handle (or null); `out` writable for `cap` impacts; `out_len` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn swell_world_made_impacts(
    world: *const SwellWorld,
    out: *mut SwellImpact,
    cap: usize,
    out_len: *mut usize,
) -> SwellStatus {
    guard(|| {
        // SAFETY: the caller's contract above.
        let w = unsafe { get(world, "world") }?;
        // SAFETY: the caller's contract above.
        let out_len = unsafe { get_mut(out_len, "out_len") }?;
        let made = w.impacts.derived();
        if cap > 0 && !made.is_empty() {
            if out.is_null() {
                return Err(Error::null("out"));
            }
            // SAFETY: non-null, and the caller promises `cap` writable impacts.
            let dst = unsafe { std::slice::from_raw_parts_mut(out, cap) };
            for (d, m) in dst.iter_mut().zip(made) {
                *d = SwellImpact {
                    t: m.t,
                    position: m.position,
                    strength: m.strength,
                    radius: m.radius,
                };
            }
        }
        *out_len = made.len();
        Ok(())
    })
}
