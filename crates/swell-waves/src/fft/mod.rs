//! The Tessendorf FFT ocean: a seeded random sea on a periodic square tile, evolved in time by
//! the dispersion relation and turned into grids by inverse FFTs.
//!
//! # Recipe
//!
//! This is the whole model, precise enough to reproduce elsewhere. N = `resolution`,
//! L = `tile_size`, λ = `choppiness`, T = `repeat_period`, Δk = 2π/L.
//!
//! 1. **Wave vectors.** k = Δk·(m, n) for integers −N/2 < m, n < N/2. The Nyquist row and column
//!    (m or n = −N/2) are left empty: those waves are shorter than the grid can carry in both
//!    signs, and dropping them keeps every field exactly real. k = 0 is empty (no mean level).
//!    With a [`Band`], a mode is kept iff `min_wavelength ≤ 2π/|k| < max_wavelength`, where
//!    `|k| = sqrt(kx² + kz²)`, `kx = m·Δk`, `kz = n·Δk` in f64.
//! 2. **Amplitudes.** For a kept mode, `(g1, g2) = SwellRng::new(mode_key(seed, m, n), 0)
//!    .gaussian_pair()` (see [`crate::math`]) and
//!    `h0(k) = (g1·s, g2·s)`, `s = sqrt(E(k)·Δk²·0.25)` where E is the wave-vector variance
//!    density (m⁴). The draw depends on (seed, m, n) only, so grids of the same L and different N
//!    share the waves they have in common, bit for bit.
//! 3. **Why that scale.** The height is `h(x, t) = Σ_k h̃(k, t)·e^{i k·x}` with
//!    `h̃(k, t) = h0(k)·e^{−iωt} + conj(h0(−k))·e^{+iωt}`; the h0(k) part is a wave travelling
//!    along +k (phase `k·x − ωt`, the crate's Gerstner convention) and the second part keeps h
//!    real. Then the mean of h² over the tile is `Σ_k |h̃(k, t)|²`. The draws for k and −k are
//!    independent, so its expectation is `Σ_k E|h0(k)|² + E|h0(−k)|² = 2·Σ_k E|h0(k)|²` (the
//!    kept set is symmetric), and `E|h0(k)|² = E[g1² + g2²]·s² = 2·E(k)Δk²/4`: the expectation is
//!    `Σ_k E(k)·Δk²`, the discrete m0, and Hs = 4·sqrt(m0).
//! 4. **Frequencies.** `ω = dispersion.omega(|k|)`, quantised down to a multiple of
//!    ω0 = 2π/T: `ω_q = floor(ω/ω0)·ω0`. Time is reduced first, `t_r = t.rem_euclid(T)`, and the
//!    phase `ω_q·t_r` goes through `reduce_phase` and `math::sin_cos`. So the sea repeats exactly
//!    every T seconds, and frames at t and t + T are identical to the bit.
//! 5. **Fields.** Eight real grids, each `Σ_k c(k)·h̃(k, t)·e^{i k·x}` with the multipliers of
//!    [`FftGrid`]: height, displacement (Dx, Dz), slopes, Jacobian terms. A frame computes only the
//!    grids asked for ([`FftFields`]), one 2-D inverse real transform each
//!    (`transform` module: N/2 column FFTs and N/2 packed row FFTs of length N, all unnormalised
//!    inverse DFTs). Grid node (i, j) is the point (i·L/N, j·L/N), stored at `[j·N + i]`.
//! 6. **Sampling.** [`FftFrame::sample`] reads a frame anywhere with a [`SampleFilter`] on the
//!    periodic grid ([`FftFrame::sample_height`] and [`FftFrame::sample_grid`] read one grid,
//!    to the same bits); [`FftLayer::sample_reference`] sums the series directly (the reference).
//!
//! 7. **Time grid.** Frames are computed at grid times `t_n = n·Δ`, Δ = T/M,
//!    M = max(1, round(T/Δ_spec)) ([`FftSpec::time_step`], default 1/60 s). A query at t reads
//!    the frames of n, the largest index with `n·Δ ≤ t_r` (`floor(t_r/Δ)` up to rounding),
//!    and `n + 1 (mod M)` with weight
//!    `w = clamp((t_r − n·Δ)/Δ, 0, 1)`: each sampled field is `a + (b − a)·w`
//!    ([`lerp_samples`]), and only `a` is read when `w = 0`. [`FftLayer::grid_position`] gives
//!    (n, n + 1, w); `accuracy.time = "exact"` ([`crate::query::TimeSampling::Exact`]) computes
//!    the frame at t itself instead.
//!
//! # Determinism
//! With [`FftBackend::Portable`] (the crate's own FFT: RustFFT's scalar plan, operation for
//! operation, run on up to 8 transforms at once by SIMD lanes, see `lanes`) a frame is the same
//! to the bit on every CPU, every SIMD level, every run and every thread count, and the same as
//! RustFFT's scalar planner gave. [`FftBackend::Native`] uses SIMD kernels chosen at
//! run time, and its low bits (~1e-14 relative) depend on the CPU.

