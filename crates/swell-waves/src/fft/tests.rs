//! Cross-cutting tests of the FFT layer against direct summation and against the physics it
//! promises. Every density here is synthetic (a smooth bump in k): the real spectra live in
//! `spectrum` and are glued on with one closure.

use glam::DVec2;
use rustfft::num_complex::Complex;

use super::*;
use crate::math::{SwellRng, TAU, mode_key};
use crate::spectrum::{Dispersion, SpectrumSpec};

fn spec(resolution: u32, tile_size: f64) -> FftSpec {
    FftSpec {
        resolution,
        tile_size,
        choppiness: 1.0,
        repeat_period: 200.0,
        spectrum: SpectrumSpec::PiersonMoskowitz { wind_speed: 10.0 },
        spreading: Default::default(),
        wind_direction: [1.0, 0.0],
        band: None,
        seed: None,
        backend: FftBackend::Portable,
        time_step: None,
    }
}

/// A wind sea in wave-vector form: a Gaussian ring around wavelength `peak_wavelength` (width
/// σ_k = 0.2·k_p), spread as `(0.15 + max(0, k̂·x̂))²` about +x, scaled so that the continuous
/// ∫∫E dk is roughly `(hs/4)²`. Smooth, directional (E(k) ≠ E(−k)) and zero nowhere.
fn bump(peak_wavelength: f64, hs: f64) -> impl Fn(DVec2) -> f64 {
    let kp = TAU / peak_wavelength;
    let sigma = 0.2 * kp;
    // ∫ ring dk ≈ 2π·kp·sqrt(2π)·σ; mean of the directional factor over θ ≈ 0.33.
    let norm = (hs / 4.0).powi(2) / (TAU * kp * (TAU).sqrt() * sigma * 0.33);
    move |k: DVec2| {
        let len = k.length();
        let ring = (-(len - kp) * (len - kp) / (2.0 * sigma * sigma)).exp();
        let d = 0.15 + (k.x / len).max(0.0);
        norm * ring * d * d
    }
}

fn layer_with(spec: &FftSpec, seed: u64, density: impl Fn(DVec2) -> f64) -> FftLayer {
    FftLayer::from_density(spec, seed, Dispersion::default(), "layers[0]", density).unwrap()
}

fn hs(layer: &FftLayer) -> f64 {
    4.0 * layer.variance().sqrt()
}

/// Node (i, j) as a world point.
fn node(layer: &FftLayer, i: usize, j: usize) -> DVec2 {
    let h = layer.tile_size() / layer.resolution() as f64;
    DVec2::new(i as f64 * h, j as f64 * h)
}

/// The eight values of a sample, in [`FftGrid::ALL`] order.
fn values(s: &FftSample) -> [f64; 8] {
    [
        s.displacement.y,
        s.displacement.x,
        s.displacement.z,
        s.slope.x,
        s.slope.y,
        s.jacobian.x,
        s.jacobian.y,
        s.jacobian.z,
    ]
}

fn bits(frame: &FftFrame) -> Vec<u64> {
    FftGrid::ALL
        .iter()
        .filter_map(|&g| frame.grid(g))
        .flat_map(|g| g.iter().map(|v| v.to_bits()))
        .collect()
}

#[test]
fn grid_nodes_match_direct_summation_for_all_eight_fields() {
    let layer = layer_with(&spec(32, 80.0), 11, bump(20.0, 2.0));
    let tol = 1e-9 * hs(&layer);
    assert!(hs(&layer) > 0.5, "{}", hs(&layer));
    for t in [0.0, 37.3, -5.5] {
        let frame = layer.frame(t, FftFields::ALL);
        for j in 0..32 {
            for i in 0..32 {
                let r = values(&layer.sample_reference(node(&layer, i, j), t));
                for g in FftGrid::ALL {
                    let v = frame.grid(g).unwrap()[j * 32 + i];
                    assert!(
                        (v - r[g.index()]).abs() <= tol,
                        "{g:?} ({i},{j}) t={t}: {v} vs {}",
                        r[g.index()]
                    );
                }
            }
        }
    }
}

