//! FFT layers seen through the surface and query API: only the transforms a query needs,
//! physically normalised spectra (Hs = 4·sqrt(m0)), exact periodicity, grid vs direct summation.

use crate::common;

use common::points;
use glam::DVec2;
use serde_json::{Value, json};
use swell_waves::fft::{FftFields, SampleFilter};
use swell_waves::spectrum::{DirectionalSpectrum, Dispersion, SpectrumSpec, SpreadingSpec};
use swell_waves::{
    Inversion, InversionMethod, Layer, QueryFields, QueryOptions, Surface, SurfaceSpec,
};

fn surface(v: Value) -> Surface {
    let spec: SurfaceSpec = serde_json::from_value(v).unwrap();
    Surface::new(&spec).unwrap()
}

fn fft(n: u32, tile: f64, choppiness: f64, spectrum: Value, seed: u64) -> Surface {
    surface(
        json!({"seed": seed, "layers": [{"kind": "fft", "resolution": n, "tile_size": tile,
        "choppiness": choppiness, "wind_direction": [1.0, 0.3], "spectrum": spectrum,
        "spreading": {"kind": "cos2s", "s": 4.0}}]}),
    )
}

#[test]
fn a_height_only_request_runs_only_the_height_transform() {
    let flat = fft(
        64,
        200.0,
        0.0,
        json!({"kind": "jonswap", "wind_speed": 8.0, "fetch": 50000.0}),
        1,
    );
    let sea = flat
        .at(3.0, QueryFields::HEIGHT, &QueryOptions::default())
        .unwrap();
    assert_eq!(
        sea.transforms(),
        1,
        "height only, no choppiness: one inverse FFT"
    );
    // A choppy layer must invert the horizontal displacement: height + Dx + Dz, by either
    // method (Newton takes its Jacobian from the displacement grids' interpolant); the three
    // Jacobian grids only for fields that report them.
    let choppy = fft(
        64,
        200.0,
        1.0,
        json!({"kind": "jonswap", "wind_speed": 8.0, "fetch": 50000.0}),
        1,
    );
    assert_eq!(
        choppy
            .at(3.0, QueryFields::HEIGHT, &QueryOptions::default())
            .unwrap()
            .transforms(),
        3
    );
    let fp = QueryOptions {
        inversion: Inversion {
            method: InversionMethod::FixedPoint,
            ..Default::default()
        },
        ..Default::default()
    };
    assert_eq!(
        choppy
            .at(3.0, QueryFields::HEIGHT, &fp)
            .unwrap()
            .transforms(),
        3
    );
    assert_eq!(
        choppy
            .at(3.0, QueryFields::ALL, &QueryOptions::default())
            .unwrap()
            .transforms(),
        8
    );
}

#[test]
fn zero_wind_is_a_flat_sea_without_nan() {
    for spectrum in [
        json!({"kind": "phillips", "wind_speed": 0.0}),
        json!({"kind": "pierson_moskowitz", "wind_speed": 0.0}),
        json!({"kind": "jonswap", "wind_speed": 0.0, "fetch": 1000.0}),
    ] {
        let s = fft(32, 100.0, 1.0, spectrum, 3);
        let sea = s
            .at(10.0, QueryFields::ALL, &QueryOptions::default())
            .unwrap();
        for p in points(3, 50, (0.0, 0.0), 500.0) {
            let r = sea.query(p, QueryFields::ALL);
            assert_eq!(r.height, 0.0);
            assert_eq!(r.normal, glam::DVec3::Y);
            assert_eq!(r.jacobian, 1.0);
        }
    }
}

