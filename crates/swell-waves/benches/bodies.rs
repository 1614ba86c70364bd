//! Floating-body step cost: one box body (default 4 × 2 cells) per tick, and 1,000 bodies per
//! tick, on a calm analytic sea (8 Gerstner waves, fold 0.5) and on the same sea plus a 64²
//! FFT layer (frames and velocity grids computed once per tick and shared by every body).
//! The share of one core that 1,000 bodies at 30 Hz take is `30 × (time per 1,000-body tick)`.
//!
//! Run: `cargo bench -p swell-waves --bench bodies` (add `-- --quick` for a fast pass).

mod common;

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use serde_json::json;
use swell_waves::body::{BodySpec, BodyState, World, WorldSettings};
use swell_waves::{QueryOptions, Surface, SurfaceSpec};

fn sea(fft: bool) -> Surface {
    let waves = common::gerstner_waves(8, 15.0, 12.0, 0.08, 0.5);
    let mut layers = vec![json!({"kind": "gerstner", "waves": waves})];
    if fft {
        layers.push(json!({"kind": "fft", "resolution": 64, "tile_size": 128.0,
            "choppiness": 0.0, "spectrum": {"kind": "pierson_moskowitz", "wind_speed": 5.0},
            "wind_direction": [1.0, 0.2]}));
    }
    let spec: SurfaceSpec = serde_json::from_value(json!({ "layers": layers })).unwrap();
    Surface::new(&spec).unwrap()
}

/// `n` 2 t boats (4 m × 2 m × 1 m, default cells, light drag) on a 30 m grid, settled for 60
/// ticks so the bench measures floating, not falling.
fn world(n: usize, s: &Surface) -> World {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let spec = BodySpec {
        linear_drag: 20_000.0,
        quadratic_drag: 1000.0,
        angular_damping: 20_000.0,
        ..BodySpec::boxed(2000.0, 4.0, 2.0, 1.0)
    };
    for i in 0..n {
        let p = DVec3::new((i % 32) as f64 * 30.0, 0.25, (i / 32) as f64 * 30.0);
        w.add(&spec, BodyState::at_rest(p, i as f64 * 0.1)).unwrap();
    }
    for _ in 0..60 {
        w.step_surface(s, &QueryOptions::default()).unwrap();
    }
    w
}

fn bodies(c: &mut Criterion) {
    for (name, fft) in [("gerstner8", false), ("gerstner8+fft64", true)] {
        let s = sea(fft);
        let mut g = c.benchmark_group(format!("bodies/{name}"));
        g.sample_size(20);
        let mut one = world(1, &s);
        g.throughput(Throughput::Elements(1));
        g.bench_function("step 1 body", |b| {
            b.iter(|| one.step_surface(black_box(&s), &QueryOptions::default()))
        });
        let mut many = world(1000, &s);
        g.throughput(Throughput::Elements(1000));
        g.bench_function("step 1000 bodies", |b| {
            b.iter(|| many.step_surface(black_box(&s), &QueryOptions::default()))
        });
        g.finish();
    }
}

criterion_group!(benches, bodies);
criterion_main!(benches);
