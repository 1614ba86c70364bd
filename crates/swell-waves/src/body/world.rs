//! A set of rigid floating bodies stepped together at a fixed rate: the deterministic
//! simulation a scene's authority runs.
//!
//! # Determinism
//! The state at tick n is a pure function of the world settings, the sea (its spec), the bodies'
//! specs and initial states and the input log: bodies live in a `BTreeMap` and are stepped in id
//! order, inputs are summed in the order they were given, every sum has a fixed order, and all
//! maths is plain IEEE arithmetic plus the crate's `sin_cos`. Bodies do not interact, so one
//! body's trajectory does not depend on which other bodies exist. [`World::snapshot`] /
//! [`World::restore`] copy the whole state, so a restored world reproduces every later tick to
//! the bit. A world rebuilt from persisted parts ([`World::resume`], [`World::restore_body`])
//! does too when it is given each body's state, status and [`WarmStart`].

use std::collections::BTreeMap;
use std::sync::Arc;

use glam::{DMat3, DQuat, DVec3};

use super::buoyancy::{CellWater, loads};
use super::spec::{BodyModel, BodySpec};
use super::state::{BodyState, BodyStatus, quat_from_rotation_vector};
use crate::error::{SpecError, finite, positive};
use crate::fft::FftVelocityFrame;
use crate::query::{QueryFields, QueryOptions};
use crate::surface::{FrameMemo, Surface, SurfaceAt};
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// A body's id within a world.
pub type BodyId = u64;

/// Largest tick rate, Hz: beyond 1 kHz a game server gains nothing (it is far beyond any game's
/// network rate) and the sea evaluations per second explode. The server bounds scene tick rates
/// with this same constant, since a scene's bodies step at its tick rate.
pub const MAX_TICK_HZ: f64 = 1000.0;
/// Smallest tick rate, Hz: one tick every 100 s. Slower than that is a typo, and tick spans
/// (`1/tick_hz`, and the stream's waits in ticks) would overflow time types.
pub const MIN_TICK_HZ: f64 = 0.01;

/// Sea water density, kg/m³: the usual surface value (fresh water is 1000, the open ocean
/// 1020–1030). The default of [`WorldSettings::water_density`], and what the server uses.
pub const SEA_WATER_DENSITY: f64 = 1025.0;
/// Most substeps per tick a body may take (the clamp of [`substeps_for`]).
pub const MAX_SUBSTEPS: u32 = 256;
/// Largest phase advance of the stiffest natural oscillation per substep, rad. Semi-implicit
/// Euler is stable for `h·ω < 2`; at 0.25 the oscillation period is off by `(h·ω)²/24 ≈ 0.3%`
/// and a natural period spans at least 25 substeps, so the moment a column leaves the water is
/// resolved too. Halving it doubles the cost of stiff bodies.
pub const PHASE_PER_SUBSTEP: f64 = 0.25;

/// Settings shared by every body of a world.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct WorldSettings {
    /// Ticks per second, Hz (in (0, 1000]); the step is `dt = 1/tick_hz`. Default 30.
    pub tick_hz: f64,
    /// Water density ρ, kg/m³ (> 0). Default [`SEA_WATER_DENSITY`] (1025).
    pub water_density: f64,
    /// Gravity g, m/s² (> 0). Default 9.81; use the sea's.
    pub gravity: f64,
    /// Sea time of tick 0, s (finite). Tick n is at `start_time + n/tick_hz`. Default 0.
    pub start_time: f64,
}

impl Default for WorldSettings {
    fn default() -> Self {
        Self {
            tick_hz: 30.0,
            water_density: SEA_WATER_DENSITY,
            gravity: crate::spectrum::STANDARD_GRAVITY,
            start_time: 0.0,
        }
    }
}

