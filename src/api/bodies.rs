//! Floating-body endpoints: spawn, list, read, delete, input. The simulation itself is in
//! [`crate::bodies`]; its loop starts when a scene gets its first body.

use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde::Serialize;

use crate::api::json::RawBody;
use crate::bodies::{InputRequest, SceneBodies, SpawnRequest, body_not_found};
use crate::error::ApiError;
use crate::service::json::from_slice;
use crate::service::types::{BodyDescription, HullExtent};
use crate::state::AppState;

/// `GET /v1/scenes/{id}/bodies` answer.
#[derive(Debug, Clone, Serialize)]
pub struct BodiesResponse {
    /// Scene tick of the states.
    pub tick: i64,
    /// Scene time of the states, s.
    pub t: f64,
    /// Bodies in id order: state, mass and hull.
    pub bodies: Vec<BodyDescription>,
}

/// Every body of `b` (or the one with id `only`) with its mass and hull, in id order.
fn describe(b: &SceneBodies, only: Option<u64>) -> Vec<BodyDescription> {
    let states = b.states(only.as_ref().map(std::slice::from_ref));
    let record = b.record();
    states
        .into_iter()
        .filter_map(|state| {
            let r = record.bodies.iter().find(|r| r.id == state.id)?;
            Some(BodyDescription {
                state,
                mass: r.spec.mass,
                hull: HullExtent::from(&r.spec.hull),
            })
        })
        .collect()
}

fn parse_body_id(raw: &str) -> Result<u64, ApiError> {
    raw.parse::<u64>().map_err(|_| {
        ApiError::invalid(
            "body",
            format!("body id {raw:?} is not an unsigned integer"),
        )
    })
}

/// `POST /v1/scenes/{id}/bodies` (admin): spawns a body at rest; 201 with its state.
pub async fn create(
    State(state): State<AppState>,
    Path(id): Path<String>,
    RawBody(body): RawBody,
) -> Result<Response, ApiError> {
    let req: SpawnRequest = from_slice(&body)?;
    let out = state.spawn_body(&id, req).await?;
    Ok((StatusCode::CREATED, axum::Json(out)).into_response())
}

/// `GET /v1/scenes/{id}/bodies`.
pub async fn list(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<axum::Json<BodiesResponse>, ApiError> {
    let entry = state.scene(&id)?;
    Ok(axum::Json(match state.bodies.get(&id) {
        Some(cell) => {
            let b = cell.lock();
            BodiesResponse {
                tick: b.tick(),
                t: b.t(),
                bodies: describe(&b, None),
            }
        }
        None => {
            let r = state.read_clock(&entry);
            BodiesResponse {
                tick: r.tick,
                t: r.t,
                bodies: Vec::new(),
            }
        }
    }))
}

/// `GET /v1/scenes/{id}/bodies/{bid}`: the body's state, mass and hull.
pub async fn get_one(
    State(state): State<AppState>,
    Path((id, bid)): Path<(String, String)>,
) -> Result<axum::Json<BodyDescription>, ApiError> {
    state.scene(&id)?;
    let bid = parse_body_id(&bid)?;
    let cell = state.bodies.get(&id).ok_or_else(|| body_not_found(bid))?;
    let one = describe(&cell.lock(), Some(bid)).pop();
    Ok(axum::Json(one.ok_or_else(|| body_not_found(bid))?))
}

/// `DELETE /v1/scenes/{id}/bodies/{bid}` (admin): 204.
pub async fn delete(
    State(state): State<AppState>,
    Path((id, bid)): Path<(String, String)>,
) -> Result<StatusCode, ApiError> {
    state.scene(&id)?;
    let bid = parse_body_id(&bid)?;
    state.remove_body(&id, bid).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// `POST /v1/scenes/{id}/bodies/{bid}/input` (admin): 202 with the tick the bodies are at.
pub async fn input(
    State(state): State<AppState>,
    Path((id, bid)): Path<(String, String)>,
    RawBody(body): RawBody,
) -> Result<Response, ApiError> {
    state.scene(&id)?;
    let bid = parse_body_id(&bid)?;
    let req: InputRequest = from_slice(&body)?;
    let tick = state.body_input(&id, bid, req).await?;
    Ok((
        StatusCode::ACCEPTED,
        axum::Json(serde_json::json!({"tick": tick})),
    )
        .into_response())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::types::HullKind;
    use swell_waves::body::{CellSpec, HullSpec};

    /// A box hull is described by its own dimensions; a cells hull by the box around its
    /// columns (each `sqrt(volume/height)` square), centred where that box is.
    #[test]
    fn hull_extent_of_box_and_cells() {
        let b = HullExtent::from(&HullSpec::Box {
            length: 8.0,
            beam: 3.0,
            height: 1.5,
            cells: None,
        });
        assert_eq!(
            (b.kind, b.length, b.beam, b.height, b.center),
            (HullKind::Box, 8.0, 3.0, 1.5, [0.0; 3])
        );
        let cell = |x: f64, y: f64, z: f64, volume: f64, height: f64| CellSpec {
            position: [x, y, z],
            volume,
            height,
        };
        // Columns of 2 x 2 m (volume 4 m³, 1 m high) at x = ±5, one of 1 x 1 m, 2 m high, at z = 3.
        let c = HullExtent::from(&HullSpec::Cells {
            cells: vec![
                cell(-5.0, 0.0, 0.0, 4.0, 1.0),
                cell(5.0, 0.0, 0.0, 4.0, 1.0),
                cell(0.0, 0.5, 3.0, 2.0, 2.0),
            ],
        });
        assert_eq!(c.kind, HullKind::Cells);
        assert_eq!((c.length, c.beam, c.height), (12.0, 4.5, 2.0));
        assert_eq!(c.center, [0.0, 0.5, 1.25]);
    }
}
