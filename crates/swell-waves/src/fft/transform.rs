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
//! order, so no transform needs a copy of its own: the columns from the spectrum, and the row
//! pairs from the column pass, which packs them as it finishes each block of columns. A frame
//! gathers h̃ into lanes once and forms each grid's column spectra from them, W columns per
//! vector operation ([`Spread`]). The buffers are 64-byte aligned, and at 8 lanes a grid that
//! is aligned too (a frame's are) is written with non-temporal stores.
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
use super::FftGrid;
use super::lanes::{C, Lane, LaneFft, Lanes};
use super::{AlignedVec, aligned};
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
    /// Native backend: one column's spectrum (N), made just before its transform.
    column: AlignedVec<Complex<f64>>,
    /// Native backend: one block of packed rows (ROW_PAIRS rows of N, ROW_STRIDE_PAD apart)
    /// and its transform, and RustFFT's scratch.
    rows_in: Vec<Complex<f64>>,
    rows_out: Vec<Complex<f64>>,
    fft: Vec<Complex<f64>>,
    /// Portable backend: N values of W lanes, for the width in use (only one is ever sized).
    lanes1: AlignedVec<C<1>>,
    lanes2: AlignedVec<C<2>>,
    lanes4: AlignedVec<C<4>>,
    lanes8: AlignedVec<C<8>>,
    /// Portable backend: the row pass's packed input Z (N/2 row pairs × N entries, N/2·N/W
    /// values of W lanes), made by the column pass and transformed in place by the row pass.
    /// Block b (row pairs bW … bW + W − 1, one per lane) is `[b·N .. (b+1)·N]`, entry m at
    /// the plan's position `scatter[m]`: each block is contiguous and already in gather order.
    rows1: AlignedVec<C<1>>,
    rows2: AlignedVec<C<2>>,
    rows4: AlignedVec<C<4>>,
    rows8: AlignedVec<C<8>>,
    /// Portable backend: h̃ in lanes for [`Spread`] (N/2·N/W values of W lanes; block b,
    /// columns bW … bW + W − 1, at `[b·N .. (b+1)·N]` in the plan's order), and the width it
    /// was gathered at (0: none yet).
    spread1: AlignedVec<C<1>>,
    spread2: AlignedVec<C<2>>,
    spread4: AlignedVec<C<4>>,
    spread8: AlignedVec<C<8>>,
    spread_width: usize,
    /// h̃(k, t) over the half plane (N/2·N), filled by the frame.
    pub(crate) htilde: AlignedVec<Complex<f64>>,
    /// `(sin, cos)` of each distinct frequency's phase at the frame's time (see
    /// `FftLayer::phase_omegas`); resized by the frame.
    pub(crate) phases: Vec<(f64, f64)>,
}

/// Where a 2-D transform's column spectra come from.
#[derive(Clone, Copy)]
enum Columns<'a> {
    /// A stored half spectrum, column m at `[m·N .. (m+1)·N]`.
    Half(&'a [Complex<f64>]),
    /// One grid of a frame: `c(k)·h̃` with `h̃` and the multiplier's parts in lane layout
    /// ([`Spread`]).
    Spread(Spread<'a>),
}

/// A frame's grid for the portable column pass: h̃ (half plane, column m at `[m·N ..]`), the
/// grid whose multiplier c(k) applies, and the layer's wave vectors in lane layout.
///
/// The first grid of a frame (`fresh`) gathers h̃ into lanes once, in the plan's order
/// (`Scratch::spread*`, one block of W columns after another); every grid then forms its
/// column spectra from those lanes, W columns per vector operation, straight into the
/// transform's input. Each lane does exactly [`FftGrid::apply_column`]'s operations on its
/// entry, so the bits are those of transforming the assembled spectrum (a test pins it).
#[derive(Clone, Copy)]
pub(crate) struct Spread<'a> {
    pub(crate) htilde: &'a [Complex<f64>],
    pub(crate) fresh: bool,
    pub(crate) grid: FftGrid,
    pub(crate) lambda: f64,
    pub(crate) waves: &'a SpreadWaves,
}

