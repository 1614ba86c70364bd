//! Issue 28: a live native client predicts and reconciles its boat to the server's bits.
//!
//! Before, the server did not publish its body world's anchor tick or a body's spawn tick, so a
//! client of `crates/swell-ffi` could replay the golden body logs but not a live server's boat.
//! Here a real server (clock paused and moved by seeks, so every tick is stepped exactly once,
//! whenever the loop gets to it) spawns two boats and takes inputs; a world of the C ABI, built
//! from nothing but what the answers publish (`anchor_tick`, `spawn_tick`, each input's
//! `from_tick` and `ticks`), must hold the server's states bit for bit at several ticks; then a
//! clock jump re-anchors the server's world, and a second client world built from the new
//! `anchor_tick` and the body's `carried` state and inputs must follow it to the bit too.

use crate::common;
use crate::native::{arr, at_tick, ok, post, seek_paused, when_field};

use std::ptr;

use common::{TOKEN, TestServer, config};
use reqwest::Method;
use serde_json::{Value, json};
use swell_ffi::*;

const SCENE: &str = "lake";
/// Scene tick the test starts at (t ≈ 10⁵ s at 30 Hz: the anchor's rounding is exercised).
const T0: i64 = 3_000_000;

fn boat(x: f64, yaw: f64) -> Value {
    json!({"mass": 3000.0, "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5},
           "position": [x, 0.4, -3.0], "yaw": yaw})
}

/// A published state as the C ABI holds one.
fn state(v: &Value) -> SwellBodyState {
    SwellBodyState {
        id: v["id"].as_u64().unwrap(),
        position: arr(&v["position"]),
        rotation: arr(&v["rotation"]),
        velocity: arr(&v["velocity"]),
        angular_velocity: arr(&v["angular_velocity"]),
        submerged: v["submerged"].as_f64().unwrap(),
        quarantined: i32::from(v["quarantined"].as_bool().unwrap()),
    }
}

/// The answer's `from_tick` and `ticks` as a C ABI input (force and torque as sent).
/// Body `id` as the server has it once its world has reached scene tick `tick`.
async fn body_at(s: &TestServer, id: u64, tick: i64) -> Value {
    at_tick(s, &format!("/v1/scenes/{SCENE}/bodies/{id}"), tick).await
}

async fn input(s: &TestServer, id: u64, req: &Value) -> Value {
    post(s, SCENE, &format!("bodies/{id}/input"), req, 202).await
}

fn swell_input(sent: &Value, answer: &Value) -> SwellInput {
    SwellInput {
        force: arr(&sent["force"]),
        torque: arr(&sent["torque"]),
        from_tick: answer["from_tick"].as_i64().unwrap(),
        ticks: answer["ticks"].as_u64().unwrap(),
    }
}

/// Steps `world` to `tick` and checks body `id` against the server's state there, bit for bit
/// (`SwellBodyState`'s `PartialEq` compares the f64s; their bits are compared too, so -0.0 and
/// 0.0 would differ).
fn check(world: *mut SwellWorld, id: u64, server: &Value, tick: i64) {
    let mut mine = SwellBodyState::default();
    // SAFETY: `world` is a live handle of this test.
    unsafe {
        ok(swell_world_step_to(world, tick));
        ok(swell_world_state(world, id, &mut mine));
    }
    let theirs = state(server);
    let bits = |s: &SwellBodyState| -> Vec<u64> {
        s.position
            .iter()
            .chain(&s.rotation)
            .chain(&s.velocity)
            .chain(&s.angular_velocity)
            .chain([&s.submerged])
            .map(|x| x.to_bits())
            .collect()
    };
    assert_eq!(
        (bits(&mine), mine.quarantined),
        (bits(&theirs), theirs.quarantined),
        "body {id} at tick {tick}: client {mine:?}, server {theirs:?}"
    );
}

