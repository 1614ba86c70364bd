//! The 2-D inverse transform of a Hermitian spectrum into a real N×N grid.
//!
//! A real field `f(x_i, z_j) = Σ_{m,n} F[m, n]·e^{2πi(m·i + n·j)/N}` (unnormalised inverse DFT,
//! RustFFT's `Inverse` convention) has a Hermitian spectrum, `F[−m, −n] = conj(F[m, n])`, so half
//! of it is enough:
//!
//! 1. **Column pass.** For each kx column `m = 0 … N/2 − 1`, a complex length-N inverse FFT along
//!    z: `G[m, j] = Σ_n F[m, n]·e^{2πi n j/N}`. The Nyquist column `m = N/2` is empty in every
//!    layer (see [`super::FftLayer`]), so its transform, which would give zeros, is skipped.
//! 2. **Row pass.** Each row j, `G[·, j]`, is Hermitian in m (`G[−m, j] = conj(G[m, j])`), so its
//!    transform is real. Rows are packed in pairs `(a, b) = (2p, 2p + 1)`: the complex sequence
//!    `Z[m] = G_a[m] + i·G_b[m]` (with `Z[−m] = conj(G_a[m]) + i·conj(G_b[m])`, `Z[N/2] = 0`,
//!    and only the real parts of `G_a[0]`, `G_b[0]`, which are real up to rounding) is
//!    transformed once; `f(·, a) = Re z`, `f(·, b) = Im z`. The row pass costs N/2 complex
//!    transforms.
//!
//! How it is scheduled does not change a bit (every 1-D transform is independent of the others
//! in its batch and runs the same operation sequence on the same input).
//!
//! **Portable backend.** The 1-D transforms are the crate's own ([`super::lanes`]): RustFFT's
//! scalar plan ported operation for operation, so the bits are those RustFFT's
//! `FftPlannerScalar` gave, and run W at a time, one transform per SIMD lane: W columns
//! (`m0 … m0 + W − 1`), then W row pairs. W is 1, 2, 4 or 8 by [`crate::simd::simd_level`];
//! every width gives the same bits. Inputs are gathered straight into the plan's bit-reversed
//! order, so no transform needs a copy of its own.
//!
//! **Native backend.** RustFFT's run-time dispatched planner, one transform at a time; rows are
//! packed, transformed and unpacked in blocks that stay in cache (`ROW_PAIRS`).
//!
//! We do not use the `realfft` crate: it only plans through RustFFT's SIMD `FftPlanner`, whose
//! bits depend on the CPU.

use std::sync::{Arc, Mutex};

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

use super::FftBackend;
use super::lanes::{C, LaneFft};
use crate::simd::{SimdLevel, simd_level};

/// Plans and scratch sizes for inverse real 2-D transforms of one size, and a pool of working
/// memory so that a frame allocates only the grids it returns.
pub(crate) struct InverseRealFft2 {
    n: usize,
    engine: Engine,
    /// Scratch returned by finished frames. Frames on several threads each take their own (the
    /// pool grows to the number of concurrent frames and no further); the buffers' contents
    /// never reach a result, so reuse cannot change one.
    pool: Mutex<Vec<Scratch>>,
}

/// Which 1-D transform a 2-D transform runs.
#[derive(Clone)]
enum Engine {
    /// The crate's lane-parallel port of RustFFT's scalar plan, with `scatter[m]`, the position
    /// input m takes in the plan's gather order.
    Lanes { fft: LaneFft, scatter: Vec<u32> },
    /// RustFFT's SIMD planner (the native backend).
    Rust(Arc<dyn Fft<f64>>),
}

impl Clone for InverseRealFft2 {
    fn clone(&self) -> Self {
        Self {
            n: self.n,
            engine: self.engine.clone(),
            pool: Mutex::new(Vec::new()),
        }
    }
}

impl std::fmt::Debug for InverseRealFft2 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("InverseRealFft2")
            .field("n", &self.n)
            .finish_non_exhaustive()
    }
}

