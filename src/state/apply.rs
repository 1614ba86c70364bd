//! The reducer: the one function that applies an acknowledged change ([`Op`]) to the registry.
//!
//! Every path that changes scenes, clocks or a scene's impact set calls [`AppState::apply`]: a
//! local write once its op is durable ([`super::store::Local`]), the journal's replay at start-up
//! ([`super::restore`]) and a fleet's change feed on every replica, the writer included
//! ([`crate::store::shared`]), and its re-read of Redis after a reconnect (the scenes, clocks and
//! impacts that differ, as ops: [`crate::store::fleet::resync_impacts`]). So the three cannot drift apart (the shape of a replicated state
//! machine: one log, one `apply`). The rules:
//!
//! - a put replaces the scene; the replaced scene's clock stays unless the put moves its epoch
//!   (a new scene's spec always carries one, filled in when it was created), and then the clock
//!   is the fresh one the op records, one generation on ([`Op::ScenePut`]'s `clock`); its
//!   impacts start empty (a new [`crate::impacts::SceneImpacts`]) and its FFT frames are
//!   dropped;
//! - a delete takes the scene's clock, frames and bodies with it;
//! - a clock record is anchored at its own Unix time ([`ClockRecord::restore`]), so every process
//!   that applies it reads the same `t` at the same instant, whenever it applied it;
//! - an impact joins the scene's set without the API's limits (the process that accepted it
//!   checked them; every replay and replica must hold the same set), announced to tick frames
//!   with the tick the scene's bodies feel it from when the op carries one;
//! - an op on a scene this process does not hold changes nothing (its other records are gone
//!   with it).
//!
//! Body events are not applied here: a scene's body world is a deterministic function of its own
//! log, applied by the body world itself ([`crate::bodies::SceneBodies::replay`] on replay, the
//! body driver live: [`super::bodies`], [`crate::store::bodies`]).
//!
//! [`ClockRecord::restore`]: crate::scene::store::ClockRecord::restore

use serde_json::Value;

use super::AppState;
use crate::journal::Op;
use crate::scene::store::ClockRecord;
use crate::scene::{Clock, Scene, SceneSpec};

/// What the process that accepted an op already made of it, handed to [`AppState::apply`] so
/// it is not made twice.
#[derive(Debug, Default)]
pub enum Prepared {
    /// Nothing: `apply` makes what it needs from the op (builds a put's scene, anchors a clock
    /// record at its Unix time).
    #[default]
    Nothing,
    /// A put's scene, built from the op's spec.
    Scene(Box<Scene>),
    /// A clock change as the writer computed it (the record's reading anchored where the
    /// writer's clock was: the same `t` at every instant, to the bit of the live clock).
    Clock(Clock),
}

/// Builds the scene of a put (blocking: an FFT layer evaluates its spectrum). `None`, logged, if
/// the spec no longer builds: a model upgrade must not stop a server or a replica from starting.
pub fn build(id: &str, spec: &Value) -> Option<Scene> {
    match SceneSpec::from_value(spec.clone()).and_then(|s| Scene::build(id, s)) {
        Ok(s) => Some(s),
        Err(e) => {
            tracing::error!(scene = %id, error = %e, "skipping a scene that does not build");
            None
        }
    }
}

impl AppState {
    /// Applies `op` to the registry (see the module docs). Blocking only when a put's scene must
    /// be built here (`prepared` is not [`Prepared::Scene`]): callers on the reactor build it
    /// first.
    pub fn apply(&self, op: &Op, prepared: Prepared) {
        match op {
            Op::ScenePut {
                scene: id,
                spec,
                clock,
            } => {
                let scene = match prepared {
                    Prepared::Scene(s) => Some(*s),
                    _ => build(id, spec),
                };
                if let Some(scene) = scene {
                    self.put_built(scene, clock.as_ref());
                }
            }
            Op::SceneDelete { scene } => {
                self.remove_loaded(scene);
                self.bodies.remove_scene(scene);
            }
            Op::Clock { scene, clock: rec } => {
                if let Ok(entry) = self.scene(scene) {
                    let clock = match prepared {
                        Prepared::Clock(c) => c,
                        _ => rec.restore(self.now()),
                    };
                    self.replace_clock(&entry, clock);
                }
            }
            Op::Impact {
                scene,
                impact,
                body_tick,
            } => {
                if let Ok(entry) = self.scene(scene)
                    && let Err(e) = entry.scene.impacts.add(*impact, *body_tick)
                {
                    tracing::error!(scene = %scene, error = %e, "skipping an impact");
                }
            }
            // A body world applies its own log (see the module docs).
            Op::Body { .. } => {}
        }
    }

    /// Puts a built scene, keeping the clock of the scene it replaces unless its epoch moved.
    /// A moved epoch starts the clock afresh, one generation on: from `record`, the clock the
    /// accepting process recorded with the put, so every process that applies it holds the same
    /// clock whatever it held before. It is a clock change like an admin's: stream sessions of
    /// the scene are told ([`AppState::announce_clock_change`]), on every process that applies
    /// the put. So is a put that creates the scene (generation 0): a session that outlived the
    /// scene's delete (one not following ticks stays open) would otherwise go on with the
    /// deleted clock's fit, and a client at a later generation would take every pong of the new
    /// clock, generation 0, for one sent before a change and drop it.
    fn put_built(&self, scene: Scene, record: Option<&ClockRecord>) {
        let before = self.scene(&scene.id).ok().map(|e| {
            let clock = *e.clock.lock().unwrap_or_else(|p| p.into_inner());
            (clock, e.scene.spec.epoch)
        });
        let created = before.is_none();
        let (clock, moved) = match (record, before) {
            (Some(rec), before) => (Some(rec.restore(self.now())), before.is_some()),
            // A moved epoch without a record: a put journaled before puts carried one, or the
            // scene as a re-read of a fleet's store or a snapshot gives it (the clock's own
            // record follows and replaces this one). Fresh, one generation on, all the same.
            (None, Some((old, epoch))) => match scene.spec.epoch {
                Some(new) if Some(new) != epoch => (Some(old.restarted_from(new)), true),
                _ => (Some(old), false),
            },
            (None, None) => (None, false),
        };
        let id = scene.id.clone();
        self.insert_loaded(scene, clock);
        if moved || created {
            self.announce_clock_change(&id);
        }
    }
}
