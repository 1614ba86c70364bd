//! Every endpoint answers, over a real socket.

use crate::common;

use common::{TOKEN, TestServer, code, config, small_spec};
use reqwest::Method;
use serde_json::json;

#[tokio::test]
async fn lists_builtin_scenes() {
    let s = TestServer::start(config()).await;
    let (st, v) = s.get_json("/v1/scenes").await;
    assert_eq!(st, 200);
    let ids: Vec<&str> = v["scenes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["calm", "harbour", "lake", "open-sea", "storm"]);
    let open_sea = &v["scenes"][3];
    assert_eq!(open_sea["layers"], json!(["fft", "gerstner"]));
    assert_eq!(open_sea["tick_hz"], json!(30.0));
    s.stop().await;
}

#[tokio::test]
async fn scene_detail_has_spec_derived_version_and_hash() {
    let s = TestServer::start(config()).await;
    let (st, v) = s.get_json("/v1/scenes/lake").await;
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["id"], "lake");
    assert_eq!(v["model_version"], json!(swell_waves::MODEL_VERSION));
    assert_eq!(v["spec_hash"].as_str().unwrap().len(), 16);
    assert_eq!(v["spec"]["layers"][0]["kind"], "gerstner");
    let layer = &v["derived"]["layers"][0];
    assert_eq!(layer["kind"], "gerstner");
    // One explicit wave plus a 4×4 cascade, each with k, ω, direction, phase, steepness.
    let waves = layer["waves"].as_array().unwrap();
    assert_eq!(waves.len(), 17);
    for w in waves {
        for f in ["amplitude", "wavenumber", "omega", "phase", "steepness"] {
            assert!(w[f].is_number(), "{f} in {w}");
        }
        assert_eq!(w["direction"].as_array().unwrap().len(), 2);
    }
    assert!(layer["fold_number"].as_f64().unwrap() < 1.0);
    let (_, fft) = s.get_json("/v1/scenes/open-sea").await;
    let f = &fft["derived"]["layers"][0];
    assert_eq!(f["kind"], "fft");
    assert_eq!(f["resolution"], json!(256));
    assert_eq!(f["backend"], "portable");
    assert!(f["seed"].is_u64());
    assert!(f["rng"].as_str().unwrap().starts_with("pcg32-splitmix64"));
    let c = &v["clock"];
    assert!(c["t"].is_number() && c["tick"].is_i64() && c["paused"] == json!(false));
    s.stop().await;
}

