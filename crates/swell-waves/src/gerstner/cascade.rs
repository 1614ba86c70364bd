//! Cascades: sets of Gerstner waves at several scales, each set with waves in several directions,
//! under global amplitude / wavelength / steepness controls (the shipped-game recipe: four sets at
//! scales 2, 1, 0.5, 0.25 with four near-cardinal directions each).

use glam::DVec2;

use crate::error::{SpecError, direction, finite, in_range, positive};
use crate::math::{SwellRng, TAU, sin_cos, splitmix64};
use crate::spectrum::Dispersion;
use crate::wave::Wave;
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// PCG32 stream used by the cascade generator (each generator draws from its own stream).
const CASCADE_STREAM: u64 = 1;

/// A cascade generator as written in a scene spec.
///
/// Wave `(i, j)` for scale `σ_i` and direction angle `α_j`:
/// - wavelength `λ_ij = wavelength · σ_i · (1 + wavelength_jitter · (2u₁ − 1))`,
/// - amplitude `A_ij = amplitude · σ_i · λ_ij / (wavelength · σ_i)` (so every wave has the same
///   `k·A`, i.e. the same shape at a different size),
/// - direction: `direction` rotated by `α_j + direction_jitter · (2u₂ − 1)` degrees,
/// - phase `2π·u₃`,
/// - steepness `Q = steepness / (n · k·A)` clamped to 1, so the fold number is `steepness`
///   (or less if clamped), with n the number of waves.
///
/// `u₁, u₂, u₃` are uniforms drawn in that order per wave, sets in `scales` order and directions
/// in `directions` order, from `SwellRng::new(splitmix64(seed), 1)`.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct CascadeSpec {
    /// Wavelength of the scale-1 set, m (> 0).
    pub wavelength: f64,
    /// Amplitude of the scale-1 set, m (≥ 0).
    pub amplitude: f64,
    /// Target fold number of the whole cascade in [0, 1).
    pub steepness: f64,
    /// Scale of each set (> 0). Default `[2, 1, 0.5, 0.25]`.
    #[cfg_attr(feature = "serde", serde(default = "default_scales"))]
    pub scales: Vec<f64>,
    /// Direction angles of the waves in every set, degrees from `direction`. Default
    /// `[0, 90, 180, 270]` (near-cardinal once jittered).
    #[cfg_attr(feature = "serde", serde(default = "default_directions"))]
    pub directions: Vec<f64>,
    /// The main direction `[x, z]` the angles are measured from. Default `[1, 0]`.
    #[cfg_attr(feature = "serde", serde(default = "default_main_direction"))]
    pub direction: [f64; 2],
    /// Random direction jitter, degrees in [0, 180]. Default 15.
    #[cfg_attr(feature = "serde", serde(default = "default_direction_jitter"))]
    pub direction_jitter: f64,
    /// Random relative wavelength jitter in [0, 0.9]. Default 0.2.
    #[cfg_attr(feature = "serde", serde(default = "default_wavelength_jitter"))]
    pub wavelength_jitter: f64,
}

impl Default for CascadeSpec {
    fn default() -> Self {
        Self {
            wavelength: 40.0,
            amplitude: 0.5,
            steepness: 0.5,
            scales: default_scales(),
            directions: default_directions(),
            direction: default_main_direction(),
            direction_jitter: default_direction_jitter(),
            wavelength_jitter: default_wavelength_jitter(),
        }
    }
}

fn default_scales() -> Vec<f64> {
    vec![2.0, 1.0, 0.5, 0.25]
}
fn default_directions() -> Vec<f64> {
    vec![0.0, 90.0, 180.0, 270.0]
}
fn default_main_direction() -> [f64; 2] {
    [1.0, 0.0]
}
fn default_direction_jitter() -> f64 {
    15.0
}
fn default_wavelength_jitter() -> f64 {
    0.2
}