/// Working memory for [`InverseRealFft2::process`] and for a frame's spectra; reusable across
/// calls and fields. Nothing read from it ever reaches a result before being overwritten.
pub(crate) struct Scratch {
    /// Native backend: G[m, j] after the column pass (N/2·N, column m at `[m·N .. (m+1)·N]`).
    cols: Vec<Complex<f64>>,
    /// Portable backend: G after the column pass as four N/2 × N/2 planes (N² values), laid
    /// out for the row pass: plane `2·(j mod 2) + c` (c = 0 real, 1 imaginary part) holds
    /// G[m, j] at `[m·N/2 + j/2]`, so a block of row pairs reads W consecutive values.
    planes: Vec<f64>,
    /// Up to 8 columns' spectra (N each), filled by the caller of `process_with`.
    column: Vec<Complex<f64>>,
    /// Native backend: one block of packed rows (ROW_PAIRS rows of N, ROW_STRIDE_PAD apart)
    /// and its transform, and RustFFT's scratch.
    rows_in: Vec<Complex<f64>>,
    rows_out: Vec<Complex<f64>>,
    fft: Vec<Complex<f64>>,
    /// Portable backend: N values of W lanes, for the width in use (only one is ever sized).
    lanes1: Vec<C<1>>,
    lanes2: Vec<C<2>>,
    lanes4: Vec<C<4>>,
    lanes8: Vec<C<8>>,
    /// h̃(k, t) over the half plane (N/2·N), filled by the frame.
    pub(crate) htilde: Vec<Complex<f64>>,
    /// `(sin, cos)` of each distinct frequency's phase at the frame's time (see
    /// `FftLayer::phase_omegas`); resized by the frame.
    pub(crate) phases: Vec<(f64, f64)>,
}

/// Where a 2-D transform's column spectra come from.
enum Columns<'a, F> {
    /// A stored half spectrum, column m at `[m·N .. (m+1)·N]`.
    Half(&'a [Complex<f64>]),
    /// Made on demand: `f(m, buf)` writes column m into `buf` (N entries, all of them).
    Made(F),
}

impl InverseRealFft2 {
    /// Plans the length-`n` inverse transform for the backend (`n` a power of two, ≥ 16).
    pub(crate) fn new(n: usize, backend: FftBackend) -> Self {
        let engine = match backend {
            FftBackend::Portable => {
                let fft = LaneFft::new(n);
                let mut scatter = vec![0u32; n];
                for (p, &s) in fft.gather_order().iter().enumerate() {
                    scatter[s as usize] = p as u32;
                }
                Engine::Lanes { fft, scatter }
            }
            FftBackend::Native => Engine::Rust(FftPlanner::new().plan_fft_inverse(n)),
        };
        Self {
            n,
            engine,
            pool: Mutex::new(Vec::new()),
        }
    }

    /// Fresh working memory sized for this transform.
    pub(crate) fn scratch(&self) -> Scratch {
        let zero = Complex::new(0.0, 0.0);
        let half = self.n / 2 * self.n;
        let (rows, fft_len, cols, planes) = match &self.engine {
            Engine::Rust(fft) => (
                ROW_PAIRS.min(self.n / 2),
                fft.get_outofplace_scratch_len()
                    .max(fft.get_immutable_scratch_len()),
                half,
                0,
            ),
            Engine::Lanes { .. } => (0, 0, 0, self.n * self.n),
        };
        Scratch {
            cols: vec![zero; cols],
            planes: vec![0.0; planes],
            column: Vec::new(),
            rows_in: vec![zero; rows * (self.n + ROW_STRIDE_PAD)],
            rows_out: vec![zero; rows * self.n],
            fft: vec![zero; fft_len],
            lanes1: Vec::new(),
            lanes2: Vec::new(),
            lanes4: Vec::new(),
            lanes8: Vec::new(),
            htilde: vec![zero; half],
            phases: Vec::new(),
        }
    }

    /// Working memory from the pool, or fresh if the pool is empty (or its lock poisoned: a
    /// panic elsewhere must not stop frames).
    pub(crate) fn take_scratch(&self) -> Scratch {
        let pooled = self.pool.lock().ok().and_then(|mut p| p.pop());
        pooled.unwrap_or_else(|| self.scratch())
    }

    /// Returns working memory to the pool.
    pub(crate) fn give_back(&self, scratch: Scratch) {
        if let Ok(mut p) = self.pool.lock() {
            p.push(scratch);
        }
    }

