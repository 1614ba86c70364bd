//! Who may do what: roles and the bearer tokens that carry them.
//!
//! Three roles, each including the ones below it:
//!
//! - [`Role::Admin`] — scenes and clocks (put, delete, seek, rate, pause), and everything a
//!   `game` token may do.
//! - [`Role::Game`] — what a game server relays from its players: body spawns, inputs and
//!   deletes, impacts (splashes); and every read.
//! - [`Role::Reader`] — queries and streams. Reads are public unless the server is configured to
//!   require a token for them ([`Access::reads_need_token`]).
//!
//! Tokens come from `--admin-token` (an `admin` token, as before roles existed), from the
//! environment (`SWELL_ADMIN_TOKENS`, `SWELL_GAME_TOKENS`, `SWELL_READER_TOKENS`: comma-separated)
//! and from a tokens file (`--tokens-file`), one `role token` per line:
//!
//! ```text
//! # comments and blank lines are ignored
//! admin  3f9c…                       # a token as issued
//! game   sha256:5e88489…             # or its SHA-256, hex: the file need not hold secrets
//! reader sha256:…
//! ```
//!
//! Only SHA-256 digests are kept in memory, and a presented token is hashed and compared with
//! every digest without an early exit, so timing says nothing about how close a guess was. The
//! file is read again when it changes ([`Access::reload_if_changed`], every few seconds): tokens
//! rotate without a restart. A file that fails to parse keeps the tokens in force and logs why.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, RwLock};
use std::time::SystemTime;

use sha2::{Digest, Sha256};

/// A role a token carries; each includes the ones below it (`Admin` > `Game` > `Reader`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Role {
    /// Queries and streams.
    Reader,
    /// Bodies, inputs and impacts (what a game server relays), and reads.
    Game,
    /// Scenes and clocks, and everything else.
    Admin,
}

impl Role {
    /// The role's name as the tokens file and the OpenAPI document spell it.
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Reader => "reader",
            Role::Game => "game",
            Role::Admin => "admin",
        }
    }

    /// Parses `admin`, `game` or `reader`.
    pub fn parse(s: &str) -> Option<Role> {
        match s {
            "admin" => Some(Role::Admin),
            "game" => Some(Role::Game),
            "reader" => Some(Role::Reader),
            _ => None,
        }
    }
}

/// A token's SHA-256 digest.
type Digest32 = [u8; 32];

fn digest(token: &str) -> Digest32 {
    Sha256::digest(token.as_bytes()).into()
}

/// The digests in force, with their roles.
#[derive(Debug, Default, Clone)]
struct TokenSet {
    entries: Vec<(Digest32, Role)>,
}

impl TokenSet {
    fn add_plain(&mut self, role: Role, token: &str) {
        self.entries.push((digest(token), role));
    }

    /// The role of `token`, if it is one of ours. Compares with every digest, whatever matches,
    /// each without an early exit.
    fn role_of(&self, token: &str) -> Option<Role> {
        let d = digest(token);
        let mut found: Option<Role> = None;
        for (e, role) in &self.entries {
            let same = e.iter().zip(&d).fold(0u8, |acc, (a, b)| acc | (a ^ b)) == 0;
            if same {
                // The highest role when one token is listed under several.
                found = Some(found.map_or(*role, |f| f.max(*role)));
            }
        }
        found
    }
}

/// Why a tokens file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum TokensError {
    /// The file could not be read.
    #[error("cannot read tokens file {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A line is not `role token`.
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// `line` without its comment: from a `#` at the start or after a space or tab to the end. A `#`
/// inside a token (`s3cr#t…`) is part of it, so a token is never cut short silently.
fn strip_comment(line: &str) -> &str {
    let mut prev_blank = true;
    for (i, c) in line.char_indices() {
        if c == '#' && prev_blank {
            return &line[..i];
        }
        prev_blank = c == ' ' || c == '\t';
    }
    line
}

