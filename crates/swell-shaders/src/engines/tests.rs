//! Tests of the engine includes: the item splitter, and for every test surface that each include
//! holds naga's functions (renamed reads of the block only), declares the block's members in
//! order and nothing an engine would reject.

use super::*;
use crate::tests::all_surfaces;
use crate::wgsl::{emit, phase_vec4s, wave_constants};
use crate::{Entry, Lang, export};

#[test]
fn items_split_at_top_level_braces() {
    let text = "#version 300 es\n\nstruct A {\n    vec3 x;\n};\nconst uint N = 1u;\n\
                float f(A a) {\n    if (true) {\n        return 1.0;\n    }\n    return 0.0;\n}\n\nvoid main() {\n}\n\
                float g(float2 p)\n\n{\n    return p.x;\n}\n";
    let it = items(text);
    assert_eq!(it.len(), 6, "{it:?}");
    assert_eq!(it[5].function_name(), Some("g"));
    assert!(it[5].text.ends_with("}\n"));
    assert_eq!(it[1].struct_name(), Some("A"));
    assert_eq!(it[1].function_name(), None);
    assert_eq!(it[3].function_name(), Some("f"));
    assert_eq!(it[4].function_name(), Some("main"));
    assert!(it[2].starts_with("const"));
}

#[test]
fn words_and_prefixes_respect_identifier_boundaries() {
    assert!(contains_word("SwellSample s;", "SwellSample"));
    assert!(!contains_word("SwellSampleX s;", "SwellSample"));
    assert!(!contains_word("ConstructSwellSample(", "SwellSample"));
    let (t, n) = replace_prefix(
        "swell.phases[0].x + my_swell.a + (swell.b)",
        "swell.",
        "swell_",
    );
    assert_eq!(t, "swell_phases[0].x + my_swell.a + (swell_b)");
    assert_eq!(n, 2);
}

#[test]
fn unreferenced_structs_are_dropped_transitively() {
    let it = items(
        "struct A {\n    float x;\n};\nstruct B {\n    A a;\n};\nstruct C {\n    float y;\n};\nfloat f(C c) {\n    return c.y;\n}\n",
    );
    let kept = drop_unreferenced_structs(it);
    let names: Vec<_> = kept.iter().filter_map(|i| i.struct_name()).collect();
    assert_eq!(names, ["C"]);
}

/// The functions naga writes for `lang` with every entry point, reads of the block (and, with
/// `textures`, naga's GLSL names of the FFT textures) renamed as the include renames them: the
/// include must hold each of them verbatim.
fn naga_functions(text: &str, block: &str, textures: &[(String, String)]) -> Vec<String> {
    items(text)
        .into_iter()
        .filter(|i| i.function_name().is_some_and(|n| n.starts_with("swell_")))
        .filter(|i| {
            !Entry::ALL
                .iter()
                .any(|e| i.function_name() == Some(e.name()))
        })
        .map(|i| {
            let mut t = replace_prefix(&i.text, block, UNIFORM_PREFIX).0;
            for (from, to) in textures {
                t = replace_word(&t, from, to).0;
            }
            t
        })
        .collect()
}

/// Two FFT layers (layer indices 0 and 2, so FFT position f and layer index differ for the
/// second: bindings 2 and 3 hold `swell_fft2_a/_b`) around a Gerstner layer.
const TWO_FFT: &str = r#"{"seed": 4, "layers": [
  {"kind": "fft", "resolution": 16, "tile_size": 48, "choppiness": 0.8, "repeat_period": 120,
   "wind_direction": [1, 0.2], "spectrum": {"kind": "jonswap", "wind_speed": 9, "fetch": 60000}},
  {"kind": "gerstner", "waves": [{"amplitude": 0.3, "wavelength": 60, "direction": [0.3, 1], "steepness": 0.4}]},
  {"kind": "fft", "resolution": 32, "tile_size": 20, "choppiness": 0.0, "repeat_period": 80,
   "wind_direction": [-0.5, 1], "spectrum": {"kind": "jonswap", "wind_speed": 5, "fetch": 20000}}]}"#;