/// The generated sea's variance against the spectrum: (1) the expected variance of the modes,
/// Σ E(k)·Δk², against the analytic m0 of Pierson–Moskowitz (and the converged quadrature of
/// JONSWAP) when the grid covers the peak; (2) the realised variance of the height grid,
/// averaged over seeds, against that sum; (3) Hs = 4·sqrt(m0).
#[test]
fn generated_sea_variance_matches_the_spectrum() {
    let g = 9.81;
    for (spec_json, spectrum) in [
        (
            json!({"kind": "pierson_moskowitz", "wind_speed": 10.0}),
            SpectrumSpec::PiersonMoskowitz { wind_speed: 10.0 },
        ),
        (
            json!({"kind": "jonswap", "wind_speed": 12.0, "fetch": 100000.0}),
            SpectrumSpec::Jonswap {
                wind_speed: 12.0,
                fetch: 100000.0,
                gamma: 3.3,
            },
        ),
    ] {
        let (n, tile) = (256usize, 1600.0);
        let wind = DVec2::new(1.0, 0.3).normalize();
        let ds = DirectionalSpectrum::new(
            &spectrum,
            &SpreadingSpec::Cos2s { s: 4.0 },
            wind,
            Dispersion::default(),
            "x",
        )
        .unwrap();
        let m0 = ds.m0();
        if let SpectrumSpec::PiersonMoskowitz { wind_speed } = spectrum {
            let wp = 0.855 * g / wind_speed;
            let analytic = 0.0081 * g * g / (5.0 * wp.powi(4));
            assert!(
                (m0 / analytic - 1.0).abs() < 1e-6,
                "PM m0 {m0} vs {analytic}"
            );
        }
        // (1) Discretised spectrum over the grid's modes (|m|, |n| < N/2, k ≠ 0).
        let dk = std::f64::consts::TAU / tile;
        let half = (n / 2) as i32;
        let mut discrete = 0.0;
        for m in -half + 1..half {
            for q in -half + 1..half {
                if m != 0 || q != 0 {
                    discrete += ds.density(DVec2::new(m as f64 * dk, q as f64 * dk)) * dk * dk;
                }
            }
        }
        assert!(
            (discrete / m0 - 1.0).abs() < 0.03,
            "discrete {discrete} vs m0 {m0}"
        );
        // (2) Realised variance of the height grid, mean over seeds.
        let seeds = 12;
        let mut mean_var = 0.0;
        for seed in 0..seeds {
            let s = fft(n as u32, tile, 0.0, spec_json.clone(), seed);
            let frame = s.fft_frame(0, 17.0, FftFields::HEIGHT).unwrap();
            let h = frame.grid(swell_waves::fft::FftGrid::Height).unwrap();
            mean_var += h.iter().map(|v| v * v).sum::<f64>() / h.len() as f64 / seeds as f64;
        }
        assert!(
            (mean_var / discrete - 1.0).abs() < 0.1,
            "grid variance {mean_var} vs {discrete}"
        );
        // (3) Hs.
        assert!((ds.hs() - 4.0 * m0.sqrt()).abs() < 1e-12);
        let hs_grid = 4.0 * mean_var.sqrt();
        assert!(
            (hs_grid / ds.hs() - 1.0).abs() < 0.08,
            "Hs grid {hs_grid} vs {}",
            ds.hs()
        );
    }
}

#[test]
fn fft_surface_repeats_exactly_after_the_repeat_period() {
    let s = surface(
        json!({"seed": 5, "layers": [{"kind": "fft", "resolution": 32, "tile_size": 64.0,
        "repeat_period": 100.0, "choppiness": 1.0, "wind_direction": [0.0, 1.0],
        "spectrum": {"kind": "phillips", "wind_speed": 6.0}}]}),
    );
    for t in [1e9, 12.5, 1e9 + 0.25] {
        let a = s.at(t, QueryFields::ALL, &QueryOptions::default()).unwrap();
        let b = s
            .at(t + 100.0, QueryFields::ALL, &QueryOptions::default())
            .unwrap();
        for p in points(5, 40, (0.0, 0.0), 1e4) {
            let (ra, rb) = (a.query(p, QueryFields::ALL), b.query(p, QueryFields::ALL));
            assert_eq!(ra.height.to_bits(), rb.height.to_bits(), "t={t}");
            assert_eq!(ra.normal, rb.normal);
        }
    }
}

/// FFT grid sampling against direct f64 Fourier summation at random points, through the query
/// path (inversion included). Bound: 1% of Hs for bicubic on a sea whose shortest kept waves
/// span at least 8 grid cells; bilinear is allowed 5%.
#[test]
fn grid_heights_match_direct_summation_within_a_bound_scaled_to_hs() {
    let v = json!({"seed": 8, "layers": [{"kind": "fft", "resolution": 64, "tile_size": 256.0,
        "choppiness": 0.7, "wind_direction": [1.0, 0.3], "band": {"min_wavelength": 32.0},
        "spectrum": {"kind": "jonswap", "wind_speed": 10.0, "fetch": 80000.0}}]});
    let s = surface(v);
    let Layer::Fft(layer) = &s.layers()[0] else {
        unreachable!()
    };
    let hs = 4.0 * layer.variance().sqrt();
    let exact = QueryOptions {
        reference: true,
        ..Default::default()
    };
    let sea_ref = s.at(4.0, QueryFields::ALL, &exact).unwrap();
    for (filter, bound) in [
        (SampleFilter::Bicubic, 0.01),
        (SampleFilter::Bilinear, 0.05),
    ] {
        let o = QueryOptions {
            filter,
            ..Default::default()
        };
        let sea = s.at(4.0, QueryFields::ALL, &o).unwrap();
        let mut worst = 0.0f64;
        for p in points(8, 300, (0.0, 0.0), 2000.0) {
            worst = worst.max((sea.height(p.x, p.y) - sea_ref.height(p.x, p.y)).abs());
        }
        assert!(
            worst <= bound * hs,
            "{filter:?}: worst {worst} m vs {} m",
            bound * hs
        );
    }
}

