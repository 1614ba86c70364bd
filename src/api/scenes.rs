//! Scene endpoints: list, detail, put, delete, clock.

use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};

use crate::api::json::RawBody;
use crate::error::ApiError;
use crate::scene::SceneEntry;
use crate::scene::clock::ClockReading;
use crate::service::json::from_slice;
use crate::service::types::{ClockUpdate, SceneDetail, SceneList, SceneSummary};
use crate::state::{AppState, PutOutcome};

/// The detail view of a scene.
pub fn detail(state: &AppState, entry: &SceneEntry) -> SceneDetail {
    let s = &entry.scene;
    SceneDetail {
        id: s.id.clone(),
        spec: s.spec.clone(),
        derived: s.derived(),
        model_version: swell_waves::MODEL_VERSION,
        spec_hash: s.spec_hash.clone(),
        clock: state.read_clock(entry),
    }
}

/// `GET /v1/scenes`.
pub async fn list(State(state): State<AppState>) -> axum::Json<SceneList> {
    let scenes = state
        .scenes()
        .iter()
        .map(|e| SceneSummary {
            id: e.scene.id.clone(),
            description: e.scene.spec.description.clone(),
            layers: e
                .scene
                .layer_kinds()
                .into_iter()
                .map(String::from)
                .collect(),
            tick_hz: e.scene.spec.tick_hz,
        })
        .collect();
    axum::Json(SceneList { scenes })
}

/// `GET /v1/scenes/{id}`.
pub async fn get(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<axum::Json<SceneDetail>, ApiError> {
    let entry = state.scene(&id)?;
    Ok(axum::Json(detail(&state, &entry)))
}

/// `PUT /v1/scenes/{id}` (admin): 201 when created, 200 when replaced; the body is the detail.
pub async fn put(
    State(state): State<AppState>,
    Path(id): Path<String>,
    RawBody(body): RawBody,
) -> Result<Response, ApiError> {
    let spec: serde_json::Value = from_slice(&body)?;
    let (outcome, entry) = state.put_scene(&id, spec).await?;
    tracing::info!(scene = %id, ?outcome, hash = %entry.scene.spec_hash, "scene put");
    let status = match outcome {
        PutOutcome::Created => StatusCode::CREATED,
        PutOutcome::Replaced => StatusCode::OK,
    };
    Ok((status, axum::Json(detail(&state, &entry))).into_response())
}

/// `DELETE /v1/scenes/{id}` (admin): 204.
pub async fn delete(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<StatusCode, ApiError> {
    state.delete_scene(&id).await?;
    tracing::info!(scene = %id, "scene deleted");
    Ok(StatusCode::NO_CONTENT)
}

/// `GET /v1/scenes/{id}/clock`.
pub async fn get_clock(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<axum::Json<ClockReading>, ApiError> {
    let entry = state.scene(&id)?;
    Ok(axum::Json(state.read_clock(&entry)))
}

/// `PUT /v1/scenes/{id}/clock` (admin).
pub async fn put_clock(
    State(state): State<AppState>,
    Path(id): Path<String>,
    RawBody(body): RawBody,
) -> Result<axum::Json<ClockReading>, ApiError> {
    let update: ClockUpdate = from_slice(&body)?;
    let reading = state.set_clock(&id, update).await?;
    tracing::info!(scene = %id, t = reading.t, rate = reading.rate, paused = reading.paused, "clock set");
    Ok(axum::Json(reading))
}
