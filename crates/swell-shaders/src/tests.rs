//! Tests of the emitter, the translations, the uniforms and the spectrum export.

use glam::{DVec2, DVec3};
use swell_waves::{Layer, QueryFields, QueryOptions, Surface, SurfaceSpec};

use crate::uniforms::frame;
use crate::wgsl::{MAX_SHADER_WAVES, wave_constants};
use crate::{Entry, Lang, ShaderError, export, spectrum};

fn surface(json: &str) -> Surface {
    let spec: SurfaceSpec = serde_json::from_str(json).unwrap();
    Surface::new(&spec).unwrap()
}

const SINE: &str = r#"{"seed": 1, "layers": [{"kind": "sine", "waves": [
  {"amplitude": 0.12, "wavelength": 18, "direction": [1, 0.2]},
  {"amplitude": 0.06, "wavelength": 7.5, "direction": [0.3, 1], "phase": 1.1},
  {"amplitude": 0.03, "wavelength": 3.2, "direction": [-0.6, 0.8], "phase": 2.3}]}]}"#;

/// Fold number 0.9: the acceptance-style steep Gerstner sea (one explicit wave and a cascade).
const GERSTNER: &str = r#"{"seed": 7, "depth": 12, "layers": [{"kind": "gerstner",
  "waves": [{"amplitude": 0.5, "wavelength": 20, "direction": [1, 0.4], "steepness": 0.9, "phase": 0.3}],
  "cascade": {"wavelength": 8, "amplitude": 0.08, "steepness": 0.6, "direction": [1, 0.4]}}]}"#;

const FFT_ONLY: &str = r#"{"seed": 3, "layers": [{"kind": "fft", "resolution": 16, "tile_size": 40,
  "choppiness": 1.0, "repeat_period": 100, "wind_direction": [1, 0.3],
  "spectrum": {"kind": "jonswap", "wind_speed": 8, "fetch": 50000, "gamma": 3.3}}]}"#;

const MIXED: &str = r#"{"seed": 42, "depth": 30, "layers": [
  {"kind": "fft", "resolution": 32, "tile_size": 64, "choppiness": 1.2, "repeat_period": 150,
   "wind_direction": [1, 0.3], "spectrum": {"kind": "jonswap", "wind_speed": 10, "fetch": 100000}},
  {"kind": "gerstner", "waves": [{"amplitude": 0.6, "wavelength": 160, "direction": [0.4, 1], "steepness": 0.3}]},
  {"kind": "sine", "waves": [{"amplitude": 0.05, "wavelength": 5, "direction": [-1, 0], "phase": -2}]}]}"#;

/// A low Gerstner swell under a particle layer at three scales (harbour-like, fewer particles).
const PARTICLES: &str = r#"{"seed": 21, "layers": [
  {"kind": "gerstner", "waves": [{"amplitude": 0.12, "wavelength": 26, "direction": [1, 0.3], "steepness": 0.4}]},
  {"kind": "particles", "count": 96, "tile_size": 16, "radius": 1.0, "scales": [0.33, 0.66, 1.0]}]}"#;

/// Every test surface, named (shared with `engines/tests.rs`).
pub(crate) fn all_surfaces() -> Vec<(&'static str, Surface)> {
    [
        ("sine", SINE),
        ("particles", PARTICLES),
        ("gerstner", GERSTNER),
        ("fft", FFT_ONLY),
        ("mixed", MIXED),
    ]
    .into_iter()
    .map(|(n, j)| (n, surface(j)))
    .collect()
}