    /// Transforms a half spectrum into a real grid.
    ///
    /// `half` holds columns `m = 0 … N/2 − 1` back to back, column m at `[m·N .. (m+1)·N]`,
    /// entry n (wrapped: index `n mod N`) along kz. The missing Nyquist column is taken as zero.
    /// `out[j·N + i]` receives f at `x = i·L/N`, `z = j·L/N`.
    #[inline(always)]
    pub(crate) fn process(&self, half: &[Complex<f64>], scratch: &mut Scratch, out: &mut [f64]) {
        let n = self.n;
        debug_assert_eq!(half.len(), n / 2 * n);
        match &self.engine {
            Engine::Lanes { fft, scatter } => self.dispatch(
                fft,
                scatter,
                Columns::<fn(usize, &mut [Complex<f64>])>::Half(half),
                scratch,
                out,
            ),
            Engine::Rust(fft) => {
                // Column pass straight from `half` into G: RustFFT's immutable form runs the
                // same algorithm as its in-place one.
                fft.process_immutable_with_scratch(half, &mut scratch.cols, &mut scratch.fft);
                self.row_pass_rust(fft, scratch, out);
            }
        }
    }

    /// [`InverseRealFft2::process`] of the half spectrum whose column m `column(m, buf)` writes
    /// into `buf` (N entries, every one of them): a few columns at a time, each transformed
    /// while it is in L1, and no N/2·N spectrum is ever stored. Same bits as `process` of the
    /// assembled spectrum.
    #[inline(always)]
    pub(crate) fn process_with(
        &self,
        mut column: impl FnMut(usize, &mut [Complex<f64>]),
        scratch: &mut Scratch,
        out: &mut [f64],
    ) {
        let n = self.n;
        match &self.engine {
            Engine::Lanes { fft, scatter } => {
                self.dispatch(fft, scatter, Columns::Made(column), scratch, out)
            }
            Engine::Rust(fft) => {
                scratch.column.resize(n, Complex::new(0.0, 0.0));
                for (m, g) in scratch.cols.chunks_exact_mut(n).enumerate() {
                    column(m, &mut scratch.column);
                    fft.process_outofplace_with_scratch(&mut scratch.column, g, &mut scratch.fft);
                }
                self.row_pass_rust(fft, scratch, out);
            }
        }
    }

