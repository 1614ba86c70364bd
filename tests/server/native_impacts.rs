//! Issue 28: a native client ripples its queries with the scene's impacts, to the server's bits.
//!
//! A real server takes three impacts on `harbour`; a surface of the C ABI built from the
//! scene's spec (`GET /v1/scenes/harbour`) and given the impacts `GET …/impacts` lists
//! (`swell_surface_set_impacts`) must answer `/sample`'s bits for every field at 400 points
//! around them; without the impacts it must not.

use crate::common;
use crate::native::{ok, status_message};

use std::ptr;

use common::{TOKEN, TestServer, config};
use reqwest::Method;
use serde_json::{Value, json};
use swell_ffi::*;

fn bits(v: &Value) -> u64 {
    v.as_f64()
        .unwrap_or_else(|| panic!("not a number: {v}"))
        .to_bits()
}

#[tokio::test]
async fn a_native_surface_with_the_scenes_impacts_answers_the_servers_bits() {
    let s = TestServer::start(config()).await;
    let (_, clock) = s.get_json("/v1/scenes/harbour/clock").await;
    let now = clock["t"].as_f64().unwrap();
    for (dt, x, z, strength, radius) in [
        (-1.0, 2.0, 1.0, 0.3, 0.6),
        (0.0, -4.0, 3.5, 0.5, 1.0),
        (0.5, 1.0, -6.0, 0.2, 0.4),
    ] {
        let (st, v) = s
            .admin(
                Method::POST,
                "/v1/scenes/harbour/impacts",
                Some(&json!({"t": now + dt, "position": [x, z], "strength": strength, "radius": radius})),
                Some(TOKEN),
            )
            .await;
        assert_eq!(st, 202, "{v}");
    }
    let t = now + 2.0;
    let (st, scene) = s.get_json("/v1/scenes/harbour").await;
    assert_eq!(st, 200, "{scene}");
    let (st, listed) = s
        .get_json(&format!("/v1/scenes/harbour/impacts?t={t}"))
        .await;
    assert_eq!(st, 200, "{listed}");
    let impacts: Vec<SwellImpact> = listed["impacts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| SwellImpact {
            t: i["t"].as_f64().unwrap(),
            position: [
                i["position"][0].as_f64().unwrap(),
                i["position"][1].as_f64().unwrap(),
            ],
            strength: i["strength"].as_f64().unwrap(),
            radius: i["radius"].as_f64().unwrap(),
        })
        .collect();
    assert_eq!(impacts.len(), 3, "{listed}");

    // 400 points on a 20 × 20 grid over the rings (0.6 m apart, from (-6, -8)).
    let points: Vec<[f64; 2]> = (0..400)
        .map(|i| {
            [
                -6.0 + 0.6 * f64::from(i % 20),
                -8.0 + 0.6 * f64::from(i / 20),
            ]
        })
        .collect();
    let (st, server) = s
        .post_json(
            "/v1/scenes/harbour/sample",
            &json!({"t": t, "points": points,
                    "fields": ["height", "normal", "displacement", "jacobian", "residual"]}),
        )
        .await;
    assert_eq!(st, 200, "{server}");

    let spec = scene["spec"].to_string();
    let mut sea: *mut SwellSurface = ptr::null_mut();
    // SAFETY: the JSON is readable for its length; `sea` is writable.
    ok(unsafe { swell_surface_new(spec.as_ptr().cast(), spec.len(), &mut sea) });
    let flat: Vec<f64> = points.iter().flatten().copied().collect();
    let sample = |sea: *mut SwellSurface| {
        let mut out = vec![SwellPoint::default(); points.len()];
        // SAFETY: a live surface, 2n readable doubles, n writable points.
        ok(unsafe {
            swell_surface_sample(
                sea,
                t,
                flat.as_ptr(),
                points.len(),
                SWELL_FIELD_ALL,
                ptr::null(),
                out.as_mut_ptr(),
            )
        });
        out
    };
    let differing = |mine: &[SwellPoint]| {
        let mut n = 0;
        for (i, p) in mine.iter().enumerate() {
            let same = bits(&server["height"][i]) == p.height.to_bits()
                && (0..3).all(|k| bits(&server["normal"][i][k]) == p.normal[k].to_bits())
                && (0..3)
                    .all(|k| bits(&server["displacement"][i][k]) == p.displacement[k].to_bits())
                && bits(&server["jacobian"][i]) == p.jacobian.to_bits()
                && bits(&server["residual"][i]) == p.residual.to_bits()
                && server["folded"][i].as_bool() == Some(p.folded != 0);
            if !same {
                n += 1;
            }
        }
        n
    };
    // Without the impacts: the points the rings reach differ (129 of 400 here).
    let bare = differing(&sample(sea));
    assert!(
        bare > 50,
        "only {bare} of 400 points differ without the impacts"
    );
    // SAFETY: a live surface; `impacts` readable for its length.
    ok(unsafe { swell_surface_set_impacts(sea, impacts.as_ptr(), impacts.len()) });
    assert_eq!(
        differing(&sample(sea)),
        0,
        "points off the server's bits with the impacts"
    );

    // A bad impact is refused, naming it, and the set in force stays.
    let mut bad = impacts.clone();
    bad[1].strength = f64::NAN;
    // SAFETY: as above.
    let st = unsafe { swell_surface_set_impacts(sea, bad.as_ptr(), bad.len()) };
    assert_eq!(st, SWELL_ERR_INVALID_SPEC);
    assert!(
        status_message().contains("impacts[1].strength"),
        "{}",
        status_message()
    );
    assert_eq!(differing(&sample(sea)), 0);
    // Null handles and lists are reported, not read.
    // SAFETY: null pointers, which the function checks.
    assert_eq!(
        unsafe { swell_surface_set_impacts(ptr::null(), impacts.as_ptr(), 1) },
        SWELL_ERR_NULL
    );
    // SAFETY: as above.
    assert_eq!(
        unsafe { swell_surface_set_impacts(sea, ptr::null(), 2) },
        SWELL_ERR_NULL
    );
    assert!(status_message().contains("impacts"), "{}", status_message());
    // Cleared: the bare surface again.
    // SAFETY: n = 0 with a null list.
    ok(unsafe { swell_surface_set_impacts(sea, ptr::null(), 0) });
    assert_eq!(differing(&sample(sea)), bare);
    // SAFETY: a live handle, freed once.
    unsafe { swell_surface_free(sea) };
    s.stop().await;
}
