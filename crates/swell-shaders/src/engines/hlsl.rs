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
//! - `SWELL_UNIFORMS_DECLARED`: declare nothing; the shader declares the members itself.
//!
//! Coordinate helpers at the end map Swell's right-handed, y-up, metre frame to Unity's
//! (left-handed, y up, metres: z mirrored) and Unreal's (left-handed, z up, centimetres:
//! `(X, Y, Z) = 100·(x, z, y)`).

use std::fmt::Write as _;

use naga::valid::{Capabilities, ValidationFlags, Validator};

use super::{
    Item, UNIFORM_PREFIX, UniformMember, check_no_collision, contains_word,
    drop_unreferenced_structs, err, items, replace_prefix, uniform_members, wgsl_header,
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

    let mut kept = Vec::new();
    let mut cbuffers = Vec::new();
    for item in items(&text) {
        if item.starts_with("cbuffer ") {
            cbuffers.push(item.text.trim().to_owned());
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
    let kept = drop_unreferenced_structs(kept);
    check_no_collision(STAGE, &members, &kept)?;
    let body: String = kept
        .iter()
        .map(|i| i.text.as_str())
        .collect::<Vec<_>>()
        .join("\n");
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
    let _ = write!(
        s,
        "#ifndef {GUARD}\n#define {GUARD}\n\n#ifndef SWELL_UNIFORMS_DECLARED\n#ifdef SWELL_NO_CBUFFER\n{}#else\ncbuffer SwellUniforms {{\n{}}}\n#endif\n#endif\n\n",
        declarations(&members, ""),
        declarations(&members, "    "),
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
