//! Floating bodies: the static orientation of a body resting on the surface (probe points and a
//! plane fit), and a deterministic rigid-body buoyancy simulation stepped at a fixed rate.
//!
//! # The simulation
//! - **Body** ([`BodySpec`]): mass, a hull of vertical columns ([`HullSpec`]: a box split into
//!   4 × 2 columns by default, or explicit cells), centre of mass, inertia from the hull
//!   ([`Hull::inertia`]), linear and quadratic drag, angular damping, a wavelength filter.
//! - **Forces** each substep (formulas on [`BodySpec`]): gravity `m·g` at the centre of mass;
//!   buoyancy `ρ·g·V·f` per cell at the cell centre (f the cell's submerged fraction under the
//!   sea height above it), so torques arise; drag against the water's own orbital velocity
//!   ([`crate::velocity`]) scaled by f; angular damping; inputs ([`BodyInput`]: force and torque
//!   in the body frame from a tick for a number of ticks).
//! - **Integrator**: fixed step `dt = 1/tick_hz`, split into [`substeps_for`] substeps so that
//!   the stiffest natural oscillation (`ω_n = sqrt(ρ·g·A_wp/m)` for heave) advances at most
//!   0.25 rad per substep; semi-implicit (symplectic) Euler for translation; angular momentum
//!   in the world frame with the rotated inertia, the orientation quaternion advanced by
//!   `exp(h·ω)` and renormalised.
//! - **Containment**: a body whose state turns non-finite is rolled back to its state before
//!   the step, its velocities zeroed, and flagged ([`BodyStatus`]); NaN never leaves a step.
//! - **Determinism**: see [`World`].
//! - **Impacts** ([`WorldImpacts`]): the API impacts a world feels from the tick they reach
//!   it, and the splashes and wakes its bodies make when the sea's particle layer has
//!   `body_impacts`; the bodies step on the sea rippled by both.
//! - **A scene's authority** sets its world up with [`authority_settings`],
//!   [`authority_step_options`] and [`SpawnSpec`] (the default damping): the server and the C ABI
//!   both build from these, so a client's prediction reaches the server's bits.
//!
//! Limits: no added mass or radiation damping (heave periods are the hydrostatic
//! `2π·sqrt(m/(ρ·g·A_wp))`); buoyancy is vertical (no wave-pressure gradient, so a body drifts
//! only through drag against the orbital velocity); bodies do not collide.

mod authority;
mod buoyancy;
mod hull;
mod impacts;
mod orientation;
mod spec;
mod state;
mod water;
mod world;

pub use authority::{DEFAULT_DAMPING_RATIO, SpawnSpec, authority_settings, authority_step_options};
pub use hull::{
    Cell, CellSpec, DEFAULT_BOX_CELLS, Hull, HullSpec, MAX_BOX_CELLS_PER_SIDE, MAX_CELLS,
    MAX_HULL_SIZE, MIN_HULL_SIZE,
};
pub use impacts::{
    BODY_IMPACT_HISTORY, Derived, MAX_BODY_IMPACTS, MAX_BODY_NEAR_IMPACTS, MAX_FELT_IMPACTS,
    WorldImpacts, ripple_or_bare,
};
pub use orientation::{
    BodyFootprint, MAX_FOOTPRINT, MAX_PROBES, MAX_YAW, Orientation, fit_plane, yaw_quat,
};
pub use spec::{BodyModel, BodySpec, MAX_MASS, MAX_WAVELENGTH_FACTOR};
pub use state::{BodyState, BodyStatus, quat_from_rotation_vector};
pub use water::WaterPoint;
pub use world::{
    Body, BodyId, BodyInput, MAX_SUBSTEPS, MAX_TICK_HZ, MIN_TICK_HZ, PHASE_PER_SUBSTEP,
    SEA_WATER_DENSITY, WarmStart, World, WorldSettings, WorldSnapshot, substeps_for,
};
