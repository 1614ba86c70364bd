//! The reference path: the Fourier series summed directly at one point, in f64.

use glam::{DVec2, DVec3};
use rustfft::num_complex::Complex;

use super::fields::FftGrid;
use super::layer::FftLayer;
use super::sample::FftSample;
use crate::math::{reduce_phase, sin_cos};

impl FftLayer {
    /// All eight fields at world point `p0 = (x, z)`, m, and time `t`, s, by direct summation
    /// over every kept wave vector: slow (O(N²) per point) and obviously correct.
    ///
    /// Uses the same h0(k), ω_q and time reduction as [`FftLayer::frame`]. The point is reduced
    /// exactly into the tile first (`x.rem_euclid(L)`, which is exact in f64, and the series
    /// has period L), then each term is `c(k)·h̃(k, t)·e^{i k·x}` with the phase `k·x` reduced by
    /// `reduce_phase` before `sin_cos`. Terms for k and −k are conjugate, so the sum runs over
    /// the half plane (m > 0, or m = 0 and n > 0) and takes twice the real part.
    pub fn sample_reference(&self, p0: DVec2, t: f64) -> FftSample {
        let n = self.n;
        let t_r = t.rem_euclid(self.repeat_period);
        let x = p0.x.rem_euclid(self.tile_size);
        let z = p0.y.rem_euclid(self.tile_size);
        let mut acc = [0.0f64; 8];
        for (idx, mode) in self.half.iter().enumerate() {
            let (m, q) = (idx / n, idx % n);
            // Column m = 0: only n = 1 … N/2 − 1 (stored at 1 … N/2 − 1); the rest are the
            // conjugates.
            if mode.is_empty() || (m == 0 && q >= n / 2) {
                continue;
            }
            let (s, c) = sin_cos(reduce_phase(mode.omega_q * t_r));
            let h = mode.evolve(s, c);
            let (sx, cx) = sin_cos(reduce_phase(mode.kx * x + mode.kz * z));
            let e = h * Complex::new(cx, sx);
            for grid in FftGrid::ALL {
                let v = grid.apply(mode.kx, mode.kz, mode.inv_k, self.choppiness, e);
                acc[grid.index()] += 2.0 * v.re;
            }
        }
        FftSample {
            displacement: DVec3::new(acc[1], acc[0], acc[2]),
            slope: DVec2::new(acc[3], acc[4]),
            jacobian: DVec3::new(acc[5], acc[6], acc[7]),
        }
    }
}

impl FftLayer {
    /// Orbital velocity `(vx, vy, vz)`, m/s, at undisplaced point `p0` and time `t` by direct
    /// summation: the reference for [`FftLayer::velocity_frame`]. Same reductions as
    /// [`FftLayer::sample_reference`], with `∂h̃/∂t` in place of `h̃`.
    pub fn velocity_reference(&self, p0: DVec2, t: f64) -> DVec3 {
        let n = self.n;
        let t_r = t.rem_euclid(self.repeat_period);
        let x = p0.x.rem_euclid(self.tile_size);
        let z = p0.y.rem_euclid(self.tile_size);
        let mut acc = [0.0f64; 3];
        for (idx, mode) in self.half.iter().enumerate() {
            let (m, q) = (idx / n, idx % n);
            if mode.is_empty() || (m == 0 && q >= n / 2) {
                continue;
            }
            let (s, c) = sin_cos(reduce_phase(mode.omega_q * t_r));
            let r = super::velocity::htilde_rate(mode, s, c);
            let (sx, cx) = sin_cos(reduce_phase(mode.kx * x + mode.kz * z));
            let e = r * Complex::new(cx, sx);
            for (slot, grid) in [
                FftGrid::DisplacementX,
                FftGrid::Height,
                FftGrid::DisplacementZ,
            ]
            .into_iter()
            .enumerate()
            {
                let v = grid.apply(mode.kx, mode.kz, mode.inv_k, self.choppiness, e);
                acc[slot] += 2.0 * v.re;
            }
        }
        DVec3::new(acc[0], acc[1], acc[2])
    }
}
