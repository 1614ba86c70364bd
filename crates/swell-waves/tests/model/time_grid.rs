//! The FFT time grid: frames at `t_n = n·Δ`, queries in between read `a + (b − a)·w`.
//!
//! Checked here: the grid position is exact (a grid time reads one frame with weight 0, every
//! t lies in `[t_n, t_{n+1})`); the grid snapshot is the hand-written interpolation of exact
//! frames (the slow reference); grid and exact sampling agree to the interpolation bound; `t`
//! and `t + T` give the same bits; caller-supplied frames at the wrong times are refused.

use crate::common;

use std::sync::Arc;

use common::points;
use serde_json::{Value, json};
use swell_waves::fft::{FftFields, FftLayer, lerp_samples};
use swell_waves::math::SwellRng;
use swell_waves::{
    Layer, LayerFrames, QueryFields, QueryOptions, SpecError, Surface, SurfaceSpec, TimeSampling,
};

fn surface(v: Value) -> Result<Surface, SpecError> {
    let spec: SurfaceSpec = serde_json::from_value(v).unwrap();
    Surface::new(&spec)
}

/// A choppy JONSWAP sea on a 128 m tile, plus a Gerstner swell (analytic layers never use the
/// grid), with time step `dt` (None: the default) and repeat period `period`.
fn sea(dt: Option<f64>, period: f64) -> Surface {
    let mut fft = json!({"kind": "fft", "resolution": 64, "tile_size": 128.0,
        "choppiness": 1.0, "repeat_period": period, "wind_direction": [1.0, 0.3],
        "spectrum": {"kind": "jonswap", "wind_speed": 12.0, "fetch": 80000.0},
        "spreading": {"kind": "cos2s", "s": 4.0}});
    if let Some(dt) = dt {
        fft["time_step"] = json!(dt);
    }
    surface(json!({"seed": 9, "layers": [fft,
        {"kind": "gerstner", "waves": [{"amplitude": 0.4, "wavelength": 90.0,
            "direction": [0.2, 1.0], "steepness": 0.3}]}]}))
    .unwrap()
}

fn layer(s: &Surface) -> &FftLayer {
    match &s.layers()[0] {
        Layer::Fft(f) => f,
        _ => panic!("layer 0 is the FFT layer"),
    }
}

/// Seeded times over several repeat periods, negative ones included.
fn times(seed: u64, count: usize, span: f64) -> Vec<f64> {
    let mut rng = SwellRng::new(seed, 0);
    (0..count).map(|_| (rng.uniform() - 0.3) * span).collect()
}

#[test]
fn the_step_divides_the_repeat_period() {
    let s = sea(None, 200.0);
    let f = layer(&s);
    assert_eq!(f.grid_steps(), 12_000, "200 s at 1/60 s");
    assert_eq!(f.time_step(), 200.0 / 12_000.0);
    // 0.07 s does not divide 300 s: rounded to 4286 steps of 300/4286 s.
    let s = sea(Some(0.07), 300.0);
    assert_eq!(layer(&s).grid_steps(), 4286);
    assert_eq!(layer(&s).time_step(), 300.0 / 4286.0);
    // A step as long as the period (the shortest period, 1 s): one step, the whole period.
    let s = sea(Some(1.0), swell_waves::fft::MIN_REPEAT_PERIOD);
    assert_eq!(layer(&s).grid_steps(), 1);
    assert_eq!(layer(&s).time_step(), 1.0);
}

#[test]
fn a_bad_time_step_is_an_error_naming_it() {
    for dt in [0.0, -1.0, 1e-4, 250.0] {
        let fft = json!({"kind": "fft", "resolution": 16, "tile_size": 50.0,
            "repeat_period": 200.0, "time_step": dt, "wind_direction": [1.0, 0.0],
            "spectrum": {"kind": "phillips", "wind_speed": 5.0, "amplitude": 1e-4}});
        let e = surface(json!({"layers": [fft]})).unwrap_err();
        assert_eq!(e.field(), "layers[0].time_step", "dt = {dt}: {e}");
    }
}

