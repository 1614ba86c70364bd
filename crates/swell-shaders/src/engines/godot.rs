//! The Godot 4 shader include (`lang=gdshaderinc`).
//!
//! naga has no Godot back end, and Godot's shading language is GLSL ES 3.00 with a different
//! outer layer: no `#version` or `precision` lines, no interface blocks or `in`/`out`
//! variables at the top level, uniforms declared one by one (`uniform vec4 name[n];`, set with
//! `ShaderMaterial.set_shader_parameter`), and stage functions (`vertex()`, `fragment()`) that
//! the including shader writes. So the include is naga's GLSL ES output with that outer layer
//! rewritten: the structs, constants and `swell_*` functions as naga wrote them, the uniform
//! block replaced by one `uniform vec4 swell_u_<member>[n]` per member, `main` and the entry
//! point's interface dropped. An FFT layer's two result textures, naga's
//! `_group_1_binding_{2f}_vs` / `_{2f+1}_vs`, become `uniform sampler2D swell_fft{L}_a` /
//! `_b` (the WGSL names), read with `texelFetch` as naga wrote it.
//!
//! Godot is right-handed, y up, in metres: Swell's frame, so there is no conversion. A sea mesh
//! drawn at the render origin (unrotated, unscaled) has `VERTEX.xz` = Swell's local x/z.

use std::fmt::Write as _;

use super::{
    FftTexture, Item, UNIFORM_PREFIX, UniformMember, check_no_collision, drop_unreferenced_structs,
    err, fft_textures, items, replace_prefix, replace_word, uniform_members, wgsl_header,
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
    let textures = fft_textures(&module, &members, STAGE)?;
    let mut kept = Vec::new();
    let mut dropped = Vec::new();
    let mut reads = 0;
    let mut texture_reads = vec![0usize; textures.len()];
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
        let (mut t, n) = replace_prefix(&item.text, BLOCK, UNIFORM_PREFIX);
        reads += n;
        for (tex, count) in textures.iter().zip(&mut texture_reads) {
            let (r, k) = replace_word(&t, &naga_texture(tex), &tex.name);
            t = r;
            *count += k;
        }
        kept.push(Item { text: t });
    }
    // Every FFT texture naga bound was declared (and is dropped) and is read under its new name.
    for (tex, count) in textures.iter().zip(&texture_reads) {
        let decl = format!("uniform highp sampler2D {};", naga_texture(tex));
        if *count == 0 || !dropped.iter().any(|d| d.trim() == decl) {
            return Err(err(
                STAGE,
                format!(
                    "FFT texture {}: expected naga's `{decl}` and reads of it; {count} read(s), dropped {dropped:?}",
                    tex.name
                ),
            ));
        }
    }
    // (A surface without sine or Gerstner waves reads nothing from the block: `reads` may be 0.)
    if !dropped.iter().any(|d| d.starts_with("void main()")) {
        return Err(err(
            STAGE,
            format!("unexpected GLSL layout: dropped {dropped:?}, {reads} block reads"),
        ));
    }
    let kept = drop_unreferenced_structs(kept);
    check_no_collision(STAGE, &members, &textures, &kept)?;
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
    if !textures.is_empty() {
        s.push_str(FFT_NOTE);
    }
    let _ = write!(
        s,
        "#ifndef {GUARD}\n#define {GUARD}\n\n{}{}\n",
        declarations(&members),
        texture_declarations(&textures),
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

/// naga's GLSL name for an FFT texture of the surface module in a vertex shader.
fn naga_texture(t: &FftTexture) -> String {
    format!("_group_1_binding_{}_vs", t.binding)
}

/// One `uniform sampler2D` per FFT texture. `swell_sample` reads them with `texelFetch` (its own
/// Catmull–Rom filter and tile wrap), which ignores the sampler's filter and repeat: the hints
/// say what the data are (node values, a repeating tile) for anyone sampling them otherwise.
/// `hint_default_black`: a texture not yet set reads as zeros (the sea without that layer),
/// not as Godot's default white (1 m everywhere).
fn texture_declarations(textures: &[FftTexture]) -> String {
    textures
        .iter()
        .map(|t| {
            format!(
                "uniform sampler2D {} : hint_default_black, filter_nearest, repeat_enable;\n",
                t.name
            )
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

/// The usage note of an include whose surface has FFT layers.
const FFT_NOTE: &str = "//
// FFT layers: swell_sample reads each FFT layer L's two result textures, declared here as
// uniform sampler2D swell_fftL_a = (Dx, h, Dz, dDx/dx) and swell_fftL_b = (dh/dx, dh/dz,
// dDz/dz, dDx/dz) per grid node: N×N RGBA32F (Image.FORMAT_RGBAF; N in the layer line above),
// read with texelFetch (the include filters them itself, Catmull–Rom, and wraps the tile).
// swell_u_fft[f].xy is layer f's grid offset (f counts FFT layers; the tail of /uniforms block).
// Fill them every frame (set_shader_parameter(\"swell_fftL_a\", texture)) with the layer's
// passes, plain shaders outside this include: on the RenderingDevice, the GLSL 4.50 compute
// passes GET /v1/scenes/{id}/shader?lang=glsl&layer=L&entry=swell_fft_evolve_cs and
// &entry=swell_fft_butterfly_cs (local size 8×8, dispatch ceil(N/8)^2 groups), bound to a
// Texture2DRD; or on the CPU (the spectrum and an inverse FFT, as the JS client's FftLayer
// does) into an ImageTexture. Per frame: one evolve pass reading the spectrum texture (N×N
// RGBA32F from GET /v1/scenes/{id}/spectrum?layer=L, texel (i, j) = (h0.re, h0.im,
// round(omega·T/2π), 0)) with block SwellFftPass = (cycle = /uniforms fft[*].cycle, stage = 0),
// then 2·log2(N) butterfly passes, stage = (Ns, axis) for Ns = 1, 2, …, N/2 along x (axis 0)
// then z (axis 1), ping-pong between two texture pairs; the last pass's two outputs are
// swell_fftL_a and _b. docs/clients.md (FFT layers) has the whole recipe.
";
