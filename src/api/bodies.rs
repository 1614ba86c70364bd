//! Floating-body endpoints: spawn, list, read, delete, input. The simulation itself is in
//! [`crate::bodies`]; its loop starts when a scene gets its first body.

use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde::de::IgnoredAny;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use swell_waves::body::CellSpec;

use crate::api::json::RawBody;
use crate::bodies::{InputRequest, SceneBodies, SpawnRequest, body_not_found};
use crate::error::ApiError;
use crate::service::json::{from_slice, from_value_at};
use crate::service::types::{
    BodyDescription, CarriedBody, FeltImpact, HullExtent, HullKind, InputSpan,
};
use crate::state::AppState;

/// `GET /v1/scenes/{id}/bodies` answer.
#[derive(Debug, Clone, Serialize)]
pub struct BodiesResponse {
    /// Scene tick of the states.
    pub tick: i64,
    /// Scene time of the states, s.
    pub t: f64,
    /// Scene tick the scene's body world is anchored at (world tick 0; it moves when a clock
    /// jump re-anchors the world); absent while the scene has never had a body.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub anchor_tick: Option<i64>,
    /// Bodies in id order: state, mass, hull, spawn tick.
    pub bodies: Vec<BodyDescription>,
    /// The API impacts the body world feels (in canonical order: time, then x, z, strength,
    /// radius), each with the scene tick it reached the world at (`body_tick`, also in the
    /// impact's POST answer): a client that replays the bodies feels each at that tick.
    /// Impacts go an hour behind the bodies' time. Absent when there are none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub felt_impacts: Vec<FeltImpact>,
}

/// `GET /v1/scenes/{id}/bodies/{bid}` answer: the body with the ticks of its state and world.
#[derive(Debug, Clone, Serialize)]
pub struct BodyResponse {
    /// The body.
    #[serde(flatten)]
    pub body: BodyDescription,
    /// Scene tick of the state.
    pub tick: i64,
    /// Scene tick the scene's body world is anchored at.
    pub anchor_tick: i64,
}

/// Every body of `b` (or the one with id `only`) with its mass, hull and origin, in id order.
fn describe(b: &SceneBodies, only: Option<u64>) -> Vec<BodyDescription> {
    let states = b.states(only.as_ref().map(std::slice::from_ref));
    let record = b.record();
    let anchor = b.anchor();
    states
        .into_iter()
        .filter_map(|state| {
            let r = record.bodies.iter().find(|r| r.id == state.id)?;
            let origin = b.origin(state.id);
            Some(BodyDescription {
                state,
                mass: r.spec.mass,
                hull: HullExtent::from(&r.spec.hull),
                spawn_tick: origin.and_then(|o| o.spawn_tick),
                carried: origin
                    .and_then(|o| o.carried.as_ref())
                    .map(|c| carried(state.id, anchor, c)),
            })
        })
        .collect()
}

/// A carried body as published: scene ticks, and the state as a stream carries it.
fn carried(id: u64, anchor: i64, c: &crate::bodies::Carried) -> CarriedBody {
    let s = &c.state;
    CarriedBody {
        state: crate::bodies::BodyState {
            id,
            position: s.position.to_array(),
            rotation: s.rotation.to_array(),
            velocity: s.velocity.to_array(),
            angular_velocity: s.angular_velocity.to_array(),
            submerged: 0.0,
            quarantined: false,
        },
        inputs: c
            .inputs
            .iter()
            .map(|i| InputSpan {
                force: i.force,
                torque: i.torque,
                from_tick: anchor + i.from_tick as i64,
                ticks: i.ticks,
            })
            .collect(),
    }
}

/// The API impacts `b` feels, with their ticks.
fn felt(b: &SceneBodies) -> Vec<FeltImpact> {
    b.felt_impacts()
        .iter()
        .zip(b.felt_impact_ticks())
        .map(|(i, tick)| FeltImpact {
            body_tick: *tick,
            t: i.t,
            position: i.position,
            strength: i.strength,
            radius: i.radius,
        })
        .collect()
}

/// A spawn hull's `kind`, read before the rest of it (`swell_waves::body::HullSpec`'s tag).
#[derive(Deserialize)]
struct HullTag {
    kind: HullKind,
}

