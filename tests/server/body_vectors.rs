//! Body vectors: `proto/vectors/bodies_v1.json` pins the states the server's own body code
//! (`swell::bodies::SceneBodies`, the code the body loop, journal replay and fleet followers
//! step with) reaches from a logged history: a scene, the tick its world is anchored at, spawns
//! and inputs at their ticks. A client's prediction (the C ABI in `crates/swell-ffi`, whose C
//! test replays these logs) is right when it reaches these bits.
//!
//! The world is stepped one tick at a time, as the live loop does (never more than
//! `MAX_CATCH_UP_TICKS` at once, so it never re-anchors), on `Sea::Direct`: the live loop's
//! shared frame cache gives the same bits (`bodies_on_the_shared_frame_cache_step_to_the_bits_of_a_direct_replay`).
//!
//! If this test fails, the server's body trajectories changed. If that was not the intent, fix
//! the change. If it was, re-mint with
//!     SWELL_MINT_VECTORS=1 cargo test --workspace --test server -- body_vectors::
//! and say so in the change: clients that predict bodies must update with the server.

use std::path::PathBuf;

use serde_json::{Value, json};
use swell::bodies::{InputRequest, SceneBodies, Sea, SpawnRequest};
use swell::scene::{Scene, SceneSpec};

fn path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("proto/vectors/bodies_v1.json")
}

/// Scene tick the worlds are anchored at: about where the built-in scenes' wall-anchored
/// clocks are (t ≈ 2.8·10⁷ s at 30 Hz), so the anchor's rounding is exercised as it is live.
const ANCHOR: i64 = 840_000_017;
/// Ticks each history runs for after the anchor (2 s at 30 Hz).
const TICKS: i64 = 60;

fn builtin(id: &str) -> String {
    swell::scene::builtin::BUILTIN
        .iter()
        .find(|(i, _)| *i == id)
        .map(|(_, text)| (*text).to_owned())
        .unwrap_or_else(|| panic!("no built-in scene {id}"))
}

/// One history: `(tick, event)` in order; an event is `{"spawn": request}` or
/// `{"input": {"body": id, ...request}}`.
fn log() -> Vec<(i64, Value)> {
    let a = ANCHOR;
    vec![
        (
            a,
            json!({"spawn": {"mass": 3000.0,
                "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5},
                "position": [5.0, 0.4, -3.0], "yaw": 0.3}}),
        ),
        (
            a + 3,
            json!({"input": {"body": 0, "force": [6000.0, 0.0, 0.0], "torque": [0.0, 2500.0, 0.0],
                "from_tick": a + 5, "ticks": 30}}),
        ),
        (
            a + 12,
            json!({"spawn": {"mass": 800.0,
                "hull": {"kind": "cells", "cells": [
                    {"position": [1.5, 0.0, 0.0], "volume": 0.9, "height": 0.6},
                    {"position": [-1.5, 0.0, 0.0], "volume": 0.9, "height": 0.6},
                    {"position": [0.0, 0.0, 0.8], "volume": 0.5, "height": 0.6}]},
                "position": [-20.5, 1.2, 14.25], "yaw": -2.0, "quadratic_drag": 40.0}}),
        ),
        (
            a + 12,
            json!({"input": {"body": 0, "force": [0.0, 0.0, -1500.0], "torque": [300.0, 0.0, 0.0]}}),
        ),
        (
            a + 20,
            json!({"input": {"body": 1, "force": [900.0, 0.0, 450.0], "torque": [0.0, -120.0, 0.0],
                "from_tick": a + 20, "ticks": 25}}),
        ),
        (
            a + 25,
            json!({"input": {"body": 1, "force": [0.0, 200.0, 0.0], "ticks": 10}}),
        ),
    ]
}

fn hex(x: f64) -> String {
    format!("{:016x}", x.to_bits())
}

/// Replays the log on the server's body code, recording every body's state at every tick.
fn replay(scene_text: &str) -> Vec<Value> {
    let spec: SceneSpec = serde_json::from_str(scene_text).expect("scene spec parses");
    let scene = Scene::build("vectors", spec).expect("scene builds");
    let (hz, g) = (scene.spec.tick_hz, scene.spec.surface.gravity);
    let mut bodies = SceneBodies::new(ANCHOR, hz, g).expect("body world");
    let log = log();
    let mut states = Vec::new();
    for tick in ANCHOR..=ANCHOR + TICKS {
        let adv = bodies.advance_to(tick, Sea::Direct(&scene.surface), hz, g);
        assert!(
            !adv.reanchored,
            "stepping one tick at a time never re-anchors"
        );
        assert_eq!(bodies.tick(), tick);
        for (_, event) in log.iter().filter(|(t, _)| *t == tick) {
            if let Some(req) = event.get("spawn") {
                let req: SpawnRequest = serde_json::from_value(req.clone()).unwrap();
                bodies.spawn(&req).expect("spawn");
            } else {
                let mut input = event["input"].clone();
                let id = input["body"].as_u64().unwrap();
                input.as_object_mut().unwrap().remove("body");
                let req: InputRequest = serde_json::from_value(input).unwrap();
                bodies.input(id, &req).expect("input");
            }
        }
        let list: Vec<Value> = bodies
            .states(None)
            .iter()
            .map(|s| {
                let h = |v: &[f64]| v.iter().map(|x| hex(*x)).collect::<Vec<_>>();
                json!({
                    "id": s.id,
                    "position_m": s.position,
                    "bits": {
                        "position": h(&s.position),
                        "rotation": h(&s.rotation),
                        "velocity": h(&s.velocity),
                        "angular_velocity": h(&s.angular_velocity),
                        "submerged": hex(s.submerged),
                        "quarantined": s.quarantined,
                    }
                })
            })
            .collect();
        states.push(json!({"tick": tick, "bodies": list}));
    }
    states
}

