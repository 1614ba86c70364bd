//! Wave particles (Yuksel et al. 2007; the ambient use follows Naughty Dog's and the seed
//! article's): small travelling bumps whose position is known at any time from their start and
//! velocity, so they are part of the deterministic sea rather than a client-side effect.
//!
//! A particle layer (`{"kind": "particles"}`; every field has a default) holds:
//! - **ambient particles** ([`ambient`]): N seeded particles on a periodic tile of size L,
//!   `p(t) = wrap(p0 + v·t)` exactly at any t, optionally summed at several tile scales;
//! - **interaction ripples** ([`ripple`]): rings of particles from [`Impact`] events that
//!   expand at the wave speed of their radius, lose amplitude with distance, subdivide into
//!   three when the gap between neighbours exceeds the radius (split times in closed form) and
//!   die below an amplitude floor or after a lifetime. The live set at t is a pure function of
//!   the impact list and t.
//!
//! Every particle is the smooth compact [`kernel`] `a·(1 − |x − c|²/r²)³` with its analytic
//! gradient, so normals are exact. Particles move the surface vertically only (no horizontal
//! displacement: a particle layer never makes heights need inversion), and they ride on the
//! other layers: they are evaluated at the undisplaced point like every layer.
//!
//! A [`ParticleField`] (the layer at one time) finds the particles near a point through uniform
//! grids (the ambient one shared across a window of times), so a query costs O(particles near
//! the point), not O(all particles); at most [`MAX_RINGS_PER_POINT`]
//! rings (the newest covering the point) add to one point, so piled-up splashes cannot make a
//! query arbitrarily expensive.
//!
//! Impacts reach a snapshot through [`crate::SurfaceAt::with_impacts`]; the first particle
//! layer of a surface carries them (its [`RippleSpec`] shapes the rings). A surface without a
//! particle layer pays nothing and gives the same bits as before this layer existed.

pub mod ambient;
pub mod body_impacts;
mod field;
pub mod kernel;
pub mod ripple;
#[cfg(test)]
mod tests;

pub use ambient::Ambient;
pub use body_impacts::{BodyImpactSpec, BodyStep};
pub use field::{MAX_RINGS_PER_POINT, ParticleField, RING_GRID_MIN};
pub use ripple::{Impact, Impacts, Ring, RingState, RippleSpec};

use glam::DVec2;