/// Waves of at least 8 grid cells (the band cuts shorter ones): Catmull–Rom is within 0.2% of Hs
/// for h and D, and within 0.2% of Hs·k_max for slopes and Jacobian terms, at random points.
/// (Measured worst over 300 points: 0.07% for h, 0.06% for D, ≤ 0.035% for the rest.)
#[test]
fn bicubic_matches_reference_at_random_points_when_well_resolved() {
    let n = 64;
    let l = 100.0;
    let mut s = spec(n, l);
    s.band = Some(Band {
        min_wavelength: 8.0 * l / f64::from(n),
        max_wavelength: None,
    });
    let layer = layer_with(&s, 5, bump(25.0, 3.0));
    let hs = hs(&layer);
    let k_max = TAU / (8.0 * l / f64::from(n));
    let t = 1234.5;
    let frame = layer.frame(t, FftFields::ALL);
    let mut rng = SwellRng::new(77, 9);
    let mut worst = [0.0f64; 8];
    for _ in 0..300 {
        let p = DVec2::new(rng.uniform() * 300.0 - 150.0, rng.uniform() * 300.0 - 150.0);
        let a = values(&frame.sample(p, SampleFilter::Bicubic));
        let r = values(&layer.sample_reference(p, t));
        for g in 0..8 {
            let scale = if g < 3 { hs } else { hs * k_max };
            worst[g] = worst[g].max((a[g] - r[g]).abs() / scale);
        }
    }
    for (g, w) in worst.iter().enumerate() {
        assert!(*w < 0.002, "{:?}: {w}", FftGrid::ALL[g]);
    }
    // Bilinear and nearest are coarser but still bounded.
    let p = DVec2::new(13.37, -42.1);
    let r = layer.sample_reference(p, t).displacement.y;
    assert!((frame.sample(p, SampleFilter::Bilinear).displacement.y - r).abs() < 0.1 * hs);
    assert!((frame.sample(p, SampleFilter::Nearest).displacement.y - r).abs() < 0.5 * hs);
}

#[test]
fn far_points_are_finite_and_match_the_reference() {
    let n = 64;
    let l = 100.0;
    let mut s = spec(n, l);
    s.band = Some(Band {
        min_wavelength: 8.0 * l / f64::from(n),
        max_wavelength: None,
    });
    let layer = layer_with(&s, 6, bump(25.0, 3.0));
    let hs = hs(&layer);
    let t = 86_400.25;
    let frame = layer.frame(t, FftFields::ALL);
    for p in [
        DVec2::new(1e7, -1e7),
        DVec2::new(1e7 + 0.123, 9_999_999.77),
        DVec2::new(-1e7 - 3.3, 2.5e6),
    ] {
        let a = frame.sample(p, SampleFilter::Bicubic);
        let r = layer.sample_reference(p, t);
        for (v, w) in values(&a).iter().zip(values(&r)) {
            assert!(v.is_finite());
            assert!(
                (v - w).abs() < 0.01 * hs * TAU / (8.0 * l / f64::from(n)),
                "{p}: {v} vs {w}"
            );
        }
        assert!((a.displacement.y - r.displacement.y).abs() < 0.01 * hs);
    }
    // A far point reads the same as the point one whole number of tiles back.
    let near = frame.sample(DVec2::new(37.5, 12.5), SampleFilter::Bicubic);
    let far = frame.sample(DVec2::new(37.5 + 1e7, 12.5 - 1e7), SampleFilter::Bicubic);
    assert_eq!(near, far);
}

#[test]
fn backends_agree_and_portable_frames_repeat_bit_for_bit() {
    let mut s = spec(128, 200.0);
    let portable = layer_with(&s, 21, bump(30.0, 2.5));
    s.backend = FftBackend::Native;
    let native = layer_with(&s, 21, bump(30.0, 2.5));
    let hs = hs(&portable);
    let k_max = TAU / (2.0 * 200.0 / 128.0);
    let a = portable.frame(99.9, FftFields::ALL);
    let b = native.frame(99.9, FftFields::ALL);
    for g in FftGrid::ALL {
        let scale = if g.index() < 3 { hs } else { hs * k_max };
        for (x, y) in a.grid(g).unwrap().iter().zip(b.grid(g).unwrap()) {
            assert!((x - y).abs() <= 1e-12 * scale, "{g:?}: {x} vs {y}");
        }
    }
    assert!(bits(&a) == bits(&portable.frame(99.9, FftFields::ALL)));
    // A height-only frame holds the same height bits as the full frame.
    let h = portable.frame(99.9, FftFields::HEIGHT);
    assert_eq!(h.grid(FftGrid::Height), a.grid(FftGrid::Height));
}

#[test]
fn frames_one_repeat_period_apart_are_bit_identical() {
    let layer = layer_with(&spec(64, 100.0), 3, bump(20.0, 2.0));
    // Pairs (t, t + T) with t + T exact in f64 (t and t + T in the same binade, or integers).
    for t in [1e9, 12_345.678, -37.25, 1.5e-3 + 1024.0] {
        let a = layer.frame(t, FftFields::ALL);
        let b = layer.frame(t + 200.0, FftFields::ALL);
        assert!(bits(&a) == bits(&b), "t = {t}");
        let p = DVec2::new(3.3, 4.4);
        assert_eq!(
            layer.sample_reference(p, t),
            layer.sample_reference(p, t + 200.0)
        );
    }
    // And the sea does move in between.
    let a = layer.frame(1e9, FftFields::HEIGHT);
    let b = layer.frame(1e9 + 3.0, FftFields::HEIGHT);
    assert!(bits(&a) != bits(&b));
}

