//! Scene clock over HTTP: pause, rate, seek; queries without `t` use the clock.
//! Paused clocks make every assertion exact (no timing flakiness).

use crate::common;

use common::{TestServer, bits, config};
use serde_json::json;

#[tokio::test]
async fn pause_seek_rate_and_resume() {
    let s = TestServer::start(config()).await;
    // Seek and pause at once: t is exactly 100 from then on.
    let (st, c) = s
        .put_clock("calm", &json!({"t": 100.0, "paused": true}))
        .await;
    assert_eq!(st, 200, "{c}");
    assert_eq!(c["t"], json!(100.0));
    assert_eq!(c["paused"], json!(true));
    assert_eq!(c["tick"], json!(3000));
    assert_eq!(c["tick_hz"], json!(30.0));
    let (_, c2) = s.get_json("/v1/scenes/calm/clock").await;
    assert_eq!(c2["t"], json!(100.0));

    // A query without t runs at the clock's t and says so; it equals the query at t = 100.
    let (_, now) = s.get_json("/v1/scenes/calm/height?x=3&z=4").await;
    assert_eq!(now["t"], json!(100.0));
    let (_, explicit) = s.get_json("/v1/scenes/calm/height?x=3&z=4&t=100").await;
    assert_eq!(bits(&now["height"]), bits(&explicit["height"]));
    let (_, sample) = s
        .post_json("/v1/scenes/calm/sample", &json!({"points": [[3, 4]]}))
        .await;
    assert_eq!(sample["t"], json!(100.0));

    // Rate changes while paused keep t.
    let (_, c) = s.put_clock("calm", &json!({"rate": -2.0})).await;
    assert_eq!(
        (c["t"].as_f64(), c["rate"].as_f64()),
        (Some(100.0), Some(-2.0))
    );

    // Resume: runs backwards from 100.
    let (_, c) = s.put_clock("calm", &json!({"paused": false})).await;
    assert_eq!(c["paused"], json!(false));
    tokio::time::sleep(std::time::Duration::from_millis(30)).await;
    let (_, c) = s.get_json("/v1/scenes/calm/clock").await;
    let t = c["t"].as_f64().unwrap();
    assert!(t < 100.0 && t > 90.0, "running backwards: {t}");

    // Pause again: frozen where it was.
    let (_, c) = s.put_clock("calm", &json!({"paused": true})).await;
    let frozen = c["t"].as_f64().unwrap();
    tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    let (_, c) = s.get_json("/v1/scenes/calm/clock").await;
    assert_eq!(c["t"].as_f64().unwrap(), frozen);

    // Clocks are per scene.
    let (_, other) = s.get_json("/v1/scenes/lake/clock").await;
    assert_eq!(other["rate"], json!(1.0));
    s.stop().await;
}

#[tokio::test]
async fn fast_forward_runs_faster() {
    let s = TestServer::start(config()).await;
    s.put_clock("lake", &json!({"t": 0.0, "rate": 1000.0}))
        .await;
    tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    let (_, c) = s.get_json("/v1/scenes/lake/clock").await;
    assert!(c["t"].as_f64().unwrap() >= 50.0, "{c}");
    s.stop().await;
}

