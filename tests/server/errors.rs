//! Every bad input gets a 4xx with `{"error":{"code","message","field"?}}`, and changes nothing.

use crate::common;

use common::{TOKEN, TestServer, code, config, small_spec};
use reqwest::Method;
use serde_json::{Value, json};

#[tokio::test]
async fn malformed_json_is_400_with_serdes_message() {
    let s = TestServer::start(config()).await;
    let (st, v) = s
        .post_raw("/v1/scenes/calm/sample", "{\"points\": [[1, 2]")
        .await;
    assert_eq!((st, code(&v)), (400, "bad_json"), "{v}");
    assert!(v["error"]["message"].as_str().unwrap().contains("EOF"));
    let (st, v) = s
        .post_raw("/v1/scenes/calm/sample", r#"{"points": [[1, "a"]]}"#)
        .await;
    assert_eq!((st, code(&v)), (400, "bad_json"));
    assert_eq!(v["error"]["field"], "points[0][1]");
    let (st, v) = s
        .post_raw("/v1/scenes/calm/sample", r#"{"points": [[1, 2]]} trailing"#)
        .await;
    assert_eq!((st, code(&v)), (400, "bad_json"));
    let (st, v) = s
        .post_raw("/v1/scenes/calm/sample", r#"{"points": [], "colour": 1}"#)
        .await;
    assert_eq!((st, code(&v)), (400, "bad_json"));
    assert_eq!(v["error"]["field"], "colour");
    s.stop().await;
}

#[tokio::test]
async fn overflowing_and_non_finite_numbers_are_rejected() {
    let s = TestServer::start(config()).await;
    // JSON has no NaN/inf, but 1e999 overflows f64.
    let (st, v) = s
        .post_raw("/v1/scenes/calm/sample", r#"{"points": [[1e999, 0]]}"#)
        .await;
    assert_eq!((st, code(&v)), (400, "bad_json"), "{v}");
    let (st, v) = s
        .post_raw(
            "/v1/scenes/calm/sample",
            r#"{"t": -1e400, "points": [[0, 0]]}"#,
        )
        .await;
    assert_eq!(st, 400, "{v}");
    // Query strings parse "inf"/"NaN"/"1e999" as floats: those must be rejected too.
    for q in ["x=inf&z=0", "x=0&z=NaN", "x=1e999&z=0", "x=0&z=0&t=inf"] {
        let (st, v) = s.get_json(&format!("/v1/scenes/calm/height?{q}")).await;
        assert_eq!((st, code(&v)), (400, "invalid_value"), "{q}: {v}");
        assert!(v["error"]["field"].is_string(), "{q}: {v}");
    }
    let (st, v) = s.get_json("/v1/scenes/calm/height?x=abc&z=0").await;
    assert_eq!(st, 400, "{v}");
    let (st, v) = s.get_json("/v1/scenes/calm/height?x=1").await;
    assert_eq!(st, 400, "missing z: {v}");
    // Coordinates beyond the limit.
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/sample",
            &json!({"points": [[0, 0], [2e9, 0]]}),
        )
        .await;
    assert_eq!(
        (st, v["error"]["field"].as_str()),
        (400, Some("points[1][0]"))
    );
    s.stop().await;
}

#[tokio::test]
async fn unknown_scene_is_404_everywhere() {
    let s = TestServer::start(config()).await;
    for path in [
        "/v1/scenes/nope",
        "/v1/scenes/nope/clock",
        "/v1/scenes/nope/height?x=0&z=0",
        "/v1/scenes/NOT-VALID/height?x=0&z=0",
    ] {
        let (st, v) = s.get_json(path).await;
        assert_eq!((st, code(&v)), (404, "not_found"), "{path}");
    }
    let (st, v) = s
        .post_json("/v1/scenes/nope/sample", &json!({"points": [[0, 0]]}))
        .await;
    assert_eq!((st, code(&v)), (404, "not_found"));
    let (st, v) = s
        .post_json("/v1/scenes/nope/orientation", &json!({"bodies": []}))
        .await;
    assert_eq!((st, code(&v)), (404, "not_found"));
    let (st, v) = s.get_json("/v2/whatever").await;
    assert_eq!((st, code(&v)), (404, "no_such_route"));
    s.stop().await;
}

#[tokio::test]
async fn unknown_field_name_in_fields_is_400_naming_it() {
    let s = TestServer::start(config()).await;
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/sample",
            &json!({"points": [[0, 0]], "fields": ["height", "curl"]}),
        )
        .await;
    assert_eq!((st, code(&v)), (400, "unknown_field"));
    assert_eq!(v["error"]["field"], "fields[1]");
    assert!(v["error"]["message"].as_str().unwrap().contains("curl"));
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/sample",
            &json!({"points": [[0, 0]], "accuracy": {"iterations": 1000}}),
        )
        .await;
    assert_eq!(
        (st, v["error"]["field"].as_str()),
        (400, Some("accuracy.iterations"))
    );
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/sample",
            &json!({"points": [[0, 0]], "accuracy": {"filter": "sinc"}}),
        )
        .await;
    assert_eq!((st, code(&v)), (400, "bad_json"));
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/sample",
            &json!({"points": [[0, 0]], "accuracy": {"precision": "f16"}}),
        )
        .await;
    assert_eq!((st, code(&v)), (400, "bad_json"));
    assert!(
        v["error"]["message"].as_str().unwrap().contains("f16"),
        "{v}"
    );
    s.stop().await;
}