/// The crate's test surfaces, the built-in `open-sea` and `storm` FFT scenes, and [`TWO_FFT`].
fn engine_surfaces() -> Vec<(&'static str, swell_waves::Surface)> {
    let build = |json: &str| {
        let spec: swell_waves::SurfaceSpec = serde_json::from_str(json).unwrap();
        swell_waves::Surface::new(&spec).unwrap()
    };
    let mut v = all_surfaces();
    v.push(("open-sea", build(crate::fft::tests::OPEN_SEA)));
    v.push(("storm", build(crate::fft::tests::STORM)));
    v.push(("two-fft", build(TWO_FFT)));
    v
}

/// `(FFT position f, layer index L)` of every FFT layer of `s`.
fn fft_slots(s: &swell_waves::Surface) -> Vec<(usize, usize)> {
    crate::fft::layers(s)
        .iter()
        .enumerate()
        .map(|(f, (li, _))| (f, *li))
        .collect()
}

#[test]
fn hlsl_include_is_nagas_functions_over_a_registerless_cbuffer() {
    for (name, s) in engine_surfaces() {
        let inc = export(&s, Lang::HlslInclude, None).unwrap();
        let waves = wave_constants(&s).unwrap().len();
        // Guarded, no entry point, no explicit register, no naga cbuffer.
        assert!(inc.contains("#ifndef SWELL_HLSL_INCLUDED\n#define SWELL_HLSL_INCLUDED\n"));
        assert!(
            inc.trim_end().ends_with("#endif // SWELL_HLSL_INCLUDED"),
            "{name}"
        );
        for absent in [
            "swell_vs",
            "swell_probe_vs",
            "swell_probe_fs",
            "SV_",
            "register(",
            "swell.",
            "SwellCamera",
        ] {
            assert!(!inc.contains(absent), "{name}: {absent} in\n{inc}");
        }
        let m = phase_vec4s(waves);
        assert!(
            inc.contains(&format!(
                "cbuffer SwellUniforms {{\n    float4 swell_u_phases[{m}];\n"
            )),
            "{name}\n{inc}"
        );
        assert!(inc.contains(&format!(
            "#ifdef SWELL_NO_CBUFFER\nfloat4 swell_u_phases[{m}];\n"
        )));
        // Every wave is summed once, each reading its own phase slot.
        assert_eq!(
            inc.matches("swell_wave(").count() - 1,
            waves,
            "{name}: calls + the definition"
        );
        for i in 0..waves {
            let slot = format!("swell_u_phases[{}].{}", i / 4, ["x", "y", "z", "w"][i % 4]);
            assert!(inc.contains(&slot), "{name}: {slot}");
        }
        // Every function naga writes for the HLSL output is in the include, verbatim but for
        // the block reads.
        let hlsl = export(&s, Lang::Hlsl, None).unwrap();
        let funcs = naga_functions(&hlsl, "swell.", &[]);
        assert!(funcs.len() >= 8, "{name}: {}", funcs.len());
        for f in &funcs {
            assert!(inc.contains(f.as_str()), "{name}: missing\n{f}");
        }
        for helper in [
            "swell_from_unity",
            "swell_to_unity",
            "swell_local_from_unity",
            "swell_local_from_unreal",
            "swell_to_unreal",
            "swell_dir_to_unreal",
            "swell_from_unreal",
        ] {
            assert!(
                inc.contains(&format!(
                    "float{} {helper}(",
                    if helper.contains("local") { 2 } else { 3 }
                )),
                "{helper}"
            );
        }
    }
}

#[test]
fn particle_members_are_declared_in_block_order() {
    let (_, s) = all_surfaces()
        .into_iter()
        .find(|(n, _)| *n == "particles")
        .unwrap();
    let (module, _) = crate::translate::parse_and_validate(&emit(&s).unwrap()).unwrap();
    let members = uniform_members(&module, "test").unwrap();
    let names: Vec<_> = members.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "phases",
            "particle_head",
            "particle_offsets",
            "ambient",
            "rings"
        ]
    );
    assert_eq!(members[1].len, None);
    assert_eq!(members[3].len, Some(96));
    let hlsl = export(&s, Lang::HlslInclude, None).unwrap();
    let godot = export(&s, Lang::Gdshaderinc, None).unwrap();
    let (mut at_h, mut at_g) = (0, 0);
    for m in &members {
        let decl = match m.len {
            Some(n) => format!("swell_u_{}[{n}];", m.name),
            None => format!("swell_u_{};", m.name),
        };
        let h = hlsl[at_h..]
            .find(&format!("    float4 {decl}"))
            .unwrap_or_else(|| panic!("{decl}"));
        let g = godot[at_g..]
            .find(&format!("uniform vec4 {decl}"))
            .unwrap_or_else(|| panic!("{decl}"));
        (at_h, at_g) = (at_h + h, at_g + g);
    }
}