/// Σ over the full plane of |h̃(k, t)|², with h̃ built here from h0 and std trigonometry.
fn spectral_energy(layer: &FftLayer, t: f64) -> f64 {
    let h = (layer.resolution() / 2) as i32;
    let dk = TAU / layer.tile_size();
    let w0 = TAU / layer.repeat_period();
    let d = Dispersion::default();
    let mut sum = 0.0;
    for m in 1 - h..h {
        for q in 1 - h..h {
            let w = (d.omega(f64::from(m * m + q * q).sqrt() * dk) / w0).floor() * w0;
            let ht = layer.h0(m, q) * Complex::from_polar(1.0, -w * t)
                + layer.h0(-m, -q).conj() * Complex::from_polar(1.0, w * t);
            sum += ht.norm_sqr();
        }
    }
    sum
}

#[test]
fn parseval_grid_mean_square_equals_spectral_energy_and_expected_m0() {
    let n = 64;
    let l = 150.0;
    let density = bump(25.0, 2.0);
    let dk = TAU / l;
    // Expected discrete m0: Σ_k E(k)·Δk² over the kept modes.
    let mut expected = 0.0;
    for m in -31..32 {
        for q in -31..32 {
            if (m, q) != (0, 0) {
                expected += density(DVec2::new(f64::from(m), f64::from(q)) * dk) * dk * dk;
            }
        }
    }
    let t = 17.0;
    let seeds = 24;
    let mut mean = 0.0;
    for seed in 0..seeds {
        let layer = layer_with(&spec(n, l), 1000 + seed, &density);
        let frame = layer.frame(t, FftFields::HEIGHT);
        let g = frame.grid(FftGrid::Height).unwrap();
        let ms = g.iter().map(|v| v * v).sum::<f64>() / g.len() as f64;
        let e = spectral_energy(&layer, t);
        assert!((ms - e).abs() <= 1e-10 * e, "seed {seed}: {ms} vs {e}");
        mean += ms / seeds as f64;
    }
    assert!((mean / expected - 1.0).abs() < 0.1, "{mean} vs {expected}");
}

#[test]
fn variance_is_the_time_average_of_the_mean_square() {
    let layer = layer_with(&spec(32, 60.0), 8, bump(15.0, 1.0));
    // Over one repeat period the cross terms h0(k)·h0(−k) average out exactly (ω_q ≠ 0 for all
    // kept modes here: the longest wave, 60 m, has ω ≈ 1.01 rad/s ≫ 2π/200).
    let steps = 400;
    let mut avg = 0.0;
    for s in 0..steps {
        avg += spectral_energy(&layer, 200.0 * f64::from(s) / f64::from(steps)) / f64::from(steps);
    }
    assert!(
        (avg / layer.variance() - 1.0).abs() < 1e-9,
        "{avg} vs {}",
        layer.variance()
    );
}

#[test]
fn amplitudes_are_keyed_by_mode_numbers_not_grid_size() {
    let l = 120.0;
    let dk = TAU / l;
    // Zero beyond 30·Δk, so everything lies inside the 64² grid (|m|, |n| ≤ 31).
    let base = bump(20.0, 2.0);
    let density = move |k: DVec2| if k.length() < 30.0 * dk { base(k) } else { 0.0 };
    let small = layer_with(&spec(64, l), 42, &density);
    let large = layer_with(&spec(128, l), 42, &density);
    for m in -31..32 {
        for q in -31..32 {
            assert_eq!(small.h0(m, q), large.h0(m, q), "({m}, {q})");
        }
    }
    // The draw is the specified one: Gaussian pair of PCG32 keyed by (seed, m, n).
    let (g1, g2) = SwellRng::new(mode_key(42, 5, -3), 0).gaussian_pair();
    let s = (density(DVec2::new(5.0, -3.0) * dk) * dk * dk / 4.0).sqrt();
    assert_eq!(small.h0(5, -3), Complex::new(g1 * s, g2 * s));
    // Same sea: node (i, j) of the 64² grid is node (2i, 2j) of the 128² grid.
    let hs = hs(&small);
    let a = small.frame(55.5, FftFields::ALL);
    let b = large.frame(55.5, FftFields::ALL);
    for g in FftGrid::ALL {
        let (ga, gb) = (a.grid(g).unwrap(), b.grid(g).unwrap());
        for j in 0..64 {
            for i in 0..64 {
                let (x, y) = (ga[j * 64 + i], gb[2 * j * 128 + 2 * i]);
                assert!(
                    (x - y).abs() <= 1e-12 * hs.max(1.0),
                    "{g:?} ({i},{j}): {x} vs {y}"
                );
            }
        }
    }
}

/// One wave: density non-zero only at k0 = Δk·(4, 0).
fn single_mode(choppiness: f64) -> (FftLayer, f64, f64) {
    let mut s = spec(32, 64.0);
    s.choppiness = choppiness;
    let dk = TAU / 64.0;
    let k0 = DVec2::new(4.0 * dk, 0.0);
    let layer = layer_with(&s, 9, move |k: DVec2| {
        if (k - k0).length() < 0.25 * dk {
            0.5
        } else {
            0.0
        }
    });
    (layer, k0.x, dk)
}

