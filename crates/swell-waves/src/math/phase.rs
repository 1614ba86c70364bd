//! Reduction of a wave phase to [−π, π] in f64.
//!
//! A phase `k·x − ω·t + φ` grows without bound with time and distance. Reduced naively
//! (`x − 2π·round(x / 2π)` with one constant) the product `n·2π` loses the low bits of the phase
//! once `n` is large. We subtract `n·2π` in four pieces (Cody–Waite): each piece of 2π carries at
//! most 21 significant bits, so `n·piece` is exact for |n| < 2³², i.e. for phases up to about
//! 2.7·10¹⁰ rad (a 1 rad/s wave after 850 years). Beyond that the result is still deterministic,
//! only less accurate.

/// 2π, the full turn, in radians.
pub const TAU: f64 = std::f64::consts::TAU;

/// 1 / 2π.
const INV_TAU: f64 = 0.159_154_943_091_895_35;
// 2π = TAU_1 + TAU_2 + TAU_3 + TAU_4 (+ 4.9e-36); the first three carry 21 significant bits.
const TAU_1: f64 = 6.283_184_051_513_672;
const TAU_2: f64 = 1.255_665_665_667_038_4e-6;
const TAU_3: f64 = 2.489_347_703_665_823e-13;
const TAU_4: f64 = 1.165_092_822_437_342_4e-19;

/// Reduces a phase (radians) to the interval [−π, π].
///
/// The result equals `x − 2π·n` with `n = round(x / 2π)`, computed so that `n·2π` is exact for
/// |x| < 2.7·10¹⁰ rad. Non-finite input gives NaN (callers validate their inputs first).
#[inline]
pub fn reduce_phase(x: f64) -> f64 {
    reduce_phase_with::<RoundBySelects>(x)
}

/// [`reduce_phase`] with the rounding `R`: the same bits whichever `R` (each gives
/// `f64::round`'s), so a kernel picks the one its SIMD level runs fastest.
#[inline(always)]
pub(crate) fn reduce_phase_with<R: Rounding>(x: f64) -> f64 {
    let n = R::round(x * INV_TAU);
    ((x - n * TAU_1) - n * TAU_2) - n * TAU_3 - n * TAU_4
}

/// [`reduce_phase_with`] on `G` values at once, step by step: each step of the reduction runs on
/// all of them before the next, so their independent chains sit side by side in the
/// instruction stream. Element `g` gets the bits of `reduce_phase_with::<R>(x[g])`.
#[inline(always)]
pub(crate) fn reduce_phases_with<R: Rounding, const G: usize>(x: &[f64; G]) -> [f64; G] {
    let n: [f64; G] = std::array::from_fn(|g| R::round(x[g] * INV_TAU));
    let v: [f64; G] = std::array::from_fn(|g| x[g] - n[g] * TAU_1);
    let v: [f64; G] = std::array::from_fn(|g| v[g] - n[g] * TAU_2);
    let v: [f64; G] = std::array::from_fn(|g| v[g] - n[g] * TAU_3);
    std::array::from_fn(|g| v[g] - n[g] * TAU_4)
}

/// A way to compute `x.round()` (nearest integer, ties away from zero) to the bit, for every
/// non-NaN `x`. The implementations differ only in speed, which depends on the instructions a
/// kernel is compiled for; a test pins each to `f64::round`.
pub(crate) trait Rounding {
    /// `x.round()`, to the bit.
    fn round(x: f64) -> f64;
}

/// [`round_ties_away`]: adds, compares and selects, vectorises at every x86-64 level. The
/// reference rounding, and the one baseline (SSE2) code uses.
pub(crate) struct RoundBySelects;

impl Rounding for RoundBySelects {
    #[inline(always)]
    fn round(x: f64) -> f64 {
        round_ties_away(x)
    }
}

/// [`round_ties_away_by_trunc`]: four instructions where the CPU truncates in one (SSE4.1's
/// `roundpd`, AVX-512's `vrndscalepd`), but a C library call per value on baseline x86-64. Only
/// kernels compiled for AVX2 or AVX-512 use it (so elsewhere only the tests do).
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(crate) struct RoundByTrunc;

