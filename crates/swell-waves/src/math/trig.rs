//! Sine and cosine from a fixed polynomial kernel.
//!
//! The argument is first reduced to [−π, π] by [`reduce_phase`], then to [−π/4, π/4] by a
//! quadrant step, and evaluated with the classic minimax polynomials of fdlibm's `__kernel_sin`
//! and `__kernel_cos` (error below 1 ulp on the reduced interval). Every step is plain `*` and
//! `+`, so the bits are the same on every CPU; the platform's `sin` is not.

use super::phase::{reduce_phase, round_ties_away};

// π/2 = PIO2_1 + PIO2_2 (+ 3.5e-27); PIO2_1 has 33 significant bits, so q·PIO2_1 is exact for
// the quadrant numbers |q| ≤ 2 we use.
const PIO2_1: f64 = 1.570_796_326_734_125_6;
const PIO2_2: f64 = 6.077_100_506_506_192e-11;
const TWO_OVER_PI: f64 = std::f64::consts::FRAC_2_PI;

// fdlibm's published coefficients, kept digit for digit so the kernel is recognisably that one.
#[allow(clippy::excessive_precision)]
const S1: f64 = -1.666_666_666_666_663_243_48e-1;
#[allow(clippy::excessive_precision)]
const S2: f64 = 8.333_333_333_322_489_461_24e-3;
#[allow(clippy::excessive_precision)]
const S3: f64 = -1.984_126_982_985_794_931_34e-4;
#[allow(clippy::excessive_precision)]
const S4: f64 = 2.755_731_370_707_006_767_89e-6;
#[allow(clippy::excessive_precision)]
const S5: f64 = -2.505_076_025_340_686_341_95e-8;
#[allow(clippy::excessive_precision)]
const S6: f64 = 1.589_690_995_211_550_102_21e-10;

#[allow(clippy::excessive_precision)]
const C1: f64 = 4.166_666_666_666_660_190_37e-2;
#[allow(clippy::excessive_precision)]
const C2: f64 = -1.388_888_888_887_410_957_49e-3;
#[allow(clippy::excessive_precision)]
const C3: f64 = 2.480_158_728_947_672_941_78e-5;
#[allow(clippy::excessive_precision)]
const C4: f64 = -2.755_731_435_139_066_330_35e-7;
#[allow(clippy::excessive_precision)]
const C5: f64 = 2.087_572_321_298_174_827_90e-9;
#[allow(clippy::excessive_precision)]
const C6: f64 = -1.135_964_755_778_819_482_65e-11;

#[inline]
fn kernel_sin(y: f64) -> f64 {
    let z = y * y;
    let r = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
    y + y * z * (S1 + z * r)
}

#[inline]
fn kernel_cos(y: f64) -> f64 {
    let z = y * y;
    let r = z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    w + (((1.0 - w) - hz) + z * r)
}

/// `(sin x, cos x)` for any finite `x` (radians), deterministic to the bit on every platform.
///
/// Accuracy: within 2 ulp of the exact value for |x| ≤ π, and within 2 ulp of the exact value of
/// the reduced phase up to |x| ≈ 2.7·10¹⁰ (see [`reduce_phase`]).
///
/// Branch-free, so that a loop over points or waves vectorises: the quadrant number q ∈ {−2, …, 2}
/// (rounded by [`round_ties_away`], the same bits as `f64::round`) picks `(s, c)`, `(c, −s)`,
/// `(−s, −c)` or `(−c, s)` for `q mod 4 = 0, 1, 2, 3` with selects and sign flips, which are exact:
/// the result is the same to the bit as the branching version this replaced.
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    let r = reduce_phase(x);
    let q = round_ties_away(r * TWO_OVER_PI);
    let y = (r - q * PIO2_1) - q * PIO2_2;
    let s = kernel_sin(y);
    let c = kernel_cos(y);
    // q ∈ {−2, …, 2}: odd quadrants swap sine and cosine; q mod 4 ∈ {2, 3} (q = 2, −1, −2)
    // negates the sine, q mod 4 ∈ {1, 2} (q = 1, ±2) the cosine.
    let odd = q.abs() == 1.0;
    let a = if odd { c } else { s };
    let b = if odd { s } else { c };
    let neg_sin = q == 2.0 || q < -0.5;
    let neg_cos = q > 0.5 || q == -2.0;
    (flip(a, neg_sin), flip(b, neg_cos))
}

/// `-v` if `neg`, else `v`, as a sign-bit flip (exactly what negation does) without a branch.
#[inline(always)]
fn flip(v: f64, neg: bool) -> f64 {
    f64::from_bits(v.to_bits() ^ (u64::from(neg) << 63))
}

// Single-precision minimax polynomials for sin and cos on [−π/4, π/4] (Cephes `sinf`/`cosf`),
// relative error about 1 ulp of f32 there.
#[allow(clippy::excessive_precision)]
const SF1: f32 = -1.666_665_461_1e-1;
#[allow(clippy::excessive_precision)]
const SF2: f32 = 8.332_160_873_6e-3;
#[allow(clippy::excessive_precision)]
const SF3: f32 = -1.951_529_589_1e-4;
#[allow(clippy::excessive_precision)]
const CF1: f32 = 4.166_664_568_298_827e-2;
#[allow(clippy::excessive_precision)]
const CF2: f32 = -1.388_731_625_493_765e-3;
#[allow(clippy::excessive_precision)]
const CF3: f32 = 2.443_315_711_809_948e-5;

