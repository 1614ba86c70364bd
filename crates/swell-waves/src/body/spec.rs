//! What a floating body is: mass, hull, centre of mass, drag and damping, the wavelength filter;
//! validated into a [`BodyModel`] with everything the integrator needs precomputed.

use glam::{DMat3, DVec3};

use super::hull::{Hull, HullSpec};
use crate::error::{SpecError, field_path, finite, non_negative, positive};
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Largest mass a body may have, kg: 10⁹ kg is a supertanker; beyond that the number is a typo.
pub const MAX_MASS: f64 = 1e9;
/// Largest [`BodySpec::min_wavelength_factor`]: beyond 100 hull lengths every wave is filtered.
pub const MAX_WAVELENGTH_FACTOR: f64 = 100.0;

/// A floating rigid body as written in a scene spec.
///
/// Forces each substep (see [`crate::body`]): gravity `−m·g·ŷ` at the centre of mass; per cell,
/// buoyancy `ρ·g·V·f·ŷ` at the cell centre, f the submerged fraction; per cell, drag
/// `−f·(V/ΣV)·(c₁ + c₂·|u|)·u` at the cell centre, u the cell's velocity relative to the water;
/// an angular damping torque `−c_ω·(V_sub/ΣV)·ω`. So the drag coefficients are those of the
/// fully submerged hull, and a body in the air feels neither drag nor damping.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct BodySpec {
    /// Mass m, kg (> 0, ≤ 10⁹). A body floats if `m < ρ·ΣV`.
    pub mass: f64,
    /// The hull.
    pub hull: HullSpec,
    /// Centre of mass in the body frame `[x, y, z]`, m; must lie inside the hull's bounding
    /// box. Default the origin (the box centre). Lower it for more roll stability.
    #[cfg_attr(feature = "serde", serde(default))]
    pub center_of_mass: [f64; 3],
    /// Linear drag c₁ of the fully submerged hull, N·s/m (≥ 0). Default 0. For a heave damping
    /// ratio ζ at draft fraction f: `c₁ ≈ 2·ζ·sqrt(ρ·g·A_wp·m)/f`.
    #[cfg_attr(feature = "serde", serde(default))]
    pub linear_drag: f64,
    /// Quadratic drag c₂ of the fully submerged hull, N·s²/m² (≥ 0); about `½·ρ·C_d·area`.
    /// Default 0.
    #[cfg_attr(feature = "serde", serde(default))]
    pub quadratic_drag: f64,
    /// Angular damping c_ω, N·m·s/rad (≥ 0), scaled by the submerged volume fraction.
    /// Default 0.
    #[cfg_attr(feature = "serde", serde(default))]
    pub angular_damping: f64,
    /// Size filter: analytic (sine and Gerstner) waves shorter than this factor times the hull
    /// length are ignored by this body (in [0, 100]); 0, the default, keeps every wave. A hull
    /// averages out waves much shorter than itself anyway, and skipping them saves their
    /// evaluation. Not applied to FFT layers, which are sampled from grids as a whole.
    #[cfg_attr(feature = "serde", serde(default))]
    pub min_wavelength_factor: f64,
}

/// A validated body with its derived constants.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyModel {
    pub(crate) mass: f64,
    pub(crate) hull: Hull,
    pub(crate) com: DVec3,
    pub(crate) inertia: DMat3,
    pub(crate) inv_inertia: DMat3,
    /// Smallest principal-axis moment bound used by the drag limiter: the smallest diagonal
    /// entry of the body-frame inertia, kg·m².
    pub(crate) min_moment: f64,
    pub(crate) linear_drag: f64,
    pub(crate) quadratic_drag: f64,
    pub(crate) angular_damping: f64,
    pub(crate) min_wavelength: f64,
}

impl BodySpec {
    /// A box body with the default 4 × 2 cells, centre of mass at the box centre, no drag.
    pub fn boxed(mass: f64, length: f64, beam: f64, height: f64) -> BodySpec {
        BodySpec {
            mass,
            hull: HullSpec::Box {
                length,
                beam,
                height,
                cells: None,
            },
            center_of_mass: [0.0; 3],
            linear_drag: 0.0,
            quadratic_drag: 0.0,
            angular_damping: 0.0,
            min_wavelength_factor: 0.0,
        }
    }