/// A layer's wave-vector parts laid out for [`Spread`]: `kx[m]` (`kx_cols`), `kz[p]` the kz of
/// the entry at plan position p (`kz_rows[gather[p]]`), and `inv_k[p·N/2 + m]` = `1/|k|` of
/// entry (m, gather[p]) (`inv_ks`, 0 for an empty entry), so the W columns of a block are W
/// consecutive values at every position.
#[derive(Clone, Debug)]
pub(crate) struct SpreadWaves {
    kx: Vec<f64>,
    kz: Vec<f64>,
    inv_k: AlignedVec<f64>,
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
        let (rows, fft_len, cols) = match &self.engine {
            Engine::Rust(fft) => (
                ROW_PAIRS.min(self.n / 2),
                fft.get_outofplace_scratch_len()
                    .max(fft.get_immutable_scratch_len()),
                half,
            ),
            Engine::Lanes { .. } => (0, 0, 0),
        };
        Scratch {
            cols: vec![zero; cols],
            column: AlignedVec::new(0),
            rows_in: vec![zero; rows * (self.n + ROW_STRIDE_PAD)],
            rows_out: vec![zero; rows * self.n],
            fft: vec![zero; fft_len],
            lanes1: AlignedVec::new(0),
            lanes2: AlignedVec::new(0),
            lanes4: AlignedVec::new(0),
            lanes8: AlignedVec::new(0),
            rows1: AlignedVec::new(0),
            rows2: AlignedVec::new(0),
            rows4: AlignedVec::new(0),
            rows8: AlignedVec::new(0),
            spread1: AlignedVec::new(0),
            spread2: AlignedVec::new(0),
            spread4: AlignedVec::new(0),
            spread8: AlignedVec::new(0),
            spread_width: 0,
            htilde: aligned(half, zero),
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
            Engine::Lanes { fft, scatter } => {
                self.dispatch(fft, scatter, Columns::Half(half), scratch, out)
            }
            Engine::Rust(fft) => {
                // Column pass straight from `half` into G: RustFFT's immutable form runs the
                // same algorithm as its in-place one.
                fft.process_immutable_with_scratch(half, &mut scratch.cols, &mut scratch.fft);
                self.row_pass_rust(fft, scratch, out);
            }
        }
    }

    /// The wave-vector parts of a layer laid out for [`Spread`] (portable backend; `None` for
    /// the native one, which multiplies column by column).
    pub(crate) fn spread_waves(
        &self,
        kx_cols: &[f64],
        kz_rows: &[f64],
        inv_ks: &[f64],
    ) -> Option<SpreadWaves> {
        let Engine::Lanes { fft, .. } = &self.engine else {
            return None;
        };
        let (n, h) = (self.n, self.n / 2);
        let gather = fft.gather_order();
        let mut inv_k = aligned(h * n, 0.0);
        for (p, &g) in gather.iter().enumerate() {
            for m in 0..h {
                inv_k[p * h + m] = inv_ks[m * n + g as usize];
            }
        }
        Some(SpreadWaves {
            kx: kx_cols.to_vec(),
            kz: gather.iter().map(|&g| kz_rows[g as usize]).collect(),
            inv_k,
        })
    }

    /// One grid of a frame into `out`: the transform of the half spectrum `c(k)·h̃` of `grid`
    /// ([`FftGrid::apply_column`] on the layer's `kx_cols`, `kz_rows`, `inv_ks`, choppiness
    /// `lambda`). `fresh` is true for a frame's first grid: h̃ changed since the last call with
    /// this scratch. The portable backend reads the multiplier's parts from `waves`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn process_grid(
        &self,
        grid: FftGrid,
        fresh: bool,
        htilde: &[Complex<f64>],
        (kx_cols, kz_rows, inv_ks): (&[f64], &[f64], &[f64]),
        lambda: f64,
        waves: Option<&SpreadWaves>,
        scratch: &mut Scratch,
        out: &mut [f64],
    ) {
        let n = self.n;
        match (&self.engine, waves) {
            (Engine::Lanes { fft, scatter }, Some(waves)) => {
                let spread = Spread {
                    htilde,
                    fresh,
                    grid,
                    lambda,
                    waves,
                };
                self.dispatch(fft, scatter, Columns::Spread(spread), scratch, out)
            }
            _ if grid == FftGrid::Height => self.process(htilde, scratch, out),
            (Engine::Rust(fft), _) => {
                scratch.column.resize(n, Complex::new(0.0, 0.0));
                for (m, g) in scratch.cols.chunks_exact_mut(n).enumerate() {
                    let span = m * n..(m + 1) * n;
                    grid.apply_column(
                        kx_cols[m],
                        kz_rows,
                        &inv_ks[span.clone()],
                        lambda,
                        &htilde[span],
                        &mut scratch.column,
                    );
                    fft.process_outofplace_with_scratch(&mut scratch.column, g, &mut scratch.fft);
                }
                self.row_pass_rust(fft, scratch, out);
            }
            (Engine::Lanes { .. }, None) => {
                // Not reached (a portable layer always has its spread waves); the assembled
                // spectrum gives the same bits.
                let mut half = aligned(n / 2 * n, Complex::new(0.0, 0.0));
                for (m, col) in half.chunks_exact_mut(n).enumerate() {
                    let span = m * n..(m + 1) * n;
                    let inv = &inv_ks[span.clone()];
                    grid.apply_column(kx_cols[m], kz_rows, inv, lambda, &htilde[span], col);
                }
                self.process(&half, scratch, out);
            }
        }
    }

    /// The portable 2-D transform at the level in use: the same bits at every level.
    #[inline(always)]
    fn dispatch(
        &self,
        fft: &LaneFft,
        scatter: &[u32],
        columns: Columns<'_>,
        s: &mut Scratch,
        out: &mut [f64],
    ) {
        match simd_level() {
            SimdLevel::Scalar => {
                // SAFETY: `[f64; 1]` lanes run on every CPU.
                unsafe { lanes_2d::<Lanes<1>, 1>(fft, scatter, columns, s, out) }
            }
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
            // SAFETY: `[f64; 1]` lanes run on every CPU.
            _ => unsafe { lanes_2d::<Lanes<1>, 1>(fft, scatter, columns, s, out) },
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

/// The lane buffers of width W in a scratch: one transform's values, and the row pass's input.
trait LaneBuf<const W: usize> {
    fn lanes(&mut self) -> &mut AlignedVec<C<W>>;
    fn rows(&mut self) -> &mut AlignedVec<C<W>>;
    fn spread(&mut self) -> &mut AlignedVec<C<W>>;
}
impl LaneBuf<1> for Scratch {
    fn lanes(&mut self) -> &mut AlignedVec<C<1>> {
        &mut self.lanes1
    }
    fn rows(&mut self) -> &mut AlignedVec<C<1>> {
        &mut self.rows1
    }
    fn spread(&mut self) -> &mut AlignedVec<C<1>> {
        &mut self.spread1
    }
}
impl LaneBuf<2> for Scratch {
    fn lanes(&mut self) -> &mut AlignedVec<C<2>> {
        &mut self.lanes2
    }
    fn rows(&mut self) -> &mut AlignedVec<C<2>> {
        &mut self.rows2
    }
    fn spread(&mut self) -> &mut AlignedVec<C<2>> {
        &mut self.spread2
    }
}
impl LaneBuf<4> for Scratch {
    fn lanes(&mut self) -> &mut AlignedVec<C<4>> {
        &mut self.lanes4
    }
    fn rows(&mut self) -> &mut AlignedVec<C<4>> {
        &mut self.rows4
    }
    fn spread(&mut self) -> &mut AlignedVec<C<4>> {
        &mut self.spread4
    }
}
impl LaneBuf<8> for Scratch {
    fn lanes(&mut self) -> &mut AlignedVec<C<8>> {
        &mut self.lanes8
    }
    fn rows(&mut self) -> &mut AlignedVec<C<8>> {
        &mut self.rows8
    }
    fn spread(&mut self) -> &mut AlignedVec<C<8>> {
        &mut self.spread8
    }
}

/// The portable 2-D inverse real transform with W 1-D transforms per step (module docs).
///
/// Column pass: columns `m0 … m0 + W − 1` are gathered into lanes in the plan's order (from a
/// stored half spectrum, or for a frame's grid from h̃'s lanes times the grid's multiplier,
/// see [`Spread`]) and transformed; the row pairs' packed input (`Z[m] = G_a[m] + i·G_b[m]`,
/// exactly the scalar packing's operations, W lanes per vector operation) is made from them at
/// once and stored, transposed to lanes of row pairs, in the plan's order (`Scratch::rows*`).
/// Row pass: each block of W row pairs is transformed in place and unpacked into `out`.
///
/// # Safety
/// V must have W lanes and the CPU its instructions (see [`LaneFft::run_simd`]); W = 8 and 4
/// mean AVX-512 F and AVX2 (the levels that use them).
#[inline(always)]
unsafe fn lanes_2d<V: Lane, const W: usize>(
    fft: &LaneFft,
    scatter: &[u32],
    columns: Columns<'_>,
    s: &mut Scratch,
    out: &mut [f64],
) where
    Scratch: LaneBuf<W>,
{
    let n = fft.len();
    let h = n / 2;
    debug_assert_eq!(out.len(), n * n);
    let mut data = std::mem::replace(LaneBuf::<W>::lanes(s), AlignedVec::new(0));
    data.resize(n, C::ZERO);
    let mut zs = std::mem::replace(LaneBuf::<W>::rows(s), AlignedVec::new(0));
    zs.resize(h * n / W, C::ZERO);
    let mut spread = std::mem::replace(LaneBuf::<W>::spread(s), AlignedVec::new(0));
    // At 8 lanes the grid is written with non-temporal stores when it starts on a 64-byte
    // boundary (a frame's grids do): its N² values would otherwise be read into the cache
    // before being overwritten, and push the transform's working set out of L2. Each store is
    // then a whole cache line; at 4 lanes (half lines, eight rows in flight) streaming was
    // slower than plain stores (1.9 against 1.4 ms a frame at the AVX2 level).
    let stream = W == 8 && out.as_ptr().cast::<u8>().align_offset(64) == 0;
    // A frame's first grid, or a width other than the lanes were gathered at (the level is
    // process-wide and may change between calls), gathers h̃ again.
    let gather_spread = match &columns {
        Columns::Spread(sp) if sp.fresh || s.spread_width != W => {
            spread.resize(h * n / W, C::ZERO);
            true
        }
        _ => false,
    };
    for m0 in (0..h).step_by(W) {
        let block = m0 / W * n..(m0 / W + 1) * n;
        match &columns {
            Columns::Half(half) => {
                // SAFETY: V's instructions are available (this function's contract).
                unsafe {
                    gather_columns::<V, W>(&half[m0 * n..(m0 + W) * n], fft, scatter, &mut data)
                }
            }
            Columns::Spread(sp) => {
                let lanes = &mut spread[block];
                if gather_spread {
                    // SAFETY: as above.
                    unsafe {
                        gather_columns::<V, W>(
                            &sp.htilde[m0 * n..(m0 + W) * n],
                            fft,
                            scatter,
                            lanes,
                        )
                    }
                }
                // SAFETY: as above.
                unsafe { multiply_columns::<V, W>(sp, m0, lanes, &mut data) };
            }
        }
        // SAFETY: V's instructions are available (this function's contract).
        unsafe { fft.run_simd::<V, W>(&mut data) };
        // The row pass's input, made here while G's columns are in lanes: for each row pair p
        // (rows a = 2p, b = 2p + 1), Z[m] = G_a[m] + i·G_b[m] and Z[N − m] = conj(G_a[m]) +
        // i·conj(G_b[m]) in the scalar packing's operations, then W × W transposes turn lanes
        // of columns into lanes of row pairs, stored at the entries' places in the plan's order.
        // Where lane l's entries go in every block: Z[m] to `scatter[m]`, Z[N − m] to
        // `scatter[N − m]`; m = 0 has no Z[N − 0], so its row goes to a sink.
        let at_pos: [usize; W] = std::array::from_fn(|l| scatter[m0 + l] as usize);
        let at_neg: [Option<usize>; W] =
            std::array::from_fn(|l| (m0 + l > 0).then(|| scatter[n - m0 - l] as usize));
        let mut sink = C::<W>::ZERO;
        let sink: *mut C<W> = &mut sink;
        for (jb, block) in data.chunks_exact(2 * W).enumerate() {
            let base = zs[jb * n..(jb + 1) * n].as_mut_ptr();
            // Four W × W blocks, each made in registers and stored transposed: Re Z[m],
            // Im Z[m], Re Z[N − m], Im Z[N − m] of the W row pairs r (rows 2r, 2r + 1).
            for part in 0..4 {
                let mut rows = [V::splat(0.0); W];
                for (r, row) in rows.iter_mut().enumerate() {
                    let (ga, gb) = (&block[2 * r], &block[2 * r + 1]);
                    // SAFETY: each array holds W f64, V's lane count (this function's contract).
                    let (are, aim, bre, bim) = unsafe {
                        (
                            V::load(ga.re.as_ptr()),
                            V::load(ga.im.as_ptr()),
                            V::load(gb.re.as_ptr()),
                            V::load(gb.im.as_ptr()),
                        )
                    };
                    *row = match part {
                        // m = 0 (lane 0 of the first batch): Z[0] = (G_a[0].re, G_b[0].re),
                        // real up to rounding.
                        0 if m0 == 0 => are.sub(bim).with_lane0(are),
                        0 => are.sub(bim),
                        1 if m0 == 0 => aim.add(bre).with_lane0(bre),
                        1 => aim.add(bre),
                        2 => are.add(bim),
                        _ => bre.sub(aim),
                    };
                }
                let to: [*mut f64; W] = std::array::from_fn(|l| {
                    let d: *mut C<W> = match (part < 2, at_neg[l]) {
                        // SAFETY: scatter[k] < n = the block's length for k < n (m < h).
                        (true, _) => unsafe { base.add(at_pos[l]) },
                        (false, Some(at)) => unsafe { base.add(at) },
                        (false, None) => sink,
                    };
                    // SAFETY: `d` points to a live C<W> (of `zs` or the sink).
                    unsafe {
                        if part % 2 == 1 {
                            std::ptr::addr_of_mut!((*d).im).cast::<f64>()
                        } else {
                            std::ptr::addr_of_mut!((*d).re).cast::<f64>()
                        }
                    }
                });
                // SAFETY: V has W lanes; each destination is the re or im array (W f64) of a
                // distinct entry (scatter is a permutation, and m, N − m and the sink never
                // coincide).
                unsafe { V::transpose_store(rows, to) };
            }
        }
    }
    for (jb, zblock) in zs.chunks_exact_mut(n).enumerate() {
        let a0 = 2 * W * jb;
        // m = N/2: the empty Nyquist entry.
        zblock[scatter[h] as usize] = C::ZERO;
        // SAFETY: V's instructions are available (this function's contract).
        unsafe { fft.run_simd::<V, W>(zblock) };
        // Unpacked W outputs at a time: a W × W transpose per part, written W values per row.
        let block = &mut out[a0 * n..(a0 + 2 * W) * n];
        assert_eq!(block.len(), 2 * W * n);
        let out_base = block.as_mut_ptr();
        for (i0, d) in (0..n).step_by(W).zip(zblock.chunks_exact(W)) {
            for im in [false, true] {
                let mut rows = [V::splat(0.0); W];
                for (row, x) in rows.iter_mut().zip(d) {
                    let part = if im { &x.im } else { &x.re };
                    // SAFETY: W f64, V's lane count (this function's contract).
                    *row = unsafe { V::load(part.as_ptr()) };
                }
                // SAFETY: (2q + 1)·n + i0 + W ≤ 2·W·n for q < W and i0 + W ≤ n.
                let to: [*mut f64; W] = std::array::from_fn(|q| unsafe {
                    out_base.add((2 * q + usize::from(im)) * n + i0)
                });
                // SAFETY: V has W lanes; W disjoint rows of W f64 written in `out`, each
                // aligned to W f64 where `stream` (the grid starts on a 64-byte boundary and
                // every row offset is a multiple of W f64).
                unsafe {
                    if stream {
                        V::transpose_stream(rows, to)
                    } else {
                        V::transpose_store(rows, to)
                    }
                }
            }
        }
    }
    if stream {
        V::fence();
    }
    *LaneBuf::<W>::lanes(s) = data;
    *LaneBuf::<W>::rows(s) = zs;
    *LaneBuf::<W>::spread(s) = spread;
    if gather_spread {
        s.spread_width = W;
    }
}

/// Gathers W columns (`src`, N entries each, back to back) into lanes in the plan's order:
/// `dst[scatter[k]]` lane l = `src[l·N + k]`.
///
/// # Safety
/// V must have W lanes and the CPU its instructions.
#[inline(always)]
unsafe fn gather_columns<V: Lane, const W: usize>(
    src: &[Complex<f64>],
    fft: &LaneFft,
    scatter: &[u32],
    dst: &mut [C<W>],
) {
    let n = fft.len();
    if W >= 2 {
        // W/2 consecutive entries of the W columns are a W × W block of f64 (re, im
        // interleaved): transposed, its rows are the lanes' real and imaginary parts of
        // those entries, each stored whole at the entry's place in the plan's order.
        let half = W / 2;
        assert!(src.len() >= W * n && dst.len() >= n && scatter.len() >= n);
        let base = dst.as_mut_ptr();
        for k0 in (0..n).step_by(half) {
            let mut rows = [V::splat(0.0); W];
            for (l, row) in rows.iter_mut().enumerate() {
                // Complex<f64> is repr(C) (re, im): W/2 entries are W f64 in a row.
                let from = src[l * n + k0..][..half].as_ptr().cast::<f64>();
                // SAFETY: W f64 of `src` (asserted above), V's lane count.
                *row = unsafe { V::load(from) };
            }
            let to: [*mut f64; W] = std::array::from_fn(|c| {
                // SAFETY: scatter[k] < n = dst.len() (a permutation of 0..n), so `d`
                // points to a live element of `dst`.
                unsafe {
                    let d = base.add(scatter[k0 + c / 2] as usize);
                    if c % 2 == 0 {
                        std::ptr::addr_of_mut!((*d).re).cast::<f64>()
                    } else {
                        std::ptr::addr_of_mut!((*d).im).cast::<f64>()
                    }
                }
            });
            // SAFETY: V has W lanes; each destination row is the re or im array (W f64) of a
            // distinct element of `dst` (scatter is a permutation).
            unsafe { V::transpose_store(rows, to) };
        }
    } else {
        for (d, &k) in dst.iter_mut().zip(fft.gather_order()) {
            for l in 0..W {
                let v = src[l * n + k as usize];
                d.re[l] = v.re;
                d.im[l] = v.im;
            }
        }
    }
}

/// The column spectra `c(k)·h̃` of columns `m0 … m0 + W − 1` for `sp.grid`, from h̃'s lanes
/// (`lanes`, the block's N positions in the plan's order) into `data`: per lane, exactly
/// [`FftGrid::apply_column`]'s operations (the factor formed left to right, `(−(r·h.im),
/// r·h.re)` or `(r·h.re, r·h.im)`, and the empty entry's constant where `1/|k| = 0`).
///
/// # Safety
/// V must have W lanes and the CPU its instructions.
#[inline(always)]
unsafe fn multiply_columns<V: Lane, const W: usize>(
    sp: &Spread<'_>,
    m0: usize,
    lanes: &[C<W>],
    data: &mut [C<W>],
) {
    /// `data[p] = c·h` with c = i·r (`IMAG`) or r, r = `factor(kz, 1/|k|)` per lane.
    ///
    /// # Safety
    /// As [`multiply_columns`].
    #[inline(always)]
    unsafe fn run<V: Lane, const W: usize, const IMAG: bool>(
        factor: impl Fn(V, V) -> V,
        empty: Complex<f64>,
        waves: &SpreadWaves,
        m0: usize,
        lanes: &[C<W>],
        data: &mut [C<W>],
    ) {
        let h = waves.kx.len();
        let n = lanes.len();
        assert!(data.len() == n && waves.kz.len() == n && waves.inv_k.len() == h * n);
        assert!(m0 + W <= h);
        let (empty_re, empty_im) = (V::splat(empty.re), V::splat(empty.im));
        for p in 0..n {
            // SAFETY: p < n and m0 + W ≤ h (asserted), so the W values at p·h + m0 are inside
            // `inv_k`; each lane array holds W f64, V's lane count (the caller's contract).
            unsafe {
                let inv_k = V::load(waves.inv_k.as_ptr().add(p * h + m0));
                let r = factor(V::splat(*waves.kz.get_unchecked(p)), inv_k);
                let x = lanes.get_unchecked(p);
                let (hre, him) = (V::load(x.re.as_ptr()), V::load(x.im.as_ptr()));
                let (re, im) = if IMAG {
                    (r.mul(him).neg(), r.mul(hre))
                } else {
                    (r.mul(hre), r.mul(him))
                };
                let d = data.get_unchecked_mut(p);
                V::where_zero(inv_k, empty_re, re).store(d.re.as_mut_ptr());
                V::where_zero(inv_k, empty_im, im).store(d.im.as_mut_ptr());
            }
        }
    }
    let g = sp.grid;
    let empty = g.apply(0.0, 0.0, 0.0, sp.lambda, Complex::new(0.0, 0.0));
    let w = sp.waves;
    assert!(m0 + W <= w.kx.len());
    // SAFETY: W f64 of `kx` at m0 (asserted).
    let kx = unsafe { V::load(w.kx.as_ptr().add(m0)) };
    let lambda = V::splat(sp.lambda);
    // λ·kx once per block: the same operation, so the same bits, as per entry.
    let lkx = lambda.mul(kx);
    // SAFETY (each arm): the caller's contract.
    unsafe {
        match g {
            FftGrid::Height => data.copy_from_slice(lanes),
            FftGrid::DisplacementX => {
                run::<V, W, true>(|_, ik| lkx.mul(ik), empty, w, m0, lanes, data)
            }
            FftGrid::DisplacementZ => {
                run::<V, W, true>(|kz, ik| lambda.mul(kz).mul(ik), empty, w, m0, lanes, data)
            }
            FftGrid::SlopeX => run::<V, W, true>(|_, _| kx, empty, w, m0, lanes, data),
            FftGrid::SlopeZ => run::<V, W, true>(|kz, _| kz, empty, w, m0, lanes, data),
            FftGrid::DxDx => {
                run::<V, W, false>(|_, ik| lkx.mul(kx).mul(ik).neg(), empty, w, m0, lanes, data)
            }
            FftGrid::DzDz => run::<V, W, false>(
                |kz, ik| lambda.mul(kz).mul(kz).mul(ik).neg(),
                empty,
                w,
                m0,
                lanes,
                data,
            ),
            FftGrid::DxDz => run::<V, W, false>(
                |kz, ik| lkx.mul(kz).mul(ik).neg(),
                empty,
                w,
                m0,
                lanes,
                data,
            ),
        }
    }
}

/// [`lanes_2d`] with two lanes, compiled for SSE2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
fn lanes_2d_sse2(
    fft: &LaneFft,
    scatter: &[u32],
    columns: Columns<'_>,
    s: &mut Scratch,
    out: &mut [f64],
) {
    // SAFETY: this function is compiled for SSE2, which its callers checked; `__m128d`
    // holds 2 f64.
    unsafe { lanes_2d::<std::arch::x86_64::__m128d, 2>(fft, scatter, columns, s, out) }
}

/// [`lanes_2d`] with four lanes, compiled for AVX2 (never FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn lanes_2d_avx2(
    fft: &LaneFft,
    scatter: &[u32],
    columns: Columns<'_>,
    s: &mut Scratch,
    out: &mut [f64],
) {
    // SAFETY: this function is compiled for AVX2, which its callers checked; `__m256d`
    // holds 4 f64.
    unsafe { lanes_2d::<std::arch::x86_64::__m256d, 4>(fft, scatter, columns, s, out) }
}

/// [`lanes_2d`] with eight lanes, compiled for AVX-512 F (never FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn lanes_2d_avx512(
    fft: &LaneFft,
    scatter: &[u32],
    columns: Columns<'_>,
    s: &mut Scratch,
    out: &mut [f64],
) {
    // SAFETY: this function is compiled for AVX-512 F, which its callers checked; `__m512d`
    // holds 8 f64.
    unsafe { lanes_2d::<std::arch::x86_64::__m512d, 8>(fft, scatter, columns, s, out) }
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
    use crate::math::{SwellRng, TAU, sin_cos};

    /// Every lane width this CPU has gives the scalar grid's bits, for a stored spectrum and
    /// for each frame grid made from h̃'s lanes ([`Spread`]), whatever `simd_level` says; and
    /// a [`Spread`] grid has the bits of transforming its assembled spectrum
    /// (`FftGrid::apply_column`, empty entries included).
    #[test]
    fn every_width_gives_the_scalar_bits() {
        type Run<'r> = &'r dyn Fn(Columns<'_>, &mut Scratch, &mut [f64]);
        for n in [16, 64, 256] {
            let h = n / 2;
            let mut rng = SwellRng::new(n as u64, 4);
            let mut half: Vec<Complex<f64>> = (0..h * n)
                .map(|_| {
                    let (a, b) = rng.gaussian_pair();
                    Complex::new(a, b)
                })
                .collect();
            let kx: Vec<f64> = (0..h).map(|m| m as f64 * 0.3).collect();
            let kz: Vec<f64> = (0..n).map(|_| rng.gaussian_pair().0).collect();
            let mut inv_k: Vec<f64> = (0..h * n)
                .map(|i| 1.0 / (kx[i / n].powi(2) + kz[i % n].powi(2)).sqrt())
                .collect();
            // Empty entries as a layer stores them: 1/|k| = 0 and h̃ = 0, the DC entry among
            // them, and a few more.
            for i in [0, 3, n + 5, h * n - 1] {
                inv_k[i] = 0.0;
                half[i] = Complex::new(0.0, 0.0);
            }
            let t = InverseRealFft2::new(n, FftBackend::Portable);
            let Engine::Lanes { fft, scatter } = &t.engine else {
                unreachable!("a portable plan");
            };
            let waves = t.spread_waves(&kx, &kz, &inv_k).expect("portable");
            let lambda = 1.3;
            let mut cases: Vec<Option<FftGrid>> = vec![None];
            cases.extend(FftGrid::ALL.map(Some));
            for case in cases {
                // Each run uses a fresh scratch, so its first grid gathers h̃ (`fresh`).
                let grid = |run: Run<'_>| -> Vec<u64> {
                    let columns = match case {
                        None => Columns::Half(&half),
                        Some(grid) => Columns::Spread(Spread {
                            htilde: &half,
                            fresh: true,
                            grid,
                            lambda,
                            waves: &waves,
                        }),
                    };
                    // Into a grid on a 64-byte boundary (non-temporal stores) and into one
                    // 8 bytes past it (plain stores): the same bits.
                    let mut buf = aligned(n * n + 1, f64::NAN);
                    let mut s = t.scratch();
                    run(columns, &mut s, &mut buf[..n * n]);
                    let streamed: Vec<u64> = buf[..n * n].iter().map(|v| v.to_bits()).collect();
                    let columns = match columns {
                        Columns::Spread(sp) => Columns::Spread(Spread { fresh: false, ..sp }),
                        c => c,
                    };
                    run(columns, &mut s, &mut buf[1..]);
                    let stored: Vec<u64> = buf[1..].iter().map(|v| v.to_bits()).collect();
                    assert!(streamed == stored, "n = {n}, {case:?}: stored != streamed");
                    stored
                };
                // SAFETY: `[f64; 1]` lanes run on every CPU.
                let want =
                    grid(&|c, s, o| unsafe { lanes_2d::<Lanes<1>, 1>(fft, scatter, c, s, o) });
                let check = |name: &str, got: Vec<u64>| {
                    assert!(got == want, "n = {n}, {case:?}: {name} differs from scalar");
                };
                if let Some(g) = case {
                    let mut assembled = vec![Complex::new(0.0, 0.0); h * n];
                    for (m, col) in assembled.chunks_exact_mut(n).enumerate() {
                        let span = m * n..(m + 1) * n;
                        g.apply_column(kx[m], &kz, &inv_k[span.clone()], lambda, &half[span], col);
                    }
                    let (mut s, mut out) = (t.scratch(), vec![f64::NAN; n * n]);
                    t.process(&assembled, &mut s, &mut out);
                    check(
                        "the assembled spectrum",
                        out.iter().map(|v| v.to_bits()).collect(),
                    );
                }
                #[cfg(target_arch = "x86_64")]
                {
                    use std::arch::is_x86_feature_detected as has;
                    // SAFETY (each call): the CPU has the path's features, checked just before
                    // (every x86-64 CPU has SSE2).
                    check(
                        "sse2",
                        grid(&|c, s, o| unsafe { lanes_2d_sse2(fft, scatter, c, s, o) }),
                    );
                    if has!("avx2") {
                        check(
                            "avx2",
                            grid(&|c, s, o| unsafe { lanes_2d_avx2(fft, scatter, c, s, o) }),
                        );
                    }
                    if has!("avx512f") {
                        check(
                            "avx512",
                            grid(&|c, s, o| unsafe { lanes_2d_avx512(fft, scatter, c, s, o) }),
                        );
                    }
                }
            }
        }
    }

    /// A frame's later grids read h̃'s lanes gathered by its first; a scratch whose lanes were
    /// gathered at another width (the level changed between calls) gathers them again.
    #[test]
    fn spread_lanes_are_regathered_for_another_width() {
        let n = 64;
        let mut rng = SwellRng::new(8, 2);
        let mk = |rng: &mut SwellRng| -> Vec<Complex<f64>> {
            (0..n / 2 * n)
                .map(|_| {
                    let (a, b) = rng.gaussian_pair();
                    Complex::new(a, b)
                })
                .collect()
        };
        let (first, second) = (mk(&mut rng), mk(&mut rng));
        let kx: Vec<f64> = (0..n / 2).map(|m| m as f64).collect();
        let kz: Vec<f64> = (0..n).map(|q| q as f64 - 7.0).collect();
        let inv_k = vec![0.5; n / 2 * n];
        let t = InverseRealFft2::new(n, FftBackend::Portable);
        let Engine::Lanes { fft, scatter } = &t.engine else {
            unreachable!("a portable plan");
        };
        let waves = t.spread_waves(&kx, &kz, &inv_k).expect("portable");
        let spread = |htilde, fresh| {
            Columns::Spread(Spread {
                htilde,
                fresh,
                grid: FftGrid::SlopeX,
                lambda: 1.0,
                waves: &waves,
            })
        };
        let bits = |o: &[f64]| -> Vec<u64> { o.iter().map(|v| v.to_bits()).collect() };
        let mut want = vec![0.0; n * n];
        let mut s = t.scratch();
        // SAFETY: `[f64; 1]` lanes run on every CPU.
        unsafe { lanes_2d::<Lanes<1>, 1>(fft, scatter, spread(&second, true), &mut s, &mut want) };
        // Lanes of `first` at width 1, then `second` at width 2 without `fresh`: the width
        // changed, so `second` is gathered.
        let mut s = t.scratch();
        let mut out = vec![0.0; n * n];
        // SAFETY: as above.
        unsafe { lanes_2d::<Lanes<1>, 1>(fft, scatter, spread(&first, true), &mut s, &mut out) };
        // SAFETY: `[f64; 2]` lanes run on every CPU.
        unsafe { lanes_2d::<Lanes<2>, 2>(fft, scatter, spread(&second, false), &mut s, &mut out) };
        assert_eq!(bits(&out), bits(&want));
        // And not `fresh` at the same width: the lanes gathered last (`second`) are read.
        // SAFETY: as above.
        unsafe { lanes_2d::<Lanes<2>, 2>(fft, scatter, spread(&first, false), &mut s, &mut out) };
        assert_eq!(bits(&out), bits(&want));
    }

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
