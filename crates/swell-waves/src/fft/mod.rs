//! The Tessendorf FFT ocean.

use crate::spectrum::{SpectrumSpec, SpreadingSpec};
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Which FFT implementation turns spectra into grids.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum FftBackend {
    /// RustFFT's scalar planner: identical bits on every CPU. The default.
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
}

#[cfg(feature = "serde")]
fn default_choppiness() -> f64 {
    1.0
}
#[cfg(feature = "serde")]
fn default_repeat_period() -> f64 {
    200.0
}
