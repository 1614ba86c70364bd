//! The WGSL emitter: one module per surface, with every sine and Gerstner wave's constants baked
//! in and its frame phase offset read from a uniform.
//!
//! # The shader's interface
//!
//! ```wgsl
//! struct SwellUniforms { phases: array<vec4<f32>, M> }  // M = max(1, ⌈waves/4⌉)
//! @group(0) @binding(0) var<uniform> swell: SwellUniforms;
//! struct SwellCamera { view_proj: mat4x4<f32> }           // used by swell_vs only
//! @group(0) @binding(1) var<uniform> swell_camera: SwellCamera;
//!
//! struct SwellSample { displacement: vec3<f32>, d_dx: vec3<f32>, d_dz: vec3<f32> }
//! fn swell_sample(p_local: vec2<f32>) -> SwellSample     // (Dx, y, Dz) and ∂/∂x0, ∂/∂z0
//! fn swell_displacement(p_local: vec2<f32>) -> vec3<f32>
//! fn swell_height_at_undisplaced(p_local: vec2<f32>) -> f32
//! fn swell_invert(p_local: vec2<f32>) -> vec2<f32>       // the p0 whose surface point is above p
//! fn swell_height(p_local: vec2<f32>) -> f32             // elevation above p (inverted)
//! fn swell_normal(s: SwellSample) -> vec3<f32>
//! fn swell_jacobian(s: SwellSample) -> f32
//! ```
//!
//! Wave i (in layer order, then wave order; FFT layers have none) reads its phase offset from
//! `swell.phases[i / 4][i % 4]`: `φ_i(t, o)` of [`crate::uniforms::frame`], radians. Positions
//! are local: `p_local = p_world − o`, with `o` the origin the offsets were computed for.
//!
//! A surface with a particle layer adds the particle members to `SwellUniforms` after
//! `phases` and sums the particles in `swell_sample` (see [`crate::particles`]). A surface with
//! FFT layers adds `fft: array<vec4<f32>, F>` after those (the origin's grid offset per FFT
//! layer), binds each FFT layer's two result textures at `@group(1)`, and samples them in
//! `swell_sample` (see [`crate::fft`]).
//!
//! The entry points are listed in [`crate::Entry`].

use std::fmt::Write as _;

use swell_waves::{Layer, Surface};

use crate::error::ShaderError;

/// Most sine and Gerstner waves one shader carries: 1024 phase offsets are 256 vec4s, 4 KiB of
/// uniforms, a quarter of the 16 KiB uniform block WebGL2 guarantees; and the unrolled sum of
/// 1024 waves is already a slow vertex shader. Larger surfaces are an error, not a silent cut.
pub const MAX_SHADER_WAVES: usize = 1024;

/// Newton steps of `swell_height`'s inversion of `p0 + D(p0) = p`. From p0 = p, each step
/// roughly squares the error; the model's default inversion converges to 10⁻⁵ m in 3 steps at
/// fold number 0.95 (`STACK.md`), and one more keeps the f32 result at its own rounding.
pub const NEWTON_STEPS: u32 = 4;

/// The per-wave constants baked into the shader, rounded to f32 from f64 products:
/// `k·d.x`, `k·d.z`, `A`, `Q·A·d.x`, `Q·A·d.z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaveConstants {
    /// `k·d` (rad/m), the local phase gradient.
    pub kd: [f32; 2],
    /// Amplitude A, m.
    pub amplitude: f32,
    /// `Q·A·d` (m), the horizontal displacement amplitude.
    pub qad: [f32; 2],
}

/// The constants of every sine and Gerstner wave of `surface`, in uniform-slot order.
///
/// # Errors
/// [`ShaderError::TooManyWaves`] past [`MAX_SHADER_WAVES`]; [`ShaderError::NotRepresentable`]
/// when a constant overflows f32.
pub fn wave_constants(surface: &Surface) -> Result<Vec<WaveConstants>, ShaderError> {
    let waves: Vec<_> = surface
        .layers()
        .iter()
        .flat_map(|l| l.waves().iter())
        .collect();
    if waves.len() > MAX_SHADER_WAVES {
        return Err(ShaderError::TooManyWaves {
            waves: waves.len(),
            max: MAX_SHADER_WAVES,
        });
    }
    waves
        .iter()
        .enumerate()
        .map(|(i, w)| {
            let (dx, dz) = (w.direction.x, w.direction.y);
            let qa = w.steepness * w.amplitude;
            let f = |what: &'static str, value: f64| {
                let v = value as f32;
                if v.is_finite() {
                    Ok(v)
                } else {
                    Err(ShaderError::NotRepresentable {
                        wave: i,
                        what,
                        value,
                    })
                }
            };
            Ok(WaveConstants {
                kd: [
                    f("k·d.x", w.wavenumber * dx)?,
                    f("k·d.z", w.wavenumber * dz)?,
                ],
                amplitude: f("amplitude", w.amplitude)?,
                qad: [f("Q·A·d.x", qa * dx)?, f("Q·A·d.z", qa * dz)?],
            })
        })
        .collect()
}

