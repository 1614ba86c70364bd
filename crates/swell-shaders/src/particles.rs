//! The particle layer in the shader: ambient wave particles and impact rings, evaluated with
//! the model's kernel `a·(1 − q²)³` and its analytic gradient.
//!
//! The host does the f64 work once per frame ([`block`]): every ambient particle's position at
//! t on the tile (`wrap(u0 + w·t)`, tile units), the render origin's offset on each scale's
//! tile (`wrap(o/(s·L))`), and each live ring's centre relative to the origin, radius d,
//! amplitude, particle radius and count. The shader adds the local position and sums, in f32:
//!
//! - ambient, per scale s (constants baked in): `q = fract(offset_s + p_local/(s·L))`; per
//!   particle `δ = q − u_i`, `δ −= round(δ)` (nearest periodic image),
//!   `h += s·a_i·w³`, `∇h += −6·s·a_i·w²·δ·(L/r)²/(s·L)`, `w = 1 − |δ|²·(L/r)²`;
//! - rings: `rel = p_local − (c − o)`; nothing unless `|ρ − d| < r`; otherwise the particles
//!   `i` in the angular window around `atan2(rel)` (all of them when `r² ≥ 4dρ`), at
//!   `d·(cos, sin)(2π·i/N)`, with the same kernel.
//!
//! # The uniform block
//! `SwellUniforms` gains, after `phases`: `particle_head: vec4<f32>` (x: live rings uploaded),
//! `particle_offsets: array<vec4<f32>, 2>` (scale k's offset at `[k/2].xy` or `.zw`),
//! `ambient: array<vec4<f32>, NA>` (`(u.x, u.z, a, 0)`, NA = the layer's count, at least 1) and
//! `rings: array<vec4<f32>, 2·MAX_SHADER_RINGS>` (ring k: `[2k] = (c.x − o.x, c.z − o.z, d, a)`,
//! `[2k+1] = (r, N, 1/r², 0)`). Every member is vec4-aligned, so the block is a flat list of
//! f32s in this order (std140).

use glam::DVec2;
use swell_waves::particles::{Impacts, ParticleLayer};
use swell_waves::{Layer, Surface};

use crate::error::ShaderError;

/// Most ambient particles the shader carries: 512 vec4s (8 KiB of the 16 KiB uniform block
/// WebGL2 promises), and every vertex loops over them once per scale.
pub const MAX_SHADER_PARTICLES: usize = 512;
/// Live rings uploaded per frame (2 vec4s each); more are left out of the shader (listed first
/// in canonical order are kept) and the uniforms say how many were dropped.
pub const MAX_SHADER_RINGS: usize = 32;

/// The surface's particle layer, if it has one, checked for export.
///
/// # Errors
/// More than one particle layer, or more than [`MAX_SHADER_PARTICLES`] ambient particles.
pub fn layer(surface: &Surface) -> Result<Option<&ParticleLayer>, ShaderError> {
    let layers: Vec<&ParticleLayer> = surface
        .layers()
        .iter()
        .filter_map(|l| match l {
            Layer::Particles(p) => Some(&**p),
            _ => None,
        })
        .collect();
    match layers.as_slice() {
        [] => Ok(None),
        [p] if p.ambient().len() <= MAX_SHADER_PARTICLES => Ok(Some(p)),
        [p] => Err(ShaderError::TooManyParticles {
            particles: p.ambient().len(),
            max: MAX_SHADER_PARTICLES,
        }),
        _ => Err(ShaderError::TooManyParticles {
            particles: layers.len(),
            max: 1,
        }),
    }
}

/// vec4s of the ambient array: the particle count, at least 1.
pub fn ambient_vec4s(layer: &ParticleLayer) -> usize {
    layer.ambient().len().max(1)
}

/// The block members (after `phases`), the constants and functions of the particle layer, and
/// the lines `swell_sample` adds (one per scale, then the rings).
pub fn wgsl(layer: &ParticleLayer) -> (String, String, String) {
    let amb = layer.ambient();
    let members = format!(
        "    particle_head: vec4<f32>,\n    particle_offsets: array<vec4<f32>, 2>,\n    \
         ambient: array<vec4<f32>, {}>,\n    rings: array<vec4<f32>, {}>,\n",
        ambient_vec4s(layer),
        2 * MAX_SHADER_RINGS
    );
    let rr = amb.radius() / amb.tile_size();
    let funcs = format!(
        "\nconst SWELL_AMBIENT: u32 = {n}u;\nconst SWELL_INV_RR2: f32 = {inv};\n{PARTICLE_FNS}",
        n = amb.len(),
        inv = lit((1.0 / (rr * rr)) as f32),
    );
    let mut calls = String::new();
    for (k, &s) in amb.scales().iter().enumerate() {
        let off = format!(
            "swell.particle_offsets[{}].{}",
            k / 2,
            if k % 2 == 0 { "xy" } else { "zw" }
        );
        calls.push_str(&format!(
            "    s = swell_ambient(s, p, {}, {}, {off});\n",
            lit((1.0 / (s * amb.tile_size())) as f32),
            lit(s as f32),
        ));
    }
    calls.push_str("    s = swell_rings(s, p);\n");
    (members, funcs, calls)
}

