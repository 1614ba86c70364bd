//! The Debian programs the integration tests run (`redis-server`, `nginx`, `kill`, `chromium`),
//! installed with `apt-get` when missing, so that `cargo test --workspace` sets itself up on a
//! fresh Debian machine with only Rust on it (issue 30).
//!
//! A program is looked up on the PATH, then in `/usr/sbin` and `/usr/bin` (Debian puts daemons
//! such as nginx in `/usr/sbin`, which a normal user's PATH may lack). When it is missing, its
//! package is installed: `apt-get install` as root, `sudo -n apt-get install` otherwise (`-n`:
//! a password prompt would hang a test, so it fails instead, and the panic says what to run);
//! `apt-get update` first only when the install fails (a fresh image has no package lists).
//!
//! Installs are serialised so that parallel tests do not race apt: within a test binary by a
//! mutex (its tests run on threads), across the test binaries cargo runs by an exclusive lock on
//! a file in `target/tmp/`, and against any other apt on the machine by apt's own lock, which
//! is waited for (`DPkg::Lock::Timeout`) rather than failed on. Each lock holder looks again
//! before installing, so a package is installed once. A failed install is remembered for the
//! rest of the process, so one missing package costs one attempt, not one per test.
//!
//! `SWELL_TEST_NO_INSTALL=1` turns the install off: a missing program then panics with the
//! command that installs it.
#![allow(dead_code, unreachable_pub)]

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;

/// Where the cross-process install lock lives: cargo's per-workspace temp dir for integration
/// tests (`target/tmp`), which every test binary of this workspace shares.
const LOCK_FILE: &str = concat!(env!("CARGO_TARGET_TMPDIR"), "/swell-apt.lock");

/// How long apt may wait for another apt or dpkg on the machine to finish, in seconds.
const APT_LOCK_WAIT_S: &str = "600";

/// The path of `name`, installing Debian's `package` first when it is missing.
///
/// # Panics
/// When the program is missing and cannot be installed (no network, not root and no
/// password-less sudo, not Debian, or `SWELL_TEST_NO_INSTALL=1`); the message says what to run.
pub fn program(name: &str, package: &str) -> PathBuf {
    if let Some(p) = find(name) {
        return p;
    }
    // Outcomes of this process's installs, by package: a failure is not retried by every test.
    static INSTALLED: Mutex<Option<HashMap<String, Result<(), String>>>> = Mutex::new(None);
    let mut installed = INSTALLED.lock().unwrap_or_else(|e| e.into_inner());
    let outcome = installed
        .get_or_insert_with(HashMap::new)
        .entry(package.to_owned())
        .or_insert_with(|| install(name, package))
        .clone();
    drop(installed);
    match (outcome, find(name)) {
        (_, Some(p)) => p,
        (Err(why), None) => {
            panic!("{name} not found and not installed ({why}): apt-get install -y {package}")
        }
        (Ok(()), None) => panic!(
            "{name} still not found after installing {package}: apt-get install -y {package}"
        ),
    }
}

/// `name` on the PATH, else in the Debian system directories.
pub fn find(name: &str) -> Option<PathBuf> {
    let path = std::env::var("PATH").unwrap_or_default();
    path.split(':')
        .filter(|d| !d.is_empty())
        .chain(["/usr/sbin", "/usr/bin", "/sbin", "/bin"])
        .map(|d| Path::new(d).join(name))
        .find(|p| p.is_file())
}

/// Installs `package` under the cross-process lock, unless another process did meanwhile.
fn install(name: &str, package: &str) -> Result<(), String> {
    if std::env::var_os("SWELL_TEST_NO_INSTALL").is_some_and(|v| v != "0") {
        return Err("SWELL_TEST_NO_INSTALL is set".into());
    }
    let _ = std::fs::create_dir_all(env!("CARGO_TARGET_TMPDIR"));
    let lock = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(LOCK_FILE)
        .map_err(|e| format!("opening {LOCK_FILE}: {e}"))?;
    // Released when `lock` is dropped (closing the file releases the lock).
    lock.lock()
        .map_err(|e| format!("locking {LOCK_FILE}: {e}"))?;
    if find(name).is_some() {
        return Ok(());
    }
    eprintln!("{name} missing: installing Debian's {package} (apt-get)");
    let sudo = !is_root();
    if apt(sudo, &["install", package]).is_ok() {
        return Ok(());
    }
    apt(sudo, &["update"])?;
    apt(sudo, &["install", package])
}

/// Runs `apt-get -y -qq ARGS` non-interactively (through `sudo -n` when `sudo`), waiting for
/// apt's lock; the error is the tail of its output.
fn apt(sudo: bool, args: &[&str]) -> Result<(), String> {
    let mut cmd = if sudo {
        let mut c = Command::new("sudo");
        c.args(["-n", "env", "DEBIAN_FRONTEND=noninteractive", "apt-get"]);
        c
    } else {
        let mut c = Command::new("apt-get");
        c.env("DEBIAN_FRONTEND", "noninteractive");
        c
    };
    cmd.args(["-y", "-qq", "--no-install-recommends"])
        .arg(format!("-oDPkg::Lock::Timeout={APT_LOCK_WAIT_S}"))
        .args(args);
    let out = cmd
        .output()
        .map_err(|e| format!("running {}apt-get: {e}", if sudo { "sudo " } else { "" }))?;
    if out.status.success() {
        return Ok(());
    }
    let text = String::from_utf8_lossy(&out.stderr);
    let tail: Vec<&str> = text.lines().rev().take(3).collect();
    Err(format!(
        "apt-get {} exited with {}: {}",
        args.join(" "),
        out.status,
        tail.into_iter().rev().collect::<Vec<_>>().join(" / ")
    ))
}

/// Whether this process runs as root (`/proc/self/status`'s effective uid), without libc.
fn is_root() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("Uid:"))
                .and_then(|l| l.split_whitespace().nth(2).map(|u| u == "0"))
        })
        .unwrap_or(false)
}
