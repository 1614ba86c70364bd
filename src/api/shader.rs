//! What a GPU client needs to render a scene's sea: the generated shader, the frame's uniform
//! values, and an FFT layer's spectrum. Thin handlers over [`swell_shaders`].
//!
//! - `GET /v1/scenes/{id}/shader?lang=wgsl|glsl|glsl_es|hlsl|msl[&entry=]` — source text;
//!   `lang=hlsl_include|gdshaderinc` — the engine includes (Unity/Unreal HLSL, Godot), which
//!   hold no entry point and take no `entry` (an FFT scene's include reads the layers' result
//!   textures, which the pass modules below fill);
//!   `&entry=swell_fft_vs|swell_fft_evolve|swell_fft_butterfly&layer=N` — FFT layer N's pass
//!   module (see [`swell_shaders::fft`]).
//! - `GET /v1/scenes/{id}/uniforms?[t=][&origin=x,z]` — the frame's phase offsets (f64 maths).
//! - `GET /v1/scenes/{id}/spectrum?layer=N` — binary `swell-spectrum/1` (see
//!   [`swell_shaders::spectrum`]).
//!
//! A spectrum is the same bytes for every request of a scene build: it is encoded once and
//! shared ([`crate::scene::answers`]).
//!
//! Every answer carries `Swell-Model-Version`, `Swell-Spec-Hash` and a strong `ETag`; a request
//! whose `If-None-Match` holds the current ETag gets 304 and no body.

use std::sync::Arc;

