//! What the journal keeps of a scene's bodies: the changes ([`BodyEvent`]) and whole-world
//! snapshots ([`WorldRecord`]), and how a world is rebuilt from them.
//!
//! A body world's state at a tick is a pure function of where it started and of its events in
//! order (see [`crate::bodies`]): between two events the world only takes fixed steps. Every
//! event therefore records `at`, the scene tick the world was at when the change was made;
//! replaying steps the world to `at` first, then applies the change. Re-anchoring (a clock jump,
//! or a loop that fell too far behind) is an event too, so a replayed world jumps exactly where
//! the live one did and continues the same trajectory, to the bit.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

use swell_waves::body::{BodyInput, BodySpec, BodyStatus, World};

use super::{SceneBodies, settings};

/// One change to a scene's body world, in the order it was made.
///
/// Serialised externally tagged (`{"spawned": {...}}`): no buffering of numbers through serde's
/// internal-tag machinery, so every f64 round-trips exactly.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BodyEvent {
    /// The scene's empty world was made, anchored at scene tick `anchor`.
    Created {
        /// Scene tick of world tick 0.
        anchor: i64,
        /// The scene's tick rate, Hz.
        tick_hz: f64,
        /// The scene's gravity, m/s².
        gravity: f64,
    },
    /// A body was added.
    Spawned {
        /// Scene tick of the world when it was added.
        at: i64,
        /// Its id.
        id: u64,
        /// Its spec, defaults filled in (so a change of server defaults cannot change a replay).
        spec: BodySpec,
        /// Its initial state.
        state: swell_waves::body::BodyState,
    },
    /// A body was removed.
    Removed {
        /// Scene tick of the world when it was removed.
        at: i64,
        /// Its id.
        id: u64,
    },
    /// An input was queued.
    Input {
        /// Scene tick of the world when it was queued.
        at: i64,
        /// The input, `from_tick` relative to the world's anchor (as the world holds it).
        input: BodyInput,
    },
    /// The bodies feel an API impact from scene tick `at` on ([`SceneBodies::feel`]).
    Impact {
        /// Scene tick of the world when it reached it.
        at: i64,
        /// The impact.
        impact: swell_waves::particles::Impact,
    },
    /// The world was re-anchored from scene tick `at` to `to` (a clock jump or a settings
    /// change), keeping every body's state and the rest of its inputs.
    Reanchored {
        /// Scene tick of the world before the jump.
        at: i64,
        /// Scene tick after it.
        to: i64,
        /// The scene's tick rate after it, Hz.
        tick_hz: f64,
        /// The scene's gravity after it, m/s².
        gravity: f64,
    },
}

/// A whole body world, exactly: enough to continue its trajectory to the bit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorldRecord {
    /// Scene tick of world tick 0.
    pub anchor: i64,
    /// Scene tick the states are at.
    pub tick: i64,
    /// Tick rate, Hz.
    pub tick_hz: f64,
    /// Gravity, m/s².
    pub gravity: f64,
    /// The id the next spawned body gets.
    pub next_id: u64,
    /// Bodies in id order.
    pub bodies: Vec<super::BodyRecord>,
    /// Inputs not over yet, per body in id order, each in the order given.
    pub inputs: Vec<BodyInput>,
    /// What each body's last step measured (reported until its next step), by id.
    #[serde(default)]
    pub statuses: BTreeMap<u64, BodyStatus>,
    /// The impacts the bodies made that are still kept (derived state, like the states: a
    /// world rebuilt from this record ripples the same sea as the one it was taken from).
    #[serde(default)]
    pub impacts: Vec<swell_waves::particles::Impact>,
    /// Per body, the distance travelled since its last wake impact, m.
    #[serde(default)]
    pub wake: BTreeMap<u64, f64>,
    /// The API impacts the bodies feel ([`SceneBodies::felt_impacts`]).
    #[serde(default)]
    pub felt: Vec<swell_waves::particles::Impact>,
    /// The scene tick each of `felt` reached the world at, index for index
    /// ([`SceneBodies::felt_impact_ticks`]; absent in records written before they were kept:
    /// those ticks are not published).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub felt_ticks: Vec<Option<i64>>,
    /// Per body, where its next tick starts the hull cells' height inversions
    /// ([`swell_waves::body::Body::warm_start`]; absent in records written before they carried
    /// over between ticks: those bodies start cold once).
    #[serde(default)]
    pub warm: BTreeMap<u64, swell_waves::body::WarmStart>,
    /// Per body, where its trajectory in this world starts ([`super::Origin`]; absent in
    /// records written before it was kept: those bodies' spawn ticks are not published).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub origins: BTreeMap<u64, super::Origin>,
}

