//! The impacts a body world steps on: API impacts it *feels* (each from the tick it reached the
//! world) and the impacts its own bodies *make* (splashes and wakes, when the sea's particle
//! layer has `body_impacts`: [`crate::particles::body_impacts`]).
//!
//! A server's scene bodies and a native client's world (the C ABI in `swell-ffi`) both step
//! through [`WorldImpacts::step`], so both feel, derive, prune and ripple alike and reach the
//! same bits.
//!
//! # The rules
//! - **Felt impacts** are kept in canonical order ([`Impact::canonical_cmp`]); at most
//!   [`MAX_FELT_IMPACTS`] (beyond, the canonically first goes). One is felt from the tick it is
//!   added on: added before the step from tick n, the step reads the sea rippled by it.
//! - **Derived impacts**: after each fixed step, every body (in id order) is tested for a splash,
//!   then a wake, with its state and submerged fraction before and after the step; `t` is the
//!   step's end (`start_time + (n + 1)/tick_hz`). An impact off the model's map is dropped
//!   (counted in [`Derived::off_map`]); one
//!   that would make more than [`MAX_BODY_NEAR_IMPACTS`] derived impacts within one ring
//!   lifetime before it is dropped (counted in [`Derived::dropped`]); beyond
//!   [`MAX_BODY_IMPACTS`] the oldest go. Each body carries the distance it travelled since its
//!   last wake impact, m (part of the state: persist it with [`WorldImpacts::wake`]).
//! - **Pruning**, after each step's derivation and on a re-anchor: derived impacts more than
//!   [`BODY_IMPACT_HISTORY`] behind the world's time or after it (left in the future by a
//!   re-anchor back in time) go; felt ones more than [`BODY_IMPACT_HISTORY`] behind go (a felt
//!   impact may lie in the future: it stays).
//! - **What the bodies step on**: the surface rippled by the felt impacts followed by the derived
//!   ones, as one [`Impacts`] set ([`WorldImpacts::ripples`]; the set sorts them canonically).
//!   A set with more rings alive at once than the model allows leaves the sea without ripples
//!   ([`ripple_or_bare`]): the same on every path, since it depends only on the set and the time.

use std::collections::BTreeMap;
use std::sync::Arc;

use super::world::{BodyId, World};
use crate::error::SpecError;
use crate::particles::{BodyImpactSpec, BodyStep, Impact, Impacts};
use crate::query::{QueryFields, QueryOptions};
use crate::surface::{FrameMemo, Surface, SurfaceAt};

/// How long impacts are kept behind the bodies' time, s: the longest ring lifetime a particle
/// layer allows (an hour), so queries of the past hour see the ripples they saw live. Shorter
/// would drop rings that still ripple; longer only costs memory.
pub const BODY_IMPACT_HISTORY: f64 = 3600.0;
/// Most derived impacts (splashes, wakes) a world may make within one ring lifetime before the
/// newest: beyond it a new one is dropped. The server sets it at half of its limit on impacts
/// near each other (1,024), so API impacts keep room, and together far below the model's 4,096
/// live rings. The count covers derived impacts only, so what is dropped depends on the bodies
/// alone (deterministic).
pub const MAX_BODY_NEAR_IMPACTS: usize = 512;
/// Most derived impacts kept (the oldest go first): bounds memory and snapshots.
pub const MAX_BODY_IMPACTS: usize = 16_384;
/// Most API impacts a world feels at once: the server's limit on a scene's API impacts, so a
/// replay of an old journal cannot hold more.
pub const MAX_FELT_IMPACTS: usize = 100_000;

/// What one step derived: impacts kept, impacts dropped by [`MAX_BODY_NEAR_IMPACTS`], and
/// impacts off the model's map.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Derived {
    /// Impacts added to the derived set.
    pub made: u32,
    /// Impacts dropped because too many derived ones were near in time.
    pub dropped: u32,
    /// Impacts dropped because no ring can carry them: made by a body beyond ±1e9 m
    /// ([`crate::particles::ripple::MAX_IMPACT_COORD`]) or at a time beyond ±1e12 s
    /// ([`crate::particles::ripple::MAX_IMPACT_TIME`]), where [`Impact::validate`] refuses
    /// them. A server whose coordinates go past 1e9 m lets bodies there, and their splashes
    /// and wakes would otherwise vanish without trace.
    pub off_map: u32,
}

/// The impacts of one body world: the API impacts it feels, the ones its bodies made, each
/// body's wake distance, and the combined set it steps on (see the module docs for the rules).
#[derive(Debug, Clone, Default)]
pub struct WorldImpacts {
    /// Felt API impacts, in canonical order.
    felt: Vec<Impact>,
    /// Per felt impact (same index), the scene tick it reached the world at, when known: a label
    /// for publishing, never stepped on.
    felt_ticks: Vec<Option<i64>>,
    /// Derived impacts, in canonical order (time first).
    derived: Vec<Impact>,
    /// Derived since the owner last took them.
    fresh: Vec<Impact>,
    /// Bumped whenever `derived` changes.
    version: u64,
    /// Per body, horizontal distance travelled since its last wake impact, m.
    wake: BTreeMap<BodyId, f64>,
    /// `felt` and `derived` as one set; `None` when either changed since it was built.
    ripples: Option<Arc<Impacts>>,
}

