//! The crate's own inverse FFT of power-of-two length, run on W transforms at once ("vertical"
//! SIMD: lane l of every value belongs to transform l).
//!
//! # Algorithm
//! It is RustFFT 6.4's scalar plan for these lengths, operation for operation, so its bits are
//! the ones `FftPlannerScalar` gave (the frames the golden vectors pin):
//! - N = 16 and 32: RustFFT's `Butterfly16` / `Butterfly32` (split radix over `Butterfly8` and
//!   `Butterfly4`).
//! - N ≥ 64: `Radix4` over a base butterfly of 16 (log₂N even) or 8 (odd): a base-4
//!   bit-reversed transpose of the input ([`LaneFft::gather_order`]), the base butterfly on each
//!   chunk, then radix-4 layers with twiddles `e^{+2πi·i·k/len}`
//!   ([`crate::math::fft_inverse_twiddle`]).
//!
//! Complex products are `num_complex`'s `(a·c − b·d, a·d + b·c)`; rotations by i and
//! conjugations are exact sign moves. Each lane does exactly that sequence, so the lane width
//! (1, 2, 4 or 8) cannot change a bit, and the scalar instance (W = 1) is the reference every
//! wider one is tested against. A test compares every supported length with RustFFT's scalar
//! planner bit for bit, and one compares with a direct DFT.

/// W f64 lanes: each operation is the scalar one applied to every lane. Arrays of a fixed W
/// compile to vector instructions inside functions built for a SIMD level (see
/// `transform::InverseRealFft2`); the arithmetic is the same at any width.
pub(crate) type Lanes<const W: usize> = [f64; W];

#[inline(always)]
fn add<const W: usize>(a: Lanes<W>, b: Lanes<W>) -> Lanes<W> {
    std::array::from_fn(|l| a[l] + b[l])
}
#[inline(always)]
fn sub<const W: usize>(a: Lanes<W>, b: Lanes<W>) -> Lanes<W> {
    std::array::from_fn(|l| a[l] - b[l])
}
#[inline(always)]
fn mul<const W: usize>(a: Lanes<W>, b: Lanes<W>) -> Lanes<W> {
    std::array::from_fn(|l| a[l] * b[l])
}
#[inline(always)]
fn neg<const W: usize>(a: Lanes<W>) -> Lanes<W> {
    std::array::from_fn(|l| -a[l])
}

/// W complex values, real parts then imaginary parts.
#[derive(Clone, Copy, Debug)]
pub(crate) struct C<const W: usize> {
    pub(crate) re: Lanes<W>,
    pub(crate) im: Lanes<W>,
}

impl<const W: usize> C<W> {
    pub(crate) const ZERO: Self = Self {
        re: [0.0; W],
        im: [0.0; W],
    };
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            re: add(self.re, o.re),
            im: add(self.im, o.im),
        }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self {
            re: sub(self.re, o.re),
            im: sub(self.im, o.im),
        }
    }
    /// `self · (re, im)` for one complex constant shared by all lanes, as num_complex computes
    /// it: `(a·c − b·d, a·d + b·c)` with `self = a + bi`.
    #[inline(always)]
    fn mul_c(self, (re, im): (f64, f64)) -> Self {
        let (c, d) = ([re; W], [im; W]);
        Self {
            re: sub(mul(self.re, c), mul(self.im, d)),
            im: add(mul(self.re, d), mul(self.im, c)),
        }
    }
    /// `self · s` for a real s shared by all lanes.
    #[inline(always)]
    fn scale(self, s: f64) -> Self {
        Self {
            re: mul(self.re, [s; W]),
            im: mul(self.im, [s; W]),
        }
    }
    /// `self · i` (RustFFT's `rotate_90` in the inverse direction): `(−im, re)`.
    #[inline(always)]
    fn rot(self) -> Self {
        Self {
            re: neg(self.im),
            im: self.re,
        }
    }
}

#[inline(always)]
fn conj((re, im): (f64, f64)) -> (f64, f64) {
    (re, -im)
}

/// RustFFT's `Butterfly2::perform_fft_strided`.
#[inline(always)]
fn bf2<const W: usize>(a: &mut C<W>, b: &mut C<W>) {
    let t = a.add(*b);
    *b = a.sub(*b);
    *a = t;
}

/// RustFFT's `Butterfly4::perform_fft_contiguous` (inverse).
#[inline(always)]
fn bf4<const W: usize>(v: &mut [C<W>; 4]) {
    let [mut v0, mut v1, mut v2, mut v3] = *v;
    bf2(&mut v0, &mut v2);
    bf2(&mut v1, &mut v3);
    v3 = v3.rot();
    bf2(&mut v0, &mut v1);
    bf2(&mut v2, &mut v3);
    *v = [v0, v2, v1, v3];
}

