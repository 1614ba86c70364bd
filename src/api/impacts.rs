//! Impact endpoints: `POST /v1/scenes/{id}/impacts` (game) adds a splash that ripples on the
//! scene's particle layer; `GET /v1/scenes/{id}/impacts` lists the impacts that can still be
//! rippling. The set itself is [`crate::impacts`].

use axum::extract::{Path, Query, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use swell_waves::particles::Impact;

use crate::api::json::RawBody;
use crate::error::{ApiError, ErrorCode};
use crate::impacts::{IMPACT_HORIZON_S, ImpactEvent, apply_tick};
use crate::service::json::from_slice;
use crate::state::AppState;

/// `POST /v1/scenes/{id}/impacts` body.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImpactRequest {
    /// World `[x, z]`, m.
    pub position: [f64; 2],
    /// Scene time of the impact, s. Default: the start of the scene's next tick, so every
    /// subscriber gets it in a frame before it starts rippling.
    #[serde(default)]
    pub t: Option<f64>,
    /// Splash height at the impact point, m, in (0, 100].
    pub strength: f64,
    /// Particle radius of the ring, m, in [0.01, 1000].
    pub radius: f64,
}

/// `POST /v1/scenes/{id}/impacts` answer (202).
#[derive(Debug, Clone, Serialize)]
pub struct ImpactAccepted {
    /// The first tick at or after the impact: `ceil(t·tick_hz)`. Its frame carries the event.
    pub tick: i64,
    /// Scene time of the impact, s.
    pub t: f64,
    /// Scene tick the scene's body world feels it from (it reached the world at that tick:
    /// on one process the tick the bodies were at, in a fleet the tick the body log sequenced
    /// it at, which every replica applies it at). A client replaying the bodies feels it at
    /// this tick (`swell_world_feel_impact`). Absent when the scene has no body world.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body_tick: Option<i64>,
}

/// `POST /v1/scenes/{id}/impacts` (game): validates, adds to the scene's set, journals (durable
/// before the answer), 202 `{"tick","t","body_tick"?}`. In a fleet the impact is stored in Redis instead and
/// applied by every replica from the change feed (this one before it answers).
///
/// # Errors
/// 400 `invalid_value` naming the field (`t` beyond `limits.max_time` too, which is where a
/// clock held at that limit puts the default next tick); 422 `invalid_spec` for a scene without a particle
/// layer; 409 `too_many_impacts` over a limit; 404 for an unknown scene; 503
/// `store_unavailable` in a fleet whose Redis is unreachable.
pub async fn create(
    State(state): State<AppState>,
    Path(id): Path<String>,
    RawBody(body): RawBody,
) -> Result<Response, ApiError> {
    let req: ImpactRequest = from_slice(&body)?;
    let entry = state.scene(&id)?;
    let scene = &entry.scene;
    let Some(layer) = scene.surface.impact_layer() else {
        return Err(ApiError::new(ErrorCode::InvalidSpec, format!("scene {id} has no particle layer: impacts ripple on one (add {{\"kind\": \"particles\"}} to its layers)"),
        )
        .with_field("layers"));
    };
    let hz = scene.spec.tick_hz;
    let t = match req.t {
        Some(t) => t,
        None => (state.read_clock(&entry).tick + 1) as f64 / hz,
    };
    // Every client time is bounded by `max_time`, an impact's too (the list refuses a t past
    // it): a clock held at the limit has no next tick to splash at.
    let t = state.limits.check_time(t, "t")?;
    // Where queries may look (the model's own bound, checked next, is wider than a server
    // configured with a smaller `max_coordinate`): a splash beyond it could never be seen.
    for (i, &v) in req.position.iter().enumerate() {
        crate::service::query::check_coord(&state.limits, v, || format!("position[{i}]"))?;
    }
    let impact = Impact {
        t,
        position: req.position,
        strength: req.strength,
        radius: req.radius,
    };
    impact
        .validate("")
        .map_err(|e| ApiError::invalid(e.field(), e.to_string()))?;
    // Only impacts whose rings can still be seen, or will be soon: not the distant past (the
    // ring would be dead on arrival) nor the distant future (it would sit in the set for ever).
    let now = state.read_clock(&entry).t;
    let lifetime = layer.ripples().lifetime;
    if !(t >= now - lifetime && t <= now + IMPACT_HORIZON_S) {
        return Err(ApiError::new(ErrorCode::ImpactOutOfWindow, format!(
                "t = {t} is outside [now - lifetime, now + {IMPACT_HORIZON_S}] = [{}, {}] of this scene's clock",
                now - lifetime,
                now + IMPACT_HORIZON_S
            ),
        )
        .with_field("t"));
    }
    let body_tick = state.add_impact(entry.clone(), impact, lifetime).await?;
    metrics::counter!("swell_impacts_total").increment(1);
    Ok((
        StatusCode::ACCEPTED,
        axum::Json(ImpactAccepted {
            tick: apply_tick(t, hz),
            t,
            body_tick,
        }),
    )
        .into_response())
}

/// `GET /v1/scenes/{id}/impacts` query.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ListQuery {
    /// Scene time, s (default: the clock's now).
    pub t: Option<f64>,
}

/// `GET /v1/scenes/{id}/impacts` answer: every impact that can be rippling at t or later
/// (`t0 ≥ t − lifetime`), in canonical order: what a client joining a stream needs.
#[derive(Debug, Clone, Serialize)]
pub struct ImpactList {
    /// The time asked about, s.
    pub t: f64,
    /// The impacts.
    pub impacts: Vec<ImpactEvent>,
}

/// `GET /v1/scenes/{id}/impacts[?t=]`.
///
/// # Errors
/// 404 for an unknown scene; 400 for a t that is not finite or beyond `limits.max_time`, or a
/// query string that cannot be read.
pub async fn list(
    State(state): State<AppState>,
    Path(id): Path<String>,
    q: Result<Query<ListQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<axum::Json<ImpactList>, ApiError> {
    let entry = state.scene(&id)?;
    let Query(q) = q.map_err(|r| super::errors::query_rejection(&r))?;
    let t = match q.t {
        Some(t) => state.limits.check_time(t, "t")?,
        None => state.read_clock(&entry).t,
    };
    let scene = &entry.scene;
    let lifetime = scene
        .surface
        .impact_layer()
        .map_or(0.0, |l| l.ripples().lifetime);
    let set = scene.impacts.current();
    let ev = set.events();
    let from = ev.partition_point(|e| e.t < t - lifetime);
    Ok(axum::Json(ImpactList {
        t,
        impacts: ev[from..]
            .iter()
            .map(|i| ImpactEvent::new(i, scene.spec.tick_hz))
            .collect(),
    }))
}