impl WorldSettings {
    /// Checks the settings.
    ///
    /// # Errors
    /// `tick_hz` not in [0.01, 1000]; `water_density` or `gravity` not finite and > 0;
    /// `start_time` not finite.
    pub fn validate(&self) -> Result<(), SpecError> {
        let hz = positive("tick_hz", self.tick_hz)?;
        if !(MIN_TICK_HZ..=MAX_TICK_HZ).contains(&hz) {
            return Err(SpecError::OutOfRange {
                field: "tick_hz".into(),
                value: hz,
                allowed: format!("in [{MIN_TICK_HZ}, {MAX_TICK_HZ}] Hz"),
            });
        }
        positive("water_density", self.water_density)?;
        positive("gravity", self.gravity)?;
        finite("start_time", self.start_time)?;
        Ok(())
    }
}

/// A force and torque applied to one body, in the body frame, for a span of ticks (thrust,
/// rudder, a push).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct BodyInput {
    /// The body.
    pub body: BodyId,
    /// Force in the body frame, N, applied at the centre of mass.
    pub force: [f64; 3],
    /// Torque in the body frame, N·m.
    pub torque: [f64; 3],
    /// First tick it acts on.
    pub from_tick: u64,
    /// Number of ticks it acts for (≥ 1).
    pub ticks: u64,
}

impl BodyInput {
    fn active(&self, tick: u64) -> bool {
        tick >= self.from_tick && tick - self.from_tick < self.ticks
    }
}

/// One body in a world: its model, state and status.
#[derive(Debug, Clone)]
pub struct Body {
    model: Arc<BodyModel>,
    state: BodyState,
    status: BodyStatus,
    /// What each hull cell's height inversion found on the body's last substep (one entry per
    /// cell), and the seconds from that substep to the next tick's first; `None` before the
    /// first step and after a rollback (cold starts).
    warm: Option<(f64, Vec<CellWater>)>,
}

/// Where a body's next tick starts its hull cells' height inversions: what they found on the
/// body's last substep. Part of the body's state for determinism: the next tick's bits depend on
/// it (to within the inversion tolerance, not beyond), so a world rebuilt from persisted parts
/// must get it back ([`World::restore_body`]) to continue the trajectory bit for bit.
///
/// Carrying it across the tick saves the first substep's extra Newton rounds: from the world
/// point a cell takes ~3 rounds to converge on a choppy sea, from the prediction ~1.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct WarmStart {
    /// Seconds from the last substep to the next tick's first (the body's substep length), s.
    pub since: f64,
    /// Per hull cell, in the hull's order: world x, z (m); source point x, z (m); water particle
    /// velocity x, z (m/s); the horizontal displacement's slopes `∂Dx/∂x, ∂Dx/∂z, ∂Dz/∂x,
    /// ∂Dz/∂z` at the source.
    pub cells: Vec<[f64; 10]>,
}

impl Body {
    /// The validated model.
    pub fn model(&self) -> &BodyModel {
        &self.model
    }

    /// The current state.
    pub fn state(&self) -> &BodyState {
        &self.state
    }

    /// The status after the last step.
    pub fn status(&self) -> &BodyStatus {
        &self.status
    }

    /// Where the next tick starts this body's height inversions (`None`: from the cells' world
    /// points). Persist it with the state to resume bit for bit ([`World::restore_body`]).
    pub fn warm_start(&self) -> Option<WarmStart> {
        self.warm.as_ref().map(|(since, cells)| WarmStart {
            since: *since,
            cells: cells.iter().map(|c| c.to_array()).collect(),
        })
    }
}

/// Substeps per tick for a body: `n = clamp(ceil(dt·ω/0.25), 1, 256)` rounded up to a power of
/// two, with ω the larger of the heave and rotation natural frequencies
/// ([`BodyModel::heave_frequency`], [`BodyModel::rotation_frequency`]) and 0.25 rad the
/// [`PHASE_PER_SUBSTEP`]. The power of two makes substep times nest (`i/n` of a tick is exact
/// and the same for every n that has it), so bodies share sea snapshots within a tick.
pub fn substeps_for(model: &BodyModel, settings: &WorldSettings) -> u32 {
    let (rho, g) = (settings.water_density, settings.gravity);
    let omega = model
        .heave_frequency(rho, g)
        .max(model.rotation_frequency(rho, g));
    let raw = (omega / settings.tick_hz / PHASE_PER_SUBSTEP).ceil();
    let n = if raw.is_finite() && raw >= 1.0 {
        raw.min(f64::from(MAX_SUBSTEPS)) as u32
    } else if raw.is_nan() || raw > 1.0 {
        MAX_SUBSTEPS
    } else {
        1
    };
    n.next_power_of_two().min(MAX_SUBSTEPS)
}