#[test]
fn single_mode_is_a_wave_travelling_along_plus_k() {
    let (layer, k, dk) = single_mode(0.0);
    assert_eq!(layer.modes(), 32 * 32 - 1 - (2 * 32 - 1));
    let h0 = layer.h0(4, 0);
    // h = 2|h0|·cos(k·x − ω_q·t + arg h0), with E|h0|² = E·Δk²/2.
    let amp = 2.0 * h0.norm();
    let (g1, g2) = SwellRng::new(mode_key(9, 4, 0), 0).gaussian_pair();
    assert!((amp - 2.0 * (g1 * g1 + g2 * g2).sqrt() * (0.5 * dk * dk / 4.0).sqrt()).abs() < 1e-15);
    assert!((layer.variance() - amp * amp / 2.0).abs() < 1e-15);
    let w0 = TAU / 200.0;
    let w = ((9.81 * k).sqrt() / w0).floor() * w0;
    let phi = h0.arg();
    let t = 3.7;
    let frame = layer.frame(t, FftFields::HEIGHT);
    let g = frame.grid(FftGrid::Height).unwrap();
    for j in 0..32 {
        for i in 0..32 {
            let x = i as f64 * 2.0;
            let want = amp * (k * x - w * t + phi).cos();
            assert!((g[j * 32 + i] - want).abs() < 1e-12, "({i},{j})");
        }
    }
    // After dt = Δx/c the whole pattern has moved one cell towards +x.
    let dt = 2.0 * k / w;
    let later = layer.frame(t + dt, FftFields::HEIGHT);
    let g2 = later.grid(FftGrid::Height).unwrap();
    for i in 0..32 {
        assert!((g2[(i + 1) % 32] - g[i]).abs() < 1e-12 * amp, "{i}");
        // Not towards −x.
    }
    assert!((0..32).any(|i| (g2[(i + 31) % 32] - g[i]).abs() > 0.1 * amp));
}

#[test]
fn single_mode_with_choppiness_crowds_points_under_the_crest() {
    let (layer, k, _) = single_mode(1.0);
    let amp = 2.0 * layer.h0(4, 0).norm();
    let frame = layer.frame(10.0, FftFields::ALL);
    let h = frame.grid(FftGrid::Height).unwrap();
    let dx = frame.grid(FftGrid::DisplacementX).unwrap();
    let jxx = frame.grid(FftGrid::DxDx).unwrap();
    let row = 5 * 32;
    let crest = (0..32)
        .max_by(|&a, &b| h[row + a].total_cmp(&h[row + b]))
        .unwrap();
    let trough = (0..32)
        .min_by(|&a, &b| h[row + a].total_cmp(&h[row + b]))
        .unwrap();
    // Displaced spacing across the crest is shorter than across the trough.
    let span = |c: usize| {
        let (a, b) = ((c + 31) % 32, (c + 1) % 32);
        (4.0 + dx[row + b]) - dx[row + a]
    };
    assert!(
        span(crest) < 4.0 && span(trough) > 4.0,
        "{} {}",
        span(crest),
        span(trough)
    );
    // ∂Dx/∂x ≈ −λ·A·k under the crest and +λ·A·k under the trough (8 cells per wave: the
    // nearest node is within π/8 of the extremum, cos(π/8) ≈ 0.92).
    assert!(jxx[row + crest] < -0.9 * amp * k && jxx[row + trough] > 0.9 * amp * k);
    // The Gerstner relation: for h = A sin θ, Dx = λ·A·cos θ, so Dx² + h² = A² (λ = 1).
    for i in 0..32 {
        assert!((dx[row + i].powi(2) + h[row + i].powi(2) - amp * amp).abs() < 1e-12);
    }
    // No displacement across the wave (it travels along x).
    assert!(
        frame
            .grid(FftGrid::DisplacementZ)
            .unwrap()
            .iter()
            .all(|v| v.abs() < 1e-15)
    );
}

#[test]
fn diagonal_wave_travels_along_its_wave_vector() {
    let dk = TAU / 64.0;
    let k0 = DVec2::new(-3.0 * dk, 2.0 * dk);
    let layer = layer_with(&spec(32, 64.0), 4, move |k: DVec2| {
        if (k - k0).length() < 0.25 * dk {
            1.0
        } else {
            0.0
        }
    });
    let w0 = TAU / 200.0;
    let w = ((9.81 * k0.length()).sqrt() / w0).floor() * w0;
    let c = w / k0.length();
    let dt = 0.8;
    let dir = k0.normalize();
    let amp = 2.0 * layer.h0(-3, 2).norm();
    for p in [DVec2::new(1.0, 2.0), DVec2::new(-30.0, 17.5)] {
        let now = layer.sample_reference(p, 5.0).displacement.y;
        let ahead = layer
            .sample_reference(p + dir * c * dt, 5.0 + dt)
            .displacement
            .y;
        let behind = layer
            .sample_reference(p - dir * c * dt, 5.0 + dt)
            .displacement
            .y;
        assert!((now - ahead).abs() < 1e-9 * amp, "{now} vs {ahead}");
        assert!((now - behind).abs() > 1e-3 * amp);
    }
}

