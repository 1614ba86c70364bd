//! Sine and cosine from a fixed polynomial kernel.
//!
//! The argument is first reduced to [−π, π] by [`reduce_phase`](super::reduce_phase), then to
//! [−π/4, π/4] by a quadrant step, and evaluated with the classic minimax polynomials of fdlibm's
//! `__kernel_sin` and `__kernel_cos` (error below 1 ulp on the reduced interval). Every step is
//! plain `*` and `+`, so the bits are the same on every CPU; the platform's `sin` is not.

use super::phase::{ROUND_MAGIC, RoundBySelects, Rounding, reduce_phase_with, reduce_phases_with};

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
/// the reduced phase up to |x| ≈ 2.7·10¹⁰ (see [`reduce_phase`](super::reduce_phase)).
///
/// Branch-free, so that a loop over points or waves vectorises: the quadrant number
/// q ∈ {−2, …, 2} (rounded by [`round_ties_away`](super::round_ties_away), the same bits as
/// `f64::round`) picks `(s, c)`, `(c, −s)`, `(−s, −c)` or `(−c, s)` for `q mod 4 = 0, 1, 2, 3`
/// with selects and sign flips, which are exact: the result is the same to the bit as the
/// branching version this replaced.
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    sin_cos_with::<RoundBySelects>(x)
}

/// [`sin_cos`] with the rounding `R` (the same bits whichever `R`).
#[inline(always)]
pub(crate) fn sin_cos_with<R: Rounding>(x: f64) -> (f64, f64) {
    sin_cos_of_reduced::<R>(reduce_phase_with::<R>(x))
}

/// [`sin_cos`] after its reduction to [−π, π]: the quadrant step, the two polynomials and the
/// quadrant's selects, for `r = reduce_phase(x)`.
#[inline(always)]
fn sin_cos_of_reduced<R: Rounding>(r: f64) -> (f64, f64) {
    let q = R::round(r * TWO_OVER_PI);
    let y = (r - q * PIO2_1) - q * PIO2_2;
    let s = kernel_sin(y);
    let c = kernel_cos(y);
    quadrant(q, s, c)
}

/// `(sin, cos)` of `y + q·π/2` from `s = sin y`, `c = cos y` and the quadrant number
/// q ∈ {−2, …, 2}: odd quadrants swap sine and cosine; q mod 4 ∈ {2, 3} (q = 2, −1, −2)
/// negates the sine, q mod 4 ∈ {1, 2} (q = 1, ±2) the cosine. The residue is read from the bits
/// of `m = q + 1.5·2⁵²` ([`ROUND_MAGIC`]): for a whole number q with |q| < 2⁵¹ the sum is exact
/// and lies in [2⁵², 2⁵³), where one unit in the last place is 1, so its low mantissa bits are
/// 2⁵¹ + q, i.e. q in two's complement mod 4 (2⁵¹ ≡ 0 mod 4): bit 0 is q's parity, bit 1 is set
/// exactly when q mod 4 ∈ {2, 3}, and `m + 1` (exact too) gives `(q + 1) mod 4`. The selects and
/// sign flips are then bit operations: exactly the values a comparison of q with each quadrant
/// picks, in fewer instructions once vectorised (−0 reads as 0, as it compares).
#[inline(always)]
fn quadrant(q: f64, s: f64, c: f64) -> (f64, f64) {
    let m = q + ROUND_MAGIC;
    let odd = m.to_bits() & 1 != 0;
    let (a, b) = if odd { (c, s) } else { (s, c) };
    let neg_sin = (m.to_bits() << 62) & SIGN;
    let neg_cos = ((m + 1.0).to_bits() << 62) & SIGN;
    (
        f64::from_bits(a.to_bits() ^ neg_sin),
        f64::from_bits(b.to_bits() ^ neg_cos),
    )
}

/// The sign bit of an f64.
const SIGN: u64 = 1 << 63;

