//! # swell-shaders
//!
//! Shader export for Swell's wave model: everything a GPU client needs to render the very sea the
//! server answers from, generated from the same built [`swell_waves::Surface`].
//!
//! - One emitter writes **WGSL** from the surface's sine and Gerstner waves, with every wave's
//!   constants baked in ([`wgsl::emit`]).
//! - [`naga`] (pinned to exactly [`NAGA_VERSION`]) validates that module and translates it to
//!   **GLSL 4.50**, **GLSL ES 3.00** (WebGL2), **HLSL** (shader model 5.1) and **MSL** (2.1)
//!   ([`translate`]); and packages the functions as engine includes: an HLSL include for Unity
//!   and Unreal and a Godot `.gdshaderinc` ([`engines`]), FFT layers' result textures declared
//!   the engine's way.
//! - The host computes each wave's phase offset for the frame in f64 ([`uniforms`]); the shader
//!   adds only a small local term (see *Precision* below).
//! - A particle layer is evaluated in the shader with the model's kernel: its ambient particles'
//!   positions at t and the live impact rings come in the uniform block, computed by the host
//!   in f64 ([`particles`]).
//! - FFT layers are exported as data: the initial spectrum h0(k) and the quantised ω(k), exactly
//!   as the model draws them ([`spectrum`]); and as code: per FFT layer a pass module (evolution
//!   and a fragment-pass inverse FFT, [`fft`], [`export_fft`]) whose result textures the surface
//!   shader samples with the model's filter.
//!
//! ```
//! use swell_shaders::{Entry, Lang, export};
//! use swell_waves::{LayerSpec, Surface, SurfaceSpec};
//! use swell_waves::sine::{SineLayerSpec, SineWave};
//!
//! let spec = SurfaceSpec {
//!     seed: 1, gravity: 9.81, depth: None,
//!     layers: vec![LayerSpec::Sine(SineLayerSpec { waves: vec![SineWave {
//!         amplitude: 0.5, wavelength: 20.0, direction: [1.0, 0.0], phase: 0.0, speed: None,
//!     }] })],
//! };
//! let surface = Surface::new(&spec).unwrap();
//! let glsl = export(&surface, Lang::GlslEs, Some(Entry::ProbeFragment)).unwrap();
//! assert!(glsl.starts_with("#version 300 es"));
//! // The frame's uniforms at t = 1e6 s around a camera 1000 km out, computed in f64.
//! let block = swell_shaders::uniforms::frame(&surface, 1e6, glam::DVec2::new(1e6, 0.0));
//! assert!(block.phases[0].abs() <= std::f64::consts::PI);
//! ```
//!
//! # Layout
//! - [`lang`] — [`Lang`] (the output languages) and [`Entry`] (the entry points).
//! - [`fft`] — FFT layers: the pass module (evolve, butterflies) and the sampling code.
//! - [`particles`] — the particle layer's shader code and its part of the uniform block.
//! - [`wgsl`] — the WGSL emitter: the shader's interface (uniform block, functions, entry points).
//! - [`translate`] — naga: parse, validate, write GLSL / GLSL ES / HLSL / MSL.
//! - [`engines`] — engine-ready includes: HLSL for Unity and Unreal, a Godot `.gdshaderinc`.
//! - [`uniforms`] — the frame's uniform values: per-wave phase offsets in f64.
//! - [`spectrum`] — the binary export of an FFT layer's h0(k) and ω(k).
//! - [`error`] — [`ShaderError`].
//!
//! # Conventions
//! The model's, unchanged: right-handed, **y up**, the sea in x/z; metres, seconds, radians.
//! A wave of amplitude A, wave number k, direction d (unit, `[x, z]`), frequency ω, phase φ and
//! steepness Q moves the undisplaced point p0 by `(Q·A·d.x·cos θ, A·sin θ, Q·A·d.z·cos θ)` with
//! `θ = k·(d·p0) − ω·t + φ` (Q = 0 for sine waves). Derivatives, normal and Jacobian follow
//! [`swell_waves::wave::SurfaceSample`]: the normal is `(e_z + ∂D/∂z0) × (e_x + ∂D/∂x0)`,
//! normalised.
//!
//! # Precision
//! GPUs evaluate in f32, and their `sin`/`cos` are only accurate near [−π, π]. A phase
//! `k·x − ω·t` after an hour, or a kilometre from the origin, is thousands of radians: in f32 its
//! rounding alone is centimetres of wave. So the phase is split. The host (in f64) computes, once
//! per frame and wave i, for a render origin `o` (world x/z, near the camera):
//!
//! `φ_i(t, o) = wrap(k_i·(d_i·o) − ω_i·t + φ_i)`, wrap reducing to [−π, π]
//!
//! and the shader, given a point's local position `p_local = p_world − o`, adds only the small
//! local term: `θ_i = k_i·(d_i·p_local) + φ_i(t, o)`, which it wraps to [−π, π] again before
//! `sin`/`cos`. The error then depends on |p_local| (keep the origin within a few hundred
//! metres of what is drawn) and not on t or on the distance from the world origin.
//! [`uniforms::frame`] is that computation, bit-identical to the model's own
//! [`swell_waves::wave::Wave::phase_at`].
//!
//! # Determinism
//! The emitted text is a pure function of the surface (and of [`NAGA_VERSION`] for the
//! translations): the same scene gives the same bytes on every run and machine. The GPU results
//! are not bit-exact (GPU trig is approximate): they agree with the model within the bounds
//! measured by the browser parity test (`docs/clients.md`).
#![warn(missing_docs)]

