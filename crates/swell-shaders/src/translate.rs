//! naga: parse and validate the emitted WGSL, then write GLSL 4.50, GLSL ES 3.00, HLSL or MSL.
//!
//! Back-end choices, each fixed so the outputs are the same bytes on every run:
//! - **GLSL / GLSL ES**: one entry point per output, renamed `main` (naga's rule). Flags:
//!   `FORCE_POINT_SIZE` (vertex shaders write `gl_PointSize = 1.0`, so probes can be drawn as
//!   points) and `INCLUDE_UNUSED_ITEMS` (every `swell_*` function is in every output, for
//!   clients that call them from their own code). *Not* `ADJUST_COORDINATE_SPACE`: clip space is
//!   left as the shader computes it (`gl_Position = view_proj · p` exactly), so a GL client
//!   passes its usual GL projection matrix and nothing is flipped behind its back. Uniform
//!   blocks are named by naga `SwellUniforms_block_0{Vertex|Fragment}` and
//!   `SwellCamera_block_1{Vertex|Fragment}`, at binding points 0 and 1 in GLSL 4.50 (ES 3.00
//!   has no `binding` layout: bind the blocks by name); varyings `_vs2fs_location{N}`.
//! - **HLSL**: shader model 5.1; `swell` is `cbuffer swell : register(b0)`, `swell_camera`
//!   `register(b1)`.
//! - **MSL**: version 2.1; bindings assigned by naga (`fake_missing_bindings`).

use naga::back::{glsl, hlsl, msl};
use naga::valid::{Capabilities, ModuleInfo, ValidationFlags, Validator};

use crate::error::ShaderError;
use crate::lang::{Entry, Lang};

/// Parses WGSL and validates it with every check naga has.
///
/// # Errors
/// [`ShaderError::Naga`] with stage `parse` or `validate` and naga's message.
pub fn parse_and_validate(source: &str) -> Result<(naga::Module, ModuleInfo), ShaderError> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| ShaderError::Naga {
        stage: "parse",
        message: e.emit_to_string(source),
    })?;
    let info = Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&module)
        .map_err(|e| ShaderError::Naga {
            stage: "validate",
            message: format!("{:?}", e.into_inner()),
        })?;
    Ok((module, info))
}

/// Translates the WGSL `source` into `lang` (see [`crate::export`] for what `entry` selects).
///
/// # Errors
/// [`ShaderError::Naga`] if naga rejects the source or fails to write it.
pub fn translate(source: &str, lang: Lang, entry: Option<Entry>) -> Result<String, ShaderError> {
    let (module, info) = parse_and_validate(source)?;
    match lang {
        Lang::Wgsl => Ok(source.to_owned()),
        Lang::Glsl => write_glsl(&module, &info, glsl::Version::Desktop(450), entry),
        Lang::GlslEs => write_glsl(
            &module,
            &info,
            glsl::Version::Embedded {
                version: 300,
                is_webgl: true,
            },
            entry,
        ),
        Lang::Hlsl => write_hlsl(&module, &info, entry),
        Lang::Msl => write_msl(&module, &info, entry),
        Lang::HlslInclude => crate::engines::hlsl::include(source),
        Lang::Gdshaderinc => crate::engines::godot::include(source),
    }
}

fn naga_err(stage: &'static str) -> impl Fn(&dyn std::fmt::Display) -> ShaderError {
    move |e| ShaderError::Naga {
        stage,
        message: e.to_string(),
    }
}

fn write_glsl(
    module: &naga::Module,
    info: &ModuleInfo,
    version: glsl::Version,
    entry: Option<Entry>,
) -> Result<String, ShaderError> {
    let entry = entry.unwrap_or(Entry::Vertex);
    // Binding points equal to the WGSL bindings (`swell` 0, `swell_camera` 1; an FFT pass
    // module's textures 1 and 2 and its compute outputs 3 and 4; the surface module's FFT textures `@group(1)` 0, 1, …, which
    // are texture units, a namespace apart from uniform blocks); naga writes them as
    // `layout(binding = N)` where the version has it (4.20+, not ES 3.00).
    let mut binding_map = glsl::BindingMap::default();
    for (group, count) in [(0u32, 5u8), (1, 16)] {
        for b in 0..count {
            binding_map.insert(
                naga::ResourceBinding {
                    group,
                    binding: u32::from(b),
                },
                b,
            );
        }
    }
    let options = glsl::Options {
        version,
        writer_flags: glsl::WriterFlags::FORCE_POINT_SIZE | glsl::WriterFlags::INCLUDE_UNUSED_ITEMS,
        binding_map,
        ..glsl::Options::default()
    };
    let pipeline = glsl::PipelineOptions {
        shader_stage: entry.stage(),
        entry_point: entry.name().to_owned(),
        multiview: None,
    };
    let mut out = String::new();
    let mut writer = glsl::Writer::new(
        &mut out,
        module,
        info,
        &options,
        &pipeline,
        naga::proc::BoundsCheckPolicies::default(),
    )
    .map_err(|e| naga_err("glsl")(&e))?;
    writer.write().map_err(|e| naga_err("glsl")(&e))?;
    Ok(out)
}

/// naga's HLSL of `module` (every entry point when `entry` is `None`).
pub(crate) fn write_hlsl(
    module: &naga::Module,
    info: &ModuleInfo,
    entry: Option<Entry>,
) -> Result<String, ShaderError> {
    let options = hlsl::Options {
        shader_model: hlsl::ShaderModel::V5_1,
        ..hlsl::Options::default()
    };
    let pipeline = hlsl::PipelineOptions {
        entry_point: entry.map(|e| (e.stage(), e.name().to_owned())),
    };
    let mut out = String::new();
    hlsl::Writer::new(&mut out, &options, &pipeline)
        .write(module, info, None)
        .map_err(|e| naga_err("hlsl")(&e))?;
    Ok(out)
}

fn write_msl(
    module: &naga::Module,
    info: &ModuleInfo,
    entry: Option<Entry>,
) -> Result<String, ShaderError> {
    let options = msl::Options {
        lang_version: (2, 1),
        ..msl::Options::default()
    };
    let pipeline = msl::PipelineOptions {
        entry_point: entry.map(|e| (e.stage(), e.name().to_owned())),
        ..msl::PipelineOptions::default()
    };
    let (out, _) =
        msl::write_string(module, info, &options, &pipeline).map_err(|e| naga_err("msl")(&e))?;
    Ok(out)
}
