//! Surfaces of the server's built-in scenes (`src/scene/builtin.rs`), for the model's benches and
//! examples: one copy of each spec. Each bench uses some of them.
#![allow(dead_code)]

use glam::DVec2;
use serde_json::json;
use swell_waves::wave::Wave;
use swell_waves::{Surface, SurfaceSpec};

fn surface(v: serde_json::Value) -> Surface {
    let spec: SurfaceSpec = serde_json::from_value(v).expect("a built-in spec");
    Surface::new(&spec).expect("a built-in surface")
}

/// `harbour`: two Gerstner waves under 512 ambient wave particles at three scales.
pub fn harbour() -> Surface {
    surface(json!({"seed": 21, "layers": [
        {"kind": "gerstner", "waves": [
            {"amplitude": 0.12, "wavelength": 26, "direction": [1, 0.3], "steepness": 0.4},
            {"amplitude": 0.05, "wavelength": 9, "direction": [0.2, 1], "steepness": 0.4, "phase": 1.3}
        ]},
        {"kind": "particles", "count": 512, "tile_size": 32, "radius": 1.0, "amplitude": 0.03,
         "scales": [0.33, 0.66, 1.0],
         "ripples": {"particles": 8, "decay": 30, "floor": 0.0001, "lifetime": 60}}
    ]}))
}

/// `lake`: a Gerstner wave and its cascade.
pub fn lake() -> Surface {
    surface(json!({"seed": 7, "depth": 12, "layers": [
        {"kind": "gerstner",
         "waves": [{"amplitude": 0.25, "wavelength": 22, "direction": [1, 0.4], "steepness": 0.5}],
         "cascade": {"wavelength": 8, "amplitude": 0.08, "steepness": 0.5, "direction": [1, 0.4]}}
    ]}))
}

/// `n` Gerstner waves (JSON specs) with wavelengths `first`, `first + step`, …, m, directions
/// spread by the golden angle, phase `i`, each with steepness k·A = `ka` and the same Q, chosen
/// so that the fold number Σ Q·k·A is `fold`.
pub fn gerstner_waves(
    n: usize,
    first: f64,
    step: f64,
    ka: f64,
    fold: f64,
) -> Vec<serde_json::Value> {
    (0..n)
        .map(|i| {
            let l = first + step * i as f64;
            let a = (i as f64 * 2.399).sin_cos();
            json!({"amplitude": ka * l / std::f64::consts::TAU, "wavelength": l,
                   "direction": [a.1, a.0], "phase": i as f64, "steepness": fold / (n as f64 * ka)})
        })
        .collect()
}

/// The `targets/gerstner16_*` surface: 16 Gerstner waves, wavelengths 4 to 94 m, each with
/// k·A = 0.1 and Q = fold/1.6, so that the fold number Σ Q·k·A is `fold`.
pub fn gerstner16(fold: f64) -> Surface {
    let waves = gerstner_waves(16, 4.0, 6.0, 0.1, fold);
    surface(json!({"layers": [{"kind": "gerstner", "waves": waves}]}))
}

/// The naive way with normals: per point, per wave, std sin/cos on the unreduced phase, the
/// displacement and its six derivatives summed, then the normal. The same work as
/// `sample_batch(.., true)` + `SurfaceSample::normal`.
pub fn naive_gerstner_normal(waves: &[Wave], pts: &[DVec2], t: f64, out: &mut [[f64; 6]]) {
    for (p, o) in pts.iter().zip(out.iter_mut()) {
        let mut d = [0.0; 3];
        let (mut ddx, mut ddz) = ([0.0; 3], [0.0; 3]);
        for w in waves {
            let th = w.wavenumber * w.direction.dot(*p) - w.omega * t + w.phase;
            let (s, c) = th.sin_cos();
            let (dx, dz) = (w.direction.x, w.direction.y);
            let qa = w.steepness * w.amplitude;
            d[0] += qa * dx * c;
            d[1] += w.amplitude * s;
            d[2] += qa * dz * c;
            let akc = w.amplitude * w.wavenumber * c;
            let qaks = qa * w.wavenumber * s;
            ddx[0] -= qaks * dx * dx;
            ddx[1] += akc * dx;
            ddx[2] -= qaks * dx * dz;
            ddz[0] -= qaks * dx * dz;
            ddz[1] += akc * dz;
            ddz[2] -= qaks * dz * dz;
        }
        let tx = glam::DVec3::new(1.0 + ddx[0], ddx[1], ddx[2]);
        let tz = glam::DVec3::new(ddz[0], ddz[1], 1.0 + ddz[2]);
        let n = tz.cross(tx).normalize();
        *o = [d[0], d[1], d[2], n.x, n.y, n.z];
    }
}