/// Parses a tokens file's text into `(digest, role)` entries.
fn parse_file(path: &Path, text: &str) -> Result<Vec<(Digest32, Role)>, TokensError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = strip_comment(raw).trim();
        if line.is_empty() {
            continue;
        }
        let err = |message: String| TokensError::Parse {
            path: path.to_owned(),
            line: i + 1,
            message,
        };
        let mut parts = line.split_whitespace();
        let (Some(role), Some(token), None) = (parts.next(), parts.next(), parts.next()) else {
            return Err(err(
                "expected `role token` (role: admin, game or reader)".into()
            ));
        };
        let role = Role::parse(role)
            .ok_or_else(|| err(format!("unknown role {role:?}: admin, game or reader")))?;
        let d = match token.strip_prefix("sha256:") {
            Some(hex) => {
                parse_hex32(hex).ok_or_else(|| err("sha256: needs 64 hex digits".to_owned()))?
            }
            None if token.len() < MIN_TOKEN_BYTES => {
                return Err(err(format!(
                    "a token shorter than {MIN_TOKEN_BYTES} bytes is too easy to guess"
                )));
            }
            None => digest(token),
        };
        out.push((d, role));
    }
    Ok(out)
}

fn parse_hex32(hex: &str) -> Option<Digest32> {
    if hex.len() != 64 {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, b) in out.iter_mut().enumerate() {
        *b = u8::from_str_radix(hex.get(2 * i..2 * i + 2)?, 16).ok()?;
    }
    Some(out)
}

/// The tokens in force and whether reads need one. Cheap to read from every request (one
/// `RwLock` read and a hash).
#[derive(Debug)]
pub struct Access {
    fixed: TokenSet,
    tokens: RwLock<TokenSet>,
    file: Option<PathBuf>,
    file_mtime: Mutex<Option<SystemTime>>,
    reads_need_token: bool,
}

/// What a request presented and what it is allowed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Presented {
    /// No `Authorization: Bearer` header.
    None,
    /// A token that is none of ours.
    Unknown,
    /// A valid token with its role.
    Valid(Role),
}

impl Access {
    /// Access with `admin_token` as an admin token, the tokens of `env` (role → comma-separated
    /// tokens) and of `file` (if any).
    ///
    /// # Errors
    /// The file cannot be read or parsed.
    pub fn new(
        admin_token: &str,
        env: &[(Role, String)],
        file: Option<PathBuf>,
        reads_need_token: bool,
    ) -> Result<Access, TokensError> {
        let mut fixed = TokenSet::default();
        if !admin_token.is_empty() {
            fixed.add_plain(Role::Admin, admin_token);
        }
        for (role, list) in env {
            for t in list_tokens(list) {
                fixed.add_plain(*role, t);
            }
        }
        let access = Access {
            tokens: RwLock::new(fixed.clone()),
            fixed,
            file,
            file_mtime: Mutex::new(None),
            reads_need_token,
        };
        if let Some(path) = &access.file {
            access.load_file(path)?;
        }
        Ok(access)
    }

    /// Only `admin_token`, reads public (tests, in-process tools).
    pub fn admin_only(admin_token: &str) -> Access {
        let mut fixed = TokenSet::default();
        fixed.add_plain(Role::Admin, admin_token);
        Access {
            tokens: RwLock::new(fixed.clone()),
            fixed,
            file: None,
            file_mtime: Mutex::new(None),
            reads_need_token: false,
        }
    }

    /// Whether queries and streams need a `reader` token (else they are public).
    pub fn reads_need_token(&self) -> bool {
        self.reads_need_token
    }

    fn load_file(&self, path: &Path) -> Result<(), TokensError> {
        let mtime = std::fs::metadata(path).and_then(|m| m.modified()).ok();
        let text = std::fs::read_to_string(path).map_err(|source| TokensError::Read {
            path: path.to_owned(),
            source,
        })?;
        let entries = parse_file(path, &text)?;
        let mut set = self.fixed.clone();
        set.entries.extend(entries);
        *self.tokens.write().unwrap_or_else(|p| p.into_inner()) = set;
        *self.file_mtime.lock().unwrap_or_else(|p| p.into_inner()) = mtime;
        Ok(())
    }