fn lit(v: f32) -> String {
    format!("{v:?}f")
}

/// The particle part of the uniform block at time t for render origin o, as f32s (layout in
/// the module docs), and how many live rings did not fit.
pub fn block(layer: &ParticleLayer, impacts: &Impacts, t: f64, origin: DVec2) -> (Vec<f32>, usize) {
    let amb = layer.ambient();
    let live = layer.live_rings(t, impacts);
    let kept = live.len().min(MAX_SHADER_RINGS);
    let mut out = vec![kept as f32, 0.0, 0.0, 0.0];
    let mut offsets = [0.0f32; 8];
    for (k, &s) in amb.scales().iter().enumerate() {
        let inv = 1.0 / (s * amb.tile_size());
        let wrap = |v: f64| {
            let w = v - v.floor();
            if w >= 1.0 { 0.0 } else { w }
        };
        offsets[2 * k] = wrap(origin.x * inv) as f32;
        offsets[2 * k + 1] = wrap(origin.y * inv) as f32;
    }
    out.extend_from_slice(&offsets);
    for i in 0..amb.len() {
        let u = amb.position(i, t);
        let (_, _, a) = amb.particle(i);
        out.extend_from_slice(&[u.x as f32, u.y as f32, a as f32, 0.0]);
    }
    if amb.is_empty() {
        out.extend_from_slice(&[0.0; 4]);
    }
    for k in 0..MAX_SHADER_RINGS {
        match live.get(k) {
            Some((ring, st)) => {
                let c = ring.center - origin;
                let r = ring.radius;
                out.extend_from_slice(&[
                    c.x as f32,
                    c.y as f32,
                    st.distance as f32,
                    st.amplitude as f32,
                    r as f32,
                    st.count as f32,
                    (1.0 / (r * r)) as f32,
                    0.0,
                ]);
            }
            None => out.extend_from_slice(&[0.0; 8]),
        }
    }
    (out, live.len() - kept)
}

/// The kernel, the ambient sum of one scale, and the rings.
const PARTICLE_FNS: &str = "
// One particle: a·(1 − q²)³ with q² = |d|²·inv_r2 < 1, gradient −6·a·(1 − q²)²·inv_r2·d·gscale.
fn swell_kernel(s: SwellSample, d: vec2<f32>, a: f32, inv_r2: f32, gscale: f32) -> SwellSample {
    var o = s;
    let q2 = dot(d, d) * inv_r2;
    if (q2 < 1.0) {
        let w = 1.0 - q2;
        let g = -6.0 * a * w * w * inv_r2 * gscale;
        o.displacement.y = o.displacement.y + a * w * w * w;
        o.d_dx.y = o.d_dx.y + g * d.x;
        o.d_dz.y = o.d_dz.y + g * d.y;
    }
    return o;
}

// The ambient particles at one tile scale: inv_sl = 1/(s·L), amp = s, off = wrap(o/(s·L)).
fn swell_ambient(s: SwellSample, p: vec2<f32>, inv_sl: f32, amp: f32, off: vec2<f32>) -> SwellSample {
    var o = s;
    let q = fract(off + p * inv_sl);
    for (var i = 0u; i < SWELL_AMBIENT; i = i + 1u) {
        let e = swell.ambient[i];
        var d = q - e.xy;
        d = d - round(d);
        o = swell_kernel(o, d, amp * e.z, SWELL_INV_RR2, inv_sl);
    }
    return o;
}

// The live impact rings: only the particles in the angular window that can reach p.
fn swell_rings(s: SwellSample, p: vec2<f32>) -> SwellSample {
    var o = s;
    let count = u32(swell.particle_head.x);
    for (var k = 0u; k < count; k = k + 1u) {
        let a = swell.rings[2u * k];
        let b = swell.rings[2u * k + 1u];
        let rel = p - a.xy;
        let rho = length(rel);
        let d = a.z;
        let r = b.x;
        if (abs(rho - d) >= r) {
            continue;
        }
        let n = i32(b.y);
        var lo = 0;
        var hi = n - 1;
        if (r * r < 4.0 * d * rho) {
            let half = 3.14159265f * r / (2.0 * sqrt(d * rho));
            let phi = atan2(rel.y, rel.x);
            let per = f32(n) / SWELL_TAU;
            lo = i32(floor((phi - half) * per)) - 2;
            hi = i32(ceil((phi + half) * per)) + 2;
            if (hi - lo + 1 >= n) {
                lo = 0;
                hi = n - 1;
            }
        }
        for (var j = lo; j <= hi; j = j + 1) {
            let i = ((j % n) + n) % n;
            let ang = SWELL_TAU * (f32(i) / f32(n));
            let dir = vec2<f32>(cos(ang), sin(ang));
            o = swell_kernel(o, rel - d * dir, a.w, b.z, 1.0);
        }
    }
    return o;
}
";
