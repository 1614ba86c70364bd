//! Real processes for fleet tests: `redis-server`, `swell` replicas and `nginx`, each on a free
//! loopback port with its own temp dir, killed when dropped (pass or fail).
#![allow(dead_code, unreachable_pub)]

use std::io::{Read as _, Write as _};
use std::net::TcpStream;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

#[path = "system.rs"]
mod system;

pub const TOKEN: &str = "fleet-token";

/// A free loopback port (bind 0, read it, release it: a small race, fine in tests).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A child process killed (SIGKILL) and reaped on drop.
pub struct Proc {
    pub child: Child,
    pub what: String,
}

impl Proc {
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// `kill -9` and reap.
    pub fn kill9(mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Sends `sig` (e.g. "STOP", "CONT", "TERM") with kill(1).
    pub fn signal(&self, sig: &str) {
        let ok = Command::new(which("kill", "procps"))
            .args([format!("-{sig}"), self.pid().to_string()])
            .status()
            .is_ok_and(|s| s.success());
        assert!(ok, "kill -{sig} {} ({})", self.pid(), self.what);
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Finds a Debian binary (PATH, then /usr/sbin for nginx), installing its package when missing
/// (see `system.rs`); panics with the install hint when it cannot.
pub fn which(name: &str, package: &str) -> PathBuf {
    system::program(name, package)
}

/// Sends one inline Redis command and returns the first reply line (`+PONG`).
pub fn redis_line(port: u16, cmd: &str) -> Option<String> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).ok()?;
    s.set_read_timeout(Some(Duration::from_millis(500))).ok()?;
    s.write_all(format!("{cmd}\r\n").as_bytes()).ok()?;
    let mut buf = [0u8; 256];
    let n = s.read(&mut buf).ok()?;
    let line = String::from_utf8_lossy(&buf[..n]);
    Some(line.lines().next().unwrap_or("").to_owned())
}

/// A `redis-server` with AOF (fsync on every write) in its own temp dir; restartable on the same
/// port and dir (it reloads the AOF).
pub struct Redis {
    pub port: u16,
    pub dir: tempfile::TempDir,
    proc: Option<Proc>,
}

impl Redis {
    pub fn start() -> Redis {
        let mut r = Redis {
            port: free_port(),
            dir: tempfile::tempdir().unwrap(),
            proc: None,
        };
        r.restart();
        r
    }

    pub fn url(&self) -> String {
        format!("redis://127.0.0.1:{}/0", self.port)
    }