#[test]
fn gdshaderinc_is_nagas_glsl_es_functions_without_the_outer_layer() {
    for (name, s) in engine_surfaces() {
        let inc = export(&s, Lang::Gdshaderinc, None).unwrap();
        let waves = wave_constants(&s).unwrap().len();
        assert!(inc.contains("#ifndef SWELL_GDSHADERINC\n#define SWELL_GDSHADERINC\n"));
        // What Godot's language has no place for in an include, or reserves.
        for line in inc.lines().filter(|l| !l.starts_with("//")) {
            for bad in [
                "#version",
                "precision ",
                "layout(",
                "shader_type",
                "gl_",
                "_group_",
                "flat ",
                "void main(",
            ] {
                assert!(!line.contains(bad), "{name}: {bad} in {line:?}");
            }
            assert!(
                !line.starts_with("in ") && !line.starts_with("out "),
                "{name}: {line}"
            );
        }
        assert!(inc.contains(&format!(
            "uniform vec4 swell_u_phases[{}];",
            phase_vec4s(waves)
        )));
        assert_eq!(inc.matches("swell_wave(").count() - 1, waves, "{name}");
        let glsl = export(&s, Lang::GlslEs, Some(Entry::ProbeVertex)).unwrap();
        let renames: Vec<(String, String)> = fft_slots(&s)
            .into_iter()
            .flat_map(|(f, li)| {
                [
                    (
                        format!("_group_1_binding_{}_vs", 2 * f),
                        format!("swell_fft{li}_a"),
                    ),
                    (
                        format!("_group_1_binding_{}_vs", 2 * f + 1),
                        format!("swell_fft{li}_b"),
                    ),
                ]
            })
            .collect();
        let funcs = naga_functions(&glsl, "_group_0_binding_0_vs.", &renames);
        assert!(funcs.len() >= 8, "{name}: {}", funcs.len());
        for f in &funcs {
            assert!(inc.contains(f.as_str()), "{name}: missing\n{f}");
        }
        assert!(inc.contains("struct SwellSample {"), "{name}");
    }
}

/// A regression: with the prefix `swell_`, the particle members `ambient` and `rings` became
/// `swell_ambient` and `swell_rings`, the names of two functions, and the particle surface's
/// includes read an array named like the function they were in (glslang and Godot reject that).
#[test]
fn uniform_names_never_collide_with_function_names() {
    let (_, s) = all_surfaces()
        .into_iter()
        .find(|(n, _)| *n == "particles")
        .unwrap();
    for lang in [Lang::HlslInclude, Lang::Gdshaderinc] {
        let inc = export(&s, lang, None).unwrap();
        let funcs: Vec<String> = items(&inc)
            .iter()
            .filter_map(|i| i.function_name().map(str::to_owned))
            .collect();
        assert!(
            funcs.iter().any(|f| f == "swell_ambient") && funcs.iter().any(|f| f == "swell_rings")
        );
        assert!(
            inc.contains("swell_u_ambient[") && inc.contains("swell_u_rings["),
            "{lang:?}"
        );
        for f in &funcs {
            assert!(
                !inc.contains(&format!(" {f}[")),
                "{lang:?}: {f} is also an array"
            );
        }
    }
    let bad = [UniformMember {
        name: "ambient".into(),
        len: Some(4),
    }];
    let clash = items("float swell_u_ambient(float2 p) {\n    return p.x;\n}\n");
    assert!(check_no_collision("test", &bad, &[], &clash).is_err());
}

