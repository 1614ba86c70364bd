//! FFT layers on the GPU: the evolution step, a fragment-pass inverse 2-D FFT (WebGL2 / GLSL ES
//! 3.00 and every other language naga writes; a compute version of the same per-texel work for
//! the others, [`emit_compute`]), and the assembly and sampling of the transformed grids in the
//! surface shader.
//!
//! # The passes, per FFT layer and frame
//!
//! Generated per layer ([`emit_passes`]) from its built parameters: resolution N, tile side L,
//! choppiness λ and the largest frequency index (below). Every pass draws one full-screen
//! triangle (`swell_fft_vs`, three vertices, no attributes) into two RGBA32F N×N targets:
//!
//! 1. **Evolve** (`swell_fft_evolve`, once): reads the spectrum texture (N×N RGBA32F, texel
//!    (i, j) = `(h0.re, h0.im, q, 0)` of `/spectrum` record (i, j), `q = ω_q·T/2π`, a whole
//!    number) and writes the spectra of the eight grids, two real grids per complex value, in
//!    FFT order (texel (u, v) holds mode `m = u` for `u < N/2`, else `u − N`; likewise v):
//!    target 0 = `(Dx + i·h, Dz + i·∂Dx/∂x)`, target 1 = `(∂h/∂x + i·∂h/∂z, ∂Dz/∂z + i·∂Dx/∂z)`.
//! 2. **Butterflies** (`swell_fft_butterfly`, 2·log₂N times): one radix-2 Stockham stage of an
//!    unnormalised inverse DFT (`e^{+i…}`) along x (`stage.y = 0`) for half-spans
//!    `Ns = 1, 2, …, N/2` (`stage.x`), then along z (`stage.y = 1`) likewise; ping-pong between
//!    two pairs of targets. Stockham needs no bit reversal: input and output are in natural
//!    order. Since every grid is real, after the last stage target 0 holds
//!    `(Dx, h, Dz, ∂Dx/∂x)` and target 1 `(∂h/∂x, ∂h/∂z, ∂Dz/∂z, ∂Dx/∂z)` at grid node (i, j)
//!    (the layout of the viewer's CPU FFT textures, so either source fills the same samplers),
//!    the point `(i·L/N, j·L/N)`: the model's grids ([`swell_waves::fft::FftGrid`]).
//!
//! The surface shader ([`crate::wgsl`]) then samples those two textures with the model's
//! Catmull–Rom filter (the server's default) and adds them to `swell_sample`, so displacement,
//! normal, Jacobian and the inverted height include the FFT layer like any other.
//!
//! # Precision by construction: the per-frame phase
//!
//! Mode k's phase is `ω_q·t`. ω_q is a whole multiple q of `ω0 = 2π/T`, so `ω_q·t = 2π·q·τ (mod
//! 2π)` with `τ = (t mod T)/T ∈ [0, 1)`, reduced on the host in f64. In f32, `q·τ` loses about
//! `q·2⁻²⁴` cycles (1.2·10⁻⁴ rad measured on storm, q ≤ 315). So the host splits τ into three f32s
//! ([`cycle`]): `τ₁ = ⌊τ·2^b⌋/2^b`, `τ₂ = ⌊(τ − τ₁)·2^{2b}⌋/2^{2b}`, `τ₃ = τ − τ₁ − τ₂`, with `b =
//! 24 − bits(q_max)` (q_max the layer's largest q, baked in the shader). Then `q·τ₁` and `q·τ₂` are
//! exact in f32 (at most 24 significant bits), their `fract` too, and `q·τ₃ < 2^{24−3b}` is small:
//! the shader's phase `2π·(fract(q·τ₁) + fract(q·τ₂) + q·τ₃)`, wrapped to [−π, π], is off by 4·10⁻⁷
//! rad at most (measured up to t = 10⁹ s) whatever t is. Its sine and cosine, and the butterflies'
//! twiddles, come from the model's f32 turn kernel, not the GPU's `sin`/`cos`. Layers whose q_max
//! needs `b < 8` (a repeat period far longer than the waves need) are refused
//! ([`ShaderError::BadLayer`]).
//!
//! The sampling shader gets the render origin's place on the tile the same way: per FFT layer,
//! `((o.x mod L)·N/L, (o.z mod L)·N/L)` in f64 ([`grid_offset`]), so the shader's grid
//! coordinate `offset + p_local·N/L` stays small.
//!
//! # Uniforms
//! - Pass module, `@group(0) @binding(0)`: `SwellFftPass { cycle: vec4<f32>, stage: vec4<f32> }`:
//!   `cycle.xyz = (τ₁, τ₂, τ₃)` for the evolve pass; `stage.xy = (Ns, axis)` for a butterfly.
//!   `@binding(1)`, `@binding(2)`: the input textures (evolve: the spectrum texture at 1, 2 is
//!   not read; butterfly: the previous pass's two targets). The compute module writes to
//!   storage textures at `@binding(3)` and `@binding(4)` instead of render targets.
//! - Surface module: `SwellUniforms.fft[f].xy`, the grid offset of FFT layer f (f counts FFT
//!   layers in layer order), after the phase and particle members; FFT layer f's two result
//!   textures at `@group(1) @binding(2f)` and `@binding(2f + 1)`.
//!
//! # Time
//! The GPU evaluates the layer at t itself: the server's `accuracy.time = "exact"`. Its default
//! answers interpolate linearly between frames at grid times `n·time_step` (the spectrum
//! header's `time_step`), a few tenths of a millimetre away (up to about 1 mm on `storm`); the
//! browser test measures both.