/// A box hull's fields as `HullSpec::Box` takes them (same names, types and defaults), read
/// only for the error that names a wrong one.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
#[expect(dead_code, reason = "read for its errors only")]
struct BoxHullFields {
    kind: IgnoredAny,
    length: f64,
    beam: f64,
    height: f64,
    #[serde(default)]
    cells: Option<[u32; 2]>,
}

/// A cells hull's fields as `HullSpec::Cells` takes them, read only for the error that names a
/// wrong one (the cells are the model's own `CellSpec`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
#[expect(dead_code, reason = "read for its errors only")]
struct CellsHullFields {
    kind: IgnoredAny,
    cells: Vec<CellSpec>,
}

/// Names the field of a spawn's hull that is wrongly typed, missing or unknown, as serde names
/// one anywhere else in the request (400 `bad_json` at `hull.length`, `hull.cells[2].volume`,
/// `hull.kind`). The model's `HullSpec` is an internally tagged enum, which serde buffers: its
/// own errors name only `hull` (or the field alone: `hull.volume` for a cell's), and it takes
/// unknown fields (it cannot refuse them itself without also refusing spawns already in
/// journals on replay; a misspelt optional field, `"cell": [8, 2]`, was dropped without a word
/// and the hull got its defaults). So the hull's JSON is read here by its kind, with fields of
/// the model's types. Ok when there is no hull object (serde's own error names `hull`).
fn check_hull(body: &[u8]) -> Result<(), ApiError> {
    let Ok(Value::Object(mut request)) = serde_json::from_slice::<Value>(body) else {
        return Ok(());
    };
    let Some(hull @ Value::Object(_)) = request.remove("hull") else {
        return Ok(());
    };
    let tag: HullTag = from_value_at(hull.clone(), "hull")?;
    match tag.kind {
        HullKind::Box => from_value_at::<BoxHullFields>(hull, "hull").map(drop),
        HullKind::Cells => from_value_at::<CellsHullFields>(hull, "hull").map(drop),
    }
    .map_err(ApiError::from)
}

fn parse_body_id(raw: &str) -> Result<u64, ApiError> {
    raw.parse::<u64>().map_err(|_| {
        ApiError::invalid(
            "body",
            format!("body id {raw:?} is not an unsigned integer"),
        )
    })
}

/// `POST /v1/scenes/{id}/bodies` (game): spawns a body at rest; 201 with its state.
pub async fn create(
    State(state): State<AppState>,
    Path(id): Path<String>,
    RawBody(body): RawBody,
) -> Result<Response, ApiError> {
    let parsed = from_slice::<SpawnRequest>(&body);
    // Before serde's error, which names any field inside the hull only as `hull`; after a
    // successful parse too, for a field the hull's kind does not take.
    check_hull(&body)?;
    let req = parsed?;
    // Where queries may look (`limits.max_coordinate`) is where a body may start: beyond it the
    // sea cannot be queried, and a stream's compact (f32) offsets would not be finite.
    for (i, v) in req.position.into_iter().enumerate() {
        crate::service::query::check_coord(&state.limits, v, || format!("position[{i}]"))?;
    }
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
                anchor_tick: Some(b.anchor()),
                bodies: describe(&b, None),
                felt_impacts: felt(&b),
            }
        }
        None => {
            let r = state.read_clock(&entry);
            BodiesResponse {
                tick: r.tick,
                t: r.t,
                anchor_tick: None,
                bodies: Vec::new(),
                felt_impacts: Vec::new(),
            }
        }
    }))
}

/// `GET /v1/scenes/{id}/bodies/{bid}`: the body's state, mass, hull and origin, with the
/// state's tick and the world's anchor.
pub async fn get_one(
    State(state): State<AppState>,
    Path((id, bid)): Path<(String, String)>,
) -> Result<axum::Json<BodyResponse>, ApiError> {
    state.scene(&id)?;
    let bid = parse_body_id(&bid)?;
    let cell = state.bodies.get(&id).ok_or_else(|| body_not_found(bid))?;
    let b = cell.lock();
    let one = describe(&b, Some(bid)).pop();
    Ok(axum::Json(BodyResponse {
        body: one.ok_or_else(|| body_not_found(bid))?,
        tick: b.tick(),
        anchor_tick: b.anchor(),
    }))
}

