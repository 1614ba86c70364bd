//! One travelling wave, the building block of the sine and Gerstner layers.

use glam::DVec2;

use crate::error::{SpecError, direction, finite, in_range, non_negative, positive};
use crate::math::{TAU, reduce_phase, sin_cos};
use crate::spectrum::Dispersion;

/// A built, validated wave: everything needed to evaluate it, and everything a client needs to
/// render exactly the same wave.
///
/// Phase `θ = k·(d·p0) − ω·t + φ`. A sine wave moves the surface vertically only
/// (`y = A·sin θ`); a Gerstner wave also moves it horizontally by `Q·A·d·cos θ`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Wave {
    /// Amplitude A, m.
    pub amplitude: f64,
    /// Wave number k = 2π/λ, rad/m.
    pub wavenumber: f64,
    /// Angular frequency ω, rad/s (from the dispersion relation, or `c·k` when a speed is given).
    pub omega: f64,
    /// Unit direction of travel `[x, z]`.
    pub direction: DVec2,
    /// Phase offset φ, rad.
    pub phase: f64,
    /// Gerstner steepness Q in [0, 1] (0 for a sine wave).
    pub steepness: f64,
}

/// Sum of a set of waves and their first derivatives at one undisplaced point.
///
/// `displacement` is `(Dx, y, Dz)`: the horizontal displacement and the elevation. `d_dx` is
/// `∂(Dx, y, Dz)/∂x0` and `d_dz` is `∂(Dx, y, Dz)/∂z0`, so the displaced surface's tangents are
/// `(1, 0, 0) + d_dx` and `(0, 0, 1) + d_dz`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SurfaceSample {
    /// `(Dx, y, Dz)`, m.
    pub displacement: glam::DVec3,
    /// Derivative of `displacement` along x0 (dimensionless).
    pub d_dx: glam::DVec3,
    /// Derivative of `displacement` along z0 (dimensionless).
    pub d_dz: glam::DVec3,
}

impl SurfaceSample {
    /// Adds another sample (layers sum linearly).
    #[inline]
    pub fn add(&mut self, o: &SurfaceSample) {
        self.displacement += o.displacement;
        self.d_dx += o.d_dx;
        self.d_dz += o.d_dz;
    }

    /// Jacobian determinant of the horizontal map `p0 ↦ p0 + (Dx, Dz)`:
    /// `J = (1 + ∂Dx/∂x)(1 + ∂Dz/∂z) − (∂Dx/∂z)(∂Dz/∂x)`. `J ≤ 0` means the surface folds here.
    #[inline]
    pub fn jacobian(&self) -> f64 {
        (1.0 + self.d_dx.x) * (1.0 + self.d_dz.z) - self.d_dz.x * self.d_dx.z
    }

    /// Unit normal of the displaced surface: `(e_z + d_dz) × (e_x + d_dx)`, normalised (y up).
    /// Falls back to straight up if the tangents are degenerate (a fold's edge).
    #[inline]
    pub fn normal(&self) -> glam::DVec3 {
        let tx = glam::DVec3::X + self.d_dx;
        let tz = glam::DVec3::Z + self.d_dz;
        let n = tz.cross(tx);
        let len = n.length();
        if len > 1e-300 && len.is_finite() {
            n / len
        } else {
            glam::DVec3::Y
        }
    }
}