use std::fmt::Write as _;

use swell_waves::fft::FftLayer;
use swell_waves::{Layer, Surface};

use crate::error::ShaderError;

/// Smallest piece width b of the phase split: below 8 bits `q·τ₃` is no longer small (see the
/// [module docs](self)), i.e. q_max ≥ 2¹⁶.
pub const MIN_CYCLE_BITS: u32 = 8;

/// The FFT layers of `surface`: `(layer index, layer)`, in layer order (f = position here).
pub fn layers(surface: &Surface) -> Vec<(usize, &FftLayer)> {
    surface
        .layers()
        .iter()
        .enumerate()
        .filter_map(|(i, l)| match l {
            Layer::Fft(f) => Some((i, &**f)),
            _ => None,
        })
        .collect()
}

/// The frequency index of an exported ω_q: `ω_q·T/2π` rounded (ω_q is a whole multiple of 2π/T,
/// so this is exact up to the rounding of the division).
pub fn frequency_index(omega_q: f64, repeat_period: f64) -> f64 {
    (omega_q * repeat_period / swell_waves::math::TAU).round()
}

/// The largest frequency index q among `layer`'s exported records: that of the corner mode
/// `(N/2 − 1, N/2 − 1)`, the longest wave vector written, since ω(k) grows with k (deep or
/// finite depth) and the quantisation `floor(ω/ω0)` keeps the order. Formed as
/// [`crate::spectrum::records`] forms ω_q, so it is the maximum over the records (tested), at
/// the cost of one mode rather than N² (`/uniforms` calls it every frame).
pub fn max_frequency_index(
    layer: &FftLayer,
    dispersion: &swell_waves::spectrum::Dispersion,
) -> u64 {
    let h = (layer.resolution() / 2) as i32 - 1;
    let dk = swell_waves::math::TAU / layer.tile_size();
    let omega0 = swell_waves::math::TAU / layer.repeat_period();
    let len = glam::DVec2::new(f64::from(h) * dk, f64::from(h) * dk).length();
    let omega = (dispersion.omega(len) / omega0).floor() * omega0;
    frequency_index(omega, layer.repeat_period()) as u64
}