/// [`sin_cos_of_reduced`] on `G` values at once, step by step (each Horner step of each
/// polynomial runs on all of them before the next), so that `G` independent chains sit side
/// by side in the instruction stream. Element `g` gets the bits of
/// `sin_cos_of_reduced::<R>(r[g])`: the same operations on the same operands in the same order.
#[inline(always)]
fn sin_cos_of_reduced_each<R: Rounding, const G: usize>(r: &[f64; G]) -> ([f64; G], [f64; G]) {
    use std::array::from_fn as each;
    let q: [f64; G] = each(|g| R::round(r[g] * TWO_OVER_PI));
    let y: [f64; G] = each(|g| (r[g] - q[g] * PIO2_1) - q[g] * PIO2_2);
    let z: [f64; G] = each(|g| y[g] * y[g]);
    // kernel_sin: y + y·z·(S1 + z·(S2 + z·(S3 + z·(S4 + z·(S5 + z·S6))))).
    let p: [f64; G] = each(|g| S5 + z[g] * S6);
    let p: [f64; G] = each(|g| S4 + z[g] * p[g]);
    let p: [f64; G] = each(|g| S3 + z[g] * p[g]);
    let p: [f64; G] = each(|g| S2 + z[g] * p[g]);
    let s: [f64; G] = each(|g| y[g] + y[g] * z[g] * (S1 + z[g] * p[g]));
    // kernel_cos: w + (((1 − w) − hz) + z·r), r = z·(C1 + z·(… + z·C6)), hz = z/2, w = 1 − hz.
    let p: [f64; G] = each(|g| C5 + z[g] * C6);
    let p: [f64; G] = each(|g| C4 + z[g] * p[g]);
    let p: [f64; G] = each(|g| C3 + z[g] * p[g]);
    let p: [f64; G] = each(|g| C2 + z[g] * p[g]);
    let p: [f64; G] = each(|g| z[g] * (C1 + z[g] * p[g]));
    let hz: [f64; G] = each(|g| 0.5 * z[g]);
    let w: [f64; G] = each(|g| 1.0 - hz[g]);
    let c: [f64; G] = each(|g| w[g] + (((1.0 - w[g]) - hz[g]) + z[g] * p[g]));
    let mut sin = [0.0; G];
    let mut cos = [0.0; G];
    for g in 0..G {
        (sin[g], cos[g]) = quadrant(q[g], s[g], c[g]);
    }
    (sin, cos)
}

/// Below this magnitude a phase already reduced to [−π, π] is left unchanged, to the bit, by a
/// second [`reduce_phase`](super::reduce_phase): `|r|/2π` then rounds to less than ½, so
/// `n = ±0` (the sign of r), and `r − (±0)·piece` is r for every r but −0, which no reduction
/// outputs (`x − n·2π₁` is +0 when it is zero, and later steps only subtract). Deliberately just
/// below π: a margin of 1.6·10⁻³, so about one reduced phase in 2,000 takes the second
/// reduction (and with it the group of 32 it is in, about one group in 60). A smaller value
/// sends more groups through it; a value at or above π would be wrong.
#[allow(clippy::approx_constant)]
const SURELY_REDUCED: f64 = 3.14;

/// `sin_cos(reduce_phase(θ))` for a group of `G` waves × `B` points, element by element: the
/// bits of the scalar composition in every element, for any rounding `R`.
///
/// What makes it faster than calling [`sin_cos`] per element:
/// - each step (a reduction step, a Horner step, a select) runs on all `G` waves of a lane
///   before the next step ([`reduce_phases_with`], [`sin_cos_of_reduced_each`]), so `G`
///   independent dependency chains sit side by side in the instruction stream and the CPU
///   overlaps their latencies; chains written one after another were left that way by the
///   compiler, and the core's scheduler could not look far enough ahead to overlap them;
/// - `sin_cos` reduces its argument again; on an already reduced phase that is the identity
///   except within 1.6·10⁻³ of ±π ([`SURELY_REDUCED`]), so the group repeats the reduction only
///   when one of its elements lies there, and then for all of them (exact for the others too);
/// - the caller picks `R`: [`RoundByTrunc`](super::phase::RoundByTrunc) where the CPU
///   truncates in one instruction.
///
/// Only plain `*`, `+`, `−`, compares, selects and sign-bit flips, in the scalar order, so the
/// width the compiler chooses changes nothing.
///
/// Loop shape: lanes outer, waves inner. The inner steps over `G` are unrolled first, and the
/// vectoriser then widens the lane loop, so that each scalar operation becomes one vector
/// operation over lanes (lanes outer also keeps it from packing across waves, which costs
/// shuffles).
// Indexing several lane arrays by one counter is the shape the vectoriser wants; the negated
// comparison sends NaN down the full reduction.
#[allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
pub(crate) fn sin_cos_phases<R: Rounding, const G: usize, const B: usize>(
    theta: &[[f64; B]; G],
) -> ([[f64; B]; G], [[f64; B]; G]) {
    let mut r = [[0.0f64; B]; G];
    // `!(|r| < …)` so that NaN takes the full path too.
    let mut again = false;
    for l in 0..B {
        let v = reduce_phases_with::<R, G>(&std::array::from_fn(|g| theta[g][l]));
        for g in 0..G {
            r[g][l] = v[g];
            again |= !(v[g].abs() < SURELY_REDUCED);
        }
    }
    if again {
        for l in 0..B {
            let v = reduce_phases_with::<R, G>(&std::array::from_fn(|g| r[g][l]));
            for g in 0..G {
                r[g][l] = v[g];
            }
        }
    }
    let mut s = [[0.0f64; B]; G];
    let mut c = [[0.0f64; B]; G];
    for l in 0..B {
        let (sl, cl) = sin_cos_of_reduced_each::<R, G>(&std::array::from_fn(|g| r[g][l]));
        for g in 0..G {
            (s[g][l], c[g][l]) = (sl[g], cl[g]);
        }
    }
    (s, c)
}

