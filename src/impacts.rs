//! A scene's impact events: what `POST /v1/scenes/{id}/impacts` adds, the journal keeps and tick
//! frames carry, and what every query of the scene ripples with.
//!
//! The model makes the ripples a pure function of the impact set and t
//! ([`swell_waves::particles`]), so the server only has to agree on the set. It has two parts:
//! - **API impacts**: every accepted one is journaled (an [`crate::journal::Op::Impact`] record,
//!   folded into the snapshot's admin part) before its answer, or in a fleet stored in Redis
//!   with a change-feed entry that every replica applies ([`crate::store::fleet`]); a restart or
//!   a replica rebuilds the same set. Replacing or deleting a scene starts it empty.
//! - **Body impacts**: splashes and wakes the scene's bodies make when its particle layer has
//!   `body_impacts`, derived while they are stepped ([`crate::bodies::SceneBodies`]) and
//!   mirrored here ([`SceneImpacts::sync_bodies`]). They are a pure function of the body log, so
//!   they are never logged: every path that steps the bodies derives them again.
//!
//! The set is held per scene ([`SceneImpacts`], on [`crate::scene::Scene`]); queries see the
//! union of both parts. Bodies feel both too, but from a tick recorded in their own history
//! ([`crate::bodies::SceneBodies::feel`]), so a body's trajectory never depends on when an
//! impact happened to arrive.

use std::collections::VecDeque;
use std::sync::{Arc, RwLock};

use serde::{Deserialize, Serialize};

use swell_waves::SurfaceAt;
use swell_waves::error::SpecError;
use swell_waves::particles::{Impact, Impacts};

/// Most impacts a scene holds (100,000 impacts are a few MB and a replay of milliseconds).
/// Only live ones count: an impact expires once it is more than a ring lifetime older than the
/// newest impact of the set ([`SceneImpacts::set_lifetime`]), so a scene that splashes forever
/// never fills up.
pub const MAX_SCENE_IMPACTS: usize = 100_000;

/// How far ahead of the scene clock's now an impact may be dated, s. Beyond it: 422. A relay
/// schedules splashes a frame or a tick ahead; a minute covers any clock skew and keeps a
/// client from filling the set with events nobody will see for years.
pub const IMPACT_HORIZON_S: f64 = 60.0;
/// Most impacts within one ring lifetime of each other: bounds the rings alive at any time
/// (the model allows 4,096) and so the cost of a snapshot with ripples.
pub const MAX_NEAR_IMPACTS: usize = 1024;

/// Why [`SceneImpacts::add_checked`] refused an impact.
#[derive(Debug, Clone, PartialEq)]
pub enum AddError {
    /// Over a limit (the message says which).
    Full(String),
    /// The model rejected it.
    Invalid(SpecError),
}

/// Recently added impacts kept for the tick loop to put in frames (more than a tick's worth
/// of admin requests can add; one frame carries at most this many).
const RECENT: usize = 1024;

/// An impact as a tick frame and `GET …/impacts` carry it: the event and the tick it applies
/// at (`ceil(t·tick_hz)`, the first tick frame at or after it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ImpactEvent {
    /// First tick at or after the impact.
    pub tick: i64,
    /// In a tick frame, for an API impact on a scene with a body world: the scene tick the
    /// scene's bodies feel it from, the `body_tick` of its POST answer and of `GET …/bodies`
    /// (`felt_impacts`), which a client replaying the bodies feels it at
    /// (`swell_world_feel_impact`). Absent for impacts the bodies made (splashes and wakes: a
    /// client's world derives them itself), on scenes without a body world, in
    /// `GET …/impacts`, and for an impact a fleet replica caught up on after losing the store.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub body_tick: Option<i64>,
    /// Scene time of the impact, s.
    pub t: f64,
    /// World `[x, z]`, m.
    pub position: [f64; 2],
    /// Splash height, m.
    pub strength: f64,
    /// Particle radius, m.
    pub radius: f64,
}

impl ImpactEvent {
    /// The event of `impact` in a scene ticking at `tick_hz`.
    pub fn new(impact: &Impact, tick_hz: f64) -> ImpactEvent {
        ImpactEvent {
            tick: apply_tick(impact.t, tick_hz),
            body_tick: None,
            t: impact.t,
            position: impact.position,
            strength: impact.strength,
            radius: impact.radius,
        }
    }
}