pub mod engines;
pub mod error;
pub mod fft;
pub mod lang;
pub mod particles;
pub mod spectrum;
pub mod translate;
pub mod uniforms;
pub mod wgsl;

#[cfg(test)]
mod tests;

pub use error::ShaderError;
pub use lang::{Entry, Lang};

use swell_waves::Surface;

/// The exact naga version the translations are written with (pinned in `Cargo.toml`): its
/// output's names (uniform blocks, varyings) are part of the GLSL/HLSL/MSL interface.
pub const NAGA_VERSION: &str = "30.0.1";

/// The shader for `surface` in `lang`.
///
/// `entry` picks the entry point for the languages that hold one per output (GLSL and GLSL ES:
/// default [`Entry::Vertex`]); HLSL and MSL write only `entry` when given, else all three; WGSL
/// is the whole module whatever `entry` says, and the engine includes
/// ([`Lang::is_include`]) hold no entry point, so `entry` does not change them.
///
/// # Errors
/// [`ShaderError::TooManyWaves`] or [`ShaderError::NotRepresentable`] when the surface cannot be
/// emitted; [`ShaderError::Naga`] if naga rejects the module or fails to write it (a bug in the
/// emitter, caught by the tests for every built-in scene); [`ShaderError::NeedsLayer`] for an
/// FFT pass entry point (use [`export_fft`]). An engine include of a surface with FFT layers
/// reads the layers' result textures, which the passes of [`export_fft`] fill.
pub fn export(surface: &Surface, lang: Lang, entry: Option<Entry>) -> Result<String, ShaderError> {
    if let Some(e) = entry.filter(|e| e.is_fft()) {
        return Err(ShaderError::NeedsLayer { entry: e.name() });
    }
    let source = wgsl::emit(surface)?;
    finish(source, lang, entry)
}

/// The pass module of the FFT layer at index `layer` of `surface` in `lang` ([`fft`]):
/// `entry` picks [`Entry::FftVertex`] (the default for GLSL), [`Entry::FftEvolve`] or
/// [`Entry::FftButterfly`]; WGSL is the whole module. A compute entry point
/// ([`Entry::FftEvolveCompute`], [`Entry::FftButterflyCompute`]) gives the compute module
/// ([`fft::emit_compute`]) instead, in any language but GLSL ES
/// ([`ShaderError::Unsupported`]).
///
/// # Errors
/// [`ShaderError::BadLayer`] when `layer` is not an FFT layer or its frequencies are too high
/// for the f32 phase ([`fft::cycle_bits`]); [`ShaderError::Naga`] as [`export`]. A surface
/// entry point here is [`ShaderError::BadLayer`] too (it is not in a pass module); an engine
/// include language is [`ShaderError::PassesNotInInclude`] (the passes are plain shaders).
pub fn export_fft(
    surface: &Surface,
    layer: usize,
    lang: Lang,
    entry: Option<Entry>,
) -> Result<String, ShaderError> {
    if lang.is_include() {
        return Err(ShaderError::PassesNotInInclude {
            lang: lang.name(),
            layer,
        });
    }
    if let Some(e) = entry.filter(|e| !e.is_fft()) {
        return Err(ShaderError::BadLayer {
            layer,
            reason: format!(
                "entry {} is in the surface shader, not in an FFT pass module",
                e.name()
            ),
        });
    }
    let compute = entry.is_some_and(Entry::is_compute);
    if let Some(e) = entry.filter(|_| compute && lang == Lang::GlslEs) {
        return Err(ShaderError::Unsupported {
            entry: e.name(),
            lang: lang.name(),
        });
    }
    let source = if compute {
        fft::emit_compute(surface, layer)?
    } else {
        fft::emit_passes(surface, layer)?
    };
    // GLSL holds one entry point: this module's default is its vertex shader.
    let entry = if lang.single_entry() {
        Some(entry.unwrap_or(Entry::FftVertex))
    } else {
        entry
    };
    finish(source, lang, entry)
}

fn finish(source: String, lang: Lang, entry: Option<Entry>) -> Result<String, ShaderError> {
    match lang {
        Lang::Wgsl => {
            // Validated here too, so a WGSL client never receives a module naga rejects.
            translate::parse_and_validate(&source)?;
            Ok(source)
        }
        _ => translate::translate(&source, lang, entry),
    }
}