#[test]
fn frames_count_one_transform_per_grid() {
    let layer = layer_with(&spec(16, 50.0), 1, bump(10.0, 1.0));
    let cases = [
        (FftFields::NONE, 0),
        (FftFields::HEIGHT, 1),
        (FftFields::HEIGHT | FftFields::SLOPES, 3),
        (FftFields::DISPLACEMENT.union(FftFields::JACOBIAN), 5),
        (FftFields::ALL, 8),
    ];
    for (fields, count) in cases {
        let frame = layer.frame(0.0, fields);
        assert_eq!(frame.transforms(), count, "{fields:?}");
        assert_eq!(fields.grid_count(), count);
        for g in FftGrid::ALL {
            assert_eq!(frame.grid(g).is_some(), fields.has(g));
        }
    }
    // Fields not computed read as zero.
    let s = layer
        .frame(1.0, FftFields::HEIGHT)
        .sample(DVec2::new(3.0, 4.0), SampleFilter::Bicubic);
    assert_ne!(s.displacement.y, 0.0);
    assert_eq!((s.displacement.x, s.displacement.z), (0.0, 0.0));
    assert_eq!(s.slope, DVec2::ZERO);
    assert_eq!(s.jacobian, glam::DVec3::ZERO);
}

#[test]
fn zero_density_gives_a_flat_sea_without_nan() {
    let layer = layer_with(&spec(32, 100.0), 2, |_| 0.0);
    assert_eq!(layer.variance(), 0.0);
    let frame = layer.frame(12.0, FftFields::ALL);
    for g in FftGrid::ALL {
        assert!(frame.grid(g).unwrap().iter().all(|&v| v == 0.0), "{g:?}");
    }
    let p = DVec2::new(1e7, -3.0);
    assert_eq!(frame.sample(p, SampleFilter::Bicubic), FftSample::default());
    assert_eq!(layer.sample_reference(p, 12.0), FftSample::default());
}

#[test]
fn band_keeps_only_wavelengths_in_range() {
    let l = 100.0;
    let mut s = spec(64, l);
    s.band = Some(Band {
        min_wavelength: 10.0,
        max_wavelength: Some(25.0),
    });
    let layer = layer_with(&s, 1, |_| 1.0);
    let mut count = 0;
    let dk = TAU / l;
    for m in -31..32i32 {
        for q in -31..32i32 {
            // The documented recipe, rounding included (2π/|k| for k = (m, n)·Δk).
            let wl = TAU / DVec2::new(f64::from(m) * dk, f64::from(q) * dk).length();
            let kept = (10.0..25.0).contains(&wl);
            assert_eq!(layer.h0(m, q) != Complex::new(0.0, 0.0), kept, "({m},{q})");
            count += usize::from(kept);
        }
    }
    assert_eq!(layer.modes(), count);
    // Nyquist (m = −32) and out-of-grid modes are empty.
    assert_eq!(layer.h0(-32, 0), Complex::new(0.0, 0.0));
    assert_eq!(layer.h0(40, 0), Complex::new(0.0, 0.0));
}

#[test]
fn validation_errors_name_the_field() {
    let ok = spec(64, 100.0);
    let build =
        |s: &FftSpec| FftLayer::from_density(s, 1, Dispersion::default(), "layers[2]", |_| 1.0);
    assert!(build(&ok).is_ok());
    type Edit = Box<dyn Fn(&mut FftSpec)>;
    let cases: Vec<(Edit, &str)> = vec![
        (Box::new(|s| s.resolution = 48), "layers[2].resolution"),
        (Box::new(|s| s.resolution = 8), "layers[2].resolution"),
        (Box::new(|s| s.resolution = 2048), "layers[2].resolution"),
        (Box::new(|s| s.tile_size = 0.0), "layers[2].tile_size"),
        (
            Box::new(|s| s.tile_size = f64::INFINITY),
            "layers[2].tile_size",
        ),
        (Box::new(|s| s.choppiness = -0.1), "layers[2].choppiness"),
        (Box::new(|s| s.choppiness = 10.5), "layers[2].choppiness"),
        (
            Box::new(|s| s.choppiness = f64::NAN),
            "layers[2].choppiness",
        ),
        (
            Box::new(|s| s.repeat_period = -1.0),
            "layers[2].repeat_period",
        ),
        (
            Box::new(|s| s.wind_direction = [0.0, 0.0]),
            "layers[2].wind_direction",
        ),
        (
            Box::new(|s| s.wind_direction = [f64::NAN, 1.0]),
            "layers[2].wind_direction[0]",
        ),
        (
            Box::new(|s| {
                s.band = Some(Band {
                    min_wavelength: -1.0,
                    max_wavelength: None,
                })
            }),
            "layers[2].band.min_wavelength",
        ),
        (
            Box::new(|s| {
                s.band = Some(Band {
                    min_wavelength: 5.0,
                    max_wavelength: Some(5.0),
                })
            }),
            "layers[2].band.max_wavelength",
        ),
    ];
    for (edit, field) in cases {
        let mut s = ok.clone();
        edit(&mut s);
        let err = build(&s).unwrap_err();
        assert_eq!(err.field(), field, "{err}");
    }
    let err = FftLayer::from_density(&ok, 1, Dispersion::default(), "layers[2]", |k| {
        if k.x > 1.0 { f64::NAN } else { 1.0 }
    })
    .unwrap_err();
    assert_eq!(err.field(), "layers[2].spectrum");
    let err =
        FftLayer::from_density(&ok, 1, Dispersion::default(), "layers[2]", |_| -1.0).unwrap_err();
    assert_eq!(err.field(), "layers[2].spectrum");
}

