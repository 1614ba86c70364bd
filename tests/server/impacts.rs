//! Impacts (issue 15): `POST /v1/scenes/{id}/impacts` ripples every query of the scene at any
//! t, tick frames carry the new events (JSON and protobuf), and the journal keeps them across a
//! restart so the sea comes back to the same bits.

use crate::common;

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
    // Impacts are dated near the scene clock's now (issue 27): hold harbour's clock at t = 100.
    let (st, v) = s
        .put_clock("harbour", &json!({"t": 100.0, "paused": true}))
        .await;
    assert_eq!(st, 200, "{v}");
    let before_at = |t| heights(&s, "harbour", t);
    let (b_early, b_late) = (before_at(99.0).await, before_at(102.0).await);
    // A boat footprint where the ring passes 2 s after the impact (a 1 m particle runs at
    // 2.5 m/s in deep water: about 5 m out).
    let orient = || async {
        let (st, v) = s
            .post_json(
                "/v1/scenes/harbour/orientation",
                &json!({"t": 102.0, "bodies": [{"position": [5.0, 0.0], "yaw": 0.0, "length": 4.0, "beam": 2.0}]}),
            )
            .await;
        assert_eq!(st, 200, "{v}");
        v.to_string()
    };
    let o_before = orient().await;
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
    // Orientation sees the ripple too (issue 15: "queries, orientation and bodies see the
    // particles").
    assert_ne!(orient().await, o_before, "orientation ignores the ring");
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

