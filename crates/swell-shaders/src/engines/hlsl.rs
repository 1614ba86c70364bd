//! The HLSL include for Unity and Unreal (`lang=hlsl_include`).
//!
//! naga's HLSL of the surface's module with the entry points removed (the engine writes its
//! own), and instead of naga's `cbuffer swell : register(b0)` holding a struct, the block's
//! members as `float4 swell_u_<member>[n]` in a `cbuffer SwellUniforms` with no explicit
//! register (the engine assigns registers; an explicit `b0` collides with Unity's and Unreal's
//! own buffers). The packing is unchanged: every member is a float4 or an array of them, one
//! 16-byte register each, so the cbuffer's bytes are the `/uniforms` `block` as it is.
//!
//! Macros the including shader may define first:
//! - `SWELL_NO_CBUFFER`: the members as plain globals (Unreal loose shader parameters bound
//!   with `SHADER_PARAMETER_ARRAY(FVector4f, swell_u_phases, [n])`; Unity's `$Globals`).
//! - `SWELL_UNIFORMS_DECLARED`: declare nothing; the shader declares the members (and the FFT
//!   textures) itself.
//!
//! A surface with FFT layers reads each layer's two result textures: naga's
//! `Texture2D<float4> swell_fft0_a : register(t0, space1)` becomes `Texture2D<float4>
//! swell_fft0_a;` (same name, read with `.Load`, no sampler), with a usage note saying which
//! pass shaders fill them (`export_fft`, outside the include).
//!
//! Coordinate helpers at the end map Swell's right-handed, y-up, metre frame to Unity's
//! (left-handed, y up, metres: z mirrored) and Unreal's (left-handed, z up, centimetres:
//! `(X, Y, Z) = 100·(x, z, y)`).

use std::fmt::Write as _;

use naga::valid::{Capabilities, ValidationFlags, Validator};

use super::{
    FftTexture, Item, UNIFORM_PREFIX, UniformMember, check_no_collision, contains_word,
    drop_unreferenced_structs, err, fft_textures, items, replace_prefix, uniform_members,
    wgsl_header,
};
use crate::error::ShaderError;

const STAGE: &str = "hlsl_include";

/// The include guard, defined by the include.
pub const GUARD: &str = "SWELL_HLSL_INCLUDED";

/// The HLSL include for the WGSL module `wgsl` (as [`crate::wgsl::emit`] writes it).
///
/// # Errors
/// [`ShaderError::Naga`] if naga rejects the module or its output is not what the rewrite
/// expects (an emitter or naga-upgrade bug, caught by the tests).
pub fn include(wgsl: &str) -> Result<String, ShaderError> {
    let (mut module, _) = crate::translate::parse_and_validate(wgsl)?;
    let members = uniform_members(&module, STAGE)?;
    // Without entry points naga still writes every struct, constant, global and function; the
    // entry points' interface structs become unreferenced and are dropped below.
    module.entry_points.clear();
    let info = Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&module)
        .map_err(|e| err(STAGE, format!("{:?}", e.into_inner())))?;
    let text = crate::translate::write_hlsl(&module, &info, None)?;

    let textures = fft_textures(&module, &members, STAGE)?;
    let mut kept = Vec::new();
    let mut cbuffers = Vec::new();
    let mut bound_textures = Vec::new();
    for item in items(&text) {
        if item.starts_with("cbuffer ") {
            cbuffers.push(item.text.trim().to_owned());
            continue;
        }
        // naga's `Texture2D<float4> swell_fft0_a : register(t0, space1);`: declared again
        // below without the register.
        if item.starts_with("Texture2D<float4> ") && item.text.contains(": register(") {
            bound_textures.push(item.text.trim().to_owned());
            continue;
        }
        let (t, _) = replace_prefix(&item.text, "swell.", UNIFORM_PREFIX);
        kept.push(Item { text: t });
    }
    if cbuffers.len() != 2
        || !cbuffers
            .iter()
            .any(|c| c.starts_with("cbuffer swell : register(b0)"))
    {
        return Err(err(
            STAGE,
            format!("expected naga's two cbuffers (swell, swell_camera), found {cbuffers:?}"),
        ));
    }
    // Each FFT texture naga bound, under the WGSL name at its register in space 1, and nothing
    // else: the include's declarations below keep those names.
    let expected: Vec<String> = textures
        .iter()
        .map(|t| {
            format!(
                "Texture2D<float4> {} : register(t{}, space1);",
                t.name, t.binding
            )
        })
        .collect();
    if bound_textures != expected {
        return Err(err(
            STAGE,
            format!("expected naga's FFT textures {expected:?}, found {bound_textures:?}"),
        ));
    }
    let kept = drop_unreferenced_structs(kept);
    check_no_collision(STAGE, &members, &textures, &kept)?;
    let body: String = kept
        .iter()
        .map(|i| i.text.as_str())
        .collect::<Vec<_>>()
        .join("\n");
    for t in &textures {
        if !contains_word(&body, &t.name) {
            return Err(err(STAGE, format!("texture {} is never read", t.name)));
        }
    }
    for gone in ["swell_camera", "SwellUniforms", "SwellCamera"] {
        if contains_word(&body, gone) {
            return Err(err(STAGE, format!("{gone} is still referenced")));
        }
    }
    if body.contains("swell.") || body.contains("register(") {
        return Err(err(STAGE, "a bound resource is still referenced"));
    }

    let mut s = wgsl_header(wgsl);
    s.push_str(PREAMBLE);
    if !textures.is_empty() {
        s.push_str(FFT_NOTE);
    }
    let _ = write!(
        s,
        "#ifndef {GUARD}\n#define {GUARD}\n\n#ifndef SWELL_UNIFORMS_DECLARED\n#ifdef SWELL_NO_CBUFFER\n{}#else\ncbuffer SwellUniforms {{\n{}}}\n#endif\n{}#endif\n\n",
        declarations(&members, ""),
        declarations(&members, "    "),
        texture_declarations(&textures),
    );
    s.push_str(&body);
    s.push_str(CONVERSIONS);
    let _ = writeln!(s, "\n#endif // {GUARD}");
    Ok(s)
}

