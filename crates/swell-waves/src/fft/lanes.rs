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
//!
//! # Registers
//! The butterflies work on values of a [`Lane`] type: `[f64; W]` arrays (portable, what
//! [`LaneFft::run`] uses) or, on x86-64, the SSE2 / AVX / AVX-512 vector of W f64
//! ([`LaneFft::run_simd`], from functions compiled for that level). A chunk (16 or 32 values,
//! the base butterfly) or a radix-4 butterfly (4 values) is loaded once, computed in registers
//! and stored once. Written over `[f64; W]` alone, LLVM kept whole chunks on the stack and
//! spent about half the transform's time moving them (vector types are what it keeps in
//! registers); the operations, and so the bits, are the same.

/// W f64 lanes: each operation is the scalar one applied to every lane; the memory layout of a
/// lane vector, and the portable [`Lane`] type.
pub(crate) type Lanes<const W: usize> = [f64; W];

/// W complex values in memory, real parts then imaginary parts (a transform's working array
/// holds one per position).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(crate) struct C<const W: usize> {
    pub(crate) re: Lanes<W>,
    pub(crate) im: Lanes<W>,
}

impl<const W: usize> C<W> {
    pub(crate) const ZERO: Self = Self {
        re: [0.0; W],
        im: [0.0; W],
    };
}

/// A vector of f64 lanes the butterflies compute on: every operation is the scalar IEEE one on
/// each lane, rounded once (no FMA, no reassociation).
///
/// # Safety
/// An implementation for a vector type may only be used where the CPU has its instructions:
/// [`LaneFft::run_simd`] states that contract for its callers.
pub(crate) unsafe trait Lane: Copy {
    /// Loads the lanes from `p` (no alignment needed).
    ///
    /// # Safety
    /// `p` must be valid for reading the lanes' f64.
    unsafe fn load(p: *const f64) -> Self;
    /// Stores the lanes at `p` (no alignment needed).
    ///
    /// # Safety
    /// `p` must be valid for writing the lanes' f64.
    unsafe fn store(self, p: *mut f64);
    /// `a + b` per lane.
    fn add(self, o: Self) -> Self;
    /// `a − b` per lane.
    fn sub(self, o: Self) -> Self;
    /// `a · b` per lane.
    fn mul(self, o: Self) -> Self;
    /// `−a` per lane: the sign bit flipped, as Rust's scalar `-x` (so `−0.0` and NaNs too).
    fn neg(self) -> Self;
    /// `x` in every lane.
    fn splat(x: f64) -> Self;
    /// Lane 0 of `from`, the other lanes of `self` (a move: no bit changes).
    fn with_lane0(self, from: Self) -> Self;
    /// Per lane, `if key == 0.0 { a } else { b }` (IEEE equality: −0.0 is zero, NaN is not).
    fn where_zero(key: Self, a: Self, b: Self) -> Self;
    /// The transpose of the W × W block whose rows are `rows`, `out[c]` lane r = `rows[r]`
    /// lane c, shuffled in registers (moves only: the bits are untouched).
    ///
    /// # Panics
    /// If W is not the type's lane count.
    fn transposed<const W: usize>(rows: [Self; W]) -> [Self; W];
    /// Stores the lanes at `p` with a non-temporal store where the type has one (it skips
    /// reading the destination's cache line first; follow such stores with [`Lane::fence`]
    /// before the data is shared); a plain store otherwise.
    ///
    /// # Safety
    /// `p` must be valid for writing the lanes' f64 and aligned to the vector's size.
    unsafe fn store_stream(self, p: *mut f64);
    /// Stores the transpose of the block whose rows are `rows` ([`Lane::transposed`]):
    /// `dst[c][r] = rows[r][c]`.
    ///
    /// # Safety
    /// W must be the type's lane count, and each `dst[c]` valid for writing W f64 (no
    /// alignment needed).
    #[inline(always)]
    unsafe fn transpose_store<const W: usize>(rows: [Self; W], dst: [*mut f64; W]) {
        for (col, d) in Self::transposed(rows).into_iter().zip(dst) {
            // SAFETY: the caller's contract.
            unsafe { col.store(d) };
        }
    }
    /// [`Lane::transpose_store`] with [`Lane::store_stream`].
    ///
    /// # Safety
    /// As `transpose_store`, and each `dst[c]` aligned to the vector's size.
    #[inline(always)]
    unsafe fn transpose_stream<const W: usize>(rows: [Self; W], dst: [*mut f64; W]) {
        for (col, d) in Self::transposed(rows).into_iter().zip(dst) {
            // SAFETY: the caller's contract.
            unsafe { col.store_stream(d) };
        }
    }
    /// Orders earlier non-temporal stores before later stores (`sfence`; nothing for arrays).
    fn fence();
}

