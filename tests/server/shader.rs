//! The GPU-client endpoints over a real socket: `/shader`, `/uniforms`, `/spectrum`.

use crate::common;

use common::{TestServer, bits, code, config, into_json};
use serde_json::{Value, json};

const LANGS: [&str; 7] = [
    "wgsl",
    "glsl",
    "glsl_es",
    "hlsl",
    "msl",
    "hlsl_include",
    "gdshaderinc",
];

fn header<'a>(r: &'a reqwest::Response, name: &str) -> &'a str {
    r.headers()
        .get(name)
        .unwrap_or_else(|| panic!("no {name} header"))
        .to_str()
        .unwrap()
}

#[tokio::test]
async fn shader_in_every_language_for_every_builtin_scene_with_version_headers_and_etag() {
    let s = TestServer::start(config()).await;
    for id in ["calm", "lake", "open-sea", "storm"] {
        let (_, detail) = s.get_json(&format!("/v1/scenes/{id}")).await;
        let hash = detail["spec_hash"].as_str().unwrap().to_owned();
        for lang in LANGS {
            let path = format!("/v1/scenes/{id}/shader?lang={lang}");
            let fft = ["open-sea", "storm"].contains(&id);
            let r = s.get(&path).await;
            assert_eq!(r.status(), 200, "{path}");
            assert!(header(&r, "content-type").starts_with("text/plain"));
            assert_eq!(header(&r, "swell-spec-hash"), hash);
            assert_eq!(
                header(&r, "swell-model-version"),
                swell_waves::MODEL_VERSION.to_string()
            );
            let tag = header(&r, "etag").to_owned();
            let text = r.text().await.unwrap();
            match lang {
                "wgsl" => assert!(text.contains("fn swell_sample(p: vec2<f32>)")),
                "glsl" => assert!(text.starts_with("#version 450")),
                "glsl_es" => assert!(text.starts_with("#version 300 es")),
                "hlsl" => assert!(text.contains("cbuffer swell")),
                "hlsl_include" => {
                    assert!(text.contains("cbuffer SwellUniforms {"));
                    assert!(text.contains("float3 swell_to_unity(float3 v)"));
                    assert!(!text.contains("swell_vs") && !text.contains("register("));
                    // An FFT scene's include (200 since the includes carry FFT layers) reads
                    // the FFT layer's result textures and says how the passes fill them.
                    assert_eq!(
                        text.contains(
                            "Texture2D<float4> swell_fft0_a;\nTexture2D<float4> swell_fft0_b;\n"
                        ),
                        fft,
                        "{path}"
                    );
                    assert_eq!(text.contains("entry=swell_fft_evolve_cs"), fft, "{path}");
                }
                "gdshaderinc" => {
                    assert!(text.contains("uniform vec4 swell_u_phases["));
                    assert!(!text.contains("#version") && !text.contains("void main()"));
                    assert_eq!(
                        text.contains("uniform sampler2D swell_fft0_a : hint_default_black, filter_nearest, repeat_enable;"),
                        fft,
                        "{path}"
                    );
                    assert_eq!(text.contains("texelFetch(swell_fft0_b, "), fft, "{path}");
                }
                _ => assert!(text.contains("metal_stdlib")),
            }
            // Revalidation: 304, no body, same tag.
            let r = s
                .client
                .get(s.url(&path))
                .header("if-none-match", &tag)
                .send()
                .await
                .unwrap();
            assert_eq!(r.status(), 304, "{path}");
            assert_eq!(header(&r, "etag"), tag);
            assert!(r.text().await.unwrap().is_empty());
        }
    }
    // The lake's 17 Gerstner waves are all in the shader, with their phase slots.
    let text = s
        .get("/v1/scenes/lake/shader?lang=wgsl")
        .await
        .text()
        .await
        .unwrap();
    assert_eq!(text.matches("s = swell_wave(").count(), 17);
    assert!(text.contains("swell.phases[4].x"));
    // GLSL picks its entry point; the probe fragment shader writes two float targets.
    let fs = s
        .get("/v1/scenes/lake/shader?lang=glsl_es&entry=swell_probe_fs")
        .await
        .text()
        .await
        .unwrap();
    assert!(fs.contains("layout(location = 1) out vec4"), "{fs}");
    // Different entry points are different texts with different tags.
    let a = s.get("/v1/scenes/lake/shader?lang=glsl").await;
    let b = s
        .get("/v1/scenes/lake/shader?lang=glsl&entry=swell_probe_vs")
        .await;
    assert_ne!(header(&a, "etag"), header(&b, "etag"));
    s.stop().await;
}

