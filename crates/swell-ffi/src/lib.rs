//! # swell-ffi
//!
//! Swell's wave model behind a C ABI, for native game engines (Unreal, Godot GDExtension,
//! C# P/Invoke, anything that links C): the same code the server runs, so a native client
//! evaluates the sea and predicts its own boat to the server's bits.
//!
//! The header is `include/swell.h`, generated from this crate by cbindgen and checked in
//! (`tests/header.rs` fails when it is stale and says how to regenerate it).
//!
//! # Layout
//! - [`error`] — status codes (`SWELL_OK`, `SWELL_ERR_*`), the thread's last error message,
//!   and the guard that keeps panics from crossing the boundary.
//! - [`scene`] — a scene spec read exactly as the server reads a scene `PUT`.
//! - [`surface`] — surface handles and their queries: height with inversion, normal,
//!   displacement, Jacobian, residual, a footprint's orientation; FFT layers included.
//! - [`world`] — body worlds set up as the server sets up a scene's bodies: spawn, inputs,
//!   step, state, copies for rewinding (prediction and reconciliation), API impacts felt and
//!   the bodies' own splashes and wakes.
//!
//! # Conventions
//! The model's: right-handed, y up, the sea in x/z; metres, seconds, radians, kilograms;
//! quaternions `[x, y, z, w]`; scene time t in seconds and scene ticks `floor(t·tick_hz)`.
//!
//! # The C contract
//! - Every fallible function returns a [`SwellStatus`]: `SWELL_OK` (0) or an error code;
//!   [`swell_last_error_message`] then says what was wrong (per thread).
//! - No panic unwinds into C: each exported function runs in `catch_unwind` and reports a
//!   caught panic as `SWELL_ERR_PANIC`.
//! - Handles are opaque pointers with explicit free functions (`swell_surface_free`,
//!   `swell_world_free`; null is ignored). Null pointers where a value is needed are
//!   `SWELL_ERR_NULL`, never a crash; other invalid pointers are undefined behaviour.
//! - Plain C types only (fixed-width integers, doubles, arrays inside structs, `const char*`
//!   with a length): callable from C# with `[DllImport]` and blittable structs.
//!
//! # Determinism
//! The model's promise holds through the ABI: the same spec, time and point give the server's
//! bits (the C test checks `proto/vectors/surface_v1.json`), and a world anchored at the
//! server's tick, given the same spawns and inputs at the same ticks, reaches the server's body
//! states bit for bit (the C test checks `proto/vectors/bodies_v1.json`, produced by the
//! server's own body code). Impacts too: a surface given the scene's impacts
//! ([`swell_surface_set_impacts`]) answers the server's query bits, and a world fed the API
//! impacts at the ticks the server published ([`swell_world_feel_impact`]) steps on them and on
//! its bodies' own splashes and wakes as the server's world does (the model's
//! `body::WorldImpacts`, which both step through).
#![warn(missing_docs)]

pub mod error;
pub mod scene;
pub mod surface;
pub mod world;

pub use error::*;
pub use surface::*;
pub use world::*;

/// The model version the library's numbers belong to (`swell_waves::MODEL_VERSION`): compare it
/// with the server's to know you evaluate the same sea.
#[unsafe(no_mangle)]
pub extern "C" fn swell_model_version() -> u32 {
    swell_waves::MODEL_VERSION
}