/// A set of bodies in one sea, stepped at a fixed rate.
///
/// Determinism: the state at tick n is a pure function of the settings, the sea, the bodies'
/// specs and initial states and the input log. Bodies are stepped in id order (`BTreeMap`),
/// inputs summed in the order given, and a body's trajectory does not depend on the other
/// bodies. [`World::snapshot`] / [`World::restore`] reproduce every later tick to the bit.
#[derive(Debug, Clone)]
pub struct World {
    settings: WorldSettings,
    tick: u64,
    next_id: BodyId,
    bodies: BTreeMap<BodyId, Body>,
    /// Per body, in the order given.
    inputs: BTreeMap<BodyId, Vec<BodyInput>>,
}

/// A copy of a world's whole state (settings, tick, bodies, input log), for
/// [`World::restore`].
#[derive(Debug, Clone)]
pub struct WorldSnapshot(World);

impl WorldSnapshot {
    /// The tick the snapshot was taken at.
    pub fn tick(&self) -> u64 {
        self.0.tick
    }
}

impl World {
    /// An empty world at tick 0.
    ///
    /// # Errors
    /// Invalid settings (see [`WorldSettings::validate`]).
    pub fn new(settings: WorldSettings) -> Result<World, SpecError> {
        settings.validate()?;
        Ok(World {
            settings,
            tick: 0,
            next_id: 0,
            bodies: BTreeMap::new(),
            inputs: BTreeMap::new(),
        })
    }

    /// An empty world whose next tick is `tick` and whose next [`World::add`] gives `next_id`
    /// (or more): the frame to restore a persisted world into, before inserting its bodies
    /// ([`World::insert`]) and inputs ([`World::input`]). Unlike a world started at tick 0
    /// with a later `start_time`, it keeps the persisted world's substep times to the bit
    /// (`start_time + (tick + k/256)/tick_hz` rounds differently for another split of the
    /// same instant), so the restored world continues the same trajectory.
    ///
    /// # Errors
    /// Invalid settings (see [`WorldSettings::validate`]).
    pub fn resume(settings: WorldSettings, tick: u64, next_id: BodyId) -> Result<World, SpecError> {
        let mut w = World::new(settings)?;
        w.tick = tick;
        w.next_id = next_id;
        Ok(w)
    }

    /// Puts back body `id` exactly as a persisted world had it: its state to the bit, its
    /// status (what its last step measured), with the substep count its model gives here, and
    /// where its next tick starts the height inversions (`warm`, [`Body::warm_start`]; one
    /// with the wrong number of cells or a value that is not finite is dropped: cold starts).
    /// [`World::insert`] normalises the rotation, which moves the last bits of a quaternion the
    /// world itself produced and so the whole later trajectory; here a rotation within 1e-9 of
    /// unit length is kept as it is (a stepped body's is unit to ~1e-15) and only one further
    /// off is normalised.
    ///
    /// # Errors
    /// As [`World::insert`].
    pub fn restore_body(
        &mut self,
        id: BodyId,
        spec: &BodySpec,
        state: BodyState,
        status: BodyStatus,
        warm: Option<&WarmStart>,
    ) -> Result<(), SpecError> {
        let normalised = state.validated("state")?;
        let exact = if (state.rotation.length() - 1.0).abs() <= 1e-9 {
            state
        } else {
            normalised
        };
        self.insert(id, spec, exact)?;
        if let Some(b) = self.bodies.get_mut(&id) {
            b.state = exact;
            b.status = BodyStatus {
                substeps: b.status.substeps,
                ..status
            };
            b.warm = warm
                .filter(|w| {
                    w.since.is_finite()
                        && w.since > 0.0
                        && w.cells.len() == b.model.hull.cells.len()
                        && w.cells.iter().flatten().all(|v| v.is_finite())
                })
                .map(|w| {
                    (
                        w.since,
                        w.cells.iter().map(|c| CellWater::from_array(*c)).collect(),
                    )
                });
        }
        Ok(())
    }