#[tokio::test]
async fn shader_errors_name_the_parameter() {
    let s = TestServer::start(config()).await;
    for (q, field) in [
        ("", "lang"),
        ("?lang=spirv", "lang"),
        ("?lang=GLSL", "lang"),
        ("?lang=glsl&entry=main", "entry"),
        // The engine includes hold no entry point: naming one is a mistake, not ignored.
        ("?lang=hlsl_include&entry=swell_vs", "entry"),
        ("?lang=gdshaderinc&entry=swell_probe_fs", "entry"),
        ("?lang=godot", "lang"),
    ] {
        let (st, v) = s.get_json(&format!("/v1/scenes/calm/shader{q}")).await;
        assert_eq!((st, code(&v)), (400, "invalid_value"), "{q}: {v}");
        assert_eq!(v["error"]["field"], field, "{q}: {v}");
    }
    let (st, v) = s.get_json("/v1/scenes/calm/shader?lang=spirv").await;
    assert_eq!(st, 400);
    assert!(
        v["error"]["message"].as_str().unwrap().contains("glsl_es"),
        "the message lists the languages: {v}"
    );
    let (_, v) = s
        .get_json("/v1/scenes/calm/shader?lang=hlsl_include&entry=swell_vs")
        .await;
    assert!(
        v["error"]["message"]
            .as_str()
            .unwrap()
            .contains("no entry point"),
        "{v}"
    );
    let (st, v) = s.get_json("/v1/scenes/nope/shader?lang=wgsl").await;
    assert_eq!((st, code(&v)), (404, "not_found"));
    s.stop().await;
}

/// The uniforms are the documented formula evaluated on the scene's own derived waves, and with
/// them the shader's sum at the origin reproduces `/sample` there.
#[tokio::test]
async fn uniforms_follow_the_formula_and_reproduce_sample() {
    let s = TestServer::start(config()).await;
    let (_, detail) = s.get_json("/v1/scenes/calm").await;
    let waves = detail["derived"]["layers"][0]["waves"]
        .as_array()
        .unwrap()
        .clone();
    let (t, ox, oz) = (1e6 + 0.25, 1e6, -2.5e5);
    let r = s
        .get(&format!("/v1/scenes/calm/uniforms?t={t}&origin={ox},{oz}"))
        .await;
    assert_eq!(r.status(), 200);
    let tag = header(&r, "etag").to_owned();
    let (_, u) = into_json(r).await;
    assert_eq!(u["spec_hash"], detail["spec_hash"]);
    assert_eq!(u["model_version"], json!(swell_waves::MODEL_VERSION));
    assert_eq!(u["t"], json!(t));
    assert_eq!(u["origin"], json!([ox, oz]));
    assert_eq!(u["waves"], json!(3));
    let phases = u["phases"].as_array().unwrap();
    let block = u["block"].as_array().unwrap();
    assert_eq!(block.len(), 4);
    assert_eq!(u["block_bytes"], json!(16));
    let f = |w: &Value, k: &str| w[k].as_f64().unwrap();
    let mut height = 0.0;
    for (i, w) in waves.iter().enumerate() {
        let d = [
            w["direction"][0].as_f64().unwrap(),
            w["direction"][1].as_f64().unwrap(),
        ];
        let along = d[0] * ox + d[1] * oz;
        let expect = swell_waves::math::reduce_phase(
            f(w, "wavenumber") * along - f(w, "omega") * t + f(w, "phase"),
        );
        assert_eq!(bits(&phases[i]), expect.to_bits(), "wave {i}");
        assert_eq!(bits(&block[i]), f64::from(expect as f32).to_bits());
        height += f(w, "amplitude") * expect.sin();
    }
    assert_eq!(block[3], json!(0.0));
    let (st, v) = s
        .post_json(
            "/v1/scenes/calm/sample",
            &json!({"t": t, "points": [[ox, oz]], "fields": ["height"]}),
        )
        .await;
    assert_eq!(st, 200, "{v}");
    let sampled = v["height"][0].as_f64().unwrap();
    assert!(
        (sampled - height).abs() < 1e-9,
        "uniforms give {height}, /sample {sampled}"
    );
    // Same query, same body, same tag.
    let r = s
        .get(&format!("/v1/scenes/calm/uniforms?t={t}&origin={ox},{oz}"))
        .await;
    assert_eq!(header(&r, "etag"), tag);
    s.stop().await;
}

