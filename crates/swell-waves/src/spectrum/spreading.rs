//! Directional spreading functions D(θ, ω), θ measured from the wind direction (radians).
//!
//! Each integrates to 1 over θ ∈ [−π, π], so multiplying a one-dimensional spectrum by D spreads
//! its variance over direction without changing m0. θ is first reduced to [−π, π] (D is 2π
//! periodic) by the exact IEEE remainder.
//!
//! - cos-2s (Longuet-Higgins 1963): `D = Q(s)·|cos(θ/2)|^(2s)`,
//!   `Q(s) = 2^(2s−1)/π · Γ(s+1)²/Γ(2s+1)`, evaluated through `lgamma` so large s cannot overflow.
//! - Mitsuyasu (1975): cos-2s with `s = s_p·(ω/ωp)^5` (ω ≤ ωp) or `s_p·(ω/ωp)^−2.5` (ω > ωp),
//!   `s_p = 11.5·(g/(ωp·U))^2.5`.
//! - Donelan–Banner (1985): `D = β/(2·tanh(β·π))·sech²(β·θ)`, normalised exactly.
//! - Horvath (2015): Donelan–Banner times a swell term `cos^(2·s_ξ)(θ/2)`,
//!   `s_ξ = 16·tanh(ωp/ω)·ξ²`, renormalised by a factor N(ω/ωp) tabulated at construction.

use super::quadrature::simpson;
use crate::error::{SpecError, in_range};
use crate::math::{TAU, cos, exp, ln, pow, tanh};
use std::f64::consts::{LN_2, LN_10, PI};

use super::SpreadingSpec;

/// Largest cos-2s exponent s, for `Cos2s` (validated) and Mitsuyasu (clamped). s = 1000 already
/// gives a lobe only ≈ 2.6° wide (standard deviation `≈ 2/sqrt(2s)` rad); much larger s would
/// need a finer grid than any FFT tile provides, and `Q(s)` grows like sqrt(s).
pub(crate) const MAX_COS2S_S: f64 = 1000.0;

/// The uniform spreading 1/(2π), used when there is no spectral peak (a flat sea).
const UNIFORM: f64 = 0.5 / PI;

/// Donelan–Banner: ω/ωp below this is clamped to it (their fit starts at 0.56; below it the first
/// branch would keep narrowing long waves, which the data do not support).
const DB_LOW: f64 = 0.56;
/// Donelan–Banner branch limits on ω/ωp.
const DB_MID: f64 = 0.95;
const DB_HIGH: f64 = 1.6;

/// Horvath normalisation table over ln(ω/ωp): segment limits on ω/ωp. Donelan–Banner's β jumps at
/// 0.95 and 1.6 (and has a kink at 0.56), so each segment is smooth and interpolated on its own.
/// Below 0.05, `tanh(ωp/ω) = 1` in f64 and N is constant; above 1000 the (rare) slow reference is
/// used.
const TABLE_BREAKS: [f64; 5] = [0.05, DB_LOW, DB_MID, DB_HIGH, 1000.0];
/// Node spacing in ln(ω/ωp). N is smooth within a segment; cubic interpolation on this grid keeps
/// the normalisation error below 1e-6 (measured by `horvath_table_matches_reference`; linear
/// interpolation on the same grid was 1e-4), far inside the 1e-3 required of ∫D dθ. Halving it
/// divides the error by 16 and doubles construction cost (≈ 400 nodes × 258 evaluations now,
/// ≈ 9 ms in a release build).
const TABLE_STEP: f64 = 0.025;
/// Simpson intervals for each half of one normalisation integral (see [`horvath_normaliser`]).
const NORM_INTERVALS: usize = 128;

/// A built spreading function.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Spreading {
    /// 1/(2π) everywhere (no peak to scale a frequency-dependent spreading by).
    Uniform,
    /// Fixed cos-2s; `q` = Q(s).
    Cos2s { s: f64, q: f64 },
    /// Mitsuyasu's cos-2s; `s_p` is the exponent at the peak ωp.
    Mitsuyasu { s_p: f64, omega_p: f64 },
    /// Donelan–Banner about the peak ωp.
    DonelanBanner { omega_p: f64 },
    /// Horvath with swell ξ > 0.
    Horvath {
        omega_p: f64,
        /// 16·ξ².
        swell_scale: f64,
        table: Vec<Segment>,
    },
}

/// One smooth piece of the Horvath normalisation table.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Segment {
    ln_lo: f64,
    step: f64,
    values: Vec<f64>,
}

