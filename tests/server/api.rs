//! Every endpoint answers, over a real socket.

use crate::common;

use common::{TOKEN, TestServer, code, config, small_spec};
use std::collections::{BTreeMap, BTreeSet};

use reqwest::Method;
use serde_json::{Value, json};

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

/// The OpenAPI document against the server. It used to declare a `200` alone for every
/// operation (a new scene answers 201, a spawn 201, an input or impact 202, a delete 204, a
/// revalidated shader 304), no `{bid}` or `{scene}` path parameter, no query parameter for
/// `/shader`, `/uniforms`, `/spectrum` or `GET /impacts`, no body for spawns, inputs and
/// impacts, languages `/shader` refuses, and a layer `kind` enum without `particles`.
#[tokio::test]
async fn openapi_declares_the_parameters_and_statuses_the_server_uses() {
    let s = TestServer::start(config()).await;
    let (st, doc) = s.get_json("/openapi.json").await;
    assert_eq!(st, 200);
    let paths = doc["paths"].as_object().unwrap();
    assert!(paths.contains_key("/v1/scenes/{id}/bodies/{bid}/input"));
    assert!(paths.contains_key("/viewer/{scene}"));

    // Every `{name}` of a path is a required path parameter of each of its operations, and no
    // operation declares one its path lacks.
    for (path, ops) in paths {
        let names: BTreeSet<&str> = path
            .split('/')
            .filter_map(|seg| seg.strip_prefix('{')?.strip_suffix('}'))
            .collect();
        for (method, op) in ops.as_object().unwrap() {
            let declared: BTreeSet<&str> = params(op, "path")
                .map(|p| {
                    assert_eq!(p["required"], true, "{method} {path}: {p}");
                    assert!(p["schema"]["type"].is_string(), "{method} {path}: {p}");
                    p["name"].as_str().unwrap()
                })
                .collect();
            assert_eq!(declared, names, "{method} {path}: path parameters");
        }
    }

    // The query parameters are the handlers' query structs, with `required` as they treat them.
    // (method, path, [(name, required)]).
    type Queries<'a> = &'a [(&'a str, &'a str, &'a [(&'a str, bool)])];
    let queries: Queries = &[
        (
            "get",
            "/v1/scenes/{id}/height",
            &[("t", false), ("x", true), ("z", true)],
        ),
        (
            "get",
            "/v1/scenes/{id}/shader",
            &[("entry", false), ("lang", true), ("layer", false)],
        ),
        (
            "get",
            "/v1/scenes/{id}/uniforms",
            &[("origin", false), ("t", false)],
        ),
        ("get", "/v1/scenes/{id}/spectrum", &[("layer", true)]),
        ("get", "/v1/scenes/{id}/impacts", &[("t", false)]),
        ("post", "/v1/scenes/{id}/impacts", &[]),
    ];
    for (method, path, want) in queries {
        let got: BTreeMap<&str, bool> = params(&doc["paths"][*path][*method], "query")
            .map(|p| (p["name"].as_str().unwrap(), p["required"] == true))
            .collect();
        let want: BTreeMap<&str, bool> = want.iter().copied().collect();
        assert_eq!(got, want, "{method} {path}: query parameters");
    }

    // Request bodies: the game routes' bodies are described, JSON only.
    for (method, path, schema) in [
        ("post", "/v1/scenes/{id}/bodies", "SpawnRequest"),
        ("post", "/v1/scenes/{id}/bodies/{bid}/input", "InputRequest"),
        ("post", "/v1/scenes/{id}/impacts", "ImpactRequest"),
    ] {
        let content = &doc["paths"][path][method]["requestBody"]["content"];
        assert_eq!(
            content["application/json"]["schema"]["$ref"],
            format!("#/components/schemas/{schema}"),
            "{method} {path}"
        );
        assert!(
            content["application/x-protobuf"].is_null(),
            "{method} {path}"
        );
    }
    let schemas = &doc["components"]["schemas"];
    assert_eq!(
        schemas["InputRequest"]["required"],
        Value::Null,
        "force, torque default to 0"
    );
    assert_eq!(
        schemas["ImpactRequest"]["required"],
        json!(["position", "strength", "radius"])
    );

    // Real answers: each status the server gives is among the operation's responses.
    let declared = |method: &str, path: &str, status: u16| {
        let responses = &doc["paths"][path][method]["responses"];
        assert!(
            responses[status.to_string()].is_object(),
            "{method} {path} answered {status}; the document declares {}",
            responses
                .as_object()
                .unwrap()
                .keys()
                .cloned()
                .collect::<Vec<_>>()
                .join(", ")
        );
    };
    let (st, v) = s.put_scene("openapi", &small_spec()).await;
    assert_eq!(st, 201, "{v}");
    declared("put", "/v1/scenes/{id}", st);
    let (st, v) = s.put_scene("openapi", &small_spec()).await;
    assert_eq!(st, 200, "{v}");
    declared("put", "/v1/scenes/{id}", st);
    let boat = json!({"mass": 3000.0, "position": [0.0, 1.0, 0.0],
        "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5}});
    let (st, v) = s
        .admin(
            Method::POST,
            "/v1/scenes/openapi/bodies",
            Some(&boat),
            Some(TOKEN),
        )
        .await;
    assert_eq!(st, 201, "{v}");
    declared("post", "/v1/scenes/{id}/bodies", st);
    let bid = v["id"].as_u64().unwrap();
    let (st, v) = s
        .admin(
            Method::POST,
            &format!("/v1/scenes/openapi/bodies/{bid}/input"),
            Some(&json!({"force": [1000.0, 0.0, 0.0]})),
            Some(TOKEN),
        )
        .await;
    assert_eq!(st, 202, "{v}");
    declared("post", "/v1/scenes/{id}/bodies/{bid}/input", st);
    let (st, v) = s
        .admin(
            Method::DELETE,
            &format!("/v1/scenes/openapi/bodies/{bid}"),
            None,
            Some(TOKEN),
        )
        .await;
    assert_eq!(st, 204, "{v}");
    declared("delete", "/v1/scenes/{id}/bodies/{bid}", st);
    let splash = json!({"position": [0.0, 0.0], "strength": 0.5, "radius": 1.0});
    let (st, v) = s
        .admin(
            Method::POST,
            "/v1/scenes/harbour/impacts",
            Some(&splash),
            Some(TOKEN),
        )
        .await;
    assert_eq!(st, 202, "{v}");
    declared("post", "/v1/scenes/{id}/impacts", st);
    let (st, _) = s
        .admin(Method::DELETE, "/v1/scenes/openapi", None, Some(TOKEN))
        .await;
    assert_eq!(st, 204);
    declared("delete", "/v1/scenes/{id}", st);

    // `lang`: every value the document offers is accepted, and one it does not is refused.
    let shader = "/v1/scenes/{id}/shader";
    let lang = params(&doc["paths"][shader]["get"], "query")
        .find(|p| p["name"] == "lang")
        .unwrap();
    let langs = lang["schema"]["enum"].as_array().unwrap();
    assert!(langs.contains(&json!("gdshaderinc")) && !langs.contains(&json!("godot")));
    for l in langs {
        let r = s
            .get(&format!(
                "/v1/scenes/calm/shader?lang={}",
                l.as_str().unwrap()
            ))
            .await;
        assert_eq!(r.status(), 200, "lang={l}");
    }
    let (st, _) = s.get_json("/v1/scenes/calm/shader?lang=godot").await;
    assert_eq!(st, 400);
    let r = s.get("/v1/scenes/calm/shader?lang=wgsl").await;
    let tag = r.headers()["etag"].clone();
    let r = s
        .client
        .get(s.url("/v1/scenes/calm/shader?lang=wgsl"))
        .header("if-none-match", tag)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 304);
    declared("get", shader, 304);

    // The layer kinds: every built-in scene's layers are of a kind the spec schema offers.
    let kinds =
        &schemas["SceneSpec"]["properties"]["layers"]["items"]["properties"]["kind"]["enum"];
    assert!(
        kinds.as_array().unwrap().contains(&json!("particles")),
        "{kinds}"
    );
    let (_, list) = s.get_json("/v1/scenes").await;
    for scene in list["scenes"].as_array().unwrap() {
        for kind in scene["layers"].as_array().unwrap() {
            assert!(
                kinds.as_array().unwrap().contains(kind),
                "{kind} of {scene}"
            );
        }
    }
    assert!(schemas["SceneSpec"]["properties"]["epoch"].is_object());
    s.stop().await;
}

/// The parameters of `op` that are `in` `place`.
fn params<'a>(op: &'a Value, place: &'a str) -> impl Iterator<Item = &'a Value> + 'a {
    op["parameters"]
        .as_array()
        .into_iter()
        .flatten()
        .filter(move |p| p["in"] == place)
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
