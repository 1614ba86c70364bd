//! Orientation of a floating body from the heights under probe points.
//!
//! Body frame: `u` points forward (bow), `v` to the side, y up. A body at world `(x, z)` with yaw
//! ψ (rotation about +y, right-handed: positive ψ turns the bow from +x towards −z) has its
//! forward axis along `(cos ψ, 0, −sin ψ)` and its side axis along `(sin ψ, 0, cos ψ)`.
//! We sample the sea height at each probe, fit the plane `y = heave + b·u + c·v` by least
//! squares, and report:
//! - `heave`: the plane's height at the body origin, m;
//! - `pitch = atan(b)` (bow up is positive) and `roll = atan(c)` (the +v side up is positive), rad;
//! - `normal`: the plane's unit normal in world space;
//! - `rotation = yaw · tilt`: first tilt (the shortest rotation taking +y to the body-frame normal
//!   `(−b, 1, −c)/|…|`), then yaw about +y into the world.

use glam::{DQuat, DVec2, DVec3};

use crate::error::{SpecError, finite, in_range, positive_at_most};
use crate::math::sin_cos;
use crate::surface::SurfaceAt;
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Most explicit probes per body: each costs one height query.
pub const MAX_PROBES: usize = 256;

/// Largest footprint length or beam, and largest `|u|`, `|v|` of an explicit probe, m: 10 km.
/// Twenty times the longest ship afloat, so no real body is refused, and small enough that the
/// plane fit's sums of squared probe offsets (over at most [`MAX_PROBES`] probes) stay finite
/// with room to spare. Unbounded, a length of 1e300 overflowed the fit and the orientation came
/// out NaN.
pub const MAX_FOOTPRINT: f64 = 10_000.0;

/// Largest `|yaw|`, rad: 10⁹ rad (1.6·10⁸ turns). The crate's deterministic `sin_cos` reduces
/// its argument exactly only up to about 2.7·10¹⁰ rad, and far beyond that its answer is not even
/// finite; unbounded, a yaw of 7e99 made every probe's world position NaN and the orientation came
/// out NaN. No heading a client accumulates gets near this (a body turning at 1 rad/s for 30 years).
pub const MAX_YAW: f64 = 1e9;

/// Where a body touches the water: a rectangular footprint, or explicit probe points.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct BodyFootprint {
    /// World position `(x, z)` of the body origin, m.
    pub position: [f64; 2],
    /// Yaw ψ, rad (rotation about +y), within ±[`MAX_YAW`].
    #[cfg_attr(feature = "serde", serde(default))]
    pub yaw: f64,
    /// Length along the forward axis, m (in (0, [`MAX_FOOTPRINT`]]).
    pub length: f64,
    /// Beam (width) along the side axis, m (in (0, [`MAX_FOOTPRINT`]]).
    pub beam: f64,
    /// Explicit probe points `(u, v)` in the body frame, m (each within ±[`MAX_FOOTPRINT`]).
    /// Absent means a 3×3 grid over the footprint (corners, edge midpoints, centre).
    #[cfg_attr(feature = "serde", serde(default))]
    pub probes: Option<Vec<[f64; 2]>>,
}

/// A body's orientation on the sea.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orientation {
    /// Height of the fitted plane at the body origin, m.
    pub heave: f64,
    /// World rotation: yaw after tilt.
    pub rotation: DQuat,
    /// World unit normal of the fitted plane.
    pub normal: DVec3,
    /// Pitch, rad (bow up positive).
    pub pitch: f64,
    /// Roll, rad (+v side up positive).
    pub roll: f64,
}

/// Rotation by ψ about +y, built with the crate's deterministic `sin_cos` (glam's
/// `from_rotation_y` would use the platform's).
pub fn yaw_quat(yaw: f64) -> DQuat {
    let (s, c) = sin_cos(0.5 * yaw);
    DQuat::from_xyzw(0.0, s, 0.0, c)
}

