//! The `pir` command line: `pir render`, `pir compare`.

mod cli;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
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
