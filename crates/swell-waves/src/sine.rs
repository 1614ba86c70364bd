//! Compound sine layers: a sum of directional sines, vertical motion only.
//!
//! `y = Σ A·sin(k·(d·p) − ω·t + φ)`. Cheap, never folds, and the height at a world point needs no
//! inversion because nothing moves sideways.

use crate::error::SpecError;
use crate::spectrum::Dispersion;
use crate::wave::Wave;
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Most waves one sine or Gerstner layer may hold: each costs a sin/cos per point per query.
pub const MAX_WAVES_PER_LAYER: usize = 1024;

/// One sine wave as written in a scene spec.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SineWave {
    /// Amplitude A, m (≥ 0).
    pub amplitude: f64,
    /// Wavelength λ, m (> 0); k = 2π/λ.
    pub wavelength: f64,
    /// Direction of travel `[x, z]`, normalised; zero is an error.
    pub direction: [f64; 2],
    /// Phase offset φ, rad. Default 0.
    #[cfg_attr(feature = "serde", serde(default))]
    pub phase: f64,
    /// Phase speed c, m/s; absent means the dispersion relation decides (ω = sqrt(g·k·tanh(k·h))).
    #[cfg_attr(feature = "serde", serde(default))]
    pub speed: Option<f64>,
}

/// A compound sine layer as written in a scene spec.
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SineLayerSpec {
    /// The waves, 1..=1024 of them.
    pub waves: Vec<SineWave>,
}

/// A built compound sine layer.
#[derive(Debug, Clone, PartialEq)]
pub struct SineLayer {
    waves: Vec<Wave>,
}

impl SineLayer {
    /// Validates and builds the layer. `field` is the error path prefix, e.g. `layers[0]`.
    ///
    /// # Errors
    /// An empty or over-long wave list, or any invalid wave (see [`Wave::build`]).
    pub fn new(
        spec: &SineLayerSpec,
        dispersion: &Dispersion,
        field: &str,
    ) -> Result<Self, SpecError> {
        check_wave_count(&format!("{field}.waves"), spec.waves.len())?;
        let waves = spec
            .waves
            .iter()
            .enumerate()
            .map(|(i, w)| {
                Wave::build(
                    &format!("{field}.waves[{i}]"),
                    w.amplitude,
                    w.wavelength,
                    w.direction,
                    w.phase,
                    w.speed,
                    0.0,
                    dispersion,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { waves })
    }

    /// The built waves (steepness 0), in spec order.
    pub fn waves(&self) -> &[Wave] {
        &self.waves
    }
}

/// Rejects empty or over-long wave lists.
pub(crate) fn check_wave_count(field: &str, len: usize) -> Result<(), SpecError> {
    if len == 0 || len > MAX_WAVES_PER_LAYER {
        return Err(SpecError::BadLength {
            field: field.to_string(),
            len,
            allowed: format!("1..={MAX_WAVES_PER_LAYER}"),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wave::SurfaceSample;
    use glam::DVec2;

    #[test]
    fn sum_of_sines_matches_formula() {
        let spec = SineLayerSpec {
            waves: vec![
                SineWave {
                    amplitude: 0.5,
                    wavelength: 10.0,
                    direction: [1.0, 0.0],
                    phase: 0.0,
                    speed: None,
                },
                SineWave {
                    amplitude: 0.2,
                    wavelength: 3.0,
                    direction: [0.0, 2.0],
                    phase: 1.0,
                    speed: Some(2.0),
                },
            ],
        };
        let layer = SineLayer::new(&spec, &Dispersion::default(), "layers[0]").unwrap();
        let (x, z, t) = (1.3, -2.2, 4.0);
        let mut s = SurfaceSample::default();
        for w in layer.waves() {
            w.accumulate(DVec2::new(x, z), t, false, &mut s);
        }
        let k1 = std::f64::consts::TAU / 10.0;
        let k2 = std::f64::consts::TAU / 3.0;
        let expect = 0.5 * (k1 * x - (9.81 * k1).sqrt() * t).sin()
            + 0.2 * (k2 * z - 2.0 * k2 * t + 1.0).sin();
        assert!((s.displacement.y - expect).abs() < 1e-12);
        assert_eq!(s.displacement.x, 0.0);
        assert_eq!(s.displacement.z, 0.0);
    }

    #[test]
    fn empty_layer_is_rejected() {
        let e = SineLayer::new(
            &SineLayerSpec::default(),
            &Dispersion::default(),
            "layers[3]",
        )
        .unwrap_err();
        assert_eq!(e.field(), "layers[3].waves");
    }
}