/// Coefficients of the single-precision polynomial for sin(πu) on u ∈ [−½, ½], in powers of
/// z = u²: `sin(πu) ≈ u·(c₀ + z·(c₁ + z·(c₂ + z·(c₃ + z·c₄))))`, evaluated in f32 in that order
/// ([`sin_cos_turns_f32`]). Near-minimax, fitted for this crate by iteratively reweighted least
/// squares on Chebyshev nodes; fit error 3.3·10⁻⁹, below half an f32 ulp of 1. Public so that
/// GPU code generated from the model (the shader crate) uses the very same kernel.
#[allow(clippy::excessive_precision)]
pub const SINPI_F32: [f32; 5] = [
    3.141_592_502_593_994,
    -5.167_706_966_400_146,
    2.550_031_423_568_726,
    -0.598_045_170_307_159_4,
    0.077_220_155_298_709_87,
];
/// Coefficients of the single-precision polynomial for cos(πu) on u ∈ [−½, ½], in powers of
/// z = u²: `cos(πu) ≈ c₀ + z·(c₁ + z·(c₂ + z·(c₃ + z·c₄)))`, with c₀ held at 1 so that cos 0 = 1
/// exactly; fit error 5.3·10⁻⁸. See [`SINPI_F32`].
#[allow(clippy::excessive_precision)]
pub const COSPI_F32: [f32; 5] = [
    1.0,
    -4.934_795_379_638_672,
    4.058_451_175_689_697,
    -1.332_093_834_877_014,
    0.220_080_688_595_771_8,
];