#[tokio::test]
async fn uniforms_errors_name_the_parameter() {
    let s = TestServer::start(config()).await;
    for (q, field) in [
        ("t=abc", "t"),
        ("t=1e99", "t"),
        ("t=NaN", "t"),
        ("origin=1", "origin"),
        ("origin=1,2,3", "origin"),
        ("origin=a,0", "origin"),
        ("origin=1e300,0", "origin"),
    ] {
        let (st, v) = s.get_json(&format!("/v1/scenes/lake/uniforms?{q}")).await;
        assert_eq!((st, code(&v)), (400, "invalid_value"), "{q}: {v}");
        assert_eq!(v["error"]["field"], field, "{q}: {v}");
    }
    // No t: the clock's now; an FFT-only scene has no waves: one zero vec4, then the FFT
    // layer's grid offset (0 at origin 0).
    let (st, v) = s.get_json("/v1/scenes/storm/uniforms").await;
    assert_eq!(st, 200, "{v}");
    assert!(v["t"].as_f64().unwrap() >= 0.0);
    assert_eq!(v["phases"], json!([]));
    assert_eq!(v["block"], json!(vec![0.0; 8]));
    s.stop().await;
}

#[tokio::test]
async fn spectrum_is_binary_with_a_json_header_and_rejects_other_layers() {
    let s = TestServer::start(config()).await;
    let r = s.get("/v1/scenes/open-sea/spectrum?layer=0").await;
    assert_eq!(r.status(), 200);
    assert_eq!(header(&r, "content-type"), "application/octet-stream");
    let tag = header(&r, "etag").to_owned();
    let bytes = r.bytes().await.unwrap();
    assert_eq!(&bytes[..4], b"SWSP");
    let hlen = u32::from_le_bytes(bytes[4..8].try_into().unwrap()) as usize;
    let h: Value = serde_json::from_slice(&bytes[8..8 + hlen]).unwrap();
    assert_eq!(h["resolution"], json!(256));
    assert_eq!(h["tile_size"], json!(256.0));
    assert_eq!(h["choppiness"], json!(1.0));
    assert_eq!(h["repeat_period"], json!(200.0));
    assert_eq!(h["grid_steps"], json!(12_000), "200 s at 1/60 s");
    assert_eq!(h["time_step"], json!(200.0 / 12_000.0));
    assert_eq!(h["scene"], "open-sea");
    assert_eq!(h["layer"], json!(0));
    let (_, detail) = s.get_json("/v1/scenes/open-sea").await;
    assert_eq!(h["spec_hash"], detail["spec_hash"]);
    assert_eq!(
        h["seed"].as_str().unwrap(),
        detail["derived"]["layers"][0]["seed"]
            .as_u64()
            .unwrap()
            .to_string()
    );
    assert_eq!(h["variance"], detail["derived"]["layers"][0]["variance"]);
    let off = h["data_offset"].as_u64().unwrap() as usize;
    assert_eq!(bytes.len(), off + 256 * 256 * 24);
    // Σ|h0|² over every record is half the layer's variance (the model's definition).
    let mut sum = 0.0;
    for r in bytes[off..].chunks_exact(24) {
        let re = f64::from_le_bytes(r[0..8].try_into().unwrap());
        let im = f64::from_le_bytes(r[8..16].try_into().unwrap());
        sum += re * re + im * im;
    }
    let var = h["variance"].as_f64().unwrap();
    assert!(
        (2.0 * sum - var).abs() <= 1e-12 * var,
        "{} vs {var}",
        2.0 * sum
    );
    let r = s
        .client
        .get(s.url("/v1/scenes/open-sea/spectrum?layer=0"))
        .header("if-none-match", &tag)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 304);

    for (q, needle) in [
        ("layer=1", "gerstner layer"),
        ("layer=2", "out of range"),
        ("layer=-1", "not a layer index"),
        ("layer=x", "not a layer index"),
        ("", "required"),
    ] {
        let (st, v) = s
            .get_json(&format!("/v1/scenes/open-sea/spectrum?{q}"))
            .await;
        assert_eq!((st, code(&v)), (400, "invalid_value"), "{q}: {v}");
        assert_eq!(v["error"]["field"], "layer");
        assert!(
            v["error"]["message"].as_str().unwrap().contains(needle),
            "{q}: {v}"
        );
    }
    let (st, v) = s.get_json("/v1/scenes/calm/spectrum?layer=0").await;
    assert_eq!((st, code(&v)), (400, "invalid_value"), "{v}");
    s.stop().await;
}

