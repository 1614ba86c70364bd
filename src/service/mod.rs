//! The query service: what a query *is*, independent of how it arrived. HTTP
//! ([`crate::api`]) and WebSocket ([`crate::stream`]) decode a request into these types, call
//! the same functions and encode the same answers; the domain modules (`state`, `scene`,
//! `bodies`, `impacts`, `stream`) depend on this module, never on the HTTP layer.
//!
//! - [`types`] — request and response structs shared by every transport (JSON and protobuf).
//! - [`query`] — time resolution, field and accuracy parsing, and the blocking `run_*` queries.
//! - [`error`] — why a query or a clock change was refused ([`error::QueryError`],
//!   [`error::ClockUpdateError`]); `crate::error` maps them to what a client sees.
//! - [`json`] — JSON decoding with the path of a bad field in the error.
//! - [`finite`] — the check every answer passes before it is encoded: no NaN or infinity on
//!   the wire.

pub mod error;
pub mod finite;
pub mod json;
pub mod query;
pub mod types;

#[cfg(test)]
mod tests {
    /// Issue 10: "the domain modules stop importing from `api`". Every source file outside
    /// `src/api/` (and the crate root, which mounts the router) is read, comments dropped, and
    /// checked for a path into the HTTP layer.
    #[test]
    fn nothing_outside_the_http_layer_imports_it() {
        fn walk(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
            for e in std::fs::read_dir(dir).unwrap() {
                let p = e.unwrap().path();
                if p.is_dir() {
                    walk(&p, out);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    out.push(p);
                }
            }
        }
        let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let mut files = Vec::new();
        walk(&src, &mut files);
        // Built, so that this file does not name them itself.
        let needles = [["crate", "::api"].concat(), ["super", "::api"].concat()];
        let mut offenders = Vec::new();
        for f in &files {
            let rel = f.strip_prefix(&src).unwrap();
            if rel.starts_with("api") || rel == std::path::Path::new("lib.rs") {
                continue;
            }
            let text = std::fs::read_to_string(f).unwrap();
            for (n, line) in text.lines().enumerate() {
                let code = line.split("//").next().unwrap_or("");
                if needles.iter().any(|n| code.contains(n.as_str())) {
                    offenders.push(format!("{}:{}: {}", rel.display(), n + 1, line.trim()));
                }
            }
        }
        assert!(files.len() > 30, "found only {} files", files.len());
        assert!(
            offenders.is_empty(),
            "imports of the HTTP layer:\n{offenders:#?}"
        );
    }
}