/// √½ as RustFFT's `Butterfly8` holds it (`sqrt` is correctly rounded everywhere).
#[inline(always)]
fn root2() -> f64 {
    0.5f64.sqrt()
}

/// RustFFT's `Butterfly8::perform_fft_contiguous` (inverse).
#[inline(always)]
fn bf8<const W: usize>(b: &mut [C<W>; 8]) {
    let mut s0 = [b[0], b[2], b[4], b[6]];
    let mut s1 = [b[1], b[3], b[5], b[7]];
    bf4(&mut s0);
    bf4(&mut s1);
    let r2 = root2();
    s1[1] = s1[1].rot().add(s1[1]).scale(r2);
    s1[2] = s1[2].rot();
    s1[3] = s1[3].rot().sub(s1[3]).scale(r2);
    for i in 0..4 {
        let (a, c) = (&mut s0[i], &mut s1[i]);
        bf2(a, c);
    }
    *b = [s0[0], s0[1], s0[2], s0[3], s1[0], s1[1], s1[2], s1[3]];
}

/// Twiddles of RustFFT's `Butterfly16` (`tw16[k] = twiddle(k + 1, 16)`) and `Butterfly32`.
struct SplitTwiddles {
    tw16: [(f64, f64); 3],
    tw32: [(f64, f64); 7],
}

impl SplitTwiddles {
    fn new() -> Self {
        Self {
            tw16: std::array::from_fn(|k| crate::math::fft_inverse_twiddle(k + 1, 16)),
            tw32: std::array::from_fn(|k| crate::math::fft_inverse_twiddle(k + 1, 32)),
        }
    }
}

/// RustFFT's split-radix step shared by `Butterfly16` and `Butterfly32`: `evens` (already
/// transformed, length 2H) and the two odd quarter transforms (length H), twiddled by `tw`
/// (H − 1 entries), combined into `out` (4H).
#[inline(always)]
fn split_combine<const W: usize, const H: usize>(
    evens: &[C<W>],
    n1: &mut [C<W>; H],
    n3: &mut [C<W>; H],
    tw: &[(f64, f64)],
    out: &mut [C<W>],
) {
    for k in 1..H {
        n1[k] = n1[k].mul_c(tw[k - 1]);
        n3[k] = n3[k].mul_c(conj(tw[k - 1]));
    }
    for k in 0..H {
        let (a, b) = (&mut n1[k], &mut n3[k]);
        bf2(a, b);
    }
    for v in n3.iter_mut() {
        *v = v.rot();
    }
    for k in 0..H {
        out[k] = evens[k].add(n1[k]);
        out[k + H] = evens[k + H].add(n3[k]);
        out[k + 2 * H] = evens[k].sub(n1[k]);
        out[k + 3 * H] = evens[k + H].sub(n3[k]);
    }
}

/// RustFFT's `Butterfly16::perform_fft_contiguous` (inverse), in place on 16 values.
#[inline(always)]
fn bf16<const W: usize>(b: &mut [C<W>], tw: &SplitTwiddles) {
    let mut evens: [C<W>; 8] = std::array::from_fn(|k| b[2 * k]);
    let mut n1: [C<W>; 4] = std::array::from_fn(|k| b[4 * k + 1]);
    let mut n3: [C<W>; 4] = std::array::from_fn(|k| b[(4 * k + 15) % 16]);
    bf8(&mut evens);
    bf4(&mut n1);
    bf4(&mut n3);
    split_combine(&evens, &mut n1, &mut n3, &tw.tw16, b);
}

/// RustFFT's `Butterfly32::perform_fft_contiguous` (inverse), in place on 32 values.
#[inline(always)]
fn bf32<const W: usize>(b: &mut [C<W>], tw: &SplitTwiddles) {
    let mut evens: [C<W>; 16] = std::array::from_fn(|k| b[2 * k]);
    let mut n1: [C<W>; 8] = std::array::from_fn(|k| b[4 * k + 1]);
    let mut n3: [C<W>; 8] = std::array::from_fn(|k| b[(4 * k + 31) % 32]);
    bf16(&mut evens, tw);
    bf8(&mut n1);
    bf8(&mut n3);
    split_combine(&evens, &mut n1, &mut n3, &tw.tw32, b);
}