/// An FFT surface's includes declare each FFT layer's two result textures the engine's way,
/// under the WGSL names, read them where naga read its bound textures, declare the grid offsets
/// (`swell_u_fft`), and say in the header how the passes fill them; a surface without FFT
/// layers declares no texture and carries no FFT note.
#[test]
fn fft_surfaces_includes_declare_the_result_textures() {
    for (name, s) in engine_surfaces() {
        let slots = fft_slots(&s);
        let hlsl = export(&s, Lang::HlslInclude, None).unwrap();
        let godot = export(&s, Lang::Gdshaderinc, None).unwrap();
        if slots.is_empty() {
            for inc in [&hlsl, &godot] {
                assert!(!inc.contains("swell_fft"), "{name}");
                assert!(!inc.contains("FFT layers:"), "{name}");
            }
            continue;
        }
        // HLSL: registerless Texture2D<float4> globals with the other declarations (so
        // SWELL_UNIFORMS_DECLARED skips them too), read with Load.
        let decls = hlsl
            .split("#ifndef SWELL_UNIFORMS_DECLARED\n")
            .nth(1)
            .and_then(|r| r.split("#endif\n\n").next())
            .unwrap_or_else(|| panic!("{name}: no declaration block\n{hlsl}"));
        assert!(
            decls.contains(&format!("float4 swell_u_fft[{}];", slots.len())),
            "{name}: {decls}"
        );
        assert!(hlsl.contains("// FFT layers: swell_sample reads"), "{name}");
        assert!(
            hlsl.contains("lang=hlsl&layer=L&entry=swell_fft_evolve_cs"),
            "{name}"
        );
        assert!(!hlsl.contains("register("), "{name}");
        for (f, li) in &slots {
            for ab in ["a", "b"] {
                let tex = format!("swell_fft{li}_{ab}");
                assert!(
                    decls.contains(&format!("Texture2D<float4> {tex};\n")),
                    "{name}: {tex} in {decls}"
                );
                assert!(hlsl.contains(&format!("{tex}.Load(int3(")), "{name}: {tex}");
            }
            assert!(hlsl.contains(&format!("swell_u_fft[{f}]")), "{name}: {f}");
            assert!(
                hlsl.contains(&format!("// layer {li}: fft, N = ")),
                "{name}"
            );
        }
        // Godot: one sampler2D uniform per texture, read with texelFetch; naga's names gone.
        assert!(
            godot.contains("// FFT layers: swell_sample reads"),
            "{name}"
        );
        assert!(godot.contains(&format!("uniform vec4 swell_u_fft[{}];", slots.len())));
        assert!(!godot.contains("_group_"), "{name}");
        for (f, li) in &slots {
            for ab in ["a", "b"] {
                let tex = format!("swell_fft{li}_{ab}");
                assert!(
                    godot.contains(&format!(
                        "uniform sampler2D {tex} : hint_default_black, filter_nearest, repeat_enable;\n"
                    )),
                    "{name}: {tex}"
                );
                assert!(
                    godot.contains(&format!("texelFetch({tex}, ")),
                    "{name}: {tex}"
                );
            }
            assert!(godot.contains(&format!("swell_u_fft[{f}]")), "{name}: {f}");
        }
        // The passes that fill the textures are plain shaders, not includes.
        for lang in [Lang::HlslInclude, Lang::Gdshaderinc] {
            let e = crate::export_fft(&s, slots[0].1, lang, None).unwrap_err();
            assert!(
                matches!(e, ShaderError::PassesNotInInclude { layer, .. } if layer == slots[0].1),
                "{name}: {e}"
            );
        }
    }
}

/// The rewrite refuses a module whose textures are not the FFT layers' pairs (here one more
/// texture at `@group(1)`): a changed emitter or naga fails here rather than shipping an
/// include that reads an undeclared texture.
#[test]
fn a_texture_the_rewrite_does_not_expect_is_refused() {
    let (_, s) = all_surfaces()
        .into_iter()
        .find(|(n, _)| *n == "fft")
        .unwrap();
    let wgsl = emit(&s).unwrap() + "@group(1) @binding(2) var swell_fft9_a: texture_2d<f32>;\n";
    for e in [
        hlsl::include(&wgsl).unwrap_err(),
        godot::include(&wgsl).unwrap_err(),
    ] {
        assert!(
            matches!(&e, ShaderError::Naga { message, .. } if message.contains("2 textures per FFT layer")),
            "{e}"
        );
    }
    let (module, _) = crate::translate::parse_and_validate(&emit(&s).unwrap()).unwrap();
    let members = uniform_members(&module, "test").unwrap();
    let tex = fft_textures(&module, &members, "test").unwrap();
    assert_eq!(
        tex,
        [
            FftTexture {
                name: "swell_fft0_a".into(),
                binding: 0
            },
            FftTexture {
                name: "swell_fft0_b".into(),
                binding: 1
            }
        ]
    );
    assert_eq!(
        replace_word("a _g_1 _g_10 x_g_1", "_g_1", "t"),
        ("a t _g_10 x_g_1".into(), 1)
    );
}