fn mint() -> Value {
    let log: Vec<Value> = log()
        .into_iter()
        .map(|(tick, mut e)| {
            e["tick"] = json!(tick);
            e
        })
        .collect();
    let cases: Vec<Value> = ["calm", "lake", "open-sea", "harbour"]
        .iter()
        .map(|id| {
            let scene = builtin(id);
            let states = replay(&scene);
            // The spec as the server serves it (`GET /v1/scenes/{id}`'s `spec`): every field
            // written out, numbers in shortest round-trip form. A client may build from either.
            let spec: SceneSpec = serde_json::from_str(&scene).unwrap();
            let served = serde_json::to_string(&spec).unwrap();
            json!({"name": id, "scene": scene, "served": served, "anchor": ANCHOR, "log": log,
                   "states": states})
        })
        .collect();
    json!({
        "model_version": swell_waves::MODEL_VERSION,
        "about": "Swell body vectors: for each case, build the scene from `scene` (the JSON a client PUTs), anchor its body world at scene tick `anchor` (world tick 0 = that tick, start time anchor/tick_hz), then for every tick from the anchor on: step to it, apply the `log` events at that tick in order (`spawn`: the POST .../bodies request, ids given in order from 0; `input`: the POST .../bodies/{id}/input request; a missing from_tick means the current tick), and compare every body's state with `states` (IEEE-754 binary64 bits in hex). Produced by the server's body code (swell::bodies::SceneBodies) in tests/server/body_vectors.rs. See README.md here.",
        "cases": cases,
    })
}

/// The file's text: pretty at the top, one line per log event and per tick's states (every
/// number pretty-printed on its own line would make the file three times larger).
fn layout(v: &Value) -> String {
    let line = |x: &Value| serde_json::to_string(x).unwrap();
    let mut out = String::from("{\n");
    out += &format!("  \"model_version\": {},\n", v["model_version"]);
    out += &format!("  \"about\": {},\n", v["about"]);
    out += "  \"cases\": [\n";
    let cases = v["cases"].as_array().unwrap();
    for (i, c) in cases.iter().enumerate() {
        out += "    {\n";
        for k in ["name", "scene", "served", "anchor"] {
            out += &format!("      \"{k}\": {},\n", line(&c[k]));
        }
        for (k, last) in [("log", false), ("states", true)] {
            let items: Vec<String> = c[k]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| format!("        {}", line(x)))
                .collect();
            out += &format!("      \"{k}\": [\n{}\n      ]", items.join(",\n"));
            out += if last { "\n" } else { ",\n" };
        }
        out += if i + 1 < cases.len() {
            "    },\n"
        } else {
            "    }\n"
        };
    }
    out += "  ]\n}\n";
    out
}

#[test]
fn body_vectors_match_the_server_bit_for_bit() {
    let fresh = mint();
    if std::env::var_os("SWELL_MINT_VECTORS").is_some() {
        std::fs::write(path(), layout(&fresh)).unwrap();
        eprintln!("minted {}", path().display());
        return;
    }
    let text = std::fs::read_to_string(path()).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; mint with SWELL_MINT_VECTORS=1 cargo test --workspace --test server -- body_vectors::",
            path().display()
        )
    });
    let file: Value = serde_json::from_str(&text).unwrap();
    let (want, got) = (
        file["cases"].as_array().unwrap(),
        fresh["cases"].as_array().unwrap(),
    );
    assert_eq!(
        want.len(),
        got.len(),
        "case list changed: re-mint deliberately"
    );
    for (w, g) in want.iter().zip(got) {
        assert_eq!(w["scene"], g["scene"], "{}: scene changed", g["name"]);
        assert_eq!(
            w["served"], g["served"],
            "{}: served spec changed",
            g["name"]
        );
        assert_eq!(w["log"], g["log"], "{}: log changed", g["name"]);
        for (ws, gs) in w["states"]
            .as_array()
            .unwrap()
            .iter()
            .zip(g["states"].as_array().unwrap())
        {
            assert_eq!(
                ws, gs,
                "{} at tick {}: the server's body states moved. If intended, re-mint \
                 (SWELL_MINT_VECTORS=1 cargo test --workspace --test server -- body_vectors::): clients that \
                 predict bodies must hear of it.",
                g["name"], gs["tick"]
            );
        }
    }
    assert_eq!(file["model_version"], fresh["model_version"]);
}