#[test]
fn every_time_lies_between_its_two_grid_times() {
    for (dt, period) in [(None, 200.0), (Some(0.07), 300.0), (Some(0.25), 17.3)] {
        let s = sea(dt, period);
        let f = layer(&s);
        let m = f.grid_steps();
        for t in times(3, 20_000, 5.0 * period) {
            let p = f.grid_position(t);
            let t_r = t.rem_euclid(period);
            assert!(p.index < m && p.next == (p.index + 1) % m, "{t}: {p:?}");
            assert!((0.0..=1.0).contains(&p.weight), "{t}: {p:?}");
            assert!(f.grid_time(p.index) <= t_r, "{t}: {p:?}");
            if p.index + 1 < m {
                assert!(t_r < f.grid_time(p.index + 1), "{t}: {p:?}");
            }
        }
        // A grid time reads its own frame alone, whatever the rounding of t_r/Δ.
        for n in (0..m).step_by((m / 997).max(1) as usize) {
            let p = f.grid_position(f.grid_time(n));
            assert_eq!((p.index, p.weight), (n, 0.0), "grid index {n}");
        }
    }
}

/// Fast path against the slow reference: a grid snapshot reads exactly
/// `a + (b − a)·w` of the two exact frames at the surrounding grid times, per point, and the
/// analytic layer as an exact-time snapshot does.
#[test]
fn a_grid_snapshot_is_the_interpolation_of_the_exact_grid_frames() {
    let s = sea(None, 200.0);
    let f = layer(&s);
    let grid = QueryOptions::default();
    let exact = QueryOptions {
        time: TimeSampling::Exact,
        ..grid
    };
    let pts = points(11, 64, (0.0, 0.0), 300.0);
    for t in times(5, 12, 400.0) {
        let p = f.grid_position(t);
        let fields = FftFields::ALL;
        let (a, b) = (
            f.frame(f.grid_time(p.index), fields),
            f.frame(f.grid_time(p.next), fields),
        );
        let sea = s.at(t, QueryFields::ALL, &grid).unwrap();
        let swell = s.at(t, QueryFields::ALL, &exact).unwrap();
        for &p0 in &pts {
            let fft = lerp_samples(
                &a.sample(p0, grid.filter),
                &b.sample(p0, grid.filter),
                p.weight,
            );
            // The analytic part is the exact snapshot's sample minus its FFT part.
            let exact_fft = f.frame(t, fields).sample(p0, grid.filter);
            let analytic = swell.sample(p0, true).displacement - exact_fft.displacement;
            let got = sea.sample(p0, true).displacement;
            let want = fft.displacement + analytic;
            assert!(
                (got - want).abs().max_element() < 1e-12,
                "t = {t}, p0 = {p0}: {got} vs {want}"
            );
        }
        // Bit for bit on a surface with the FFT layer alone.
        let alone = surface(json!({"seed": 9, "layers": [
            {"kind": "fft", "resolution": 64, "tile_size": 128.0, "choppiness": 1.0,
             "wind_direction": [1.0, 0.3],
             "spectrum": {"kind": "jonswap", "wind_speed": 12.0, "fetch": 80000.0},
             "spreading": {"kind": "cos2s", "s": 4.0}}]}))
        .unwrap();
        let fa = layer(&alone);
        let (a, b) = (
            fa.frame(fa.grid_time(p.index), fields),
            fa.frame(fa.grid_time(p.next), fields),
        );
        let snap = alone.at(t, QueryFields::ALL, &grid).unwrap();
        for &p0 in &pts {
            let want = lerp_samples(
                &a.sample(p0, grid.filter),
                &b.sample(p0, grid.filter),
                p.weight,
            );
            let got = snap.sample(p0, true);
            assert_eq!(
                got.displacement.to_array().map(f64::to_bits),
                want.displacement.to_array().map(f64::to_bits)
            );
            assert_eq!(got.d_dx.y.to_bits(), want.slope.x.to_bits());
        }
    }
}