#[test]
fn cascaded_fft_bands_do_not_double_count() {
    // Two FFT layers split at 40 m: together they hold each mode of the shared spectrum once.
    let band = |min: Option<f64>, max: Option<f64>, tile: f64| {
        json!({"kind": "fft", "resolution": 64, "tile_size": tile, "choppiness": 0.0,
               "wind_direction": [1.0, 0.0], "seed": 1,
               "band": {"min_wavelength": min.unwrap_or(0.0), "max_wavelength": max},
               "spectrum": {"kind": "pierson_moskowitz", "wind_speed": 8.0}})
    };
    let s =
        surface(json!({"layers": [band(Some(40.0), None, 512.0), band(None, Some(40.0), 64.0)]}));
    let (Layer::Fft(a), Layer::Fft(b)) = (&s.layers()[0], &s.layers()[1]) else {
        unreachable!()
    };
    // The long-wave layer has no mode shorter than 40 m and the short one none at or above it.
    for m in -31..32i32 {
        for n in -31..32i32 {
            let ka = std::f64::consts::TAU / 512.0 * ((m * m + n * n) as f64).sqrt();
            if ka > 0.0 && std::f64::consts::TAU / ka < 40.0 {
                assert_eq!(a.h0(m, n), Default::default());
            }
            let kb = std::f64::consts::TAU / 64.0 * ((m * m + n * n) as f64).sqrt();
            if kb > 0.0 && std::f64::consts::TAU / kb >= 40.0 {
                assert_eq!(b.h0(m, n), Default::default());
            }
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 24, ..Default::default() })]

    /// Random valid mixed seas (a small FFT layer plus Gerstner waves): finite outputs, unit
    /// normals, batch equal to single; the 1 mm residual holds wherever the surface does not fold.
    #[test]
    fn random_mixed_seas_are_finite_and_batch_equals_single(
        seed in 0u64..1000,
        wind in 0.0f64..25.0,
        dir in -3.0f64..3.0,
        chop in 0.0f64..0.6,
        kind in 0usize..4,
        t in -1e6f64..1e9,
        x in -1e7f64..1e7,
    ) {
        let spectrum = match kind {
            0 => json!({"kind": "phillips", "wind_speed": wind}),
            1 => json!({"kind": "pierson_moskowitz", "wind_speed": wind}),
            2 => json!({"kind": "jonswap", "wind_speed": wind, "fetch": 30000.0}),
            _ => json!({"kind": "tma", "wind_speed": wind, "fetch": 30000.0}),
        };
        let s = surface(json!({"seed": seed, "depth": 20.0, "layers": [
            {"kind": "fft", "resolution": 16, "tile_size": 50.0, "choppiness": chop,
             "wind_direction": [dir.cos(), dir.sin()], "spectrum": spectrum},
            {"kind": "gerstner", "waves": [{"amplitude": 0.3, "wavelength": 30.0, "direction": [1.0, 1.0], "steepness": 0.5}]}
        ]}));
        let sea = s.at(t, QueryFields::ALL, &QueryOptions::default()).unwrap();
        let pts = points(seed, 6, (x, -x), 100.0);
        let batch = sea.query_batch(&pts, QueryFields::ALL);
        for (p, b) in pts.iter().zip(&batch) {
            let r = sea.query(*p, QueryFields::ALL);
            proptest::prop_assert_eq!(r, *b);
            proptest::prop_assert!(r.height.is_finite() && r.jacobian.is_finite() && r.displacement.is_finite());
            proptest::prop_assert!((r.normal.length() - 1.0).abs() < 1e-9);
            if r.jacobian > 0.2 {
                proptest::prop_assert!(r.residual <= 1e-3, "residual {} J {}", r.residual, r.jacobian);
            }
        }
    }
}

/// Regression (issue 11, the `config_toml` fuzz target): `tile_size = 1e308` built a layer whose
/// heights were NaN. The tile side is now bounded, and the error names it.
#[test]
fn a_tile_size_out_of_range_is_an_error_naming_it() {
    for tile in [1e308, 1e6, 0.5, 0.0, -3.0] {
        let spec: SurfaceSpec = serde_json::from_value(json!({"layers": [{"kind": "fft",
            "resolution": 64, "tile_size": tile, "wind_direction": [0.0, 5.5],
            "spectrum": {"kind": "jonswap", "wind_speed": 0.4, "fetch": 200.0}}]}))
        .unwrap();
        let e = Surface::new(&spec).unwrap_err();
        assert_eq!(e.field(), "layers[0].tile_size", "tile {tile}: {e}");
    }
    // The bounds themselves build, and answer finite heights.
    for tile in [
        swell_waves::fft::MIN_TILE_SIZE,
        swell_waves::fft::MAX_TILE_SIZE,
    ] {
        let s = fft(
            64,
            tile,
            1.0,
            json!({"kind": "jonswap", "wind_speed": 0.4, "fetch": 200.0}),
            7,
        );
        let at = s
            .at(3.0, QueryFields::HEIGHT, &QueryOptions::default())
            .unwrap();
        for p in [(0.0, 17.25), (-401.5, 3.0)] {
            assert!(at.height(p.0, p.1).is_finite(), "tile {tile} at {p:?}");
        }
    }
}

