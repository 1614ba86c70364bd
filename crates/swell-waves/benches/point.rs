//! What one height at "now" costs the model: a snapshot at a new t and one point, as the
//! server's `GET /v1/scenes/{id}/height` does it, on the built-in `harbour` sea (two Gerstner
//! waves under 512 ambient wave particles at three scales) beside `lake` (Gerstner only). Every
//! iteration moves t on by 17 µs (a server answering ~60k queries a second at now) and takes
//! the next of 1,024 seeded points, so nothing is reused that a real query could not reuse.
//! The ratio `harbour/lake` is the figure to read (same process, so machine speed cancels).
//!
//! Run: `cargo bench -p swell-waves --bench point` (add `-- --quick` for a fast pass).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec2;
use serde_json::json;
use swell_waves::math::SwellRng;
use swell_waves::{QueryFields, QueryOptions, Surface, SurfaceSpec};

fn surface(v: serde_json::Value) -> Surface {
    let spec: SurfaceSpec = serde_json::from_value(v).unwrap();
    Surface::new(&spec).unwrap()
}

/// The built-in `harbour` scene's surface (src/scene/builtin.rs).
fn harbour() -> Surface {
    surface(json!({"seed": 21, "layers": [
        {"kind": "gerstner", "waves": [
            {"amplitude": 0.12, "wavelength": 26, "direction": [1, 0.3], "steepness": 0.4},
            {"amplitude": 0.05, "wavelength": 9, "direction": [0.2, 1], "steepness": 0.4, "phase": 1.3}
        ]},
        {"kind": "particles", "count": 512, "tile_size": 32, "radius": 1.0, "amplitude": 0.03,
         "scales": [0.33, 0.66, 1.0],
         "ripples": {"particles": 8, "decay": 30, "floor": 0.0001, "lifetime": 60}}
    ]}))
}

/// The built-in `lake` scene's surface.
fn lake() -> Surface {
    surface(json!({"seed": 7, "depth": 12, "layers": [
        {"kind": "gerstner",
         "waves": [{"amplitude": 0.25, "wavelength": 22, "direction": [1, 0.4], "steepness": 0.5}],
         "cascade": {"wavelength": 8, "amplitude": 0.08, "steepness": 0.5, "direction": [1, 0.4]}}
    ]}))
}

/// 1,024 seeded points in a 400 m square.
fn points() -> Vec<DVec2> {
    let mut rng = SwellRng::new(29, 4);
    (0..1024)
        .map(|_| DVec2::new(rng.uniform() * 400.0 - 200.0, rng.uniform() * 400.0 - 200.0))
        .collect()
}

fn point(c: &mut Criterion) {
    let pts = points();
    let mut g = c.benchmark_group("point_height_now");
    for (name, s) in [("lake", lake()), ("harbour", harbour())] {
        let (mut t, mut i) = (1.0e6, 0usize);
        g.bench_function(name, |b| {
            b.iter(|| {
                t += 17.0e-6;
                i = (i + 1) & 1023;
                let sea = s
                    .at(t, QueryFields::HEIGHT, &QueryOptions::default())
                    .unwrap();
                black_box(sea.query(pts[i], QueryFields::HEIGHT).height)
            });
        });
    }
    g.finish();
}

criterion_group!(benches, point);
criterion_main!(benches);