/// Piece width b of the phase split for a layer whose largest frequency index is `q_max`:
/// `24 − bits(q_max)`.
///
/// # Errors
/// [`ShaderError::BadLayer`] when b would be below [`MIN_CYCLE_BITS`].
pub fn cycle_bits(layer_index: usize, q_max: u64) -> Result<u32, ShaderError> {
    let bits = 64 - q_max.leading_zeros();
    if bits + MIN_CYCLE_BITS > 24 {
        return Err(ShaderError::BadLayer {
            layer: layer_index,
            reason: format!(
                "its highest frequency is {q_max}·2π/T: the shader's f32 phase needs it below 2^{}; shorten repeat_period",
                24 - MIN_CYCLE_BITS
            ),
        });
    }
    Ok(24 - bits)
}

/// The evolve pass's `cycle` uniform at time `t` (s): `[τ₁, τ₂, τ₃, 0]` of the
/// [module docs](self), formed in f64 from `τ = t.rem_euclid(T)/T` and split at `bits`.
pub fn cycle(t: f64, repeat_period: f64, bits: u32) -> [f32; 4] {
    let tau = t.rem_euclid(repeat_period) / repeat_period;
    let s1 = f64::from(1u32 << bits);
    let s2 = s1 * s1;
    let t1 = (tau * s1).floor() / s1;
    let r = tau - t1;
    let t2 = (r * s2).floor() / s2;
    let t3 = r - t2;
    // τ₁ and τ₂ have at most `bits` significant bits: exact in f32.
    [t1 as f32, t2 as f32, t3 as f32, 0.0]
}

/// The render origin's grid coordinate on `layer`'s tile: `((o mod L)·N/L)` per axis, in
/// `[0, N)`, formed in f64 (the sampling shader adds `p_local·N/L`).
pub fn grid_offset(layer: &FftLayer, origin: glam::DVec2) -> [f32; 2] {
    let l = layer.tile_size();
    let n = layer.resolution() as f64;
    let g = |x: f64| {
        let v = x.rem_euclid(l) * n / l;
        // rem_euclid can round up to L for tiny negative x: that is node 0 again.
        (if v >= n { 0.0 } else { v }) as f32
    };
    [g(origin.x), g(origin.y)]
}

/// An f32 as a WGSL literal (Rust's shortest round-trip form).
fn lit(v: f32) -> String {
    format!("{v:?}f")
}

/// The WGSL pass module for the FFT layer at index `layer` of `surface` (see the
/// [module docs](self)): entry points `swell_fft_vs`, `swell_fft_evolve`, `swell_fft_butterfly`.
///
/// # Errors
/// [`ShaderError::BadLayer`] when `layer` is not an FFT layer of `surface`, or its frequencies
/// are too high for the f32 phase ([`cycle_bits`]).
pub fn emit_passes(surface: &Surface, layer: usize) -> Result<String, ShaderError> {
    Ok(emit_common(surface, layer)? + FRAGMENT_ENTRIES)
}

/// The WGSL compute version of [`emit_passes`]: entry points `swell_fft_evolve_cs` and
/// `swell_fft_butterfly_cs` (workgroups of 8×8, one invocation per texel), the same uniforms
/// and inputs, outputs to RGBA32F storage textures at `@binding(3)` and `@binding(4)`. The same
/// arithmetic as the fragment passes per texel (not a workgroup-shared Stockham: each stage is
/// one dispatch, 2·log₂N of them). Validated by naga; run by headless Chromium's WebGPU
/// (`tests/server/browser_fft.rs`), where it reads back the fragment passes' values to the bit.
///
/// # Errors
/// As [`emit_passes`].
pub fn emit_compute(surface: &Surface, layer: usize) -> Result<String, ShaderError> {
    Ok(emit_common(surface, layer)? + COMPUTE_ENTRIES)
}

