//! What one height at "now" costs the model: a snapshot at a new t and one point, as the
//! server's `GET /v1/scenes/{id}/height` does it, on the built-in `harbour` sea (two Gerstner
//! waves under 512 ambient wave particles at three scales) beside `lake` (Gerstner only). Every
//! iteration moves t on by 17 µs (a server answering ~60k queries a second at now) and takes
//! the next of 1,024 seeded points, so nothing is reused that a real query could not reuse.
//! The ratio `harbour/lake` is the figure to read (same process, so machine speed cancels).
//!
//! Run: `cargo bench -p swell-waves --bench point` (add `-- --quick` for a fast pass).

mod common;

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec2;
use swell_waves::math::SwellRng;
use swell_waves::{QueryFields, QueryOptions};

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
    for (name, s) in [("lake", common::lake()), ("harbour", common::harbour())] {
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
