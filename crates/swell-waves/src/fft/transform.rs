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
//! All N/2 columns go through RustFFT in one call (its buffers may hold several transforms back
//! to back), and likewise the N/2 packed rows.
//!
//! We do not use the `realfft` crate: it only plans through RustFFT's SIMD `FftPlanner`, so the
//! portable backend (the scalar planner, identical bits on every CPU) could not use it.

use std::sync::{Arc, Mutex};

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner, FftPlannerScalar};

use super::FftBackend;

/// Plans and scratch sizes for inverse real 2-D transforms of one size, and a pool of working
/// memory so that a frame allocates only the grids it returns.
pub(crate) struct InverseRealFft2 {
    n: usize,
    fft: Arc<dyn Fft<f64>>,
    /// Scratch returned by finished frames. Frames on several threads each take their own (the
    /// pool grows to the number of concurrent frames and no further); the buffers' contents
    /// never reach a result, so reuse cannot change one.
    pool: Mutex<Vec<Scratch>>,
}

impl Clone for InverseRealFft2 {
    fn clone(&self) -> Self {
        Self {
            n: self.n,
            fft: Arc::clone(&self.fft),
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
/// calls and fields.
pub(crate) struct Scratch {
    rows: Vec<Complex<f64>>,
    fft: Vec<Complex<f64>>,
    /// h̃(k, t) over the half plane (N/2·N), filled by the frame.
    pub(crate) htilde: Vec<Complex<f64>>,
    /// `(sin, cos)` of each distinct frequency's phase at the frame's time (see
    /// `FftLayer::phase_omegas`); resized by the frame.
    pub(crate) phases: Vec<(f64, f64)>,
    /// One field's half spectrum (N/2·N), overwritten by the column pass.
    pub(crate) spectrum: Vec<Complex<f64>>,
}

impl InverseRealFft2 {
    /// Plans the length-`n` inverse transform with the backend's planner (`n` even, ≥ 2).
    pub(crate) fn new(n: usize, backend: FftBackend) -> Self {
        let fft = match backend {
            FftBackend::Portable => FftPlannerScalar::new().plan_fft_inverse(n),
            FftBackend::Native => FftPlanner::new().plan_fft_inverse(n),
        };
        Self {
            n,
            fft,
            pool: Mutex::new(Vec::new()),
        }
    }

    /// Fresh working memory sized for this transform.
    pub(crate) fn scratch(&self) -> Scratch {
        let zero = Complex::new(0.0, 0.0);
        let half = self.n / 2 * self.n;
        Scratch {
            rows: vec![zero; half],
            fft: vec![zero; self.fft.get_inplace_scratch_len()],
            htilde: vec![zero; half],
            phases: Vec::new(),
            spectrum: vec![zero; half],
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
    /// entry n (wrapped: index `n mod N`) along kz; it is overwritten. The missing Nyquist column
    /// is taken as zero. `out[j·N + i]` receives f at `x = i·L/N`, `z = j·L/N`.
    pub(crate) fn process(
        &self,
        half: &mut [Complex<f64>],
        scratch: &mut Scratch,
        out: &mut [f64],
    ) {
        let n = self.n;
        let h = n / 2;
        debug_assert_eq!(half.len(), h * n);
        debug_assert_eq!(out.len(), n * n);
        // Column pass: G[m, j] in place.
        self.fft.process_with_scratch(half, &mut scratch.fft);
        // Pack row pairs.
        for p in 0..h {
            let (a, b) = (2 * p, 2 * p + 1);
            let row = &mut scratch.rows[p * n..(p + 1) * n];
            row[0] = Complex::new(half[a].re, half[b].re);
            row[h] = Complex::new(0.0, 0.0);
            for m in 1..h {
                let ga = half[m * n + a];
                let gb = half[m * n + b];
                row[m] = Complex::new(ga.re - gb.im, ga.im + gb.re);
                row[n - m] = Complex::new(ga.re + gb.im, gb.re - ga.im);
            }
        }
        // Row pass.
        self.fft
            .process_with_scratch(&mut scratch.rows, &mut scratch.fft);
        for p in 0..h {
            let row = &scratch.rows[p * n..(p + 1) * n];
            let (lo, hi) = out[2 * p * n..(2 * p + 2) * n].split_at_mut(n);
            for i in 0..n {
                lo[i] = row[i].re;
                hi[i] = row[i].im;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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
            let mut buf = half.clone();
            t.process(&mut buf, &mut s, &mut out);
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
