//! The in-process yardstick of P6 (`docs/performance.md`, "Load"): points per second of a
//! 4,096-point height batch on a built-in scene, through the same `run_sample` the HTTP handler
//! calls, with no transport or encoding. `swell-load sample --points 4096` over HTTP is reported
//! as a ratio to this.
//!
//! ```sh
//! cargo run --release --example inprocess_batch -- [scene] [points] [seconds] [threads]
//! ```
//! Defaults: `lake 4096 5 2`. `threads` callers run batches at once (match the load tool's
//! `--concurrency`). Scene time is fixed at t = 60 s, as in the HTTP run (`--t 60`), so an FFT
//! frame is computed once and shared, as the server's frame cache does.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use swell::frames::FrameCache;
use swell::scene::Scene;
use swell::service::types::SampleRequest;

/// The batches' time: fixed, as in the HTTP runs this is compared with (`--t 60`).
const AT: swell::service::query::At = swell::service::query::At { t: 60.0, now: 60.0 };

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_id = args.first().map_or("lake", String::as_str).to_owned();
    let points: usize = args.get(1).map_or(4096, |s| s.parse().expect("points"));
    let seconds: f64 = args.get(2).map_or(5.0, |s| s.parse().expect("seconds"));
    let threads: usize = args.get(3).map_or(2, |s| s.parse().expect("threads"));
    let (_, spec) = swell::scene::builtin::specs()
        .into_iter()
        .find(|(id, _)| *id == scene_id)
        .unwrap_or_else(|| panic!("{scene_id} is not a built-in scene"));
    let scene = Arc::new(Scene::build(&scene_id, spec).expect("built-in scenes build"));
    let frames = Arc::new(FrameCache::new(32));
    let limits = Arc::new(swell::Limits::default());
    // Points in the load tool's default area (±1000 m), from a fixed LCG: the values do not
    // matter to the cost, only their count.
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut unit = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let req = Arc::new(SampleRequest {
        t: Some(60.0),
        points: (0..points)
            .map(|_| [unit() * 2000.0 - 1000.0, unit() * 2000.0 - 1000.0])
            .collect(),
        ..Default::default()
    });
    // Warm-up: the first call computes the scene's frame at t = 60 (FFT scenes).
    swell::service::query::run_sample(&frames, &limits, &scene, AT, &req).expect("a valid request");
    let done = Arc::new(AtomicU64::new(0));
    let end = Instant::now() + Duration::from_secs_f64(seconds);
    let start = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..threads {
            let (frames, limits, scene, req, done) = (&frames, &limits, &scene, &req, &done);
            s.spawn(move || {
                while Instant::now() < end {
                    let r = swell::service::query::run_sample(frames, limits, scene, AT, req)
                        .expect("a valid request");
                    assert_eq!(r.height.map(|h| h.len()), Some(points));
                    done.fetch_add(1, Ordering::Relaxed);
                }
            });
        }
    });
    let secs = start.elapsed().as_secs_f64();
    let batches = done.load(Ordering::Relaxed);
    println!(
        "{scene_id}: {points}-point height batches in process, {threads} threads: {batches} in {secs:.2} s = {:.1} batches/s, {:.0} points/s",
        batches as f64 / secs,
        (batches * points as u64) as f64 / secs
    );
}