/// Most ticks a replay steps between two events (or from the last event to the clock at
/// start-up) before it re-anchors instead: an hour at 30 Hz. Only a corrupt record or a
/// server that was down for longer needs more, and stepping that far would hold up the start.
pub const MAX_REPLAY_STEPS: i64 = 108_000;

impl SceneBodies {
    /// Takes the changes made since the last call, oldest first (the caller journals them while
    /// it still holds the world's lock, so the journal's order is the world's order).
    pub fn take_events(&mut self) -> Vec<BodyEvent> {
        std::mem::take(&mut self.events)
    }

    /// The whole world, for a snapshot.
    pub fn world_record(&self) -> WorldRecord {
        let rec = self.record();
        WorldRecord {
            anchor: self.anchor,
            tick: rec.tick,
            tick_hz: self.tick_hz,
            gravity: self.gravity,
            next_id: self.world.next_id(),
            bodies: rec.bodies,
            inputs: self.world.inputs().copied().collect(),
            statuses: self
                .world
                .bodies()
                .map(|(id, b)| (id, *b.status()))
                .collect(),
            impacts: self.impacts.derived().to_vec(),
            wake: self.impacts.wake().clone(),
            felt: self.impacts.felt().to_vec(),
            felt_ticks: self.impacts.felt_ticks().to_vec(),
            warm: self
                .world
                .bodies()
                .filter_map(|(id, b)| Some((id, b.warm_start()?)))
                .collect(),
            origins: self.origins.clone(),
        }
    }

    /// Rebuilds a world from a snapshot. Bodies or inputs the model no longer accepts are
    /// skipped and logged.
    ///
    /// # Errors
    /// Settings the model rejects, as a message.
    pub fn from_world_record(rec: &WorldRecord) -> Result<SceneBodies, String> {
        if rec.tick < rec.anchor {
            return Err(format!(
                "tick {} is before the anchor {}",
                rec.tick, rec.anchor
            ));
        }
        let world = World::resume(
            settings(rec.anchor, rec.tick_hz, rec.gravity),
            (rec.tick - rec.anchor) as u64,
            rec.next_id,
        )
        .map_err(|e| e.to_string())?;
        let mut b = SceneBodies {
            world,
            specs: Default::default(),
            anchor: rec.anchor,
            tick_hz: rec.tick_hz,
            gravity: rec.gravity,
            events: Vec::new(),
            // Kept only where it validates: a damaged record cannot put an impact the model
            // rejects into a scene.
            impacts: swell_waves::body::WorldImpacts::restore(
                &rec.felt,
                &rec.felt_ticks,
                &rec.impacts,
                &rec.wake,
                |id| rec.bodies.iter().any(|r| r.id == id),
            ),
            origins: BTreeMap::new(),
            created_seq: 0,
        };
        for r in &rec.bodies {
            let status = rec.statuses.get(&r.id).copied().unwrap_or_default();
            match b
                .world
                .restore_body(r.id, &r.spec, r.state, status, rec.warm.get(&r.id))
            {
                Ok(()) => {
                    b.specs.insert(r.id, r.spec.clone());
                    if let Some(o) = rec.origins.get(&r.id) {
                        b.origins.insert(r.id, o.clone());
                    }
                }
                Err(e) => tracing::error!(body = r.id, error = %e, "snapshot: skipping a body"),
            }
        }
        for i in &rec.inputs {
            if let Err(e) = b.world.input(*i) {
                tracing::error!(body = i.body, error = %e, "snapshot: skipping an input");
            }
        }
        Ok(b)
    }