    /// Validates the spec and precomputes the body's constants. `field` prefixes error paths
    /// (`bodies[3]` names `bodies[3].mass`); an empty `field` names them from the spec's root
    /// (`mass`, `hull.length`), as [`super::World::add`] does.
    ///
    /// # Errors
    /// [`SpecError`] naming the field when: `{field}.mass` is not finite and in (0, 10⁹];
    /// any hull field is invalid (see [`HullSpec::build`]); `{field}.center_of_mass[i]` is not
    /// finite or lies outside the hull's bounding box; a drag or damping coefficient is not
    /// finite and ≥ 0; `{field}.min_wavelength_factor` is not in [0, 100]; the inertia tensor
    /// is not invertible (`{field}.hull`, only for absurd scales).
    pub fn build(&self, field: &str) -> Result<BodyModel, SpecError> {
        let at = |name: &str| field_path(field, name);
        let mass = positive(&at("mass"), self.mass)?;
        if mass > MAX_MASS {
            return Err(SpecError::OutOfRange {
                field: at("mass"),
                value: mass,
                allowed: format!("in (0, {MAX_MASS}] kg"),
            });
        }
        let hull = self.hull.build(&at("hull"))?;
        let (lo, hi) = hull.bounds();
        for i in 0..3 {
            let name = at(&format!("center_of_mass[{i}]"));
            let v = finite(&name, self.center_of_mass[i])?;
            if !(lo[i]..=hi[i]).contains(&v) {
                return Err(SpecError::OutOfRange {
                    field: name,
                    value: v,
                    allowed: format!("in [{}, {}] m (inside the hull)", lo[i], hi[i]),
                });
            }
        }
        let com = DVec3::from_array(self.center_of_mass);
        let linear_drag = non_negative(&at("linear_drag"), self.linear_drag)?;
        let quadratic_drag = non_negative(&at("quadratic_drag"), self.quadratic_drag)?;
        let angular_damping = non_negative(&at("angular_damping"), self.angular_damping)?;
        let factor = non_negative(&at("min_wavelength_factor"), self.min_wavelength_factor)?;
        if factor > MAX_WAVELENGTH_FACTOR {
            return Err(SpecError::OutOfRange {
                field: at("min_wavelength_factor"),
                value: factor,
                allowed: format!("in [0, {MAX_WAVELENGTH_FACTOR}]"),
            });
        }
        let inertia = hull.inertia(mass, com);
        let det = inertia.determinant();
        let inv_inertia = inertia.inverse();
        let min_moment = inertia.x_axis.x.min(inertia.y_axis.y).min(inertia.z_axis.z);
        if !(det > 0.0 && det.is_finite() && inv_inertia.is_finite() && min_moment > 0.0) {
            return Err(SpecError::Inconsistent {
                field: at("hull"),
                reason: format!(
                    "the inertia tensor of this mass and hull is not invertible (determinant {det})"
                ),
            });
        }
        Ok(BodyModel {
            mass,
            min_wavelength: factor * hull.length(),
            hull,
            com,
            inertia,
            inv_inertia,
            min_moment,
            linear_drag,
            quadratic_drag,
            angular_damping,
        })
    }
}

impl BodyModel {
    /// Mass m, kg.
    pub fn mass(&self) -> f64 {
        self.mass
    }

    /// The hull.
    pub fn hull(&self) -> &Hull {
        &self.hull
    }

    /// Centre of mass in the body frame, m.
    pub fn center_of_mass(&self) -> DVec3 {
        self.com
    }

    /// Body-frame inertia tensor about the centre of mass, kg·m² (see [`Hull::inertia`]).
    pub fn inertia(&self) -> DMat3 {
        self.inertia
    }

    /// Analytic waves shorter than this are ignored, m (`min_wavelength_factor · hull length`).
    pub fn min_wavelength(&self) -> f64 {
        self.min_wavelength
    }

    /// Natural heave frequency on flat water, `ω_n = sqrt(ρ·g·A_wp/m)`, rad/s: the stiffness of
    /// the hydrostatic spring `k = ρ·g·A_wp` over the mass (no added mass).
    pub fn heave_frequency(&self, water_density: f64, gravity: f64) -> f64 {
        (water_density * gravity * self.hull.waterplane_area / self.mass).sqrt()
    }

    /// Natural frequency of the stiffer of roll and pitch on flat water, rad/s:
    /// `sqrt(ρ·g·Σ a_i·z_i²/I_xx)` (roll) and `sqrt(ρ·g·Σ a_i·x_i²/I_zz)` (pitch), with `a_i`
    /// the cell cross-sections and `x_i`, `z_i` their body-frame offsets from the centre of
    /// mass. For a box both are below the heave frequency; for odd cell layouts they may not be.
    pub fn rotation_frequency(&self, water_density: f64, gravity: f64) -> f64 {
        let (mut roll, mut pitch) = (0.0, 0.0);
        for c in &self.hull.cells {
            let r = c.position - self.com;
            let a = c.volume / c.height;
            roll += a * r.z * r.z;
            pitch += a * r.x * r.x;
        }
        let k = water_density * gravity;
        (k * roll / self.inertia.x_axis.x)
            .max(k * pitch / self.inertia.z_axis.z)
            .sqrt()
    }
}
