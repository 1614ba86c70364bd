//! The in-process yardstick of P8 (`docs/performance.md`): how long one tick of N floating
//! bodies takes on a built-in scene, through the same `SceneBodies::advance_to` the server's
//! body loop calls, reading FFT frames from a frame cache as the loop does
//! (`Sea::Shared`), with no HTTP, no stream and no other load.
//!
//! ```sh
//! cargo run --release --example body_step -- [scene] [bodies] [ticks] [paced|back-to-back]
//! ```
//! Defaults: `lake 1000 150 back-to-back`. `back-to-back` steps tick after tick, with warm
//! caches: the bodies' cost alone. `paced` sleeps until each tick's wall-clock boundary (every
//! `1/tick_hz` s), as the server's body loop does, so every step starts after ~25 ms asleep,
//! with whatever the caches and the host made of that (on this project's 2-core VM, 10–25%
//! more per step; see `docs/performance.md`, P8). The boats are `swell-load`'s (8 m × 3 m ×
//! 1.5 m, 3 t, on a 20 m grid around the origin, dropped from 0.5 m, as `swell-load
//! --spawn-bodies` spawns them) and stepped for 30 ticks before the measured ones.
//! The share of one core at 30 Hz is `30 × time per tick`. As in the live server, the FFT grid
//! frames around each tick are computed ahead (`FrameCache::compute_ahead`, what the server's
//! frame-ahead loop calls), outside the timed step: the figure is the bodies' own cost.

use std::time::Instant;

use swell::bodies::{SceneBodies, Sea, SpawnRequest};
use swell::frames::FrameCache;
use swell::scene::Scene;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_id = args.first().map_or("lake", String::as_str).to_owned();
    let bodies: usize = args.get(1).map_or(1000, |s| s.parse().expect("bodies"));
    let ticks: i64 = args.get(2).map_or(150, |s| s.parse().expect("ticks"));
    let paced = match args.get(3).map(String::as_str) {
        None | Some("back-to-back") => false,
        Some("paced") => true,
        Some(other) => panic!("{other}: expected `paced` or `back-to-back`"),
    };
    let (_, spec) = swell::scene::builtin::specs()
        .into_iter()
        .find(|(id, _)| *id == scene_id)
        .unwrap_or_else(|| panic!("{scene_id} is not a built-in scene"));
    let scene = Scene::build(&scene_id, spec).expect("built-in scenes build");
    let (hz, g) = (scene.spec.tick_hz, scene.spec.surface.gravity);
    let cache = FrameCache::new(64);
    let start = 1_000_000_i64;
    let mut world = SceneBodies::new(start, hz, g).expect("the scene's settings");
    // swell-load's layout (`spawn_bodies`, default area): a square grid of 20 m around the
    // origin, dropped from 0.5 m.
    let cols = (bodies as f64).sqrt().ceil().max(1.0) as usize;
    for i in 0..bodies {
        let x = 20.0 * ((i % cols) as f64 - cols as f64 / 2.0);
        let z = 20.0 * ((i / cols) as f64 - cols as f64 / 2.0);
        let req: SpawnRequest = serde_json::from_value(serde_json::json!({
            "mass": 3000.0,
            "hull": {"kind": "box", "length": 8.0, "beam": 3.0, "height": 1.5},
            "position": [x, 0.5, z],
            "yaw": 0.0
        }))
        .expect("a valid spawn");
        world.spawn(&req).expect("the boat spawns");
    }
    let step = |world: &mut SceneBodies, tick: i64| {
        let sea = Sea::Shared {
            cache: &cache,
            scene: &scene,
            now: tick as f64 / hz,
        };
        world.advance_to(tick, sea, hz, g);
    };
    // The server's frame-ahead loop computes the grid frames around now before the body loop
    // reads them (on FFT scenes); here that happens before each tick, outside the timing.
    let ahead = |tick: i64| {
        cache.compute_ahead(&scene, tick as f64 / hz, 1.0);
    };
    for k in 1..=30 {
        ahead(start + k);
        step(&mut world, start + k);
    }
    let mut stepping = std::time::Duration::ZERO;
    let period = std::time::Duration::from_secs_f64(1.0 / hz);
    let mut boundary = Instant::now();
    for k in 31..=30 + ticks {
        ahead(start + k);
        if paced {
            // As the server's body loop: sleep until the tick's wall-clock boundary.
            boundary += period;
            std::thread::sleep(boundary.saturating_duration_since(Instant::now()));
        }
        let t0 = Instant::now();
        step(&mut world, start + k);
        stepping += t0.elapsed();
    }
    let per_tick = stepping.as_secs_f64() / ticks as f64;
    println!(
        "{scene_id}: {bodies} bodies, {ticks} ticks{}: {:.2} ms per tick, {:.1} µs per body; \
         {:.0}% of one core at {hz} Hz",
        if paced { " paced" } else { "" },
        per_tick * 1e3,
        per_tick * 1e6 / bodies.max(1) as f64,
        per_tick * hz * 100.0
    );
}