    /// The portable 2-D transform at the level in use: the same bits at every level.
    #[inline(always)]
    fn dispatch<F: FnMut(usize, &mut [Complex<f64>])>(
        &self,
        fft: &LaneFft,
        scatter: &[u32],
        columns: Columns<'_, F>,
        s: &mut Scratch,
        out: &mut [f64],
    ) {
        match simd_level() {
            SimdLevel::Scalar => lanes_2d::<1, F>(fft, scatter, columns, s, out),
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Sse2 => {
                // SAFETY: every x86-64 CPU has SSE2.
                unsafe { lanes_2d_sse2(fft, scatter, columns, s, out) }
            }
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => {
                // SAFETY: `simd_level` returns Avx2 only where the CPU has AVX2 (detected).
                unsafe { lanes_2d_avx2(fft, scatter, columns, s, out) }
            }
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => {
                // SAFETY: `simd_level` returns Avx512 only where the CPU has AVX-512 F.
                unsafe { lanes_2d_avx512(fft, scatter, columns, s, out) }
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => lanes_2d::<1, F>(fft, scatter, columns, s, out),
        }
    }

    /// The row pass from G (`scratch.cols`) into `out` with RustFFT (native backend),
    /// ROW_PAIRS pairs at a time: pack the block (a tiled transpose: for each m the block's
    /// 2·ROW_PAIRS values of G[m, ·] are contiguous), transform it, unpack it into `out`. The
    /// block stays in L1/L2 from packing to unpacking.
    #[inline(always)]
    fn row_pass_rust(&self, fft: &Arc<dyn Fft<f64>>, scratch: &mut Scratch, out: &mut [f64]) {
        let n = self.n;
        let h = n / 2;
        debug_assert_eq!(out.len(), n * n);
        let pairs = ROW_PAIRS.min(h);
        let g = &scratch.cols;
        let (rows, zs) = (&mut scratch.rows_in, &mut scratch.rows_out);
        // Packed rows sit ROW_STRIDE_PAD entries further apart than N: with a stride of exactly
        // N·16 bytes (a multiple of 4 KiB) the block's rows all map to the same L1 sets, and
        // packing, which writes one entry in each row in turn, thrashes them.
        let stride = n + ROW_STRIDE_PAD;
        for p0 in (0..h).step_by(pairs) {
            let a0 = 2 * p0;
            for q in 0..pairs {
                let (a, b) = (a0 + 2 * q, a0 + 2 * q + 1);
                rows[q * stride] = Complex::new(g[a].re, g[b].re);
                rows[q * stride + h] = Complex::new(0.0, 0.0);
            }
            for m in 1..h {
                let col = &g[m * n + a0..m * n + a0 + 2 * pairs];
                for (q, ab) in col.chunks_exact(2).enumerate() {
                    let (ga, gb) = (ab[0], ab[1]);
                    rows[q * stride + m] = Complex::new(ga.re - gb.im, ga.im + gb.re);
                    rows[q * stride + n - m] = Complex::new(ga.re + gb.im, gb.re - ga.im);
                }
            }
            for (row, z) in rows.chunks_exact_mut(stride).zip(zs.chunks_exact_mut(n)) {
                fft.process_outofplace_with_scratch(&mut row[..n], z, &mut scratch.fft);
            }
            let block = &mut out[a0 * n..(a0 + 2 * pairs) * n];
            for (z, pair) in zs.chunks_exact(n).zip(block.chunks_exact_mut(2 * n)) {
                let (lo, hi) = pair.split_at_mut(n);
                for (l, z) in lo.iter_mut().zip(z) {
                    *l = z.re;
                }
                for (h, z) in hi.iter_mut().zip(z) {
                    *h = z.im;
                }
            }
        }
    }
}

/// The lane buffer of width W in a scratch.
trait LaneBuf<const W: usize> {
    fn lanes(&mut self) -> &mut Vec<C<W>>;
}
impl LaneBuf<1> for Scratch {
    fn lanes(&mut self) -> &mut Vec<C<1>> {
        &mut self.lanes1
    }
}
impl LaneBuf<2> for Scratch {
    fn lanes(&mut self) -> &mut Vec<C<2>> {
        &mut self.lanes2
    }
}
impl LaneBuf<4> for Scratch {
    fn lanes(&mut self) -> &mut Vec<C<4>> {
        &mut self.lanes4
    }
}
impl LaneBuf<8> for Scratch {
    fn lanes(&mut self) -> &mut Vec<C<8>> {
        &mut self.lanes8
    }
}

/// The portable 2-D inverse real transform with W 1-D transforms per step (module docs).
///
/// Column pass: columns `m0 … m0 + W − 1` are gathered into lanes in the plan's order,
/// transformed, and stored into G's planes (`Scratch::planes`). Row pass: row pairs
/// `p0 … p0 + W − 1` are packed (`Z[m] = G_a[m] + i·G_b[m]`, exactly the scalar packing's
/// operations, W lanes per vector operation) into lanes, transformed, and unpacked into `out`.
#[inline(always)]
fn lanes_2d<const W: usize, F: FnMut(usize, &mut [Complex<f64>])>(
    fft: &LaneFft,
    scatter: &[u32],
    columns: Columns<'_, F>,
    s: &mut Scratch,
    out: &mut [f64],
) where
    Scratch: LaneBuf<W>,
{
    let n = fft.len();
    let h = n / 2;
    debug_assert_eq!(out.len(), n * n);
    let zero = Complex::new(0.0, 0.0);
    let mut data = std::mem::take(LaneBuf::<W>::lanes(s));
    data.resize(n, C::ZERO);
    let gather = fft.gather_order();
    let mut columns = columns;
    if matches!(columns, Columns::Made(_)) {
        s.column.resize(W * n, zero);
    }
    for m0 in (0..h).step_by(W) {
        let src: &[Complex<f64>] = match &mut columns {
            Columns::Half(half) => &half[m0 * n..(m0 + W) * n],
            Columns::Made(f) => {
                for (l, buf) in s.column.chunks_exact_mut(n).take(W).enumerate() {
                    f(m0 + l, buf);
                }
                &s.column[..W * n]
            }
        };
        if W >= 4 {
            // W/2 consecutive entries of the W columns are a W × W block of f64 (re, im
            // interleaved): transposed, its rows are the lanes' real and imaginary parts of
            // those entries, each stored whole at the entry's place in the plan's order.
            let half = W / 2;
            for k0 in (0..n).step_by(half) {
                let t = transpose::<W>(std::array::from_fn(|l| {
                    let col = &src[l * n + k0..][..half];
                    std::array::from_fn(|c| {
                        if c % 2 == 0 {
                            col[c / 2].re
                        } else {
                            col[c / 2].im
                        }
                    })
                }));
                for c2 in 0..half {
                    data[scatter[k0 + c2] as usize] = C {
                        re: t[2 * c2],
                        im: t[2 * c2 + 1],
                    };
                }
            }
        } else {
            for (d, &k) in data.iter_mut().zip(gather) {
                for l in 0..W {
                    let v = src[l * n + k as usize];
                    d.re[l] = v.re;
                    d.im[l] = v.im;
                }
            }
        }
        fft.run(&mut data);
        let hh = h * h;
        let (re_e, rest) = s.planes.split_at_mut(hh);
        let (im_e, rest) = rest.split_at_mut(hh);
        let (re_o, im_o) = rest.split_at_mut(hh);
        // W × W block transposes: W consecutive even (odd) outputs of the W columns become W
        // consecutive plane entries of each column.
        for (jp0, block) in (0..h).step_by(W).zip(data.chunks_exact(2 * W)) {
            let planes: [(&mut [f64], [[f64; W]; W]); 4] = [
                (
                    &mut *re_e,
                    transpose(std::array::from_fn(|r| block[2 * r].re)),
                ),
                (
                    &mut *im_e,
                    transpose(std::array::from_fn(|r| block[2 * r].im)),
                ),
                (
                    &mut *re_o,
                    transpose(std::array::from_fn(|r| block[2 * r + 1].re)),
                ),
                (
                    &mut *im_o,
                    transpose(std::array::from_fn(|r| block[2 * r + 1].im)),
                ),
            ];
            for (plane, t) in planes {
                for (l, row) in t.iter().enumerate() {
                    plane[(m0 + l) * h + jp0..][..W].copy_from_slice(row);
                }
            }
        }
    }
    let hh = h * h;
    let (re_e, rest) = s.planes.split_at(hh);
    let (im_e, rest) = rest.split_at(hh);
    let (re_o, im_o) = rest.split_at(hh);
    let lanes_at =
        |plane: &[f64], at: usize| -> [f64; W] { plane[at..at + W].try_into().expect("W values") };
    for p0 in (0..h).step_by(W) {
        let a0 = 2 * p0;
        let (d0, dh) = (scatter[0] as usize, scatter[h] as usize);
        // m = 0: (G_a[0].re, G_b[0].re); m = N/2: the empty Nyquist entry.
        data[d0] = C {
            re: lanes_at(re_e, p0),
            im: lanes_at(re_o, p0),
        };
        data[dh] = C::ZERO;
        for m in 1..h {
            let at = m * h + p0;
            let (ga_re, ga_im) = (lanes_at(re_e, at), lanes_at(im_e, at));
            let (gb_re, gb_im) = (lanes_at(re_o, at), lanes_at(im_o, at));
            let (pm, pn) = (scatter[m] as usize, scatter[n - m] as usize);
            data[pm] = C {
                re: std::array::from_fn(|q| ga_re[q] - gb_im[q]),
                im: std::array::from_fn(|q| ga_im[q] + gb_re[q]),
            };
            data[pn] = C {
                re: std::array::from_fn(|q| ga_re[q] + gb_im[q]),
                im: std::array::from_fn(|q| gb_re[q] - ga_im[q]),
            };
        }
        fft.run(&mut data);
        // Unpacked W outputs at a time: a W × W transpose per part, written W values per row.
        let block = &mut out[a0 * n..(a0 + 2 * W) * n];
        for (i0, d) in (0..n).step_by(W).zip(data.chunks_exact(W)) {
            let re = transpose::<W>(std::array::from_fn(|k| d[k].re));
            let im = transpose::<W>(std::array::from_fn(|k| d[k].im));
            for q in 0..W {
                block[2 * q * n + i0..][..W].copy_from_slice(&re[q]);
                block[(2 * q + 1) * n + i0..][..W].copy_from_slice(&im[q]);
            }
        }
    }
    *LaneBuf::<W>::lanes(s) = data;
}

/// `m` transposed (`out[c][r] = m[r][c]`): moves only, so every level gives the same bits. W = 4
/// and 8 use AVX2 / AVX-512 shuffles: `lanes_2d::<4>` runs only inside [`lanes_2d_avx2`] and
/// `lanes_2d::<8>` only inside [`lanes_2d_avx512`], where those instructions are enabled.
#[inline(always)]
fn transpose<const W: usize>(m: [[f64; W]; W]) -> [[f64; W]; W] {
    #[cfg(target_arch = "x86_64")]
    {
        if W == 8 {
            let a: [[f64; 8]; 8] = std::array::from_fn(|r| std::array::from_fn(|c| m[r][c]));
            // SAFETY: W = 8 only in `lanes_2d_avx512`, which runs where the CPU has AVX-512 F.
            let t = unsafe { transpose8_avx512(&a) };
            return std::array::from_fn(|r| std::array::from_fn(|c| t[r][c]));
        }
        if W == 4 {
            let a: [[f64; 4]; 4] = std::array::from_fn(|r| std::array::from_fn(|c| m[r][c]));
            // SAFETY: W = 4 only in `lanes_2d_avx2`, which runs where the CPU has AVX2.
            let t = unsafe { transpose4_avx2(&a) };
            return std::array::from_fn(|r| std::array::from_fn(|c| t[r][c]));
        }
    }
    std::array::from_fn(|c| std::array::from_fn(|r| m[r][c]))
}

/// 8 × 8 transpose in AVX-512 registers: pairs interleaved, then 2×2 and 4×4 blocks moved
/// with two-source permutes (24 shuffles, no arithmetic).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn transpose8_avx512(m: &[[f64; 8]; 8]) -> [[f64; 8]; 8] {
    use std::arch::x86_64::*;
    // SAFETY: every pointer is to an array of 8 f64 (unaligned loads and stores are allowed).
    unsafe {
        let r: [__m512d; 8] = std::array::from_fn(|i| _mm512_loadu_pd(m[i].as_ptr()));
        // t_lo(a, b) = [a0 b0 a2 b2 a4 b4 a6 b6], t_hi = [a1 b1 a3 b3 a5 b5 a7 b7].
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
        let cols = [
            perm(u[0], LOW, v[0]),
            perm(u[2], LOW, v[2]),
            perm(u[1], LOW, v[1]),
            perm(u[3], LOW, v[3]),
            perm(u[0], HIGH, v[0]),
            perm(u[2], HIGH, v[2]),
            perm(u[1], HIGH, v[1]),
            perm(u[3], HIGH, v[3]),
        ];
        let mut out = [[0.0; 8]; 8];
        for (o, c) in out.iter_mut().zip(cols) {
            _mm512_storeu_pd(o.as_mut_ptr(), c);
        }
        out
    }
}

