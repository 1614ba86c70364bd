//! `swell`: the command line. Parses arguments and calls the library; nothing else.

use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Parser, Subcommand};
use tracing_subscriber::EnvFilter;

/// Swell: deterministic ocean physics for multiplayer games.
#[derive(Debug, Parser)]
#[command(version, about, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// `swell` alone means `swell serve` with these options.
    #[command(flatten)]
    serve: ServeArgs,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Serve the HTTP API (the default).
    Serve(Box<ServeArgs>),
    /// List the built-in scene ids and descriptions.
    Scenes,
    /// Exit 0 if a server answers 2xx at `--url` (container health checks: no curl needed).
    Healthcheck(HealthcheckArgs),
    /// Print the `sha256:` form of a token (read from stdin) for the tokens file, so the file
    /// need not hold the token itself.
    HashToken,
}

#[derive(Debug, Clone, Args)]
struct HealthcheckArgs {
    /// The URL to GET (plain HTTP).
    #[arg(long, env = "SWELL_HEALTHCHECK_URL", default_value = swell::healthcheck::DEFAULT_URL)]
    url: String,
    /// Seconds to wait for the answer.
    #[arg(long, default_value_t = 2.0)]
    timeout: f64,
}

#[derive(Debug, Clone, Args)]
struct ServeArgs {
    /// Address to listen on.
    #[arg(long, env = "SWELL_BIND", default_value = "127.0.0.1:8080")]
    bind: SocketAddr,
    /// TOML file with extra scenes (`[scenes.<id>]`) and `[limits]`.
    #[arg(long, env = "SWELL_CONFIG")]
    config: Option<PathBuf>,
    /// Directory where admin changes (scenes, clocks) are persisted and restored from.
    #[arg(long, env = "SWELL_DATA_DIR", default_value = "./swell-data")]
    data_dir: PathBuf,
    /// Shared store for a fleet of replicas, `redis://HOST:PORT/DB`: scenes and clock changes
    /// live there and every replica applies them. Without it: the data dir.
    #[arg(long, env = "SWELL_STORE", value_parser = parse_store)]
    store: Option<swell::store::StoreUrl>,
    /// Admin bearer token; without one a random token is generated and printed once.
    #[arg(long, env = "SWELL_ADMIN_TOKEN", hide_env_values = true)]
    admin_token: Option<String>,
    /// More admin tokens, comma-separated.
    #[arg(long, env = "SWELL_ADMIN_TOKENS", hide_env_values = true)]
    admin_tokens: Option<String>,
    /// `game` tokens (bodies, inputs, impacts), comma-separated.
    #[arg(long, env = "SWELL_GAME_TOKENS", hide_env_values = true)]
    game_tokens: Option<String>,
    /// `reader` tokens (queries, streams; only needed with --reads-need-token), comma-separated.
    #[arg(long, env = "SWELL_READER_TOKENS", hide_env_values = true)]
    reader_tokens: Option<String>,
    /// File of `role token` lines (`role sha256:<hex>` too), read again when it changes.
    #[arg(long, env = "SWELL_TOKENS_FILE")]
    tokens_file: Option<PathBuf>,
    /// Queries and streams need a reader (or game, or admin) token; public otherwise.
    /// The variable takes true/false, 1/0, yes/no or on/off.
    #[arg(long, env = "SWELL_READS_NEED_TOKEN", value_parser = clap::builder::BoolishValueParser::new())]
    reads_need_token: bool,
    /// Serve /healthz, /readyz and /metrics on this address too, outside every client limit
    /// (Kubernetes probes, Prometheus).
    #[arg(long, env = "SWELL_PROBE_BIND")]
    probe_bind: Option<SocketAddr>,
    /// Start without the built-in scenes.
    #[arg(long)]
    no_builtin_scenes: bool,
    /// Seconds between journal snapshots while anything changes (bounds the replay at start);
    /// with --store, between body snapshots in Redis.
    #[arg(long, env = "SWELL_SNAPSHOT_INTERVAL", default_value_t = 30.0)]
    snapshot_interval: f64,
    /// Journal records that trigger a snapshot (and a compaction of the log) at once.
    #[arg(long, env = "SWELL_SNAPSHOT_RECORDS", default_value_t = 10_000)]
    snapshot_records: usize,
    /// Seconds shutdown waits for sessions and loops to end before the final snapshot.
    #[arg(long, env = "SWELL_SHUTDOWN_TIMEOUT", default_value_t = 10.0)]
    shutdown_timeout: f64,
    /// Seconds the server keeps serving after the shutdown signal with /readyz answering 503,
    /// before it stops accepting (so load balancers stop sending first).
    #[arg(long, env = "SWELL_DRAIN_DELAY", default_value_t = 2.0)]
    drain_delay: f64,
}

fn main() -> anyhow::Result<()> {
    // Before any thread starts: a thread keeps the arena it is given (see `swell::memory`).
    swell::memory::limit_arenas(swell::memory::ARENAS);
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?
        .block_on(run())
}