impl BodyFootprint {
    /// Validates the body and returns its probes in the body frame.
    ///
    /// # Errors
    /// Non-finite position; a yaw that is not finite or beyond ±[`MAX_YAW`]; length or beam ≤ 0
    /// (a body of zero size has no orientation) or above [`MAX_FOOTPRINT`]; a probe coordinate
    /// beyond ±[`MAX_FOOTPRINT`]; an empty or over-long probe list.
    pub fn probes(&self, field: &str) -> Result<Vec<DVec2>, SpecError> {
        finite(&format!("{field}.position[0]"), self.position[0])?;
        finite(&format!("{field}.position[1]"), self.position[1])?;
        in_range(&format!("{field}.yaw"), self.yaw, -MAX_YAW, MAX_YAW)?;
        let l = positive_at_most(&format!("{field}.length"), self.length, MAX_FOOTPRINT)?;
        let b = positive_at_most(&format!("{field}.beam"), self.beam, MAX_FOOTPRINT)?;
        match &self.probes {
            None => {
                let mut v = Vec::with_capacity(9);
                for i in [-0.5, 0.0, 0.5] {
                    for j in [-0.5, 0.0, 0.5] {
                        v.push(DVec2::new(i * l, j * b));
                    }
                }
                Ok(v)
            }
            Some(p) => {
                if p.is_empty() || p.len() > MAX_PROBES {
                    return Err(SpecError::BadLength {
                        field: format!("{field}.probes"),
                        len: p.len(),
                        allowed: format!("1..={MAX_PROBES}"),
                    });
                }
                p.iter()
                    .enumerate()
                    .map(|(i, q)| {
                        let (lo, hi) = (-MAX_FOOTPRINT, MAX_FOOTPRINT);
                        in_range(&format!("{field}.probes[{i}][0]"), q[0], lo, hi)?;
                        in_range(&format!("{field}.probes[{i}][1]"), q[1], lo, hi)?;
                        Ok(DVec2::new(q[0], q[1]))
                    })
                    .collect()
            }
        }
    }

    /// World position of a body-frame probe `(u, v)`.
    pub fn probe_world(&self, probe: DVec2) -> DVec2 {
        let (s, c) = sin_cos(self.yaw);
        // forward = (cos ψ, −sin ψ), side = (sin ψ, cos ψ) in (x, z).
        DVec2::new(
            self.position[0] + probe.x * c + probe.y * s,
            self.position[1] - probe.x * s + probe.y * c,
        )
    }

    /// Samples the sea under every probe and fits the orientation.
    ///
    /// # Errors
    /// As [`BodyFootprint::probes`].
    pub fn orientation(&self, sea: &SurfaceAt<'_>, field: &str) -> Result<Orientation, SpecError> {
        let probes = self.probes(field)?;
        let heights: Vec<f64> = probes
            .iter()
            .map(|&p| {
                let w = self.probe_world(p);
                sea.height(w.x, w.y)
            })
            .collect();
        Ok(fit_plane(self.yaw, &probes, &heights))
    }
}

