//! Wave spectra, directional spreading and the dispersion relation.
//!
//! A spectrum says how the sea's variance (m²) is spread over frequency and direction. Every
//! spectrum here is physically normalised: the variance of a generated sea is m0 = ∫ S(ω) dω and
//! its significant wave height is Hs = 4·sqrt(m0).
//!
//! # Layout
//! - `dispersion`: ω(k) and its inverse, deep and finite depth.
//! - `pierson_moskowitz`, `jonswap`, `tma`, `phillips`: the one-dimensional spectra.
//! - `spreading`: directional spreading functions D(θ, ω).
//! - `directional`: [`DirectionalSpectrum`], a validated spectrum + spreading + dispersion, the
//!   one type the rest of the crate samples.
//! - `quadrature`: the fixed (deterministic) quadrature rules used for normalisation.
//!
//! Units throughout: ω in rad/s, k in rad/m, θ in radians from the wind direction;
//! S(ω) in m²·s, S_k(k) in m³, the Cartesian density E(kx, kz) in m⁴.

mod directional;
mod dispersion;
mod jonswap;
mod phillips;
mod pierson_moskowitz;
mod quadrature;
mod spreading;
mod tma;

pub use directional::{DirectionalSpectrum, MAX_WIND_SPEED};
pub use dispersion::{Dispersion, STANDARD_GRAVITY};

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Which one-dimensional spectrum a sea follows. Wind speed is U10 (m/s at 10 m above the sea).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)
)]
pub enum SpectrumSpec {
    /// Phillips (Tessendorf's choice), as a wavenumber spectrum:
    /// `S(k) = (α/2)·k⁻³·exp(−1/(k·L)²)·exp(−(k·ℓ)²)` in m³, L = U²/g, ℓ = `small_wave_cutoff`.
    Phillips {
        /// U10 wind speed, m/s (≥ 0; 0 gives a flat sea).
        wind_speed: f64,
        /// Phillips constant α (dimensionless), default 0.0081 (the equilibrium-range constant).
        #[cfg_attr(feature = "serde", serde(default = "default_alpha"))]
        amplitude: f64,
        /// Small-wave suppression length ℓ, m (≥ 0), default 0 (off).
        #[cfg_attr(feature = "serde", serde(default))]
        small_wave_cutoff: f64,
    },
    /// Pierson–Moskowitz, a fully developed sea:
    /// `S(ω) = α·g²·ω⁻⁵·exp(−5/4·(ωp/ω)⁴)` in m²·s, α = 0.0081, ωp = 0.855·g/U.
    PiersonMoskowitz {
        /// U10 wind speed, m/s (≥ 0).
        wind_speed: f64,
    },
    /// JONSWAP, a fetch-limited sea: Pierson–Moskowitz shape times the peak enhancement
    /// `γ^exp(−(ω−ωp)²/(2σ²ωp²))`, α = 0.076·(U²/(F·g))^0.22, ωp = 22·(g²/(U·F))^(1/3).
    Jonswap {
        /// U10 wind speed, m/s (≥ 0).
        wind_speed: f64,
        /// Fetch F, m (> 0): the distance over which the wind has blown.
        fetch: f64,
        /// Peak enhancement γ (≥ 1), default 3.3.
        #[cfg_attr(feature = "serde", serde(default = "default_gamma"))]
        gamma: f64,
    },
    /// TMA: JONSWAP times the Kitaigorodskii finite-depth factor Φ(ω, h); h is the surface depth.
    Tma {
        /// U10 wind speed, m/s (≥ 0).
        wind_speed: f64,
        /// Fetch F, m (> 0).
        fetch: f64,
        /// Peak enhancement γ (≥ 1), default 3.3.
        #[cfg_attr(feature = "serde", serde(default = "default_gamma"))]
        gamma: f64,
    },
}

/// How a spectrum's energy spreads over direction θ (relative to the wind direction). Every
/// spreading function D(θ, ω) integrates to 1 over θ ∈ [−π, π].
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)
)]
pub enum SpreadingSpec {
    /// Longuet-Higgins cos-2s with a fixed exponent: `D = Q(s)·|cos(θ/2)|^(2s)`.
    Cos2s {
        /// Spreading exponent s (> 0); larger is narrower.
        s: f64,
    },
    /// Mitsuyasu's frequency-dependent cos-2s: s = s_p·(ω/ωp)^5 below the peak and
    /// s_p·(ω/ωp)^−2.5 above it, s_p = 11.5·(g/(ωp·U))^2.5.
    Mitsuyasu,
    /// Horvath (2015): Donelan–Banner spreading times a swell term
    /// `cos^(2·s_ξ)(θ/2)`, `s_ξ = 16·tanh(ωp/ω)·ξ²`, renormalised. `swell` ξ = 0 is plain
    /// Donelan–Banner; ξ → 1 narrows long waves into a swell.
    Horvath {
        /// Swell parameter ξ in [0, 1].
        #[cfg_attr(feature = "serde", serde(default))]
        swell: f64,
    },
    /// Plain Donelan–Banner (Horvath with ξ = 0). The default.
    #[default]
    DonelanBanner,
}

#[cfg(feature = "serde")]
fn default_alpha() -> f64 {
    0.0081
}
#[cfg(feature = "serde")]
fn default_gamma() -> f64 {
    3.3
}