/// Regression (issue 11, the `scene_spec` fuzz target in a 10-minute run): `repeat_period =
/// 1.991e303` built a layer whose heights were NaN (the evolution's phase ω_q·(t mod T) left the
/// range the deterministic `sin_cos` reduces). The period is now bounded, and the error names it.
#[test]
fn a_repeat_period_out_of_range_is_an_error_naming_it() {
    let layer = |period: f64| {
        serde_json::from_value::<SurfaceSpec>(json!({"layers": [{"kind": "fft",
            "resolution": 64, "tile_size": 32.0, "repeat_period": period,
            "wind_direction": [2.0, 0.3],
            "spectrum": {"kind": "jonswap", "wind_speed": 11.0, "fetch": 100000.0}}]}))
        .unwrap()
    };
    // The second, a subnormal period (2π/T infinite), from the target's rerun after the first fix.
    for period in [1.991e303, 1.0e7, 1.996e-321, 0.5, 0.0, -5.0] {
        let e = Surface::new(&layer(period)).unwrap_err();
        assert_eq!(e.field(), "layers[0].repeat_period", "period {period}: {e}");
    }
    // The bounds build and answer finite heights, late in the cycle too.
    for (period, t) in [
        (swell_waves::fft::MAX_REPEAT_PERIOD, 12.345),
        (swell_waves::fft::MAX_REPEAT_PERIOD, 9.99e5),
        (swell_waves::fft::MIN_REPEAT_PERIOD, 0.75),
    ] {
        let s = Surface::new(&layer(period)).unwrap();
        let at = s
            .at(t, QueryFields::HEIGHT, &QueryOptions::default())
            .unwrap();
        for p in [(0.0, 0.0), (-401.5, 3.0)] {
            assert!(at.height(p.0, p.1).is_finite(), "t {t} at {p:?}");
        }
    }
}

/// Newton's steps read the displacement grids' interpolant, never the Jacobian grids, so a
/// height does not depend on what else was asked: the same bits from a height-only snapshot (3
/// grids), one for every field (8 grids), a batch, and a body's water query, in f64 and f32, on a
/// choppy FFT sea under a Gerstner swell. And Newton still converges: every residual within the
/// tolerance, in at most 5 steps.
#[test]
fn a_height_has_the_same_bits_whatever_else_is_asked() {
    let sea = surface(json!({"seed": 11, "layers": [
        {"kind": "fft", "resolution": 64, "tile_size": 120.0, "choppiness": 1.0,
         "wind_direction": [1.0, 0.3], "spectrum": {"kind": "jonswap", "wind_speed": 14.0, "fetch": 80000.0},
         "spreading": {"kind": "cos2s", "s": 4.0}},
        {"kind": "gerstner", "waves": [{"amplitude": 0.4, "wavelength": 60, "direction": [0.2, 1], "steepness": 0.4}]}]}));
    for precision in [swell_waves::Precision::F64, swell_waves::Precision::F32] {
        let options = QueryOptions {
            precision,
            ..Default::default()
        };
        for t in [0.0, 13.37, 1.0e6 + 0.01] {
            let h = sea.at(t, QueryFields::HEIGHT, &options).unwrap();
            let all = sea.at(t, QueryFields::ALL, &options).unwrap();
            let pts = points(5, 300, (0.0, 0.0), 70.0);
            let batch = all.query_batch(&pts, QueryFields::ALL);
            for (p, b) in pts.iter().zip(&batch) {
                let one = h.query(*p, QueryFields::HEIGHT);
                let every = all.query(*p, QueryFields::ALL);
                assert_eq!(
                    one.height.to_bits(),
                    every.height.to_bits(),
                    "{precision:?} t={t} {p}"
                );
                assert_eq!(
                    b.height.to_bits(),
                    every.height.to_bits(),
                    "batch {precision:?} t={t} {p}"
                );
                assert!(every.residual <= options.inversion.tolerance, "{every:?}");
                if precision == swell_waves::Precision::F64 {
                    assert_eq!(h.water_at(*p, 0.0).height.to_bits(), one.height.to_bits());
                }
            }
            let steps = pts
                .iter()
                .map(|p| h.invert(*p, false).iterations)
                .max()
                .unwrap();
            assert!(steps <= 5, "Newton took {steps} steps at t={t}");
        }
    }
}