/// 4 × 4 transpose in AVX2 registers (unpack, then swap 128-bit halves).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn transpose4_avx2(m: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    use std::arch::x86_64::*;
    // SAFETY: every pointer is to an array of 4 f64 (unaligned loads and stores are allowed).
    unsafe {
        let r: [__m256d; 4] = std::array::from_fn(|i| _mm256_loadu_pd(m[i].as_ptr()));
        let t0 = _mm256_unpacklo_pd(r[0], r[1]);
        let t1 = _mm256_unpackhi_pd(r[0], r[1]);
        let t2 = _mm256_unpacklo_pd(r[2], r[3]);
        let t3 = _mm256_unpackhi_pd(r[2], r[3]);
        let cols = [
            _mm256_permute2f128_pd(t0, t2, 0x20),
            _mm256_permute2f128_pd(t1, t3, 0x20),
            _mm256_permute2f128_pd(t0, t2, 0x31),
            _mm256_permute2f128_pd(t1, t3, 0x31),
        ];
        let mut out = [[0.0; 4]; 4];
        for (o, c) in out.iter_mut().zip(cols) {
            _mm256_storeu_pd(o.as_mut_ptr(), c);
        }
        out
    }
}

/// [`lanes_2d`] with two lanes, compiled for SSE2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
fn lanes_2d_sse2<F: FnMut(usize, &mut [Complex<f64>])>(
    fft: &LaneFft,
    scatter: &[u32],
    columns: Columns<'_, F>,
    s: &mut Scratch,
    out: &mut [f64],
) {
    lanes_2d::<2, F>(fft, scatter, columns, s, out);
}

