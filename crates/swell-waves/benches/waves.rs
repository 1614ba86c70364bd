//! Per-point cost of each layer and query, FFT frame cost by resolution and fields, and the
//! portable vs native FFT backends. A naive scalar loop with std sin/cos sits in the same bench
//! so speed-ups are ratios measured in one run.
//!
//! Run: `cargo bench -p swell-waves --bench waves` (add `-- --quick` for a fast pass).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec2;
use serde_json::json;
use swell_waves::fft::{FftFields, SampleFilter};
use swell_waves::{QueryFields, QueryOptions, Surface, SurfaceSpec, wave::Wave};

const POINTS: usize = 4096;

fn surface(v: serde_json::Value) -> Surface {
    let spec: SurfaceSpec = serde_json::from_value(v).unwrap();
    Surface::new(&spec).unwrap()
}

fn gerstner16(fold: f64) -> Surface {
    let waves: Vec<_> = (0..16)
        .map(|i| {
            let l = 4.0 + 6.0 * i as f64;
            let ka = 0.1;
            let a = (i as f64 * 2.399).sin_cos();
            json!({"amplitude": ka * l / std::f64::consts::TAU, "wavelength": l,
                   "direction": [a.1, a.0], "phase": i as f64, "steepness": fold / (16.0 * ka)})
        })
        .collect();
    surface(json!({"layers": [{"kind": "gerstner", "waves": waves}]}))
}

fn points() -> Vec<DVec2> {
    (0..POINTS)
        .map(|i| DVec2::new((i % 64) as f64 * 1.37 - 40.0, (i / 64) as f64 * 1.91 - 60.0))
        .collect()
}

/// The naive way: one wave at a time, std sin/cos on an unreduced phase, no batching care.
fn naive_gerstner(waves: &[Wave], pts: &[DVec2], t: f64, out: &mut [[f64; 3]]) {
    for (p, o) in pts.iter().zip(out.iter_mut()) {
        let mut d = [0.0; 3];
        for w in waves {
            let th = w.wavenumber * w.direction.dot(*p) - w.omega * t + w.phase;
            let (s, c) = th.sin_cos();
            d[0] += w.steepness * w.amplitude * w.direction.x * c;
            d[1] += w.amplitude * s;
            d[2] += w.steepness * w.amplitude * w.direction.y * c;
        }
        *o = d;
    }
}

fn analytic(c: &mut Criterion) {
    let pts = points();
    let mut g = c.benchmark_group("gerstner16_per_point");
    g.throughput(Throughput::Elements(POINTS as u64));
    let s = gerstner16(0.9);
    let sea = s
        .at(10.0, QueryFields::ALL, &QueryOptions::default())
        .unwrap();
    let waves = s.layers()[0].waves().to_vec();
    let mut out = vec![[0.0; 3]; POINTS];
    g.bench_function("naive_std_sincos_displacement", |b| {
        b.iter(|| naive_gerstner(&waves, black_box(&pts), 10.0, &mut out))
    });
    g.bench_function("displacement", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&p| sea.displacement(black_box(p)).y)
                .sum::<f64>()
        })
    });
    g.bench_function("displacement_and_derivatives", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&p| sea.sample(black_box(p), true).d_dx.y)
                .sum::<f64>()
        })
    });
    g.bench_function("height_newton_default_S0.9", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&p| sea.height(black_box(p).x, p.y))
                .sum::<f64>()
        })
    });
    g.bench_function("query_all_fields", |b| {
        b.iter(|| sea.query_batch(black_box(&pts), QueryFields::ALL))
    });
    g.finish();

    let sine = surface(
        json!({"layers": [{"kind": "sine", "waves": (0..8).map(|i| json!(
        {"amplitude": 0.1, "wavelength": 3.0 + i as f64 * 5.0, "direction": [1.0, i as f64 * 0.3]})).collect::<Vec<_>>()}]}),
    );
    let sea = sine
        .at(10.0, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap();
    let mut g = c.benchmark_group("sine8_per_point");
    g.throughput(Throughput::Elements(POINTS as u64));
    g.bench_function("height", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&p| sea.height(black_box(p).x, p.y))
                .sum::<f64>()
        })
    });
    g.finish();
}

fn fft_surface(n: u32, backend: &str, choppiness: f64) -> Surface {
    surface(
        json!({"seed": 1, "layers": [{"kind": "fft", "resolution": n, "tile_size": 256.0,
        "choppiness": choppiness, "wind_direction": [1.0, 0.2], "backend": backend,
        "spectrum": {"kind": "jonswap", "wind_speed": 10.0, "fetch": 100000.0}}]}),
    )
}

fn fft(c: &mut Criterion) {
    let mut g = c.benchmark_group("fft_frame");
    g.sample_size(20);
    for n in [64u32, 128, 256, 512] {
        let s = fft_surface(n, "portable", 1.0);
        g.bench_function(format!("portable_{n}_all_fields"), |b| {
            b.iter(|| s.fft_frame(0, black_box(10.0), FftFields::ALL))
        });
        g.bench_function(format!("portable_{n}_height_only"), |b| {
            b.iter(|| s.fft_frame(0, black_box(10.0), FftFields::HEIGHT))
        });
    }
    let s = fft_surface(256, "native", 1.0);
    g.bench_function("native_256_all_fields", |b| {
        b.iter(|| s.fft_frame(0, black_box(10.0), FftFields::ALL))
    });
    g.finish();

    let pts = points();
    let s = fft_surface(256, "portable", 1.0);
    let mut g = c.benchmark_group("fft_per_point");
    g.throughput(Throughput::Elements(POINTS as u64));
    for (name, filter) in [
        ("nearest", SampleFilter::Nearest),
        ("bilinear", SampleFilter::Bilinear),
        ("bicubic", SampleFilter::Bicubic),
    ] {
        let o = QueryOptions {
            filter,
            ..Default::default()
        };
        let sea = s.at(10.0, QueryFields::ALL, &o).unwrap();
        g.bench_function(format!("displacement_{name}"), |b| {
            b.iter(|| {
                pts.iter()
                    .map(|&p| sea.displacement(black_box(p)).y)
                    .sum::<f64>()
            })
        });
        g.bench_function(format!("height_newton_{name}"), |b| {
            b.iter(|| {
                pts.iter()
                    .map(|&p| sea.height(black_box(p).x, p.y))
                    .sum::<f64>()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, analytic, fft);
criterion_main!(benches);