/// FFT layers' pass shaders: `entry=swell_fft_*` with `layer=`, in every language; the
/// uniforms carry the evolve pass's phase split and the grid offset; every misuse of `layer`
/// is a 400 naming it.
#[tokio::test]
async fn fft_pass_shaders_and_their_uniforms() {
    let s = TestServer::start(config()).await;
    for lang in LANGS {
        for entry in ["swell_fft_vs", "swell_fft_evolve", "swell_fft_butterfly"] {
            let path = format!("/v1/scenes/storm/shader?lang={lang}&entry={entry}&layer=0");
            let r = s.get(&path).await;
            if ["hlsl_include", "gdshaderinc"].contains(&lang) {
                // The engine includes hold no entry point, FFT passes included.
                assert_eq!(r.status(), 400, "{path}");
                continue;
            }
            assert_eq!(r.status(), 200, "{path}");
            let text = r.text().await.unwrap();
            if lang == "glsl_es" {
                assert!(text.starts_with("#version 300 es"), "{text}");
                if entry != "swell_fft_vs" {
                    assert!(text.contains("texelFetch"), "{text}");
                }
            }
        }
    }
    // The compute versions: WGSL (and GLSL 4.50, HLSL, MSL), not GLSL ES.
    let r = s
        .get("/v1/scenes/storm/shader?lang=wgsl&entry=swell_fft_butterfly_cs&layer=0")
        .await;
    assert_eq!(r.status(), 200);
    assert!(
        r.text()
            .await
            .unwrap()
            .contains("@compute @workgroup_size(8, 8)")
    );
    let (st, v) = s
        .get_json("/v1/scenes/storm/shader?lang=glsl_es&entry=swell_fft_evolve_cs&layer=0")
        .await;
    assert_eq!(st, 400, "{v}");
    assert_eq!(v["error"]["field"], "lang", "{v}");
    // The surface shader of an FFT scene samples the layer's textures.
    let text = s
        .get("/v1/scenes/open-sea/shader?lang=wgsl")
        .await
        .text()
        .await
        .unwrap();
    assert!(text.contains("s = swell_fft0(s, p);"), "{text}");
    for (q, why) in [
        ("entry=swell_fft_evolve", "needs"),
        ("entry=swell_fft_evolve&layer=1", "gerstner"),
        ("entry=swell_fft_evolve&layer=9", "out of range"),
        ("entry=swell_fft_evolve&layer=x", "not a layer index"),
        ("entry=swell_probe_fs&layer=0", "only for the FFT pass"),
    ] {
        let (st, v) = s
            .get_json(&format!("/v1/scenes/open-sea/shader?lang=glsl_es&{q}"))
            .await;
        assert_eq!(st, 400, "{q}: {v}");
        assert_eq!(v["error"]["field"], "layer", "{q}: {v}");
        assert!(
            v["error"]["message"].as_str().unwrap().contains(why),
            "{q}: {v}"
        );
    }
    // t = 10⁶ s: τ = (10⁶ mod 300)/300 = 1/3, split at b = 24 − bits(q_max) bits.
    let (st, v) = s
        .get_json("/v1/scenes/storm/uniforms?t=1000000&origin=1000000,-3")
        .await;
    assert_eq!(st, 200, "{v}");
    let c: Vec<f64> = v["fft"][0]["cycle"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(v["fft"][0]["layer"], 0);
    assert!((c[0] + c[1] + c[2] - 1.0 / 3.0).abs() < 1e-12, "{c:?}");
    assert!(c[0] > 0.33 && c[1] > 0.0 && c[2].abs() < 1e-8, "{c:?}");
    // Grid offset: (10⁶ mod 256, −3 mod 256) m at 1 m per node.
    let block = v["block"].as_array().unwrap();
    assert_eq!(block[4..6], [json!(64.0), json!(253.0)]);
    s.stop().await;
}

/// The export `/spectrum` answered with before answers were cached, made here the same way:
/// the cache must not change a byte.
fn export_now(s: &TestServer, id: &str, layer: usize, seed: u64) -> Vec<u8> {
    let entry = s.state.scene(id).unwrap();
    let meta = swell_shaders::spectrum::SpectrumMeta {
        scene: id.to_owned(),
        spec_hash: entry.scene.spec_hash.clone(),
        seed,
    };
    swell_shaders::spectrum::export(&entry.scene.surface, layer, &meta).unwrap()
}

/// Issue 27: every `/spectrum` request built the whole export (1.5 MB at 256²) and held its own
/// copy until sent, so many clients fetching the same spectrum held as many copies. The answer
/// is now made once per scene build and shared: a second request (or eight at once) builds
/// nothing, the bytes are those of a fresh export, and a replaced scene's spectrum is its own,
/// with the old one's bytes given back to the budget at once.
#[tokio::test]
async fn a_spectrum_is_built_once_per_scene_build_and_shared() {
    let s = TestServer::start(config()).await;
    let (st, _) = s.put_scene("sea", &common::fft_spec()).await;
    assert_eq!(st, 201);
    let old = s.state.scene("sea").unwrap().scene.clone();
    assert_eq!(old.answers.builds(), 0);
    let get = || async {
        let r = s.get("/v1/scenes/sea/spectrum?layer=0").await;
        assert_eq!(r.status(), 200);
        r.bytes().await.unwrap()
    };
    let first = get().await;
    assert_eq!(old.answers.builds(), 1);
    let second = get().await;
    assert_eq!(old.answers.builds(), 1, "the second request built it again");
    let burst = futures_util::future::join_all((0..8).map(|_| get())).await;
    assert_eq!(
        old.answers.builds(),
        1,
        "concurrent requests built it again"
    );
    let (_, detail) = s.get_json("/v1/scenes/sea").await;
    let seed = detail["derived"]["layers"][0]["seed"].as_u64().unwrap();
    let fresh = export_now(&s, "sea", 0, seed);
    assert_eq!(first.as_ref(), fresh.as_slice());
    assert_eq!(second, first);
    assert!(burst.iter().all(|b| *b == first));
    // The cached bytes are the budget's, once.
    assert_eq!(old.answers.cached_bytes(), first.len());
    assert!(s.state.buffers.held() >= first.len());

    // Replaced: another sea, another spectrum, built afresh; the old bytes are gone at once.
    let mut spec = common::fft_spec();
    spec["seed"] = json!(12);
    assert_eq!(s.put_scene("sea", &spec).await.0, 200);
    assert_eq!(old.answers.cached_bytes(), 0);
    let new = s.state.scene("sea").unwrap().scene.clone();
    assert_ne!(new.uid, old.uid);
    let replaced = get().await;
    assert_eq!(new.answers.builds(), 1);
    assert_ne!(
        replaced, first,
        "the replaced scene answered the old spectrum"
    );
    let (_, detail) = s.get_json("/v1/scenes/sea").await;
    let seed = detail["derived"]["layers"][0]["seed"].as_u64().unwrap();
    assert_eq!(replaced.as_ref(), export_now(&s, "sea", 0, seed).as_slice());
    // A request that was already making the old build's answer keeps nothing for it.
    let late = old
        .answers
        .get_or_build(
            swell::scene::answers::AnswerKey::Spectrum { layer: 0 },
            &s.state.buffers,
            || async { Ok::<_, ()>(bytes::Bytes::from_static(b"late")) },
        )
        .await
        .unwrap();
    assert_eq!(late.as_ref(), b"late");
    assert_eq!(old.answers.cached_bytes(), 0);

    // Deleted: the bytes go back to the budget.
    let held = s.state.buffers.held();
    let (st, _) = s
        .admin(
            reqwest::Method::DELETE,
            "/v1/scenes/sea",
            None,
            Some(common::TOKEN),
        )
        .await;
    assert_eq!(st, 204);
    assert_eq!(new.answers.cached_bytes(), 0);
    assert!(s.state.buffers.held() <= held - replaced.len());
    s.stop().await;
}
