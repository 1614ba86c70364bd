//! Issue 28 (the missing piece): a native client's bodies feel impacts as the server's do.
//!
//! Before, the server's bodies felt API impacts from the tick they reached its body world, which
//! it did not publish, and stepped on their own splashes and wakes, which only the server's code
//! derived: a swell-ffi world diverged at the first impact (and refused a scene with
//! `body_impacts` outright). Here a real server (clock paused and moved by seeks, so every tick
//! is stepped exactly once) runs a scene whose particle layer has `body_impacts`: one boat is
//! dropped (a splash), one is driven (a wake), and API impacts land near them while they tick. A
//! world of the C ABI built only from what the server published (`anchor_tick`, `spawn_tick`,
//! input answers, each impact's `body_tick`) holds both boats bit for bit at several ticks after
//! the impacts; the same world without the API impacts does not.

use crate::common;
use crate::native::{arr, at_tick, ok, seek_paused};

use std::ptr;
use std::time::{Duration, Instant};

use common::{TestServer, config};
use serde_json::{Value, json};
use swell_ffi::*;

const SCENE: &str = "wharf";
/// Scene tick the test starts at (t = 10⁵ s at 30 Hz).
const T0: i64 = 3_000_000;

fn scene() -> Value {
    json!({"tick_hz": 30, "seed": 5, "layers": [
        {"kind": "gerstner", "waves": [
            {"amplitude": 0.1, "wavelength": 24, "direction": [1, 0.2], "steepness": 0.4}]},
        {"kind": "particles", "count": 64, "tile_size": 32, "radius": 1.0, "amplitude": 0.02,
         "ripples": {"lifetime": 60}, "body_impacts": {}}
    ]})
}

/// Seeks the paused clock into the middle of scene tick `tick` and waits until the bodies
/// are there.
async fn seek(s: &TestServer, tick: i64) -> Value {
    seek_paused(s, SCENE, tick).await;
    at_tick(s, &format!("/v1/scenes/{SCENE}/bodies"), tick).await
}

async fn post(s: &TestServer, path: &str, body: &Value, want: u16) -> Value {
    crate::native::post(s, SCENE, path, body, want).await
}

fn boat(x: f64, y: f64) -> Value {
    json!({"mass": 3000.0, "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5},
           "position": [x, y, 0.0]})
}

/// Every number of a state, as bits: a published one, and one of the C ABI.
fn published_bits(v: &Value) -> Vec<u64> {
    let mut out: Vec<f64> = Vec::new();
    out.extend(arr::<3>(&v["position"]));
    out.extend(arr::<4>(&v["rotation"]));
    out.extend(arr::<3>(&v["velocity"]));
    out.extend(arr::<3>(&v["angular_velocity"]));
    out.push(v["submerged"].as_f64().unwrap());
    out.iter().map(|x| x.to_bits()).collect()
}

fn native_bits(world: *mut SwellWorld, id: u64, tick: i64) -> Vec<u64> {
    let mut s = SwellBodyState::default();
    // SAFETY: `world` is a live handle of this test.
    unsafe {
        ok(swell_world_step_to(world, tick));
        ok(swell_world_state(world, id, &mut s));
    }
    s.position
        .iter()
        .chain(&s.rotation)
        .chain(&s.velocity)
        .chain(&s.angular_velocity)
        .chain([&s.submerged])
        .map(|x| x.to_bits())
        .collect()
}

/// The C ABI's copy of an impact as the server lists it.
fn swell_impact(v: &Value) -> SwellImpact {
    SwellImpact {
        t: v["t"].as_f64().unwrap(),
        position: arr(&v["position"]),
        strength: v["strength"].as_f64().unwrap(),
        radius: v["radius"].as_f64().unwrap(),
    }
}