/// A clock sought to exactly `limits.max_time` (1e10 s by default) used to run on past it, so a
/// client that echoed the clock's `t` back (a height at now, a sample, the impacts at now) was
/// refused with 400 (`t` out of range). It holds at the limit now and reads as paused (rate
/// kept), and its `t` is accepted everywhere; a rate back inwards runs it again, and a fast
/// rate that reaches the other end holds it there too.
#[tokio::test]
async fn a_clock_at_max_time_holds_there_and_its_t_is_accepted() {
    let s = TestServer::start(config()).await;
    let max = swell::Limits::default().max_time;
    let (st, c) = s.put_clock("calm", &json!({"t": max})).await;
    assert_eq!(st, 200, "{c}");
    assert_eq!(c["t"], json!(max));
    assert_eq!(
        (&c["rate"], &c["paused"]),
        (&json!(1.0), &json!(true)),
        "{c}"
    );
    tokio::time::sleep(std::time::Duration::from_millis(30)).await;
    let (_, c) = s.get_json("/v1/scenes/calm/clock").await;
    assert_eq!(c["t"], json!(max), "held at max_time: {c}");
    assert_eq!(c["paused"], json!(true), "{c}");
    assert_eq!(c["tick"], json!(max as i64 * 30), "{c}");
    let now = c["t"].as_f64().unwrap();

    // The clock's t, echoed back, is a valid time everywhere; a query without t runs at it.
    let (st, h) = s
        .get_json(&format!("/v1/scenes/calm/height?x=1&z=2&t={now}"))
        .await;
    assert_eq!(st, 200, "{h}");
    let (_, at_now) = s.get_json("/v1/scenes/calm/height?x=1&z=2").await;
    assert_eq!(at_now["t"], json!(max));
    assert_eq!(bits(&at_now["height"]), bits(&h["height"]));
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/sample",
            &json!({"t": now, "points": [[1, 2]]}),
        )
        .await;
    assert_eq!((st, &v["t"]), (200, &json!(max)), "{v}");
    let (st, v) = s
        .get_json(&format!("/v1/scenes/harbour/impacts?t={now}"))
        .await;
    assert_eq!(st, 200, "{v}");
    // Impacts: at the held t, and not past it (the default t, the next tick, is past it).
    let (st, h) = s.put_clock("harbour", &json!({"t": max})).await;
    assert_eq!(st, 200, "{h}");
    let splash = |t: Option<f64>| {
        let mut b = json!({"position": [0.0, 0.0], "strength": 0.5, "radius": 2.0});
        if let Some(t) = t {
            b["t"] = json!(t);
        }
        b
    };
    let server = &s;
    let post = |b: serde_json::Value| async move {
        server
            .admin(
                reqwest::Method::POST,
                "/v1/scenes/harbour/impacts",
                Some(&b),
                Some(common::TOKEN),
            )
            .await
    };
    let (st, v) = post(splash(Some(max))).await;
    assert_eq!((st, &v["t"]), (202, &json!(max)), "{v}");
    for past in [Some(max + 1.0), None] {
        let (st, v) = post(splash(past)).await;
        assert_eq!(
            (st, &v["error"]["field"]),
            (400, &json!("t")),
            "{past:?}: {v}"
        );
    }
    let (st, v) = s
        .get_json(&format!("/v1/scenes/calm/uniforms?t={now}"))
        .await;
    assert_eq!(st, 200, "{v}");

    // A rate inwards runs it again, from the limit.
    let (st, c) = s.put_clock("calm", &json!({"rate": -1.0})).await;
    assert_eq!(st, 200, "{c}");
    assert_eq!(c["paused"], json!(false), "{c}");
    let t = c["t"].as_f64().unwrap();
    assert!(t <= max && t > max - 1.0, "from the limit: {c}");
    tokio::time::sleep(std::time::Duration::from_millis(30)).await;
    let (_, c) = s.get_json("/v1/scenes/calm/clock").await;
    let t = c["t"].as_f64().unwrap();
    assert!(t < max && t > max - 10.0, "runs back from the limit: {c}");

    // A rate that reaches the other end holds there too.
    let (st, c) = s
        .put_clock("lake", &json!({"t": -max + 1.0, "rate": -1000.0}))
        .await;
    assert_eq!(st, 200, "{c}");
    tokio::time::sleep(std::time::Duration::from_millis(30)).await;
    let (_, c) = s.get_json("/v1/scenes/lake/clock").await;
    assert_eq!((&c["t"], &c["paused"]), (&json!(-max), &json!(true)), "{c}");
    assert_eq!(c["rate"], json!(-1000.0));
    let (st, h) = s
        .get_json(&format!("/v1/scenes/lake/height?x=1&z=2&t={}", -max))
        .await;
    assert_eq!(st, 200, "{h}");
    s.stop().await;
}

/// The next text frame, as JSON (other frames skipped), within 10 s.
async fn next_text(ws: &mut common::Ws) -> serde_json::Value {
    use futures_util::StreamExt;
    use tokio_tungstenite::tungstenite::Message;
    loop {
        let m = tokio::time::timeout(std::time::Duration::from_secs(10), ws.next())
            .await
            .expect("a message within 10 s")
            .expect("socket open")
            .expect("frame");
        if let Message::Text(t) = m {
            return serde_json::from_str(t.as_str()).expect("JSON");
        }
    }
}

