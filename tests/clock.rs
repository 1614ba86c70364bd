//! Scene clock over HTTP: pause, rate, seek; queries without `t` use the clock.
//! Paused clocks make every assertion exact (no timing flakiness).

mod common;

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
