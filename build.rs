//! Generates the protobuf types of `proto/swell/v1/*.proto` (the wire schema, the single source
//! of truth) into `OUT_DIR`, included by `src/wire/mod.rs`.
//!
//! protox parses the `.proto` files in pure Rust, so no system `protoc` is needed. Because the
//! code is generated on every build whose inputs changed, it can never be stale: there is no
//! checked-in copy for CI to compare against.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("cargo:rerun-if-changed=proto");
    let fds = protox::compile(
        ["proto/swell/v1/query.proto", "proto/swell/v1/stream.proto"],
        ["proto"],
    )?;
    prost_build::Config::new().compile_fds(fds)?;
    Ok(())
}