/// Reads text frames until one of type `ty` (skipping tick frames and anything else).
async fn next_of_type(ws: &mut common::Ws, ty: &str) -> serde_json::Value {
    loop {
        let v = next_text(ws).await;
        if v["type"] == ty {
            return v;
        }
    }
}

async fn ping_json(ws: &mut common::Ws, id: u64) -> serde_json::Value {
    use futures_util::SinkExt;
    let ping = json!({"type": "ping", "id": id, "client_time": 1.5});
    ws.send(tokio_tungstenite::tungstenite::Message::Text(
        ping.to_string().into(),
    ))
    .await
    .unwrap();
    next_of_type(ws, "pong").await
}

/// Issue 28: the pong carries the clock's rate, pause flag and generation; every admin change
/// (seek, rate, pause) is one more generation, and every session of the scene gets a `clock`
/// event with the new reading at once, whether it subscribed to ticks or not.
#[tokio::test]
async fn pong_carries_rate_paused_generation_and_changes_send_a_clock_event() {
    let s = TestServer::start(config()).await;
    let mut ws = common::ws_connect(s.addr, "calm", None).await;
    let p = ping_json(&mut ws, 1).await;
    assert_eq!(
        (&p["rate"], &p["paused"], &p["generation"]),
        (&json!(1.0), &json!(false), &json!(0)),
        "{p}"
    );

    // A seek and a rate change in one update: one generation.
    let (st, c) = s
        .put_clock("calm", &json!({"t": 5000.0, "rate": 2.0}))
        .await;
    assert_eq!(st, 200, "{c}");
    assert_eq!(
        c["generation"],
        json!(1),
        "the HTTP reading has it too: {c}"
    );
    let ev = next_of_type(&mut ws, "clock").await;
    assert!(ev.get("id").is_none(), "unprompted: {ev}");
    assert_eq!((&ev["generation"], &ev["rate"]), (&json!(1), &json!(2.0)));
    let t = ev["t"].as_f64().unwrap();
    assert!(
        (5000.0..5001.0).contains(&t),
        "the reading after the seek: {ev}"
    );
    assert_eq!(ev["tick"], json!((t * 30.0).floor() as i64));
    assert!(ev["unix"].as_f64().unwrap() > 1.7e9);
    let p = ping_json(&mut ws, 2).await;
    assert_eq!((&p["rate"], &p["generation"]), (&json!(2.0), &json!(1)));
    assert!(p["scene_time"].as_f64().unwrap() >= t);

    // Pause: generation 2; the pong reads the frozen t.
    let (_, c) = s.put_clock("calm", &json!({"paused": true})).await;
    let ev = next_of_type(&mut ws, "clock").await;
    assert_eq!(
        (&ev["generation"], &ev["paused"]),
        (&json!(2), &json!(true))
    );
    assert_eq!(ev["t"], c["t"], "frozen");
    let p = ping_json(&mut ws, 3).await;
    assert_eq!((&p["paused"], &p["generation"]), (&json!(true), &json!(2)));
    assert_eq!(p["scene_time"], c["t"]);

    // Another scene's change is not this session's news.
    s.put_clock("lake", &json!({"rate": 3.0})).await;
    let p = ping_json(&mut ws, 4).await;
    assert_eq!(p["generation"], json!(2));
    s.stop().await;
}