/// `(sin 2πu, cos 2πu)` in single precision for a phase `u` in turns, already reduced to
/// [−½, ½] (in f64, by the caller: `u = p − round(p)`).
///
/// Half-angle form, no quadrant step, no branch: with `s = sin(πu)` and `c = cos(πu)` from
/// degree-9 and degree-8 polynomials in u (`z = u²`, Horner), `sin 2πu = (s + s)·c` and
/// `cos 2πu = c·c − s·s`. About 20 f32 operations, all plain `*`, `+` and `−`, so it is the
/// same to the bit on every CPU and vectorises at any width.
///
/// An approximation knob, not the model's default: the error is within 5·10⁻⁷ of the exact
/// values for every f32 in [−½, ½] (4.2·10⁻⁷ measured, mostly from rounding u itself to f32),
/// against ≈ 2·10⁻¹⁶ for [`sin_cos`]. Outside [−½, ½] it is not sin/cos; it stays finite for
/// |u| ≤ 100 (callers clamp).
#[inline(always)]
pub fn sin_cos_turns_f32(u: f32) -> (f32, f32) {
    let z = u * u;
    let s = u
        * (SINPI_F32[0]
            + z * (SINPI_F32[1] + z * (SINPI_F32[2] + z * (SINPI_F32[3] + z * SINPI_F32[4]))));
    let c = COSPI_F32[0]
        + z * (COSPI_F32[1] + z * (COSPI_F32[2] + z * (COSPI_F32[3] + z * COSPI_F32[4])));
    ((s + s) * c, c * c - s * s)
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
    use crate::math::reduce_phase;

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

    /// The quadrant's bit operations against the comparisons they replace, on every quadrant
    /// number a reduced phase gives (−0 included) and NaN, with signed zeros, NaN and ordinary
    /// values for the sine and cosine.
    #[test]
    fn quadrant_bits_match_the_comparisons() {
        let by_comparisons = |q: f64, s: f64, c: f64| {
            let odd = q.abs() == 1.0;
            let (a, b) = if odd { (c, s) } else { (s, c) };
            let neg_sin = q == 2.0 || q < -0.5;
            let neg_cos = q > 0.5 || q == -2.0;
            let flip = |v: f64, neg: bool| if neg { -v } else { v };
            (flip(a, neg_sin), flip(b, neg_cos))
        };
        let values = [0.0, -0.0, 0.25, -0.75, 1.0, -1e-300, f64::NAN];
        for q in [-2.0, -1.0, -0.0, 0.0, 1.0, 2.0, f64::NAN] {
            for s in values {
                for c in values {
                    let (a, b) = quadrant(q, s, c);
                    let (e, f) = by_comparisons(q, s, c);
                    assert_eq!(
                        (a.to_bits(), b.to_bits()),
                        (e.to_bits(), f.to_bits()),
                        "q {q}, s {s}, c {c}"
                    );
                }
            }
        }
    }

    /// Every f32 in [−½, ½] (2·10⁹ of them would take too long: a dense sweep plus the ends and
    /// the tiny values), against the platform's f64 sin/cos of the same turn.
    #[test]
    fn single_precision_turns_kernel_is_within_half_a_micro() {
        let n = 400_000;
        let mut us: Vec<f32> = (0..=n).map(|i| -0.5 + i as f32 / n as f32).collect();
        us.extend([
            0.0,
            -0.0,
            1e-30,
            -1e-30,
            0.25,
            -0.25,
            0.5,
            -0.5,
            0.499_999_97,
        ]);
        let mut worst = 0.0f64;
        for u in us {
            let (s, c) = sin_cos_turns_f32(u);
            let x = std::f64::consts::TAU * f64::from(u);
            worst = worst
                .max((f64::from(s) - x.sin()).abs())
                .max((f64::from(c) - x.cos()).abs());
        }
        assert!(worst < 5e-7, "worst error {worst}");
        assert_eq!(sin_cos_turns_f32(0.0), (0.0, 1.0));
        // Out of range it is not sin/cos, but finite.
        for u in [3.0f32, -70.0, 100.0] {
            let (s, c) = sin_cos_turns_f32(u);
            assert!(s.is_finite() && c.is_finite(), "{u}");
        }
    }

    /// `sin_cos_phases` (the batch kernels' fast path) against the scalar composition
    /// `sin_cos(reduce_phase(θ))` it stands for, bit for bit, with both roundings: seeded random
    /// phases over 14 orders of magnitude, and phases at and around odd multiples of π, whose
    /// first reduction lands next to ±π, where `sin_cos`'s own reduction moves them again (the
    /// test checks that some do, so the rare branch is exercised).
    #[test]
    fn grouped_phases_match_scalar_sin_cos_bit_for_bit() {
        use crate::math::phase::{RoundByTrunc, reduce_phase};
        const G: usize = 4;
        const B: usize = 8;
        let mut rng = crate::math::SwellRng::new(29, 2);
        let t = SURELY_REDUCED;
        let mut xs: Vec<f64> = vec![0.0, -0.0, 1e-300, -1e-300, t, -t, t + 0.01, -t - 0.01];
        let mut moved = 0;
        for k in -40..=40 {
            let base = f64::from(2 * k + 1) * std::f64::consts::PI;
            for d in [-1e-3, -1e-9, -1e-14, 0.0, 1e-14, 1e-9, 1e-3] {
                let x = base + d;
                for v in [
                    x,
                    f64::from_bits(x.to_bits() + 1),
                    f64::from_bits(x.to_bits() - 1),
                ] {
                    let r = reduce_phase(v);
                    if reduce_phase(r).to_bits() != r.to_bits() {
                        moved += 1;
                    }
                    xs.push(v);
                }
            }
        }
        assert!(moved > 0, "no phase took the second reduction");
        for _ in 0..50_000 {
            let scale = 10f64.powi((rng.uniform() * 14.0) as i32 - 3);
            xs.push((2.0 * rng.uniform() - 1.0) * scale);
        }
        // Shuffle the near-π phases among the others, so that groups mix both kinds.
        for i in (1..xs.len()).rev() {
            let j = (rng.uniform() * (i + 1) as f64) as usize;
            xs.swap(i, j.min(i));
        }
        for chunk in xs.chunks(G * B) {
            let theta: [[f64; B]; G] =
                std::array::from_fn(|g| std::array::from_fn(|l| chunk[(g * B + l) % chunk.len()]));
            let by_selects = sin_cos_phases::<RoundBySelects, G, B>(&theta);
            let by_trunc = sin_cos_phases::<RoundByTrunc, G, B>(&theta);
            for g in 0..G {
                for l in 0..B {
                    let x = theta[g][l];
                    let (s, c) = sin_cos(reduce_phase(x));
                    let want = (s.to_bits(), c.to_bits());
                    for (name, (gs, gc)) in [("selects", by_selects), ("trunc", by_trunc)] {
                        let got = (gs[g][l].to_bits(), gc[g][l].to_bits());
                        assert_eq!(got, want, "{name}: sin_cos(reduce_phase({x:e}))");
                    }
                }
            }
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
