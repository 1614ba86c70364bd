//! The JSON Schemas of floating bodies and impacts in `/openapi.json`, as the HTTP answers and
//! the stream's tick frames carry them: `BodyState` and `ImpactEvent` (a tick frame's), and the
//! answers built from them: `BodyList` (`GET …/bodies`), `BodyDetail` (`GET …/bodies/{bid}`),
//! `SpawnedBody` (a spawn's 201), `InputAccepted` (an input's 202), `ImpactList`
//! (`GET …/impacts`) and `ImpactAccepted` (an impact's 202).
//!
//! Each is closed (`additionalProperties: false`): the encoders write no other field, and a
//! client may rely on that. Where an answer repeats the fields of another component (a body's
//! description flattens its state; a listed impact is a tick frame's event without `body_tick`),
//! each field is a `$ref` to that component's field, so the two cannot drift apart; a `$ref`
//! to the whole component would not do, as it is closed too.
//!
//! `tests/server/openapi.rs` validates real answers of every route here against their schemas
//! and checks that every documented field comes in one of them at least.

use serde_json::{Map, Value, json};

/// Where the components live, for `$ref`s.
const COMPONENTS: &str = "#/components/schemas/";

/// The fields of a tick frame's `BodyState`, all required (`crate::service::types::BodyState`
/// writes every one).
const BODY_STATE_FIELDS: &[&str] = &[
    "id",
    "position",
    "rotation",
    "velocity",
    "angular_velocity",
    "submerged",
    "quarantined",
];