#[tokio::test]
async fn a_native_world_built_from_the_published_ticks_follows_the_server_bit_for_bit() {
    let s = TestServer::start(config()).await;
    seek_paused(&s, SCENE, T0).await;
    let spawn = |b: Value| {
        let s = &s;
        async move {
            let (st, v) = s
                .admin(
                    Method::POST,
                    &format!("/v1/scenes/{SCENE}/bodies"),
                    Some(&b),
                    Some(TOKEN),
                )
                .await;
            assert_eq!(st, 201, "{v}");
            v
        }
    };
    // The first boat makes the world: anchored where the clock is.
    let a = spawn(boat(5.0, 0.0)).await;
    assert_eq!(
        (a["spawn_tick"].as_i64(), a["anchor_tick"].as_i64()),
        (Some(T0), Some(T0))
    );
    // The second one joins 12 ticks later, in the same world.
    seek_paused(&s, SCENE, T0 + 12).await;
    body_at(&s, a["id"].as_u64().unwrap(), T0 + 12).await;
    let b_spec = boat(-20.0, 0.3);
    let b = spawn(b_spec.clone()).await;
    let (anchor, spawn_tick) = (
        b["anchor_tick"].as_i64().unwrap(),
        b["spawn_tick"].as_i64().unwrap(),
    );
    assert_eq!((anchor, spawn_tick), (T0, T0 + 12), "{b}");
    let id = b["id"].as_u64().unwrap();
    // Thrust and rudder from two ticks ahead, and a sideways push from the current tick (no
    // from_tick: the answer says which tick that is).
    let push = json!({"force": [20000.0, 0.0, 0.0], "torque": [0.0, 3000.0, 0.0],
                      "from_tick": T0 + 14, "ticks": 40});
    let shove = json!({"force": [0.0, 0.0, 6000.0], "torque": [0.0, 0.0, 0.0], "ticks": 5});
    let push_ok = input(&s, id, &push).await;
    let shove_ok = input(&s, id, &shove).await;
    assert_eq!(
        push_ok,
        json!({"tick": T0 + 12, "from_tick": T0 + 14, "ticks": 40, "anchor_tick": T0})
    );
    assert_eq!(
        shove_ok,
        json!({"tick": T0 + 12, "from_tick": T0 + 12, "ticks": 5, "anchor_tick": T0})
    );
    // The list says the same of the world and the boat.
    let (_, list) = s.get_json(&format!("/v1/scenes/{SCENE}/bodies")).await;
    assert_eq!(list["anchor_tick"], json!(T0), "{list}");
    assert_eq!(list["bodies"][1]["spawn_tick"], json!(T0 + 12), "{list}");
    assert!(list["bodies"][1].get("carried").is_none(), "{list}");

    // The client's world, from the published ticks only.
    let (_, scene) = s.get_json(&format!("/v1/scenes/{SCENE}")).await;
    let scene_json = scene["spec"].to_string();
    let spawn_json = b_spec.to_string();
    let (mut sea, mut world) = (ptr::null_mut(), ptr::null_mut());
    // SAFETY: every pointer passed is a live handle from these calls or a local.
    unsafe {
        ok(swell_surface_new(
            scene_json.as_ptr().cast(),
            scene_json.len(),
            &mut sea,
        ));
        ok(swell_world_new(sea, anchor, &mut world));
        ok(swell_world_step_to(world, spawn_tick));
        ok(swell_world_spawn_as(
            world,
            id,
            spawn_json.as_ptr().cast(),
            spawn_json.len(),
        ));
        ok(swell_world_input(world, id, &swell_input(&push, &push_ok)));
        ok(swell_world_input(
            world,
            id,
            &swell_input(&shove, &shove_ok),
        ));
    }
    check(world, id, &b, spawn_tick);
    // Forward in steps the loop walks through (never more than its catch-up limit at once).
    for tick in [T0 + 20, T0 + 35, T0 + 54, T0 + 70] {
        seek_paused(&s, SCENE, tick).await;
        let server = body_at(&s, id, tick).await;
        assert_eq!(server["anchor_tick"], json!(T0), "{server}");
        check(world, id, &server, tick);
    }
    // It moved: the comparison is not of two boats at rest.
    let moved = body_at(&s, id, T0 + 70).await;
    assert!(arr::<3>(&moved["position"])[0] > -20.0 + 1.0, "{moved}");

    // An input still to come, then a jump the world cannot step through: it re-anchors there.
    let late = json!({"force": [-8000.0, 0.0, 0.0], "torque": [0.0, -1500.0, 0.0],
                      "from_tick": T0 + 72, "ticks": 100});
    input(&s, id, &late).await;
    let jump = T0 + 70 + 600;
    seek_paused(&s, SCENE, jump).await;
    let path = format!("/v1/scenes/{SCENE}/bodies/{id}");
    let carried = when_field(&s, &path, "anchor_tick", jump).await;
    assert_eq!(carried["spawn_tick"], json!(T0 + 12), "{carried}");
    let c = &carried["carried"];
    assert_eq!(c["inputs"].as_array().map(Vec::len), Some(1), "{carried}");
    // A client world from the new anchor: the boat put at its carried state, its carried
    // inputs queued (the spawn request only gives it its hull and mass).
    let mut rebuilt = ptr::null_mut();
    // SAFETY: as above.
    unsafe {
        ok(swell_world_new(sea, jump, &mut rebuilt));
        ok(swell_world_spawn_as(
            rebuilt,
            id,
            spawn_json.as_ptr().cast(),
            spawn_json.len(),
        ));
        ok(swell_world_set_state(rebuilt, id, &state(&c["state"])));
        for i in c["inputs"].as_array().unwrap() {
            ok(swell_world_input(rebuilt, id, &swell_input(i, i)));
        }
    }
    for tick in [jump + 10, jump + 40] {
        seek_paused(&s, SCENE, tick).await;
        let server = body_at(&s, id, tick).await;
        check(rebuilt, id, &server, tick);
    }
    // SAFETY: live handles, freed once.
    unsafe {
        swell_world_free(world);
        swell_world_free(rebuilt);
        swell_surface_free(sea);
    }
    s.stop().await;
}
