//! What impact rings cost a query: a 2,000-point height sample on the `harbour` sea (two
//! Gerstner waves under 512 ambient wave particles) with no impacts, and with 1,024 live rings at
//! the largest size (strength 100 m, radius 1,000 m) all centred near the sampled area, so every
//! ring passes over every point. Issue 27's target: the second costs ≤ 10× the first.
//!
//! Run: `cargo bench -p swell-waves --bench impacts` (add `-- --quick` for a fast pass).

mod common;

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec2;
use swell_waves::particles::{Impact, Impacts};
use swell_waves::{QueryFields, QueryOptions};

/// 2,000 points on a 50 × 40 grid, 2 m apart.
fn points() -> Vec<DVec2> {
    (0..2000)
        .map(|i| DVec2::new((i % 50) as f64 * 2.0, (i / 50) as f64 * 2.0))
        .collect()
}

/// `n` impacts at the largest size, 2 ms apart ending at `t` (a ring of radius 1,000 m lives
/// ~4.4 s, so all are alive at `t`), centred within 50 m of (50, 40).
pub fn big_impacts(n: usize, t: f64) -> Impacts {
    let events = (0..n)
        .map(|i| {
            let a = i as f64 * 2.399;
            Impact {
                t: t - 0.002 * (n - i) as f64,
                position: [50.0 + 50.0 * a.cos(), 40.0 + 50.0 * a.sin()],
                strength: 100.0,
                radius: 1000.0,
            }
        })
        .collect();
    Impacts::from_events(events).unwrap()
}

fn impacts(c: &mut Criterion) {
    let s = common::harbour();
    let pts = points();
    let t = 1000.0;
    let mut g = c.benchmark_group("impacts");
    g.throughput(Throughput::Elements(pts.len() as u64));
    let none = Impacts::new();
    let pile = big_impacts(1024, t);
    let live = s
        .at(t, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap()
        .with_impacts(&pile)
        .unwrap()
        .particle_field(1)
        .map(|f| f.live_rings());
    assert_eq!(live, Some(1024), "every ring alive at t");
    for (name, set) in [("none", &none), ("1024_max_rings", &pile)] {
        g.bench_function(format!("sample2000_height/{name}"), |b| {
            b.iter(|| {
                let at = s
                    .at(t, QueryFields::HEIGHT, &QueryOptions::default())
                    .unwrap()
                    .with_impacts(set)
                    .unwrap();
                black_box(at.query_batch(&pts, QueryFields::HEIGHT))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, impacts);
criterion_main!(benches);
