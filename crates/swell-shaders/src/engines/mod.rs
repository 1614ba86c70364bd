//! Engine-ready includes: the surface's `swell_*` functions packaged for a game engine's shader
//! compiler, with no entry point, the uniforms declared the way the engine sets them, and the
//! engine's coordinate conventions spelled out.
//!
//! - [`hlsl`] — one HLSL include for Unity and Unreal (`lang=hlsl_include`): a named
//!   `cbuffer SwellUniforms` (or plain globals) and conversion helpers for Unity's left-handed
//!   y-up and Unreal's left-handed z-up centimetre frames.
//! - [`godot`] — a Godot 4 `.gdshaderinc` (`lang=gdshaderinc`): `uniform vec4 swell_u_*[]`
//!   arrays and the functions; Godot is right-handed, y up, in metres, as Swell is.
//!
//! Both are naga's translations of the very WGSL module the other languages come from (so the
//! maths is the validated WGSL's, statement for statement), rewritten at the top level only:
//! the text is split into top-level items (structs, constants, uniform blocks, functions,
//! entry points), the entry points and the bound uniform blocks are dropped, the engine's
//! uniform declarations are written instead, and the functions' reads of the uniform block
//! (`swell.phases[i]` in HLSL, `_group_0_binding_0_vs.phases[i]` in GLSL) become reads of the
//! flat uniforms `swell_u_phases[i]` ([`UNIFORM_PREFIX`]). Every rewrite checks that what it replaced was there and
//! that no reference to a dropped item is left, so a naga upgrade that changes its output
//! fails the tests instead of shipping a broken include.

pub mod godot;
pub mod hlsl;

use naga::{Module, TypeInner, VectorSize};

use crate::error::ShaderError;

/// The prefix of the includes' uniform names: member `phases` is `swell_u_phases`. Not plain
/// `swell_`: the particle members `ambient` and `rings` would then collide with the functions
/// `swell_ambient` and `swell_rings` (each include checks that no uniform name is a function
/// name).
pub const UNIFORM_PREFIX: &str = "swell_u_";

/// A member of `SwellUniforms`: its WGSL name and, for an array, its length. Every member is a
/// `vec4<f32>` or an array of them (the block is a flat list of vec4s, see [`crate::wgsl`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UniformMember {
    /// The member's name in the WGSL struct (`phases`, `ambient`, ...).
    pub name: String,
    /// `Some(n)` for `array<vec4<f32>, n>`, `None` for a single `vec4<f32>`.
    pub len: Option<u32>,
}

fn err(stage: &'static str, message: impl Into<String>) -> ShaderError {
    ShaderError::Naga {
        stage,
        message: message.into(),
    }
}

/// The members of the uniform block bound at `@group(0) @binding(0)`, in order.
///
/// # Errors
/// [`ShaderError::Naga`] (stage `stage`) when there is no such block, or a member is not a
/// vec4 or an array of vec4s (the includes declare every member as `float4`/`vec4`).
pub(crate) fn uniform_members(
    module: &Module,
    stage: &'static str,
) -> Result<Vec<UniformMember>, ShaderError> {
    let (_, var) = module
        .global_variables
        .iter()
        .find(|(_, v)| {
            v.binding
                .as_ref()
                .is_some_and(|b| b.group == 0 && b.binding == 0)
        })
        .ok_or_else(|| err(stage, "no uniform block at group 0, binding 0"))?;
    let TypeInner::Struct { ref members, .. } = module.types[var.ty].inner else {
        return Err(err(stage, "the uniform block is not a struct"));
    };
    let is_vec4 = |ty: naga::Handle<naga::Type>| {
        matches!(
            module.types[ty].inner,
            TypeInner::Vector {
                size: VectorSize::Quad,
                scalar: naga::Scalar::F32
            }
        )
    };
    members
        .iter()
        .map(|m| {
            let name = m
                .name
                .clone()
                .ok_or_else(|| err(stage, "unnamed uniform member"))?;
            match module.types[m.ty].inner {
                _ if is_vec4(m.ty) => Ok(UniformMember { name, len: None }),
                TypeInner::Array {
                    base,
                    size: naga::ArraySize::Constant(n),
                    ..
                } if is_vec4(base) => Ok(UniformMember {
                    name,
                    len: Some(n.get()),
                }),
                _ => Err(err(
                    stage,
                    format!("uniform member {name} is not a vec4 or an array of vec4s"),
                )),
            }
        })
        .collect()
}