/// The first tick at or after scene time t: `ceil(t·tick_hz)` (saturating).
pub fn apply_tick(t: f64, tick_hz: f64) -> i64 {
    (t * tick_hz).ceil() as i64
}

#[derive(Debug, Default)]
struct Inner {
    /// What queries see: the union of `api` and `bodies`.
    set: Arc<Impacts>,
    /// Impacts accepted through the API (journaled, or shared through the fleet's store).
    api: Arc<Impacts>,
    /// Impacts the scene's bodies made, as [`crate::bodies::SceneBodies`] last derived them.
    bodies: Arc<Impacts>,
    /// The [`crate::bodies::SceneBodies::impacts_version`] `bodies` mirrors.
    body_version: u64,
    /// Impacts added so far (never decreases; numbers [`SceneImpacts::since`]).
    added: u64,
    /// The last [`RECENT`] additions, `(number, impact, body tick)` (the body tick of an API
    /// impact whose writer knew it: [`ImpactEvent::body_tick`]).
    recent: VecDeque<(u64, Impact, Option<i64>)>,
    /// The ring lifetime of the scene's particle layer, s: API impacts older than the newest by
    /// more than this are dropped. `None`: keep all (no particle layer, nothing ripples).
    lifetime: Option<f64>,
}

impl Inner {
    /// Recomputes the union after `api` or `bodies` changed. Both hold at most
    /// [`MAX_SCENE_IMPACTS`] + [`crate::bodies::MAX_BODY_IMPACTS`], far below the model's
    /// limit, so the merge cannot fail; if it did, the API part alone is kept.
    fn remerge(&mut self) {
        self.set = if self.bodies.is_empty() {
            Arc::clone(&self.api)
        } else if self.api.is_empty() {
            Arc::clone(&self.bodies)
        } else {
            match Impacts::merged(&self.api, &self.bodies) {
                Ok(u) => Arc::new(u),
                Err(_) => Arc::clone(&self.api),
            }
        };
    }

    fn announce(&mut self, impact: Impact, body_tick: Option<i64>) {
        self.added += 1;
        let n = self.added;
        self.recent.push_back((n, impact, body_tick));
        if self.recent.len() > RECENT {
            self.recent.pop_front();
        }
    }
}

/// One scene's impacts: those accepted through the API and those its bodies made. Readers
/// clone an `Arc` under a short read lock.
#[derive(Debug, Default)]
pub struct SceneImpacts(RwLock<Inner>);