    /// The id the next [`World::add`] gives: one more than the largest ever given.
    pub fn next_id(&self) -> BodyId {
        self.next_id
    }

    /// The settings.
    pub fn settings(&self) -> &WorldSettings {
        &self.settings
    }

    /// The next tick to be stepped (the number of steps taken so far).
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Sea time of tick `tick`, s: `start_time + tick/tick_hz`.
    pub fn time_of_tick(&self, tick: u64) -> f64 {
        self.substep_time(tick, 0)
    }

    /// Sea time of the current tick, s (the state is the state at this time).
    pub fn time(&self) -> f64 {
        self.time_of_tick(self.tick)
    }

    /// `start_time + (tick + key/256)/tick_hz`; `key/256` is exact.
    fn substep_time(&self, tick: u64, key: u32) -> f64 {
        self.settings.start_time
            + (tick as f64 + f64::from(key) / f64::from(MAX_SUBSTEPS)) / self.settings.tick_hz
    }

    /// Adds a body with the next free id (one more than the largest ever given) and returns
    /// the id.
    ///
    /// # Errors
    /// An invalid spec or initial state, each named from its root as a spawn request writes it:
    /// `mass`, `hull.length`, `hull.cells[2].volume` (see [`BodySpec::build`]); `position[1]`
    /// (a spawn's `position`), and the fields a spawn does not write, `rotation`, `velocity[0]`,
    /// `angular_velocity[2]` (see [`BodyState::validated`]; a spawn's rotation comes from its
    /// `yaw`, which a finite yaw within ±[`super::MAX_YAW`] makes valid).
    pub fn add(&mut self, spec: &BodySpec, initial: BodyState) -> Result<BodyId, SpecError> {
        let id = self.next_id;
        self.insert(id, spec, initial)?;
        Ok(id)
    }

    /// Adds or replaces the body `id`.
    ///
    /// # Errors
    /// As [`World::add`].
    pub fn insert(
        &mut self,
        id: BodyId,
        spec: &BodySpec,
        initial: BodyState,
    ) -> Result<(), SpecError> {
        let model = spec.build("")?;
        let state = initial.validated("")?;
        let status = BodyStatus {
            substeps: substeps_for(&model, &self.settings),
            ..BodyStatus::default()
        };
        self.bodies.insert(
            id,
            Body {
                model: Arc::new(model),
                state,
                status,
                warm: None,
            },
        );
        self.next_id = self.next_id.max(id.saturating_add(1));
        Ok(())
    }

    /// Removes a body and its inputs; whether it existed.
    pub fn remove(&mut self, id: BodyId) -> bool {
        self.inputs.remove(&id);
        self.bodies.remove(&id).is_some()
    }

    /// The body `id`.
    pub fn body(&self, id: BodyId) -> Option<&Body> {
        self.bodies.get(&id)
    }

    /// Every body, in id order.
    pub fn bodies(&self) -> impl Iterator<Item = (BodyId, &Body)> {
        self.bodies.iter().map(|(&id, b)| (id, b))
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.bodies.len()
    }

    /// Whether the world has no bodies.
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    /// Appends an input to the log. Inputs for the same body and tick add up, in the order
    /// given.
    ///
    /// # Errors
    /// An unknown body (`input.body`), a non-finite force or torque component
    /// (`input.force[i]`, `input.torque[i]`), or `ticks = 0` (`input.ticks`).
    pub fn input(&mut self, input: BodyInput) -> Result<(), SpecError> {
        if !self.bodies.contains_key(&input.body) {
            return Err(SpecError::Inconsistent {
                field: "input.body".into(),
                reason: format!("no body with id {}", input.body),
            });
        }
        for i in 0..3 {
            finite(&format!("input.force[{i}]"), input.force[i])?;
            finite(&format!("input.torque[{i}]"), input.torque[i])?;
        }
        if input.ticks == 0 {
            return Err(SpecError::OutOfRange {
                field: "input.ticks".into(),
                value: 0.0,
                allowed: ">= 1".into(),
            });
        }
        self.inputs.entry(input.body).or_default().push(input);
        Ok(())
    }

