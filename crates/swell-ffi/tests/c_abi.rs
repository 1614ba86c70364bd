//! C programs built with the system `cc` against the static library (`libswell_ffi.a`, built
//! by cargo with this test) and `include/swell.h`:
//!
//! - `tests/c/golden.c` checks every output of `proto/vectors/surface_v1.json` bit for bit, and
//!   `tests/c/golden_f32.c` those of `surface_f32_v1.json` (the single-precision fast path);
//! - `tests/c/bodies.c` replays the body logs of `proto/vectors/bodies_v1.json` (produced by
//!   the server's body code, `tests/server/body_vectors.rs` in the root crate) and checks every body's
//!   state at every tick bit for bit, and that a rewound prediction repeats its trajectory;
//! - `tests/c/errors.c` checks status codes, messages and null handling.
//!
//! The vectors are turned into plain token files here (doubles as hex bit patterns), so the C
//! side needs no JSON parser and no decimal conversion can move a bit.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn vectors(name: &str) -> Value {
    let path = crate_dir().join("../../proto/vectors").join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).expect("vectors are JSON")
}

/// The static library cargo built for this test run. `cargo test` builds the library's crate
/// types into the test binary's own `deps/` folder and does not copy them up to
/// `target/<profile>/` (only `cargo build` does), so the copy up there may be stale: `deps/`
/// first (the newest `libswell_ffi*.a`), the profile folder only if there is none.
fn static_lib() -> PathBuf {
    let exe = std::env::current_exe().expect("test binary path");
    let deps = exe.parent().expect("deps folder");
    let profile = deps.parent().expect("profile folder");
    let mut found: Vec<(std::time::SystemTime, PathBuf)> = std::fs::read_dir(deps)
        .expect("read deps")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("libswell_ffi") && n.ends_with(".a"))
        })
        .filter_map(|p| Some((p.metadata().ok()?.modified().ok()?, p)))
        .collect();
    found.sort();
    match found.pop() {
        Some((_, p)) => p,
        None => {
            let uplifted = profile.join("libswell_ffi.a");
            assert!(
                uplifted.exists(),
                "no libswell_ffi.a in {} or {}",
                deps.display(),
                profile.display()
            );
            uplifted
        }
    }
}

/// Compiles `tests/c/<name>.c` with `cc` against the static library; returns the executable.
fn build(name: &str) -> PathBuf {
    let out_dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("swell-ffi-c");
    std::fs::create_dir_all(&out_dir).unwrap();
    let exe = out_dir.join(name);
    let dir = crate_dir();
    let output = Command::new("cc")
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
            "-O1",
        ])
        .arg("-I")
        .arg(dir.join("include"))
        .arg(dir.join("tests/c").join(format!("{name}.c")))
        .arg(static_lib())
        // What a Rust staticlib needs from the C runtime on Linux.
        .args(["-lpthread", "-ldl", "-lm"])
        .arg("-o")
        .arg(&exe)
        .output()
        .expect("run cc (the system C compiler)");
    assert!(
        output.status.success(),
        "cc failed on {name}.c:\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    exe
}

/// Runs `exe input`; asserts it passed and returns its "N passed" count.
fn run(exe: &Path, input: &str) -> u64 {
    let path = exe.with_extension("in");
    std::fs::write(&path, input).unwrap();
    let output = Command::new(exe)
        .arg(&path)
        .output()
        .expect("run the C test");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "{} failed ({}):\n{stdout}\n{stderr}",
        exe.display(),
        output.status
    );
    let line = stdout.lines().last().unwrap_or_default();
    let passed: u64 = line
        .split(" passed")
        .next()
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| panic!("no 'N passed' line in {stdout:?}"));
    assert!(line.ends_with(", 0 failed"), "{stdout}\n{stderr}");
    passed
}

fn hex_f64(v: &Value) -> String {
    format!("{:016x}", v.as_f64().expect("a number").to_bits())
}

fn hex_str(v: &Value) -> &str {
    v.as_str().expect("a hex string")
}

fn text(out: &mut String, keyword: &str, json: &str) {
    let _ = write!(out, "{keyword} {}\n{json}\n", json.len());
}

#[test]
fn a_c_program_reproduces_the_golden_vectors_bit_for_bit() {
    let file = vectors("surface_v1.json");
    let mut input = String::new();
    let mut points = 0;
    for case in file["cases"].as_array().unwrap() {
        let _ = writeln!(input, "case {}", case["name"].as_str().unwrap());
        text(&mut input, "spec", &case["spec"].to_string());
        for e in case["expected"].as_array().unwrap() {
            let b = &e["bits"];
            let mut line = format!(
                "point {} {} {} {}",
                hex_f64(&e["t"]),
                hex_f64(&e["point"][0]),
                hex_f64(&e["point"][1]),
                hex_str(&b["height"])
            );
            for k in ["normal", "displacement"] {
                for v in b[k].as_array().unwrap() {
                    line += &format!(" {}", hex_str(v));
                }
            }
            line += &format!(
                " {} {} {}",
                hex_str(&b["jacobian"]),
                hex_str(&b["residual"]),
                u8::from(b["folded"].as_bool().unwrap())
            );
            let _ = writeln!(input, "{line}");
            points += 1;
        }
    }
    input += "end\n";
    let passed = run(&build("golden"), &input);
    assert_eq!(passed, points, "every golden point was checked");
}

