//! Protobuf on the HTTP query endpoints: a JSON request and its protobuf twin decode to the
//! same request and give the same bits; errors come back as `ErrorResponse`.

use crate::common;

use common::{TestServer, bits, config};
use prost::Message as _;
use serde_json::{Value, json};
use swell::wire::v1;

const PB: &str = "application/x-protobuf";

async fn post_pb(s: &TestServer, path: &str, body: Vec<u8>) -> (u16, String, Vec<u8>) {
    let r = s
        .client
        .post(s.url(path))
        .header("content-type", PB)
        .header("accept", PB)
        .body(body)
        .send()
        .await
        .expect("POST");
    let st = r.status().as_u16();
    let ct = r
        .headers()
        .get("content-type")
        .map(|v| v.to_str().unwrap().to_owned())
        .unwrap_or_default();
    (st, ct, r.bytes().await.unwrap().to_vec())
}

fn p2(x: f64, z: f64) -> v1::Point2 {
    v1::Point2 { x, z }
}

fn vec3_bits(v: &v1::Vec3, j: &Value, what: &str) {
    for (i, c) in [v.x, v.y, v.z].iter().enumerate() {
        assert_eq!(c.to_bits(), bits(&j[i]), "{what}[{i}]");
    }
}

#[tokio::test]
async fn sample_protobuf_twins_give_json_bits() {
    let s = TestServer::start(config()).await;
    let pts = [(0.0, 0.0), (12.5, -3.0), (1234.5678, 0.001), (-7.25, 99.0)];
    for scene in ["lake", "open-sea", "storm"] {
        for origin in [None, Some((10_000.0, -20_000.5))] {
            let mut body = json!({"t": 61.75, "points": pts.map(|(x, z)| [x, z]),
                "fields": ["height", "normal", "displacement", "jacobian", "residual"]});
            if let Some((x, z)) = origin {
                body["origin"] = json!([x, z]);
            }
            let (st, j) = s
                .post_json(&format!("/v1/scenes/{scene}/sample"), &body)
                .await;
            assert_eq!(st, 200, "{j}");
            let req = v1::SampleRequest {
                t: Some(61.75),
                origin: origin.map(|(x, z)| p2(x, z)),
                points: pts.iter().map(|&(x, z)| p2(x, z)).collect(),
                fields: [
                    v1::Field::Height,
                    v1::Field::Normal,
                    v1::Field::Displacement,
                    v1::Field::Jacobian,
                    v1::Field::Residual,
                ]
                .map(|f| f as i32)
                .to_vec(),
                accuracy: None,
            };
            let (st, ct, bytes) = post_pb(
                &s,
                &format!("/v1/scenes/{scene}/sample"),
                req.encode_to_vec(),
            )
            .await;
            assert_eq!((st, ct.as_str()), (200, PB));
            let r = v1::SampleResponse::decode(bytes.as_slice()).unwrap();
            assert_eq!(r.t.to_bits(), bits(&j["t"]));
            assert_eq!(r.height.len(), pts.len());
            for i in 0..pts.len() {
                assert_eq!(
                    r.height[i].to_bits(),
                    bits(&j["height"][i]),
                    "{scene} height[{i}]"
                );
                vec3_bits(&r.normal[i], &j["normal"][i], "normal");
                vec3_bits(&r.displacement[i], &j["displacement"][i], "displacement");
                assert_eq!(r.jacobian[i].to_bits(), bits(&j["jacobian"][i]));
                assert_eq!(r.folded[i], j["folded"][i].as_bool().unwrap());
                assert_eq!(r.residual[i].to_bits(), bits(&j["residual"][i]));
            }
        }
    }
    s.stop().await;
}

