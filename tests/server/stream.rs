//! The WebSocket stream over real sockets: both subprotocols, ping/pong, queries bit-identical
//! to HTTP, tick frames, errors that keep the socket open, limits, slow consumers and shutdown.

use crate::common;

use std::time::Duration;

use common::{TestServer, Ws, bits, config, ws_connect, ws_try_connect};
use futures_util::{SinkExt, StreamExt};
use prost::Message as _;
use serde_json::{Value, json};
use swell::wire::v1;
use tokio::time::timeout;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::protocol::frame::coding::CloseCode;

pub(crate) async fn send_json(ws: &mut Ws, v: Value) {
    ws.send(Message::Text(v.to_string().into()))
        .await
        .expect("send");
}

/// The next text frame as JSON (skipping tick frames unless `ticks`).
pub(crate) async fn recv_json(ws: &mut Ws, ticks: bool) -> Value {
    loop {
        let m = timeout(Duration::from_secs(10), ws.next())
            .await
            .expect("a message within 10 s")
            .expect("socket open")
            .expect("frame");
        if let Message::Text(t) = m {
            let v: Value = serde_json::from_str(t.as_str()).expect("JSON");
            if ticks || v["type"] != "tick" {
                return v;
            }
        }
    }
}

async fn recv_proto(ws: &mut Ws) -> v1::ServerMessage {
    loop {
        let m = timeout(Duration::from_secs(10), ws.next())
            .await
            .expect("a message within 10 s")
            .expect("socket open")
            .expect("frame");
        if let Message::Binary(b) = m {
            return v1::ServerMessage::decode(b.as_ref()).expect("ServerMessage");
        }
    }
}

/// Every number of `a` and `b` (same shape) has the same bits; `a` may carry extra keys
/// (`type`, `id`).
fn assert_same_bits(a: &Value, b: &Value, path: &str) {
    match b {
        Value::Number(_) => assert_eq!(bits(a), bits(b), "{path}: {a} vs {b}"),
        Value::Array(items) => {
            let other = a
                .as_array()
                .unwrap_or_else(|| panic!("{path}: not an array"));
            assert_eq!(other.len(), items.len(), "{path}: length");
            for (i, (x, y)) in other.iter().zip(items).enumerate() {
                assert_same_bits(x, y, &format!("{path}[{i}]"));
            }
        }
        Value::Object(map) => {
            for (k, y) in map {
                assert_same_bits(&a[k], y, &format!("{path}.{k}"));
            }
        }
        other => assert_eq!(a, other, "{path}"),
    }
}

#[tokio::test]
async fn json_is_the_default_and_ping_answers_with_scene_time() {
    let s = TestServer::start(config()).await;
    let mut ws = ws_connect(s.addr, "calm", None).await;
    send_json(
        &mut ws,
        json!({"type": "ping", "id": 1, "client_time": 12.5}),
    )
    .await;
    let v = recv_json(&mut ws, false).await;
    assert_eq!(v["type"], "pong", "{v}");
    assert_eq!(v["id"], 1);
    assert_eq!(v["client_time"], 12.5);
    let t = v["scene_time"].as_f64().expect("scene_time");
    let (_, clock) = s.get_json("/v1/scenes/calm/clock").await;
    let hz = clock["tick_hz"].as_f64().unwrap();
    assert_eq!(v["tick"].as_i64().unwrap(), (t * hz).floor() as i64);
    assert!(clock["t"].as_f64().unwrap() >= t, "the clock moves forward");
    s.stop().await;
}

#[tokio::test]
async fn json_subprotocol_is_echoed_when_asked() {
    let s = TestServer::start(config()).await;
    use tokio_tungstenite::tungstenite::client::IntoClientRequest;
    let mut req = format!("ws://{}/v1/scenes/calm/stream", s.addr)
        .into_client_request()
        .unwrap();
    req.headers_mut().insert(
        "sec-websocket-protocol",
        "chat, swell.v1.json".parse().unwrap(),
    );
    let (_ws, resp) = tokio_tungstenite::connect_async(req)
        .await
        .expect("upgrade");
    assert_eq!(
        resp.headers()["sec-websocket-protocol"].to_str().unwrap(),
        "swell.v1.json"
    );
    s.stop().await;
}

