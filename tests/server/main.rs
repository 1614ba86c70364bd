//! The server's integration tests, one module per area, in one test binary: one build and one
//! link for all of them (21 binaries, one per file, took ~20 s of CPU each in a cold build,
//! every one linked against the whole server; this one ~40 s), and tests that wait on sockets,
//! child processes or browsers overlap with the rest instead of running file by file.
//!
//! Kept in binaries of their own (`tests/*.rs`): `fleet` (its 200 ms bounds must not measure the
//! load of other tests; its tests run one at a time), `hostile` (latency and RSS bounds under an
//! attack it makes itself), `memory` (the process's RSS) and `shader_snapshots` (snapshot names).
//!
//! Run one area with a filter: `cargo test --workspace --test server -- durability::`.

#[path = "../common/mod.rs"]
mod common;

mod api;
mod bodies;
mod body_vectors;
mod browser_fft;
mod browser_parity;
mod clock;
mod connections;
mod determinism;
mod durability;
mod error_codes;
mod errors;
mod impacts;
mod layers;
mod lifecycle;
mod native;
mod native_body_impacts;
mod native_impacts;
mod native_reconcile;
mod openapi;
mod process;
mod protobuf;
mod shader;
mod stream;
