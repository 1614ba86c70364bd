//! [`ShaderError`]: why a surface could not be exported.

/// Why a shader or an export could not be produced.
#[derive(Debug, thiserror::Error)]
pub enum ShaderError {
    /// More sine and Gerstner waves than one shader carries: the phase offsets are a uniform
    /// array of `⌈waves/4⌉` vec4s, and WebGL2 only promises 16 KiB of uniform block.
    #[error("the surface has {waves} sine and Gerstner waves; a shader carries at most {max}")]
    TooManyWaves {
        /// Waves in the surface.
        waves: usize,
        /// The most one shader carries ([`crate::wgsl::MAX_SHADER_WAVES`]).
        max: usize,
    },
    /// A wave constant does not fit in f32 (finite in f64, infinite once rounded).
    #[error("wave {wave} has {what} = {value}, which is not a finite f32")]
    NotRepresentable {
        /// Index of the wave among the surface's sine and Gerstner waves.
        wave: usize,
        /// Which constant.
        what: &'static str,
        /// Its f64 value.
        value: f64,
    },
    /// naga rejected the emitted module or failed to write a translation: an emitter bug.
    #[error("naga failed at {stage}: {message}")]
    Naga {
        /// Which step: `parse`, `validate`, `glsl`, `hlsl`, `msl`.
        stage: &'static str,
        /// naga's message.
        message: String,
    },
    /// More ambient particles (or particle layers) than a shader carries.
    #[error(
        "the surface has {particles} ambient particles (or particle layers); a shader carries at most {max}"
    )]
    TooManyParticles {
        /// Particles (or particle layers) in the surface.
        particles: usize,
        /// The most one shader carries ([`crate::particles::MAX_SHADER_PARTICLES`], or 1 layer).
        max: usize,
    },
    /// A layer index that is not a layer of the surface, or not an FFT layer.
    #[error("layer {layer}: {reason}")]
    BadLayer {
        /// The index asked for.
        layer: usize,
        /// Why it cannot be exported.
        reason: String,
    },
    /// An FFT pass entry point asked for without saying which FFT layer.
    #[error("entry {entry} is an FFT pass: it needs the index of an FFT layer (layer=)")]
    NeedsLayer {
        /// The entry point's name.
        entry: &'static str,
    },
    /// An engine include asked for a surface with FFT layers: the includes carry the sine,
    /// Gerstner and particle layers (uniforms only); an FFT layer needs its textures and pass
    /// shaders, which they do not declare yet.
    #[error(
        "lang {lang} (an engine include) cannot carry this surface's {layers} FFT layer(s) yet: use lang=hlsl or glsl_es with the FFT pass shaders (entry=swell_fft_*, docs/clients.md)"
    )]
    IncludeWithFft {
        /// The include's language name.
        lang: &'static str,
        /// FFT layers in the surface.
        layers: usize,
    },
    /// An entry point the language cannot hold (a compute shader in GLSL ES 3.00).
    #[error(
        "entry {entry} is a compute shader: lang {lang} has none (use wgsl, glsl, hlsl or msl, or the fragment passes)"
    )]
    Unsupported {
        /// The entry point's name.
        entry: &'static str,
        /// The language's name.
        lang: &'static str,
    },
}