#[tokio::test]
async fn a_native_world_feels_the_published_impacts_and_its_own_splashes_to_the_servers_bits() {
    let s = TestServer::start(config()).await;
    let (st, v) = s.put_scene(SCENE, &scene()).await;
    assert!(st == 200 || st == 201, "{v}");
    seek(&s, T0).await;
    // A boat dropped from 2 m (it splashes when it hits the water) makes the world.
    let dropped = boat(0.0, 2.0);
    let a = post(&s, "bodies", &dropped, 201).await;
    let anchor = a["anchor_tick"].as_i64().unwrap();
    assert_eq!((a["spawn_tick"].as_i64(), anchor), (Some(T0), T0), "{a}");
    // A second one, 6 ticks later, driven hard enough to leave a wake.
    seek(&s, T0 + 6).await;
    let driven = boat(-14.0, 0.4);
    let b = post(&s, "bodies", &driven, 201).await;
    let push = json!({"force": [30000.0, 0.0, 0.0], "torque": [0.0, 2000.0, 0.0],
                      "from_tick": T0 + 7, "ticks": 200});
    let push_ok = post(&s, &format!("bodies/{}/input", b["id"]), &push, 202).await;

    // Client worlds from the published ticks only: one feels the impacts, one does not.
    let (_, scene) = s.get_json(&format!("/v1/scenes/{SCENE}")).await;
    let scene_json = scene["spec"].to_string();
    let mut sea = ptr::null_mut();
    let (mut world, mut bare) = (ptr::null_mut(), ptr::null_mut());
    let (ida, idb) = (a["id"].as_u64().unwrap(), b["id"].as_u64().unwrap());
    let input = SwellInput {
        force: arr(&push["force"]),
        torque: arr(&push["torque"]),
        from_tick: push_ok["from_tick"].as_i64().unwrap(),
        ticks: push_ok["ticks"].as_u64().unwrap(),
    };
    // SAFETY: every pointer passed is a live handle from these calls or a local.
    unsafe {
        ok(swell_surface_new(
            scene_json.as_ptr().cast(),
            scene_json.len(),
            &mut sea,
        ));
        ok(swell_world_new(sea, anchor, &mut world));
        for (id, spec, spawned) in [(ida, &dropped, &a), (idb, &driven, &b)] {
            let text = spec.to_string();
            ok(swell_world_step_to(
                world,
                spawned["spawn_tick"].as_i64().unwrap(),
            ));
            ok(swell_world_spawn_as(
                world,
                id,
                text.as_ptr().cast(),
                text.len(),
            ));
        }
        ok(swell_world_input(world, idb, &input));
        ok(swell_world_clone(world, &mut bare));
    }
    // Both boats at `tick` on the server, the native world, and the one without API impacts;
    // whether the last differs.
    let mut bare_differs = false;
    let mut check = |server: &Value, tick: i64| {
        for (k, id) in [ida, idb].into_iter().enumerate() {
            let theirs = published_bits(&server["bodies"][k]);
            assert_eq!(
                native_bits(world, id, tick),
                theirs,
                "body {id} at tick {tick}: {}",
                server["bodies"][k]
            );
            bare_differs |= native_bits(bare, id, tick) != theirs;
        }
    };

    // API impacts while the boats tick: at the next tick's start, half a second in the past
    // (already rippling when the bodies feel it) and one ahead. The client learns of each from
    // its answer and feels it at the published tick.
    let mut posted = Vec::new();
    for (tick, dt, x, z) in [
        (T0 + 12, None, 3.0, 2.0),
        (T0 + 20, Some(-0.5), -8.0, -2.0),
        (T0 + 20, Some(0.3), 1.0, -3.0),
        (T0 + 33, None, -4.0, 2.5),
    ] {
        let server = seek(&s, tick).await;
        check(&server, tick);
        let mut req = json!({"position": [x, z], "strength": 0.6, "radius": 1.0});
        if let Some(dt) = dt {
            req["t"] = json!(tick as f64 / 30.0 + dt);
        }
        let answer = post(&s, "impacts", &req, 202).await;
        // The bodies were at `tick` when it reached them (one process).
        assert_eq!(answer["body_tick"], json!(tick), "{answer}");
        let impact = SwellImpact {
            t: answer["t"].as_f64().unwrap(),
            position: [x, z],
            strength: 0.6,
            radius: 1.0,
        };
        // SAFETY: a live world and a local.
        ok(unsafe {
            swell_world_feel_impact(world, &impact, answer["body_tick"].as_i64().unwrap())
        });
        posted.push(answer);
    }
    // The list of bodies says the same of each felt impact.
    let listed = seek(&s, T0 + 34).await;
    check(&listed, T0 + 34);
    let felt = listed["felt_impacts"].as_array().expect("felt_impacts");
    assert_eq!(felt.len(), 4, "{listed}");
    for p in &posted {
        assert!(
            felt.iter()
                .any(|f| f["t"] == p["t"] && f["body_tick"] == p["body_tick"]),
            "{p} not in {listed}"
        );
    }
    for tick in [T0 + 50, T0 + 75, T0 + 100] {
        let server = seek(&s, tick).await;
        check(&server, tick);
    }
    assert!(
        bare_differs,
        "a world without the API impacts followed the server: the impacts did not move the boats"
    );
    // The bodies made impacts of their own (the splash, the wake), in the native world too.
    let mut made = 0;
    // SAFETY: a live world; no buffer with cap 0.
    ok(unsafe { swell_world_made_impacts(world, ptr::null_mut(), 0, &mut made) });
    assert!(made >= 2, "{made} impacts made by the bodies");
    let (_, listed) = s.get_json(&format!("/v1/scenes/{SCENE}/impacts")).await;
    let mut mine = vec![
        SwellImpact {
            t: 0.0,
            position: [0.0; 2],
            strength: 0.0,
            radius: 0.0
        };
        made
    ];
    // SAFETY: `mine` holds `made` impacts.
    ok(unsafe { swell_world_made_impacts(world, mine.as_mut_ptr(), made, &mut made) });
    for m in &mine {
        assert!(
            listed["impacts"].as_array().unwrap().iter().any(|i| {
                i["t"].as_f64().map(f64::to_bits) == Some(m.t.to_bits())
                    && arr::<2>(&i["position"]) == m.position
            }),
            "{m:?} is not among the server's impacts {listed}"
        );
    }

    // A tick already stepped is refused, naming it; a bad impact names its field.
    let one = swell_impact(&felt[0]);
    // SAFETY: live handles and locals.
    unsafe {
        assert_eq!(
            swell_world_feel_impact(world, &one, T0),
            SWELL_ERR_INVALID_ARGUMENT
        );
        let bad = SwellImpact {
            strength: f64::NAN,
            ..one
        };
        assert_eq!(
            swell_world_feel_impact(world, &bad, SWELL_FROM_NOW),
            SWELL_ERR_INVALID_SPEC
        );
        let msg = std::ffi::CStr::from_ptr(swell_last_error_message()).to_string_lossy();
        assert!(msg.contains("impact.strength"), "{msg}");
        assert_eq!(
            swell_world_feel_impact(ptr::null_mut(), &one, 0),
            SWELL_ERR_NULL
        );
        swell_world_free(world);
        swell_world_free(bare);
        swell_surface_free(sea);
    }
    s.stop().await;
}

