//! What `swell_world_set_state` (the reconciliation fallback) costs: a world whose boat is put
//! back to its own state (so only the hull cells' inversion warm starts are lost) is compared
//! with the world that never stopped, through the same C functions a client calls.

use std::ptr;

use swell_ffi::*;

const BOAT: &str = r#"{"mass": 3000, "hull": {"kind": "box", "length": 8, "beam": 3, "height": 1.5},
    "position": [5, 0.4, -3], "yaw": 0.3}"#;

fn scene(id: &str) -> String {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../proto/vectors/bodies_v1.json"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == id)
        .unwrap()["scene"]
        .as_str()
        .unwrap()
        .to_owned()
}

fn ok(status: SwellStatus) {
    assert_eq!(status, SWELL_OK, "status {status}");
}

/// Largest position difference, m, and whether any bit differs, after `ticks` ticks from a
/// `set_state` at tick 30 of a boat that was spawned at tick 0 and pushed.
fn drift(id: &str, ticks: i64) -> (f64, bool) {
    let text = scene(id);
    let mut s = ptr::null_mut();
    let (mut a, mut b) = (ptr::null_mut(), ptr::null_mut());
    let mut boat = 0u64;
    let mut worst = 0.0f64;
    let mut differs = false;
    // SAFETY: every pointer passed is a live handle from these calls or a local.
    unsafe {
        ok(swell_surface_new(text.as_ptr().cast(), text.len(), &mut s));
        ok(swell_world_new(s, 1000, &mut a));
        ok(swell_world_spawn(
            a,
            BOAT.as_ptr().cast(),
            BOAT.len(),
            &mut boat,
        ));
        let push = SwellInput {
            force: [5000.0, 0.0, 0.0],
            torque: [0.0, 2000.0, 0.0],
            from_tick: SWELL_FROM_NOW,
            ticks: 20,
        };
        ok(swell_world_input(a, boat, &push));
        ok(swell_world_step_to(a, 1030));
        ok(swell_world_clone(a, &mut b));
        let mut st = SwellBodyState::default();
        ok(swell_world_state(b, boat, &mut st));
        ok(swell_world_set_state(b, boat, &st));
        for t in 1031..=1030 + ticks {
            ok(swell_world_step_to(a, t));
            ok(swell_world_step_to(b, t));
            let (mut x, mut y) = (SwellBodyState::default(), SwellBodyState::default());
            ok(swell_world_state(a, boat, &mut x));
            ok(swell_world_state(b, boat, &mut y));
            differs |= x != y;
            for k in 0..3 {
                worst = worst.max((x.position[k] - y.position[k]).abs());
            }
        }
        swell_world_free(a);
        swell_world_free(b);
        swell_surface_free(s);
    }
    (worst, differs)
}

#[test]
fn a_boat_put_back_to_its_streamed_state_stays_within_a_millimetre() {
    for id in ["lake", "open-sea"] {
        let (worst, differs) = drift(id, 60);
        eprintln!(
            "{id}: set_state then 60 ticks: max position difference {worst:.3e} m, bits differ: {differs}"
        );
        assert!(worst < 1e-3, "{id}: {worst} m");
    }
}