mod fields;
mod frame;
mod lanes;
mod layer;
mod reference;
mod sample;
#[cfg(test)]
mod tests;
mod transform;
mod velocity;

pub use fields::{FftFields, FftGrid};
pub use frame::FftFrame;
pub use layer::{
    FftLayer, GridPosition, MAX_CHOPPINESS, MAX_REPEAT_PERIOD, MAX_RESOLUTION, MAX_TILE_SIZE,
    MIN_REPEAT_PERIOD, MIN_RESOLUTION, MIN_TILE_SIZE,
};
pub(crate) use sample::FftReads;
pub use sample::{FftSample, SampleFilter, lerp_samples, sample_between};
pub use velocity::FftVelocityFrame;

/// A vector whose first element sits on a 64-byte boundary (a cache line, and one AVX-512
/// vector): the transforms' lane buffers and the grids. With the allocator's 16-byte alignment
/// every 64-byte vector load or store of these buffers straddled two cache lines, which cost the
/// AVX-512 frame about a fifth of its time. Alignment moves no value, so no bit changes.
pub(crate) type AlignedVec<T> = aligned_vec::AVec<T, aligned_vec::ConstAlign<64>>;

/// A grid of f64 values whose first value sits on a 64-byte boundary, in a plain `Vec` with up to
/// 7 values of slack before it (an [`AlignedVec`] would do, but the allocator's aligned path for
/// grid-sized blocks (512 KiB at 256²) left the server holding far more memory under frame
/// churn). Dereferences to exactly its `len` values.
#[derive(Debug)]
pub(crate) struct Grid {
    buf: Vec<f64>,
    start: usize,
    len: usize,
}

impl Grid {
    /// `len` zeros.
    pub(crate) fn zeroed(len: usize) -> Self {
        let buf = vec![0.0; len + 7];
        // A Vec<f64> is 8-byte aligned, so at most 7 values from a 64-byte boundary.
        let start = buf.as_ptr().align_offset(64).min(7);
        Self { buf, start, len }
    }
}

impl Clone for Grid {
    fn clone(&self) -> Self {
        // The copy's buffer has its own address, so its own offset.
        let mut g = Self::zeroed(self.len);
        g.copy_from_slice(self);
        g
    }
}

impl std::ops::Deref for Grid {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.buf[self.start..self.start + self.len]
    }
}

impl std::ops::DerefMut for Grid {
    fn deref_mut(&mut self) -> &mut [f64] {
        &mut self.buf[self.start..self.start + self.len]
    }
}

/// `len` copies of `v` in an [`AlignedVec`].
pub(crate) fn aligned<T: Clone>(len: usize, v: T) -> AlignedVec<T> {
    let mut a = AlignedVec::new(0);
    a.resize(len, v);
    a
}

