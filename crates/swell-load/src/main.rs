//! `swell-load`: the command line. Parses arguments, wires Ctrl-C, runs, prints.

use std::io::IsTerminal as _;
use std::process::ExitCode;

use clap::Parser as _;
use tokio_util::sync::CancellationToken;

#[tokio::main]
async fn main() -> ExitCode {
    // `swell-load hostile …`: the hostile-client battery, with its own arguments.
    if std::env::args().nth(1).as_deref() == Some("hostile") {
        let args = swell_load::hostile::HostileArgs::parse_from(std::env::args().skip(1));
        return match swell_load::hostile::run(&args).await {
            Ok(report) => {
                if args.json {
                    println!(
                        "{}",
                        serde_json::to_string(&report).expect("a report serialises")
                    );
                } else {
                    print!("{report}");
                }
                if report.failures.is_empty() {
                    ExitCode::SUCCESS
                } else {
                    ExitCode::from(1)
                }
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(1)
            }
        };
    }
    let args = swell_load::Args::parse();
    let fail_on_errors = args.fail_on_errors;
    let json = args.json;
    let options = match args.into_options() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    // Ctrl-C stops the run; the report of what was measured so far is still printed. A second
    // Ctrl-C while it winds down exits at once.
    let stop = CancellationToken::new();
    let s = stop.clone();
    tokio::spawn(async move {
        if tokio::signal::ctrl_c().await.is_ok() {
            eprintln!("\nswell-load: interrupted, finishing up (Ctrl-C again to quit)");
            s.cancel();
            if tokio::signal::ctrl_c().await.is_ok() {
                std::process::exit(130);
            }
        }
    });
    let progress = std::io::stderr().is_terminal();
    match swell_load::run(options, stop, progress).await {
        Ok(report) => {
            if json {
                println!(
                    "{}",
                    serde_json::to_string(&report).expect("a report serialises")
                );
            } else {
                print!("{report}");
            }
            if fail_on_errors && report.has_failures() {
                eprintln!("swell-load: failures during the run (--fail-on-errors)");
                return ExitCode::from(1);
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
