//! Every SIMD level gives the scalar path's bits: FFT frames (every field, every resolution from
//! 16 to 512) and the f64 sine/Gerstner batch paths (displacement and derivatives), on seeded
//! random inputs.
//!
//! Without `SWELL_SIMD` the test checks every level this CPU has. With `SWELL_SIMD=<level>` it
//! checks that level only (capped to the CPU's), which is how CI runs it, once per level:
//!     for l in scalar sse2 avx2 avx512; do SWELL_SIMD=$l cargo test -p swell-waves --test simd_levels; done
//!
//! One `#[test]` on purpose: the level is process-wide (`force_simd_level`), and tests in one
//! binary run on parallel threads.

use glam::DVec2;
use serde_json::json;
use swell_waves::fft::{FftFields, FftGrid};
use swell_waves::math::SwellRng;
use swell_waves::simd::{SimdLevel, force_simd_level, simd_level};
use swell_waves::wave::SurfaceSample;
use swell_waves::{QueryFields, QueryOptions, Surface, SurfaceSpec};

fn surface(v: serde_json::Value) -> Surface {
    let spec: SurfaceSpec = serde_json::from_value(v).unwrap();
    Surface::new(&spec).unwrap()
}

fn fft_surface(n: u32, choppiness: f64) -> Surface {
    surface(
        json!({"seed": 3, "layers": [{"kind": "fft", "resolution": n, "tile_size": 97.0,
        "choppiness": choppiness, "wind_direction": [1.0, 0.3],
        "spectrum": {"kind": "jonswap", "wind_speed": 12.0, "fetch": 80000.0}}]}),
    )
}

/// Two analytic surfaces with random waves: a Gerstner layer of 23 waves (not a multiple of any
/// lane count) over a sine layer of 5.
fn analytic_surface(rng: &mut SwellRng) -> Surface {
    let mut wave = |steep: bool| {
        let l = 2.0 + 60.0 * rng.uniform();
        let a = (rng.uniform() - 0.5) * 6.0;
        let mut w = json!({"amplitude": 0.02 * l * rng.uniform(), "wavelength": l,
            "direction": [a.cos(), a.sin()], "phase": 10.0 * rng.uniform()});
        if steep {
            w["steepness"] = json!(0.5 * rng.uniform());
        }
        w
    };
    let gerstner: Vec<_> = (0..23).map(|_| wave(true)).collect();
    let sine: Vec<_> = (0..5).map(|_| wave(false)).collect();
    surface(json!({"seed": 9, "layers": [
        {"kind": "gerstner", "waves": gerstner},
        {"kind": "sine", "waves": sine}
    ]}))
}

fn frame_bits(s: &Surface, t: f64) -> Vec<Vec<u64>> {
    let f = s.fft_frame(0, t, FftFields::ALL).unwrap();
    FftGrid::ALL
        .into_iter()
        .map(|g| f.grid(g).unwrap().iter().map(|v| v.to_bits()).collect())
        .collect()
}

fn batch_bits(s: &Surface, t: f64, pts: &[DVec2]) -> Vec<u64> {
    let sea = s.at(t, QueryFields::ALL, &QueryOptions::default()).unwrap();
    let mut out = vec![SurfaceSample::default(); pts.len()];
    sea.sample_batch(pts, true, &mut out);
    out.iter()
        .flat_map(|s| {
            [s.displacement, s.d_dx, s.d_dz]
                .into_iter()
                .flat_map(|v| v.to_array().map(f64::to_bits))
        })
        .collect()
}

#[test]
fn every_simd_level_gives_the_scalar_bits() {
    let levels = match SimdLevel::from_env() {
        // The forced level, as far as this CPU goes.
        Some(_) => vec![simd_level()],
        None => SimdLevel::available(),
    };
    eprintln!(
        "levels checked: {levels:?} (CPU: {:?})",
        SimdLevel::detected()
    );

    let mut rng = SwellRng::new(2026, 29);
    let ffts: Vec<(Surface, f64)> = [16, 32, 64, 128, 256, 512]
        .into_iter()
        .map(|n| {
            (
                fft_surface(n, if n == 64 { 0.0 } else { 1.3 }),
                1e4 * rng.uniform(),
            )
        })
        .collect();
    let analytic = analytic_surface(&mut rng);
    // 1,000 points (not a multiple of any block size), some far from the origin.
    let pts: Vec<DVec2> = (0..1000)
        .map(|i| {
            let scale = if i % 7 == 0 { 1e6 } else { 300.0 };
            DVec2::new((rng.uniform() - 0.5) * scale, (rng.uniform() - 0.5) * scale)
        })
        .collect();
    let times = [0.0, 17.25, 1e5 + rng.uniform()];

    force_simd_level(Some(SimdLevel::Scalar));
    assert_eq!(simd_level(), SimdLevel::Scalar);
    let fft_ref: Vec<_> = ffts.iter().map(|(s, t)| frame_bits(s, *t)).collect();
    let batch_ref: Vec<_> = times
        .iter()
        .map(|&t| batch_bits(&analytic, t, &pts))
        .collect();

    for level in levels {
        force_simd_level(Some(level));
        assert_eq!(simd_level(), level, "level not in force");
        for ((s, t), expected) in ffts.iter().zip(&fft_ref) {
            let got = frame_bits(s, *t);
            for (g, (a, b)) in FftGrid::ALL.into_iter().zip(got.iter().zip(expected)) {
                assert!(
                    a == b,
                    "{level:?}: FFT frame {g:?} at N = {} differs from the scalar path",
                    (a.len() as f64).sqrt()
                );
            }
        }
        for (&t, expected) in times.iter().zip(&batch_ref) {
            assert!(
                batch_bits(&analytic, t, &pts) == *expected,
                "{level:?}: analytic batch at t = {t} differs from the scalar path"
            );
        }
    }
    force_simd_level(None);
}