use crate::error::{SpecError, direction, in_range, positive_at_most};
use crate::spectrum::Dispersion;
use ambient::AmbientParams;
use field::LiveRing;
use ripple::MIN_IMPACT_RADIUS;
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Most ambient particles per layer: 16,384 (a 128² grid of cells keeps queries local; the
/// seed article finds under 1,000 enough).
pub const MAX_AMBIENT_PARTICLES: u32 = 16_384;
/// Most tile scales per layer.
pub const MAX_SCALES: usize = 4;
/// Largest tile size, m.
pub const MAX_TILE_SIZE: f64 = 100_000.0;
/// Smallest tile size, m: with the smallest scale, a shader's `1/(scale·tile)` stays a small f32.
pub const MIN_TILE_SIZE: f64 = 0.1;
/// Smallest tile scale.
pub const MIN_SCALE: f64 = 1.0 / 64.0;
/// Largest tile scale.
pub const MAX_SCALE: f64 = 64.0;

/// A particle layer spec. Every field has a default, so `{"kind": "particles"}` is valid.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct ParticleLayerSpec {
    /// Ambient particles per tile, 0..=16384. Default 512: about 1.6 particles overlap any
    /// point at the default size and radius, dense enough to hide the tile's grid.
    pub count: u32,
    /// Tile size L, m, in [0.1, 100000]. Default 32 m: several boat lengths, so the tile's period
    /// is hard to see (the finer scales break it up further).
    pub tile_size: f64,
    /// Particle radius r, m, in [0.01, L/4] (a particle must not overlap its own periodic image).
    /// Default 1 m: detail between the Gerstner or FFT swell and the shader's normal maps.
    pub radius: f64,
    /// Particle amplitude a, m, in [0, 10]. Default 0.03 m: a ripple, not a wave.
    pub amplitude: f64,
    /// Relative random spread of the amplitudes, in [0, 1]: particle i gets
    /// `a·(1 − jitter·U)`. Default 0.5.
    pub amplitude_jitter: f64,
    /// Particle speed |v|, m/s, in (0, 1000]. Default: the phase speed of a wave four radii
    /// long on this surface (`ω(k)/k`, `k = π/(2r)`), 2.5 m/s in deep water at r = 1 m.
    pub speed: Option<f64>,
    /// Mean direction of travel `[x, z]` (e.g. the wind's). Default: none, directions spread
    /// evenly as in the seed article (each 2°–5° clockwise from the last).
    pub direction: Option<[f64; 2]>,
    /// With a `direction`: the width of the directions around it, degrees, in [0, 360].
    /// Default 120°.
    pub spread: f64,
    /// Tile scales s, 1..=4 values in [1/64, 64]: the pattern is also summed shrunk to s (tile
    /// s·L, radius s·r, amplitude s·a, speed s·v). Default `[1]`; the seed samples
    /// `[0.33, 0.66, 1]`.
    pub scales: Vec<f64>,
    /// Seed of the ambient draws. Default: the surface seed's layer seed.
    pub seed: Option<u64>,
    /// How impact rings behave.
    pub ripples: RippleSpec,
    /// Impacts from floating bodies (splashes, wakes): absent (the default), bodies make none;
    /// `{}` turns them on with [`BodyImpactSpec`]'s defaults. Only the first particle layer's
    /// (the one impacts ripple on) counts.
    #[cfg_attr(feature = "serde", serde(skip_serializing_if = "Option::is_none"))]
    pub body_impacts: Option<BodyImpactSpec>,
}

impl Default for ParticleLayerSpec {
    fn default() -> Self {
        Self {
            count: 512,
            tile_size: 32.0,
            radius: 1.0,
            amplitude: 0.03,
            amplitude_jitter: 0.5,
            speed: None,
            direction: None,
            spread: 120.0,
            scales: vec![1.0],
            seed: None,
            ripples: RippleSpec::default(),
            body_impacts: None,
        }
    }
}

/// A built particle layer: the ambient particles and the ripple settings.
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleLayer {
    ambient: Ambient,
    ripples: RippleSpec,
    body_impacts: Option<BodyImpactSpec>,
    dispersion: Dispersion,
    seed: u64,
}

impl ParticleLayer {
    /// Validates `spec` and draws the ambient particles from `seed`. `field` prefixes error
    /// paths (`layers[i]`).
    ///
    /// # Errors
    /// Any field outside the range its doc gives, named with its path.
    pub fn new(
        spec: &ParticleLayerSpec,
        seed: u64,
        dispersion: Dispersion,
        field: &str,
    ) -> Result<ParticleLayer, SpecError> {
        let f = |name: &str| format!("{field}.{name}");
        in_range(
            &f("count"),
            f64::from(spec.count),
            0.0,
            f64::from(MAX_AMBIENT_PARTICLES),
        )?;
        let tile = in_range(
            &f("tile_size"),
            spec.tile_size,
            MIN_TILE_SIZE,
            MAX_TILE_SIZE,
        )?;
        let radius = in_range(&f("radius"), spec.radius, MIN_IMPACT_RADIUS, tile / 4.0)?;
        in_range(&f("amplitude"), spec.amplitude, 0.0, 10.0)?;
        in_range(&f("amplitude_jitter"), spec.amplitude_jitter, 0.0, 1.0)?;
        let speed = match spec.speed {
            Some(v) => positive_at_most(&f("speed"), v, 1000.0)?,
            None => ripple::particle_speed(radius, &dispersion),
        };
        let dir = spec
            .direction
            .map(|d| direction(&f("direction"), d))
            .transpose()?;
        in_range(&f("spread"), spec.spread, 0.0, 360.0)?;
        if spec.scales.is_empty() || spec.scales.len() > MAX_SCALES {
            return Err(SpecError::BadLength {
                field: f("scales"),
                len: spec.scales.len(),
                allowed: format!("1..={MAX_SCALES}"),
            });
        }
        for (i, &s) in spec.scales.iter().enumerate() {
            in_range(&f(&format!("scales[{i}]")), s, MIN_SCALE, MAX_SCALE)?;
        }
        spec.ripples.validate(&f("ripples"))?;
        if let Some(b) = &spec.body_impacts {
            b.validate(&f("body_impacts"))?;
        }
        let ambient = Ambient::new(&AmbientParams {
            count: spec.count,
            tile,
            radius,
            amplitude: spec.amplitude,
            jitter: spec.amplitude_jitter,
            speed,
            direction: dir,
            spread_rad: spec.spread * (crate::math::TAU / 360.0),
            scales: &spec.scales,
            seed,
        });
        Ok(ParticleLayer {
            ambient,
            ripples: spec.ripples,
            body_impacts: spec.body_impacts,
            dispersion,
            seed,
        })
    }