/// naga validates the WGSL of every surface and writes every language and entry point; the
/// desktop GLSL is parsed back by naga's GLSL front end and validated again.
#[test]
fn every_language_and_entry_point_translates_and_validates() {
    for (name, s) in all_surfaces() {
        let wgsl = export(&s, Lang::Wgsl, None).unwrap();
        crate::translate::parse_and_validate(&wgsl).unwrap();
        for lang in Lang::ALL {
            for entry in Entry::ALL {
                let out = export(&s, lang, Some(entry));
                let out = out.unwrap_or_else(|e| panic!("{name} {lang:?} {entry:?}: {e}"));
                match lang {
                    Lang::Wgsl => assert_eq!(out, wgsl),
                    Lang::Glsl => {
                        assert!(out.starts_with("#version 450 core"), "{out}");
                        assert!(out.contains("void main()"));
                        assert!(out.contains("swell_sample("), "{name}: every function kept");
                        // naga's GLSL front end cannot read `layout(binding = N) uniform
                        // sampler2D` (not implemented in 30.0.1): the FFT layers' textures are
                        // checked by glslangValidator in .ci/shader-check instead.
                        if out.contains("sampler2D") {
                            continue;
                        }
                        let stage = entry.stage();
                        let module = naga::front::glsl::Frontend::default()
                            .parse(&naga::front::glsl::Options::from(stage), &out)
                            .unwrap_or_else(|e| {
                                panic!("{name} {entry:?}: {}", e.emit_to_string(&out))
                            });
                        naga::valid::Validator::new(
                            naga::valid::ValidationFlags::all(),
                            naga::valid::Capabilities::empty(),
                        )
                        .validate(&module)
                        .unwrap_or_else(|e| panic!("{name} {entry:?} GLSL re-validated: {e:?}"));
                    }
                    Lang::GlslEs => {
                        assert!(out.starts_with("#version 300 es"), "{out}");
                        assert!(out.contains("precision highp float;"));
                        assert!(out.contains("void main()"));
                    }
                    Lang::Hlsl => {
                        assert!(out.contains("cbuffer swell : register(b0)"), "{out}");
                        assert!(out.contains(entry.name()));
                    }
                    Lang::Msl => {
                        assert!(out.contains("#include <metal_stdlib>"));
                        assert!(out.contains(entry.name()));
                    }
                    // No entry point whatever `entry` says (engines/tests.rs checks the rest).
                    Lang::HlslInclude | Lang::Gdshaderinc => {
                        assert_eq!(out, export(&s, lang, None).unwrap());
                        assert!(!out.contains(Entry::Vertex.name()), "{name} {lang:?}");
                    }
                }
            }
        }
        // HLSL and MSL without an entry point hold all three.
        for lang in [Lang::Hlsl, Lang::Msl] {
            let out = export(&s, lang, None).unwrap();
            for e in Entry::ALL {
                assert!(out.contains(e.name()), "{name} {lang:?} lacks {}", e.name());
            }
        }
    }
}

/// Every wave appears once, with its constants as literals that parse back to the same f32.
#[test]
fn wgsl_bakes_every_wave_with_exact_constants() {
    let s = surface(GERSTNER);
    let wgsl = crate::wgsl::emit(&s).unwrap();
    let consts = wave_constants(&s).unwrap();
    assert_eq!(consts.len(), 17);
    let calls: Vec<&str> = wgsl
        .lines()
        .filter(|l| l.trim_start().starts_with("s = swell_wave("))
        .collect();
    assert_eq!(calls.len(), consts.len());
    for (i, (line, c)) in calls.iter().zip(&consts).enumerate() {
        let nums: Vec<f32> = line
            .split(['(', ')', ','])
            .filter_map(|t| t.trim().strip_suffix('f')?.parse().ok())
            .collect();
        assert_eq!(
            nums,
            [c.kd[0], c.kd[1], c.amplitude, c.qad[0], c.qad[1]],
            "{line}"
        );
        assert!(
            line.contains(&format!(
                "swell.phases[{}].{}",
                i / 4,
                ["x", "y", "z", "w"][i % 4]
            )),
            "{line}"
        );
    }
    assert!(
        wgsl.contains("phases: array<vec4<f32>, 5>"),
        "17 waves need 5 vec4s"
    );
    // Constants come from the model's wave, with its sign convention: k·d, Q·A·d.
    let w = s.layers()[0].waves()[0];
    assert_eq!(c0(&consts).kd[0], (w.wavenumber * w.direction.x) as f32);
    assert_eq!(c0(&consts).qad[1], (0.9 * 0.5 * w.direction.y) as f32);
}

fn c0(c: &[crate::wgsl::WaveConstants]) -> crate::wgsl::WaveConstants {
    c[0]
}

