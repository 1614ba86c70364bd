//! The dispersion relation of linear gravity waves.

use crate::error::{SpecError, positive};

/// Standard gravity, m/s². The default for every surface.
pub const STANDARD_GRAVITY: f64 = 9.81;

/// Links a wave's wave number k (rad/m) to its angular frequency ω (rad/s).
///
/// Deep water: `ω² = g·k`. Finite depth h: `ω² = g·k·tanh(k·h)`. Waves much shorter than twice
/// the depth do not feel the bottom (`tanh(k·h) → 1`), so `depth: None` is the deep limit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dispersion {
    /// Gravitational acceleration g, m/s² (> 0).
    pub gravity: f64,
    /// Water depth h, m (> 0), or `None` for deep water.
    pub depth: Option<f64>,
}

impl Default for Dispersion {
    fn default() -> Self {
        Self {
            gravity: STANDARD_GRAVITY,
            depth: None,
        }
    }
}

impl Dispersion {
    /// Validated constructor.
    ///
    /// # Errors
    /// [`SpecError`] when `gravity` or `depth` is not finite and positive.
    pub fn new(gravity: f64, depth: Option<f64>) -> Result<Self, SpecError> {
        positive("gravity", gravity)?;
        if let Some(h) = depth {
            positive("depth", h)?;
        }
        Ok(Self { gravity, depth })
    }

    /// Angular frequency ω(k) = sqrt(g·k·tanh(k·h)) in rad/s; `ω(0) = 0`.
    #[inline]
    pub fn omega(&self, k: f64) -> f64 {
        match self.depth {
            None => (self.gravity * k).sqrt(),
            Some(h) => (self.gravity * k * crate::math::tanh(k * h)).sqrt(),
        }
    }

    /// Group velocity dω/dk in m/s: `g·(tanh(kh) + kh·sech²(kh)) / (2ω)`; deep water `ω / (2k)`.
    /// At k = 0 this is the long-wave limit: `sqrt(g·h)` (finite depth) or +∞ (deep water).
    #[inline]
    pub fn d_omega_dk(&self, k: f64) -> f64 {
        match self.depth {
            None => {
                if k > 0.0 {
                    0.5 * (self.gravity / k).sqrt()
                } else {
                    f64::INFINITY
                }
            }
            Some(h) => {
                if k * h < 1e-8 {
                    return (self.gravity * h).sqrt();
                }
                let th = crate::math::tanh(k * h);
                let sech2 = 1.0 - th * th;
                self.gravity * (th + k * h * sech2) / (2.0 * self.omega(k))
            }
        }
    }

    /// Wave number for a given angular frequency (inverse of [`Dispersion::omega`]), rad/m.
    /// Deep water: `k = ω²/g`. Finite depth: Newton iteration on `ω² = g·k·tanh(k·h)` from the
    /// deep-water guess, converged to a relative 1e-14 (at most 50 steps).
    pub fn wavenumber(&self, omega: f64) -> f64 {
        let k_deep = omega * omega / self.gravity;
        let Some(h) = self.depth else {
            return k_deep;
        };
        if omega <= 0.0 {
            return 0.0;
        }
        // Start from the larger of the deep and shallow (ω/sqrt(gh)) guesses: f is convex.
        let mut k = k_deep.max(omega / (self.gravity * h).sqrt());
        for _ in 0..50 {
            let th = crate::math::tanh(k * h);
            let f = self.gravity * k * th - omega * omega;
            let df = self.gravity * (th + k * h * (1.0 - th * th));
            let step = f / df;
            k -= step;
            if step.abs() <= 1e-14 * k {
                break;
            }
        }
        k
    }

    /// Phase speed c = ω / k of a wave of wave number k, m/s.
    #[inline]
    pub fn phase_speed(&self, k: f64) -> f64 {
        self.omega(k) / k
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deep_water_matches_formula() {
        let d = Dispersion::default();
        let k = std::f64::consts::TAU / 100.0;
        assert_eq!(d.omega(k), (9.81 * k).sqrt());
        assert!((d.d_omega_dk(k) - d.omega(k) / (2.0 * k)).abs() < 1e-15);
        assert!((d.wavenumber(d.omega(k)) - k).abs() < 1e-15);
    }

    #[test]
    fn finite_depth_inverts_and_has_shallow_limit() {
        let d = Dispersion::new(9.81, Some(5.0)).unwrap();
        for &k in &[1e-4, 0.01, 0.1, 1.0, 10.0] {
            let w = d.omega(k);
            assert!((d.wavenumber(w) - k).abs() < 1e-12 * k.max(1.0), "{k}");
            // Group velocity against a central difference.
            let e = 1e-6 * k;
            let fd = (d.omega(k + e) - d.omega(k - e)) / (2.0 * e);
            assert!((d.d_omega_dk(k) - fd).abs() < 1e-5 * fd, "{k}");
        }
        // Long waves travel at sqrt(g·h).
        assert!((d.phase_speed(1e-5) - (9.81f64 * 5.0).sqrt()).abs() < 1e-4);
    }

    #[test]
    fn rejects_bad_constants() {
        assert!(Dispersion::new(0.0, None).is_err());
        assert!(Dispersion::new(9.81, Some(-1.0)).is_err());
        assert!(Dispersion::new(f64::NAN, None).is_err());
    }
}
