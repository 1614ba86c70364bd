//! How a scene's authority sets up its body world: the spawn request with its default damping,
//! the world settings for a scene tick anchor, and the query options a body step reads the sea
//! with.
//!
//! These live in the model, not in the server, so every program that must reach the server's
//! bits (the server's body loop, its journal replay, the C ABI in `swell-ffi` that native
//! clients predict their boats with) builds the world from the same code.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use super::{BodySpec, HullSpec, SEA_WATER_DENSITY, WorldSettings};
use crate::{QueryOptions, TimeSampling};

/// Damping ratio of the server's default drag: about 30% of critical in heave, so a spawned boat
/// settles within a few oscillations, as players expect, instead of bobbing forever.
pub const DEFAULT_DAMPING_RATIO: f64 = 0.3;

/// A body as a client asks for it (the server's `POST /v1/scenes/{id}/bodies` body): the model
/// spec with the damping left to defaults, and where it starts.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SpawnSpec {
    /// Mass, kg.
    pub mass: f64,
    /// Hull: `{"kind":"box","length","beam","height","cells"?:[nx,nz]}` or
    /// `{"kind":"cells","cells":[{"position":[x,y,z],"volume","height"}]}`.
    pub hull: HullSpec,
    /// World position of the body origin `[x, y, z]`, m.
    pub position: [f64; 3],
    /// Yaw, rad (about +y), within ±[`super::MAX_YAW`].
    #[cfg_attr(feature = "serde", serde(default))]
    pub yaw: f64,
    /// Centre of mass in the body frame, m. Default the hull centre.
    #[cfg_attr(feature = "serde", serde(default))]
    pub center_of_mass: [f64; 3],
    /// Linear drag, N·s/m. Default: [`DEFAULT_DAMPING_RATIO`] of critical heave damping.
    #[cfg_attr(feature = "serde", serde(default))]
    pub linear_drag: Option<f64>,
    /// Quadratic drag, N·s²/m². Default 0.
    #[cfg_attr(feature = "serde", serde(default))]
    pub quadratic_drag: f64,
    /// Angular damping, N·m·s/rad. Default: the linear default times the hull's
    /// `(L² + B²)/12` (the same damping ratio in pitch and roll, roughly).
    #[cfg_attr(feature = "serde", serde(default))]
    pub angular_damping: Option<f64>,
    /// Waves shorter than this factor times the hull length do not move the body (analytic
    /// layers only). Default 0.
    #[cfg_attr(feature = "serde", serde(default))]
    pub min_wavelength_factor: f64,
}

impl SpawnSpec {
    /// The model spec, with the default damping filled in for gravity `gravity` (m/s²).
    pub fn body_spec(&self, gravity: f64) -> BodySpec {
        let (area, length, beam, volume) = match &self.hull {
            HullSpec::Box {
                length,
                beam,
                height,
                ..
            } => (length * beam, *length, *beam, length * beam * height),
            HullSpec::Cells { cells } => {
                let v: f64 = cells.iter().map(|c| c.volume).sum();
                let a: f64 = cells
                    .iter()
                    .map(|c| {
                        if c.height > 0.0 {
                            c.volume / c.height
                        } else {
                            0.0
                        }
                    })
                    .sum();
                let side = a.max(0.0).sqrt();
                (a, side, side, v)
            }
        };
        // Heave stiffness ρ·g·A and critical damping 2·sqrt(k·m); drag acts on the submerged
        // fraction f = m/(ρ·V) at rest, so divide by it to get that damping at the waterline.
        let k = SEA_WATER_DENSITY * gravity * area;
        let f = (self.mass / (SEA_WATER_DENSITY * volume)).clamp(0.05, 1.0);
        let c = 2.0 * DEFAULT_DAMPING_RATIO * (k * self.mass).max(0.0).sqrt() / f;
        let c = if c.is_finite() { c } else { 0.0 };
        BodySpec {
            mass: self.mass,
            hull: self.hull.clone(),
            center_of_mass: self.center_of_mass,
            linear_drag: self.linear_drag.unwrap_or(c),
            quadratic_drag: self.quadratic_drag,
            angular_damping: self
                .angular_damping
                .unwrap_or(c * (length * length + beam * beam) / 12.0),
            min_wavelength_factor: self.min_wavelength_factor,
        }
    }
}

/// The settings of a scene's body world anchored at scene tick `anchor`: world tick 0 is that
/// scene tick (`start_time = anchor/tick_hz`), sea water, the scene's gravity.
///
/// The anchor is part of the bits: substep times are `start_time + (n + k/256)/tick_hz`, which
/// rounds differently for another split of the same instant, so a world that must reproduce
/// another's trajectory needs the same anchor.
pub fn authority_settings(anchor: i64, tick_hz: f64, gravity: f64) -> WorldSettings {
    WorldSettings {
        tick_hz,
        water_density: SEA_WATER_DENSITY,
        gravity,
        start_time: anchor as f64 / tick_hz,
    }
}

/// The query options a scene's bodies read the sea with: a 1 mm inversion tolerance, FFT layers
/// on the model's default time grid.
///
/// A 1 mm residual moves a cell's height by at most the slope times 1 mm, far below what a hull
/// cell (metres across) resolves, and a looser tolerance than the query default (0.01 mm) saves
/// Newton steps on every cell of every body every tick. Measured in the server's tests
/// (`a_one_millimetre_body_tolerance_is_invisible_at_hull_scale`): over 10 s a boat stays within
/// 0.24 mm and 0.002° of its 0.01-mm trajectory on `lake`, and within 0.63 mm and 0.004° on
/// `storm` (folding, where the inversion is ill-conditioned).
///
/// FFT layers are read on the grid as queries read them, so a server takes a body step's grid
/// frames from the cache its queries fill; velocity grids (drag) are central differences of the
/// grid frames around the tick time (`SurfaceAt::with_grid_velocity`). At 30 Hz and Δ = 1/60 s a
/// body's substep times are grid times (one frame each); other rates read the two grid frames
/// around a substep time.
pub fn authority_step_options() -> QueryOptions {
    let mut o = QueryOptions::default();
    o.inversion.tolerance = 1e-3;
    o.time = TimeSampling::Grid;
    o
}