    /// Reads the tokens file again if its modification time changed. Returns whether the tokens
    /// changed. A file that cannot be read or parsed leaves the tokens in force (logged).
    pub fn reload_if_changed(&self) -> bool {
        let Some(path) = &self.file else {
            return false;
        };
        let mtime = std::fs::metadata(path).and_then(|m| m.modified()).ok();
        if mtime == *self.file_mtime.lock().unwrap_or_else(|p| p.into_inner()) {
            return false;
        }
        match self.load_file(path) {
            Ok(()) => {
                tracing::info!(file = %path.display(), "tokens file reloaded");
                true
            }
            Err(e) => {
                tracing::error!(error = %e, "tokens file not reloaded; the previous tokens stay in force");
                // Do not retry the same broken file every few seconds.
                *self.file_mtime.lock().unwrap_or_else(|p| p.into_inner()) = mtime;
                false
            }
        }
    }

    /// What the bearer token (if any) of a request is worth.
    pub fn check(&self, bearer: Option<&str>) -> Presented {
        match bearer {
            None => Presented::None,
            Some(t) => match self
                .tokens
                .read()
                .unwrap_or_else(|p| p.into_inner())
                .role_of(t)
            {
                Some(r) => Presented::Valid(r),
                None => Presented::Unknown,
            },
        }
    }

    /// A short, stable key for a token (rate limits per token): the first 8 bytes of its digest.
    pub fn token_key(token: &str) -> u64 {
        let d = digest(token);
        let mut b = [0u8; 8];
        b.copy_from_slice(&d[..8]);
        u64::from_le_bytes(b)
    }
}

/// The SHA-256 of `token` as the tokens file's `sha256:` form (for operators: `swell hash-token`).
pub fn hashed(token: &str) -> String {
    let d = digest(token);
    let hex: String = d.iter().map(|b| format!("{b:02x}")).collect();
    format!("sha256:{hex}")
}

/// Shortest plain token accepted, bytes. 16 bytes of a random alphabet (`openssl rand -hex 16`
/// gives 32) put a guess beyond any rate of tries a server answers; shorter ones are words and
/// dates an attacker tries first. The tokens file holds every plain token to it; tokens given
/// on the command line or in the environment are held to it when the server listens beyond
/// loopback ([`check_given_tokens`]).
pub const MIN_TOKEN_BYTES: usize = 16;

/// A token given on the command line or in the environment that is shorter than
/// [`MIN_TOKEN_BYTES`]. Its `Display` names the option, never the token.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShortToken {
    /// The option that gave it, with its variable: `--admin-token (SWELL_ADMIN_TOKEN)`.
    pub option: &'static str,
    /// Its place in a comma-separated list (1-based); `None` for a single-token option.
    pub index: Option<usize>,
    /// Its length, bytes.
    pub len: usize,
}

impl std::fmt::Display for ShortToken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let which = match self.index {
            Some(i) => format!("token {i} of {}", self.option),
            None => format!("the token of {}", self.option),
        };
        write!(
            f,
            "{which} is {} bytes, shorter than the {MIN_TOKEN_BYTES} bytes a token needs",
            self.len
        )
    }
}

/// A short token ([`ShortToken`]) on a server that listens beyond loopback: it must not start.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{token} when the server listens beyond loopback ({bind} {addr}); give a longer one \
    (`openssl rand -hex 16`) or listen on loopback only"
)]
pub struct ExposedShortToken {
    /// The first short token.
    pub token: ShortToken,
    /// The option of the first address that is not loopback (`--bind`, `--probe-bind`).
    pub bind: &'static str,
    /// That address.
    pub addr: std::net::SocketAddr,
}