/// Number of vec4s in `SwellUniforms.phases` for `waves` waves: `max(1, ⌈waves/4⌉)` (WGSL has
/// no zero-length uniform arrays).
pub fn phase_vec4s(waves: usize) -> usize {
    waves.div_ceil(4).max(1)
}

/// An f32 as a WGSL literal that parses back to the same bits (`{:?}` is Rust's shortest
/// round-trip form, `1e-5`, `0.12`, `-3.0`, all valid WGSL with the `f` suffix).
fn lit(v: f32) -> String {
    format!("{v:?}f")
}

/// The WGSL module for `surface` (see the [module docs](self) for its interface).
///
/// # Errors
/// As [`wave_constants`].
pub fn emit(surface: &Surface) -> Result<String, ShaderError> {
    let consts = wave_constants(surface)?;
    let particles = crate::particles::layer(surface)?.map(crate::particles::wgsl);
    let fft = crate::fft::sampling_wgsl(surface);
    let m = phase_vec4s(consts.len());
    let mut s = String::with_capacity(4096 + 160 * consts.len());
    let w = &mut s;
    // Writing to a String cannot fail; the results are ignored below for that reason.
    let _ = writeln!(
        w,
        "// Generated by swell-shaders {} (naga {}) from a Swell surface; model version {}.\n\
         // Do not edit: fetch it again when the scene's spec_hash or model_version changes.\n\
         //\n\
         // Conventions: y up, the sea in x/z, metres, seconds, radians. Wave i moves the\n\
         // undisplaced point p0 by (Q·A·d.x·cos θ, A·sin θ, Q·A·d.z·cos θ),\n\
         // θ = k·(d·p_local) + φ_i, where the host computes, in f64, once per frame,\n\
         //   φ_i(t, o) = wrap(k_i·(d_i·o) − ω_i·t + φ_i)  (wrap: reduce to [−π, π])\n\
         // for a render origin o near the camera, and p_local = p_world − o (x/z).\n\
         // GET /v1/scenes/{{id}}/uniforms?t=&origin=x,z returns exactly these values.",
        env!("CARGO_PKG_VERSION"),
        crate::NAGA_VERSION,
        swell_waves::MODEL_VERSION,
    );
    let mut slot = 0;
    for (li, layer) in surface.layers().iter().enumerate() {
        let (kind, n) = match layer {
            Layer::Sine(_) => ("sine", layer.waves().len()),
            Layer::Gerstner(_) => ("gerstner", layer.waves().len()),
            Layer::Fft(f) => {
                let _ = writeln!(
                    w,
                    "// layer {li}: fft, N = {n}, tile {l} m, sampled from its pass module's result \
                     textures swell_fft{li}_a/_b (passes: GET /v1/scenes/{{id}}/shader?entry=swell_fft_evolve\
                     &layer={li}; spectrum: GET /v1/scenes/{{id}}/spectrum?layer={li})",
                    n = f.resolution(),
                    l = f.tile_size(),
                );
                continue;
            }
            Layer::Particles(p) => {
                let _ = writeln!(
                    w,
                    "// layer {li}: particles: {} ambient particles × {} scale(s), positions and \
                     live rings from the uniforms",
                    p.ambient().len(),
                    p.ambient().scales().len()
                );
                continue;
            }
        };
        let _ = writeln!(
            w,
            "// layer {li}: {kind}, {n} waves, phase slots {slot}..{}",
            slot + n
        );
        slot += n;
    }
    let _ = writeln!(
        w,
        "\nconst SWELL_WAVES: u32 = {n}u;\n\
         const SWELL_TAU: f32 = 6.2831855f;\n\
         \n\
         // Phase offsets φ_i(t, o), radians, wave i at phases[i / 4][i % 4] (std140-compatible).\n\
         struct SwellUniforms {{\n    phases: array<vec4<f32>, {m}>,\n{pm}}}\n\
         @group(0) @binding(0) var<uniform> swell: SwellUniforms;\n\
         \n\
         // The render entry point's camera: clip = view_proj · (local position, 1).\n\
         struct SwellCamera {{\n    view_proj: mat4x4<f32>,\n}}\n\
         @group(0) @binding(1) var<uniform> swell_camera: SwellCamera;\n\
         \n\
         // The summed waves at one undisplaced local point: displacement (Dx, y, Dz) and its\n\
         // derivatives along x0 and z0.\n\
         struct SwellSample {{\n    displacement: vec3<f32>,\n    d_dx: vec3<f32>,\n    d_dz: vec3<f32>,\n}}\n",
        n = consts.len(),
        pm = particles.as_ref().map_or(String::new(), |p| p.0.clone())
            + fft.as_ref().map_or("", |f| f.0.as_str()),
    );
    w.push_str(WAVE_FN);
    if let Some((_, funcs, _)) = &particles {
        w.push_str(funcs);
    }
    if let Some((_, funcs, _)) = &fft {
        w.push_str(funcs);
    }
    let _ = writeln!(
        w,
        "\n// Every sine and Gerstner wave at the undisplaced local point p (m).\n\
         fn swell_sample(p: vec2<f32>) -> SwellSample {{\n    \
         var s = SwellSample(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));"
    );
    for (i, c) in consts.iter().enumerate() {
        let _ = writeln!(
            w,
            "    s = swell_wave(s, p, vec2<f32>({}, {}), swell.phases[{}].{}, {}, vec2<f32>({}, {}));",
            lit(c.kd[0]),
            lit(c.kd[1]),
            i / 4,
            ["x", "y", "z", "w"][i % 4],
            lit(c.amplitude),
            lit(c.qad[0]),
            lit(c.qad[1]),
        );
    }
    if let Some((_, _, calls)) = &particles {
        w.push_str(calls);
    }
    if let Some((_, _, calls)) = &fft {
        w.push_str(calls);
    }
    w.push_str("    return s;\n}\n");
    w.push_str(HELPERS);
    if crate::fft::layers(surface)
        .iter()
        .any(|(_, f)| f.choppiness() > 0.0)
    {
        // Choppy FFT layers move points metres: the server's inversion (see crate::fft).
        w.push_str(&crate::fft::height_newton());
    } else if surface.layers().iter().any(|l| match l {
        Layer::Gerstner(_) => l.waves().iter().any(|w| w.steepness > 0.0),
        _ => false,
    }) {
        let _ = write!(
            w,
            "{}",
            HEIGHT_NEWTON.replace("NEWTON_STEPS", &NEWTON_STEPS.to_string())
        );
    } else {
        w.push_str(HEIGHT_DIRECT);
    }
    w.push_str(ENTRY_POINTS);
    Ok(s)
}