impl Wave {
    /// Builds a wave from its spec values. `field` is the error path prefix.
    ///
    /// ω comes from `dispersion` unless `speed` (phase speed c, m/s) is given, then `ω = c·k`.
    ///
    /// # Errors
    /// Amplitude < 0, wavelength ≤ 0, a zero direction, a non-finite phase, a speed ≤ 0, a
    /// steepness outside [0, 1], or anything non-finite.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        field: &str,
        amplitude: f64,
        wavelength: f64,
        dir: [f64; 2],
        phase: f64,
        speed: Option<f64>,
        steepness: f64,
        dispersion: &Dispersion,
    ) -> Result<Wave, SpecError> {
        non_negative(&format!("{field}.amplitude"), amplitude)?;
        positive(&format!("{field}.wavelength"), wavelength)?;
        let direction = direction(&format!("{field}.direction"), dir)?;
        finite(&format!("{field}.phase"), phase)?;
        in_range(&format!("{field}.steepness"), steepness, 0.0, 1.0)?;
        let k = TAU / wavelength;
        let omega = match speed {
            Some(c) => positive(&format!("{field}.speed"), c)? * k,
            None => dispersion.omega(k),
        };
        if !(k.is_finite() && omega.is_finite()) {
            return Err(SpecError::OutOfRange {
                field: format!("{field}.wavelength"),
                value: wavelength,
                allowed: "a wavelength whose wave number and frequency are finite".into(),
            });
        }
        Ok(Wave {
            amplitude,
            wavenumber: k,
            omega,
            direction,
            phase: reduce_phase(phase),
            steepness,
        })
    }

    /// Wavelength λ = 2π/k, m.
    pub fn wavelength(&self) -> f64 {
        TAU / self.wavenumber
    }

    /// This wave's share of the fold number, `Q·k·A`.
    pub fn fold_contribution(&self) -> f64 {
        self.steepness * self.wavenumber * self.amplitude
    }

    /// The phase `θ = k·(d·p0) − ω·t + φ`, formed in f64 and reduced to [−π, π].
    #[inline]
    pub fn phase_at(&self, p0: DVec2, t: f64) -> f64 {
        let along = self.direction.x * p0.x + self.direction.y * p0.y;
        reduce_phase(self.wavenumber * along - self.omega * t + self.phase)
    }

    /// Adds this wave's displacement (and, if `derivatives`, its derivatives) at `p0`, time `t`.
    #[inline]
    pub fn accumulate(&self, p0: DVec2, t: f64, derivatives: bool, out: &mut SurfaceSample) {
        let (s, c) = sin_cos(self.phase_at(p0, t));
        accumulate_with(self, s, c, derivatives, out);
    }

    /// Slow reference: the same sum with the phase left unreduced and the platform's f64
    /// `sin`/`cos` (which reduce exactly). For tests and reports, not for model results.
    pub fn accumulate_reference(&self, p0: DVec2, t: f64, out: &mut SurfaceSample) {
        let along = self.direction.x * p0.x + self.direction.y * p0.y;
        let theta = self.wavenumber * along - self.omega * t + self.phase;
        let (s, c) = theta.sin_cos(); // reference path: platform trig on purpose
        accumulate_with(self, s, c, true, out);
    }
}

#[inline]
fn accumulate_with(w: &Wave, s: f64, c: f64, derivatives: bool, out: &mut SurfaceSample) {
    let a = w.amplitude;
    let qa = w.steepness * a;
    let (dx, dz) = (w.direction.x, w.direction.y);
    out.displacement.x += qa * dx * c;
    out.displacement.y += a * s;
    out.displacement.z += qa * dz * c;
    if derivatives {
        let ak_c = a * w.wavenumber * c;
        let qak_s = qa * w.wavenumber * s;
        // ∂/∂x0 of (Q A dx cos θ, A sin θ, Q A dz cos θ) with ∂θ/∂x0 = k dx.
        out.d_dx.x -= qak_s * dx * dx;
        out.d_dx.y += ak_c * dx;
        out.d_dx.z -= qak_s * dx * dz;
        out.d_dz.x -= qak_s * dx * dz;
        out.d_dz.y += ak_c * dz;
        out.d_dz.z -= qak_s * dz * dz;
    }
}