#[tokio::test]
async fn sample_protobuf_accuracy_matches_json_accuracy() {
    let s = TestServer::start(config()).await;
    let body = json!({"t": 5, "points": [[3, 4]], "fields": ["height"],
        "accuracy": {"method": "fixed_point", "iterations": 3, "tolerance": 0.001, "filter": "bilinear"}});
    let (_, j) = s.post_json("/v1/scenes/storm/sample", &body).await;
    let req = v1::SampleRequest {
        t: Some(5.0),
        points: vec![p2(3.0, 4.0)],
        fields: vec![v1::Field::Height as i32],
        accuracy: Some(v1::Accuracy {
            method: v1::InversionMethod::FixedPoint as i32,
            iterations: Some(3),
            tolerance: Some(0.001),
            filter: v1::Filter::Bilinear as i32,
            precision: v1::Precision::Unspecified as i32,
            time: v1::TimeSampling::Unspecified as i32,
        }),
        origin: None,
    };
    let (st, _, bytes) = post_pb(&s, "/v1/scenes/storm/sample", req.encode_to_vec()).await;
    assert_eq!(st, 200);
    let r = v1::SampleResponse::decode(bytes.as_slice()).unwrap();
    assert_eq!(r.height[0].to_bits(), bits(&j["height"][0]));

    // Exact time sampling (a frame at t itself, between two grid times): JSON and protobuf
    // agree, and differ from the grid's interpolated answer by well under a millimetre.
    let body = json!({"t": 5.01, "points": [[3, 4]], "accuracy": {"time": "exact"}});
    let (_, exact) = s.post_json("/v1/scenes/storm/sample", &body).await;
    let (_, grid) = s
        .post_json(
            "/v1/scenes/storm/sample",
            &json!({"t": 5.01, "points": [[3, 4]]}),
        )
        .await;
    let req = v1::SampleRequest {
        t: Some(5.01),
        points: vec![p2(3.0, 4.0)],
        accuracy: Some(v1::Accuracy {
            time: v1::TimeSampling::Exact as i32,
            ..Default::default()
        }),
        ..Default::default()
    };
    let (st, _, bytes) = post_pb(&s, "/v1/scenes/storm/sample", req.encode_to_vec()).await;
    assert_eq!(st, 200);
    let r = v1::SampleResponse::decode(bytes.as_slice()).unwrap();
    assert_eq!(r.height[0].to_bits(), bits(&exact["height"][0]));
    let (e, g) = (
        exact["height"][0].as_f64().unwrap(),
        grid["height"][0].as_f64().unwrap(),
    );
    assert!(e != g && (e - g).abs() < 1e-3, "exact {e} vs grid {g}");

    // The f32 fast path, on a scene with analytic layers: JSON and protobuf twins agree.
    let body = json!({"t": 5, "points": [[3, 4], [-70.5, 12.25]], "fields": ["height", "normal"],
        "accuracy": {"precision": "f32"}});
    let (_, j) = s.post_json("/v1/scenes/open-sea/sample", &body).await;
    let req = v1::SampleRequest {
        t: Some(5.0),
        points: vec![p2(3.0, 4.0), p2(-70.5, 12.25)],
        fields: vec![v1::Field::Height as i32, v1::Field::Normal as i32],
        accuracy: Some(v1::Accuracy {
            precision: v1::Precision::F32 as i32,
            ..Default::default()
        }),
        origin: None,
    };
    let (st, _, bytes) = post_pb(&s, "/v1/scenes/open-sea/sample", req.encode_to_vec()).await;
    assert_eq!(st, 200);
    let r = v1::SampleResponse::decode(bytes.as_slice()).unwrap();
    for i in 0..2 {
        assert_eq!(r.height[i].to_bits(), bits(&j["height"][i]));
        assert_eq!(r.normal[i].y.to_bits(), bits(&j["normal"][i][1]));
    }
    s.stop().await;
}

#[tokio::test]
async fn orientation_protobuf_twin_gives_json_bits() {
    let s = TestServer::start(config()).await;
    let body = json!({"t": 30.5, "bodies": [
        {"position": [5, 5], "yaw": 0.3, "length": 12, "beam": 4},
        {"position": [-40, 17.5], "length": 6, "beam": 2.5, "probes": [[1, 0], [-1, 0.5], [0, -1]]}]});
    let (st, j) = s.post_json("/v1/scenes/open-sea/orientation", &body).await;
    assert_eq!(st, 200, "{j}");
    let req = v1::OrientationRequest {
        t: Some(30.5),
        bodies: vec![
            v1::Body {
                position: Some(p2(5.0, 5.0)),
                yaw: 0.3,
                length: 12.0,
                beam: 4.0,
                probes: vec![],
            },
            v1::Body {
                position: Some(p2(-40.0, 17.5)),
                yaw: 0.0,
                length: 6.0,
                beam: 2.5,
                probes: vec![p2(1.0, 0.0), p2(-1.0, 0.5), p2(0.0, -1.0)],
            },
        ],
    };
    let (st, _, bytes) = post_pb(&s, "/v1/scenes/open-sea/orientation", req.encode_to_vec()).await;
    assert_eq!(st, 200);
    let r = v1::OrientationResponse::decode(bytes.as_slice()).unwrap();
    assert_eq!(r.t.to_bits(), bits(&j["t"]));
    for (i, b) in r.bodies.iter().enumerate() {
        let jb = &j["bodies"][i];
        assert_eq!(b.heave.to_bits(), bits(&jb["heave"]));
        assert_eq!(b.pitch.to_bits(), bits(&jb["pitch"]));
        assert_eq!(b.roll.to_bits(), bits(&jb["roll"]));
        vec3_bits(b.normal.as_ref().unwrap(), &jb["normal"], "normal");
        let q = b.rotation.as_ref().unwrap();
        for (k, c) in [q.x, q.y, q.z, q.w].iter().enumerate() {
            assert_eq!(c.to_bits(), bits(&jb["rotation"][k]), "rotation[{k}]");
        }
    }
    s.stop().await;
}

