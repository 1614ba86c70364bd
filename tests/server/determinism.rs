//! Same scene + same t + same point = same bits, whichever way it is asked and from whichever
//! server: `/height`, `/sample` alone or in a batch, with or without `origin`, and a second server
//! started with the same config.

use crate::common;

use common::{TestServer, bits, config, fft_spec, small_spec};
use serde_json::{Value, json};

/// Points where `origin + local` is exact in f64 (small dyadic fractions), so the world point is
/// the same number whether the client adds the origin or the server does.
const ORIGIN: [f64; 2] = [1024.0, -2048.0];
const LOCAL: [[f64; 2]; 4] = [[0.5, 0.25], [-3.75, 12.125], [100.0, -7.5], [0.0, 0.0]];
const T: f64 = 37.25;

fn world(p: [f64; 2]) -> [f64; 2] {
    [ORIGIN[0] + p[0], ORIGIN[1] + p[1]]
}

async fn heights(s: &TestServer, scene: &str) -> Vec<u64> {
    let mut out = Vec::new();
    for p in LOCAL {
        let w = world(p);
        let (st, v) = s
            .get_json(&format!(
                "/v1/scenes/{scene}/height?x={}&z={}&t={T}",
                w[0], w[1]
            ))
            .await;
        assert_eq!(st, 200, "{v}");
        assert_eq!(bits(&v["t"]), T.to_bits());
        out.push(bits(&v["height"]));
    }
    out
}

fn column(v: &Value, field: &str) -> Vec<u64> {
    v[field].as_array().unwrap().iter().map(bits).collect()
}

async fn check_scene(s: &TestServer, scene: &str) -> Vec<u64> {
    let by_height = heights(s, scene).await;
    let path = format!("/v1/scenes/{scene}/sample");

    // Batch, world coordinates.
    let pts: Vec<[f64; 2]> = LOCAL.iter().map(|&p| world(p)).collect();
    let (st, batch) = s.post_json(&path, &json!({"t": T, "points": pts})).await;
    assert_eq!(st, 200, "{batch}");
    assert_eq!(
        column(&batch, "height"),
        by_height,
        "{scene}: batch vs /height"
    );

    // Batch, origin + local.
    let (_, with_origin) = s
        .post_json(&path, &json!({"t": T, "origin": ORIGIN, "points": LOCAL}))
        .await;
    assert_eq!(column(&with_origin, "height"), by_height, "{scene}: origin");

    // One at a time.
    for (i, p) in LOCAL.iter().enumerate() {
        let (_, one) = s
            .post_json(&path, &json!({"t": T, "origin": ORIGIN, "points": [p]}))
            .await;
        assert_eq!(
            column(&one, "height"),
            vec![by_height[i]],
            "{scene}: single {i}"
        );
    }

    // Asking for more fields does not change the height.
    let (_, all) = s
        .post_json(
            &path,
            &json!({"t": T, "points": pts, "fields": ["height", "normal", "displacement", "jacobian", "residual"]}),
        )
        .await;
    assert_eq!(column(&all, "height"), by_height, "{scene}: all fields");
    by_height
}

#[tokio::test]
async fn every_way_of_asking_gives_the_same_bits() {
    let s = TestServer::start(config()).await;
    for scene in ["calm", "lake", "open-sea", "storm"] {
        check_scene(&s, scene).await;
    }
    s.stop().await;
}

#[tokio::test]
async fn a_second_server_with_the_same_config_gives_the_same_bits() {
    let a = TestServer::start(config()).await;
    let b = TestServer::start(config()).await;
    for (id, spec) in [("g", small_spec()), ("f", fft_spec())] {
        assert_eq!(a.put_scene(id, &spec).await.0, 201);
        assert_eq!(b.put_scene(id, &spec).await.0, 201);
    }
    for scene in ["calm", "lake", "open-sea", "storm", "g", "f"] {
        let ha = check_scene(&a, scene).await;
        let hb = check_scene(&b, scene).await;
        assert_eq!(ha, hb, "{scene}: server A vs server B");
        let (_, da) = a.get_json(&format!("/v1/scenes/{scene}")).await;
        let (_, db) = b.get_json(&format!("/v1/scenes/{scene}")).await;
        assert_eq!(da["spec_hash"], db["spec_hash"]);
        assert_eq!(da["derived"], db["derived"]);
    }
    a.stop().await;
    b.stop().await;
}

/// A number sent in JSON reaches the model exactly: t comes back with the same bits (serde_json
/// `float_roundtrip`), including values whose shortest form has 17 digits.
#[tokio::test]
async fn times_round_trip_exactly() {
    let s = TestServer::start(config()).await;
    for t in [
        0.1f64 + 0.2,
        1.0 / 3.0,
        123_456.789_012_345_67,
        5e-324,
        -0.0,
    ] {
        let (_, v) = s
            .post_json(
                "/v1/scenes/calm/sample",
                &json!({"t": t, "points": [[0, 0]]}),
            )
            .await;
        assert_eq!(bits(&v["t"]), t.to_bits(), "{t}");
    }
    s.stop().await;
}

/// Concurrent requests at one t share one FFT frame and all agree.
#[tokio::test]
async fn concurrent_fft_requests_agree() {
    let s = std::sync::Arc::new(TestServer::start(config()).await);
    let mut tasks = Vec::new();
    for _ in 0..16 {
        let s = s.clone();
        tasks.push(tokio::spawn(async move {
            let (st, v) = s
                .post_json(
                    "/v1/scenes/open-sea/sample",
                    &json!({"t": 99.5, "points": [[3.5, 4.25], [-10, 20]]}),
                )
                .await;
            assert_eq!(st, 200);
            column(&v, "height")
        }));
    }
    let mut first = None;
    for t in tasks {
        let h = t.await.unwrap();
        match &first {
            None => first = Some(h),
            Some(f) => assert_eq!(&h, f),
        }
    }
    if let Ok(s) = std::sync::Arc::try_unwrap(s) {
        s.stop().await;
    }
}