/// [`lanes_2d`] with four lanes, compiled for AVX2 (never FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn lanes_2d_avx2<F: FnMut(usize, &mut [Complex<f64>])>(
    fft: &LaneFft,
    scatter: &[u32],
    columns: Columns<'_, F>,
    s: &mut Scratch,
    out: &mut [f64],
) {
    lanes_2d::<4, F>(fft, scatter, columns, s, out);
}

/// [`lanes_2d`] with eight lanes, compiled for AVX-512 F (never FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn lanes_2d_avx512<F: FnMut(usize, &mut [Complex<f64>])>(
    fft: &LaneFft,
    scatter: &[u32],
    columns: Columns<'_, F>,
    s: &mut Scratch,
    out: &mut [f64],
) {
    lanes_2d::<8, F>(fft, scatter, columns, s, out);
}

/// Row pairs packed, transformed and unpacked per block of the row pass: 8 pairs at N = 256 is
/// 32 KiB of packed rows plus 32 KiB of their transforms. Any value dividing N/2 (or ≥ N/2)
/// gives the same bits; this one measured fastest at 256².
const ROW_PAIRS: usize = 8;

/// Padding between packed rows, in complex entries: 4 (one 64-byte cache line) moves each row
/// to different L1 sets. The padding is never read.
const ROW_STRIDE_PAD: usize = 4;