#[tokio::test]
async fn invalid_spec_is_422_with_the_models_message_and_field() {
    let s = TestServer::start(config()).await;
    let mut spec = small_spec();
    spec["layers"][0]["waves"][1]["steepness"] = json!(1.5);
    let (st, v) = s.put_scene("bad", &spec).await;
    assert_eq!((st, code(&v)), (422, "invalid_spec"), "{v}");
    assert_eq!(v["error"]["field"], "layers[0].waves[1].steepness");
    assert!(v["error"]["message"].as_str().unwrap().contains("1.5"));
    // Folding across waves.
    let mut spec = small_spec();
    spec["layers"][0]["waves"][0]["amplitude"] = json!(5.0);
    spec["layers"][0]["waves"][0]["steepness"] = json!(1.0);
    let (st, v) = s.put_scene("bad", &spec).await;
    assert_eq!((st, code(&v)), (422, "invalid_spec"), "{v}");
    // tick_hz.
    let mut spec = small_spec();
    spec["tick_hz"] = json!(0);
    let (st, v) = s.put_scene("bad", &spec).await;
    assert_eq!((st, v["error"]["field"].as_str()), (422, Some("tick_hz")));
    // Unknown fields at the top and deep inside, named.
    let mut spec = small_spec();
    spec["gravty"] = json!(9.8);
    let (st, v) = s.put_scene("bad", &spec).await;
    assert_eq!((st, code(&v)), (400, "bad_json"));
    assert_eq!(v["error"]["field"], "gravty", "{v}");
    let mut spec = small_spec();
    spec["layers"][0]["waves"][0]["amplitdue"] = json!(1);
    let (st, v) = s.put_scene("bad", &spec).await;
    assert_eq!(st, 400);
    // The whole path, through the layer's `kind` tag (serde's buffering used to cut it at
    // `layers[0]`).
    assert_eq!(v["error"]["field"], "layers[0].waves[0].amplitdue", "{v}");
    assert!(
        v["error"]["message"]
            .as_str()
            .unwrap()
            .contains("amplitdue"),
        "{v}"
    );
    // Unknown layer kind.
    let (st, v) = s
        .put_scene("bad", &json!({"layers": [{"kind": "tsunami"}]}))
        .await;
    assert_eq!(st, 400, "{v}");
    // Bad id.
    let (st, v) = s.put_scene("Bad_Id", &small_spec()).await;
    assert_eq!((st, v["error"]["field"].as_str()), (400, Some("id")));
    // Nothing changed.
    let (st, _) = s.get_json("/v1/scenes/bad").await;
    assert_eq!(st, 404);
    let (_, list) = s.get_json("/v1/scenes").await;
    assert_eq!(list["scenes"].as_array().unwrap().len(), 5);
    s.stop().await;
}

#[tokio::test]
async fn admin_token_missing_is_401_wrong_is_403() {
    let s = TestServer::start(config()).await;
    let spec = small_spec();
    for (method, path, body) in [
        (Method::PUT, "/v1/scenes/calm", Some(&spec)),
        (Method::DELETE, "/v1/scenes/calm", None),
        (
            Method::PUT,
            "/v1/scenes/calm/clock",
            Some(&json!({"paused": true})),
        ),
    ] {
        let (st, v) = s.admin(method.clone(), path, body, None).await;
        assert_eq!((st, code(&v)), (401, "unauthorized"), "{method} {path}");
        let (st, v) = s.admin(method.clone(), path, body, Some("guess")).await;
        assert_eq!((st, code(&v)), (403, "forbidden"), "{method} {path}");
    }
    // Auth is checked before the body is read: garbage with no token is still 401.
    let r = s
        .client
        .put(s.url("/v1/scenes/x"))
        .body("not json")
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 401);
    // Nothing changed.
    let (_, v) = s.get_json("/v1/scenes/calm").await;
    assert_eq!(v["spec"]["layers"][0]["kind"], "sine");
    assert_eq!(v["clock"]["paused"], json!(false));
    let _ = TOKEN;
    s.stop().await;
}

