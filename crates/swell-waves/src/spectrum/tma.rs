//! The TMA finite-depth factor (Bouws et al. 1985; Kitaigorodskii's Φ).
//!
//! TMA is JONSWAP times `Φ(ω, h)`, which bends the ω⁻⁵ tail to the shallow-water k⁻³ law. With
//! `ωh = ω·sqrt(h/g)`: `Φ = ωh²/2` for `ωh ≤ 1`, `1 − (2 − ωh)²/2` for `1 < ωh ≤ 2`, and 1 beyond
//! (Thompson and Vincent's piecewise fit). Φ and its first derivative are continuous; its second
//! derivative jumps at `ωh = 1` and 2, so quadratures split there.

/// Φ(ω, h), dimensionless in [0, 1]. `depth: None` (deep water) gives 1: the factor is the
/// identity once `h → ∞`, so a TMA sea on deep water is JONSWAP.
#[inline]
pub(crate) fn depth_factor(omega: f64, depth: Option<f64>, gravity: f64) -> f64 {
    let Some(h) = depth else {
        return 1.0;
    };
    let wh = omega * (h / gravity).sqrt();
    if wh <= 1.0 {
        0.5 * wh * wh
    } else if wh <= 2.0 {
        let d = 2.0 - wh;
        1.0 - 0.5 * d * d
    } else {
        1.0
    }
}

/// The angular frequencies (rad/s) where Φ changes formula: `ωh = 1` and `ωh = 2`.
pub(crate) fn kinks(depth: Option<f64>, gravity: f64) -> Option<[f64; 2]> {
    let h = depth?;
    let w1 = (gravity / h).sqrt();
    Some([w1, 2.0 * w1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn piecewise_values() {
        let (g, h) = (9.81f64, 4.0f64);
        let s = (h / g).sqrt();
        assert!((depth_factor(0.5 / s, Some(h), g) - 0.125).abs() < 1e-15);
        assert!((depth_factor(1.0 / s, Some(h), g) - 0.5).abs() < 1e-15);
        assert!((depth_factor(1.5 / s, Some(h), g) - 0.875).abs() < 1e-15);
        assert_eq!(depth_factor(3.0 / s, Some(h), g), 1.0);
        assert_eq!(depth_factor(0.1, None, g), 1.0);
    }
}
