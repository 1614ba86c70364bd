//! The water velocity query against the time derivative of the displacement (central
//! differences), and the FFT velocity grids against direct summation.

use crate::common;

use glam::{DVec2, DVec3};
use swell_waves::body::WaterPoint;
use swell_waves::fft::{FftBackend, FftSpec};
use swell_waves::spectrum::{SpectrumSpec, SpreadingSpec};
use swell_waves::{LayerSpec, QueryFields, QueryOptions, Surface, SurfaceAt, SurfaceSpec};

fn fft_layer(choppiness: f64) -> LayerSpec {
    LayerSpec::Fft(FftSpec {
        resolution: 32,
        tile_size: 100.0,
        choppiness,
        repeat_period: 60.0,
        spectrum: SpectrumSpec::PiersonMoskowitz { wind_speed: 8.0 },
        spreading: SpreadingSpec::default(),
        wind_direction: [1.0, 0.4],
        // No waves shorter than 8 grid cells, where the bicubic filter is accurate.
        band: Some(swell_waves::fft::Band {
            min_wavelength: 25.0,
            max_wavelength: None,
        }),
        seed: Some(5),
        backend: FftBackend::Portable,
        time_step: None,
    })
}

/// Central difference of the displacement at fixed p0: (D(t + e) − D(t − e)) / 2e.
fn dd_dt(s: &Surface, p0: DVec2, t: f64, e: f64, opts: &QueryOptions) -> DVec3 {
    let at = |t: f64| s.at(t, QueryFields::ALL, opts).unwrap().displacement(p0);
    (at(t + e) - at(t - e)) / (2.0 * e)
}

#[test]
fn analytic_velocity_is_the_time_derivative_of_displacement() {
    let mut spec = common::gerstner_spec(3, 12, 0.8);
    spec.layers.extend(common::sine_spec().layers);
    let s = Surface::new(&spec).unwrap();
    let opts = QueryOptions::default();
    for &(x, z, t) in &[(0.0, 0.0, 0.0), (13.2, -40.1, 7.3), (-300.0, 25.0, 1234.5)] {
        let p0 = DVec2::new(x, z);
        let v = s.at(t, QueryFields::HEIGHT, &opts).unwrap().velocity(p0);
        let fd = dd_dt(&s, p0, t, 1e-4, &opts);
        // Central difference error ~ e²·|d³D/dt³| ≤ 1e-8·Σ A·ω³ plus rounding 1e-16/1e-4.
        assert!((v - fd).length() < 1e-6, "{v} vs {fd} at {x} {z} {t}");
        let r = s
            .at(t, QueryFields::HEIGHT, &opts)
            .unwrap()
            .velocity_reference(p0);
        assert!((v - r).length() < 1e-9, "{v} vs reference {r}");
    }
}

#[test]
fn a_single_gerstner_particle_circles_at_omega_a() {
    // Q = 1: the particle runs round a circle of radius A at angular speed ω, so |v| = ω·A.
    let spec: SurfaceSpec = serde_json::from_value(serde_json::json!({"layers": [{"kind": "gerstner",
        "waves": [{"amplitude": 0.8, "wavelength": 30.0, "direction": [0.6, 0.8], "steepness": 1.0}]}]}))
    .unwrap();
    let s = Surface::new(&spec).unwrap();
    let w = s.layers()[0].waves()[0];
    for i in 0..20 {
        let t = 0.37 * i as f64;
        let v = s
            .at(t, QueryFields::HEIGHT, &QueryOptions::default())
            .unwrap()
            .velocity(DVec2::new(1.0, 2.0));
        assert!((v.length() - w.omega * 0.8).abs() < 1e-12);
    }
}