#[tokio::test]
async fn height_answers_protobuf_when_accepted() {
    let s = TestServer::start(config()).await;
    let (_, j) = s.get_json("/v1/scenes/lake/height?x=12.5&z=-3&t=60").await;
    let r = s
        .client
        .get(s.url("/v1/scenes/lake/height?x=12.5&z=-3&t=60"))
        .header("accept", PB)
        .send()
        .await
        .unwrap();
    assert_eq!(r.headers()["content-type"], PB);
    let h = v1::HeightResponse::decode(r.bytes().await.unwrap()).unwrap();
    assert_eq!(h.height.to_bits(), bits(&j["height"]));
    s.stop().await;
}

#[tokio::test]
async fn json_body_with_protobuf_answer_and_vice_versa() {
    let s = TestServer::start(config()).await;
    let r = s
        .client
        .post(s.url("/v1/scenes/calm/sample"))
        .header("accept", PB)
        .json(&json!({"t": 1, "points": [[1, 2]]}))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    let pb = v1::SampleResponse::decode(r.bytes().await.unwrap()).unwrap();
    let req = v1::SampleRequest {
        t: Some(1.0),
        points: vec![p2(1.0, 2.0)],
        ..Default::default()
    };
    let r = s
        .client
        .post(s.url("/v1/scenes/calm/sample"))
        .header("content-type", PB)
        .body(req.encode_to_vec())
        .send()
        .await
        .unwrap();
    let (st, j) = common::into_json(r).await;
    assert_eq!(st, 200);
    assert_eq!(pb.height[0].to_bits(), bits(&j["height"][0]));
    s.stop().await;
}

#[tokio::test]
async fn protobuf_errors_name_the_field_and_come_back_as_error_response() {
    let s = TestServer::start(config()).await;
    // FIELD_UNSPECIFIED.
    let req = v1::SampleRequest {
        points: vec![p2(0.0, 0.0)],
        fields: vec![v1::Field::Height as i32, v1::Field::Unspecified as i32],
        ..Default::default()
    };
    let (st, ct, bytes) = post_pb(&s, "/v1/scenes/calm/sample", req.encode_to_vec()).await;
    assert_eq!((st, ct.as_str()), (400, PB));
    let e = v1::ErrorResponse::decode(bytes.as_slice())
        .unwrap()
        .error
        .unwrap();
    assert_eq!(e.field.as_deref(), Some("fields[1]"));
    // A value outside the enum.
    let req = v1::SampleRequest {
        points: vec![p2(0.0, 0.0)],
        accuracy: Some(v1::Accuracy {
            method: 7,
            ..Default::default()
        }),
        ..Default::default()
    };
    let (st, _, bytes) = post_pb(&s, "/v1/scenes/calm/sample", req.encode_to_vec()).await;
    assert_eq!(st, 400);
    let e = v1::ErrorResponse::decode(bytes.as_slice())
        .unwrap()
        .error
        .unwrap();
    assert_eq!(e.field.as_deref(), Some("accuracy.method"));
    // Malformed bytes.
    let (st, _, bytes) = post_pb(&s, "/v1/scenes/calm/sample", vec![0xff, 0xff, 0xff]).await;
    assert_eq!(st, 400);
    let e = v1::ErrorResponse::decode(bytes.as_slice())
        .unwrap()
        .error
        .unwrap();
    assert_eq!(e.code, "bad_protobuf");
    // Unknown scene, as protobuf.
    let (st, _, bytes) = post_pb(&s, "/v1/scenes/nope/orientation", vec![]).await;
    assert_eq!(st, 404);
    let e = v1::ErrorResponse::decode(bytes.as_slice())
        .unwrap()
        .error
        .unwrap();
    assert_eq!(e.code, "not_found");
    // Missing body position.
    let req = v1::OrientationRequest {
        t: None,
        bodies: vec![v1::Body {
            length: 2.0,
            beam: 1.0,
            ..Default::default()
        }],
    };
    let (st, _, bytes) = post_pb(&s, "/v1/scenes/calm/orientation", req.encode_to_vec()).await;
    assert_eq!(st, 400);
    let e = v1::ErrorResponse::decode(bytes.as_slice())
        .unwrap()
        .error
        .unwrap();
    assert_eq!(e.field.as_deref(), Some("bodies[0].position"));
    // Without Accept: protobuf, errors stay JSON.
    let r = s
        .client
        .post(s.url("/v1/scenes/calm/sample"))
        .header("content-type", PB)
        .body(vec![0xff, 0xff])
        .send()
        .await
        .unwrap();
    let (st, v) = common::into_json(r).await;
    assert_eq!((st, common::code(&v)), (400, "bad_protobuf"));
    s.stop().await;
}
