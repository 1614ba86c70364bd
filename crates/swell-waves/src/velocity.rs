//! Orbital velocity of the water at the surface: the time derivative of the displaced position
//! of a surface particle, `v(p0, t) = ∂/∂t (p0 + D(p0, t))` at fixed undisplaced point p0, m/s.
//!
//! - Sine and Gerstner waves: with `θ = k·(d·p0) − ω·t + φ`, so `∂θ/∂t = −ω`, one wave gives
//!   `v = (Q·A·ω·d_x·sin θ, −A·ω·cos θ, Q·A·ω·d_z·sin θ)` (a sine wave has Q = 0, so only the
//!   vertical part). For a Gerstner wave the particle runs round a circle of radius A (Q = 1) at
//!   angular speed ω: the crest moves forward at `Q·A·ω`, the trough backwards.
//! - FFT layers: the same derivative of the Fourier series, from grids computed on request
//!   ([`SurfaceAt::with_velocity`], [`crate::fft::FftLayer::velocity_frame`]).
//!
//! [`SurfaceAt::velocity_at`] answers for a world point: it inverts the horizontal displacement
//! first (the particle that is *at* world (x, z) now), then takes that particle's velocity.

use std::sync::Arc;

use glam::{DVec2, DVec3};

use crate::error::SpecError;
use crate::fft::FftVelocityFrame;
use crate::math::{TAU, sin_cos};
use crate::query::TimeSampling;
use crate::surface::{Layer, SurfaceAt};
use crate::wave::Wave;

/// Adds one wave's particle velocity at undisplaced point `p0`, time `t`, to `out`, m/s:
/// `(Q·A·ω·d_x·sin θ, −A·ω·cos θ, Q·A·ω·d_z·sin θ)` with the wave's reduced phase θ.
#[inline]
pub fn accumulate_velocity(w: &Wave, p0: DVec2, t: f64, out: &mut DVec3) {
    let (s, c) = sin_cos(w.phase_at(p0, t));
    velocity_with(w, s, c, out);
}

/// Slow reference for [`accumulate_velocity`]: unreduced phase and the platform's f64
/// `sin`/`cos`. For tests only.
pub fn accumulate_velocity_reference(w: &Wave, p0: DVec2, t: f64, out: &mut DVec3) {
    let along = w.direction.x * p0.x + w.direction.y * p0.y;
    let theta = w.wavenumber * along - w.omega * t + w.phase;
    let (s, c) = theta.sin_cos(); // determinism: reference (platform trig on purpose)
    velocity_with(w, s, c, out);
}

#[inline]
fn velocity_with(w: &Wave, s: f64, c: f64, out: &mut DVec3) {
    let aw = w.amplitude * w.omega;
    let qaw_s = w.steepness * aw * s;
    out.x += qaw_s * w.direction.x;
    out.y -= aw * c;
    out.z += qaw_s * w.direction.y;
}

/// Whether a wave is kept by a minimum-wavelength filter: `λ ≥ min_wavelength`, tested as
/// `k·min_wavelength ≤ 2π` (no division; `min_wavelength = 0` keeps every wave).
#[inline]
pub(crate) fn keeps(w: &Wave, min_wavelength: f64) -> bool {
    w.wavenumber * min_wavelength <= TAU
}

impl<'s> SurfaceAt<'s> {
    /// Computes the orbital velocity grids of every FFT layer at this snapshot's time, so that
    /// [`SurfaceAt::velocity`] reads grids instead of summing series (one to three extra
    /// transforms per FFT layer). A no-op for surfaces without FFT layers and in reference mode.
    #[must_use]
    pub fn with_velocity(mut self) -> Self {
        if self.options.reference || !self.surface.has_fft() {
            return self;
        }
        let t = self.t;
        self.velocities = self
            .surface
            .layers()
            .iter()
            .map(|l| match l {
                Layer::Fft(f) => Some(Arc::new(f.velocity_frame(t))),
                _ => None,
            })
            .collect();
        self
    }

    /// Like [`SurfaceAt::with_velocity`], with each FFT layer's velocity grids from the time
    /// grid's frames when this snapshot reads grid frames ([`TimeSampling::Grid`]): central
    /// differences, no transform ([`crate::fft::FftLayer::grid_velocity_frame`]). `at(t')`
    /// returns this surface at another time t' with the same options and frames from the same
    /// source as this snapshot's (a shared cache, where they are usually there already); it is
    /// asked for grid times only. A layer whose frames `at` does not give, and every layer with
    /// [`TimeSampling::Exact`], gets [`crate::fft::FftLayer::velocity_frame`] instead.
    #[must_use]
    pub fn with_grid_velocity(mut self, mut at: impl FnMut(f64) -> Option<SurfaceAt<'s>>) -> Self {
        if self.options.reference || !self.surface.has_fft() {
            return self;
        }
        let t = self.t;
        let grid = self.options.time == TimeSampling::Grid;
        self.velocities = self
            .surface
            .layers()
            .iter()
            .enumerate()
            .map(|(i, l)| match l {
                Layer::Fft(f) => {
                    let from_grid = grid
                        .then(|| {
                            f.grid_velocity_frame(t, |k| {
                                at(f.grid_time(k))?.single_frame(i).cloned()
                            })
                        })
                        .flatten();
                    Some(Arc::new(from_grid.unwrap_or_else(|| f.velocity_frame(t))))
                }
                _ => None,
            })
            .collect();
        self
    }

