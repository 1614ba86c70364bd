//! The store: where an acknowledged change is made durable, behind one interface.
//!
//! [`AppState`] holds one [`Store`] and never asks which it is:
//!
//! - [`Local`] — the data dir's journal ([`crate::journal`]), or memory only without one: one
//!   process, every change fsynced before its answer, then applied ([`AppState::apply`]). The
//!   embedded default (`swell serve` needs nothing else).
//! - a fleet's Redis ([`crate::store::shared::Shared`]): the change is written to Redis with an
//!   entry of the change feed that every replica applies in feed order, the writer included, and
//!   the writer answers once its own replica has applied it (read-your-writes).
//!
//! Body changes are commands ([`BodyCmd`]) applied by the body driver
//! ([`crate::bodies::drive`]): at once under the world's lock here, at their tick from the
//! scene's sequenced log in a fleet.

use std::fmt::Debug;
use std::sync::Arc;

use futures_util::future::BoxFuture;
use serde_json::{Value, json};
use swell_waves::particles::Impact;

use super::AppState;
use super::StateError;
use super::apply::Prepared;
use crate::bodies::drive::BodyCmd;
use crate::bodies::{BodyState, InputRequest, SpawnRequest, body_not_found};
use crate::journal::Op;
use crate::scene::SceneEntry;
use crate::service::types::{InputAccepted, SpawnedBody};

/// Where acknowledged changes go (see the module docs). Every method is called with the state
/// it changes; admin changes ([`Store::commit`]) with the state's admin lock held.
pub trait Store: Send + Sync + Debug {
    /// Makes an admin change (scene put or delete, clock) durable and applies it
    /// ([`AppState::apply`], with what the caller already `prepared`).
    ///
    /// # Errors
    /// [`StateError::Internal`] if the journal cannot be written;
    /// [`StateError::StoreUnavailable`] when the shared store is unreachable.
    fn commit<'a>(
        &'a self,
        state: &'a AppState,
        op: Op,
        prepared: Prepared,
    ) -> BoxFuture<'a, Result<(), StateError>>;

    /// Adds an API impact to `entry`'s scene, checked against the set's limits with rings
    /// living `lifetime` s; the scene's bodies feel it from their current tick (one process) or
    /// the tick the body log sequences it at (a fleet). Returns that tick, the one every
    /// world that replays the scene's bodies feels it from; `None` when the scene has no body
    /// world (nothing feels it).
    ///
    /// # Errors
    /// [`StateError::TooManyImpacts`] over a limit, [`StateError::ImpactRejected`] for an
    /// impact the model rejects; otherwise as [`Store::commit`].
    fn add_impact<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        impact: Impact,
        lifetime: f64,
    ) -> BoxFuture<'a, Result<Option<i64>, StateError>>;

    /// Spawns a body; its state once applied, with its spawn tick and the world's anchor.
    ///
    /// # Errors
    /// [`StateError::Body`] as [`crate::bodies::drive::apply`]; otherwise as [`Store::commit`].
    fn spawn_body<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        req: SpawnRequest,
    ) -> BoxFuture<'a, Result<SpawnedBody, StateError>>;

    /// Removes body `id`.
    ///
    /// # Errors
    /// [`StateError::Body`] for a body the scene does not have; otherwise as [`Store::commit`].
    fn remove_body<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        id: u64,
    ) -> BoxFuture<'a, Result<(), StateError>>;

    /// Queues an input for body `id`; the tick it was accepted at (local: the world's tick; a
    /// fleet: the tick it applies at) and the tick it acts from.
    ///
    /// # Errors
    /// [`StateError::Body`] for a body the scene does not have or a bad input; otherwise as
    /// [`Store::commit`].
    fn body_input<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        id: u64,
        input: InputRequest,
    ) -> BoxFuture<'a, Result<InputAccepted, StateError>>;

    /// What `/readyz` says of the store.
    fn status(&self, state: &AppState) -> Value;
}

/// The journal of one process (or memory only, without a data dir).
#[derive(Debug, Default)]
pub struct Local;

/// Journals `op` and waits until it is durable (nothing to do without a data dir).
async fn journal_op(state: &AppState, op: Op) -> Result<(), StateError> {
    let Some(j) = state.journal() else {
        return Ok(());
    };
    let seq = j.append(op).map_err(StateError::internal)?;
    j.commit(seq).await.map_err(StateError::internal)
}

/// Waits until the journal holds record `seq` durably: the answer goes out only then.
async fn commit_seq(state: &AppState, seq: u64) -> Result<(), StateError> {
    match state.journal() {
        Some(j) => j.commit(seq).await.map_err(StateError::internal),
        None => Ok(()),
    }
}

/// Journals the body changes just made to `b` (call with its lock held); the seq to commit.
fn journal_events(
    state: &AppState,
    scene: &str,
    b: &mut crate::bodies::SceneBodies,
) -> Result<u64, StateError> {
    crate::journal::snapshot::append_body_events(state.journal(), scene, b)
        .map_err(StateError::internal)
}

/// What a local body command did.
struct Done {
    /// A spawn's new body, as it is right after the spawn.
    spawned: Option<BodyState>,
    /// The world's tick.
    tick: i64,
    /// The world's anchor.
    anchor: i64,
    /// The journal record to commit (the change is made even when journaling failed).
    seq: Result<u64, StateError>,
}

