//! Spec builders shared by the integration tests.
#![allow(dead_code)]

use swell_waves::gerstner::{GerstnerLayerSpec, GerstnerWave};
use swell_waves::math::SwellRng;
use swell_waves::sine::{SineLayerSpec, SineWave};
use swell_waves::{LayerSpec, SurfaceSpec};

/// `n` Gerstner waves with random wavelengths (2..100 m), directions and phases, each with the
/// same k·A (0.1, or more when few waves must reach a high fold number, so that Q ≤ 1) and
/// steepness chosen so the fold number is exactly `fold`.
pub fn gerstner_spec(seed: u64, n: usize, fold: f64) -> SurfaceSpec {
    let mut r = SwellRng::new(seed, 99);
    let ka = (fold / n as f64).max(0.1);
    // fold / (n · fold/n) can round to 1 + ε: clamp (Q > 1 is rightly rejected by the model).
    let q = (fold / (n as f64 * ka)).min(1.0);
    let waves = (0..n)
        .map(|_| {
            let l = 2.0 + 98.0 * r.uniform();
            let ang = std::f64::consts::TAU * r.uniform();
            GerstnerWave {
                amplitude: ka * l / std::f64::consts::TAU,
                wavelength: l,
                direction: [ang.cos(), ang.sin()],
                phase: std::f64::consts::TAU * r.uniform(),
                speed: None,
                steepness: q,
            }
        })
        .collect();
    SurfaceSpec {
        seed,
        gravity: 9.81,
        depth: None,
        layers: vec![LayerSpec::Gerstner(GerstnerLayerSpec {
            waves,
            ..Default::default()
        })],
    }
}

pub fn sine_spec() -> SurfaceSpec {
    SurfaceSpec {
        seed: 0,
        gravity: 9.81,
        depth: None,
        layers: vec![LayerSpec::Sine(SineLayerSpec {
            waves: vec![
                SineWave {
                    amplitude: 0.4,
                    wavelength: 30.0,
                    direction: [1.0, 0.2],
                    phase: 0.0,
                    speed: None,
                },
                SineWave {
                    amplitude: 0.15,
                    wavelength: 9.0,
                    direction: [-0.3, 1.0],
                    phase: 1.0,
                    speed: None,
                },
            ],
        })],
    }
}

/// Uniform random points in a square of half-side `r` around `c`.
pub fn points(seed: u64, n: usize, c: (f64, f64), r: f64) -> Vec<glam::DVec2> {
    let mut g = SwellRng::new(seed, 7);
    (0..n)
        .map(|_| {
            glam::DVec2::new(
                c.0 + r * (2.0 * g.uniform() - 1.0),
                c.1 + r * (2.0 * g.uniform() - 1.0),
            )
        })
        .collect()
}

/// Whether this CPU has AVX2, i.e. whether the run-time AVX2 paths exist to be compared with the
/// baseline build's. Without it, says that `test` is skipped (comparing a path with itself
/// proves nothing) rather than passing silently.
pub fn avx2_or_skip(test: &str) -> bool {
    #[cfg(target_arch = "x86_64")]
    let avx2 = std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    let avx2 = false;
    if !avx2 {
        eprintln!(
            "SKIPPED {test}: this CPU has no AVX2, so there is no second path to compare with \
             the baseline"
        );
    }
    avx2
}
