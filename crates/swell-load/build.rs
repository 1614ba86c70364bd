//! Generates the protobuf types of the workspace's `proto/swell/v1/*.proto` (the wire schema,
//! the single source of truth) into `OUT_DIR`, the same way the server does. The load tool talks
//! to a server over the network only, so it compiles its own copy rather than importing the
//! server crate.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("cargo:rerun-if-changed=../../proto");
    let fds = protox::compile(
        ["swell/v1/query.proto", "swell/v1/stream.proto"],
        ["../../proto"],
    )?;
    prost_build::Config::new().compile_fds(fds)?;
    Ok(())
}