/// A live client needs each API impact's `body_tick` to feel it where the server's bodies did;
/// before, tick frames carried the impacts without it and a client had to poll
/// `GET …/bodies`. Here subscribers in both codecs get every impact posted on a scene with
/// bodies with the `body_tick` of its POST answer (and of `felt_impacts`), and the impacts the
/// bodies made (a dropped boat's splash) without one.
#[tokio::test]
async fn tick_frames_carry_each_api_impacts_body_tick_in_both_codecs() {
    use common::ws_connect;
    use futures_util::{SinkExt, StreamExt};
    use prost::Message as _;
    use swell::wire::v1;
    use tokio_tungstenite::tungstenite::Message;

    let s = TestServer::start(config()).await;
    let (st, v) = s.put_scene(SCENE, &scene()).await;
    assert!(st == 200 || st == 201, "{v}");
    // Dropped from 2 m: it splashes, an impact the bodies make.
    post(&s, "bodies", &boat(0.0, 2.0), 201).await;
    let mut json_ws = ws_connect(s.addr, SCENE, None).await;
    json_ws
        .send(Message::Text(
            json!({"type": "subscribe", "ticks": true})
                .to_string()
                .into(),
        ))
        .await
        .unwrap();
    let mut proto_ws = ws_connect(s.addr, SCENE, Some("swell.v1.protobuf")).await;
    let sub = v1::ClientMessage {
        id: None,
        msg: Some(v1::client_message::Msg::Subscribe(v1::Subscribe {
            ticks: true,
            ..Default::default()
        })),
    };
    proto_ws
        .send(Message::Binary(sub.encode_to_vec().into()))
        .await
        .unwrap();
    // Both loops run before the impacts go in.
    for ws in [&mut json_ws, &mut proto_ws] {
        let _ = tokio::time::timeout(Duration::from_secs(10), ws.next())
            .await
            .expect("a first frame");
    }
    let mut posted = Vec::new();
    for (x, z) in [(3.0, 2.0), (-5.0, 1.5)] {
        let answer = post(
            &s,
            "impacts",
            &json!({"position": [x, z], "strength": 0.6, "radius": 1.0}),
            202,
        )
        .await;
        assert!(answer["body_tick"].is_i64(), "{answer}");
        posted.push(answer);
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // Each codec's frames: (t, body_tick) of every impact, until both posted ones came.
    let mine = |t: f64| posted.iter().any(|p| p["t"].as_f64() == Some(t));
    let mut seen: Vec<Vec<(f64, Option<i64>)>> = Vec::new();
    for ws in [&mut json_ws, &mut proto_ws] {
        let mut got: Vec<(f64, Option<i64>)> = Vec::new();
        let deadline = Instant::now() + Duration::from_secs(20);
        while got.iter().filter(|(t, _)| mine(*t)).count() < posted.len() {
            let left = deadline.saturating_duration_since(Instant::now());
            let m = tokio::time::timeout(left, ws.next())
                .await
                .unwrap_or_else(|_| panic!("frames so far carried {got:?}, posted {posted:?}"))
                .unwrap()
                .unwrap();
            match m {
                Message::Text(t) => {
                    let f: Value = serde_json::from_str(t.as_str()).unwrap();
                    for e in f["impacts"].as_array().into_iter().flatten() {
                        got.push((e["t"].as_f64().unwrap(), e["body_tick"].as_i64()));
                    }
                }
                Message::Binary(b) => {
                    if let Some(v1::server_message::Msg::Tick(tick)) =
                        v1::ServerMessage::decode(b.as_ref()).unwrap().msg
                    {
                        got.extend(tick.impacts.iter().map(|e| (e.t, e.body_tick)));
                    }
                }
                _ => {}
            }
        }
        seen.push(got);
    }
    for (codec, got) in ["json", "protobuf"].into_iter().zip(&seen) {
        for p in &posted {
            let t = p["t"].as_f64().unwrap();
            let carried: Vec<_> = got.iter().filter(|(gt, _)| *gt == t).collect();
            assert_eq!(carried.len(), 1, "{codec}: {got:?}");
            assert_eq!(carried[0].1, p["body_tick"].as_i64(), "{codec}: {p}");
        }
        for (t, body_tick) in got.iter().filter(|(t, _)| !mine(*t)) {
            assert_eq!(*body_tick, None, "{codec}: a body-made impact at t = {t}");
        }
    }
    // The same ticks as the list of bodies publishes.
    let (_, listed) = s.get_json(&format!("/v1/scenes/{SCENE}/bodies")).await;
    for p in &posted {
        assert!(
            listed["felt_impacts"]
                .as_array()
                .into_iter()
                .flatten()
                .any(|f| f["t"] == p["t"] && f["body_tick"] == p["body_tick"]),
            "{p} not in {listed}"
        );
    }
    s.stop().await;
}