    /// The input log, per body in id order, each in the order given.
    pub fn inputs(&self) -> impl Iterator<Item = &BodyInput> {
        self.inputs.values().flatten()
    }

    /// How many of body `body`'s inputs have not ended by the current tick (acting now or
    /// later): the ones [`World::prune_inputs`] keeps.
    pub fn live_inputs(&self, body: BodyId) -> usize {
        let tick = self.tick;
        self.inputs.get(&body).map_or(0, |list| {
            list.iter()
                .filter(|i| i.from_tick.saturating_add(i.ticks) > tick)
                .count()
        })
    }

    /// Drops inputs that ended before the current tick (they cannot act again). Does not change
    /// any later state.
    pub fn prune_inputs(&mut self) {
        let tick = self.tick;
        for list in self.inputs.values_mut() {
            list.retain(|i| i.from_tick.saturating_add(i.ticks) > tick);
        }
        self.inputs.retain(|_, l| !l.is_empty());
    }

    /// A copy of the whole state.
    pub fn snapshot(&self) -> WorldSnapshot {
        WorldSnapshot(self.clone())
    }

    /// Puts the world back to a snapshot: every later tick then repeats to the bit.
    pub fn restore(&mut self, snapshot: &WorldSnapshot) {
        *self = snapshot.0.clone();
    }