// SAFETY: plain Rust arithmetic, valid on every CPU.
unsafe impl<const W: usize> Lane for Lanes<W> {
    #[inline(always)]
    unsafe fn load(p: *const f64) -> Self {
        // SAFETY: the caller's contract (W f64 readable at p).
        unsafe { p.cast::<Self>().read_unaligned() }
    }
    #[inline(always)]
    unsafe fn store(self, p: *mut f64) {
        // SAFETY: the caller's contract (W f64 writable at p).
        unsafe { p.cast::<Self>().write_unaligned(self) }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        std::array::from_fn(|l| self[l] + o[l])
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        std::array::from_fn(|l| self[l] - o[l])
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        std::array::from_fn(|l| self[l] * o[l])
    }
    #[inline(always)]
    fn neg(self) -> Self {
        std::array::from_fn(|l| -self[l])
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        [x; W]
    }
    #[inline(always)]
    fn with_lane0(mut self, from: Self) -> Self {
        self[0] = from[0];
        self
    }
    #[inline(always)]
    fn where_zero(key: Self, a: Self, b: Self) -> Self {
        std::array::from_fn(|l| if key[l] == 0.0 { a[l] } else { b[l] })
    }
    #[inline(always)]
    fn transposed<const K: usize>(rows: [Self; K]) -> [Self; K] {
        assert!(K == W, "transposed: lane count");
        std::array::from_fn(|c| std::array::from_fn(|r| rows[r][c]))
    }
    #[inline(always)]
    unsafe fn store_stream(self, p: *mut f64) {
        // SAFETY: the caller's contract.
        unsafe { self.store(p) }
    }
    #[inline(always)]
    fn fence() {}
}

/// The x86-64 vector [`Lane`]s: `__m128d` (SSE2, W = 2), `__m256d` (AVX, W = 4) and `__m512d`
/// (AVX-512 F, W = 8). Each method is one instruction (`neg` an xor with the sign bit, as the
/// compiler emits for scalar `-x`).
#[cfg(target_arch = "x86_64")]
pub(crate) mod x86 {
    use super::Lane;
    use std::arch::x86_64::*;

