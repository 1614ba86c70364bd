//! Gerstner (trochoidal) layers: explicit waves, cascades, and waves sampled from a spectrum.
//!
//! A point p0 of the flat sea moves to `x = p0 + Σ Q·A·d·cos θ`, `y = Σ A·sin θ`,
//! `θ = k·(d·p0) − ω·t + φ`. The surface stays a graph (never loops) while the fold number
//! `S = Σ Q·k·A` is below 1; a layer (or a surface) with S ≥ 1 is rejected.

mod cascade;
mod sampled;

pub use cascade::CascadeSpec;
pub use sampled::{MAX_SAMPLED_WAVES, SpectrumWavesSpec};

use crate::error::SpecError;
use crate::sine::check_wave_count;
use crate::spectrum::Dispersion;
use crate::wave::Wave;
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// One explicit Gerstner wave as written in a scene spec.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct GerstnerWave {
    /// Amplitude A, m (≥ 0).
    pub amplitude: f64,
    /// Wavelength λ, m (> 0).
    pub wavelength: f64,
    /// Direction of travel `[x, z]`, normalised; zero is an error.
    pub direction: [f64; 2],
    /// Phase offset φ, rad. Default 0.
    #[cfg_attr(feature = "serde", serde(default))]
    pub phase: f64,
    /// Phase speed c, m/s; absent means the dispersion relation decides.
    #[cfg_attr(feature = "serde", serde(default))]
    pub speed: Option<f64>,
    /// Steepness Q in [0, 1]: 0 is a sine, 1 gives the sharpest crest a lone wave can have.
    pub steepness: f64,
}

/// A Gerstner layer as written in a scene spec: explicit waves plus any generated ones, summed.
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct GerstnerLayerSpec {
    /// Explicit waves.
    #[cfg_attr(feature = "serde", serde(default))]
    pub waves: Vec<GerstnerWave>,
    /// A cascade generator (sets of waves at several scales and directions).
    #[cfg_attr(feature = "serde", serde(default))]
    pub cascade: Option<CascadeSpec>,
    /// A spectrum sampler (N waves drawn from a spectrum with the layer's seed).
    #[cfg_attr(feature = "serde", serde(default))]
    pub spectrum: Option<SpectrumWavesSpec>,
    /// Seed of the generators; absent means derived from the surface seed and layer index.
    #[cfg_attr(feature = "serde", serde(default))]
    pub seed: Option<u64>,
}

/// A built Gerstner layer: the full wave list (explicit first, then generated) and its fold
/// number.
#[derive(Debug, Clone, PartialEq)]
pub struct GerstnerLayer {
    waves: Vec<Wave>,
    fold: f64,
}

impl GerstnerLayer {
    /// Validates and builds the layer; generators draw from `seed`.
    ///
    /// # Errors
    /// No waves at all (or more than [`crate::sine::MAX_WAVES_PER_LAYER`]), any invalid wave or
    /// generator field, or a fold number S ≥ 1 ([`SpecError::Folding`], which reports S).
    pub fn new(
        spec: &GerstnerLayerSpec,
        seed: u64,
        dispersion: &Dispersion,
        field: &str,
    ) -> Result<Self, SpecError> {
        let mut waves = spec
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
                    w.steepness,
                    dispersion,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        if let Some(c) = &spec.cascade {
            waves.extend(c.generate(seed, dispersion, &format!("{field}.cascade"))?);
        }
        if let Some(g) = &spec.spectrum {
            waves.extend(g.generate(seed, dispersion, &format!("{field}.spectrum"))?);
        }
        check_wave_count(&format!("{field}.waves"), waves.len())?;
        let fold = fold_number(&waves);
        if fold >= 1.0 || !fold.is_finite() {
            return Err(SpecError::Folding {
                field: field.to_string(),
                fold,
            });
        }
        Ok(Self { waves, fold })
    }

    /// Every wave of the layer, explicit then generated: exactly what a client must render.
    pub fn waves(&self) -> &[Wave] {
        &self.waves
    }

    /// The fold number `S = Σ Q·k·A` (< 1).
    pub fn fold_number(&self) -> f64 {
        self.fold
    }
}

/// `S = Σ Q·k·A` over `waves`: the largest possible compression of the horizontal map.
/// The map's Jacobian is at least `1 − S`, so below 1 the surface never loops.
pub fn fold_number(waves: &[Wave]) -> f64 {
    waves.iter().map(Wave::fold_contribution).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gw(a: f64, l: f64, q: f64) -> GerstnerWave {
        GerstnerWave {
            amplitude: a,
            wavelength: l,
            direction: [1.0, 0.5],
            phase: 0.0,
            speed: None,
            steepness: q,
        }
    }

    #[test]
    fn fold_number_at_or_above_one_is_rejected_with_its_value() {
        let l = std::f64::consts::TAU; // k = 1
        let spec = GerstnerLayerSpec {
            waves: vec![gw(0.6, l, 1.0), gw(0.5, l, 0.8)],
            ..Default::default()
        };
        let e = GerstnerLayer::new(&spec, 0, &Dispersion::default(), "layers[1]").unwrap_err();
        match e {
            SpecError::Folding { field, fold } => {
                assert_eq!(field, "layers[1]");
                assert!((fold - 1.0).abs() < 1e-12);
            }
            other => panic!("{other}"),
        }
        let ok = GerstnerLayerSpec {
            waves: vec![gw(0.6, l, 1.0), gw(0.3, l, 0.8)],
            ..Default::default()
        };
        let layer = GerstnerLayer::new(&ok, 0, &Dispersion::default(), "layers[1]").unwrap();
        assert!((layer.fold_number() - 0.84).abs() < 1e-12);
    }

    #[test]
    fn a_layer_needs_waves() {
        let e = GerstnerLayer::new(
            &GerstnerLayerSpec::default(),
            0,
            &Dispersion::default(),
            "layers[0]",
        )
        .unwrap_err();
        assert_eq!(e.field(), "layers[0].waves");
    }
}