/// `DELETE /v1/scenes/{id}/bodies/{bid}` (game): 204.
pub async fn delete(
    State(state): State<AppState>,
    Path((id, bid)): Path<(String, String)>,
) -> Result<StatusCode, ApiError> {
    state.scene(&id)?;
    let bid = parse_body_id(&bid)?;
    state.remove_body(&id, bid).await?;
    Ok(StatusCode::NO_CONTENT)
}

/// `POST /v1/scenes/{id}/bodies/{bid}/input` (game): 202 with the tick the bodies are at, the
/// tick the input acts from and for how many, and the world's anchor
/// ([`crate::service::types::InputAccepted`]).
pub async fn input(
    State(state): State<AppState>,
    Path((id, bid)): Path<(String, String)>,
    RawBody(body): RawBody,
) -> Result<Response, ApiError> {
    state.scene(&id)?;
    let bid = parse_body_id(&bid)?;
    let req: InputRequest = from_slice(&body)?;
    let accepted = state.body_input(&id, bid, req).await?;
    Ok((StatusCode::ACCEPTED, axum::Json(accepted)).into_response())
}

#[cfg(test)]
mod tests {
    use super::*;
    use swell_waves::body::HullSpec;

    /// The field a spawn's hull gets wrong is named under `hull` (serde names only `hull`),
    /// and every hull the model writes passes: `check_hull`'s fields are `HullSpec`'s.
    #[test]
    fn check_hull_names_the_field_inside_the_hull() {
        let spawn = |hull: Value| serde_json::to_vec(&serde_json::json!({"hull": hull})).unwrap();
        let field = |hull: Value| {
            let e = check_hull(&spawn(hull)).unwrap_err();
            assert_eq!(e.code, crate::error::ErrorCode::BadJson, "{e}");
            e.field.unwrap_or_default()
        };
        let cell = CellSpec {
            position: [1.0, 0.0, -1.0],
            volume: 2.0,
            height: 1.0,
        };
        for hull in [
            HullSpec::Box {
                length: 8.0,
                beam: 3.0,
                height: 1.5,
                cells: None,
            },
            HullSpec::Box {
                length: 8.0,
                beam: 3.0,
                height: 1.5,
                cells: Some([16, 1]),
            },
            HullSpec::Cells {
                cells: vec![cell; 3],
            },
        ] {
            let v = serde_json::to_value(&hull).unwrap();
            check_hull(&spawn(v.clone())).unwrap_or_else(|e| panic!("{v}: {e}"));
            let parsed: HullSpec = serde_json::from_value(v).unwrap();
            assert_eq!(parsed, hull);
        }
        let boxed = serde_json::json!({"kind": "box", "length": 8, "beam": 3.0, "height": 1.5});
        let mut b = boxed.clone();
        b["length"] = serde_json::json!("x");
        assert_eq!(field(b), "hull.length");
        let mut b = boxed.clone();
        b.as_object_mut().unwrap().remove("beam");
        assert_eq!(field(b), "hull.beam");
        let mut b = boxed.clone();
        b["cells"] = serde_json::json!([4, -2]);
        assert_eq!(field(b), "hull.cells[1]");
        let mut b = boxed.clone();
        b["cell"] = serde_json::json!([8, 2]);
        assert_eq!(field(b), "hull.cell");
        let mut b = boxed;
        b["kind"] = serde_json::json!("boat");
        assert_eq!(field(b), "hull.kind");
        assert_eq!(field(serde_json::json!({"length": 8.0})), "hull.kind");
        let cells = |c: Value| serde_json::json!({"kind": "cells", "cells": [cell, cell, c]});
        let c = serde_json::json!({"position": [0, 0, 0], "volume": "2", "height": 1});
        assert_eq!(field(cells(c)), "hull.cells[2].volume");
        let c = serde_json::json!({"position": [0, 0], "volume": 2, "height": 1});
        assert_eq!(field(cells(c)), "hull.cells[2].position");
        let c = serde_json::json!({"position": [0, 0, 0], "volume": 2});
        assert_eq!(field(cells(c)), "hull.cells[2].height");
        let c = serde_json::json!({"position": [0, 0, 0], "volume": 2, "height": 1, "mass": 1});
        assert_eq!(field(cells(c)), "hull.cells[2].mass");
        // Not a hull object, or not JSON: serde's own error names it.
        assert!(check_hull(&spawn(serde_json::json!(3))).is_ok());
        assert!(check_hull(b"{").is_ok());
    }

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