/// Header, per-layer constants, the turn kernel and the per-texel pass functions.
fn emit_common(surface: &Surface, layer: usize) -> Result<String, ShaderError> {
    let f = crate::spectrum::fft_layer(surface, layer)?;
    let q_max = max_frequency_index(f, &surface.dispersion());
    let bits = cycle_bits(layer, q_max)?;
    let n = f.resolution();
    let dk = swell_waves::math::TAU / f.tile_size();
    let mut s = String::with_capacity(8192);
    let _ = writeln!(
        s,
        "// Generated by swell-shaders {} (naga {}) for FFT layer {layer}; model version {}.\n\
         // Do not edit: fetch it again when the scene's spec_hash or model_version changes.\n\
         //\n\
         // N = {n}, tile L = {l} m, choppiness {lambda}, repeat period T = {t} s, largest\n\
         // frequency index q_max = {q_max}, phase split b = {bits} bits.\n\
         // Per frame: one swell_fft_evolve pass, then 2·log2(N) = {passes} swell_fft_butterfly\n\
         // passes (Ns = 1, 2, …, N/2 along x, then along z), ping-pong, two RGBA32F N×N targets.\n\
         // cycle.xyz: tau = (t mod T)/T split in f64: t1 = floor(tau·2^b)/2^b,\n\
         // t2 = floor((tau − t1)·2^2b)/2^2b, t3 = tau − t1 − t2 (GET /v1/scenes/{{id}}/uniforms\n\
         // gives them as fft[*].cycle).",
        env!("CARGO_PKG_VERSION"),
        crate::NAGA_VERSION,
        swell_waves::MODEL_VERSION,
        l = f.tile_size(),
        lambda = f.choppiness(),
        t = f.repeat_period(),
        passes = 2 * n.trailing_zeros(),
    );
    let _ = write!(
        s,
        "
const SWELL_FFT_N: i32 = {n}i;
// Δk = 2π/L, rad/m.
const SWELL_FFT_DK: f32 = {dk};
// Choppiness λ.
const SWELL_FFT_LAMBDA: f32 = {lambda};
{sincos}{PASSES}",
        sincos = sincos_wgsl(),
        dk = lit(dk as f32),
        lambda = lit(f.choppiness() as f32),
    );
    Ok(s)
}

// The polynomials of the model's single-precision turn kernel
// (`swell_waves::math::sin_cos_turns_f32`), the model's own constants: `sin(πu)` and `cos(πu)`
// on u ∈ [−½, ½]. The passes use it rather than the GPU's `sin`/`cos`, whose accuracy is the
// driver's (SwiftShader's cost a 256² storm layer 3 mm of displacement through the twiddles;
// this kernel is within 5·10⁻⁷ everywhere and the same on every GPU). A test pins the shader's
// kernel to the model's, bit for bit.
use swell_waves::math::{COSPI_F32 as COSPI, SINPI_F32 as SINPI};

/// `(sin 2πu, cos 2πu)` for u in [−½, ½], the shader's `swell_sincos_turns` in Rust (the same
/// operations in the same order as the model's kernel), for the CPU twin of the passes.
#[cfg(test)]
pub(crate) fn sin_cos_turns(u: f32) -> (f32, f32) {
    let z = u * u;
    let s = u * (SINPI[0] + z * (SINPI[1] + z * (SINPI[2] + z * (SINPI[3] + z * SINPI[4]))));
    let c = COSPI[0] + z * (COSPI[1] + z * (COSPI[2] + z * (COSPI[3] + z * COSPI[4])));
    ((s + s) * c, c * c - s * s)
}

fn sincos_wgsl() -> String {
    let (s, c) = (SINPI.map(lit), COSPI.map(lit));
    format!(
        "
// (sin 2πu, cos 2πu) for u in turns in [−½, ½]: the model's f32 kernel (half-angle form of
// degree-9/8 polynomials for sin πu, cos πu), within 5e-7, independent of the GPU's sin/cos.
fn swell_sincos_turns(u: f32) -> vec2<f32> {{
    let z = u * u;
    let s = u * ({} + z * ({} + z * ({} + z * ({} + z * {}))));
    let c = {} + z * ({} + z * ({} + z * ({} + z * {})));
    return vec2<f32>((s + s) * c, c * c - s * s);
}}
",
        s[0], s[1], s[2], s[3], s[4], c[0], c[1], c[2], c[3], c[4]
    )
}

