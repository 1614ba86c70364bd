//! Golden vectors: `proto/vectors/surface_v1.json` pins the model's outputs bit for bit, and
//! `proto/vectors/surface_f32_v1.json` those of the single-precision fast path
//! (`Precision::F32`) on the same cases.
//!
//! The file is self-contained so any client (any language) can check itself against it: each case
//! holds a surface spec (the scene JSON's wave part), times, world points and the expected outputs
//! as IEEE-754 bit patterns (hex) plus a decimal for people.
//!
//! If this test fails, the model's numbers changed. If that was not the intent, fix the change.
//! If it was, re-mint with
//!     SWELL_MINT_VECTORS=1 cargo test -p swell-waves --test golden
//! bump `swell_waves::MODEL_VERSION`, and say so in the change: clients compare that version to
//! know they render the same sea as the server. See proto/vectors/README.md.

use std::path::PathBuf;

use glam::DVec2;
use serde_json::{Value, json};
use swell_waves::{Precision, QueryFields, QueryOptions, Surface, SurfacePointF32, SurfaceSpec};

fn vectors_path(precision: Precision) -> PathBuf {
    let name = match precision {
        Precision::F64 => "surface_v1.json",
        Precision::F32 => "surface_f32_v1.json",
    };
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../proto/vectors")
        .join(name)
}