    /// Like [`SurfaceAt::with_velocity`] with velocity frames supplied by the caller (a cache
    /// shared between requests): one entry per layer, `Some` exactly for FFT layers, computed
    /// at this snapshot's time.
    ///
    /// # Errors
    /// [`SpecError::Inconsistent`] (field `velocity_frames`) if the list does not match the
    /// layers.
    pub fn with_velocity_frames(
        mut self,
        frames: Vec<Option<Arc<FftVelocityFrame>>>,
    ) -> Result<Self, SpecError> {
        let ok = frames.len() == self.surface.layers().len()
            && self
                .surface
                .layers()
                .iter()
                .zip(&frames)
                .all(|(l, f)| matches!(l, Layer::Fft(_)) == f.is_some());
        if !ok {
            return Err(SpecError::Inconsistent {
                field: "velocity_frames".into(),
                reason: "one velocity frame is needed per FFT layer, and none for other layers"
                    .into(),
            });
        }
        self.velocities = frames;
        Ok(self)
    }

    /// Velocity `(vx, vy, vz)`, m/s, of the surface particle whose undisplaced position is `p0`.
    ///
    /// FFT layers read the velocity grids when [`SurfaceAt::with_velocity`] computed them, and
    /// otherwise fall back to direct summation ([`crate::fft::FftLayer::velocity_reference`],
    /// O(N²) per point: correct but slow).
    pub fn velocity(&self, p0: DVec2) -> DVec3 {
        self.velocity_filtered(p0, 0.0)
    }

    /// [`SurfaceAt::velocity`] leaving out analytic (sine and Gerstner) waves shorter than
    /// `min_wavelength`, m, and particles narrower than it (`4r < min_wavelength`). FFT layers
    /// are never filtered. Particles move the surface vertically only (`∂h/∂t`). `min_wavelength = 0` is exactly
    /// [`SurfaceAt::velocity`].
    pub fn velocity_filtered(&self, p0: DVec2, min_wavelength: f64) -> DVec3 {
        self.velocity_layers(p0, min_wavelength, DVec3::ZERO, true)
    }

    /// The sum of [`SurfaceAt::velocity_filtered`], layer by layer in order, starting from
    /// `out`; `analytic = false` leaves out the sine and Gerstner layers (a caller that summed
    /// them already, in the same order, passes that sum as `out`).
    #[inline(always)]
    pub(crate) fn velocity_layers(
        &self,
        p0: DVec2,
        min_wavelength: f64,
        mut out: DVec3,
        analytic: bool,
    ) -> DVec3 {
        for (i, layer) in self.surface.layers().iter().enumerate() {
            match layer {
                Layer::Sine(_) | Layer::Gerstner(_) if !analytic => {}
                Layer::Sine(_) | Layer::Gerstner(_) => {
                    for w in layer.waves() {
                        if keeps(w, min_wavelength) {
                            accumulate_velocity(w, p0, self.t, &mut out);
                        }
                    }
                }
                Layer::Fft(f) => {
                    let grid = self.velocities.get(i).and_then(Option::as_ref);
                    out += match grid {
                        Some(v) if !self.options.reference => v.sample(p0, self.options.filter),
                        _ => f.velocity_reference(p0, self.t),
                    };
                }
                Layer::Particles(p) => {
                    if let Some(field) = self.particle_field(i) {
                        out.y += field.vertical_velocity(p, p0, min_wavelength);
                    }
                }
            }
        }
        out
    }

    /// Velocity, m/s, of the surface particle that lies above world `(x, z)` now: inverts the
    /// horizontal displacement with the snapshot's settings ([`SurfaceAt::invert`]) and returns
    /// the velocity of the source point.
    pub fn velocity_at(&self, world: DVec2) -> DVec3 {
        let source = self.invert(world, false).source;
        self.velocity(source)
    }

    /// Slow reference for [`SurfaceAt::velocity`]: analytic waves with unreduced phases and
    /// platform f64 trig, FFT layers by direct summation. For tests and reports.
    pub fn velocity_reference(&self, p0: DVec2) -> DVec3 {
        let mut out = DVec3::ZERO;
        for (i, layer) in self.surface.layers().iter().enumerate() {
            match layer {
                Layer::Sine(_) | Layer::Gerstner(_) => {
                    for w in layer.waves() {
                        accumulate_velocity_reference(w, p0, self.t, &mut out);
                    }
                }
                Layer::Particles(p) => {
                    if let Some(field) = self.particle_field(i) {
                        out.y += field.sample_reference(p, p0).2;
                    }
                }
                Layer::Fft(f) => out += f.velocity_reference(p0, self.t),
            }
        }
        out
    }
}
