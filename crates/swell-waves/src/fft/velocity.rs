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
//!
//! [`super::FftLayer::grid_velocity_frame`] gives the same grids for nothing but a subtraction
//! per value, from the time grid's frames that a server computes anyway: the central difference
//! `(F(t_{n+1}) − F(t_{n−1}))/(2Δ)` at grid time t_n. For a mode of frequency ω that is
//! `sin(ωΔ)/(ωΔ)` of its exact rate, a relative error of about `(ωΔ)²/6`: 0.2 % for the
//! shortest waves of a 1 m grid (ω ≈ 6.6 rad/s) at the default Δ = 1/60 s, 0.005 % at a wind
//! sea's peak (ω ≈ 1 rad/s). Bodies read it for their drag ([`crate::body::World::step_with`]).

use std::sync::Arc;

use super::Grid;

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

    /// Number of 2-D inverse transforms this frame cost (1 for a height field, 3 if choppy; 0
    /// for grids from [`FftLayer::grid_velocity_frame`]).
    pub fn transforms(&self) -> usize {
        self.frame.transforms()
    }

    /// Velocity `(vx, vy, vz)`, m/s, of the surface particle whose undisplaced position is
    /// `p0 = (x, z)`, read with `filter` (see [`FftFrame::sample`]).
    #[inline(always)]
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
        let grids = self.velocity_grids();
        let mut out_grids: [Option<Grid>; 8] = Default::default();
        let mut buf = vec![zero; rate.len()];
        let mut scratch = self.transform.scratch();
        for &grid in grids {
            for (m, col) in buf.chunks_exact_mut(n).enumerate() {
                let span = m * n..(m + 1) * n;
                let (inv_k, rate) = (&self.inv_ks[span.clone()], &rate[span]);
                let kx = self.kx_cols[m];
                grid.apply_column(kx, &self.kz_rows, inv_k, self.choppiness, rate, col);
            }
            let mut out = Grid::zeroed(n * n);
            self.transform.process(&buf, &mut scratch, &mut out);
            out_grids[grid.index()] = Some(out);
        }
        self.velocity_frame_of(t, out_grids, grids.len(), None)
    }

    /// The grids a velocity frame holds: `∂h/∂t`, and `∂Dx/∂t`, `∂Dz/∂t` for a choppy layer.
    fn velocity_grids(&self) -> &'static [FftGrid] {
        if self.choppiness > 0.0 {
            &[
                FftGrid::Height,
                FftGrid::DisplacementX,
                FftGrid::DisplacementZ,
            ]
        } else {
            &[FftGrid::Height]
        }
    }

    /// A velocity frame at `t` holding `grids` (those of [`FftLayer::velocity_grids`]), made
    /// with `transforms` transforms; its buffers go to `pool` when dropped.
    fn velocity_frame_of(
        &self,
        t: f64,
        grids: [Option<Grid>; 8],
        transforms: usize,
        pool: Option<Arc<super::frame::GridPool>>,
    ) -> FftVelocityFrame {
        let fields = if self.choppiness > 0.0 {
            FftFields::HEIGHT.union(FftFields::DISPLACEMENT)
        } else {
            FftFields::HEIGHT
        };
        FftVelocityFrame {
            frame: FftFrame {
                t,
                fields,
                n: self.n,
                tile_size: self.tile_size,
                grids,
                transforms,
                pool,
            },
        }
    }
}

impl FftLayer {
    /// The velocity grids at time `t`, s, as the time derivative of the surface the time grid
    /// interpolates, by central differences of grid frames (no transform): with
    /// `C_n = (F_{n+1} − F_{n−1})/(2Δ)` per value of the `Height`, `DisplacementX` and
    /// `DisplacementZ` grids (`Height` alone for a non-choppy layer) and `(n, w)` the
    /// [`FftLayer::grid_position`] of t, the grids are `C_n` on a grid time (w = 0) and
    /// `C_n + (C_{n+1} − C_n)·w` between grid times. Indices wrap modulo M, so `t` and `t + T`
    /// give the same bits. Error against [`FftLayer::velocity_frame`] at a grid time: a factor
    /// `sin(ωΔ)/(ωΔ)` per mode (see the module docs).
    ///
    /// `frame_at(k)` returns the frame of grid index k (`FftLayer::grid_frame(k, fields)` or
    /// a cached copy of it) with at least the grids above; called for `n − 1`, `n + 1`, and
    /// when w > 0 also `n` and `n + 2`. `None` if it returns `None` or a frame at another time
    /// or without those grids.
    pub fn grid_velocity_frame(
        &self,
        t: f64,
        mut frame_at: impl FnMut(u64) -> Option<Arc<FftFrame>>,
    ) -> Option<FftVelocityFrame> {
        let m = self.grid_steps;
        let p = self.grid_position(t);
        let grids = self.velocity_grids();
        let mut get = |k: u64| {
            let f = frame_at(k)?;
            let ok = f.t().to_bits() == self.grid_time(k).to_bits()
                && f.n == self.n
                && grids.iter().all(|&g| f.grid(g).is_some());
            ok.then_some(f)
        };
        let before = get((p.index + m - 1) % m)?;
        let after = get(p.next)?;
        let later = if p.weight > 0.0 {
            Some((get(p.index)?, get((p.next + 1) % m)?, p.weight))
        } else {
            None
        };
        let rate = 0.5 / self.time_step;
        let mut out_grids: [Option<Grid>; 8] = Default::default();
        for &grid in grids {
            // Present in every frame: checked by `get`.
            let (Some(a), Some(b)) = (before.grid(grid), after.grid(grid)) else {
                return None;
            };
            let mut out = self.grid_pool.take();
            for ((o, a), b) in out.iter_mut().zip(a).zip(b) {
                *o = (b - a) * rate;
            }
            if let Some((c, d, w)) = &later {
                let (Some(c), Some(d)) = (c.grid(grid), d.grid(grid)) else {
                    return None;
                };
                for ((o, c), d) in out.iter_mut().zip(c).zip(d) {
                    let next = (d - c) * rate;
                    *o += (next - *o) * w;
                }
            }
            out_grids[grid.index()] = Some(out);
        }
        Some(self.velocity_frame_of(t, out_grids, 0, Some(Arc::clone(&self.grid_pool))))
    }
}