/// One of an FFT layer's two result textures as the surface module binds it: `swell_fft{L}_a`
/// or `swell_fft{L}_b` (L the layer index) at `@group(1) @binding(b)`, a `texture_2d<f32>` that
/// `swell_sample` reads with `textureLoad` (its own Catmull–Rom filter and tile wrap: no
/// sampler). The includes declare it under the same name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FftTexture {
    /// The WGSL name, kept by both includes (`swell_fft0_a`).
    pub name: String,
    /// Its binding in `@group(1)`: 2f for `_a`, 2f + 1 for `_b` (f counts FFT layers).
    pub binding: u32,
}

/// The FFT result textures the surface module binds at `@group(1)`, in binding order; empty
/// for a surface without FFT layers.
///
/// # Errors
/// [`ShaderError::Naga`] (stage `stage`) when a `@group(1)` resource is unnamed or not a
/// `texture_2d<f32>` named `swell_fft…`, or their number is not twice the length of the uniform member `fft`
/// (the one grid offset per FFT layer), or the bindings are not 0, 1, 2, ….
pub(crate) fn fft_textures(
    module: &Module,
    members: &[UniformMember],
    stage: &'static str,
) -> Result<Vec<FftTexture>, ShaderError> {
    let mut out = Vec::new();
    for (_, v) in module.global_variables.iter() {
        let Some(b) = v.binding.as_ref().filter(|b| b.group == 1) else {
            continue;
        };
        let name = v
            .name
            .clone()
            .ok_or_else(|| err(stage, "unnamed @group(1) resource"))?;
        let is_texture = matches!(
            module.types[v.ty].inner,
            TypeInner::Image {
                dim: naga::ImageDimension::D2,
                arrayed: false,
                class: naga::ImageClass::Sampled {
                    kind: naga::ScalarKind::Float,
                    multi: false
                },
            }
        );
        if !is_texture || !name.starts_with("swell_fft") {
            return Err(err(
                stage,
                format!("@group(1) resource {name} is not an FFT result texture_2d<f32>"),
            ));
        }
        out.push(FftTexture {
            name,
            binding: b.binding,
        });
    }
    out.sort_by_key(|t| t.binding);
    let layers = members
        .iter()
        .find(|m| m.name == "fft")
        .map_or(0, |m| m.len.unwrap_or(1));
    let bindings: Vec<u32> = out.iter().map(|t| t.binding).collect();
    if out.len() != 2 * layers as usize || bindings.iter().copied().ne(0..bindings.len() as u32) {
        return Err(err(
            stage,
            format!(
                "expected 2 textures per FFT layer ({layers} layer(s)) at @group(1) bindings 0, 1, ...; found {bindings:?}"
            ),
        ));
    }
    Ok(out)
}

/// Replaces every whole-identifier `from` in `text` with `to`; returns the text and the count.
pub(crate) fn replace_word(text: &str, from: &str, to: &str) -> (String, usize) {
    replace_where(text, from, to, |before, after| {
        !before.is_some_and(is_ident) && !after.is_some_and(is_ident)
    })
}

/// Replaces each `from` in `text` for which `keep(char before, char after)` holds with `to`;
/// returns the text and how many were replaced.
fn replace_where(
    text: &str,
    from: &str,
    to: &str,
    keep: impl Fn(Option<char>, Option<char>) -> bool,
) -> (String, usize) {
    let mut out = String::with_capacity(text.len());
    let mut last = 0;
    let mut n = 0;
    for (i, _) in text.match_indices(from) {
        let before = text[..i].chars().next_back();
        let after = text[i + from.len()..].chars().next();
        if !keep(before, after) {
            continue;
        }
        out.push_str(&text[last..i]);
        out.push_str(to);
        last = i + from.len();
        n += 1;
    }
    out.push_str(&text[last..]);
    (out, n)
}

/// One top-level item of naga's text output: a preprocessor or precision line, a struct, a
/// constant, a uniform block, an interface variable or a whole function, as written.
#[derive(Debug, Clone)]
pub(crate) struct Item {
    pub text: String,
}

impl Item {
    fn first_line(&self) -> &str {
        self.text.lines().next().unwrap_or("").trim()
    }

    /// `Some(name)` for `struct name {`.
    pub fn struct_name(&self) -> Option<&str> {
        let rest = self.first_line().strip_prefix("struct ")?;
        Some(rest.split([' ', '{']).next().unwrap_or(rest))
    }