impl CascadeSpec {
    /// Generates the wave list (deterministic in `seed`).
    ///
    /// # Errors
    /// Any field out of range; empty `scales`/`directions`; more than 1024 waves.
    pub fn generate(
        &self,
        seed: u64,
        dispersion: &Dispersion,
        field: &str,
    ) -> Result<Vec<Wave>, SpecError> {
        positive(&format!("{field}.wavelength"), self.wavelength)?;
        finite(&format!("{field}.amplitude"), self.amplitude)?;
        in_range(&format!("{field}.amplitude"), self.amplitude, 0.0, f64::MAX)?;
        finite(&format!("{field}.steepness"), self.steepness)?;
        if !(0.0..1.0).contains(&self.steepness) {
            return Err(SpecError::OutOfRange {
                field: format!("{field}.steepness"),
                value: self.steepness,
                allowed: "in [0, 1)".into(),
            });
        }
        in_range(
            &format!("{field}.direction_jitter"),
            self.direction_jitter,
            0.0,
            180.0,
        )?;
        in_range(
            &format!("{field}.wavelength_jitter"),
            self.wavelength_jitter,
            0.0,
            0.9,
        )?;
        let main = direction(&format!("{field}.direction"), self.direction)?;
        let n = self.scales.len() * self.directions.len();
        if self.scales.is_empty()
            || self.directions.is_empty()
            || n > crate::sine::MAX_WAVES_PER_LAYER
        {
            return Err(SpecError::BadLength {
                field: format!("{field}.scales"),
                len: n,
                allowed: "at least one scale and one direction, at most 1024 waves in all".into(),
            });
        }
        for (i, s) in self.scales.iter().enumerate() {
            positive(&format!("{field}.scales[{i}]"), *s)?;
        }
        for (j, a) in self.directions.iter().enumerate() {
            finite(&format!("{field}.directions[{j}]"), *a)?;
        }
        let base_angle = crate::math::atan2(main.y, main.x);
        let ka = TAU * self.amplitude / self.wavelength;
        let q = if ka > 0.0 {
            (self.steepness / (n as f64 * ka)).min(1.0)
        } else {
            0.0
        };
        let mut rng = SwellRng::new(splitmix64(seed), CASCADE_STREAM);
        let mut waves = Vec::with_capacity(n);
        for (i, &scale) in self.scales.iter().enumerate() {
            for (j, &angle) in self.directions.iter().enumerate() {
                let u1 = rng.uniform();
                let u2 = rng.uniform();
                let u3 = rng.uniform();
                let base = self.wavelength * scale;
                let lambda = base * (1.0 + self.wavelength_jitter * (2.0 * u1 - 1.0));
                let amplitude = self.amplitude * scale * (lambda / base);
                let deg = angle + self.direction_jitter * (2.0 * u2 - 1.0);
                let (s, c) = sin_cos(base_angle + deg * (TAU / 360.0));
                let d = DVec2::new(c, s);
                waves.push(Wave::build(
                    &format!("{field}.scales[{i}].directions[{j}]"),
                    amplitude,
                    lambda,
                    [d.x, d.y],
                    TAU * u3,
                    None,
                    q,
                    dispersion,
                )?);
            }
        }
        Ok(waves)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gerstner::fold_number;

    #[test]
    fn default_cascade_has_sixteen_waves_at_four_scales_with_target_fold_number() {
        let c = CascadeSpec {
            steepness: 0.7,
            ..Default::default()
        };
        let waves = c.generate(7, &Dispersion::default(), "c").unwrap();
        assert_eq!(waves.len(), 16);
        assert!((fold_number(&waves) - 0.7).abs() < 1e-12);
        // Scale 2 set is twice the wavelength of the scale 1 set, within the jitter.
        for (i, scale) in [2.0, 1.0, 0.5, 0.25].iter().enumerate() {
            for w in &waves[i * 4..i * 4 + 4] {
                let rel = w.wavelength() / (40.0 * scale);
                assert!((0.8 - 1e-12..=1.2 + 1e-12).contains(&rel), "{rel}");
                assert!((w.amplitude / w.wavelength() - 0.5 / 40.0).abs() < 1e-12);
            }
        }
        // Four near-cardinal directions per set: each within 15° of its nominal angle.
        for (j, nominal) in [0.0f64, 90.0, 180.0, 270.0].iter().enumerate() {
            let d = waves[4 + j].direction;
            let ang = d.y.atan2(d.x).to_degrees().rem_euclid(360.0);
            let diff = (ang - nominal + 540.0).rem_euclid(360.0) - 180.0;
            assert!(diff.abs() <= 15.0 + 1e-9, "{ang} vs {nominal}");
        }
    }

    #[test]
    fn cascade_is_deterministic_in_seed() {
        let c = CascadeSpec::default();
        let d = Dispersion::default();
        assert_eq!(
            c.generate(3, &d, "c").unwrap(),
            c.generate(3, &d, "c").unwrap()
        );
        assert_ne!(
            c.generate(3, &d, "c").unwrap(),
            c.generate(4, &d, "c").unwrap()
        );
    }

    #[test]
    fn cascade_validation_names_fields() {
        let d = Dispersion::default();
        let e = CascadeSpec {
            steepness: 1.0,
            ..Default::default()
        }
        .generate(0, &d, "layers[1].cascade")
        .unwrap_err();
        assert_eq!(e.field(), "layers[1].cascade.steepness");
        let e = CascadeSpec {
            scales: vec![],
            ..Default::default()
        }
        .generate(0, &d, "c")
        .unwrap_err();
        assert_eq!(e.field(), "c.scales");
        let e = CascadeSpec {
            scales: vec![1.0, -1.0],
            ..Default::default()
        }
        .generate(0, &d, "c")
        .unwrap_err();
        assert_eq!(e.field(), "c.scales[1]");
        let e = CascadeSpec {
            direction: [0.0, 0.0],
            ..Default::default()
        }
        .generate(0, &d, "c")
        .unwrap_err();
        assert_eq!(e.field(), "c.direction");
    }
}
