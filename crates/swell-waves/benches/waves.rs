//! Per-point cost of each layer and query, FFT frame cost by resolution and fields, and the
//! portable vs native FFT backends. A naive scalar loop with std sin/cos sits in the same bench
//! so speed-ups are ratios measured in one run.
//!
//! Run: `cargo bench -p swell-waves --bench waves` (add `-- --quick` for a fast pass). The
//! `targets/*` groups hold the performance targets, each next to its yardstick so the
//! ratio comes from one run; `docs/performance.md` records them.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec2;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlannerScalar};
use serde_json::json;
use swell_waves::fft::{FftFields, FftGrid, SampleFilter};
use swell_waves::simd::{SimdLevel, force_simd_level};
use swell_waves::wave::SurfaceSample;
use swell_waves::{
    Inversion, InversionMethod, Layer, QueryFields, QueryOptions, Surface, SurfaceSpec, wave::Wave,
};

mod common;
use common::{gerstner16, naive_gerstner_normal};

const POINTS: usize = 4096;

fn surface(v: serde_json::Value) -> Surface {
    let spec: SurfaceSpec = serde_json::from_value(v).unwrap();
    Surface::new(&spec).unwrap()
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

/// Plain bilinear lookup of a periodic N×N grid (N a power of two) at world (x, z): the
/// yardstick for the model's grid sampling.
fn plain_bilinear(g: &[f64], n: usize, inv_cell: f64, x: f64, z: f64) -> f64 {
    let (gx, gz) = (x * inv_cell, z * inv_cell);
    let (fx0, fz0) = (gx.floor(), gz.floor());
    let (fx, fz) = (gx - fx0, gz - fz0);
    let m = n as i64 - 1;
    let (i, j) = ((fx0 as i64 & m) as usize, (fz0 as i64 & m) as usize);
    let (i1, j1) = ((i + 1) & (n - 1), (j + 1) & (n - 1));
    let r0 = (1.0 - fx) * g[j * n + i] + fx * g[j * n + i1];
    let r1 = (1.0 - fx) * g[j1 * n + i] + fx * g[j1 * n + i1];
    (1.0 - fz) * r0 + fz * r1
}

/// The bare 2-D inverse real transforms a frame needs, one per grid: N/2 column FFTs and N/2
/// packed row FFTs of length N each (RustFFT's scalar planner, as the portable backend), on
/// preallocated buffers, nothing else.
struct BareTransforms {
    fft: std::sync::Arc<dyn Fft<f64>>,
    cols: Vec<Complex<f64>>,
    rows: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
    /// Output buffers and scratch of the out-of-place form.
    cols_out: Vec<Complex<f64>>,
    rows_out: Vec<Complex<f64>>,
    oop_scratch: Vec<Complex<f64>>,
}

impl BareTransforms {
    fn new(n: usize) -> Self {
        let fft = FftPlannerScalar::new().plan_fft_inverse(n);
        let z = Complex::new(0.0, 0.0);
        let scratch = vec![z; fft.get_inplace_scratch_len()];
        let oop_scratch = vec![z; fft.get_outofplace_scratch_len()];
        Self {
            fft,
            cols: vec![Complex::new(0.1, 0.2); n / 2 * n],
            rows: vec![Complex::new(0.3, 0.4); n / 2 * n],
            scratch,
            cols_out: vec![z; n / 2 * n],
            rows_out: vec![z; n / 2 * n],
            oop_scratch,
        }
    }
    /// The same transforms out of place (RustFFT's in-place call is this plus a copy back of
    /// each transform): the cheapest way to run them, so the fairest yardstick.
    fn run_out_of_place(&mut self, grids: usize) {
        for _ in 0..grids {
            self.fft.process_outofplace_with_scratch(
                &mut self.cols,
                &mut self.cols_out,
                &mut self.oop_scratch,
            );
            self.fft.process_outofplace_with_scratch(
                &mut self.rows,
                &mut self.rows_out,
                &mut self.oop_scratch,
            );
        }
    }
    fn run(&mut self, grids: usize) {
        for _ in 0..grids {
            self.fft
                .process_with_scratch(&mut self.cols, &mut self.scratch);
            self.fft
                .process_with_scratch(&mut self.rows, &mut self.scratch);
        }
    }
}

/// The targets, each beside its yardstick.
fn targets(c: &mut Criterion) {
    let pts = points();
    let mut g = c.benchmark_group("targets");
    g.sample_size(20);
    g.throughput(Throughput::Elements(POINTS as u64));

    // 1. 16-wave Gerstner displacement + normal, batch vs naive std sin/cos.
    let s = gerstner16(0.9);
    let sea = s
        .at(10.0, QueryFields::ALL, &QueryOptions::default())
        .unwrap();
    let waves = s.layers()[0].waves().to_vec();
    let mut naive = vec![[0.0; 6]; POINTS];
    g.bench_function("gerstner16_disp_normal/naive_std_sincos", |b| {
        b.iter(|| naive_gerstner_normal(&waves, black_box(&pts), 10.0, &mut naive))
    });
    let mut buf = vec![SurfaceSample::default(); POINTS];
    let mut normals = vec![glam::DVec3::ZERO; POINTS];
    g.bench_function("gerstner16_disp_normal/batch", |b| {
        b.iter(|| {
            sea.sample_batch(black_box(&pts), true, &mut buf);
            for (n, s) in normals.iter_mut().zip(&buf) {
                *n = s.normal();
            }
        })
    });

    // The same outputs from the single-precision fast path (`Precision::F32`): f64 phase
    // reduction, f32 sin/cos, sums and normals.
    let mut fast = vec![swell_waves::SurfacePointF32::default(); POINTS];
    g.bench_function("gerstner16_disp_normal/batch_f32", |b| {
        b.iter(|| sea.displacement_normal_f32(black_box(&pts), &mut fast))
    });

    // 2. Height with inversion to ≤ 1 mm at S = 0.9 vs one displacement evaluation. Newton
    // with a 1 mm residual tolerance (the accuracy report shows the default settings reach
    // 0.003 mm and Newton × 3 0.0003 mm at S = 0.9).
    g.bench_function("height_S0.9/one_displacement_evaluation", |b| {
        b.iter(|| sea.sample_batch(black_box(&pts), false, &mut buf))
    });
    let mm = QueryOptions {
        inversion: Inversion {
            method: InversionMethod::Newton,
            iterations: 8,
            tolerance: 1e-3,
        },
        ..Default::default()
    };
    let sea_mm = s.at(10.0, QueryFields::HEIGHT, &mm).unwrap();
    let mut res = vec![Default::default(); POINTS];
    g.bench_function("height_S0.9/newton_to_1mm", |b| {
        b.iter(|| sea_mm.query_batch_into(black_box(&pts), QueryFields::HEIGHT, &mut res))
    });
    g.finish();

    // 3. FFT frame 256² all fields vs the bare transforms; height-only vs full.
    let mut g = c.benchmark_group("targets_fft");
    g.sample_size(10);
    let s = fft_surface(256, "portable", 1.0);
    let mut bare = BareTransforms::new(256);
    g.bench_function("frame256/bare_8_inverse_real_transforms", |b| {
        b.iter(|| bare.run(8))
    });
    g.bench_function(
        "frame256/bare_8_inverse_real_transforms_out_of_place",
        |b| b.iter(|| bare.run_out_of_place(8)),
    );
    g.bench_function("frame256/all_fields", |b| {
        b.iter(|| s.fft_frame(0, black_box(10.0), FftFields::ALL))
    });
    g.bench_function("frame256/height_only", |b| {
        b.iter(|| s.fft_frame(0, black_box(10.0), FftFields::HEIGHT))
    });
    // The same frames recycling the previous frame's grids (what a tick loop does): no fresh
    // pages from the OS for the output.
    let layer = match &s.layers()[0] {
        Layer::Fft(f) => f,
        _ => unreachable!(),
    };
    let mut recycled = layer.frame(10.0, FftFields::ALL);
    g.bench_function("frame256/all_fields_recycled", |b| {
        b.iter(|| layer.frame_into(black_box(10.0), FftFields::ALL, &mut recycled))
    });
    let mut recycled_h = layer.frame(10.0, FftFields::HEIGHT);
    g.bench_function("frame256/height_only_recycled", |b| {
        b.iter(|| layer.frame_into(black_box(10.0), FftFields::HEIGHT, &mut recycled_h))
    });
    g.finish();

    // 4. Bilinear FFT-grid height sample vs one plain bilinear lookup of the same grid.
    let mut g = c.benchmark_group("targets_sample");
    g.sample_size(20);
    g.throughput(Throughput::Elements(POINTS as u64));
    let frame = s.fft_frame(0, 10.0, FftFields::HEIGHT).unwrap();
    let grid = frame.grid(FftGrid::Height).unwrap().to_vec();
    let layer_n = match &s.layers()[0] {
        Layer::Fft(f) => f.resolution(),
        _ => unreachable!(),
    };
    let inv_cell = layer_n as f64 / 256.0;
    g.bench_function("height_bilinear/plain_lookup", |b| {
        b.iter(|| {
            pts.iter()
                .map(|p| plain_bilinear(&grid, layer_n, inv_cell, black_box(p.x), p.y))
                .sum::<f64>()
        })
    });
    // The target row: the height accessor, which reads the height grid only.
    g.bench_function("height_bilinear/frame_sample_height", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&p| frame.sample_height(black_box(p), SampleFilter::Bilinear))
                .sum::<f64>()
        })
    });
    // The full sample (every grid the frame has; here only height) and its `.displacement.y`:
    // what this row measured before `sample_height` existed.
    g.bench_function("height_bilinear/frame_sample_full", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&p| {
                    frame
                        .sample(black_box(p), SampleFilter::Bilinear)
                        .displacement
                        .y
                })
                .sum::<f64>()
        })
    });
    g.finish();
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
    // The portable frame at each SIMD level this CPU has (the same bits at every level; the
    // rows above run at the widest).
    let s = fft_surface(256, "portable", 1.0);
    for level in SimdLevel::available() {
        force_simd_level(Some(level));
        g.bench_function(format!("portable_256_all_fields_{}", level.name()), |b| {
            b.iter(|| s.fft_frame(0, black_box(10.0), FftFields::ALL))
        });
    }
    force_simd_level(None);
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

criterion_group!(benches, targets, analytic, fft);
criterion_main!(benches);