/// The layer-independent body of the pass module (the constants above it are per layer).
const PASSES: &str = r"
// cycle.xyz: the evolve pass's phase split (t1, t2, t3); stage.xy: a butterfly's (Ns, axis).
struct SwellFftPass {
    cycle: vec4<f32>,
    stage: vec4<f32>,
}
@group(0) @binding(0) var<uniform> swell_fft_pass: SwellFftPass;
// Evolve: the spectrum texture (h0.re, h0.im, q, 0). Butterfly: the previous pass's targets.
@group(0) @binding(1) var swell_fft_in_a: texture_2d<f32>;
@group(0) @binding(2) var swell_fft_in_b: texture_2d<f32>;

struct SwellFftOut {
    @location(0) a: vec4<f32>,
    @location(1) b: vec4<f32>,
}


fn swell_cmul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

// X + i·Y for the spectra X, Y of two real grids: its inverse transform is x + i·y.
fn swell_pack(x: vec2<f32>, y: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(x.x - y.y, x.y + y.x);
}

// c·h for an imaginary multiplier c = i·r.
fn swell_times_i(r: f32, h: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(-(r * h.y), r * h.x);
}

// h~(k, t) = h0(k)·e^{-iθ} + conj(h0(-k))·e^{+iθ}, θ = ω_q·t = 2π·q·τ, for the mode at FFT-order
// texel (u, v); then the eight grids' spectra c(k)·h~ (the model's FftGrid multipliers).
fn swell_fft_evolve_at(uv: vec2<i32>) -> SwellFftOut {
    let n = SWELL_FFT_N;
    // Spectrum record (i, j) holds mode (i − N/2, j − N/2); FFT texel u holds mode u or u − N.
    let rec = (uv + vec2<i32>(n / 2)) & vec2<i32>(n - 1);
    let mirror = (vec2<i32>(n) - rec) & vec2<i32>(n - 1);
    let s0 = textureLoad(swell_fft_in_a, rec, 0);
    let s1 = textureLoad(swell_fft_in_a, mirror, 0);
    let c = swell_fft_pass.cycle;
    let q = s0.z;
    // fract(q·t1) and fract(q·t2) are exact (at most 24 significant bits); q·t3 is small.
    var cyc = fract(q * c.x) + fract(q * c.y);
    cyc = cyc - round(cyc) + q * c.z;
    // θ = 2π·u, u in turns in [−½, ½].
    let sc = swell_sincos_turns(cyc - round(cyc));
    let sn = sc.x;
    let cs = sc.y;
    let a = s0.x;
    let b = s0.y;
    let p = s1.x;
    let pq = s1.y;
    let h = vec2<f32>((a * cs + b * sn) + (p * cs + pq * sn), (b * cs - a * sn) + (p * sn - pq * cs));
    let m = vec2<f32>(rec - vec2<i32>(n / 2));
    let kx = m.x * SWELL_FFT_DK;
    let kz = m.y * SWELL_FFT_DK;
    let k2 = kx * kx + kz * kz;
    if (k2 == 0.0) {
        return SwellFftOut(vec4<f32>(0.0), vec4<f32>(0.0));
    }
    let inv_k = inverseSqrt(k2);
    let lam = SWELL_FFT_LAMBDA;
    let dx = swell_times_i(lam * kx * inv_k, h);
    let dz = swell_times_i(lam * kz * inv_k, h);
    let sx = swell_times_i(kx, h);
    let sz = swell_times_i(kz, h);
    let jxx = -(lam * kx * kx * inv_k) * h;
    let jzz = -(lam * kz * kz * inv_k) * h;
    let jxz = -(lam * kx * kz * inv_k) * h;
    let z0 = swell_pack(dx, h);
    let z1 = swell_pack(dz, jxx);
    let z2 = swell_pack(sx, sz);
    let z3 = swell_pack(jzz, jxz);
    return SwellFftOut(vec4<f32>(z0, z1), vec4<f32>(z2, z3));
}

