//! Impacts (issue 15): `POST /v1/scenes/{id}/impacts` ripples every query of the scene at any
//! t, tick frames carry the new events (JSON and protobuf), and the journal keeps them across a
//! restart so the sea comes back to the same bits.

mod common;

use std::time::Duration;

use common::{TOKEN, TestServer, bits, code, config, config_with_dir, ws_connect};
use futures_util::{SinkExt, StreamExt};
use prost::Message as _;
use reqwest::Method;
use serde_json::{Value, json};
use swell::wire::v1;
use tokio::time::timeout;
use tokio_tungstenite::tungstenite::Message;

/// Points along a line through the impact point, out to 12 m.
fn line() -> Vec<[f64; 2]> {
    (0..96).map(|i| [i as f64 * 0.125, 0.5]).collect()
}

async fn heights(s: &TestServer, scene: &str, t: f64) -> Vec<u64> {
    let (st, v) = s
        .post_json(
            &format!("/v1/scenes/{scene}/sample"),
            &json!({"t": t, "points": line()}),
        )
        .await;
    assert_eq!(st, 200, "{v}");
    v["height"].as_array().unwrap().iter().map(bits).collect()
}

async fn impact(s: &TestServer, scene: &str, body: Value) -> (u16, Value) {
    s.admin(
        Method::POST,
        &format!("/v1/scenes/{scene}/impacts"),
        Some(&body),
        Some(TOKEN),
    )
    .await
}

#[tokio::test]
async fn an_impact_ripples_queries_at_any_t_and_survives_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let s = TestServer::start(config_with_dir(dir.path().to_owned())).await;
    let before_at = |t| heights(&s, "harbour", t);
    let (b_early, b_late) = (before_at(99.0).await, before_at(102.0).await);
    let (st, v) = impact(
        &s,
        "harbour",
        json!({"position": [0.0, 0.0], "t": 100.0, "strength": 0.5, "radius": 1.0}),
    )
    .await;
    assert_eq!(st, 202, "{v}");
    assert_eq!(v, json!({"tick": 3000, "t": 100.0}));
    // Before t0 nothing changed; after it, the ring moved heights along the line.
    assert_eq!(heights(&s, "harbour", 99.0).await, b_early);
    let a_late = heights(&s, "harbour", 102.0).await;
    let moved = a_late.iter().zip(&b_late).filter(|(a, b)| a != b).count();
    assert!(moved > 5, "the ring moves heights: {moved}");
    // The list endpoint has it, with its tick.
    let (_, l) = s.get_json("/v1/scenes/harbour/impacts?t=101").await;
    assert_eq!(l["impacts"][0]["tick"], 3000);
    assert_eq!(l["impacts"][0]["position"], json!([0.0, 0.0]));
    s.stop().await;

    // A restarted server has the impact: the same bits at the same t.
    let s = TestServer::start(config_with_dir(dir.path().to_owned())).await;
    assert_eq!(heights(&s, "harbour", 102.0).await, a_late);
    // A second impact goes to the log's tail after the snapshot; both survive.
    let (st, _) = impact(
        &s,
        "harbour",
        json!({"position": [6.0, 0.0], "t": 101.0, "strength": 0.2, "radius": 0.5}),
    )
    .await;
    assert_eq!(st, 202);
    let two = heights(&s, "harbour", 102.0).await;
    assert_ne!(two, a_late);
    s.stop().await;
    let s = TestServer::start(config_with_dir(dir.path().to_owned())).await;
    assert_eq!(heights(&s, "harbour", 102.0).await, two);
    let (_, l) = s.get_json("/v1/scenes/harbour/impacts?t=101").await;
    assert_eq!(l["impacts"].as_array().unwrap().len(), 2);
    // Replacing the scene starts its impacts afresh (journaled too).
    let (_, spec) = s.get_json("/v1/scenes/harbour").await;
    let (st, _) = s.put_scene("harbour", &spec["spec"]).await;
    assert_eq!(st, 200);
    assert_eq!(heights(&s, "harbour", 102.0).await, b_late);
    s.stop().await;
    let s = TestServer::start(config_with_dir(dir.path().to_owned())).await;
    assert_eq!(heights(&s, "harbour", 102.0).await, b_late);
    s.stop().await;
}