/// `(sin r, cos r)` in single precision for a phase `r` already reduced to [−π, π] in f64 (by
/// [`reduce_phase`]): the quadrant step is done in f64 (so the reduced argument is exact to f64),
/// then the argument is rounded to f32 and the polynomials run in f32.
///
/// An approximation knob, not the model's default: the error is a few f32 ulp (≈ 2·10⁻⁷ absolute),
/// against ≈ 2·10⁻¹⁶ for [`sin_cos`]. Deterministic to the bit like everything here (plain `*`
/// and `+`, no fused operations, branch-free).
#[inline(always)]
pub fn sin_cos_f32(r: f64) -> (f32, f32) {
    let q = round_ties_away(r * TWO_OVER_PI);
    let y = ((r - q * PIO2_1) - q * PIO2_2) as f32;
    let z = y * y;
    let s = ((SF3 * z + SF2) * z + SF1) * z * y + y;
    let c = ((CF3 * z + CF2) * z + CF1) * z * z - 0.5 * z + 1.0;
    let odd = q.abs() == 1.0;
    let a = if odd { c } else { s };
    let b = if odd { s } else { c };
    let neg_sin = q == 2.0 || q < -0.5;
    let neg_cos = q > 0.5 || q == -2.0;
    (flip32(a, neg_sin), flip32(b, neg_cos))
}

#[inline(always)]
fn flip32(v: f32, neg: bool) -> f32 {
    f32::from_bits(v.to_bits() ^ (u32::from(neg) << 31))
}

/// `sin x`, deterministic (see [`sin_cos`]).
#[inline]
pub fn sin(x: f64) -> f64 {
    sin_cos(x).0
}

/// `cos x`, deterministic (see [`sin_cos`]).
#[inline]
pub fn cos(x: f64) -> f64 {
    sin_cos(x).1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernel against the platform's correctly-reduced sin/cos on a dense sweep.
    #[test]
    fn matches_std_within_two_ulp_on_reduced_range() {
        let n = 200_000;
        for i in 0..=n {
            let x = -std::f64::consts::PI + 2.0 * std::f64::consts::PI * (i as f64) / (n as f64);
            let (s, c) = sin_cos(x);
            assert!(
                (s - x.sin()).abs() <= 2.0 * f64::EPSILON,
                "sin({x}) = {s} vs {}",
                x.sin()
            );
            assert!(
                (c - x.cos()).abs() <= 2.0 * f64::EPSILON,
                "cos({x}) = {c} vs {}",
                x.cos()
            );
        }
    }

    /// The branching quadrant selection this kernel used until the batch paths needed it
    /// branch-free; the two must agree to the bit.
    fn sin_cos_branching(x: f64) -> (f64, f64) {
        let r = reduce_phase(x);
        let q = (r * TWO_OVER_PI).round();
        let y = (r - q * PIO2_1) - q * PIO2_2;
        let s = kernel_sin(y);
        let c = kernel_cos(y);
        match (q as i64) & 3 {
            0 => (s, c),
            1 => (c, -s),
            2 => (-s, -c),
            _ => (-c, s),
        }
    }

    #[test]
    fn branch_free_quadrants_keep_the_bits() {
        let mut rng = crate::math::SwellRng::new(11, 3);
        let mut xs: Vec<f64> = vec![0.0, -0.0, 1e-300, -1e-300];
        for q in -8..=8 {
            let b = q as f64 * std::f64::consts::FRAC_PI_4;
            for d in [-1e-12, -1e-16, 0.0, 1e-16, 1e-12] {
                xs.push(b + d);
            }
        }
        for _ in 0..300_000 {
            let scale = 10f64.powi((rng.uniform() * 12.0) as i32 - 2);
            xs.push((2.0 * rng.uniform() - 1.0) * scale);
        }
        for x in xs {
            let (a, b) = sin_cos(x);
            let (c, d) = sin_cos_branching(x);
            assert_eq!(
                (a.to_bits(), b.to_bits()),
                (c.to_bits(), d.to_bits()),
                "{x:e}"
            );
        }
    }

    #[test]
    fn single_precision_kernel_is_within_a_few_f32_ulp() {
        let n = 100_000;
        for i in 0..=n {
            let x = -std::f64::consts::PI + std::f64::consts::TAU * (i as f64) / (n as f64);
            let (s, c) = sin_cos_f32(reduce_phase(x));
            assert!((f64::from(s) - x.sin()).abs() < 3e-7, "sin {x}");
            assert!((f64::from(c) - x.cos()).abs() < 3e-7, "cos {x}");
        }
    }

    #[test]
    fn large_arguments_stay_accurate() {
        for &x in &[1e3, 12_345.678, 1e6 + 0.5, 1e9, -1e9 - 0.25, 3.3e9] {
            let (s, c) = sin_cos(x);
            assert!((s - x.sin()).abs() < 1e-15 * x.abs().max(1.0), "{x}");
            assert!((c - x.cos()).abs() < 1e-15 * x.abs().max(1.0), "{x}");
        }
    }

    #[test]
    fn exact_values_at_quadrant_points() {
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        let (s, c) = sin_cos(std::f64::consts::FRAC_PI_2);
        assert_eq!(s, 1.0);
        assert!(c.abs() < 1e-16);
        assert!(s * s + c * c - 1.0 < 1e-15);
    }
}