/// One case: name, surface spec JSON, times (s), world points `[x, z]` (m).
type Case = (&'static str, Value, Vec<f64>, Vec<[f64; 2]>);

/// The cases, as JSON specs (exactly what a scene file or the server would hold).
fn cases() -> Vec<Case> {
    let times = vec![0.0, 12.345, 3600.0, 1e9 + 0.5];
    let pts = vec![
        [0.0, 0.0],
        [13.7, -4.2],
        [-250.5, 999.25],
        [1e7, -1e7 + 0.5],
        [-3.3e6, 7.7e5],
    ];
    vec![
        (
            "calm_sine",
            json!({"seed": 1, "layers": [{"kind": "sine", "waves": [
                {"amplitude": 0.3, "wavelength": 24.0, "direction": [1.0, 0.3]},
                {"amplitude": 0.12, "wavelength": 7.5, "direction": [-0.2, 1.0], "phase": 0.7},
                {"amplitude": 0.05, "wavelength": 3.1, "direction": [0.6, -0.8], "speed": 1.9}
            ]}]}),
            times.clone(),
            pts.clone(),
        ),
        (
            "lake_gerstner_cascade",
            json!({"seed": 7, "depth": 12.0, "layers": [{"kind": "gerstner",
                "waves": [{"amplitude": 0.4, "wavelength": 30.0, "direction": [1.0, 0.0], "steepness": 0.5}],
                "cascade": {"wavelength": 12.0, "amplitude": 0.15, "steepness": 0.6}
            }]}),
            times.clone(),
            pts.clone(),
        ),
        (
            "steep_gerstner_s095",
            json!({"seed": 3, "layers": [{"kind": "gerstner", "waves": [
                {"amplitude": 1.0, "wavelength": 40.0, "direction": [1.0, 0.2], "steepness": 1.0},
                {"amplitude": 0.5, "wavelength": 17.0, "direction": [0.3, 1.0], "steepness": 0.95},
                {"amplitude": 0.2, "wavelength": 6.0, "direction": [-1.0, 0.4], "steepness": 0.95}
            ]}]}),
            times.clone(),
            pts.clone(),
        ),
        (
            "open_sea_fft_jonswap_plus_swell",
            json!({"seed": 42, "layers": [
                {"kind": "fft", "resolution": 32, "tile_size": 128.0, "choppiness": 0.8,
                 "repeat_period": 200.0, "wind_direction": [1.0, 0.5],
                 "spectrum": {"kind": "jonswap", "wind_speed": 9.0, "fetch": 60000.0},
                 "spreading": {"kind": "horvath", "swell": 0.3}},
                {"kind": "gerstner", "waves": [
                    {"amplitude": 0.5, "wavelength": 90.0, "direction": [0.2, 1.0], "steepness": 0.5}]}
            ]}),
            times.clone(),
            pts.clone(),
        ),
        (
            "fft_phillips_pm_bands",
            json!({"seed": 9, "layers": [
                {"kind": "fft", "resolution": 16, "tile_size": 400.0, "choppiness": 0.0,
                 "wind_direction": [0.0, 1.0], "band": {"min_wavelength": 40.0},
                 "spectrum": {"kind": "pierson_moskowitz", "wind_speed": 12.0},
                 "spreading": {"kind": "cos2s", "s": 6.0}},
                {"kind": "fft", "resolution": 16, "tile_size": 40.0, "choppiness": 1.0,
                 "wind_direction": [0.0, 1.0], "band": {"max_wavelength": 40.0},
                 "spectrum": {"kind": "phillips", "wind_speed": 12.0}}
            ]}),
            times,
            pts,
        ),
    ]
}

fn hex(x: f64) -> String {
    format!("{:016x}", x.to_bits())
}

fn hex32(x: f32) -> String {
    format!("{:08x}", x.to_bits())
}

fn outputs(spec: &Value, times: &[f64], pts: &[[f64; 2]], precision: Precision) -> Vec<Value> {
    let spec: SurfaceSpec = serde_json::from_value(spec.clone()).expect("case spec decodes");
    let surface = Surface::new(&spec).expect("case spec is valid");
    let options = QueryOptions {
        precision,
        ..Default::default()
    };
    let mut out = Vec::new();
    for &t in times {
        let sea = surface.at(t, QueryFields::ALL, &options).unwrap();
        if precision == Precision::F32 {
            // The f32 batch API (displacement + normal of undisplaced points, f32 bits) and the
            // height query run with f32 evaluation (f64 bits).
            let world: Vec<DVec2> = pts.iter().map(|p| DVec2::new(p[0], p[1])).collect();
            let mut fast = vec![SurfacePointF32::default(); world.len()];
            sea.displacement_normal_f32(&world, &mut fast);
            for (p, f) in pts.iter().zip(&fast) {
                let r = sea.query(DVec2::new(p[0], p[1]), QueryFields::ALL);
                let (d, n) = (f.displacement, f.normal);
                out.push(json!({
                    "t": t, "point": p,
                    "height_m": r.height,
                    "bits": {
                        "height": hex(r.height),
                        "displacement_f32": [hex32(d.x), hex32(d.y), hex32(d.z)],
                        "normal_f32": [hex32(n.x), hex32(n.y), hex32(n.z)],
                    }
                }));
            }
            continue;
        }
        for p in pts {
            let r = sea.query(DVec2::new(p[0], p[1]), QueryFields::ALL);
            out.push(json!({
                "t": t, "point": p,
                "height_m": r.height,
                "bits": {
                    "height": hex(r.height),
                    "normal": [hex(r.normal.x), hex(r.normal.y), hex(r.normal.z)],
                    "displacement": [hex(r.displacement.x), hex(r.displacement.y), hex(r.displacement.z)],
                    "jacobian": hex(r.jacobian),
                    "residual": hex(r.residual),
                    "folded": r.folded,
                }
            }));
        }
    }
    out
}

fn mint(precision: Precision) -> Value {
    let about = match precision {
        Precision::F64 => {
            "Swell golden vectors: for each case, build the surface from `spec`, query every point at every time with default accuracy (Newton inversion, 8 steps, 1e-5 m; bicubic FFT sampling; portable FFT backend) and compare the IEEE-754 bits. See README.md here."
        }
        Precision::F32 => {
            "Swell golden vectors of the single-precision fast path (precision f32): for each case and time, `displacement_f32` and `normal_f32` are the f32 batch outputs at each point taken as undisplaced (binary32 bits), `height` the height query with f32 evaluation (binary64 bits); otherwise as surface_v1.json. See README.md here."
        }
    };
    let cases: Vec<Value> = cases()
        .into_iter()
        .map(|(name, spec, times, pts)| {
            let expected = outputs(&spec, &times, &pts, precision);
            json!({"name": name, "spec": spec, "times": times, "points": pts, "expected": expected})
        })
        .collect();
    json!({
        "model_version": swell_waves::MODEL_VERSION,
        "about": about,
        "cases": cases,
    })
}

#[test]
fn golden_vectors_match_bit_for_bit() {
    check(Precision::F64);
}

#[test]
fn golden_f32_vectors_match_bit_for_bit() {
    check(Precision::F32);
}

fn check(precision: Precision) {
    let path = vectors_path(precision);
    if std::env::var_os("SWELL_MINT_VECTORS").is_some() {
        let text = serde_json::to_string_pretty(&mint(precision)).unwrap() + "\n";
        std::fs::write(&path, text).unwrap();
        eprintln!("minted {}", path.display());
        return;
    }
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; mint with SWELL_MINT_VECTORS=1 cargo test -p swell-waves --test golden",
            path.display()
        )
    });
    let file: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(
        file["model_version"].as_u64(),
        Some(swell_waves::MODEL_VERSION as u64),
        "vectors were minted for another model version"
    );
    let files_cases = file["cases"].as_array().unwrap();
    let code_cases = cases();
    assert_eq!(
        files_cases.len(),
        code_cases.len(),
        "case list changed: re-mint deliberately"
    );
    for (fc, (name, spec, times, pts)) in files_cases.iter().zip(code_cases) {
        assert_eq!(fc["name"], name);
        assert_eq!(
            fc["spec"], spec,
            "{name}: spec in file differs from the test's"
        );
        // Recompute from the file's own inputs: this is what a client does.
        let ftimes: Vec<f64> = serde_json::from_value(fc["times"].clone()).unwrap();
        let fpts: Vec<[f64; 2]> = serde_json::from_value(fc["points"].clone()).unwrap();
        assert_eq!((ftimes.clone(), fpts.clone()), (times, pts));
        let got = outputs(&fc["spec"], &ftimes, &fpts, precision);
        let want = fc["expected"].as_array().unwrap();
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            assert_eq!(
                g["bits"], w["bits"],
                "{name} at t={} point={}: model output changed. If intended, re-mint (SWELL_MINT_VECTORS=1 \
                 cargo test -p swell-waves --test golden) and bump MODEL_VERSION: clients must hear of it.",
                w["t"], w["point"]
            );
        }
    }
}