#[tokio::test]
async fn bad_impacts_are_rejected_with_the_field_named() {
    let s = TestServer::start(config()).await;
    let ok = json!({"position": [1.0, 2.0], "strength": 0.3, "radius": 0.5});
    let (st, _) = s
        .admin(Method::POST, "/v1/scenes/harbour/impacts", Some(&ok), None)
        .await;
    assert_eq!(st, 401);
    for (body, field) in [
        (
            json!({"position": [1.0, 2.0], "strength": 0.0, "radius": 0.5}),
            "strength",
        ),
        (
            json!({"position": [1.0, 2.0], "strength": 0.3, "radius": 5000.0}),
            "radius",
        ),
        (
            json!({"position": [1e12, 2.0], "strength": 0.3, "radius": 0.5}),
            "position[0]",
        ),
        (
            json!({"position": [1.0, 2.0], "strength": 0.3, "radius": 0.5, "t": 1e13}),
            "t",
        ),
    ] {
        let (st, v) = impact(&s, "harbour", body).await;
        assert_eq!((st, code(&v)), (400, "invalid_value"), "{v}");
        assert_eq!(v["error"]["field"], field, "{v}");
    }
    let (st, v) = impact(
        &s,
        "harbour",
        json!({"position": [1.0, 2.0], "strength": 0.3, "radius": 0.5, "size": 1}),
    )
    .await;
    assert_eq!((st, code(&v)), (400, "bad_json"), "{v}");
    let (st, v) = impact(&s, "calm", ok.clone()).await;
    assert_eq!((st, code(&v)), (422, "invalid_spec"), "{v}");
    let (st, _) = impact(&s, "nowhere", ok).await;
    assert_eq!(st, 404);
    s.stop().await;
}

/// A subscriber gets the impact in a tick frame, in both codecs, at (or before) the tick the
/// POST answered with.
#[tokio::test]
async fn tick_frames_carry_new_impacts() {
    let s = TestServer::start(config()).await;
    for proto in [false, true] {
        let mut ws = ws_connect(s.addr, "harbour", proto.then_some("swell.v1.protobuf")).await;
        let sub = json!({"type": "subscribe", "ticks": true});
        if proto {
            let m = v1::ClientMessage {
                id: None,
                msg: Some(v1::client_message::Msg::Subscribe(v1::Subscribe {
                    ticks: true,
                    ..Default::default()
                })),
            };
            ws.send(Message::Binary(m.encode_to_vec().into()))
                .await
                .unwrap();
        } else {
            ws.send(Message::Text(sub.to_string().into()))
                .await
                .unwrap();
        }
        // Wait for the first frame so the loop runs, then add an impact at the next tick.
        let _ = timeout(Duration::from_secs(10), ws.next()).await.unwrap();
        let (st, v) = impact(
            &s,
            "harbour",
            json!({"position": [3.0, 4.0], "strength": 0.25, "radius": 0.75}),
        )
        .await;
        assert_eq!(st, 202, "{v}");
        let t0 = v["t"].as_f64().unwrap();
        let found = timeout(Duration::from_secs(10), async {
            loop {
                let m = ws.next().await.unwrap().unwrap();
                match m {
                    Message::Text(t) => {
                        let f: Value = serde_json::from_str(t.as_str()).unwrap();
                        if let Some(list) = f["impacts"].as_array() {
                            return (
                                list[0]["t"].as_f64().unwrap(),
                                list[0]["position"][1].as_f64().unwrap(),
                            );
                        }
                    }
                    Message::Binary(b) => {
                        let f = v1::ServerMessage::decode(b.as_ref()).unwrap();
                        if let Some(v1::server_message::Msg::Tick(tick)) = f.msg
                            && let Some(e) = tick.impacts.first()
                        {
                            return (e.t, e.z);
                        }
                    }
                    _ => {}
                }
            }
        })
        .await
        .expect("a frame with the impact");
        assert_eq!(found, (t0, 4.0), "proto = {proto}");
    }
    s.stop().await;
}