#[tokio::test]
async fn height_sample_and_orientation_answer() {
    let s = TestServer::start(config()).await;
    let (st, v) = s.get_json("/v1/scenes/calm/height?x=1.5&z=-2&t=10").await;
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["t"], json!(10.0));
    assert!(v["height"].as_f64().unwrap().abs() < 0.3);

    // Without t: the clock's now, returned.
    let (st, v) = s.get_json("/v1/scenes/calm/height?x=0&z=0").await;
    assert_eq!(st, 200);
    assert!(v["t"].as_f64().unwrap() >= 0.0);

    let (st, v) = s
        .post_json(
            "/v1/scenes/open-sea/sample",
            &json!({"t": 4.0, "points": [[0, 0], [10.5, -3.25], [100, 200]],
                    "fields": ["height", "normal", "displacement", "jacobian", "residual"]}),
        )
        .await;
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["height"].as_array().unwrap().len(), 3);
    for n in v["normal"].as_array().unwrap() {
        let n: Vec<f64> = n
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((len - 1.0).abs() < 1e-9 && n[1] > 0.0);
    }
    assert_eq!(v["displacement"][0].as_array().unwrap().len(), 3);
    assert_eq!(v["folded"].as_array().unwrap().len(), 3);
    assert!(v["residual"][1].as_f64().unwrap() < 1e-3);

    // Default: height only.
    let (_, v) = s
        .post_json(
            "/v1/scenes/lake/sample",
            &json!({"t": 1, "points": [[1, 2]]}),
        )
        .await;
    let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
    assert_eq!(keys, ["height", "t"]);

    // precision f32 runs the single-precision fast path: close to the f64 answer, not equal.
    let ask = |precision: &'static str| {
        json!({"t": 9.5, "points": [[1, 2], [-33.5, 80.25], [400, -12]], "fields": ["height", "normal"],
            "accuracy": {"precision": precision}})
    };
    let (st64, a) = s.post_json("/v1/scenes/lake/sample", &ask("f64")).await;
    let (st32, b) = s.post_json("/v1/scenes/lake/sample", &ask("f32")).await;
    assert_eq!((st64, st32), (200, 200), "{a} {b}");
    let (_, d) = s
        .post_json(
            "/v1/scenes/lake/sample",
            &json!({"t": 9.5, "points": [[1, 2], [-33.5, 80.25], [400, -12]], "fields": ["height", "normal"]}),
        )
        .await;
    assert_eq!(a, d, "f64 is the default");
    let mut differs = false;
    for i in 0..3 {
        let (h64, h32) = (
            a["height"][i].as_f64().unwrap(),
            b["height"][i].as_f64().unwrap(),
        );
        assert!((h64 - h32).abs() < 1e-4, "f32 height {h32} vs f64 {h64}");
        differs |= h64 != h32;
    }
    assert!(differs, "precision f32 did not reach the model");

    // Accuracy settings are accepted.
    let (st, _) = s
        .post_json(
            "/v1/scenes/storm/sample",
            &json!({"t": 1, "points": [[1, 2]], "accuracy":
                {"method": "fixed_point", "iterations": 4, "tolerance": 1e-4, "filter": "bilinear"}}),
        )
        .await;
    assert_eq!(st, 200);

    let (st, v) = s
        .post_json(
            "/v1/scenes/lake/orientation",
            &json!({"t": 3, "bodies": [
                {"position": [5, 5], "yaw": 0.3, "length": 12, "beam": 4},
                {"position": [-20, 7], "length": 3, "beam": 2, "probes": [[1, 0], [-1, 0], [0, 1]]}
            ]}),
        )
        .await;
    assert_eq!(st, 200, "{v}");
    let b = &v["bodies"][0];
    assert_eq!(b["rotation"].as_array().unwrap().len(), 4);
    assert_eq!(b["normal"].as_array().unwrap().len(), 3);
    assert!(b["heave"].is_number() && b["pitch"].is_number() && b["roll"].is_number());
    assert_eq!(v["bodies"].as_array().unwrap().len(), 2);
    s.stop().await;
}

#[tokio::test]
async fn admin_put_replace_delete() {
    let s = TestServer::start(config()).await;
    let (st, v) = s.put_scene("marina", &small_spec()).await;
    assert_eq!(st, 201, "{v}");
    assert_eq!(v["id"], "marina");
    assert_eq!(v["spec"]["tick_hz"], json!(20.0));
    let hash1 = v["spec_hash"].clone();
    let (st, v) = s.get_json("/v1/scenes/marina/height?x=1&z=1&t=0").await;
    assert_eq!(st, 200, "{v}");

    let mut spec2 = small_spec();
    spec2["seed"] = json!(4);
    let (st, v) = s.put_scene("marina", &spec2).await;
    assert_eq!(st, 200, "replace answers 200: {v}");
    assert_ne!(v["spec_hash"], hash1);

    // Same spec, same hash (stable canonical JSON).
    let (_, v) = s.put_scene("marina", &spec2).await;
    let (_, again) = s.get_json("/v1/scenes/marina").await;
    assert_eq!(v["spec_hash"], again["spec_hash"]);

    let (st, _) = s
        .admin(Method::DELETE, "/v1/scenes/marina", None, Some(TOKEN))
        .await;
    assert_eq!(st, 204);
    let (st, v) = s.get_json("/v1/scenes/marina").await;
    assert_eq!((st, code(&v)), (404, "not_found"));
    let (st, v) = s
        .admin(Method::DELETE, "/v1/scenes/marina", None, Some(TOKEN))
        .await;
    assert_eq!((st, code(&v)), (404, "not_found"));
    s.stop().await;
}