/// The same in protobuf: `Pong.rate/paused/generation` and `ServerMessage.clock`.
#[tokio::test]
async fn protobuf_pong_and_clock_change() {
    use futures_util::{SinkExt, StreamExt};
    use prost::Message as _;
    use swell::wire::v1;
    use tokio_tungstenite::tungstenite::Message;
    let s = TestServer::start(config()).await;
    let mut ws = common::ws_connect(s.addr, "calm", Some("swell.v1.protobuf")).await;
    async fn next(ws: &mut common::Ws) -> v1::ServerMessage {
        loop {
            let m = tokio::time::timeout(std::time::Duration::from_secs(10), ws.next())
                .await
                .expect("a message within 10 s")
                .expect("socket open")
                .expect("frame");
            if let Message::Binary(b) = m {
                return v1::ServerMessage::decode(b.as_ref()).expect("ServerMessage");
            }
        }
    }
    s.put_clock("calm", &json!({"rate": -0.5})).await;
    let m = next(&mut ws).await;
    let Some(v1::server_message::Msg::Clock(c)) = m.msg else {
        panic!("{m:?}")
    };
    assert_eq!(
        (m.id, c.rate, c.paused, c.generation, c.tick_hz),
        (None, -0.5, false, 1, 30.0)
    );
    let ping = v1::ClientMessage {
        id: Some(7),
        msg: Some(v1::client_message::Msg::Ping(v1::Ping { client_time: 2.0 })),
    };
    ws.send(Message::Binary(ping.encode_to_vec().into()))
        .await
        .unwrap();
    let m = next(&mut ws).await;
    let Some(v1::server_message::Msg::Pong(p)) = m.msg else {
        panic!("{m:?}")
    };
    assert_eq!(
        (m.id, p.rate, p.paused, p.generation),
        (Some(7), -0.5, false, 1)
    );
    s.stop().await;
}

/// The generation is part of the journaled clock record: a restart replays it as it was
/// written (not a count of the changes this process applied), so it agrees with the replicas
/// and clients of the process before.
#[tokio::test]
async fn the_generation_survives_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let s = TestServer::start(common::config_with_dir(dir.path().to_owned())).await;
    for update in [
        json!({"t": 10.0}),
        json!({"rate": 2.0}),
        json!({"paused": true}),
    ] {
        assert_eq!(s.put_clock("calm", &update).await.0, 200);
    }
    let (_, before) = s.get_json("/v1/scenes/calm/clock").await;
    assert_eq!(before["generation"], json!(3));
    s.stop().await;
    let s = TestServer::start(common::config_with_dir(dir.path().to_owned())).await;
    let (_, after) = s.get_json("/v1/scenes/calm/clock").await;
    assert_eq!(
        (&after["generation"], &after["t"]),
        (&json!(3), &before["t"])
    );
    let (_, c) = s.put_clock("calm", &json!({"paused": false})).await;
    assert_eq!(c["generation"], json!(4), "counts on from the record");
    s.stop().await;
}

/// Sends a ping and returns the `type` of every text message that came before its pong (the
/// session queues its messages in order, so an event queued before the ping is among them).
async fn types_before_pong(ws: &mut common::Ws, id: u64) -> Vec<String> {
    use futures_util::SinkExt;
    use tokio_tungstenite::tungstenite::Message;
    let ping = json!({"type": "ping", "id": id, "client_time": 1.5});
    ws.send(Message::Text(ping.to_string().into()))
        .await
        .unwrap();
    let mut seen = Vec::new();
    loop {
        let v = next_text(ws).await;
        if v["type"] == "pong" && v["id"] == json!(id) {
            return seen;
        }
        seen.push(v["type"].as_str().unwrap_or("").to_owned());
    }
}

