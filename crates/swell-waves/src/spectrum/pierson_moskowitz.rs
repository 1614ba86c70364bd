//! Pierson–Moskowitz: the spectrum of a fully developed wind sea.
//!
//! `S(ω) = α·g²·ω⁻⁵·exp(−5/4·(ωp/ω)⁴)` in m²·s (ω in rad/s), with the analytic variance
//! `m0 = ∫ S dω = α·g² / (5·ωp⁴)` (substitute `x = (ωp/ω)⁴`). JONSWAP and TMA reuse this shape.

use crate::math::exp;

/// Phillips' equilibrium-range constant α (dimensionless). 0.0081 is the value Pierson and
/// Moskowitz (1964) fitted to fully developed North Atlantic seas; S scales linearly with it.
pub(crate) const ALPHA: f64 = 0.0081;

/// Dimensionless peak frequency `ωp·U10/g` of a fully developed sea. 0.855 is the usual U10 form
/// of Pierson–Moskowitz's peak (e.g. Horvath 2015); a larger value shifts energy to shorter
/// waves and, since `m0 ∝ ωp⁻⁴`, lowers Hs.
pub(crate) const PEAK_FACTOR: f64 = 0.855;

/// Above this value of `(ωp/ω)⁴` the factor `exp(−5/4·(ωp/ω)⁴)` is below e⁻⁷⁵⁰, i.e. exactly 0 in
/// f64. Returning 0 early also keeps `ω⁻⁵` from overflowing to ∞ at tiny ω (∞·0 would be NaN).
const CUTOFF_RATIO4: f64 = 600.0;

/// Peak angular frequency `ωp = 0.855·g/U` in rad/s for a wind speed `U > 0` (m/s).
pub(crate) fn peak_omega(wind_speed: f64, gravity: f64) -> f64 {
    PEAK_FACTOR * gravity / wind_speed
}

/// The shape `α·g²·ω⁻⁵·exp(−5/4·(ωp/ω)⁴)` in m²·s, given `alpha_g2 = α·g²`; 0 for ω ≤ 0 or NaN.
/// Integer powers are plain products (exactly rounded, so deterministic).
#[inline]
pub(crate) fn shape(alpha_g2: f64, omega_p: f64, omega: f64) -> f64 {
    if omega.is_nan() || omega <= 0.0 {
        return 0.0;
    }
    let x = omega_p / omega;
    let x4 = (x * x) * (x * x);
    if x4.is_nan() || x4 > CUTOFF_RATIO4 {
        return 0.0;
    }
    let w2 = omega * omega;
    alpha_g2 / (w2 * w2 * omega) * exp(-1.25 * x4)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shape_matches_formula_at_the_peak() {
        // At ω = ωp: α g² ωp⁻⁵ e^(−5/4).
        let (a, wp) = (0.0081 * 9.81 * 9.81, 0.8);
        let want = a / 0.8f64.powi(5) * (-1.25f64).exp();
        assert!((shape(a, wp, wp) - want).abs() < 1e-14 * want);
    }

    #[test]
    fn shape_is_zero_not_nan_at_the_ends() {
        for w in [
            0.0,
            -1.0,
            1e-300,
            5e-324,
            f64::NAN,
            f64::INFINITY,
            f64::MIN_POSITIVE,
        ] {
            let v = shape(0.78, 0.8, w);
            assert_eq!(v, 0.0, "{w}");
        }
    }
}