impl Spreading {
    /// Validates `spec` and builds it. `omega_p` (rad/s) is the spectral peak (None for a flat
    /// sea), `wind_speed` U (m/s), `gravity` g (m/s²).
    ///
    /// # Errors
    /// `{field}.s` outside (0, 1000]; `{field}.swell` outside [0, 1] (or non-finite).
    pub(crate) fn new(
        spec: &SpreadingSpec,
        omega_p: Option<f64>,
        wind_speed: f64,
        gravity: f64,
        field: &str,
    ) -> Result<Self, SpecError> {
        match *spec {
            SpreadingSpec::Cos2s { s } => {
                let name = format!("{field}.s");
                let s = in_range(&name, s, 0.0, MAX_COS2S_S)?;
                if s <= 0.0 {
                    return Err(SpecError::OutOfRange {
                        field: name,
                        value: s,
                        allowed: format!("in (0, {MAX_COS2S_S}]"),
                    });
                }
                Ok(Self::Cos2s {
                    s,
                    q: cos2s_norm(s),
                })
            }
            SpreadingSpec::Mitsuyasu => Ok(match omega_p {
                None => Self::Uniform,
                Some(wp) => Self::Mitsuyasu {
                    s_p: 11.5 * pow(gravity / (wp * wind_speed), 2.5),
                    omega_p: wp,
                },
            }),
            SpreadingSpec::DonelanBanner => Ok(match omega_p {
                None => Self::Uniform,
                Some(wp) => Self::DonelanBanner { omega_p: wp },
            }),
            SpreadingSpec::Horvath { swell } => {
                let xi = in_range(&format!("{field}.swell"), swell, 0.0, 1.0)?;
                Ok(match omega_p {
                    None => Self::Uniform,
                    // ξ = 0 is plain Donelan–Banner, normalised exactly (N = 1).
                    Some(wp) if xi == 0.0 => Self::DonelanBanner { omega_p: wp },
                    Some(wp) => {
                        let swell_scale = 16.0 * xi * xi;
                        Self::Horvath {
                            omega_p: wp,
                            swell_scale,
                            table: horvath_table(swell_scale),
                        }
                    }
                })
            }
        }
    }

    /// D(θ, ω) in 1/rad; θ any finite angle (radians from the wind), ω ≥ 0 (rad/s).
    pub(crate) fn eval(&self, theta: f64, omega: f64) -> f64 {
        // Exact IEEE remainder: θ in [−π, π] for every finite θ (unchanged when already there).
        let theta = libm::remainder(theta, TAU);
        match self {
            Self::Uniform => UNIFORM,
            Self::Cos2s { s, q } => q * cos2s_shape(theta, *s),
            Self::Mitsuyasu { s_p, omega_p } => {
                let s = mitsuyasu_s(*s_p, omega / omega_p);
                cos2s_norm(s) * cos2s_shape(theta, s)
            }
            Self::DonelanBanner { omega_p } => {
                donelan_banner(theta, donelan_banner_beta(omega / omega_p))
            }
            Self::Horvath {
                omega_p,
                swell_scale,
                table,
            } => {
                let r = omega / omega_p;
                let beta = donelan_banner_beta(r);
                let s_xi = swell_exponent(*swell_scale, r);
                let n = horvath_lookup(table, r).unwrap_or_else(|| horvath_normaliser(beta, s_xi));
                n * donelan_banner(theta, beta) * cos2s_shape(theta, s_xi)
            }
        }
    }
}

/// `Q(s) = 2^(2s−1)/π · Γ(s+1)²/Γ(2s+1)` in 1/rad, the cos-2s normaliser; `Q(0) = 1/(2π)`.
/// Through `lgamma` (libm) so that s up to [`MAX_COS2S_S`] neither overflows nor loses digits:
/// `Q ≈ sqrt(s/π)/2` for large s.
pub(crate) fn cos2s_norm(s: f64) -> f64 {
    exp((2.0 * s - 1.0) * LN_2 - ln(PI) + 2.0 * libm::lgamma(s + 1.0) - libm::lgamma(2.0 * s + 1.0))
}

/// `|cos(θ/2)|^(2s)` (dimensionless); θ in [−π, π].
#[inline]
fn cos2s_shape(theta: f64, s: f64) -> f64 {
    pow(cos(0.5 * theta).abs(), 2.0 * s)
}