#[test]
fn layer_is_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<FftLayer>();
    check::<FftFrame>();
}

/// Frames reuse pooled scratch (spectra, row buffers, FFT scratch): a frame computed after
/// others, on dirty buffers, and frames computed on several threads at once must equal a frame
/// from a freshly built layer, bit for bit.
#[test]
fn pooled_scratch_does_not_change_frames() {
    let s = spec(32, 100.0);
    let fresh = layer_with(&s, 4, bump(20.0, 2.0));
    let want = bits(&fresh.frame(13.5, FftFields::ALL));
    let used = layer_with(&s, 4, bump(20.0, 2.0));
    let _ = used.frame(99.0, FftFields::ALL);
    let _ = used.frame(1.0, FftFields::SLOPES);
    assert_eq!(bits(&used.frame(13.5, FftFields::ALL)), want);
    // Recycling an old frame's grids gives the same bits (every value is overwritten).
    let mut recycled = used.frame(50.0, FftFields::ALL);
    used.frame_into(13.5, FftFields::ALL, &mut recycled);
    assert_eq!(bits(&recycled), want);
    used.frame_into(13.5, FftFields::HEIGHT, &mut recycled);
    assert_eq!(recycled.fields(), FftFields::HEIGHT);
    assert_eq!(bits(&recycled), bits(&fresh.frame(13.5, FftFields::HEIGHT)));
    std::thread::scope(|scope| {
        let hs: Vec<_> = (0..3)
            .map(|_| scope.spawn(|| bits(&used.frame(13.5, FftFields::ALL))))
            .collect();
        for h in hs {
            assert_eq!(h.join().unwrap(), want);
        }
    });
}

/// Time interpolation between two frames: exact at both ends, linear in between.
#[test]
fn sample_between_interpolates_linearly_in_time() {
    let layer = layer_with(&spec(32, 100.0), 4, bump(20.0, 2.0));
    let (a, b) = (
        layer.frame(10.0, FftFields::ALL),
        layer.frame(10.1, FftFields::ALL),
    );
    let p = DVec2::new(3.3, -7.1);
    let f = SampleFilter::Bicubic;
    assert_eq!(
        values(&sample_between(&a, &b, 10.0, p, f)),
        values(&a.sample(p, f))
    );
    assert_eq!(
        values(&sample_between(&a, &b, 10.1, p, f)),
        values(&b.sample(p, f))
    );
    let mid = values(&sample_between(&a, &b, 10.05, p, f));
    let (va, vb) = (values(&a.sample(p, f)), values(&b.sample(p, f)));
    for i in 0..8 {
        assert!((mid[i] - 0.5 * (va[i] + vb[i])).abs() < 1e-12);
    }
    // And it is close to the exact frame at the middle time for a short tick.
    let exact = values(&layer.frame(10.05, FftFields::ALL).sample(p, f));
    assert!(
        (mid[0] - exact[0]).abs() < 0.01,
        "{} vs {}",
        mid[0],
        exact[0]
    );
}

/// The evolution gathers (sin, cos) from a table of the distinct ω_q; it must give exactly the
/// bits of evaluating each entry's own phase, `sin_cos(reduce_phase(ω_q·t_r))`, which is what the
/// recipe and the golden vectors specify.
#[test]
fn evolution_table_equals_the_per_entry_phase_bit_for_bit() {
    use crate::math::{reduce_phase, sin_cos};
    let mut long = spec(128, 300.0);
    long.repeat_period = 1.0e5;
    for (spec, density) in [
        (spec(256, 256.0), bump(40.0, 2.0)),
        (spec(64, 80.0), bump(10.0, 1.0)),
        (long, bump(30.0, 3.0)),
    ] {
        let layer = layer_with(&spec, 11, density);
        // With T = 200 s the table is ~1% of the entries (187 of 32 768 at 256²); a long T makes
        // it larger (every ω distinct in the limit) but never wrong.
        if spec.repeat_period == 200.0 {
            assert!(layer.phase_omegas.len() < layer.half.len() / 8);
        }
        let mut table = vec![Complex::new(0.0, 0.0); layer.half.len()];
        let mut phases = Vec::new();
        for t in [0.0f64, 0.1, 10.0, 77.7, 199.999, -3.25, 1.0e7 + 0.5] {
            let t_r = t.rem_euclid(layer.repeat_period);
            layer.evolve_into(t_r, &mut phases, &mut table);
            for (mode, h) in layer.half.iter().zip(&table) {
                let want = if mode.is_empty() {
                    Complex::new(0.0, 0.0)
                } else {
                    let (s, c) = sin_cos(reduce_phase(mode.omega_q * t_r));
                    mode.evolve(s, c)
                };
                assert_eq!(
                    (h.re.to_bits(), h.im.to_bits()),
                    (want.re.to_bits(), want.im.to_bits()),
                    "t = {t}, omega_q = {}",
                    mode.omega_q
                );
            }
        }
    }
}