// One radix-2 Stockham stage of the inverse DFT along an axis, half-span Ns: output index x
// (along the axis) reads inputs j and j + N/2, j = (x / 2Ns)·Ns + x mod Ns, and writes
// a + w·b (x mod 2Ns < Ns) or a − w·b, w = e^{+iπ·(x mod Ns)/Ns}.
fn swell_fft_butterfly_at(xy: vec2<i32>) -> SwellFftOut {
    let n = SWELL_FFT_N;
    let ns = i32(swell_fft_pass.stage.x);
    let axis = i32(swell_fft_pass.stage.y);
    var x = xy.x;
    if (axis == 1) {
        x = xy.y;
    }
    let k = x & (ns - 1);
    let j = (x / (2 * ns)) * ns + k;
    var ia = vec2<i32>(j, xy.y);
    var ib = vec2<i32>(j + n / 2, xy.y);
    if (axis == 1) {
        ia = vec2<i32>(xy.x, j);
        ib = vec2<i32>(xy.x, j + n / 2);
    }
    // w = e^{iπ·k/Ns}: k/(2Ns) turns, in [0, ½).
    let sc = swell_sincos_turns(f32(k) / f32(2 * ns));
    let w = vec2<f32>(sc.y, sc.x);
    var sign = 1.0;
    if ((x & ns) != 0) {
        sign = -1.0;
    }
    let a0 = textureLoad(swell_fft_in_a, ia, 0);
    let b0 = textureLoad(swell_fft_in_a, ib, 0);
    let a1 = textureLoad(swell_fft_in_b, ia, 0);
    let b1 = textureLoad(swell_fft_in_b, ib, 0);
    let o0 = vec4<f32>(a0.xy + sign * swell_cmul(w, b0.xy), a0.zw + sign * swell_cmul(w, b0.zw));
    let o1 = vec4<f32>(a1.xy + sign * swell_cmul(w, b1.xy), a1.zw + sign * swell_cmul(w, b1.zw));
    return SwellFftOut(o0, o1);
}
";

/// The fragment-pass entry points (every language, WebGL2 included).
const FRAGMENT_ENTRIES: &str = r"
// A full-screen triangle: draw 3 vertices, no attributes.
@vertex
fn swell_fft_vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn swell_fft_evolve(@builtin(position) frag: vec4<f32>) -> SwellFftOut {
    return swell_fft_evolve_at(vec2<i32>(floor(frag.xy)));
}

@fragment
fn swell_fft_butterfly(@builtin(position) frag: vec4<f32>) -> SwellFftOut {
    return swell_fft_butterfly_at(vec2<i32>(floor(frag.xy)));
}
";

/// The compute entry points (WebGPU, GLSL 4.50, HLSL, MSL): the same per-texel work, one
/// invocation per texel, written to two storage textures.
const COMPUTE_ENTRIES: &str = r"
// The outputs: two RGBA32F storage textures (the fragment version's two targets).
@group(0) @binding(3) var swell_fft_out_a: texture_storage_2d<rgba32float, write>;
@group(0) @binding(4) var swell_fft_out_b: texture_storage_2d<rgba32float, write>;

// Dispatch ⌈N/8⌉ × ⌈N/8⌉ workgroups.
@compute @workgroup_size(8, 8)
fn swell_fft_evolve_cs(@builtin(global_invocation_id) id: vec3<u32>) {
    let xy = vec2<i32>(id.xy);
    if (xy.x >= SWELL_FFT_N || xy.y >= SWELL_FFT_N) {
        return;
    }
    let o = swell_fft_evolve_at(xy);
    textureStore(swell_fft_out_a, xy, o.a);
    textureStore(swell_fft_out_b, xy, o.b);
}

