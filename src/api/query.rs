//! Query endpoints over HTTP: height, sample, orientation. Each resolves the scene and its time
//! and runs the transport-free query of [`crate::service::query`], inline when it is cheap, on
//! the compute pool when not ([`run_query`]).

use std::sync::Arc;

use axum::extract::rejection::QueryRejection;
use axum::extract::{Path, Query, State};
use swell_waves::{QueryFields, QueryOptions};

use crate::api::admission::Reserve;
use crate::api::wire::{Accept, Body, Reply, SampleReply};
use crate::error::ApiError;
use crate::service::query::{
    orientation_probes, orientation_request_bytes, resolve_time, run_height, run_orientation,
    run_query, run_sample, runs_inline, sample_request_bytes, sample_request_numbers,
    sample_runs_inline,
};
use crate::service::types::{
    HeightQuery, HeightResponse, OrientationRequest, OrientationResponse, SampleRequest,
};
use crate::state::AppState;

/// `GET /v1/scenes/{id}/height?x=&z=[&t=]`.
pub async fn height(
    State(state): State<AppState>,
    Path(id): Path<String>,
    Accept(format): Accept,
    query: Result<Query<HeightQuery>, QueryRejection>,
) -> Result<Reply<HeightResponse>, ApiError> {
    let entry = state.scene(&id)?;
    let Query(q) = query.map_err(|r| super::errors::query_rejection(&r))?;
    let at = resolve_time(&state, &entry, q.t)?;
    let scene = Arc::clone(&entry.scene);
    let st = state.clone();
    let inline = runs_inline(
        &state.frames,
        &scene,
        at,
        1,
        QueryFields::HEIGHT,
        &QueryOptions::default(),
    );
    run_query(inline, move || {
        run_height(&st.frames, &st.limits, &scene, at, q.x, q.z)
    })
    .await
    .map_err(ApiError::from)
    .map(|r| Reply(format, r))
}

/// `POST /v1/scenes/{id}/sample`.
pub async fn sample(
    State(state): State<AppState>,
    Path(id): Path<String>,
    Accept(format): Accept,
    reserve: Reserve,
    Body(req): Body<SampleRequest>,
) -> Result<SampleReply, ApiError> {
    let entry = state.scene(&id)?;
    // A large JSON answer is encoded as it is sent: only its arrays are held.
    let encoded = if SampleReply::streams(format, sample_request_numbers(&req)) {
        0
    } else {
        format.number_bytes()
    };
    reserve.bytes(sample_request_bytes(&req, encoded))?;
    let at = resolve_time(&state, &entry, req.t)?;
    let scene = Arc::clone(&entry.scene);
    let st = state.clone();
    let inline = sample_runs_inline(&state.frames, &scene, at, &req);
    // A large protobuf answer is encoded here too, off the reactor.
    run_query(inline, move || {
        run_sample(&st.frames, &st.limits, &scene, at, &req)
            .map(|r| SampleReply::prepare(format, r))
    })
    .await
    .map_err(ApiError::from)
}

/// `POST /v1/scenes/{id}/orientation`.
pub async fn orientation(
    State(state): State<AppState>,
    Path(id): Path<String>,
    Accept(format): Accept,
    reserve: Reserve,
    Body(req): Body<OrientationRequest>,
) -> Result<Reply<OrientationResponse>, ApiError> {
    let entry = state.scene(&id)?;
    reserve.bytes(orientation_request_bytes(&req, format.number_bytes()))?;
    let at = resolve_time(&state, &entry, req.t)?;
    let scene = Arc::clone(&entry.scene);
    let st = state.clone();
    let inline = runs_inline(
        &state.frames,
        &scene,
        at,
        orientation_probes(&req),
        QueryFields::HEIGHT,
        &QueryOptions::default(),
    );
    run_query(inline, move || {
        run_orientation(&st.frames, &st.limits, &scene, at, &req)
    })
    .await
    .map_err(ApiError::from)
    .map(|r| Reply(format, r))
}