    /// Steps every body by one tick, `dt = 1/tick_hz`, with the sea at substep time t given by
    /// `sea(t)`. Within one step `sea` is called once per distinct substep time, in increasing
    /// order of first use (`t` = tick time first); it must return the surface at exactly that
    /// time with height queries available and, for FFT layers, velocity grids
    /// ([`SurfaceAt::with_velocity`]; without them velocities are summed directly, slowly).
    /// [`World::step_surface`] does this for a whole [`Surface`].
    ///
    /// Each body takes [`substeps_for`] substeps of semi-implicit Euler (see [`crate::body`]).
    /// A hull cell's height inversion starts from a prediction made from what the body's
    /// previous substep found, in this tick or the last (one Newton step with the displacement
    /// extrapolated by the particle velocity), which saves Newton rounds; from the world point
    /// on a body's first step and after a rollback. What carries over between ticks is part of
    /// the body ([`Body::warm_start`]), so snapshots keep it.
    /// A body whose state becomes non-finite is put back to its state before the step with its
    /// velocities zeroed, and flagged ([`BodyStatus::quarantined`], [`BodyStatus::rollbacks`]).
    pub fn step<'s>(&mut self, mut sea: impl FnMut(f64) -> SurfaceAt<'s>) {
        let tick = self.tick;
        let dt = 1.0 / self.settings.tick_hz;
        let (rho, g) = (self.settings.water_density, self.settings.gravity);
        // Sea snapshots of this tick, keyed by substep time in 1/256 of a tick.
        let mut cache: Vec<(u32, SurfaceAt<'s>)> = Vec::new();
        let times: Vec<f64> = (0..MAX_SUBSTEPS)
            .map(|k| self.substep_time(tick, k))
            .collect();
        for (id, body) in self.bodies.iter_mut() {
            let (mut f_in, mut t_in) = (DVec3::ZERO, DVec3::ZERO);
            for i in self.inputs.get(id).into_iter().flatten() {
                if i.active(tick) {
                    f_in += DVec3::from_array(i.force);
                    t_in += DVec3::from_array(i.torque);
                }
            }
            let n = body.status.substeps;
            let h = dt / f64::from(n);
            let start = body.state;
            let mut state = start;
            let mut submerged = 0.0;
            let mut ok = true;
            // Per cell: what its inversion found on the body's previous substep (this one's
            // start is predicted from it; see `loads`), carried over from the last tick.
            let cells = body.model.hull.cells.len();
            let (mut since, mut warm) = match body.warm.take() {
                Some((since, warm)) if warm.len() == cells => (Some(since), warm),
                _ => (None, vec![CellWater::default(); cells]),
            };
            for i in 0..n {
                let key = i * (MAX_SUBSTEPS / n);
                let pos = match cache.iter().position(|(k, _)| *k == key) {
                    Some(p) => p,
                    None => {
                        cache.push((key, sea(times[key as usize])));
                        cache.len() - 1
                    }
                };
                let s = substep(
                    &body.model,
                    &mut state,
                    &cache[pos].1,
                    Forces {
                        f_in,
                        t_in,
                        h,
                        rho,
                        g,
                    },
                    &mut warm,
                    since,
                );
                since = Some(h);
                submerged = s;
                if !state.is_finite() {
                    ok = false;
                    break;
                }
            }
            if ok && state.is_finite() && submerged.is_finite() {
                body.state = state;
                body.status.submerged = submerged;
                body.status.quarantined = false;
                body.warm = Some((h, warm));
            } else {
                body.state = BodyState {
                    velocity: DVec3::ZERO,
                    angular_velocity: DVec3::ZERO,
                    ..start
                };
                body.status.quarantined = true;
                body.status.rollbacks += 1;
            }
        }
        self.tick += 1;
    }

    /// [`World::step`] with the sea of `surface`: `surface.at(t, HEIGHT, options)` with
    /// velocity grids for FFT layers, per substep time, FFT frames computed once for the tick
    /// (a [`FrameMemo`] of its own). Fine for analytic layers; for FFT layers a caller that
    /// steps many ticks should keep frames between them ([`World::step_memo`], or a server's
    /// cache through [`World::step_with`]).
    ///
    /// # Errors
    /// Invalid `options` (nothing is stepped then).
    pub fn step_surface(
        &mut self,
        surface: &Surface,
        options: &QueryOptions,
    ) -> Result<(), SpecError> {
        self.step_memo(surface, options, &FrameMemo::new())
    }

    /// [`World::step_surface`] keeping FFT frames in `memo` from one call to the next (the
    /// same bits: a frame depends only on its layer, time and fields).
    ///
    /// # Errors
    /// Invalid `options` (nothing is stepped then).
    pub fn step_memo(
        &mut self,
        surface: &Surface,
        options: &QueryOptions,
        memo: &FrameMemo,
    ) -> Result<(), SpecError> {
        self.step_with(surface, options, |t| {
            surface.at_memo(t, QueryFields::HEIGHT, options, memo)
        })
    }

    /// [`World::step_surface`] with the height snapshots supplied by `at` (a server's shared
    /// frame cache, say): `at(t)` must return `surface` at exactly t, ready for
    /// [`QueryFields::HEIGHT`] queries with `options`, as `surface.at(t, HEIGHT, options)` would;
    /// velocity grids are added here. A snapshot built from the same frames as `surface.at`
    /// gives the same bits, so the trajectory does not depend on where the frames came from.
    ///
    /// Velocity grids of FFT layers are made once per tick, at the tick's time, and every later
    /// substep of the tick reads those ([`SurfaceAt::with_velocity_frames`]): the water velocity
    /// only enters the drag, and a tick (1/30 s) moves the fastest modes' velocity phase by ω·Δt.
    /// With [`crate::TimeSampling::Grid`] they are central differences of the grid frames
    /// around the tick time ([`SurfaceAt::with_grid_velocity`]; `at` is asked for those grid
    /// times too, which a cache has already: no transform), otherwise computed
    /// ([`SurfaceAt::with_velocity`], three 256² transforms, which were a third of an FFT
    /// scene's body cost).
    ///
    /// # Errors
    /// Invalid `options` (nothing is stepped then). An error from `at` (which a finite substep
    /// time and valid options never give) steps on a flat sea instead of panicking.
    pub fn step_with<'s>(
        &mut self,
        surface: &'s Surface,
        options: &QueryOptions,
        mut at: impl FnMut(f64) -> Result<SurfaceAt<'s>, SpecError>,
    ) -> Result<(), SpecError> {
        options.validate()?;
        // The tick's velocity grids: computed with the first snapshot (the tick time's), shared
        // by the later substeps.
        let mut tick_velocities: Option<Vec<Option<Arc<FftVelocityFrame>>>> = None;
        self.step(|t| match at(t) {
            Ok(s) => match &tick_velocities {
                None => {
                    let s = s.with_grid_velocity(|t| at(t).ok());
                    tick_velocities = Some(s.velocities.clone());
                    s
                }
                Some(v) => {
                    // The same surface and options: exactly what `with_velocity` left on the
                    // first snapshot (nothing for analytic layers or in reference mode).
                    let mut s = s;
                    s.velocities = v.clone();
                    s
                }
            },
            Err(_) => unreachable_sea(surface, options),
        });
        Ok(())
    }
}