/// On a grid time the grid and the exact snapshot are the same snapshot; in between they differ
/// by the interpolation error, `max|∂²h/∂t²|·Δ²/8` — about a tenth of a millimetre on this
/// 12 m/s sea at the default 1/60 s.
#[test]
fn grid_and_exact_sampling_agree_to_the_interpolation_bound() {
    let s = sea(None, 200.0);
    let f = layer(&s);
    let grid = QueryOptions::default();
    let exact = QueryOptions {
        time: TimeSampling::Exact,
        ..grid
    };
    let pts = points(13, 256, (0.0, 0.0), 500.0);
    let on_grid = f.grid_time(1234);
    let (g, e) = (
        s.at(on_grid, QueryFields::ALL, &grid).unwrap(),
        s.at(on_grid, QueryFields::ALL, &exact).unwrap(),
    );
    for &p in &pts {
        assert_eq!(g.query(p, QueryFields::ALL), e.query(p, QueryFields::ALL));
    }
    let mut worst: f64 = 0.0;
    for t in times(17, 8, 200.0) {
        let (g, e) = (
            s.at(t, QueryFields::ALL, &grid).unwrap(),
            s.at(t, QueryFields::ALL, &exact).unwrap(),
        );
        for &p in &pts {
            let (a, b) = (
                g.query(p, QueryFields::HEIGHT),
                e.query(p, QueryFields::HEIGHT),
            );
            worst = worst.max((a.height - b.height).abs());
            let (a, b) = (g.sample(p, false), e.sample(p, false));
            worst = worst.max((a.displacement - b.displacement).length());
        }
    }
    eprintln!("grid vs exact: max {:.4} mm", worst * 1e3);
    assert!(worst > 0.0 && worst < 1e-3, "max error {worst} m");
}

#[test]
fn t_and_t_plus_the_period_read_the_same_bits() {
    let s = sea(None, 200.0);
    let o = QueryOptions::default();
    let pts = points(19, 32, (0.0, 0.0), 200.0);
    // Times whose sum with T is exact in f64 (t_r is then the same number).
    for t in [0.015625, 13.375, 199.9375] {
        let (a, b) = (
            s.at(t, QueryFields::ALL, &o).unwrap(),
            s.at(t + 200.0, QueryFields::ALL, &o).unwrap(),
        );
        // Only the FFT layer repeats with T (the Gerstner swell does not), so compare it alone.
        let f = layer(&s);
        assert_eq!(f.grid_position(t), f.grid_position(t + 200.0), "t = {t}");
        for &p in &pts {
            let fa = a.sample(p, true);
            let fb = b.sample(p, true);
            assert!(fa.displacement.is_finite() && fb.displacement.is_finite());
        }
    }
    // A surface of the FFT layer alone: identical bits.
    let alone = surface(
        json!({"layers": [{"kind": "fft", "resolution": 32, "tile_size": 64.0,
        "repeat_period": 100.0, "wind_direction": [1.0, 0.0],
        "spectrum": {"kind": "jonswap", "wind_speed": 9.0, "fetch": 40000.0}}]}),
    )
    .unwrap();
    for t in [0.015625, 42.125, 99.9921875] {
        let (a, b) = (
            alone.at(t, QueryFields::ALL, &o).unwrap(),
            alone.at(t + 100.0, QueryFields::ALL, &o).unwrap(),
        );
        for &p in &pts {
            assert_eq!(a.query(p, QueryFields::ALL), b.query(p, QueryFields::ALL));
        }
    }
}

#[test]
fn frames_at_other_times_are_refused() {
    let s = sea(None, 200.0);
    let f = layer(&s);
    let o = QueryOptions::default();
    let t = f.grid_time(77) + 0.4 * f.time_step();
    let frame = |t| Arc::new(f.frame(t, FftFields::ALL));
    let ok = |a: f64, b: Option<f64>| {
        s.at_with_frames(
            t,
            vec![
                Some(LayerFrames {
                    frame: frame(a),
                    next: b.map(frame),
                }),
                None,
            ],
            &o,
        )
        .is_ok()
    };
    assert!(ok(f.grid_time(77), Some(f.grid_time(78))));
    assert!(!ok(t, None), "an exact frame given to a grid snapshot");
    assert!(!ok(f.grid_time(77), None), "the next frame is missing");
    assert!(!ok(f.grid_time(76), Some(f.grid_time(77))));
    let exact = QueryOptions {
        time: TimeSampling::Exact,
        ..o
    };
    let exact_ok = |a: f64| {
        s.at_with_frames(t, vec![Some(LayerFrames::exact(frame(a))), None], &exact)
            .is_ok()
    };
    assert!(exact_ok(t));
    assert!(!exact_ok(f.grid_time(77)));
    // A query at a grid time needs no next frame.
    let on = f.grid_time(77);
    assert!(
        s.at_with_frames(on, vec![Some(LayerFrames::exact(frame(on))), None], &o)
            .is_ok()
    );
}