/// The one-grid accessors read exactly what `sample` reads, for every filter and grid, and 0 for
/// grids the frame lacks; so do the partial reads of `sample_some` (the inversion's and the
/// height queries'), which read several grids at once (`Stencil::read_many`) and leave the rest
/// at 0. `sample` itself reads all eight at once when the frame has them all, so this also pins
/// `read_many` against `read`, grid by grid.
#[test]
fn sample_height_and_sample_grid_equal_sample_bit_for_bit() {
    let layer = layer_with(&spec(32, 50.0), 3, bump(12.0, 1.5));
    let mut rng = SwellRng::new(8, 1);
    for fields in [FftFields::ALL, FftFields::HEIGHT, FftFields::SLOPES] {
        let frame = layer.frame(4.5, fields);
        for _ in 0..300 {
            let (a, b) = rng.gaussian_pair();
            let p0 = DVec2::new(a * 80.0, b * 80.0);
            for filter in [
                SampleFilter::Nearest,
                SampleFilter::Bilinear,
                SampleFilter::Bicubic,
            ] {
                let all = values(&frame.sample(p0, filter));
                assert_eq!(frame.sample_height(p0, filter).to_bits(), all[0].to_bits());
                for (g, v) in FftGrid::ALL.into_iter().zip(all) {
                    assert_eq!(frame.sample_grid(g, p0, filter).to_bits(), v.to_bits());
                }
                // Newton's read: the displacement grids' bits, and in the Jacobian slots the
                // interpolant's derivatives (`newton_jacobian`), never the Jacobian grids.
                let nj = frame.newton_jacobian(p0);
                let newton = [all[0], all[1], all[2], 0.0, 0.0, nj.x, nj.y, nj.z];
                for (reads, want) in [
                    (
                        FftReads::Displacement,
                        [all[0], all[1], all[2], 0.0, 0.0, 0.0, 0.0, 0.0],
                    ),
                    (FftReads::Newton, newton),
                    (FftReads::All, all),
                ] {
                    let some = values(&frame.sample_some(p0, filter, reads));
                    for (g, (w, v)) in want.iter().zip(some).enumerate() {
                        assert_eq!(v.to_bits(), w.to_bits(), "{reads:?} grid {g}");
                    }
                }
            }
        }
    }
}

/// Dropped frames hand their grids to the layer, and the next frames reuse them (no fresh pages)
/// with unchanged bits; the pool keeps at most one full frame's grids.
#[test]
fn dropped_frames_recycle_their_grids_without_changing_bits() {
    let s = spec(32, 100.0);
    let fresh = layer_with(&s, 4, bump(20.0, 2.0));
    let want = bits(&fresh.frame(13.5, FftFields::ALL));
    let layer = layer_with(&s, 4, bump(20.0, 2.0));
    let old = layer.frame(77.0, FftFields::ALL);
    let old_ptrs: Vec<_> = FftGrid::ALL
        .iter()
        .map(|&g| old.grid(g).unwrap().as_ptr())
        .collect();
    // A clone holds its own copies; dropping both offers 16 grids to a pool that keeps 8.
    let copy = old.clone();
    drop(old);
    drop(copy);
    let again = layer.frame(13.5, FftFields::ALL);
    assert_eq!(bits(&again), want);
    let reused = FftGrid::ALL
        .iter()
        .filter(|&&g| old_ptrs.contains(&again.grid(g).unwrap().as_ptr()))
        .count();
    assert!(reused > 0, "no grid buffer was reused");
    assert!(layer.grid_pool.free.lock().unwrap().len() <= FftGrid::ALL.len());
    // A recycled frame's unused grids go back to the pool too.
    let mut r = layer.frame(5.0, FftFields::ALL);
    layer.frame_into(13.5, FftFields::HEIGHT, &mut r);
    assert_eq!(bits(&r), bits(&fresh.frame(13.5, FftFields::HEIGHT)));
}

