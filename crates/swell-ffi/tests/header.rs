//! `include/swell.h` is generated from this crate by cbindgen and checked in, so engines can use
//! it without a Rust toolchain. This test regenerates it in memory and fails when the checked-in
//! file differs (a changed exported function or type without a regenerated header).
//!
//! Regenerate with
//!     SWELL_BLESS_HEADER=1 cargo test -p swell-ffi --test header
//! and commit the header with the change.

use std::path::PathBuf;

#[test]
fn the_checked_in_header_is_what_cbindgen_generates() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/lib.rs"))
        .generate()
        .expect("cbindgen generates the header");
    let mut fresh = Vec::new();
    bindings.write(&mut fresh);
    let fresh = String::from_utf8(fresh).expect("the header is UTF-8");
    let path = dir.join("include/swell.h");
    if std::env::var_os("SWELL_BLESS_HEADER").is_some() {
        std::fs::write(&path, &fresh).expect("write include/swell.h");
        eprintln!("wrote {}", path.display());
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == fresh,
        "{} is stale: the exported API changed. Regenerate it with\n    \
         SWELL_BLESS_HEADER=1 cargo test -p swell-ffi --test header\nand commit it.",
        path.display()
    );
}
