//! The dynamic state of a body, its status flags, and rotation helpers built on the crate's
//! deterministic `sin_cos` (glam's `from_axis_angle` and friends call the platform's).

use glam::{DQuat, DVec3};

use crate::error::{SpecError, field_path, finite};
use crate::math::sin_cos;
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Where a body is and how it moves.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct BodyState {
    /// World position of the body origin (the box centre for a box hull), m.
    pub position: DVec3,
    /// World rotation of the body frame (unit quaternion): +x bow, +y up, +z side.
    pub rotation: DQuat,
    /// World velocity of the centre of mass, m/s.
    pub velocity: DVec3,
    /// World angular velocity, rad/s.
    pub angular_velocity: DVec3,
}

impl BodyState {
    /// At rest at `position`, turned by `yaw` about +y (rad; positive turns the bow from +x
    /// towards −z, as in [`super::yaw_quat`]).
    pub fn at_rest(position: DVec3, yaw: f64) -> BodyState {
        BodyState {
            position,
            rotation: super::yaw_quat(yaw),
            velocity: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
        }
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.position.is_finite()
            && self.rotation.is_finite()
            && self.velocity.is_finite()
            && self.angular_velocity.is_finite()
    }

    /// Checks every component is finite and the rotation has non-zero length, and returns the
    /// state with its rotation normalised. `field` prefixes error paths (empty: the fields are
    /// at the root, `position[i]`).
    ///
    /// # Errors
    /// A non-finite component (`{field}.position[i]`, …), or a zero rotation
    /// (`{field}.rotation`).
    pub fn validated(&self, field: &str) -> Result<BodyState, SpecError> {
        let vecs = [
            ("position", self.position),
            ("velocity", self.velocity),
            ("angular_velocity", self.angular_velocity),
        ];
        for (name, v) in vecs {
            for i in 0..3 {
                finite(&field_path(field, &format!("{name}[{i}]")), v[i])?;
            }
        }
        let q = self.rotation;
        for (i, c) in [q.x, q.y, q.z, q.w].into_iter().enumerate() {
            finite(&field_path(field, &format!("rotation[{i}]")), c)?;
        }
        let len = q.length();
        if !(len > 1e-12 && len.is_finite()) {
            return Err(SpecError::OutOfRange {
                field: field_path(field, "rotation"),
                value: len,
                allowed: "a quaternion of non-zero length (it is normalised)".into(),
            });
        }
        Ok(BodyState {
            rotation: q / len,
            ..*self
        })
    }
}

/// What happened to a body in the last step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct BodyStatus {
    /// Submerged fraction of the hull volume at the last substep, in [0, 1].
    pub submerged: f64,
    /// The last step produced a non-finite state and was rolled back (velocities zeroed).
    pub quarantined: bool,
    /// How many steps have been rolled back since the body was added.
    pub rollbacks: u64,
    /// Substeps per tick this body takes (see [`super::substeps_for`]).
    pub substeps: u32,
}

/// The rotation by the rotation vector `phi` (axis · angle, rad) as a unit quaternion:
/// `(sin(θ/2)·φ/θ, cos(θ/2))` with θ = |φ|, using [`crate::math::sin_cos`]. Below θ = 1e-12
/// the first-order form `(φ/2, 1)` (normalised) is used, exact to rounding there.
pub fn quat_from_rotation_vector(phi: DVec3) -> DQuat {
    let theta = phi.length();
    if theta < 1e-12 {
        let half = phi * 0.5;
        return DQuat::from_xyzw(half.x, half.y, half.z, 1.0).normalize();
    }
    let (s, c) = sin_cos(0.5 * theta);
    let axis = phi * (s / theta);
    DQuat::from_xyzw(axis.x, axis.y, axis.z, c)
}