impl Rounding for RoundByTrunc {
    #[inline(always)]
    fn round(x: f64) -> f64 {
        round_ties_away_by_trunc(x)
    }
}

/// ½ − 2⁻⁵⁴, the largest double below ½.
const BELOW_HALF: f64 = 0.499_999_999_999_999_94;

/// `x.round()` as `trunc(x + copysign(½ − 2⁻⁵⁴, x))`: the same bits as `f64::round` (and
/// [`round_ties_away`]) for every non-NaN input, pinned by tests.
///
/// Why it is exact: x and the added constant have the same sign, so the sum only moves away
/// from zero. Where |x| has a fraction below ½ the sum stays below the next integer (adding
/// ½ − 2⁻⁵⁴ rather than ½ keeps x = ½ − 2⁻⁵⁴ from rounding up to 1); where the fraction is ½ or
/// more the sum reaches the next integer, either exactly or by rounding up to it (a sum just
/// below an integer that is not representable rounds to that integer, never past it); where
/// |x| ≥ 2⁵² the constant is below half an ulp and the sum is x. Truncation then drops the
/// fraction and keeps the sign, so −0.3 gives −0.0 as `round` does.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
#[inline(always)]
pub(crate) fn round_ties_away_by_trunc(x: f64) -> f64 {
    (x + BELOW_HALF.copysign(x)).trunc()
}

/// 1.5·2⁵²: adding and subtracting it rounds any |p| < 2⁵¹ to the nearest integer (ties to
/// even), because the sum stays in [2⁵², 2⁵³) where the unit in the last place is exactly 1.
pub(crate) const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0;

/// Reduces a phase in turns (cycles, not radians) to [−½, ½]: `p − round(p)`, with `round` to
/// nearest, ties to even, done as `(p + 1.5·2⁵²) − 1.5·2⁵²`.
///
/// Exact (the subtraction of a nearby integer loses nothing) for |p| < 2⁵¹ ≈ 2.3·10¹⁵ turns;
/// beyond that the result is deterministic and finite but not reduced. Three operations and no
/// branch: the reduction of the single-precision fast path, where a phase is formed in f64 as
/// `(k/2π)·(d·p0) + c` and only the reduced turn goes to f32.
#[inline(always)]
pub fn reduce_turns(p: f64) -> f64 {
    p - ((p + ROUND_MAGIC) - ROUND_MAGIC)
}

/// 2⁵²: at and above this magnitude every f64 is an integer, and below it `v ± 2⁵²` rounds `v`
/// to an integer (ties to even) because the sum's unit in the last place is exactly 1.
const TWO_52: f64 = 4_503_599_627_370_496.0;

