//! Arbitrary bytes as an admin request body: the first byte picks which one, the rest is the JSON
//! body, parsed with the server's own parser and applied as the handler applies it.
//! - 0: `PUT …/clock` (`ClockUpdate`): validated, applied to a running clock; the clock then
//!   reads a finite time for an hour of wall time either way.
//! - 1: `POST …/bodies` (`SpawnRequest`): spawned into an empty body world on `calm` and on
//!   `lake`, stepped 5 ticks.
//! - 2: `POST …/bodies/{id}/input` (`InputRequest`): given to a boat floating on `lake`, stepped
//!   5 ticks.
//!
//! No panic; a rejection is a 4xx; accepted bodies' states (and the clock) stay finite.
#![no_main]

use libfuzzer_sys::fuzz_target;
use swell::bodies::{InputRequest, SceneBodies, SpawnRequest};
use swell::scene::Scene;
use swell::scene::clock::Clock;
use swell::service::types::ClockUpdate;
use swell_fuzz::{assert_client_error, assert_finite, fixture};

/// Wall time the clocks start at (the built-ins' epoch plus a month), s.
const NOW: f64 = 1_767_225_600.0 + 30.0 * 86_400.0;

fuzz_target!(|data: &[u8]| {
    let Some((&which, body)) = data.split_first() else {
        return;
    };
    match which % 3 {
        0 => clock(body),
        1 => spawn(body),
        _ => input(body),
    }
});

fn clock(body: &[u8]) {
    let Ok(update) = swell::service::json::from_slice::<ClockUpdate>(body) else {
        return;
    };
    if let Err(e) = update.validate(&fixture().limits) {
        return assert_client_error(&e);
    }
    let mut c = Clock::starting_at(NOW, 60.0);
    if let Some(t) = update.t {
        c.seek(NOW, t);
    }
    if let Some(r) = update.rate {
        c.set_rate(NOW, r);
    }
    if let Some(p) = update.paused {
        c.set_paused(NOW, p);
    }
    for dt in [0.0, 1.0, 3600.0] {
        let t = c.t(NOW + dt);
        assert!(t.is_finite(), "clock reads {t} {dt} s after {update:?}");
    }
}

fn scene(id: &str) -> &'static Scene {
    fixture()
        .scenes
        .iter()
        .find(|s| s.id == id)
        .expect("a built-in scene")
}

/// A world anchored where the fixture's clock reads ([`swell_fuzz::DEFAULT_T`]).
fn world(scene: &Scene) -> SceneBodies {
    let tick = (swell_fuzz::DEFAULT_T * scene.spec.tick_hz) as i64;
    SceneBodies::new(tick, scene.spec.tick_hz, scene.spec.surface.gravity)
        .expect("built-in scenes have valid tick rates and gravity")
}

fn step(b: &mut SceneBodies, scene: &Scene, what: &dyn std::fmt::Debug) {
    let target = b.tick() + 5;
    b.advance_to(
        target,
        swell::bodies::Sea::Direct(&scene.surface),
        scene.spec.tick_hz,
        scene.spec.surface.gravity,
    );
    assert_eq!(b.tick(), target);
    assert_finite(&b.states(None), &scene.id, what);
}

fn spawn(body: &[u8]) {
    let Ok(req) = swell::service::json::from_slice::<SpawnRequest>(body) else {
        return;
    };
    for id in ["calm", "lake"] {
        let scene = scene(id);
        let mut b = world(scene);
        match b.spawn(&req) {
            Ok(_) => step(&mut b, scene, &req),
            Err(e) => assert_client_error(&swell::ApiError::from(e)),
        }
    }
}

fn input(body: &[u8]) {
    let Ok(req) = swell::service::json::from_slice::<InputRequest>(body) else {
        return;
    };
    let scene = scene("lake");
    let mut b = world(scene);
    let boat: SpawnRequest = serde_json::from_value(serde_json::json!({
        "mass": 3000.0,
        "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5},
        "position": [0.0, 0.3, 0.0]
    }))
    .expect("a valid boat");
    let id = b.spawn(&boat).expect("the boat spawns");
    match b.input(id, &req) {
        Ok(()) => step(&mut b, scene, &req),
        Err(e) => assert_client_error(&swell::ApiError::from(e)),
    }
}