#[test]
fn fft_only_surface_has_an_empty_sum_and_one_padding_vec4() {
    let s = surface(FFT_ONLY);
    let wgsl = crate::wgsl::emit(&s).unwrap();
    assert!(wgsl.contains("phases: array<vec4<f32>, 1>"));
    assert!(wgsl.contains("layer 0: fft, N = 16, tile 40 m, sampled from"));
    assert!(wgsl.contains("s = swell_fft0(s, p);"));
    assert!(!wgsl.contains("s = swell_wave("));
    let u = frame(&s, 5.0, DVec2::ZERO);
    assert!(u.phases.is_empty());
    // One padding vec4 of phases, then the FFT layer's grid offset (0 at the origin).
    assert_eq!(u.block, [0.0; 8]);
}

#[test]
fn too_many_waves_is_an_error_not_a_truncated_shader() {
    let wave = r#"{"amplitude": 0.01, "wavelength": 3, "direction": [1, 0]}"#;
    let layer = format!(
        r#"{{"kind": "sine", "waves": [{}]}}"#,
        vec![wave; 1000].join(",")
    );
    let s = surface(&format!(r#"{{"layers": [{layer}, {layer}]}}"#));
    match export(&s, Lang::Wgsl, None) {
        Err(ShaderError::TooManyWaves { waves: 2000, max }) => assert_eq!(max, MAX_SHADER_WAVES),
        other => panic!("{other:?}"),
    }
}

#[test]
fn output_is_deterministic() {
    for (_, s) in all_surfaces() {
        for lang in Lang::ALL
            .into_iter()
            .filter(|l| !(l.is_include() && s.has_fft()))
        {
            assert_eq!(
                export(&s, lang, None).unwrap(),
                export(&s, lang, None).unwrap()
            );
        }
    }
}

/// The uniforms are the model's own phases, to the bit, in slot order across layers.
#[test]
fn uniforms_are_the_models_phases() {
    let s = surface(MIXED);
    let (t, o) = (1e6 + 0.37, DVec2::new(1e6, -2.5e5));
    let u = frame(&s, t, o);
    let waves: Vec<_> = s.layers().iter().flat_map(|l| l.waves()).collect();
    assert_eq!(u.phases.len(), 2);
    for (p, w) in u.phases.iter().zip(&waves) {
        assert_eq!(p.to_bits(), w.phase_at(o, t).to_bits());
        assert!(p.abs() <= std::f64::consts::PI);
    }
    // One vec4 of phases, then the FFT layer's grid offset.
    assert_eq!(u.block.len(), 8);
    assert_eq!(u.block[1], u.phases[1] as f32);
    assert_eq!(u.block[2..4], [0.0, 0.0]);
    let Layer::Fft(f) = &s.layers()[0] else {
        panic!("layer 0 is the FFT layer")
    };
    assert_eq!(u.block[4..6], crate::fft::grid_offset(f, o));
    assert_eq!(crate::uniforms::block_bytes(&u).len(), 32);
}

/// What the shader computes, in f32 on the CPU: the emitted constants, the uniform block and
/// the emitted arithmetic (`swell_wave`, `swell_normal`). GPU trig differs from std's f32 trig by
/// a few 1e-6 at most, so this bounds the GPU error from above up to that.
fn shader_twin(c: &[crate::wgsl::WaveConstants], block: &[f32], p: [f32; 2]) -> (DVec3, DVec3) {
    let tau = 6.283_185_5f32;
    let (mut d, mut dx, mut dz) = ([0f32; 3], [0f32; 3], [0f32; 3]);
    for (i, w) in c.iter().enumerate() {
        let raw = w.kd[0] * p[0] + w.kd[1] * p[1] + block[i];
        let th = raw - tau * (raw / tau).round();
        let (sn, cs) = th.sin_cos();
        let g = [-w.qad[0] * sn, w.amplitude * cs, -w.qad[1] * sn];
        d[0] += w.qad[0] * cs;
        d[1] += w.amplitude * sn;
        d[2] += w.qad[1] * cs;
        for k in 0..3 {
            dx[k] += w.kd[0] * g[k];
            dz[k] += w.kd[1] * g[k];
        }
    }
    let v = |a: [f32; 3]| DVec3::new(a[0].into(), a[1].into(), a[2].into());
    let tx = DVec3::X + v(dx);
    let tz = DVec3::Z + v(dz);
    (v(d), tz.cross(tx).normalize())
}

/// Precision by construction: with the offsets from the host in f64, the f32 shader arithmetic
/// stays within the parity bounds (2 mm, 0.1°) at t = 10⁶ s and 1000 km out, where the naive
/// f32 phase `k·x − ω·t` is off by whole radians.
#[test]
fn shader_arithmetic_meets_the_bounds_far_out_and_late() {
    let s = surface(GERSTNER);
    let consts = wave_constants(&s).unwrap();
    let mut worst = (0.0f64, 0.0f64);
    for &(t, ox, oz) in &[(0.0, 0.0, 0.0), (1e6, 1e6, -1e6), (3.7e5, -2e5, 7e5)] {
        let o = DVec2::new(ox, oz);
        let u = frame(&s, t, o);
        let sea = s.at(t, QueryFields::ALL, &QueryOptions::default()).unwrap();
        for i in 0..40 {
            let local = DVec2::new(-60.0 + 3.1 * i as f64, 45.0 - 2.3 * i as f64);
            let model = sea.sample(o + local, true);
            let (d, n) = shader_twin(&consts, &u.block, [local.x as f32, local.y as f32]);
            worst.0 = worst.0.max((d - model.displacement).length());
            worst.1 = worst
                .1
                .max(n.dot(model.normal()).clamp(-1.0, 1.0).acos().to_degrees());
        }
    }
    eprintln!(
        "f32 shader twin: displacement {:.2e} m, normal {:.2e}°",
        worst.0, worst.1
    );
    assert!(worst.0 < 2e-4, "displacement off by {} m", worst.0);
    assert!(worst.1 < 0.01, "normal off by {}°", worst.1);

    // The bug this design avoids: the phase formed in f32 from world position and time.
    let w = s.layers()[0].waves()[0];
    let (t, x) = (1e6f32, 1e6f32);
    let naive = (w.wavenumber as f32) * (w.direction.x as f32 * x) - (w.omega as f32) * t;
    let exact = w.phase_at(DVec2::new(1e6, 0.0), 1e6);
    let err = swell_waves::math::reduce_phase(f64::from(naive) - exact).abs();
    assert!(err > 0.01, "naive f32 phase error only {err} rad");
}

/// The exported records rebuild the model's own height by the documented formula
/// `h = Σ_k 2·Re[h0(k)·e^{i(k·x − ω_q t)}]`, against the model's direct-summation reference.
#[test]
fn spectrum_records_rebuild_the_models_height() {
    let s = surface(MIXED);
    let Layer::Fft(layer) = &s.layers()[0] else {
        panic!()
    };
    let meta = spectrum::SpectrumMeta {
        scene: "mixed".into(),
        spec_hash: "0123456789abcdef".into(),
        seed: 9,
    };
    let bytes = spectrum::export(&s, 0, &meta).unwrap();
    assert_eq!(&bytes[..4], b"SWSP");
    let hlen = u32::from_le_bytes(bytes[4..8].try_into().unwrap()) as usize;
    let header: serde_json::Value = serde_json::from_slice(&bytes[8..8 + hlen]).unwrap();
    assert_eq!(header["format"], "swell-spectrum/1");
    assert_eq!(header["resolution"], 32);
    assert_eq!(header["tile_size"], 64.0);
    assert_eq!(header["choppiness"], 1.2);
    assert_eq!(header["repeat_period"], 150.0);
    assert_eq!(header["depth"], 30.0);
    assert_eq!(header["seed"], "9");
    let off = header["data_offset"].as_u64().unwrap() as usize;
    assert_eq!(off % 8, 0);
    assert!(off >= 8 + hlen);
    let n = 32usize;
    assert_eq!(bytes.len(), off + n * n * 24);
    let f = |i: usize| f64::from_le_bytes(bytes[off + 8 * i..off + 8 * i + 8].try_into().unwrap());
    let rec = |i: usize, j: usize| {
        let r = 3 * (j * n + i);
        [f(r), f(r + 1), f(r + 2)]
    };
    // Nyquist row/column and k = 0 are empty; h0 matches the model's accessor to the bit.
    assert_eq!(rec(0, 5), [0.0; 3]);
    assert_eq!(rec(7, 0), [0.0; 3]);
    assert_eq!(rec(16, 16), [0.0; 3]);
    let h0 = layer.h0(3, -2);
    assert_eq!(rec(19, 14)[0].to_bits(), h0.re.to_bits());
    assert_eq!(rec(19, 14)[1].to_bits(), h0.im.to_bits());
    // ω_q is a whole multiple of 2π/T.
    let omega0 = std::f64::consts::TAU / 150.0;
    let q = rec(19, 14)[2] / omega0;
    assert!((q - q.round()).abs() < 1e-9 && q >= 1.0, "{q}");

    let dk = std::f64::consts::TAU / 64.0;
    for &(x, z, t) in &[
        (3.0, -7.5, 0.0),
        (100.25, 40.0, 12.5),
        (-1e4, 2e4, 1e6 + 3.3),
    ] {
        let t_r = f64::rem_euclid(t, 150.0);
        let (xr, zr) = (f64::rem_euclid(x, 64.0), f64::rem_euclid(z, 64.0));
        let mut h = 0.0;
        for j in 0..n {
            for i in 0..n {
                let [re, im, om] = rec(i, j);
                let (m, q) = (i as f64 - 16.0, j as f64 - 16.0);
                let th = m * dk * xr + q * dk * zr - om * t_r;
                h += 2.0 * (re * th.cos() - im * th.sin());
            }
        }
        let reference = layer.sample_reference(DVec2::new(x, z), t).displacement.y;
        assert!(
            (h - reference).abs() < 1e-9,
            "({x}, {z}, {t}): rebuilt {h}, model {reference}"
        );
        assert!(reference.abs() > 1e-4, "a test point with some sea");
    }
}

#[test]
fn spectrum_of_a_non_fft_or_missing_layer_is_an_error() {
    let s = surface(MIXED);
    let meta = spectrum::SpectrumMeta {
        scene: "m".into(),
        spec_hash: String::new(),
        seed: 0,
    };
    let e = spectrum::export(&s, 1, &meta).unwrap_err();
    assert!(e.to_string().contains("gerstner layer"), "{e}");
    let e = spectrum::export(&s, 3, &meta).unwrap_err();
    assert!(e.to_string().contains("out of range"), "{e}");
}

/// The shader's particle arithmetic, replayed in f32 on the CPU from the uploaded block, against
/// the model's particle layer (ambient at three scales and two live rings), far out and late:
/// the block layout, the offsets and the formulas agree to f32 rounding.
#[test]
fn particle_block_twin_matches_the_model() {
    use swell_waves::particles::{Impact, Impacts};
    let s = surface(PARTICLES);
    let Layer::Particles(layer) = &s.layers()[1] else {
        panic!("second layer is particles")
    };
    let amb = layer.ambient();
    let origin = DVec2::new(-3.5e5, 1e6);
    let t = 9876.5;
    let impacts = Impacts::from_events(vec![
        Impact {
            t: t - 2.0,
            position: [origin.x + 4.0, origin.y - 1.0],
            strength: 0.5,
            radius: 0.8,
        },
        Impact {
            t: t - 5.0,
            position: [origin.x - 6.0, origin.y + 2.0],
            strength: 0.3,
            radius: 0.5,
        },
    ])
    .unwrap();
    let u = crate::uniforms::frame_with_impacts(&s, &impacts, t, origin);
    let (block, _) = crate::particles::block(layer, &impacts, t, origin);
    assert_eq!(&u.block[u.block.len() - block.len()..], &block[..]);
    let field = layer.field(t, Some(&impacts)).unwrap();
    let rr = (amb.radius() / amb.tile_size()) as f32;
    let inv_rr2 = 1.0 / (rr * rr);
    let kernel = |h: &mut f32, g: &mut [f32; 2], d: [f32; 2], a: f32, inv_r2: f32, gs: f32| {
        let q2 = (d[0] * d[0] + d[1] * d[1]) * inv_r2;
        if q2 < 1.0 {
            let w = 1.0 - q2;
            let k = -6.0 * a * w * w * inv_r2 * gs;
            *h += a * w * w * w;
            g[0] += k * d[0];
            g[1] += k * d[1];
        }
    };
    let mut worst = (0.0f64, 0.0f64);
    let mut rings_hit = 0;
    for i in 0..400 {
        let p = [
            ((i % 20) as f32 - 10.0) * 0.7,
            ((i / 20) as f32 - 10.0) * 0.7,
        ];
        let (mut h, mut g) = (0.0f32, [0.0f32; 2]);
        for (k, &sc) in amb.scales().iter().enumerate() {
            let inv_sl = (1.0 / (sc * amb.tile_size())) as f32;
            let off = [block[4 + 2 * k], block[4 + 2 * k + 1]];
            let fr = |v: f32| v - v.floor();
            let q = [fr(off[0] + p[0] * inv_sl), fr(off[1] + p[1] * inv_sl)];
            for j in 0..amb.len() {
                let e = &block[12 + 4 * j..16 + 4 * j];
                let mut d = [q[0] - e[0], q[1] - e[1]];
                d[0] -= d[0].round_ties_even();
                d[1] -= d[1].round_ties_even();
                kernel(&mut h, &mut g, d, sc as f32 * e[2], inv_rr2, inv_sl);
            }
        }
        let rings = &block[12 + 4 * amb.len().max(1)..];
        for k in 0..block[0] as usize {
            let (a, b) = (&rings[8 * k..8 * k + 4], &rings[8 * k + 4..8 * k + 8]);
            let rel = [p[0] - a[0], p[1] - a[1]];
            let rho = (rel[0] * rel[0] + rel[1] * rel[1]).sqrt();
            if (rho - a[2]).abs() >= b[0] {
                continue;
            }
            rings_hit += 1;
            let n = b[1] as u32;
            for j in 0..n {
                let ang = std::f32::consts::TAU * (j as f32 / n as f32);
                let d = [rel[0] - a[2] * ang.cos(), rel[1] - a[2] * ang.sin()];
                kernel(&mut h, &mut g, d, a[3], b[2], 1.0);
            }
        }
        let world = origin + DVec2::new(f64::from(p[0]), f64::from(p[1]));
        let (mh, mg) = field.sample(layer, world, 0.0);
        worst.0 = worst.0.max((f64::from(h) - mh).abs());
        worst.1 = worst
            .1
            .max((DVec2::new(f64::from(g[0]), f64::from(g[1])) - mg).length());
    }
    assert!(
        rings_hit > 10,
        "the points should cross the rings: {rings_hit}"
    );
    assert!(
        worst.0 < 2e-5 && worst.1 < 2e-4,
        "f32 twin vs model: {worst:?}"
    );
}

#[test]
fn too_many_particles_is_an_error() {
    let s = surface(r#"{"layers": [{"kind": "particles", "count": 600}]}"#);
    assert!(matches!(
        export(&s, Lang::Wgsl, None),
        Err(ShaderError::TooManyParticles { particles: 600, .. })
    ));
}

/// Particle layers at the edges of what the model accepts (the smallest and largest tiles,
/// scales and radii) export shaders that naga validates: every constant is a finite f32 (a
/// tile of 1e-39 m once wrote `inff` into the WGSL and answered 500).
#[test]
fn particle_layers_at_the_bounds_export_valid_shaders() {
    use swell_waves::particles::{MAX_SCALE, MAX_TILE_SIZE, MIN_SCALE, MIN_TILE_SIZE};
    let min_radius = 0.01;
    for (tile, radius) in [
        (MIN_TILE_SIZE, min_radius),
        (MAX_TILE_SIZE, min_radius),
        (MAX_TILE_SIZE, MAX_TILE_SIZE / 4.0),
    ] {
        let s = surface(&format!(
            r#"{{"layers": [{{"kind": "particles", "count": 8, "tile_size": {tile}, "radius": {radius}, "scales": [{MIN_SCALE}, {MAX_SCALE}]}}]}}"#
        ));
        for lang in [Lang::Wgsl, Lang::Glsl] {
            // export parses the WGSL it writes with naga first: an `inff` fails there.
            export(&s, lang, None).unwrap_or_else(|e| panic!("{tile} {radius}: {e}"));
        }
    }
}