impl WorldImpacts {
    /// No impacts.
    pub fn new() -> WorldImpacts {
        WorldImpacts::default()
    }

    /// Rebuilds the impacts of a persisted world: `felt` (with `felt_ticks`, index for index;
    /// missing ones unknown) felt again, `derived` kept where it validates (canonical order, at
    /// most [`MAX_BODY_IMPACTS`]), `wake` kept for the bodies `has_body` knows where finite. A
    /// damaged record cannot put an impact the model rejects into a world.
    pub fn restore(
        felt: &[Impact],
        felt_ticks: &[Option<i64>],
        derived: &[Impact],
        wake: &BTreeMap<BodyId, f64>,
        has_body: impl Fn(BodyId) -> bool,
    ) -> WorldImpacts {
        let mut w = WorldImpacts::new();
        for (i, impact) in felt.iter().enumerate() {
            let _ = w.feel(*impact, felt_ticks.get(i).copied().flatten());
        }
        w.derived = derived
            .iter()
            .filter(|i| i.validate("").is_ok())
            .copied()
            .collect();
        w.derived.sort_by(|a, c| a.canonical_cmp(c));
        let excess = w.derived.len().saturating_sub(MAX_BODY_IMPACTS);
        w.derived.drain(..excess);
        w.version = u64::from(!w.derived.is_empty());
        w.wake = wake
            .iter()
            .filter(|(id, d)| has_body(**id) && d.is_finite())
            .map(|(id, d)| (*id, *d))
            .collect();
        w
    }

    /// Makes the world feel `impact` from its current tick on; `tick` is the scene tick it
    /// reached the world at, kept only to be published ([`WorldImpacts::felt_ticks`]). Beyond
    /// [`MAX_FELT_IMPACTS`] the canonically first felt one goes.
    ///
    /// # Errors
    /// An impact the model rejects ([`Impact::validate`]; field `impact.…`): nothing changes.
    pub fn feel(&mut self, impact: Impact, tick: Option<i64>) -> Result<(), SpecError> {
        impact.validate("impact")?;
        let at = self
            .felt
            .partition_point(|e| e.canonical_cmp(&impact).is_le());
        self.felt.insert(at, impact);
        self.felt_ticks.insert(at, tick);
        if self.felt.len() > MAX_FELT_IMPACTS {
            self.felt.remove(0);
            self.felt_ticks.remove(0);
        }
        self.ripples = None;
        Ok(())
    }

    /// The felt API impacts, in canonical order.
    pub fn felt(&self) -> &[Impact] {
        &self.felt
    }

    /// The scene tick each felt impact reached the world at ([`WorldImpacts::felt`]'s order),
    /// `None` where not known (a record written before they were kept).
    pub fn felt_ticks(&self) -> &[Option<i64>] {
        &self.felt_ticks
    }

    /// The derived impacts held, in canonical order.
    pub fn derived(&self) -> &[Impact] {
        &self.derived
    }

    /// Per body, the distance travelled since its last wake impact, m.
    pub fn wake(&self) -> &BTreeMap<BodyId, f64> {
        &self.wake
    }

    /// Bumped whenever the derived impacts change (cheap change detection).
    pub fn version(&self) -> u64 {
        self.version
    }

    /// The impacts derived since the last call, oldest first (at most
    /// [`MAX_BODY_NEAR_IMPACTS`]: older ones are forgotten).
    pub fn take_fresh(&mut self) -> Vec<Impact> {
        std::mem::take(&mut self.fresh)
    }

    /// Forgets body `id`'s wake distance (the body was removed).
    pub fn forget(&mut self, id: BodyId) {
        self.wake.remove(&id);
    }

    /// What the bodies step on besides the surface: the felt and derived impacts as one set
    /// (`None` when there are none, so worlds without impacts pay nothing). Cached until either
    /// part changes.
    pub fn ripples(&mut self) -> Option<Arc<Impacts>> {
        if self.felt.is_empty() && self.derived.is_empty() {
            return None;
        }
        if self.ripples.is_none() {
            let mut all = Vec::with_capacity(self.felt.len() + self.derived.len());
            all.extend_from_slice(&self.felt);
            all.extend_from_slice(&self.derived);
            // Both parts are validated and bounded far below the model's set limit.
            self.ripples = Impacts::from_events(all).ok().map(Arc::new);
        }
        self.ripples.clone()
    }

    /// Drops derived impacts more than [`BODY_IMPACT_HISTORY`] behind `now` (s, the world's
    /// time) or after it, and felt ones more than [`BODY_IMPACT_HISTORY`] behind.
    pub fn prune(&mut self, now: f64) {
        if !self.felt.is_empty() {
            let old = self
                .felt
                .partition_point(|e| e.t < now - BODY_IMPACT_HISTORY);
            if old > 0 {
                self.felt.drain(..old);
                self.felt_ticks.drain(..old);
                self.ripples = None;
            }
        }
        if self.derived.is_empty() {
            return;
        }
        let n = self.derived.len();
        let future = self.derived.partition_point(|e| e.t <= now);
        self.derived.truncate(future);
        let old = self
            .derived
            .partition_point(|e| e.t < now - BODY_IMPACT_HISTORY);
        self.derived.drain(..old);
        if self.derived.len() != n {
            self.version += 1;
            self.ripples = None;
        }
    }