fn declarations(members: &[UniformMember], indent: &str) -> String {
    members
        .iter()
        .map(|m| match m.len {
            Some(n) => format!("{indent}float4 {UNIFORM_PREFIX}{}[{n}];\n", m.name),
            None => format!("{indent}float4 {UNIFORM_PREFIX}{};\n", m.name),
        })
        .collect()
}

/// `Texture2D<float4> swell_fft0_a;` per FFT texture, no register (the engine assigns it).
fn texture_declarations(textures: &[FftTexture]) -> String {
    textures
        .iter()
        .map(|t| format!("Texture2D<float4> {};\n", t.name))
        .collect()
}

const PREAMBLE: &str = "//
// HLSL include for Unity and Unreal (lang=hlsl_include): the swell_* functions, no entry point.
// Uniforms: cbuffer SwellUniforms holds the frame's f32 `block` (GET /v1/scenes/{id}/uniforms
// ?t=&origin=x,z, or the same formula computed on the host in double precision), as it is: its
// members are the block's vec4s in order. Define SWELL_NO_CBUFFER before including for plain
// globals instead (Unreal loose parameters, Unity $Globals), or SWELL_UNIFORMS_DECLARED to
// declare the members yourself.
// Coordinates: the functions work in Swell's frame (right-handed, y up, metres; positions local
// to the render origin). The helpers at the end convert: Unity (left-handed, y up, metres) is
// Swell with z mirrored; Unreal (left-handed, z up, centimetres) is (X, Y, Z) = 100·(x, z, y).
";

/// The usage note of an include whose surface has FFT layers: what the textures hold, how an
/// engine produces them (the pass shaders, outside the include) and binds them.
const FFT_NOTE: &str = "//
// FFT layers: swell_sample reads each FFT layer L's two result textures, declared here as
// Texture2D<float4> swell_fftL_a = (Dx, h, Dz, dDx/dx) and swell_fftL_b = (dh/dx, dh/dz, dDz/dz,
// dDx/dz) per grid node: N×N RGBA32F (R32G32B32A32_FLOAT; N in the layer line above), read with
// Load (no sampler state: the include filters them itself, Catmull–Rom, and wraps the tile).
// swell_u_fft[f].xy is layer f's grid offset (f counts FFT layers; the tail of /uniforms block).
// The engine fills the textures every frame with the layer's passes, plain HLSL outside this
// include: GET /v1/scenes/{id}/shader?lang=hlsl&layer=L&entry=swell_fft_evolve_cs and
// &entry=swell_fft_butterfly_cs (compute, [numthreads(8, 8, 1)], dispatch ceil(N/8)^2 groups;
// Unity: a ComputeShader asset with #pragma kernel; Unreal: a global compute shader), or
// entry=swell_fft_vs + swell_fft_evolve / swell_fft_butterfly (full-screen fragment passes into
// two RGBA32F targets). Per frame: one evolve pass reading the spectrum texture (N×N RGBA32F
// from GET /v1/scenes/{id}/spectrum?layer=L, texel (i, j) = (h0.re, h0.im, round(omega·T/2π), 0))
// with cbuffer swell_fft_pass = (cycle = /uniforms fft[*].cycle, stage = 0), then 2·log2(N)
// butterfly passes, stage = (Ns, axis) for Ns = 1, 2, …, N/2 along x (axis 0) then z (axis 1),
// ping-pong between two texture pairs; the last pass's two outputs are swell_fftL_a and _b.
// docs/clients.md (FFT layers) has the whole recipe.
";

const CONVERSIONS: &str = "
// Unity: left-handed, y up, metres. Swell's (x, y, z) is Unity's (x, y, -z): a mirror in z, its
// own inverse, the same for positions, displacements and normals.
float3 swell_from_unity(float3 v) {
    return float3(v.x, v.y, -v.z);
}

float3 swell_to_unity(float3 v) {
    return float3(v.x, v.y, -v.z);
}

// Swell local x/z of an object-space position of a sea mesh drawn at the render origin
// (unrotated, unscaled): pass it to swell_sample / swell_height.
float2 swell_local_from_unity(float3 p) {
    return float2(p.x, -p.z);
}

// Unreal: left-handed, z up, centimetres. Swell's (x, y, z) m is Unreal's (X, Y, Z) =
// 100·(x, z, y) cm: y and z swapped (the mirror between the two handednesses) and the unit.
static const float SWELL_UNREAL_CM_PER_M = 100.0;

// Swell local x/z of a local-space position (cm) of a sea mesh drawn at the render origin.
float2 swell_local_from_unreal(float3 p) {
    return p.xy / SWELL_UNREAL_CM_PER_M;
}

// Positions and displacements, m -> cm.
float3 swell_to_unreal(float3 v) {
    return float3(v.x, v.z, v.y) * SWELL_UNREAL_CM_PER_M;
}

// Unit vectors (normals): axes only, no unit.
float3 swell_dir_to_unreal(float3 n) {
    return float3(n.x, n.z, n.y);
}

float3 swell_from_unreal(float3 v) {
    return float3(v.x, v.z, v.y) / SWELL_UNREAL_CM_PER_M;
}
";