#[test]
fn fft_velocity_grid_matches_direct_summation_and_time_difference() {
    for chop in [0.0, 1.0] {
        let spec = SurfaceSpec {
            seed: 1,
            gravity: 9.81,
            depth: None,
            layers: vec![fft_layer(chop)],
        };
        let s = Surface::new(&spec).unwrap();
        let swell_waves::Layer::Fft(layer) = &s.layers()[0] else {
            unreachable!()
        };
        let opts = QueryOptions::default();
        let t = 17.25;
        let sea = s.at(t, QueryFields::HEIGHT, &opts).unwrap().with_velocity();
        let frame = layer.velocity_frame(t);
        assert_eq!(frame.transforms(), if chop > 0.0 { 3 } else { 1 });
        // Scale: the largest particle speed is about Σ ω·|h̃|; compare relative to the r.m.s.
        let mut rms = 0.0;
        let mut worst: f64 = 0.0;
        let n = 32;
        for i in 0..n {
            // At grid nodes the grid is exact (up to FFT rounding).
            let node = DVec2::new(i as f64 * 100.0 / 32.0, (i * 7 % 32) as f64 * 100.0 / 32.0);
            let g = sea.velocity(node);
            let r = layer.velocity_reference(node, t);
            rms += r.length_squared() / n as f64;
            worst = worst.max((g - r).length());
        }
        let rms = rms.sqrt();
        assert!(rms > 0.01, "sea too calm to test: {rms}");
        assert!(
            worst < 1e-9 * rms.max(1.0),
            "node error {worst} (rms {rms})"
        );
        // Between nodes the bicubic filter: within a few percent of the r.m.s. (the same
        // filter error as the height grid's on a sea of waves ≥ 8 cells long).
        let mut worst: f64 = 0.0;
        for i in 0..50 {
            let p = DVec2::new(3.7 * i as f64 + 0.3, -2.9 * i as f64 + 0.8);
            worst = worst.max((sea.velocity(p) - layer.velocity_reference(p, t)).length());
        }
        assert!(worst < 0.05 * rms, "between nodes {worst} vs rms {rms}");
        // The reference is the time derivative of the reference displacement (ω quantised the
        // same way in both).
        let p = DVec2::new(12.5, 40.0);
        let e = 1e-4;
        let d = |t: f64| layer.sample_reference(p, t).displacement;
        let fd = (d(t + e) - d(t - e)) / (2.0 * e);
        let v = layer.velocity_reference(p, t);
        assert!((v - fd).length() < 1e-6 * rms.max(1.0), "{v} vs {fd}");
        // Without velocity grids the snapshot falls back to the (same) direct sum.
        let plain = s.at(t, QueryFields::HEIGHT, &opts).unwrap();
        assert_eq!(plain.velocity(p), v);
    }
}