/// A plan: the length's base butterfly, the gather order and the radix-4 twiddles.
#[derive(Clone)]
pub(crate) struct LaneFft {
    n: usize,
    /// 8, 16 or 32: the butterfly run on each chunk before the radix-4 layers.
    base: usize,
    /// `gather[p]`: the input index that goes to position p (RustFFT's base-4 bit-reversed
    /// transpose; the identity when `n == base`).
    gather: Vec<u32>,
    /// The radix-4 layers' twiddles, in RustFFT's order (layer by layer, then column i, then
    /// k = 1, 2, 3).
    twiddles: Vec<(f64, f64)>,
    split: std::sync::Arc<SplitTwiddles>,
}

impl std::fmt::Debug for LaneFft {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LaneFft")
            .field("n", &self.n)
            .field("base", &self.base)
            .finish_non_exhaustive()
    }
}

impl LaneFft {
    /// Plans the unnormalised inverse transform of length `n`.
    ///
    /// # Panics
    /// If `n` is not a power of two in 16..=2^20 (the FFT layer validates 16..=1024).
    pub(crate) fn new(n: usize) -> Self {
        assert!(
            n.is_power_of_two() && (16..=1 << 20).contains(&n),
            "LaneFft length {n}"
        );
        let bits = n.trailing_zeros();
        // RustFFT's planner: 16 and 32 are butterflies; above, Radix4 over 16 (even exponent)
        // or 8 (odd exponent).
        let base = match n {
            16 => 16,
            32 => 32,
            _ if bits % 2 == 1 => 8,
            _ => 16,
        };
        let width = n / base;
        let gather = if width == 1 {
            (0..n as u32).collect()
        } else {
            let digits = width.trailing_zeros() / 2;
            let rev = |mut x: usize| {
                let mut r = 0;
                for _ in 0..digits {
                    r = r * 4 + x % 4;
                    x /= 4;
                }
                r
            };
            // RustFFT's `bitreversed_transpose::<_, 4>(base, input, output)`:
            // output[y + rev(x)·base] = input[x + y·width].
            let mut g = vec![0u32; n];
            for x in 0..width {
                for y in 0..base {
                    g[y + rev(x) * base] = (x + y * width) as u32;
                }
            }
            g
        };
        let mut twiddles = Vec::new();
        let mut cross = base;
        while cross < n {
            let columns = cross;
            cross *= 4;
            for i in 0..columns {
                for k in 1..4 {
                    twiddles.push(crate::math::fft_inverse_twiddle(i * k, cross));
                }
            }
        }
        Self {
            n,
            base,
            gather,
            twiddles,
            split: std::sync::Arc::new(SplitTwiddles::new()),
        }
    }

    /// Length N.
    pub(crate) fn len(&self) -> usize {
        self.n
    }

    /// Where each position's input comes from: fill `data[p]` with input `gather_order()[p]`
    /// before [`LaneFft::run`].
    pub(crate) fn gather_order(&self) -> &[u32] {
        &self.gather
    }

    /// Transforms W sequences in place; `data` (N values) must hold the input in gather order.
    /// On return `data[j]` is output j.
    #[inline(always)]
    pub(crate) fn run<const W: usize>(&self, data: &mut [C<W>]) {
        debug_assert_eq!(data.len(), self.n);
        let split = &*self.split;
        match self.base {
            8 => {
                for c in data.chunks_exact_mut(8) {
                    let c: &mut [C<W>; 8] = c.try_into().expect("chunk of 8");
                    bf8(c);
                }
            }
            16 => {
                for c in data.chunks_exact_mut(16) {
                    bf16(c, split);
                }
            }
            _ => {
                for c in data.chunks_exact_mut(32) {
                    bf32(c, split);
                }
            }
        }
        let mut cross = self.base;
        let mut tw: &[(f64, f64)] = &self.twiddles;
        while cross < self.n {
            let columns = cross;
            cross *= 4;
            for chunk in data.chunks_exact_mut(cross) {
                radix4_layer(chunk, &tw[..3 * columns], columns);
            }
            tw = &tw[3 * columns..];
        }
    }
}