use axum::body::Bytes;
use axum::extract::{Path, Query, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use glam::DVec2;
use serde::Deserialize;
use swell_shaders::{Entry, Lang, ShaderError};
use swell_waves::LayerSpec;
use swell_waves::surface::layer_seed;

use super::admission::SharedAnswer;
use crate::error::{ApiError, ErrorCode};
use crate::scene::answers::AnswerKey;
use crate::scene::{Scene, fnv1a64_hex};
use crate::service::query::{check_time, resolve_time, run_query};
use crate::state::AppState;

/// Query of `/shader`. Every parameter is a string here and parsed by hand, so a bad value gets
/// a message naming its parameter rather than a generic rejection.
#[derive(Debug, Deserialize)]
pub struct ShaderQuery {
    lang: Option<String>,
    entry: Option<String>,
    layer: Option<String>,
}

/// Query of `/uniforms`.
#[derive(Debug, Deserialize)]
pub struct UniformsQuery {
    t: Option<String>,
    origin: Option<String>,
}

/// Query of `/spectrum`.
#[derive(Debug, Deserialize)]
pub struct SpectrumQuery {
    layer: Option<String>,
}

/// Query strings are parsed leniently into [`Option<String>`] fields; only a malformed query
/// string (bad percent-encoding) is rejected here.
fn query<T>(q: Result<Query<T>, axum::extract::rejection::QueryRejection>) -> Result<T, ApiError> {
    q.map(|Query(v)| v)
        .map_err(|r| super::errors::query_rejection(&r))
}

fn parse_lang(lang: Option<&str>) -> Result<Lang, ApiError> {
    let names = Lang::ALL.map(Lang::name).join(", ");
    match lang {
        None => Err(ApiError::invalid(
            "lang",
            format!("lang is required: one of {names}"),
        )),
        Some(l) => Lang::parse(l).ok_or_else(|| {
            ApiError::invalid("lang", format!("unknown lang {l:?}: one of {names}"))
        }),
    }
}

fn parse_entry(entry: Option<&str>) -> Result<Option<Entry>, ApiError> {
    entry
        .map(|e| {
            Entry::parse(e).ok_or_else(|| {
                ApiError::invalid(
                    "entry",
                    format!(
                        "unknown entry {e:?}: one of {}",
                        Entry::ALL
                            .into_iter()
                            .chain(Entry::FFT)
                            .chain(Entry::FFT_COMPUTE)
                            .map(Entry::name)
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )
            })
        })
        .transpose()
}

/// Parses `origin=x,z` (metres, world x/z), each within `max` in magnitude; absent is (0, 0).
fn parse_origin(origin: Option<&str>, max: f64) -> Result<DVec2, ApiError> {
    let Some(text) = origin else {
        return Ok(DVec2::ZERO);
    };
    let bad = |why: String| ApiError::invalid("origin", format!("origin {text:?}: {why}"));
    let parts: Vec<&str> = text.split(',').collect();
    let [x, z] = parts[..] else {
        return Err(bad("expected two numbers x,z".into()));
    };
    let num = |s: &str| -> Result<f64, ApiError> {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| bad(format!("{s:?} is not a number")))?;
        if v.is_finite() && v.abs() <= max {
            Ok(v)
        } else {
            Err(bad(format!(
                "{} is out of range: a finite coordinate within ±{max} m",
                swell_waves::error::Num(v)
            )))
        }
    };
    Ok(DVec2::new(num(x)?, num(z)?))
}

/// A layer index (`layer=`).
fn parse_layer(text: &str) -> Result<usize, ApiError> {
    text.trim().parse().map_err(|_| {
        ApiError::invalid(
            "layer",
            format!("layer = {text:?} is not a layer index (0, 1, ...)"),
        )
    })
}

fn shader_error(e: ShaderError) -> ApiError {
    match e {
        ShaderError::TooManyWaves { .. }
        | ShaderError::NotRepresentable { .. }
        | ShaderError::TooManyParticles { .. } => {
            ApiError::new(ErrorCode::ShaderUnavailable, e.to_string())
        }
        ShaderError::BadLayer { .. } | ShaderError::NeedsLayer { .. } => {
            ApiError::invalid("layer", e.to_string())
        }
        ShaderError::Unsupported { .. } | ShaderError::PassesNotInInclude { .. } => {
            ApiError::invalid("lang", e.to_string())
        }
        ShaderError::Naga { .. } => ApiError::internal(e),
    }
}

/// A strong ETag: FNV-1a of `key` in quotes.
fn etag(key: &[u8]) -> String {
    format!("\"{}\"", fnv1a64_hex(key))
}

/// Whether `If-None-Match` lists `tag` (or `*`).
fn not_modified(headers: &HeaderMap, tag: &str) -> bool {
    headers
        .get_all(header::IF_NONE_MATCH)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .map(str::trim)
        .any(|t| t == tag || t == "*" || t.strip_prefix("W/") == Some(tag))
}

/// The answer: `body` with `content_type`, the scene's version headers and `tag`; or 304.
fn reply(
    scene: &Scene,
    headers: &HeaderMap,
    tag: &str,
    content_type: &'static str,
    body: impl FnOnce() -> Result<Bytes, ApiError>,
) -> Result<Response, ApiError> {
    let mut resp = if not_modified(headers, tag) {
        StatusCode::NOT_MODIFIED.into_response()
    } else {
        let mut r = (StatusCode::OK, body()?).into_response();
        r.headers_mut()
            .insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
        r
    };
    let h = resp.headers_mut();
    // Hex digits and quotes only: always a valid header value.
    if let Ok(v) = HeaderValue::from_str(tag) {
        h.insert(header::ETAG, v);
    }
    h.insert(
        "swell-model-version",
        HeaderValue::from(swell_waves::MODEL_VERSION),
    );
    if let Ok(v) = HeaderValue::from_str(&scene.spec_hash) {
        h.insert("swell-spec-hash", v);
    }
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
    Ok(resp)
}

/// `GET /v1/scenes/{id}/shader?lang=&entry=`.
pub async fn shader(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
    q: Result<Query<ShaderQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, ApiError> {
    let entry_ = state.scene(&id)?;
    let q = query(q)?;
    let lang = parse_lang(q.lang.as_deref())?;
    let entry = parse_entry(q.entry.as_deref())?;
    if let (true, Some(e)) = (lang.is_include(), entry) {
        return Err(ApiError::invalid(
            "entry",
            format!(
                "lang={} is an include with no entry point: drop entry={}",
                lang.name(),
                e.name()
            ),
        ));
    }
    // An FFT pass entry point names its layer; the surface shader takes none.
    let layer = match (entry.filter(|e| e.is_fft()), q.layer.as_deref()) {
        (Some(_), Some(text)) => Some(parse_layer(text)?),
        (Some(e), None) => {
            return Err(shader_error(ShaderError::NeedsLayer { entry: e.name() }));
        }
        (None, Some(_)) => {
            return Err(ApiError::invalid(
                "layer",
                "layer is only for the FFT pass entry points (swell_fft_vs, swell_fft_evolve, swell_fft_butterfly, swell_fft_evolve_cs, swell_fft_butterfly_cs)",
            ));
        }
        (None, None) => None,
    };
    let scene = Arc::clone(&entry_.scene);
    // The text is a pure function of these (the spec through its hash), so the tag is known
    // before the work and a revalidation costs nothing.
    let tag = etag(
        format!(
            "shader|{}|{}|{}|{}|{}|{}|{}",
            swell_waves::MODEL_VERSION,
            scene.spec_hash,
            env!("CARGO_PKG_VERSION"),
            swell_shaders::NAGA_VERSION,
            lang.name(),
            entry.map_or("", Entry::name),
            layer.map_or(String::new(), |l| l.to_string()),
        )
        .as_bytes(),
    );
    if not_modified(&headers, &tag) {
        return reply(&scene, &headers, &tag, "text/plain; charset=utf-8", || {
            Ok(Bytes::new())
        });
    }
    let s = Arc::clone(&scene);
    let text = run_query(false, move || {
        match layer {
            Some(l) => swell_shaders::export_fft(&s.surface, l, lang, entry),
            None => swell_shaders::export(&s.surface, lang, entry),
        }
        .map_err(shader_error)
    })
    .await?;
    reply(&scene, &headers, &tag, "text/plain; charset=utf-8", || {
        Ok(Bytes::from(text))
    })
}

/// `GET /v1/scenes/{id}/uniforms?t=&origin=x,z`: `t` defaults to the scene clock's now, the
/// origin to (0, 0).
pub async fn uniforms(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
    q: Result<Query<UniformsQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, ApiError> {
    let entry = state.scene(&id)?;
    let q = query(q)?;
    let t = match q.t.as_deref() {
        None => resolve_time(&state, &entry, None)?.t,
        Some(s) => {
            let v: f64 = s.trim().parse().map_err(|_| {
                ApiError::invalid("t", format!("t = {s:?} is not a number (seconds)"))
            })?;
            check_time(&state.limits, v, "t")?
        }
    };
    let origin = parse_origin(q.origin.as_deref(), state.limits.max_coordinate)?;
    let scene = Arc::clone(&entry.scene);
    let u = swell_shaders::uniforms::frame_with_impacts(
        &scene.surface,
        &scene.impacts.current(),
        t,
        origin,
    );
    if let Some(i) = u.phases.iter().position(|p| !p.is_finite()) {
        return Err(ApiError::non_finite(format!(
            "phases[{i}] = {}",
            u.phases[i]
        )));
    }
    let block: Vec<f64> = u.block.iter().map(|&v| f64::from(v)).collect();
    let body = serde_json::json!({
        "scene": scene.id,
        "model_version": swell_waves::MODEL_VERSION,
        "spec_hash": scene.spec_hash,
        "t": t,
        "origin": [origin.x, origin.y],
        "waves": u.phases.len(),
        "phases": u.phases,
        "block": block,
        "block_bytes": 4 * u.block.len(),
        "rings_dropped": u.rings_dropped,
        "fft": u.fft_cycles.iter().map(|(layer, c)| serde_json::json!({
            "layer": layer,
            "cycle": c.iter().map(|&v| f64::from(v)).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "layout": "SwellUniforms { phases: array<vec4<f32>, block.len()/4> } at @group(0) @binding(0): upload block as f32 (value i is phases[i/4][i%4])",
        "formula": "phases[i] = wrap(k_i*(d_i . origin) - omega_i*t + phi_i) in f64, wrapped to [-pi, pi]; the shader adds k_i*(d_i . p_local), p_local = p_world - origin",
        "fft_formula": "block ends with one vec4 per FFT layer: ((origin mod L)*N/L per axis, 0, 0); fft[*].cycle is the layer's evolve-pass uniform: tau = (t mod T)/T split in f64 into t1 = floor(tau*2^b)/2^b, t2 = floor((tau - t1)*2^2b)/2^2b, t3 = tau - t1 - t2 (b in the pass shader's header)",
    });
    let bytes = serde_json::to_vec(&body).map_err(ApiError::internal)?;
    let tag = etag(&bytes);
    reply(&scene, &headers, &tag, "application/json", || {
        Ok(Bytes::from(bytes))
    })
}

/// `GET /v1/scenes/{id}/spectrum?layer=N`.
pub async fn spectrum(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
    q: Result<Query<SpectrumQuery>, axum::extract::rejection::QueryRejection>,
) -> Result<Response, ApiError> {
    let entry = state.scene(&id)?;
    let q = query(q)?;
    let Some(text) = q.layer.as_deref() else {
        return Err(ApiError::invalid(
            "layer",
            "layer is required: the index of an FFT layer",
        ));
    };
    let layer = parse_layer(text)?;
    let scene = Arc::clone(&entry.scene);
    // Checked before any work: the error names the layer's kind or the range.
    swell_shaders::spectrum::fft_layer(&scene.surface, layer).map_err(shader_error)?;
    let seed = match scene.spec.surface.layers.get(layer) {
        Some(LayerSpec::Fft(f)) => f
            .seed
            .unwrap_or_else(|| layer_seed(scene.spec.surface.seed, layer)),
        _ => return Err(ApiError::internal("built FFT layer without an FFT spec")),
    };
    let tag = etag(
        format!(
            "spectrum|{}|{}|{}|{layer}",
            swell_waves::MODEL_VERSION,
            scene.spec_hash,
            swell_shaders::spectrum::FORMAT,
        )
        .as_bytes(),
    );
    if not_modified(&headers, &tag) {
        return reply(&scene, &headers, &tag, "application/octet-stream", || {
            Ok(Bytes::new())
        });
    }
    // A pure function of the build and the layer: made once and shared by every request for
    // it (the layer was checked above, which bounds the keys), freed with the build.
    let s = Arc::clone(&scene);
    let bytes = scene
        .answers
        .get_or_build(AnswerKey::Spectrum { layer }, &state.buffers, || {
            run_query(false, move || {
                let meta = swell_shaders::spectrum::SpectrumMeta {
                    scene: s.id.clone(),
                    spec_hash: s.spec_hash.clone(),
                    seed,
                };
                swell_shaders::spectrum::export(&s.surface, layer, &meta)
                    .map(Bytes::from)
                    .map_err(shader_error)
            })
        })
        .await?;
    let mut resp = reply(&scene, &headers, &tag, "application/octet-stream", || {
        Ok(bytes)
    })?;
    // Its bytes are charged once, to the cache, not again per request that sends them.
    resp.extensions_mut().insert(SharedAnswer);
    Ok(resp)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin;

    /// naga validates the WGSL of every built-in scene and writes every language and entry
    /// point from it (the FFT-only `storm` gives an empty wave sum, still a valid shader).
    #[test]
    fn every_builtin_scene_exports_in_every_language() {
        for (id, spec) in builtin::specs() {
            let scene = Scene::build(&id, spec).unwrap();
            for lang in Lang::ALL {
                for entry in [None, Some(Entry::Vertex), Some(Entry::ProbeFragment)] {
                    let out = swell_shaders::export(&scene.surface, lang, entry);
                    let text = out.unwrap_or_else(|e| panic!("{id} {lang:?} {entry:?}: {e}"));
                    assert!(text.contains("swell_sample"), "{id} {lang:?}");
                }
                for (li, _) in swell_shaders::fft::layers(&scene.surface) {
                    for entry in Entry::FFT {
                        let out = swell_shaders::export_fft(&scene.surface, li, lang, Some(entry));
                        if lang.is_include() {
                            // The passes are plain shaders; the includes read their results.
                            assert!(
                                matches!(out, Err(ShaderError::PassesNotInInclude { .. })),
                                "{id} {lang:?}"
                            );
                            continue;
                        }
                        out.unwrap_or_else(|e| panic!("{id} layer {li} {lang:?} {entry:?}: {e}"));
                    }
                }
            }
        }
    }

    #[test]
    fn origin_parsing_names_the_parameter() {
        assert_eq!(parse_origin(None, 1e9).unwrap(), DVec2::ZERO);
        assert_eq!(
            parse_origin(Some("1e6, -2.5"), 1e9).unwrap(),
            DVec2::new(1e6, -2.5)
        );
        for bad in ["1", "1,2,3", "x,1", "nan,0", "1e10,0", ""] {
            let e = parse_origin(Some(bad), 1e9).unwrap_err();
            assert_eq!(e.field.as_deref(), Some("origin"), "{bad}");
            assert_eq!(e.status(), StatusCode::BAD_REQUEST);
        }
    }

    #[test]
    fn if_none_match_matches_lists_and_weak_tags() {
        let mut h = HeaderMap::new();
        h.insert(
            header::IF_NONE_MATCH,
            HeaderValue::from_static("\"a\", W/\"b\""),
        );
        assert!(not_modified(&h, "\"a\""));
        assert!(not_modified(&h, "\"b\""));
        assert!(!not_modified(&h, "\"c\""));
        assert!(!not_modified(&HeaderMap::new(), "\"a\""));
    }
}