    /// Rebuilds a world from its `Created` event.
    ///
    /// # Errors
    /// Any other event, or settings the model rejects, as a message.
    pub fn from_created(ev: &BodyEvent) -> Result<SceneBodies, String> {
        match *ev {
            BodyEvent::Created {
                anchor,
                tick_hz,
                gravity,
            } => {
                let mut b =
                    SceneBodies::new(anchor, tick_hz, gravity).map_err(|e| e.to_string())?;
                b.events.clear();
                Ok(b)
            }
            _ => Err("a body world's first event must be `created`".into()),
        }
    }

    /// Steps to scene tick `target` with fixed steps only (a replay: the live world got there
    /// the same way, or a `Reanchored` event would say otherwise). A target behind the world or
    /// more than [`MAX_REPLAY_STEPS`] ahead can only come from a damaged journal or a long
    /// downtime: the world is re-anchored there instead (and the event kept for the journal).
    /// Returns whether it re-anchored.
    pub fn step_to(&mut self, target: i64, surface: &swell_waves::Surface) -> bool {
        let now = self.tick();
        if target == now {
            return false;
        }
        if target < now || target - now > MAX_REPLAY_STEPS {
            let (hz, g) = (self.tick_hz, self.gravity);
            self.reanchor(target, hz, g);
            return true;
        }
        let options = super::step_options();
        let memo = swell_waves::FrameMemo::new();
        while self.tick() < target {
            if !self.step_once(super::Sea::Memo(surface, &memo), &options) {
                break;
            }
        }
        self.world.prune_inputs();
        false
    }

    /// Replays one event: steps to its tick on `surface`, then applies it. Events that no longer
    /// apply (an unknown body) are skipped and logged. `Created` is handled by the caller
    /// ([`SceneBodies::from_created`]).
    pub fn replay(&mut self, ev: &BodyEvent, surface: &swell_waves::Surface) {
        let at = match ev {
            BodyEvent::Created { .. } => return,
            BodyEvent::Spawned { at, .. }
            | BodyEvent::Removed { at, .. }
            | BodyEvent::Input { at, .. }
            | BodyEvent::Impact { at, .. }
            | BodyEvent::Reanchored { at, .. } => *at,
        };
        if self.step_to(at, surface) {
            tracing::warn!(
                tick = at,
                "replay: the journal jumps; bodies re-anchored there"
            );
        }
        match ev {
            BodyEvent::Spawned {
                at,
                id,
                spec,
                state,
            } => match self.world.insert(*id, spec, *state) {
                Ok(()) => {
                    self.specs.insert(*id, spec.clone());
                    self.spawned(*id, *at);
                }
                Err(e) => tracing::error!(body = id, error = %e, "replay: skipping a spawn"),
            },
            BodyEvent::Removed { id, .. } => {
                self.specs.remove(id);
                self.impacts.forget(*id);
                self.origins.remove(id);
                self.world.remove(*id);
            }
            BodyEvent::Input { input, .. } => {
                if let Err(e) = self.world.input(*input) {
                    tracing::error!(body = input.body, error = %e, "replay: skipping an input");
                }
            }
            BodyEvent::Impact { at, impact } => {
                if !self.feel_quietly(*impact, *at) {
                    tracing::error!("replay: skipping an impact the model rejects");
                }
            }
            BodyEvent::Reanchored {
                to,
                tick_hz,
                gravity,
                ..
            } => self.reanchor(*to, *tick_hz, *gravity),
            BodyEvent::Created { .. } => {}
        }
        // What replaying did is already in the journal.
        self.events.clear();
    }
}
