//! A fleet: real `swell` processes sharing scenes and clocks through a real `redis-server` (AOF,
//! fsync always) on loopback ports. An admin change through one replica is served by the
//! others within 200 ms; Redis down → queries still answered, admin writes 503; Redis back →
//! every replica reconnects and resyncs by itself.

#[path = "common/procs.rs"]
mod procs;
#[path = "common/replay.rs"]
mod replay;

use std::time::{Duration, Instant};

use procs::{Redis, Replica, TOKEN, client, replicas};
use reqwest::{Client, Method};
use serde_json::{Value, json};
use swell::store::bodies::BodyCmd;

/// The tests of this file run one at a time: each starts Redis and three replicas, and the
/// 200 ms bound must not measure another test's load on a 2-core machine.
static SERIAL: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// The propagation bound the issue sets.
const WITHIN: Duration = Duration::from_millis(200);

fn spec(amplitude: f64) -> Value {
    json!({
        "description": "fleet test sea",
        "tick_hz": 20,
        "seed": 5,
        "layers": [{"kind": "gerstner", "waves": [
            {"amplitude": amplitude, "wavelength": 30, "direction": [1, 0.5], "steepness": 0.5}
        ]}]
    })
}

async fn admin(
    c: &Client,
    r: &Replica,
    m: Method,
    path: &str,
    body: Option<Value>,
) -> (u16, Value) {
    let mut rb = c.request(m, r.url(path)).bearer_auth(TOKEN);
    if let Some(b) = body {
        rb = rb.json(&b);
    }
    let resp = rb.send().await.expect("admin request");
    let st = resp.status().as_u16();
    let text = resp.text().await.unwrap();
    (st, serde_json::from_str(&text).unwrap_or(Value::Null))
}

async fn get(c: &Client, r: &Replica, path: &str) -> (u16, Value) {
    let resp = c.get(r.url(path)).send().await.expect("GET");
    let st = resp.status().as_u16();
    let text = resp.text().await.unwrap();
    (st, serde_json::from_str(&text).unwrap_or(Value::Null))
}

