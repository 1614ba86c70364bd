//! Orbital velocity grids of an FFT layer: the time derivative of the displaced surface point.
//!
//! With `h̃(k, t) = h0(k)·e^{−iω_q t} + conj(h0(−k))·e^{+iω_q t}` (see [`super::FftLayer::frame`]),
//! `∂h̃/∂t = −iω_q·h0(k)·e^{−iω_q t} + iω_q·conj(h0(−k))·e^{+iω_q t}`, with the same quantised
//! ω_q as the frame's phase, so velocity and displacement are exactly consistent. The velocity of
//! the water particle at the surface, at undisplaced point p0, is
//! `(∂Dx/∂t, ∂h/∂t, ∂Dz/∂t) = Σ_k c(k)·∂h̃/∂t·e^{i k·x}` with the multipliers c(k) of the
//! `DisplacementX`, `Height` and `DisplacementZ` grids ([`super::FftGrid`]).
//!
//! These grids are not part of [`super::FftFields`]: a frame never computes them unless asked
//! through [`super::FftLayer::velocity_frame`], which costs one extra 2-D inverse transform for a
//! height field (choppiness 0) and three for a choppy layer.

use glam::{DVec2, DVec3};
use rustfft::num_complex::Complex;

use super::fields::{FftFields, FftGrid};
use super::frame::FftFrame;
use super::layer::{FftLayer, Mode};
use super::sample::SampleFilter;
use crate::math::{reduce_phase, sin_cos};

/// `∂h̃/∂t` of one mode, given `(s, c) = sin_cos(reduce_phase(ω_q·t_r))`.
///
/// Bit-level recipe, with h0 = a + ib, h0(−k) = p + iq (compare [`Mode::evolve`]):
/// `re = ω_q·((b·c − a·s) − (p·s − q·c))`, `im = ω_q·((p·c + q·s) − (a·c + b·s))`.
#[inline]
pub(crate) fn htilde_rate(mode: &Mode, s: f64, c: f64) -> Complex<f64> {
    let (a, b) = (mode.h0.re, mode.h0.im);
    let (p, q) = (mode.h0_neg.re, mode.h0_neg.im);
    let w = mode.omega_q;
    Complex::new(
        w * ((b * c - a * s) - (p * s - q * c)),
        w * ((p * c + q * s) - (a * c + b * s)),
    )
}

/// The orbital velocity grids of an FFT layer at one time.
///
/// Internally an [`FftFrame`] whose `Height` grid holds `∂h/∂t` and whose `DisplacementX` /
/// `DisplacementZ` grids hold `∂Dx/∂t`, `∂Dz/∂t` (absent, i.e. zero, for a non-choppy layer), so
/// sampling uses exactly the filters of [`FftFrame::sample`].
#[derive(Debug, Clone)]
pub struct FftVelocityFrame {
    frame: FftFrame,
}

impl FftVelocityFrame {
    /// The time asked for, s.
    pub fn t(&self) -> f64 {
        self.frame.t()
    }

    /// Number of 2-D inverse transforms this frame cost (1 for a height field, 3 if choppy).
    pub fn transforms(&self) -> usize {
        self.frame.transforms()
    }

    /// Velocity `(vx, vy, vz)`, m/s, of the surface particle whose undisplaced position is
    /// `p0 = (x, z)`, read with `filter` (see [`FftFrame::sample`]).
    pub fn sample(&self, p0: DVec2, filter: SampleFilter) -> DVec3 {
        self.frame
            .sample_some(p0, filter, super::FftReads::Displacement)
            .displacement
    }
}

impl FftLayer {
    /// The orbital velocity grids at time `t`, s: the time derivative of the displacement
    /// series, `Σ_k c(k)·∂h̃/∂t·e^{i k·x}` with
    /// `∂h̃/∂t = −iω_q·h0(k)·e^{−iω_q t} + iω_q·conj(h0(−k))·e^{+iω_q t}` and the multipliers
    /// c(k) of the `Height`, `DisplacementX`, `DisplacementZ` grids. Time is reduced modulo the
    /// repeat period exactly as in [`FftLayer::frame`], so velocity frames at `t` and `t + T`
    /// are bit-identical. Deterministic with the portable backend.
    pub fn velocity_frame(&self, t: f64) -> FftVelocityFrame {
        let n = self.n;
        let t_r = t.rem_euclid(self.repeat_period);
        let choppy = self.choppiness > 0.0;
        let zero = Complex::new(0.0, 0.0);
        // One sin_cos per distinct ω_q, gathered per entry: the bits of the per-entry phase (see
        // `FftLayer::frame_into`).
        let phases: Vec<(f64, f64)> = self
            .phase_omegas
            .iter()
            .map(|&w| sin_cos(reduce_phase(w * t_r)))
            .collect();
        let rate: Vec<Complex<f64>> = self
            .half
            .iter()
            .zip(&self.phase_index)
            .map(|(mode, &ix)| {
                if mode.is_empty() {
                    return zero;
                }
                let (s, c) = phases[ix as usize];
                htilde_rate(mode, s, c)
            })
            .collect();
        let grids: &[FftGrid] = if choppy {
            &[
                FftGrid::Height,
                FftGrid::DisplacementX,
                FftGrid::DisplacementZ,
            ]
        } else {
            &[FftGrid::Height]
        };
        let mut out_grids: [Option<Vec<f64>>; 8] = Default::default();
        let mut buf = vec![zero; rate.len()];
        let mut scratch = self.transform.scratch();
        for &grid in grids {
            for (m, col) in buf.chunks_exact_mut(n).enumerate() {
                let span = m * n..(m + 1) * n;
                let (inv_k, rate) = (&self.inv_ks[span.clone()], &rate[span]);
                let kx = self.kx_cols[m];
                grid.apply_column(kx, &self.kz_rows, inv_k, self.choppiness, rate, col);
            }
            let mut out = vec![0.0; n * n];
            self.transform.process(&buf, &mut scratch, &mut out);
            out_grids[grid.index()] = Some(out);
        }
        let fields = if choppy {
            FftFields::HEIGHT.union(FftFields::DISPLACEMENT)
        } else {
            FftFields::HEIGHT
        };
        FftVelocityFrame {
            frame: FftFrame {
                t,
                fields,
                n,
                tile_size: self.tile_size,
                grids: out_grids,
                transforms: grids.len(),
                pool: None,
            },
        }
    }
}
