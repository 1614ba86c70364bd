//! Driving a scene's body world: the one way both stores change and step it.
//!
//! A change to the bodies is a [`BodyCmd`]. On one process the API applies it at once, under
//! the world's lock ([`crate::state::store::Local`]); in a fleet every replica applies it from the
//! scene's sequenced log at its tick ([`crate::store::bodies`]). Both call [`apply`], so the body
//! limits are checked in one place, and both step the world with [`step`] (the local body loop
//! when the clock crosses a tick boundary, a fleet's follower at each watermark), which mirrors
//! the impacts the bodies made into the scene's set before the states are published.

use serde::{Deserialize, Serialize};

use super::{Advance, BodyError, InputRequest, SceneBodies, Sea, SpawnRequest};
use crate::scene::Scene;

/// A body command as logged.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BodyCmd {
    /// Spawn a body.
    Spawn(SpawnRequest),
    /// Remove body `id`.
    Remove {
        /// Body id.
        id: u64,
    },
    /// Queue an input for body `id`.
    Input {
        /// Body id.
        id: u64,
        /// The input.
        input: InputRequest,
    },
    /// The bodies feel an API impact from this tick on ([`crate::bodies::SceneBodies::feel`]).
    /// Appended with the impact itself ([`crate::store::fleet::Fleet::add_impact`]), only to a scene
    /// that has a body log: a world that does not exist yet has nothing to feel it.
    Impact(swell_waves::particles::Impact),
}

/// Applies `cmd` to the world of scene `scene` (call under its lock): a spawn gives the new
/// body's id.
///
/// # Errors
/// [`BodyError::SceneFull`] for a spawn into a world that holds `max_bodies` already;
/// [`BodyError::NotFound`] for a body that is not there; [`BodyError::Invalid`] or
/// [`BodyError::Rejected`] for a request the body model rejects (nothing changed then).
pub fn apply(
    b: &mut SceneBodies,
    scene: &str,
    cmd: &BodyCmd,
    max_bodies: usize,
) -> Result<Option<u64>, BodyError> {
    match cmd {
        BodyCmd::Spawn(req) => {
            if b.len() >= max_bodies {
                return Err(BodyError::SceneFull {
                    scene: scene.to_owned(),
                    max: max_bodies,
                });
            }
            b.spawn(req).map(Some)
        }
        BodyCmd::Remove { id } => {
            if b.remove(*id) {
                Ok(None)
            } else {
                Err(BodyError::NotFound { id: *id })
            }
        }
        BodyCmd::Input { id, input } => b.input(*id, input).map(|()| None),
        BodyCmd::Impact(impact) => {
            b.feel(*impact);
            Ok(None)
        }
    }
}

/// Steps the world to scene tick `target` on `scene`'s sea, then mirrors the impacts the step
/// made into the scene's set (announced: tick frames carry them), before the caller publishes
/// the states: a tick frame that waited for the states also finds the impacts.
pub fn step(b: &mut SceneBodies, target: i64, sea: Sea<'_>, scene: &Scene) -> Advance {
    let adv = b.advance_to(target, sea, scene.spec.tick_hz, scene.spec.surface.gravity);
    b.sync_impacts(&scene.impacts, true);
    adv
}