    macro_rules! lane {
        ($t:ty, $load:ident, $store:ident, $add:ident, $sub:ident, $mul:ident, $xor:ident,
         $set1:ident, $lanes:literal, $lane0:ident, $select:ident, $transpose:ident, $stream:ident) => {
            // SAFETY: the trait's contract puts the CPU check on the users of these types
            // (`LaneFft::run_simd`); each method is the lane-wise IEEE operation.
            unsafe impl Lane for $t {
                #[inline(always)]
                unsafe fn load(p: *const f64) -> Self {
                    // SAFETY: the caller's contract; unaligned load.
                    unsafe { $load(p) }
                }
                #[inline(always)]
                unsafe fn store(self, p: *mut f64) {
                    // SAFETY: the caller's contract; unaligned store.
                    unsafe { $store(p, self) }
                }
                #[inline(always)]
                fn add(self, o: Self) -> Self {
                    // SAFETY: the CPU has the instruction (the trait's contract).
                    unsafe { $add(self, o) }
                }
                #[inline(always)]
                fn sub(self, o: Self) -> Self {
                    // SAFETY: as `add`.
                    unsafe { $sub(self, o) }
                }
                #[inline(always)]
                fn mul(self, o: Self) -> Self {
                    // SAFETY: as `add`.
                    unsafe { $mul(self, o) }
                }
                #[inline(always)]
                fn neg(self) -> Self {
                    // SAFETY: as `add`.
                    unsafe { $xor(self, $set1(-0.0)) }
                }
                #[inline(always)]
                fn splat(x: f64) -> Self {
                    // SAFETY: as `add`.
                    unsafe { $set1(x) }
                }
                #[inline(always)]
                fn with_lane0(self, from: Self) -> Self {
                    $lane0(self, from)
                }
                #[inline(always)]
                fn where_zero(key: Self, a: Self, b: Self) -> Self {
                    $select(key, a, b)
                }
                #[inline(always)]
                fn transposed<const W: usize>(rows: [Self; W]) -> [Self; W] {
                    assert!(W == $lanes, "transposed: lane count");
                    let cols = $transpose(std::array::from_fn(|r| rows[r]));
                    std::array::from_fn(|c| cols[c])
                }
                #[inline(always)]
                unsafe fn store_stream(self, p: *mut f64) {
                    // SAFETY: the caller's contract (aligned to the vector's size).
                    unsafe { $stream(p, self) }
                }
                #[inline(always)]
                fn fence() {
                    // SAFETY: SSE is on every x86-64 CPU.
                    unsafe { _mm_sfence() }
                }
            }
        };
    }

    /// Lane 0 of `b`, lane 1 of `a` (SSE2).
    #[inline(always)]
    fn lane0_128(a: __m128d, b: __m128d) -> __m128d {
        // SAFETY: SSE2 is on every x86-64 CPU.
        unsafe { _mm_move_sd(a, b) }
    }

    /// Lane 0 of `b`, lanes 1–3 of `a` (AVX; the trait's contract puts the CPU check on the
    /// caller).
    #[inline(always)]
    fn lane0_256(a: __m256d, b: __m256d) -> __m256d {
        // SAFETY: the `Lane` contract: AVX is available where `__m256d` lanes are used.
        unsafe { _mm256_blend_pd::<1>(a, b) }
    }

    /// Lane 0 of `b`, lanes 1–7 of `a` (AVX-512 F, as `lane0_256`).
    #[inline(always)]
    fn lane0_512(a: __m512d, b: __m512d) -> __m512d {
        // SAFETY: the `Lane` contract: AVX-512 F is available where `__m512d` lanes are used.
        unsafe { _mm512_mask_blend_pd(1, a, b) }
    }

    /// `a` where `key == 0.0`, else `b` (SSE2: a compare mask, then and / andnot / or).
    #[inline(always)]
    fn select_128(key: __m128d, a: __m128d, b: __m128d) -> __m128d {
        // SAFETY: SSE2 is on every x86-64 CPU.
        unsafe {
            let zero = _mm_cmpeq_pd(key, _mm_setzero_pd());
            _mm_or_pd(_mm_and_pd(zero, a), _mm_andnot_pd(zero, b))
        }
    }

    /// `a` where `key == 0.0`, else `b` (AVX, as `lane0_256`).
    #[inline(always)]
    fn select_256(key: __m256d, a: __m256d, b: __m256d) -> __m256d {
        // SAFETY: the `Lane` contract: AVX is available where `__m256d` lanes are used.
        unsafe { _mm256_blendv_pd(b, a, _mm256_cmp_pd::<_CMP_EQ_OQ>(key, _mm256_setzero_pd())) }
    }

    /// `a` where `key == 0.0`, else `b` (AVX-512 F, as `lane0_512`).
    #[inline(always)]
    fn select_512(key: __m512d, a: __m512d, b: __m512d) -> __m512d {
        // SAFETY: the `Lane` contract: AVX-512 F is available where `__m512d` lanes are used.
        unsafe {
            let zero = _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(key, _mm512_setzero_pd());
            _mm512_mask_blend_pd(zero, b, a)
        }
    }