impl Local {
    /// Applies a body command to scene `id`'s world at once, publishes the states (a spawn or
    /// removal) and journals the events, all under the world's lock.
    fn body_cmd(
        state: &AppState,
        cell: &crate::bodies::registry::SceneBodiesCell,
        id: &str,
        cmd: &BodyCmd,
    ) -> Result<Done, StateError> {
        let mut b = cell.lock();
        let out = crate::bodies::drive::apply(&mut b, id, cmd, state.limits.max_scene_bodies)?;
        if matches!(cmd, BodyCmd::Spawn(_) | BodyCmd::Remove { .. }) {
            cell.publish(&b);
        }
        let seq = journal_events(state, id, &mut b);
        let spawned = match out {
            Some(bid) => Some(b.state(bid)?),
            None => None,
        };
        Ok(Done {
            spawned,
            tick: b.tick(),
            anchor: b.anchor(),
            seq,
        })
    }
}

impl Store for Local {
    fn commit<'a>(
        &'a self,
        state: &'a AppState,
        op: Op,
        prepared: Prepared,
    ) -> BoxFuture<'a, Result<(), StateError>> {
        Box::pin(async move {
            journal_op(state, op.clone()).await?;
            state.apply(&op, prepared);
            if matches!(op, Op::SceneDelete { .. }) {
                // The frames and spectra just dropped may be hundreds of MB: give them back now.
                tokio::task::spawn_blocking(|| crate::memory::release_if_held(0));
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
            let id = entry.scene.id.clone();
            // Checked, journaled, felt and applied under one lock, so concurrent adds can
            // neither overshoot the limits nor reach the journal in another order than the set.
            let (seq, felt, body_seq) = {
                let _one = state.impact_lock();
                entry.scene.impacts.check_room(&impact, lifetime)?;
                let logged = Op::Impact {
                    scene: id.clone(),
                    impact,
                    body_tick: None,
                };
                let seq = match state.journal() {
                    Some(j) => j.append(logged).map_err(StateError::internal)?,
                    None => 0,
                };
                // The scene's bodies feel it from their current tick: recorded in their history
                // under their lock, so a replay feels it from the same tick
                // (crate::bodies::SceneBodies::feel). Felt before the set announces it, so the
                // tick frame that carries it carries that tick (`BodyEvent::Impact::at`) too.
                let (felt, body_seq) = match state.bodies.get(&id) {
                    Some(cell) => {
                        let done = Local::body_cmd(state, &cell, &id, &BodyCmd::Impact(impact))?;
                        (Some(done.tick), Some(done.seq))
                    }
                    None => (None, None),
                };
                // The op as journaled, with the tick its frame announces (never logged).
                state.apply(
                    &Op::Impact {
                        scene: id.clone(),
                        impact,
                        body_tick: felt,
                    },
                    Prepared::Nothing,
                );
                (seq, felt, body_seq)
            };
            // A body journal that failed is reported once the set holds the impact, as the
            // journaled op says it does.
            let seq = match body_seq {
                Some(body) => seq.max(body?),
                None => seq,
            };
            commit_seq(state, seq).await?;
            Ok(felt)
        })
    }

    fn spawn_body<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        req: SpawnRequest,
    ) -> BoxFuture<'a, Result<SpawnedBody, StateError>> {
        Box::pin(async move {
            let id = entry.scene.id.as_str();
            let reading = state.read_clock(&entry);
            let cell = state.bodies.get_or_create(
                id,
                reading.tick,
                entry.scene.spec.tick_hz,
                entry.scene.spec.surface.gravity,
            )?;
            let done = Local::body_cmd(state, &cell, id, &BodyCmd::Spawn(req))?;
            // The body is in the world now: step it even if the journal failed (answered with
            // 500).
            super::bodies::ensure_running(state, id, &cell);
            commit_seq(state, done.seq?).await?;
            let out = done
                .spawned
                .ok_or_else(|| StateError::internal("a spawn gave no body id"))?;
            tracing::info!(scene = %id, body = out.id, "body spawned");
            Ok(SpawnedBody {
                state: out,
                spawn_tick: done.tick,
                anchor_tick: done.anchor,
            })
        })
    }

    fn remove_body<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        id: u64,
    ) -> BoxFuture<'a, Result<(), StateError>> {
        Box::pin(async move {
            let scene = entry.scene.id.as_str();
            let cell = state.bodies.get(scene).ok_or_else(|| body_not_found(id))?;
            let done = Local::body_cmd(state, &cell, scene, &BodyCmd::Remove { id })?;
            commit_seq(state, done.seq?).await?;
            tracing::info!(scene = %scene, body = id, "body removed");
            Ok(())
        })
    }

    fn body_input<'a>(
        &'a self,
        state: &'a AppState,
        entry: Arc<SceneEntry>,
        id: u64,
        input: InputRequest,
    ) -> BoxFuture<'a, Result<InputAccepted, StateError>> {
        Box::pin(async move {
            let scene = entry.scene.id.as_str();
            let cell = state.bodies.get(scene).ok_or_else(|| body_not_found(id))?;
            let done = Local::body_cmd(state, &cell, scene, &BodyCmd::Input { id, input })?;
            commit_seq(state, done.seq?).await?;
            // Accepted only if not in the past: it acts from what was asked, or from the
            // world's tick (crate::bodies::SceneBodies::input).
            Ok(InputAccepted {
                tick: done.tick,
                from_tick: input.from_tick.unwrap_or(done.tick),
                ticks: input.ticks.unwrap_or(1),
                anchor_tick: Some(done.anchor),
            })
        })
    }

    fn status(&self, state: &AppState) -> Value {
        match state.journal() {
            Some(_) => json!({"kind": "data_dir"}),
            None => json!({"kind": "memory"}),
        }
    }
}