    /// Starts it (again) and waits for PONG.
    pub fn restart(&mut self) {
        assert!(self.proc.is_none(), "redis is running");
        let child = Command::new(which("redis-server", "redis-server"))
            .args(["--port", &self.port.to_string(), "--bind", "127.0.0.1"])
            .arg("--dir")
            .arg(self.dir.path())
            .args(["--appendonly", "yes", "--appendfsync", "always"])
            .args(["--save", "", "--daemonize", "no", "--loglevel", "warning"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("redis-server starts");
        self.proc = Some(Proc {
            child,
            what: "redis-server".into(),
        });
        let start = Instant::now();
        while redis_line(self.port, "PING").as_deref() != Some("+PONG") {
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "redis-server never answered PING"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// `kill -9`: Redis gone at once (what it acknowledged is in the AOF, fsynced).
    pub fn kill9(&mut self) {
        if let Some(p) = self.proc.take() {
            p.kill9();
        }
    }
}

/// A `swell serve` process on a free port.
pub struct Replica {
    pub port: u16,
    pub base: String,
    pub proc: Option<Proc>,
    pub log: PathBuf,
    _dir: tempfile::TempDir,
}

impl Replica {
    /// Starts `swell serve --store <store>` (plus `extra` args); does not wait.
    pub fn spawn(store: &str, extra: &[&str]) -> Replica {
        let port = free_port();
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("swell.log");
        let child = Command::new(env!("CARGO_BIN_EXE_swell"))
            .args(["serve", "--bind", &format!("127.0.0.1:{port}")])
            .args(["--store", store, "--admin-token", TOKEN])
            .arg("--data-dir")
            .arg(dir.path().join("data"))
            .args(extra)
            .env("RUST_LOG", "info,swell::store=debug")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .expect("the swell binary starts");
        Replica {
            port,
            base: format!("http://127.0.0.1:{port}"),
            proc: Some(Proc {
                child,
                what: format!("swell :{port}"),
            }),
            log,
            _dir: dir,
        }
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    /// The replica's log so far (for failure messages).
    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Waits until `/readyz` answers 200.
    pub async fn wait_ready(&self, client: &reqwest::Client) {
        let start = Instant::now();
        loop {
            if let Ok(r) = client.get(self.url("/readyz")).send().await
                && r.status() == 200
            {
                return;
            }
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "replica :{} never became ready; log:\n{}",
                self.port,
                self.log()
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
}

/// Starts `n` replicas on `store` and waits until all are ready.
pub async fn replicas(store: &str, n: usize, client: &reqwest::Client) -> Vec<Replica> {
    let rs: Vec<Replica> = (0..n).map(|_| Replica::spawn(store, &[])).collect();
    for r in &rs {
        r.wait_ready(client).await;
    }
    rs
}

pub fn client() -> reqwest::Client {
    reqwest::Client::builder()
        .no_proxy()
        .timeout(Duration::from_secs(10))
        .build()
        .unwrap()
}

/// Debian's nginx as a plain process with `docker/nginx.conf`, only its upstream `server`
/// addresses (→ `upstreams`) and its `listen` address (→ a free loopback port) substituted.
pub struct Nginx {
    pub port: u16,
    pub base: String,
    _proc: Proc,
    _dir: tempfile::TempDir,
}

impl Drop for Nginx {
    /// A fast shutdown (SIGTERM) so the master stops its workers: a `kill -9` of the master
    /// (what dropping the [`Proc`] does) leaves them running, orphaned, after the test.
    fn drop(&mut self) {
        let _ = Command::new(which("kill", "procps"))
            .args(["-TERM", &self._proc.pid().to_string()])
            .status();
        let until = Instant::now() + Duration::from_secs(3);
        while Instant::now() < until {
            if matches!(self._proc.child.try_wait(), Ok(Some(_))) {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Nginx {
    /// nginx with docker/nginx.conf, its upstream servers and listen address replaced.
    pub async fn start(upstreams: &[u16], client: &reqwest::Client) -> Nginx {
        Self::start_conf(upstreams, client, false).await
    }

    /// [`Nginx::start`] without the config's loopback exemption from its per-client limits
    /// (the lines marked `# loopback exempt`), so that clients bound to 127.0.x.y addresses
    /// meet them as clients elsewhere would.
    pub async fn start_limiting_loopback(upstreams: &[u16], client: &reqwest::Client) -> Nginx {
        Self::start_conf(upstreams, client, true).await
    }

    async fn start_conf(
        upstreams: &[u16],
        client: &reqwest::Client,
        limit_loopback: bool,
    ) -> Nginx {
        let conf =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docker/nginx.conf"))
                .expect("docker/nginx.conf");
        let exempt_lines = conf
            .lines()
            .filter(|l| l.ends_with("# loopback exempt"))
            .count();
        assert!(
            exempt_lines >= 1,
            "docker/nginx.conf marks no loopback exemption"
        );
        let mut next = upstreams.iter();
        let mut out = String::new();
        let port = free_port();
        let mut servers = 0;
        for line in conf.lines() {
            let t = line.trim_start();
            let indent = &line[..line.len() - t.len()];
            if t.starts_with("server ") && t.contains(':') && t.ends_with(';') {
                let rest = t.split_once(' ').unwrap().1;
                let params = rest.split_once(' ').map_or(";", |(_, p)| p);
                let p = next.next().expect("more upstream lines than replicas");
                out.push_str(&format!("{indent}server 127.0.0.1:{p} {params}\n"));
                servers += 1;
            } else if t.starts_with("listen ") {
                out.push_str(&format!("{indent}listen 127.0.0.1:{port};\n"));
            } else if limit_loopback && t.ends_with("# loopback exempt") {
                continue;
            } else {
                out.push_str(line);
                out.push('\n');
            }
        }
        assert_eq!(
            servers,
            upstreams.len(),
            "docker/nginx.conf lists {servers} upstream servers"
        );
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("temp")).unwrap();
        let path = dir.path().join("nginx.conf");
        std::fs::write(&path, out).unwrap();
        let child = Command::new(which("nginx", "nginx"))
            .arg("-p")
            .arg(dir.path())
            .arg("-c")
            .arg(&path)
            .arg("-g")
            .arg(format!(
                "daemon off; pid {}/nginx.pid;",
                dir.path().display()
            ))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("nginx starts");
        let n = Nginx {
            port,
            base: format!("http://127.0.0.1:{port}"),
            _proc: Proc {
                child,
                what: "nginx".into(),
            },
            _dir: dir,
        };
        let start = Instant::now();
        loop {
            if let Ok(r) = client.get(format!("{}/nginx-healthz", n.base)).send().await
                && r.status() == 200
            {
                return n;
            }
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "nginx never answered"
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }
}