/// Issue 27: a running clock that reached ±`max_time` held there, reading as paused, but stream
/// sessions sent a `clock` event on admin changes only, so a client following the clock on its
/// own ran past the limit until a pong said otherwise (and a pong of the same generation does
/// not restart a client's fit). Every session of the scene, subscribed to ticks or not, now
/// gets one `clock` event when the hold starts: `paused: true`, `t` exactly the limit, the rate
/// and generation unchanged; one per hold, not one per tick or per look.
#[tokio::test]
async fn a_clock_reaching_max_time_sends_every_session_one_clock_event() {
    use futures_util::SinkExt;
    use std::time::{Duration, Instant};
    let s = TestServer::start(config()).await;
    let max = swell::Limits::default().max_time;
    let mut quiet = common::ws_connect(s.addr, "calm", None).await;
    let mut ticking = common::ws_connect(s.addr, "calm", None).await;
    let subscribe = json!({"type": "subscribe", "ticks": true});
    ticking
        .send(tokio_tungstenite::tungstenite::Message::Text(
            subscribe.to_string().into(),
        ))
        .await
        .unwrap();
    // Both sessions run (and listen for clock changes) once they have answered a ping.
    ping_json(&mut quiet, 1).await;
    ping_json(&mut ticking, 1).await;

    // 30 scene seconds from each end at 100 per second: held 0.3 s after each change.
    let rate = 100.0;
    for (round, (from, limit, rate)) in [
        (max - 30.0, max, rate),
        (max - 30.0, max, rate),
        (-max + 30.0, -max, -rate),
    ]
    .into_iter()
    .enumerate()
    {
        let generation = json!(round + 1);
        let changed = Instant::now();
        let (st, c) = s.put_clock("calm", &json!({"t": from, "rate": rate})).await;
        assert_eq!(st, 200, "{c}");
        assert_eq!(
            (&c["paused"], &c["generation"]),
            (&json!(false), &generation)
        );
        for ws in [&mut quiet, &mut ticking] {
            let ev = next_of_type(ws, "clock").await;
            assert_eq!(
                (&ev["paused"], &ev["generation"]),
                (&json!(false), &generation),
                "round {round}: the change itself: {ev}"
            );
            let ev = next_of_type(ws, "clock").await;
            let waited = changed.elapsed();
            assert!(
                waited >= Duration::from_millis(250) && waited < Duration::from_secs(5),
                "round {round}: the hold's event came {waited:?} after the change: {ev}"
            );
            assert!(ev.get("id").is_none(), "unprompted: {ev}");
            assert_eq!(
                (&ev["t"], &ev["paused"], &ev["rate"], &ev["generation"]),
                (&json!(limit), &json!(true), &json!(rate), &generation),
                "round {round}: held at the limit: {ev}"
            );
            assert_eq!(ev["tick"], json!(limit as i64 * 30), "{ev}");
        }
        // Once: nothing more while it holds (the sessions looked at the clock again since).
        tokio::time::sleep(Duration::from_millis(300)).await;
        for ws in [&mut quiet, &mut ticking] {
            let before = types_before_pong(ws, 10 + round as u64).await;
            assert!(
                !before.iter().any(|t| t == "clock"),
                "round {round}: a second clock event for one hold: {before:?}"
            );
        }
    }
    s.stop().await;
}

/// A scene put that moves the scene's epoch restarts its clock (from the new epoch) without an
/// admin clock change: sessions were not told, and a client following the clock on its own
/// ran on the old one until its fit caught up. Now every session of the scene gets a `clock`
/// event with the new reading; a put that keeps the epoch keeps the clock and sends none.
///
/// The fresh clock used to be generation 0, so a client whose fit was at generation 0 (no admin
/// change yet, the common case) could not tell pongs of the old clock from the new one's and
/// mixed them into one fit. It is now one generation after the clock it replaces, in the event,
/// the pongs and `GET …/clock`, and a fresh clock again (rate 1, running) after an admin change.
/// A scene deleted and put again announces its new clock (generation 0) to a session that
/// outlived the delete.
#[tokio::test]
async fn a_put_that_moves_the_epoch_sends_a_clock_event() {
    let s = TestServer::start(config()).await;
    let now = common::unix_now();
    let mut spec = common::small_spec();
    spec["epoch"] = json!(now - 100.0);
    assert_eq!(s.put_scene("moved", &spec).await.0, 201);
    let mut ws = common::ws_connect(s.addr, "moved", None).await;
    let before = ping_json(&mut ws, 1).await;
    let t0 = before["scene_time"].as_f64().unwrap();
    assert!((t0 - 100.0).abs() < 5.0, "{before}");
    assert_eq!(
        before["generation"],
        json!(0),
        "a new scene's clock: {before}"
    );

    // The same epoch, another description: the clock stays, nothing to tell.
    spec["description"] = json!("the same sea, renamed");
    assert_eq!(s.put_scene("moved", &spec).await.0, 200);
    let seen = types_before_pong(&mut ws, 2).await;
    assert!(!seen.iter().any(|t| t == "clock"), "{seen:?}");
    let (_, c) = s.get_json("/v1/scenes/moved/clock").await;
    assert_eq!(c["generation"], json!(0), "{c}");

    // 1,000 s earlier: the clock jumps forward by as much, and the session says so.
    spec["epoch"] = json!(now - 1100.0);
    assert_eq!(s.put_scene("moved", &spec).await.0, 200);
    let ev = next_of_type(&mut ws, "clock").await;
    let t = ev["t"].as_f64().unwrap();
    assert!((t - 1100.0).abs() < 5.0, "the new epoch's reading: {ev}");
    assert!(ev.get("id").is_none(), "unprompted: {ev}");
    assert_eq!(ev["paused"], json!(false), "{ev}");
    assert_eq!(ev["generation"], json!(1), "one on from 0: {ev}");
    let p = ping_json(&mut ws, 3).await;
    assert_eq!(p["generation"], json!(1), "{p}");
    let (_, c) = s.get_json("/v1/scenes/moved/clock").await;
    assert_eq!(c["generation"], json!(1), "{c}");

    // After an admin change (generation 2, paused at rate 3), a move is generation 3 and a
    // fresh clock: rate 1, running, from the new epoch.
    let (st, c) = s
        .put_clock("moved", &json!({"rate": 3.0, "paused": true}))
        .await;
    assert_eq!((st, &c["generation"]), (200, &json!(2)), "{c}");
    assert_eq!(next_of_type(&mut ws, "clock").await["generation"], json!(2));
    spec["epoch"] = json!(now - 2100.0);
    assert_eq!(s.put_scene("moved", &spec).await.0, 200);
    fresh_clock_event(&mut ws, 3, 2100.0).await;

    // Deleted and put again: a session not following ticks outlives the delete, and the new
    // scene's clock (generation 0, below the client's 3) is announced, or the client would drop
    // its pongs as older than its fit.
    let (st, _) = s
        .admin(
            reqwest::Method::DELETE,
            "/v1/scenes/moved",
            None,
            Some(common::TOKEN),
        )
        .await;
    assert_eq!(st, 204);
    spec["epoch"] = json!(now - 300.0);
    assert_eq!(s.put_scene("moved", &spec).await.0, 201);
    fresh_clock_event(&mut ws, 0, 300.0).await;
    s.stop().await;
}

