//! Command-line interface: argument definitions and dispatch.

mod compare;
mod convert;
mod merge;
mod progress;
mod rays;
mod reference;
mod render;
mod setup;
mod study;

use clap::{Parser, Subcommand};

/// pir: Progressive Instant Radiosity.
///
/// Renders scenes written to pir's TOML scene format (or Mitsuba 3's) with a path tracer (the ground truth) or
/// with progressive many-light methods, and compares images with references.
#[derive(Parser, Debug)]
#[command(name = "pir", version, about, long_about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    Render(render::RenderArgs),
    Compare(compare::CompareArgs),
    Merge(merge::MergeArgs),
    Study(study::StudyArgs),
    Reference(reference::ReferenceArgs),
    Convert(convert::ConvertArgs),
    Rays(rays::RaysArgs),
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(a) => render::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Study(a) => study::run(a),
        Command::Reference(a) => reference::run(a),
        Command::Convert(a) => convert::run(a),
        Command::Rays(a) => rays::run(a),
    }
}
