//! The Godot 4 shader include (`lang=gdshaderinc`).
//!
//! naga has no Godot back end, and Godot's shading language is GLSL ES 3.00 with a different
//! outer layer: no `#version` or `precision` lines, no interface blocks or `in`/`out`
//! variables at the top level, uniforms declared one by one (`uniform vec4 name[n];`, set with
//! `ShaderMaterial.set_shader_parameter`), and stage functions (`vertex()`, `fragment()`) that
//! the including shader writes. So the include is naga's GLSL ES output with that outer layer
//! rewritten: the structs, constants and `swell_*` functions as naga wrote them, the uniform
//! block replaced by one `uniform vec4 swell_u_<member>[n]` per member, `main` and the entry
//! point's interface dropped.
//!
//! Godot is right-handed, y up, in metres: Swell's frame, so there is no conversion. A sea mesh
//! drawn at the render origin (unrotated, unscaled) has `VERTEX.xz` = Swell's local x/z.

use std::fmt::Write as _;

use super::{
    Item, UNIFORM_PREFIX, UniformMember, check_no_collision, drop_unreferenced_structs, err, items,
    replace_prefix, uniform_members, wgsl_header,
};
use crate::error::ShaderError;
use crate::lang::{Entry, Lang};

const STAGE: &str = "gdshaderinc";

/// The include guard, defined by the include.
pub const GUARD: &str = "SWELL_GDSHADERINC";

/// naga's GLSL name for the `@group(0) @binding(0)` block in a vertex shader.
const BLOCK: &str = "_group_0_binding_0_vs.";

/// The Godot include for the WGSL module `wgsl` (as [`crate::wgsl::emit`] writes it).
///
/// # Errors
/// [`ShaderError::Naga`] if naga rejects the module or its output is not what the rewrite
/// expects (an emitter or naga-upgrade bug, caught by the tests).
pub fn include(wgsl: &str) -> Result<String, ShaderError> {
    let (module, _) = crate::translate::parse_and_validate(wgsl)?;
    let members = uniform_members(&module, STAGE)?;
    // GLSL needs an entry point; the probe vertex shader's is the smallest interface, and with
    // INCLUDE_UNUSED_ITEMS every function is written whatever the entry point uses.
    let glsl = crate::translate::translate(wgsl, Lang::GlslEs, Some(Entry::ProbeVertex))?;
    let mut kept = Vec::new();
    let mut dropped = Vec::new();
    let mut reads = 0;
    for item in items(&glsl) {
        let outer = [
            "#",
            "precision ",
            "uniform ",
            "layout(",
            "in ",
            "out ",
            "flat ",
            "smooth ",
        ]
        .iter()
        .any(|p| item.starts_with(p));
        if outer || item.function_name() == Some("main") {
            dropped.push(item.text.lines().next().unwrap_or("").to_owned());
            continue;
        }
        let (t, n) = replace_prefix(&item.text, BLOCK, UNIFORM_PREFIX);
        reads += n;
        kept.push(Item { text: t });
    }
    // (A surface without sine or Gerstner waves reads nothing from the block: `reads` may be 0.)
    if !dropped.iter().any(|d| d.starts_with("void main()")) {
        return Err(err(
            STAGE,
            format!("unexpected GLSL layout: dropped {dropped:?}, {reads} block reads"),
        ));
    }
    let kept = drop_unreferenced_structs(kept);
    check_no_collision(STAGE, &members, &kept)?;
    let body: String = kept
        .iter()
        .map(|i| i.text.as_str())
        .collect::<Vec<_>>()
        .join("\n");
    for gone in ["_group_", "gl_", "SwellUniforms", "SwellCamera"] {
        if body.contains(gone) {
            return Err(err(STAGE, format!("{gone} is still referenced")));
        }
    }

    let mut s = wgsl_header(wgsl);
    s.push_str(PREAMBLE);
    let _ = write!(
        s,
        "#ifndef {GUARD}\n#define {GUARD}\n\n{}\n",
        declarations(&members)
    );
    s.push_str(&body);
    let _ = writeln!(s, "\n#endif");
    Ok(s)
}

fn declarations(members: &[UniformMember]) -> String {
    members
        .iter()
        .map(|m| match m.len {
            Some(n) => format!("uniform vec4 {UNIFORM_PREFIX}{}[{n}];\n", m.name),
            None => format!("uniform vec4 {UNIFORM_PREFIX}{};\n", m.name),
        })
        .collect()
}

const PREAMBLE: &str = "//
// Godot 4 shader include (lang=gdshaderinc): save it as e.g. res://swell/sea.gdshaderinc and
// #include it from a spatial shader; call swell_sample / swell_normal / swell_height from
// vertex(). Godot is right-handed, y up, metres, as Swell is: no conversion. A sea mesh drawn
// at the render origin (unrotated, unscaled) has VERTEX.xz = the local x/z these take.
// Uniforms: every frame set swell_u_phases (and any other swell_u_* array below) with
// set_shader_parameter from the f32 `block` of GET /v1/scenes/{id}/uniforms?t=&origin=x,z (or
// the same formula computed in double precision), 4 floats per vec4, in declaration order.
";
