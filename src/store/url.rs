//! `--store`: which backend holds admin changes.

use std::fmt;

/// A parsed `--store` value: `redis://HOST:PORT/DB` (or `rediss://` for TLS, passed through to
/// the client as written).
#[derive(Clone, PartialEq, Eq)]
pub struct StoreUrl {
    url: String,
}

impl StoreUrl {
    /// Parses and checks a store URL.
    ///
    /// # Errors
    /// A scheme other than `redis://` / `rediss://` / `redis+unix://`, or a URL the Redis client
    /// cannot read; the message names the value (without its password).
    pub fn parse(s: &str) -> Result<StoreUrl, String> {
        let ok_scheme = ["redis://", "rediss://", "redis+unix://"]
            .iter()
            .any(|p| s.starts_with(p));
        let shown = StoreUrl { url: s.to_owned() }.to_string();
        if !ok_scheme {
            return Err(format!(
                "--store {shown:?}: expected redis://HOST:PORT/DB (the data dir is the default store; omit --store to use it)"
            ));
        }
        redis::Client::open(s).map_err(|e| format!("--store {shown:?}: {e}"))?;
        Ok(StoreUrl { url: s.to_owned() })
    }

    /// The URL as given (with any password): for the client only, never for logs.
    pub fn as_secret_str(&self) -> &str {
        &self.url
    }
}

/// Shows the URL with any password replaced by `***`.
impl fmt::Display for StoreUrl {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // redis://user:password@host:port/db → redis://user:***@host:port/db
        match (self.url.find("://"), self.url.rfind('@')) {
            (Some(s), Some(at)) if at > s + 3 => {
                let userinfo = &self.url[s + 3..at];
                let user = userinfo.split(':').next().unwrap_or("");
                write!(f, "{}{user}:***{}", &self.url[..s + 3], &self.url[at..])
            }
            _ => f.write_str(&self.url),
        }
    }
}

impl fmt::Debug for StoreUrl {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "StoreUrl({self})")
    }
}

#[cfg(test)]
mod tests {
    use super::StoreUrl;

    #[test]
    fn parses_redis_urls_and_hides_passwords() {
        let u = StoreUrl::parse("redis://127.0.0.1:6379/2").unwrap();
        assert_eq!(u.to_string(), "redis://127.0.0.1:6379/2");
        let u = StoreUrl::parse("redis://app:s3cret@redis:6379/0").unwrap();
        assert_eq!(u.to_string(), "redis://app:***@redis:6379/0");
        assert!(!format!("{u:?}").contains("s3cret"));
        let e = StoreUrl::parse("postgres://x").unwrap_err();
        assert!(e.contains("expected redis://"), "{e}");
    }
}
