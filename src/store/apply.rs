//! Applying an admin change from the shared store to this replica's registry.
//!
//! The same rules as a local admin change ([`crate::state::AppState::put_scene`] and friends)
//! and as the journal's replay: a replaced scene keeps its clock unless the put moves its epoch;
//! a deletion takes the scene's bodies with it; a clock record is anchored at its own Unix time
//! ([`ClockRecord::restore`]), so every replica that applies it reads the same `t` at the same
//! instant, whenever it applied it. An impact joins the scene's set without the API's limits
//! (the replica that accepted it checked them; every replica must hold the same set).

use serde_json::Value;

use crate::journal::Op;
use crate::scene::store::ClockRecord;
use crate::scene::{Scene, SceneSpec};
use crate::state::AppState;

/// Builds the scene of a put (blocking: an FFT layer evaluates its spectrum). `None`, logged,
/// if the spec no longer builds (a model upgrade must not stop a replica from starting).
pub fn build(id: &str, spec: &Value) -> Option<Scene> {
    match SceneSpec::from_value(spec.clone()).and_then(|s| Scene::build(id, s)) {
        Ok(s) => Some(s),
        Err(e) => {
            tracing::error!(scene = %id, error = %e.message, "store: skipping a scene that does not build");
            None
        }
    }
}

/// Puts a built scene, keeping the clock of the scene it replaces unless its epoch moved.
pub fn put(state: &AppState, scene: Scene) {
    let clock = state
        .scene(&scene.id)
        .ok()
        .filter(|e| scene.spec.epoch.is_none() || scene.spec.epoch == e.scene.spec.epoch)
        .map(|e| *e.clock.lock().unwrap_or_else(|p| p.into_inner()));
    state.insert_loaded(scene, clock);
}

/// Removes a scene and its bodies.
pub fn delete(state: &AppState, id: &str) {
    state.remove_loaded(id);
    state.bodies.remove_scene(id);
}

/// Sets a scene's clock from a record (nothing if the scene is unknown here).
pub fn clock(state: &AppState, id: &str, rec: &ClockRecord) {
    if let Ok(entry) = state.scene(id) {
        state.replace_clock(&entry, rec.restore(state.now()));
    }
}

/// Applies an admin op whose scene (for a put) is already built, or needs no building.
pub fn op(state: &AppState, op: &Op, built: Option<Scene>) {
    match op {
        Op::ScenePut { .. } => {
            if let Some(scene) = built {
                put(state, scene);
            }
        }
        Op::SceneDelete { scene } => delete(state, scene),
        Op::Clock { scene, clock: rec } => clock(state, scene, rec),
        Op::Impact { scene, impact } => crate::impacts::restore_into(state, scene, &[*impact]),
        // Body changes go through each scene's sequenced body log (crate::store::bodies).
        Op::Body { .. } => {}
    }
}