    /// One fixed step of `world` by `step_world(world, ripples)`, which must step it once on
    /// `surface`'s sea rippled by `ripples` when given ([`ripple_or_bare`]); then, when
    /// `surface`'s particle layer has `body_impacts`, the impacts the step made (see the module
    /// docs). Every caller that must reach the same bits steps through here.
    ///
    /// # Errors
    /// `step_world`'s error (nothing derived then).
    pub fn step<E>(
        &mut self,
        world: &mut World,
        surface: &Surface,
        step_world: impl FnOnce(&mut World, Option<&Impacts>) -> Result<(), E>,
    ) -> Result<Derived, E> {
        let rules = surface
            .impact_layer()
            .and_then(|l| l.body_impacts().map(|r| (*r, l.ripples().lifetime)));
        // Only worlds that make impacts pay for this copy.
        let before: Vec<(BodyId, super::BodyState, f64)> = match rules {
            Some(_) => world
                .bodies()
                .map(|(id, b)| (id, *b.state(), b.status().submerged))
                .collect(),
            None => Vec::new(),
        };
        let ripples = self.ripples();
        step_world(world, ripples.as_deref())?;
        Ok(match rules {
            Some((rules, lifetime)) => self.derive(world, &rules, lifetime, &before),
            None => Derived::default(),
        })
    }

    /// [`WorldImpacts::step`] on `surface` read with `options`, FFT frames kept in `memo`
    /// between calls: what a world that has no frame cache of its own steps with (a journal
    /// replay, the C ABI).
    ///
    /// # Errors
    /// Invalid `options` (nothing is stepped then).
    pub fn step_memo(
        &mut self,
        world: &mut World,
        surface: &Surface,
        options: &QueryOptions,
        memo: &FrameMemo,
    ) -> Result<Derived, SpecError> {
        self.step(world, surface, |world, ripples| {
            world.step_with(surface, options, |t| {
                surface
                    .at_memo(t, QueryFields::HEIGHT, options, memo)
                    .map(|sea| match ripples {
                        Some(r) => ripple_or_bare(sea, r),
                        None => sea,
                    })
            })
        })
    }

    /// Applies the body-impact rules to the step just taken, in body id order (splash before
    /// wake), within the limits.
    fn derive(
        &mut self,
        world: &World,
        rules: &BodyImpactSpec,
        lifetime: f64,
        before: &[(BodyId, super::BodyState, f64)],
    ) -> Derived {
        let t = world.time();
        let dt = 1.0 / world.settings().tick_hz;
        let mut made = Vec::new();
        for (id, state, submerged) in before {
            let Some(body) = world.body(*id) else {
                continue;
            };
            let step = BodyStep {
                before: *state,
                submerged_before: *submerged,
                after: *body.state(),
                submerged_after: body.status().submerged,
            };
            if let Some(i) = rules.splash(&step, t) {
                made.push(i);
            }
            let travel = self.wake.entry(*id).or_insert(0.0);
            if let Some(i) = rules.wake(&step, dt, travel, t) {
                made.push(i);
            }
        }
        let mut out = Derived::default();
        let mut changed = false;
        self.prune(t);
        for i in made {
            // Off the model's map (|x| > 1e9 m): not an impact it can ripple; dropped, and
            // counted so the caller can say so (the derived set, and so the bits, are as if
            // the body had made none).
            if i.validate("").is_err() {
                out.off_map += 1;
                continue;
            }
            let near = self.derived.len() - self.derived.partition_point(|e| e.t < i.t - lifetime);
            if near >= MAX_BODY_NEAR_IMPACTS {
                out.dropped += 1;
                continue;
            }
            let at = self
                .derived
                .partition_point(|e| e.canonical_cmp(&i).is_le());
            self.derived.insert(at, i);
            if self.fresh.len() >= MAX_BODY_NEAR_IMPACTS {
                self.fresh.remove(0);
            }
            self.fresh.push(i);
            changed = true;
            out.made += 1;
        }
        if self.derived.len() > MAX_BODY_IMPACTS {
            let excess = self.derived.len() - MAX_BODY_IMPACTS;
            self.derived.drain(..excess);
            changed = true;
        }
        if changed {
            self.version += 1;
            self.ripples = None;
        }
        out
    }
}

/// `sea` with the rings of `impacts` alive at its time, or `sea` as it is when more rings are
/// alive at once than the model allows ([`SurfaceAt::with_impacts`]'s error; the limits on API
/// and derived impacts keep that out of reach). The total variant the bodies step with.
pub fn ripple_or_bare<'s>(sea: SurfaceAt<'s>, impacts: &Impacts) -> SurfaceAt<'s> {
    match sea.clone().with_impacts(impacts) {
        Ok(rippled) => rippled,
        Err(_) => sea,
    }
}
