//! Writes the GLSL outputs of every built-in scene (GLSL 4.50 and GLSL ES 3.00, every entry
//! point, and every FFT layer's pass module as `{scene}.{lang}.fft{layer}.{entry}`) into a
//! directory, named `{scene}.{lang}.{entry}.{vert|frag}` so that `glslangValidator` picks the
//! stage from the extension (FFT compute passes: GLSL 4.50 only, `.comp`), and the engine
//! includes, `{scene}.hlsl_include.hlsl` and `{scene}.gdshaderinc`. `.ci/shader-check` compiles
//! them (the includes inside small test shaders), `.ci/godot-check` runs the Godot ones through
//! Godot.
//!
//! `cargo run --example shader_export -- DIR`

use anyhow::Context;
use swell::scene::{Scene, builtin};
use swell_shaders::{Entry, Lang};

fn main() -> anyhow::Result<()> {
    let dir = std::env::args()
        .nth(1)
        .context("usage: shader_export DIR")?;
    std::fs::create_dir_all(&dir)?;
    let mut written = 0;
    for (id, spec) in builtin::specs() {
        let scene = Scene::build(&id, spec)?;
        for lang in [Lang::Glsl, Lang::GlslEs] {
            for entry in Entry::ALL {
                let text = swell_shaders::export(&scene.surface, lang, Some(entry))?;
                let ext = if entry == Entry::ProbeFragment {
                    "frag"
                } else {
                    "vert"
                };
                let path = format!("{dir}/{id}.{}.{}.{ext}", lang.name(), entry.name());
                std::fs::write(&path, text).with_context(|| path.clone())?;
                written += 1;
            }
            for (li, _) in swell_shaders::fft::layers(&scene.surface) {
                for entry in Entry::FFT {
                    let text = swell_shaders::export_fft(&scene.surface, li, lang, Some(entry))?;
                    let ext = if entry == Entry::FftVertex {
                        "vert"
                    } else {
                        "frag"
                    };
                    let path = format!("{dir}/{id}.{}.fft{li}.{}.{ext}", lang.name(), entry.name());
                    std::fs::write(&path, text).with_context(|| path.clone())?;
                    written += 1;
                }
                // Compute versions: desktop GLSL only (GLSL ES 3.00 has no compute shaders).
                for entry in Entry::FFT_COMPUTE
                    .into_iter()
                    .filter(|_| lang == Lang::Glsl)
                {
                    let text = swell_shaders::export_fft(&scene.surface, li, lang, Some(entry))?;
                    let path = format!("{dir}/{id}.{}.fft{li}.{}.comp", lang.name(), entry.name());
                    std::fs::write(&path, text).with_context(|| path.clone())?;
                    written += 1;
                }
            }
        }
        // The engine includes, FFT scenes' too (they declare the result textures).
        for (lang, ext) in [
            (Lang::HlslInclude, "hlsl_include.hlsl"),
            (Lang::Gdshaderinc, "gdshaderinc"),
        ] {
            let text = swell_shaders::export(&scene.surface, lang, None)?;
            let path = format!("{dir}/{id}.{ext}");
            std::fs::write(&path, text).with_context(|| path.clone())?;
            written += 1;
        }
    }
    println!("wrote {written} GLSL files and engine includes to {dir}");
    Ok(())
}