@compute @workgroup_size(8, 8)
fn swell_fft_butterfly_cs(@builtin(global_invocation_id) id: vec3<u32>) {
    let xy = vec2<i32>(id.xy);
    if (xy.x >= SWELL_FFT_N || xy.y >= SWELL_FFT_N) {
        return;
    }
    let o = swell_fft_butterfly_at(xy);
    textureStore(swell_fft_out_a, xy, o.a);
    textureStore(swell_fft_out_b, xy, o.b);
}
";

/// The sampling part of the surface module for the FFT layers of `surface`: the uniform
/// member (empty without FFT layers), the texture bindings and functions, and the lines
/// `swell_sample` adds. `None` without FFT layers.
pub fn sampling_wgsl(surface: &Surface) -> Option<(String, String, String)> {
    let fl = layers(surface);
    if fl.is_empty() {
        return None;
    }
    let member = format!("    fft: array<vec4<f32>, {}>,\n", fl.len());
    let mut funcs = String::from(SAMPLE_HELPERS);
    let mut calls = String::new();
    for (f, (li, layer)) in fl.iter().enumerate() {
        let n = layer.resolution();
        let _ = write!(
            funcs,
            "
// FFT layer {li}: N = {n}, tile {l} m. Its two result textures (the last butterfly pass's
// targets): (Dx, h, Dz, dDx/dx) and (dh/dx, dh/dz, dDz/dz, dDx/dz) per grid node.
@group(1) @binding({ba}) var swell_fft{li}_a: texture_2d<f32>;
@group(1) @binding({bb}) var swell_fft{li}_b: texture_2d<f32>;

// FFT layer {li} at the undisplaced local point p, Catmull–Rom over the 4×4 nodes around it
// (the server's default filter); its grid coordinate is swell.fft[{f}].xy + p·N/L.
fn swell_fft{li}(s: SwellSample, p: vec2<f32>) -> SwellSample {{
    let g = swell.fft[{f}].xy + p * {scale};
    let cell = floor(g);
    let wx = swell_catmull_rom(g.x - cell.x);
    let wz = swell_catmull_rom(g.y - cell.y);
    let base = vec2<i32>(cell) - vec2<i32>(1);
    var a = vec4<f32>(0.0);
    var b = vec4<f32>(0.0);
    for (var r = 0; r < 4; r = r + 1) {{
        var ra = vec4<f32>(0.0);
        var rb = vec4<f32>(0.0);
        for (var c = 0; c < 4; c = c + 1) {{
            let at = (base + vec2<i32>(c, r)) & vec2<i32>({mask});
            ra = ra + wx[c] * textureLoad(swell_fft{li}_a, at, 0);
            rb = rb + wx[c] * textureLoad(swell_fft{li}_b, at, 0);
        }}
        a = a + wz[r] * ra;
        b = b + wz[r] * rb;
    }}
    var o = s;
    o.displacement = o.displacement + a.xyz;
    o.d_dx = o.d_dx + vec3<f32>(a.w, b.x, b.w);
    o.d_dz = o.d_dz + vec3<f32>(b.w, b.y, b.z);
    return o;
}}
",
            l = layer.tile_size(),
            ba = 2 * f,
            bb = 2 * f + 1,
            scale = lit((n as f64 / layer.tile_size()) as f32),
            mask = n - 1,
        );
        let _ = writeln!(calls, "    s = swell_fft{li}(s, p);");
    }
    Some((member, funcs, calls))
}