#[tokio::test]
async fn too_many_points_is_413() {
    let mut cfg = config();
    cfg.limits.max_points = 100;
    let s = TestServer::start(cfg).await;
    let points: Vec<[f64; 2]> = (0..101).map(|i| [i as f64, 0.0]).collect();
    let (st, v) = s
        .post_json("/v1/scenes/calm/sample", &json!({"points": points}))
        .await;
    assert_eq!((st, code(&v)), (413, "too_many_points"), "{v}");
    let (st, _) = s
        .post_json("/v1/scenes/calm/sample", &json!({"points": &points[..100]}))
        .await;
    assert_eq!(st, 200);
    // Probes over all bodies count as points too (12 bodies × 9 default probes > 100).
    let bodies: Vec<_> = (0..12)
        .map(|i| json!({"position": [i, 0], "length": 2, "beam": 1}))
        .collect();
    let (st, v) = s
        .post_json("/v1/scenes/calm/orientation", &json!({"bodies": bodies}))
        .await;
    assert_eq!((st, code(&v)), (413, "too_many_points"), "{v}");
    s.stop().await;
}

#[tokio::test]
async fn oversized_body_is_413() {
    let mut cfg = config();
    cfg.limits.max_body_bytes = 1024;
    let s = TestServer::start(cfg).await;
    let big = format!(r#"{{"points": [{}]}}"#, vec!["[1.0, 2.0]"; 200].join(","));
    let (st, v) = s.post_raw("/v1/scenes/calm/sample", &big).await;
    assert_eq!((st, code(&v)), (413, "body_too_large"), "{v}");
    s.stop().await;
}

#[tokio::test]
async fn bad_bodies_and_clock_values_are_400() {
    let s = TestServer::start(config()).await;
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/orientation",
            &json!({"bodies": [{"position": [0, 0], "length": 0, "beam": 1}]}),
        )
        .await;
    assert_eq!(
        (st, v["error"]["field"].as_str()),
        (400, Some("bodies[0].length")),
        "{v}"
    );
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/orientation",
            &json!({"bodies": [{"position": [0, 0], "length": 1, "beam": 1, "mass": 3}]}),
        )
        .await;
    assert_eq!((st, code(&v)), (400, "bad_json"), "{v}");
    let (st, v) = s.put_clock("calm", &json!({"rate": 1e9})).await;
    assert_eq!((st, v["error"]["field"].as_str()), (400, Some("rate")));
    let (st, v) = s.put_clock("calm", &json!({"speed": 2})).await;
    assert_eq!((st, code(&v)), (400, "bad_json"));
    let (st, v) = s.put_clock("calm", &json!({"t": 1e300})).await;
    assert_eq!((st, v["error"]["field"].as_str()), (400, Some("t")));
    let (_, c) = s.get_json("/v1/scenes/calm/clock").await;
    assert_eq!(
        (c["rate"].as_f64(), c["paused"].as_bool()),
        (Some(1.0), Some(false))
    );
    s.stop().await;
}