    /// The 2 × 2 transpose of two rows (SSE2 unpacks).
    #[inline(always)]
    pub(crate) fn transpose2(r: [__m128d; 2]) -> [__m128d; 2] {
        // SAFETY: SSE2 is on every x86-64 CPU.
        unsafe { [_mm_unpacklo_pd(r[0], r[1]), _mm_unpackhi_pd(r[0], r[1])] }
    }

    /// The 4 × 4 transpose of four rows: unpack, then swap 128-bit halves (AVX; the `Lane`
    /// contract puts the CPU check on the caller).
    #[inline(always)]
    pub(crate) fn transpose4(r: [__m256d; 4]) -> [__m256d; 4] {
        // SAFETY: the `Lane` contract: AVX is available where `__m256d` lanes are used.
        unsafe {
            let t0 = _mm256_unpacklo_pd(r[0], r[1]);
            let t1 = _mm256_unpackhi_pd(r[0], r[1]);
            let t2 = _mm256_unpacklo_pd(r[2], r[3]);
            let t3 = _mm256_unpackhi_pd(r[2], r[3]);
            [
                _mm256_permute2f128_pd(t0, t2, 0x20),
                _mm256_permute2f128_pd(t1, t3, 0x20),
                _mm256_permute2f128_pd(t0, t2, 0x31),
                _mm256_permute2f128_pd(t1, t3, 0x31),
            ]
        }
    }

    /// The 8 × 8 transpose of eight rows: pairs interleaved, then 2×2 and 4×4 blocks moved
    /// with two-source permutes (24 shuffles; AVX-512 F, as `transpose4`).
    #[inline(always)]
    pub(crate) fn transpose8(r: [__m512d; 8]) -> [__m512d; 8] {
        // SAFETY: the `Lane` contract: AVX-512 F is available where `__m512d` lanes are used;
        // the index vectors are 8 i64 each.
        unsafe {
            // lo(a, b) = [a0 b0 a2 b2 a4 b4 a6 b6], hi = [a1 b1 a3 b3 a5 b5 a7 b7].
            let lo = |a, b| _mm512_unpacklo_pd(a, b);
            let hi = |a, b| _mm512_unpackhi_pd(a, b);
            let t = [
                lo(r[0], r[1]),
                hi(r[0], r[1]),
                lo(r[2], r[3]),
                hi(r[2], r[3]),
                lo(r[4], r[5]),
                hi(r[4], r[5]),
                lo(r[6], r[7]),
                hi(r[6], r[7]),
            ];
            let perm = |a, idx: [i64; 8], b| {
                _mm512_permutex2var_pd(a, _mm512_loadu_si512(idx.as_ptr().cast()), b)
            };
            const EVEN: [i64; 8] = [0, 1, 8, 9, 4, 5, 12, 13];
            const ODD: [i64; 8] = [2, 3, 10, 11, 6, 7, 14, 15];
            // u[k]: rows 0–3 (v: rows 4–7) of columns (c, c + 4) for c = 0, 2, 1, 3.
            let u = [
                perm(t[0], EVEN, t[2]),
                perm(t[0], ODD, t[2]),
                perm(t[1], EVEN, t[3]),
                perm(t[1], ODD, t[3]),
            ];
            let v = [
                perm(t[4], EVEN, t[6]),
                perm(t[4], ODD, t[6]),
                perm(t[5], EVEN, t[7]),
                perm(t[5], ODD, t[7]),
            ];
            const LOW: [i64; 8] = [0, 1, 2, 3, 8, 9, 10, 11];
            const HIGH: [i64; 8] = [4, 5, 6, 7, 12, 13, 14, 15];
            [
                perm(u[0], LOW, v[0]),
                perm(u[2], LOW, v[2]),
                perm(u[1], LOW, v[1]),
                perm(u[3], LOW, v[3]),
                perm(u[0], HIGH, v[0]),
                perm(u[2], HIGH, v[2]),
                perm(u[1], HIGH, v[1]),
                perm(u[3], HIGH, v[3]),
            ]
        }
    }
    lane!(
        __m128d,
        _mm_loadu_pd,
        _mm_storeu_pd,
        _mm_add_pd,
        _mm_sub_pd,
        _mm_mul_pd,
        _mm_xor_pd,
        _mm_set1_pd,
        2,
        lane0_128,
        select_128,
        transpose2,
        _mm_stream_pd
    );
    lane!(
        __m256d,
        _mm256_loadu_pd,
        _mm256_storeu_pd,
        _mm256_add_pd,
        _mm256_sub_pd,
        _mm256_mul_pd,
        _mm256_xor_pd,
        _mm256_set1_pd,
        4,
        lane0_256,
        select_256,
        transpose4,
        _mm256_stream_pd
    );
    lane!(
        __m512d,
        _mm512_loadu_pd,
        _mm512_storeu_pd,
        _mm512_add_pd,
        _mm512_sub_pd,
        _mm512_mul_pd,
        xor512,
        _mm512_set1_pd,
        8,
        lane0_512,
        select_512,
        transpose8,
        _mm512_stream_pd
    );

