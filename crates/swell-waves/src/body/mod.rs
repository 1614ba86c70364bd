//! Floating bodies. For now: the static orientation of a body resting on the surface, from
//! probe points and a least-squares plane fit.

mod orientation;

pub use orientation::{BodyFootprint, MAX_PROBES, Orientation, fit_plane, yaw_quat};