#[tokio::test]
async fn sample_and_orientation_on_the_socket_equal_http_bits() {
    let s = TestServer::start(config()).await;
    let mut ws = ws_connect(s.addr, "lake", Some("swell.v1.json")).await;
    let requests = [
        (
            "sample",
            json!({"t": 60.25, "points": [[0, 0], [12.5, -3], [1e3, 7.75]],
                   "fields": ["height", "normal", "displacement", "jacobian", "residual"]}),
        ),
        (
            "sample",
            json!({"t": 3.5, "origin": [10000, -20000], "points": [[0.5, 0.25], [-3, 4]],
                   "fields": ["height", "normal"], "accuracy": {"method": "fixed_point", "iterations": 5}}),
        ),
        (
            "orientation",
            json!({"t": 7, "bodies": [{"position": [5, 5], "yaw": 0.3, "length": 12, "beam": 4},
                                       {"position": [-20, 3], "length": 4, "beam": 2, "probes": [[1, 0], [-1, 0], [0, 1]]}]}),
        ),
    ];
    for (i, (kind, body)) in requests.iter().enumerate() {
        let (st, http) = s.post_json(&format!("/v1/scenes/lake/{kind}"), body).await;
        assert_eq!(st, 200, "{http}");
        let mut msg = body.clone();
        msg["type"] = json!(kind);
        msg["id"] = json!(i);
        send_json(&mut ws, msg).await;
        let v = recv_json(&mut ws, false).await;
        assert_eq!(v["type"], format!("{kind}_result"), "{v}");
        assert_eq!(v["id"], i);
        assert_same_bits(&v, &http, kind);
    }
    s.stop().await;
}

#[tokio::test]
async fn protobuf_subprotocol_answers_with_http_bits() {
    let s = TestServer::start(config()).await;
    let mut ws = ws_connect(s.addr, "open-sea", Some("swell.v1.protobuf")).await;
    // Ping.
    let ping = v1::ClientMessage {
        id: Some(9),
        msg: Some(v1::client_message::Msg::Ping(v1::Ping { client_time: 4.0 })),
    };
    ws.send(Message::Binary(ping.encode_to_vec().into()))
        .await
        .unwrap();
    let m = recv_proto(&mut ws).await;
    assert_eq!(m.id, Some(9));
    let Some(v1::server_message::Msg::Pong(p)) = m.msg else {
        panic!("{m:?}")
    };
    assert_eq!(p.client_time, 4.0);
    // Sample, against HTTP JSON.
    let body = json!({"t": 42.125, "origin": [5000, 6000], "points": [[0, 0], [1.5, 2], [-7, 3]],
                      "fields": ["height", "normal", "jacobian"]});
    let (_, http) = s.post_json("/v1/scenes/open-sea/sample", &body).await;
    let pts = [(0.0, 0.0), (1.5, 2.0), (-7.0, 3.0)]
        .map(|(x, z)| v1::Point2 { x, z })
        .to_vec();
    let req = v1::ClientMessage {
        id: Some(10),
        msg: Some(v1::client_message::Msg::Sample(v1::SampleRequest {
            t: Some(42.125),
            origin: Some(v1::Point2 {
                x: 5000.0,
                z: 6000.0,
            }),
            points: pts,
            fields: vec![
                v1::Field::Height as i32,
                v1::Field::Normal as i32,
                v1::Field::Jacobian as i32,
            ],
            accuracy: None,
        })),
    };
    ws.send(Message::Binary(req.encode_to_vec().into()))
        .await
        .unwrap();
    let m = recv_proto(&mut ws).await;
    assert_eq!(m.id, Some(10));
    let Some(v1::server_message::Msg::SampleResult(r)) = m.msg else {
        panic!("{m:?}")
    };
    assert_eq!(r.t.to_bits(), bits(&http["t"]));
    for (i, h) in r.height.iter().enumerate() {
        assert_eq!(h.to_bits(), bits(&http["height"][i]), "height[{i}]");
        let n = &r.normal[i];
        for (j, c) in [n.x, n.y, n.z].iter().enumerate() {
            assert_eq!(c.to_bits(), bits(&http["normal"][i][j]), "normal[{i}][{j}]");
        }
        assert_eq!(r.jacobian[i].to_bits(), bits(&http["jacobian"][i]));
        assert_eq!(r.folded[i], http["folded"][i].as_bool().unwrap());
    }
    // An invalid enum value is an error frame and the socket stays open.
    let bad = v1::ClientMessage {
        id: Some(11),
        msg: Some(v1::client_message::Msg::Sample(v1::SampleRequest {
            fields: vec![0],
            ..Default::default()
        })),
    };
    ws.send(Message::Binary(bad.encode_to_vec().into()))
        .await
        .unwrap();
    let m = recv_proto(&mut ws).await;
    let Some(v1::server_message::Msg::Error(e)) = m.msg else {
        panic!("{m:?}")
    };
    assert_eq!((m.id, e.field.as_deref()), (Some(11), Some("fields[0]")));
    // Garbage bytes too.
    ws.send(Message::Binary(vec![0xff, 0xff, 0xff].into()))
        .await
        .unwrap();
    let m = recv_proto(&mut ws).await;
    let Some(v1::server_message::Msg::Error(e)) = m.msg else {
        panic!("{m:?}")
    };
    assert_eq!(e.code, "bad_protobuf");
    ws.send(Message::Binary(ping.encode_to_vec().into()))
        .await
        .unwrap();
    assert!(matches!(
        recv_proto(&mut ws).await.msg,
        Some(v1::server_message::Msg::Pong(_))
    ));
    s.stop().await;
}