    /// `_mm512_xor_pd` needs AVX-512 DQ; the integer xor needs only F (the level's feature).
    ///
    /// # Safety
    /// The CPU must have AVX-512 F.
    #[inline(always)]
    unsafe fn xor512(a: __m512d, b: __m512d) -> __m512d {
        // SAFETY: the caller's contract; casts are free.
        unsafe {
            _mm512_castsi512_pd(_mm512_xor_si512(
                _mm512_castpd_si512(a),
                _mm512_castpd_si512(b),
            ))
        }
    }
}

/// W complex values in registers: one [`Lane`] of real parts, one of imaginary parts.
#[derive(Clone, Copy)]
struct Cv<V> {
    re: V,
    im: V,
}

impl<V: Lane> Cv<V> {
    #[inline(always)]
    fn zero() -> Self {
        Self {
            re: V::splat(0.0),
            im: V::splat(0.0),
        }
    }
    /// # Safety
    /// `p` valid for reading; V has W lanes.
    #[inline(always)]
    unsafe fn load<const W: usize>(p: *const C<W>) -> Self {
        // SAFETY: the caller's contract; `re` and `im` are W f64 each.
        unsafe {
            Self {
                re: V::load(std::ptr::addr_of!((*p).re).cast()),
                im: V::load(std::ptr::addr_of!((*p).im).cast()),
            }
        }
    }
    /// # Safety
    /// `p` valid for writing; V has W lanes.
    #[inline(always)]
    unsafe fn store<const W: usize>(self, p: *mut C<W>) {
        // SAFETY: the caller's contract; `re` and `im` are W f64 each.
        unsafe {
            self.re.store(std::ptr::addr_of_mut!((*p).re).cast());
            self.im.store(std::ptr::addr_of_mut!((*p).im).cast());
        }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self {
            re: self.re.add(o.re),
            im: self.im.add(o.im),
        }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self {
            re: self.re.sub(o.re),
            im: self.im.sub(o.im),
        }
    }
    /// `self · (re, im)` for one complex constant shared by all lanes, as num_complex computes
    /// it: `(a·c − b·d, a·d + b·c)` with `self = a + bi`.
    #[inline(always)]
    fn mul_c(self, (re, im): (f64, f64)) -> Self {
        let (c, d) = (V::splat(re), V::splat(im));
        Self {
            re: self.re.mul(c).sub(self.im.mul(d)),
            im: self.re.mul(d).add(self.im.mul(c)),
        }
    }
    /// `self · s` for a real s shared by all lanes.
    #[inline(always)]
    fn scale(self, s: f64) -> Self {
        let s = V::splat(s);
        Self {
            re: self.re.mul(s),
            im: self.im.mul(s),
        }
    }
    /// `self · i` (RustFFT's `rotate_90` in the inverse direction): `(−im, re)`.
    #[inline(always)]
    fn rot(self) -> Self {
        Self {
            re: self.im.neg(),
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
fn bf2<V: Lane>(a: &mut Cv<V>, b: &mut Cv<V>) {
    let t = a.add(*b);
    *b = a.sub(*b);
    *a = t;
}

/// RustFFT's `Butterfly4::perform_fft_contiguous` (inverse).
#[inline(always)]
fn bf4<V: Lane>(v: &mut [Cv<V>; 4]) {
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
fn bf8<V: Lane>(b: &mut [Cv<V>; 8]) {
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
/// transformed, length E = 2H) and the two odd quarter transforms (length H), twiddled by `tw`
/// (H − 1 entries), combined into the four quarters of the output.
#[inline(always)]
fn split_combine<V: Lane, const H: usize, const E: usize>(
    evens: [Cv<V>; E],
    mut n1: [Cv<V>; H],
    mut n3: [Cv<V>; H],
    tw: &[(f64, f64)],
) -> [[Cv<V>; H]; 4] {
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
    let mut out = [[Cv::zero(); H]; 4];
    for k in 0..H {
        out[0][k] = evens[k].add(n1[k]);
        out[1][k] = evens[k + H].add(n3[k]);
        out[2][k] = evens[k].sub(n1[k]);
        out[3][k] = evens[k + H].sub(n3[k]);
    }
    out
}

/// RustFFT's `Butterfly16::perform_fft_contiguous` (inverse) of 16 values.
#[inline(always)]
fn bf16<V: Lane>(b: &mut [Cv<V>; 16], tw: &SplitTwiddles) {
    let mut evens = [Cv::zero(); 8];
    let (mut n1, mut n3) = ([Cv::zero(); 4], [Cv::zero(); 4]);
    for k in 0..8 {
        evens[k] = b[2 * k];
    }
    for k in 0..4 {
        n1[k] = b[4 * k + 1];
        n3[k] = b[(4 * k + 15) % 16];
    }
    bf8(&mut evens);
    bf4(&mut n1);
    bf4(&mut n3);
    let q = split_combine::<V, 4, 8>(evens, n1, n3, &tw.tw16);
    for k in 0..16 {
        b[k] = q[k / 4][k % 4];
    }
}

/// RustFFT's `Butterfly32::perform_fft_contiguous` (inverse) of 32 values.
#[inline(always)]
fn bf32<V: Lane>(b: &mut [Cv<V>; 32], tw: &SplitTwiddles) {
    let mut evens = [Cv::zero(); 16];
    let (mut n1, mut n3) = ([Cv::zero(); 8], [Cv::zero(); 8]);
    for k in 0..16 {
        evens[k] = b[2 * k];
    }
    for k in 0..8 {
        n1[k] = b[4 * k + 1];
        n3[k] = b[(4 * k + 31) % 32];
    }
    bf16(&mut evens, tw);
    bf8(&mut n1);
    bf8(&mut n3);
    let q = split_combine::<V, 8, 16>(evens, n1, n3, &tw.tw32);
    for k in 0..32 {
        b[k] = q[k / 8][k % 8];
    }
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

    /// Transforms W sequences in place on `[f64; W]` lanes (the portable form, and the
    /// reference of [`LaneFft::run_simd`]); `data` (N values) must hold the input in gather
    /// order. On return `data[j]` is output j.
    ///
    /// # Panics
    /// If `data.len()` is not N.
    #[cfg(test)]
    pub(crate) fn run<const W: usize>(&self, data: &mut [C<W>]) {
        // SAFETY: `[f64; W]` lanes run on every CPU.
        unsafe { self.run_simd::<Lanes<W>, W>(data) }
    }

    /// [`LaneFft::run`] on lanes of type V (W f64 each): the same operations, so the same bits.
    ///
    /// # Safety
    /// V must have exactly W lanes, and the CPU the instructions of V (call it from a function
    /// compiled for V's level, after checking the CPU, so that its methods inline).
    ///
    /// # Panics
    /// If `data.len()` is not N.
    #[inline(always)]
    pub(crate) unsafe fn run_simd<V: Lane, const W: usize>(&self, data: &mut [C<W>]) {
        assert_eq!(data.len(), self.n, "LaneFft::run: data length");
        debug_assert_eq!(std::mem::size_of::<V>(), W * std::mem::size_of::<f64>());
        let split = &*self.split;
        let base = data.as_mut_ptr();
        // Base butterflies: each chunk loaded once, transformed in registers, stored once.
        // SAFETY (all loads and stores below): positions < N = data.len(); V has W lanes (the
        // caller's contract), the width of each `re` and `im` array.
        match self.base {
            8 => {
                for c in 0..self.n / 8 {
                    unsafe {
                        let b = base.add(8 * c);
                        let mut v = load_chunk::<V, W, 8>(b);
                        bf8(&mut v);
                        store_chunk(v, b);
                    }
                }
            }
            16 => {
                for c in 0..self.n / 16 {
                    unsafe {
                        let b = base.add(16 * c);
                        let mut v = load_chunk::<V, W, 16>(b);
                        bf16(&mut v, split);
                        store_chunk(v, b);
                    }
                }
            }
            _ => {
                for c in 0..self.n / 32 {
                    unsafe {
                        let b = base.add(32 * c);
                        let mut v = load_chunk::<V, W, 32>(b);
                        bf32(&mut v, split);
                        store_chunk(v, b);
                    }
                }
            }
        }
        let mut cross = self.base;
        let mut tw: &[(f64, f64)] = &self.twiddles;
        while cross < self.n {
            let columns = cross;
            cross *= 4;
            let (layer, rest) = tw.split_at(3 * columns);
            for chunk in 0..self.n / cross {
                // SAFETY: the chunk's 4·columns = cross values lie inside `data`.
                unsafe { radix4_layer::<V, W>(base.add(chunk * cross), layer, columns) };
            }
            tw = rest;
        }
    }
}

/// K consecutive values from `p` into registers. Plain loops, not `std::array::from_fn`: a
/// closure passed to a library function compiled without the level's features cannot inline
/// the intrinsics, which then become calls.
///
/// # Safety
/// `p` valid for reading K values; V has W lanes and its instructions are available.
#[inline(always)]
unsafe fn load_chunk<V: Lane, const W: usize, const K: usize>(p: *const C<W>) -> [Cv<V>; K] {
    let mut v = [Cv::zero(); K];
    for (k, x) in v.iter_mut().enumerate() {
        // SAFETY: k < K (the caller's contract).
        *x = unsafe { Cv::load(p.add(k)) };
    }
    v
}

/// K values from registers to `p`.
///
/// # Safety
/// `p` valid for writing K values; V has W lanes and its instructions are available.
#[inline(always)]
unsafe fn store_chunk<V: Lane, const W: usize, const K: usize>(v: [Cv<V>; K], p: *mut C<W>) {
    for (k, x) in v.iter().enumerate() {
        // SAFETY: k < K (the caller's contract).
        unsafe { x.store(p.add(k)) };
    }
}

/// RustFFT's `butterfly_4` over one chunk of `4·columns` values at `chunk`, with the layer's
/// twiddles (three per column).
///
/// # Safety
/// `chunk` valid for reading and writing 4·columns values; V has W lanes and its instructions
/// are available (as [`LaneFft::run_simd`]).
#[inline(always)]
unsafe fn radix4_layer<V: Lane, const W: usize>(
    chunk: *mut C<W>,
    tw: &[(f64, f64)],
    columns: usize,
) {
    for (i, t) in tw.chunks_exact(3).take(columns).enumerate() {
        // SAFETY: i + 3·columns < 4·columns, inside the chunk (the caller's contract).
        unsafe {
            let p = chunk.add(i);
            let mut s = [
                Cv::<V>::load(p),
                Cv::<V>::load(p.add(columns)).mul_c(t[0]),
                Cv::<V>::load(p.add(2 * columns)).mul_c(t[1]),
                Cv::<V>::load(p.add(3 * columns)).mul_c(t[2]),
            ];
            bf4(&mut s);
            for (k, v) in s.iter().enumerate() {
                v.store(p.add(k * columns));
            }
        }
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

    /// The vector lanes the SIMD levels use give `[f64; W]`'s bits (the portable form, pinned
    /// to RustFFT above) at every length, for each vector type this CPU has, on the same seeded
    /// inputs with special values.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vector_lanes_equal_array_lanes() {
        use std::arch::x86_64::{__m128d, __m256d, __m512d};
        fn check<V: Lane, const W: usize>(fft: &LaneFft, seed: u64) {
            let n = fft.len();
            let mut rng = SwellRng::new(seed, 9);
            let mut data: Vec<C<W>> = (0..n)
                .map(|_| C {
                    re: std::array::from_fn(|_| rng.gaussian_pair().0),
                    im: std::array::from_fn(|_| rng.gaussian_pair().1),
                })
                .collect();
            data[1].re[0] = -0.0;
            data[2].im[W - 1] = 1e300;
            data[3].re[W / 2] = f64::MIN_POSITIVE / 4.0;
            let mut want = data.clone();
            fft.run(&mut want);
            // SAFETY: the caller checked that the CPU has V's instructions; V holds W f64.
            unsafe { fft.run_simd::<V, W>(&mut data) };
            let bits = |v: &[C<W>]| -> Vec<u64> {
                v.iter()
                    .flat_map(|c| c.re.iter().chain(&c.im).map(|x| x.to_bits()))
                    .collect()
            };
            assert_eq!(bits(&data), bits(&want), "n = {n}, W = {W}");
        }
        for bits in 4..=10 {
            let fft = LaneFft::new(1 << bits);
            check::<__m128d, 2>(&fft, bits);
            if std::arch::is_x86_feature_detected!("avx2") {
                check::<__m256d, 4>(&fft, bits);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                check::<__m512d, 8>(&fft, bits);
            }
        }
    }

    /// The block transposes move every value to its transposed place, through plain and
    /// non-temporal stores, for every lane type (the vector ones where the CPU has them).
    #[test]
    fn block_transposes_transpose() {
        fn check<V: Lane, const W: usize>() {
            #[repr(C, align(64))]
            struct Block<const W: usize>([[f64; W]; W]);
            let m: [[f64; W]; W] =
                std::array::from_fn(|r| std::array::from_fn(|c| (r * W + c) as f64));
            // SAFETY: each row holds W f64, V's lane count.
            let rows: [V; W] = std::array::from_fn(|r| unsafe { V::load(m[r].as_ptr()) });
            let want: [[f64; W]; W] = std::array::from_fn(|c| std::array::from_fn(|r| m[r][c]));
            for stream in [false, true] {
                let mut out = Block([[0.0; W]; W]);
                let base = out.0.as_mut_ptr();
                // SAFETY: `base.add(c)` for c < W is a row of `out`.
                let dst: [*mut f64; W] =
                    std::array::from_fn(|c| unsafe { (*base.add(c)).as_mut_ptr() });
                // SAFETY: W disjoint rows of W f64, each aligned to W·8 bytes (the block is
                // 64-byte aligned and W·8 divides 64); the caller checked the CPU.
                unsafe {
                    if stream {
                        V::transpose_stream(rows, dst);
                        V::fence();
                    } else {
                        V::transpose_store(rows, dst);
                    }
                }
                assert_eq!(out.0, want, "W = {W}, stream {stream}");
            }
        }
        check::<Lanes<1>, 1>();
        check::<Lanes<2>, 2>();
        check::<Lanes<8>, 8>();
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{__m128d, __m256d, __m512d};
            check::<__m128d, 2>();
            if std::arch::is_x86_feature_detected!("avx2") {
                check::<__m256d, 4>();
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                check::<__m512d, 8>();
            }
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