/// An impact the set would expire at once is refused with the reason, not acknowledged and
/// dropped: after a seek backwards past the scene's splashes (harbour's rings live 60 s), a
/// splash at the new now is more than a lifetime older than the newest one. A `t` beyond
/// `max_time` on `GET …/impacts` is refused like everywhere else.
#[tokio::test]
async fn an_impact_older_than_the_newest_by_a_lifetime_is_refused_not_dropped() {
    let s = TestServer::start(config()).await;
    let at = |t: f64| json!({"position": [1.0, 2.0], "strength": 0.3, "radius": 0.5, "t": t});
    let (st, v) = s
        .put_clock("harbour", &json!({"t": 1000.0, "paused": true}))
        .await;
    assert_eq!(st, 200, "{v}");
    let (st, v) = impact(&s, "harbour", at(1000.0)).await;
    assert_eq!(st, 202, "{v}");
    let (st, v) = s
        .put_clock("harbour", &json!({"t": 0.0, "paused": true}))
        .await;
    assert_eq!(st, 200, "{v}");
    let (st, v) = impact(&s, "harbour", at(0.0)).await;
    assert_eq!((st, code(&v)), (400, "invalid_value"), "{v}");
    assert_eq!(v["error"]["field"], "t", "{v}");
    let msg = v["error"]["message"].as_str().unwrap();
    assert!(msg.contains("newest impact is at t = 1000"), "{msg}");
    // Within a lifetime of the newest: still accepted (the clock allows it).
    let (st, v) = s
        .put_clock("harbour", &json!({"t": 950.0, "paused": true}))
        .await;
    assert_eq!(st, 200, "{v}");
    let (st, v) = impact(&s, "harbour", at(950.0)).await;
    assert_eq!(st, 202, "{v}");
    let (st, v) = s.get_json("/v1/scenes/harbour/impacts?t=900").await;
    assert_eq!(st, 200, "{v}");
    let ts: Vec<f64> = v["impacts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["t"].as_f64().unwrap())
        .collect();
    assert_eq!(ts, [950.0, 1000.0], "{v}");
    for q in ["t=1e300", "t=abc"] {
        let (st, v) = s.get_json(&format!("/v1/scenes/harbour/impacts?{q}")).await;
        assert_eq!(st, 400, "{q}: {v}");
        assert_eq!(v["error"]["field"], "t", "{q}: {v}");
    }
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
                            // No body world: nothing felt it, so no body tick.
                            assert!(list[0].get("body_tick").is_none(), "{f}");
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
                            assert_eq!(e.body_tick, None);
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

/// A `swell` process on a data dir (killed with SIGKILL when dropped), or an in-process
/// server's address, driven over HTTP.
struct Srv {
    base: String,
    client: reqwest::Client,
    child: Option<std::process::Child>,
}

impl Drop for Srv {
    fn drop(&mut self) {
        if let Some(c) = &mut self.child {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

impl Srv {
    async fn spawn(dir: &std::path::Path) -> Srv {
        let port = common::free_port();
        let log = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(dir.with_extension("log"))
            .unwrap();
        let child = std::process::Command::new(env!("CARGO_BIN_EXE_swell"))
            .args(["serve", "--bind", &format!("127.0.0.1:{port}")])
            .arg("--data-dir")
            .arg(dir)
            .args(["--admin-token", TOKEN, "--snapshot-records", "5"])
            .stdout(std::process::Stdio::null())
            .stderr(log)
            .spawn()
            .expect("the swell binary starts");
        let s = Srv {
            base: format!("http://127.0.0.1:{port}"),
            client: reqwest::Client::builder().no_proxy().build().unwrap(),
            child: Some(child),
        };
        let t0 = std::time::Instant::now();
        while !matches!(s.req(Method::GET, "/readyz", None).await, Some((200, _))) {
            assert!(t0.elapsed() < Duration::from_secs(60), "never became ready");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        s
    }

    fn of(s: &TestServer) -> Srv {
        Srv {
            base: s.url(""),
            client: s.client.clone(),
            child: None,
        }
    }

    async fn req(&self, m: Method, path: &str, body: Option<&Value>) -> Option<(u16, String)> {
        let mut rb = self
            .client
            .request(m, format!("{}{path}", self.base))
            .bearer_auth(TOKEN);
        if let Some(b) = body {
            rb = rb.json(b);
        }
        let r = rb.send().await.ok()?;
        Some((r.status().as_u16(), r.text().await.ok()?))
    }

    async fn ok(&self, m: Method, path: &str, body: Option<&Value>) -> Value {
        let (st, text) = self.req(m, path, body).await.expect("request");
        assert!((200..300).contains(&st), "{path}: {st} {text}");
        serde_json::from_str(&text).unwrap_or(Value::Null)
    }

    /// Seeks `scene`'s paused clock (30 Hz) to `tick` (at most 60 ticks on: the bodies step
    /// there instead of re-anchoring) and waits until its bodies are there.
    async fn seek(&self, scene: &str, tick: i64) {
        let t = (tick as f64 + 0.5) / 30.0;
        let path = format!("/v1/scenes/{scene}/clock");
        self.ok(Method::PUT, &path, Some(&json!({"t": t, "paused": true})))
            .await;
        let t0 = std::time::Instant::now();
        loop {
            let v = self
                .ok(Method::GET, &format!("/v1/scenes/{scene}/bodies"), None)
                .await;
            if v["tick"] == json!(tick) {
                return;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(20),
                "bodies never reached tick {tick}: {v}"
            );
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    }

    /// The scene's impacts (every one since t = 0) as the server wrote them: equal text is
    /// equal bits.
    async fn impacts(&self, scene: &str) -> (String, Vec<Value>) {
        let v = self
            .ok(
                Method::GET,
                &format!("/v1/scenes/{scene}/impacts?t=0"),
                None,
            )
            .await;
        let list = v["impacts"].as_array().unwrap().clone();
        (v["impacts"].to_string(), list)
    }
}

/// A calm sine sea under a particle layer (no ambient particles, so only ripples move it) whose
/// bodies make impacts when `body_impacts` is given.
fn dock(body_impacts: Option<Value>) -> Value {
    let mut particles = json!({"kind": "particles", "count": 0});
    if let Some(b) = body_impacts {
        particles["body_impacts"] = b;
    }
    json!({"tick_hz": 30, "seed": 9, "layers": [
        {"kind": "sine", "waves": [{"amplitude": 0.05, "wavelength": 20, "direction": [1, 0]}]},
        particles
    ]})
}

/// An 8 m × 3 m × 1.5 m, 3 t box at `[x, y, 0]`; `drag` sets a light linear drag (a driven
/// boat that gets going: the default damping holds a 3 kN push to 0.02 m/s).
fn hull(x: f64, y: f64, drag: Option<f64>) -> Value {
    let mut b = json!({"mass": 3000.0, "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5},
        "position": [x, y, 0.0]});
    if let Some(d) = drag {
        b["linear_drag"] = json!(d);
    }
    b
}

/// The same requests on several servers: a boat dropped from 3 m (its hull bottom 2.25 m above
/// the water) and a floating boat pushed along +x by 3 kN (1 m/s², about 3 m/s after 3 s),
/// stepped by seeks from tick 3000 to `to`.
async fn drop_and_drive(servers: &[&Srv], scene: &str, to: i64) {
    for s in servers {
        s.seek(scene, 3000).await;
        let path = format!("/v1/scenes/{scene}/bodies");
        let v = s.ok(Method::POST, &path, Some(&hull(0.0, 3.0, None))).await;
        assert_eq!(v["id"], 0);
        // Floating at its draft (m/(ρ·L·B) = 0.12 m): it enters no water fast, so no splash.
        let v = s
            .ok(Method::POST, &path, Some(&hull(30.0, 0.63, Some(3000.0))))
            .await;
        assert_eq!(v["id"], 1);
        s.ok(
            Method::POST,
            &format!("{path}/1/input"),
            Some(&json!({"force": [3000.0, 0.0, 0.0], "ticks": 100000})),
        )
        .await;
        let mut tick = 3000;
        while tick < to {
            tick = (tick + 15).min(to);
            s.seek(scene, tick).await;
        }
    }
}

/// Issue 15, "bodies generate impacts themselves when a scene enables it": a hull that hits the
/// water fast splashes at a tick fixed by its fall, a driven hull leaves wake impacts at the
/// set spacing, tick frames carry them, a scene without `body_impacts` gets none, and another
/// server (or the same one after a kill -9) derives the very same list, to the bit.
#[tokio::test]
async fn bodies_splash_and_leave_wakes_identically_on_every_server_and_after_kill_9() {
    let dirs = tempfile::tempdir().unwrap();
    let da = dirs.path().join("a");
    let a = Srv::spawn(&da).await;
    let b_server = TestServer::start(config()).await;
    let b = Srv::of(&b_server);
    let spec = dock(Some(json!({"wake_spacing": 0.5})));
    for s in [&a, &b] {
        s.ok(Method::PUT, "/v1/scenes/dock", Some(&spec)).await;
        s.ok(Method::PUT, "/v1/scenes/plain", Some(&dock(None)))
            .await;
    }
    // A subscriber on `b` sees the body impacts in tick frames as they are made.
    let mut ws = ws_connect(b_server.addr, "dock", None).await;
    ws.send(Message::Text(
        json!({"type": "subscribe", "ticks": true})
            .to_string()
            .into(),
    ))
    .await
    .unwrap();
    drop_and_drive(&[&a, &b], "dock", 3090).await;
    drop_and_drive(&[&b], "plain", 3090).await;

    let (text, list) = b.impacts("dock").await;
    // The splash: free fall of 2.25 m takes sqrt(2·2.25/9.81) = 0.677 s = 20.3 ticks, so the
    // hull is first wet at the end of tick 3021 (the swell is 5 cm: ±0.3 tick), and it hits
    // at 6.6 m/s, over the default 2 m/s.
    let splashes: Vec<&Value> = list.iter().filter(|i| i["strength"] == 0.3).collect();
    assert_eq!(splashes.len(), 1, "{text}");
    let s = splashes[0];
    assert_eq!(s["tick"], 3021, "{s}");
    assert_eq!(bits(&s["t"]), (3021.0f64 / 30.0).to_bits(), "{s}");
    assert_eq!(s["radius"], 1.0, "{s}");
    assert!(s["position"][0].as_f64().unwrap().abs() < 1e-3, "{s}");
    // The wake: one impact of 5 cm each 0.5 m the driven hull covers once faster than 1 m/s
    // (from about x = 30.5), along +x.
    let wakes: Vec<&Value> = list.iter().filter(|i| i["strength"] == 0.05).collect();
    assert_eq!(splashes.len() + wakes.len(), list.len(), "{text}");
    assert!(wakes.len() >= 3, "{} wake impacts: {text}", wakes.len());
    for w in wakes.windows(2) {
        let (x0, x1) = (
            w[0]["position"][0].as_f64().unwrap(),
            w[1]["position"][0].as_f64().unwrap(),
        );
        // The distance left over at a drop counts towards the next, so a gap is the spacing
        // to within one tick's travel (< 0.12 m here: under 3.5 m/s), and they average to it.
        let gap = x1 - x0;
        assert!((0.38..0.62).contains(&gap), "wake gap {gap} m: {text}");
        assert!(w[1]["tick"].as_i64() > w[0]["tick"].as_i64());
        assert_eq!(w[0]["radius"], 0.5);
    }
    let x = |w: &Value| w["position"][0].as_f64().unwrap();
    let mean = (x(wakes[wakes.len() - 1]) - x(wakes[0])) / (wakes.len() - 1) as f64;
    assert!((mean - 0.5).abs() < 0.03, "mean wake gap {mean} m: {text}");
    assert!(x(wakes[0]) > 30.8, "{text}");
    // Another server derived the same list, to the bit.
    assert_eq!(a.impacts("dock").await.0, text);
    // Without `body_impacts`, the same bodies make none.
    assert_eq!(b.impacts("plain").await.1.len(), 0);

    // The subscriber got the splash in a tick frame.
    let framed = timeout(Duration::from_secs(5), async {
        loop {
            if let Some(Ok(Message::Text(t))) = ws.next().await {
                let f: Value = serde_json::from_str(t.as_str()).unwrap();
                if let Some(l) = f["impacts"].as_array()
                    && let Some(s) = l.iter().find(|i| i["strength"] == 0.3)
                {
                    return (f["tick"].clone(), s.clone());
                }
            }
        }
    })
    .await
    .expect("a frame with the splash");
    // (The paused clock moves by seeks of 15 ticks, so the frame is that of a later tick.)
    assert!(framed.0.as_i64().unwrap() >= 3021, "{framed:?}");
    assert_eq!(&framed.1, s);

    // kill -9 and restart: the body impacts are back, the same bits, and the bodies go on
    // making the same ones as the server that never stopped.
    drop(a);
    let a = Srv::spawn(&da).await;
    assert_eq!(a.impacts("dock").await.0, text);
    for s in [&a, &b] {
        for tick in [3110, 3130, 3150] {
            s.seek("dock", tick).await;
        }
    }
    let (text2, list2) = b.impacts("dock").await;
    assert!(
        list2.len() > list.len(),
        "the driven boat keeps leaving a wake"
    );
    assert_eq!(a.impacts("dock").await.0, text2);
    // ...and the sea they make is the same: heights near the splash, 1 s after it.
    let h = |s: &Srv| {
        let s = s.base.clone();
        let c = reqwest::Client::builder().no_proxy().build().unwrap();
        async move {
            let r = c
                .post(format!("{s}/v1/scenes/dock/sample"))
                .json(&json!({"t": 3051.0 / 30.0, "points": line()}))
                .send()
                .await
                .unwrap();
            r.json::<Value>().await.unwrap()["height"].to_string()
        }
    };
    let (ha, hb) = (h(&a).await, h(&b).await);
    assert_eq!(ha, hb);
    let (_, plain) = b
        .req(
            Method::POST,
            "/v1/scenes/plain/sample",
            Some(&json!({"t": 3051.0 / 30.0, "points": line()})),
        )
        .await
        .unwrap();
    let plain: Value = serde_json::from_str(&plain).unwrap();
    assert_ne!(
        plain["height"].to_string(),
        hb,
        "the splash ripples the sea"
    );
    drop(b);
    b_server.stop().await;
}

/// Issue 27, "bodies beyond ±1e9 m make splashes the model silently drops": with
/// `max_coordinate` raised to 1e12 m a boat may be spawned at x = 2e9 m, past the model's map
/// of impacts (±1e9 m), so its splash can ripple nothing. It used to vanish without a trace;
/// now `swell_body_impacts_off_map_total` counts it (shown at 0 before any), and the same drop
/// at x = 0 still splashes without being counted.
#[tokio::test]
async fn a_splash_off_the_models_map_is_counted_not_lost_without_trace() {
    let mut c = config();
    c.limits.max_coordinate = 1e12;
    let server = TestServer::start(c).await;
    let s = Srv::of(&server);
    let off_map = || async {
        let page = server.get("/metrics").await.text().await.unwrap();
        common::metric(&page, "swell_body_impacts_off_map_total")
            .unwrap_or_else(|| panic!("no swell_body_impacts_off_map_total in\n{page}"))
    };
    let before = off_map().await;
    for (scene, x) in [("far", 2e9), ("near", 0.0)] {
        s.ok(
            Method::PUT,
            &format!("/v1/scenes/{scene}"),
            Some(&dock(Some(json!({})))),
        )
        .await;
        s.seek(scene, 3000).await;
        let path = format!("/v1/scenes/{scene}/bodies");
        s.ok(Method::POST, &path, Some(&hull(x, 3.0, None))).await;
        // The hull falls 2.25 m: wet at tick 3021 (see the test above).
        for tick in [3015, 3030] {
            s.seek(scene, tick).await;
        }
        let v = s.ok(Method::GET, &path, None).await;
        // It fell where it was spawned (the splash is where the body is).
        let at = v["bodies"][0]["position"][0].as_f64().unwrap();
        assert!((at - x).abs() < 0.1, "{v}");
        let after = off_map().await;
        let (list_text, list) = s.impacts(scene).await;
        if x == 0.0 {
            assert_eq!(list.len(), 1, "the splash at x = 0: {list_text}");
            assert_eq!(list[0]["tick"], 3021, "{list_text}");
            assert_eq!(after, before + 1.0, "only the far splash is counted");
        } else {
            assert!(list.is_empty(), "{list_text}");
            assert_eq!(after, before + 1.0, "the far splash is counted");
        }
    }
    server.stop().await;
}

/// The bodies of `scene` as the server wrote them at its current tick: equal text is equal
/// bits.
async fn bodies_text(s: &Srv, scene: &str) -> String {
    let v = s
        .ok(Method::GET, &format!("/v1/scenes/{scene}/bodies"), None)
        .await;
    format!("{} {}", v["tick"], v["bodies"])
}

/// Issue 15, "queries, orientation and bodies see the particles": an API impact under a
/// floating boat rocks it, from the tick the impact reached its world, to the same bits on
/// another server and after a kill -9 (the journal sequences the impact among the body
/// events); the same boat on the same sea without the impact does something else.
#[tokio::test]
async fn an_api_impact_rocks_boats_identically_on_every_server_and_after_kill_9() {
    let dirs = tempfile::tempdir().unwrap();
    let da = dirs.path().join("a");
    let a = Srv::spawn(&da).await;
    let b_server = TestServer::start(config()).await;
    let b = Srv::of(&b_server);
    for s in [&a, &b] {
        s.ok(Method::PUT, "/v1/scenes/dock", Some(&dock(None)))
            .await;
    }
    b.ok(Method::PUT, "/v1/scenes/plain", Some(&dock(None)))
        .await;
    let splash =
        json!({"position": [3.0, 0.0], "t": 3020.0 / 30.0, "strength": 0.5, "radius": 1.0});
    for (s, scene, hit) in [(&a, "dock", true), (&b, "dock", true), (&b, "plain", false)] {
        s.seek(scene, 3000).await;
        // Floating at its draft, centred 3 m from where the impact lands.
        s.ok(
            Method::POST,
            &format!("/v1/scenes/{scene}/bodies"),
            Some(&hull(0.0, 0.63, None)),
        )
        .await;
        s.seek(scene, 3015).await;
        if hit {
            let v = s
                .ok(
                    Method::POST,
                    &format!("/v1/scenes/{scene}/impacts"),
                    Some(&splash),
                )
                .await;
            assert_eq!(v["tick"], 3020, "{v}");
        }
        for tick in [3030, 3045, 3060] {
            s.seek(scene, tick).await;
        }
    }
    let at_3060 = bodies_text(&b, "dock").await;
    assert_eq!(bodies_text(&a, "dock").await, at_3060);
    assert_ne!(
        bodies_text(&b, "plain").await,
        at_3060,
        "the impact rocks the boat"
    );
    // kill -9 and restart: the journal brings the impact back into the body world's history.
    drop(a);
    let a = Srv::spawn(&da).await;
    assert_eq!(bodies_text(&a, "dock").await, at_3060);
    for s in [&a, &b] {
        for tick in [3075, 3090] {
            s.seek("dock", tick).await;
        }
    }
    assert_eq!(bodies_text(&a, "dock").await, bodies_text(&b, "dock").await);
    drop(b);
    b_server.stop().await;
}

#[tokio::test]
async fn bad_body_impact_settings_are_rejected_with_the_field_named() {
    let s = TestServer::start(config()).await;
    let (st, v) = s
        .put_scene("dock", &dock(Some(json!({"wake_spacing": 0.0}))))
        .await;
    assert_eq!((st, code(&v)), (422, "invalid_spec"), "{v}");
    assert_eq!(
        v["error"]["field"], "layers[1].body_impacts.wake_spacing",
        "{v}"
    );
    let (st, v) = s
        .put_scene("dock", &dock(Some(json!({"splash_strength": -1.0}))))
        .await;
    assert_eq!((st, code(&v)), (422, "invalid_spec"), "{v}");
    assert_eq!(
        v["error"]["field"], "layers[1].body_impacts.splash_strength",
        "{v}"
    );
    let (st, v) = s
        .put_scene("dock", &dock(Some(json!({"wake_size": 1.0}))))
        .await;
    assert_eq!((st, code(&v)), (400, "bad_json"), "{v}");
    assert!(
        v["error"]["message"]
            .as_str()
            .unwrap()
            .contains("wake_size"),
        "{v}"
    );
    // `{}` is valid (every field has a default), and the spec keeps what was given.
    let (st, v) = s.put_scene("dock", &dock(Some(json!({})))).await;
    assert_eq!(st, 201, "{v}");
    assert_eq!(
        v["spec"]["layers"][1]["body_impacts"]["wake_spacing"], 4.0,
        "{v}"
    );
    // A scene without it has none in its spec (and its hash is as before the field existed).
    let (_, v) = s.get_json("/v1/scenes/harbour").await;
    assert!(v["spec"]["layers"][1].get("body_impacts").is_none(), "{v}");
    s.stop().await;
}

/// Issue 30: a fleet replica that re-read Redis replaced its scenes' impact sets directly,
/// beside the one reducer. It now adds the impacts it lacks as the feed would (`Op::Impact`
/// through `AppState::apply`, announced to tick frames), adds nothing twice, and keeps an
/// impact Redis lost, as it keeps such a scene. (`resync_impacts` is what the re-read calls
/// with Redis's lists; here it gets them by hand on a local server.)
#[tokio::test]
async fn a_fleet_re_read_adds_the_impacts_it_lacks_through_the_reducer() {
    let s = TestServer::start(config()).await;
    let (_, clock) = s.get_json("/v1/scenes/harbour/clock").await;
    let now = clock["t"].as_f64().unwrap();
    let (st, v) = impact(
        &s,
        "harbour",
        json!({"t": now, "position": [1.0, 2.0], "strength": 0.2, "radius": 0.5}),
    )
    .await;
    assert_eq!(st, 202, "{v}");
    let ours = swell_waves::particles::Impact {
        t: now,
        position: [1.0, 2.0],
        strength: 0.2,
        radius: 0.5,
    };
    let missed = swell_waves::particles::Impact {
        t: now + 0.5,
        position: [6.0, 1.0],
        strength: 0.3,
        radius: 0.75,
    };
    let seen = s.state.scene("harbour").unwrap().scene.impacts.added();
    let heights_before = heights(&s, "harbour", now + 2.0).await;
    let scenes = vec!["harbour".to_owned()];
    // Redis has the one we missed, not ours (lost): ours is kept, the missed one added.
    let lists = vec![vec![serde_json::to_string(&missed).unwrap()]];
    assert_eq!(
        swell::store::fleet::resync_impacts(&s.state, &scenes, &lists),
        1
    );
    let entry = s.state.scene("harbour").unwrap();
    assert_eq!(entry.scene.impacts.api().events(), &[ours, missed]);
    // Announced: a tick loop that saw everything before the re-read gets it as new.
    assert_eq!(entry.scene.impacts.since(seen).1, vec![(missed, None)]);
    assert_ne!(heights(&s, "harbour", now + 2.0).await, heights_before);
    // Again, with both: nothing to add, nothing doubled.
    let both = vec![vec![
        serde_json::to_string(&ours).unwrap(),
        serde_json::to_string(&missed).unwrap(),
    ]];
    assert_eq!(
        swell::store::fleet::resync_impacts(&s.state, &scenes, &both),
        0
    );
    assert_eq!(entry.scene.impacts.api().len(), 2);
    // The same set as a server that got both through the API.
    let other = TestServer::start(config()).await;
    for i in [ours, missed] {
        let (st, v) = impact(
            &other,
            "harbour",
            json!({"t": i.t, "position": i.position, "strength": i.strength, "radius": i.radius}),
        )
        .await;
        assert_eq!(st, 202, "{v}");
    }
    assert_eq!(
        heights(&other, "harbour", now + 2.0).await,
        heights(&s, "harbour", now + 2.0).await
    );
    other.stop().await;
    s.stop().await;
}