async fn run() -> anyhow::Result<()> {
    // Logs go to stderr (colour only on a terminal); stdout is kept for what the operator needs
    // to read or pipe: the generated admin token and the listening address.
    use std::io::IsTerminal as _;
    tracing_subscriber::fmt()
        .with_env_filter(
            EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| EnvFilter::new("info,tower_http=warn")),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        // A log line that cannot be written (stderr full or closed) is dropped: reporting it
        // would eprintln! to the same stderr, and that panics.
        .log_internal_errors(false)
        .init();
    let cli = Cli::parse();
    match cli.command {
        Some(Command::Scenes) => {
            for (id, spec) in swell::scene::builtin::specs() {
                println!("{id}\t{}", spec.description);
            }
            Ok(())
        }
        Some(Command::Healthcheck(args)) => {
            let timeout = std::time::Duration::try_from_secs_f64(args.timeout)
                .context("--timeout must be a non-negative number of seconds")?;
            match swell::healthcheck::check(&args.url, timeout).await {
                Ok(status) => {
                    println!("ok: {} answered {status}", args.url);
                    Ok(())
                }
                Err(e) => {
                    eprintln!("unhealthy: {e}");
                    std::process::exit(1);
                }
            }
        }
        Some(Command::HashToken) => {
            let mut token = String::new();
            std::io::stdin()
                .read_line(&mut token)
                .context("reading the token from stdin")?;
            println!("{}", swell::access::hashed(token.trim()));
            Ok(())
        }
        Some(Command::Serve(args)) => serve(*args).await,
        None => serve(cli.serve).await,
    }
}

/// A line on stdout for the operator. A stdout that is closed or full loses the line, not the
/// server (`println!` panics on a write error).
fn say(line: &str) {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{line}").and_then(|()| out.flush());
}

/// A warning line on stderr, outside the log (which `RUST_LOG` may silence): the operator
/// should see it whatever the log level. A stderr that cannot be written loses the line.
fn warn_line(line: &str) {
    use std::io::Write as _;
    let mut err = std::io::stderr().lock();
    let _ = writeln!(err, "{line}").and_then(|()| err.flush());
}

/// The tokens file's length rule ([`swell::access::MIN_TOKEN_BYTES`]) for the tokens given as
/// options or variables: a short one stops startup when any listener (`--bind`,
/// `--probe-bind`) is beyond loopback, and is allowed with a warning when every one is on
/// loopback (tests and local scripts use `--admin-token tok`).
fn check_token_lengths(args: &ServeArgs) -> anyhow::Result<()> {
    use swell::access::Given;
    let given: Vec<(&'static str, Given<'_>)> = [
        (
            "--admin-token (SWELL_ADMIN_TOKEN)",
            args.admin_token.as_deref().map(Given::One),
        ),
        (
            "--admin-tokens (SWELL_ADMIN_TOKENS)",
            args.admin_tokens.as_deref().map(Given::List),
        ),
        (
            "--game-tokens (SWELL_GAME_TOKENS)",
            args.game_tokens.as_deref().map(Given::List),
        ),
        (
            "--reader-tokens (SWELL_READER_TOKENS)",
            args.reader_tokens.as_deref().map(Given::List),
        ),
    ]
    .into_iter()
    .filter_map(|(option, g)| g.map(|g| (option, g)))
    .collect();
    let mut binds = vec![("--bind", args.bind)];
    binds.extend(args.probe_bind.map(|a| ("--probe-bind", a)));
    for short in swell::access::check_given_tokens(&given, &binds)? {
        let on: Vec<String> = binds.iter().map(|(o, a)| format!("{o} {a}")).collect();
        warn_line(&format!(
            "warning: {short}; allowed because every listener is on loopback ({}), refused on \
            any other address",
            on.join(", ")
        ));
    }
    Ok(())
}

fn parse_store(s: &str) -> Result<swell::store::StoreUrl, String> {
    swell::store::StoreUrl::parse(s)
}

async fn serve(args: ServeArgs) -> anyhow::Result<()> {
    // A blank token (an unset shell variable, `--admin-token " "`) would be a token anyone can
    // guess; refuse to start rather than serve with it.
    if args
        .admin_token
        .as_deref()
        .is_some_and(|t| t.trim().is_empty())
    {
        anyhow::bail!(
            "--admin-token (SWELL_ADMIN_TOKEN) is empty or blank; give a token or leave it out to get a random one"
        );
    }
    check_token_lengths(&args)?;
    let mut config = swell::Config {
        bind: args.bind,
        data_dir: Some(args.data_dir),
        store: args.store.clone(),
        admin_token: args.admin_token.clone(),
        env_tokens: [
            (swell::access::Role::Admin, &args.admin_tokens),
            (swell::access::Role::Game, &args.game_tokens),
            (swell::access::Role::Reader, &args.reader_tokens),
        ]
        .into_iter()
        .filter_map(|(role, list)| list.clone().map(|l| (role, l)))
        .collect(),
        tokens_file: args.tokens_file.clone(),
        reads_need_token: args.reads_need_token,
        probe_bind: args.probe_bind,
        builtin_scenes: !args.no_builtin_scenes,
        snapshots: swell::journal::snapshot::SnapshotPolicy {
            interval: std::time::Duration::try_from_secs_f64(args.snapshot_interval)
                .context("--snapshot-interval must be a non-negative number of seconds")?,
            max_records: args.snapshot_records.max(1),
        },
        shutdown_timeout: std::time::Duration::try_from_secs_f64(args.shutdown_timeout)
            .context("--shutdown-timeout must be a non-negative number of seconds")?,
        drain_delay: std::time::Duration::try_from_secs_f64(args.drain_delay)
            .context("--drain-delay must be a non-negative number of seconds")?,
        ..Default::default()
    };
    if let Some(path) = &args.config {
        let file = swell::config::load_file(path)?;
        config.scenes = file.scenes;
        if let Some(l) = file.limits {
            config.limits = l;
        }
    }
    let server = swell::Server::bind(config)
        .await
        .context("starting the server")?;
    if args.admin_token.is_none() {
        // Printed once, to stdout (not the log), so it can be captured and is not kept in logs.
        say(&format!("admin token: {}", server.admin_token()));
    }
    say(&format!(
        "swell listening on http://{}",
        server.local_addr()
    ));
    if let Some(p) = server.probe_addr() {
        say(&format!("probes on http://{p}"));
    }
    server
        .run(swell::shutdown_signal())
        .await
        .context("serving")?;
    Ok(())
}