    /// The ambient particles.
    pub fn ambient(&self) -> &Ambient {
        &self.ambient
    }

    /// The ripple settings.
    pub fn ripples(&self) -> &RippleSpec {
        &self.ripples
    }

    /// When floating bodies make impacts on this layer (none: they make none).
    pub fn body_impacts(&self) -> Option<&BodyImpactSpec> {
        self.body_impacts.as_ref()
    }

    /// The seed the ambient particles were drawn from.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The ring an impact makes on this layer.
    pub fn ring(&self, impact: &Impact) -> Ring {
        Ring::new(impact, &self.ripples, &self.dispersion)
    }

    /// The rings of `impacts` alive at t, in canonical order, with their state.
    pub fn live_rings(&self, t: f64, impacts: &Impacts) -> Vec<(Ring, RingState)> {
        impacts
            .window(t, self.ripples.lifetime)
            .iter()
            .filter_map(|e| {
                let ring = self.ring(e);
                ring.state(t).map(|s| (ring, s))
            })
            .collect()
    }

    /// The layer at time t with the rings of `impacts` (none if `None`), ready for queries.
    /// Cheap: the spatial indexes are built on the first query.
    ///
    /// # Errors
    /// More than [`ripple::MAX_LIVE_RINGS`] rings alive at t (field `impacts`).
    pub fn field(&self, t: f64, impacts: Option<&Impacts>) -> Result<ParticleField, SpecError> {
        let rings: Vec<LiveRing> = match impacts {
            None => Vec::new(),
            Some(impacts) => {
                let live = self.live_rings(t, impacts);
                if live.len() > ripple::MAX_LIVE_RINGS {
                    return Err(SpecError::BadLength {
                        field: "impacts".into(),
                        len: live.len(),
                        allowed: format!(
                            "at most {} rings alive at t = {t}",
                            ripple::MAX_LIVE_RINGS
                        ),
                    });
                }
                live.into_iter()
                    .map(|(ring, s)| LiveRing {
                        ring,
                        d: s.distance,
                        n: s.count,
                        amp: s.amplitude,
                        inv_r2: 1.0 / (ring.radius * ring.radius),
                        amp_rate: -ring.speed / self.ripples.decay,
                    })
                    .collect()
            }
        };
        Ok(ParticleField::new(t, rings))
    }

    /// The layer's height and gradient at x, t with `impacts`, straight from the closed forms
    /// ([`ParticleField::sample_reference`]). Slow; for tests and reports.
    pub fn sample_reference(&self, x: DVec2, t: f64, impacts: Option<&Impacts>) -> (f64, DVec2) {
        match self.field(t, impacts) {
            Ok(f) => {
                let (h, g, _) = f.sample_reference(self, x);
                (h, g)
            }
            Err(_) => (f64::NAN, DVec2::NAN),
        }
    }
}
