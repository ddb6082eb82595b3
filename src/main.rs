//! The `pir` command line: `pir render`, `compare`, `merge`, `study` and `reference`.

#![deny(unsafe_code)]

mod cli;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    // Bad input is reported as an error, never by a panic. Should a bug panic anyway, say so in
    // one line, without a backtrace (whatever RUST_BACKTRACE says), and exit non-zero.
    std::panic::set_hook(Box::new(|info| {
        // Output piped into a reader that stopped early (`pir compare … | head`): `println!`
        // panics on the closed pipe. Leave quietly with the status of a process ended by
        // SIGPIPE, as other command-line tools do.
        let message = info.payload_as_str().unwrap_or_default();
        if message.starts_with("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(141);
        }
        eprintln!("pir: internal error (a bug in pir, please report it): {info}");
    }));
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // `{:#}` prints the whole context chain on one line and never a backtrace,
            // whatever RUST_BACKTRACE says.
            eprintln!("pir: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