/// Least-squares plane `y = heave + b·u + c·v` through body-frame probes and their heights, and
/// the orientation it implies (see the module docs). Total: any finite input with
/// `|yaw| ≤` [`MAX_YAW`] gives a finite answer. Probes that do not span a plane (one point, or
/// all on a line) fix only the slope they can see: a single point gives a level plane; collinear
/// probes tilt only along their line.
pub fn fit_plane(yaw: f64, probes: &[DVec2], heights: &[f64]) -> Orientation {
    let n = probes.len().min(heights.len());
    let (mut b, mut c, mut heave) = (0.0, 0.0, 0.0);
    if n > 0 {
        let inv_n = 1.0 / n as f64;
        let mut mu = DVec2::ZERO;
        let mut my = 0.0;
        for i in 0..n {
            mu += probes[i];
            my += heights[i];
        }
        mu *= inv_n;
        my *= inv_n;
        let (mut suu, mut suv, mut svv, mut suy, mut svy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..n {
            let d = probes[i] - mu;
            let y = heights[i] - my;
            suu += d.x * d.x;
            suv += d.x * d.y;
            svv += d.y * d.y;
            suy += d.x * y;
            svy += d.y * y;
        }
        let trace = suu + svv;
        let det = suu * svv - suv * suv;
        if trace > 0.0 {
            if det > 1e-12 * trace * trace {
                b = (svv * suy - suv * svy) / det;
                c = (suu * svy - suv * suy) / det;
            } else {
                // Collinear probes: slope only along their line e (the principal axis).
                let e = if suu >= svv {
                    DVec2::new(suu, suv)
                } else {
                    DVec2::new(suv, svv)
                }
                .normalize_or_zero();
                let see = e.x * e.x * suu + 2.0 * e.x * e.y * suv + e.y * e.y * svv;
                if see > 0.0 {
                    let s = (e.x * suy + e.y * svy) / see;
                    b = s * e.x;
                    c = s * e.y;
                }
            }
        }
        if !(b.is_finite() && c.is_finite()) {
            b = 0.0;
            c = 0.0;
        }
        heave = my - b * mu.x - c * mu.y;
        if !heave.is_finite() {
            heave = my;
        }
    }
    let body_normal = DVec3::new(-b, 1.0, -c).normalize();
    let tilt = DQuat::from_rotation_arc(DVec3::Y, body_normal);
    let yq = yaw_quat(yaw);
    let rotation = (yq * tilt).normalize();
    Orientation {
        heave,
        rotation,
        normal: (yq * body_normal).normalize(),
        pitch: libm::atan(b),
        roll: libm::atan(c),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn grid() -> Vec<DVec2> {
        BodyFootprint {
            position: [0.0, 0.0],
            yaw: 0.0,
            length: 10.0,
            beam: 4.0,
            probes: None,
        }
        .probes("b")
        .unwrap()
    }

    #[test]
    fn fits_an_exact_plane() {
        let p = grid();
        let h: Vec<f64> = p.iter().map(|q| 1.5 + 0.1 * q.x - 0.2 * q.y).collect();
        let o = fit_plane(0.3, &p, &h);
        assert!((o.heave - 1.5).abs() < 1e-12);
        assert!((o.pitch - 0.1f64.atan()).abs() < 1e-12);
        assert!((o.roll - (-0.2f64).atan()).abs() < 1e-12);
        // rotation maps body up to the world normal; and body forward to a tilted yawed axis.
        let up = o.rotation * DVec3::Y;
        assert!((up - o.normal).length() < 1e-12);
        assert!((o.normal.length() - 1.0).abs() < 1e-12);
        // The world normal is perpendicular to the plane's world forward tangent.
        let fwd_world = yaw_quat(0.3) * DVec3::new(1.0, 0.1, 0.0);
        assert!(o.normal.dot(fwd_world).abs() < 1e-12);
    }

    #[test]
    fn yaw_turns_bow_from_x_towards_minus_z() {
        let q = yaw_quat(std::f64::consts::FRAC_PI_2);
        let f = q * DVec3::X;
        assert!((f - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-15);
        let b = BodyFootprint {
            position: [10.0, 20.0],
            yaw: std::f64::consts::FRAC_PI_2,
            length: 2.0,
            beam: 1.0,
            probes: None,
        };
        let w = b.probe_world(DVec2::new(1.0, 0.0));
        assert!((w - DVec2::new(10.0, 19.0)).length() < 1e-12);
    }

    #[test]
    fn degenerate_probes_stay_finite() {
        // One probe: level.
        let o = fit_plane(0.0, &[DVec2::new(1.0, 1.0)], &[2.0]);
        assert_eq!((o.heave, o.pitch, o.roll), (2.0, 0.0, 0.0));
        // Collinear along u: pitch only.
        let p = [
            DVec2::new(-1.0, 0.0),
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
        ];
        let o = fit_plane(0.0, &p, &[0.0, 0.5, 1.0]);
        assert!((o.pitch - 0.5f64.atan()).abs() < 1e-12);
        assert_eq!(o.roll, 0.0);
        // All probes at one point.
        let p = [DVec2::new(3.0, 3.0); 4];
        let o = fit_plane(1.0, &p, &[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(o.heave, 2.5);
        assert!(o.rotation.is_finite());
    }

    #[test]
    fn zero_size_bodies_are_rejected() {
        let mut b = BodyFootprint {
            position: [0.0, 0.0],
            yaw: 0.0,
            length: 0.0,
            beam: 1.0,
            probes: None,
        };
        assert_eq!(
            b.probes("bodies[0]").unwrap_err().field(),
            "bodies[0].length"
        );
        b.length = 1.0;
        b.beam = -1.0;
        assert_eq!(b.probes("bodies[0]").unwrap_err().field(), "bodies[0].beam");
        b.beam = 1.0;
        b.probes = Some(vec![]);
        assert_eq!(
            b.probes("bodies[0]").unwrap_err().field(),
            "bodies[0].probes"
        );
        b.probes = Some(vec![[f64::NAN, 0.0]]);
        assert!(b.probes("bodies[0]").is_err());
    }

    proptest! {
        /// Never NaN, for any finite input.
        #[test]
        fn plane_fit_is_total(
            yaw in -1e6f64..1e6,
            pts in proptest::collection::vec((-1e4f64..1e4, -1e4f64..1e4, -1e3f64..1e3), 1..12),
        ) {
            let p: Vec<DVec2> = pts.iter().map(|&(u, v, _)| DVec2::new(u, v)).collect();
            let h: Vec<f64> = pts.iter().map(|&(_, _, y)| y).collect();
            let o = fit_plane(yaw, &p, &h);
            prop_assert!(o.heave.is_finite() && o.pitch.is_finite() && o.roll.is_finite());
            prop_assert!(o.rotation.is_finite() && o.normal.is_finite());
            prop_assert!((o.normal.length() - 1.0).abs() < 1e-9);
            prop_assert!(o.normal.y > 0.0);
        }
    }
}