/// Polls `path` on `r` every 2 ms until `ok(status, body)`; returns how long it took from
/// `since`. Panics after 5 s.
async fn until(
    c: &Client,
    r: &Replica,
    path: &str,
    since: Instant,
    ok: impl Fn(u16, &Value) -> bool,
) -> Duration {
    loop {
        let (st, v) = get(c, r, path).await;
        if ok(st, &v) {
            return since.elapsed();
        }
        assert!(
            since.elapsed() < Duration::from_secs(5),
            "replica :{} never showed the change at {path}: {st} {v}\nlog:\n{}",
            r.port,
            r.log()
        );
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
}

fn check_within(what: &str, lags: &[Duration]) {
    eprintln!(
        "{what}: seen by the other replicas after {:?}",
        lags.iter()
            .map(|d| d.as_secs_f64() * 1e3)
            .collect::<Vec<_>>()
    );
    for l in lags {
        assert!(*l < WITHIN, "{what}: a replica took {l:?} (> {WITHIN:?})");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_admin_change_through_one_replica_is_served_by_the_others_within_200_ms() {
    let _serial = SERIAL.lock().await;
    let redis = Redis::start();
    let c = client();
    let rs = replicas(&redis.url(), 3, &c).await;
    let (r1, others) = (&rs[0], &rs[1..]);

    // Scene put (created) through replica 1.
    let (st, put) = admin(&c, r1, Method::PUT, "/v1/scenes/marina", Some(spec(0.4))).await;
    assert_eq!(st, 201, "{put}");
    let hash = put["spec_hash"].as_str().unwrap().to_owned();
    let epoch = put["spec"]["epoch"].as_f64().unwrap();
    let t0 = Instant::now();
    let mut lags = Vec::new();
    for r in others {
        lags.push(
            until(&c, r, "/v1/scenes/marina", t0, |st, v| {
                st == 200 && v["spec_hash"] == hash.as_str()
            })
            .await,
        );
        // The same spec, epoch included (to the bit), on every replica.
        let (_, v) = get(&c, r, "/v1/scenes/marina").await;
        assert_eq!(v["spec"], put["spec"]);
        assert_eq!(
            v["spec"]["epoch"].as_f64().unwrap().to_bits(),
            epoch.to_bits()
        );
    }
    check_within("scene put", &lags);

    // Replaced through replica 2: seen by 1 and 3, the clock kept.
    let (st, rep) = admin(
        &c,
        &rs[1],
        Method::PUT,
        "/v1/scenes/marina",
        Some(spec(0.7)),
    )
    .await;
    assert_eq!(st, 200, "{rep}");
    let hash2 = rep["spec_hash"].as_str().unwrap().to_owned();
    assert_ne!(hash, hash2);
    let t0 = Instant::now();
    let mut lags = Vec::new();
    for r in [&rs[0], &rs[2]] {
        lags.push(
            until(&c, r, "/v1/scenes/marina", t0, |st, v| {
                st == 200 && v["spec_hash"] == hash2.as_str()
            })
            .await,
        );
    }
    check_within("scene replace (through replica 2)", &lags);

    // Clock: pause and seek → every replica reads exactly t = 100, paused.
    let (st, clk) = admin(
        &c,
        r1,
        Method::PUT,
        "/v1/scenes/marina/clock",
        Some(json!({"t": 100.0, "paused": true})),
    )
    .await;
    assert_eq!(st, 200, "{clk}");
    assert_eq!(clk["t"], 100.0);
    let t0 = Instant::now();
    let mut lags = Vec::new();
    for r in others {
        lags.push(
            until(&c, r, "/v1/scenes/marina/clock", t0, |st, v| {
                st == 200 && v["paused"] == true && v["t"].as_f64() == Some(100.0)
            })
            .await,
        );
    }
    check_within("clock pause + seek", &lags);

    // Rate 2 and resume: the same anchor everywhere, so t − rate·unix agrees.
    let (st, clk) = admin(
        &c,
        r1,
        Method::PUT,
        "/v1/scenes/marina/clock",
        Some(json!({"rate": 2.0, "paused": false})),
    )
    .await;
    assert_eq!(st, 200, "{clk}");
    let base = |v: &Value| v["t"].as_f64().unwrap() - 2.0 * v["unix"].as_f64().unwrap();
    let ours = base(&clk);
    let t0 = Instant::now();
    let mut lags = Vec::new();
    for r in others {
        lags.push(
            until(&c, r, "/v1/scenes/marina/clock", t0, |st, v| {
                st == 200 && v["paused"] == false && v["rate"].as_f64() == Some(2.0)
            })
            .await,
        );
        let (_, v) = get(&c, r, "/v1/scenes/marina/clock").await;
        assert!(
            (base(&v) - ours).abs() < 1e-5,
            "replica :{} anchors the clock elsewhere: {v} vs {clk}",
            r.port
        );
    }
    check_within("clock rate + resume", &lags);

    // Delete through replica 1 → 404 everywhere.
    let (st, _) = admin(&c, r1, Method::DELETE, "/v1/scenes/marina", None).await;
    assert_eq!(st, 204);
    let t0 = Instant::now();
    let mut lags = Vec::new();
    for r in others {
        lags.push(until(&c, r, "/v1/scenes/marina", t0, |st, _| st == 404).await);
    }
    check_within("scene delete", &lags);

    // A built-in scene's clock paused through replica 3: the same bits on replicas 1 and 2,
    // and (issue 28) the same generation, with a `clock` event to a session on replica 1.
    let mut ws = {
        let url = format!("ws://127.0.0.1:{}/v1/scenes/calm/stream", rs[0].port);
        tokio_tungstenite::connect_async(url.as_str())
            .await
            .expect("stream on replica 1")
            .0
    };
    // Reads until the clock event and notes when it came.
    let event = tokio::spawn(async move {
        use futures_util::StreamExt;
        loop {
            let m = tokio::time::timeout(Duration::from_secs(5), ws.next())
                .await
                .expect("a clock event within 5 s")
                .expect("socket open")
                .expect("frame");
            if let tokio_tungstenite::tungstenite::Message::Text(t) = m {
                let v: Value = serde_json::from_str(t.as_str()).unwrap();
                if v["type"] == "clock" {
                    return (Instant::now(), v);
                }
            }
        }
    });
    let (st, clk) = admin(
        &c,
        &rs[2],
        Method::PUT,
        "/v1/scenes/calm/clock",
        Some(json!({"paused": true})),
    )
    .await;
    assert_eq!(st, 200, "{clk}");
    let t_bits = clk["t"].as_f64().unwrap().to_bits();
    let t0 = Instant::now();
    let mut lags = Vec::new();
    for r in &rs[..2] {
        lags.push(
            until(&c, r, "/v1/scenes/calm/clock", t0, |st, v| {
                st == 200 && v["t"].as_f64().map(f64::to_bits) == Some(t_bits)
            })
            .await,
        );
    }
    check_within("built-in clock pause (through replica 3)", &lags);
    let (came, event) = event.await.expect("reader");
    check_within(
        "clock event (replica 1)",
        &[came.saturating_duration_since(t0)],
    );
    assert_eq!(event["generation"], clk["generation"], "{event} vs {clk}");
    assert_eq!(event["t"].as_f64().unwrap().to_bits(), t_bits);
    for r in &rs[..2] {
        let (_, v) = get(&c, r, "/v1/scenes/calm/clock").await;
        assert_eq!(v["generation"], clk["generation"], "replica :{}", r.port);
    }

    // A replica started now catches up from the store alone.
    let late = Replica::spawn(&redis.url(), &[]);
    late.wait_ready(&c).await;
    let (st, v) = get(&c, &late, "/v1/scenes/marina").await;
    assert_eq!(st, 404, "{v}");
    let (_, v) = get(&c, &late, "/v1/scenes/calm/clock").await;
    assert_eq!(v["t"].as_f64().unwrap().to_bits(), t_bits, "{v}");
    assert_eq!(v["paused"], true);
    assert_eq!(
        v["generation"], clk["generation"],
        "from the record, not a count"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn redis_down_serves_read_only_and_a_restart_resyncs_every_replica() {
    let _serial = SERIAL.lock().await;
    let mut redis = Redis::start();
    let c = client();
    let rs = replicas(&redis.url(), 2, &c).await;
    let (st, v) = admin(&c, &rs[0], Method::PUT, "/v1/scenes/reef", Some(spec(0.3))).await;
    assert_eq!(st, 201, "{v}");
    until(&c, &rs[1], "/v1/scenes/reef", Instant::now(), |st, _| {
        st == 200
    })
    .await;
    let q = "/v1/scenes/reef/height?x=3.5&z=-2&t=12.25";
    let (_, before) = get(&c, &rs[1], q).await;

    // Redis gone.
    redis.kill9();
    for r in &rs {
        // Queries go on from the last known scenes, to the same bits.
        let (st, v) = get(&c, r, q).await;
        assert_eq!(st, 200, "{v}");
        assert_eq!(
            v["height"].as_f64().unwrap().to_bits(),
            before["height"].as_f64().unwrap().to_bits()
        );
        let (st, v) = get(&c, r, "/v1/scenes/reef/clock").await;
        assert_eq!(st, 200, "{v}");
    }
    // Admin writes: 503 with a message, nothing changed.
    let t0 = Instant::now();
    let (st, v) = admin(
        &c,
        &rs[0],
        Method::PUT,
        "/v1/scenes/reef/clock",
        Some(json!({"paused": true})),
    )
    .await;
    let took = t0.elapsed();
    assert_eq!(st, 503, "{v}");
    assert_eq!(v["error"]["code"], "store_unavailable", "{v}");
    assert!(
        v["error"]["message"].as_str().unwrap().contains("Redis"),
        "{v}"
    );
    assert!(took < Duration::from_secs(3), "the refusal took {took:?}");
    let (st, v) = admin(&c, &rs[1], Method::DELETE, "/v1/scenes/reef", None).await;
    assert_eq!(
        (st, v["error"]["code"].as_str()),
        (503, Some("store_unavailable")),
        "{v}"
    );
    let (st, v) = get(&c, &rs[1], "/v1/scenes/reef/clock").await;
    assert_eq!((st, v["paused"].as_bool()), (200, Some(false)));
    // Still ready (serving), and saying the store is down.
    for r in &rs {
        until(&c, r, "/readyz", Instant::now(), |st, v| {
            st == 200 && v["store"]["connected"] == false
        })
        .await;
    }

    // Redis back (same port, same AOF): every replica reconnects by itself.
    redis.restart();
    let t0 = Instant::now();
    for r in &rs {
        let lag = until(&c, r, "/readyz", t0, |st, v| {
            st == 200 && v["store"]["connected"] == true
        })
        .await;
        eprintln!(
            "replica :{} reconnected {lag:?} after Redis came back",
            r.port
        );
        assert!(lag < Duration::from_secs(4), "reconnect took {lag:?}");
    }
    // Nothing was lost (the put is in the AOF) and writes work again.
    let (st, v) = admin(
        &c,
        &rs[1],
        Method::PUT,
        "/v1/scenes/reef/clock",
        Some(json!({"t": 7.0, "paused": true})),
    )
    .await;
    assert_eq!(st, 200, "{v}");
    let lag = until(
        &c,
        &rs[0],
        "/v1/scenes/reef/clock",
        Instant::now(),
        |st, v| st == 200 && v["t"].as_f64() == Some(7.0) && v["paused"] == true,
    )
    .await;
    check_within("clock change after the Redis restart", &[lag]);

    // A change made while a replica's feed is stopped (SIGSTOP, so it misses the stream's
    // push) still reaches it once it runs again.
    rs[1].proc.as_ref().unwrap().signal("STOP");
    let (st, v) = admin(
        &c,
        &rs[0],
        Method::PUT,
        "/v1/scenes/lagoon",
        Some(spec(0.2)),
    )
    .await;
    assert_eq!(st, 201, "{v}");
    rs[1].proc.as_ref().unwrap().signal("CONT");
    until(&c, &rs[1], "/v1/scenes/lagoon", Instant::now(), |st, _| {
        st == 200
    })
    .await;

    // A restart that loses nothing, and a replica started after it, sees everything.
    let late = Replica::spawn(&redis.url(), &[]);
    late.wait_ready(&c).await;
    for path in ["/v1/scenes/reef", "/v1/scenes/lagoon"] {
        let (st, v) = get(&c, &late, path).await;
        assert_eq!(st, 200, "{path}: {v}");
    }
    let (_, v) = get(&c, &late, "/v1/scenes/reef/clock").await;
    assert_eq!(
        (v["t"].as_f64(), v["paused"].as_bool()),
        (Some(7.0), Some(true)),
        "{v}"
    );
}

/// A scene put that moves the epoch started a fresh clock at generation 0 on every replica and
/// deleted the scene's clock record in Redis, so a client whose fit was at generation 0 could
/// not tell the old clock's pongs from the new one's. The put now carries the fresh clock (from
/// the new epoch, rate 1, running, one generation after the clock it replaces) in its feed
/// entry and writes it as the scene's clock record in the same script: every replica reads the
/// same clock, and so does a replica started afterwards, which knows it from the record alone.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_put_that_moves_the_epoch_gives_every_replica_the_same_clock_one_generation_on() {
    let _serial = SERIAL.lock().await;
    let redis = Redis::start();
    let c = client();
    let rs = replicas(&redis.url(), 2, &c).await;
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64();
    let clock = "/v1/scenes/tide/clock";
    let mut sea = spec(0.3);
    sea["epoch"] = json!(now - 100.0);
    // A particle layer, for the impact below.
    sea["layers"]
        .as_array_mut()
        .unwrap()
        .push(json!({"kind": "particles"}));
    let (st, v) = admin(
        &c,
        &rs[0],
        Method::PUT,
        "/v1/scenes/tide",
        Some(sea.clone()),
    )
    .await;
    assert_eq!(st, 201, "{v}");
    // A clock change through the other replica: generation 1 everywhere.
    until(&c, &rs[1], clock, Instant::now(), |st, _| st == 200).await;
    let (st, v) = admin(&c, &rs[1], Method::PUT, clock, Some(json!({"rate": 2.0}))).await;
    assert_eq!((st, &v["generation"]), (200, &json!(1)), "{v}");
    until(&c, &rs[0], clock, Instant::now(), |_, v| {
        v["generation"] == 1
    })
    .await;
    // An impact, which any put drops (with the clock record, in the same script).
    let (_, v) = get(&c, &rs[0], clock).await;
    let t = v["t"].as_f64().unwrap() + 5.0;
    let impact = json!({"position": [2.0, 0.5], "t": t, "strength": 0.4, "radius": 0.8});
    let (st, v) = admin(
        &c,
        &rs[0],
        Method::POST,
        "/v1/scenes/tide/impacts",
        Some(impact),
    )
    .await;
    assert_eq!(st, 202, "{v}");
    let redis_says = |cmd: &str| procs::redis_line(redis.port, cmd).unwrap_or_default();
    assert_eq!(redis_says("LLEN swell:impacts:tide:list"), ":1");

    // 1,000 s earlier, through replica 1: generation 2, a fresh clock from the new epoch.
    let epoch = now - 1100.0;
    sea["epoch"] = json!(epoch);
    let (st, v) = admin(&c, &rs[0], Method::PUT, "/v1/scenes/tide", Some(sea)).await;
    assert_eq!(st, 200, "{v}");
    assert_eq!(redis_says("HEXISTS swell:admin clock:tide"), ":1");
    assert_eq!(redis_says("EXISTS swell:impacts:tide:list"), ":0");
    until(&c, &rs[1], clock, Instant::now(), |_, v| v["rate"] == 1.0).await;
    // Where the clock reads t = 0, by a reading: the new epoch, to the bit, on every replica
    // (for Unix times of today `t = unix − epoch` and `unix − t` are exact subtractions).
    let zero = |v: &Value| v["unix"].as_f64().unwrap() - v["t"].as_f64().unwrap();
    let check = |who: &str, v: &Value| {
        assert_eq!(
            (&v["generation"], &v["rate"], &v["paused"]),
            (&json!(2), &json!(1.0), &json!(false)),
            "{who}: {v}"
        );
        assert_eq!(zero(v).to_bits(), epoch.to_bits(), "{who}: {v}");
    };
    for r in &rs {
        let (_, v) = get(&c, r, clock).await;
        check(&format!("replica :{}", r.port), &v);
    }

    // A replica started now catches up from the store alone: the scene's clock record.
    let late = Replica::spawn(&redis.url(), &[]);
    late.wait_ready(&c).await;
    let (_, v) = get(&c, &late, clock).await;
    check("a replica started afterwards", &v);
}

/// Heights (as bits) along a line through `[0, 0]` on scene `harbour` at `t`, from `r`.
async fn harbour_heights(c: &Client, r: &Replica, t: f64) -> Vec<u64> {
    let points: Vec<[f64; 2]> = (0..64).map(|i| [i as f64 * 0.25, 0.5]).collect();
    let resp = c
        .post(r.url("/v1/scenes/harbour/sample"))
        .json(&json!({"t": t, "points": points}))
        .send()
        .await
        .expect("sample");
    assert_eq!(resp.status().as_u16(), 200);
    let v: Value = resp.json().await.unwrap();
    v["height"]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| h.as_f64().unwrap().to_bits())
        .collect()
}

/// Issue 15 in a fleet: an impact posted through replica 1 used to ripple on replica 1 only
/// (the admin feed did not carry impacts), so replicas answered different bits for the same t
/// and point. Now it is stored in Redis with a feed entry: every replica ripples with it within
/// the admin-change bound, tick frames on another replica carry it, and it survives a Redis
/// restart and reaches a replica that starts later.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_impact_through_one_replica_ripples_identically_on_every_replica() {
    use futures_util::{SinkExt as _, StreamExt as _};
    use tokio_tungstenite::tungstenite::Message;
    let _serial = SERIAL.lock().await;
    let mut redis = Redis::start();
    let c = client();
    let rs = replicas(&redis.url(), 3, &c).await;
    // A tick subscriber on replica 2 (the impact goes in through replica 1).
    let mut ws = tokio_tungstenite::connect_async(format!(
        "ws://127.0.0.1:{}/v1/scenes/harbour/stream",
        rs[1].port
    ))
    .await
    .expect("upgrade")
    .0;
    ws.send(Message::text(r#"{"type":"subscribe","ticks":true}"#))
        .await
        .unwrap();
    // A time a little ahead of the clock: the ring starts at t0 and is 1.5 s old at `at`.
    let (_, clk) = get(&c, &rs[0], "/v1/scenes/harbour/clock").await;
    let t0 = (clk["t"].as_f64().unwrap() + 5.0).floor();
    let at = t0 + 1.5;
    let before = harbour_heights(&c, &rs[0], at).await;
    for r in &rs[1..] {
        assert_eq!(harbour_heights(&c, r, at).await, before);
    }

    let (st, v) = admin(
        &c,
        &rs[0],
        Method::POST,
        "/v1/scenes/harbour/impacts",
        Some(json!({"position": [2.0, 0.5], "t": t0, "strength": 0.4, "radius": 0.8})),
    )
    .await;
    assert_eq!(st, 202, "{v}");
    assert_eq!(v["t"].as_f64(), Some(t0), "{v}");
    let posted = Instant::now();
    // Read-your-writes: the replica that answered ripples with it already.
    let after = harbour_heights(&c, &rs[0], at).await;
    let moved = after.iter().zip(&before).filter(|(a, b)| a != b).count();
    assert!(moved > 5, "the ring moves heights along the line: {moved}");
    // The others within the admin-change bound, to the bit.
    let mut lags = Vec::new();
    for r in &rs[1..] {
        loop {
            if harbour_heights(&c, r, at).await == after {
                lags.push(posted.elapsed());
                break;
            }
            assert!(
                posted.elapsed() < Duration::from_secs(5),
                "replica :{} never rippled with the impact\nlog:\n{}",
                r.port,
                r.log()
            );
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
    }
    check_within("impact", &lags);
    // Replica 2's tick frames carry it.
    let framed = tokio::time::timeout(Duration::from_secs(5), async {
        loop {
            let Some(Ok(Message::Text(t))) = ws.next().await else {
                panic!("the stream ended");
            };
            let f: Value = serde_json::from_str(t.as_str()).unwrap();
            if let Some(list) = f["impacts"].as_array() {
                return list[0].clone();
            }
        }
    })
    .await
    .expect("a tick frame with the impact on replica 2");
    assert_eq!(framed["t"].as_f64(), Some(t0), "{framed}");
    assert_eq!(framed["position"], json!([2.0, 0.5]), "{framed}");
    assert_eq!(
        framed["tick"].as_i64(),
        Some((t0 * 30.0) as i64),
        "{framed}"
    );
    drop(ws);
    // Listed the same everywhere.
    let path = format!("/v1/scenes/harbour/impacts?t={t0}");
    let (_, l1) = get(&c, &rs[0], &path).await;
    assert_eq!(l1["impacts"].as_array().map(Vec::len), Some(1), "{l1}");
    for r in &rs[1..] {
        assert_eq!(get(&c, r, &path).await.1, l1);
    }

    // Redis restarts (AOF): the impact is still there; every replica still ripples with it
    // once reconnected, and a replica started now does too.
    redis.kill9();
    redis.restart();
    for r in &rs {
        until(&c, r, "/readyz", Instant::now(), |st, v| {
            st == 200 && v["store"]["connected"] == true
        })
        .await;
        assert_eq!(harbour_heights(&c, r, at).await, after);
    }
    let late = Replica::spawn(&redis.url(), &[]);
    late.wait_ready(&c).await;
    assert_eq!(harbour_heights(&c, &late, at).await, after);
    assert_eq!(get(&c, &late, &path).await.1, l1);

    // Issue 27: the list in Redis held every impact ever made, so after 100,000 a scene
    // refused every splash. An impact more than a ring lifetime (60 s on harbour) newer than
    // the first drops it from the list, as every replica drops it from its set.
    let llen =
        || procs::redis_line(redis.port, "LLEN swell:impacts:harbour:list").unwrap_or_default();
    assert_eq!(llen(), ":1");
    let (st, v) = admin(
        &c,
        &rs[1],
        Method::PUT,
        "/v1/scenes/harbour/clock",
        Some(json!({"t": t0 + 100.0})),
    )
    .await;
    assert_eq!(st, 200, "{v}");
    let (st, v) = admin(
        &c,
        &rs[1],
        Method::POST,
        "/v1/scenes/harbour/impacts",
        Some(json!({"position": [5.0, 5.0], "t": t0 + 100.0, "strength": 0.2, "radius": 0.5})),
    )
    .await;
    assert_eq!(st, 202, "{v}");
    assert_eq!(llen(), ":1", "the expired impact is still in Redis");

    // Replacing the scene through replica 3 starts its impacts afresh everywhere (and in
    // Redis: the late replica agrees).
    let (_, spec) = get(&c, &rs[0], "/v1/scenes/harbour").await;
    let (st, v) = admin(
        &c,
        &rs[2],
        Method::PUT,
        "/v1/scenes/harbour",
        Some(spec["spec"].clone()),
    )
    .await;
    assert_eq!(st, 200, "{v}");
    for r in rs.iter().chain([&late]) {
        until(&c, r, &path, Instant::now(), |st, v| {
            st == 200 && v["impacts"].as_array().is_some_and(Vec::is_empty)
        })
        .await;
        assert_eq!(harbour_heights(&c, r, at).await, before);
    }
}

/// A query as sent: method, path, body, content type, accept.
#[derive(Clone)]
struct Query {
    post: bool,
    path: String,
    body: Vec<u8>,
    protobuf_in: bool,
    protobuf_out: bool,
}

/// splitmix64: a tiny seeded generator, so a failure replays.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn coord(&mut self) -> f64 {
        // Any f64 in ±5 km with a random mantissa, so bits differ between points.
        ((self.next() >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e4
    }
}

/// A random query; `t: None` means the scene's now.
fn random_query(rng: &mut Rng, t: Option<f64>) -> Query {
    use prost::Message as _;
    use swell::wire::v1;
    // "Now" only on the analytic scenes: at now an FFT scene makes every replica compute the
    // frames its clock reaches, 60 a second per scene (the run-ahead), more than this test's
    // two cores should spend; fixed times cover the FFT scenes from cached frames.
    let scenes: &[&str] = if t.is_some() {
        &["calm", "lake", "open-sea", "storm"]
    } else {
        &["calm", "lake"]
    };
    let scene = scenes[rng.below(scenes.len() as u64) as usize];
    let protobuf_out = rng.below(2) == 0;
    let (x, z) = (rng.coord(), rng.coord());
    match rng.below(4) {
        0 => {
            let tq = t.map(|t| format!("&t={t}")).unwrap_or_default();
            Query {
                post: false,
                path: format!("/v1/scenes/{scene}/height?x={x}&z={z}{tq}"),
                body: Vec::new(),
                protobuf_in: false,
                protobuf_out,
            }
        }
        1 => {
            let n = 1 + rng.below(8) as usize;
            let points: Vec<[f64; 2]> = (0..n)
                .map(|_| [rng.coord() / 100.0, rng.coord() / 100.0])
                .collect();
            let mut body = json!({"origin": [x, z], "points": points,
                "fields": ["height", "normal", "displacement", "jacobian"]});
            if let Some(t) = t {
                body["t"] = json!(t);
            }
            Query {
                post: true,
                path: format!("/v1/scenes/{scene}/sample"),
                body: serde_json::to_vec(&body).unwrap(),
                protobuf_in: false,
                protobuf_out,
            }
        }
        2 => {
            let n = 1 + rng.below(8) as usize;
            let req = v1::SampleRequest {
                t,
                origin: Some(v1::Point2 { x, z }),
                points: (0..n)
                    .map(|_| v1::Point2 {
                        x: rng.coord() / 100.0,
                        z: rng.coord() / 100.0,
                    })
                    .collect(),
                fields: vec![v1::Field::Height as i32, v1::Field::Normal as i32],
                accuracy: None,
            };
            Query {
                post: true,
                path: format!("/v1/scenes/{scene}/sample"),
                body: req.encode_to_vec(),
                protobuf_in: true,
                protobuf_out,
            }
        }
        _ => {
            let mut body = json!({"bodies": [{"position": [x, z], "yaw": (rng.below(628) as f64) / 100.0,
                "length": 4 + rng.below(20), "beam": 2 + rng.below(5)}]});
            if let Some(t) = t {
                body["t"] = json!(t);
            }
            Query {
                post: true,
                path: format!("/v1/scenes/{scene}/orientation"),
                body: serde_json::to_vec(&body).unwrap(),
                protobuf_in: false,
                protobuf_out,
            }
        }
    }
}

async fn send(c: &Client, base: &str, q: &Query) -> (u16, Vec<u8>) {
    let url = format!("{base}{}", q.path);
    let mut rb = if q.post {
        c.post(url).body(q.body.clone())
    } else {
        c.get(url)
    };
    rb = rb.header(
        "content-type",
        if q.protobuf_in {
            "application/x-protobuf"
        } else {
            "application/json"
        },
    );
    if q.protobuf_out {
        rb = rb.header("accept", "application/x-protobuf");
    }
    let r = rb.send().await.expect("query");
    (r.status().as_u16(), r.bytes().await.expect("body").to_vec())
}

/// The `t` an answer used (JSON `"t"`, or field 1 of every protobuf answer).
fn answer_t(q: &Query, bytes: &[u8]) -> f64 {
    use prost::Message as _;
    use swell::wire::v1;
    if !q.protobuf_out {
        let v: Value = serde_json::from_slice(bytes).unwrap();
        return v["t"].as_f64().unwrap();
    }
    if q.path.contains("/height") {
        v1::HeightResponse::decode(bytes).unwrap().t
    } else if q.path.contains("/sample") {
        v1::SampleResponse::decode(bytes).unwrap().t
    } else {
        v1::OrientationResponse::decode(bytes).unwrap().t
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ten_thousand_random_queries_answer_the_same_bytes_through_nginx_and_each_replica() {
    use futures_util::StreamExt as _;
    let _serial = SERIAL.lock().await;
    let redis = Redis::start();
    let c = client();
    let rs = replicas(&redis.url(), 3, &c).await;
    let ports: Vec<u16> = rs.iter().map(|r| r.port).collect();
    let nginx = procs::Nginx::start(&ports, &c).await;
    // A few fixed times (FFT frames for them stay cached) and "now" for about one query in six.
    const TIMES: [f64; 5] = [0.0, 12.5, 60.0, 1234.5678, 86_400.25];
    let mut rng = Rng(0x5EA_F1EE7);
    let queries: Vec<(Query, bool)> = (0..10_000)
        .map(|_| {
            let now = rng.below(6) == 0;
            let t = (!now).then(|| TIMES[rng.below(TIMES.len() as u64) as usize]);
            let mut r2 = Rng(rng.next());
            (random_query(&mut r2, t), now)
        })
        .collect();
    let started = Instant::now();
    let bases: Vec<String> = rs.iter().map(|r| r.base.clone()).collect();
    let results = futures_util::stream::iter(queries.into_iter().enumerate())
        .map(|(i, (q, now))| {
            let (c, nginx, bases) = (c.clone(), nginx.base.clone(), bases.clone());
            async move {
                let (st, via_nginx) = send(&c, &nginx, &q).await;
                assert_eq!(
                    st,
                    200,
                    "query {i} {} through nginx: {}",
                    q.path,
                    String::from_utf8_lossy(&via_nginx)
                );
                // "Now" is each replica's own reading: pin the t nginx's replica used, and every
                // replica must give the same bytes for it.
                let pinned = if now {
                    pin(&q, answer_t(&q, &via_nginx))
                } else {
                    q.clone()
                };
                for b in &bases {
                    let (st, direct) = send(&c, b, &pinned).await;
                    assert_eq!(st, 200, "query {i} {} at {b}", pinned.path);
                    assert!(
                        direct == via_nginx,
                        "query {i} {} (now: {now}): {b} answered\n{}\nnginx answered\n{}",
                        pinned.path,
                        String::from_utf8_lossy(&direct),
                        String::from_utf8_lossy(&via_nginx)
                    );
                }
                now
            }
        })
        .buffer_unordered(16)
        .collect::<Vec<bool>>()
        .await;
    let nows = results.iter().filter(|n| **n).count();
    eprintln!(
        "{} queries ({} at now, pinned) × (nginx + 3 replicas): byte-identical, {:.1} s",
        results.len(),
        nows,
        started.elapsed().as_secs_f64()
    );
    assert_eq!(results.len(), 10_000);
    assert!(nows > 1000, "{nows} queries at now");

    // WebSockets through nginx (docker/nginx.conf's upgrade headers): the subprotocol is
    // negotiated, ping/pong answers, tick frames flow.
    use futures_util::SinkExt as _;
    use tokio_tungstenite::tungstenite::{Message, client::IntoClientRequest as _};
    let mut req = format!("ws://127.0.0.1:{}/v1/scenes/calm/stream", nginx.port)
        .into_client_request()
        .unwrap();
    req.headers_mut()
        .insert("sec-websocket-protocol", "swell.v1.json".parse().unwrap());
    let (mut ws, resp) = tokio_tungstenite::connect_async(req)
        .await
        .expect("upgrade through nginx");
    assert_eq!(resp.headers()["sec-websocket-protocol"], "swell.v1.json");
    ws.send(Message::text(r#"{"type":"ping","id":1,"client_time":5.5}"#))
        .await
        .unwrap();
    ws.send(Message::text(r#"{"type":"subscribe","ticks":true}"#))
        .await
        .unwrap();
    let (mut pong, mut ticks) = (false, Vec::new());
    let deadline = Instant::now() + Duration::from_secs(10);
    while !(pong && ticks.len() >= 3) {
        assert!(Instant::now() < deadline, "no pong/ticks through nginx");
        let Some(Ok(Message::Text(text))) = ws.next().await else {
            continue;
        };
        let v: Value = serde_json::from_str(&text).unwrap();
        match v["type"].as_str() {
            Some("pong") => pong = v["client_time"] == 5.5,
            Some("tick") => ticks.push(v["tick"].as_i64().unwrap()),
            _ => {}
        }
    }
    assert!(ticks.windows(2).all(|w| w[1] > w[0]), "{ticks:?}");
}

/// The same query with `t` given explicitly.
fn pin(q: &Query, t: f64) -> Query {
    use prost::Message as _;
    use swell::wire::v1;
    let mut p = q.clone();
    if !q.post {
        p.path = format!("{}&t={t}", q.path);
    } else if q.protobuf_in {
        let mut req = v1::SampleRequest::decode(q.body.as_slice()).unwrap();
        req.t = Some(t);
        p.body = req.encode_to_vec();
    } else {
        let mut v: Value = serde_json::from_slice(&q.body).unwrap();
        v["t"] = json!(t);
        p.body = serde_json::to_vec(&v).unwrap();
    }
    p
}

/// GET /bodies on every replica until all report tick `>= min` and the same tick; returns the
/// bodies JSON text of each (serde_json writes shortest round-trip numbers: equal text is equal
/// bits).
async fn settled_bodies(c: &Client, rs: &[&Replica], scene: &str) -> (i64, Vec<String>) {
    let start = Instant::now();
    let mut prev = None;
    loop {
        let mut ticks = Vec::new();
        let mut texts = Vec::new();
        for r in rs {
            let (st, v) = get(c, r, &format!("/v1/scenes/{scene}/bodies")).await;
            assert_eq!(st, 200, "{v}");
            ticks.push(v["tick"].as_i64().unwrap());
            texts.push(v["bodies"].to_string());
        }
        // Settled: the same tick everywhere, twice in a row 150 ms apart (a watermark read
        // just before the pause may still arrive).
        if ticks.iter().all(|t| *t == ticks[0]) {
            if prev == Some(ticks[0]) {
                return (ticks[0], texts);
            }
            prev = Some(ticks[0]);
            tokio::time::sleep(Duration::from_millis(150)).await;
            continue;
        }
        prev = None;
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "replicas never settled: {ticks:?}"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

async fn sequencer_of(c: &Client, rs: &[Replica], scene: &str) -> Option<usize> {
    for (i, r) in rs.iter().enumerate() {
        if r.proc.is_none() {
            continue;
        }
        let (_, v) = get(c, r, "/readyz").await;
        if v["store"]["sequencing"]
            .as_array()
            .is_some_and(|a| a.iter().any(|s| s == scene))
        {
            return Some(i);
        }
    }
    None
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bodies_spawned_and_driven_through_different_replicas_are_bit_identical_and_survive_the_sequencer()
 {
    let _serial = SERIAL.lock().await;
    let redis = Redis::start();
    let c = client();
    // Body snapshots every second, so the replica started at the end joins from one.
    let mut rs: Vec<Replica> = (0..3)
        .map(|_| Replica::spawn(&redis.url(), &["--snapshot-interval", "1"]))
        .collect();
    for r in &rs {
        r.wait_ready(&c).await;
    }
    // With a particle layer (no ambient particles): the impact below ripples under the boats.
    let mut bay = spec(0.5);
    bay["layers"]
        .as_array_mut()
        .unwrap()
        .push(json!({"kind": "particles", "count": 0}));
    let (st, v) = admin(&c, &rs[0], Method::PUT, "/v1/scenes/bay", Some(bay)).await;
    assert_eq!(st, 201, "{v}");
    // The reference: the whole body log, recorded as it is written, replayed in this process.
    let served = v["spec"].clone();
    let rec = replay::Recorder::start(&redis.url(), "bay").await;
    until(&c, &rs[2], "/v1/scenes/bay", Instant::now(), |st, _| {
        st == 200
    })
    .await;
    until(&c, &rs[1], "/v1/scenes/bay", Instant::now(), |st, _| {
        st == 200
    })
    .await;

    // Two boats spawned through replica 1, driven through replica 2.
    let boat = |x: f64| {
        json!({"mass": 3000, "hull": {"kind": "box", "length": 8, "beam": 3, "height": 1.5},
        "position": [x, 1.0, 0.0], "yaw": 0.3})
    };
    let mut spawned = Vec::new();
    for (i, x) in [0.0, 20.0].into_iter().enumerate() {
        let (st, v) = admin(
            &c,
            &rs[0],
            Method::POST,
            "/v1/scenes/bay/bodies",
            Some(boat(x)),
        )
        .await;
        assert_eq!(st, 201, "{v}");
        assert_eq!(v["id"], i as u64, "{v}");
        // The ticks a native client replays it from (issue 28), as applied from the log.
        assert!(v["spawn_tick"].as_i64() >= v["anchor_tick"].as_i64(), "{v}");
        spawned.push((v["spawn_tick"].clone(), v["anchor_tick"].clone()));
    }
    // Every replica has both (their followers picked the log up), with the same ticks.
    for r in &rs {
        until(&c, r, "/v1/scenes/bay/bodies", Instant::now(), |st, v| {
            st == 200 && v["bodies"].as_array().is_some_and(|b| b.len() == 2)
        })
        .await;
        let (_, v) = get(&c, r, "/v1/scenes/bay/bodies").await;
        for (i, (spawn_tick, anchor_tick)) in spawned.iter().enumerate() {
            assert_eq!(&v["bodies"][i]["spawn_tick"], spawn_tick, "{v}");
            assert_eq!(&v["anchor_tick"], anchor_tick, "{v}");
        }
    }
    let (st, v) = admin(
        &c,
        &rs[1],
        Method::POST,
        "/v1/scenes/bay/bodies/0/input",
        Some(json!({"force": [40000, 0, 0], "torque": [0, 5000, 0], "ticks": 40})),
    )
    .await;
    assert_eq!(st, 202, "{v}");
    // No from_tick: it acts from the tick it applies at; no anchor (answered before applied).
    assert_eq!(
        (&v["from_tick"], &v["ticks"]),
        (&v["tick"], &json!(40)),
        "{v}"
    );
    assert!(v.get("anchor_tick").is_none(), "{v}");
    // An impact through replica 3 under boat 0: every replica's bodies feel it from the tick
    // the log sequenced it at (issue 15), as the replay below does.
    let (st, v) = admin(
        &c,
        &rs[2],
        Method::POST,
        "/v1/scenes/bay/impacts",
        Some(json!({"position": [2.0, 0.5], "strength": 0.8, "radius": 1.5})),
    )
    .await;
    assert_eq!(st, 202, "{v}");
    let logged = Instant::now();
    while !rec
        .entries()
        .iter()
        .any(|e| matches!(e.command(), Some((_, BodyCmd::Impact(_)))))
    {
        assert!(
            logged.elapsed() < Duration::from_secs(5),
            "the impact never reached the body log"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // The answer publishes the tick the log sequenced it at, which every replica feels it from
    // (what a native client feels it at).
    let sequenced = rec.entries().iter().find_map(|e| match e.command() {
        Some((tick, BodyCmd::Impact(_))) => Some(tick),
        _ => None,
    });
    assert_eq!(v["body_tick"].as_i64(), sequenced, "{v}");
    for r in &rs {
        until(&c, r, "/v1/scenes/bay/bodies", Instant::now(), |st, b| {
            st == 200 && b["felt_impacts"][0]["body_tick"] == v["body_tick"]
        })
        .await;
    }

    // Tick frames from all three replicas: the same states for the same tick.
    let mut socks = Vec::new();
    for r in &rs {
        let mut ws = {
            use tokio_tungstenite::tungstenite::client::IntoClientRequest as _;
            let req = format!("ws://127.0.0.1:{}/v1/scenes/bay/stream", r.port)
                .into_client_request()
                .unwrap();
            tokio_tungstenite::connect_async(req)
                .await
                .expect("upgrade")
                .0
        };
        use futures_util::SinkExt as _;
        ws.send(tokio_tungstenite::tungstenite::Message::text(
            r#"{"type":"subscribe","ticks":true}"#,
        ))
        .await
        .unwrap();
        socks.push(ws);
    }
    let mut frames: Vec<std::collections::BTreeMap<i64, String>> = vec![Default::default(); 3];
    // Each replica's frames' impacts, and a second impact posted while they stream: every
    // replica's frame announces it with the tick the log sequenced (its POST answer's), not
    // one of its own (what a live native client feels it at).
    let mut announced: Vec<Vec<Value>> = vec![Vec::new(); 3];
    let mut second: Option<Value> = None;
    let started = Instant::now();
    let until_t = started + Duration::from_millis(1500);
    while Instant::now() < until_t {
        if second.is_none() && started.elapsed() > Duration::from_millis(300) {
            let (st, v) = admin(
                &c,
                &rs[0],
                Method::POST,
                "/v1/scenes/bay/impacts",
                Some(json!({"position": [-3.0, 1.0], "strength": 0.5, "radius": 1.0})),
            )
            .await;
            assert_eq!(st, 202, "{v}");
            assert!(v["body_tick"].is_i64(), "{v}");
            second = Some(v);
        }
        for (i, ws) in socks.iter_mut().enumerate() {
            use futures_util::StreamExt as _;
            if let Ok(Some(Ok(tokio_tungstenite::tungstenite::Message::Text(t)))) =
                tokio::time::timeout(Duration::from_millis(20), ws.next()).await
            {
                let v: Value = serde_json::from_str(&t).unwrap();
                if v["type"] == "tick" {
                    frames[i].insert(v["tick"].as_i64().unwrap(), v["bodies"].to_string());
                    announced[i].extend(v["impacts"].as_array().into_iter().flatten().cloned());
                }
            }
        }
    }
    let second = second.expect("the second impact");
    for (i, got) in announced.iter().enumerate() {
        let carried: Vec<&Value> = got.iter().filter(|e| e["t"] == second["t"]).collect();
        assert_eq!(carried.len(), 1, "replica {i}'s frames carried {got:?}");
        assert_eq!(carried[0]["body_tick"], second["body_tick"], "replica {i}");
    }
    let common: Vec<i64> = frames[0]
        .keys()
        .filter(|k| frames[1].contains_key(k) && frames[2].contains_key(k))
        .copied()
        .collect();
    let same = common
        .iter()
        .filter(|k| frames[0][k] == frames[1][k] && frames[1][k] == frames[2][k])
        .count();
    eprintln!(
        "tick frames: {} ticks seen by all three, {same} identical",
        common.len()
    );
    assert!(common.len() >= 10, "{} common ticks", common.len());
    // A frame's tick is the tick of its states (a late tick is skipped, never filled with older
    // states), so every tick all three sent is identical...
    assert_eq!(
        same,
        common.len(),
        "{same} of {} frames identical",
        common.len()
    );
    // ... and every frame of every replica is the single-process replay at its tick.
    let newest = frames
        .iter()
        .filter_map(|f| f.keys().next_back().copied())
        .max()
        .unwrap();
    let reference = replay::replay(&rec.until_watermark(newest).await, &served);
    for (i, f) in frames.iter().enumerate() {
        for (tick, text) in f {
            let bodies: Value = serde_json::from_str(text).unwrap();
            replay::assert_replayed(&reference, *tick, &bodies, &format!("replica {i}'s frame"));
        }
    }
    drop(socks);

    // Paused: every replica settles at the same tick with the same bits.
    let (st, _) = admin(
        &c,
        &rs[2],
        Method::PUT,
        "/v1/scenes/bay/clock",
        Some(json!({"paused": true})),
    )
    .await;
    assert_eq!(st, 200);
    let refs: Vec<&Replica> = rs.iter().collect();
    let (tick, texts) = settled_bodies(&c, &refs, "bay").await;
    assert!(
        texts.iter().all(|t| t == &texts[0]),
        "states differ at tick {tick}:\n{texts:#?}"
    );
    let reference = replay::replay(&rec.until_watermark(tick).await, &served);
    replay::assert_replayed(
        &reference,
        tick,
        &serde_json::from_str(&texts[0]).unwrap(),
        "paused replicas",
    );
    let (st, _) = admin(
        &c,
        &rs[2],
        Method::PUT,
        "/v1/scenes/bay/clock",
        Some(json!({"paused": false})),
    )
    .await;
    assert_eq!(st, 200);

    // kill -9 the sequencer while inputs keep coming through a survivor and queries through
    // the others; another replica takes the lease, nothing acknowledged is lost, no divergence.
    let seq = sequencer_of(&c, &rs, "bay").await.expect("a sequencer");
    let survivors: Vec<usize> = (0..3).filter(|i| *i != seq).collect();
    let via = survivors[0];
    let killed_at = Instant::now();
    rs[seq].proc.take().unwrap().kill9();
    let mut acked = 0;
    let mut refused = 0;
    let mut taken: Option<Duration> = None;
    // Each input has its own force, so the log shows which ones are in it: (force, apply tick).
    let mut acknowledged: Vec<(f64, i64)> = Vec::new();
    while killed_at.elapsed() < Duration::from_secs(4) {
        let force = 20000.0 + acknowledged.len() as f64;
        let (st, v) = admin(
            &c,
            &rs[via],
            Method::POST,
            "/v1/scenes/bay/bodies/1/input",
            Some(json!({"force": [0, 0, force], "ticks": 5})),
        )
        .await;
        if st == 202 {
            acked += 1;
            acknowledged.push((force, v["tick"].as_i64().unwrap()));
        } else {
            refused += 1
        }
        if taken.is_none() && sequencer_of(&c, &rs, "bay").await.is_some() {
            taken = Some(killed_at.elapsed());
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let taken = taken.expect("a survivor took the lease within 4 s");
    eprintln!(
        "failover: lease taken {taken:?} after kill -9; inputs acknowledged {acked}, refused {refused}"
    );
    assert!(
        taken < Duration::from_millis(2500),
        "failover took {taken:?}"
    );
    assert_eq!(
        refused, 0,
        "inputs are acknowledged by Redis, not by the sequencer"
    );
    let (st, _) = admin(
        &c,
        &rs[via],
        Method::PUT,
        "/v1/scenes/bay/clock",
        Some(json!({"paused": true})),
    )
    .await;
    assert_eq!(st, 200);
    let refs: Vec<&Replica> = survivors.iter().map(|i| &rs[*i]).collect();
    let (tick, texts) = settled_bodies(&c, &refs, "bay").await;
    assert!(
        texts.iter().all(|t| t == &texts[0]),
        "survivors differ at tick {tick}:\n{texts:#?}"
    );
    // The survivors equal the uninterrupted single-process replay, and every acknowledged input
    // is in the log at the tick its answer gave.
    let entries = rec.until_watermark(tick).await;
    replay::replay_has_inputs(&entries, &acknowledged);
    let reference = replay::replay(&entries, &served);
    replay::assert_replayed(
        &reference,
        tick,
        &serde_json::from_str(&texts[0]).unwrap(),
        "survivors after the failover",
    );
    // A replica started now rebuilds the same world from Redis (snapshot + log).
    let late = Replica::spawn(&redis.url(), &["--snapshot-interval", "1"]);
    late.wait_ready(&c).await;
    until(
        &c,
        &late,
        "/v1/scenes/bay/bodies",
        Instant::now(),
        |st, v| st == 200 && v["bodies"].as_array().is_some_and(|b| b.len() == 2),
    )
    .await;
    assert!(
        late.log().contains("bodies from a snapshot"),
        "the late replica did not start from a snapshot:\n{}",
        late.log()
    );
    // Compaction: the log holds about two snapshot intervals, not the whole run (~7 s of
    // watermarks at 20 Hz plus ~80 commands were appended).
    let len: i64 = procs::redis_line(redis.port, "XLEN swell:bodies:bay:log")
        .and_then(|l| l.trim_start_matches(':').parse().ok())
        .expect("XLEN");
    eprintln!("body log length after compaction: {len}");
    assert!(len < 120, "the body log was not compacted: {len} entries");
    let mut refs = refs;
    refs.push(&late);
    let (tick2, texts) = settled_bodies(&c, &refs, "bay").await;
    assert_eq!(tick2, tick);
    assert!(
        texts.iter().all(|t| t == &texts[0]),
        "the late replica differs at tick {tick}:\n{texts:#?}"
    );
}

/// `swell-load`, built beside this test by `cargo test --workspace` (the CI command).
fn swell_load() -> std::path::PathBuf {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().and_then(|d| d.parent()).unwrap();
    let p = dir.join("swell-load");
    assert!(
        p.is_file(),
        "{} is missing: `cargo test --workspace` builds it (or `cargo build --profile test -p swell-load`)",
        p.display()
    );
    p
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn kill_9_of_the_sequencer_during_a_swell_load_mixed_run_through_nginx() {
    let _serial = SERIAL.lock().await;
    let load = swell_load();
    let redis = Redis::start();
    let c = client();
    let mut rs: Vec<Replica> = (0..3)
        .map(|_| Replica::spawn(&redis.url(), &["--snapshot-interval", "1"]))
        .collect();
    for r in &rs {
        r.wait_ready(&c).await;
    }
    let ports: Vec<u16> = rs.iter().map(|r| r.port).collect();
    let nginx = procs::Nginx::start(&ports, &c).await;
    let (st, v) = admin(&c, &rs[0], Method::PUT, "/v1/scenes/bay", Some(spec(0.5))).await;
    assert_eq!(st, 201, "{v}");
    let served = v["spec"].clone();
    let rec = replay::Recorder::start(&redis.url(), "bay").await;
    for r in &rs[1..] {
        until(&c, r, "/v1/scenes/bay", Instant::now(), |st, _| st == 200).await;
    }
    for x in [0.0, 15.0, 30.0] {
        let body = json!({"mass": 2000, "hull": {"kind": "box", "length": 6, "beam": 2.5, "height": 1.2},
            "position": [x, 0.5, 0.0]});
        let (st, v) = admin(
            &c,
            &rs[1],
            Method::POST,
            "/v1/scenes/bay/bodies",
            Some(body),
        )
        .await;
        assert_eq!(st, 201, "{v}");
    }
    for r in &rs {
        until(&c, r, "/v1/scenes/bay/bodies", Instant::now(), |st, v| {
            st == 200 && v["bodies"].as_array().is_some_and(|b| b.len() == 3)
        })
        .await;
    }
    // Body inputs through nginx for the whole run (one every ~40 ms, each with its own force,
    // timed so a failure can be placed against the kill).
    let driver = {
        let (c, base) = (c.clone(), nginx.base.clone());
        tokio::spawn(async move {
            let mut sent: Vec<(Instant, u16, f64, Option<i64>)> = Vec::new();
            let start = Instant::now();
            while start.elapsed() < Duration::from_millis(4800) {
                let k = sent.len();
                let force = 30000.0 + k as f64;
                let at = Instant::now();
                let r = c
                    .post(format!("{base}/v1/scenes/bay/bodies/{}/input", k % 3))
                    .bearer_auth(TOKEN)
                    .json(&json!({"force": [0, 0, force], "ticks": 3}))
                    .send()
                    .await;
                let (st, tick) = match r {
                    Ok(r) => {
                        let st = r.status().as_u16();
                        let v: Value = r.json().await.unwrap_or(Value::Null);
                        (st, v["tick"].as_i64())
                    }
                    Err(_) => (0, None),
                };
                sent.push((at, st, force, tick));
                tokio::time::sleep(Duration::from_millis(40)).await;
            }
            sent
        })
    };
    // 5 s of `mixed` (90% height, 9% samples, 1% orientation at 200 req/s, open loop) and 3
    // tick subscribers, all through nginx; the sequencer is killed 1.5 s in.
    let load_started = Instant::now();
    let run = std::process::Command::new(&load)
        .args([
            "mixed",
            "--url",
            &nginx.base,
            "--scene",
            "bay",
            "--rate",
            "200",
        ])
        .args([
            "--duration",
            "5s",
            "--warmup",
            "0s",
            "--subscribers",
            "3",
            "--timeout",
            "3s",
            "--json",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("swell-load starts");
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let seq = sequencer_of(&c, &rs, "bay").await.expect("a sequencer");
    let killed_at = Instant::now();
    rs[seq].proc.take().unwrap().kill9();
    let mut taken = None;
    while taken.is_none() && killed_at.elapsed() < Duration::from_secs(5) {
        if sequencer_of(&c, &rs, "bay").await.is_some() {
            taken = Some(killed_at.elapsed());
        }
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
    let out = tokio::task::spawn_blocking(move || run.wait_with_output())
        .await
        .unwrap()
        .unwrap();
    let report: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "swell-load report ({e}): {}\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )
    });
    let req = &report["requests"];
    let (ok, errors) = (req["ok"].as_u64().unwrap(), req["errors"].as_u64().unwrap());
    let inputs = driver.await.unwrap();
    eprintln!(
        "chaos: sequencer (replica {seq}) killed; lease taken after {taken:?}; swell-load mixed through nginx: {ok} ok, {errors} failed {}; stream: {} frames, {} gaps, disconnects {}",
        req["errors_by_kind"],
        report["stream"]["frames"],
        report["stream"]["gaps"],
        report["stream"]["disconnects"]
    );
    assert!(
        out.status.success(),
        "swell-load did not complete: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let taken = taken.expect("a survivor took the lease");
    assert!(
        taken < Duration::from_millis(2500),
        "failover took {taken:?}"
    );
    assert!(ok >= 900, "{ok} answered of ~1000");
    // Errors only from requests that were in flight on the killed replica (nginx retries GETs
    // on another upstream, not POSTs)...
    assert!(errors <= 20, "{errors} failed requests");
    // ... so only from the second of the kill to that of the lease's move (swell-load counts
    // failures by the second they were due; its window starts a few ms after `load_started`).
    let by_second: Vec<u64> = req["errors_per_second"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_u64().unwrap())
        .collect();
    let kill_s = killed_at.duration_since(load_started).as_secs_f64();
    let window = (kill_s - 0.5).floor()..=(kill_s + taken.as_secs_f64()).floor();
    eprintln!(
        "chaos: swell-load errors by second {by_second:?}; kill at {kill_s:.2} s; failover window {window:?} s"
    );
    for (second, n) in by_second.iter().enumerate() {
        assert!(
            *n == 0 || window.contains(&(second as f64)),
            "{n} swell-load errors in second {second}, outside the failover window {window:?}"
        );
    }
    // The body inputs: acknowledged ones carry their apply tick; failures only around the kill.
    let rel = |at: Instant| {
        if at >= killed_at {
            at.duration_since(killed_at).as_secs_f64()
        } else {
            -killed_at.duration_since(at).as_secs_f64()
        }
    };
    let acknowledged: Vec<(f64, i64)> = inputs
        .iter()
        .filter(|i| i.1 == 202)
        .map(|i| (i.2, i.3.expect("a 202 names its apply tick")))
        .collect();
    let failed: Vec<(f64, u16)> = inputs
        .iter()
        .filter(|i| i.1 != 202)
        .map(|i| (rel(i.0), i.1))
        .collect();
    eprintln!(
        "chaos: body inputs through nginx: {} acknowledged, {} failed (seconds after the kill, status): {failed:?}",
        acknowledged.len(),
        failed.len()
    );
    assert!(
        acknowledged.len() >= 40,
        "only {} inputs acknowledged",
        acknowledged.len()
    );
    for (at, st) in &failed {
        assert!(
            (-0.5..=taken.as_secs_f64() + 0.5).contains(at),
            "an input failed ({st}) {at:.2} s after the kill, outside the failover window"
        );
    }
    // The survivors carry on identically.
    let survivors: Vec<&Replica> = rs.iter().filter(|r| r.proc.is_some()).collect();
    let (st, _) = admin(
        &c,
        survivors[0],
        Method::PUT,
        "/v1/scenes/bay/clock",
        Some(json!({"paused": true})),
    )
    .await;
    assert_eq!(st, 200);
    let (tick, texts) = settled_bodies(&c, &survivors, "bay").await;
    assert!(
        texts.iter().all(|t| t == &texts[0]),
        "survivors differ at tick {tick}:\n{texts:#?}"
    );
    let n = serde_json::from_str::<Value>(&texts[0])
        .unwrap()
        .as_array()
        .unwrap()
        .len();
    assert_eq!(n, 3);
    // ... equal to the uninterrupted single-process replay of the log, which holds every
    // acknowledged input at the tick its answer gave.
    let entries = rec.until_watermark(tick).await;
    replay::replay_has_inputs(&entries, &acknowledged);
    let reference = replay::replay(&entries, &served);
    replay::assert_replayed(
        &reference,
        tick,
        &serde_json::from_str(&texts[0]).unwrap(),
        "survivors of the chaos run",
    );
}

/// The scenes a replica says it sequences (`/readyz`).
async fn sequencing(c: &Client, r: &Replica) -> Vec<String> {
    let (_, v) = get(c, r, "/readyz").await;
    v["store"]["sequencing"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|s| s.as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default()
}

/// Waits (at most `limit`) until `r`'s log contains `needle`.
async fn until_logged(r: &Replica, needle: &str, limit: Duration) {
    let start = Instant::now();
    while !r.log().contains(needle) {
        assert!(
            start.elapsed() < limit,
            "replica :{} never logged {needle:?}:\n{}",
            r.port,
            r.log()
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// The snapshot write is fenced in Redis: a holder of an old token writes nothing, neither the
/// snapshot nor the trim (they used to be plain SET and XTRIM behind the replica's own belief
/// that it held the lease, so a sequencer paused past its lease could overwrite the new
/// holder's snapshot with an older one when it resumed).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_body_snapshot_under_an_old_fencing_token_writes_nothing() {
    use redis::AsyncCommands as _;
    use swell::store::bodies::write_snapshot;
    use swell::store::fleet::EntryId;
    let _serial = SERIAL.lock().await;
    let redis = Redis::start();
    let mut conn = replay::connect(&redis.url()).await;
    let log = "swell:bodies:cove:log";
    let mut ids = Vec::new();
    for w in 0..5 {
        let id: String = conn.xadd(log, "*", &[("wm", w)]).await.unwrap();
        ids.push(EntryId::parse(&id).unwrap());
    }
    let _: () = conn.set("swell:bodies:cove:lease", "8").await.unwrap();
    let xlen = |mut conn: redis::aio::MultiplexedConnection| async move {
        conn.xlen::<_, usize>(log).await.unwrap()
    };

    // Token 7 (deposed): refused, nothing written, nothing trimmed.
    let wrote = write_snapshot(&mut conn, "cove", 7, r#"{"old":true}"#, Some(ids[3]))
        .await
        .unwrap();
    assert!(!wrote);
    assert_eq!(
        replay::get(&redis.url(), "swell:bodies:cove:snap").await,
        None
    );
    assert_eq!(xlen(conn.clone()).await, 5);
    // No lease at all (expired, nobody took it yet): refused too.
    let _: () = conn.del("swell:bodies:cove:lease").await.unwrap();
    assert!(
        !write_snapshot(&mut conn, "cove", 8, "{}", Some(ids[3]))
            .await
            .unwrap()
    );
    assert_eq!(xlen(conn.clone()).await, 5);

    // Token 8 (the holder): written, and the log trimmed to the entry named (it stays).
    let _: () = conn.set("swell:bodies:cove:lease", "8").await.unwrap();
    let wrote = write_snapshot(&mut conn, "cove", 8, r#"{"new":true}"#, Some(ids[3]))
        .await
        .unwrap();
    assert!(wrote);
    assert_eq!(
        replay::get(&redis.url(), "swell:bodies:cove:snap")
            .await
            .as_deref(),
        Some(r#"{"new":true}"#)
    );
    assert_eq!(xlen(conn.clone()).await, 2);
    // Without a trim point only the snapshot is written.
    assert!(
        write_snapshot(&mut conn, "cove", 8, r#"{"newer":true}"#, None)
            .await
            .unwrap()
    );
    assert_eq!(xlen(conn).await, 2);
}

/// Followers and sequencers that stop and resume, issue 12's audit:
/// - a follower stopped (SIGSTOP) for longer than two snapshot intervals finds the log trimmed
///   past its last read and reloads from the snapshot (it used to read on from whatever the
///   stream still held, silently skipping the trimmed commands and watermarks);
/// - a sequencer stopped past its lease and resumed learns from Redis that it was deposed and
///   writes nothing under its old token (no watermark, and the snapshot in Redis stays the new
///   holder's);
/// - through both, every replica stays equal to the single-process replay of the log.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stopped_follower_reloads_past_a_trim_and_a_deposed_sequencer_cannot_write() {
    let _serial = SERIAL.lock().await;
    let redis = Redis::start();
    let c = client();
    let rs: Vec<Replica> = (0..3)
        .map(|_| Replica::spawn(&redis.url(), &["--snapshot-interval", "1"]))
        .collect();
    for r in &rs {
        r.wait_ready(&c).await;
    }
    let (st, v) = admin(&c, &rs[0], Method::PUT, "/v1/scenes/cove", Some(spec(0.5))).await;
    assert_eq!(st, 201, "{v}");
    let served = v["spec"].clone();
    let rec = replay::Recorder::start(&redis.url(), "cove").await;
    for r in &rs[1..] {
        until(&c, r, "/v1/scenes/cove", Instant::now(), |st, _| st == 200).await;
    }
    for x in [0.0, 20.0] {
        let body = json!({"mass": 3000, "hull": {"kind": "box", "length": 8, "beam": 3, "height": 1.5},
            "position": [x, 1.0, 0.0]});
        let (st, v) = admin(
            &c,
            &rs[0],
            Method::POST,
            "/v1/scenes/cove/bodies",
            Some(body),
        )
        .await;
        assert_eq!(st, 201, "{v}");
    }
    for r in &rs {
        until(&c, r, "/v1/scenes/cove/bodies", Instant::now(), |st, v| {
            st == 200 && v["bodies"].as_array().is_some_and(|b| b.len() == 2)
        })
        .await;
    }
    let seq = sequencer_of(&c, &rs, "cove").await.expect("a sequencer");
    let others: Vec<usize> = (0..3).filter(|i| *i != seq).collect();
    let (follower, via) = (others[0], others[1]);
    let mut k = 0u32;
    let mut input = |r: usize| {
        k += 1;
        let c = c.clone();
        let url = rs[r].url(&format!("/v1/scenes/cove/bodies/{}/input", k % 2));
        async move {
            let resp = c
                .post(url)
                .bearer_auth(TOKEN)
                .json(&json!({"force": [10000.0 + f64::from(k), 0, 0], "ticks": 4}))
                .send()
                .await
                .unwrap();
            assert_eq!(resp.status(), 202, "{}", resp.text().await.unwrap());
        }
    };

    // 1. A follower stopped for 3.5 s while inputs go through another replica: snapshots every
    // second trim the log one snapshot behind, so the entries after its last read are gone.
    rs[follower].proc.as_ref().unwrap().signal("STOP");
    let stopped = Instant::now();
    while stopped.elapsed() < Duration::from_millis(3500) {
        input(via).await;
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    rs[follower].proc.as_ref().unwrap().signal("CONT");
    until_logged(
        &rs[follower],
        "trimmed past this replica's last read",
        Duration::from_secs(10),
    )
    .await;

    // 2. The sequencer stopped past its lease (1.5 s): another replica takes it with a higher
    // token, snapshots and trims under it; then the old one resumes.
    let token = |v: Option<String>| v.and_then(|t| t.parse::<u64>().ok());
    let old = token(replay::get(&redis.url(), "swell:bodies:cove:lease").await)
        .expect("the lease holds a token");
    rs[seq].proc.as_ref().unwrap().signal("STOP");
    let t0 = Instant::now();
    loop {
        let mut holder = None;
        for i in &others {
            if sequencing(&c, &rs[*i]).await.iter().any(|s| s == "cove") {
                holder = Some(*i);
            }
        }
        if holder.is_some() {
            eprintln!("lease moved {:?} after SIGSTOP", t0.elapsed());
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "nobody took the lease"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let new = token(replay::get(&redis.url(), "swell:bodies:cove:lease").await).unwrap();
    assert!(new > old, "new token {new}, old {old}");
    let t1 = Instant::now();
    while t1.elapsed() < Duration::from_millis(1500) {
        input(via).await;
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    rs[seq].proc.as_ref().unwrap().signal("CONT");
    // It learns it was deposed (a renewal, watermark or snapshot refused by Redis, or a renewal
    // that could not be made in time) and stops sequencing.
    let start = Instant::now();
    while !["newer holder", "gave up the body lease"]
        .iter()
        .any(|n| rs[seq].log().contains(n))
    {
        assert!(
            start.elapsed() < Duration::from_secs(5),
            "the resumed sequencer never noticed it was deposed:\n{}",
            rs[seq].log()
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    until(&c, &rs[seq], "/readyz", Instant::now(), |st, v| {
        st == 200
            && v["store"]["sequencing"]
                .as_array()
                .is_some_and(|a| !a.iter().any(|s| s == "cove"))
    })
    .await;
    // Give its tasks time to try anything they still had in hand, inputs going on.
    let t2 = Instant::now();
    while t2.elapsed() < Duration::from_millis(1500) {
        input(seq).await;
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    // Nothing was written under the old token after the new one's first watermark, and the
    // snapshot in Redis is a holder's of the new token (or a later one).
    let snap: Value = serde_json::from_str(
        &replay::get(&redis.url(), "swell:bodies:cove:snap")
            .await
            .unwrap(),
    )
    .unwrap();
    let snap_token = snap["token"]
        .as_u64()
        .expect("the snapshot names its token");
    assert!(
        snap_token >= new,
        "snapshot token {snap_token}, lease token {new}"
    );
    let entries = rec.entries();
    let first_new = entries
        .iter()
        .position(|e| e.fence() == Some(new))
        .expect("watermarks under the new token");
    let stale = entries[first_new..]
        .iter()
        .filter(|e| e.fence() == Some(old))
        .count();
    assert_eq!(
        stale, 0,
        "{stale} watermarks under the old token after the new holder's first"
    );

    // Every replica, the resumed ones included, equals the others and the replay.
    let (st, _) = admin(
        &c,
        &rs[via],
        Method::PUT,
        "/v1/scenes/cove/clock",
        Some(json!({"paused": true})),
    )
    .await;
    assert_eq!(st, 200);
    let refs: Vec<&Replica> = rs.iter().collect();
    let (tick, texts) = settled_bodies(&c, &refs, "cove").await;
    assert!(
        texts.iter().all(|t| t == &texts[0]),
        "replicas differ at tick {tick}:\n{texts:#?}"
    );
    let reference = replay::replay(&rec.until_watermark(tick).await, &served);
    replay::assert_replayed(
        &reference,
        tick,
        &serde_json::from_str(&texts[0]).unwrap(),
        "replicas after a stopped follower and a deposed sequencer",
    );
    eprintln!(
        "stop/resume: {} log entries recorded, {k} inputs, settled at tick {tick}, old token {old}, new {new}, snapshot token {snap_token}",
        entries.len()
    );
}