impl SceneImpacts {
    fn read(&self) -> std::sync::RwLockReadGuard<'_, Inner> {
        // Writers swap whole values: a poisoned lock still holds a consistent state.
        self.0.read().unwrap_or_else(|p| p.into_inner())
    }

    fn write(&self) -> std::sync::RwLockWriteGuard<'_, Inner> {
        self.0.write().unwrap_or_else(|p| p.into_inner())
    }

    /// The current set: API impacts and body impacts together, in canonical order.
    pub fn current(&self) -> Arc<Impacts> {
        Arc::clone(&self.read().set)
    }

    /// The impacts accepted through the API (what the journal or the fleet's store holds).
    pub fn api(&self) -> Arc<Impacts> {
        Arc::clone(&self.read().api)
    }

    /// Impacts added to this set so far (the numbering [`SceneImpacts::since`] uses).
    pub fn added(&self) -> u64 {
        self.read().added
    }

    /// Number of impacts held.
    pub fn len(&self) -> usize {
        self.read().set.len()
    }

    /// Whether none are held.
    pub fn is_empty(&self) -> bool {
        self.read().set.is_empty()
    }

    /// How many impacts of the set have a time within `window` seconds of `t` (the ones whose
    /// rings can be alive together with one at t).
    pub fn near(&self, t: f64, window: f64) -> usize {
        near_in(self.read().set.events(), t, window)
    }

    /// Checks the limits an API impact must fit: fewer than [`MAX_NEAR_IMPACTS`] impacts (API
    /// and body ones) within `window` seconds of its time, fewer than [`MAX_SCENE_IMPACTS`]
    /// API impacts.
    ///
    /// # Errors
    /// [`AddError::Full`] over a limit.
    pub fn check_room(&self, impact: &Impact, window: f64) -> Result<(), AddError> {
        let g = self.read();
        room(&g, impact, window)
    }

    /// Adds an API impact unless that would break a limit of [`SceneImpacts::check_room`]
    /// (checked and added under one lock, so concurrent adds cannot overshoot).
    ///
    /// # Errors
    /// [`AddError::Full`] over a limit; [`AddError::Invalid`] for an impact the model rejects.
    pub fn add_checked(&self, impact: Impact, window: f64) -> Result<(), AddError> {
        let mut g = self.write();
        room(&g, &impact, window)?;
        Self::push(&mut g, impact, None).map_err(AddError::Invalid)
    }

    /// Adds an API impact (replaying the journal, or applying the fleet's feed: no limits, it
    /// was accepted once), announced to tick frames with `body_tick`, the scene tick its
    /// bodies feel it from where known ([`ImpactEvent::body_tick`]).
    ///
    /// # Errors
    /// The model's: an invalid impact or a full set.
    pub fn add(&self, impact: Impact, body_tick: Option<i64>) -> Result<(), SpecError> {
        Self::push(&mut self.write(), impact, body_tick)
    }

    /// Sets the ring lifetime that expires API impacts (at scene build).
    pub fn set_lifetime(&self, lifetime: f64) {
        self.write().lifetime = Some(lifetime);
    }

    fn push(g: &mut Inner, impact: Impact, body_tick: Option<i64>) -> Result<(), SpecError> {
        let with = g.api.with(impact)?;
        g.api = Arc::new(expire(with, g.lifetime));
        g.remerge();
        g.announce(impact, body_tick);
        Ok(())
    }

    /// Mirrors the impacts a scene's bodies derived ([`crate::bodies::SceneBodies::sync_impacts`]
    /// calls it under the world's lock, after stepping and before publishing its states, so a
    /// tick frame that waited for the states also finds the impacts): `fresh`, the ones made
    /// since the last call, are numbered as new (tick frames carry them) when `announce`; a
    /// restore passes false. `derived` (all of them) is asked for only when `version` moved.
    /// Cheap when nothing changed.
    pub fn sync_bodies(
        &self,
        fresh: Vec<Impact>,
        version: u64,
        derived: impl FnOnce() -> Impacts,
        announce: bool,
    ) {
        if version == self.read().body_version && fresh.is_empty() {
            return;
        }
        let derived = Arc::new(derived());
        let mut g = self.write();
        g.bodies = derived;
        g.body_version = version;
        g.remerge();
        if announce {
            // Body-derived: no body tick (a client's world derives them itself).
            for i in fresh {
                g.announce(i, None);
            }
        }
    }

    /// The impacts added after addition number `seen` (oldest first, at most the last 1,024),
    /// each with its body tick ([`ImpactEvent::body_tick`]), and the number of the latest
    /// addition: a tick loop passes back what it got to see only new ones next time.
    pub fn since(&self, seen: u64) -> (u64, Vec<(Impact, Option<i64>)>) {
        let g = self.read();
        let new = g
            .recent
            .iter()
            .filter(|(n, _, _)| *n > seen)
            .map(|(_, i, b)| (*i, *b))
            .collect();
        (g.added, new)
    }

    /// `sea` with this set's ripples ([`SurfaceAt::with_impacts`]); unchanged when the set is
    /// empty (no cost for scenes that never had an impact).
    ///
    /// # Errors
    /// `sea`'s error, or more rings alive at its time than the model allows.
    pub fn apply<'s>(
        &self,
        sea: Result<SurfaceAt<'s>, SpecError>,
    ) -> Result<SurfaceAt<'s>, SpecError> {
        let sea = sea?;
        let set = self.current();
        if set.is_empty() {
            return Ok(sea);
        }
        sea.with_impacts(&set)
    }
}

/// `set` without the impacts that are more than `lifetime` older than its newest one: their
/// rings are dead at the newest impact's time and at every later one. A pure function of the
/// set, so every replica and every replay of the same adds holds the same impacts. (Queries of
/// times before the newest impact by more than a lifetime no longer see the expired rings.)
fn expire(set: Impacts, lifetime: Option<f64>) -> Impacts {
    let Some(lifetime) = lifetime else {
        return set;
    };
    let events = set.events();
    // Canonical order is by t first: the newest is the last.
    let Some(newest) = events.last().map(|e| e.t) else {
        return set;
    };
    let keep_from = newest - lifetime;
    if events.iter().all(|e| e.t >= keep_from) {
        return set;
    }
    let kept: Vec<Impact> = events
        .iter()
        .filter(|e| e.t >= keep_from)
        .copied()
        .collect();
    // A subset of a valid set is valid.
    Impacts::from_events(kept).unwrap_or(set)
}

