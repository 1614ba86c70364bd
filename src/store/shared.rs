//! A fleet's store: Redis, shared by every replica ([`crate::state::store::Store`]).
//!
//! Admin changes and API impacts go through [`Fleet`] (written with a change-feed entry every
//! replica applies, this one before it answers); body commands through [`FleetBodies`] (the
//! scene's sequenced log, applied by every replica at its tick).

use std::sync::Arc;

use futures_util::future::BoxFuture;
use serde_json::{Value, json};
use swell_waves::particles::Impact;

use super::bodies::FleetBodies;
use super::fleet::Fleet;
use crate::bodies::{InputRequest, SpawnRequest};
use crate::impacts::MAX_SCENE_IMPACTS;
use crate::journal::Op;
use crate::scene::SceneEntry;
use crate::service::types::{InputAccepted, SpawnedBody};
use crate::state::apply::Prepared;
use crate::state::store::Store;
use crate::state::{AppState, StateError};

/// Redis as the store of one replica.
#[derive(Debug, Clone)]
pub struct Shared {
    /// Admin changes, impacts and the change feed.
    pub fleet: Fleet,
    /// Body logs.
    pub bodies: FleetBodies,
}

impl Store for Shared {
    fn commit<'a>(
        &'a self,
        _state: &'a AppState,
        op: Op,
        prepared: Prepared,
    ) -> BoxFuture<'a, Result<(), StateError>> {
        Box::pin(async move {
            // The feed applies it here as on every replica (a put's scene built by the caller
            // is handed over, not rebuilt).
            let built = match prepared {
                Prepared::Scene(s) => Some(*s),
                _ => None,
            };
            let deleted = match &op {
                Op::SceneDelete { scene } => Some(scene.clone()),
                _ => None,
            };
            self.fleet.commit(op, built).await?;
            if let Some(id) = deleted {
                self.fleet.delete_body_log(&id).await;
            }
            Ok(())
        })
    }

    fn add_impact<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        impact: Impact,
        lifetime: f64,
    ) -> BoxFuture<'a, Result<Option<i64>, StateError>> {
        Box::pin(async move {
            // Into the scene's impact list in Redis with the feed entry that makes every
            // replica (this one included, before the answer) add it. The ring-lifetime limit is
            // checked against this replica's set; the total in Redis.
            entry.scene.impacts.check_room(&impact, lifetime)?;
            let wanted = state.read_clock(&entry).tick + 1;
            self.fleet
                .add_impact(&entry.scene.id, impact, MAX_SCENE_IMPACTS, wanted, lifetime)
                .await
        })
    }

    fn spawn_body<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        req: SpawnRequest,
    ) -> BoxFuture<'a, Result<SpawnedBody, StateError>> {
        Box::pin(async move {
            let out = self.bodies.spawn(state, &entry.scene.id, req).await?;
            tracing::info!(scene = %entry.scene.id, body = out.state.id, "body spawned (fleet)");
            Ok(out)
        })
    }

    fn remove_body<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        id: u64,
    ) -> BoxFuture<'a, Result<(), StateError>> {
        Box::pin(async move { self.bodies.remove(state, &entry.scene.id, id).await })
    }

    fn body_input<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        id: u64,
        input: InputRequest,
    ) -> BoxFuture<'a, Result<InputAccepted, StateError>> {
        Box::pin(async move { self.bodies.input(state, &entry.scene.id, id, input).await })
    }

    fn status(&self, _state: &AppState) -> Value {
        json!({
            "kind": "redis",
            "connected": self.fleet.is_connected(),
            // Scenes whose bodies this replica sequences (holds the lease of).
            "sequencing": self.bodies.sequenced(),
        })
    }
}