/// Sums `waves` at `p0`, time `t` into `out`.
#[inline]
pub fn accumulate_all(
    waves: &[Wave],
    p0: DVec2,
    t: f64,
    derivatives: bool,
    out: &mut SurfaceSample,
) {
    for w in waves {
        w.accumulate(p0, t, derivatives, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wave(q: f64) -> Wave {
        Wave::build(
            "w",
            1.0,
            20.0,
            [1.0, 0.0],
            0.0,
            None,
            q,
            &Dispersion::default(),
        )
        .unwrap()
    }

    #[test]
    fn derivatives_match_central_differences() {
        let w = Wave::build(
            "w",
            0.7,
            13.0,
            [0.3, -0.8],
            0.4,
            None,
            0.8,
            &Dispersion::default(),
        )
        .unwrap();
        let p = DVec2::new(3.1, -7.4);
        let t = 12.5;
        let mut s = SurfaceSample::default();
        w.accumulate(p, t, true, &mut s);
        let e = 1e-6;
        let at = |q: DVec2| {
            let mut o = SurfaceSample::default();
            w.accumulate(q, t, false, &mut o);
            o.displacement
        };
        let fx = (at(p + DVec2::X * e) - at(p - DVec2::X * e)) / (2.0 * e);
        let fz = (at(p + DVec2::Y * e) - at(p - DVec2::Y * e)) / (2.0 * e);
        assert!((fx - s.d_dx).length() < 1e-7, "{fx} vs {}", s.d_dx);
        assert!((fz - s.d_dz).length() < 1e-7, "{fz} vs {}", s.d_dz);
    }

    /// The Gerstner sign convention: points crowd towards the crest, so the crest (where the
    /// surface is highest) is narrower than the trough. On the displaced profile the part above
    /// mid-height spans θ ∈ (0, π), whose ends move by `Q·A·cos θ`, so its width is exactly
    /// `λ/2 − 2·Q·A` (and the trough's `λ/2 + 2·Q·A`). A flipped sign would swap them.
    #[test]
    fn single_gerstner_crest_is_sharper_than_trough() {
        let w = wave(0.9);
        let n = 20_000;
        let lambda = w.wavelength();
        let mut above = 0.0;
        let mut prev: Option<(f64, f64)> = None;
        for i in 0..=n {
            let x0 = lambda * i as f64 / n as f64;
            let mut s = SurfaceSample::default();
            w.accumulate(DVec2::new(x0, 0.0), 0.0, false, &mut s);
            let (x, y) = (x0 + s.displacement.x, s.displacement.y);
            if let Some((px, py)) = prev
                && y > 0.0
                && py > 0.0
            {
                above += x - px;
            }
            prev = Some((x, y));
        }
        let expect = 0.5 * lambda - 2.0 * 0.9 * 1.0;
        assert!(
            (above - expect).abs() < 1e-2,
            "crest width {above}, expected {expect}"
        );
        // And with Q = 0 (a sine) both halves are equal.
        let w0 = wave(0.0);
        let mut above0 = 0.0;
        for i in 0..n {
            let x0 = lambda * (i as f64 + 0.5) / n as f64;
            let mut s = SurfaceSample::default();
            w0.accumulate(DVec2::new(x0, 0.0), 0.0, false, &mut s);
            if s.displacement.y > 0.0 {
                above0 += lambda / n as f64;
            }
        }
        assert!((above0 - 0.5 * lambda).abs() < 1e-3 * lambda);
    }

    #[test]
    fn wave_travels_along_its_direction() {
        let w = wave(0.0);
        // A crest at x = x_c at t moves to x_c + c·dt at t + dt.
        let c = w.omega / w.wavenumber;
        let y = |x: f64, t: f64| {
            let mut s = SurfaceSample::default();
            w.accumulate(DVec2::new(x, 0.0), t, false, &mut s);
            s.displacement.y
        };
        for &(x, t) in &[(1.0, 0.0), (4.5, 3.0), (-2.0, 10.0)] {
            assert!((y(x, t) - y(x + c * 0.7, t + 0.7)).abs() < 1e-12);
        }
    }

    #[test]
    fn far_positions_and_huge_times_match_reference() {
        let w = wave(0.8);
        for &(x, z, t) in &[
            (1e7, -1e7, 0.0),
            (-9.9e6, 3.3e6, 1e9),
            (0.5, 0.5, 1e9 + 0.25),
        ] {
            let p = DVec2::new(x, z);
            let mut a = SurfaceSample::default();
            let mut b = SurfaceSample::default();
            w.accumulate(p, t, true, &mut a);
            w.accumulate_reference(p, t, &mut b);
            assert!(
                (a.displacement - b.displacement).length() < 1e-6,
                "{x} {z} {t}"
            );
        }
    }

    #[test]
    fn validation_names_fields() {
        let d = Dispersion::default();
        let e = Wave::build("waves[2]", -1.0, 1.0, [1.0, 0.0], 0.0, None, 0.0, &d).unwrap_err();
        assert_eq!(e.field(), "waves[2].amplitude");
        let e = Wave::build("w", 1.0, 0.0, [1.0, 0.0], 0.0, None, 0.0, &d).unwrap_err();
        assert_eq!(e.field(), "w.wavelength");
        let e = Wave::build("w", 1.0, 1.0, [0.0, 0.0], 0.0, None, 0.0, &d).unwrap_err();
        assert!(matches!(e, SpecError::ZeroDirection { .. }));
        let e = Wave::build("w", 1.0, 1.0, [1.0, 0.0], f64::NAN, None, 0.0, &d).unwrap_err();
        assert_eq!(e.field(), "w.phase");
        let e = Wave::build("w", 1.0, 1.0, [1.0, 0.0], 0.0, Some(0.0), 0.0, &d).unwrap_err();
        assert_eq!(e.field(), "w.speed");
        let e = Wave::build("w", 1.0, 1.0, [1.0, 0.0], 0.0, None, 1.5, &d).unwrap_err();
        assert_eq!(e.field(), "w.steepness");
    }

    #[test]
    fn speed_override_sets_omega() {
        let d = Dispersion::default();
        let w = Wave::build("w", 1.0, 10.0, [1.0, 0.0], 0.0, Some(3.0), 0.0, &d).unwrap();
        assert!((w.omega - 3.0 * TAU / 10.0).abs() < 1e-15);
    }
}