/// One wave's contribution, the model's `accumulate_with` in f32. The local phase is wrapped to
/// [−π, π] before `sin`/`cos` (GPU trig is accurate only there); `g` is the common factor of the
/// six derivatives: `∂/∂x0 = k·d.x·g`, `∂/∂z0 = k·d.z·g`.
const WAVE_FN: &str = "
// One wave: kd = k·d (rad/m), phi = φ_i(t, o) (rad), a = A (m), qad = Q·A·d (m).
fn swell_wave(s: SwellSample, p: vec2<f32>, kd: vec2<f32>, phi: f32, a: f32, qad: vec2<f32>) -> SwellSample {
    let raw = kd.x * p.x + kd.y * p.y + phi;
    let theta = raw - SWELL_TAU * round(raw / SWELL_TAU);
    let sn = sin(theta);
    let cs = cos(theta);
    let g = vec3<f32>(-qad.x * sn, a * cs, -qad.y * sn);
    var o = s;
    o.displacement = o.displacement + vec3<f32>(qad.x * cs, a * sn, qad.y * cs);
    o.d_dx = o.d_dx + kd.x * g;
    o.d_dz = o.d_dz + kd.y * g;
    return o;
}
";

const HELPERS: &str = "
// (Dx, y, Dz) at the undisplaced local point p.
fn swell_displacement(p: vec2<f32>) -> vec3<f32> {
    return swell_sample(p).displacement;
}