/// RustFFT's `butterfly_4` over one chunk of `4·columns` values.
#[inline(always)]
fn radix4_layer<const W: usize>(chunk: &mut [C<W>], tw: &[(f64, f64)], columns: usize) {
    let (q0, rest) = chunk.split_at_mut(columns);
    let (q1, rest) = rest.split_at_mut(columns);
    let (q2, q3) = rest.split_at_mut(columns);
    for ((((a, b), c), d), t) in q0
        .iter_mut()
        .zip(q1.iter_mut())
        .zip(q2.iter_mut())
        .zip(q3.iter_mut())
        .zip(tw.chunks_exact(3))
    {
        let mut s = [*a, b.mul_c(t[0]), c.mul_c(t[1]), d.mul_c(t[2])];
        bf4(&mut s);
        *a = s[0];
        *b = s[1];
        *c = s[2];
        *d = s[3];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::SwellRng;
    use rustfft::FftPlannerScalar;
    use rustfft::num_complex::Complex;

    fn random(n: usize, seed: u64) -> Vec<Complex<f64>> {
        let mut rng = SwellRng::new(seed, 5);
        (0..n)
            .map(|_| {
                let (a, b) = rng.gaussian_pair();
                Complex::new(a, b)
            })
            .collect()
    }

    fn lanes<const W: usize>(
        fft: &LaneFft,
        inputs: &[Vec<Complex<f64>>],
    ) -> Vec<Vec<Complex<f64>>> {
        let n = fft.len();
        let mut data = vec![C::<W>::ZERO; n];
        for (p, &s) in fft.gather_order().iter().enumerate() {
            for (l, x) in inputs.iter().enumerate().take(W) {
                data[p].re[l] = x[s as usize].re;
                data[p].im[l] = x[s as usize].im;
            }
        }
        fft.run(&mut data);
        (0..W)
            .map(|l| {
                data.iter()
                    .map(|c| Complex::new(c.re[l], c.im[l]))
                    .collect()
            })
            .collect()
    }

    /// Every length the FFT layer allows, at widths 1, 4 and 8, against RustFFT's scalar
    /// planner: the same bits (what keeps the golden vectors), on seeded Gaussian inputs with
    /// a few special values (zeros, negative zeros, a huge and a tiny value) mixed in.
    #[test]
    fn same_bits_as_rustfft_scalar_planner() {
        for bits in 4..=10 {
            let n = 1usize << bits;
            let fft = LaneFft::new(n);
            let reference = FftPlannerScalar::new().plan_fft_inverse(n);
            let mut inputs: Vec<_> = (0..8).map(|l| random(n, 100 * bits as u64 + l)).collect();
            inputs[1][3] = Complex::new(-0.0, 0.0);
            inputs[2]
                .iter_mut()
                .for_each(|c| *c = Complex::new(0.0, -0.0));
            inputs[3][0] = Complex::new(1e300, -1e-300);
            let expected: Vec<Vec<Complex<f64>>> = inputs
                .iter()
                .map(|x| {
                    let mut y = x.clone();
                    reference.process(&mut y);
                    y
                })
                .collect();
            let bits_of = |v: &[Complex<f64>]| -> Vec<(u64, u64)> {
                v.iter().map(|c| (c.re.to_bits(), c.im.to_bits())).collect()
            };
            for (l, got) in lanes::<8>(&fft, &inputs).iter().enumerate() {
                assert_eq!(bits_of(got), bits_of(&expected[l]), "n = {n}, lane {l}");
            }
            for (l, got) in lanes::<4>(&fft, &inputs[4..]).iter().enumerate() {
                assert_eq!(bits_of(got), bits_of(&expected[4 + l]), "n = {n}, w 4");
            }
            let got = lanes::<1>(&fft, &inputs[5..6]);
            assert_eq!(bits_of(&got[0]), bits_of(&expected[5]), "n = {n}, w 1");
        }
    }

    /// Against a direct O(N²) inverse DFT with exact twiddles from the crate's sin/cos: error
    /// within a few ulp of the sum's magnitude times log N.
    #[test]
    fn matches_direct_dft() {
        for bits in [4, 5, 6, 7, 8, 9] {
            let n = 1usize << bits;
            let fft = LaneFft::new(n);
            let inputs: Vec<_> = (0..2).map(|l| random(n, 7 + l)).collect();
            let out = lanes::<2>(&fft, &inputs);
            for (x, y) in inputs.iter().zip(&out) {
                let scale: f64 = x.iter().map(|c| c.norm()).sum();
                for (j, y) in y.iter().enumerate() {
                    let mut acc = Complex::new(0.0, 0.0);
                    for (k, v) in x.iter().enumerate() {
                        let (s, c) = crate::math::sin_cos(
                            crate::math::TAU * ((j * k) % n) as f64 / n as f64,
                        );
                        acc += v * Complex::new(c, s);
                    }
                    let tol = 4.0 * f64::EPSILON * scale * bits as f64;
                    assert!((acc - y).norm() < tol, "n = {n}, j = {j}: {acc} vs {y}");
                }
            }
        }
    }
}