/// Values that used to be accepted and then broke what came after (an outside audit): a scene
/// whose waves overflow (500 on every query), a tick rate so low the stream panicked, a particle
/// layer whose shader held an f32 infinity (500), a body spawned beyond `max_coordinate` (an
/// infinity in compact frames), a cell hull whose derived damping was NaN, an input force that
/// quarantined its boat. Each is now refused with its field named, and the message writes big
/// numbers as `1e300`, not 301 digits.
#[tokio::test]
async fn values_that_would_break_later_work_are_refused_up_front() {
    let s = TestServer::start(config()).await;
    let wave = |k: &str, v: f64| {
        let mut spec = small_spec();
        spec["layers"][0]["waves"][0][k] = json!(v);
        spec
    };
    let particles = |k: &str, v: Value| {
        let mut layer = json!({"kind": "particles"});
        layer[k] = v;
        json!({"layers": [layer]})
    };
    let mut slow = small_spec();
    slow["tick_hz"] = json!(1e-20);
    for (spec, field) in [
        (wave("amplitude", 1e308), "layers[0].waves[0].amplitude"),
        (wave("wavelength", 1e-300), "layers[0].waves[0].wavelength"),
        (wave("phase", 1e308), "layers[0].waves[0].phase"),
        (wave("speed", 1e300), "layers[0].waves[0].speed"),
        (slow, "tick_hz"),
        (particles("scales", json!([1e-50])), "layers[0].scales[0]"),
        (particles("tile_size", json!(1e-39)), "layers[0].tile_size"),
    ] {
        let (st, v) = s.put_scene("bad", &spec).await;
        assert_eq!(
            (st, code(&v), v["error"]["field"].as_str()),
            (422, "invalid_spec", Some(field)),
            "{v}"
        );
        let msg = v["error"]["message"].as_str().unwrap();
        assert!(msg.len() < 300, "{msg}");
    }
    let (st, v) = s.put_scene("bad", &wave("amplitude", 1e308)).await;
    assert!(
        v["error"]["message"].as_str().unwrap().contains("= 1e308"),
        "{st} {v}"
    );
    let boat =
        |position: Value, hull: Value| json!({"mass": 3000.0, "hull": hull, "position": position});
    let hull = json!({"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5});
    let cells = json!({"kind": "cells", "cells": [{"position": [0, 0, 0], "volume": 1e300, "height": 1e-300}]});
    for (body, status, field) in [
        (boat(json!([1e300, 0, 0]), hull.clone()), 400, "position[0]"),
        (boat(json!([0, 2e9, 0]), hull.clone()), 400, "position[1]"),
        (boat(json!([0, 0, 0]), cells), 422, "hull.cells[0].height"),
    ] {
        let (st, v) = s
            .admin(
                Method::POST,
                "/v1/scenes/calm/bodies",
                Some(&body),
                Some(TOKEN),
            )
            .await;
        assert_eq!(
            (st, v["error"]["field"].as_str()),
            (status, Some(field)),
            "{v}"
        );
    }
    let (st, v) = s
        .admin(
            Method::POST,
            "/v1/scenes/calm/bodies",
            Some(&boat(json!([0, 0.5, 0]), hull)),
            Some(TOKEN),
        )
        .await;
    assert_eq!(st, 201, "{v}");
    let id = v["id"].as_u64().unwrap();
    let input = format!("/v1/scenes/calm/bodies/{id}/input");
    for (body, field) in [
        (json!({"force": [1e308, 0, 0]}), "force[0]"),
        (json!({"torque": [0, -1e17, 0]}), "torque[1]"),
        (json!({"from_tick": i64::MAX}), "from_tick"),
    ] {
        let (st, v) = s
            .admin(Method::POST, &input, Some(&body), Some(TOKEN))
            .await;
        assert_eq!(
            (st, code(&v), v["error"]["field"].as_str()),
            (400, "invalid_value", Some(field)),
            "{v}"
        );
    }
    let (st, v) = s
        .admin(
            Method::POST,
            &input,
            Some(&json!({"force": [1e6, 0, 0], "ticks": 3})),
            Some(TOKEN),
        )
        .await;
    assert_eq!(st, 202, "{v}");
    // A query string that cannot be read: bad_request, naming the field.
    let (st, v) = s.get_json("/v1/scenes/calm/height?x=abc&z=1").await;
    assert_eq!(
        (st, code(&v), v["error"]["field"].as_str()),
        (400, "bad_request", Some("x")),
        "{v}"
    );
    // An empty `fields` list asks for the default, as in protobuf.
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/sample",
            &json!({"points": [[1, 2]], "fields": []}),
        )
        .await;
    assert_eq!(st, 200, "{v}");
    assert_eq!(v["height"].as_array().map(Vec::len), Some(1), "{v}");
    s.stop().await;
}

/// Regression (issue 11): `{"length": 1e300}` was accepted and answered 200 with
/// `"heave": null` (a NaN written as JSON null). Body sizes are bounded: 400 naming the field.
#[tokio::test]
async fn issue_11_huge_body_is_400_not_a_null_heave() {
    let s = TestServer::start(config()).await;
    let max = swell_waves::body::MAX_FOOTPRINT;
    for (body, field) in [
        (
            json!({"position": [0, 0], "length": 1e300, "beam": 1}),
            "bodies[0].length",
        ),
        (
            json!({"position": [0, 0], "length": 1, "beam": 2.0 * max}),
            "bodies[0].beam",
        ),
        (
            json!({"position": [0, 0], "length": 1, "beam": 1, "probes": [[0, 1e300]]}),
            "bodies[0].probes[0][1]",
        ),
    ] {
        let (st, v) = s
            .post_json("/v1/scenes/lake/orientation", &json!({"bodies": [body]}))
            .await;
        assert_eq!(
            (st, code(&v), v["error"]["field"].as_str()),
            (400, "invalid_value", Some(field)),
            "{v}"
        );
    }
    // The largest allowed body is answered, with numbers.
    let (st, v) = s
        .post_json(
            "/v1/scenes/lake/orientation",
            &json!({"bodies": [{"position": [0, 0], "length": max, "beam": max}]}),
        )
        .await;
    assert_eq!(st, 200, "{v}");
    assert!(v["bodies"][0]["heave"].is_f64(), "{v}");
    s.stop().await;
}

#[tokio::test]
async fn wrong_method_is_405_json() {
    let s = TestServer::start(config()).await;
    let r = s
        .client
        .patch(s.url("/v1/scenes/calm"))
        .send()
        .await
        .unwrap();
    let (st, v) = common::into_json(r).await;
    assert_eq!((st, code(&v)), (405, "method_not_allowed"));
    s.stop().await;
}

#[tokio::test]
async fn protobuf_admin_bodies_are_refused() {
    // Query bodies may be protobuf (tests/server/protobuf.rs); scene specs are JSON only.
    let s = TestServer::start(config()).await;
    let r = s
        .client
        .put(s.url("/v1/scenes/calm"))
        .bearer_auth(common::TOKEN)
        .header("content-type", "application/x-protobuf")
        .body(vec![1u8, 2, 3])
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 415);
    s.stop().await;
}