/// Adds the body and impact schemas to `schemas`, the components object [`super::ops`] built.
pub fn add(schemas: &mut Value) {
    let u64_id = |description: &str| json!({"type": "integer", "minimum": 0, "maximum": u64::MAX, "description": description});
    let xyz = |description: &str| {
        json!({"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3,
            "description": description})
    };
    let tick = |description: &str| json!({"type": "integer", "description": description});
    let list = |component: &str, description: &str| {
        json!({"type": "array", "items": {"$ref": format!("{COMPONENTS}{component}")},
            "description": description})
    };
    // A body's description: its state's fields, then mass, hull and origin
    // (crate::service::types::BodyDescription, the state flattened).
    let mut description = refs("BodyState", BODY_STATE_FIELDS);
    description.extend(object_fields(json!({
        "mass": {"type": "number", "description": "kg"},
        "hull": {"$ref": format!("{COMPONENTS}HullExtent")},
        "spawn_tick": tick("scene tick the body was spawned at (absent for a body restored \
            from a record written before spawn ticks were kept)"),
        "carried": {"$ref": format!("{COMPONENTS}CarriedBody")},
    })));
    let description_required = [BODY_STATE_FIELDS, &["mass", "hull"]].concat();
    let description_names: Vec<&str> = description.keys().map(String::as_str).collect();
    // One body's answer: the description's fields and the ticks of its state and world.
    let mut detail = refs("BodyDescription", &description_names);
    detail.extend(object_fields(json!({
        "tick": tick("scene tick of the state"),
        "anchor_tick": tick("scene tick the scene's body world is anchored at (world tick 0)"),
    })));
    // A spawn's answer: the new body's state and its ticks (crate::service::types::SpawnedBody).
    let mut spawned = refs("BodyState", BODY_STATE_FIELDS);
    spawned.extend(object_fields(json!({
        "spawn_tick": tick("scene tick the spawn applied at (the state's tick)"),
        "anchor_tick": tick("scene tick the body world is anchored at (world tick 0)"),
    })));
    // What GET …/impacts lists: a tick frame's event less `body_tick`, which only a frame
    // carries (crate::impacts::ImpactEvent::new leaves it out).
    let listed = &["tick", "t", "position", "strength", "radius"];
    // An impact the bodies feel (crate::service::types::FeltImpact): no `tick`, and its
    // `body_tick` absent only in records written before the ticks were kept.
    let felt = &["body_tick", "t", "position", "strength", "radius"];
    let added = json!({
        // crate::service::types::BodyState: a tick frame's body.
        "BodyState": closed(BODY_STATE_FIELDS, object_fields(json!({
            "id": u64_id("body id, unique within the scene"),
            "position": xyz("world position of the body origin [x, y, z], m"),
            "rotation": {"type": "array", "items": {"type": "number"}, "minItems": 4, "maxItems": 4,
                "description": "world rotation quaternion [x, y, z, w]"},
            "velocity": xyz("linear velocity, m/s"),
            "angular_velocity": xyz("angular velocity (world frame), rad/s"),
            "submerged": {"type": "number",
                "description": "submerged fraction of the hull volume during the last step, 0..1"},
            "quarantined": {"type": "boolean", "description": "the last step went non-finite \
                and was rolled back: the state is the last good one"}}))),
        // crate::impacts::ImpactEvent: an impact in a tick frame.
        "ImpactEvent": closed(&["tick", "t", "position", "strength", "radius"], object_fields(json!({
            "tick": tick("first tick at or after the impact"),
            "body_tick": tick("the scene tick the scene's bodies feel it from (API impacts on \
                a scene with bodies only)"),
            "t": {"type": "number", "description": "scene time of the impact, s"},
            "position": {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2,
                "description": "world [x, z], m"},
            "strength": {"type": "number", "description": "splash height, m"},
            "radius": {"type": "number", "description": "particle radius, m"}}))),
        // crate::service::types::HullExtent.
        "HullExtent": closed(&["kind", "length", "beam", "height", "center"], object_fields(json!({
            "kind": {"type": "string", "enum": ["box", "cells"], "description": "as spawned"},
            "length": {"type": "number", "description": "extent along x, m (a box hull's length; \
                for cells, the bounding box of the cells' columns)"},
            "beam": {"type": "number", "description": "extent along z, m"},
            "height": {"type": "number", "description": "extent along y, m"},
            "center": xyz("centre of that box in the body frame, m (a box hull: the origin)")}))),
        // crate::service::types::CarriedBody and InputSpan.
        "CarriedBody": closed(&["state", "inputs"], object_fields(json!({
            "state": {"$ref": format!("{COMPONENTS}BodyState")},
            "inputs": {"type": "array", "description": "its inputs still running at the \
                re-anchor, each acting from the anchor tick for the ticks it had left",
                "items": closed(&["force", "torque", "from_tick", "ticks"], object_fields(json!({
                    "force": xyz("in the body frame, N"),
                    "torque": xyz("in the body frame, N·m"),
                    "from_tick": tick("first scene tick it acts on"),
                    "ticks": {"type": "integer", "minimum": 0, "maximum": u64::MAX,
                        "description": "number of ticks it acts for"}})))}}))),
        "BodyDescription": closed(&description_required, description),
        // crate::api::bodies::BodiesResponse: GET …/bodies.
        "BodyList": closed(&["tick", "t", "bodies"], object_fields(json!({
            "tick": tick("scene tick of the states"),
            "t": {"type": "number", "description": "scene time of the states, s"},
            "anchor_tick": tick("scene tick the body world is anchored at (world tick 0); \
                absent while the scene has never had a body"),
            "bodies": list("BodyDescription", "every body, in id order"),
            "felt_impacts": {"type": "array", "description": "the API impacts the body world \
                feels, in canonical order, each with the scene tick it reached the world at \
                (absent when there are none)",
                "items": closed(&felt[1..], refs("ImpactEvent", felt))}}))),
        // crate::api::bodies::BodyResponse: GET …/bodies/{bid}.
        "BodyDetail": closed(&[&description_required[..], &["tick", "anchor_tick"]].concat(), detail),
        // crate::service::types::SpawnedBody: POST …/bodies (201).
        "SpawnedBody": closed(&[BODY_STATE_FIELDS, &["spawn_tick", "anchor_tick"]].concat(), spawned),
        // crate::service::types::InputAccepted: POST …/bodies/{bid}/input (202).
        "InputAccepted": closed(&["tick", "from_tick", "ticks"], object_fields(json!({
            "tick": tick("on one process, the tick the bodies were at when it was accepted; in \
                a fleet, the tick it applies at"),
            "from_tick": tick("first scene tick it acts on"),
            "ticks": {"type": "integer", "minimum": 1, "maximum": crate::bodies::MAX_INPUT_TICKS,
                "description": "number of ticks it acts for"},
            "anchor_tick": tick("scene tick the body world was anchored at when it was \
                accepted (one process only: a fleet answers before its replicas apply it)")}))),
        // crate::api::impacts::ImpactList: GET …/impacts.
        "ImpactList": closed(&["t", "impacts"], object_fields(json!({
            "t": {"type": "number", "description": "the time asked about, s"},
            "impacts": {"type": "array", "description": "every impact that can be rippling at \
                t or later, in canonical order",
                "items": closed(listed, refs("ImpactEvent", listed))}}))),
        // crate::api::impacts::ImpactAccepted: POST …/impacts (202).
        "ImpactAccepted": closed(&["tick", "t"], refs("ImpactEvent", &["tick", "t", "body_tick"])),
    });
    if let Value::Object(added) = added {
        for (name, schema) in added {
            schemas[name.as_str()] = schema;
        }
    }
}

/// `names`, each a `$ref` to the field of that name of `component`.
fn refs(component: &str, names: &[&str]) -> Map<String, Value> {
    names
        .iter()
        .map(|name| {
            let r = format!("{COMPONENTS}{component}/properties/{name}");
            ((*name).to_owned(), json!({"$ref": r}))
        })
        .collect()
}

/// The fields of a `json!` object.
fn object_fields(v: Value) -> Map<String, Value> {
    match v {
        Value::Object(map) => map,
        _ => Map::new(),
    }
}

/// A closed object of `properties`, `required` the names that are always written.
fn closed(required: &[&str], properties: Map<String, Value>) -> Value {
    json!({"type": "object", "required": required, "additionalProperties": false,
        "properties": properties})
}