/// `swell_invert` / `swell_height` for a surface with choppy FFT layers: the server's default
/// inversion ([`swell_waves::query::Inversion`]) in f32 — Newton on `p0 + D(p0) = p` from
/// p0 = p for up to its 8 steps, a fixed-point step where `det J ≤ 10⁻⁹`, stopping at its
/// tolerance, and the iterate with the lowest residual wins. A storm layer (λ = 2.6) moves
/// points by metres, and the 4 plain Newton steps that suit Gerstner seas left some probes
/// 15 mm off (measured by the browser test); Gerstner-only surfaces keep those.
pub fn height_newton() -> String {
    let inv = swell_waves::query::Inversion::default();
    format!(
        "
// The undisplaced point whose surface point lies above the local point p: the server's default
// inversion, Newton on p0 + (Dx, Dz)(p0) = p from p0 = p, at most {steps} steps, a fixed-point step
// where the Jacobian is (near) singular, stopping once the residual is below {tol} m; the
// iterate with the lowest residual is returned.
fn swell_invert(p: vec2<f32>) -> vec2<f32> {{
    var p0 = p;
    var best = p;
    var best_r = 3.4e38f;
    for (var i = 0u; i <= {steps}u; i = i + 1u) {{
        let s = swell_sample(p0);
        let r = p0 + s.displacement.xz - p;
        let rr = length(r);
        if (rr < best_r) {{
            best_r = rr;
            best = p0;
        }}
        if (rr <= {tol} || i == {steps}u) {{
            break;
        }}
        let a = 1.0 + s.d_dx.x;
        let b = s.d_dz.x;
        let c = s.d_dx.z;
        let d = 1.0 + s.d_dz.z;
        let det = a * d - b * c;
        if (det > 1e-9f) {{
            p0 = p0 - vec2<f32>(d * r.x - b * r.y, a * r.y - c * r.x) / det;
        }} else {{
            p0 = p0 - r;
        }}
    }}
    return best;
}}

// Elevation of the surface above the local point p.
fn swell_height(p: vec2<f32>) -> f32 {{
    return swell_sample(swell_invert(p)).displacement.y;
}}
",
        steps = inv.iterations,
        tol = lit(inv.tolerance as f32),
    )
}

/// Catmull–Rom weights, the model's formulas (`swell_waves::fft::SampleFilter::Bicubic`).
const SAMPLE_HELPERS: &str = "
// Catmull–Rom weights of nodes -1, 0, 1, 2 at fraction t (the model's bicubic filter).
fn swell_catmull_rom(t: f32) -> vec4<f32> {
    return vec4<f32>(
        0.5 * (((-t + 2.0) * t - 1.0) * t),
        0.5 * ((3.0 * t - 5.0) * t * t + 2.0),
        0.5 * (((-3.0 * t + 4.0) * t + 1.0) * t),
        0.5 * ((t - 1.0) * t * t));
}
";

/// The `SwellUniforms.fft` values of `surface` for render origin `origin`: per FFT layer
/// `(offset.x, offset.z, 0, 0)` ([`grid_offset`]); empty without FFT layers.
pub fn block(surface: &Surface, origin: glam::DVec2) -> Vec<f32> {
    layers(surface)
        .iter()
        .flat_map(|(_, l)| {
            let [x, z] = grid_offset(l, origin);
            [x, z, 0.0, 0.0]
        })
        .collect()
}

/// Per FFT layer (layer index, `cycle` uniform at `t`), for the evolve passes; a layer whose
/// phase cannot be exported ([`cycle_bits`]) is left out.
pub fn cycles(surface: &Surface, t: f64) -> Vec<(usize, [f32; 4])> {
    let d = surface.dispersion();
    layers(surface)
        .into_iter()
        .filter_map(|(li, l)| {
            let bits = cycle_bits(li, max_frequency_index(l, &d)).ok()?;
            Some((li, cycle(t, l.repeat_period(), bits)))
        })
        .collect()
}

#[cfg(test)]
pub(crate) mod twin;

#[cfg(test)]
pub(crate) mod tests;