/// How many of `events` (canonical order) lie within `window` seconds of `t`.
fn near_in(events: &[Impact], t: f64, window: f64) -> usize {
    let lo = events.partition_point(|e| e.t < t - window);
    let hi = events.partition_point(|e| e.t <= t + window);
    hi.saturating_sub(lo)
}

fn room(g: &Inner, impact: &Impact, window: f64) -> Result<(), AddError> {
    // (Canonical order is by t first: the newest is the last event.)
    // An impact the set would expire at once (more than a lifetime older than its newest, as
    // after a clock seek backwards past the scene's splashes) is refused, not dropped unseen.
    if let Some(lifetime) = g.lifetime
        && let Some(newest) = g.api.events().last().map(|e| e.t)
        && impact.t < newest - lifetime
    {
        return Err(AddError::Invalid(SpecError::OutOfRange {
            field: "t".into(),
            value: impact.t,
            allowed: format!(
                ">= {}: the scene's newest impact is at t = {newest}, and impacts more than a \
                 ring lifetime ({lifetime} s) older than the newest have expired (replace the \
                 scene to start its impacts afresh)",
                newest - lifetime
            ),
        }));
    }
    let near = near_in(g.set.events(), impact.t, window);
    if near >= MAX_NEAR_IMPACTS {
        return Err(AddError::Full(format!(
            "{near} impacts already lie within {window} s (a ring's lifetime) of t = {}: at most \
             {MAX_NEAR_IMPACTS} may",
            impact.t
        )));
    }
    if g.api.len() >= MAX_SCENE_IMPACTS {
        return Err(AddError::Full(format!(
            "the scene holds {} impacts, the limit",
            g.api.len()
        )));
    }
    Ok(())
}

/// The impacts of `new` that `old` does not hold (both canonical; duplicates counted).
pub fn missing(old: &[Impact], new: &[Impact]) -> Vec<Impact> {
    let mut out = Vec::new();
    let mut i = 0;
    for n in new {
        while i < old.len() && old[i].canonical_cmp(n).is_lt() {
            i += 1;
        }
        if i < old.len() && old[i].canonical_cmp(n).is_eq() {
            i += 1;
        } else {
            out.push(*n);
        }
    }
    out
}

/// The impacts a scene's next tick frame carries: those added since `seen`, which is moved on,
/// each API one with the tick the scene's bodies feel it from where known.
/// A replaced scene starts its numbering afresh, so a number above the scene's count means
/// "from the start".
pub fn frame_events(scene: &crate::scene::Scene, seen: &mut u64) -> Vec<ImpactEvent> {
    let (latest, new) = scene.impacts.since(if *seen > scene.impacts.added() {
        0
    } else {
        *seen
    });
    *seen = latest;
    new.iter()
        .map(|(i, body_tick)| ImpactEvent {
            body_tick: *body_tick,
            ..ImpactEvent::new(i, scene.spec.tick_hz)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn impact(t: f64) -> Impact {
        Impact {
            t,
            position: [1.5, -2.25],
            strength: 0.4,
            radius: 0.6,
        }
    }

    #[test]
    fn since_returns_each_addition_once_and_limits_hold() {
        let s = SceneImpacts::default();
        let (seen, none) = s.since(0);
        assert!(none.is_empty());
        s.add_checked(impact(1.0), 60.0).unwrap();
        s.add_checked(impact(2.0), 60.0).unwrap();
        let (seen2, new) = s.since(seen);
        assert_eq!(new.len(), 2);
        assert_eq!(s.since(seen2).1.len(), 0);
        for k in 0..(MAX_NEAR_IMPACTS - 2) {
            s.add_checked(impact(3.0 + k as f64 * 1e-3), 60.0).unwrap();
        }
        assert!(matches!(
            s.add_checked(impact(5.0), 60.0),
            Err(AddError::Full(_))
        ));
        // Far enough away in time, it fits.
        s.add_checked(impact(500.0), 60.0).unwrap();
    }
}