/// Mitsuyasu's exponent at `r = ω/ωp`, clamped to [0, [`MAX_COS2S_S`]].
#[inline]
pub(crate) fn mitsuyasu_s(s_p: f64, r: f64) -> f64 {
    let s = if r <= 1.0 {
        let r2 = r * r;
        s_p * (r2 * r2 * r)
    } else {
        s_p * pow(r, -2.5)
    };
    s.clamp(0.0, MAX_COS2S_S)
}

/// Donelan–Banner's β at `r = ω/ωp` (dimensionless):
/// `2.61·r^1.3` for r < 0.95 (r clamped up to 0.56), `2.28·r^−0.65` for 0.95 ≤ r < 1.6, and
/// `10^(−0.4 + 0.8393·exp(−0.567·ln(r²)))` for r ≥ 1.6 (Banner 1990's high-frequency extension;
/// tends to 10^−0.4 ≈ 0.40, a broad spread, for short waves). β is discontinuous at 0.95 and 1.6,
/// as in the published fit.
pub(crate) fn donelan_banner_beta(r: f64) -> f64 {
    if r < DB_MID {
        2.61 * pow(r.max(DB_LOW), 1.3)
    } else if r < DB_HIGH {
        2.28 * pow(r, -0.65)
    } else {
        high_beta(r)
    }
}

fn high_beta(r: f64) -> f64 {
    exp((-0.4 + 0.8393 * exp(-0.567 * ln(r * r))) * LN_10)
}

/// `β/(2·tanh(β·π))·sech²(β·θ)`, θ in [−π, π]. sech² is formed from `e^(−2|x|)` so that large
/// |βθ| underflows to 0 instead of overflowing.
#[inline]
fn donelan_banner(theta: f64, beta: f64) -> f64 {
    let e = exp(-2.0 * (beta * theta).abs());
    let sech2 = 4.0 * e / ((1.0 + e) * (1.0 + e));
    beta / (2.0 * tanh(beta * PI)) * sech2
}

/// Horvath's swell exponent `s_ξ = 16·ξ²·tanh(ωp/ω)`, given `swell_scale = 16·ξ²`.
#[inline]
fn swell_exponent(swell_scale: f64, r: f64) -> f64 {
    swell_scale * tanh(1.0 / r)
}

/// Reference normaliser `N = 1 / ∫_{−π}^{π} D_DB(θ; β)·cos^(2s)(θ/2) dθ`.
///
/// The integrand is even, so `2∫_0^π`. At θ = π the swell factor behaves like `(π−θ)^(2s)` (not
/// smooth for non-integer s) and Donelan–Banner has a slope there, so a periodic trapezoid rule
/// converges only algebraically. We split at π/2: on [0, π/2] (smooth, holding the peak) plain
/// Simpson; on [π/2, π] the substitution `θ = π − (π/2)·w³` turns the endpoint into a
/// `w^(2+6s)` zero before Simpson in w. [`NORM_INTERVALS`] intervals each: relative error < 1e-7
/// against 16× as many (see tests).
pub(crate) fn horvath_normaliser(beta: f64, s_xi: f64) -> f64 {
    1.0 / horvath_integral(beta, s_xi, NORM_INTERVALS)
}

fn horvath_integral(beta: f64, s_xi: f64, intervals: usize) -> f64 {
    let f = |theta: f64| donelan_banner(theta, beta) * cos2s_shape(theta, s_xi);
    let near = simpson(f, 0.0, 0.5 * PI, intervals);
    let far = simpson(
        |w| {
            let w2 = w * w;
            1.5 * PI * w2 * f(PI - 0.5 * PI * (w2 * w))
        },
        0.0,
        1.0,
        intervals,
    );
    2.0 * (near + far)
}

/// β on the branch of segment `seg` (so a node on a branch limit uses its own segment's formula).
fn segment_beta(seg: usize, r: f64) -> f64 {
    match seg {
        0 | 1 => 2.61 * pow(r.max(DB_LOW), 1.3),
        2 => 2.28 * pow(r, -0.65),
        _ => high_beta(r),
    }
}

fn horvath_table(swell_scale: f64) -> Vec<Segment> {
    TABLE_BREAKS
        .windows(2)
        .enumerate()
        .map(|(seg, lim)| {
            let (ln_lo, ln_hi) = (ln(lim[0]), ln(lim[1]));
            let n = ((ln_hi - ln_lo) / TABLE_STEP).ceil() as usize + 1;
            let step = (ln_hi - ln_lo) / (n - 1) as f64;
            let values = (0..n)
                .map(|j| {
                    let r = exp(ln_lo + j as f64 * step);
                    horvath_normaliser(segment_beta(seg, r), swell_exponent(swell_scale, r))
                })
                .collect();
            Segment {
                ln_lo,
                step,
                values,
            }
        })
        .collect()
}

