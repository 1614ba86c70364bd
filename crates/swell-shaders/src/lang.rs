//! The output languages and the entry points of the exported shader.

/// A shading language the surface can be exported in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Lang {
    /// WGSL (WebGPU): the emitted module itself, every entry point.
    Wgsl,
    /// GLSL 4.50 core (desktop OpenGL, Vulkan-style GLSL toolchains): one entry point, as `main`.
    Glsl,
    /// GLSL ES 3.00 (WebGL2, OpenGL ES 3): one entry point, as `main`.
    GlslEs,
    /// HLSL, shader model 5.1 (Direct3D 11/12, Unity, Unreal).
    Hlsl,
    /// Metal Shading Language 2.1.
    Msl,
    /// An HLSL include for Unity and Unreal: the functions, a `cbuffer SwellUniforms` with no
    /// explicit register, coordinate helpers; no entry point ([`crate::engines::hlsl`]).
    HlslInclude,
    /// A Godot 4 `.gdshaderinc`: the functions and `uniform vec4 swell_u_*[]` arrays; no entry
    /// point ([`crate::engines::godot`]).
    Gdshaderinc,
}

impl Lang {
    /// Every language, in the order the API lists them.
    pub const ALL: [Lang; 7] = [
        Lang::Wgsl,
        Lang::Glsl,
        Lang::GlslEs,
        Lang::Hlsl,
        Lang::Msl,
        Lang::HlslInclude,
        Lang::Gdshaderinc,
    ];

    /// The name used in the API's `lang` parameter.
    pub fn name(self) -> &'static str {
        match self {
            Lang::Wgsl => "wgsl",
            Lang::Glsl => "glsl",
            Lang::GlslEs => "glsl_es",
            Lang::Hlsl => "hlsl",
            Lang::Msl => "msl",
            Lang::HlslInclude => "hlsl_include",
            Lang::Gdshaderinc => "gdshaderinc",
        }
    }

    /// Parses an API name (exact, lower case); `None` for anything else.
    pub fn parse(name: &str) -> Option<Lang> {
        Lang::ALL.into_iter().find(|l| l.name() == name)
    }

    /// Whether an output holds exactly one entry point (GLSL renames it `main`).
    pub fn single_entry(self) -> bool {
        matches!(self, Lang::Glsl | Lang::GlslEs)
    }

    /// Whether the output is an engine include: functions and uniforms, no entry point (an
    /// `entry` does not apply to it).
    pub fn is_include(self) -> bool {
        matches!(self, Lang::HlslInclude | Lang::Gdshaderinc)
    }
}

/// An entry point of the exported shader.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Entry {
    /// `swell_vs`: the render vertex shader. Input `@location(0)` the undisplaced local x/z of a
    /// grid vertex; outputs the clip position `view_proj · (displaced local position, 1)`, and at
    /// locations 0–2 the displaced local position, the unit normal and the Jacobian.
    Vertex,
    /// `swell_probe_vs`: a pass-through vertex shader for probes (one point per probe): input
    /// `@location(0)` the local x/z to evaluate, `@location(1)` the clip-space x/y of the pixel to
    /// write it into.
    ProbeVertex,
    /// `swell_probe_fs`: evaluates the surface at the probe's local x/z and writes, to two float
    /// targets, `(Dx, y, Dz, J)` and `(normal.x, normal.y, normal.z, height)`: what `/sample`
    /// answers for that world point. `(Dx, y, Dz)` is the displacement of the point taken as
    /// undisplaced; J, the normal and the height belong to the surface point above it
    /// (horizontal displacement inverted).
    ProbeFragment,
    /// `swell_fft_vs`: the FFT passes' vertex shader, a full-screen triangle from the vertex
    /// index (draw 3 vertices, no attributes). In an FFT layer's pass module ([`crate::fft`]).
    FftVertex,
    /// `swell_fft_evolve`: the FFT layer's evolution pass h̃(k, t) and the spectra of its eight
    /// grids, into two RGBA32F targets ([`crate::fft`]).
    FftEvolve,
    /// `swell_fft_butterfly`: one radix-2 Stockham stage of the inverse 2-D FFT, along x or z
    /// ([`crate::fft`]).
    FftButterfly,
    /// `swell_fft_evolve_cs`: the evolve pass as a compute shader (8×8 workgroups, storage
    /// texture outputs), in an FFT layer's compute module ([`crate::fft::emit_compute`]); not
    /// for GLSL ES.
    FftEvolveCompute,
    /// `swell_fft_butterfly_cs`: one butterfly stage as a compute shader; not for GLSL ES.
    FftButterflyCompute,
}

impl Entry {
    /// The surface module's entry points.
    pub const ALL: [Entry; 3] = [Entry::Vertex, Entry::ProbeVertex, Entry::ProbeFragment];

    /// The entry points of an FFT layer's pass module ([`crate::fft::emit_passes`]).
    pub const FFT: [Entry; 3] = [Entry::FftVertex, Entry::FftEvolve, Entry::FftButterfly];

    /// The entry points of an FFT layer's compute module ([`crate::fft::emit_compute`]).
    pub const FFT_COMPUTE: [Entry; 2] = [Entry::FftEvolveCompute, Entry::FftButterflyCompute];

    /// Whether this entry point is in an FFT layer's pass or compute module (and so needs a
    /// layer).
    pub fn is_fft(self) -> bool {
        Entry::FFT.contains(&self) || self.is_compute()
    }

    /// Whether this entry point is a compute shader.
    pub fn is_compute(self) -> bool {
        Entry::FFT_COMPUTE.contains(&self)
    }

    /// The function name in the WGSL module (and the API's `entry` parameter).
    pub fn name(self) -> &'static str {
        match self {
            Entry::Vertex => "swell_vs",
            Entry::ProbeVertex => "swell_probe_vs",
            Entry::ProbeFragment => "swell_probe_fs",
            Entry::FftVertex => "swell_fft_vs",
            Entry::FftEvolve => "swell_fft_evolve",
            Entry::FftButterfly => "swell_fft_butterfly",
            Entry::FftEvolveCompute => "swell_fft_evolve_cs",
            Entry::FftButterflyCompute => "swell_fft_butterfly_cs",
        }
    }

    /// Parses an entry point name (of either module); `None` for anything else.
    pub fn parse(name: &str) -> Option<Entry> {
        Entry::ALL
            .into_iter()
            .chain(Entry::FFT)
            .chain(Entry::FFT_COMPUTE)
            .find(|e| e.name() == name)
    }

    /// The pipeline stage.
    pub fn stage(self) -> naga::ShaderStage {
        match self {
            Entry::Vertex | Entry::ProbeVertex | Entry::FftVertex => naga::ShaderStage::Vertex,
            Entry::ProbeFragment | Entry::FftEvolve | Entry::FftButterfly => {
                naga::ShaderStage::Fragment
            }
            Entry::FftEvolveCompute | Entry::FftButterflyCompute => naga::ShaderStage::Compute,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknowns_are_rejected() {
        for l in Lang::ALL {
            assert_eq!(Lang::parse(l.name()), Some(l));
        }
        for e in Entry::ALL
            .into_iter()
            .chain(Entry::FFT)
            .chain(Entry::FFT_COMPUTE)
        {
            assert_eq!(Entry::parse(e.name()), Some(e));
            assert_eq!(
                e.is_fft(),
                Entry::FFT.contains(&e) || Entry::FFT_COMPUTE.contains(&e)
            );
        }
        assert_eq!(Lang::parse("GLSL"), None);
        assert_eq!(Lang::parse("spirv"), None);
        assert_eq!(Entry::parse("main"), None);
    }
}