use crate::spectrum::{SpectrumSpec, SpreadingSpec};
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Which FFT implementation turns spectra into grids.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum FftBackend {
    /// The crate's own FFT (RustFFT's scalar plan, the same bits, run W transforms at a time
    /// on SIMD lanes): identical bits on every CPU and SIMD level. The default.
    #[default]
    Portable,
    /// RustFFT's planner with run-time SIMD detection: fastest, but the low bits differ between
    /// CPUs (about 1e-14 relative), so replicas on different hardware may disagree.
    Native,
}

/// Optional wavelength band of an FFT layer; waves outside `[min_wavelength, max_wavelength)` are
/// left out, so several FFT layers with different tile sizes act as cascades without counting a
/// wave twice.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Band {
    /// Shortest wavelength kept, m (≥ 0).
    #[cfg_attr(feature = "serde", serde(default))]
    pub min_wavelength: f64,
    /// Longest wavelength kept (exclusive), m (> min); absent means no upper limit.
    #[cfg_attr(feature = "serde", serde(default))]
    pub max_wavelength: Option<f64>,
}

/// A Tessendorf FFT ocean layer: a periodic tile of side `tile_size` sampled on a
/// `resolution`² grid.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct FftSpec {
    /// Grid size N per side: a power of two in 16..=1024.
    pub resolution: u32,
    /// Tile side L, m (> 0). Wave vectors are `2π/L·(m, n)` with |m|, |n| < N/2.
    pub tile_size: f64,
    /// Horizontal displacement scale λ (≥ 0): 0 is a height field, 1 is Tessendorf's choppy sea.
    #[cfg_attr(feature = "serde", serde(default = "default_choppiness"))]
    pub choppiness: f64,
    /// Repeat period T, s (> 0): frequencies are rounded down to multiples of 2π/T, so the sea
    /// repeats exactly every T seconds. Default 200 s.
    #[cfg_attr(feature = "serde", serde(default = "default_repeat_period"))]
    pub repeat_period: f64,
    /// The spectrum.
    pub spectrum: SpectrumSpec,
    /// Directional spreading, default Donelan–Banner.
    #[cfg_attr(feature = "serde", serde(default))]
    pub spreading: SpreadingSpec,
    /// Wind direction `[x, z]` (normalised; zero is an error).
    pub wind_direction: [f64; 2],
    /// Optional wavelength band.
    #[cfg_attr(feature = "serde", serde(default))]
    pub band: Option<Band>,
    /// Seed for this layer; absent means derived from the surface seed and the layer index.
    #[cfg_attr(feature = "serde", serde(default))]
    pub seed: Option<u64>,
    /// FFT backend, default portable.
    #[cfg_attr(feature = "serde", serde(default))]
    pub backend: FftBackend,
    /// Step Δ of the layer's time grid, s: frames are computed at grid times `t_n = n·Δ` and a
    /// query between two of them interpolates (see [`crate::query::TimeSampling`]). Rounded so
    /// that the repeat period holds a whole number of steps: the step in use is `T/M` with
    /// `M = max(1, round(T/Δ))`. In `[MIN_TIME_STEP, T]`; absent means [`DEFAULT_TIME_STEP`].
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub time_step: Option<f64>,
}

/// Default step of an FFT layer's time grid, s: 1/60 s. Linear interpolation between frames
/// this far apart is off by at most about `max|∂²h/∂t²|·Δ²/8`: a few tenths of a millimetre on
/// the built-in seas, where 1/30 s measured 2.7 mm on the steep, choppy `storm` (see
/// `docs/accuracy.md`, time grid section). Halving Δ quarters the error and doubles the frames
/// a server computes to follow its clock (60 a second per FFT layer in use).
pub const DEFAULT_TIME_STEP: f64 = 1.0 / 60.0;

/// Smallest time step a layer may ask for, s: a 1 kHz grid already makes frames cost more than
/// a server can follow in real time at 256².
pub const MIN_TIME_STEP: f64 = 1e-3;

#[cfg(feature = "serde")]
fn default_choppiness() -> f64 {
    1.0
}
#[cfg(feature = "serde")]
fn default_repeat_period() -> f64 {
    200.0
}