/// Waits for the session's next `clock` event and asserts it announces a fresh clock (rate 1,
/// running) at `generation`, reading about `t` (within the seconds a test takes).
async fn fresh_clock_event(ws: &mut common::Ws, generation: u64, t: f64) {
    let ev = next_of_type(ws, "clock").await;
    assert_eq!(
        (&ev["generation"], &ev["rate"], &ev["paused"]),
        (&json!(generation), &json!(1.0), &json!(false)),
        "{ev}"
    );
    assert!((ev["t"].as_f64().unwrap() - t).abs() < 5.0, "{ev}");
}

/// What a crash of the server on `dir` leaves (its journal as it is: every acknowledged record
/// is durable), copied to a new data dir for another server to start on.
fn crashed_copy(dir: &std::path::Path) -> tempfile::TempDir {
    let copy = tempfile::tempdir().unwrap();
    std::fs::create_dir(copy.path().join("journal")).unwrap();
    for f in ["journal.log", "snapshot.bin"] {
        let from = dir.join("journal").join(f);
        if from.exists() {
            std::fs::copy(from, copy.path().join("journal").join(f)).unwrap();
        }
    }
    copy
}

/// Asserts that scene `moved` of `s` holds exactly a fresh clock from `epoch` at `generation`:
/// the clock `Clock::from_epoch` gives, bounded as the server bounds its clocks.
fn holds_fresh_clock(what: &str, s: &TestServer, epoch: f64, generation: u64) {
    let entry = s.state.scene("moved").unwrap();
    let held = *entry.clock.lock().unwrap();
    let fresh = swell::scene::Clock::from_epoch(epoch)
        .with_generation(generation)
        .within(s.state.limits.max_time);
    assert_eq!(held, fresh, "{what}");
}