/// Only reachable if `Surface::at` rejects a finite time with valid options, which it does not;
/// returns the surface at t = 0 rather than panicking.
#[cold]
fn unreachable_sea<'s>(surface: &'s Surface, options: &QueryOptions) -> SurfaceAt<'s> {
    surface
        .at_with_frames(
            0.0,
            vec![None; surface.layers().len()],
            &QueryOptions {
                reference: true,
                ..*options
            },
        )
        .unwrap_or_else(|_| unreachable!("reference snapshots need no frames"))
}

/// What a substep applies besides the sea: the tick's input force and torque (body frame, N
/// and N·m), the substep length h, s, water density ρ, kg/m³, and gravity g, m/s².
#[derive(Clone, Copy)]
struct Forces {
    f_in: DVec3,
    t_in: DVec3,
    h: f64,
    rho: f64,
    g: f64,
}

/// One semi-implicit Euler substep of length `h`; returns the submerged volume fraction.
///
/// Linear: `v ← v + h·F/m`, `x ← x + h·v`. Angular, in the world frame: `L = I_w·ω + h·τ` with
/// `I_w = R·I·Rᵀ`, the orientation advanced by the rotation vector `h·I_w⁻¹·L`, then
/// `ω = I_w'⁻¹·L` with the new orientation (so a torque-free body keeps its angular momentum
/// exactly). Drag is limited so that one substep never removes more than the relative velocity
/// (the implicit-Euler bound): if `h·Σrate > m` the drag force is scaled by `m/(h·Σrate)`, and
/// likewise the drag torque against the smallest moment of inertia.
///
/// `warm` and `since` are the cells' inversion starts (see [`loads`]): `since = Some(h)` on
/// every substep but a body's first and the first after a rollback.
fn substep(
    model: &BodyModel,
    state: &mut BodyState,
    sea: &SurfaceAt<'_>,
    Forces {
        f_in,
        t_in,
        h,
        rho,
        g,
    }: Forces,
    warm: &mut [CellWater],
    since: Option<f64>,
) -> f64 {
    let rot = DMat3::from_quat(state.rotation);
    let com = state.position + rot * model.com;
    let l = loads(
        model,
        com,
        &rot,
        state.velocity,
        state.angular_velocity,
        sea,
        rho,
        g,
        warm,
        since,
    );
    let lin_scale = if h * l.drag_rate > model.mass {
        model.mass / (h * l.drag_rate)
    } else {
        1.0
    };
    let rot_scale = if h * l.drag_rate_rot > model.min_moment {
        model.min_moment / (h * l.drag_rate_rot)
    } else {
        1.0
    };
    let force = l.force + l.drag_force * lin_scale + rot * f_in;
    let torque = l.torque + l.drag_torque * rot_scale + rot * t_in;

    let v = state.velocity + force * (h / model.mass);
    let com = com + v * h;
    let inv_world = |r: &DMat3| *r * model.inv_inertia * r.transpose();
    let momentum = rot * (model.inertia * (rot.transpose() * state.angular_velocity)) + torque * h;
    let w_mid = inv_world(&rot) * momentum;
    let q: DQuat = (quat_from_rotation_vector(w_mid * h) * state.rotation).normalize();
    let rot_new = DMat3::from_quat(q);
    state.angular_velocity = inv_world(&rot_new) * momentum;
    state.rotation = q;
    state.velocity = v;
    state.position = com - rot_new * model.com;
    l.submerged / model.hull.volume
}