#[test]
fn velocity_at_a_world_point_follows_the_particle_found_by_inversion() {
    let s = Surface::new(&common::gerstner_spec(9, 6, 0.7)).unwrap();
    let sea = s
        .at(4.0, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap();
    let world = DVec2::new(5.0, -3.0);
    let source = sea.invert(world, false).source;
    assert_eq!(sea.velocity_at(world), sea.velocity(source));
    // Filtered water query with no filter: same height bits as the plain query.
    let w = sea.water_at(world, 0.0);
    assert_eq!(w.height.to_bits(), sea.height(world.x, world.y).to_bits());
    assert_eq!(w.velocity, sea.velocity(source));
    // With every wave filtered out the water is flat and still.
    let w = sea.water_at(world, 1e6);
    assert_eq!((w.height, w.velocity), (0.0, DVec3::ZERO));
}

/// Regression (issue 11): `water_at` turned a NaN height into 0 (its inversion kept only
/// iterates with a residual below +inf, so a NaN first iterate left the initial 0 in place),
/// where `height` answers NaN. A body there read calm water instead of being rolled back by the
/// step's finiteness check. Both must now agree, NaN included.
#[test]
fn issue_11_water_at_reports_nan_like_height_does() {
    let s = Surface::new(&common::gerstner_spec(9, 6, 0.7)).unwrap();
    let sea = s
        .at(4.0, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap();
    let far = DVec2::new(f64::INFINITY, 0.0);
    assert!(sea.height(far.x, far.y).is_nan());
    let w = sea.water_at(far, 0.0);
    assert!(
        w.height.is_nan(),
        "water_at said {} where height is NaN",
        w.height
    );
}

#[test]
fn velocity_frames_from_the_caller_must_match_the_layers() {
    let s = Surface::new(&common::gerstner_spec(9, 6, 0.7)).unwrap();
    let sea = s
        .at(4.0, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap();
    let e = sea.with_velocity_frames(vec![]).unwrap_err();
    assert_eq!(e.field(), "velocity_frames");
}

/// The bodies' fast path: `water_lanes` (vectorised inversion, analytic velocities taken from
/// its own `sin_cos`) against `water_at` one point at a time, bit for bit, on seeded random
/// points: steep Gerstner (inversion), Gerstner plus an FFT layer, an FFT layer before Gerstner
/// waves (velocities summed after), sine only (no horizontal motion), Gerstner plus wave particles (which the filter also
/// drops), with and without a filter that drops waves (the
/// per-point fallback), under both inversion methods, NaN points included; and warm-started
/// (`water_lanes_from` against `water_at_from`), which lands on the cold start's solution.
/// The lane kernel is `#[inline(always)]` (the body step's hot loop): every call site compiles
/// the whole vectorised inversion again, ~25 s of a cold build each, so the test calls it from
/// this one place.
#[inline(never)]
fn lanes_from(
    sea: &SurfaceAt<'_>,
    pts: &[DVec2; 4],
    starts: &[DVec2; 4],
    min_wavelength: f64,
) -> [WaterPoint; 4] {
    sea.water_lanes_from(pts, starts, min_wavelength)
}

#[test]
fn water_lanes_equal_water_at_bit_for_bit() {
    let mut mixed = common::gerstner_spec(5, 8, 0.9);
    mixed.layers.push(fft_layer(1.2));
    let mut with_particles = common::gerstner_spec(3, 4, 0.6);
    with_particles.layers.push(
        serde_json::from_value(serde_json::json!({"kind": "particles", "radius": 4.0}))
            .expect("a particle layer"),
    );
    // An FFT layer before the analytic ones: velocities summed after the inversion, not in it.
    let mut fft_first = common::gerstner_spec(4, 5, 0.6);
    fft_first.layers.insert(0, fft_layer(1.0));
    let seas = [
        Surface::new(&common::gerstner_spec(9, 6, 0.7)).unwrap(),
        Surface::new(&mixed).unwrap(),
        Surface::new(&fft_first).unwrap(),
        Surface::new(&common::sine_spec()).unwrap(),
        Surface::new(&with_particles).unwrap(),
    ];
    // SplitMix64 → uniform in [lo, hi): seeded, no RNG crate needed.
    let mut state = 11u64;
    let mut uniform = |lo: f64, hi: f64| {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        lo + (hi - lo) * ((z >> 11) as f64 / (1u64 << 53) as f64)
    };
    for s in &seas {
        for method in [
            swell_waves::InversionMethod::Newton,
            swell_waves::InversionMethod::FixedPoint,
        ] {
            let mut opts = QueryOptions::default();
            opts.inversion.method = method;
            opts.inversion.tolerance = 1e-4;
            let sea = s
                .at(7.25, QueryFields::HEIGHT, &opts)
                .unwrap()
                .with_velocity();
            for min_wavelength in [0.0, 30.0] {
                for _ in 0..200 {
                    let mut pts: [DVec2; 4] = std::array::from_fn(|_| {
                        DVec2::new(uniform(-300.0, 300.0), uniform(-300.0, 300.0))
                    });
                    if uniform(0.0, 1.0) < 0.05 {
                        pts[2] = DVec2::new(f64::NAN, 1.0);
                    }
                    // `water_lanes` is `water_lanes_from` with the points as their own starts.
                    let lanes = lanes_from(&sea, &pts, &pts, min_wavelength);
                    // Warm starts, as a body's later substeps use them: a few cm off.
                    let starts: [DVec2; 4] = std::array::from_fn(|l| {
                        pts[l] + DVec2::new(uniform(-0.05, 0.05), uniform(-0.05, 0.05))
                    });
                    let warm = lanes_from(&sea, &pts, &starts, min_wavelength);
                    let bits = |v: DVec3| v.to_array().map(f64::to_bits);
                    for (l, p) in pts.iter().enumerate() {
                        let one = sea.water_at(*p, min_wavelength);
                        assert_eq!(lanes[l].height.to_bits(), one.height.to_bits(), "{p}");
                        assert_eq!(bits(lanes[l].velocity), bits(one.velocity), "{p}");
                        assert_eq!(
                            bits(lanes[l].source.extend(0.0)),
                            bits(one.source.extend(0.0))
                        );
                        let from = sea.water_at_from(*p, starts[l], min_wavelength);
                        assert_eq!(warm[l].height.to_bits(), from.height.to_bits(), "{p}");
                        assert_eq!(bits(warm[l].velocity), bits(from.velocity), "{p}");
                        // The same solution as a cold start, within the tolerance's reach.
                        if one.height.is_finite() && from.height.is_finite() {
                            let moved = (warm[l].source - lanes[l].source).length();
                            assert!(moved < 0.05, "{p}: sources {moved} m apart");
                        }
                    }
                }
            }
        }
    }
}

/// An FFT layer like the built-in `open-sea`'s and `storm`'s (1 m grid, so the same shortest
/// waves), on a smaller tile for speed.
fn wind_sea(choppiness: f64, wind_speed: f64) -> Surface {
    let spec: SurfaceSpec = serde_json::from_value(serde_json::json!({"seed": 42, "layers": [
        {"kind": "fft", "resolution": 64, "tile_size": 64, "choppiness": choppiness,
         "repeat_period": 200, "wind_direction": [1, 0.3],
         "spectrum": {"kind": "jonswap", "wind_speed": wind_speed, "fetch": 100000, "gamma": 3.3}}]}))
    .unwrap();
    Surface::new(&spec).unwrap()
}

/// The largest difference between two velocity frames over every node and between nodes, and
/// the largest speed of the first, m/s.
fn frame_gap(
    a: &swell_waves::fft::FftVelocityFrame,
    b: &swell_waves::fft::FftVelocityFrame,
) -> (f64, f64) {
    let filter = swell_waves::fft::SampleFilter::Bicubic;
    let (mut gap, mut top) = (0.0_f64, 0.0_f64);
    for i in 0..64 * 64 {
        let p = DVec2::new((i % 64) as f64 + 0.25, (i / 64) as f64 + 0.5);
        let (va, vb) = (a.sample(p, filter), b.sample(p, filter));
        gap = gap.max((va - vb).length());
        top = top.max(va.length());
    }
    (gap, top)
}

/// The grid velocity (central differences of grid frames, no transform) against the transformed
/// rate: each mode is scaled by sin(ωΔ)/(ωΔ), so the gap is about (ωΔ)²/6 of the speed of the
/// shortest waves, far below 0.1 % of the sea's top speed.
#[test]
fn grid_velocity_is_the_transformed_rate_within_the_central_difference_error() {
    for (chop, wind) in [(1.0, 10.0), (2.6, 20.0), (0.0, 10.0)] {
        let s = wind_sea(chop, wind);
        let swell_waves::Layer::Fft(layer) = &s.layers()[0] else {
            unreachable!()
        };
        let fields =
            swell_waves::fft::FftFields::HEIGHT.union(swell_waves::fft::FftFields::DISPLACEMENT);
        let frame_at = |k: u64| Some(std::sync::Arc::new(layer.grid_frame(k, fields)));
        // On a grid time, and between two (20.5625 s: a binary fraction, so t + T is exact).
        assert!(layer.grid_position(20.5625).weight > 0.0);
        for t in [layer.grid_time(1234), 20.5625] {
            let grid = layer.grid_velocity_frame(t, frame_at).unwrap();
            assert_eq!(grid.transforms(), 0);
            let exact = layer.velocity_frame(t);
            let (gap, top) = frame_gap(&exact, &grid);
            eprintln!(
                "choppiness {chop}, U10 {wind} m/s, t = {t:.4}: gap {gap:.2e} m/s, top speed {top:.2} m/s"
            );
            assert!(top > 0.1, "sea too calm to test: {top}");
            assert!(gap < 1e-3 * top, "gap {gap} m/s vs top speed {top} m/s");
            // The same bits a repeat period later (indices wrap modulo M).
            let later = layer
                .grid_velocity_frame(t + layer.repeat_period(), frame_at)
                .unwrap();
            if t == 20.5625 {
                assert_eq!(frame_gap(&grid, &later).0, 0.0);
            }
        }
        // A frame at another time, or without the displacement grids, is refused.
        let t = layer.grid_time(600);
        assert!(layer.grid_velocity_frame(t, |_| None).is_none());
        let wrong = |k: u64| Some(std::sync::Arc::new(layer.grid_frame(k + 1, fields)));
        assert!(layer.grid_velocity_frame(t, wrong).is_none());
        let bare = |k: u64| {
            Some(std::sync::Arc::new(
                layer.grid_frame(k, swell_waves::fft::FftFields::SLOPES),
            ))
        };
        assert!(layer.grid_velocity_frame(t, bare).is_none());
    }
}

/// `with_grid_velocity` reads the frames `at` gives, and falls back to the transformed rate
/// where it gives none (and with exact time sampling).
#[test]
fn with_grid_velocity_uses_grid_frames_and_falls_back_to_transforms() {
    let s = wind_sea(1.0, 10.0);
    let opts = QueryOptions::default();
    let t = 30.0;
    let p = DVec2::new(3.3, -7.9);
    let at = |t: f64| s.at(t, QueryFields::HEIGHT, &opts).ok();
    let from_grid = s
        .at(t, QueryFields::HEIGHT, &opts)
        .unwrap()
        .with_grid_velocity(at);
    let transformed = s.at(t, QueryFields::HEIGHT, &opts).unwrap().with_velocity();
    let none = s
        .at(t, QueryFields::HEIGHT, &opts)
        .unwrap()
        .with_grid_velocity(|_| None);
    assert_eq!(none.velocity(p), transformed.velocity(p));
    let (g, x) = (from_grid.velocity(p), transformed.velocity(p));
    assert_ne!(g, x, "the grid velocity is a difference, not the transform");
    assert!((g - x).length() < 1e-3 * x.length().max(0.1), "{g} vs {x}");
    let exact = QueryOptions {
        time: swell_waves::TimeSampling::Exact,
        ..opts
    };
    let a = s
        .at(t, QueryFields::HEIGHT, &exact)
        .unwrap()
        .with_grid_velocity(|t| s.at(t, QueryFields::HEIGHT, &exact).ok());
    let b = s
        .at(t, QueryFields::HEIGHT, &exact)
        .unwrap()
        .with_velocity();
    assert_eq!(a.velocity(p), b.velocity(p));
}

/// Snapshots through a `FrameMemo` are the snapshots `Surface::at` makes, bit for bit, and the
/// memo keeps at most `FrameMemo::CAPACITY` frames.
#[test]
fn frame_memo_snapshots_equal_fresh_ones() {
    let s = wind_sea(1.0, 10.0);
    let opts = QueryOptions::default();
    let memo = swell_waves::FrameMemo::new();
    for k in 0..20 {
        let t = 40.0 + f64::from(k) / 90.0;
        let fresh = s.at(t, QueryFields::HEIGHT, &opts).unwrap();
        // Twice: the second from the memo.
        for _ in 0..2 {
            let memo_at = s.at_memo(t, QueryFields::HEIGHT, &opts, &memo).unwrap();
            for p in common::points(k as u64, 8, (0.0, 0.0), 50.0) {
                assert_eq!(
                    memo_at.height(p.x, p.y).to_bits(),
                    fresh.height(p.x, p.y).to_bits(),
                    "t = {t}, {p}"
                );
            }
        }
    }
    assert!(memo.len() <= swell_waves::FrameMemo::CAPACITY);
}
