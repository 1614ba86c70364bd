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
    /// An FFT layer's pass shaders asked for in an engine include language: an include holds
    /// the surface's functions (FFT layers included, reading the passes' result textures); the
    /// passes themselves are plain shaders the engine runs, in `hlsl`, `glsl`, `msl` or `wgsl`.
    #[error(
        "lang {lang} is an engine include of the surface functions; FFT layer {layer}'s passes are plain shaders: use lang=hlsl, glsl, msl or wgsl with entry=swell_fft_* (docs/clients.md)"
    )]
    PassesNotInInclude {
        /// The include's language name.
        lang: &'static str,
        /// The FFT layer asked for.
        layer: usize,
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