#[tokio::test]
async fn subscribe_sends_ticks_that_follow_the_clock() {
    let s = TestServer::start(config()).await;
    // small_spec ticks at 20 Hz.
    assert_eq!(s.put_scene("tick20", &common::small_spec()).await.0, 201);
    let mut ws = ws_connect(s.addr, "tick20", None).await;
    send_json(&mut ws, json!({"type": "subscribe", "ticks": true})).await;
    let mut ticks = Vec::new();
    while ticks.len() < 10 {
        let v = recv_json(&mut ws, true).await;
        assert_eq!(v["type"], "tick", "{v}");
        assert_eq!(v["bodies"], json!([]), "no bodies yet");
        let tick = v["tick"].as_i64().unwrap();
        assert_eq!(
            v["t"].as_f64().unwrap(),
            tick as f64 / 20.0,
            "t is the tick's start"
        );
        ticks.push(tick);
    }
    assert!(
        ticks.windows(2).all(|w| w[1] > w[0]),
        "increasing: {ticks:?}"
    );
    // Roughly the rate: 10 frames at 20 Hz span about 10 ticks (skips only when starved).
    assert!(ticks[9] - ticks[0] < 40, "{ticks:?}");

    // Reversed clock: ticks go down.
    s.put_clock("tick20", &json!({"rate": -1})).await;
    let mut down = Vec::new();
    let mut clock_events = 0;
    while down.len() < 5 {
        let v = recv_json(&mut ws, true).await;
        // The change itself is announced to the session (issue 28), between frames.
        if v["type"] == "clock" {
            assert_eq!((&v["rate"], &v["generation"]), (&json!(-1.0), &json!(1)));
            clock_events += 1;
            continue;
        }
        down.push(v["tick"].as_i64().unwrap());
    }
    // The first frame may still be from before the change.
    assert!(
        down[1..].windows(2).all(|w| w[1] < w[0]),
        "decreasing: {down:?}"
    );
    assert_eq!(clock_events, 1, "one clock event for one change");

    // Paused: no new frames.
    s.put_clock("tick20", &json!({"paused": true})).await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    while let Ok(Some(_)) = timeout(Duration::from_millis(10), ws.next()).await {}
    assert!(
        timeout(Duration::from_millis(400), ws.next())
            .await
            .is_err(),
        "no frames while paused"
    );

    // Unsubscribe: the scene's loop stops once nobody listens.
    send_json(&mut ws, json!({"type": "subscribe", "ticks": false})).await;
    send_json(&mut ws, json!({"type": "ping", "id": 1, "client_time": 0})).await;
    assert_eq!(recv_json(&mut ws, false).await["type"], "pong");
    let mut stopped = false;
    for _ in 0..50 {
        if s.state_tickers() == 0 {
            stopped = true;
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert!(stopped, "the tick loop stops without subscribers");
    s.stop().await;
}

#[tokio::test]
async fn errors_come_back_as_error_frames_and_the_socket_stays_open() {
    let s = TestServer::start(config()).await;
    let mut ws = ws_connect(s.addr, "calm", None).await;
    ws.send(Message::Text("{not json".into())).await.unwrap();
    let v = recv_json(&mut ws, false).await;
    assert_eq!(
        (v["type"].as_str(), v["code"].as_str()),
        (Some("error"), Some("bad_json"))
    );

    send_json(&mut ws, json!({"type": "dance", "id": 5})).await;
    let v = recv_json(&mut ws, false).await;
    assert_eq!(
        (v["id"].as_u64(), v["code"].as_str()),
        (Some(5), Some("unknown_type"))
    );

    send_json(
        &mut ws,
        json!({"type": "sample", "id": 6, "points": [[0, 0]], "fields": ["colour"]}),
    )
    .await;
    let v = recv_json(&mut ws, false).await;
    assert_eq!(
        (v["id"].as_u64(), v["code"].as_str()),
        (Some(6), Some("unknown_field"))
    );
    assert_eq!(v["field"], "fields[0]");

    send_json(
        &mut ws,
        json!({"type": "sample", "id": 7, "t": 1e300, "points": [[0, 0]]}),
    )
    .await;
    let v = recv_json(&mut ws, false).await;
    assert_eq!(
        (v["id"].as_u64(), v["field"].as_str()),
        (Some(7), Some("t"))
    );

    ws.send(Message::Binary(vec![1, 2, 3].into()))
        .await
        .unwrap();
    let v = recv_json(&mut ws, false).await;
    assert_eq!(v["code"], "wrong_frame_type");

    send_json(&mut ws, json!({"type": "ping", "id": 8, "client_time": 1})).await;
    let v = recv_json(&mut ws, false).await;
    assert_eq!(
        (v["type"].as_str(), v["id"].as_u64()),
        (Some("pong"), Some(8))
    );
    s.stop().await;
}

#[tokio::test]
async fn unknown_scene_and_plain_get_are_refused_before_the_upgrade() {
    let s = TestServer::start(config()).await;
    match ws_try_connect(s.addr, "nope", None).await {
        Err(tokio_tungstenite::tungstenite::Error::Http(r)) => assert_eq!(r.status(), 404),
        other => panic!("expected 404, got {other:?}"),
    }
    match ws_try_connect(s.addr, "calm", Some("mqtt")).await {
        Err(tokio_tungstenite::tungstenite::Error::Http(r)) => assert_eq!(r.status(), 400),
        other => panic!("expected 400, got {other:?}"),
    }
    let (st, v) = s.get_json("/v1/scenes/calm/stream").await;
    assert_eq!((st, common::code(&v)), (400, "websocket_required"));
    s.stop().await;
}

/// A message many times the socket's read buffer (`stream::WS_READ_BUFFER_BYTES`, 8 KiB) is read
/// whole over several reads: a ping padded with 200 kB of JSON whitespace gets its pong.
#[tokio::test]
async fn a_message_longer_than_the_read_buffer_is_read_whole() {
    let s = TestServer::start(config()).await;
    let mut ws = ws_connect(s.addr, "calm", None).await;
    let padded = format!(
        r#"{{"type":"ping","id":2,{}"client_time":1.5}}"#,
        " ".repeat(25 * swell::stream::WS_READ_BUFFER_BYTES)
    );
    ws.send(Message::Text(padded.into())).await.expect("send");
    let v = recv_json(&mut ws, false).await;
    assert_eq!(
        (&v["type"], &v["id"], &v["client_time"]),
        (&json!("pong"), &json!(2), &json!(1.5)),
        "{v}"
    );
    s.stop().await;
}

/// Regression (issue 11): a message over `ws_max_message_bytes` dropped the connection without
/// the documented Close 1009: the client saw no status (1005) or an abnormal closure. (This test
/// used to accept a close without a frame.) Both a message a little over the limit and one far
/// over it, most of which the server never reads, must get Close 1009 with a reason.
#[tokio::test]
async fn issue_11_oversized_message_gets_close_1009() {
    let mut cfg = config();
    cfg.limits.ws_max_message_bytes = 4096;
    let s = TestServer::start(cfg).await;
    for pad in [8192, 512 * 1024] {
        let mut ws = ws_connect(s.addr, "calm", None).await;
        let big = format!(
            r#"{{"type":"ping","client_time":0,"pad":"{}"}}"#,
            "x".repeat(pad)
        );
        let _ = ws.send(Message::Text(big.into())).await;
        let end = timeout(Duration::from_secs(5), async {
            loop {
                match ws.next().await {
                    Some(Ok(Message::Close(f))) => return Ok(f),
                    Some(Ok(_)) => {}
                    other => return Err(format!("{other:?}")),
                }
            }
        })
        .await
        .expect("closed within 5 s");
        let frame = end
            .unwrap_or_else(|e| panic!("{pad}: no Close frame, the stream ended with {e}"))
            .unwrap_or_else(|| panic!("{pad}: a Close frame without a status code"));
        assert_eq!(frame.code, CloseCode::Size, "{pad}: {frame:?}");
        assert!(frame.reason.contains("4096"), "{pad}: {frame:?}");
    }
    s.stop().await;
}

/// A subscriber that stops reading and sends nothing is disconnected once one message has
/// waited `ws_send_stall_ms` for its socket (tick frames are read by the socket's writer task,
/// not queued), while another subscriber keeps getting the ticks.
#[tokio::test]
async fn a_subscriber_that_stops_reading_is_disconnected_after_the_send_stall() {
    let mut cfg = config();
    cfg.limits.ws_send_stall_ms = 300;
    let s = TestServer::start(cfg).await;
    let mut spec = common::small_spec();
    spec["tick_hz"] = json!(60);
    assert_eq!(s.put_scene("busy", &spec).await.0, 201);
    // 100 boats: JSON frames of ~15 kB, ~1 MB/s.
    spawn_boats(&s, "busy", 100).await;
    let mut healthy = ws_connect(s.addr, "busy", None).await;
    send_json(&mut healthy, json!({"type": "subscribe", "ticks": true})).await;
    // The slow client's socket holds 4 kB, so the server's sends block within a second.
    let socket = tokio::net::TcpSocket::new_v4().unwrap();
    socket.set_recv_buffer_size(4096).unwrap();
    let stream = socket.connect(s.addr).await.unwrap();
    let url = format!("ws://{}/v1/scenes/busy/stream", s.addr);
    let (mut slow, _) = tokio_tungstenite::client_async(url, stream).await.unwrap();
    slow.send(Message::Text(
        json!({"type": "subscribe", "ticks": true})
            .to_string()
            .into(),
    ))
    .await
    .unwrap();
    // Meanwhile the healthy client gets the ticks.
    let mut ticks = 0;
    let window = tokio::time::Instant::now();
    while window.elapsed() < Duration::from_secs(3) {
        if recv_json(&mut healthy, true).await["type"] == "tick" {
            ticks += 1;
        }
    }
    assert!(
        ticks >= 60,
        "healthy client got {ticks} ticks in 3 s at 60 Hz"
    );
    // The slow client reads what was buffered, then finds the connection closed. Had the
    // server kept it, reading would let its frames flow again and never end.
    let ended = timeout(Duration::from_secs(10), async {
        loop {
            match slow.next().await {
                Some(Ok(Message::Close(_))) | Some(Err(_)) | None => return,
                Some(Ok(_)) => {}
            }
        }
    })
    .await;
    assert!(
        ended.is_ok(),
        "the subscriber that stopped reading was not disconnected"
    );
    s.stop().await;
}

#[tokio::test]
async fn a_client_that_stops_reading_is_disconnected_without_delaying_others() {
    let mut cfg = config();
    cfg.limits.ws_send_queue = 8;
    let s = TestServer::start(cfg).await;
    assert_eq!(s.put_scene("tick20", &common::small_spec()).await.0, 201);
    let mut healthy = ws_connect(s.addr, "tick20", None).await;
    send_json(&mut healthy, json!({"type": "subscribe", "ticks": true})).await;
    let mut slow = ws_connect(s.addr, "tick20", None).await;
    send_json(&mut slow, json!({"type": "subscribe", "ticks": true})).await;
    // Each answer is ~0.5 MB of JSON; 60 of them overflow any socket buffer, and the slow client
    // never reads while they are sent.
    let points: Vec<[f64; 2]> = (0..4000)
        .map(|i| [i as f64 * 0.37, i as f64 * -0.11])
        .collect();
    const SENT: u64 = 60;
    for i in 0..SENT {
        let msg = json!({"type": "sample", "id": i, "t": 1.0, "points": points,
                         "fields": ["height", "normal", "displacement"]});
        if slow
            .send(Message::Text(msg.to_string().into()))
            .await
            .is_err()
        {
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // Meanwhile the healthy client keeps getting ticks.
    let mut ticks = 0;
    let window = tokio::time::Instant::now();
    while window.elapsed() < Duration::from_secs(1) {
        let v = recv_json(&mut healthy, true).await;
        if v["type"] == "tick" {
            ticks += 1;
        }
    }
    assert!(
        ticks >= 5,
        "healthy client got {ticks} ticks in 1 s at 20 Hz"
    );
    // The slow client finds its stream cut short: fewer answers than asked, then the end.
    let mut answers = 0;
    let ended = timeout(Duration::from_secs(20), async {
        loop {
            match slow.next().await {
                Some(Ok(Message::Text(t))) => {
                    if t.as_str().contains("sample_result") {
                        answers += 1;
                    }
                }
                Some(Ok(Message::Close(_))) | Some(Err(_)) | None => return,
                Some(Ok(_)) => {}
            }
        }
    })
    .await;
    assert!(ended.is_ok(), "the slow client's connection ends");
    assert!(
        answers < SENT,
        "got {answers} of {SENT} answers before the cut"
    );
    // And the healthy client is still served.
    send_json(
        &mut healthy,
        json!({"type": "ping", "id": 1, "client_time": 0}),
    )
    .await;
    assert_eq!(recv_json(&mut healthy, false).await["type"], "pong");
    s.stop().await;
}

#[tokio::test]
async fn graceful_shutdown_sends_close_to_open_sockets() {
    let mut s = TestServer::start(config()).await;
    let mut ws = ws_connect(s.addr, "calm", None).await;
    send_json(&mut ws, json!({"type": "subscribe", "ticks": true})).await;
    recv_json(&mut ws, true).await;
    let task = s.begin_stop();
    let code = timeout(Duration::from_secs(5), async {
        loop {
            match ws.next().await {
                Some(Ok(Message::Close(f))) => return f.map(|f| f.code),
                Some(Ok(_)) => {}
                other => panic!("stream ended without Close: {other:?}"),
            }
        }
    })
    .await
    .expect("Close within 5 s");
    assert_eq!(code, Some(CloseCode::Away));
    drop(ws);
    timeout(Duration::from_secs(10), task)
        .await
        .expect("server stops")
        .expect("task")
        .expect("clean");
}

/// Issue 10's pin: on an FFT scene, the same `t` gives the same bits from `/height`, `/sample`
/// and the WebSocket, asked at the clock's now (no `t`) or with that time written out, whether
/// the grid frames are computed by the query or were cached by an earlier one; and `"exact"`
/// time sampling is a different (sub-millimetre) answer, not a cached grid one.
#[tokio::test]
async fn now_and_the_same_explicit_t_give_the_same_bits_on_every_path() {
    let s = TestServer::start(config()).await;
    for scene in ["storm", "open-sea"] {
        // A paused clock between two grid times: now is one fixed number.
        let (st, c) = s
            .put_clock(scene, &json!({"t": 1234.5678, "paused": true}))
            .await;
        assert_eq!(st, 200, "{c}");
        let now = c["t"].as_f64().unwrap();
        let (x, z) = (12.5, -3.25);
        let mut answers = Vec::new();
        for q in [
            format!("/v1/scenes/{scene}/height?x={x}&z={z}"),
            format!("/v1/scenes/{scene}/height?x={x}&z={z}&t={now}"),
        ] {
            let (st, v) = s.get_json(&q).await;
            assert_eq!(st, 200, "{v}");
            assert_eq!(bits(&v["t"]), now.to_bits());
            answers.push((q, bits(&v["height"])));
        }
        for body in [
            json!({"points": [[x, z]]}),
            json!({"t": now, "points": [[x, z]]}),
        ] {
            let (st, v) = s
                .post_json(&format!("/v1/scenes/{scene}/sample"), &body)
                .await;
            assert_eq!(st, 200, "{v}");
            answers.push((format!("sample {body}"), bits(&v["height"][0])));
        }
        let mut ws = ws_connect(s.addr, scene, None).await;
        for (i, body) in [
            json!({"type": "sample", "id": 1, "points": [[x, z]]}),
            json!({"type": "sample", "id": 2, "t": now, "points": [[x, z]]}),
        ]
        .into_iter()
        .enumerate()
        {
            send_json(&mut ws, body.clone()).await;
            let v = recv_json(&mut ws, false).await;
            assert_eq!(v["id"], i + 1, "{v}");
            answers.push((format!("ws {body}"), bits(&v["height"][0])));
        }
        let first = answers[0].1;
        for (how, b) in &answers {
            assert_eq!(*b, first, "{scene}: {how} differs from {}", answers[0].0);
        }
        let (_, exact) = s
            .post_json(
                &format!("/v1/scenes/{scene}/sample"),
                &json!({"points": [[x, z]], "accuracy": {"time": "exact"}}),
            )
            .await;
        let (e, g) = (exact["height"][0].as_f64().unwrap(), f64::from_bits(first));
        assert!(
            e != g && (e - g).abs() < 1e-3,
            "{scene}: exact {e} vs grid {g}"
        );
        // The scene description states the grid clients must use to get these bits.
        let (_, d) = s.get_json(&format!("/v1/scenes/{scene}")).await;
        let layer = &d["derived"]["layers"][0];
        let (period, steps) = (
            layer["repeat_period"].as_f64().unwrap(),
            layer["grid_steps"].as_u64().unwrap(),
        );
        assert_eq!(steps as f64, period * 60.0, "{layer}");
        assert_eq!(bits(&layer["time_step"]), (period / steps as f64).to_bits());
    }
    s.stop().await;
}

/// A scene deleted under a subscriber: the session sends `not_found` (no id), then Close 4404
/// with the reason, so a client stops instead of reconnecting to a URL that now answers 404.
#[tokio::test]
async fn a_subscriber_of_a_deleted_scene_gets_not_found_then_close_4404() {
    let s = TestServer::start(config()).await;
    assert_eq!(s.put_scene("doomed", &common::small_spec()).await.0, 201);
    let mut ws = ws_connect(s.addr, "doomed", None).await;
    send_json(&mut ws, json!({"type": "subscribe", "ticks": true})).await;
    let v = recv_json(&mut ws, true).await;
    assert_eq!(v["type"], "tick", "{v}");
    let (st, _) = s
        .admin(
            reqwest::Method::DELETE,
            "/v1/scenes/doomed",
            None,
            Some(common::TOKEN),
        )
        .await;
    assert_eq!(st, 204);
    let v = recv_json(&mut ws, false).await;
    assert_eq!(
        (v["type"].as_str(), v["code"].as_str()),
        (Some("error"), Some("not_found")),
        "{v}"
    );
    assert!(v.get("id").is_none(), "{v}");
    let close = loop {
        match timeout(Duration::from_secs(5), ws.next()).await {
            Ok(Some(Ok(Message::Close(c)))) => break c,
            Ok(Some(Ok(_))) => continue,
            other => panic!("no Close frame: {other:?}"),
        }
    };
    let close = close.expect("a close code");
    assert_eq!(close.code, CloseCode::from(swell::stream::SCENE_GONE));
    assert!(close.reason.contains("doomed"), "{}", close.reason);
    s.stop().await;
}

/// Spawns `n` floating boxes on `scene`, in a grid 20 m apart; their ids.
async fn spawn_boats(s: &TestServer, scene: &str, n: u32) -> Vec<u64> {
    let mut ids = Vec::new();
    for i in 0..n {
        let boat = json!({"mass": 3000.0,
            "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5},
            "position": [f64::from(i % 10) * 20.0, 0.6, f64::from(i / 10) * 20.0]});
        let (st, v) = s
            .admin(
                reqwest::Method::POST,
                &format!("/v1/scenes/{scene}/bodies"),
                Some(&boat),
                Some(common::TOKEN),
            )
            .await;
        assert_eq!(st, 201, "{v}");
        ids.push(v["id"].as_u64().expect("id"));
    }
    ids
}

/// The ids of a tick frame's bodies.
fn frame_bodies(f: &Value) -> Vec<u64> {
    f["bodies"]
        .as_array()
        .expect("bodies")
        .iter()
        .map(|b| b["id"].as_u64().expect("id"))
        .collect()
}

/// More subscribers than a task's I/O budget (tokio's 128 operations a poll): the scene's
/// shards write every frame straight to the sockets of subscribers that read, each its own
/// bodies, in tick order; none is left to a subscriber's writer task.
#[tokio::test]
async fn three_hundred_subscribers_get_their_frames_straight_from_the_shards() {
    let s = TestServer::start(config()).await;
    let mut spec = common::small_spec();
    spec["tick_hz"] = json!(30);
    assert_eq!(s.put_scene("crowd", &spec).await.0, 201);
    let boats = spawn_boats(&s, "crowd", 10).await;
    let mut clients = Vec::new();
    for i in 0..300 {
        let mut ws = ws_connect(s.addr, "crowd", None).await;
        let mine = boats[i % boats.len()];
        send_json(
            &mut ws,
            json!({"type": "subscribe", "ticks": true, "bodies": [mine]}),
        )
        .await;
        clients.push((ws, mine));
    }
    // Every client reads at once, a second's worth of frames each.
    let readers = clients.into_iter().map(|(mut ws, mine)| {
        tokio::spawn(async move {
            let mut ticks = Vec::new();
            while ticks.len() < 30 {
                let f = recv_json(&mut ws, true).await;
                if f["type"] != "tick" {
                    continue;
                }
                assert_eq!(frame_bodies(&f), [mine], "{f}");
                ticks.push(f["tick"].as_i64().expect("tick"));
            }
            ws
        })
    });
    let mut open = Vec::new();
    for (i, r) in futures_util::future::join_all(readers)
        .await
        .into_iter()
        .enumerate()
    {
        open.push(r.unwrap_or_else(|e| panic!("subscriber {i}: {e}")));
    }
    let lp = s.state.tickers.get("crowd").expect("the scene's loop runs");
    assert_eq!(
        lp.handed_off(),
        0,
        "frames left to writer tasks with every subscriber reading"
    );
    drop(open);
    s.stop().await;
}

/// A subscriber whose socket fills while it does not read is not cut off before the send
/// stall: once it reads again, the frames come again, the newest first, the ones in between
/// skipped (a gap in the tick numbers, never an older tick after a newer one).
#[tokio::test]
async fn a_subscriber_that_pauses_reading_skips_to_the_newest_frame() {
    let mut cfg = config();
    cfg.limits.ws_send_stall_ms = 20_000;
    cfg.limits.ws_read_check_ms = 0;
    let s = TestServer::start(cfg).await;
    let mut spec = common::small_spec();
    spec["tick_hz"] = json!(60);
    assert_eq!(s.put_scene("busy", &spec).await.0, 201);
    // 100 boats: JSON frames of ~15 kB, ~1 MB/s.
    spawn_boats(&s, "busy", 100).await;
    // The client's socket holds 4 kB, so the server's socket is full within a second.
    let socket = tokio::net::TcpSocket::new_v4().unwrap();
    socket.set_recv_buffer_size(4096).unwrap();
    let stream = socket.connect(s.addr).await.unwrap();
    let url = format!("ws://{}/v1/scenes/busy/stream", s.addr);
    let (mut ws, _) =
        tokio_tungstenite::client_async(url, tokio_tungstenite::MaybeTlsStream::Plain(stream))
            .await
            .unwrap();
    send_json(&mut ws, json!({"type": "subscribe", "ticks": true})).await;
    let first = recv_json(&mut ws, true).await;
    assert_eq!(first["type"], "tick", "{first}");
    tokio::time::sleep(Duration::from_secs(3)).await;
    let lp = s.state.tickers.get("busy").expect("the scene's loop runs");
    assert!(
        lp.handed_off() > 0,
        "3 s of frames not read, and none was left to the writer"
    );
    // Reading again: ticks only go up, with a gap where the socket had no room, and keep
    // coming.
    let mut last = first["tick"].as_i64().unwrap();
    let mut gap = 0;
    let mut after = 0;
    let resumed = tokio::time::Instant::now();
    while resumed.elapsed() < Duration::from_secs(3) {
        let f = recv_json(&mut ws, true).await;
        if f["type"] != "tick" {
            continue;
        }
        let t = f["tick"].as_i64().unwrap();
        assert!(t > last, "tick {t} after tick {last}");
        gap = gap.max(t - last - 1);
        last = t;
        after += 1;
    }
    assert!(
        gap >= 30,
        "no frame skipped during 3 s unread (largest gap {gap} ticks)"
    );
    assert!(
        after >= 90,
        "{after} frames in the 3 s after reading again, at 60 Hz"
    );
    s.stop().await;
}