#[tokio::test]
async fn ops_endpoints() {
    let s = TestServer::start(config()).await;
    let (st, v) = s.get_json("/healthz").await;
    assert_eq!((st, v["status"].as_str()), (200, Some("ok")));
    let (st, v) = s.get_json("/readyz").await;
    assert_eq!((st, v["status"].as_str()), (200, Some("ready")));

    // Make some traffic, including an FFT frame, then read the metrics.
    s.post_json(
        "/v1/scenes/open-sea/sample",
        &json!({"t": 12.0, "points": [[1, 1], [2, 2]]}),
    )
    .await;
    let text = s.get("/metrics").await.text().await.unwrap();
    for name in [
        "swell_http_requests_total",
        "swell_http_request_duration_seconds_bucket",
        "swell_points_sampled_total",
        "swell_fft_frames_total",
        "swell_fft_frame_seconds",
        // Counters of rare events are there (at 0) before the first one.
        "swell_ws_slow_consumer_disconnects_total",
        "swell_ws_read_check_disconnects_total",
        "swell_ws_ticks_skipped_total",
        "swell_http_send_stalls_total",
    ] {
        assert!(text.contains(name), "{name} missing from /metrics:\n{text}");
    }
    assert!(text.contains(r#"route="/v1/scenes/{id}/sample""#));
    // The sample at t = 12 s, far from open-sea's now, computed its own frames.
    assert!(
        text.contains(r#"swell_fft_frames_total{by="query_far"}"#),
        "{text}"
    );

    let (st, doc) = s.get_json("/openapi.json").await;
    assert_eq!(st, 200);
    assert_eq!(doc["openapi"], "3.1.0");
    for (method, path, _) in swell::api::ops::ROUTES {
        assert!(
            doc["paths"][*path][*method].is_object(),
            "{method} {path} missing"
        );
    }
    let r = s.get("/docs").await;
    assert_eq!(r.status(), 200);
    let html = r.text().await.unwrap();
    assert!(html.contains("/openapi.json") && !html.contains("https://"));
    s.stop().await;
}

/// Every route in `ROUTES` is served (no 404 "no such endpoint"), so the docs cannot list a
/// route the router lacks.
#[tokio::test]
async fn documented_routes_exist() {
    let s = TestServer::start(config()).await;
    for (method, path, _) in swell::api::ops::ROUTES {
        let url = s.url(&path.replace("{id}", "calm"));
        let m = Method::from_bytes(method.to_uppercase().as_bytes()).unwrap();
        let r = s.client.request(m, url).send().await.unwrap();
        let status = r.status().as_u16();
        let body = r.text().await.unwrap();
        assert!(
            !(status == 404 && body.contains("no such endpoint")) && status != 405,
            "{method} {path}: {status} {body}"
        );
    }
    s.stop().await;
}

/// The viewer's page on a scene is 200; on an unknown scene the page still comes (it shows the
/// miss and offers the picker) with status 404; any missing asset is 404 `not_found`.
#[tokio::test]
async fn viewer_page_and_assets_answer_404_for_what_is_not_there() {
    let s = TestServer::start(config()).await;
    let html = |r: &reqwest::Response| {
        r.headers()[reqwest::header::CONTENT_TYPE]
            .to_str()
            .unwrap()
            .starts_with("text/html")
    };
    let r = s.get("/viewer/lake").await;
    assert_eq!((r.status().as_u16(), html(&r)), (200, true));
    let r = s.get("/viewer/no-such-sea").await;
    assert_eq!((r.status().as_u16(), html(&r)), (404, true));
    assert!(r.text().await.unwrap().contains("<html"));
    for path in [
        "/viewer/assets/nope.js",
        "/viewer/assets/deep/nope.js",
        "/viewer/assets/client/nope.js",
    ] {
        let (st, v) = s.get_json(path).await;
        assert_eq!((st, code(&v)), (404, "not_found"), "{path}: {v}");
    }
    s.stop().await;
}