/// `x.round()` (nearest integer, ties away from zero), computed with adds, compares and bit
/// selects only, so that loops over it vectorise.
///
/// Why not `f64::round`: on baseline x86-64 (no SSE4.1) LLVM lowers it to a call into the C
/// library, which stops a loop from vectorising; with SSE4.1 it is a short inline sequence. This
/// function gives the same bits as `f64::round` for every non-NaN input (signed zeros
/// included; pinned by tests), on every target and level:
/// 1. `r = (x + c) − c` with `c = ±2⁵²` (sign of x) rounds to nearest, ties to even, exactly;
/// 2. a tie that went towards zero (`x − r = ±0.5` with the sign of x) is moved one away;
/// 3. `|x| ≥ 2⁵²` is already an integer and is kept as is;
/// 4. the sign is copied from x, as `round` keeps it (`round(−0.3) = −0.0`).
#[inline]
pub fn round_ties_away(x: f64) -> f64 {
    let c = TWO_52.copysign(x);
    let r = (x + c) - c;
    let d = x - r; // exact: |d| ≤ 0.5 and r is the nearest integer to x
    let half = 0.5f64.copysign(x);
    let r = if d == half { r + 2.0 * half } else { r };
    let r = if x.abs() >= TWO_52 { x } else { r };
    r.copysign(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reduce_turns_is_exact_and_in_range() {
        for &(p, r) in &[
            (0.0, 0.0),
            (0.25, 0.25),
            (-0.75, 0.25),
            (1.5, -0.5),
            (2.5, 0.5),
            (1e9 + 0.125, 0.125),
            (-3e14 - 0.375, -0.375),
        ] {
            assert_eq!(reduce_turns(p), r, "{p}");
        }
        let mut rng = crate::math::SwellRng::new(5, 9);
        for _ in 0..100_000 {
            let p = (2.0 * rng.uniform() - 1.0) * 10f64.powi((rng.uniform() * 15.0) as i32);
            let r = reduce_turns(p);
            assert!(r.abs() <= 0.5, "{p} -> {r}");
            assert_eq!(r, p - p.round_ties_even(), "{p}");
        }
    }

    #[test]
    fn round_ties_away_matches_std_round_bit_for_bit() {
        let mut probes = vec![
            0.0,
            -0.0,
            0.3,
            -0.3,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            -2.5,
            0.499_999_999_999_999_94,
            -0.499_999_999_999_999_94,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            TWO_52,
            -TWO_52,
        ];
        // Around every power of two: integers, halves and their neighbours, both signs.
        for e in 0..64 {
            let base = 2f64.powi(e);
            for v in [base, base + 0.5, base - 0.5, base + 1.5, base * 1.25 + 0.5] {
                for w in [
                    v,
                    f64::from_bits(v.to_bits() + 1),
                    f64::from_bits(v.to_bits() - 1),
                ] {
                    probes.push(w);
                    probes.push(-w);
                }
            }
        }
        let mut rng = super::super::SwellRng::new(5, 5);
        for _ in 0..200_000 {
            let u = rng.uniform();
            let scale = 2f64.powi((rng.uniform() * 70.0) as i32 - 10);
            probes.push((u - 0.5) * scale);
            // Random bit patterns: every exponent.
            let b = f64::from_bits(rng.next_u64());
            if !b.is_nan() {
                probes.push(b);
            }
        }
        for x in probes {
            assert_eq!(
                round_ties_away(x).to_bits(),
                x.round().to_bits(),
                "round({x:e})"
            );
            assert_eq!(
                round_ties_away_by_trunc(x).to_bits(),
                x.round().to_bits(),
                "trunc form of round({x:e})"
            );
        }
    }

    #[test]
    fn pieces_sum_to_tau() {
        assert_eq!(TAU_1 + TAU_2 + TAU_3 + TAU_4, TAU);
    }

    #[test]
    fn small_phases_are_unchanged() {
        for &x in &[0.0, 1.0, -1.0, 3.0, -3.0] {
            assert_eq!(reduce_phase(x), x);
        }
    }

    #[test]
    fn huge_phase_matches_exact_reduction() {
        // x = 1e9 exactly. 1e9 mod 2π computed with 60-digit arithmetic (Python decimal):
        // 1e9 - 159154943 * 2π = -1.3895409099...
        // 159154943 * 2π = 1000000001.389540910...; check against the sine of the reduction.
        let r = reduce_phase(1e9);
        assert!((-std::f64::consts::PI..=std::f64::consts::PI).contains(&r));
        // std's sin reduces with Payne–Hanek (exact); compare through it.
        assert!((r.sin() - 1e9f64.sin()).abs() < 1e-15, "{r}");
        assert!((r.cos() - 1e9f64.cos()).abs() < 1e-15, "{r}");
    }

    #[test]
    fn reduction_is_accurate_over_a_wide_range() {
        let mut x = 1.0f64;
        while x < 2e10 {
            for s in [-1.0, 1.0] {
                let v = s * x * 1.000_000_123;
                let r = reduce_phase(v);
                assert!(r.abs() <= std::f64::consts::PI + 1e-15);
                assert!(
                    (r.sin() - v.sin()).abs() < 2e-16 * v.abs().max(1.0) + 1e-15,
                    "{v}"
                );
            }
            x *= 1.7;
        }
    }
}