    /// `Some(name)` for a function definition `ret name(args)` followed by its body (on the same
    /// line or, as naga's HLSL writes it, on the next ones); not for a struct, a declaration
    /// ending in `;` or a one-line block.
    pub fn function_name(&self) -> Option<&str> {
        let line = self.first_line();
        if self.struct_name().is_some()
            || line.starts_with('#')
            || line.ends_with(';')
            || line.ends_with('}')
            || !self.text.contains('{')
        {
            return None;
        }
        let head = &line[..line.find('(')?];
        head.split_whitespace().last()
    }

    pub fn starts_with(&self, prefix: &str) -> bool {
        self.first_line().starts_with(prefix)
    }
}

/// Splits naga's output into top-level items. An item ends on a line where the brace depth is
/// back to zero and which ends in `;` or `}` or is a preprocessor line, so a function whose
/// body opens on a later line (naga's HLSL puts a blank line between) stays one item; blank
/// lines between items are dropped. (naga writes no braces inside comments or strings, and
/// puts every top-level declaration on lines of its own.)
pub(crate) fn items(text: &str) -> Vec<Item> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut depth = 0i32;
    for line in text.lines() {
        let t = line.trim();
        if cur.is_empty() && t.is_empty() {
            continue;
        }
        depth += line.matches('{').count() as i32 - line.matches('}').count() as i32;
        cur.push_str(line);
        cur.push('\n');
        if depth <= 0 && (t.ends_with(';') || t.ends_with('}') || t.starts_with('#')) {
            depth = 0;
            out.push(Item {
                text: std::mem::take(&mut cur),
            });
        }
    }
    if !cur.trim().is_empty() {
        out.push(Item { text: cur });
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Whether `word` occurs in `text` as a whole identifier.
pub(crate) fn contains_word(text: &str, word: &str) -> bool {
    text.match_indices(word).any(|(i, _)| {
        let before = text[..i].chars().next_back();
        let after = text[i + word.len()..].chars().next();
        !before.is_some_and(is_ident) && !after.is_some_and(is_ident)
    })
}

/// Replaces every `from` that does not follow an identifier character (so `swell.` but not
/// `my_swell.`) with `to`; returns the text and how many were replaced.
pub(crate) fn replace_prefix(text: &str, from: &str, to: &str) -> (String, usize) {
    replace_where(text, from, to, |before, _| !before.is_some_and(is_ident))
}

/// Drops the structs nothing kept refers to (the uniform and camera block types, the entry
/// points' interface structs), keeping the order of what stays.
pub(crate) fn drop_unreferenced_structs(items: Vec<Item>) -> Vec<Item> {
    let mut keep: Vec<bool> = vec![true; items.len()];
    loop {
        let mut changed = false;
        for i in 0..items.len() {
            let Some(name) = items[i].struct_name() else {
                continue;
            };
            if !keep[i] {
                continue;
            }
            let used = items
                .iter()
                .enumerate()
                .any(|(j, it)| j != i && keep[j] && contains_word(&it.text, name));
            if !used {
                keep[i] = false;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    items
        .into_iter()
        .zip(keep)
        .filter_map(|(it, k)| k.then_some(it))
        .collect()
}

/// Checks that no uniform name of `members` and no texture of `textures` is also the name of a
/// function among `items`.
pub(crate) fn check_no_collision(
    stage: &'static str,
    members: &[UniformMember],
    textures: &[FftTexture],
    items: &[Item],
) -> Result<(), ShaderError> {
    let names = members
        .iter()
        .map(|m| format!("{UNIFORM_PREFIX}{}", m.name))
        .chain(textures.iter().map(|t| t.name.clone()));
    for name in names {
        if items
            .iter()
            .any(|i| i.function_name() == Some(name.as_str()))
        {
            return Err(err(
                stage,
                format!("uniform {name} collides with a function"),
            ));
        }
    }
    Ok(())
}

/// The leading `//` lines of the emitted WGSL (generator, versions, conventions, the layers and
/// their phase slots): the includes start with the same header.
pub(crate) fn wgsl_header(wgsl: &str) -> String {
    wgsl.lines()
        .take_while(|l| l.starts_with("//"))
        .map(|l| format!("{l}\n"))
        .collect()
}

#[cfg(test)]
mod tests;