/// What a token option gave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Given<'a> {
    /// One token, as it is (`--admin-token`: a comma is part of it).
    One(&'a str),
    /// A comma-separated list, split as [`Access::new`] splits it: whitespace trimmed, empty
    /// entries skipped (`--game-tokens`).
    List(&'a str),
}

/// The tokens of a comma-separated list option (`--game-tokens a,b`): whitespace trimmed,
/// empty entries skipped. One rule for [`Access::new`], which adds them, and
/// [`check_given_tokens`], which measures them.
fn list_tokens(list: &str) -> impl Iterator<Item = &str> {
    list.split(',').map(str::trim).filter(|t| !t.is_empty())
}

/// Whether `addr` reaches this host only: `127.0.0.0/8`, `::1`, or an IPv4-mapped loopback
/// address. `0.0.0.0` and `::` listen on every interface, so they are not.
pub fn is_loopback(addr: &std::net::SocketAddr) -> bool {
    addr.ip().to_canonical().is_loopback()
}

/// Checks tokens given on the command line or in the environment against [`MIN_TOKEN_BYTES`],
/// the rule of the tokens file. `given` pairs each option (with its variable) with what it
/// gave; `binds` pairs each listening option with its address.
///
/// Short tokens are what tests, examples and local scripts use (`--admin-token tok`), and on a
/// loopback address only this host can try them, so there they are allowed and returned for
/// the caller to warn about.
///
/// # Errors
/// [`ExposedShortToken`] naming the first short token and the first address beyond loopback,
/// when there are both.
pub fn check_given_tokens(
    given: &[(&'static str, Given<'_>)],
    binds: &[(&'static str, std::net::SocketAddr)],
) -> Result<Vec<ShortToken>, ExposedShortToken> {
    let mut short = Vec::new();
    for &(option, value) in given {
        match value {
            Given::One(t) if t.len() < MIN_TOKEN_BYTES => short.push(ShortToken {
                option,
                index: None,
                len: t.len(),
            }),
            Given::One(_) => {}
            Given::List(list) => {
                for (i, t) in list_tokens(list).enumerate() {
                    if t.len() < MIN_TOKEN_BYTES {
                        short.push(ShortToken {
                            option,
                            index: Some(i + 1),
                            len: t.len(),
                        });
                    }
                }
            }
        }
    }
    match (short.first(), binds.iter().find(|(_, a)| !is_loopback(a))) {
        (Some(token), Some(&(bind, addr))) => Err(ExposedShortToken {
            token: token.clone(),
            bind,
            addr,
        }),
        _ => Ok(short),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roles_from_every_source_and_the_file_reloads() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tokens");
        let game = "game-token-0123456789";
        std::fs::write(
            &path,
            format!(
                "# players' relay\ngame {game}\nreader {}  # hashed\n",
                hashed("reader-token-0123456789")
            ),
        )
        .unwrap();
        let env = [(
            Role::Game,
            "env-game-token-000001, env-game-token-000002".to_owned(),
        )];
        let a = Access::new("admin-token-0123456789", &env, Some(path.clone()), true).unwrap();
        assert_eq!(
            a.check(Some("admin-token-0123456789")),
            Presented::Valid(Role::Admin)
        );
        assert_eq!(a.check(Some(game)), Presented::Valid(Role::Game));
        assert_eq!(
            a.check(Some("env-game-token-000002")),
            Presented::Valid(Role::Game)
        );
        assert_eq!(
            a.check(Some("reader-token-0123456789")),
            Presented::Valid(Role::Reader)
        );
        assert_eq!(a.check(Some("nope")), Presented::Unknown);
        assert_eq!(a.check(None), Presented::None);
        assert!(a.reads_need_token());

        // Rotation: the game token is replaced; the old one stops working, the new one works.
        // (A later mtime: some filesystems keep whole seconds.)
        std::thread::sleep(std::time::Duration::from_millis(1100));
        std::fs::write(&path, "game game-token-rotated-0001\n").unwrap();
        assert!(a.reload_if_changed());
        assert_eq!(a.check(Some(game)), Presented::Unknown);
        assert_eq!(
            a.check(Some("game-token-rotated-0001")),
            Presented::Valid(Role::Game)
        );
        // Fixed tokens survive a reload.
        assert_eq!(
            a.check(Some("env-game-token-000001")),
            Presented::Valid(Role::Game)
        );
        // A broken file keeps what is in force.
        std::thread::sleep(std::time::Duration::from_millis(1100));
        std::fs::write(&path, "superuser x\n").unwrap();
        assert!(!a.reload_if_changed());
        assert_eq!(
            a.check(Some("game-token-rotated-0001")),
            Presented::Valid(Role::Game)
        );
    }

    #[test]
    fn bad_lines_name_the_line() {
        let p = Path::new("t");
        let e = parse_file(p, "admin\n").unwrap_err().to_string();
        assert!(e.contains("t:1"), "{e}");
        let e = parse_file(p, "\nroot abcdefabcdefabcdef\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("t:2") && e.contains("unknown role"), "{e}");
        let e = parse_file(p, "game short\n").unwrap_err().to_string();
        assert!(e.contains("shorter than 16 bytes"), "{e}");
        let e = parse_file(p, "game sha256:abc\n").unwrap_err().to_string();
        assert!(e.contains("64 hex"), "{e}");
    }

    /// A `#` starts a comment only at the start of a line or after a blank: one inside a token
    /// belongs to it (it used to cut the token there).
    #[test]
    fn a_hash_inside_a_token_is_part_of_it() {
        let p = Path::new("t");
        let text = "# rotated 2026-11\ngame s3cr#t-token-0000001  # the relay\n\t# note\n";
        let entries = parse_file(p, text).unwrap();
        assert_eq!(entries.len(), 1);
        assert_eq!(entries[0], (digest("s3cr#t-token-0000001"), Role::Game));
        // A short token with a `#` in it is refused as short, not cut.
        assert!(parse_file(p, "game s3cr#t\n").is_err());
    }

    /// The CLI/env rule: short tokens pass with a report on loopback, and stop a server that
    /// listens anywhere else, whichever listener it is; IPv4-mapped loopback is loopback, the
    /// unspecified addresses are not.
    #[test]
    fn short_given_tokens_pass_on_loopback_only() {
        use std::net::SocketAddr;
        let addr = |s: &str| s.parse::<SocketAddr>().unwrap();
        for a in [
            "127.0.0.1:80",
            "127.0.0.2:0",
            "[::1]:8080",
            "[::ffff:127.0.0.1]:1",
        ] {
            assert!(is_loopback(&addr(a)), "{a}");
        }
        for a in [
            "0.0.0.0:80",
            "[::]:80",
            "10.0.0.1:80",
            "[::ffff:10.0.0.1]:1",
        ] {
            assert!(!is_loopback(&addr(a)), "{a}");
        }
        let given = [
            ("--admin-token (SWELL_ADMIN_TOKEN)", Given::One("tok,en")),
            (
                "--game-tokens (SWELL_GAME_TOKENS)",
                Given::List(" game-token-0123456789 , ,zq9,"),
            ),
            ("--reader-tokens (SWELL_READER_TOKENS)", Given::List("")),
        ];
        let local = [
            ("--bind", addr("127.0.0.1:0")),
            ("--probe-bind", addr("[::1]:9")),
        ];
        let short = check_given_tokens(&given, &local).unwrap();
        assert_eq!(
            short,
            [
                ShortToken {
                    option: "--admin-token (SWELL_ADMIN_TOKEN)",
                    index: None,
                    len: 6
                },
                ShortToken {
                    option: "--game-tokens (SWELL_GAME_TOKENS)",
                    index: Some(2),
                    len: 3
                },
            ]
        );
        assert_eq!(
            short[1].to_string(),
            "token 2 of --game-tokens (SWELL_GAME_TOKENS) is 3 bytes, shorter than the 16 bytes \
            a token needs"
        );
        let exposed = [
            ("--bind", addr("127.0.0.1:0")),
            ("--probe-bind", addr("0.0.0.0:9")),
        ];
        let e = check_given_tokens(&given, &exposed).unwrap_err();
        assert_eq!((e.bind, e.addr), ("--probe-bind", addr("0.0.0.0:9")));
        let msg = e.to_string();
        assert!(
            msg.contains("--admin-token") && msg.contains("(--probe-bind 0.0.0.0:9)"),
            "{msg}"
        );
        assert!(!msg.contains("tok,en"), "{msg}");
        // Long tokens pass anywhere, with nothing to report.
        let long = [(
            "--admin-token (SWELL_ADMIN_TOKEN)",
            Given::One("admin-token-0123456789"),
        )];
        assert_eq!(check_given_tokens(&long, &exposed), Ok(Vec::new()));
    }
}