#[test]
fn a_c_program_reproduces_the_f32_golden_vectors_bit_for_bit() {
    let file = vectors("surface_f32_v1.json");
    let mut input = String::new();
    let mut points = 0;
    for case in file["cases"].as_array().unwrap() {
        let _ = writeln!(input, "case {}", case["name"].as_str().unwrap());
        text(&mut input, "spec", &case["spec"].to_string());
        for e in case["expected"].as_array().unwrap() {
            let b = &e["bits"];
            let mut line = format!(
                "point {} {} {} {}",
                hex_f64(&e["t"]),
                hex_f64(&e["point"][0]),
                hex_f64(&e["point"][1]),
                hex_str(&b["height"])
            );
            for k in ["displacement_f32", "normal_f32"] {
                for v in b[k].as_array().unwrap() {
                    line += &format!(" {}", hex_str(v));
                }
            }
            let _ = writeln!(input, "{line}");
            points += 1;
        }
    }
    input += "end\n";
    let passed = run(&build("golden_f32"), &input);
    assert_eq!(passed, points, "every golden point was checked");
}

/// The bodies test replays every case twice: from the scene JSON as PUT, and from the spec as
/// the server serves it (`GET /v1/scenes/{id}`): both must build the sea of the states.
#[test]
fn a_c_program_replays_a_body_log_to_the_servers_states() {
    let file = vectors("bodies_v1.json");
    let cases = file["cases"].as_array().unwrap().len() as u64;
    let mut total = 0;
    for key in ["scene", "served"] {
        let (input, expected) = body_input(&file, key);
        let passed = run(&build("bodies"), &input);
        // Every state, plus one rewound-prediction check per case.
        assert_eq!(passed, expected + cases, "from {key}");
        total += passed;
    }
    assert!(total > 0);
}

/// The C program's input for every case of `file`, building the scene from `key`; and the number
/// of states it checks.
fn body_input(file: &Value, key: &str) -> (String, u64) {
    let mut input = String::new();
    let mut expected = 0;
    for case in file["cases"].as_array().unwrap() {
        let _ = writeln!(input, "case {}", case["name"].as_str().unwrap());
        text(&mut input, "scene", case[key].as_str().unwrap());
        let _ = writeln!(input, "anchor {}", case["anchor"]);
        // Events and expectations in tick order; at a tick, events before the states.
        let mut next_id = 0u64;
        let log = case["log"].as_array().unwrap();
        let states = case["states"].as_array().unwrap();
        let mut e = 0;
        for s in states {
            let tick = s["tick"].as_i64().unwrap();
            while e < log.len() && log[e]["tick"].as_i64().unwrap() <= tick {
                let ev = &log[e];
                let at = ev["tick"].as_i64().unwrap();
                if let Some(req) = ev.get("spawn") {
                    text(
                        &mut input,
                        &format!("spawn {at} {next_id}"),
                        &req.to_string(),
                    );
                    next_id += 1;
                } else {
                    let i = &ev["input"];
                    let mut line = format!("input {at} {}", i["body"]);
                    for k in ["force", "torque"] {
                        for c in 0..3 {
                            let v = i.get(k).map_or(0.0, |a| a[c].as_f64().unwrap());
                            line += &format!(" {:016x}", v.to_bits());
                        }
                    }
                    let from = i
                        .get("from_tick")
                        .map_or("now".to_owned(), |f| f.to_string());
                    let ticks = i.get("ticks").map_or(1, |t| t.as_u64().unwrap());
                    let _ = writeln!(input, "{line} {from} {ticks}");
                }
                e += 1;
            }
            for b in s["bodies"].as_array().unwrap() {
                let bits = &b["bits"];
                let mut line = format!("expect {tick} {}", b["id"]);
                for k in ["position", "rotation", "velocity", "angular_velocity"] {
                    for v in bits[k].as_array().unwrap() {
                        line += &format!(" {}", hex_str(v));
                    }
                }
                line += &format!(
                    " {} {}",
                    hex_str(&bits["submerged"]),
                    u8::from(bits["quarantined"].as_bool().unwrap())
                );
                let _ = writeln!(input, "{line}");
                expected += 1;
            }
        }
        input += "done\n";
    }
    input += "end\n";
    (input, expected)
}

#[test]
fn a_c_program_sees_codes_and_messages_not_crashes() {
    let passed = run(&build("errors"), "");
    assert!(passed > 0);
}
