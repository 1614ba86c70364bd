//! The model's integration tests, one module per area, in one test binary: one build and one
//! link of the model and its dev-dependencies for all of them instead of one per file.
//!
//! Kept in binaries of their own (`tests/*.rs`): `golden` (CI builds it again for x86-64-v3)
//! and `simd_levels` (CI runs it once per forced SIMD level).
//!
//! Run one area with a filter: `cargo test --workspace --test model -- velocity::`.

#[path = "../common/mod.rs"]
mod common;

mod bodies;
mod body_physics;
mod fft_surface;
mod particles;
mod queries;
mod time_grid;
mod velocity;