// Elevation of the surface point that started at p (no inversion).
fn swell_height_at_undisplaced(p: vec2<f32>) -> f32 {
    return swell_sample(p).displacement.y;
}

// Unit normal of the displaced surface: (e_z + d_dz) × (e_x + d_dx), normalised; straight up where
// the tangents are degenerate (a fold's edge).
fn swell_normal(s: SwellSample) -> vec3<f32> {
    let n = cross(vec3<f32>(0.0, 0.0, 1.0) + s.d_dz, vec3<f32>(1.0, 0.0, 0.0) + s.d_dx);
    let len2 = dot(n, n);
    if (len2 > 1e-30f) {
        return n * inverseSqrt(len2);
    }
    return vec3<f32>(0.0, 1.0, 0.0);
}

// Jacobian determinant of p0 -> p0 + (Dx, Dz): J <= 0 where the surface folds (foam).
fn swell_jacobian(s: SwellSample) -> f32 {
    return (1.0 + s.d_dx.x) * (1.0 + s.d_dz.z) - s.d_dz.x * s.d_dx.z;
}
";

const HEIGHT_NEWTON: &str = "
// The undisplaced point whose surface point lies above the local point p: solves
// p0 + (Dx, Dz)(p0) = p by Newton's method from p0 = p (NEWTON_STEPS steps; the Gerstner fold
// number < 1 keeps the Jacobian positive).
fn swell_invert(p: vec2<f32>) -> vec2<f32> {
    var p0 = p;
    for (var i = 0u; i < NEWTON_STEPSu; i = i + 1u) {
        let s = swell_sample(p0);
        let r = p0 + s.displacement.xz - p;
        let a = 1.0 + s.d_dx.x;
        let b = s.d_dz.x;
        let c = s.d_dx.z;
        let d = 1.0 + s.d_dz.z;
        let det = a * d - b * c;
        p0 = p0 - vec2<f32>(d * r.x - b * r.y, a * r.y - c * r.x) / det;
    }
    return p0;
}

// Elevation of the surface above the local point p.
fn swell_height(p: vec2<f32>) -> f32 {
    return swell_sample(swell_invert(p)).displacement.y;
}
";

const HEIGHT_DIRECT: &str = "
// The undisplaced point whose surface point lies above p: p itself (no wave here moves the
// surface horizontally).
fn swell_invert(p: vec2<f32>) -> vec2<f32> {
    return p;
}

// Elevation of the surface above the local point p.
fn swell_height(p: vec2<f32>) -> f32 {
    return swell_sample(p).displacement.y;
}
";

const ENTRY_POINTS: &str = "
struct SwellVertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) jacobian: f32,
}

// Render vertex shader: a grid vertex at undisplaced local x/z, displaced by the sea.
@vertex
fn swell_vs(@location(0) p_local: vec2<f32>) -> SwellVertexOut {
    let s = swell_sample(p_local);
    let pos = vec3<f32>(p_local.x, 0.0, p_local.y) + s.displacement;
    return SwellVertexOut(swell_camera.view_proj * vec4<f32>(pos, 1.0), pos, swell_normal(s), swell_jacobian(s));
}

struct SwellProbeVarying {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) p_local: vec2<f32>,
}

// Probe vertex shader: one point per probe, drawn at clip_xy, carrying its local x/z.
@vertex
fn swell_probe_vs(@location(0) p_local: vec2<f32>, @location(1) clip_xy: vec2<f32>) -> SwellProbeVarying {
    return SwellProbeVarying(vec4<f32>(clip_xy, 0.0, 1.0), p_local);
}

struct SwellProbeOut {
    @location(0) displacement: vec4<f32>,
    @location(1) normal: vec4<f32>,
}

// Probe fragment shader, the answers of /sample at the probe's world point: (Dx, y, Dz) of the
// point taken as undisplaced and the Jacobian, normal and height of the surface point above it.
@fragment
fn swell_probe_fs(@location(0) @interpolate(flat) p_local: vec2<f32>) -> SwellProbeOut {
    let at = swell_sample(p_local);
    let above = swell_sample(swell_invert(p_local));
    return SwellProbeOut(vec4<f32>(at.displacement, swell_jacobian(above)), vec4<f32>(swell_normal(above), above.displacement.y));
}
";