/// The clock a put that moves the epoch starts is recorded with the put, so a restart agrees
/// with the server before it: a replay of the log (what a crash leaves), a snapshot taken before
/// the put and a replay of the put after it, and the final snapshot of a graceful stop all hold
/// the same clock, at the same generation. The live put used to start generation 0 (see
/// `a_put_that_moves_the_epoch_sends_a_clock_event`), and a snapshot kept the replaced clock's
/// record (a put did not touch it), so a graceful restart brought the old clock back. A past
/// epoch gives exactly the clock the epoch defines; one still to come, the same reading.
#[tokio::test]
async fn a_put_that_moves_the_epoch_gives_the_same_clock_after_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let s = TestServer::start(common::config_with_dir(dir.path().to_owned())).await;
    let now = common::unix_now();
    let mut spec = common::small_spec();
    spec["epoch"] = json!(now - 100.0);
    assert_eq!(s.put_scene("moved", &spec).await.0, 201);
    spec["epoch"] = json!(now - 1100.0);
    assert_eq!(s.put_scene("moved", &spec).await.0, 200);
    let (_, c) = s.get_json("/v1/scenes/moved/clock").await;
    assert_eq!(c["generation"], json!(1), "{c}");
    holds_fresh_clock("live", &s, now - 1100.0, 1);
    // A crash now: the log alone is replayed.
    let crashed = crashed_copy(dir.path());
    assert!(!crashed.path().join("journal/snapshot.bin").exists());
    let r = TestServer::start(common::config_with_dir(crashed.path().to_owned())).await;
    holds_fresh_clock("the log replayed", &r, now - 1100.0, 1);
    r.stop().await;

    // An admin change (generation 2), a snapshot, then a move (3) that only the log holds.
    assert_eq!(s.put_clock("moved", &json!({"t": 5000.0})).await.0, 200);
    let (state, journal) = (s.state.clone(), s.state.journal().unwrap().clone());
    tokio::task::spawn_blocking(move || swell::state::snapshots::take(&state, &journal))
        .await
        .unwrap()
        .unwrap();
    spec["epoch"] = json!(now - 2100.0);
    assert_eq!(s.put_scene("moved", &spec).await.0, 200);
    holds_fresh_clock("live", &s, now - 2100.0, 3);
    let crashed = crashed_copy(dir.path());
    assert!(crashed.path().join("journal/snapshot.bin").exists());
    let r = TestServer::start(common::config_with_dir(crashed.path().to_owned())).await;
    holds_fresh_clock("a snapshot, then the put replayed", &r, now - 2100.0, 3);
    r.stop().await;

    // An admin change (4), then an epoch 1,000 s ahead (5): t runs from −1000.
    assert_eq!(s.put_clock("moved", &json!({"rate": 2.0})).await.0, 200);
    spec["epoch"] = json!(now + 1000.0);
    assert_eq!(s.put_scene("moved", &spec).await.0, 200);
    let (_, before) = s.get_json("/v1/scenes/moved/clock").await;
    assert!(
        (before["t"].as_f64().unwrap() + 1000.0).abs() < 5.0,
        "{before}"
    );
    // Where the clock reads t = 0, by a reading: the epoch, to the bit (for Unix times of today
    // the subtractions that make `t` and undo it here are exact), before and after a restart.
    let zero = |c: &serde_json::Value| c["unix"].as_f64().unwrap() - c["t"].as_f64().unwrap();
    let same = |what: &str, after: &serde_json::Value| {
        assert_eq!(
            (&after["generation"], &after["rate"], &after["paused"]),
            (&json!(5), &json!(1.0), &json!(false)),
            "{what}: {before} then {after}"
        );
        for c in [&before, after] {
            assert_eq!(zero(c).to_bits(), (now + 1000.0).to_bits(), "{what}: {c}");
        }
    };
    same("live", &before);
    let crashed = crashed_copy(dir.path());
    let r = TestServer::start(common::config_with_dir(crashed.path().to_owned())).await;
    same(
        "the log replayed",
        &r.get_json("/v1/scenes/moved/clock").await.1,
    );
    r.stop().await;

    // A graceful stop: the final snapshot holds the put's clock, and nothing is replayed.
    s.stop().await;
    let s = TestServer::start(common::config_with_dir(dir.path().to_owned())).await;
    same(
        "from the final snapshot",
        &s.get_json("/v1/scenes/moved/clock").await.1,
    );
    let (_, c) = s.put_clock("moved", &json!({"paused": true})).await;
    assert_eq!(c["generation"], json!(6), "counts on from the record");
    s.stop().await;
}
