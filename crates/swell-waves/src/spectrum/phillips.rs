//! The Phillips spectrum (Tessendorf's choice), defined over wave number.
//!
//! `S_k(k) = (α/2)·k⁻³·exp(−1/(k·L)²)·exp(−(k·ℓ)²)` in m³ (k in rad/m), `L = U²/g` the largest
//! wave a wind U can sustain, ℓ a small-wave suppression length. In deep water `ω² = g·k` maps
//! `(α/2)·k⁻³` to the equilibrium range `α·g²·ω⁻⁵`, so α means the same as Pierson–Moskowitz's.

use super::Dispersion;
use crate::math::{exp, ln};

/// Largest accepted α: 1, about 120 times the equilibrium value. S and m0 scale linearly with α;
/// the bound keeps every density finite for every accepted wind speed.
pub(crate) const MAX_ALPHA: f64 = 1.0;
/// Largest accepted small-wave cutoff ℓ, m. Real uses are centimetres to metres (ℓ ≈ L/1000 in
/// Tessendorf's notes); 1000 m already removes every wave shorter than a few kilometres.
pub(crate) const MAX_CUTOFF: f64 = 1000.0;
/// Above this exponent `1/(kL)² + (kℓ)²` the exponential is below e⁻⁷⁰⁰ (0 in f64 after the
/// multiplication by α/2·k⁻³); returning early keeps k⁻³ = ∞ at tiny k from making ∞·0 = NaN.
const MAX_EXPONENT: f64 = 700.0;

/// A built Phillips spectrum (validated parameters).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Phillips {
    /// α/2, dimensionless.
    half_alpha: f64,
    /// L = U²/g, m (> 0).
    l: f64,
    /// ℓ, m (≥ 0).
    cutoff: f64,
}

impl Phillips {
    /// From U > 0 (m/s), α ≥ 0, ℓ ≥ 0 (m) and g > 0 (m/s²), validated by the caller.
    pub(crate) fn new(
        wind_speed: f64,
        amplitude: f64,
        small_wave_cutoff: f64,
        gravity: f64,
    ) -> Self {
        Self {
            half_alpha: 0.5 * amplitude,
            l: wind_speed * wind_speed / gravity,
            cutoff: small_wave_cutoff,
        }
    }

    /// `S_k(k)` in m³; 0 for k ≤ 0, non-finite k, and where the exponentials underflow.
    #[inline]
    pub(crate) fn density_k(&self, k: f64) -> f64 {
        if !(k > 0.0 && k.is_finite()) {
            return 0.0;
        }
        let a = 1.0 / (k * self.l);
        let kl = k * self.cutoff;
        let e = a * a + kl * kl;
        if e.is_nan() || e > MAX_EXPONENT {
            return 0.0;
        }
        self.half_alpha / (k * k * k) * exp(-e)
    }

    /// `ln(S_k(k)/(α/2))`: the log shape without α, finite for every k > 0 (used to locate the
    /// peak even where `S_k` itself underflows).
    fn ln_shape(&self, k: f64) -> f64 {
        let a = 1.0 / (k * self.l);
        let kl = k * self.cutoff;
        -3.0 * ln(k) - a * a - kl * kl
    }

    /// Wave number (rad/m) where the frequency spectrum `S(ω) = S_k(k)/(dω/dk)` peaks.
    ///
    /// Deep water has a closed form: `d ln S/d ln k = 0` gives
    /// `k² = (4/L²) / (5/2 + sqrt(25/4 + 16·(ℓ/L)²))`, i.e. `ωp = (4/5)^(1/4)·g/U` when ℓ = 0.
    /// For any dispersion we scan `ln S` on 64 points of a bracket around that (from the peak of
    /// S_k itself, which finite depth moves towards, to past the deep value) and refine the best
    /// cell by golden section to 1e-12 in ln k. Fixed iteration counts: deterministic.
    pub(crate) fn peak_wavenumber(&self, dispersion: &Dispersion) -> f64 {
        let r2 = (self.cutoff / self.l) * (self.cutoff / self.l);
        let l2 = self.l * self.l;
        // Peak of S_k (slope −3) and of the deep-water S(ω) (slope −5/2).
        let k_sk = ((4.0 / l2) / (3.0 + (9.0 + 16.0 * r2).sqrt())).sqrt();
        let k_deep = ((4.0 / l2) / (2.5 + (6.25 + 16.0 * r2).sqrt())).sqrt();
        let objective = |u: f64| {
            let k = exp(u);
            self.ln_shape(k) - ln(dispersion.d_omega_dk(k))
        };
        let (lo, hi) = (ln(k_sk) - 1.0, ln(k_deep) + 1.0);
        const SCAN: usize = 64;
        let step = (hi - lo) / SCAN as f64;
        let mut best = (0, f64::NEG_INFINITY);
        for i in 0..=SCAN {
            let v = objective(lo + i as f64 * step);
            if v > best.1 {
                best = (i, v);
            }
        }
        let mut a = lo + best.0.saturating_sub(1) as f64 * step;
        let mut b = lo + (best.0 + 1).min(SCAN) as f64 * step;
        // Golden section: the bracket shrinks by 0.618 per step; 80 steps take it below 1e-16.
        let inv_phi = 0.5 * (5f64.sqrt() - 1.0);
        let mut c = b - inv_phi * (b - a);
        let mut d = a + inv_phi * (b - a);
        let (mut fc, mut fd) = (objective(c), objective(d));
        for _ in 0..80 {
            if b - a <= 1e-12 {
                break;
            }
            if fc >= fd {
                b = d;
                d = c;
                fd = fc;
                c = b - inv_phi * (b - a);
                fc = objective(c);
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + inv_phi * (b - a);
                fd = objective(d);
            }
        }
        exp(0.5 * (a + b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_matches_formula() {
        let (u, g) = (12.0f64, 9.81f64);
        let p = Phillips::new(u, 0.0081, 0.1, g);
        let l = u * u / g;
        for k in [0.01f64, 0.1, 1.0, 5.0] {
            let want = 0.00405 / k.powi(3)
                * (-1.0 / (k * l).powi(2)).exp()
                * (-(k * 0.1f64).powi(2)).exp();
            assert!((p.density_k(k) - want).abs() <= 1e-13 * want, "{k}");
        }
    }

    #[test]
    fn density_is_zero_not_nan_at_the_ends() {
        let p = Phillips::new(10.0, 0.0081, 0.0, 9.81);
        for k in [0.0, -1.0, 5e-324, 1e-200, f64::NAN, f64::INFINITY, 1e300] {
            assert_eq!(p.density_k(k), 0.0, "{k}");
        }
    }

    #[test]
    fn deep_water_peak_has_the_closed_form() {
        let g = 9.81f64;
        for u in [3.0f64, 10.0, 30.0] {
            let p = Phillips::new(u, 0.0081, 0.0, g);
            let kp = p.peak_wavenumber(&Dispersion::default());
            let wp = (g * kp).sqrt();
            let want = 0.8f64.powf(0.25) * g / u;
            assert!((wp - want).abs() < 1e-7 * want, "{u}: {wp} vs {want}");
        }
    }
}
