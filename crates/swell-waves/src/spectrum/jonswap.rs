//! JONSWAP: the spectrum of a fetch-limited wind sea (Hasselmann et al. 1973).
//!
//! `S(ω) = α·g²·ω⁻⁵·exp(−5/4·(ωp/ω)⁴)·γ^r` in m²·s, `r = exp(−(ω−ωp)²/(2·σ²·ωp²))`, with the
//! fetch laws `α = 0.076·(U²/(F·g))^0.22` and `ωp = 22·(g²/(U·F))^(1/3)` (U in m/s, F in m).
//! With γ = 1 it is the Pierson–Moskowitz shape with these α and ωp.

use super::pierson_moskowitz;
use crate::math::{exp, ln, pow};

/// Width σ of the peak enhancement below the peak (ω ≤ ωp); 0.07 is JONSWAP's mean fit.
pub(crate) const SIGMA_BELOW: f64 = 0.07;
/// Width σ above the peak (ω > ωp); 0.09 is JONSWAP's mean fit. The switch at ωp makes S's second
/// derivative jump there, so quadratures split at ωp.
pub(crate) const SIGMA_ABOVE: f64 = 0.09;
/// Largest accepted peak enhancement γ. Measured seas lie in about 1–7 (mean 3.3); 20 leaves room
/// for stylised seas while keeping the peak (γ times the PM value) well scaled.
pub(crate) const MAX_GAMMA: f64 = 20.0;
/// Longest accepted fetch, m (10 000 km, more than any ocean basin). Beyond it the fetch laws
/// extrapolate far past a fully developed sea (use Pierson–Moskowitz for that), and the peak
/// `α·g²·ωp⁻⁵` grows without bound as F → ∞.
pub(crate) const MAX_FETCH: f64 = 1.0e7;

/// A built JONSWAP spectrum (validated parameters).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Jonswap {
    /// α·g², m²/s⁴.
    pub(crate) alpha_g2: f64,
    /// Peak angular frequency ωp, rad/s.
    pub(crate) omega_p: f64,
    /// ln γ, so that `γ^r = exp(r·ln γ)`.
    ln_gamma: f64,
}

impl Jonswap {
    /// From U > 0 (m/s), F > 0 (m), γ ≥ 1 and g > 0 (m/s²), all validated by the caller.
    pub(crate) fn new(wind_speed: f64, fetch: f64, gamma: f64, gravity: f64) -> Self {
        let alpha = 0.076 * pow(wind_speed * wind_speed / (fetch * gravity), 0.22);
        let omega_p = 22.0 * pow(gravity * gravity / (wind_speed * fetch), 1.0 / 3.0);
        Self {
            alpha_g2: alpha * gravity * gravity,
            omega_p,
            ln_gamma: ln(gamma),
        }
    }

    /// S(ω) in m²·s; 0 for ω ≤ 0.
    #[inline]
    pub(crate) fn density(&self, omega: f64) -> f64 {
        let base = pierson_moskowitz::shape(self.alpha_g2, self.omega_p, omega);
        if base == 0.0 || self.ln_gamma == 0.0 {
            return base;
        }
        let sigma = if omega <= self.omega_p {
            SIGMA_BELOW
        } else {
            SIGMA_ABOVE
        };
        let d = (omega - self.omega_p) / (sigma * self.omega_p);
        let r = exp(-0.5 * d * d);
        base * exp(r * self.ln_gamma)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fetch_laws_and_peak_enhancement() {
        let (u, f, g) = (10.0f64, 100_000.0f64, 9.81f64);
        let j = Jonswap::new(u, f, 3.3, g);
        let alpha = 0.076 * (u * u / (f * g)).powf(0.22);
        let wp = 22.0 * (g * g / (u * f)).powf(1.0 / 3.0);
        assert!((j.omega_p - wp).abs() < 1e-12 * wp);
        assert!((j.alpha_g2 - alpha * g * g).abs() < 1e-12 * alpha * g * g);
        // At the peak r = 1: S = γ × PM shape.
        let pm = alpha * g * g / wp.powi(5) * (-1.25f64).exp();
        assert!((j.density(wp) - 3.3 * pm).abs() < 1e-12 * pm);
    }
}
