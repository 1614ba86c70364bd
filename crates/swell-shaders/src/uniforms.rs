//! The frame's uniform values: every sine and Gerstner wave's phase offset, computed in f64.
//!
//! For wave i (amplitude A, wave number k, unit direction d, frequency ω, phase φ), time t (s)
//! and render origin o (world x/z, m):
//!
//! `φ_i(t, o) = wrap(k_i·(d_i·o) − ω_i·t + φ_i)`, wrap = reduction to [−π, π]
//!
//! formed and reduced in f64 exactly as the model forms a phase
//! ([`swell_waves::wave::Wave::phase_at`]`(o, t)`, Cody–Waite reduction, exact for phases below
//! 2.7·10¹⁰ rad). The shader adds `k_i·(d_i·p_local)` for `p_local = p_world − o`, so
//! `θ = k·(d·p_world) − ω·t + φ` up to the f32 rounding of a term no larger than the local
//! distance times k, whatever t and o are.

use glam::DVec2;
use swell_waves::Surface;
use swell_waves::particles::Impacts;

use crate::wgsl::phase_vec4s;

/// One frame's uniform values.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameUniforms {
    /// Scene time t, s.
    pub t: f64,
    /// Render origin o, world x/z, m.
    pub origin: DVec2,
    /// `φ_i(t, o)` in f64, radians in [−π, π], one per sine and Gerstner wave in shader slot
    /// order (layer order, then wave order).
    pub phases: Vec<f64>,
    /// The `SwellUniforms` block as f32s, ready to upload: `phases` rounded to f32 and padded
    /// with zeros to `4·max(1, ⌈n/4⌉)` values (`phases[i / 4][i % 4]` is value i), then, for a
    /// surface with a particle layer, the particle members ([`crate::particles::block`]), then,
    /// for a surface with FFT layers, their grid offsets ([`crate::fft::block`]).
    pub block: Vec<f32>,
    /// Live impact rings that did not fit in the block ([`crate::particles::MAX_SHADER_RINGS`]).
    pub rings_dropped: usize,
    /// Per FFT layer, `(layer index, cycle)`: the evolve pass's phase split at t
    /// ([`crate::fft::cycle`]); its grid offset is in `block` ([`crate::fft::block`]).
    pub fft_cycles: Vec<(usize, [f32; 4])>,
}

/// The uniforms of `surface` at time `t` (s) for render origin `origin` (world x/z, m).
///
/// Inputs are not checked: a non-finite `t` or `origin` gives NaN phases (callers validate
/// first, as the server does).
pub fn frame(surface: &Surface, t: f64, origin: DVec2) -> FrameUniforms {
    frame_with_impacts(surface, &Impacts::new(), t, origin)
}

/// [`frame`] with the rings of `impacts` on the surface's particle layer (ignored without one).
pub fn frame_with_impacts(
    surface: &Surface,
    impacts: &Impacts,
    t: f64,
    origin: DVec2,
) -> FrameUniforms {
    let phases: Vec<f64> = surface
        .layers()
        .iter()
        .flat_map(|l| l.waves().iter())
        .map(|w| w.phase_at(origin, t))
        .collect();
    let mut block = vec![0.0f32; 4 * phase_vec4s(phases.len())];
    for (b, p) in block.iter_mut().zip(&phases) {
        *b = *p as f32;
    }
    let mut rings_dropped = 0;
    if let Ok(Some(layer)) = crate::particles::layer(surface) {
        let (more, dropped) = crate::particles::block(layer, impacts, t, origin);
        block.extend_from_slice(&more);
        rings_dropped = dropped;
    }
    block.extend(crate::fft::block(surface, origin));
    FrameUniforms {
        t,
        origin,
        phases,
        block,
        rings_dropped,
        fft_cycles: crate::fft::cycles(surface, t),
    }
}

/// The uniform block as little-endian bytes (what a client copies into its uniform buffer).
pub fn block_bytes(u: &FrameUniforms) -> Vec<u8> {
    u.block.iter().flat_map(|v| v.to_le_bytes()).collect()
}
