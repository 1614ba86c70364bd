//! The README's error table and [`ErrorCode`] agree, both ways: every code the server can send is
//! a row with the code's one status (`—` for a WebSocket-only code), and every row is a code.
//! Also: no source file writes a code by hand that the enum does not have.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use swell::api::errors::code_for;
use swell::error::ErrorCode;

const README: &str = include_str!("../../README.md");

/// The rows of the table under "### Errors": code → status column, as written.
fn readme_table() -> BTreeMap<String, String> {
    let start = README
        .find("\n### Errors\n")
        .expect("README has a \"### Errors\" section");
    let section = &README[start + 1..];
    let end = section[4..].find("\n#").map_or(section.len(), |i| i + 4);
    let section = &section[..end];
    let mut lines = section.lines().skip_while(|l| !l.starts_with('|'));
    let header: Vec<&str> = cells(lines.next().expect("a table in ### Errors"));
    assert_eq!(header, ["code", "status", "meaning"], "the table's columns");
    let rule = lines.next().expect("the table's rule row");
    assert!(rule.starts_with("|---"), "{rule}");
    let mut rows = BTreeMap::new();
    for line in lines.take_while(|l| l.starts_with('|')) {
        let c = cells(line);
        assert_eq!(c.len(), 3, "three cells: {line}");
        let code = c[0]
            .strip_prefix('`')
            .and_then(|s| s.strip_suffix('`'))
            .unwrap_or_else(|| panic!("a code in backticks: {line}"));
        assert!(!c[2].is_empty(), "a meaning for {code}");
        let before = rows.insert(code.to_owned(), c[1].to_owned());
        assert!(before.is_none(), "{code} is listed twice");
    }
    assert!(!rows.is_empty(), "the table has rows");
    rows
}

fn cells(line: &str) -> Vec<&str> {
    let inner = line.trim().trim_start_matches('|').trim_end_matches('|');
    inner.split('|').map(str::trim).collect()
}

fn documented_status(code: ErrorCode) -> String {
    if code.websocket_only() {
        "—".to_owned()
    } else {
        code.status().as_u16().to_string()
    }
}

#[test]
fn readme_lists_exactly_the_codes_with_their_one_status() {
    let table = readme_table();
    let mut problems = Vec::new();
    for &code in ErrorCode::ALL {
        match table.get(code.as_str()) {
            None => problems.push(format!("`{code}` is not in the README's error table")),
            Some(st) if *st != documented_status(code) => problems.push(format!(
                "`{code}`: README says {st}, the enum says {}",
                documented_status(code)
            )),
            Some(_) => {}
        }
    }
    for code in table.keys() {
        if !ErrorCode::ALL.iter().any(|c| c.as_str() == code) {
            problems.push(format!(
                "`{code}` is in the README's error table but not an ErrorCode"
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn every_status_the_rewriter_meets_gets_a_code_of_that_status_or_a_fallback() {
    for s in 400..600u16 {
        let status = axum::http::StatusCode::from_u16(s).unwrap();
        let code = code_for(status);
        let fallback = if s >= 500 {
            ErrorCode::Internal
        } else {
            ErrorCode::BadRequest
        };
        assert!(
            code.status() == status || code == fallback,
            "{s} → {code} ({})",
            code.status()
        );
        assert!(!code.websocket_only(), "{s} → {code}");
    }
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// A code written as a string in an error body (`"code":"…"` in a raw body, `"code": "…"` in
/// `json!`) must be one of the enum's: the enum is the one place codes are made.
#[test]
fn no_source_file_writes_a_code_outside_the_enum() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut problems = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        for pat in [r#""code":""#, r#"\"code\":\""#, r#""code": ""#] {
            for (i, _) in text.match_indices(pat) {
                let rest = &text[i + pat.len()..];
                let word: String = rest
                    .chars()
                    .take_while(|c| c.is_ascii_lowercase() || *c == '_')
                    .collect();
                if word.is_empty() {
                    continue; // e.g. a placeholder filled from the enum
                }
                if !ErrorCode::ALL.iter().any(|c| c.as_str() == word) {
                    problems.push(format!("{}: code {word:?}", file.display()));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// `/openapi.json` lists the codes as an `enum` made from [`ErrorCode::ALL`] (issue 27): it
/// said only `"type": "string"`, so a client generated from the document could not match on a
/// code, and nothing tied the document to the enum. The HTTP `Error` lists every code an HTTP
/// answer can carry (all but the WebSocket-only ones), in the enum's order; the stream's `error`
/// message every code, the WebSocket-only ones included, and shares the other fields with
/// `Error`.
#[test]
fn openapi_lists_exactly_the_codes_the_server_can_send() {
    let doc = swell::api::ops::openapi_document(&swell::Limits::default());
    let schemas = &doc["components"]["schemas"];
    let listed = |code: &serde_json::Value| -> Vec<String> {
        assert_eq!(code["type"], "string", "{code}");
        code["enum"]
            .as_array()
            .unwrap_or_else(|| panic!("no enum in {code}"))
            .iter()
            .map(|c| c.as_str().unwrap().to_owned())
            .collect()
    };
    let http = listed(&schemas["Error"]["properties"]["error"]["properties"]["code"]);
    let expected: Vec<&str> = ErrorCode::ALL
        .iter()
        .filter(|c| !c.websocket_only())
        .map(|c| c.as_str())
        .collect();
    assert_eq!(http, expected);
    let stream_error = &schemas["StreamError"]["properties"];
    let stream = listed(&stream_error["code"]);
    let all: Vec<&str> = ErrorCode::ALL.iter().map(|c| c.as_str()).collect();
    assert_eq!(stream, all);
    for ws in ["unknown_type", "wrong_frame_type"] {
        assert!(stream.iter().any(|c| c == ws), "{ws}");
        assert!(!http.iter().any(|c| c == ws), "{ws} is WebSocket-only");
    }
    for field in ["message", "field"] {
        assert_eq!(
            stream_error[field]["$ref"],
            format!("#/components/schemas/Error/properties/error/properties/{field}")
        );
    }
}