#[cfg(test)]
mod tests {
    use super::*;

    /// The shuffle transposes move every value to its transposed place (where the CPU has them).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn shuffle_transposes_transpose() {
        let m8: [[f64; 8]; 8] =
            std::array::from_fn(|r| std::array::from_fn(|c| (r * 8 + c) as f64));
        let want8: [[f64; 8]; 8] = std::array::from_fn(|c| std::array::from_fn(|r| m8[r][c]));
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512 F, checked on the line above.
            assert_eq!(unsafe { transpose8_avx512(&m8) }, want8);
        }
        let m4: [[f64; 4]; 4] =
            std::array::from_fn(|r| std::array::from_fn(|c| (r * 4 + c) as f64));
        let want4: [[f64; 4]; 4] = std::array::from_fn(|c| std::array::from_fn(|r| m4[r][c]));
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked on the line above.
            assert_eq!(unsafe { transpose4_avx2(&m4) }, want4);
        }
    }
    use crate::math::{SwellRng, TAU, sin_cos};

    /// Random Hermitian spectrum with an empty Nyquist column, against a direct 2-D sum.
    #[test]
    fn matches_direct_inverse_dft() {
        let n = 16;
        let h = n / 2;
        let mut rng = SwellRng::new(99, 1);
        // Full spectrum F[m][n] (indices mod N), Hermitian, Nyquist column (m = N/2) empty.
        let mut full = vec![Complex::new(0.0, 0.0); n * n];
        for m in 0..n {
            for q in 0..n {
                if m == h {
                    continue;
                }
                let (mm, qq) = ((n - m) % n, (n - q) % n);
                if (m, q) <= (mm, qq) {
                    let (a, b) = rng.gaussian_pair();
                    let v = if (m, q) == (mm, qq) {
                        Complex::new(a, 0.0)
                    } else {
                        Complex::new(a, b)
                    };
                    full[m * n + q] = v;
                    full[mm * n + qq] = v.conj();
                }
            }
        }
        let half: Vec<_> = full[..h * n].to_vec();
        for backend in [FftBackend::Portable, FftBackend::Native] {
            let t = InverseRealFft2::new(n, backend);
            let mut s = t.scratch();
            let mut out = vec![0.0; n * n];
            t.process(&half, &mut s, &mut out);
            for j in 0..n {
                for i in 0..n {
                    let mut acc = Complex::new(0.0, 0.0);
                    for m in 0..n {
                        for q in 0..n {
                            let (sn, cs) = sin_cos(TAU * ((m * i + q * j) % n) as f64 / n as f64);
                            acc += full[m * n + q] * Complex::new(cs, sn);
                        }
                    }
                    assert!(acc.im.abs() < 1e-12);
                    assert!(
                        (acc.re - out[j * n + i]).abs() < 1e-12,
                        "{backend:?} {i} {j}"
                    );
                }
            }
        }
    }
}