#[tokio::test]
async fn slow_requests_time_out_with_503() {
    let mut cfg = config();
    // Reading and parsing 60k points alone takes far longer than 1 ms.
    cfg.limits.request_timeout_ms = 1;
    let s = TestServer::start(cfg).await;
    let pts: Vec<[f64; 2]> = (0..60_000).map(|i| [i as f64 * 0.5, 1.0]).collect();
    let (st, v) = s
        .post_json(
            "/v1/scenes/storm/sample",
            &json!({"t": 1.0, "points": pts, "fields": ["height", "normal"]}),
        )
        .await;
    assert_eq!((st, code(&v)), (503, "timeout"), "{v}");
    s.stop().await;
}

#[tokio::test]
async fn empty_batches_are_fine() {
    let s = TestServer::start(config()).await;
    let (st, v) = s
        .post_json(
            "/v1/scenes/open-sea/sample",
            &json!({"t": 1.0, "points": []}),
        )
        .await;
    assert_eq!(st, 200);
    assert_eq!(v["height"], json!([]));
    let (st, v) = s
        .post_json(
            "/v1/scenes/open-sea/orientation",
            &json!({"t": 1.0, "bodies": []}),
        )
        .await;
    assert_eq!((st, v["bodies"].clone()), (200, json!([])));
    s.stop().await;
}

/// Regression (issue 11, found by the `json_orientation` fuzz target): a finite but huge yaw
/// (`7e99`) was accepted, the model's deterministic sin/cos of it was NaN, every probe landed at a
/// NaN world point and the answer was a 500 `non_finite_result` instead of a 400; a spawn with
/// such a yaw would have put a body with a NaN rotation in the world. Yaw is bounded by
/// `swell_waves::body::MAX_YAW`: 400 naming the field, and the bound itself still answers.
#[tokio::test]
async fn issue_11_huge_yaw_is_400_not_a_non_finite_answer() {
    let s = TestServer::start(config()).await;
    let max = swell_waves::body::MAX_YAW;
    for yaw in [7e99, -2.0 * max] {
        let (st, v) = s
            .post_json(
                "/v1/scenes/calm/orientation",
                &json!({"t": 362, "bodies": [{"position": [20, -4], "yaw": yaw, "length": 39,
                                              "beam": 12, "probes": [[0, 0]]}]}),
            )
            .await;
        assert_eq!(
            (st, code(&v), v["error"]["field"].as_str()),
            (400, "invalid_value", Some("bodies[0].yaw")),
            "{v}"
        );
        let (st, v) = s
            .admin(
                Method::POST,
                "/v1/scenes/calm/bodies",
                Some(&json!({"mass": 3000.0,
                             "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5},
                             "position": [5.0, 0.0, -3.0], "yaw": yaw})),
                Some(TOKEN),
            )
            .await;
        assert_eq!(
            (st, code(&v), v["error"]["field"].as_str()),
            (400, "invalid_value", Some("yaw")),
            "{v}"
        );
    }
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/orientation",
            &json!({"bodies": [{"position": [20, -4], "yaw": max, "length": 39, "beam": 12}]}),
        )
        .await;
    assert_eq!(st, 200, "{v}");
    assert!(v["bodies"][0]["heave"].is_f64(), "{v}");
    assert!(v["bodies"][0]["rotation"][3].is_f64(), "{v}");
    s.stop().await;
}