/// N at `r = ω/ωp` from the table; None above the table (the caller integrates directly).
fn horvath_lookup(table: &[Segment], r: f64) -> Option<f64> {
    let (seg, r) = if r < DB_LOW {
        (0, r.max(TABLE_BREAKS[0]))
    } else if r < DB_MID {
        (1, r)
    } else if r < DB_HIGH {
        (2, r)
    } else if r <= TABLE_BREAKS[4] {
        (3, r)
    } else {
        return None;
    };
    let s = &table[seg];
    // Cubic Lagrange interpolation through the 4 nodes around r (stencil shifted inwards at the
    // segment ends, never across a branch limit): error O(step⁴).
    let t = (ln(r) - s.ln_lo) / s.step;
    let j0 = ((t.floor() - 1.0).max(0.0) as usize).min(s.values.len() - 4);
    let t = t - j0 as f64;
    let v = &s.values[j0..j0 + 4];
    let (t1, t2, t3) = (t - 1.0, t - 2.0, t - 3.0);
    Some(
        -v[0] * t1 * t2 * t3 / 6.0 + v[1] * t * t2 * t3 / 2.0 - v[2] * t * t1 * t3 / 2.0
            + v[3] * t * t1 * t2 / 6.0,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cos2s_norm_matches_closed_forms() {
        // s = 1: Q = 2/π · 1/2 = 1/π. s = 2: 8/π · 4/24 = 4/(3π).
        assert!((cos2s_norm(1.0) - 1.0 / PI).abs() < 1e-14);
        assert!((cos2s_norm(2.0) - 4.0 / (3.0 * PI)).abs() < 1e-14);
        assert!((cos2s_norm(0.0) - 0.5 / PI).abs() < 1e-15);
        // Large s: Q ≈ sqrt(s/π)/2 · (1 + 1/(8s)).
        let s = 1000.0f64;
        let approx = (s / PI).sqrt() / 2.0 * (1.0 + 1.0 / (8.0 * s));
        assert!((cos2s_norm(s) - approx).abs() < 1e-6 * approx);
    }

    #[test]
    fn donelan_banner_beta_branches() {
        assert!((donelan_banner_beta(0.8) - 2.61 * 0.8f64.powf(1.3)).abs() < 1e-14);
        assert!((donelan_banner_beta(0.1) - 2.61 * 0.56f64.powf(1.3)).abs() < 1e-14);
        assert!((donelan_banner_beta(1.2) - 2.28 * 1.2f64.powf(-0.65)).abs() < 1e-14);
        let want = 10f64.powf(-0.4 + 0.8393 * (-0.567 * (9.0f64).ln()).exp());
        assert!((donelan_banner_beta(3.0) - want).abs() < 1e-13);
    }

    #[test]
    fn horvath_normaliser_quadrature_is_converged() {
        for &(beta, s) in &[
            (0.4, 0.01),
            (0.4, 0.3),
            (2.44, 16.0),
            (1.2, 2.5),
            (1.0, 0.0),
        ] {
            let coarse = 1.0 / horvath_integral(beta, s, NORM_INTERVALS);
            let fine = 1.0 / horvath_integral(beta, s, 16 * NORM_INTERVALS);
            assert!(
                (coarse - fine).abs() < 1e-7 * fine,
                "{beta} {s}: {coarse} {fine}"
            );
        }
        // s = 0 is plain Donelan–Banner: N = 1.
        for beta in [0.4, 1.3, 2.44] {
            let n = horvath_normaliser(beta, 0.0);
            assert!((n - 1.0).abs() < 1e-7, "{beta}: {n}");
        }
    }

    #[test]
    fn horvath_table_matches_reference() {
        // Measures the interpolation error of the N(ω/ωp) table against the direct integral at
        // points between nodes; the documented bound on TABLE_STEP comes from here.
        let mut worst: f64 = 0.0;
        for xi in [0.2f64, 0.5, 1.0] {
            let scale = 16.0 * xi * xi;
            let table = horvath_table(scale);
            for i in 0..2000 {
                let r = 0.03 * (1000.0f64 / 0.03).powf((i as f64 + 0.37) / 2000.0);
                let got = horvath_lookup(&table, r).unwrap();
                let want = horvath_normaliser(donelan_banner_beta(r), swell_exponent(scale, r));
                worst = worst.max((got - want).abs() / want);
            }
        }
        assert!(worst < 1e-6, "table error {worst}");
    }
}
