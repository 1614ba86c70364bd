//! Fixed, deterministic quadrature rules used to normalise spectra and spreading functions.
//!
//! Everything here is a plain composite rule with a fixed node count: the same inputs sum the same
//! terms in the same order, so results are bit-identical everywhere (no adaptive refinement whose
//! path could depend on rounding).

use crate::math::exp;

/// Composite Simpson rule for `∫_a^b f(x) dx` with `n` intervals (`n` is rounded up to even, at
/// least 2). Error `O(h⁴)` for smooth `f`.
pub(crate) fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let n = (n.max(2) + 1) & !1;
    let h = (b - a) / n as f64;
    let mut sum = f(a) + f(b);
    for i in 1..n {
        let w = if i % 2 == 1 { 4.0 } else { 2.0 };
        sum += w * f(a + i as f64 * h);
    }
    sum * h / 3.0
}

/// `∫ f(x) dx` over `[breaks[0], breaks[last]]` (all breaks > 0, ascending), by composite Simpson
/// in `u = ln x` (`dx = x·du`) on each piece between consecutive breaks, with about `per_unit`
/// intervals per unit of `ln x` (at least 16 per piece).
///
/// The log variable suits spectra, which span decades in ω or k; breaks go where the integrand's
/// second derivative jumps (the JONSWAP σ switch at ωp, the TMA kinks), so every piece is smooth
/// and Simpson keeps its fourth order.
/// Most Simpson intervals one piece of [`simpson_log`] may use.
const MAX_INTERVALS: usize = 1 << 16;

pub(crate) fn simpson_log(f: impl Fn(f64) -> f64, breaks: &[f64], per_unit: f64) -> f64 {
    let mut total = 0.0;
    for pair in breaks.windows(2) {
        let (a, b) = (crate::math::ln(pair[0]), crate::math::ln(pair[1]));
        if !(a.is_finite() && b.is_finite()) || b <= a {
            continue;
        }
        // Capped: a piece spanning absurd decades (a subnormal gravity puts the spectral peak
        // near 1e-320) must cost bounded work, not overflow the node count. Physical spectra
        // use a few thousand intervals, far below the cap, so their sums are unchanged.
        let n = (((b - a) * per_unit).ceil() as usize).clamp(16, MAX_INTERVALS);
        total += simpson(
            |u| {
                let x = exp(u);
                f(x) * x
            },
            a,
            b,
            n,
        );
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Found by fuzzing scene specs (issue 11): `gravity: 9.815e-324` put a spectrum's breaks
    /// ~1400 decades apart; the node count saturated to usize::MAX and `n + 1` overflowed (a
    /// panic in debug builds, garbage in release). The work is now bounded and the sum finite.
    #[test]
    fn a_piece_spanning_absurd_decades_costs_bounded_work() {
        let v = simpson_log(|x| 1.0 / (x * x), &[1e-320, 1.0, f64::MAX], 256.0);
        assert!(!v.is_nan(), "no panic, a number: {v}");
        let v = simpson_log(|_| 0.0, &[5e-324, 1.0], 1e300);
        assert_eq!(v, 0.0);
    }

    #[test]
    fn simpson_is_exact_for_cubics() {
        let v = simpson(|x| x * x * x - 2.0 * x + 1.0, 0.0, 2.0, 4);
        assert!((v - (4.0 - 4.0 + 2.0)).abs() < 1e-14, "{v}");
    }

    #[test]
    fn simpson_log_integrates_a_power_law() {
        // ∫_1^10 x⁻² dx = 1 − 1/10.
        let v = simpson_log(|x| 1.0 / (x * x), &[1.0, 3.0, 10.0], 256.0);
        assert!((v - 0.9).abs() < 1e-11, "{v}");
    }
}