/// The frames' column-wise multiplier pass (`apply_column`, wave vectors in parts) gives
/// `apply`'s bits on each mode's own `kx`, `kz`, `1/|k|`, empty entries included, on real
/// layers: full band, a band-limited one (whole empty regions) and one with zero energy.
#[test]
fn column_multiplier_pass_equals_the_per_mode_formula_bit_for_bit() {
    let mut limited = spec(32, 300.0);
    limited.band = Some(crate::fft::Band {
        min_wavelength: 30.0,
        max_wavelength: Some(150.0),
    });
    let layers = [
        layer_with(&spec(64, 500.0), 3, bump(60.0, 2.0)),
        layer_with(&limited, 4, bump(60.0, 2.0)),
        layer_with(&spec(16, 100.0), 5, |_| 0.0),
    ];
    for layer in &layers {
        let n = layer.resolution();
        let mut htilde = vec![Complex::new(0.0, 0.0); n / 2 * n];
        let mut phases = Vec::new();
        layer.evolve_into(37.5, &mut phases, &mut htilde);
        let mut out = vec![Complex::new(0.0, 0.0); n];
        for grid in FftGrid::ALL {
            for m in 0..n / 2 {
                let span = m * n..(m + 1) * n;
                let h = &htilde[span.clone()];
                let inv = &layer.inv_ks[span.clone()];
                let kx = layer.kx_cols[m];
                grid.apply_column(kx, &layer.kz_rows, inv, layer.choppiness, h, &mut out);
                for ((o, mode), h) in out.iter().zip(&layer.half[span]).zip(h) {
                    let want = grid.apply(mode.kx, mode.kz, mode.inv_k, layer.choppiness, *h);
                    assert_eq!(
                        (o.re.to_bits(), o.im.to_bits()),
                        (want.re.to_bits(), want.im.to_bits()),
                        "{grid:?} column {m}"
                    );
                }
            }
        }
    }
}

/// `FftFrame::newton_jacobian` against its slow reference: central differences of the bicubic
/// read itself (`sample` with `Bicubic`, ±1e-4 of a grid step), on seeded random points, wrapped
/// ones included. It is the derivative of the function Newton solves. And it is the sea's
/// Jacobian: within a few per cent of the spectral Jacobian grids on a spectrum resolved by the
/// grid (peak 12 m on a 50/64 m grid).
#[test]
fn the_newton_jacobian_is_the_derivative_of_the_bicubic_read() {
    let layer = layer_with(&spec(64, 50.0), 5, bump(12.0, 1.5));
    let frame = layer.frame(7.25, FftFields::ALL);
    let h = 1e-4 * 50.0 / 64.0;
    let d = |p: DVec2| frame.sample(p, SampleFilter::Bicubic).displacement;
    let mut rng = SwellRng::new(21, 1);
    let (mut worst_fd, mut worst_sea, mut scale): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for k in 0..400 {
        let (a, b) = rng.gaussian_pair();
        // Every tenth point on the tile's wrapping edge.
        let p0 = if k % 10 == 0 {
            DVec2::new(50.0 * (k / 10) as f64 - 1e-3, b * 30.0)
        } else {
            DVec2::new(a * 60.0, b * 60.0)
        };
        let j = frame.newton_jacobian(p0);
        let ddx = (d(p0 + DVec2::X * h) - d(p0 - DVec2::X * h)) / (2.0 * h);
        let ddz = (d(p0 + DVec2::Y * h) - d(p0 - DVec2::Y * h)) / (2.0 * h);
        let fd = [ddx.x, ddz.z, 0.5 * (ddz.x + ddx.z)];
        let sea = frame.sample(p0, SampleFilter::Bicubic).jacobian;
        for (got, (want, grid)) in [j.x, j.y, j.z]
            .into_iter()
            .zip(fd.into_iter().zip([sea.x, sea.y, sea.z]))
        {
            assert!(got.is_finite());
            worst_fd = worst_fd.max((got - want).abs());
            worst_sea = worst_sea.max((got - grid).abs());
            scale = scale.max(grid.abs());
        }
    }
    assert!(
        scale > 0.1,
        "the test sea is too flat to tell: max |J| {scale}"
    );
    assert!(
        worst_fd < 1e-6,
        "against central differences of the read: {worst_fd}"
    );
    assert!(
        worst_sea < 0.05 * scale,
        "against the Jacobian grids: {worst_sea} (max |J| {scale})"
    );
    // No displacement grids (a height-only frame): zero.
    assert_eq!(
        layer
            .frame(7.25, FftFields::HEIGHT)
            .newton_jacobian(DVec2::new(3.0, 4.0)),
        glam::DVec3::ZERO
    );
}

/// A frame's grids start on a 64-byte boundary (the transform writes them with non-temporal
/// stores only then), clones too, and hold exactly their values.
#[test]
fn grids_start_on_a_cache_line_and_so_do_their_clones() {
    for len in [1, 256, 65_536] {
        let mut g = super::Grid::zeroed(len);
        assert_eq!(g.len(), len);
        assert_eq!(g.as_ptr() as usize % 64, 0, "len {len}");
        g[len - 1] = 3.0;
        let c = g.clone();
        assert_eq!(c.as_ptr() as usize % 64, 0, "clone, len {len}");
        assert_eq!(&*c, &*g);
    }
    let layer = layer_with(&spec(64, 500.0), 3, bump(60.0, 2.0));
    let frame = layer.frame(2.0, FftFields::ALL);
    for grid in FftGrid::ALL {
        let g = frame.grid(grid).expect("all fields");
        assert_eq!(g.as_ptr() as usize % 64, 0, "{grid:?}");
    }
}
